//! Non-planar face tessellation (Smith 1991, §2.2).
//!
//! A face is non-planar when one of its vertices lies farther than epsilon
//! from the face's best-fit plane (the Newell normal of its outer contour
//! through the centroid of its vertices). Such a face is replaced, in place,
//! by triangles that keep its material and orientation:
//!
//! * a quadrilateral is split along the diagonal that folds it least (the
//!   smaller angle between the two triangles' normals), never along a
//!   diagonal that lies outside the quad;
//! * anything larger, holes included, gets the constrained Delaunay
//!   triangulation (spade) of its contours projected on the best-fit plane:
//!   no new vertices, and the most regular triangles those vertices allow.
//!
//! A face whose projection crosses or touches itself is first made sound by
//! the snap-rounded arrangement of its contours on that plane (even-odd
//! region; the crossings become vertices on the plane), then triangulated,
//! with a warning. Triangles are named `NAME.1`, `NAME.2`, … after their face
//! (unnamed faces give unnamed triangles). Planar faces and all other
//! statements pass through unchanged.

use geom::triangulate::fold_triangles;
use geom::{DVec3, Plane};
use rustc_hash::FxHashSet;
use ug::{Face, FaceId, Item, Model, VertexId};

/// What the tessellation did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub faces: usize,
    pub nonplanar: usize,
    pub triangles: usize,
    /// Non-planar faces whose projection crosses or touches itself: repaired
    /// in the plane before they were triangulated.
    pub repaired: Vec<String>,
    /// Non-planar faces left with no area at all (dropped).
    pub failed: Vec<String>,
}

/// Largest distance of a face's vertices from its best-fit plane, and that plane.
pub fn deviation(m: &Model, f: &Face) -> Option<(f64, Plane)> {
    let pts: Vec<Vec<DVec3>> = f
        .contours
        .iter()
        .map(|c| c.iter().map(|&v| m.pos(v)).collect())
        .collect();
    Plane::face_deviation(&pts)
}

/// Triangles for a non-planar face, as vertex triples in the face's orientation
/// (see [`geom::triangulate::fold_triangles`]).
pub fn tessellate(m: &Model, f: &Face) -> Option<Vec<[VertexId; 3]>> {
    let pts: Vec<Vec<DVec3>> = f
        .contours
        .iter()
        .map(|c| c.iter().map(|&v| m.pos(v)).collect())
        .collect();
    let ids: Vec<VertexId> = f.contours.iter().flatten().copied().collect();
    let tris = fold_triangles(&pts)?;
    Some(
        tris.into_iter()
            .map(|t| [ids[t[0]], ids[t[1]], ids[t[2]]])
            .collect(),
    )
}

/// Replaces every face that deviates from its plane by more than `eps` with triangles.
pub fn planarize(m: &Model, eps: f64) -> (Model, Stats) {
    planarize_where(m, eps, &|_| true)
}

/// [`planarize`] of the faces `fold` takes only.
fn planarize_where(m: &Model, eps: f64, fold: &dyn Fn(&Face) -> bool) -> (Model, Stats) {
    let mut stats = Stats::default();
    let mut names: FxHashSet<String> = m.faces.iter().filter_map(|f| f.name.clone()).collect();
    names.extend(m.wires.iter().filter_map(|w| w.name.clone()));
    let mut out = Model {
        materials: m.materials.clone(),
        vertices: m.vertices.clone(),
        wires: m.wires.clone(),
        defs: m.defs.clone(),
        instances: m.instances.clone(),
        ..Model::default()
    };
    for it in &m.items {
        let Item::Face(fid) = it else {
            out.items.push(it.clone());
            continue;
        };
        let f = &m.faces[fid.idx()];
        stats.faces += 1;
        let label = f
            .name
            .clone()
            .unwrap_or_else(|| format!("#{}", stats.faces));
        let tris = match deviation(m, f) {
            Some((dev, _)) if dev > eps && fold(f) => {
                stats.nonplanar += 1;
                let t = tessellate(m, f).or_else(|| {
                    stats.repaired.push(label.clone());
                    let base = f
                        .name
                        .clone()
                        .unwrap_or_else(|| format!("f{}", stats.faces));
                    repaired_triangles(&mut out, f, eps, &base)
                });
                if t.as_ref().is_none_or(|t| t.is_empty()) {
                    stats.failed.push(label.clone());
                    continue;
                }
                t
            }
            _ => None,
        };
        match tris {
            None => {
                push_face(&mut out, f.clone());
            }
            Some(tris) => {
                stats.triangles += tris.len();
                let mut k = 0;
                for t in tris {
                    let name = f.name.as_ref().map(|n| {
                        loop {
                            k += 1;
                            let cand = format!("{n}.{k}");
                            if names.insert(cand.clone()) {
                                break cand;
                            }
                        }
                    });
                    push_face(
                        &mut out,
                        Face {
                            name,
                            contours: vec![t.to_vec()],
                            material: f.material,
                        },
                    );
                }
            }
        }
    }
    (out, stats)
}

/// The model with its faces that are off their plane by more than `eps`
/// folded into triangles ([`planarize`]), and how many there were; the
/// model itself, untouched, when there are none. For the tools that weld
/// the vertices they make to others within `eps` (`ugisect`, `ugcopl`): a
/// face may end up a little more than `eps` off its plane (1.0–1.8 eps on
/// the 100k CAD building, 15 faces through the chain), and no tool passes
/// a non-planar face on.
pub fn refold(m: Model, eps: f64) -> (Model, usize) {
    refold_where(m, eps, &|_| true)
}

/// [`refold`] of the faces named in `names` only (the faces a step bent,
/// where others may have come in bent: `ugclean`).
pub fn refold_named(m: Model, eps: f64, names: &[String]) -> (Model, usize) {
    if names.is_empty() {
        return (m, 0);
    }
    let names: FxHashSet<&str> = names.iter().map(String::as_str).collect();
    refold_where(m, eps, &|f: &Face| {
        f.name.as_deref().is_some_and(|n| names.contains(n))
    })
}

/// [`refold`] of the faces `fold` takes.
fn refold_where(m: Model, eps: f64, fold: &dyn Fn(&Face) -> bool) -> (Model, usize) {
    let bent = m.top_faces().any(|f| {
        let face = &m.faces[f.idx()];
        fold(face) && deviation(&m, face).is_some_and(|(dev, _)| dev > eps)
    });
    if !bent {
        return (m, 0);
    }
    let (out, st) = planarize_where(&m, eps, fold);
    (out, st.nonplanar)
}

/// Triangles of a face whose projection on its best-fit plane crosses or
/// touches itself: the arrangement of its contours there (snapped at
/// `eps`), each piece of its even-odd region triangulated; crossings become
/// new vertices of `out` on the plane, named `BASE.xK`.
fn repaired_triangles(
    out: &mut Model,
    f: &Face,
    eps: f64,
    base: &str,
) -> Option<Vec<[VertexId; 3]>> {
    use geom::arrange::Tag;
    use winged::pieces::{Layout, Point};
    let pts: Vec<Vec<DVec3>> = f
        .contours
        .iter()
        .map(|c| c.iter().map(|&v| out.pos(v)).collect())
        .collect();
    let mut layout = Layout::new(Layout::frame_of(&pts)?);
    layout.contours(&f.contours, Tag::Toggle(0), |v| out.pos(v));
    let arr = layout.arrange(eps, false);
    let mut made: rustc_hash::FxHashMap<u32, VertexId> = Default::default();
    let mut tris = Vec::new();
    for face in arr.faces.iter().filter(|a| a.has(0)) {
        let loops2: Vec<Vec<geom::DVec2>> = face
            .loops
            .iter()
            .map(|l| l.iter().map(|&k| arr.points[k as usize]).collect())
            .collect();
        let loops = layout.loops(&arr, face);
        let flat_k: Vec<u32> = face.loops.iter().flatten().copied().collect();
        let flat_p: Vec<Point> = loops.into_iter().flatten().collect();
        let Some(t) = geom::triangulate::triangulate_polygon(&loops2) else {
            continue;
        };
        let mut id = |i: usize| -> VertexId {
            match flat_p[i] {
                Point::Vertex(v) => v,
                Point::New(p) => *made.entry(flat_k[i]).or_insert_with(|| {
                    let name = (1..)
                        .map(|k| format!("{base}.x{k}"))
                        .find(|n| !out.vertices.iter().any(|v| &v.name == n))
                        .unwrap_or_default();
                    out.add_vertex(ug::Vertex {
                        name,
                        pos: p,
                        color: None,
                    })
                }),
            }
        };
        for tri in t {
            tris.push([id(tri[0]), id(tri[1]), id(tri[2])]);
        }
    }
    Some(tris)
}

fn push_face(out: &mut Model, f: Face) -> FaceId {
    let id = FaceId(out.faces.len() as u32);
    out.faces.push(f);
    out.items.push(Item::Face(id));
    id
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(src: &str) -> Model {
        ug::parse(src.as_bytes(), "t").unwrap().model
    }

    #[test]
    fn quad_splits_along_the_smaller_fold() {
        // c is lifted: the fold along a-c is zero only if … compute both.
        let m = model("v a 0 0 0; v b 1 0 0; v c 1 1 0.5; v d 0 1 0; f q (a b c d);");
        let (out, st) = planarize(&m, 1e-9);
        assert_eq!(st.nonplanar, 1);
        assert_eq!(out.faces.len(), 2);
        // Splitting along b-d keeps a, b, d in the ground plane (fold = atan(0.5)·…);
        // along a-c both triangles tilt. The b-d diagonal folds less here.
        let names: Vec<_> = out.faces.iter().map(|f| f.name.clone().unwrap()).collect();
        assert_eq!(names, ["q.1", "q.2"]);
        let has_bd = out.faces.iter().all(|f| {
            let c = &f.contours[0];
            c.contains(&VertexId(1)) && c.contains(&VertexId(3))
        });
        assert!(has_bd, "{:?}", out.faces);
    }

    /// A face bent by welding (a corner lifted 5 eps: 1.25 eps off the
    /// best-fit plane) is folded; planar ones, and a model with none bent
    /// (a corner lifted 3 eps), stay as they are.
    #[test]
    fn refold_folds_only_bent_faces() {
        let eps = 1e-4;
        let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0.0005; v d 0 1 0; v e 2 0 0; v g 2 1 0;
                   v h 1 1 0; f bent (a b c d); f flat (b e g h);";
        let (out, n) = refold(model(src), eps);
        assert_eq!(n, 1);
        let names: Vec<_> = out.faces.iter().map(|f| f.name.clone().unwrap()).collect();
        assert_eq!(names, ["bent.1", "bent.2", "flat"]);
        let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0.0003; v d 0 1 0; f q (a b c d);";
        let (out, n) = refold(model(src), eps);
        assert_eq!((n, out.faces.len()), (0, 1));
    }

    #[test]
    fn planar_faces_pass_through() {
        let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; f q (a b c d);";
        let m = model(src);
        let (out, st) = planarize(&m, 1e-9);
        assert_eq!(st.nonplanar, 0);
        assert_eq!(out, m);
    }

    #[test]
    fn triangles_keep_orientation_and_area() {
        let m = model(
            "v a 0 0 0; v b 4 0 0; v c 4 4 0.3; v d 0 4 0; v e -1 2 0.1;\
             v h0 1 1 0; v h1 1 3 0; v h2 3 3 0; v h3 3 1 0; c_rgb g 0.5 0.5 0.5;\
             f p (a b c d e) (h0 h1 h2 h3) g;",
        );
        let (out, st) = planarize(&m, 1e-9);
        assert_eq!(st.nonplanar, 1);
        let n = deviation(&m, &m.faces[0]).unwrap().1.n;
        let mut area = 0.0;
        for f in &out.faces {
            let p: Vec<DVec3> = f.contours[0].iter().map(|&v| out.pos(v)).collect();
            let tn = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(tn.dot(n) > 0.0, "triangle faces the other way");
            assert_eq!(f.material, m.faces[0].material);
            // Projected area onto the best-fit plane.
            area += tn.dot(n) / 2.0;
        }
        let frame = geom::Frame::new(DVec3::ZERO, n);
        let c2: Vec<Vec<geom::DVec2>> = m.faces[0]
            .contours
            .iter()
            .map(|c| c.iter().map(|&v| frame.to_2d(m.pos(v))).collect())
            .collect();
        let expect: f64 = c2.iter().map(|c| geom::signed_area_2d(c)).sum();
        assert!((area - expect).abs() < 1e-9, "{area} vs {expect}");
    }

    #[test]
    fn derived_names_avoid_existing_ones() {
        let m = model("v a 0 0 0; v b 1 0 0; v c 1 1 1; v d 0 1 0; f q.1 (a b d); f q (a b c d);");
        let (out, _) = planarize(&m, 1e-9);
        let names: Vec<_> = out.faces.iter().map(|f| f.name.clone().unwrap()).collect();
        assert_eq!(names, ["q.1", "q.2", "q.3"]);
    }
}
