use glam::DVec3;
use ug::Model;

use crate::refine::{ChildEdge, child_edge};
use crate::*;

const EPS: f64 = 1e-9;

fn parse(src: &str) -> Model {
    ug::parse(src.as_bytes(), "<test>").unwrap().model
}

fn mesh(src: &str) -> (Model, Mesh) {
    let m = parse(src);
    let mesh = Mesh::from_model(&m, EPS).unwrap();
    (m, mesh)
}

/// An `nx` × `ny` grid of unit quads in the z = 0 plane, vertices `gI_J`, faces `qI_J`.
fn grid(nx: usize, ny: usize) -> String {
    let mut s = String::from("c_rgb grey 0.5 0.5 0.5;\n");
    for j in 0..=ny {
        for i in 0..=nx {
            s += &format!("v g{i}_{j} {i} {j} 0;\n");
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            s += &format!(
                "f q{i}_{j} (g{i}_{j} g{}_{j} g{}_{} g{i}_{}) grey;\n",
                i + 1,
                i + 1,
                j + 1,
                j + 1
            );
        }
    }
    s
}

/// Floor (z = 0, facing up) and wall (y = 0, facing +y) sharing the edge a–b.
const FLOOR_WALL: &str = "c_rgb grey 0.5 0.5 0.5;
v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 0 0 1; v f 1 0 1;
f floor (a b c d) grey;
f wall (a e f b) grey;";

/// The leaf of patch `p` whose polygon contains point `x` (strictly inside).
fn leaf_at(m: &Mesh, p: PatchId, x: DVec3) -> ElemId {
    let n = m.surface_normal(m.patch_surface(p));
    m.patch_leaves(p)
        .into_iter()
        .find(|&e| {
            let c = m.elem_corners(e);
            (0..c.len()).all(|k| {
                let a = m.vertex_pos(c[k]);
                let b = m.vertex_pos(c[(k + 1) % c.len()]);
                (b - a).cross(x - a).dot(n) > 0.0
            })
        })
        .expect("a leaf contains the point")
}

fn ugcheck_clean(src: &Model, m: &Mesh) {
    let out = m.to_model(src);
    let r = check::check(&out, 1e-9);
    assert!(r.tvertices.is_empty(), "T-vertices: {:?}", r.tvertices);
    assert!(r.degenerate.is_empty(), "degenerate: {:?}", r.degenerate);
    assert!(
        r.inconsistent.is_empty(),
        "inconsistent: {:?}",
        r.inconsistent
    );
    assert!(r.nonpatch.is_empty(), "nonpatch: {:?}", r.nonpatch);
}

#[test]
fn element_record_is_32_bytes() {
    assert_eq!(std::mem::size_of::<Elem>(), 32);
    assert_eq!(Mesh::record_sizes().0, 32);
}

#[test]
fn child_edge_table_matches_the_split_layout() {
    for src in [
        grid(1, 1),
        "v a 0 0 0; v b 1 0 0; v c 0 1 0; f t (a b c);".to_string(),
    ] {
        let (_, mut m) = mesh(&src);
        m.split(ElemId(0));
        let root = m.elems[0];
        let n = root.n();
        for c in 0..4usize {
            let ch = m.elems[(root.children + c as u32) as usize];
            for k in 0..n {
                let (a, b) = (ch.v[k], ch.v[(k + 1) % n]);
                match child_edge(n, c, k) {
                    ChildEdge::Sibling { child, edge } => {
                        let s = m.elems[(root.children + child as u32) as usize];
                        assert_eq!(
                            (s.v[edge], s.v[(edge + 1) % n]),
                            (b, a),
                            "n={n} c={c} k={k}"
                        );
                    }
                    ChildEdge::Parent { j, half } => {
                        let (p0, p1) = (root.v[j], root.v[(j + 1) % n]);
                        let mid = m.edge_midpoint(p0, p1).unwrap();
                        let want = if half == 0 { (p0, mid) } else { (mid, p1) };
                        assert_eq!((a, b), want, "n={n} c={c} k={k}");
                        assert_eq!(ch.pedge(k), j as u16);
                    }
                }
            }
        }
    }
}

#[test]
fn single_quad_split() {
    let (src, mut m) = mesh(&grid(1, 1));
    assert_eq!(
        (m.num_patches(), m.num_surfaces(), m.num_vertices()),
        (1, 1, 4)
    );
    assert_eq!(m.surface_normal(SurfaceId(0)), DVec3::Z);
    let s = m.split(ElemId(0));
    assert_eq!(s.refined, vec![ElemId(0)]);
    assert_eq!(s.new_vertices.len(), 5);
    let ids: Vec<u32> = s.new_vertices.iter().map(|n| n.v.0).collect();
    assert_eq!(ids, vec![4, 5, 6, 7, 8]);
    for nv in &s.new_vertices {
        let [a, b] = nv.parents;
        assert_eq!(
            m.vertex_pos(nv.v),
            (m.vertex_pos(a) + m.vertex_pos(b)) * 0.5
        );
    }
    assert_eq!(m.vertex_pos(VertId(8)), DVec3::new(0.5, 0.5, 0.0));
    assert_eq!(m.num_leaves(), 4);
    let leaves: Vec<ElemId> = m.leaves().collect();
    assert_eq!(leaves, vec![ElemId(1), ElemId(2), ElemId(3), ElemId(4)]);
    for &e in &leaves {
        assert_eq!(m.elem_level(e), 1);
        assert_eq!(m.elem_area(e), 0.25);
        assert_eq!(m.elem_longest_edge(e), 0.5);
        assert_eq!(m.elem_patch(e), PatchId(0));
        assert_eq!(m.elem_parent(e), Some(ElemId(0)));
        assert_eq!(m.anchored(e), vec![m.elem_corners(e).to_vec()]);
    }
    // Child c keeps corner c.
    for (c, &e) in leaves.iter().enumerate() {
        assert_eq!(m.elem_corners(e)[c], m.patch_corners(PatchId(0))[c]);
    }
    assert_eq!(m.elem_neighbors(ElemId(1)), vec![ElemId(2), ElemId(4)]);
    // Splitting a non-leaf does nothing.
    assert_eq!(m.split(ElemId(0)), Split::default());
    assert_eq!(m.split(ElemId(99)), Split::default());
    m.validate().unwrap();
    ugcheck_clean(&src, &m);
}

#[test]
fn quad_split_in_one_corner_forces_balance() {
    let (src, mut m) = mesh(&grid(1, 1));
    let p = PatchId(0);
    m.split(ElemId(0));
    // Always split the leaf just below and left of the centre: each split
    // pushes the refinement one level deeper against the coarse quadrants.
    let x = DVec3::new(0.49, 0.49, 0.0);
    let mut refined_counts = Vec::new();
    for _ in 0..4 {
        let e = leaf_at(&m, p, x);
        let s = m.split(e);
        assert_eq!(s.refined[0], e);
        refined_counts.push(s.refined.len());
        m.validate().unwrap();
        assert!(m.unbalanced_pairs(p).is_empty());
    }
    // Level 2 needs nothing; level 3 splits the two level-1 quadrants at the
    // centre; level 4 splits their children at the centre and, for those, the
    // third quadrant; level 5 likewise one level down.
    assert_eq!(refined_counts, vec![1, 3, 4, 4]);
    let lv = |x: f64, y: f64| m.elem_level(leaf_at(&m, p, DVec3::new(x, y, 0.0)));
    assert_eq!(lv(0.49, 0.49), 5);
    assert_eq!(lv(0.51, 0.49), 4);
    assert_eq!(lv(0.49, 0.51), 4);
    assert_eq!(lv(0.51, 0.51), 3);
    assert_eq!(lv(0.99, 0.01), 2);
    assert_eq!(lv(0.99, 0.99), 2);
    assert_eq!(lv(0.01, 0.01), 2);
    ugcheck_clean(&src, &m);
}

#[test]
fn triangle_split() {
    let (src, mut m) = mesh("v a 0 0 0; v b 2 0 0; v c 0 2 0; f t (a b c);");
    let s = m.split(ElemId(0));
    assert_eq!(s.new_vertices.len(), 3);
    let leaves: Vec<ElemId> = m.leaves().collect();
    assert_eq!(leaves.len(), 4);
    let [a, b, c] = [VertId(0), VertId(1), VertId(2)];
    let m01 = m.edge_midpoint(a, b).unwrap();
    let m12 = m.edge_midpoint(b, c).unwrap();
    let m20 = m.edge_midpoint(c, a).unwrap();
    assert_eq!(m.elem_corners(leaves[0]), &[a, m01, m20]);
    assert_eq!(m.elem_corners(leaves[1]), &[m01, b, m12]);
    assert_eq!(m.elem_corners(leaves[2]), &[m20, m12, c]);
    assert_eq!(m.elem_corners(leaves[3]), &[m12, m20, m01]);
    for &e in &leaves {
        assert!((m.elem_area(e) - 0.5).abs() < 1e-15);
    }
    // The centre child's neighbours are the three corner children.
    assert_eq!(
        m.elem_neighbors(leaves[3]),
        vec![leaves[2], leaves[0], leaves[1]]
    );
    // Split the centre child twice more towards the centre: balance splits corner children.
    let s = m.split(leaves[3]);
    assert_eq!(s.refined, vec![leaves[3]]);
    let inner = m.elem_children(leaves[3]).unwrap()[3];
    let s = m.split(inner);
    assert_eq!(s.refined.len(), 1);
    let x = m.elem_centroid(m.elem_children(inner).unwrap()[0]);
    let e = leaf_at(&m, PatchId(0), x);
    let s = m.split(e);
    assert!(s.refined.len() > 1, "{:?}", s.refined);
    m.validate().unwrap();
    assert!(m.unbalanced_pairs(PatchId(0)).is_empty());
    let total: f64 = m.leaves().map(|e| m.elem_area(e)).sum();
    assert!((total - 2.0).abs() < 1e-12);
    ugcheck_clean(&src, &m);
}

#[test]
fn balance_crosses_patch_boundaries() {
    let (src, mut m) = mesh(&grid(2, 1));
    assert_eq!(
        (m.num_patches(), m.num_surfaces(), m.num_vertices()),
        (2, 1, 6)
    );
    m.split(ElemId(0));
    // Child 1 of patch 0 touches the shared edge x = 1; its children would be
    // two levels deeper than the unsplit patch 1.
    let c1 = m.elem_children(ElemId(0)).unwrap()[1];
    assert_eq!(
        m.elem_neighbors(c1),
        vec![
            ElemId(1),
            m.elem_children(ElemId(0)).unwrap()[2],
            m.elem_children(ElemId(0)).unwrap()[0]
        ]
    );
    let s = m.split(c1);
    assert_eq!(s.refined, vec![c1, ElemId(1)]);
    // The shared edge's midpoint was made once and is shared.
    let g10 = VertId(1);
    let g11 = VertId(2);
    assert_eq!(m.vertex_pos(g10), DVec3::new(1.0, 0.0, 0.0));
    let mid = m.edge_midpoint(g10, g11).unwrap();
    assert!(
        m.elem_corners(m.elem_children(ElemId(0)).unwrap()[1])
            .contains(&mid)
    );
    assert!(
        m.elem_corners(m.elem_children(ElemId(1)).unwrap()[0])
            .contains(&mid)
    );
    m.validate().unwrap();
    // Patch 1's child 0 has hanging midpoints from patch 0's grandchildren.
    let p1c0 = m.elem_children(ElemId(1)).unwrap()[0];
    assert_eq!(m.anchored(p1c0).len(), 3);
    ugcheck_clean(&src, &m);
}

#[test]
fn stitching_floor_and_wall() {
    let (src, mut m) = mesh(FLOOR_WALL);
    assert_eq!(m.num_surfaces(), 2);
    assert_eq!(m.num_vertices(), 8, "a and b have one copy per surface");
    assert_eq!(m.surface_normal(SurfaceId(0)), DVec3::Z);
    assert_eq!(m.surface_normal(SurfaceId(1)), DVec3::Y);
    let floor = PatchId(0);
    let wall = PatchId(1);
    let [fa, fb, _, _]: [VertId; 4] = m.patch_corners(floor).try_into().unwrap();
    let [wa, _, _, wb]: [VertId; 4] = m.patch_corners(wall).try_into().unwrap();
    assert_ne!(fa, wa);
    assert_eq!(m.vertex_pos(fa), m.vertex_pos(wa));
    assert_eq!(m.vertex_surface(wa), SurfaceId(1));

    let s = m.split(m.patch_root(floor));
    assert_eq!(
        s.refined,
        vec![m.patch_root(floor)],
        "the wall is not split"
    );
    // The floor's midpoint of a-b, then the wall's stitched copy, then the rest.
    let fm = m.edge_midpoint(fa, fb).unwrap();
    let wm = m.edge_midpoint(wa, wb).unwrap();
    assert_eq!(
        s.new_vertices[0],
        NewVertex {
            v: fm,
            parents: [fa, fb]
        }
    );
    assert_eq!(
        s.new_vertices[1],
        NewVertex {
            v: wm,
            parents: [wa, wb]
        }
    );
    assert_eq!(s.new_vertices.len(), 6);
    assert_eq!(m.vertex_pos(wm), DVec3::new(0.5, 0.0, 0.0));
    assert_eq!(m.vertex_surface(wm), SurfaceId(1));
    // The wall leaf keeps its corners; its anchored contour holds the copy.
    let wroot = m.patch_root(wall);
    assert!(m.elem_is_leaf(wroot));
    assert_eq!(m.elem_contour(wroot).len(), 5);
    let pieces = m.anchored(wroot);
    assert_eq!(pieces.len(), 3);
    assert!(
        pieces.iter().all(|p| p[0] == wm),
        "fanned from the stitched vertex"
    );
    m.validate().unwrap();
    ugcheck_clean(&src, &m);

    // Deeper floor refinement along the edge: a chain of stitched vertices.
    let fc0 = m.elem_children(m.patch_root(floor)).unwrap()[0];
    let s = m.split(fc0);
    assert_eq!(s.refined, vec![fc0]);
    let q = m.edge_midpoint(fa, fm).unwrap();
    let wq = m.edge_midpoint(wa, wm).unwrap();
    assert!(s.new_vertices.contains(&NewVertex {
        v: wq,
        parents: [wa, wm]
    }));
    assert_eq!(m.vertex_pos(wq), m.vertex_pos(q));
    assert_eq!(m.edge_vertices(wb, wa), vec![wm, wq]);
    let pieces = m.anchored(wroot);
    assert!(pieces.len() >= 3, "{pieces:?}");
    m.validate().unwrap();
    ugcheck_clean(&src, &m);

    // The wall now splits: it reuses the stitched vertex, nothing goes back.
    let s = m.split(wroot);
    assert_eq!(
        s.new_vertices.len(),
        4,
        "three edge midpoints and the centre"
    );
    assert!(!s.new_vertices.iter().any(|n| n.v == wm));
    let wc0 = m.elem_children(wroot).unwrap()[0];
    assert_eq!(m.elem_corners(wc0)[3], wm);
    // Wall child 0 (at a) has the floor's quarter point on its edge.
    assert_eq!(m.anchored(wc0).len(), 3);
    m.validate().unwrap();
    ugcheck_clean(&src, &m);

    // Refining the wall along the edge stitches back into the floor.
    let s = m.split(m.elem_children(wroot).unwrap()[3]);
    let back: Vec<_> = s
        .new_vertices
        .iter()
        .filter(|n| m.vertex_surface(n.v) == SurfaceId(0))
        .collect();
    assert_eq!(back.len(), 1);
    assert_eq!(m.vertex_pos(back[0].v), DVec3::new(0.75, 0.0, 0.0));
    assert_eq!(back[0].parents, [fb, fm], "in the wall edge's direction");
    m.validate().unwrap();
    ugcheck_clean(&src, &m);
}

#[test]
fn stitching_walks_down_a_long_chain() {
    let (src, mut m) = mesh(FLOOR_WALL);
    let floor = PatchId(0);
    let wall = PatchId(1);
    // Refine the floor 6 levels at corner a (always child 0).
    let mut e = m.patch_root(floor);
    for _ in 0..6 {
        m.split(e);
        e = m.elem_children(e).unwrap()[0];
    }
    let [wa, _, _, wb]: [VertId; 4] = m.patch_corners(wall).try_into().unwrap();
    assert_eq!(m.edge_vertices(wb, wa).len(), 6);
    let wroot = m.patch_root(wall);
    let pieces = m.anchored(wroot);
    assert!(pieces.iter().all(|p| p.len() == 3 || p.len() == 4));
    m.validate().unwrap();
    ugcheck_clean(&src, &m);
}

/// A 3 × 3 grid; hanging midpoints on the centre patch's edges come from
/// splitting its four edge neighbours.
#[test]
fn anchored_quad_configurations() {
    // Edge k of the centre patch q1_1 faces: 0 → q1_0, 1 → q2_1, 2 → q1_2, 3 → q0_1.
    let neighbour = [1u32, 5, 7, 3]; // q1_0, q2_1, q1_2, q0_1 (face order j * 3 + i)
    let expect = |mask: u32| -> (usize, usize) {
        // (triangles, quads)
        match mask.count_ones() {
            0 => (0, 1),
            1 => (3, 0),
            2 if mask == 0b0101 || mask == 0b1010 => (0, 2),
            2 => (2, 1),
            3 => (3, 1),
            _ => (4, 1),
        }
    };
    for mask in 0u32..16 {
        let (src, mut m) = mesh(&grid(3, 3));
        for (k, &nb) in neighbour.iter().enumerate() {
            if mask & (1 << k) != 0 {
                m.split(ElemId(nb));
            }
        }
        let centre = ElemId(4);
        assert!(m.elem_is_leaf(centre));
        let pieces = m.anchored(centre);
        let tris = pieces.iter().filter(|p| p.len() == 3).count();
        let quads = pieces.iter().filter(|p| p.len() == 4).count();
        assert_eq!((tris, quads), expect(mask), "mask {mask:04b}: {pieces:?}");
        let area: f64 = pieces
            .iter()
            .map(|p| {
                let pts: Vec<DVec3> = p.iter().map(|&v| m.vertex_pos(v)).collect();
                geom::newell_normal(&pts).z / 2.0
            })
            .sum();
        assert!((area - 1.0).abs() < 1e-12, "mask {mask:04b}: area {area}");
        m.validate().unwrap();
        ugcheck_clean(&src, &m);
    }
}

#[test]
fn anchored_triangle_configurations() {
    // A big triangle cut into four patches; the centre one (t3) has one
    // neighbour across each edge.
    let src = "v a 0 0 0; v b 4 0 0; v c 0 4 0; v ab 2 0 0; v bc 2 2 0; v ca 0 2 0;
        f t0 (a ab ca); f t1 (ab b bc); f t2 (ca bc c); f t3 (bc ca ab);";
    // Edge k of t3: 0 = bc-ca faces t2, 1 = ca-ab faces t0, 2 = ab-bc faces t1.
    let neighbour = [2u32, 0, 1];
    for mask in 0u32..8 {
        let (srcm, mut m) = mesh(src);
        assert_eq!(m.num_surfaces(), 1);
        for (k, &nb) in neighbour.iter().enumerate() {
            if mask & (1 << k) != 0 {
                m.split(ElemId(nb));
            }
        }
        let pieces = m.anchored(ElemId(3));
        let tris = pieces.iter().filter(|p| p.len() == 3).count();
        let quads = pieces.iter().filter(|p| p.len() == 4).count();
        let want = match mask.count_ones() {
            0 => (1, 0),
            1 => (2, 0),
            2 => (1, 1),
            _ => (4, 0),
        };
        assert_eq!((tris, quads), want, "mask {mask:03b}: {pieces:?}");
        let area: f64 = pieces
            .iter()
            .map(|p| {
                let pts: Vec<DVec3> = p.iter().map(|&v| m.vertex_pos(v)).collect();
                geom::newell_normal(&pts).z / 2.0
            })
            .sum();
        assert!((area - 2.0).abs() < 1e-12);
        m.validate().unwrap();
        ugcheck_clean(&srcm, &m);
    }
}

#[test]
fn areas_sum_to_patch_areas() {
    // A convex, non-rectangular quad and a triangle sharing an edge.
    let (src, mut m) = mesh(
        "v a 0 0 0; v b 3 0 0; v c 2.5 2 0; v d 0.3 1.7 0; v e 1.5 -2 0;
         f q (a b c d); f t (a e b);",
    );
    assert_eq!(m.num_surfaces(), 1);
    let want = [m.patch_area(PatchId(0)), m.patch_area(PatchId(1))];
    assert!((want[1] - 3.0).abs() < 1e-12);
    for round in 0..4 {
        let leaves: Vec<ElemId> = m.leaves().collect();
        for (i, e) in leaves.into_iter().enumerate() {
            if (i + round) % 3 == 0 && m.elem_is_leaf(e) {
                m.split(e);
            }
        }
    }
    for p in m.patches() {
        let s: f64 = m.patch_leaves(p).iter().map(|&e| m.elem_area(e)).sum();
        assert!((s - want[p.idx()]).abs() <= 1e-12 * want[p.idx()]);
        let mut a = 0.0;
        for e in m.patch_leaves(p) {
            for piece in m.anchored(e) {
                let pts: Vec<DVec3> = piece.iter().map(|&v| m.vertex_pos(v)).collect();
                a += geom::newell_normal(&pts).z / 2.0;
            }
        }
        assert!((a - want[p.idx()]).abs() <= 1e-12 * want[p.idx()]);
    }
    m.validate().unwrap();
    ugcheck_clean(&src, &m);
}

#[test]
fn surfaces_group_by_plane_material_and_orientation() {
    // L-shaped floor of three quads, a rug (other material) next to it, and
    // a patch folded up at 90°.
    let src = "c_rgb grey 0.5 0.5 0.5; c_rgb red 0.9 0.1 0.1;
        v a 0 0 0; v b 1 0 0; v c 2 0 0; v d 0 1 0; v e 1 1 0; v f 2 1 0;
        v g 0 2 0; v h 1 2 0; v i 3 0 0; v j 3 1 0; v k 0 0 1; v l 1 0 1;
        f q0 (a b e d) grey; f q1 (b c f e) grey; f q2 (d e h g) grey;
        f rug (c i j f) red; f up (a k l b) grey;";
    let (srcm, mut m) = mesh(src);
    assert_eq!(m.num_surfaces(), 3);
    assert_eq!(
        m.surface_patches(SurfaceId(0)),
        &[PatchId(0), PatchId(1), PatchId(2)]
    );
    assert_eq!(m.surface_patches(SurfaceId(1)), &[PatchId(3)]);
    assert_eq!(m.surface_patches(SurfaceId(2)), &[PatchId(4)]);
    assert_eq!(
        m.surface_material(SurfaceId(1)),
        srcm.material_by_name("red")
    );
    // 8 floor vertices, 4 rug, 4 up.
    assert_eq!(m.num_vertices(), 16);
    // Balance runs around the L; stitching reaches the rug and the upright patch.
    let mut e = ElemId(1);
    for _ in 0..3 {
        m.split(e);
        e = m.elem_children(e).unwrap()[1];
    }
    m.validate().unwrap();
    assert!(
        m.surface_patches(SurfaceId(0))
            .iter()
            .all(|&p| m.unbalanced_pairs(p).is_empty())
    );
    ugcheck_clean(&srcm, &m);
}

#[test]
fn build_errors() {
    let err = |s: &str| Mesh::from_model(&parse(s), EPS).unwrap_err();
    let e = err("v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0.5 1.5 0; v e 0 1 0; f penta (a b c d e);");
    assert_eq!(
        e.to_string(),
        "face penta is not a triangle or convex quadrilateral (run ugcut first)"
    );
    assert!(
        matches!(&e, BuildError::NotPatch { face, reason } if face == "penta" && reason.contains("5 vertices"))
    );
    let e = err("v a 0 0 0; v b 2 0 0; v c 0.5 0.5 0; v d 0 2 0; f (a b c d);");
    assert!(
        matches!(&e, BuildError::NotPatch { face, reason } if face == "#1" && reason.contains("not convex"))
    );
    let e = err("v a 0 0 0; v b 1 0 0; v c 1 1 1; v d 0 1 0; f t (a b d); f warp (a b c d);");
    assert!(
        matches!(&e, BuildError::NotPatch { face, reason } if face == "warp" && reason.contains("planar"))
    );
    // Degenerate faces are left out and reported, not refused.
    let m = ug::parse(
        b"v a 0 0 0; v b 1 0 0; v c 2 0 0; v d 1 1 0; f line (a b c); f ok (a b d); f pinch (a a d);",
        "t.ug",
    )
    .unwrap()
    .model;
    let mesh = Mesh::from_model(&m, 1e-9).unwrap();
    assert_eq!(mesh.num_patches(), 1);
    let d = mesh.degenerate_faces();
    assert_eq!(d.len(), 2);
    assert!(d[0].0 == "line" && d[0].1.contains("zero area"), "{d:?}");
    assert!(
        d[1].0 == "pinch" && d[1].1.contains("repeats a vertex"),
        "{d:?}"
    );
    // Narrower than epsilon is ugcheck's test: a corner within eps of a
    // side not its own. At eps 0.01, a triangle 1.5 eps high over a side
    // of 10 is a patch (its area is below eps times its size), one 0.9 eps
    // high is not, nor a needle on a side of 0.005 however long.
    let m = ug::parse(
        b"v a 0 0 0; v b 10 0 0; v c 5 0.015 0; v d 5 0.009 0; v e 10 0.005 0;
          f thin (a b c); f sliver (a b d); f needle (a b e);",
        "t.ug",
    )
    .unwrap()
    .model;
    let mesh = Mesh::from_model(&m, 0.01).unwrap();
    assert_eq!(mesh.num_patches(), 1);
    let d: Vec<&str> = mesh
        .degenerate_faces()
        .iter()
        .map(|x| x.0.as_str())
        .collect();
    assert_eq!(d, ["sliver", "needle"]);
    let e = err(
        "v a 0 0 0; v b 3 0 0; v c 3 3 0; v d 0 3 0; v e 1 1 0; v f 1 2 0; v g 2 1 0;
         f holed (a b c d) (e f g);",
    );
    assert!(matches!(&e, BuildError::NotPatch { reason, .. } if reason.contains("contours")));
    let e = err("def box; v a 0 0 0; v b 1 0 0; v c 0 1 0; f t (a b c); end; i (box);");
    assert_eq!(e, BuildError::NotFlat);
    // An empty model is a valid, empty mesh.
    let m = Mesh::from_model(&Model::new(), EPS).unwrap();
    assert_eq!((m.num_patches(), m.leaves().count()), (0, 0));
    m.validate().unwrap();
}

#[test]
fn coincident_input_vertices_are_merged() {
    // Two quads whose shared edge uses distinct vertices at the same places.
    let (_, m) = mesh(
        "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;
         v b2 1 0 0; v e 2 0 0; v f 2 1 0; v c2 1 1 0;
         f l (a b c d); f r (b2 e f c2);",
    );
    assert_eq!((m.num_surfaces(), m.num_vertices()), (1, 6));
}

#[test]
fn model_output_names() {
    let (src, mut m) = mesh(FLOOR_WALL);
    let out = m.to_model(&src);
    let names: Vec<&str> = out.vertices.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "c", "d", "a.1", "e", "f", "b.1"]);
    let faces: Vec<Option<&str>> = out.faces.iter().map(|f| f.name.as_deref()).collect();
    assert_eq!(faces, [Some("floor"), Some("wall")]);
    m.split(m.patch_root(PatchId(0)));
    let out = m.to_model(&src);
    assert_eq!(out.vertices.len(), m.num_vertices());
    for (k, v) in out.vertices.iter().enumerate() {
        assert_eq!(v.pos, m.vertex_pos(VertId(k as u32)));
    }
    let names: Vec<&str> = out.vertices.iter().map(|v| v.name.as_str()).collect();
    // Floor midpoints a-b, b-c, c-d, d-a, the wall's stitched copy of a-b's, centre.
    assert_eq!(&names[8..], ["a.2", "a.1.1", "b.2", "c.1", "d.1", "a.2.1"]);
    let faces: Vec<Option<&str>> = out.faces.iter().map(|f| f.name.as_deref()).collect();
    assert_eq!(
        faces,
        [
            Some("floor.1"),
            Some("floor.2"),
            Some("floor.3"),
            Some("floor.4"),
            Some("wall.1"),
            Some("wall.2"),
            Some("wall.3")
        ]
    );
    assert!(
        out.faces
            .iter()
            .all(|f| f.material == src.material_by_name("grey"))
    );
    // Round trip through text, then check.
    let text = ug::write_string(&out);
    let back = parse(&text);
    assert_eq!(back, out);
    ugcheck_clean(&src, &m);
}

#[test]
fn derived_names_avoid_input_names() {
    let (src, mut m) = mesh(
        "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v a.1 5 5 5; v e 2 0 0;
         f q (a b c d); f q.1 (b e c);",
    );
    let _ = m.split(ElemId(0));
    let out = m.to_model(&src);
    let mut names: Vec<&str> = out.vertices.iter().map(|v| v.name.as_str()).collect();
    assert!(!names.contains(&"a.1"));
    names.sort();
    let n = names.len();
    names.dedup();
    assert_eq!(names.len(), n, "unique");
    let fnames: Vec<&str> = out.faces.iter().filter_map(|f| f.name.as_deref()).collect();
    assert!(!fnames[..4].contains(&"q.1"), "{fnames:?}");
}

#[test]
fn deterministic() {
    let run = || {
        let (src, mut m) = mesh(&grid(3, 2));
        let mut k = 7u32;
        for _ in 0..40 {
            let leaves: Vec<ElemId> = m.leaves().collect();
            k = k.wrapping_mul(1_103_515_245).wrapping_add(12345);
            m.split(leaves[(k >> 8) as usize % leaves.len()]);
        }
        ug::write_string(&m.to_model(&src))
    };
    assert_eq!(run(), run());
}

#[test]
fn split_reports_all_new_vertices_in_id_order() {
    let (_, mut m) = mesh(FLOOR_WALL);
    let mut k = 3u32;
    let mut out = Split::default();
    for _ in 0..60 {
        let leaves: Vec<ElemId> = m.leaves().collect();
        k = k.wrapping_mul(1_103_515_245).wrapping_add(12345);
        let e = leaves[(k >> 8) as usize % leaves.len()];
        let before = m.num_vertices() as u32;
        m.split_into(e, &mut out);
        let ids: Vec<u32> = out.new_vertices.iter().map(|n| n.v.0).collect();
        let want: Vec<u32> = (before..m.num_vertices() as u32).collect();
        assert_eq!(ids, want);
        for nv in &out.new_vertices {
            for p in nv.parents {
                assert!(p < nv.v);
                assert_eq!(m.vertex_surface(p), m.vertex_surface(nv.v));
            }
        }
        if !out.refined.is_empty() {
            assert_eq!(out.refined[0], e);
            assert!(out.refined.iter().all(|&r| !m.elem_is_leaf(r)));
        }
    }
    m.validate().unwrap();
}

/// `write_ug` over more patches and vertices than one parallel job takes
/// (8,192): a 100 × 100 grid of tiles `tI_J`, two of them named `t0_0.2`
/// and `t0_0.3` instead, which the pieces of `t0_0` skip, and the last
/// one named `t0_0` too (in memory: a parsed model's names are unique),
/// whose pieces count on after the first's; every third tile split, then
/// every third of the others.
#[test]
fn streamed_output_is_the_written_model_across_jobs() {
    use std::fmt::Write as _;
    let n = 100;
    let mut src = String::from("c_rgb grey 0.5 0.5 0.5;\n");
    for j in 0..=n {
        for i in 0..=n {
            let _ = writeln!(src, "v p{i}_{j} {i} {j} 0;");
        }
    }
    for j in 0..n {
        for i in 0..n {
            let name = match (i, j) {
                (5, 0) => "t0_0.2".to_string(),
                (7, 3) => "t0_0.3".to_string(),
                _ => format!("t{i}_{j}"),
            };
            let _ = writeln!(
                src,
                "f {name} (p{i}_{j} p{}_{j} p{}_{} p{i}_{}) grey;",
                i + 1,
                i + 1,
                j + 1,
                j + 1
            );
        }
    }
    let mut src = parse(&src);
    let last = src.faces.len() - 1;
    src.faces[last].name = Some("t0_0".into());
    let mut m = Mesh::from_model(&src, EPS).unwrap();
    for round in 0..2 {
        let leaves: Vec<ElemId> = m.leaves().collect();
        for e in leaves {
            if m.elem_patch(e).0 % 3 == round {
                m.split(e);
            }
        }
    }
    let mut out = Vec::new();
    m.write_ug(&src, &mut out).unwrap();
    let want = ug::write_string(&m.to_model(&src));
    // `t0_0`'s four pieces skip the input's names.
    assert!(want.contains("f t0_0.1 (") && want.contains("f t0_0.5 ("));
    assert_eq!(String::from_utf8(out).unwrap(), want);
}

/// `write_ug` streams exactly the bytes of writing `to_model`, including
/// derived names that must skip input names (vertex `a.2`, face `floor.1`)
/// and patches that share a name.
#[test]
fn streamed_output_is_the_written_model() {
    let src = "{a comment} c_rgb grey 0.5 0.5 0.5; c_rgb dot 0.1 0.2 0.3;
        defmat lamp; diffuse_rgb 0 0 0; emission_rgb 1 1 1; end;
        v a 0 0 0; v b 1 0 0 dot; v c 1 1 0; v d 0 1 0; v e 0 0 1; v f 1 0 1;
        v a.2 2 0 0; v g 2 1 0; v h 2 0 1;
        f floor (a b c d) grey;
        f wall (a e f b) grey;
        f floor.1 (b a.2 g c) grey;
        f (b h a.2) lamp;
        w floor.3 (e f);";
    let (src, mut m) = mesh(src);
    let check = |m: &Mesh| {
        let mut out = Vec::new();
        m.write_ug(&src, &mut out).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            ug::write_string(&m.to_model(&src))
        );
    };
    check(&m);
    for round in 0..3 {
        let leaves: Vec<ElemId> = m.leaves().collect();
        for (i, e) in leaves.into_iter().enumerate() {
            if (i + round) % 2 == 0 {
                m.split(e);
            }
        }
        check(&m);
    }
    let text = ug::write_string(&m.to_model(&src));
    assert!(
        text.contains("v a.3 "),
        "a derived name skips the input's a.2"
    );
    assert!(text.contains("f floor.2 ") && !text.contains("f floor.1 ("));
}

/// A 2 × 2 floor of unit-half cells with a partition (two faces back to back)
/// standing on the middle line from y = 0 to y = 1, ending at the floor's
/// middle vertex: the floor stays one surface (joined around the partition's
/// free end), but the points on the partition's foot get a copy per side,
/// and those copies receive a hair inside their own side.
const PARTITION: &str = "c_rgb grey 0.5 0.5 0.5;
    v a 0 0 0; v b 1 0 0; v c 2 0 0; v d 0 1 0; v e 1 1 0; v f 2 1 0;
    v g 0 2 0; v h 1 2 0; v i 2 2 0; v p 1 0 1; v q 1 1 1;
    f a0 (a b e d) grey; f b0 (b c f e) grey; f a1 (d e h g) grey; f b1 (e f i h) grey;
    f west (b p q e) grey; f east (e q p b) grey;";

#[test]
fn a_partition_foot_gets_a_vertex_copy_per_side() {
    let (_, m) = mesh(PARTITION);
    // Floor, and each side of the partition.
    assert_eq!(m.num_surfaces(), 3);
    let floor = m.patch_surface(PatchId(0));
    assert!((0..4).all(|p| m.patch_surface(PatchId(p)) == floor));
    let copies = |x: f64, y: f64| -> Vec<VertId> {
        (0..m.num_vertices() as u32)
            .map(VertId)
            .filter(|&v| m.vertex_surface(v) == floor && m.vertex_pos(v) == DVec3::new(x, y, 0.0))
            .collect()
    };
    // The foot's far end: one copy per side, each receiving on its side.
    let b = copies(1.0, 0.0);
    assert_eq!(b.len(), 2, "{b:?}");
    let sides: Vec<f64> = b.iter().map(|&v| m.receiver_pos(v).x - 1.0).collect();
    assert!(sides[0] * sides[1] < 0.0, "{sides:?}");
    for &v in &b {
        let step = m.receiver_pos(v) - m.vertex_pos(v);
        assert!(step.z == 0.0 && step.y > 0.0, "{step}");
        assert!(
            step.length() < 1e-3 && step.length() >= 10.0 * EPS,
            "{step}"
        );
    }
    // The free end is one point of the floor around it; inside the floor.
    let e = copies(1.0, 1.0);
    assert_eq!(e.len(), 1);
    assert_eq!(m.receiver_pos(e[0]), m.vertex_pos(e[0]));
    // Splitting a cell on one side stitches the foot's midpoint into the
    // other side's copy of the edge, stepped to its own side.
    let split = {
        let mut m = m.clone();
        let s = m.split(ElemId(0));
        m.validate().unwrap();
        let mids: Vec<VertId> = s
            .new_vertices
            .iter()
            .map(|n| n.v)
            .filter(|&v| {
                m.vertex_pos(v) == DVec3::new(1.0, 0.5, 0.0) && m.vertex_surface(v) == floor
            })
            .collect();
        assert_eq!(mids.len(), 2, "{mids:?}");
        let mut xs: Vec<f64> = mids.iter().map(|&v| m.receiver_pos(v).x - 1.0).collect();
        xs.sort_by(f64::total_cmp);
        assert!(xs[0] < 0.0 && xs[1] > 0.0, "{xs:?}");
        m
    };
    assert!(split.num_vertices() > m.num_vertices());
}

/// Splits, `times` times, the leaf of patch `p` containing `x`: the levels
/// of the leaves split (or left, when refused).
fn split_towards(m: &mut Mesh, p: PatchId, x: DVec3, times: usize) -> Vec<u32> {
    (0..times)
        .map(|_| {
            let e = leaf_at(m, p, x);
            m.split(e);
            m.elem_level(e)
        })
        .collect()
}

#[test]
fn a_sliver_beside_a_refined_element_is_not_split_below_epsilon() {
    // A unit square and, on its edge x = 1, a sliver triangle: 40 epsilons
    // wide with its apex off the edge's middle (it may be split once), or 20
    // epsilons wide with a short edge at the top (it may not be split, so
    // balance keeps the square one level down beside it).
    for (w, apex_y, sliver_leaves, square_level) in
        [(40.0 * EPS, 0.5, 4, 2), (20.0 * EPS, 1.0, 1, 1)]
    {
        let apex = (1.0 + w, apex_y);
        let src = format!(
            "c_rgb grey 0.5 0.5 0.5;
             v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v s {} {} 0;
             f q (a b c d) grey; f t (b s c) grey;",
            apex.0, apex.1
        );
        let (src, mut m) = mesh(&src);
        assert_eq!(m.num_surfaces(), 1);
        // Refine the square towards the sliver as far as it will go.
        let near = DVec3::new(0.999, 0.3, 0.0);
        let levels = split_towards(&mut m, PatchId(0), near, 20);
        m.validate().unwrap();
        assert!(m.unbalanced_pairs(PatchId(0)).is_empty());
        assert!(m.unbalanced_pairs(PatchId(1)).is_empty());
        assert_eq!(m.patch_leaves(PatchId(1)).len(), sliver_leaves, "{apex:?}");
        // The square stops where a vertex on the sliver's edge would make the
        // sliver's output triangles narrower than 4 epsilons, or where
        // balance would need the sliver split.
        assert_eq!(
            *levels.last().unwrap(),
            square_level,
            "{apex:?}: {levels:?}"
        );
        assert!(!m.can_split(leaf_at(&m, PatchId(0), near)));
        for e in m.leaves() {
            assert!(
                m.elem_width(e) >= MIN_CHILD_EPS * EPS || e == m.patch_root(PatchId(1)),
                "{}",
                m.elem_width(e)
            );
        }
        let total: f64 = m.leaves().map(|e| m.elem_area(e)).sum();
        let want = 1.0 + 0.5 * w;
        assert!((total - want).abs() < 1e-12);
        ugcheck_clean(&src, &m);
    }
}

#[test]
fn a_sliver_across_a_surface_boundary_limits_the_split_beside_it() {
    // A floor and, standing on its edge a–b, a wall that is a sliver 40
    // epsilons high: the floor's midpoints on a–b are stitched into the
    // sliver, whose output fans to them must stay wider than epsilon.
    let src = format!(
        "c_rgb grey 0.5 0.5 0.5;
         v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 0.5 0 {};
         f floor (a b c d) grey; f wall (a e b) grey;",
        40.0 * EPS
    );
    let (src, mut m) = mesh(&src);
    assert_eq!(m.num_surfaces(), 2);
    let near = DVec3::new(0.3, 0.001, 0.0);
    let levels = split_towards(&mut m, PatchId(0), near, 20);
    m.validate().unwrap();
    // Half an edge × 40 ε ≥ 4 ε × 1 (the sliver's longest edge): the
    // floor's pieces of a–b stay at least 0.1 long (level 3: 0.125).
    assert_eq!(*levels.last().unwrap(), 3, "{levels:?}");
    assert!(!m.can_split(leaf_at(&m, PatchId(0), near)));
    // Away from the sliver the floor still splits.
    assert!(m.can_split(leaf_at(&m, PatchId(0), DVec3::new(0.3, 0.9, 0.0))));
    ugcheck_clean(&src, &m);
}
