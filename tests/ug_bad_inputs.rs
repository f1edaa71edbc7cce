//! The malformed-input corpus: `ugcat` on every `fixtures/bad/*.ug` must fail
//! with exit status 2, print nothing on stdout and exactly one
//! `file:line:col: error: message` line on stderr, equal to the golden
//! `fixtures/bad/NN-name.err` (`UPDATE_GOLDEN=1` rewrites them), whose position
//! points at the offending text (or just after the token where something is
//! missing). A sidecar `NN-name.args` holds extra arguments (e.g. `--strict`).
//! Helper files that the cases include live in `fixtures/bad/inc/` and are not
//! cases themselves.

use std::path::Path;
use std::process::{Command, Output, Stdio};

use ugkit::{assert_golden, bin, root};

/// Every case, as a path relative to the workspace root, in name order.
fn cases() -> Vec<String> {
    let dir = root().join("fixtures/bad");
    let mut v: Vec<String> = std::fs::read_dir(&dir)
        .expect("fixtures/bad exists")
        .map(|e| {
            e.expect("directory entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .filter(|n| n.ends_with(".ug"))
        .map(|n| format!("fixtures/bad/{n}"))
        .collect();
    v.sort();
    v
}

/// Extra arguments from the case's `.args` sidecar (whitespace separated).
fn extra_args(case: &str) -> Vec<String> {
    let p = root().join(case.replace(".ug", ".args"));
    match std::fs::read_to_string(p) {
        Ok(s) => s.split_whitespace().map(str::to_string).collect(),
        Err(_) => Vec::new(),
    }
}

/// Runs ugcat in the workspace root (so that file names in messages are stable).
fn ugcat(args: &[String], stdin: Option<&[u8]>) -> Output {
    use std::io::Write;
    let mut cmd = Command::new(bin("ugcat"));
    cmd.args(args)
        .current_dir(root())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .stdin(Stdio::piped());
    let mut child = cmd.spawn().expect("start ugcat");
    let mut si = child.stdin.take().expect("stdin");
    if let Some(input) = stdin {
        let _ = si.write_all(input);
    }
    drop(si); // EOF
    child.wait_with_output().expect("wait for ugcat")
}

/// `file:line:col: error: message` split into its parts.
fn split_diagnostic(line: &str) -> Option<(&str, usize, usize, &str)> {
    let (head, msg) = line.split_once(": error: ")?;
    let mut it = head.rsplitn(3, ':');
    let col = it.next()?.parse().ok()?;
    let ln = it.next()?.parse().ok()?;
    let file = it.next()?;
    Some((file, ln, col, msg))
}

/// The first `'…'`-quoted text in `s` (after `after`, when given).
fn quoted<'a>(s: &'a str, after: &str) -> Option<&'a str> {
    let start = s.find(after)? + after.len();
    let rest = &s[start..];
    let open = rest.find('\'')?;
    let rest = &rest[open + 1..];
    // The quoted text may itself be a quote character: `found '''` never
    // occurs, so the closing quote is the next one.
    let close = rest.find('\'')?;
    Some(&rest[..close])
}

fn is_delim(c: char) -> bool {
    c.is_whitespace() || matches!(c, ';' | '(' | ')' | '{' | '}')
}

/// Checks that `line:col` of `src` is a sensible place for `msg`; returns why not.
fn check_position(src: &str, line: usize, col: usize, msg: &str) -> Result<(), String> {
    let src = src.strip_prefix('\u{feff}').unwrap_or(src);
    let lines: Vec<&str> = src.split('\n').collect();
    let text = lines
        .get(line - 1)
        .ok_or_else(|| format!("line {line} is past the end of the file"))?;
    let chars: Vec<char> = text.chars().collect();
    if col == 0 || col > chars.len() + 1 {
        return Err(format!(
            "column {col} is outside line {line} ({} characters)",
            chars.len()
        ));
    }
    let here: String = chars[col - 1..].iter().collect();
    let before = if col >= 2 { Some(chars[col - 2]) } else { None };
    let word: String = here.chars().take_while(|&c| !is_delim(c)).collect();
    let expect_after_token = || -> Result<(), String> {
        // Just after a token: the previous character ends a token and this one starts no word.
        match before {
            Some(b) if !b.is_whitespace() && word.is_empty() => Ok(()),
            _ => Err(format!(
                "position should be just after a token, found {here:?}"
            )),
        }
    };
    if msg.starts_with("expected ';'") || msg.starts_with("end of file inside") {
        return expect_after_token();
    }
    for (prefix, ch) in [
        ("unbalanced '('", '('),
        ("unbalanced ')'", ')'),
        ("unbalanced '}'", '}'),
        ("unterminated comment", '{'),
        ("a face contour", '('),
        ("a wire contour", '('),
    ] {
        if msg.starts_with(prefix) {
            return if here.starts_with(ch) {
                Ok(())
            } else {
                Err(format!("position should be at {ch:?}, found {here:?}"))
            };
        }
    }
    let q = if msg.contains(", found ") {
        quoted(msg, ", found ")
    } else {
        quoted(msg, "")
    };
    match q {
        // A token quoted in the message lies at the position (an include's path
        // is quoted joined to the including file's directory).
        Some(q) if q == word || q.ends_with(&format!("/{word}")) && !word.is_empty() => Ok(()),
        Some(q) if matches!(q, ";" | ")" | "(") && here.starts_with(q) => Ok(()),
        Some(q) => Err(format!("position should be at '{q}', found {here:?}")),
        None if msg.starts_with("-M4") && word == "-M4" => Ok(()),
        None => Err(format!(
            "no rule to check the position of {msg:?} ({here:?})"
        )),
    }
}

#[test]
fn at_least_35_bad_inputs() {
    let n = cases().len();
    assert!(n >= 35, "only {n} cases in fixtures/bad");
}

#[test]
fn every_case_has_a_golden_and_every_golden_a_case() {
    let dir = root().join("fixtures/bad");
    for e in std::fs::read_dir(&dir).expect("fixtures/bad") {
        let name = e.expect("entry").file_name().to_string_lossy().into_owned();
        for ext in [".err", ".args"] {
            if let Some(stem) = name.strip_suffix(ext) {
                assert!(
                    dir.join(format!("{stem}.ug")).exists(),
                    "{name} has no {stem}.ug"
                );
            }
        }
    }
    if std::env::var_os("UPDATE_GOLDEN").is_none() {
        for c in cases() {
            let err = c.replace(".ug", ".err");
            assert!(
                root().join(&err).exists(),
                "{err} is missing (run with UPDATE_GOLDEN=1)"
            );
        }
    }
}

#[test]
fn bad_inputs_fail_with_one_located_error() {
    let mut problems = Vec::new();
    for case in cases() {
        let mut args = extra_args(&case);
        args.push(case.clone());
        let out = ugcat(&args, None);
        let stderr = String::from_utf8(out.stderr).expect("UTF-8 stderr");
        assert_eq!(
            out.status.code(),
            Some(2),
            "{case}: exit status (stderr: {stderr})"
        );
        assert!(out.stdout.is_empty(), "{case}: stdout is not empty");
        assert!(
            stderr.ends_with('\n') && stderr.matches('\n').count() == 1,
            "{case}: stderr is not exactly one line:\n{stderr}"
        );
        assert_golden(&case.replace(".ug", ".err"), &stderr);
        let line = stderr.trim_end();
        let Some((file, ln, col, msg)) = split_diagnostic(line) else {
            problems.push(format!(
                "{case}: not 'file:line:col: error: message': {line}"
            ));
            continue;
        };
        // The error is in the case itself or in a file it includes.
        if file != case && !file.starts_with("fixtures/bad/inc/") {
            problems.push(format!("{case}: the error names file {file}"));
            continue;
        }
        let src = std::fs::read_to_string(root().join(file)).expect("read the named file");
        if let Err(why) = check_position(&src, ln, col, msg) {
            problems.push(format!("{line}\n    {why}"));
        }
    }
    assert!(
        problems.is_empty(),
        "badly placed errors:\n{}",
        problems.join("\n")
    );
}

#[test]
fn bad_inputs_on_stdin_are_named_stdin() {
    for case in cases() {
        let src = std::fs::read(root().join(&case)).expect("read case");
        let args = extra_args(&case);
        let out = ugcat(&args, Some(&src));
        let stderr = String::from_utf8(out.stderr).expect("UTF-8 stderr");
        assert_eq!(
            out.status.code(),
            Some(2),
            "{case} on stdin (stderr: {stderr})"
        );
        assert!(
            out.stdout.is_empty(),
            "{case} on stdin: stdout is not empty"
        );
        assert!(
            stderr.starts_with("<stdin>:") && stderr.matches('\n').count() == 1,
            "{case} on stdin: {stderr}"
        );
        if String::from_utf8_lossy(&src).contains("include") {
            // Includes resolve against the current directory for stdin, so the
            // message differs from the golden one; the name is what matters here.
            continue;
        }
        let golden =
            std::fs::read_to_string(root().join(case.replace(".ug", ".err"))).expect("golden .err");
        assert_eq!(stderr, golden.replace(&case, "<stdin>"), "{case} on stdin");
    }
}

#[test]
fn position_checker_rejects_wrong_places() {
    // The checker itself: a few positions it must refuse.
    let src = "v a 0 0 0\nv b 1 0 0;\n";
    assert!(
        check_position(
            src,
            1,
            10,
            "expected ';' to end the vertex statement, found 'v'"
        )
        .is_ok()
    );
    assert!(
        check_position(
            src,
            2,
            1,
            "expected ';' to end the vertex statement, found 'v'"
        )
        .is_err()
    );
    assert!(check_position(src, 1, 5, "bad number '0' (expected x coordinate)").is_ok());
    assert!(check_position(src, 1, 3, "bad number '0' (expected x coordinate)").is_err());
    assert!(check_position(src, 3, 1, "bad number '0'").is_err());
    assert!(check_position(src, 1, 40, "bad number '0'").is_err());
    assert!(Path::new(&root()).join("fixtures/bad/inc").is_dir());
}

/// A coordinate beyond `ug::MAX_COORDINATE` stops ugrad before it starts
/// (at 1e78 it emitted NaN and never converged: a hang), and a model too
/// small to measure is refused by name, exit status 2, nothing on stdout.
#[test]
fn models_beyond_double_precision_are_refused() {
    let run = |tool: &str, src: &str| -> Output {
        use std::io::Write;
        let mut child = Command::new(bin(tool))
            .arg("-q")
            .current_dir(root())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start tool");
        child
            .stdin
            .take()
            .expect("stdin")
            .write_all(src.as_bytes())
            .expect("write stdin");
        child.wait_with_output().expect("wait")
    };
    let model = |s: f64| {
        format!(
            "defmat lamp; emission_rgb 10 10 10; end;\nc_rgb grey 0.6 0.6 0.6;\n\
             v a 0 0 0; v b {x:e} 0 0; v c {x:e} {x:e} 0; v d 0 {x:e} 0;\n\
             f floor (a b c d) grey;\n\
             v e {l:e} {l:e} {h:e}; v f {l:e} {m:e} {h:e}; v g {m:e} {m:e} {h:e}; v h {m:e} {l:e} {h:e};\n\
             f lamp (e f g h) lamp;\n",
            x = 4.0 * s,
            l = 1.5 * s,
            m = 2.5 * s,
            h = 3.0 * s
        )
    };
    let refused = [
        (1e78, "<stdin>:3:16: error: x coordinate '4e78' is beyond"),
        (1e-40, "error: <stdin>: the model's vertices span only"),
    ];
    for tool in ["ugrad", "ugcheck", "ugvlmerge", "ugcut"] {
        for (scale, says) in refused {
            let out = run(tool, &model(scale));
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{tool} {scale}: {err}");
            assert!(out.stdout.is_empty(), "{tool} {scale}");
            assert!(err.starts_with(says), "{tool} {scale}: {err}");
        }
    }
    // Within the range both ends light.
    for s in [1e-25, 1e35] {
        let out = run("ugrad", &model(s));
        assert!(
            out.status.success(),
            "{s}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
