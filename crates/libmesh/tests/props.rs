//! Property tests: random splits on random small patch models keep the mesh
//! balanced, anchored and stitched, keep areas, and give `ugcheck`-clean output.

use std::fmt::Write as _;

use glam::DVec3;
use libmesh::{ElemId, Mesh, PatchId, Split, SurfaceId};
use proptest::prelude::*;

const EPS: f64 = 1e-9;

/// Text of a model, built point by point.
#[derive(Default)]
struct Ug {
    s: String,
    n: usize,
}

impl Ug {
    fn v(&mut self, p: DVec3) -> String {
        self.n += 1;
        let name = format!("v{}", self.n);
        let _ = writeln!(self.s, "v {name} {} {} {};", p.x, p.y, p.z);
        name
    }
    fn f(&mut self, vs: &[&String], mat: &str) {
        let _ = writeln!(
            self.s,
            "f ({}) {mat};",
            vs.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(" ")
        );
    }
}

/// A grid of `nx` × `ny` cells on the plane spanned by `u`, `v` from `o`; a
/// cell is a quad or (when its bit in `tris` is set) two triangles. `shared`
/// gives the names of the row j = 0 (to glue two grids along an edge).
#[allow(clippy::too_many_arguments)]
fn grid(
    ug: &mut Ug,
    o: DVec3,
    u: DVec3,
    v: DVec3,
    nx: usize,
    ny: usize,
    tris: u64,
    shared: Option<&[String]>,
    mat: &str,
) -> Vec<Vec<String>> {
    let mut names = vec![vec![String::new(); nx + 1]; ny + 1];
    for (j, row) in names.iter_mut().enumerate() {
        for (i, name) in row.iter_mut().enumerate() {
            *name = match (j, shared) {
                (0, Some(s)) => s[i].clone(),
                _ => ug.v(o + u * i as f64 + v * j as f64),
            };
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (
                &names[j][i],
                &names[j][i + 1],
                &names[j + 1][i + 1],
                &names[j + 1][i],
            );
            if tris >> ((j * nx + i) % 64) & 1 == 1 {
                if (i + j) % 2 == 0 {
                    ug.f(&[a, b, c], mat);
                    ug.f(&[a, c, d], mat);
                } else {
                    ug.f(&[a, b, d], mat);
                    ug.f(&[b, c, d], mat);
                }
            } else {
                ug.f(&[a, b, c, d], mat);
            }
        }
    }
    names
}

const HEAD: &str = "c_rgb grey 0.5 0.5 0.5;\nc_rgb red 0.8 0.1 0.1;\n";

/// The model kinds the properties run on.
#[derive(Clone, Debug)]
enum Kind {
    /// A flat grid of quads and triangles (skewed a little: non-rectangular quads).
    Grid {
        nx: usize,
        ny: usize,
        tris: u64,
        skew: f64,
    },
    /// An L-shaped surface of quads.
    LShape { n: usize },
    /// A floor grid and a wall grid sharing an edge at an angle (degrees).
    Angle {
        n: usize,
        ny: usize,
        tris: u64,
        angle: f64,
        two_materials: bool,
    },
    /// A closed box of six 2 × 2 surfaces (three surfaces meet at each corner).
    Box,
    /// A vertical wall (one or both sides) standing on the middle line of an
    /// `n` × 2 floor: three or four patches share each edge there.
    Fin { n: usize, tris: u64, double: bool },
}

fn model(kind: &Kind) -> ug::Model {
    let mut ug = Ug {
        s: HEAD.to_string(),
        n: 0,
    };
    match *kind {
        Kind::Grid { nx, ny, tris, skew } => {
            grid(
                &mut ug,
                DVec3::ZERO,
                DVec3::X,
                DVec3::new(skew, 1.0, 0.0),
                nx,
                ny,
                tris,
                None,
                "grey",
            );
        }
        Kind::LShape { n } => {
            // Cells of a 2n × 2n square minus the top-right n × n quadrant.
            let mut names = vec![vec![String::new(); 2 * n + 1]; 2 * n + 1];
            for (j, row) in names.iter_mut().enumerate() {
                for (i, name) in row.iter_mut().enumerate() {
                    if i <= n || j <= n {
                        *name = ug.v(DVec3::new(i as f64, j as f64, 0.0));
                    }
                }
            }
            for j in 0..2 * n {
                for i in 0..2 * n {
                    if i >= n && j >= n {
                        continue;
                    }
                    let (a, b, c, d) = (
                        &names[j][i],
                        &names[j][i + 1],
                        &names[j + 1][i + 1],
                        &names[j + 1][i],
                    );
                    ug.f(&[a, b, c, d], "grey");
                }
            }
        }
        Kind::Angle {
            n,
            ny,
            tris,
            angle,
            two_materials,
        } => {
            let floor = grid(
                &mut ug,
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                n,
                ny,
                tris,
                None,
                "grey",
            );
            // The wall rises from the floor's y = 0 edge, leaning by `angle`
            // from the floor (90: vertical); it faces the floor's side.
            let a = angle.to_radians();
            let up = DVec3::new(0.0, a.cos(), a.sin());
            let mat = if two_materials { "red" } else { "grey" };
            // Wall cells built from the shared row, walking x backwards so the
            // wall's front faces the room.
            let rev: Vec<String> = floor[0].iter().rev().cloned().collect();
            grid(
                &mut ug,
                DVec3::new(n as f64, 0.0, 0.0),
                -DVec3::X,
                up,
                n,
                2,
                tris.rotate_left(7),
                Some(&rev),
                mat,
            );
        }
        Kind::Fin { n, tris, double } => {
            let floor = grid(
                &mut ug,
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                n,
                2,
                tris,
                None,
                "grey",
            );
            // Front side facing -y (cells walk x forwards from the middle row).
            let wall = grid(
                &mut ug,
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::X,
                DVec3::Z,
                n,
                1,
                tris.rotate_left(3),
                Some(&floor[1]),
                "grey",
            );
            if double {
                // The back side: the same vertices, reversed.
                for i in 0..n {
                    let (a, b, c, d) = (&wall[0][i], &wall[0][i + 1], &wall[1][i + 1], &wall[1][i]);
                    ug.f(&[d, c, b, a], "grey");
                }
            }
        }
        Kind::Box => {
            // Unit box [0,2]^3, faces pointing inwards (a room), each 2 × 2.
            let mut ids = std::collections::BTreeMap::new();
            let mut vid = |ug: &mut Ug, p: [i32; 3]| -> String {
                ids.entry(p)
                    .or_insert_with(|| ug.v(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)))
                    .clone()
            };
            // For each axis and side: (origin, u, v) with u × v pointing inwards.
            let sides: [([i32; 3], [i32; 3], [i32; 3]); 6] = [
                ([0, 0, 0], [0, 1, 0], [1, 0, 0]), // z = 0, normal +z
                ([0, 0, 2], [1, 0, 0], [0, 1, 0]), // z = 2, normal -z
                ([0, 0, 0], [1, 0, 0], [0, 0, 1]), // y = 0, normal +y
                ([0, 2, 0], [0, 0, 1], [1, 0, 0]), // y = 2, normal -y
                ([0, 0, 0], [0, 0, 1], [0, 1, 0]), // x = 0, normal +x
                ([2, 0, 0], [0, 1, 0], [0, 0, 1]), // x = 2, normal -x
            ];
            for (o, u, v) in sides {
                for j in 0..2 {
                    for i in 0..2 {
                        let at = |di: i32, dj: i32| {
                            [0, 1, 2].map(|k| o[k] + u[k] * (i + di) + v[k] * (j + dj))
                        };
                        let a = vid(&mut ug, at(0, 0));
                        let b = vid(&mut ug, at(1, 0));
                        let c = vid(&mut ug, at(1, 1));
                        let d = vid(&mut ug, at(0, 1));
                        ug.f(&[&a, &b, &c, &d], "grey");
                    }
                }
            }
        }
    }
    ug::parse(ug.s.as_bytes(), "<prop>").unwrap().model
}

fn kind() -> impl Strategy<Value = Kind> {
    prop_oneof![
        (
            1usize..4,
            1usize..4,
            any::<u64>(),
            prop_oneof![Just(0.0), Just(0.3)]
        )
            .prop_map(|(nx, ny, tris, skew)| Kind::Grid { nx, ny, tris, skew }),
        (1usize..3).prop_map(|n| Kind::LShape { n }),
        (
            1usize..4,
            1usize..3,
            any::<u64>(),
            prop_oneof![Just(90.0), Just(60.0), Just(135.0)],
            any::<bool>()
        )
            .prop_map(|(n, ny, tris, angle, two_materials)| Kind::Angle {
                n,
                ny,
                tris,
                angle,
                two_materials
            }),
        Just(Kind::Box),
        (1usize..4, any::<u64>(), any::<bool>()).prop_map(|(n, tris, double)| Kind::Fin {
            n,
            tris,
            double
        }),
    ]
}

/// Splits `picks` leaves (index modulo the leaf count), checking each split's report.
fn run(m: &mut Mesh, picks: &[u16]) -> Result<(), TestCaseError> {
    let mut out = Split::default();
    for &k in picks {
        let leaves: Vec<ElemId> = m.leaves().collect();
        let e = leaves[k as usize % leaves.len()];
        if m.elem_level(e) >= 7 {
            continue;
        }
        let nv = m.num_vertices() as u32;
        let nl = m.num_leaves();
        m.split_into(e, &mut out);
        prop_assert_eq!(out.refined.first(), Some(&e));
        prop_assert_eq!(m.num_leaves(), nl + 3 * out.refined.len());
        let ids: Vec<u32> = out.new_vertices.iter().map(|n| n.v.0).collect();
        prop_assert_eq!(ids, (nv..m.num_vertices() as u32).collect::<Vec<_>>());
        for n in &out.new_vertices {
            let [a, b] = n.parents;
            prop_assert!(a < n.v && b < n.v);
            prop_assert_eq!(m.vertex_surface(a), m.vertex_surface(n.v));
            prop_assert_eq!(m.vertex_surface(b), m.vertex_surface(n.v));
            prop_assert_eq!(m.vertex_pos(n.v), (m.vertex_pos(a) + m.vertex_pos(b)) * 0.5);
        }
        for &r in &out.refined {
            prop_assert!(!m.elem_is_leaf(r));
        }
    }
    Ok(())
}

/// The output model less the faces of one surface.
fn without_surface(m: &Mesh, out: &ug::Model, drop: Option<SurfaceId>) -> ug::Model {
    let Some(drop) = drop else {
        return out.clone();
    };
    let mut keep = Vec::new();
    for p in m.patches() {
        let pieces: usize = m.patch_leaves(p).iter().map(|&e| m.anchored(e).len()).sum();
        keep.extend(std::iter::repeat_n(m.patch_surface(p) != drop, pieces));
    }
    let mut res = out.clone();
    res.items
        .retain(|it| !matches!(it, ug::Item::Face(f) if !keep[f.idx()]));
    res
}

/// `two_sided`: the model has a two-sided wall, whose sides (refined
/// differently) overlap in `ugcheck`'s eyes.
fn check(src: &ug::Model, m: &Mesh, two_sided: bool) -> Result<(), TestCaseError> {
    if let Err(e) = m.validate() {
        return Err(TestCaseError::fail(e));
    }
    for p in m.patches() {
        prop_assert!(m.unbalanced_pairs(p).is_empty());
        let want = m.patch_area(p);
        let leaves: f64 = m.patch_leaves(p).iter().map(|&e| m.elem_area(e)).sum();
        prop_assert!(
            (leaves - want).abs() <= 1e-9 * want,
            "leaf areas {} vs {}",
            leaves,
            want
        );
        let n = m.surface_normal(m.patch_surface(p));
        let mut pieces = 0.0;
        for e in m.patch_leaves(p) {
            for q in m.anchored(e) {
                let pts: Vec<DVec3> = q.iter().map(|&v| m.vertex_pos(v)).collect();
                pieces += geom::newell_normal(&pts).dot(n) / 2.0;
            }
        }
        prop_assert!(
            (pieces - want).abs() <= 1e-9 * want,
            "anchored areas {} vs {}",
            pieces,
            want
        );
    }
    let out = m.to_model(src);
    // The two sides of a two-sided wall are meshed independently, so seen
    // together they overlap; check the model once without each side.
    let ns = m.num_surfaces() as u32;
    let drops: Vec<Option<SurfaceId>> = if two_sided {
        vec![Some(SurfaceId(ns - 1)), Some(SurfaceId(ns - 2))]
    } else {
        vec![None]
    };
    for drop in drops {
        let out = without_surface(m, &out, drop);
        let r = check::check(&out, EPS);
        prop_assert!(r.tvertices.is_empty(), "T-vertices: {:?}", r.tvertices);
        prop_assert!(r.degenerate.is_empty(), "degenerate: {:?}", r.degenerate);
        prop_assert!(
            r.inconsistent.is_empty(),
            "inconsistent: {:?}",
            r.inconsistent
        );
        prop_assert!(
            r.nonpatch.is_empty(),
            "not triangles or convex quads: {:?}",
            r.nonpatch
        );
        prop_assert!(
            r.intersecting.is_empty(),
            "intersecting: {:?}",
            r.intersecting
        );
        prop_assert!(r.coincident.is_empty(), "coincident: {:?}", r.coincident);
        prop_assert!(r.overlapping.is_empty(), "overlapping: {:?}", r.overlapping);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_splits_keep_the_mesh_valid(kind in kind(), picks in proptest::collection::vec(any::<u16>(), 0..80)) {
        let src = model(&kind);
        let mut m = Mesh::from_model(&src, EPS).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let surfaces = match kind {
            Kind::Grid { .. } | Kind::LShape { .. } => 1,
            Kind::Angle { .. } => 2,
            Kind::Box => 6,
            // The fin's foot splits the floor: a surface each side.
            Kind::Fin { double, .. } => 3 + double as usize,
        };
        prop_assert_eq!(m.num_surfaces(), surfaces);
        run(&mut m, &picks)?;
        check(&src, &m, matches!(kind, Kind::Fin { double: true, .. }))?;
    }

    /// On quad grids the leaves match a geometric reference quadtree that
    /// balances by searching all leaves for edge neighbours.
    #[test]
    fn quad_grid_matches_reference(nx in 1usize..4, ny in 1usize..4, picks in proptest::collection::vec(any::<u16>(), 0..30)) {
        let src = model(&Kind::Grid { nx, ny, tris: 0, skew: 0.0 });
        let mut m = Mesh::from_model(&src, EPS).unwrap();
        let mut r = Reference::new(nx, ny);
        for &k in &picks {
            let leaves: Vec<ElemId> = m.leaves().collect();
            let e = leaves[k as usize % leaves.len()];
            if m.elem_level(e) >= 6 {
                continue;
            }
            r.split(square_of(&m, e));
            m.split(e);
        }
        let mut got: Vec<Sq> = m.leaves().map(|e| square_of(&m, e)).collect();
        got.sort();
        let mut want = r.leaves.clone();
        want.sort();
        prop_assert_eq!(got, want);
        check(&src, &m, false)?;
    }
}

/// A square leaf: lower-left corner in units of 2^-level, and level.
type Sq = (i64, i64, u32);

fn square_of(m: &Mesh, e: ElemId) -> Sq {
    let l = m.elem_level(e);
    let s = (1u64 << l) as f64;
    let lo = m
        .elem_corners(e)
        .iter()
        .map(|&v| m.vertex_pos(v))
        .fold(DVec3::MAX, DVec3::min);
    ((lo.x * s).round() as i64, (lo.y * s).round() as i64, l)
}

struct Reference {
    leaves: Vec<Sq>,
}

impl Reference {
    fn new(nx: usize, ny: usize) -> Reference {
        let mut leaves = Vec::new();
        for j in 0..ny as i64 {
            for i in 0..nx as i64 {
                leaves.push((i, j, 0));
            }
        }
        Reference { leaves }
    }

    /// Whether two squares share a piece of edge of positive length.
    fn touch(a: Sq, b: Sq) -> bool {
        let l = a.2.max(b.2);
        let box_of = |s: Sq| {
            let k = 1i64 << (l - s.2);
            (s.0 * k, s.1 * k, (s.0 + 1) * k, (s.1 + 1) * k)
        };
        let (a, b) = (box_of(a), box_of(b));
        let xs = a.0.max(b.0) < a.2.min(b.2);
        let ys = a.1.max(b.1) < a.3.min(b.3);
        (xs && (a.1 == b.3 || a.3 == b.1)) || (ys && (a.0 == b.2 || a.2 == b.0))
    }

    fn split(&mut self, s: Sq) {
        let Some(i) = self.leaves.iter().position(|&x| x == s) else {
            return;
        };
        loop {
            let coarse = self
                .leaves
                .iter()
                .copied()
                .find(|&t| t.2 < s.2 && Self::touch(s, t));
            match coarse {
                Some(t) => self.split(t),
                None => break,
            }
        }
        let i = self.leaves.iter().position(|&x| x == s).unwrap_or(i);
        self.leaves.swap_remove(i);
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            self.leaves.push((2 * s.0 + dx, 2 * s.1 + dy, s.2 + 1));
        }
    }
}

#[test]
fn box_corner_refinement_is_stitched_three_ways() {
    let src = model(&Kind::Box);
    let mut m = Mesh::from_model(&src, EPS).unwrap();
    // Refine the floor patch at the origin corner four levels deep at the corner.
    let floor0 = PatchId(0);
    let mut e = m.patch_root(floor0);
    for _ in 0..4 {
        m.split(e);
        e = m.elem_children(e).unwrap()[0];
    }
    check(&src, &m, false).unwrap();
}
