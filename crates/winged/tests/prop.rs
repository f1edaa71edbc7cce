//! Property tests: random edit sequences on grids of quads keep the topology
//! valid, keep area, and survive the trip through a `ug::Model`.

use glam::{DQuat, DVec3};
use proptest::prelude::*;
use ug::{Face, FaceId, Model, Vertex, VertexId};
use winged::{MergeError, Mesh};

/// An n×m grid of unit quads (counter-clockwise seen from +z before the
/// rigid motion), sharing vertices; cells are named `c<i>_<j>`. Cells for
/// which `keep` is false are left out.
fn grid(n: usize, m: usize, motion: (DQuat, DVec3), keep: impl Fn(usize, usize) -> bool) -> Model {
    let mut model = Model::new();
    let id = |i: usize, j: usize| VertexId((j * (n + 1) + i) as u32);
    for j in 0..=m {
        for i in 0..=n {
            model.add_vertex(Vertex {
                name: format!("p{i}_{j}"),
                pos: motion.0 * DVec3::new(i as f64, j as f64, 0.0) + motion.1,
                color: None,
            });
        }
    }
    for j in 0..m {
        for i in 0..n {
            if keep(i, j) {
                model.add_face(Face {
                    name: Some(format!("c{i}_{j}")),
                    contours: vec![vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]],
                    material: None,
                });
            }
        }
    }
    model
}

fn motion() -> impl Strategy<Value = (DQuat, DVec3)> {
    (
        -1.0f64..1.0,
        -1.0f64..1.0,
        -1.0f64..1.0,
        0.0f64..6.0,
        -100.0f64..100.0,
    )
        .prop_map(|(x, y, z, angle, t)| {
            let axis = DVec3::new(x, y, z + 2.0).normalize();
            (
                DQuat::from_axis_angle(axis, angle),
                DVec3::new(t, -t / 2.0, t / 3.0),
            )
        })
}

fn check(m: &Mesh) {
    if let Err(e) = m.validate() {
        panic!("invalid mesh: {e}");
    }
}

fn total_area(m: &Mesh) -> f64 {
    m.faces().map(|f| m.face_area(f)).sum()
}

/// Topology by names and statement positions, independent of ids.
type Signature = Vec<((String, String), Vec<(usize, u32, u32, String)>)>;

fn signature(m: &Mesh) -> Signature {
    let pos: std::collections::BTreeMap<FaceId, usize> =
        m.faces().enumerate().map(|(k, f)| (f, k)).collect();
    let name = |v: VertexId| m.model().vertices[v.idx()].name.clone();
    let mut sig: Signature = m
        .edges()
        .map(|e| {
            let edge = m.edge(e);
            let (a, b) = (name(edge.v[0]), name(edge.v[1]));
            let mut uses: Vec<(usize, u32, u32, String)> = edge
                .uses
                .iter()
                .map(|u| {
                    let from = if u.forward { &a } else { &b };
                    (pos[&u.face], u.contour, u.index, from.clone())
                })
                .collect();
            uses.sort();
            (if a < b { (a, b) } else { (b, a) }, uses)
        })
        .collect();
    sig.sort();
    sig
}

fn round_trip(m: &Mesh) {
    let model = m.to_model();
    let text = ug::write_string(&model);
    // The model is what parsing its text gives.
    let parsed = ug::parse(text.as_bytes(), "<prop>").unwrap().model;
    assert_eq!(parsed, model);
    let m2 = Mesh::from_model(model.clone());
    check(&m2);
    assert!(m2.repairs().is_empty());
    assert_eq!(signature(&m2), signature(m));
    assert_eq!(m2.num_edges(), m.num_edges());
    assert_eq!(m2.num_faces(), m.num_faces());
    let again = m2.into_model();
    assert_eq!(again, model);
    assert_eq!(ug::write_string(&again), text);
}

#[derive(Clone, Debug)]
enum Op {
    Split(usize, f64),
    Merge(usize, usize),
    Flip(usize),
    Remove(usize),
    Replan(usize),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        4 => (any::<usize>(), 0.1f64..0.9).prop_map(|(e, t)| Op::Split(e, t)),
        5 => (any::<usize>(), any::<usize>()).prop_map(|(f, g)| Op::Merge(f, g)),
        1 => any::<usize>().prop_map(Op::Flip),
        1 => any::<usize>().prop_map(Op::Remove),
        1 => any::<usize>().prop_map(Op::Replan),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Random splits, merges, flips, removals and re-plans on a grid.
    #[test]
    fn random_edits_keep_topology_and_area(
        n in 1usize..5, m in 1usize..5, mv in motion(),
        ops in proptest::collection::vec(op(), 0..30),
    ) {
        let mut mesh = Mesh::from_model(grid(n, m, mv, |_, _| true));
        check(&mesh);
        round_trip(&mesh);
        let mut expected = (n * m) as f64;
        prop_assert!((total_area(&mesh) - expected).abs() < 1e-9);
        for op in ops {
            let faces: Vec<FaceId> = mesh.faces().collect();
            if faces.is_empty() {
                break;
            }
            match op {
                Op::Split(k, t) => {
                    let edges: Vec<_> = mesh.edges().collect();
                    let e = edges[k % edges.len()];
                    let [p, q] = mesh.edge_points(e);
                    let uses = mesh.edge(e).uses.len();
                    let v = mesh.add_vertex(None, p.lerp(q, t));
                    let [e0, e1] = mesh.split_edge(e, v);
                    prop_assert!(!mesh.is_edge_live(e));
                    prop_assert_eq!(mesh.edge(e0).uses.len(), uses);
                    prop_assert_eq!(mesh.edge(e1).uses.len(), uses);
                }
                Op::Merge(k, j) => {
                    let a = faces[k % faces.len()];
                    let nb = mesh.face_neighbors(a);
                    if nb.is_empty() {
                        prop_assert_eq!(mesh.merge_faces(a, a), Err(MergeError::SameFace));
                        continue;
                    }
                    let b = nb[j % nb.len()];
                    let before = mesh.face_area(a) + mesh.face_area(b);
                    prop_assert_eq!(mesh.merge_faces(a, b), Ok(a));
                    prop_assert!(!mesh.is_face_live(b));
                    prop_assert!((mesh.face_area(a) - before).abs() < 1e-9);
                    prop_assert!(!mesh.face_neighbors(a).contains(&b));
                }
                Op::Flip(k) => {
                    let f = faces[k % faces.len()];
                    let first: Vec<VertexId> = mesh.face(f).contours.iter().map(|c| c[0]).collect();
                    mesh.flip_face(f);
                    let after: Vec<VertexId> = mesh.face(f).contours.iter().map(|c| c[0]).collect();
                    prop_assert_eq!(first, after);
                }
                Op::Remove(k) => {
                    let f = faces[k % faces.len()];
                    expected -= mesh.face_area(f);
                    mesh.remove_face(f);
                }
                Op::Replan(k) => {
                    // Re-plane with the same contours rotated: same face, same area.
                    let f = faces[k % faces.len()];
                    let mut cs = mesh.face(f).contours.clone();
                    for c in &mut cs {
                        c.rotate_left(1);
                    }
                    prop_assert!(mesh.set_face_contours(f, cs));
                }
            }
            check(&mesh);
            for f in mesh.faces() {
                prop_assert!(mesh.face_area(f) > 0.0);
            }
            prop_assert!((total_area(&mesh) - expected).abs() < 1e-9,
                "area {} expected {}", total_area(&mesh), expected);
        }
        round_trip(&mesh);
    }

    /// Merging a whole grid in random order gives one rectangle.
    #[test]
    fn merging_everything_gives_one_rectangle(
        n in 1usize..5, m in 1usize..5, mv in motion(),
        picks in proptest::collection::vec(any::<(usize, usize)>(), 32),
        splits in proptest::collection::vec(any::<usize>(), 0..6),
    ) {
        let mut mesh = Mesh::from_model(grid(n, m, mv, |_, _| true));
        for k in splits {
            let edges: Vec<_> = mesh.edges().collect();
            let e = edges[k % edges.len()];
            let [p, q] = mesh.edge_points(e);
            let v = mesh.add_vertex(None, p.lerp(q, 0.5));
            mesh.split_edge(e, v);
            check(&mesh);
        }
        let mut picks = picks.into_iter().cycle();
        while mesh.num_faces() > 1 {
            let (k, j) = picks.next().unwrap();
            let faces: Vec<FaceId> = mesh.faces().collect();
            let a = faces[k % faces.len()];
            let nb = mesh.face_neighbors(a);
            prop_assert!(!nb.is_empty());
            mesh.merge_faces(a, nb[j % nb.len()]).unwrap();
            check(&mesh);
        }
        let f = mesh.faces().next().unwrap();
        prop_assert_eq!(mesh.face(f).contours.len(), 1);
        prop_assert!((mesh.face_area(f) - (n * m) as f64).abs() < 1e-9);
        prop_assert!(mesh.edges().all(|e| mesh.is_boundary(e)));
        prop_assert_eq!(mesh.num_edges(), mesh.face(f).contours[0].len());
        round_trip(&mesh);
    }

    /// A ring of cells around a window merges into one face with one hole,
    /// whatever the order (intermediate faces may touch themselves).
    #[test]
    fn ring_around_window_merges_to_face_with_hole(
        k in 3usize..6, mv in motion(),
        picks in proptest::collection::vec(any::<(usize, usize)>(), 64),
    ) {
        let ring = |i: usize, j: usize| i == 0 || j == 0 || i == k - 1 || j == k - 1;
        let mut mesh = Mesh::from_model(grid(k, k, mv, ring));
        check(&mesh);
        let mut picks = picks.into_iter().cycle();
        while mesh.num_faces() > 1 {
            let (x, y) = picks.next().unwrap();
            let faces: Vec<FaceId> = mesh.faces().collect();
            let a = faces[x % faces.len()];
            let nb = mesh.face_neighbors(a);
            prop_assert!(!nb.is_empty());
            mesh.merge_faces(a, nb[y % nb.len()]).unwrap();
            check(&mesh);
            for f in mesh.faces() {
                // Every contour is simple (no vertex twice).
                for c in &mesh.face(f).contours {
                    let mut s = c.clone();
                    s.sort();
                    s.dedup();
                    prop_assert_eq!(s.len(), c.len());
                }
            }
        }
        let f = mesh.faces().next().unwrap();
        let cs = &mesh.face(f).contours;
        prop_assert_eq!(cs.len(), 2);
        prop_assert_eq!(cs[0].len(), 4 * k);
        prop_assert_eq!(cs[1].len(), 4 * (k - 2));
        let area = (k * k - (k - 2) * (k - 2)) as f64;
        prop_assert!((mesh.face_area(f) - area).abs() < 1e-9);
        round_trip(&mesh);
    }

    /// The "common representation": every quad with its own vertices. Replacing
    /// duplicates by the first vertex at each position (ugvlmerge) gives the
    /// shared-vertex grid's topology.
    #[test]
    fn replacing_duplicates_connects_the_grid(
        n in 1usize..5, m in 1usize..5, mv in motion(), order in any::<u64>(),
    ) {
        let mut model = Model::new();
        let mut at = std::collections::BTreeMap::<(usize, usize), Vec<VertexId>>::new();
        for j in 0..m {
            for i in 0..n {
                let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                let ids: Vec<VertexId> = corners
                    .iter()
                    .enumerate()
                    .map(|(c, &(x, y))| {
                        let v = model.add_vertex(Vertex {
                            name: format!("q{i}_{j}_{c}"),
                            pos: mv.0 * DVec3::new(x as f64, y as f64, 0.0) + mv.1,
                            color: None,
                        });
                        at.entry((x, y)).or_default().push(v);
                        v
                    })
                    .collect();
                model.add_face(Face { name: Some(format!("c{i}_{j}")), contours: vec![ids], material: None });
            }
        }
        let mut mesh = Mesh::from_model(model);
        prop_assert_eq!(mesh.num_edges(), 4 * n * m);
        let mut groups: Vec<Vec<VertexId>> = at.into_values().collect();
        // A deterministic shuffle of the order in which groups are processed.
        let len = groups.len();
        groups.rotate_left((order as usize) % len);
        for g in groups {
            for &dup in &g[1..] {
                prop_assert!(mesh.replace_vertex(dup, g[0]).is_empty());
                check(&mesh);
                prop_assert!(mesh.remove_vertex(dup));
            }
        }
        check(&mesh);
        let shared = Mesh::from_model(grid(n, m, mv, |_, _| true));
        prop_assert_eq!(mesh.num_edges(), shared.num_edges());
        let interior = mesh.edges().filter(|&e| mesh.is_manifold(e)).count();
        prop_assert_eq!(interior, shared.edges().filter(|&e| shared.is_manifold(e)).count());
        prop_assert!(mesh.edges().all(|e| mesh.is_boundary(e) || mesh.consistently_oriented(e)));
        let nb: Vec<usize> = mesh.faces().map(|f| mesh.face_neighbors(f).len()).collect();
        let nb_shared: Vec<usize> = shared.faces().map(|f| shared.face_neighbors(f).len()).collect();
        prop_assert_eq!(nb, nb_shared);
        round_trip(&mesh);
    }
}

#[derive(Clone, Debug)]
enum SoupOp {
    Merge(usize, usize),
    Split(usize, usize),
    Replace(usize, usize),
    Flip(usize),
    Remove(usize),
    Add(Vec<usize>),
}

fn soup_op() -> impl Strategy<Value = SoupOp> {
    prop_oneof![
        4 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| SoupOp::Merge(a, b)),
        2 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| SoupOp::Split(a, b)),
        2 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| SoupOp::Replace(a, b)),
        1 => any::<usize>().prop_map(SoupOp::Flip),
        1 => any::<usize>().prop_map(SoupOp::Remove),
        1 => proptest::collection::vec(any::<usize>(), 3..6).prop_map(SoupOp::Add),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Random faces over a few vertices (non-manifold, any orientation,
    /// repeated vertices), random edits: never a panic, always valid, a
    /// refused merge changes nothing, and the model round trip holds.
    #[test]
    fn random_soup_stays_valid(
        pts in proptest::collection::vec((0i32..4, 0i32..4, 0i32..2), 4..9),
        faces in proptest::collection::vec(proptest::collection::vec(any::<usize>(), 3..6), 1..8),
        ops in proptest::collection::vec(soup_op(), 0..25),
    ) {
        let mut model = Model::new();
        for (k, &(x, y, z)) in pts.iter().enumerate() {
            model.add_vertex(Vertex {
                name: format!("v{k}"),
                pos: DVec3::new(x as f64, y as f64, z as f64),
                color: None,
            });
        }
        let nv = pts.len();
        for (k, f) in faces.iter().enumerate() {
            model.add_face(Face {
                name: Some(format!("f{k}")),
                contours: vec![f.iter().map(|&i| VertexId((i % nv) as u32)).collect()],
                material: None,
            });
        }
        let mut mesh = Mesh::from_model(model);
        check(&mesh);
        for op in ops {
            let fs: Vec<FaceId> = mesh.faces().collect();
            let es: Vec<_> = mesh.edges().collect();
            let vs: Vec<VertexId> = mesh.vertices().collect();
            match op {
                SoupOp::Merge(a, b) if !fs.is_empty() => {
                    let a = fs[a % fs.len()];
                    let b = fs[b % fs.len()];
                    let before = signature(&mesh);
                    let model_before = mesh.to_model();
                    match mesh.merge_faces(a, b) {
                        Ok(f) => {
                            prop_assert_eq!(f, a);
                            prop_assert!(!mesh.is_face_live(b));
                        }
                        Err(_) => {
                            prop_assert_eq!(signature(&mesh), before);
                            prop_assert_eq!(mesh.to_model(), model_before);
                        }
                    }
                }
                SoupOp::Split(e, v) if !es.is_empty() => {
                    let e = es[e % es.len()];
                    let v = vs[v % vs.len()];
                    if !mesh.edge(e).v.contains(&v) {
                        mesh.split_edge(e, v);
                    }
                }
                SoupOp::Replace(a, b) => {
                    let removed = mesh.replace_vertex(vs[a % vs.len()], vs[b % vs.len()]);
                    for f in removed {
                        prop_assert!(!mesh.is_face_live(f));
                    }
                }
                SoupOp::Flip(f) if !fs.is_empty() => mesh.flip_face(fs[f % fs.len()]),
                SoupOp::Remove(f) if !fs.is_empty() => mesh.remove_face(fs[f % fs.len()]),
                SoupOp::Add(c) => {
                    let after = fs.first().copied();
                    mesh.add_face(after, Face {
                        name: Some("new".into()),
                        contours: vec![c.iter().map(|&i| vs[i % vs.len()]).collect()],
                        material: None,
                    });
                }
                _ => {}
            }
            check(&mesh);
        }
        round_trip(&mesh);
    }
}
