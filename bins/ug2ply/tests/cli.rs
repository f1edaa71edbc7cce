//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_ug2ply");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    let help = Command::new(EXE)
        .arg("--help")
        .output()
        .expect("run --help");
    assert!(help.status.success());
    let text = String::from_utf8(help.stdout).unwrap();
    assert!(text.contains("Examples:"), "{text}");
    assert!(text.contains("Usage: ug2ply"), "{text}");
    let version = Command::new(EXE)
        .arg("--version")
        .output()
        .expect("run --version");
    assert!(version.status.success());
    assert_eq!(
        String::from_utf8(version.stdout).unwrap(),
        format!("ug2ply {}\n", env!("CARGO_PKG_VERSION"))
    );
}

#[test]
fn unknown_options_are_usage_errors() {
    let out = Command::new(EXE)
        .arg("--no-such-option")
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
}

fn run(args: &[&str], stdin: &[u8]) -> std::process::Output {
    use std::io::Write;
    let mut child = Command::new(EXE)
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run");
    let _ = child.stdin.take().unwrap().write_all(stdin);
    child.wait_with_output().expect("wait")
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
