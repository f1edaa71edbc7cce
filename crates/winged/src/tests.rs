//! Unit tests on small hand-built models; `validate()` after every edit.

use glam::DVec3;
use ug::{Face, FaceId, Model, VertexId};

use crate::{EdgeId, EdgeUse, MergeError, Mesh, Repair};

fn parse(src: &str) -> Model {
    ug::parse(src.as_bytes(), "<test>").unwrap().model
}

fn mesh(src: &str) -> Mesh {
    let m = Mesh::from_model(parse(src));
    m.validate().unwrap();
    m
}

fn v(m: &Mesh, name: &str) -> VertexId {
    let i = m
        .model()
        .vertices
        .iter()
        .position(|x| x.name == name)
        .unwrap_or_else(|| panic!("no vertex {name}"));
    VertexId(i as u32)
}

fn f(m: &Mesh, name: &str) -> FaceId {
    let i = m
        .model()
        .faces
        .iter()
        .position(|x| x.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no face {name}"));
    FaceId(i as u32)
}

fn e(m: &Mesh, a: &str, b: &str) -> EdgeId {
    m.edge_between(v(m, a), v(m, b))
        .unwrap_or_else(|| panic!("no edge {a}-{b}"))
}

/// A face's contours as vertex names joined by spaces.
fn contours(m: &Mesh, face: FaceId) -> Vec<String> {
    m.face(face)
        .contours
        .iter()
        .map(|c| {
            c.iter()
                .map(|&x| m.model().vertices[x.idx()].name.as_str())
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect()
}

fn ok(m: &Mesh) {
    if let Err(e) = m.validate() {
        panic!("invalid mesh: {e}");
    }
}

fn total_area(m: &Mesh) -> f64 {
    m.faces().map(|x| m.face_area(x)).sum()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

const CUBE: &str = "
v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;
v e 0 0 1; v f 1 0 1; v g 1 1 1; v h 0 1 1;
f bottom (a d c b);
f top (e f g h);
f front (a b f e);
f back (c d h g);
f left (a e h d);
f right (b c g f);
";

/// Two unit squares sharing the edge b-c.
const TWO: &str = "
v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 2 0 0; v f 2 1 0;
f left (a b c d);
f right (b e f c);
";

/// Three walls along the z axis edge o-t (non-manifold).
const WALLS: &str = "
v o 0 0 0; v t 0 0 1;
v x 1 0 0; v xt 1 0 1; v y 0 1 0; v yt 0 1 1; v n -1 -1 0; v nt -1 -1 1;
f wx (o x xt t);
f wy (t yt y o);
f wn (o t nt n);
";

/// A 10×10 square with a 6×6 hole and a 2×2 island in the hole.
const HOLE_ISLAND: &str = "
v o0 0 0 0; v o1 10 0 0; v o2 10 10 0; v o3 0 10 0;
v h0 2 2 0; v h1 8 2 0; v h2 8 8 0; v h3 2 8 0;
v i0 4 4 0; v i1 6 4 0; v i2 6 6 0; v i3 4 6 0;
f plate (o0 o1 o2 o3) (h0 h3 h2 h1) (i0 i1 i2 i3);
";

/// Vertex names p<i><j> at (i, j) for a (n+1)×(n+1) lattice.
fn lattice(n: usize) -> String {
    let mut s = String::new();
    for j in 0..=n {
        for i in 0..=n {
            s += &format!("v p{i}{j} {i} {j} 0;\n");
        }
    }
    s
}

fn cell(i: usize, j: usize) -> String {
    format!(
        "f c{i}{j} (p{i}{j} p{}{j} p{}{} p{i}{});\n",
        i + 1,
        i + 1,
        j + 1,
        j + 1
    )
}

/// The 3×3 grid of unit cells without the centre: a ring of 8 quads around a window.
fn ring8() -> String {
    let mut s = lattice(3);
    for j in 0..3 {
        for i in 0..3 {
            if (i, j) != (1, 1) {
                s += &cell(i, j);
            }
        }
    }
    s
}

// ----------------------------------------------------------------------
// Queries
// ----------------------------------------------------------------------

#[test]
fn cube_topology() {
    let m = mesh(CUBE);
    assert_eq!(m.num_faces(), 6);
    assert_eq!(m.num_edges(), 12);
    assert_eq!(m.edges().count(), 12);
    let ids: Vec<EdgeId> = m.edges().collect();
    assert!(ids.windows(2).all(|w| w[0] < w[1]));
    for e in m.edges() {
        assert!(m.is_manifold(e));
        assert!(!m.is_boundary(e));
        assert!(m.consistently_oriented(e), "edge {e:?}");
        let edge = m.edge(e);
        assert!(edge.v[0] < edge.v[1]);
        assert!(edge.uses.windows(2).all(|w| w[0] < w[1]));
        assert!(close(m.edge_length(e), 1.0));
    }
    for x in m.vertices() {
        assert_eq!(m.vertex_edges(x).len(), 3);
        assert_eq!(m.vertex_faces(x).len(), 3);
    }
    for face in m.faces() {
        assert_eq!(m.face_neighbors(face).len(), 4);
        assert!(close(m.face_area(face), 1.0));
        assert_eq!(m.face_edges(face).len(), 4);
    }
    // Outward normals.
    let plane = m.face_plane(f(&m, "bottom")).unwrap();
    assert!((plane.n - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
    assert!(close(plane.d, 0.0));
    let plane = m.face_plane(f(&m, "top")).unwrap();
    assert!((plane.n - DVec3::Z).length() < 1e-12);
    assert!(close(plane.d, 1.0));
    assert!((m.face_normal(f(&m, "right")).unwrap() - DVec3::X).length() < 1e-12);
    // top's neighbours are the four sides, sorted.
    let mut sides = vec![f(&m, "front"), f(&m, "back"), f(&m, "left"), f(&m, "right")];
    sides.sort();
    assert_eq!(m.face_neighbors(f(&m, "top")), sides);
}

#[test]
fn edge_lookup_and_uses() {
    let m = mesh(TWO);
    let bc = e(&m, "b", "c");
    assert_eq!(m.edge_between(v(&m, "c"), v(&m, "b")), Some(bc));
    assert_eq!(m.edge_between(v(&m, "a"), v(&m, "e")), None);
    assert_eq!(m.edge_between(v(&m, "a"), v(&m, "a")), None);
    let edge = m.edge(bc);
    assert_eq!(edge.v, [v(&m, "b"), v(&m, "c")]);
    assert_eq!(
        edge.uses,
        vec![
            EdgeUse {
                face: f(&m, "left"),
                contour: 0,
                index: 1,
                forward: true
            },
            EdgeUse {
                face: f(&m, "right"),
                contour: 0,
                index: 3,
                forward: false
            },
        ]
    );
    assert_eq!(edge.faces(), vec![f(&m, "left"), f(&m, "right")]);
    assert_eq!(edge.other(v(&m, "b")), Some(v(&m, "c")));
    assert_eq!(edge.other(v(&m, "a")), None);
    assert!(m.is_manifold(bc) && m.consistently_oriented(bc));
    assert_eq!(m.edges().filter(|&x| m.is_boundary(x)).count(), 6);
    // Vertex edges ascending.
    let b = m.vertex_edges(v(&m, "b"));
    assert_eq!(b.len(), 3);
    assert!(b.windows(2).all(|w| w[0] < w[1]));
    assert!(b.contains(&bc));
    // Face edges in contour order.
    let left = f(&m, "left");
    assert_eq!(
        m.face_edges(left),
        vec![e(&m, "a", "b"), bc, e(&m, "c", "d"), e(&m, "d", "a")]
    );
    assert_eq!(m.contour_edges(left, 0), m.face_edges(left).as_slice());
    assert!(m.contour_edges(left, 1).is_empty());
    assert_eq!(m.face_neighbors(left), vec![f(&m, "right")]);
    assert_eq!(m.vertex_faces(v(&m, "c")), vec![left, f(&m, "right")]);
    assert_eq!(m.vertex_faces(v(&m, "a")), vec![left]);
    assert_eq!(
        m.face_points(left)[0],
        vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]
    );
    assert_eq!(m.edge_points(bc), [DVec3::X, DVec3::new(1.0, 1.0, 0.0)]);
    assert!(close(total_area(&m), 2.0));
    // Out-of-range vertex: no edges.
    assert!(m.vertex_edges(VertexId(999)).is_empty());
}

#[test]
fn three_walls_non_manifold() {
    let m = mesh(WALLS);
    let ot = e(&m, "o", "t");
    assert_eq!(m.edge(ot).uses.len(), 3);
    assert!(!m.is_manifold(ot));
    assert!(!m.is_boundary(ot));
    assert!(!m.consistently_oriented(ot));
    let (wx, wy, wn) = (f(&m, "wx"), f(&m, "wy"), f(&m, "wn"));
    assert_eq!(m.face_neighbors(wx), vec![wy, wn]);
    assert_eq!(m.face_neighbors(wy), vec![wx, wn]);
    let dirs: Vec<bool> = m.edge(ot).uses.iter().map(|u| u.forward).collect();
    assert_eq!(dirs, vec![false, true, true]);
    for x in m.edges().filter(|&x| x != ot) {
        assert!(m.is_boundary(x));
    }
    assert_eq!(m.num_edges(), 10);
    assert_eq!(m.vertex_edges(v(&m, "o")).len(), 4);
}

#[test]
fn hole_and_island() {
    let m = mesh(HOLE_ISLAND);
    let p = f(&m, "plate");
    assert!(close(m.face_area(p), 100.0 - 36.0 + 4.0));
    assert_eq!(m.num_edges(), 12);
    assert_eq!(m.face_edges(p).len(), 12);
    assert_eq!(m.contour_edges(p, 1)[0], e(&m, "h0", "h3"));
    assert_eq!(m.contour_edges(p, 2)[3], e(&m, "i3", "i0"));
    assert!(m.edges().all(|x| m.is_boundary(x)));
    assert!(m.face_neighbors(p).is_empty());
    let u = m.edge(e(&m, "h1", "h0")).uses[0];
    assert_eq!((u.contour, u.index, u.forward), (1, 3, false));
    let pts = m.face_points(p);
    assert_eq!(pts.len(), 3);
    assert_eq!(pts[2][1], DVec3::new(6.0, 4.0, 0.0));
    assert!((m.face_plane(p).unwrap().n - DVec3::Z).length() < 1e-12);
}

#[test]
fn keyhole_contour_walks_an_edge_twice() {
    // One contour: the square, over the bridge a-e, around the hole, back.
    let m = mesh(
        "v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 0 4 0;
         v e 1 1 0; v f 3 1 0; v g 3 3 0; v h 1 3 0;
         f k (a b c d a e h g f e);",
    );
    let k = f(&m, "k");
    let ae = e(&m, "a", "e");
    assert_eq!(m.edge(ae).uses.len(), 2);
    assert!(m.edge(ae).uses.iter().all(|u| u.face == k));
    assert!(m.consistently_oriented(ae));
    assert!(m.face_neighbors(k).is_empty());
    assert!(close(m.face_area(k), 16.0 - 4.0));
    assert_eq!(m.face_edges(k).len(), 10);
    assert_eq!(m.num_edges(), 9);
}

#[test]
fn two_contours_of_one_face_share_an_edge() {
    let m = mesh("v a 0 0 0; v b 1 0 0; v c 0 1 0; v d 1 -1 0; f two (a b c) (b a d);");
    let ab = e(&m, "a", "b");
    let uses = &m.edge(ab).uses;
    assert_eq!(uses.len(), 2);
    assert_eq!((uses[0].contour, uses[1].contour), (0, 1));
    assert!(m.consistently_oriented(ab));
    assert!(m.face_neighbors(f(&m, "two")).is_empty());
}

#[test]
fn faces_in_statement_order_and_dead_ids() {
    let mut m = mesh(CUBE);
    let order: Vec<FaceId> = m.faces().collect();
    assert_eq!(order, (0..6).map(FaceId).collect::<Vec<_>>());
    m.remove_face(FaceId(2));
    ok(&m);
    assert!(!m.is_face_live(FaceId(2)));
    assert!(!m.is_face_live(FaceId(99)));
    assert!(m.face_edges(FaceId(2)).is_empty());
    assert!(m.face_points(FaceId(2)).is_empty());
    assert_eq!(m.face_area(FaceId(2)), 0.0);
    assert!(m.face_plane(FaceId(2)).is_none());
    assert_eq!(m.faces().count(), 5);
    assert_eq!(m.num_faces(), 5);
    // Removing twice is a no-op.
    m.remove_face(FaceId(2));
    ok(&m);
}

// ----------------------------------------------------------------------
// Round trips
// ----------------------------------------------------------------------

const RICH: &str = "{ a comment }
c_rgb red 0.9 0.1 0.1;
defmat lamp;
  diffuse_rgb 0.5 0.5 0.5;
  emission_rgb 10 10 10;
end;
v a 0 0 0; v b 1 0 0 red; v c 1 1 0; v d 0 1 0; v e 2 0 0; v f 2 1 0;
f left (a b c d) red;
l sun 1 2 3;
f (b e f c) lamp;
w rail (a b e);
cam c1 0 0 5;
f hole (a b c d) (a d c b);
";

#[test]
fn round_trip_without_edits_is_exact() {
    for src in [CUBE, TWO, WALLS, HOLE_ISLAND, RICH, &ring8()] {
        let model = parse(src);
        let m = Mesh::from_model(model.clone());
        ok(&m);
        assert!(m.repairs().is_empty(), "{:?}", m.repairs());
        assert_eq!(m.to_model(), model);
        let text = ug::write_string(&model);
        let back = m.into_model();
        assert_eq!(ug::write_string(&back), text);
        assert_eq!(back, model);
    }
}

#[test]
fn round_trip_after_edits_parses_back() {
    let mut m = mesh(RICH);
    let left = f(&m, "left");
    let mid = m.add_vertex(None, DVec3::new(1.0, 0.5, 0.0));
    m.split_edge(e(&m, "b", "c"), mid);
    ok(&m);
    let right = FaceId(1);
    assert_eq!(m.merge_faces(left, right), Ok(left));
    ok(&m);
    let out = m.to_model();
    let text = ug::write_string(&out);
    let back = parse(&text);
    assert_eq!(back, out);
    let m2 = Mesh::from_model(back);
    ok(&m2);
    assert_eq!(ug::write_string(&m2.into_model()), text);
    assert!(text.contains("v v6 1 0.5 0;\nf left"), "{text}");
    assert!(
        text.contains("f left (a b e f c d) red;\nl sun 1 2 3;\nw rail (a b e);"),
        "{text}"
    );
}

#[test]
fn non_flat_model_is_flattened() {
    let src = "def sq; v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; f s (a b c d); end;
               i one (sq); i two (sq -tx 1);";
    let model = parse(src);
    assert!(!model.is_flat());
    let m = Mesh::from_model(model.clone());
    ok(&m);
    assert_eq!(m.num_faces(), 2);
    assert_eq!(m.to_model(), model.flatten().unwrap());
    assert!(Mesh::try_from_model(model).is_ok());
}

// ----------------------------------------------------------------------
// Construction repairs
// ----------------------------------------------------------------------

#[test]
fn from_model_cleans_bad_contours() {
    let mut model = parse(
        "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;
         f rep (a b b c d a);
         f deg (a b a);
         f mixed (a b c d) (a b c);
         f keep (a b c);",
    );
    // The parser refuses contours of two vertices; build one by hand.
    model.faces[2].contours[1].pop();
    // An out-of-range vertex reference and a repeated statement (hand-built model).
    model.faces[3].contours[0].insert(1, VertexId(77));
    model.items.push(ug::Item::Face(FaceId(0)));
    let m = Mesh::from_model(model);
    ok(&m);
    let (rep, deg, mixed, keep) = (FaceId(0), FaceId(1), FaceId(2), FaceId(3));
    assert_eq!(contours(&m, rep), vec!["a b c d"]);
    assert!(!m.is_face_live(deg));
    assert_eq!(contours(&m, mixed), vec!["a b c d"]);
    assert_eq!(contours(&m, keep), vec!["a b c"]);
    assert_eq!(
        m.repairs(),
        &[
            Repair::RepeatedStatement { face: rep },
            Repair::RemovedRepeats {
                face: rep,
                contour: 0,
                count: 2
            },
            Repair::RemovedRepeats {
                face: deg,
                contour: 0,
                count: 1
            },
            Repair::DroppedContour {
                face: deg,
                contour: 0
            },
            Repair::DroppedFace { face: deg },
            Repair::DroppedContour {
                face: mixed,
                contour: 1
            },
            Repair::DroppedVertexRef {
                face: keep,
                contour: 0
            },
        ]
    );
    let out = m.into_model();
    assert_eq!(out.faces.len(), 3);
    assert_eq!(out.items.len(), 4 + 3);
}

// ----------------------------------------------------------------------
// split_edge
// ----------------------------------------------------------------------

#[test]
fn split_shared_edge_affects_both_faces() {
    let mut m = mesh(TWO);
    let bc = e(&m, "b", "c");
    let ab = e(&m, "a", "b");
    let mid = m.add_vertex(Some("m"), DVec3::new(1.0, 0.5, 0.0));
    ok(&m);
    let [e0, e1] = m.split_edge(bc, mid);
    ok(&m);
    assert!(!m.is_edge_live(bc));
    assert!(m.edges().all(|x| x != bc));
    assert_eq!(m.edge(e0).v, [v(&m, "b"), mid]);
    assert_eq!(m.edge(e1).v, [v(&m, "c"), mid]);
    assert_eq!(contours(&m, f(&m, "left")), vec!["a b m c d"]);
    assert_eq!(contours(&m, f(&m, "right")), vec!["b e f c m"]);
    for x in [e0, e1] {
        assert!(m.is_manifold(x) && m.consistently_oriented(x));
    }
    // Untouched edges keep their ids.
    assert_eq!(e(&m, "a", "b"), ab);
    assert_eq!(m.num_edges(), 8);
    assert!(close(total_area(&m), 2.0));
    assert_eq!(m.vertex_edges(mid), &[e0, e1]);
}

#[test]
fn split_t_vertex_then_merge_window_ring() {
    // Four rectangles around a 1×1 window; bottom and top have T-vertices.
    let mut m = mesh(
        "v a0 0 0 0; v a3 3 0 0; v b0 0 1 0; v b1 1 1 0; v b2 2 1 0; v b3 3 1 0;
         v c0 0 2 0; v c1 1 2 0; v c2 2 2 0; v c3 3 2 0; v d0 0 3 0; v d3 3 3 0;
         f bottom (a0 a3 b3 b0);
         f right (b2 b3 c3 c2);
         f top (c0 c3 d3 d0);
         f left (b0 b1 c1 c0);",
    );
    assert!(m.face_neighbors(f(&m, "bottom")).is_empty());
    // Stitch the T-vertices into the long edges.
    let [_, rest] = m.split_edge(e(&m, "b3", "b0"), v(&m, "b1"));
    ok(&m);
    assert_eq!(m.edge(rest).v, [v(&m, "b1"), v(&m, "b3")]);
    m.split_edge(rest, v(&m, "b2"));
    ok(&m);
    let [_, rest] = m.split_edge(e(&m, "c0", "c3"), v(&m, "c1"));
    m.split_edge(rest, v(&m, "c2"));
    ok(&m);
    assert_eq!(contours(&m, f(&m, "bottom")), vec!["a0 a3 b3 b2 b1 b0"]);
    assert_eq!(contours(&m, f(&m, "top")), vec!["c0 c1 c2 c3 d3 d0"]);
    let bottom = f(&m, "bottom");
    assert_eq!(
        m.face_neighbors(bottom),
        vec![f(&m, "right"), f(&m, "left")]
    );
    let before = total_area(&m);
    assert!(close(before, 8.0));
    // Merge all four.
    let b = bottom;
    m.merge_faces(b, f(&m, "right")).unwrap();
    ok(&m);
    m.merge_faces(b, f(&m, "top")).unwrap();
    ok(&m);
    assert_eq!(contours(&m, b).len(), 1);
    m.merge_faces(b, f(&m, "left")).unwrap();
    ok(&m);
    assert_eq!(m.num_faces(), 1);
    let cs = contours(&m, b);
    assert_eq!(cs.len(), 2, "{cs:?}");
    assert!(close(m.face_area(b), 8.0));
    // The hole is the window, wound clockwise.
    let pts = m.face_points(b);
    assert!(close(geom::newell_normal(&pts[1]).z / 2.0, -1.0));
    assert_eq!(cs[1].split(' ').count(), 4);
    assert!(m.edges().all(|x| m.is_boundary(x)));
    // Collinear points on the outer boundary stay (they are vertices).
    assert_eq!(cs[0].split(' ').count(), 8);
}

#[test]
fn split_edge_used_by_three_walls_and_twice_by_one_contour() {
    let mut m = mesh(WALLS);
    let ot = e(&m, "o", "t");
    let mid = m.add_vertex(Some("m"), DVec3::new(0.0, 0.0, 0.5));
    let [lo, hi] = m.split_edge(ot, mid);
    ok(&m);
    assert_eq!(m.edge(lo).uses.len(), 3);
    assert_eq!(m.edge(hi).uses.len(), 3);
    assert_eq!(contours(&m, f(&m, "wx")), vec!["o x xt t m"]);
    assert_eq!(contours(&m, f(&m, "wy")), vec!["t yt y o m"]);
    assert_eq!(contours(&m, f(&m, "wn")), vec!["o m t nt n"]);

    let mut k = mesh(
        "v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 0 4 0;
         v e 1 1 0; v f 3 1 0; v g 3 3 0; v h 1 3 0;
         f k (a b c d a e h g f e);",
    );
    let x = k.add_vertex(Some("x"), DVec3::new(0.5, 0.5, 0.0));
    k.split_edge(e(&k, "a", "e"), x);
    ok(&k);
    assert_eq!(contours(&k, FaceId(0)), vec!["a b c d a x e h g f e x"]);
    assert!(close(k.face_area(FaceId(0)), 12.0));
}

#[test]
#[should_panic(expected = "is an end of edge")]
fn split_edge_at_its_own_end_panics() {
    let mut m = mesh(TWO);
    let bc = e(&m, "b", "c");
    let b = v(&m, "b");
    m.split_edge(bc, b);
}

// ----------------------------------------------------------------------
// add_vertex / add_face / names / order
// ----------------------------------------------------------------------

#[test]
fn add_vertex_names_never_collide() {
    let mut m = mesh(TWO);
    let x = m.add_vertex(None, DVec3::ZERO);
    assert_eq!(m.model().vertices[x.idx()].name, "v6");
    let y = m.add_vertex(Some("a"), DVec3::ONE);
    assert_eq!(m.model().vertices[y.idx()].name, "a.2");
    let z = m.add_vertex(Some("a"), DVec3::ONE);
    assert_eq!(m.model().vertices[z.idx()].name, "a.3");
    let w = m.add_vertex(Some("v10"), DVec3::ONE);
    assert_eq!(m.model().vertices[w.idx()].name, "v10");
    let u = m.add_vertex(None, DVec3::ONE);
    assert_eq!(u, VertexId(10));
    assert_eq!(m.model().vertices[u.idx()].name, "v10.2");
    assert!(m.has_vertex_name("a.3"));
    assert_eq!(m.unique_vertex_name("b"), "b.2");
    assert_eq!(m.unique_vertex_name("zz"), "zz");
    ok(&m);
    assert!(m.vertex_edges(x).is_empty());
    // New vertices go after the last vertex statement, in creation order.
    let text = ug::write_string(&m.into_model());
    assert!(
        text.contains("v f 2 1 0;\nv v6 0 0 0;\nv a.2 1 1 1;\nv a.3 1 1 1;\nv v10 1 1 1;\nv v10.2 1 1 1;\nf left"),
        "{text}"
    );
}

#[test]
fn add_vertex_to_a_model_without_vertices() {
    let mut m = Mesh::from_model(parse("c_rgb red 1 0 0;"));
    let a = m.add_vertex(Some("a"), DVec3::ZERO);
    let b = m.add_vertex(Some("b"), DVec3::X);
    let c = m.add_vertex(Some("c"), DVec3::Y);
    let t = m.add_face(
        None,
        Face {
            name: Some("t".into()),
            contours: vec![vec![a, b, c]],
            material: None,
        },
    );
    ok(&m);
    assert!(close(m.face_area(t), 0.5));
    assert_eq!(
        ug::write_string(&m.into_model()),
        "v a 0 0 0;\nv b 1 0 0;\nv c 0 1 0;\nc_rgb red 1 0 0;\nf t (a b c);\n"
    );
}

#[test]
fn add_face_after_parent_keeps_creation_order() {
    let mut m = mesh(TWO);
    let left = f(&m, "left");
    let [a, b, c, d] = ["a", "b", "c", "d"].map(|n| v(&m, n));
    let mk = |name: &str, cs: Vec<Vec<VertexId>>| Face {
        name: Some(name.into()),
        contours: cs,
        material: None,
    };
    // Replace `left` by two triangles placed where it was.
    m.remove_face(left);
    ok(&m);
    let t1 = m.add_face(Some(left), mk("left", vec![vec![a, b, c]]));
    ok(&m);
    let t2 = m.add_face(Some(left), mk("left", vec![vec![a, c, d]]));
    ok(&m);
    let t1x = m.add_face(Some(t1), mk("left", vec![vec![a, c, d]]));
    ok(&m);
    assert_eq!(m.face(t1).name.as_deref(), Some("left.2"));
    assert_eq!(m.face(t2).name.as_deref(), Some("left.3"));
    assert_eq!(m.face(t1x).name.as_deref(), Some("left.4"));
    let end = m.add_face(None, mk("end", vec![vec![a, b, c]]));
    ok(&m);
    assert_eq!(
        m.faces().collect::<Vec<_>>(),
        vec![t1, t1x, t2, f(&m, "right"), end]
    );
    // a-c is now shared by t1 and t2 (and t1x), consistently between t1 and t2.
    let ac = m.edge_between(a, c).unwrap();
    assert_eq!(m.edge(ac).uses.len(), 4);
    assert!(m.has_face_name("left.4"));
    assert_eq!(m.unique_face_name("right"), "right.2");
    let text = ug::write_string(&m.into_model());
    assert!(
        text.ends_with(
            "f left.2 (a b c);\nf left.4 (a c d);\nf left.3 (a c d);\nf right (b e f c);\nf end (a b c);\n"
        ),
        "{text}"
    );
}

#[test]
fn add_face_cleans_and_may_be_born_dead() {
    let mut m = mesh(TWO);
    let [a, b, c] = ["a", "b", "c"].map(|n| v(&m, n));
    let x = m.add_face(
        None,
        Face {
            name: None,
            contours: vec![vec![a, a, b, c, a], vec![a, b], vec![VertexId(500), b]],
            material: None,
        },
    );
    ok(&m);
    assert_eq!(contours(&m, x), vec!["a b c"]);
    let dead = m.add_face(
        None,
        Face {
            name: Some("dead".into()),
            contours: vec![vec![a, b, a]],
            material: None,
        },
    );
    ok(&m);
    assert!(!m.is_face_live(dead));
    assert_eq!(m.num_faces(), 3);
    assert!(m.faces().all(|g| g != dead));
}

#[test]
fn vertex_and_face_attributes() {
    let mut m = mesh(RICH);
    let red = m.model().material_by_name("red").unwrap();
    let a = v(&m, "a");
    m.set_vertex_pos(a, DVec3::new(-1.0, 0.0, 0.0));
    m.set_vertex_color(a, Some(red));
    let right = FaceId(1);
    m.set_face_material(right, Some(red));
    let blue = m.add_material(ug::Material {
        name: "blue".into(),
        def: ug::MaterialDef::Rgb([0.0, 0.0, 1.0]),
    });
    m.set_face_material(FaceId(2), Some(blue));
    ok(&m);
    assert!(close(m.face_area(f(&m, "left")), 1.5));
    let text = ug::write_string(&m.into_model());
    assert!(text.contains("v a -1 0 0 red;"), "{text}");
    assert!(text.contains("f (b e f c) red;"), "{text}");
    assert!(text.contains("end;\nc_rgb blue 0 0 1;\nv a"), "{text}");
    assert!(text.contains("f hole (a b c d) (a d c b) blue;"), "{text}");
}

// ----------------------------------------------------------------------
// remove_face / flip_face / set_face_contours
// ----------------------------------------------------------------------

#[test]
fn remove_face_keeps_other_edge_ids() {
    let mut m = mesh(CUBE);
    let before: Vec<(EdgeId, [VertexId; 2])> = m.edges().map(|x| (x, m.edge(x).v)).collect();
    let top = f(&m, "top");
    m.remove_face(top);
    ok(&m);
    assert_eq!(m.num_edges(), 12);
    let after: Vec<(EdgeId, [VertexId; 2])> = m.edges().map(|x| (x, m.edge(x).v)).collect();
    assert_eq!(before, after);
    assert_eq!(m.edges().filter(|&x| m.is_boundary(x)).count(), 4);
    // Removing a side now kills the top edge it alone used.
    let front = f(&m, "front");
    let ef = e(&m, "e", "f");
    m.remove_face(front);
    ok(&m);
    assert!(!m.is_edge_live(ef));
    assert!(m.edge(ef).uses.is_empty());
    assert_eq!(m.edge_between(v(&m, "e"), v(&m, "f")), None);
    assert_eq!(m.num_edges(), 11);
    assert!(!m.vertex_edges(v(&m, "e")).contains(&ef));
    assert!(m.face_neighbors(f(&m, "bottom")).len() == 3);
}

#[test]
fn flip_face_reverses_keeping_first_vertex() {
    let mut m = mesh(CUBE);
    let top = f(&m, "top");
    m.flip_face(top);
    ok(&m);
    assert_eq!(contours(&m, top), vec!["e h g f"]);
    assert!((m.face_plane(top).unwrap().n + DVec3::Z).length() < 1e-12);
    for x in m.face_edges(top) {
        assert!(m.is_manifold(x));
        assert!(!m.consistently_oriented(x));
    }
    assert_eq!(m.edges().filter(|&x| m.consistently_oriented(x)).count(), 8);
    m.flip_face(top);
    ok(&m);
    assert!(m.edges().all(|x| m.consistently_oriented(x)));

    let mut h = mesh(HOLE_ISLAND);
    let p = FaceId(0);
    h.flip_face(p);
    ok(&h);
    assert_eq!(
        contours(&h, p),
        vec!["o0 o3 o2 o1", "h0 h1 h2 h3", "i0 i3 i2 i1"]
    );
    assert!(close(h.face_area(p), 68.0)); // along its own (flipped) normal
}

#[test]
fn set_face_contours_updates_topology() {
    let mut m = mesh(TWO);
    let right = f(&m, "right");
    let bc = e(&m, "b", "c");
    let [b, e_, f_, c] = ["b", "e", "f", "c"].map(|n| v(&m, n));
    let g = m.add_vertex(Some("g"), DVec3::new(3.0, 0.5, 0.0));
    // Re-plane the right face as a pentagon.
    assert!(m.set_face_contours(right, vec![vec![b, e_, g, f_, c]]));
    ok(&m);
    assert_eq!(e(&m, "b", "c"), bc); // the shared edge keeps its id
    assert!(m.edge_between(e_, f_).is_none());
    assert!(close(m.face_area(right), 1.5));
    // replan_face is the same edit; repeats are cleaned.
    assert!(m.replan_face(right, vec![vec![b, b, e_, f_, c, b]]));
    ok(&m);
    assert_eq!(contours(&m, right), vec!["b e f c"]);
    // Nothing valid left: the face is removed.
    assert!(!m.set_face_contours(right, vec![vec![b, c]]));
    ok(&m);
    assert!(!m.is_face_live(right));
    assert!(m.is_boundary(bc));
    assert!(!m.set_face_contours(right, vec![vec![b, e_, f_]]));
    ok(&m);
}

// ----------------------------------------------------------------------
// replace_vertex / remove_vertex
// ----------------------------------------------------------------------

#[test]
fn replace_vertex_stitches_duplicates() {
    // Two squares with their own copies of the shared corners (b2 = b, c2 = c).
    let mut m = mesh(
        "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;
         v b2 1 0 0; v e 2 0 0; v f 2 1 0; v c2 1 1 0;
         f left (a b c d); f right (b2 e f c2);
         w rail (a b2 c2 c);",
    );
    let (left, right) = (f(&m, "left"), f(&m, "right"));
    assert!(m.face_neighbors(left).is_empty());
    assert!(m.replace_vertex(v(&m, "b2"), v(&m, "b")).is_empty());
    ok(&m);
    assert!(m.vertex_edges(v(&m, "b2")).is_empty());
    assert!(m.replace_vertex(v(&m, "c2"), v(&m, "c")).is_empty());
    ok(&m);
    assert_eq!(m.face_neighbors(left), vec![right]);
    let bc = e(&m, "b", "c");
    assert!(m.is_manifold(bc) && m.consistently_oriented(bc));
    assert_eq!(m.num_edges(), 7);
    assert_eq!(contours(&m, right), vec!["b e f c"]);
    // The wire follows, without the repeat it would get.
    let w = &m.model().wires[0].polylines[0];
    assert_eq!(*w, vec![v(&m, "a"), v(&m, "b"), v(&m, "c")]);
    // Unused now: b2 can go, b cannot.
    assert!(m.remove_vertex(v(&m, "b2")));
    assert!(!m.remove_vertex(v(&m, "b2")));
    assert!(!m.remove_vertex(v(&m, "b")));
    assert!(!m.is_vertex_live(v(&m, "b2")));
    ok(&m);
    let text = ug::write_string(&m.into_model());
    assert!(!text.contains("b2"), "{text}");
    assert!(text.contains("v c2 1 1 0;"), "{text}");
}

#[test]
fn replace_vertex_removes_degenerate_faces_and_contours() {
    let mut m = mesh(
        "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v x 0.5 0.5 0;
         v o0 -5 -5 0; v o1 5 -5 0; v o2 5 5 0; v o3 -5 5 0;
         v h0 2 2 0; v h1 3 2 0; v h2 3 3 0;
         f tri (a b x);
         f sq (a b c d);
         f plate (o0 o1 o2 o3) (h0 h2 h1);
         w line (x h0);",
    );
    let removed = m.replace_vertex(v(&m, "x"), v(&m, "a"));
    ok(&m);
    assert_eq!(removed, vec![f(&m, "tri")]);
    assert!(!m.is_face_live(f(&m, "tri")));
    // The hole collapses (h2 → h1 leaves two vertices): dropped, plate stays.
    let removed = m.replace_vertex(v(&m, "h2"), v(&m, "h1"));
    ok(&m);
    assert!(removed.is_empty());
    assert_eq!(contours(&m, f(&m, "plate")), vec!["o0 o1 o2 o3"]);
    // The outer contour collapses: the face goes.
    let removed = m.replace_vertex(v(&m, "c"), v(&m, "b"));
    ok(&m);
    assert!(removed.is_empty()); // (a b d) is still a triangle
    assert_eq!(contours(&m, f(&m, "sq")), vec!["a b d"]);
    let removed = m.replace_vertex(v(&m, "d"), v(&m, "b"));
    ok(&m);
    assert_eq!(removed, vec![f(&m, "sq")]);
    // No-ops.
    assert!(m.replace_vertex(v(&m, "a"), v(&m, "a")).is_empty());
    assert!(m.replace_vertex(v(&m, "a"), VertexId(999)).is_empty());
    ok(&m);
    assert_eq!(
        m.model().wires[0].polylines[0],
        vec![v(&m, "a"), v(&m, "h0")]
    );
}

#[test]
fn replace_vertex_merges_edges_into_existing_ones() {
    // Two triangles, one with a vertex y that duplicates c.
    let mut m = mesh(
        "v a 0 0 0; v b 1 0 0; v c 0 1 0; v y 0 1 0; v d 1 1 0;
         f t1 (a b c); f t2 (b d y); f t3 (y c d);",
    );
    let bc = e(&m, "b", "c");
    let removed = m.replace_vertex(v(&m, "y"), v(&m, "c"));
    ok(&m);
    assert_eq!(removed, vec![f(&m, "t3")]);
    assert_eq!(e(&m, "b", "c"), bc);
    assert!(m.consistently_oriented(bc));
    assert_eq!(m.edge(e(&m, "c", "d")).uses.len(), 1);
}

// ----------------------------------------------------------------------
// merge_faces
// ----------------------------------------------------------------------

#[test]
fn merge_two_squares() {
    let mut m = mesh(TWO);
    let (left, right) = (f(&m, "left"), f(&m, "right"));
    let ab = e(&m, "a", "b");
    let ef = e(&m, "e", "f");
    let bc = e(&m, "b", "c");
    assert_eq!(m.merge_faces(left, right), Ok(left));
    ok(&m);
    assert_eq!(contours(&m, left), vec!["a b e f c d"]);
    assert!(!m.is_face_live(right));
    assert!(!m.is_edge_live(bc));
    assert_eq!(m.num_edges(), 6);
    // Surviving edges keep their ids.
    assert_eq!(e(&m, "a", "b"), ab);
    assert_eq!(e(&m, "e", "f"), ef);
    assert!(close(m.face_area(left), 2.0));
    assert!(m.edges().all(|x| m.is_boundary(x)));
    assert_eq!(m.faces().collect::<Vec<_>>(), vec![left]);
}

#[test]
fn merge_keeps_name_material_and_place() {
    let mut m = mesh(RICH);
    let left = f(&m, "left");
    let unnamed = FaceId(1);
    // `hole` shares edges too (two contours over a b c d); merge the unnamed one into left.
    assert_eq!(m.merge_faces(unnamed, left), Ok(unnamed));
    ok(&m);
    assert_eq!(m.face(unnamed).name, None);
    let text = ug::write_string(&m.into_model());
    assert!(
        text.contains("v f 2 1 0;\nl sun 1 2 3;\nf (b e f c d a) lamp;\nw rail"),
        "{text}"
    );
}

#[test]
fn merge_errors_leave_the_mesh_alone() {
    let mut m = mesh(CUBE);
    let (top, bottom, front) = (f(&m, "top"), f(&m, "bottom"), f(&m, "front"));
    assert_eq!(m.merge_faces(top, top), Err(MergeError::SameFace));
    assert_eq!(m.merge_faces(top, bottom), Err(MergeError::NotAdjacent));
    m.remove_face(front);
    assert_eq!(m.merge_faces(top, front), Err(MergeError::DeadFace(front)));
    assert_eq!(m.merge_faces(front, top), Err(MergeError::DeadFace(front)));
    ok(&m);
    assert_eq!(m.num_faces(), 5);
    assert_eq!(
        MergeError::NotAdjacent.to_string(),
        "the faces share no edge"
    );

    // A face and its mirror image: nothing is left.
    let mut m = mesh("v a 0 0 0; v b 1 0 0; v c 1 1 0; f x (a b c); f y (a c b);");
    assert_eq!(
        m.merge_faces(FaceId(0), FaceId(1)),
        Err(MergeError::Degenerate)
    );
    ok(&m);
    assert_eq!(m.num_faces(), 2);
}

#[test]
fn merge_reverses_b_when_it_is_wound_the_other_way() {
    let mut m = mesh(
        "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 2 0 0; v f 2 1 0;
         f left (a b c d); f right (b c f e);",
    );
    let bc = e(&m, "b", "c");
    assert!(!m.consistently_oriented(bc));
    let left = f(&m, "left");
    m.merge_faces(left, f(&m, "right")).unwrap();
    ok(&m);
    assert_eq!(contours(&m, left), vec!["a b e f c d"]);
    assert!(close(m.face_area(left), 2.0));
}

#[test]
fn merge_ring_of_eight_into_face_with_hole() {
    // Several orders, including one whose intermediate face touches itself at
    // a vertex (the C-shaped seven cells around the window).
    let orders: [&[&str]; 4] = [
        &["c00", "c10", "c20", "c21", "c22", "c12", "c02", "c01"],
        &["c10", "c20", "c21", "c22", "c12", "c02", "c01", "c00"],
        &["c22", "c00", "c01", "c02", "c12", "c10", "c20", "c21"],
        &["c01", "c21", "c00", "c12", "c02", "c20", "c22", "c10"],
    ];
    for order in orders {
        let mut m = mesh(&ring8());
        let a = f(&m, order[0]);
        let mut pending: Vec<FaceId> = order[1..].iter().map(|n| f(&m, n)).collect();
        // Merge whichever pending face is adjacent, in the given order.
        while !pending.is_empty() {
            let k = pending
                .iter()
                .position(|&b| m.face_neighbors(a).contains(&b))
                .expect("some pending face is adjacent");
            let b = pending.remove(k);
            assert_eq!(m.merge_faces(a, b), Ok(a));
            ok(&m);
            assert!(close(total_area(&m), 8.0));
        }
        assert_eq!(m.num_faces(), 1);
        let cs = contours(&m, a);
        assert_eq!(cs.len(), 2, "{order:?}: {cs:?}");
        let pts = m.face_points(a);
        assert!(close(geom::face_area(&pts[..1]), 9.0), "{order:?}: {cs:?}");
        assert!(close(m.face_area(a), 8.0));
        let mut hole: Vec<&str> = cs[1].split(' ').collect();
        hole.sort();
        assert_eq!(hole, vec!["p11", "p12", "p21", "p22"]);
        assert_eq!(m.num_edges(), 12 + 4);
        assert!(m.edges().all(|x| m.is_boundary(x)));
    }
}

#[test]
fn merge_closing_a_pinch_splits_the_boundary_there() {
    // Seven cells in a C around the window, ends touching at p11.
    let mut m = mesh(&ring8());
    let a = f(&m, "c10");
    for n in ["c20", "c21", "c22", "c12", "c02", "c01"] {
        m.merge_faces(a, f(&m, n)).unwrap();
        ok(&m);
    }
    let cs = contours(&m, a);
    // The outer boundary and the window meet only at p11: two contours.
    assert_eq!(cs.len(), 2, "{cs:?}");
    assert!(cs.iter().all(|c| c.split(' ').any(|x| x == "p11")));
    assert!(close(m.face_area(a), 7.0));
    let pts = m.face_points(a);
    assert!(close(geom::face_area(&pts[..1]), 8.0));
    assert!(close(geom::newell_normal(&pts[1]).z / 2.0, -1.0));
}

#[test]
fn merge_fills_a_hole() {
    let mut m = mesh(
        "v o0 0 0 0; v o1 4 0 0; v o2 4 4 0; v o3 0 4 0;
         v h0 1 1 0; v h1 3 1 0; v h2 3 3 0; v h3 1 3 0;
         f frame (o0 o1 o2 o3) (h0 h3 h2 h1);
         f plug (h0 h1 h2 h3);",
    );
    let (fr, plug) = (f(&m, "frame"), f(&m, "plug"));
    assert_eq!(m.face_neighbors(fr), vec![plug]);
    m.merge_faces(fr, plug).unwrap();
    ok(&m);
    assert_eq!(contours(&m, fr), vec!["o0 o1 o2 o3"]);
    assert!(close(m.face_area(fr), 16.0));
    assert_eq!(m.num_edges(), 4);
    // The other way round: the plug absorbs the frame and the outer contour
    // is the frame's (largest area wound like the plug).
    let mut m = mesh(
        "v o0 0 0 0; v o1 4 0 0; v o2 4 4 0; v o3 0 4 0;
         v h0 1 1 0; v h1 3 1 0; v h2 3 3 0; v h3 1 3 0;
         f frame (o0 o1 o2 o3) (h0 h3 h2 h1);
         f plug (h0 h1 h2 h3);",
    );
    let (fr, plug) = (f(&m, "frame"), f(&m, "plug"));
    m.merge_faces(plug, fr).unwrap();
    ok(&m);
    assert_eq!(contours(&m, plug), vec!["o0 o1 o2 o3"]);
}

#[test]
fn merge_along_several_edges_and_with_island() {
    // An L-shaped face and a square fitting its notch share two edges.
    let mut m = mesh(
        "v a 0 0 0; v b 2 0 0; v c 2 1 0; v d 1 1 0; v e 1 2 0; v g 0 2 0; v h 2 2 0;
         v i0 0.2 0.2 0; v i1 0.6 0.2 0; v i2 0.6 0.6 0; v i3 0.2 0.6 0;
         v j0 0.3 0.3 0; v j1 0.5 0.3 0; v j2 0.5 0.5 0;
         f l (a b c d e g) (i0 i3 i2 i1) (j0 j1 j2);
         f notch (d c h e);",
    );
    let (l, notch) = (f(&m, "l"), f(&m, "notch"));
    let before = m.face_area(l) + m.face_area(notch);
    assert!(close(before, 4.0 - 0.16 + 0.02));
    m.merge_faces(l, notch).unwrap();
    ok(&m);
    let cs = contours(&m, l);
    assert_eq!(cs, vec!["a b c h e g", "i0 i3 i2 i1", "j0 j1 j2"]);
    assert!(close(m.face_area(l), before));
    assert!(m.vertex_edges(v(&m, "d")).is_empty());
}

#[test]
fn merge_of_non_manifold_walls() {
    let mut m = mesh(WALLS);
    let (wx, wy, wn) = (f(&m, "wx"), f(&m, "wy"), f(&m, "wn"));
    let ot = e(&m, "o", "t");
    // wx walks t→o, wy walks o→t: they merge into a bent face; wn keeps the edge.
    m.merge_faces(wx, wy).unwrap();
    ok(&m);
    assert_eq!(m.edge(ot).uses.len(), 1);
    assert_eq!(m.edge(ot).uses[0].face, wn);
    assert_eq!(contours(&m, wx), vec!["o x xt t yt y"]);
    assert_eq!(m.face_neighbors(wn), Vec::<FaceId>::new());
    assert!(m.is_boundary(ot));
}

#[test]
fn merge_keyhole_face_normalizes_the_bridge() {
    let mut m = mesh(
        "v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 0 4 0;
         v e 1 1 0; v f 3 1 0; v g 3 3 0; v h 1 3 0; v x 8 0 0; v y 8 4 0;
         f k (a b c d a e h g f e);
         f side (b x y c);",
    );
    let (k, side) = (f(&m, "k"), f(&m, "side"));
    m.merge_faces(k, side).unwrap();
    ok(&m);
    let cs = contours(&m, k);
    assert_eq!(cs, vec!["a b x y c d", "e h g f"]);
    assert!(close(m.face_area(k), 32.0 - 4.0));
    assert!(m.edge_between(v(&m, "a"), v(&m, "e")).is_none());
}

#[test]
fn merge_in_a_tilted_plane() {
    // The two squares rotated out of the xy plane.
    let model = parse(TWO);
    let rot = glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 1.1);
    let mut model2 = model.clone();
    for x in &mut model2.vertices {
        x.pos = rot * x.pos + DVec3::new(5.0, -3.0, 7.0);
    }
    let mut m = Mesh::from_model(model2);
    let (left, right) = (f(&m, "left"), f(&m, "right"));
    m.merge_faces(left, right).unwrap();
    ok(&m);
    assert_eq!(contours(&m, left), vec!["a b e f c d"]);
    assert!(close(m.face_area(left), 2.0));
}

// ----------------------------------------------------------------------
// validate catches corruption
// ----------------------------------------------------------------------

#[test]
fn validate_detects_broken_invariants() {
    let base = mesh(TWO);
    let bc = e(&base, "b", "c");

    let mut m = base.clone();
    m.edges[bc.idx()].uses.pop();
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.edges[bc.idx()].uses[0].forward = false;
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.edges[bc.idx()].uses.reverse();
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.model.faces[0].contours[0][1] = m.model.faces[0].contours[0][0];
    assert!(m.validate().unwrap_err().contains("distinct") || m.validate().is_err());

    let mut m = base.clone();
    let a = m.model.faces[0].contours[0][0];
    m.model.faces[0].contours[0].insert(1, a);
    m.contour_edges[0][0].insert(1, bc);
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.vertex_edges[v(&base, "a").idx()].clear();
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.edge_map.clear();
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.face_live[1] = false;
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.contour_edges[0][0].swap(0, 1);
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.live_edges += 1;
    assert!(m.validate().is_err());

    let mut m = base.clone();
    m.vertex_live[0] = false;
    assert!(m.validate().is_err());

    let mut m = base;
    m.model.faces[1].contours[0].truncate(2);
    assert!(m.validate().is_err());
}

#[test]
fn merging_a_whole_cube_ends_degenerate() {
    let mut m = mesh(CUBE);
    let a = f(&m, "bottom");
    for n in ["front", "right", "back", "left"] {
        assert_eq!(m.merge_faces(a, f(&m, n)), Ok(a));
        ok(&m);
    }
    // An open box: its rim is the top's outline, walked the other way.
    assert_eq!(contours(&m, a), vec!["h g f e"]);
    let top = f(&m, "top");
    assert_eq!(m.merge_faces(a, top), Err(MergeError::Degenerate));
    ok(&m);
    assert!(m.edges().all(|x| m.consistently_oriented(x)));
}

#[test]
fn faces_and_vertices_outside_the_statements() {
    // A hand-built model: face 1 is in the arena only, vertex d has no statement.
    let mut model = parse("v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; f t (a b c); f u (a c d);");
    model
        .items
        .retain(|it| *it != ug::Item::Face(FaceId(1)) && *it != ug::Item::Vertex(VertexId(3)));
    let m = Mesh::from_model(model);
    ok(&m);
    assert_eq!(m.num_faces(), 1);
    assert!(!m.is_face_live(FaceId(1)));
    assert_eq!(m.vertices().count(), 4);
    assert_eq!(
        ug::write_string(&m.into_model()),
        "v a 0 0 0;\nv b 1 0 0;\nv c 1 1 0;\nv d 0 1 0;\nf t (a b c);\n"
    );
}

/// A tent (a vertex 0.75 above the chord between its neighbours, which
/// are 1.7 apart, epsilon 1) joins the nearer neighbour in every face that
/// uses it; a vertex as far off a long chord stays.
#[test]
fn tents_join_the_nearer_neighbour() {
    let mut m = mesh(
        "v a 0 0 0; v b 1000 0 0; v u 600 0 0; v t 600.8 0.75 0; v w 601.7 0 0; \
         v c 1000 1000 0; v d 0 1000 0; v k 300 -0.5 0; v x 600.9 500 0; \
         v y 700 500 0; f A (a k u t w b c d); f B (u x t); f C (t x y w);",
    );
    let (n, dropped) = crate::weld::collapse_tents(&mut m, 1.0);
    ok(&m);
    assert_eq!(n, 1);
    // t is 1.10 from u and 1.17 from w: it joins u, and B (u x t) is left
    // without area.
    assert_eq!(dropped.len(), 1, "{dropped:?}");
    assert_eq!(dropped[0].0, f(&m, "B"));
    assert_eq!(contours(&m, f(&m, "A")), ["a k u w b c d"]);
    assert_eq!(contours(&m, f(&m, "C")), ["u x y w"]);
    // k is 0.5 off the chord a–u, but that chord is 600 long: no tent.
    let (n, _) = crate::weld::collapse_tents(&mut m, 1.0);
    assert_eq!(n, 0);
}

/// With a test of the join ([`crate::weld::collapse_tents_with`]), the tip
/// joins the nearer neighbour only if the test takes it, else the farther
/// one if the test takes that; where it takes neither, as without.
#[test]
fn a_tents_tip_joins_the_neighbour_the_test_takes() {
    let src = "v a 0 0 0; v b 1000 0 0; v u 600 0 0; v t 600.8 0.75 0; v w 601.7 0 0; \
               v c 1000 1000 0; v d 0 1000 0; v x 600.9 500 0; \
               v y 700 500 0; f A (a u t w b c d); f C (t x y w);";
    let names = |m: &crate::Mesh, v: VertexId| m.model().vertices[v.idx()].name.clone();
    // Refusing u: t joins w, the farther.
    let mut m = mesh(src);
    let not_u = |m: &crate::Mesh, _: VertexId, to: VertexId| names(m, to) != "u";
    let (n, _) = crate::weld::collapse_tents_with(&mut m, 1.0, &not_u);
    ok(&m);
    assert_eq!(n, 1);
    assert_eq!(contours(&m, f(&m, "A")), ["a u w b c d"]);
    assert_eq!(contours(&m, f(&m, "C")), ["w x y"]);
    // Refusing both: the nearer, u, as without a test.
    let mut m = mesh(src);
    let none = |_: &crate::Mesh, _: VertexId, _: VertexId| false;
    let (n, _) = crate::weld::collapse_tents_with(&mut m, 1.0, &none);
    assert_eq!(n, 1);
    assert_eq!(contours(&m, f(&m, "C")), ["u x y w"]);
}

/// Names of `near_twin_joins`' joins, per pair.
fn twin_joins(src: &str, eps: f64) -> Vec<Vec<(String, String)>> {
    let m = parse(src);
    let name = |v: VertexId| m.vertices[v.idx()].name.clone();
    crate::weld::near_twin_joins(&m, eps)
        .into_iter()
        .map(|p| p.into_iter().map(|(a, b)| (name(a), name(b))).collect())
        .collect()
}

/// A box's foot 4 mm under the floor it stands on (epsilon 2.1 mm): the
/// foot's corners join the floor's, the box's sides taking the move along
/// their planes; the floor's extra point on an edge (for a neighbour) is
/// no obstacle. Not: 5 mm apart, facing the same way, or where the move
/// would bend a face (a wedge's thin end).
#[test]
fn near_twins_back_to_back_join() {
    let floor = "v f0 0 0 3; v f1 1 0 3; v fm 1 0.4 3; v f2 1 1 3; v f3 0 1 3;\n\
                 f floor (f0 f1 fm f2 f3);\n";
    let boxed = |z: &str, foot: &str| {
        format!(
            "v b0 0 0 {z}; v b1 1 0 {z}; v b2 1 1 {z}; v b3 0 1 {z};\n\
             v t0 0 0 3.5; v t1 1 0 3.5; v t2 1 1 3.5; v t3 0 1 3.5;\n\
             f foot ({foot});\n\
             f s0 (b0 b1 t1 t0); f s1 (b1 b2 t2 t1); f s2 (b2 b3 t3 t2); f s3 (b3 b0 t0 t3);\n"
        )
    };
    let eps = 0.0021;
    let src = format!("{floor}{}", boxed("2.996", "b0 b3 b2 b1"));
    let got = twin_joins(&src, eps);
    let pairs = |v: &[(&str, &str)]| -> Vec<(String, String)> {
        v.iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    };
    assert_eq!(
        got,
        vec![pairs(&[
            ("b0", "f0"),
            ("b1", "f1"),
            ("b2", "f2"),
            ("b3", "f3")
        ])]
    );
    // Too far apart for one region.
    let src = format!("{floor}{}", boxed("2.995", "b0 b3 b2 b1"));
    assert!(twin_joins(&src, eps).is_empty());
    // Facing the same way: coincident, ugclean's business.
    let src = format!("{floor}{}", boxed("2.996", "b0 b1 b2 b3"));
    assert!(twin_joins(&src, eps).is_empty());
    // Both faces have a neighbour in their plane sharing one corner (a
    // hexagon): either move would bend one by more than half an epsilon.
    let hex = |p: &str, z: &str, c: &str| {
        format!(
            "v {p}1 1.1 0 {z}; v {p}2 1.5 -0.2 {z}; v {p}3 2 0 {z}; v {p}4 2 0.5 {z}; v {p}5 1.5 0.7 {z};\n\
             f {p}hex ({});\n",
            c
        )
    };
    let src = format!(
        "{floor}{}{}{}",
        boxed("2.996", "b0 b3 b2 b1"),
        hex("n", "3", "f1 n1 n2 n3 n4 n5"),
        "v m1 0.8 -0.6 2.996; v m2 0.4 -0.8 2.996; v m3 0 -0.6 2.996; v m4 0.1 -0.2 2.996;\n\
         v m5 0.5 -0.05 2.996; f mhex (b1 m5 m4 m3 m2 m1);\n",
    );
    let got = twin_joins(&src, eps);
    assert!(got.is_empty(), "{got:?}");
}
