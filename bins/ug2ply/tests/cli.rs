//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

const EXE: &str = env!("CARGO_BIN_EXE_ug2ply");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    cli::testkit::assert_help_and_version(EXE, "ug2ply", env!("CARGO_PKG_VERSION"));
}

#[test]
fn unknown_options_are_usage_errors() {
    cli::testkit::assert_unknown_option_is_usage_error(EXE);
}

fn run(args: &[&str], stdin: &[u8]) -> std::process::Output {
    cli::testkit::run_with_stdin(EXE, args, stdin)
}

#[test]
fn converts_a_triangle_from_stdin() {
    let out = run(
        &[],
        b"c_rgb r 1 0 0; v a 0 0 0; v b 1 0 0; v c 0 1 0; f t (a b c) r;",
    );
    assert!(out.status.success());
    let ply = String::from_utf8(out.stdout).unwrap();
    assert!(
        ply.contains("element vertex 3\n") && ply.contains("element face 1\n"),
        "{ply}"
    );
    assert!(ply.ends_with("0 1 0 255 0 0\n3 0 1 2\n"), "{ply}");
    let bad = run(&["--exposure", "x"], b"");
    assert_eq!(bad.status.code(), Some(2));
    let bad = run(&[], b"v a 0 0;");
    assert_eq!(bad.status.code(), Some(2));
    assert!(bad.stdout.is_empty());
}
