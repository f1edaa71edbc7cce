//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

const EXE: &str = env!("CARGO_BIN_EXE_ply2ug");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    cli::testkit::assert_help_and_version(EXE, "ply2ug", env!("CARGO_PKG_VERSION"));
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
    let header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                  property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let out = run(
        &[],
        format!("{header}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").as_bytes(),
    );
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8(out.stdout).unwrap(),
        "v v1 0 0 0;\nv v2 1 0 0;\nv v3 0 1 0;\nf (v1 v2 v3);\n"
    );
    let bad = run(
        &[],
        format!("{header}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n").as_bytes(),
    );
    assert_eq!(bad.status.code(), Some(2));
    assert!(bad.stdout.is_empty());
    assert_eq!(
        String::from_utf8(bad.stderr).unwrap(),
        "<stdin>:13:7: error: vertex index 3 is out of range (3 vertices)\n"
    );
}
