//! ugvlmerge end to end: the grouper's output held against `ugcheck --json`.

use serde_json::Value;
use ugkit::{fixture, run, run_ok};

const FIXTURES: [&str; 5] = [
    "vlmerge/wall-window.ug",
    "vlmerge/floor-rug.ug",
    "vlmerge/long-edge.ug",
    "vlmerge/sliver.ug",
    "vlmerge/three-walls.ug",
];

/// Defect categories that must not grow (the ones the grouper removes must vanish).
const KEPT_OR_FEWER: [&str; 4] = ["intersecting", "overlapping", "coincident", "nonplanar"];

fn path(rel: &str) -> String {
    fixture(rel).to_str().unwrap().to_string()
}

/// `ugcheck --json` of a model given as text, with an explicit epsilon when given.
fn check(ug: &str, eps: Option<f64>) -> Value {
    let e;
    let mut args = vec!["--json"];
    if let Some(eps) = eps {
        e = eps.to_string();
        args.extend(["-e", e.as_str()]);
    }
    serde_json::from_str(&run_ok("ugcheck", &args, Some(ug.as_bytes()))).unwrap()
}

fn len(report: &Value, key: &str) -> usize {
    report[key].as_array().unwrap().len()
}

fn areas(report: &Value) -> Vec<(String, f64)> {
    report["area_by_material"]
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

fn parse(ug: &str) -> ug::Model {
    ug::parse(ug.as_bytes(), "out").unwrap().model
}

fn faces(out: &str) -> Vec<&str> {
    out.lines().filter(|l| l.starts_with("f ")).collect()
}

/// Twice the signed area of a contour along `dir` (Newell).
fn newell_along(m: &ug::Model, c: &[ug::VertexId], dir: [f64; 3]) -> f64 {
    let mut n = [0.0f64; 3];
    for i in 0..c.len() {
        let a = m.pos(c[i]);
        let b = m.pos(c[(i + 1) % c.len()]);
        n[0] += (a.y - b.y) * (a.z + b.z);
        n[1] += (a.z - b.z) * (a.x + b.x);
        n[2] += (a.x - b.x) * (a.y + b.y);
    }
    n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2]
}

/// Everything the grouper promises about one input: T-vertices gone, no two
/// vertices within epsilon, nothing degenerate, no defect introduced, area
/// per material kept, deterministic, idempotent. Returns the output.
fn holds_its_promises(rel: &str) -> String {
    let p = path(rel);
    let src = std::fs::read_to_string(&p).unwrap();
    let before = check(&src, None);
    let eps = before["epsilon"].as_f64().unwrap();
    let out = run_ok("ugvlmerge", &["-q", &p], None);
    let after = check(&out, Some(eps));

    assert_eq!(len(&after, "tvertices"), 0, "{rel}: {}", after["tvertices"]);
    assert_eq!(
        len(&after, "degenerate"),
        0,
        "{rel}: {}",
        after["degenerate"]
    );
    assert!(
        len(&after, "inconsistent") <= len(&before, "inconsistent"),
        "{rel}: {}",
        after["inconsistent"]
    );
    for key in KEPT_OR_FEWER {
        assert!(
            len(&after, key) <= len(&before, key),
            "{rel}: {key} before {} after {}",
            before[key],
            after[key]
        );
    }

    // No two vertices within epsilon.
    let m = parse(&out);
    for (i, a) in m.vertices.iter().enumerate() {
        for b in &m.vertices[i + 1..] {
            assert!(
                a.pos.distance(b.pos) > eps,
                "{rel}: {} and {} are within epsilon",
                a.name,
                b.name
            );
        }
    }

    // Area per material. (ugcheck leaves degenerate faces out of the sums;
    // one with a vertex repeated consecutively is repaired, and counts after.)
    let after_areas = areas(&after);
    let repaired = len(&before, "degenerate") > 0;
    for (mat, a) in areas(&before) {
        let b = after_areas
            .iter()
            .find(|(m, _)| *m == mat)
            .map_or(0.0, |x| x.1);
        if repaired {
            assert!(b >= a - 1e-9 * a, "{rel}: {mat}: {a} → {b}");
        } else {
            assert!((a - b).abs() <= 1e-9 * a, "{rel}: {mat}: {a} → {b}");
        }
    }

    // Deterministic and idempotent.
    assert_eq!(run_ok("ugvlmerge", &["-q", &p], None), out, "{rel}");
    let again = run_ok("ugvlmerge", &["-q"], Some(out.as_bytes()));
    assert_eq!(again, out, "{rel}: a second pass changed the output");
    out
}

#[test]
fn every_fixture_is_cleaned_without_new_defects() {
    for rel in FIXTURES {
        holds_its_promises(rel);
    }
}

#[test]
fn wall_with_a_window_becomes_one_face_with_one_hole() {
    let p = path("vlmerge/wall-window.ug");
    let before = check(&std::fs::read_to_string(&p).unwrap(), None);
    assert!(len(&before, "tvertices") >= 4);
    let out = holds_its_promises("vlmerge/wall-window.ug");
    assert_eq!(
        faces(&out),
        [
            "f left (a0 b1 b4 a3) (s3 t0 t1 b3 s6 s2) plaster;",
            "f glass (s3 s2 s6 b3 t1 t0) glass;"
        ],
        "{out}"
    );
    // Outer contour counter-clockwise, the hole clockwise, seen from the front (−y).
    let m = parse(&out);
    let wall = &m.faces[0];
    assert_eq!(wall.contours.len(), 2);
    let front = [0.0, -1.0, 0.0];
    assert!(newell_along(&m, &wall.contours[0], front) > 0.0);
    assert!(newell_along(&m, &wall.contours[1], front) < 0.0);
    let glass = &m.faces[1];
    assert!(newell_along(&m, &glass.contours[0], front) > 0.0);
    let after = check(&out, None);
    let a = areas(&after);
    let close = |m: &str, x: f64| a.iter().any(|(n, v)| n == m && (v - x).abs() < 1e-9);
    assert!(close("plaster", 16.0) && close("glass", 2.0), "{a:?}");
}

#[test]
fn floor_quads_join_around_the_mat_and_the_rug_stays() {
    let out = holds_its_promises("vlmerge/floor-rug.ug");
    let f = faces(&out);
    assert_eq!(f.len(), 3, "{out}");
    assert!(
        f[0].starts_with("f fa1 (") && f[0].ends_with(" floor;"),
        "{out}"
    );
    assert_eq!(f[0].matches('(').count(), 2, "one hole, for the mat: {out}");
    assert!(
        f[1].starts_with("f mat (") && f[1].ends_with(" mat;"),
        "{out}"
    );
    assert_eq!(f[2], "f rug (r0 r1 r2 r3) rug;");
    let m = parse(&out);
    let up = [0.0, 0.0, 1.0];
    assert!(newell_along(&m, &m.faces[0].contours[0], up) > 0.0);
    assert!(newell_along(&m, &m.faces[0].contours[1], up) < 0.0);
}

#[test]
fn t_vertices_along_one_long_edge_go_in_in_order() {
    let p = path("vlmerge/long-edge.ug");
    let before = check(&std::fs::read_to_string(&p).unwrap(), None);
    assert_eq!(len(&before, "tvertices"), 5);
    let out = holds_its_promises("vlmerge/long-edge.ug");
    let f = faces(&out);
    assert_eq!(f[0], "f slab (s0 s1 s2 x9 x7 x5 x25 x1 s3) slab;", "{out}");
    // The panels are one wall, keeping their feet (the slab uses them).
    assert_eq!(f.len(), 2, "{out}");
    assert!(f[1].starts_with("f p57 (x5 x7 x9 s2 "), "{out}");
    let words: Vec<&str> = f[1].split([' ', '(', ')']).collect();
    for v in ["x1", "x25", "x5", "x7", "x9"] {
        assert!(words.contains(&v), "{v}: {out}");
    }
}

#[test]
fn collapsed_faces_are_dropped_with_a_warning() {
    let p = path("vlmerge/sliver.ug");
    let o = run("ugvlmerge", &[&p], None);
    assert!(o.status.success());
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(
        err,
        "warning: face sliver: fewer than 3 distinct vertices after merging nearly coincident vertices; dropped\n\
         warning: face #3: zero area (its vertices are collinear); dropped\n"
    );
    let out = String::from_utf8(o.stdout).unwrap();
    assert_eq!(faces(&out), ["f top (c d e f) white;"]);
    // -q silences the warnings, not the result.
    let q = run("ugvlmerge", &["-q", &p], None);
    assert!(q.stderr.is_empty());
    assert_eq!(String::from_utf8(q.stdout).unwrap(), out);
    holds_its_promises("vlmerge/sliver.ug");
}

#[test]
fn three_walls_on_one_edge_stay_apart() {
    let out = holds_its_promises("vlmerge/three-walls.ug");
    assert_eq!(
        faces(&out),
        [
            "f a (p0 p2 q2 q0) wall;",
            "f b (p2 p4 q4 q2) wall;",
            "f c (c0 p2 q2 c3) wall;",
            "f floor_a (f0 c0 p2 p0) floor;",
            "f floor_b (c0 f4 p4 p2) floor;"
        ],
        "{out}"
    );
    let after = check(&out, None);
    assert_eq!(
        len(&after, "nonmanifold_edges"),
        2,
        "{}",
        after["nonmanifold_edges"]
    );
    assert_eq!(len(&after, "intersecting"), 0);
}

#[test]
fn other_fixtures_gain_no_defect() {
    for rel in [
        "red-cube.ug",
        "check/clean-box.ug",
        "check/tvertex.ug",
        "check/degenerate.ug",
        "check/nonmanifold.ug",
        "check/wall-on-floor.ug",
        "check/overlap.ug",
        "check/intersect.ug",
    ] {
        holds_its_promises(rel);
    }
}

#[test]
fn each_step_can_be_skipped() {
    let p = path("vlmerge/wall-window.ug");
    let cat = run_ok("ugcat", &[&p], None);
    let none = run_ok(
        "ugvlmerge",
        &[
            "--no-merge-vertices",
            "--no-split-edges",
            "--no-merge-faces",
            &p,
        ],
        None,
    );
    assert_eq!(none, cat, "nothing to do: the model as ugcat writes it");

    let eps = check(&cat, None)["epsilon"].as_f64().unwrap();
    let only_vertices = run_ok(
        "ugvlmerge",
        &["-q", "--no-split-edges", "--no-merge-faces", &p],
        None,
    );
    assert_eq!(faces(&only_vertices).len(), 7);
    assert!(len(&check(&only_vertices, Some(eps)), "tvertices") > 0);
    assert!(!only_vertices.contains("v s0 "), "s0 merged into a1");

    let no_faces = run_ok("ugvlmerge", &["-q", "--no-merge-faces", &p], None);
    assert_eq!(faces(&no_faces).len(), 7);
    assert_eq!(len(&check(&no_faces, Some(eps)), "tvertices"), 0);

    let no_vertices = run_ok("ugvlmerge", &["-q", "--no-merge-vertices", &p], None);
    assert!(no_vertices.contains("v s0 "));
    assert!(faces(&no_vertices).len() > 2);
}

#[test]
fn angle_and_epsilon_decide_what_is_coplanar() {
    // Two quads folded by 2 degrees along their common edge.
    let z = 2f64.to_radians().tan();
    let src = format!(
        "c_rgb w 1 1 1; v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\
         v e 2 0 {z}; v f 2 1 {z}; f l (a b c d) w; f r (b e f c) w;"
    );
    let strict = run_ok("ugvlmerge", &[], Some(src.as_bytes()));
    assert_eq!(faces(&strict).len(), 2);
    let loose = run_ok(
        "ugvlmerge",
        &["--angle", "3", "-e", "0.05"],
        Some(src.as_bytes()),
    );
    assert_eq!(faces(&loose), ["f l (a e f d) w;"]);
    let bad = run("ugvlmerge", &["--angle", "-1"], Some(src.as_bytes()));
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn verbose_prints_the_epsilon_and_counts_per_step() {
    let p = path("vlmerge/wall-window.ug");
    let o = run("ugvlmerge", &["-v", &p], None);
    assert!(o.status.success());
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(err.starts_with("epsilon 6.7082"), "{err}");
    assert!(
        err.contains("merge vertices: 10 merged into an earlier one, 0 faces dropped"),
        "{err}"
    );
    assert!(
        err.contains("split edges: 6 T-vertices inserted into 5 edges"),
        "{err}"
    );
    assert!(
        err.contains("merge faces: 6 faces joined into 1 (1 holes)"),
        "{err}"
    );
    assert!(err.contains("2 faces, 10 vertices out"), "{err}");
}

#[test]
fn bad_input_is_reported_with_position_and_nothing_on_stdout() {
    let out = run("ugvlmerge", &[], Some(b"v a 0 0 0;\nf (a b c);\n"));
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err, "<stdin>:2:6: error: face names undefined vertex 'b'\n");
}

#[test]
fn other_statements_pass_through_in_place() {
    let src = "{ head }\nc_rgb w 1 1 1;\nv a 0 0 0;\nv b 1 0 0;\nv c 1 1 0;\nv d 0 1 0;\n\
               v e 2 0 0;\nv f 2 1 0;\nl sun 1 1 1;\nf l (a b c d) w;\nw edge (a b);\n\
               cam eye 0 0 5;\nf r (b e f c) w;\n";
    let out = run_ok("ugvlmerge", &[], Some(src.as_bytes()));
    assert_eq!(
        out,
        "{ head }\nc_rgb w 1 1 1;\nv a 0 0 0;\nv b 1 0 0;\nv d 0 1 0;\nv e 2 0 0;\nv f 2 1 0;\n\
         l sun 1 1 1;\nf l (a b e f d) w;\nw edge (a b);\ncam eye 0 0 5;\n"
    );
}

#[test]
fn instances_are_flattened_then_grouped() {
    // Three instances of one tile side by side: their copies of the shared
    // corners merge, and the tiles join into one face.
    let src = "c_rgb w 1 1 1;\ndef tile;\nv a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\n\
               f t (a b c d) w;\nend;\ni t1 (tile);\ni t2 (tile -tx 1);\ni t3 (tile -tx 2);\n";
    let out = run_ok("ugvlmerge", &["-q"], Some(src.as_bytes()));
    assert_eq!(faces(&out), ["f t1.t (t1.a t3.b t3.c t1.d) w;"], "{out}");
    assert_eq!(out.lines().filter(|l| l.starts_with("v ")).count(), 4);
    assert!(!out.contains("def ") && !out.contains("i t"), "{out}");
}

/// Contours that cross themselves into lobes of equal and opposite area
/// (fixtures/vlmerge/bow-tie.ug: a quad with two corners swapped, a figure
/// eight): no Newell area, yet they span a plane. They were dropped as
/// collinear; they are repaired into their even-odd region (the bow-tie's
/// two triangles, the figure eight's rectangle), and ugcheck names them
/// for what they are. The truly collinear face is still dropped.
#[test]
fn bow_ties_are_repaired_not_dropped() {
    let p = path("vlmerge/bow-tie.ug");
    let text = std::fs::read_to_string(&p).unwrap();
    let before = check(&text, None);
    let reasons: Vec<String> = before["degenerate"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            format!(
                "{} {}",
                d["face"].as_str().unwrap(),
                d["reason"].as_str().unwrap()
            )
        })
        .collect();
    assert_eq!(
        reasons,
        [
            "bowtie contour 1 crosses itself (its lobes' areas cancel)",
            "eight contour 1 crosses itself (its lobes' areas cancel)",
            "line zero area (its vertices are collinear)",
        ]
    );
    let o = run("ugvlmerge", &[&p], None);
    assert!(o.status.success());
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(
        err.contains("face line: zero area (its vertices are collinear); dropped"),
        "{err}"
    );
    assert!(err.contains("face bowtie: its contours cross"), "{err}");
    assert!(err.contains("face eight: its contours cross"), "{err}");
    let out = String::from_utf8(o.stdout).unwrap();
    let r = check(&out, None);
    for k in [
        "degenerate",
        "intersecting",
        "overlapping",
        "nonplanar",
        "tvertices",
    ] {
        assert_eq!(len(&r, k), 0, "{k}: {r}");
    }
    // The even-odd regions: the bow-tie's lobes (2 × 1/4), the figure
    // eight's rectangle (2 × 0.5); the floor as it was.
    let got = areas(&r);
    let want = [("floor", 16.0), ("tie", 0.5), ("eight", 1.0)];
    for (m, a) in want {
        let g = got.iter().find(|x| x.0 == m).map(|x| x.1);
        assert!(
            g.is_some_and(|g| (g - a).abs() < 1e-9),
            "{m}: {g:?} against {a}"
        );
    }
    let tie: Vec<&str> = faces(&out)
        .into_iter()
        .filter(|f| f.ends_with(" tie;"))
        .collect();
    assert_eq!(tie.len(), 2, "{tie:?}");
    // ugcut meshes them too, and ugrad takes them as they come.
    let cut = run_ok("ugcut", &["-l", "0.5", &p], None);
    let r = check(&cut, None);
    assert_eq!(len(&r, "degenerate"), 0, "{r}");
}

/// Every tool of the chain, run on its own on raw faces, makes them sound
/// before its work (`clean::group::settle`) instead of handing them on: a
/// repeated vertex, a spike, a bow-tie, a figure eight and a collinear face
/// (ugcheck calls five faces degenerate before). After each tool alone:
/// none degenerate, nothing intersecting or overlapping, and the even-odd
/// area of each material (the collinear face has none).
#[test]
fn every_tool_alone_makes_bad_faces_sound() {
    let p = path("raw/bad-faces.ug");
    let text = std::fs::read_to_string(&p).unwrap();
    assert_eq!(len(&check(&text, None), "degenerate"), 5);
    for tool in ["ugplanar", "ugflip", "ugisect", "ugcopl", "ugclean"] {
        let o = run(tool, &[&p], None);
        assert!(o.status.success(), "{tool}");
        let err = String::from_utf8(o.stderr).unwrap();
        assert!(
            err.contains("face line: ") && err.contains("; dropped"),
            "{tool}: {err}"
        );
        assert!(
            err.contains("face bowtie: its contours cross"),
            "{tool}: {err}"
        );
        let out = String::from_utf8(o.stdout).unwrap();
        let r = check(&out, None);
        for k in ["degenerate", "intersecting", "overlapping", "inconsistent"] {
            assert_eq!(len(&r, k), 0, "{tool} {k}: {r}");
        }
        let got = areas(&r);
        for (m, a) in [
            ("floor", 16.0),
            ("rep", 1.0),
            ("spike", 1.0),
            ("tie", 0.5),
            ("eight", 1.0),
        ] {
            let g = got.iter().find(|x| x.0 == m).map(|x| x.1);
            assert!(
                g.is_some_and(|g| (g - a).abs() < 1e-9),
                "{tool} {m}: {g:?} against {a}"
            );
        }
    }
}

/// A twisted quadrilateral exported twice as triangles along different
/// diagonals (a flipped duplicate fanned from its first vertex, as an OBJ
/// export does) is four faces of a thin tetrahedron, each pair folded onto
/// the other at about 2°. The grouper gives the later copy the earlier
/// copy's diagonal, so the chain resolves the duplicate as it does a
/// duplicated quad. Before, ugisect cut slivers along the folds for four
/// rounds and the chain ended with 4 intersecting pairs (11 defects after
/// ugcut).
#[test]
fn a_twisted_quad_triangulated_twice_gets_one_diagonal() {
    let p = path("vlmerge/twisted-side-triangulated-twice.ug");
    let src = std::fs::read_to_string(&p).unwrap();
    let before = check(&src, None);
    let eps = before["epsilon"].as_f64().unwrap();
    let out = run("ugvlmerge", &["-v", &p], None);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("2 triangles of twisted quads triangulated twice"),
        "{err}"
    );
    let grouped = String::from_utf8(out.stdout).unwrap();
    let m = parse(&grouped);
    let column = m.materials.iter().position(|x| x.name == "column").unwrap();
    let mut sets: Vec<Vec<&str>> = m
        .faces
        .iter()
        .filter(|f| f.material.map(|k| k.0 as usize) == Some(column))
        .map(|f| {
            let mut s: Vec<&str> = f.contours[0]
                .iter()
                .map(|&v| m.vertices[v.idx()].name.as_str())
                .collect();
            s.sort_unstable();
            s
        })
        .collect();
    assert_eq!(sets.len(), 4);
    sets.sort();
    sets.dedup();
    assert_eq!(sets.len(), 2, "{sets:?}");
    // The copy's area changes by the difference of the two triangulations.
    let area = |r: &Value| areas(r).into_iter().find(|(k, _)| k == "column").unwrap().1;
    let (a, b) = (area(&before), area(&check(&grouped, Some(eps))));
    assert!((a - b).abs() <= 1e-5 * a && a != b, "{a} → {b}");
    // The chain leaves no defect, and neither does ugcut after it.
    let chain = String::from_utf8(ugkit::chain(src.as_bytes())).unwrap();
    let r = check(&chain, Some(eps));
    for key in KEPT_OR_FEWER
        .iter()
        .chain(&["tvertices", "degenerate", "inconsistent"])
    {
        assert_eq!(len(&r, key), 0, "{key}: {}", r[key]);
    }
    let cut = run_ok("ugcut", &["-q", "-l", "0.5"], Some(chain.as_bytes()));
    let r = check(&cut, Some(eps));
    for key in KEPT_OR_FEWER
        .iter()
        .chain(&["tvertices", "degenerate", "inconsistent", "nonpatch"])
    {
        assert_eq!(len(&r, key), 0, "{key}: {}", r[key]);
    }
}

/// Two cut points 1.003 epsilon apart in space and 0.9997 epsilon apart in
/// the plane of the wall they lie on (one is 2.7e-6 off it), each on the
/// other piece's edge. The weld keeps them apart and the T-vertex step puts
/// each into the other's edge; the repair used to measure the edge between
/// them in the plane, snap them together in each face, and so make both
/// T-vertices again. "Too near" is measured in space everywhere now (the
/// weld, the T-vertex step, the repair and ugcheck).
#[test]
fn points_kept_apart_by_the_weld_are_not_snapped_together_by_the_repair() {
    let p = path("vlmerge/cut-points-an-epsilon-apart.ug");
    let eps = "3.727313e-5";
    let out = run(
        "ugvlmerge",
        &["-v", "-e", eps, "--no-merge-faces", &p],
        None,
    );
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("repaired"), "{err}");
    assert!(err.contains("2 T-vertices inserted"), "{err}");
    let text = String::from_utf8(out.stdout).unwrap();
    let r = check(&text, Some(eps.parse().unwrap()));
    for key in ["tvertices", "degenerate", "overlapping", "intersecting"] {
        assert_eq!(len(&r, key), 0, "{key}: {}", r[key]);
    }
    let m = parse(&text);
    for f in &m.faces {
        let names: Vec<&str> = f.contours[0]
            .iter()
            .map(|&v| m.vertices[v.idx()].name.as_str())
            .collect();
        assert!(names.contains(&"p") && names.contains(&"q"), "{names:?}");
    }
}

/// A face exported as two triangles along one diagonal, twice more as
/// copies (one on fresh vertex records, one flipped): the diagonal has six
/// uses and is no seam, but each copy is joined across it to its own other
/// half, so the grouper writes three quads (the duplicates are ugclean's).
/// Before, all six triangles stayed (a box's sides in a triangle export).
#[test]
fn each_copy_of_a_split_face_is_joined_to_its_own_half() {
    let p = path("vlmerge/duplicates-split-along-one-diagonal.ug");
    let out = run_ok("ugvlmerge", &["-q", &p], None);
    let m = parse(&out);
    assert_eq!(m.faces.len(), 3, "{out}");
    for f in &m.faces {
        assert_eq!(f.contours.len(), 1);
        assert_eq!(f.contours[0].len(), 4, "{out}");
    }
    let names: Vec<&str> = m.faces.iter().filter_map(|f| f.name.as_deref()).collect();
    assert_eq!(names, ["side.t1", "side.dup.t1", "side.flip.t1"]);
    // Two copies face one way, the flipped one the other.
    let dirs: Vec<f64> = m
        .faces
        .iter()
        .map(|f| newell_along(&m, &f.contours[0], [0.0, 1.0, 0.0]))
        .collect();
    assert!(
        dirs[0] * dirs[1] > 0.0 && dirs[0] * dirs[2] < 0.0,
        "{dirs:?}"
    );
    let before = check(&std::fs::read_to_string(&p).unwrap(), None);
    let after = check(&out, before["epsilon"].as_f64());
    let (a, b) = (areas(&before), areas(&after));
    assert!((a[0].1 - b[0].1).abs() <= 1e-12, "{a:?} {b:?}");
}
