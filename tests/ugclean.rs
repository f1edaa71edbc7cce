//! ugclean end to end: one face of every coincident pair goes, the right one,
//! and exactly the hidden area is removed.

use ugkit::{assert_one_degenerate, fixture, run, run_ok};

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
    // The rug takes the removed piece's vertex records (coincident with
    // its own): its edge b–c is the floor's edge, and its own records go.
    let m = ug::parse(out.as_bytes(), "o").unwrap().model;
    let names: Vec<&str> = m
        .top_vertices()
        .map(|v| m.vertex(v).name.as_str())
        .collect();
    assert_eq!(names, ["a", "b", "c", "d", "e", "f"]);
    assert!(out.contains("f rug (a b c d) rug;"), "{out}");
}

/// A wall's end face 1.1 epsilon proud of the facade it stands against
/// (the weld keeps the corners apart; ugcopl takes the faces as coplanar):
/// ugclean removes the facade's piece and the wall's end takes its vertex
/// records, so the facade around it still meets a face along every edge.
/// (Found with a pitched-roof building, property seed 326.)
#[test]
fn the_kept_face_takes_the_removed_twins_vertices() {
    let src = std::fs::read_to_string(fixture("clean/wall-end-proud-of-facade.ug")).unwrap();
    let out = run_ok("ugclean", &["-e", "0.001"], Some(src.as_bytes()));
    assert_eq!(faces(&out), ["facade.1", "end"]);
    assert!(out.contains("f end (d c e f) wall;"), "{out}");
    // The facade's outline only: 6 edges (8 with a crack at y = 1).
    let r: serde_json::Value = serde_json::from_str(&run_ok(
        "ugcheck",
        &["--json", "-e", "0.001"],
        Some(out.as_bytes()),
    ))
    .unwrap();
    assert_eq!(r["boundary_edges"].as_array().unwrap().len(), 6, "{out}");
    assert!(!out.contains("w1"), "the wall end's own records go");
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

/// The chain up to ugcopl on a small dirty CAD building (two storeys).
fn building_to_copl(seed: &str) -> String {
    let mut m = run_ok(
        "ugbuilding",
        &["--cad", "--faces", "900", "--storeys", "2", "--seed", seed],
        None,
    );
    for tool in ["ugplanar", "ugvlmerge", "ugflip", "ugisect", "ugcopl"] {
        m = run_ok(tool, &[], Some(m.as_bytes()));
    }
    m
}

/// A point inside a face (on its largest triangle, off its edges) and its
/// unit normal.
fn inner_point(m: &ug::Model, f: ug::FaceId) -> (glam::DVec3, glam::DVec3) {
    let pts: Vec<Vec<glam::DVec3>> = m.faces[f.idx()]
        .contours
        .iter()
        .map(|c| c.iter().map(|&v| m.pos(v)).collect())
        .collect();
    let n = geom::polygon::face_normal(&pts).expect("a face with a normal");
    let flat: Vec<glam::DVec3> = pts.iter().flatten().copied().collect();
    let t = geom::bvh::face_triangles(&pts)
        .into_iter()
        .map(|t| [flat[t[0]], flat[t[1]], flat[t[2]]])
        .max_by(|a, b| {
            let area = |p: &[glam::DVec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]).length();
            area(a).total_cmp(&area(b))
        })
        .unwrap();
    (t[0] * 0.2 + t[1] * 0.3 + t[2] * 0.5, n)
}

/// The light test of the enclosed faces, by ugprobe's path tracer (nothing
/// of ugclean's rays): in `model`, every face but the emitters becomes grey
/// (ρ = 0.5, so that light bounces far), inside a sky box that emits too.
/// Returns, for each face in `probe`, whether light reaches the point
/// inside it (B > 0 at 64 paths).
fn reached(model: &str, probe: &[ug::FaceId]) -> Vec<bool> {
    use ug::{Defmat, Face, Item, Material, MaterialDef, Vertex};
    let mut m = ug::parse(model.as_bytes(), "chain").unwrap().model;
    let emit = m.add_material(Material {
        name: "sky_emitter".into(),
        def: MaterialDef::Defmat(Defmat {
            diffuse: Some([0.0; 3]),
            emission: Some([1.0; 3]),
            other: vec![],
        }),
    });
    let grey = m.add_material(Material {
        name: "all_grey".into(),
        def: MaterialDef::Rgb([0.5; 3]),
    });
    // The new materials first, so that every face names a defined one.
    let mats: Vec<Item> = m.items.drain(m.items.len() - 2..).collect();
    m.items.splice(0..0, mats);
    let faces: Vec<ug::FaceId> = m.top_faces().collect();
    for &f in &faces {
        let face = &mut m.faces[f.idx()];
        if !face
            .material
            .is_some_and(|x| m.materials[x.idx()].is_emitter())
        {
            face.material = Some(grey);
        }
    }
    let (lo, hi) = m.bounds().unwrap();
    let (lo, hi) = (lo - glam::DVec3::ONE, hi + glam::DVec3::ONE);
    let corner: Vec<ug::VertexId> = (0..8)
        .map(|i| {
            let p = glam::DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            m.add_vertex(Vertex {
                name: format!("sky{i}"),
                pos: p,
                color: None,
            })
        })
        .collect();
    // Facing inwards (the reverse of a box's outward faces: these lists
    // once faced outwards, so the sky lit nothing).
    for (k, q) in [
        [1, 3, 2, 0],
        [6, 7, 5, 4],
        [4, 5, 1, 0],
        [3, 7, 6, 2],
        [2, 6, 4, 0],
        [5, 7, 3, 1],
    ]
    .iter()
    .enumerate()
    {
        m.add_face(Face {
            name: Some(format!("sky{k}")),
            contours: vec![q.iter().map(|&i| corner[i]).collect()],
            material: Some(emit),
        });
    }
    let dir = tempfile::tempdir().unwrap();
    let model_path = dir.path().join("vis.ug");
    std::fs::write(&model_path, ug::write_string(&m)).unwrap();
    let points: String = probe
        .iter()
        .map(|&f| {
            let (p, n) = inner_point(&m, f);
            format!("{} {} {} {} {} {}\n", p.x, p.y, p.z, n.x, n.y, n.z)
        })
        .collect();
    let points_path = dir.path().join("points");
    std::fs::write(&points_path, points).unwrap();
    let out = run_ok(
        "ugprobe",
        &[
            model_path.to_str().unwrap(),
            "--points",
            points_path.to_str().unwrap(),
            "--samples",
            "64",
            "-q",
        ],
        None,
    );
    let b: Vec<bool> = out
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let w: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            w[6] + w[7] + w[8] > 0.0
        })
        .collect();
    assert_eq!(b.len(), probe.len());
    b
}

#[test]
fn enclosed_faces_go_and_no_light_reached_them() {
    // Twelve seeds passed when this was written; four keep CI quick.
    for seed in ["1", "4", "7", "12"] {
        let copl = building_to_copl(seed);
        let all = run_ok("ugclean", &["--keep-enclosed"], Some(copl.as_bytes()));
        let out = run_ok("ugclean", &[], Some(copl.as_bytes()));
        let (before, after) = (faces(&all), faces(&out));
        let kept: std::collections::HashSet<String> = after.iter().cloned().collect();
        let removed = before.len() - after.len();
        // The step does something: on these buildings about half the
        // faces the chain leaves are inside walls, slabs and furniture.
        assert!(
            removed * 3 > before.len(),
            "seed {seed}: {removed} of {} removed",
            before.len()
        );
        // And leaves the model clean.
        let r = ugkit::run("ugcheck", &["--deny", "defects"], Some(out.as_bytes()));
        assert!(
            r.status.success(),
            "seed {seed}: {}",
            String::from_utf8_lossy(&r.stdout)
        );
        // No path of light from a kept face (or the sky) reaches a removed
        // one wider than 20 epsilon (the jitter leaves slivers between
        // features within epsilon, where inside and outside are below the
        // model's resolution: a wall bottom 1e-6 above a slab's side).
        let eps = check(&all)["epsilon"].as_f64().unwrap();
        let m = ug::parse(all.as_bytes(), "all").unwrap().model;
        let width = |f: ug::FaceId| {
            let pts: Vec<Vec<glam::DVec3>> = m.faces[f.idx()]
                .contours
                .iter()
                .map(|c| c.iter().map(|&v| m.pos(v)).collect())
                .collect();
            let perimeter: f64 = pts
                .iter()
                .map(|c| {
                    (0..c.len())
                        .map(|i| c[i].distance(c[(i + 1) % c.len()]))
                        .sum::<f64>()
                })
                .sum();
            2.0 * geom::face_area(&pts).abs() / perimeter
        };
        let gone: Vec<ug::FaceId> = m
            .top_faces()
            .filter(|&f| !kept.contains(m.faces[f.idx()].name.as_deref().unwrap_or("")))
            .filter(|&f| width(f) > 20.0 * eps)
            .collect();
        assert!(
            gone.len() * 2 > removed,
            "seed {seed}: most removed faces are tested"
        );
        let lit = reached(&all, &gone);
        let bad: Vec<&str> = gone
            .iter()
            .zip(&lit)
            .filter(|p| *p.1)
            .map(|(&f, _)| m.faces[f.idx()].name.as_deref().unwrap_or(""))
            .collect();
        assert!(
            bad.is_empty(),
            "seed {seed}: light reaches removed faces {bad:?}"
        );
        // The probe does see light where it comes: more than half the kept
        // faces are reached (500 of 811 on seed 1; the rest are in rooms
        // without a lamp or a window, or lit too rarely for 64 paths).
        let some: Vec<ug::FaceId> = m
            .top_faces()
            .filter(|&f| kept.contains(m.faces[f.idx()].name.as_deref().unwrap_or("")))
            .filter(|&f| width(f) > 20.0 * eps)
            .collect();
        let lit = reached(&all, &some);
        let n = lit.iter().filter(|&&x| x).count();
        assert!(
            n * 2 > some.len(),
            "seed {seed}: {n} of {} reached",
            some.len()
        );
    }
}

/// A pier's end face inside the facade slab, two of its vertices just
/// outside the facade's plane (seed 1101 of the dirty-building property,
/// after the coincident step): the enclosed step removes it, and nothing
/// is left inconsistently oriented.
#[test]
fn a_pier_end_poking_through_the_facade_is_enclosed() {
    let src = std::fs::read_to_string(fixture("clean/pier-end-in-facade.ug")).unwrap();
    assert_eq!(check(&src)["inconsistent"].as_array().unwrap().len(), 5);
    assert!(faces(&src).contains(&"s0w2p0.5.i5".to_string()));
    let out = run_ok("ugclean", &[], Some(src.as_bytes()));
    assert!(!faces(&out).contains(&"s0w2p0.5.i5".to_string()));
    let r = check(&out);
    for k in [
        "inconsistent",
        "degenerate",
        "intersecting",
        "overlapping",
        "coincident",
        "tvertices",
        "nonplanar",
    ] {
        assert_eq!(r[k].as_array().unwrap().len(), 0, "{k}: {}", r[k]);
    }
}

/// A piece of a sunk ramp's slope inside the slab, 0.01 to 0.14 mm under
/// the floor (fixtures/clean/ramp-piece-under-the-floor.ug, after the
/// 40,000-face CAD building with stairs): the enclosed step once lifted a
/// sample point of it through the floor into the lit room, and the inside
/// of the slab joined the room; now it goes, and nothing else does. (At
/// the building's relative epsilon, given: the fixture's coordinates are
/// written to 5 decimals with a sloped face, so without `-e` the tools
/// would take 2.1e-5 from that precision, and the piece's shallow end
/// would lie within it of the floor.)
#[test]
fn a_sample_is_not_lifted_through_a_face_it_lies_behind() {
    let src = std::fs::read_to_string(fixture("clean/ramp-piece-under-the-floor.ug")).unwrap();
    let out = run_ok("ugclean", &["-e", "6.5e-6"], Some(src.as_bytes()));
    let (before, after) = (faces(&src), faces(&out));
    assert!(before.contains(&"ramp".to_string()));
    let gone: Vec<&String> = before.iter().filter(|f| !after.contains(f)).collect();
    assert_eq!(gone, [&"ramp".to_string()], "{out}");
    assert_eq!(
        checked_at(&out, "6.5e-6")["inconsistent"]
            .as_array()
            .unwrap()
            .len(),
        0
    );
}

/// A box's side 6 epsilon behind another box's side facing the same way,
/// inside that box (fixtures/clean/box-side-inside-another-box.ug: two
/// boxes sunk into a slab, after the chain up to ugcopl): its sample
/// points' lift of 10 epsilon would pass through the other side's back,
/// and were not used, so its pieces inside the other box cast no ray and
/// stayed. They are lifted half-way now and go, no light reaches them
/// (ugprobe's paths), and every face that light reaches stays.
#[test]
fn a_sample_behind_a_face_near_it_is_lifted_half_way() {
    goes_unlit(
        "clean/box-side-inside-another-box.ug",
        &["b.4.i1", "b.4.i2"],
    );
}

/// A plate inside a slab 1.6 to 5 epsilon under its top, facing up
/// (fixtures/clean/plate-just-under-a-slab-top.ug; property seed 95014 at
/// 1 mm, a ramp's piece sunk under the floor): every sample point lies
/// nearer the top's back than a lift of 2 epsilon, so none was used and
/// the plate stayed. Such a point counts as a ray that met a back now: the
/// plate goes, no light reaches it, and every face that light reaches
/// stays.
#[test]
fn a_face_just_behind_the_back_of_another_is_enclosed() {
    goes_unlit("clean/plate-just-under-a-slab-top.ug", &["plate"]);
}

/// A rug 3.5 epsilon above a slab's top (fixtures/clean/rug-just-above-a-slab-top.ug):
/// too far for ugcopl to cut the top along it, near enough that the top's
/// sample points, all under the rug, are not lifted. The rug covers the
/// top only in part, so the top must stay (a first version of the rule
/// above removed it): only a face that faces cover whole counts its points
/// near a back as rays that met one. Nothing goes.
#[test]
fn a_face_covered_in_part_by_a_near_back_stays() {
    let src = std::fs::read_to_string(fixture("clean/rug-just-above-a-slab-top.ug")).unwrap();
    let out = run_ok("ugclean", &["-e", "5e-4"], Some(src.as_bytes()));
    assert_eq!(faces(&out), faces(&src), "{out}");
}

/// ugclean at `-e 5e-4` on a fixture: the faces `gone` go, light reaches
/// none of the removed faces (ugprobe's paths), each face that it reaches
/// stays, and no edge is left inconsistently oriented.
fn goes_unlit(name: &str, gone: &[&str]) {
    let src = std::fs::read_to_string(fixture(name)).unwrap();
    let out = run_ok("ugclean", &["-e", "5e-4"], Some(src.as_bytes()));
    let keep_all = run_ok(
        "ugclean",
        &["-e", "5e-4", "--keep-enclosed"],
        Some(src.as_bytes()),
    );
    let (all, after) = (faces(&keep_all), faces(&out));
    let removed: Vec<&String> = all.iter().filter(|f| !after.contains(f)).collect();
    for f in gone {
        assert!(removed.contains(&&f.to_string()), "{f} stays: {out}");
    }
    let m = ug::parse(keep_all.as_bytes(), "all").unwrap().model;
    let ids: Vec<ug::FaceId> = m.top_faces().collect();
    let lit = reached(&keep_all, &ids);
    for (&f, lit) in ids.iter().zip(lit) {
        let name = m.face(f).name.clone().unwrap_or_default();
        assert_eq!(lit, after.contains(&name), "{name}: lit {lit}");
    }
    assert_eq!(check(&out)["inconsistent"].as_array().unwrap().len(), 0);
}

/// A floor piece under a step pushed into a pier, in a cavity bounded by
/// the steps' backs and by the fronts of the pier's and other steps'
/// faces inside it (fixtures/clean/floor-under-a-step-in-a-pier.ug, from
/// the 100,000-face building with stairs): fewer than half the cavity's
/// rays meet backs, and it was kept, with an inconsistently oriented edge
/// against the step's side. At a quarter of backs it goes; no light
/// reaches any face that goes.
#[test]
fn a_cavity_inside_interpenetrating_boxes_is_enclosed() {
    let src = std::fs::read_to_string(fixture("clean/floor-under-a-step-in-a-pier.ug")).unwrap();
    let eps = ["-e", "1.08547e-4"];
    let out = run_ok("ugclean", &eps, Some(src.as_bytes()));
    let keep_all = run_ok(
        "ugclean",
        &[eps[0], eps[1], "--keep-enclosed"],
        Some(src.as_bytes()),
    );
    let after = faces(&out);
    assert!(!after.contains(&"slab0.1.i455".to_string()), "{out}");
    assert!(after.contains(&"s0r2_9st3.5.i5".to_string()), "{out}");
    let r: serde_json::Value = serde_json::from_str(&run_ok(
        "ugcheck",
        &["--json", eps[0], eps[1]],
        Some(out.as_bytes()),
    ))
    .unwrap();
    for k in ["inconsistent", "tvertices", "intersecting", "degenerate"] {
        assert_eq!(r[k].as_array().unwrap().len(), 0, "{k}: {}", r[k]);
    }
    let m = ug::parse(keep_all.as_bytes(), "all").unwrap().model;
    let gone: Vec<ug::FaceId> = m
        .top_faces()
        .filter(|&f| !after.contains(&m.face(f).name.clone().unwrap_or_default()))
        .collect();
    assert!(!gone.is_empty());
    let lit = reached(&keep_all, &gone);
    for (&f, lit) in gone.iter().zip(lit) {
        assert!(!lit, "light reaches {:?}", m.face(f).name);
    }
}

/// A face that another crosses (a panel standing half inside a block and
/// half out, not cut: fixtures/clean/panel-through-a-block.ug) stays, but
/// links nothing: the block inside the block, which sees the panel's part
/// inside, goes whole (it stayed in part when the panel was live by
/// itself), and no light reaches it.
#[test]
fn a_face_another_crosses_links_nothing() {
    let src = std::fs::read_to_string(fixture("clean/panel-through-a-block.ug")).unwrap();
    let out = run_ok("ugclean", &[], Some(src.as_bytes()));
    let after = faces(&out);
    for k in 0..6 {
        assert!(!after.contains(&format!("h.{k}")), "h.{k} stays: {out}");
        assert!(after.contains(&format!("s.{k}")), "s.{k} goes: {out}");
    }
    assert!(after.contains(&"panel".to_string()));
    let m = ug::parse(src.as_bytes(), "all").unwrap().model;
    let gone: Vec<ug::FaceId> = m
        .top_faces()
        .filter(|&f| !after.contains(&m.face(f).name.clone().unwrap_or_default()))
        .collect();
    assert_eq!(gone.len(), 6);
    assert!(reached(&src, &gone).iter().all(|&lit| !lit));
}

/// A tent (a contour vertex 0.75 epsilon off the chord, 1.7 epsilon long,
/// between its neighbours: fixtures/cut/tent-on-a-tile-side.ug, from the
/// chain's output on the 30,000-face CAD building, seed 2): ugcheck counts
/// it as degenerate, and ugclean's last step joins the tip to a neighbour,
/// so the chain writes none (before, only ugcut joined it).
#[test]
fn a_tents_tip_joins_a_neighbour() {
    let src = std::fs::read_to_string(fixture("cut/tent-on-a-tile-side.ug")).unwrap();
    let eps = ["-e", "6.257041912590766e-5"];
    let r = |text: &str| -> serde_json::Value {
        let args: Vec<&str> = ["--json"].iter().chain(&eps).copied().collect();
        serde_json::from_str(&run_ok("ugcheck", &args, Some(text.as_bytes()))).unwrap()
    };
    let before = r(&src);
    assert_one_degenerate(&before, "tent at slab2.1.iv33132");
    let out = run_ok(
        "ugclean",
        &["--keep-enclosed", "-e", eps[1]],
        Some(src.as_bytes()),
    );
    let after = r(&out);
    assert_eq!(after["degenerate"].as_array().unwrap().len(), 0, "{out}");
    assert!(
        !out.contains("slab2.1.iv33132 "),
        "the tip is joined:\n{out}"
    );
    // The faces standing on the tip move by about an epsilon: area within
    // 1e-4 (measured at a smaller epsilon: at the model's, ugcheck leaves
    // the degenerate face with the tent out of the area).
    let whole = serde_json::from_str::<serde_json::Value>(&run_ok(
        "ugcheck",
        &["--json", "-e", "1e-7"],
        Some(src.as_bytes()),
    ))
    .unwrap();
    for m in ["tile", "wood"] {
        let (a, b) = (area(&whole, m), area(&after, m));
        assert!((a - b).abs() <= 1e-4 * a, "{m}: {a} -> {b}");
    }
}

/// A rug's tent whose tip a column's face also passes
/// (fixtures/clean/tent-beside-a-column-face.ug, property seed 89021 at 10
/// times epsilon): joined to its nearer neighbour (1.23 epsilon away), the
/// tip bent the column's face 1.01 epsilon out of its plane; the other
/// neighbour (1.27 epsilon away) keeps it planar, and is taken.
#[test]
fn a_tents_tip_joins_the_neighbour_that_keeps_faces_planar() {
    let src = std::fs::read_to_string(fixture("clean/tent-beside-a-column-face.ug")).unwrap();
    let eps = "1.6544248896576782e-4";
    let out = run_ok("ugclean", &["-e", eps], Some(src.as_bytes()));
    let r: serde_json::Value = serde_json::from_str(&run_ok(
        "ugcheck",
        &["--json", "-e", eps],
        Some(out.as_bytes()),
    ))
    .unwrap();
    assert_none(&r, &["nonplanar", "degenerate"], &out);
    assert!(!out.contains("slab0.1.iv30 "), "the tip is joined:\n{out}");
    assert!(
        out.contains("(slab0.1.iv32 slab1.0.iv130"),
        "the column's face keeps its corner:\n{out}"
    );
}

/// Every defect category of ugcheck's JSON report.
const DEFECTS: &[&str] = &ugkit::DEFECT_KEYS;

/// Asserts that ugcheck's report `r` of `out` has no finding in any of
/// the categories `keys`.
fn assert_none(r: &serde_json::Value, keys: &[&str], out: &str) {
    for key in keys {
        assert_eq!(r[key].as_array().unwrap().len(), 0, "{key}:\n{out}");
    }
}

/// `ugclean --keep-enclosed` on a fixture at epsilon `eps`: its output and
/// ugcheck's report of it.
fn coincident_step_checked(path: &str, eps: &str) -> (String, serde_json::Value) {
    let src = std::fs::read_to_string(fixture(path)).unwrap();
    let out = run_ok(
        "ugclean",
        &["--keep-enclosed", "-e", eps],
        Some(src.as_bytes()),
    );
    let r = serde_json::from_str(&run_ok(
        "ugcheck",
        &["--json", "-e", eps],
        Some(out.as_bytes()),
    ))
    .unwrap();
    (out, r)
}

/// A kept face on records of its own 1.6 epsilon from its removed twin's,
/// which a neighbour of the twin shares (fixtures/clean/wall-face-in-front-of-a-removed-twin.ug,
/// seed 3 of a 2 × 1 building with stairs at `-e 1e-3`): the kept face
/// comes to walk the neighbour's edge (it took the twin's contour until
/// 2026-12-06; now it takes the two records of that edge, its upper
/// corners staying where taking the others would have made the first
/// pair's faces overlap for a moment), so the neighbour's edge is closed
/// and no face lies on another. Before, one overlapping pair after
/// ugclean.
#[test]
fn a_kept_face_closes_the_gap_its_removed_twin_leaves() {
    let (out, r) = coincident_step_checked("clean/wall-face-in-front-of-a-removed-twin.ug", "1e-3");
    assert!(
        !out.contains("f s0w4r0.2.i1.c2 "),
        "the facade piece goes:\n{out}"
    );
    let wall = out
        .lines()
        .find(|l| l.starts_with("f s0w1r0.2.i2 "))
        .unwrap_or_else(|| panic!("the wall's face stays:\n{out}"));
    assert!(
        wall.contains("slab0.2.i3.cv1 slab0.2.i3.cv4"),
        "the wall's face walks the facade neighbour's edge:\n{out}"
    );
    assert!(
        out.contains(
            "f s0w4r0.2.i5.c3 (slab0.2.i4.cv5 slab0.2.i4.cv6 slab0.2.i3.cv4 slab0.2.i3.cv1) facade;"
        ),
        "{out}"
    );
    assert_none(&r, DEFECTS, &out);
    // The default ugclean (enclosed faces removed) too.
    let src =
        std::fs::read_to_string(fixture("clean/wall-face-in-front-of-a-removed-twin.ug")).unwrap();
    let out = run_ok("ugclean", &["-e", "1e-3"], Some(src.as_bytes()));
    let r: serde_json::Value = serde_json::from_str(&run_ok(
        "ugcheck",
        &["--json", "-e", "1e-3"],
        Some(out.as_bytes()),
    ))
    .unwrap();
    assert_none(&r, DEFECTS, &out);
}

/// A pair's moves that are left after others are vetoed must not bend the
/// kept face either (fixtures/clean/vetoed-corners-bend-a-desk-bottom.ug,
/// property seed 1693): before, three of five corners took the twin's
/// records and the piece was non-planar by 1.0 epsilon after ugclean.
#[test]
fn moves_left_after_vetoes_bend_no_face() {
    let (out, r) = coincident_step_checked(
        "clean/vetoed-corners-bend-a-desk-bottom.ug",
        "1.4867539729602339e-5",
    );
    assert_none(
        &r,
        &[
            "degenerate",
            "intersecting",
            "tvertices",
            "nonplanar",
            "overlapping",
            "coincident",
        ],
        &out,
    );
    // The pair is still resolved: the later face of the same material goes.
    assert!(out.contains("f s0r2_1f0.0.i1 "), "{out}");
    assert!(!out.contains("f s0r2_1f1.0.c2 "), "{out}");
}

/// A coincident pair's corners 1.01 epsilon apart joined into one record
/// (fixtures/clean/joined-corner-on-an-edge.ug, from property seed 22 on 3 × 2
/// rooms, a triangle export with an oblique wing): the face beside them
/// came to have a corner 2.4e-7 from one of its own edges, narrower than
/// epsilon, until ugclean repaired the faces after joining.
#[test]
fn a_join_that_puts_a_corner_on_an_edge_is_repaired() {
    let (out, r) =
        coincident_step_checked("clean/joined-corner-on-an-edge.ug", "2.2780725453821576e-5");
    assert!(
        !out.contains("slab0.1.t1.i102.c3"),
        "the floor piece goes:\n{out}"
    );
    // (Four faces cut out of a model: their open edges are no concern.)
    assert_none(&r, &["degenerate", "intersecting", "tvertices"], &out);
}

/// A coincident pair's records are not shared when that would tilt a face
/// next to them so that its edge comes within epsilon of vertices it
/// passed by more than epsilon (fixtures/clean/tilted-wall-bottom-over-tiles.ug,
/// property seed 5731): before, three T-vertices after ugclean.
#[test]
fn sharing_a_pairs_records_makes_no_t_vertex() {
    let (out, r) = coincident_step_checked(
        "clean/tilted-wall-bottom-over-tiles.ug",
        "1.6427471791923383e-5",
    );
    assert_none(
        &r,
        &["degenerate", "intersecting", "tvertices", "nonplanar"],
        &out,
    );
    // The pair is still resolved: the later face of the same material goes.
    assert!(out.contains("f s0w1p0.0.i4 "), "{out}");
    assert!(!out.contains("f wing0.0.i2 "), "{out}");
}

/// A coincident pair's records are not shared when that would drag a face
/// naming them over a face it lay back to back with
/// (fixtures/clean/pier-top-dragged-over-a-ceiling-strip.ug, property seed
/// 2198 placed on a site): before, one overlapping pair after ugclean.
#[test]
fn sharing_a_pairs_records_makes_no_overlap() {
    let eps = "2.5566894059154372e-2";
    let (out, r) = coincident_step_checked("clean/pier-top-dragged-over-a-ceiling-strip.ug", eps);
    assert_none(
        &r,
        &[
            "overlapping",
            "degenerate",
            "intersecting",
            "tvertices",
            "nonplanar",
        ],
        &out,
    );
    // The pair is still resolved: the later face of the same material goes,
    // and the pier top keeps its corners.
    assert!(out.contains("f s0w2r1.4.i1 "), "{out}");
    assert!(!out.contains("f s0w12r0.4.i13 "), "{out}");
    assert!(
        out.contains("f s0w3p0.1.i1 (s0w3p0.v7 s0w3p0.v6 s0w2r1.4.iv952 s0w2r1.3.iv945)"),
        "{out}"
    );
}

/// Nor when it would drag a face that is not kept over one beside it,
/// facing the same way (fixtures/clean/pier-face-dragged-past-a-notch.ug,
/// property seed 45 at 100 times the default epsilon): before, one
/// overlapping pair after ugclean.
#[test]
fn sharing_a_pairs_records_drags_no_face_over_its_neighbour() {
    let (out, r) = coincident_step_checked(
        "clean/pier-face-dragged-past-a-notch.ug",
        "0.000979052158071641",
    );
    assert_none(&r, DEFECTS, &out);
    assert!(!out.contains("f s0w6r0.0.i1.c2 "), "{out}");
    // The pier's face keeps its corners, in the notch.
    assert!(
        out.contains("f s0w1p1.4.dup.i1 (s0w1p1.v3 s0w1p1.v2 slab0.1.iv15 slab0.1.iv14) wall;"),
        "{out}"
    );
}

/// Nor when the pairs' moves together would move a kept face over a face
/// it lies back to back with (fixtures/clean/wing-slab-side-moved-over-a-sliver.ug,
/// property seed 163 at 100 times the default epsilon): before, an
/// overlapping pair and an inconsistently oriented edge after ugclean.
#[test]
fn the_moves_together_move_no_kept_face_over_a_neighbour() {
    let (out, r) = coincident_step_checked(
        "clean/wing-slab-side-moved-over-a-sliver.ug",
        "0.001509731048476075",
    );
    assert_none(&r, DEFECTS, &out);
    // Both pairs are still resolved.
    for gone in ["f wing0.1.i4 ", "f wingslab1.5.dup.i3.c1 "] {
        assert!(!out.contains(gone), "{gone}\n{out}");
    }
    assert!(out.contains("f slab1.3.i7.c3 "), "{out}");
}

/// A kept face does not take its removed twin's shape where that shape
/// reaches over a face left
/// (fixtures/clean/notch-piece-takes-a-twin-shape-past-the-notch.ug, the
/// same seed): before, one overlapping pair after ugclean.
#[test]
fn a_kept_face_takes_no_twin_shape_that_overlaps_a_neighbour() {
    let (out, r) = coincident_step_checked(
        "clean/notch-piece-takes-a-twin-shape-past-the-notch.ug",
        "0.000979052158071641",
    );
    assert_none(&r, DEFECTS, &out);
    assert!(!out.contains("f s0w1p1.4.dup.i1 "), "{out}");
    assert!(
        out.contains(
            "f slab0.4.i3.c2 (slab0.1.iv13 slab0.4.i3.cv3 slab0.4.i3.cv2 slab0.4.i3.cv1) slab;"
        ),
        "the notch piece keeps its own shape:\n{out}"
    );
}

/// Two coincident end pieces, the removed one naming a corner the kept one
/// lacks (fixtures/clean/end-piece-missing-a-corner.ug, property seed 856:
/// a wing wall's end 1.1 epsilon past the other's, and the facade sliver
/// between them): the kept slab piece takes the removed facade piece's
/// contour, keeping its own name and material, so the sliver meets it
/// along the edge they share and no edge is walked twice the same way.
/// Before, one inconsistently oriented edge after ugclean.
#[test]
fn the_kept_face_takes_a_twin_contour_that_names_more_corners() {
    let (out, r) = coincident_step_checked(
        "clean/end-piece-missing-a-corner.ug",
        "1.292876457393198e-5",
    );
    assert!(
        !out.contains("f wing2.3.i5 "),
        "the facade's piece goes:\n{out}"
    );
    assert!(
        out.contains(
            "f wingslab1.3.i2 (wing1.v7 wing1.1.iv213 wing1.v5 wing1.2.iv220 wing1.2.iv219 wingslab1.v3) slab;"
        ),
        "{out}"
    );
    assert_none(&r, DEFECTS, &out);
}

/// Coincident end pieces on records of their own about 2 epsilon apart,
/// which sharing joins only in part (fixtures/clean/end-piece-on-records-of-its-own.ug,
/// property seed 13174): the kept wall piece takes the removed facade
/// piece's contour (its records mapped as shared), so the faces that met
/// the facade piece meet it along the same edges. Before, one
/// inconsistently oriented edge after ugclean.
#[test]
fn the_kept_face_takes_a_twin_contour_its_neighbours_walk() {
    let (out, r) = coincident_step_checked(
        "clean/end-piece-on-records-of-its-own.ug",
        "1.1117431623489092e-5",
    );
    for gone in ["f wing0.2.i8.c2 ", "f wing0.2.i11.c1 "] {
        assert!(!out.contains(gone), "the facade's pieces go:\n{out}");
    }
    assert!(
        out.contains("f wing2.2.c3 (wing0.0.iv179 wing2.5.iv201 wing2.5.iv199 wing2.v0) wall;"),
        "{out}"
    );
    assert_none(&r, DEFECTS, &out);
}

/// ugcheck's report of `text` at epsilon `eps`.
fn checked_at(text: &str, eps: &str) -> serde_json::Value {
    serde_json::from_str(&run_ok(
        "ugcheck",
        &["--json", "-e", eps],
        Some(text.as_bytes()),
    ))
    .unwrap()
}

/// A point left within epsilon of another face's edge goes into the edge:
/// ugclean's last step, so that the chain writes no T-vertex whatever the
/// steps before left (property seed 95032, rounded to 1 mm: ugcopl left
/// a tile sliver's edge 0.9 epsilon from a corner that pieces enclosed
/// and then removed had used). Nothing here is coincident or enclosed.
#[test]
fn a_point_left_on_an_edge_goes_into_it() {
    let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\n\
               v m 1.0009 0.5 0; v e 2 0 0; v f 2 1 0;\n\
               f left (a b c d);\nf right (b e f c m);\n";
    assert_eq!(
        checked_at(src, "1e-3")["tvertices"]
            .as_array()
            .unwrap()
            .len(),
        1
    );
    let out = run_ok("ugclean", &["-e", "1e-3"], Some(src.as_bytes()));
    assert!(out.contains("f left (a b m c d);"), "{out}");
    assert!(out.contains("f right (b e f c m);"), "{out}");
    assert_none(&checked_at(&out, "1e-3"), DEFECTS, &out);
}

/// A wall's corner 1.002 epsilon from a floor's corner and 0.71 epsilon
/// from both the floor's edges there joins the floor's corner (property
/// seed 95021 rounded to 1 mm, with `--keep-enclosed`: a slab's cut point
/// by a desk foot's corner). Put into the edges, it made a spike at the
/// corner, which the repair took out with the floor's corner.
#[test]
fn a_point_just_beyond_epsilon_of_a_corner_joins_it() {
    let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\n\
               v m 0.9992915 0.0007085 0; v n 1.5 -0.5 0; v n2 1.5 -0.5 1;\n\
               v m2 0.9992915 0.0007085 1;\n\
               f floor (a b c d);\nf wall (m n n2 m2);\n";
    assert!(
        !checked_at(src, "1e-3")["tvertices"]
            .as_array()
            .unwrap()
            .is_empty()
    );
    let out = run_ok("ugclean", &["-e", "1e-3"], Some(src.as_bytes()));
    assert!(out.contains("f floor (a b c d);"), "{out}");
    assert!(out.contains("f wall (b n n2 m2);"), "{out}");
    assert_none(&checked_at(&out, "1e-3"), DEFECTS, &out);
}

/// ugclean with and without `--keep-enclosed` on a fixture at epsilon
/// `eps`, each output checked free of defects; the outputs.
fn clean_both_ways(path: &str, eps: &str) -> Vec<String> {
    let src = std::fs::read_to_string(fixture(path)).unwrap();
    [&["--keep-enclosed", "-e", eps][..], &["-e", eps][..]]
        .iter()
        .map(|args| {
            let out = run_ok("ugclean", args, Some(src.as_bytes()));
            assert_none(&checked_at(&out, eps), DEFECTS, &out);
            out
        })
        .collect()
}

/// A tent's tip whose nearer neighbour would sweep its face over a wall
/// piece coplanar with it joins the other, the wall's corner
/// (fixtures/clean/tent-tip-sweeping-over-a-coplanar-wall.ug, property
/// seed 105079 at 4 decimals: an overlap of 8,400 epsilon squared).
#[test]
fn a_tents_tip_joins_the_neighbour_that_makes_no_overlap() {
    for out in clean_both_ways("clean/tent-tip-sweeping-over-a-coplanar-wall.ug", "2e-4") {
        assert!(
            out.contains("s76 wing1.4.iv426 wing2.3.iv280) facade;"),
            "the tip joins the wall's corner:\n{out}"
        );
    }
}

/// A facade strip 4 mm high on a slab's side, at 1 mm (epsilon 2.1 mm),
/// a tent's tip on each of its sides, where the slab's two pieces meet
/// between its edges (fixtures/clean/facade-foot-strip-between-slab-pieces-at-1mm.ug,
/// property seed 400886 on 3 × 2 rooms): joined to either end of its tent,
/// a tip drags one slab piece over the strip (before: the piece below
/// overlapped it, 6e-4). The tips are split: each piece takes the strip's
/// corner on its own side, and the three faces share the strip's edges.
#[test]
fn a_tip_between_two_pieces_leaves_each_for_its_own_side() {
    for out in clean_both_ways(
        "clean/facade-foot-strip-between-slab-pieces-at-1mm.ug",
        "2.1e-3",
    ) {
        for (face, walk) in [
            (
                "slab0.2.i1",
                "s0w9p0.v1 s0w2p0.3.iv1178 s0w2p0.5.iv1194 s0w9p0.v0",
            ),
            (
                "slab0.2.i4",
                "(s0w2p0.5.iv1193 s0w2p0.3.iv1177 slab0.1.iv4 slab0.1.iv3)",
            ),
            (
                "s0w9p0.2.i9",
                "(s0w2p0.5.iv1194 s0w2p0.3.iv1178 s0w2p0.3.iv1177 s0w2p0.5.iv1193)",
            ),
        ] {
            assert!(
                out.lines()
                    .any(|l| l.starts_with(&format!("f {face} ")) && l.contains(walk)),
                "{face} walks {walk}:\n{out}"
            );
        }
        // The tips are used by no face, and not written.
        assert!(
            out.lines()
                .filter(|l| l.starts_with("v ") || l.starts_with("f "))
                .all(|l| !l.contains("s0w2p0.v0") && !l.contains("s0w2p0.v1")),
            "{out}"
        );
    }
}

/// A table leg's bottom 3 mm (1.4 epsilon) under the floor at 1 mm, a
/// quad and a triangle meeting at a tent's tip under the floor piece's
/// corner (fixtures/clean/table-leg-stub-under-a-floor-at-1mm.ug, property
/// seed 400811 on 3 × 2 rooms): joined to the leg's corner, the tip made
/// the bottom the whole square, 2.4e-3 of it over the floor. Split, the
/// triangle, which the move leaves without a plane, takes that corner and
/// goes, and the quad takes the floor piece's corner.
#[test]
fn a_triangle_the_split_leaves_without_a_plane_goes() {
    for out in clean_both_ways("clean/table-leg-stub-under-a-floor-at-1mm.ug", "2.1e-3") {
        let faces: Vec<&str> = out.lines().filter(|l| l.starts_with("f ")).collect();
        assert!(
            faces.iter().any(|l| l.starts_with("f s1r0_1f0leg3.0.i1 ")
                && l.contains("(s1r0_1f0leg3.v0 s1r0_1f0leg3.v2 s1r0_1f0leg3.v3 slab1.1.iv1260)")),
            "the bottom's quad takes the floor piece's corner:\n{out}"
        );
        assert!(
            faces
                .iter()
                .all(|l| !l.starts_with("f s1r0_1f0leg3.0.i2 ")
                    && !l.contains("s1r0_1f0leg3.0.iv1149")),
            "the triangle and the tip go:\n{out}"
        );
    }
}

/// Two tents whose tips are corners of one slab piece: each join alone
/// keeps it planar, both in one pass bent it 1.1 epsilon
/// (fixtures/clean/two-tents-on-one-slab-piece.ug, property seed 103186
/// at 10 times epsilon). The second join waits for the next pass.
#[test]
fn two_tents_on_one_face_join_one_at_a_time() {
    clean_both_ways(
        "clean/two-tents-on-one-slab-piece.ug",
        "1.6157269999999999e-4",
    );
}

/// fixtures/clean/strips-coincident-after-their-tents.ug: a wall end's
/// sliver and a slab's, whose contours differ only by tents' tips (property
/// seed 400363 at 4 decimals with oblique wings). ugclean's last step joins
/// the tips, and the two then lie on the same records: the coincident step,
/// which ran before, left them as a coincident pair. Now it runs again on
/// the faces the tents changed; with and without `--keep-enclosed`, the
/// output has no defect, and one of the two is gone.
#[test]
fn the_coincident_pairs_the_tents_make_go_too() {
    let src = std::fs::read(fixture("clean/strips-coincident-after-their-tents.ug")).unwrap();
    for (extra, out) in cleaned_both_ways(&src, "2.1e-4") {
        assert_eq!(faces(&out).len(), 1, "{extra:?}: {:?}", faces(&out));
    }
}

/// ugclean's output on `src` at epsilon `eps`, without and with
/// `--keep-enclosed`, each checked to have no defect.
fn cleaned_both_ways(src: &[u8], eps: &str) -> Vec<(Option<&'static str>, String)> {
    [None, Some("--keep-enclosed")]
        .into_iter()
        .map(|extra| {
            let mut args = vec!["-q", "-e", eps];
            args.extend(extra);
            let out = run_ok("ugclean", &args, Some(src));
            let r: serde_json::Value = serde_json::from_str(&run_ok(
                "ugcheck",
                &["--json", "-e", eps],
                Some(out.as_bytes()),
            ))
            .unwrap();
            ugkit::assert_no_defects(&r, &format!("{extra:?}"));
            (extra, out)
        })
        .collect()
}

/// fixtures/clean/wall-top-bent-by-shared-records-at-1mm.ug: a wall run's
/// top kept against a pier's takes its contour and the records of another
/// pair's corners; each move keeps it within half an epsilon of its plane,
/// together they leave it 3 epsilon off (property seed 400805 at 1 mm, with
/// `--keep-enclosed`). ugclean folds such a face into triangles: with and
/// without `--keep-enclosed`, no defect, and the top is triangles.
#[test]
fn a_face_the_shared_records_bend_is_folded() {
    let src = std::fs::read(fixture("clean/wall-top-bent-by-shared-records-at-1mm.ug")).unwrap();
    for (extra, out) in cleaned_both_ways(&src, "2.1e-3") {
        // The bent top is now triangles, all of them kept.
        let tops: Vec<String> = faces(&out)
            .into_iter()
            .filter(|f| f.starts_with("s0w9r1.1.i3.c1"))
            .collect();
        assert!(tops.len() >= 2, "{extra:?}: {tops:?}");
    }
}

/// A 4 × 4 m room at 1 mm (epsilon 2.1 mm): a ceiling slab with a flush
/// light panel, and a globe lamp (a UV sphere of `nu` × `nv` facets,
/// radius `r`, centred at (`gx`, `gy`)) whose pole pokes `poke` into the
/// ceiling through the panel.
fn globe_through_a_panel(nu: usize, nv: usize, r: f64, poke: f64, gx: f64, gy: f64) -> String {
    use std::f64::consts::PI;
    use std::fmt::Write;
    let mm = |x: f64| (x * 1000.0).round() / 1000.0;
    let mut s = String::from(
        "c_rgb ceiling 0.85 0.85 0.85;\nc_rgb floor 0.5 0.5 0.5;\n\
         defmat panel;\n  diffuse_rgb 0.8 0.8 0.8;\n  emission_rgb 10 9 7;\nend;\n\
         defmat light;\n  diffuse_rgb 0.8 0.8 0.8;\n  emission_rgb 10 9 7;\nend;\n",
    );
    let v = |s: &mut String, name: &str, p: [f64; 3]| {
        writeln!(s, "v {name} {} {} {};", mm(p[0]), mm(p[1]), mm(p[2])).unwrap();
    };
    let zc = 2.8;
    for (name, z0, z1, mat) in [
        ("slab", zc, zc + 0.2, "ceiling"),
        ("floor", -0.2, 0.0, "floor"),
    ] {
        let corners = [
            [0.0, 0.0, z0],
            [4.0, 0.0, z0],
            [4.0, 4.0, z0],
            [0.0, 4.0, z0],
            [0.0, 0.0, z1],
            [4.0, 0.0, z1],
            [4.0, 4.0, z1],
            [0.0, 4.0, z1],
        ];
        for (i, p) in corners.iter().enumerate() {
            v(&mut s, &format!("{name}{i}"), *p);
        }
        for (k, q) in [
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [1, 2, 6, 5],
            [2, 3, 7, 6],
            [3, 0, 4, 7],
        ]
        .iter()
        .enumerate()
        {
            let vs: Vec<String> = q.iter().map(|i| format!("{name}{i}")).collect();
            writeln!(s, "f {name}.{k} ({}) {mat};", vs.join(" ")).unwrap();
        }
    }
    for (i, p) in [[1.4, 1.7], [1.4, 2.3], [2.6, 2.3], [2.6, 1.7]]
        .iter()
        .enumerate()
    {
        v(&mut s, &format!("pn{i}"), [p[0], p[1], zc]);
    }
    s += "f panel (pn0 pn1 pn2 pn3) panel;\n";
    let g = [gx, gy, zc + poke - r];
    let ring = |a: usize, k: usize| {
        let (ph, th) = (PI * a as f64 / nv as f64, 2.0 * PI * k as f64 / nu as f64);
        [
            g[0] + r * ph.sin() * th.cos(),
            g[1] + r * ph.sin() * th.sin(),
            g[2] + r * ph.cos(),
        ]
    };
    v(&mut s, "gn", [g[0], g[1], g[2] + r]);
    v(&mut s, "gs", [g[0], g[1], g[2] - r]);
    for a in 1..nv {
        for k in 0..nu {
            v(&mut s, &format!("g{a}_{k}"), ring(a, k));
        }
    }
    for k in 0..nu {
        let k2 = (k + 1) % nu;
        writeln!(s, "f n{k} (gn g1_{k} g1_{k2}) light;").unwrap();
        writeln!(s, "f s{k} (gs g{}_{k2} g{}_{k}) light;", nv - 1, nv - 1).unwrap();
        for a in 1..nv - 1 {
            writeln!(
                s,
                "f q{a}_{k} (g{a}_{k} g{}_{k} g{}_{k2} g{a}_{k2}) light;",
                a + 1,
                a + 1
            )
            .unwrap();
        }
    }
    s
}

/// A globe lamp whose pole pokes 3 to 10 mm into a ceiling through a flush
/// light panel, at 1 mm (epsilon 2.1 mm). ugisect cuts the panel round
/// the globe: the disc inside faces down into the globe, the cap above
/// faces up into the slab, both emitters, both within 2 to 5 epsilon of
/// each other. No light from them reaches anything; but an emitter was
/// live by itself, so the enclosed step kept both, and their patches
/// overlapped (6 of these 6 rooms kept 4 to 39 defects after ugcut at
/// -l 0.7 or 0.2; 42 of 200 such rooms drawn at random, 4 now). Now an
/// emitter whose every ray meets a back is judged like any face: both go.
#[test]
fn emitters_buried_in_solids_are_enclosed() {
    let e = ["-e", "0.0021"];
    for (nu, nv, r, poke, gx, gy) in [
        (12, 6, 0.239, 0.0066, 2.122, 1.748),
        (12, 8, 0.203, 0.003, 1.623, 1.718),
        (20, 8, 0.215, 0.0039, 2.19, 2.324),
        (16, 8, 0.127, 0.0031, 2.239, 1.673),
        (16, 4, 0.193, 0.0102, 2.021, 2.105),
        (8, 6, 0.129, 0.0072, 2.204, 1.804),
    ] {
        let model = globe_through_a_panel(nu, nv, r, poke, gx, gy);
        let what = format!("{nu} x {nv} globe, r {r}, poke {poke}");
        let cleaned = ugkit::pipe(
            model.as_bytes(),
            &[
                ("ugplanar", &e),
                ("ugvlmerge", &e),
                ("ugflip", &e),
                ("ugisect", &e),
                ("ugcopl", &e),
                ("ugclean", &e),
            ],
        );
        let text = String::from_utf8(cleaned).unwrap();
        ugkit::assert_no_defects(&checked_at(&text, "0.0021"), &what);
        // The panel's disc under the cap went; the panel round it stays.
        let names = faces(&text);
        assert!(names.iter().any(|n| n.starts_with("panel")), "{what}");
        for len in ["0.7", "0.2"] {
            let cut = run_ok("ugcut", &["-e", "0.0021", "-l", len], Some(text.as_bytes()));
            ugkit::assert_no_defects(&checked_at(&cut, "0.0021"), &format!("{what}, -l {len}"));
        }
    }
}

/// ugclean with `args` (`-v` among them) on `src`: its output and stderr,
/// and that every face in (`faces_in`) is a face out or a named removal
/// (`removed` or `dropped` lines).
fn clean_accounted(src: &str, args: &[&str], faces_in: usize) -> (String, String) {
    let out = ugkit::run("ugclean", args, Some(src.as_bytes()));
    assert!(out.status.success());
    let (text, err) = (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    );
    let named = err
        .lines()
        .filter(|l| l.starts_with("  removed ") || l.starts_with("  dropped "))
        .count();
    assert_eq!(faces(&text).len() + named, faces_in, "{err}\n{text}");
    (text, err)
}

/// A face that ugclean's last step leaves without area is dropped and
/// named by `-v`, not lost unreported: a facade sliver whose corner lies
/// just beyond epsilon of another corner and within epsilon of the edge
/// leaving it (fixtures/clean/a-sliver-a-corner-join-empties-at-1mm.ug,
/// from property seed 170202 at 1 mm, where five faces so vanished with
/// `--keep-enclosed` and the `-v` lines accounted for none). Every face
/// in is a face out or named: removed, or dropped.
#[test]
fn a_face_the_joins_leave_without_area_is_named() {
    let src =
        std::fs::read_to_string(fixture("clean/a-sliver-a-corner-join-empties-at-1mm.ug")).unwrap();
    for keep in [true, false] {
        let mut args = vec!["-v", "-e", "0.0021000000000000003"];
        if keep {
            args.push("--keep-enclosed");
        }
        let (text, err) = clean_accounted(&src, &args, 2);
        assert!(
            err.contains("1 points joined to a corner just beyond epsilon")
                && err.contains("1 faces the joins left without area, dropped")
                && err.contains("  dropped s0w1r1.3.t1.i7.c4.c1: fewer than 3 distinct vertices"),
            "{err}"
        );
        // (Without `--keep-enclosed`, neither face is found enclosed.)
        assert!(keep || err.contains("\n0 enclosed faces removed"), "{err}");
        assert_eq!(faces(&text), ["s0w1r1.3.t1.i7.c3"]);
    }
}

/// The same for a face the coincident step's shared records leave without
/// area: a wall end's sliver 4 mm wide between two walls' sides 4 mm apart
/// (fixtures/clean/a-sliver-between-coincident-wall-bottoms-at-1mm.ug).
#[test]
fn a_sliver_the_shared_records_flatten_is_named() {
    let src = std::fs::read_to_string(fixture(
        "clean/a-sliver-between-coincident-wall-bottoms-at-1mm.ug",
    ))
    .unwrap();
    let (text, err) = clean_accounted(&src, &["-v", "-e", "0.0021000000000000003"], 3);
    assert!(
        err.contains("1 faces the shared records left without area, dropped")
            && err.contains("  dropped s0w25r0.3.i1: fallen to a segment"),
        "{err}"
    );
    assert_eq!(faces(&text), ["s0w25r0.2.i2"]);
}

/// The contour of face `name` in `text` as vertex names, outer contour
/// first.
fn contour(text: &str, name: &str) -> Vec<String> {
    let m = ug::parse(text.as_bytes(), "o").unwrap().model;
    let f = m
        .top_faces()
        .find(|&f| m.face(f).name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no face {name}:\n{text}"));
    m.face(f).contours[0]
        .iter()
        .map(|&v| m.vertex(v).name.clone())
        .collect()
}

/// Two faces walking their shared edge the same way, as parts ugflip
/// oriented apart do once ugisect's cuts join them: a wall on a floor's
/// edge facing away from it (fixtures/clean/wall-walking-the-floors-edge-the-same-way.ug),
/// and a pier's side strip a centimetre wide against a sill's side from
/// property seed 500322 rounded to centimetres
/// (fixtures/clean/pier-strip-and-sill-side-walking-an-edge-the-same-way-at-1cm.ug;
/// in the chain, six such edges stayed after ugclean). ugclean's last step
/// turns the face of the lesser area, names it with `-vv`, leaves the other
/// as it was, and turns nothing on its own output.
#[test]
fn faces_walking_a_shared_edge_the_same_way_turn_to_agree() {
    for (path, eps, turned, kept) in [
        (
            "clean/wall-walking-the-floors-edge-the-same-way.ug",
            "1e-6",
            "wall",
            "floor",
        ),
        (
            "clean/pier-strip-and-sill-side-walking-an-edge-the-same-way-at-1cm.ug",
            "7.743391e-6",
            "s0w0p0.4.t2.i6.c1",
            "s0w0s.3.t2.i2",
        ),
    ] {
        let src = std::fs::read_to_string(fixture(path)).unwrap();
        let report = |text: &str| -> serde_json::Value {
            serde_json::from_str(&run_ok(
                "ugcheck",
                &["--json", "-e", eps],
                Some(text.as_bytes()),
            ))
            .unwrap()
        };
        assert_eq!(report(&src)["inconsistent"].as_array().unwrap().len(), 1);
        let res = run("ugclean", &["-vv", "-e", eps], Some(src.as_bytes()));
        assert!(res.status.success(), "{path}");
        let out = String::from_utf8(res.stdout).unwrap();
        let err = String::from_utf8(res.stderr).unwrap();
        assert_none(&report(&out), DEFECTS, &out);
        assert!(
            err.contains("1 faces turned to agree")
                && err.contains(&format!("  turned {turned}\n")),
            "{path}: {err}"
        );
        let (mut before, after) = (contour(&src, turned), contour(&out, turned));
        before[1..].reverse();
        assert_eq!(after, before, "{path}: {turned} is turned");
        assert_eq!(contour(&out, kept), contour(&src, kept), "{path}");
        let again = run("ugclean", &["-vv", "-e", eps], Some(out.as_bytes()));
        assert_eq!(String::from_utf8(again.stdout).unwrap(), out, "{path}");
        assert!(
            String::from_utf8(again.stderr)
                .unwrap()
                .contains("0 faces turned to agree"),
            "{path}"
        );
    }
}
