//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_ugcat");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    let help = Command::new(EXE)
        .arg("--help")
        .output()
        .expect("run --help");
    assert!(help.status.success());
    let text = String::from_utf8(help.stdout).unwrap();
    assert!(text.contains("Examples:"), "{text}");
    assert!(text.contains("Usage: ugcat"), "{text}");
    let version = Command::new(EXE)
        .arg("--version")
        .output()
        .expect("run --version");
    assert!(version.status.success());
    assert_eq!(
        String::from_utf8(version.stdout).unwrap(),
        format!("ugcat {}\n", env!("CARGO_PKG_VERSION"))
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
