//! The format bridges end to end: obj2ug, ug2obj, ug2ply, ply2ug and mgf2ug
//! on the fixtures in `fixtures/bridges/`, held against golden files and
//! `ugcheck`; lit models round trip through PLY and OBJ; the Cornell box OBJ
//! runs through the whole pipeline. Build the tools first: `cargo build -p
//! ugcheck -p ug2ply -p ug2obj -p obj2ug -p ply2ug -p mgf2ug -p ugplanar -p
//! ugvlmerge -p ugflip -p ugisect -p ugcopl -p ugclean -p ugcut -p ugrad`.

use std::collections::BTreeMap;

use glam::DVec3;
use ugkit::{assert_golden, fixture, run, run_ok};

fn path(rel: &str) -> String {
    fixture(rel).to_str().expect("UTF-8 path").to_string()
}

fn report(ug: &str) -> serde_json::Value {
    let json = run_ok("ugcheck", &["--json", "-"], Some(ug.as_bytes()));
    serde_json::from_str(&json).expect("valid JSON")
}

fn area(report: &serde_json::Value, material: &str) -> f64 {
    report["area_by_material"]
        .as_array()
        .expect("area_by_material")
        .iter()
        .find(|m| m["material"] == material)
        .and_then(|m| m["area"].as_f64())
        .unwrap_or_else(|| panic!("no area for {material}"))
}

/// Area per `usemtl` material of an OBJ file's faces, computed here without
/// obj2ug: Newell normals of the (planar) polygons.
fn obj_areas(text: &str) -> BTreeMap<String, f64> {
    let mut v: Vec<DVec3> = Vec::new();
    let mut mat = String::new();
    let mut out = BTreeMap::new();
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first() {
            Some(&"v") => v.push(DVec3::new(
                w[1].parse().unwrap(),
                w[2].parse().unwrap(),
                w[3].parse().unwrap(),
            )),
            Some(&"usemtl") => mat = w[1].to_string(),
            Some(&"f") => {
                let p: Vec<DVec3> = w[1..]
                    .iter()
                    .map(|r| {
                        let i: i64 = r.split('/').next().unwrap().parse().unwrap();
                        let k = if i > 0 { i - 1 } else { v.len() as i64 + i };
                        v[k as usize]
                    })
                    .collect();
                let mut n = DVec3::ZERO;
                for k in 0..p.len() {
                    n += p[k].cross(p[(k + 1) % p.len()]);
                }
                *out.entry(mat.clone()).or_insert(0.0) += n.length() / 2.0;
            }
            _ => {}
        }
    }
    out
}

#[test]
fn obj2ug_cube_is_clean_and_keeps_area_per_material() {
    let ug = run_ok("obj2ug", &[&path("bridges/cube.obj")], None);
    assert_golden("fixtures/bridges/golden/cube.ug", &ug);
    let out = run(
        "ugcheck",
        &["--deny", "defects", "-q", "-"],
        Some(ug.as_bytes()),
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let r = report(&ug);
    assert_eq!(
        r["boundary_edges"].as_array().unwrap().len(),
        0,
        "the cube is closed"
    );
    let expected = obj_areas(&std::fs::read_to_string(fixture("bridges/cube.obj")).unwrap());
    assert_eq!(expected.len(), 2);
    for (m, a) in expected {
        assert!(
            (area(&r, &m) - a).abs() < 1e-12,
            "{m}: {} vs {a}",
            area(&r, &m)
        );
    }
    assert_eq!(r["counts"]["emitters"], 1);
}

#[test]
fn obj2ug_ngons_and_negative_indices() {
    let out = run("obj2ug", &[&path("bridges/ngons.obj")], None);
    assert!(out.status.success());
    let ug = String::from_utf8(out.stdout).unwrap();
    assert_golden("fixtures/bridges/golden/ngons.ug", &ug);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr
            .contains("ngons.obj:17:1: warning: face with fewer than 3 distinct vertices dropped"),
        "{stderr}"
    );
    let r = report(&ug);
    assert_eq!(r["counts"]["faces"], 3);
    assert_eq!(r["counts"]["wires"], 1);
    assert_eq!(r["degenerate"].as_array().unwrap().len(), 0);
}

/// obj2ug | ug2obj | obj2ug gives back the same UG, byte for byte.
fn round_trip(rel: &str) {
    let first = run_ok("obj2ug", &[&path(rel)], None);
    let dir = tempfile::tempdir().unwrap();
    let ug = dir.path().join("a.ug");
    std::fs::write(&ug, &first).unwrap();
    let obj = dir.path().join("b.obj");
    run_ok(
        "ug2obj",
        &[ug.to_str().unwrap(), "-o", obj.to_str().unwrap()],
        None,
    );
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(text.contains("\nmtllib b.mtl\n"), "{text}");
    assert!(dir.path().join("b.mtl").exists());
    let second = run_ok("obj2ug", &[obj.to_str().unwrap()], None);
    assert_eq!(first, second, "{rel}: not stable through ug2obj");
}

#[test]
fn obj_round_trip_is_stable() {
    round_trip("bridges/cube.obj");
    round_trip("bridges/ngons.obj");
}

#[test]
fn ug2obj_lit_model_and_mtl_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let mtl = dir.path().join("lit.mtl");
    let obj = run_ok(
        "ug2obj",
        &[
            &path("bridges/lit-square.ug"),
            "--mtl",
            mtl.to_str().unwrap(),
        ],
        None,
    );
    assert!(obj.contains("v 0 0 0 1.0000 1.0000 1.0000\n"), "{obj}");
    assert_golden(
        "fixtures/bridges/golden/lit-square.obj",
        &obj.replace(mtl.to_str().unwrap(), "lit.mtl"),
    );
    let mtl = std::fs::read_to_string(&mtl).unwrap();
    assert_eq!(
        mtl,
        "# written by ug2obj\nnewmtl floor\nKd 0.8 0.8 0.8\nKe 0 0 0\n"
    );
    // To stdout without --mtl: no mtllib line, no MTL file.
    let obj = run_ok("ug2obj", &[&path("bridges/lit-square.ug")], None);
    assert!(!obj.contains("mtllib"), "{obj}");
}

#[test]
fn ug2ply_lit_model_golden_and_binary() {
    let ply = run_ok("ug2ply", &[&path("bridges/lit-square.ug")], None);
    assert_golden("fixtures/bridges/golden/lit-square.ply", &ply);
    let bright = run_ok(
        "ug2ply",
        &["--exposure", "2", &path("bridges/lit-square.ug")],
        None,
    );
    // B = (0.5, 0.25, 0.125): B/pi * 4 = (0.64, 0.32, 0.16) -> sRGB 209 153 111
    assert!(
        bright.contains("\n1 0 0 0.5 0.25 0.125 209 153 111\n"),
        "{bright}"
    );
    let bin = run(
        "ug2ply",
        &["--binary", &path("bridges/lit-square.ug")],
        None,
    );
    assert!(bin.status.success());
    let end = b"end_header\n";
    let at = bin
        .stdout
        .windows(end.len())
        .position(|w| w == end)
        .unwrap()
        + end.len();
    assert!(
        bin.stdout
            .starts_with(b"ply\nformat binary_little_endian 1.0\n")
    );
    // 4 vertices of 3 doubles, 3 floats, 3 uchars; one quad of a uchar and 4 ints.
    assert_eq!(bin.stdout.len() - at, 4 * (24 + 12 + 3) + 1 + 16);
}

/// Counts from a PLY header.
fn ply_counts(ply: &str) -> (usize, usize) {
    let count = |el: &str| -> usize {
        ply.lines()
            .find_map(|l| l.strip_prefix(&format!("element {el} ")))
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no element {el}"))
    };
    (count("vertex"), count("face"))
}

#[test]
fn ug2ply_cornell_box_counts() {
    let ply = run_ok("ug2ply", &[&path("cornell-box.ug")], None);
    let model = ug::parse_file(&fixture("cornell-box.ug"), &Default::default())
        .unwrap()
        .model;
    // Every face is a quad without holes: one polygon each; vertices are not
    // shared between materials here, so one PLY vertex per UG vertex used.
    assert_eq!(model.faces.len(), 16);
    assert_eq!(ply_counts(&ply), (64, 16));
    assert!(
        ply.contains("property uchar red\n") && !ply.contains("radiosity"),
        "unlit"
    );
    let body: Vec<&str> = ply.split("end_header\n").nth(1).unwrap().lines().collect();
    assert_eq!(body.len(), 64 + 16);
    assert!(body[64..].iter().all(|l| l.starts_with("4 ")));
    // The converted MGF box: the ceiling with its hole is triangulated.
    let ug = run_ok("mgf2ug", &[&path("bridges/cornell.mgf")], None);
    let ply = run_ok("ug2ply", &["-"], Some(ug.as_bytes()));
    let m = ug::parse(ug.as_bytes(), "<mgf>").unwrap().model;
    let holes: Vec<usize> = m
        .faces
        .iter()
        .filter(|f| f.contours.len() > 1)
        .map(|f| f.contours.iter().map(Vec::len).sum::<usize>())
        .collect();
    assert_eq!(holes, [8], "one face with a hole: 4 + 4 corners");
    // A square ring of 8 corners is 8 triangles.
    assert_eq!(ply_counts(&ply).1, m.faces.len() - 1 + 8);
}

#[test]
fn mgf2ug_cornell_box() {
    let out = run("mgf2ug", &[&path("bridges/cornell.mgf")], None);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ug = String::from_utf8(out.stdout).unwrap();
    assert_golden("fixtures/bridges/golden/cornell.ug", &ug);
    let r = report(&ug);
    assert!((area(&r, "lamp") - 0.0225).abs() < 1e-12);
    assert!((area(&r, "red") - 0.55 * 0.56).abs() < 1e-12);
    assert!((area(&r, "green") - 0.55 * 0.56).abs() < 1e-12);
    assert_eq!(r["counts"]["emitters"], 1);
    // Sphere (16 × 8), cylinder and cap (16 + 16), three prisms (3 × 6), five walls, lamp.
    assert_eq!(r["counts"]["faces"], 128 + 32 + 18 + 5 + 1);
    // Orientation is consistent everywhere (primitives, mirrored and included parts).
    assert_eq!(r["inconsistent"].as_array().unwrap().len(), 0);
    assert_eq!(r["degenerate"].as_array().unwrap().len(), 0);
    assert_eq!(r["nonplanar"].as_array().unwrap().len(), 0);
    // Same bytes from stdin (includes resolved from the current directory).
    let src = std::fs::read(fixture("bridges/cornell.mgf")).unwrap();
    let out = std::process::Command::new(ugkit::bin("mgf2ug"))
        .current_dir(fixture("bridges"))
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            use std::io::Write;
            c.stdin.take().unwrap().write_all(&src)?;
            c.wait_with_output()
        })
        .unwrap();
    assert_eq!(String::from_utf8(out.stdout).unwrap(), ug);
}

#[test]
fn importer_errors_are_positioned_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &str, &str, &str); 4] = [
        (
            "obj2ug",
            "bad.obj",
            "v 0 0 0\nf 1 2 3\n",
            "bad.obj:2:5: error: vertex index 2 is out of range",
        ),
        (
            "obj2ug",
            "nomtl.obj",
            "mtllib missing.mtl\n",
            "nomtl.obj:1:8: error: cannot read material library 'missing.mtl'",
        ),
        (
            "mgf2ug",
            "bad.mgf",
            "v a =\np 0 0 zero\n",
            "bad.mgf:2:7: error: bad number 'zero' (expected z)",
        ),
        (
            "mgf2ug",
            "strict.mgf",
            "frob\n",
            "strict.mgf:1:1: error: unknown entity 'frob'",
        ),
    ];
    for (tool, name, text, msg) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let out = run(tool, &["--strict", p.to_str().unwrap()], None);
        assert_eq!(out.status.code(), Some(2), "{tool} {name}");
        assert!(out.stdout.is_empty());
        let stderr = String::from_utf8(out.stderr).unwrap();
        let shown = format!("{}/{msg}", dir.path().display());
        assert!(stderr.starts_with(&shown), "{stderr}\nexpected {shown}");
    }
    // From stdin the file is <stdin>.
    let out = run("obj2ug", &[], Some(b"v 0 0 0\nf 1 1 x\n"));
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        String::from_utf8(out.stderr).unwrap(),
        "<stdin>:2:7: error: bad vertex reference 'x'\n"
    );
}

/// Runs a tool on stdin bytes, asserts success, returns stdout bytes.
fn run_bytes(name: &str, args: &[&str], stdin: &[u8]) -> Vec<u8> {
    let out = run(name, args, Some(stdin));
    assert!(
        out.status.success(),
        "{name} {args:?} failed with {:?}\nstderr:\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

fn parse_flat(ug: &str, what: &str) -> ug::Model {
    ug::parse(ug.as_bytes(), what)
        .unwrap_or_else(|e| panic!("{what}: {e}"))
        .model
        .flatten()
        .unwrap()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-300
}

/// Two UG models have the same faces in order: the same vertex positions
/// and per-vertex colours (within `rel`), and with `materials` the same face
/// names and material names and colours.
fn assert_same_lit(a: &str, b: &str, what: &str, materials: bool) {
    let (ma, mb) = (parse_flat(a, "original"), parse_flat(b, what));
    let fa: Vec<ug::FaceId> = ma.top_faces().collect();
    let fb: Vec<ug::FaceId> = mb.top_faces().collect();
    assert_eq!(fa.len(), fb.len(), "{what}: face count");
    let colour = |m: &ug::Model, v: ug::VertexId| -> [f64; 3] {
        let c = m
            .vertex(v)
            .color
            .unwrap_or_else(|| panic!("{what}: vertex {} has no colour", m.vertex(v).name));
        let mat = m.material(c);
        assert!(matches!(mat.def, ug::MaterialDef::Rgb(_)), "{what}");
        mat.diffuse()
    };
    let mut colours = std::collections::BTreeSet::new();
    for (&x, &y) in fa.iter().zip(&fb) {
        let (f, g) = (ma.face(x), mb.face(y));
        assert_eq!(f.contours.len(), 1, "no holes in the test models");
        assert_eq!(g.contours.len(), 1, "{what}");
        assert_eq!(
            f.contours[0].len(),
            g.contours[0].len(),
            "{what}: face {x:?}"
        );
        for (&u, &v) in f.contours[0].iter().zip(&g.contours[0]) {
            let (p, q) = (ma.pos(u), mb.pos(v));
            assert!(
                (0..3).all(|k| close(p[k], q[k], 1e-12)),
                "{what}: position {p} vs {q}"
            );
            let (c, d) = (colour(&ma, u), colour(&mb, v));
            assert!(
                (0..3).all(|k| close(c[k], d[k], 1e-6)),
                "{what}: colour {c:?} vs {d:?}"
            );
            colours.insert(mb.material(mb.vertex(v).color.unwrap()).name.clone());
        }
        if materials {
            assert_eq!(f.name, g.name, "{what}: face name");
            let (ka, kb) = (
                f.material.map(|m| ma.material(m)),
                g.material.map(|m| mb.material(m)),
            );
            assert_eq!(ka.map(|m| &m.name), kb.map(|m| &m.name), "{what}: material");
            if let (Some(ka), Some(kb)) = (ka, kb) {
                assert_eq!(ka.diffuse(), kb.diffuse(), "{what}: {}", ka.name);
                assert_eq!(ka.emission(), kb.emission(), "{what}: {}", ka.name);
            }
        }
    }
    // The colours are ugrad's `c_rgb _radN`.
    assert!(
        colours.iter().all(|n| n.starts_with("_rad")),
        "{what}: {colours:?}"
    );
}

/// The Cornell box lit by ugrad (a few shots, ray-cast visibility). The
/// published red wall is not planar, so ugplanar runs first (ugcut needs
/// planar faces).
fn lit_cornell_box() -> String {
    let planar = run_ok("ugplanar", &[&path("cornell-box.ug")], None);
    let cut = run_ok("ugcut", &["-l", "100"], Some(planar.as_bytes()));
    run_ok(
        "ugrad",
        &["-q", "--visibility", "ray", "--max-shots", "20"],
        Some(cut.as_bytes()),
    )
}

/// ug → ug2ply (ASCII, binary) → ply2ug and ug → ug2obj --radiosity →
/// obj2ug --vertex-colours keep positions and radiosity colours.
fn lit_round_trips(name: &str, ug: &str) {
    for args in [&[][..], &["--binary"][..]] {
        let ply = run_bytes("ug2ply", args, ug.as_bytes());
        let back = run_bytes("ply2ug", &[], &ply);
        let back = String::from_utf8(back).unwrap();
        assert_same_lit(ug, &back, &format!("{name} via ug2ply {args:?}"), false);
    }
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("lit.ug");
    std::fs::write(&src, ug).unwrap();
    let obj = dir.path().join("lit.obj");
    run_ok(
        "ug2obj",
        &[
            "--radiosity",
            src.to_str().unwrap(),
            "-o",
            obj.to_str().unwrap(),
        ],
        None,
    );
    let back = run_ok("obj2ug", &["--vertex-colours", obj.to_str().unwrap()], None);
    assert_same_lit(ug, &back, &format!("{name} via ug2obj --radiosity"), true);
    // Without --vertex-colours the colours are not read.
    let plain = run_ok("obj2ug", &[obj.to_str().unwrap()], None);
    assert!(
        parse_flat(&plain, "plain")
            .vertices
            .iter()
            .all(|v| v.color.is_none())
    );
}

#[test]
fn lit_square_round_trips_through_ply_and_obj() {
    let ug = std::fs::read_to_string(fixture("bridges/lit-square.ug")).unwrap();
    lit_round_trips("lit-square", &ug);
    // The golden PLY back as UG: ugrad's colours, no material (PLY has none).
    let back = run_ok("ply2ug", &[&path("bridges/golden/lit-square.ply")], None);
    assert_golden("fixtures/bridges/golden/lit-square.from-ply.ug", &back);
}

#[test]
fn lit_cornell_box_round_trips_through_ply_and_obj() {
    let lit = lit_cornell_box();
    let m = parse_flat(&lit, "lit");
    assert!(m.faces.len() > 1000, "{} faces", m.faces.len());
    lit_round_trips("lit Cornell box", &lit);
}

#[test]
fn ply2ug_errors_are_positioned_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let header = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                  property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let bad = dir.path().join("bad.ply");
    std::fs::write(&bad, format!("{header}0 0 0\n3 0 0 1\n")).unwrap();
    let bin_header = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n\
                      property double y\nproperty double z\nend_header\n";
    let short = dir.path().join("short.ply");
    let mut bytes = bin_header.as_bytes().to_vec();
    bytes.extend_from_slice(&1.5f64.to_le_bytes());
    bytes.extend_from_slice(&[0, 0, 0]);
    std::fs::write(&short, &bytes).unwrap();
    let cases = [
        (
            &bad,
            "bad.ply:11:7: error: vertex index 1 is out of range (1 vertices)".to_string(),
        ),
        (
            &short,
            format!(
                "short.ply:byte {}: error: truncated data: it ends in property 'y' of element 'vertex' 1 of 1",
                bin_header.len() + 8
            ),
        ),
    ];
    for (p, msg) in cases {
        let out = run("ply2ug", &[p.to_str().unwrap()], None);
        assert_eq!(out.status.code(), Some(2), "{msg}");
        assert!(out.stdout.is_empty());
        let stderr = String::from_utf8(out.stderr).unwrap();
        assert_eq!(stderr, format!("{}/{msg}\n", dir.path().display()));
    }
}

/// Per material of the faces using them: the smallest and largest sum of
/// the radiosity channels at their vertices.
fn radiosity_range(m: &ug::Model) -> BTreeMap<String, (f64, f64)> {
    let mut out: BTreeMap<String, (f64, f64)> = BTreeMap::new();
    for f in m.top_faces() {
        let face = m.face(f);
        let mat = face
            .material
            .map_or("-".to_string(), |k| m.material(k).name.clone());
        for &v in face.contours.iter().flatten() {
            let c = m.vertex(v).color.expect("lit vertex");
            let b: f64 = m.material(c).diffuse().iter().sum();
            let e = out.entry(mat.clone()).or_insert((f64::INFINITY, 0.0));
            *e = (e.0.min(b), e.1.max(b));
        }
    }
    out
}

#[test]
fn cornell_box_obj_runs_through_the_whole_pipeline() {
    let out = run("obj2ug", &[&path("bridges/cornell-box.obj")], None);
    assert!(out.status.success());
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ug = String::from_utf8(out.stdout).unwrap();
    // The same faces as the UG Cornell box: names, corners, materials.
    let (a, b) = (
        parse_flat(
            &std::fs::read_to_string(fixture("cornell-box.ug")).unwrap(),
            "ug",
        ),
        parse_flat(&ug, "obj"),
    );
    assert_eq!(a.faces.len(), b.faces.len());
    for (f, g) in a.faces.iter().zip(&b.faces) {
        assert_eq!(f.name, g.name);
        let pa: Vec<DVec3> = f.contours[0].iter().map(|&v| a.pos(v)).collect();
        let pb: Vec<DVec3> = g.contours[0].iter().map(|&v| b.pos(v)).collect();
        assert_eq!(pa, pb, "{:?}", f.name);
        let (ka, kb) = (
            a.material(f.material.unwrap()),
            b.material(g.material.unwrap()),
        );
        assert_eq!(ka.name, kb.name);
        assert_eq!((ka.diffuse(), ka.emission()), (kb.diffuse(), kb.emission()));
    }
    // The cleaning chain, then a defect-free model.
    let model = String::from_utf8(ugkit::chain(ug.as_bytes())).unwrap();
    let check = run(
        "ugcheck",
        &["--deny", "defects", "-"],
        Some(model.as_bytes()),
    );
    assert_eq!(
        check.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&check.stdout)
    );
    let r = report(&model);
    for k in ugkit::DEFECT_KEYS {
        assert_eq!(r[k].as_array().unwrap().len(), 0, "{k}");
    }
    assert_eq!(r["counts"]["emitters"], 1);
    // Meshed and lit: the light is the brightest surface.
    let cut = run_ok("ugcut", &["-q", "-l", "100"], Some(model.as_bytes()));
    let lit = run_ok(
        "ugrad",
        &["-q", "--visibility", "ray", "--converge", "1e-2"],
        Some(cut.as_bytes()),
    );
    let range = radiosity_range(&parse_flat(&lit, "lit"));
    assert_eq!(
        range.keys().collect::<Vec<_>>(),
        ["green", "light", "red", "white"],
        "{range:?}"
    );
    let light_min = range["light"].0;
    for (m, (_, hi)) in &range {
        if m != "light" {
            assert!(*hi < light_min, "{m} is brighter than the light: {range:?}");
        }
    }
    assert!(range["white"].1 > 0.0, "{range:?}");
}

/// Issue #13: a hole hung on the outline at one repeated vertex
/// (fixtures/bridges/one-vertex-seam.mgf) converts without a warning into
/// a face with a hole, which the chain and ugcut turn into clean patches
/// with the wall's area (12 less the 3 of the window).
#[test]
fn mgf2ug_one_vertex_seam() {
    let out = run("mgf2ug", &[&path("bridges/one-vertex-seam.mgf")], None);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ug = String::from_utf8(out.stdout).unwrap();
    let m = parse_flat(&ug, "mgf2ug");
    assert_eq!(m.faces.len(), 1);
    assert_eq!(m.faces[0].contours.len(), 2);
    let r = report(&ug);
    assert!(
        (area(&r, "white") - 9.0).abs() < 1e-12,
        "{}",
        area(&r, "white")
    );
    let cut = run_ok("ugcut", &["-l", "0.5"], Some(ug.as_bytes()));
    let r = report(&cut);
    assert!((area(&r, "white") - 9.0).abs() < 1e-9);
    for key in ["nonpatch", "tvertices", "degenerate", "overlapping"] {
        assert_eq!(r[key].as_array().unwrap().len(), 0, "{key}: {}", r[key]);
    }
}
