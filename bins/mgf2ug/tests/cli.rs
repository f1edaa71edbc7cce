//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

const EXE: &str = env!("CARGO_BIN_EXE_mgf2ug");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    cli::testkit::assert_help_and_version(EXE, "mgf2ug", env!("CARGO_PKG_VERSION"));
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
        &["--segments", "4"],
        b"v c =\n\tp 0 0 0\nm lamp =\n\ted 5\no ball\nsph c 1\no\n",
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ug = String::from_utf8(out.stdout).unwrap();
    assert_eq!(ug.matches("\nf ball").count(), 8, "{ug}");
    assert!(ug.contains("emission_rgb 5 5 5;"), "{ug}");
    let bad = run(&[], b"f a b c\n");
    assert_eq!(bad.status.code(), Some(2));
    assert!(bad.stdout.is_empty());
    assert_eq!(
        String::from_utf8(bad.stderr).unwrap(),
        "<stdin>:1:3: error: undefined vertex 'a'\n"
    );
    assert_eq!(run(&["--segments", "2"], b"").status.code(), Some(2));
}
