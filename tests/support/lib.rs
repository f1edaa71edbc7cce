//! Helpers for the end-to-end tests in `tests/`: run a built tool, compare
//! with golden files (`UPDATE_GOLDEN=1` rewrites them).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The workspace root (where `fixtures/` lives).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A path under `fixtures/`.
pub fn fixture(rel: &str) -> PathBuf {
    root().join("fixtures").join(rel)
}

/// The path of a built tool binary (`target/<profile>/<name>`), next to the test executable.
pub fn bin(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test>-<hash>
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("target profile directory");
    let p = dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    assert!(
        p.exists(),
        "{} is not built; run `cargo test --workspace` (or `cargo build`) first",
        p.display()
    );
    // `cargo test -p ugkit` alone does not rebuild the tools: refuse a binary
    // older than any source it was built from (cargo's dep-info file lists them).
    let built = std::fs::metadata(&p)
        .and_then(|m| m.modified())
        .expect("binary mtime");
    if let Ok(deps) = std::fs::read_to_string(dir.join(format!("{name}.d"))) {
        let first = deps.lines().next().unwrap_or("");
        let files = first.split_once(": ").map_or("", |(_, f)| f);
        for f in files.split(' ').filter(|f| !f.is_empty()) {
            if let Ok(t) = std::fs::metadata(f).and_then(|m| m.modified()) {
                assert!(
                    t <= built,
                    "{} is older than {f}; run `cargo build` or `cargo test --workspace`",
                    p.display()
                );
            }
        }
    }
    p
}

/// Runs a tool with arguments and optional stdin; returns its output.
pub fn run(name: &str, args: &[&str], stdin: Option<&[u8]>) -> Output {
    let mut cmd = Command::new(bin(name));
    cmd.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    // Always a pipe, never Stdio::null(): on some CI containers /dev/null is a
    // regular file that collects other processes' output.
    cmd.stdin(Stdio::piped());
    let mut child = cmd
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
    let mut si = child.stdin.take().expect("stdin");
    if let Some(input) = stdin {
        // The tool may exit before reading everything (e.g. on an early error).
        let _ = si.write_all(input);
    }
    drop(si); // EOF
    child.wait_with_output().expect("wait for tool")
}

/// Runs a tool and asserts it succeeded; returns stdout as a string.
pub fn run_ok(name: &str, args: &[&str], stdin: Option<&[u8]>) -> String {
    let out = run(name, args, stdin);
    assert!(
        out.status.success(),
        "{name} {args:?} failed with {:?}\nstderr:\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("UTF-8 output")
}

/// Runs the stages in order, each on the previous one's output; every
/// stage must succeed.
pub fn pipe(input: &[u8], stages: &[(&str, &[&str])]) -> Vec<u8> {
    let mut data = input.to_vec();
    for (name, args) in stages {
        let out = run(name, args, Some(&data));
        assert!(
            out.status.success(),
            "{name} {args:?} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        data = out.stdout;
    }
    data
}

/// The cleaning tools in the recommended order.
pub const CHAIN_TOOLS: [&str; 6] = [
    "ugplanar",
    "ugvlmerge",
    "ugflip",
    "ugisect",
    "ugcopl",
    "ugclean",
];

/// The recommended cleaning chain on a model, each stage asserted to
/// succeed: ugplanar | ugvlmerge | ugflip | ugisect | ugcopl | ugclean.
pub fn chain(input: &[u8]) -> Vec<u8> {
    let stages: Vec<(&str, &[&str])> = CHAIN_TOOLS.iter().map(|t| (*t, &[][..])).collect();
    pipe(input, &stages)
}

/// The recommended cleaning chain and `ugcut -l LEN` on a model, each
/// stage asserted to succeed: ugplanar | ugvlmerge | ugflip | ugisect |
/// ugcopl | ugclean | ugcut.
pub fn clean_chain(model: Vec<u8>, len: &str) -> Vec<u8> {
    let mut m = model;
    for (tool, args) in [
        ("ugplanar", vec![]),
        ("ugvlmerge", vec![]),
        ("ugflip", vec![]),
        ("ugisect", vec![]),
        ("ugcopl", vec![]),
        ("ugclean", vec![]),
        ("ugcut", vec!["-l", len]),
    ] {
        let out = run(tool, &args, Some(&m));
        assert!(
            out.status.success(),
            "{tool}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        m = out.stdout;
    }
    m
}

/// Compares `actual` with the golden file at `path` (relative to the workspace root);
/// with `UPDATE_GOLDEN=1` the file is (re)written instead.
pub fn assert_golden(path: &str, actual: &str) {
    let p = root().join(path);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d).expect("create golden directory");
        }
        std::fs::write(&p, actual).expect("write golden file");
        return;
    }
    let expected = std::fs::read_to_string(&p).unwrap_or_else(|e| {
        panic!(
            "missing golden file {} ({e}); run with UPDATE_GOLDEN=1",
            p.display()
        )
    });
    if expected != actual {
        let first = expected
            .lines()
            .zip(actual.lines())
            .position(|(a, b)| a != b);
        panic!(
            "output differs from golden file {} (first differing line: {:?})\n--- expected\n{expected}\n--- actual\n{actual}",
            p.display(),
            first.map(|k| k + 1)
        );
    }
}

/// Asserts that ugcheck's JSON report `r` names exactly one degenerate
/// face, for a reason that contains `why`.
pub fn assert_one_degenerate(r: &serde_json::Value, why: &str) {
    let degenerate = r["degenerate"].as_array().expect("a degenerate list");
    assert_eq!(degenerate.len(), 1, "{degenerate:?}");
    assert!(
        degenerate[0]["reason"].as_str().unwrap().contains(why),
        "{degenerate:?}"
    );
}

/// The keys of ugcheck's JSON report that list defects (`ugcheck --deny
/// defects`), in the report's order.
pub const DEFECT_KEYS: [&str; 7] = [
    "nonplanar",
    "tvertices",
    "intersecting",
    "overlapping",
    "coincident",
    "degenerate",
    "inconsistent",
];

/// Asserts that ugcheck's JSON report `r` lists no defect of any kind
/// ([`DEFECT_KEYS`]); `what` names the case in the message.
pub fn assert_no_defects(r: &serde_json::Value, what: &str) {
    for key in DEFECT_KEYS {
        let n = r[key].as_array().map_or(0, Vec::len);
        assert_eq!(n, 0, "{what}: {key}: {}", r[key]);
    }
}
