//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_ug2obj");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    cli::testkit::assert_help_and_version(EXE, "ug2obj", env!("CARGO_PKG_VERSION"));
}

#[test]
fn unknown_options_are_usage_errors() {
    cli::testkit::assert_unknown_option_is_usage_error(EXE);
}

#[test]
fn writes_the_mtl_beside_the_obj() {
    let dir = tempfile::tempdir().unwrap();
    let ug = dir.path().join("t.ug");
    std::fs::write(
        &ug,
        "c_rgb r 1 0 0; v a 0 0 0; v b 1 0 0; v c 0 1 0; f t (a b c) r;",
    )
    .unwrap();
    let obj = dir.path().join("t.obj");
    let out = Command::new(EXE)
        .args([ug.to_str().unwrap(), "-o", obj.to_str().unwrap()])
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stdout.is_empty());
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(
        text.contains("mtllib t.mtl\n") && text.ends_with("g t\nusemtl r\nf 1 2 3\n"),
        "{text}"
    );
    let mtl = std::fs::read_to_string(dir.path().join("t.mtl")).unwrap();
    assert!(mtl.contains("newmtl r\nKd 1 0 0\nKe 0 0 0\n"), "{mtl}");
}
