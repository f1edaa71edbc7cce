//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_mgf2ug");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    let help = Command::new(EXE)
        .arg("--help")
        .output()
        .expect("run --help");
    assert!(help.status.success());
    let text = String::from_utf8(help.stdout).unwrap();
    assert!(text.contains("Examples:"), "{text}");
    assert!(text.contains("Usage: mgf2ug"), "{text}");
    let version = Command::new(EXE)
        .arg("--version")
        .output()
        .expect("run --version");
    assert!(version.status.success());
    assert_eq!(
        String::from_utf8(version.stdout).unwrap(),
        format!("mgf2ug {}\n", env!("CARGO_PKG_VERSION"))
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
