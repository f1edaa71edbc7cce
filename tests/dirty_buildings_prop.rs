//! Issue #13's property: small dirty buildings drawn as CAD programs export
//! them (`building::cad`: box-slab walls in overlapping runs that
//! interpenetrate at every junction, walls and furniture sunk into floors,
//! openings of piers, sills, lintels and glass, running-bond tiles, rugs,
//! papers and pictures lying on other faces, rotated boxes pushed into
//! walls, vaults of twisted quads, columns with a displaced vertex, flush
//! panels and hanging light boxes, several storeys, random flips, duplicate
//! faces, vertex jitter; every fifth seed exported as triangles on vertex
//! records of their own, as STL does; a wing whose plan is sheared by an
//! arbitrary angle and a pitched roof with gables on others; stairs of
//! overlapping step boxes and ramps meeting the floor at 3–7° in every
//! other seed), over 200 seeds, and 40 more placed as CAD
//! exports place buildings on a site (turned, in millimetres, half a
//! million and four million units from the origin):
//!
//! * after the full chain (planar | group | orient | isect | copl | clean)
//!   `ugcheck` finds no defect at all (`--deny defects` would pass), both
//!   before and after ugclean's removal of enclosed faces;
//! * `ugisect` and `ugcopl` keep the area of every material (to the
//!   tolerance snapping at epsilon allows: features within epsilon of each
//!   other are merged, which moves area by up to epsilon times their length;
//!   the jitter is 1e-7 of the size);
//! * after `ugcut`, only triangles and convex quads, and no T-vertex, no
//!   degenerate patch (the chain's cleanliness survives meshing);
//! * the user's pipeline `ugvlmerge | ugisect | ugcut -l 2` gives patches
//!   only, and both it and the full chain end with `ugrad` succeeding
//!   (a few shots).
//!
//! The chain runs in process through the libraries the tools call (the
//! binaries are one call each); `tests/dirty_buildings.rs` runs the binaries.

use building::Cad;
use rayon::prelude::*;
use ug::Model;

/// The size of seed `s`'s building: one room on one storey, every fourth
/// seed two storeys, every eighth two rooms a storey; every fifth exported
/// as triangles; every third with an oblique wing and every third (another
/// third, and every sixth of the wings) with a pitched roof.
/// (`UG_CAD=X,Y,S` sets rooms along x and y and storeys for every seed,
/// Every even seed has stairs and ramps, except the regression seeds
/// ([`AS_FOUND`]), which stay the models their bugs were found in; every
/// seventh (3 mod 7, not a regression seed) round columns, globe lamps
/// and pipes (`Cad::curved`).
/// `UG_TRIANGLES=1` exports every seed as triangles, `UG_OBLIQUE=1`
/// gives every seed the wing and the roof, `UG_STAIRS=1` stairs and
/// ramps (`UG_STAIRS=0` none) and `UG_CURVED=1` the curved things
/// (`UG_CURVED=0` none): for [`more_seeds`] by hand.)
fn config(seed: u64) -> Cad {
    let cfg = size(seed);
    let env = |k: &str| std::env::var(k).is_ok_and(|v| v == "1");
    Cad {
        triangles: seed % 5 == 2 || env("UG_TRIANGLES"),
        wing: seed % 3 == 1 || env("UG_OBLIQUE") || FOUND_OBLIQUE.contains(&seed),
        pitched: seed % 3 == 2
            || seed % 6 == 1
            || env("UG_OBLIQUE")
            || FOUND_OBLIQUE.contains(&seed),
        curved: match std::env::var("UG_CURVED").as_deref() {
            Ok("1") => true,
            Ok("0") => false,
            _ => {
                (seed % 7 == 3 && !found(seed))
                    || FOUND_CURVED.contains(&seed)
                    || FOUND_CURVED_WITH_STAIRS.contains(&seed)
            }
        },
        stairs: match std::env::var("UG_STAIRS").as_deref() {
            Ok("1") => true,
            Ok("0") => false,
            _ => {
                (seed.is_multiple_of(2)
                    && !AS_FOUND.contains(&seed)
                    && !FOUND_CURVED.contains(&seed))
                    || FOUND_WITH_STAIRS.contains(&seed)
                    || FOUND_CURVED_WITH_STAIRS.contains(&seed)
            }
        },
        ..cfg
    }
}

/// Whether seed `s` is a regression seed found before the curved things
/// were added (drawn without them).
fn found(s: u64) -> bool {
    AS_FOUND.contains(&s) || FOUND_WITH_STAIRS.contains(&s) || FOUND_LARGER.contains(&s)
}

/// Seeds that once failed, drawn as they were then (without the stairs
/// and ramps added since): [`dirty_buildings_regression_seeds`] and the
/// placed 1326. [`FOUND_WITH_STAIRS`] failed with stairs and ramps.
const AS_FOUND: [u64; 22] = [
    228, 326, 367, 556, 573, 856, 1042, 1326, 1693, 5731, 10015, 10354, 11293, 11335, 11822, 11847,
    11884, 13174, 13285, 13621, 13847, 15361,
];

/// Seeds that once failed with stairs and ramps (found over 2000..2800):
/// 2012 and 2615, a ramp's slope through a furniture box's bottom at 4°,
/// the box's piece wrapping round the ramp's side so that neither face
/// lay on one side of the other, and the planes' line 1.4 epsilon off
/// the edge they share; 2664, a ramp meeting its landing at 4.2°, whose
/// snapped shared vertices lie 5.7 epsilon off one line (an intersecting
/// pair while the line through them needed 4 epsilon).
/// 3327 (found over 3000..3800, a triangle export on 2 storeys): a
/// ramp's needle piece 1.02 epsilon wide on a floor piece's reflex corner,
/// whose patch edges passed within epsilon of the needle's far corner (2
/// T-vertices after ugcut; fixtures/cut/ramp-needle-at-a-floor-corner.ug).
/// 9742 (a triangle export with a wing, as drawn; it had kept an
/// inconsistent edge with `--keep-enclosed`, later resolved): 2 overlapping
/// pairs after ugcut, a facade sliver's corner joined to the farther end
/// of its two short edges (1.73 epsilon, not 1.17), across the other
/// facade's strip lying on it (ugcut now joins the nearest).
const FOUND_WITH_STAIRS: [u64; 5] = [2012, 2615, 2664, 3327, 9742];

/// Seeds that once failed on a building of 3 × 2 rooms on 2 storeys with
/// stairs and ramps (`UG_CAD=3,2,2` over 8600..8700), drawn so here:
/// 8666, a ramp at 6.4° sharing a zigzag edge with tiles, one joint's
/// foot on the planes' line inside the ramp (an intersecting pair that
/// ugisect did not cut); 8628, a T-vertex after ugcopl on the base of a
/// wall's sliver 1.8 epsilon wide, which the welder took as without area.
const FOUND_LARGER: [u64; 3] = [8627, 8628, 8666];

/// Seeds that once failed with the curved things (drawn with them, and
/// without stairs):
/// 9033, a globe's pole resting on a ceiling piece (a touch, nothing to
/// cut) that a patch edge of the ceiling passed through: a T-vertex after
/// ugcut (fixtures/cut/cone-apex-on-a-ceiling.ug; the mesher now takes
/// such resting vertices as patch corners).
/// 27265 (found over 27000..27300, a wing and a roof): an intersecting
/// pair after the chain once ugisect cut through the vertices on the
/// other plane at steep angles: a roof piece at 20° sharing a slab's eave
/// edge, the planes' line 1.08 epsilon inside both (the middle of a
/// stretch between vertices is now taken between them).
/// 13674 (found over 13000..14000, one room): an overlapping pair after
/// ugcut, a pipe's face ending on a globe in a corner of 24°, whose end
/// edge's triangle with a foot on the long side lay on the globe's patch
/// (fixtures/cut/pipe-corner-on-a-globe.ug; no foot across a corner from
/// its short edge now).
const FOUND_CURVED: [u64; 3] = [9033, 13674, 27265];

/// Seeds that once failed with the curved things and stairs and ramps
/// (drawn with both): 25191 (found over 25000..25200, 2 storeys), a ramp
/// piece folded back under a floor slab at 3.3° along the edge they
/// share, whose triangle on that edge had its apex 1.27 epsilon from it:
/// an overlapping pair after ugcut (fixtures/cut/ramp-folded-under-a-slab.ug;
/// the mesher now puts a point far enough across such an edge).
/// 8627 (3 × 2 rooms on 2 storeys, a triangle export, also in
/// [`FOUND_LARGER`]): 4 intersecting pairs after the chain, a pipe's
/// facet through a pier and the lintel beside it at 11°, whose crossing
/// of their shared edge two pairs found 1.05 epsilon apart (an end of a
/// cut segment now reuses a vertex within 2 epsilon on both planes).
/// 42050 (found over 42000..42200 with `UG_CURVED=1`, one room, a
/// pitched roof): 2 overlapping pairs after ugcut, a globe's facets
/// hanging from the ceiling at 24°, whose cut lines met a light panel's
/// edge; a foot on that edge 4.6 epsilon from the corner made a triangle
/// lying on the facet's patch (fixtures/cut/globe-facet-at-a-panel-corner.ug;
/// no foot across a corner from an edge folded at a small angle now).
/// 71131, one overlapping pair after the chain: a slab's end piece 1.2
/// epsilon wide on a facade, its plane ill-defined, overlapped the facade
/// when measured in the facade's plane and not in its own, so ugcheck's
/// verdict hung on which face came first and ugclean's check of its moves
/// missed it (both faces are measured in the larger one's plane now).
const FOUND_CURVED_WITH_STAIRS: [u64; 4] = [25191, 8627, 42050, 71131];

/// Seeds that once failed on a building of 3 × 2 rooms on 2 storeys,
/// placed ([`place`]; `UG_CAD=3,2,2 UG_PLACED=1` over 2000..2140): 2010,
/// a T-vertex after the chain where a ramp's and a railing's coincident
/// pieces were cornered 1 epsilon either side of a desk side's ledge 2
/// epsilon long, whose ends lay within epsilon of the segment between
/// the two corners (the edge split cannot take both: one goes in now);
/// 2074, two intersecting pairs after the chain, a column's and a desk's
/// faces sunk into a floor slab at 0.55° to each other, cut and meeting
/// again in each of ugisect's rounds until the sixth (at most 4 before);
/// 2198, two overlapping pairs after the chain, a pier's top 1.5 epsilon
/// above a slab's underside, back to back with it on the same outline,
/// moved by ugclean onto a removed twin's records 1–2 epsilon off in plan
/// (a move that makes a pair overlap is not taken now).
const FOUND_PLACED_LARGER: [u64; 3] = [2010, 2074, 2198];

/// Seeds that once failed with the wing and the roof on every building
/// (`UG_OBLIQUE=1`), drawn so here: 77213 (found over 77000..77300, with
/// the curved things), an intersecting pair after ugcut, a pendant
/// light's cone facet and a triangle of its stem's face whose chord
/// through the facet's plane fanned 2.5 epsilon out of their shared
/// corner (a touch now: `geom::intersect::corner_fan`).
const FOUND_OBLIQUE: [u64; 1] = [77213];

fn size(seed: u64) -> Cad {
    if FOUND_LARGER.contains(&seed) || FOUND_PLACED_LARGER.contains(&seed) {
        return Cad {
            rooms_x: 3,
            rooms_y: 2,
            storeys: 2,
            ..Cad::default()
        };
    }
    if let Ok(v) = std::env::var("UG_CAD") {
        let n: Vec<usize> = v
            .split(',')
            .map(|x| x.parse().expect("UG_CAD is X,Y,S"))
            .collect();
        assert_eq!(n.len(), 3, "UG_CAD is X,Y,S");
        return Cad {
            rooms_x: n[0],
            rooms_y: n[1],
            storeys: n[2],
            ..Cad::default()
        };
    }
    Cad {
        storeys: 1 + usize::from(seed % 4 == 3),
        rooms_x: 1 + usize::from(seed % 8 == 5),
        rooms_y: 1,
        ..Cad::default()
    }
}

/// Area and boundary length per material (the faces are planar here:
/// after ugplanar).
fn areas(m: &Model) -> Vec<(String, (f64, f64))> {
    let mut a = vec![(0.0, 0.0); m.materials.len() + 1];
    for f in m.top_faces() {
        let face = &m.faces[f.idx()];
        let pts: Vec<Vec<glam::DVec3>> = face
            .contours
            .iter()
            .map(|c| c.iter().map(|&v| m.pos(v)).collect())
            .collect();
        let perimeter: f64 = pts
            .iter()
            .flat_map(|c| (0..c.len()).map(|i| (c[i] - c[(i + 1) % c.len()]).length()))
            .sum();
        let e = &mut a[face.material.map_or(m.materials.len(), |x| x.idx())];
        e.0 += geom::face_area(&pts).abs();
        e.1 += perimeter;
    }
    m.materials
        .iter()
        .map(|x| x.name.clone())
        .chain(["(none)".to_string()])
        .zip(a)
        .collect()
}

fn defects(r: &check::Report) -> String {
    check::DEFECTS
        .iter()
        .filter(|c| r.count(c) > 0)
        .map(|c| format!("{c} {}", r.count(c)))
        .collect::<Vec<_>>()
        .join(", ")
}

fn shoot(m: &Model, eps: f64) -> Result<(), String> {
    let mesh = libmesh::Mesh::from_model(m, eps).map_err(|e| e.to_string())?;
    let vis = radiosity::RayVisibility::new(&mesh);
    // Two shots, without refinement: the point is that ugrad takes the
    // model and lights it.
    let opts = radiosity::Options {
        max_shots: Some(2),
        tail: 0.0,
        min_edge: Some(f64::MAX),
        penumbra_size: Some(f64::MAX),
        ..radiosity::Options::default()
    };
    let mut solver = radiosity::Solver::new(mesh, &m.materials, &vis, opts);
    let stop = solver.solve(None, |_| {});
    if matches!(stop, radiosity::Stop::Dark) {
        return Err("nothing emits".into());
    }
    if solver.shots.is_empty() {
        return Err("no shot".into());
    }
    Ok(())
}

/// How seed `s`'s building is placed when [`placed`]: turned about the
/// vertical by an angle of its own (so no wall lies along an axis), in
/// millimetres every other seed, and far from the origin (site
/// coordinates: half a million and four million units east and north).
/// The scale, for the lengths given to ugcut.
fn place(m: &mut Model, seed: u64) -> f64 {
    let angle = ((seed * 37) % 360) as f64 + 0.123;
    let scale = if seed.is_multiple_of(2) { 1000.0 } else { 1.0 };
    let (s, c) = angle.to_radians().sin_cos();
    let offset = glam::DVec3::new(512_345.6, 4_187_654.3, 120.5) * scale;
    for v in &mut m.vertices {
        let p = v.pos * scale;
        v.pos = glam::DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z) + offset;
    }
    scale
}

/// Turns the building about an axis no face is aligned with (by a
/// seed-dependent angle): no floor is level and no wall upright, so no
/// coordinate comparison decides anything by luck of the axes
/// (`UG_TILT=1`, by hand).
fn tilt(m: &mut Model, seed: u64) {
    let axis = glam::DVec3::new(0.31, 0.52, 0.79).normalize();
    let angle = (7.0 + (seed * 53 % 300) as f64 * 0.17).to_radians();
    let q = glam::DQuat::from_axis_angle(axis, angle);
    for v in &mut m.vertices {
        v.pos = q * v.pos;
    }
}

/// The same building written in another order (`UG_SHUFFLE=1`, by hand):
/// vertices and faces in a seed-dependent order, vertices renamed, every
/// contour started at another of its corners. What the tools decide must
/// not rest on the order a CAD program happened to write.
fn shuffle(m: &Model, seed: u64) -> Model {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut m = m.clone();
    let (mut verts, mut faces, mut rest) = (Vec::new(), Vec::new(), Vec::new());
    for it in m.items.drain(..) {
        match it {
            ug::Item::Vertex(_) => verts.push(it),
            ug::Item::Face(_) => faces.push(it),
            _ => rest.push(it),
        }
    }
    for list in [&mut verts, &mut faces] {
        for i in (1..list.len()).rev() {
            let j = (next() % (i as u64 + 1)) as usize;
            list.swap(i, j);
        }
    }
    for (k, it) in verts.iter().enumerate() {
        if let ug::Item::Vertex(v) = it {
            m.vertices[v.idx()].name = format!("s{k}");
        }
    }
    for f in &mut m.faces {
        for c in &mut f.contours {
            let n = c.len();
            c.rotate_left((next() % n as u64) as usize);
        }
    }
    m.items = rest.into_iter().chain(verts).chain(faces).collect();
    ug::parse(ug::write_string(&m).as_bytes(), "shuffled")
        .expect("a shuffled model reads back")
        .model
}

/// How a seed's building is moved before the chain.
#[derive(Clone, Copy, Debug, Default)]
struct Moves {
    /// Far from the origin, turned, perhaps in millimetres ([`place`]).
    placed: bool,
    /// Turned about an oblique axis ([`tilt`]).
    tilted: bool,
    /// Written in another order ([`shuffle`]).
    shuffled: bool,
    /// Every coordinate rounded to this many decimals, last (`UG_ROUND=K`,
    /// by hand): an export written with a fixed precision (Revit writes
    /// metres to 4 decimals). With [`tilt`] the rounding bends faces, and
    /// the tools take the precision as their epsilon (`cli::epsilon`).
    rounded: Option<i32>,
}

/// Everything the issue asks of one seed, the building moved as `moves`
/// says first; the problems found, if any.
fn one_moved(seed: u64, moves: Moves) -> Vec<String> {
    let mut problems = Vec::new();
    let mut m = building::cad(&config(seed), seed);
    let scale = if moves.placed {
        place(&mut m, seed)
    } else {
        1.0
    };
    if moves.tilted {
        tilt(&mut m, seed);
    }
    if moves.shuffled {
        m = shuffle(&m, seed);
    }
    if let Some(k) = moves.rounded {
        let scale = 10f64.powi(k);
        for v in &mut m.vertices {
            v.pos = (v.pos * scale).round() / scale;
        }
    }
    // (`UG_DUMP=DIR` writes each seed's model, as moved, to DIR/SEED.ug:
    // to run the tools on it by hand.)
    if let Ok(dir) = std::env::var("UG_DUMP") {
        std::fs::write(format!("{dir}/{seed}.ug"), ug::write_string(&m)).expect("UG_DUMP");
    }
    // (`UG_EPS_SCALE=K` multiplies the default epsilon by K: a user's
    // larger tolerance, for `more_seeds` by hand.)
    let scale_eps = std::env::var("UG_EPS_SCALE")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(1.0);
    let eps = cli::epsilon(None, &m) * scale_eps;
    let (planar, _) = clean::planar::planarize(&m, eps);
    let (grouped, _) =
        clean::group::vlmerge(planar, &clean::group::Options::new(eps)).expect("grouped");
    let opts = clean::orient::Options {
        eps,
        ..clean::orient::Options::default()
    };
    let (oriented, _) = clean::orient::orient(grouped.clone(), &opts).expect("oriented");
    let (cut, _) = clean::isect::isect(&oriented, eps).expect("isect");
    let (copl, _) = clean::copl::copl(&cut, eps).expect("copl");
    // (With `UG_DUMP=DIR`, the chain's stages too, as DIR/SEED.STAGE.ug,
    // to run the next tool's binary on what the library calls made.)
    if let Ok(dir) = std::env::var("UG_DUMP") {
        for (stage, model) in [
            ("grouped", &grouped),
            ("oriented", &oriented),
            ("isect", &cut),
            ("copl", &copl),
        ] {
            std::fs::write(format!("{dir}/{seed}.{stage}.ug"), ug::write_string(model))
                .expect("UG_DUMP");
        }
    }
    // ugclean's steps with the enclosed faces kept, then all of them:
    // no defect either way.
    let report = check::check(&clean::clean(&copl, eps, true).0, eps);
    if report.defects() > 0 {
        problems.push(format!(
            "chain to the coincident faces: {}",
            defects(&report)
        ));
    }
    let (cleaned, _) = clean::clean(&copl, eps, false);
    let report = check::check(&cleaned, eps);
    if report.defects() > 0 {
        problems.push(format!("chain: {}", defects(&report)));
    }
    // ugisect and ugcopl keep area per material, up to what snapping at
    // epsilon may move: each boundary point moves by at most epsilon, so
    // the area by at most epsilon times the boundary length (the input's:
    // the cuts' own edges are shared by two pieces of the same material
    // and move nothing in total).
    let (before, after) = (areas(&oriented), areas(&copl));
    for ((name, (a, perimeter)), (name2, (b, _))) in before.iter().zip(&after) {
        let tol = eps * perimeter + 1e-12 * a;
        if name != name2 || (a - b).abs() > tol {
            problems.push(format!("area of {name}: {a} -> {b} ({name2})"));
        }
    }
    // ugcut: patches only, still clean.
    let popts = |len: f64| libmesh::patch::Options {
        len,
        eps,
        angle: 25.0,
        quads: true,
    };
    match libmesh::patch::cut(&cleaned, popts(0.7 * scale)) {
        Err(e) => problems.push(format!("ugcut: {e}")),
        Ok((patches, st)) => {
            replayed_as_meshed(&cleaned, popts(0.7 * scale), &patches, &st, &mut problems);
            let r = check::check(&patches, eps);
            for cat in ["nonpatch", "tvertex", "degenerate", "intersect", "overlap"] {
                if r.count(cat) > 0 {
                    problems.push(format!("after ugcut: {cat} {}", r.count(cat)));
                }
            }
            if let Err(e) = shoot(&patches, eps) {
                problems.push(format!("ugrad after the chain: {e}"));
            }
        }
    }
    // The user's pipeline: ugvlmerge | ugisect | ugcut -l 2 | ugrad.
    let (g, _) = clean::group::vlmerge(m.clone(), &clean::group::Options::new(eps)).unwrap();
    let (i, _) = clean::isect::isect(&g, eps).unwrap();
    match libmesh::patch::cut(&i, popts(2.0 * scale)) {
        Err(e) => problems.push(format!("user pipeline ugcut: {e}")),
        Ok((patches, st)) => {
            replayed_as_meshed(&i, popts(2.0 * scale), &patches, &st, &mut problems);
            let r = check::check(&patches, eps);
            if r.count("nonpatch") > 0 {
                problems.push(format!("user pipeline: nonpatch {}", r.count("nonpatch")));
            }
            if let Err(e) = shoot(&patches, eps) {
                problems.push(format!("user pipeline ugrad: {e}"));
            }
        }
    }
    problems
}

/// Where ugcut met joins and meshed again, replaying the faces they did
/// not reach: the same output as meshing them all again.
fn replayed_as_meshed(
    m: &Model,
    opts: libmesh::patch::Options,
    out: &Model,
    st: &libmesh::patch::Stats,
    problems: &mut Vec<String>,
) {
    if st.joined == 0 {
        return;
    }
    match libmesh::patch::cut_without_reuse(m, opts) {
        Ok((fresh, _)) if ug::write_string(&fresh) == ug::write_string(out) => {}
        Ok(_) => problems.push(format!(
            "ugcut -l {}: replaying {} faces gave another output than meshing them again",
            opts.len, st.replayed
        )),
        Err(e) => problems.push(format!("ugcut without replay: {e}")),
    }
}

fn run(seeds: Vec<u64>) {
    run_moved(seeds, Moves::default())
}

fn run_moved(seeds: Vec<u64>, moves: Moves) {
    let bad: Vec<String> = seeds
        .into_par_iter()
        .map(|s| (s, one_moved(s, moves)))
        .filter(|(_, p)| !p.is_empty())
        .map(|(s, p)| format!("seed {s} ({:?}): {}", config(s), p.join("; ")))
        .collect();
    assert!(
        bad.is_empty(),
        "{} seeds failed:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn dirty_buildings_seeds_0_to_49() {
    run((0..50).collect());
}

#[test]
fn dirty_buildings_seeds_50_to_99() {
    run((50..100).collect());
}

#[test]
fn dirty_buildings_seeds_100_to_149() {
    run((100..150).collect());
}

#[test]
fn dirty_buildings_seeds_150_to_199() {
    run((150..200).collect());
}

/// Seeds beyond the 200 above that failed once (found with `more_seeds`
/// over 200..600):
/// * 228, 556: a slab's side face flipped by the generator stayed inward
///   (the slab's top, whose edges the walls standing flush on it make
///   non-manifold, was a component apart from the open tray of the rest,
///   which the vote turned inside out), against the wall face flush with it;
/// * 326, 573: T-vertices after ugcut where a pier's end face, tilted by
///   the weld across a strip 1.3 epsilon wide, leaves a vertex nearly along
///   the strip's side (fixtures/cut/tilted-end.ug);
/// * 367: a wall's end about 2 epsilon in front of the facade, its piece
///   tilted onto the slab's vertices across the strip between, then pieces
///   of the two coplanar only after ugcut
///   (fixtures/copl/wall-end-past-slab.ug);
/// * 5731 (found over 5000..6000): three T-vertices after ugclean's
///   coincident step, a wall bottom 1.8 epsilon under a tiled floor tilted
///   onto it when a coincident pair's records were shared
///   (fixtures/clean/tilted-wall-bottom-over-tiles.ug);
/// * 11884 (found over 10000..12000): three coincident pairs after
///   ugclean, made coincident by the records its pairs shared (ugclean's
///   coincident step now runs again while sharing records finds new pairs);
/// * 11847 (found over 10000..12000): one intersecting pair from ugisect
///   on, a table leg resting on a column face tilted by 0.4°, the two
///   sharing an edge, which the planes' line put 2 epsilon inside both
///   (fixtures/check/leg-on-tilted-column.ug);
/// * 10015, 10354, 11293, 11335, 11822: failed with the first fix of
///   11847, which took the resting face's line at every angle (a wing's
///   side resting on a wall end at 56° while the end poked 3 epsilon
///   through it: the end was cut along the side's edge, not where the
///   side's plane crosses it);
/// * 1693 (found over 200..2000): a desk bottom's piece non-planar by 1.3
///   epsilon after ugclean's coincident step, which gave it three of its
///   twin's corners once two others were vetoed
///   (fixtures/clean/vetoed-corners-bend-a-desk-bottom.ug);
/// * 1042 (found over 200..1200): two intersecting pairs after ugcopl, a
///   wing's wall standing 1.5 epsilon through a ceiling piece that ugcopl
///   cut with a corner in its own plane below the wall's top corner
///   (fixtures/copl/wall-through-a-ceiling-cut-below-its-top.ug; ugcopl
///   now cuts the pairs its cuts make intersect);
/// * 856 (found over 200..1200): one inconsistently oriented edge after
///   ugclean's coincident step, a wing wall's end 1.1 epsilon past the
///   other's, whose end pieces were coincident and the one kept lacked a
///   corner the removed ones named
///   (fixtures/clean/end-piece-missing-a-corner.ug; the kept face now
///   takes such a twin's contour);
/// * 13285 (found over 13000..14000): 3 T-vertices after ugcut, fixed with
///   3327 ([`FOUND_WITH_STAIRS`]: a vertex just beyond epsilon of a
///   corner joins it);
/// * 13621 (found over 13000..14000): a T-vertex and a degenerate patch
///   after ugcut, a wall's end strip 1.7 to 2.6 epsilon wide divided on
///   one side only (fixtures/cut/wall-end-strip-divided-on-one-side.ug;
///   neither side of such a strip is divided now);
/// * 13847 (found over 13000..14000, a triangle export): one inconsistent
///   edge after ugclean, whose enclosed step removed the one face walking
///   an edge the other way from the two left on it (such a face now
///   stays);
/// * 13174 (found over 13000..14000, plain): one inconsistent edge after
///   ugclean's coincident step, two coincident end pieces on records
///   about 2 epsilon apart that sharing could not join
///   (fixtures/clean/end-piece-on-records-of-its-own.ug; the kept piece
///   now takes the removed one's contour where that leaves fewer such
///   edges);
/// * 15361 (found over 15000..15400, plain, a wing and a roof): 3
///   intersecting pairs after the chain, a wing slab's side face under a
///   floor slab whose top edge zigzags through tile corners 1.05 epsilon
///   either side of the floor's edge; the floor was cut along the planes'
///   line, leaving the corners inside it (`cut_segments` now cuts at a
///   steep angle through such vertices themselves).
#[test]
fn dirty_buildings_regression_seeds() {
    let mut seeds: Vec<u64> = AS_FOUND
        .iter()
        .chain(&FOUND_WITH_STAIRS)
        .chain(&FOUND_LARGER)
        .chain(&FOUND_CURVED)
        .chain(&FOUND_CURVED_WITH_STAIRS)
        .chain(&FOUND_OBLIQUE)
        .copied()
        .filter(|&s| s != 1326)
        .collect();
    seeds.sort_unstable();
    seeds.dedup();
    run(seeds);
}

/// Buildings as CAD exports place them on a site ([`place`]): turned by
/// angles of their own, half of them in millimetres, far from the origin.
/// Seed 1175 had a table leg turned inside out by ugflip (its signed
/// volume taken from the origin, 4·10⁶ m away, and decided by rounding);
/// 2499 a triangle of area under ε² from ugcut, 1326 two overlapping
/// coplanar pairs after ugcut (a column face and a table leg's crossing
/// it at 1.7°; clean since ugcut's sliver tests take the area, which
/// meshes the faces along the crossing otherwise); 3871 a needle on a
/// step of 4 epsilon after ugcut; [`FOUND_PLACED_LARGER`].
#[test]
fn dirty_buildings_placed_on_a_site() {
    run_moved(
        (1160..1200)
            .chain([1326, 2499, 3871])
            .chain(FOUND_PLACED_LARGER)
            .collect(),
        Moves {
            placed: true,
            ..Moves::default()
        },
    );
}

/// More seeds by hand: `UG_SEEDS=200..1200 cargo test --release --test
/// dirty_buildings_prop -- --ignored more_seeds` (default 200..400); with
/// `UG_CAD=3,2,2` every seed is a building of 3 × 2 rooms on 2 storeys,
/// with `UG_PLACED=1` every building placed as [`place`] does; with
/// `UG_EPS_SCALE=K` every tool and check uses K times the default epsilon,
/// with `UG_TILT=1` every building turned about an oblique axis ([`tilt`]),
/// with `UG_SHUFFLE=1` written in another order ([`shuffle`]), with
/// `UG_ROUND=K` every coordinate rounded to K decimals last; `UG_DUMP=DIR`
/// writes each seed's model, as moved, to DIR/SEED.ug, and the chain's
/// stages to DIR/SEED.STAGE.ug.
#[test]
#[ignore]
fn more_seeds() {
    let range = std::env::var("UG_SEEDS").unwrap_or_else(|_| "200..400".into());
    let (a, b) = range.split_once("..").expect("UG_SEEDS is A..B");
    let on = |k: &str| std::env::var(k).is_ok_and(|v| v == "1");
    run_moved(
        (a.parse().expect("A")..b.parse().expect("B")).collect(),
        Moves {
            placed: on("UG_PLACED"),
            tilted: on("UG_TILT"),
            shuffled: on("UG_SHUFFLE"),
            rounded: std::env::var("UG_ROUND").ok().and_then(|k| k.parse().ok()),
        },
    );
}

/// Buildings turned about an oblique axis (no floor level, no wall
/// upright: no decision rests on the axes) and written in another order
/// (vertices renamed, faces and vertices reordered, contours started at
/// another corner: no decision rests on the order a CAD program wrote).
/// When this was added, 1,360 seeds passed so by hand (tilted or
/// shuffled or both, with every kind of dirt, triangles, stairs, curved
/// things, a 10× epsilon); of 60 seeds of 3 × 2 rooms on 2 storeys,
/// placed, tilted and shuffled, two failed: 2010, which failed placed
/// alone too ([`FOUND_PLACED_LARGER`]; docs/decisions.md, "An edge split
/// that would zig-zag takes only some of its vertices"), and 2020 (with
/// `--keep-enclosed` only).
#[test]
fn dirty_buildings_tilted_and_shuffled() {
    run_moved(
        (1200..1216).collect(),
        Moves {
            tilted: true,
            shuffled: true,
            ..Moves::default()
        },
    );
}

/// Exports with a fixed precision: every coordinate rounded to 4 decimals
/// (metres to 0.1 mm, as Revit writes them), 5, 3 or 2, the buildings not
/// turned (walls turned in the plan only where a wing is). Before the
/// precision epsilon took flat oblique faces into account and became 2.1
/// times the precision (docs/decisions.md, "A rounded export's epsilon"),
/// 53 of 1,150 seeds at 4 decimals and 13 of 400 at 5 failed; the seeds
/// after the ranges are some of those. 180121 at 4 decimals: a column's
/// corner sunk into the floor, cut 1.2 epsilon from the folds either side
/// (a tent's tip joins the corner's point, which keeps both sides flat).
#[test]
fn dirty_buildings_rounded() {
    run_moved(
        (1216..1236)
            .chain([125074, 130044, 130048, 150007, 150022, 160007, 180121])
            .collect(),
        Moves {
            rounded: Some(4),
            ..Moves::default()
        },
    );
    run_moved(
        (1236..1246).chain([174022, 174112, 174172]).collect(),
        Moves {
            rounded: Some(5),
            ..Moves::default()
        },
    );
    // To millimetres (epsilon 2.1 mm on buildings of about 7.5 m, where
    // the generator's dirt is 1 to 30 mm): 170098, a pier's edge 0.998
    // epsilon in front of an oblique facade (geom::intersect's edges lying
    // in a face's plane), and 170320, a pipe on a globe's cap at 23°,
    // which that rule broke below 30°; 170842, an edge 2.4 epsilon long on
    // a neck 1.1 epsilon wide (ugcut's joins under 3 epsilon); 170770,
    // running-bond tiles overlapping off their seams (ugvlmerge's groups);
    // 170539, a kept face that took its twin's contour and spoiled an
    // edge (ugclean's reshape only where no edge is spoiled); 170817,
    // globes' cap facets leaving the ceiling at a shallow angle, whose
    // band ugcut's ceiling triangles lay in (55 overlapping pairs before
    // libmesh::patch::shallow); 170565, a pipe facet ending on a column
    // folded back onto it at 24°, a foot in the fold's band (ugcut's
    // feet beside a fold); 170449, a slab's corner 2 mm from a wall's,
    // joined the way that tilted the slab through the facade (ugcut's
    // joins turned round).
    run_moved(
        (1246..1256)
            .chain([
                170098, 170320, 170842, 170770, 170539, 170817, 170565, 170449,
            ])
            .collect(),
        Moves {
            rounded: Some(3),
            ..Moves::default()
        },
    );
    // To whole centimetres (most such seeds still fail: `benches/sweeps.sh
    // cm`): 500307, 500322 and 500382, parts ugflip oriented apart (a
    // slab's side whose corners rounded a centimetre off the floor's) that
    // the cuts then joined along edges both walk the same way (ugclean's
    // last step, `clean::orient::agree`).
    run_moved(
        vec![500307, 500322, 500382],
        Moves {
            rounded: Some(2),
            ..Moves::default()
        },
    );
}
