//! Issue #13 end to end through the binaries, on dirty CAD-like buildings
//! (`ugbuilding --cad`, several seeds, one and two storeys): the user's
//! pipeline `ugvlmerge | ugisect | ugcut -l 2 | ugrad`, the full chain
//! passing `ugcheck --deny defects`, `ugvlmerge | ugrad` (ugrad meshing
//! what is not a patch), and ugflip giving the same orientation before and
//! after ugvlmerge. The many-seed property runs in process in
//! `dirty_buildings_prop.rs`.

use std::collections::BTreeMap;

use ugkit::{chain, pipe, run, run_ok};

fn building(seed: u64, storeys: usize) -> Vec<u8> {
    run_ok(
        "ugbuilding",
        &[
            "--cad",
            "--rooms",
            "1",
            "--storeys",
            &storeys.to_string(),
            "--seed",
            &seed.to_string(),
        ],
        None,
    )
    .into_bytes()
}

fn check(data: &[u8]) -> serde_json::Value {
    serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(data))).unwrap()
}

fn count(r: &serde_json::Value, key: &str) -> usize {
    r[key].as_array().map_or(0, Vec::len)
}

/// Every vertex of a lit model has a colour, and some are lit.
fn assert_lit(data: &[u8], what: &str) {
    let m = ug::parse(data, what).unwrap().model;
    assert!(!m.faces.is_empty(), "{what}: no faces");
    assert!(
        m.vertices.iter().all(|v| v.color.is_some()),
        "{what}: a vertex without a colour"
    );
    let lit = m
        .vertices
        .iter()
        .filter(|v| v.color.is_some_and(|c| m.material(c).diffuse()[0] > 0.0))
        .count();
    assert!(lit > 0, "{what}: nothing lit");
}

const SEEDS: [(u64, usize); 3] = [(1, 1), (2, 2), (7, 1)];

#[test]
fn the_users_pipeline_lights_dirty_buildings() {
    for (seed, storeys) in SEEDS {
        let input = building(seed, storeys);
        let patches = pipe(
            &input,
            &[
                ("ugvlmerge", &[]),
                ("ugisect", &[]),
                ("ugcut", &["-l", "2"]),
            ],
        );
        let r = check(&patches);
        assert_eq!(count(&r, "nonpatch"), 0, "seed {seed}: {}", r["nonpatch"]);
        let lit = pipe(&patches, &[("ugrad", &["--max-shots", "3", "-q"])]);
        assert_lit(&lit, &format!("seed {seed}"));
    }
}

#[test]
fn the_full_chain_passes_ugcheck_deny_defects() {
    for (seed, storeys) in SEEDS {
        let input = building(seed, storeys);
        let clean = chain(&input);
        let out = run("ugcheck", &["--deny", "defects"], Some(&clean));
        assert!(
            out.status.success(),
            "seed {seed}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
        // Faces multiply by about 3 (issue #13 aims at 2; pieces hidden
        // inside walls and slabs stay today): a bound against a return of
        // the whole-line cuts (×8).
        let faces = |d: &[u8]| ug::parse(d, "m").unwrap().model.faces.len();
        assert!(
            faces(&clean) <= 4 * faces(&input),
            "seed {seed}: {} → {} faces",
            faces(&input),
            faces(&clean)
        );
        let patches = pipe(&clean, &[("ugcut", &[])]);
        let r = check(&patches);
        for key in [
            "nonpatch",
            "tvertices",
            "degenerate",
            "overlapping",
            "intersecting",
        ] {
            assert_eq!(count(&r, key), 0, "seed {seed}: {key}: {}", r[key]);
        }
        let lit = pipe(&patches, &[("ugrad", &["--max-shots", "3", "-q"])]);
        assert_lit(&lit, &format!("seed {seed} (chain)"));
    }
}

#[test]
fn ugrad_meshes_what_the_grouper_leaves() {
    let input = building(3, 1);
    let grouped = pipe(&input, &[("ugvlmerge", &[])]);
    let out = run("ugrad", &["--max-shots", "3"], Some(&grouped));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        err.lines().filter(|l| l.contains("not patches")).count(),
        1,
        "{err}"
    );
    assert_lit(&out.stdout, "ugvlmerge | ugrad");
}

/// Σ area × normal per material: a face oriented the other way changes it
/// by twice its area.
fn oriented_area(data: &[u8]) -> BTreeMap<String, [f64; 3]> {
    let m = ug::parse(data, "m").unwrap().model;
    let mut out: BTreeMap<String, [f64; 3]> = BTreeMap::new();
    for f in m.top_faces() {
        let face = &m.faces[f.idx()];
        let name = face
            .material
            .map_or(String::new(), |k| m.materials[k.idx()].name.clone());
        let mut n = glam::DVec3::ZERO;
        for c in &face.contours {
            let pts: Vec<glam::DVec3> = c.iter().map(|&v| m.pos(v)).collect();
            n += geom::newell_normal(&pts);
        }
        let e = out.entry(name).or_default();
        for k in 0..3 {
            e[k] += n[k] / 2.0;
        }
    }
    out
}

#[test]
fn ugflip_orients_the_same_before_and_after_the_grouper() {
    for (seed, storeys) in SEEDS {
        let input = building(seed, storeys);
        let planar = pipe(&input, &[("ugplanar", &[])]);
        let before = pipe(&planar, &[("ugflip", &[]), ("ugvlmerge", &[])]);
        let after = pipe(&planar, &[("ugvlmerge", &[]), ("ugflip", &[])]);
        // (Inconsistent edges are not asked about here: duplicate faces
        // facing the same way share their edges until ugclean.)
        let (a, b) = (oriented_area(&before), oriented_area(&after));
        assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
        for (k, x) in &a {
            let y = &b[k];
            for i in 0..3 {
                assert!(
                    (x[i] - y[i]).abs() <= 1e-6 * (1.0 + x[i].abs()),
                    "seed {seed}, {k}: {x:?} vs {y:?}"
                );
            }
        }
    }
}

/// The cleaning chain on `input` without `-e`: its first tool must take
/// `epsilon` from the input's precision and say so; then the stages
/// `more` (ugcut, say). The output.
fn chain_without_e(input: &[u8], epsilon: &str, more: &[(&str, &[&str])]) -> Vec<u8> {
    let first = run("ugplanar", &[], Some(input));
    assert!(first.status.success());
    let note = String::from_utf8_lossy(&first.stderr);
    assert!(note.contains(&format!("epsilon {epsilon}")), "{note}");
    let mut stages: Vec<(&str, &[&str])> = ugkit::CHAIN_TOOLS[1..]
        .iter()
        .map(|&t| (t, &["-q"][..]))
        .collect();
    stages.extend_from_slice(more);
    pipe(&first.stdout, &stages)
}

/// The cleaning chain on `input` at `-e E` (ugclean also given `clean`),
/// then the stages `more`; the output.
fn chain_at(input: &[u8], e: &str, clean: &[&str], more: &[(&str, &[&str])]) -> Vec<u8> {
    let a = ["-q", "-e", e];
    let c: Vec<&str> = a.iter().chain(clean).copied().collect();
    let mut stages: Vec<(&str, &[&str])> = ugkit::CHAIN_TOOLS
        .iter()
        .map(|&t| (t, if t == "ugclean" { &c[..] } else { &a[..] }))
        .collect();
    stages.extend_from_slice(more);
    pipe(input, &stages)
}

/// [`chain_at`], and ugcheck's report on its output at E.
fn checked_chain_at(
    input: &[u8],
    e: &str,
    clean: &[&str],
    more: &[(&str, &[&str])],
) -> serde_json::Value {
    let out = chain_at(input, e, clean, more);
    serde_json::from_str(&run_ok("ugcheck", &["--json", "-e", e], Some(&out))).unwrap()
}

/// The chain at E and then `ugcut -l 0.7`: only patches, and no defect.
fn assert_patches_clean(input: &[u8], e: &str) {
    let r = checked_chain_at(input, e, &[], &[("ugcut", &["-q", "-e", e, "-l", "0.7"])]);
    ugkit::assert_no_defects(&r, "after ugcut");
    assert_eq!(count(&r, "nonpatch"), 0, "{}", r["nonpatch"]);
}

/// A column's corner sunk 11 epsilon into a floor slab, exported to
/// 0.1 mm (fixtures/clean/column-corner-sunk-into-a-floor-at-0.1mm.ug,
/// reduced from property seed 180121 rounded to 4 decimals). The floor
/// cuts the corner edge and the two folds either side of it (the column's
/// top vertex is displaced, so its sides are folded quads) at points 1.2
/// epsilon apart; one fold's point, put into the other side's cut edge, is
/// a tent's tip there. ugclean joined it to the nearer neighbour, the
/// other fold's point, 0.8 epsilon off its own side's plane: that side
/// then reached round the corner, a wedge 1.8 epsilon wide up the whole
/// column that both sides covered, and ugcut's patches of the two
/// overlapped there. Now the tip joins the corner's point, which lies on
/// both sides (the neighbour that leaves the faces through it flatter).
#[test]
fn a_tent_at_a_corner_joins_the_corner() {
    let input = std::fs::read(ugkit::fixture(
        "clean/column-corner-sunk-into-a-floor-at-0.1mm.ug",
    ))
    .unwrap();
    let r = checked_chain_at(&input, "2.1e-4", &[], &[]);
    ugkit::assert_no_defects(&r, "after the chain");
    assert_patches_clean(&input, "2.1e-4");
    // The two sides above the floor meet along the corner only: no vertex
    // of one lies off its own plane on the other's side.
    let cleaned = ug::parse(&chain_at(&input, "2.1e-4", &[], &[]), "<chain>")
        .unwrap()
        .model;
    for f in cleaned
        .faces
        .iter()
        .filter(|f| f.name.as_deref().is_some_and(|n| n.starts_with("s0r1_1c.")))
    {
        let pts: Vec<glam::DVec3> = f.contours[0]
            .iter()
            .map(|v| cleaned.vertices[v.idx()].pos)
            .collect();
        let (dev, _) = geom::Plane::face_deviation(&[pts]).unwrap();
        assert!(dev < 0.1 * 2.1e-4, "{:?} bent by {dev}", f.name);
    }
}

/// Walls meeting a facade and a ceiling at a corner, rounded to 1 mm
/// (fixtures/clean/kept-wall-end-taking-a-facade-pieces-corner.ug, reduced
/// from property seed 170765). After ugcopl three pieces there are
/// coincident, the facade's with a corner more, 0.5 epsilon off the
/// others' edge. The kept wall piece took that contour and stopped walking
/// the edge back that a ceiling piece and another wall piece walk one way:
/// with `--keep-enclosed` (where no later step removes those), an
/// inconsistently oriented edge. Now the kept face takes the contour only
/// where that spoils no edge.
#[test]
fn a_kept_face_takes_its_twins_contour_only_where_no_edge_is_spoiled() {
    let input = std::fs::read(ugkit::fixture(
        "clean/kept-wall-end-taking-a-facade-pieces-corner.ug",
    ))
    .unwrap();
    for clean in [&["--keep-enclosed"][..], &[]] {
        let r = checked_chain_at(&input, "2.1e-3", clean, &[]);
        ugkit::assert_no_defects(&r, &format!("{clean:?}"));
    }
}

/// A slab and three walls exported as Revit writes metres: georeferenced,
/// turned about all three axes, rounded to 4 decimals
/// (fixtures/clean/rounded-turned-slab-and-walls.ug). The rounding bends
/// the faces by up to 1e-4, five times the relative epsilon; at that
/// epsilon the chain cut the 4 faces into 1,118 pieces and left 47
/// defects. The first tool takes 2.1 times the coordinates' precision as
/// epsilon (with a note), writes it on as a `{ugkit epsilon 2.1e-4}` comment, and
/// every later tool, ugcheck included, uses it: a few clean pieces.
#[test]
fn an_export_rounded_to_its_precision_is_cleaned_at_that_precision() {
    let input = std::fs::read(ugkit::fixture("clean/rounded-turned-slab-and-walls.ug")).unwrap();
    let out = chain_without_e(&input, "2.1e-4", &[]);
    let text = String::from_utf8_lossy(&out);
    assert!(text.starts_with("{ugkit epsilon 2.1e-4}"), "{text}");
    let r = check(&out);
    assert_eq!(r["epsilon"].as_f64(), Some(2.1e-4), "{}", r["epsilon"]);
    for key in ugkit::DEFECT_KEYS {
        assert_eq!(count(&r, key), 0, "{key}: {}", r[key]);
    }
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    assert!(faces <= 16, "4 faces became {faces}");
    // Given -e, the tools use it and carry nothing.
    let given = run_ok("ugplanar", &["-e", "2e-5"], Some(&input));
    assert!(!given.contains("ugkit epsilon"));
}

/// A vault's edge along a wall turned in the plan, rounded to 4 decimals
/// (fixtures/clean/vault-edge-on-a-turned-wall-rounded.ug, from property
/// seed 150007 at `UG_ROUND=4`): both faces flat, the wall oblique. At
/// the relative epsilon (5.7e-6, which the tools took before, since no
/// face is bent) the chain and ugcut left a wall piece and a vault piece
/// crossing; the tools now take 2.1e-4 from the precision, and the whole
/// chain and ugcut leave no defect.
#[test]
fn flat_oblique_faces_rounded_are_cleaned_at_their_precision() {
    let input = std::fs::read(ugkit::fixture(
        "clean/vault-edge-on-a-turned-wall-rounded.ug",
    ))
    .unwrap();
    let out = chain_without_e(&input, "2.1e-4", &[("ugcut", &["-q", "-l", "0.7"])]);
    let r = check(&out);
    assert_eq!(r["epsilon"].as_f64(), Some(2.1e-4), "{}", r["epsilon"]);
    for key in ugkit::DEFECT_KEYS {
        assert_eq!(count(&r, key), 0, "{key}: {}", r[key]);
    }
    assert_eq!(count(&r, "nonpatch"), 0, "{}", r["nonpatch"]);
    // At the relative epsilon the same chain leaves the crossing: the
    // fixture still shows what the precision fixes.
    let r = checked_chain_at(
        &input,
        "5.721e-6",
        &[],
        &[("ugcut", &["-q", "-e", "5.721e-6", "-l", "0.7"])],
    );
    assert!(count(&r, "intersecting") > 0, "{}", r["intersecting"]);
}

/// A pier's bottom and a wall's 0.2 mm apart in metres to 4 decimals
/// (fixtures/clean/pier-and-wall-bottoms-twice-the-precision-apart.ug,
/// from property seed 125074 at `UG_ROUND=4`): exactly twice the
/// precision, the epsilon the tools took until the factor became 2.1. At
/// 2.1e-4 the whole chain is clean, with and without the enclosed faces;
/// at 2e-4, where the distance is epsilon but for the last bit, it was
/// not (a degenerate face and an inconsistent edge; checked here so that
/// the fixture keeps showing the tie it was made for).
#[test]
fn faces_twice_the_precision_apart_are_no_tie() {
    let input = std::fs::read(ugkit::fixture(
        "clean/pier-and-wall-bottoms-twice-the-precision-apart.ug",
    ))
    .unwrap();
    let chain_at = |e: &str, keep: bool| {
        let clean: &[&str] = if keep { &["--keep-enclosed"] } else { &[] };
        let r = checked_chain_at(&input, e, clean, &[]);
        ugkit::DEFECT_KEYS
            .iter()
            .map(|k| count(&r, k))
            .sum::<usize>()
    };
    let e = format!("{:e}", cli::PRECISION_FACTOR * 1e-4);
    assert_eq!(chain_at(&e, false), 0);
    assert_eq!(chain_at(&e, true), 0);
    assert!(chain_at("2e-4", false) > 0);
}

/// A pier's end edge 0.9986 epsilon in front of an oblique wing facade at
/// 48°, reaching past the facade's foot and top
/// (fixtures/clean/pier-edge-within-epsilon-of-an-oblique-facade.ug, from
/// property seed 170098 at `UG_ROUND=3`, epsilon 2.1 mm). The planes'
/// line runs 1.34 epsilon outside the pier, and the pair once read as
/// disjoint: nothing was cut, and `ugcut`'s vertices on the pier's edge,
/// within epsilon of the facade's interior, made 7 intersecting pairs.
/// Now the two meet along the edge: the facade is cut there, in two
/// pieces that share the edge's stretch between its foot and top with the
/// pier, and the patches are clean.
#[test]
fn an_edge_within_epsilon_of_an_oblique_facade_cuts_it() {
    let input = std::fs::read(ugkit::fixture(
        "clean/pier-edge-within-epsilon-of-an-oblique-facade.ug",
    ))
    .unwrap();
    let cleaned = ug::parse(&chain_at(&input, "2.1e-3", &[], &[]), "<chain>")
        .unwrap()
        .model;
    let on_edge = |v: &ug::VertexId| {
        let p = cleaned.vertices[v.idx()].pos;
        (p.x - 3.471).abs() < 1e-9 && (p.y - 0.125).abs() < 1e-9
    };
    let facade: Vec<&ug::Face> = cleaned
        .faces
        .iter()
        .filter(|f| f.name.as_deref().is_some_and(|n| n.starts_with("wing0.2")))
        .collect();
    assert_eq!(facade.len(), 2);
    for f in &facade {
        assert_eq!(f.contours[0].iter().filter(|v| on_edge(v)).count(), 2);
    }
    assert_patches_clean(&input, "2.1e-3");
}
