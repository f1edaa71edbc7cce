//! ugclean end to end: one face of every coincident pair goes, the right one,
//! and exactly the hidden area is removed.

use ugkit::{fixture, run_ok};

fn check(text: &str) -> serde_json::Value {
    serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(text.as_bytes()))).unwrap()
}

fn area(r: &serde_json::Value, material: &str) -> f64 {
    r["area_by_material"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["material"] == material)
        .map_or(0.0, |m| m["area"].as_f64().unwrap())
}

fn faces(text: &str) -> Vec<String> {
    let m = ug::parse(text.as_bytes(), "o").unwrap().model;
    m.top_faces()
        .map(|f| m.face(f).name.clone().unwrap_or_default())
        .collect()
}

#[test]
fn the_piece_under_the_rug_goes_and_the_rug_stays() {
    let src = std::fs::read_to_string(fixture("clean/rug-on-floor.ug")).unwrap();
    let out = run_ok("ugclean", &[], Some(src.as_bytes()));
    assert_eq!(faces(&out), ["floor.2", "rug"]);
    let (before, after) = (check(&src), check(&out));
    assert_eq!(after["coincident"].as_array().unwrap().len(), 0);
    assert_eq!(area(&before, "floor") - area(&after, "floor"), 4.0);
    assert_eq!(area(&before, "rug"), area(&after, "rug"));
    // Vertices only the removed face used are gone; shared ones stay.
    let m = ug::parse(out.as_bytes(), "o").unwrap().model;
    let names: Vec<&str> = m
        .top_vertices()
        .map(|v| m.vertex(v).name.as_str())
        .collect();
    assert!(!names.contains(&"a") && !names.contains(&"d"), "{names:?}");
    assert!(names.contains(&"b") && names.contains(&"c"));
}

#[test]
fn the_origin_annotation_decides_for_cut_pieces() {
    let src = std::fs::read_to_string(fixture("clean/paper-on-desk.ug")).unwrap();
    let out = run_ok("ugclean", &[], Some(src.as_bytes()));
    assert_eq!(faces(&out), ["paper"]);
    assert!(
        !out.contains("ugcopl origin"),
        "the removed piece's annotation goes with it"
    );
    assert!((area(&check(&out), "paper") - 0.06).abs() < 1e-15);
}

#[test]
fn duplicates_go_and_back_to_back_sides_stay() {
    let src = std::fs::read_to_string(fixture("clean/duplicates.ug")).unwrap();
    let out = run_ok("ugclean", &[], Some(src.as_bytes()));
    assert_eq!(faces(&out), ["wall", "front", "back"]);
    let r = check(&out);
    assert_eq!(r["coincident"].as_array().unwrap().len(), 0);
    assert_eq!(area(&check(&src), "wall") - area(&r, "wall"), 6.0);
}

#[test]
fn idempotent_deterministic_and_a_no_op_without_coincident_faces() {
    for name in [
        "clean/rug-on-floor.ug",
        "clean/duplicates.ug",
        "clean/paper-on-desk.ug",
    ] {
        let p = fixture(name);
        let once = run_ok("ugclean", &[p.to_str().unwrap()], None);
        assert_eq!(
            once,
            run_ok("ugclean", &[p.to_str().unwrap()], None),
            "{name}"
        );
        assert_eq!(
            run_ok("ugclean", &[], Some(once.as_bytes())),
            once,
            "{name}"
        );
    }
    for name in [
        "cornell-box.ug",
        "check/overlap.ug",
        "check/back-to-back.ug",
    ] {
        let p = fixture(name);
        assert_eq!(
            run_ok("ugclean", &[p.to_str().unwrap()], None),
            run_ok("ugcat", &[p.to_str().unwrap()], None),
            "{name}"
        );
    }
}
