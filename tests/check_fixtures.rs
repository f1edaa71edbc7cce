//! ugcheck on the defect fixtures: each finds exactly the defect it was made
//! for and nothing else, and the text report matches its golden file.

use ugkit::{assert_golden, fixture, run, run_ok};

/// (fixture, category that must be present, how many findings, other categories that must be present)
const CASES: &[(&str, Option<&str>, usize, &[&str])] = &[
    ("clean-box", None, 0, &[]),
    ("back-to-back", None, 0, &[]),
    ("nonplanar", Some("nonplanar"), 1, &["boundary"]),
    ("tvertex", Some("tvertex"), 1, &["boundary"]),
    ("intersect", Some("intersect"), 1, &["boundary"]),
    ("wall-on-floor", Some("intersect"), 1, &["boundary"]),
    ("leg-on-tilted-column", None, 0, &["boundary", "nonpatch"]),
    (
        "globe-pole-on-a-column-top",
        None,
        0,
        &["boundary", "nonpatch"],
    ),
    ("overlap", Some("overlap"), 1, &["boundary"]),
    ("coincident", Some("coincident"), 1, &["boundary"]),
    ("degenerate", Some("degenerate"), 2, &["boundary"]),
    ("orientation", Some("orientation"), 4, &[]),
    ("nonmanifold", None, 0, &["boundary", "nonmanifold"]),
    ("nonpatch", None, 0, &["boundary", "nonpatch"]),
];

const DEFECTS: [&str; 7] = [
    "nonplanar",
    "tvertex",
    "intersect",
    "overlap",
    "coincident",
    "degenerate",
    "orientation",
];
const FACTS: [&str; 3] = ["boundary", "nonmanifold", "nonpatch"];

fn json_count(report: &serde_json::Value, category: &str) -> usize {
    let key = match category {
        "nonplanar" => "nonplanar",
        "tvertex" => "tvertices",
        "intersect" => "intersecting",
        "overlap" => "overlapping",
        "coincident" => "coincident",
        "degenerate" => "degenerate",
        "orientation" => "inconsistent",
        "boundary" => "boundary_edges",
        "nonmanifold" => "nonmanifold_edges",
        "nonpatch" => "nonpatch",
        _ => unreachable!(),
    };
    report[key]
        .as_array()
        .unwrap_or_else(|| panic!("{key} missing from JSON"))
        .len()
}

#[test]
fn each_fixture_has_exactly_its_defect() {
    for &(name, defect, n, facts) in CASES {
        let path = fixture(&format!("check/{name}.ug"));
        let json = run_ok("ugcheck", &["--json", path.to_str().unwrap()], None);
        let report: serde_json::Value = serde_json::from_str(&json).expect("valid JSON");
        for cat in DEFECTS {
            let got = json_count(&report, cat);
            let want = if Some(cat) == defect { n } else { 0 };
            assert_eq!(got, want, "{name}: {cat} count");
        }
        for cat in FACTS {
            let got = json_count(&report, cat);
            assert_eq!(
                got > 0,
                facts.contains(&cat),
                "{name}: {cat} present? (count {got})"
            );
        }
    }
}

#[test]
fn text_reports_match_golden_files() {
    for &(name, ..) in CASES {
        let rel = format!("fixtures/check/{name}.ug");
        let out = run("ugcheck", &[&rel], None);
        assert!(out.status.success());
        let text = String::from_utf8(out.stdout).unwrap();
        assert_golden(&format!("fixtures/check/{name}.check"), &text);
    }
}

#[test]
fn deny_exits_1_only_when_the_category_is_present() {
    let t = fixture("check/tvertex.ug");
    let t = t.to_str().unwrap();
    assert_eq!(
        run("ugcheck", &["-q", "--deny", "tvertex", t], None)
            .status
            .code(),
        Some(1)
    );
    assert_eq!(
        run("ugcheck", &["-q", "--deny", "defects", t], None)
            .status
            .code(),
        Some(1)
    );
    assert_eq!(
        run("ugcheck", &["-q", "--deny", "intersect,overlap", t], None)
            .status
            .code(),
        Some(0)
    );
    let clean = fixture("check/clean-box.ug");
    assert_eq!(
        run(
            "ugcheck",
            &["-q", "--deny", "all", clean.to_str().unwrap()],
            None
        )
        .status
        .code(),
        Some(0)
    );
    // An unknown category is a usage error.
    assert_eq!(
        run("ugcheck", &["--deny", "bogus", t], None).status.code(),
        Some(2)
    );
}

#[test]
fn wall_on_floor_names_the_pair() {
    let out = run_ok(
        "ugcheck",
        &[
            "--json",
            fixture("check/wall-on-floor.ug").to_str().unwrap(),
        ],
        None,
    );
    let r: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(r["intersecting"][0]["a"], "floor");
    assert_eq!(r["intersecting"][0]["b"], "wall");
}

#[test]
fn counts_and_areas_of_the_red_cube() {
    let out = run_ok(
        "ugcheck",
        &["--json", fixture("red-cube.ug").to_str().unwrap()],
        None,
    );
    let r: serde_json::Value = serde_json::from_str(&out).unwrap();
    let c = &r["counts"];
    assert_eq!(c["vertices"], 11);
    assert_eq!(c["faces"], 7);
    assert_eq!(c["edges"], 12 + 3);
    assert_eq!(c["materials"], 2);
    assert_eq!(c["emitters"], 1);
    // Six 2 x 2 faces of red, one light triangle with sides sqrt(2): area sqrt(3)/2.
    let areas = r["area_by_material"].as_array().unwrap();
    assert_eq!(areas[0]["material"], "red");
    assert!((areas[0]["area"].as_f64().unwrap() - 24.0).abs() < 1e-12);
    assert_eq!(areas[1]["material"], "whitelight");
    assert!((areas[1]["area"].as_f64().unwrap() - 3f64.sqrt() / 2.0).abs() < 1e-12);
}

#[test]
fn stdin_and_file_give_the_same_report() {
    let path = fixture("check/overlap.ug");
    let bytes = std::fs::read(&path).unwrap();
    let a = run_ok("ugcheck", &[path.to_str().unwrap()], None);
    let b = run_ok("ugcheck", &[], Some(&bytes));
    assert_eq!(a, b);
}
