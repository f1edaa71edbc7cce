//! Every fixture model (all but the malformed corpus) round-trips: the
//! canonical text parses back to the same model, and writing is idempotent.

use ugkit::{root, run_ok};

fn fixtures(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            if p.file_name().is_some_and(|n| n != "bad") {
                fixtures(&p, out);
            }
        } else if p.extension().is_some_and(|x| x == "ug") {
            out.push(p);
        }
    }
}

#[test]
fn every_fixture_round_trips() {
    let mut files = Vec::new();
    fixtures(&root().join("fixtures"), &mut files);
    files.sort();
    assert!(files.len() >= 40, "{} fixtures", files.len());
    for f in files {
        let opts = ug::ParseOptions::default();
        let parsed = ug::parse_file(&f, &opts)
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()))
            .model;
        let text = ug::write_string(&parsed);
        let again = ug::parse(text.as_bytes(), "canonical").unwrap().model;
        assert_eq!(again, parsed, "{}", f.display());
        assert_eq!(ug::write_string(&again), text, "{}", f.display());
        // ugcat agrees with the library.
        assert_eq!(
            run_ok("ugcat", &[f.to_str().unwrap()], None),
            text,
            "{}",
            f.display()
        );
    }
}
