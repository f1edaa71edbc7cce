//! ugplanar end to end: non-planar faces become triangles, nothing else changes.

use ugkit::{fixture, run, run_ok};

fn check(ug: &str) -> serde_json::Value {
    serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(ug.as_bytes()))).unwrap()
}

fn area(report: &serde_json::Value, material: &str) -> f64 {
    report["area_by_material"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["material"] == material)
        .and_then(|m| m["area"].as_f64())
        .unwrap()
}

#[test]
fn warped_faces_are_tessellated_and_planar_ones_kept() {
    let path = fixture("planar/warped.ug");
    let before = check(&std::fs::read_to_string(&path).unwrap());
    assert_eq!(before["nonplanar"].as_array().unwrap().len(), 2);
    let out = run_ok("ugplanar", &[path.to_str().unwrap()], None);
    let after = check(&out);
    for key in ugkit::DEFECT_KEYS {
        assert_eq!(
            after[key].as_array().unwrap().len(),
            0,
            "{key} after ugplanar: {}",
            after[key]
        );
    }
    let faces: Vec<&str> = out.lines().filter(|l| l.starts_with("f ")).collect();
    assert_eq!(faces.len(), 2 + 8 + 1, "{out}");
    assert!(
        faces.contains(&"f roof.1 (r0 r1 r3) roof;"),
        "quad split along the smaller fold: {out}"
    );
    assert!(faces.contains(&"f wall (w0 w1 w2 w3) wall;"));
    assert!(
        faces
            .iter()
            .filter(|f| f.starts_with("f window."))
            .all(|f| f.ends_with(" frame;"))
    );
    // Area per material is kept (ugcheck measures a non-planar face as the
    // triangles ugplanar makes of it, and planar ones as polygons).
    assert_eq!(area(&after, "wall"), 12.0);
    for m in ["roof", "frame", "wall"] {
        let (a, b) = (area(&before, m), area(&after, m));
        assert!((a - b).abs() / a <= 1e-9, "{m}: {a} → {b}");
    }
    // The window frame keeps its hole: the triangles' area is the frame's, not the rectangle's.
    assert!(area(&after, "frame") < 4.0 * 3.2 - 1.9);
}

#[test]
fn cornell_box_red_wall_is_split_and_nothing_else_changes() {
    let path = fixture("cornell-box.ug");
    let src = std::fs::read_to_string(&path).unwrap();
    let before = check(&src);
    let np = before["nonplanar"].as_array().unwrap();
    assert_eq!(np.len(), 1);
    assert_eq!(np[0]["face"], "red");
    // 3.2 mm off the plane of three corners = 0.8 mm from the best-fit plane.
    assert!((np[0]["deviation"].as_f64().unwrap() - 0.8).abs() < 1e-3);
    let out = run_ok("ugplanar", &[path.to_str().unwrap()], None);
    let after = check(&out);
    assert_eq!(after["nonplanar"].as_array().unwrap().len(), 0);
    assert_eq!(out.lines().filter(|l| l.starts_with("f red.")).count(), 2);
    assert_eq!(out.lines().filter(|l| l.starts_with("f ")).count(), 17);
    for m in ["white", "red", "green", "light"] {
        let (a, b) = (area(&before, m), area(&after, m));
        assert!((a - b).abs() / a <= 1e-9, "{m}: {a} → {b}");
    }
    // Everything but the red wall is written exactly as ugcat writes it.
    let cat = run_ok("ugcat", &[path.to_str().unwrap()], None);
    let strip = |s: &str| {
        s.lines()
            .filter(|l| !l.starts_with("f red"))
            .map(String::from)
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&out), strip(&cat));
}

#[test]
fn planar_model_passes_through_exactly_as_ugcat_writes_it() {
    for name in ["check/clean-box.ug", "red-cube.ug", "check/nonpatch.ug"] {
        let p = fixture(name);
        let p = p.to_str().unwrap();
        assert_eq!(
            run_ok("ugplanar", &[p], None),
            run_ok("ugcat", &[p], None),
            "{name}"
        );
    }
}

#[test]
fn output_is_deterministic_and_idempotent() {
    let p = fixture("planar/warped.ug");
    let a = run_ok("ugplanar", &[p.to_str().unwrap()], None);
    let b = run_ok("ugplanar", &[p.to_str().unwrap()], None);
    assert_eq!(a, b);
    let again = run_ok("ugplanar", &[], Some(a.as_bytes()));
    assert_eq!(again, a, "a second pass changes nothing");
}

#[test]
fn explicit_epsilon_leaves_slightly_warped_faces() {
    let p = fixture("check/nonplanar.ug"); // deviation 0.0495
    let p = p.to_str().unwrap();
    let loose = run_ok("ugplanar", &["-e", "0.1", p], None);
    assert_eq!(loose, run_ok("ugcat", &[p], None));
    let strict = run_ok("ugplanar", &["-e", "0.01", p], None);
    assert_eq!(strict.lines().filter(|l| l.starts_with("f ")).count(), 2);
}

#[test]
fn bad_input_is_reported_with_position_and_nothing_on_stdout() {
    let out = run("ugplanar", &[], Some(b"v a 0 0 0;\nf (a b c);\n"));
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err, "<stdin>:2:6: error: face names undefined vertex 'b'\n");
}

/// A floor with a hole, its outer contour `up` above the plane z = 0 and
/// its hole `down` below it, with epsilon 1e-3.
fn floor_with_a_hole(up: f64, down: f64) -> String {
    let mut s = String::from("c_rgb grey 0.5 0.5 0.5;\n");
    for (k, (x, y)) in [(0., 0.), (4., 0.), (4., 4.), (0., 4.)].iter().enumerate() {
        s += &format!("v o{k} {x} {y} {up};\n");
    }
    for (k, (x, y)) in [(1., 1.), (1., 3.), (3., 3.), (3., 1.)].iter().enumerate() {
        s += &format!("v h{k} {x} {y} {};\n", -down);
    }
    s + "f floor (o0 o1 o2 o3) (h0 h1 h2 h3) grey;\n"
}

/// ugplanar and ugcheck measure planarity alike (one plane through all
/// the contours' points; the check once took the outer contour's centroid
/// only, so a face with a hole the tools passed on as planar was not
/// planar to it: CAD building 30,000 seed 4 after the chain, a floor piece
/// 1.004 epsilon off): whatever ugcheck calls non-planar, ugplanar folds,
/// and what it keeps, ugcheck accepts.
#[test]
fn the_check_and_the_tools_agree_on_what_is_planar() {
    let eps = ["-e", "1e-3"];
    let report = |ug: &str| -> serde_json::Value {
        let args = ["--json", eps[0], eps[1]];
        serde_json::from_str(&run_ok("ugcheck", &args, Some(ug.as_bytes()))).unwrap()
    };
    // (up, down, planar within 1e-3 of one plane through the centroid):
    // the first is 1.4e-3 off the outer contour's own centroid plane.
    for (up, down, planar) in [
        (0.7e-3, 0.7e-3, true),
        (0.9e-3, 0.9e-3, true),
        (0.7e-3, 1.5e-3, false),
        (1.2e-3, 1.2e-3, false),
    ] {
        let src = floor_with_a_hole(up, down);
        let flagged = report(&src)["nonplanar"].as_array().unwrap().len();
        assert_eq!(flagged, usize::from(!planar), "{up} {down}");
        let out = run_ok("ugplanar", &eps, Some(src.as_bytes()));
        let faces = out.lines().filter(|l| l.starts_with("f ")).count();
        assert_eq!(faces == 1, planar, "{up} {down}: ugplanar wrote\n{out}");
        assert!(
            report(&out)["nonplanar"].as_array().unwrap().is_empty(),
            "{up} {down}"
        );
    }
}
