//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

const EXE: &str = env!("CARGO_BIN_EXE_obj2ug");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    cli::testkit::assert_help_and_version(EXE, "obj2ug", env!("CARGO_PKG_VERSION"));
}

#[test]
fn unknown_options_are_usage_errors() {
    cli::testkit::assert_unknown_option_is_usage_error(EXE);
}

fn run(args: &[&str], stdin: &[u8]) -> std::process::Output {
    cli::testkit::run_with_stdin(EXE, args, stdin)
}

#[test]
fn converts_from_stdin_and_reports_errors() {
    let out = run(
        &["--emit", "lamp=1,2,3"],
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\ng tri\nusemtl lamp\nf 1 2 3\n",
    );
    assert!(out.status.success());
    let ug = String::from_utf8(out.stdout).unwrap();
    assert!(
        ug.contains("emission_rgb 1 2 3;") && ug.ends_with("f tri (v1 v2 v3) lamp;\n"),
        "{ug}"
    );
    let bad = run(&[], b"v 0 0 0\nf 1 2 -7\n");
    assert_eq!(bad.status.code(), Some(2));
    assert!(bad.stdout.is_empty());
    assert!(
        String::from_utf8(bad.stderr)
            .unwrap()
            .starts_with("<stdin>:2:5: error: vertex index 2")
    );
    assert_eq!(run(&["--emit", "lamp"], b"").status.code(), Some(2));
}
