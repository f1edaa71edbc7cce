//! ugcopl (and ugclean after it) end to end: overlaps become faces of their
//! own, area is kept, no T-vertex, and ugclean then removes exactly the
//! hidden area.

use ugkit::{fixture, run_ok};

fn check(text: &str) -> serde_json::Value {
    serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(text.as_bytes()))).unwrap()
}

fn count(r: &serde_json::Value, key: &str) -> usize {
    r[key].as_array().unwrap().len()
}

fn areas(r: &serde_json::Value) -> Vec<(String, f64)> {
    r["area_by_material"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["material"].as_str().unwrap().to_string(),
                m["area"].as_f64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn overlaps_become_separate_faces_and_ugclean_removes_the_hidden_area() {
    // (fixture, overlap area that ugclean must remove, material that loses it)
    let cases = [
        ("check/overlap.ug", 1.0, "grey"),
        ("copl/rug.ug", 1.5, "floor"),
        ("copl/pane.ug", 2.2 * 1.4 - 2.0 * 1.2, "wall"),
        ("copl/neighbours.ug", 1.5, "grey"),
    ];
    for (name, hidden, loser) in cases {
        let src = std::fs::read_to_string(fixture(name)).unwrap();
        let before = check(&src);
        assert!(count(&before, "overlapping") > 0, "{name}");
        let cut = run_ok("ugcopl", &[], Some(src.as_bytes()));
        let mid = check(&cut);
        for key in [
            "overlapping",
            "tvertices",
            "degenerate",
            "intersecting",
            "nonplanar",
        ] {
            assert_eq!(
                count(&mid, key),
                0,
                "{name} after ugcopl: {key} {}",
                mid[key]
            );
        }
        assert!(
            count(&mid, "coincident") > 0,
            "{name}: the overlap is a face in both"
        );
        // Area per material kept by ugcopl.
        for ((m0, a0), (m1, a1)) in areas(&before).into_iter().zip(areas(&mid)) {
            assert_eq!(m0, m1);
            assert!((a0 - a1).abs() <= 1e-9 * a0, "{name}: {m0} {a0} → {a1}");
        }
        let clean = run_ok("ugclean", &[], Some(cut.as_bytes()));
        let after = check(&clean);
        for key in [
            "overlapping",
            "coincident",
            "tvertices",
            "degenerate",
            "intersecting",
        ] {
            assert_eq!(count(&after, key), 0, "{name} after ugclean: {key}");
        }
        for ((m0, a0), (_, a2)) in areas(&before).into_iter().zip(areas(&after)) {
            let want = if m0 == loser { a0 - hidden } else { a0 };
            assert!(
                (a2 - want).abs() <= 1e-9 * a0,
                "{name}: {m0} {a2}, expected {want}"
            );
        }
        // Idempotent and deterministic.
        assert_eq!(run_ok("ugcopl", &[], Some(src.as_bytes())), cut, "{name}");
        assert_eq!(
            run_ok("ugcopl", &[], Some(clean.as_bytes())),
            run_ok("ugcat", &[], Some(clean.as_bytes())),
            "{name}"
        );
    }
}

#[test]
fn pieces_carry_names_and_origin_annotations() {
    let cut = run_ok("ugcopl", &[fixture("copl/rug.ug").to_str().unwrap()], None);
    assert!(
        cut.contains("{ugcopl origin floor area 16}\nf floor.c1 "),
        "{cut}"
    );
    assert!(cut.contains("f floor.c2 "), "{cut}");
    assert!(
        cut.contains("f rug (r0 r1 r2 r3) rug;"),
        "the rug lies inside the floor and stays whole"
    );
    // The floor's rest has the rug's outline as a hole; the other piece is
    // the rug's outline itself.
    let m = ug::parse(cut.as_bytes(), "o").unwrap().model;
    let mut holes: Vec<usize> = m
        .faces
        .iter()
        .filter(|f| f.name.as_deref().is_some_and(|n| n.starts_with("floor.c")))
        .map(|f| f.contours.len())
        .collect();
    holes.sort_unstable();
    assert_eq!(holes, [1, 2]);
}

#[test]
fn models_without_coplanar_overlaps_pass_through() {
    for name in [
        "cornell-box.ug",
        "check/coincident.ug",
        "check/back-to-back.ug",
        "cut/window-wall.ug",
    ] {
        let p = fixture(name);
        assert_eq!(
            run_ok("ugcopl", &[p.to_str().unwrap()], None),
            run_ok("ugcat", &[p.to_str().unwrap()], None),
            "{name}"
        );
    }
}
