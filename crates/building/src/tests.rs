use std::collections::HashMap;

use super::*;

/// The toolkit's default epsilon: 1e-6 of the bounding-box diagonal.
fn eps(m: &Model) -> f64 {
    let (lo, hi) = m.bounds().expect("vertices");
    1e-6 * (hi - lo).length()
}

fn check(m: &Model) -> check::Report {
    check::check(m, eps(m))
}

fn segments(x: usize, y: usize) -> usize {
    (x + 1) * y + (y + 1) * x
}

#[test]
fn same_seed_same_model_other_seed_other_model() {
    let dirt = Dirt::messy();
    let a = generate(4, 3, &dirt, 7);
    assert_eq!(a, generate(4, 3, &dirt, 7));
    assert_eq!(
        ug::write_string(&a),
        ug::write_string(&generate(4, 3, &dirt, 7))
    );
    assert_ne!(a, generate(4, 3, &dirt, 8));
    // The clean building does not depend on the seed.
    assert_eq!(
        generate(3, 3, &Dirt::default(), 1),
        generate(3, 3, &Dirt::default(), 2)
    );
}

#[test]
fn face_counts_are_as_documented() {
    for (x, y) in [(1, 1), (3, 2), (5, 4)] {
        let clean = generate(x, y, &Dirt::default(), 0);
        assert_eq!(clean.faces.len(), 9 * x * y + 2 * (x + y));
        assert_eq!(clean.faces.len(), face_count(x, y, &Dirt::default()));
        for dirt in [Dirt::grouper(), Dirt::messy()] {
            assert_eq!(
                generate(x, y, &dirt, 3).faces.len(),
                face_count(x, y, &dirt)
            );
        }
        let lit = Dirt {
            lights: true,
            furniture: 3,
            ..Dirt::default()
        };
        assert_eq!(
            generate(x, y, &lit, 3).faces.len(),
            clean.faces.len() + x * y * (1 + 18)
        );
    }
    assert_eq!(building(33).faces.len(), 9_933);
    // Every face is used and every vertex is used by a face.
    let m = generate(3, 2, &Dirt::messy(), 5);
    let mut used = vec![false; m.vertices.len()];
    for f in &m.faces {
        for &v in &f.contours[0] {
            used[v.idx()] = true;
        }
    }
    assert!(used.iter().all(|&u| u));
    assert_eq!(m.top_faces().count(), m.faces.len());
    assert_eq!(m.top_vertices().count(), m.vertices.len());
}

#[test]
fn rooms_for_faces_comes_near_the_target() {
    for target in [100, 1_000, 10_000, 100_000] {
        for dirt in [Dirt::default(), Dirt::messy()] {
            let (x, y) = rooms_for_faces(target, &dirt);
            let n = face_count(x, y, &dirt);
            let per_room = face_count(2, 2, &dirt) / 4 + 4;
            assert!(
                n.abs_diff(target) <= per_room * (x + 1),
                "{target}: {x}×{y} → {n}"
            );
        }
    }
    assert_eq!(rooms_for_faces(0, &Dirt::default()), (1, 1));
}

#[test]
fn the_clean_building_has_no_defect() {
    let m = generate(4, 3, &Dirt::default(), 0);
    let r = check(&m);
    assert_eq!(r.defects(), 0, "{}", r.text(false));
    // The lower wall faces are pentagons (their foot has the floor's mid vertex).
    assert_eq!(r.count("nonpatch"), segments(4, 3));
    // The outer floor and ceiling edges meet exactly one wall each.
    assert_eq!(r.count("boundary"), 0);
}

#[test]
fn the_written_model_reads_back_the_same() {
    let m = generate(2, 3, &Dirt::messy(), 11);
    let s = ug::write_string(&m);
    let back = ug::parse(s.as_bytes(), "gen").expect("parses").model;
    assert_eq!(ug::write_string(&back), s);
    assert_eq!(back.faces.len(), m.faces.len());
}

#[test]
fn nonplanar_count_equals_the_lifted_quads() {
    for (f, seed) in [(0.05, 1), (0.2, 2), (0.4, 3)] {
        let dirt = Dirt {
            nonplanar: f,
            ..Dirt::default()
        };
        let m = generate(5, 4, &dirt, seed);
        let expect = (f * m.faces.len() as f64).round() as usize;
        let r = check(&m);
        assert_eq!(r.nonplanar.len(), expect, "{}", r.text(false));
        // About lift / 4 off the best-fit plane.
        for n in &r.nonplanar {
            assert!(
                n.deviation > 0.2 * dirt.lift && n.deviation < 0.5 * dirt.lift,
                "{n:?}"
            );
        }
        // The corner goes below the floor: no T-vertex, no orientation
        // change. (ugcheck judges a non-planar face on its best-fit plane,
        // which may cross the walls standing on the piece: it can report
        // such pairs as intersecting until the face is tessellated.)
        assert_eq!(
            r.count("tvertex") + r.count("orientation") + r.count("overlap"),
            0
        );
        // Tessellated, nothing is left.
        let (p, st) = clean::planar::planarize(&m, eps(&m));
        assert_eq!(st.nonplanar, expect);
        let r = check(&p);
        assert_eq!(r.defects(), 0, "{}", r.text(false));
    }
    // Asking for more than there are floor pieces lifts them all.
    let m = generate(
        2,
        2,
        &Dirt {
            nonplanar: 1.0,
            ..Dirt::default()
        },
        0,
    );
    let r = check(&m);
    assert_eq!(r.nonplanar.len(), 4 * 4);
    assert!(
        m.vertices
            .iter()
            .all(|v| v.pos.z >= 0.0 || v.pos.z == -0.01),
        "lifted corners go 1 cm down"
    );
}

#[test]
fn t_vertex_count_equals_the_coarse_wall_segments() {
    for f in [0.1, 0.5, 1.0] {
        let dirt = Dirt {
            tvertices: f,
            ..Dirt::default()
        };
        let m = generate(4, 5, &dirt, 9);
        let r = check(&m);
        let expect = (f * segments(4, 5) as f64).round() as usize;
        assert_eq!(r.count("tvertex"), expect, "{}", r.text(false));
        assert_eq!(r.defects(), expect);
    }
}

#[test]
fn coincident_copies_lie_within_epsilon_and_are_no_defect() {
    let dirt = Dirt {
        coincident: 0.5,
        ..Dirt::default()
    };
    let m = generate(4, 4, &dirt, 4);
    let e = eps(&m);
    // Pairs of distinct vertices closer than epsilon.
    let mut near = 0;
    for (i, a) in m.vertices.iter().enumerate() {
        for b in &m.vertices[i + 1..] {
            if (a.pos - b.pos).length() <= e {
                near += 1;
            }
        }
    }
    let walls = m.vertices.iter().filter(|v| v.name.ends_with('b')).count();
    let ceilings = (0.5f64 * 16.0).round() as usize;
    assert!(walls > 0);
    // Each offset wall copy has one twin; each ceiling corner copy has its
    // top corner and the other copies of neighbouring ceilings at that corner.
    assert!(near >= walls + 4 * ceilings, "{near}");
    let r = check(&m);
    // Only orientation findings: inner walls are single faces (see the crate docs).
    assert_eq!(r.defects(), r.count("orientation"), "{}", r.text(false));
    // The copies leave edges with one face.
    assert!(r.count("boundary") > 0);
    // The grouper's model: everything doubled.
    let g = building(3);
    let gw = g.vertices.iter().filter(|v| v.name.ends_with('b')).count();
    assert_eq!(gw, 16);
    assert_eq!(
        g.vertices
            .iter()
            .filter(|v| v.name.starts_with('c'))
            .count(),
        4 * 9
    );
}

#[test]
fn flipped_faces_show_as_inconsistent_edges() {
    let base = Dirt {
        lights: true,
        furniture: 2,
        ..Dirt::default()
    };
    let dirt = Dirt {
        flipped: 0.3,
        ..base.clone()
    };
    let clean = generate(4, 4, &base, 6);
    let m = generate(4, 4, &dirt, 6);
    assert_eq!(check(&clean).count("orientation"), 0);
    let flipped: Vec<bool> = clean
        .faces
        .iter()
        .zip(&m.faces)
        .map(|(a, b)| a.contours != b.contours)
        .collect();
    let nflipped = flipped.iter().filter(|&&f| f).count();
    assert_eq!(nflipped, (0.3 * m.faces.len() as f64).round() as usize);
    for (a, b) in clean.faces.iter().zip(&m.faces) {
        let mut r = a.contours[0].clone();
        r.reverse();
        assert!(b.contours[0] == a.contours[0] || b.contours[0] == r);
    }
    // Manifold edges (two faces) between a flipped and an unflipped face.
    let mut uses: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (f, face) in clean.faces.iter().enumerate() {
        let c = &face.contours[0];
        for i in 0..c.len() {
            let (a, b) = (c[i].0, c[(i + 1) % c.len()].0);
            uses.entry((a.min(b), a.max(b))).or_default().push(f);
        }
    }
    let expect = uses
        .values()
        .filter(|fs| fs.len() == 2 && flipped[fs[0]] != flipped[fs[1]])
        .count();
    assert!(expect > 0);
    let r = check(&m);
    assert_eq!(r.count("orientation"), expect, "{}", r.text(false));
}

#[test]
fn lights_hang_below_the_ceilings_facing_down() {
    let dirt = Dirt {
        lights: true,
        ..Dirt::default()
    };
    let m = generate(3, 2, &dirt, 0);
    let r = check(&m);
    assert_eq!(r.counts.emitters, 6);
    assert_eq!(r.defects(), 0, "{}", r.text(false));
    let light = m.material_by_name("light").unwrap();
    assert!(m.material(light).is_emitter());
    for f in m.faces.iter().filter(|f| f.material == Some(light)) {
        let p: Vec<DVec3> = f.contours[0].iter().map(|&v| m.pos(v)).collect();
        assert!(
            p.iter()
                .all(|q| (q.z - (ROOM_H - LIGHT_DROP)).abs() < 1e-12)
        );
        let n = (p[1] - p[0]).cross(p[2] - p[1]);
        assert!(n.z < 0.0, "faces down");
    }
}

#[test]
fn furniture_boxes_are_closed_outward_and_stand_on_the_floor() {
    let dirt = Dirt {
        furniture: 3,
        ..Dirt::default()
    };
    let m = generate(3, 3, &dirt, 12);
    let mat = m.material_by_name("furniture").unwrap();
    let boxes: Vec<&Face> = m.faces.iter().filter(|f| f.material == Some(mat)).collect();
    assert_eq!(boxes.len(), 6 * 3 * 9);
    for b in boxes.chunks(6) {
        // Signed volume (divergence theorem) positive: outward.
        let mut vol = 0.0;
        let mut zmin = f64::INFINITY;
        for f in b {
            let p: Vec<DVec3> = f.contours[0].iter().map(|&v| m.pos(v)).collect();
            for i in 1..p.len() - 1 {
                vol += p[0].dot(p[i].cross(p[i + 1])) / 6.0;
            }
            zmin = p.iter().fold(zmin, |z, q| z.min(q.z));
        }
        assert!(vol > 0.0);
        assert_eq!(zmin, 0.0);
    }
    let r = check(&m);
    // Each box's sides stand on an uncut floor quad and its bottom lies on it.
    assert_eq!(r.count("intersect"), 4 * 27, "{}", r.text(false));
    assert_eq!(r.count("overlap"), 27);
    assert_eq!(r.count("orientation"), 0);
    assert_eq!(r.count("tvertex"), 0);
    assert_eq!(r.count("nonplanar"), 0);
}

#[test]
fn messy_has_every_defect_kind() {
    let m = generate(5, 5, &Dirt::messy(), 42);
    let r = check(&m);
    let lifted = (0.1 * m.faces.len() as f64).round() as usize;
    assert_eq!(r.count("nonplanar"), lifted);
    for c in ["tvertex", "intersect", "overlap", "orientation"] {
        assert!(r.count(c) > 0, "{c}: {}", r.text(false));
    }
    assert_eq!(r.counts.emitters, 25);
}

#[test]
fn rng_is_stable_and_choose_is_exact() {
    let mut r = Rng::new(1, 2);
    let a: Vec<u64> = (0..3).map(|_| r.next_u64()).collect();
    let mut r = Rng::new(1, 2);
    let b: Vec<u64> = (0..3).map(|_| r.next_u64()).collect();
    assert_eq!(a, b);
    assert_ne!(Rng::new(1, 3).next_u64(), a[0]);
    for (n, k) in [(0, 0), (10, 0), (10, 3), (10, 10), (5, 9)] {
        let mask = Rng::new(9, 9).choose(n, k);
        assert_eq!(mask.len(), n);
        assert_eq!(mask.iter().filter(|&&x| x).count(), k.min(n));
    }
    let mut r = Rng::new(0, 0);
    for _ in 0..1000 {
        let u = r.unit();
        assert!((0.0..1.0).contains(&u));
        assert!(r.below(7) < 7);
    }
}

/// `--triangles`: the same surfaces as triangles fanned from each face's
/// first vertex, every face on vertex records of its own, the area per
/// material the same (without jitter; compared where the faces are planar:
/// a twisted quad's area depends on its diagonal).
#[test]
fn the_triangle_export_fans_every_convex_face_on_its_own_vertices() {
    let cfg = Cad {
        jitter: 0.0,
        ..Cad::default()
    };
    let quads = cad(&cfg, 3);
    let tris = cad(
        &Cad {
            triangles: true,
            ..cfg
        },
        3,
    );
    let (a, b) = (check(&quads), check(&tris));
    assert!(tris.faces.len() > quads.faces.len() * 3 / 2);
    let mut users = vec![0usize; tris.vertices.len()];
    for f in &tris.faces {
        assert_eq!(f.contours.len(), 1);
        for &v in &f.contours[0] {
            users[v.idx()] += 1;
        }
    }
    assert!(users.iter().all(|&u| u == 1), "a vertex record shared");
    let triangles = tris
        .faces
        .iter()
        .filter(|f| f.contours[0].len() == 3)
        .count();
    assert!(
        triangles * 100 >= tris.faces.len() * 99,
        "{triangles} of {}",
        tris.faces.len()
    );
    for (x, y) in a.area_by_material.iter().zip(&b.area_by_material) {
        assert_eq!(x.material, y.material);
        if ["vault", "column"].contains(&x.material.as_str()) {
            continue; // twisted quads: the fan's area differs
        }
        assert!(
            (x.area - y.area).abs() <= 1e-9 * x.area,
            "{}: {} vs {}",
            x.material,
            x.area,
            y.area
        );
    }
}

/// `--wing` and `--pitched`: the wing's and the roof's solids are closed,
/// outward and planar (a shear and a slope keep planes planar), the wing's
/// side walls run at an angle to the facade, the roof slopes at 20–40°,
/// and the gables reach into the roof slabs.
#[test]
fn the_wing_and_the_pitched_roof_are_closed_planar_solids_at_an_angle() {
    for seed in 1..=8 {
        let cfg = Cad {
            jitter: 0.0,
            flipped: 0.0,
            duplicates: 0.0,
            wing: true,
            pitched: true,
            ..Cad::default()
        };
        let m = cad(&cfg, seed);
        let mut solids: HashMap<&str, Vec<&Face>> = HashMap::new();
        for f in &m.faces {
            let name = f.name.as_deref().unwrap();
            let solid = name.split('.').next().unwrap();
            if [
                "wing0",
                "wing1",
                "wing2",
                "wingslab0",
                "wingslab1",
                "roofl",
                "roofr",
                "gable0",
                "gable1",
            ]
            .contains(&solid)
            {
                solids.entry(solid).or_default().push(f);
            }
        }
        assert_eq!(solids.len(), 9, "seed {seed}");
        let normal = |f: &Face| face_normal(&m, f);
        for (name, faces) in &solids {
            assert_planar_and_outward(&m, faces, &format!("seed {seed}: {name}"));
        }
        // The side walls' long faces are off every axis in plan.
        let side = normal(solids["wing0"][2]);
        assert!(
            side.z.abs() < 1e-12 && side.x.abs() > 0.03 && side.y.abs() > 0.03,
            "seed {seed}: {side}"
        );
        // The roof's top slopes at 20–40°.
        let top = normal(solids["roofl"][1]);
        let pitch = top.z.acos().to_degrees();
        assert!((20.0..=40.0).contains(&pitch), "seed {seed}: pitch {pitch}");
        let r = check(&m);
        assert!(r.count("intersect") > 0);
    }
}

/// `--stairs`: every step, landing and ramp is a closed, outward, planar
/// solid; flights and ramps both occur over a few seeds; each ramp's slope
/// meets the floor at 2.9–7.1°; the steps overlap or abut the next one.
#[test]
fn stairs_and_ramps_are_closed_solids_and_ramps_are_shallow() {
    let (mut flights, mut ramps) = (0, 0);
    for seed in 1..=12 {
        let m = without_dirt(seed, |c| c.stairs = true);
        let solids = solids(&m, |solid| {
            let kind = solid.trim_start_matches(|c: char| c != '_');
            let kind = kind.trim_start_matches(|c: char| c == '_' || c.is_ascii_digit());
            kind.starts_with("st")
                || kind.starts_with("sl")
                || kind.starts_with("ramp")
                || kind == "rl"
        });
        let normal = |f: &Face| face_normal(&m, f);
        for (name, faces) in &solids {
            assert_planar_and_outward(&m, faces, &format!("seed {seed}: {name}"));
            if name.ends_with("ramp") {
                ramps += 1;
                assert_eq!(faces.len(), 5, "{name}: a wedge");
                let slope = faces
                    .iter()
                    .map(|f| normal(f))
                    .filter(|n| n.z > 0.0)
                    .map(|n| n.z.acos().to_degrees())
                    .fold(f64::NAN, f64::max);
                assert!(
                    (2.8..=7.2).contains(&slope),
                    "seed {seed}: {name} at {slope}°"
                );
            }
            if name.ends_with("st0") {
                flights += 1;
            }
        }
    }
    assert!(
        flights >= 3 && ramps >= 3,
        "{flights} flights, {ramps} ramps"
    );
}

/// The CAD building of `seed` without flips, duplicates or jitter, with
/// `set` applied to its configuration.
fn without_dirt(seed: u64, set: impl Fn(&mut Cad)) -> Model {
    let mut cfg = Cad {
        jitter: 0.0,
        flipped: 0.0,
        duplicates: 0.0,
        ..Cad::default()
    };
    set(&mut cfg);
    cad(&cfg, seed)
}

/// The faces of each solid (the part of a face's name before its first
/// dot) whose name `keep` accepts.
fn solids(m: &Model, keep: impl Fn(&str) -> bool) -> HashMap<String, Vec<&Face>> {
    let mut out: HashMap<String, Vec<&Face>> = HashMap::new();
    for f in &m.faces {
        let solid = f.name.as_deref().unwrap().split('.').next().unwrap();
        if keep(solid) {
            out.entry(solid.to_string()).or_default().push(f);
        }
    }
    out
}

/// A face's unit normal (Newell's, over its outer contour).
fn face_normal(m: &Model, f: &Face) -> DVec3 {
    let p: Vec<DVec3> = f.contours[0].iter().map(|&v| m.pos(v)).collect();
    geom::newell_normal(&p).normalize()
}

/// The faces of one solid: each planar, and together enclosing a positive
/// volume (facing outward).
fn assert_planar_and_outward(m: &Model, faces: &[&Face], what: &str) {
    let mut vol = 0.0;
    for f in faces {
        let p: Vec<DVec3> = f.contours[0].iter().map(|&v| m.pos(v)).collect();
        let n = face_normal(m, f);
        for q in &p {
            assert!((q - p[0]).dot(n).abs() < 1e-9, "{what} not planar");
        }
        for i in 1..p.len() - 1 {
            vol += p[0].dot(p[i].cross(p[i + 1])) / 6.0;
        }
    }
    assert!(vol > 0.0, "{what} faces inward");
}

/// `--curved`: every round column, globe and pipe is a closed, outward,
/// planar solid; over a few seeds each occurs, a globe's pole lies on or
/// above its room's ceiling (touching it or pushed in), and a column
/// reaches from under the floor's top into the ceiling slab.
#[test]
fn curved_things_are_closed_solids_touching_or_crossing_what_they_meet() {
    let (mut columns, mut globes, mut pipes) = (0, 0, 0);
    for seed in 1..=8 {
        let m = without_dirt(seed, |c| c.curved = true);
        let solids = solids(&m, |solid| {
            solid.ends_with("rc") || solid.ends_with("gl") || solid.ends_with("pp")
        });
        for (name, faces) in &solids {
            assert_planar_and_outward(&m, faces, &format!("seed {seed}: {name}"));
            let zs = faces
                .iter()
                .flat_map(|f| f.contours[0].iter().map(|&v| m.pos(v).z));
            let (lo, hi) = zs.fold((f64::MAX, f64::MIN), |(a, b), z| (a.min(z), b.max(z)));
            // The room's storey, from the name `s{storey}r…`.
            let s: f64 = name[1..name.find('r').unwrap()].parse().unwrap();
            let (zf, zc) = (s * cad::STOREY, (s + 1.0) * cad::STOREY - cad::SLAB);
            if name.ends_with("rc") {
                columns += 1;
                assert!(lo <= zf && hi >= zc, "{name}: {lo}..{hi}");
            } else if name.ends_with("gl") {
                globes += 1;
                assert!(
                    hi >= zc - 1e-9 && hi <= zc + 0.05 + 1e-9,
                    "{name}: top {hi}"
                );
            } else {
                pipes += 1;
            }
        }
    }
    assert!(
        columns >= 3 && globes >= 3 && pipes >= 3,
        "{columns} columns, {globes} globes, {pipes} pipes"
    );
}
