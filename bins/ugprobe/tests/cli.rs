//! The command line every tool shares: `--help` with examples, `--version`.
//! (This integration test also makes `cargo test` build the binary, which
//! the end-to-end tests in the workspace's `tests/` run.)

const EXE: &str = env!("CARGO_BIN_EXE_ugprobe");

#[test]
fn help_has_examples_and_version_names_the_tool() {
    cli::testkit::assert_help_and_version(EXE, "ugprobe", env!("CARGO_PKG_VERSION"));
}

#[test]
fn unknown_options_are_usage_errors() {
    cli::testkit::assert_unknown_option_is_usage_error(EXE);
}
