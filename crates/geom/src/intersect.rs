//! How two planar faces meet in space: disjoint, touching along their
//! boundaries only, intersecting (some common point lies in the interior of
//! one of them), or coplanar (left to the 2-D tests).

use glam::{DVec2, DVec3};

use crate::index::BoxIndex;
use crate::plane::{Frame, Plane};
use crate::polygon::{Location, locate_2d};
use crate::predicates::{on_segment_2d, orient2d};

/// A face prepared for pair tests: contours, best-fit plane and its 2-D
/// projection; faces with many edges also get an index of their edges, so
/// that locating a point costs a query, not a pass over every edge.
#[derive(Clone)]
pub struct FaceGeom {
    pub contours: Vec<Vec<DVec3>>,
    pub plane: Plane,
    pub frame: Frame,
    pub contours_2d: Vec<Vec<DVec2>>,
    edges: Option<std::sync::Arc<EdgeIndex>>,
}

impl std::fmt::Debug for FaceGeom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FaceGeom")
            .field("contours", &self.contours)
            .field("plane", &self.plane)
            .finish()
    }
}

/// Edges of a big face in an R*-tree: (contour, index) per entry.
struct EdgeIndex {
    tree: BoxIndex,
    ids: Vec<(u32, u32)>,
}

/// Faces with more edges than this get an [`EdgeIndex`].
const INDEX_EDGES: usize = 32;

impl FaceGeom {
    /// `None` for a degenerate face (no area, or no contour).
    pub fn new(contours: Vec<Vec<DVec3>>) -> Option<FaceGeom> {
        let outer = contours.first()?;
        let plane = Plane::fit(outer)?;
        let frame = Frame::new(outer[0], plane.n);
        let contours_2d: Vec<Vec<DVec2>> = contours
            .iter()
            .map(|c| c.iter().map(|&p| frame.to_2d(p)).collect())
            .collect();
        let total: usize = contours_2d.iter().map(Vec::len).sum();
        let edges = (total > INDEX_EDGES).then(|| {
            let mut ids = Vec::with_capacity(total);
            let mut boxes = Vec::with_capacity(total);
            for (ci, c) in contours_2d.iter().enumerate() {
                for i in 0..c.len() {
                    let (a, b) = (c[i], c[(i + 1) % c.len()]);
                    boxes.push((a.min(b).extend(0.0), a.max(b).extend(0.0), ids.len() as u32));
                    ids.push((ci as u32, i as u32));
                }
            }
            std::sync::Arc::new(EdgeIndex {
                tree: BoxIndex::new(boxes),
                ids,
            })
        });
        Some(FaceGeom {
            contours,
            plane,
            frame,
            contours_2d,
            edges,
        })
    }

    /// Location of a 3-D point (assumed in or near the plane) with tolerance
    /// `eps`: within `eps` of an edge counts as the boundary.
    pub fn locate(&self, p: DVec3, eps: f64) -> Location {
        let q = self.frame.to_2d(p);
        let Some(ix) = &self.edges else {
            return locate_eps(q, &self.contours_2d, eps);
        };
        let edge = |k: u32| {
            let (ci, i) = ix.ids[k as usize];
            let c = &self.contours_2d[ci as usize];
            (c[i as usize], c[(i as usize + 1) % c.len()])
        };
        let pad = DVec2::splat(eps);
        for k in ix.tree.query((q - pad).extend(0.0), (q + pad).extend(0.0)) {
            let (a, b) = edge(k);
            if seg_dist(q, a, b) <= eps {
                return Location::Boundary;
            }
        }
        // Even-odd crossings of the ray towards +x, exactly as locate_2d.
        let mut inside = false;
        let far = DVec3::new(f64::INFINITY, q.y, 0.0);
        for k in ix.tree.query(q.extend(0.0), far) {
            let (a, b) = edge(k);
            if on_segment_2d(q, a, b) {
                return Location::Boundary;
            }
            if (a.y > q.y) != (b.y > q.y) {
                let o = orient2d(a, b, q);
                if (b.y > a.y && o > 0) || (b.y < a.y && o < 0) {
                    inside = !inside;
                }
            }
        }
        if inside {
            Location::Inside
        } else {
            Location::Outside
        }
    }
}

fn seg_dist(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length()
}

/// Point location in 2-D where anything within `eps` of an edge is the boundary.
pub fn locate_eps(p: DVec2, contours: &[Vec<DVec2>], eps: f64) -> Location {
    for c in contours {
        let n = c.len();
        for i in 0..n {
            let (a, b) = (c[i], c[(i + 1) % n]);
            let ab = b - a;
            let len2 = ab.length_squared();
            let t = if len2 > 0.0 {
                ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if (a + ab * t - p).length() <= eps {
                return Location::Boundary;
            }
        }
    }
    locate_2d(p, contours)
}

/// How two faces meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Relation {
    Disjoint,
    /// They meet only where both have boundary (a shared vertex or edge, edge on edge).
    Touch,
    /// A common point lies in the interior of at least one face (crossing faces,
    /// or an edge or vertex of one resting inside the other).
    Intersect,
    /// All of one face's vertices lie within `eps` of the other's plane.
    Coplanar,
}

fn snap(d: f64, eps: f64) -> f64 {
    if d.abs() <= eps { 0.0 } else { d }
}

/// How far from each other's planes two faces may be and still count as
/// coplanar, in epsilons. Welding vertices within epsilon can tilt two
/// faces a hair more than epsilon apart (two wall tops at nearly the same
/// height whose corners were merged): they must still be one plane, not a
/// crossing at a vanishing angle that no cut can resolve. Partial welding
/// happens only at distances up to about epsilon, so twice that covers it.
pub const COPLANAR_EPSILONS: f64 = 2.0;

/// Whether the planes are nearly parallel (within about 0.8°) and all of
/// one face's vertices lie within `COPLANAR_EPSILONS × eps` of the other's
/// plane. (Without the angle, a strip a few epsilons wide standing on a
/// face would count as lying in it.)
pub fn coplanar(a: &FaceGeom, b: &FaceGeom, eps: f64) -> bool {
    if a.plane.n.dot(b.plane.n).abs() < 0.9999 {
        return false;
    }
    let tol = COPLANAR_EPSILONS * eps;
    let within = |g: &FaceGeom, other: &FaceGeom| {
        g.contours
            .iter()
            .flatten()
            .all(|&p| other.plane.dist(p).abs() <= tol)
    };
    within(b, a) || within(a, b)
}

const POINT_CUTS: bool = false;

/// Classifies the pair (a, b) with distance tolerance `eps`.
pub fn relate(a: &FaceGeom, b: &FaceGeom, eps: f64) -> Relation {
    let da: Vec<Vec<f64>> = a
        .contours
        .iter()
        .map(|c| c.iter().map(|&p| snap(b.plane.dist(p), eps)).collect())
        .collect();
    let db: Vec<Vec<f64>> = b
        .contours
        .iter()
        .map(|c| c.iter().map(|&p| snap(a.plane.dist(p), eps)).collect())
        .collect();
    let all = |d: &Vec<Vec<f64>>, f: &dyn Fn(f64) -> bool| d.iter().flatten().all(|&x| f(x));
    if coplanar(a, b, eps) {
        return Relation::Coplanar;
    }
    if all(&db, &|x| x > 0.0)
        || all(&db, &|x| x < 0.0)
        || all(&da, &|x| x > 0.0)
        || all(&da, &|x| x < 0.0)
    {
        return Relation::Disjoint;
    }
    let (n1, n2) = (a.plane.n, b.plane.n);
    let u = n1.cross(n2);
    let uu = u.length_squared();
    if uu < 1e-24 {
        return Relation::Disjoint; // parallel planes that are not within eps
    }
    let p0 = (n2.cross(u) * a.plane.d + u.cross(n1) * b.plane.d) / uu;
    let dir = u / uu.sqrt();
    let mut ts: Vec<f64> = Vec::new();
    let mut collect = |contours: &[Vec<DVec3>], d: &[Vec<f64>]| {
        for (c, dc) in contours.iter().zip(d) {
            let n = c.len();
            for i in 0..n {
                let j = (i + 1) % n;
                let (p, q, dp, dq) = (c[i], c[j], dc[i], dc[j]);
                if dp == 0.0 {
                    ts.push((p - p0).dot(dir));
                } else if dp * dq < 0.0 {
                    let x = p + (q - p) * (dp / (dp - dq));
                    ts.push((x - p0).dot(dir));
                }
            }
        }
    };
    collect(&a.contours, &da);
    collect(&b.contours, &db);
    if ts.is_empty() {
        return Relation::Disjoint;
    }
    ts.sort_by(f64::total_cmp);
    ts.dedup_by(|x, y| (*x - *y).abs() <= eps);
    let mut samples = Vec::with_capacity(ts.len() * 2);
    for (k, &t) in ts.iter().enumerate() {
        samples.push(t);
        if let Some(&t2) = ts.get(k + 1) {
            samples.push((t + t2) / 2.0);
        }
    }
    let mut touch = false;
    for t in samples {
        let s = p0 + dir * t;
        let la = a.locate(s, eps);
        if la == Location::Outside {
            continue;
        }
        let lb = b.locate(s, eps);
        match (la, lb) {
            (_, Location::Outside) => {}
            (Location::Inside, _) | (_, Location::Inside) => return Relation::Intersect,
            _ => touch = true,
        }
    }
    if touch {
        Relation::Touch
    } else {
        Relation::Disjoint
    }
}

/// Where two faces that are not coplanar cut each other: the segments of
/// the line where their planes meet that lie in both (closed) faces and in
/// the interior of at least one, in 3-D, ordered along the line. Where a
/// face only rests on the other's boundary (edge on edge) there is no cut.
/// Where they meet at a single point inside one of them (a tip resting on a
/// face), a cut of 4 `eps` along the line through the point stands for it.
/// Empty for disjoint, touching or coplanar faces.
pub fn cut_segments(a: &FaceGeom, b: &FaceGeom, eps: f64) -> Vec<(DVec3, DVec3)> {
    let side = |g: &FaceGeom, other: &FaceGeom| -> Vec<Vec<f64>> {
        g.contours
            .iter()
            .map(|c| c.iter().map(|&p| snap(other.plane.dist(p), eps)).collect())
            .collect()
    };
    let da = side(a, b);
    let db = side(b, a);
    let all = |d: &Vec<Vec<f64>>, f: &dyn Fn(f64) -> bool| d.iter().flatten().all(|&x| f(x));
    if coplanar(a, b, eps) {
        return Vec::new();
    }
    if all(&db, &|x| x > 0.0)
        || all(&db, &|x| x < 0.0)
        || all(&da, &|x| x > 0.0)
        || all(&da, &|x| x < 0.0)
    {
        return Vec::new();
    }
    let (n1, n2) = (a.plane.n, b.plane.n);
    let u = n1.cross(n2);
    let uu = u.length_squared();
    if uu < 1e-24 {
        return Vec::new();
    }
    let p0 = (n2.cross(u) * a.plane.d + u.cross(n1) * b.plane.d) / uu;
    let dir = u / uu.sqrt();
    let mut ts: Vec<f64> = Vec::new();
    for (g, d) in [(a, &da), (b, &db)] {
        for (c, dc) in g.contours.iter().zip(d) {
            let n = c.len();
            for i in 0..n {
                let j = (i + 1) % n;
                let (p, q, dp, dq) = (c[i], c[j], dc[i], dc[j]);
                if dp == 0.0 {
                    ts.push((p - p0).dot(dir));
                } else if dp * dq < 0.0 {
                    let x = p + (q - p) * (dp / (dp - dq));
                    ts.push((x - p0).dot(dir));
                }
            }
        }
    }
    ts.sort_by(f64::total_cmp);
    ts.dedup_by(|x, y| (*x - *y).abs() <= eps);
    let mut out: Vec<(f64, f64)> = Vec::new();
    let meets = |t: f64| {
        let s = p0 + dir * t;
        let la = a.locate(s, eps);
        let lb = b.locate(s, eps);
        la != Location::Outside
            && lb != Location::Outside
            && (la == Location::Inside || lb == Location::Inside)
    };
    for w in ts.windows(2) {
        let s = p0 + dir * ((w[0] + w[1]) / 2.0);
        let la = a.locate(s, eps);
        if la == Location::Outside {
            continue;
        }
        let lb = b.locate(s, eps);
        if lb == Location::Outside || (la == Location::Boundary && lb == Location::Boundary) {
            continue;
        }
        match out.last_mut() {
            Some(last) if last.1 == w[0] => last.1 = w[1],
            _ => out.push((w[0], w[1])),
        }
    }
    // Where they meet at a point only (a corner resting inside a face):
    // a cut of 4 epsilon along the line through it, for the cutter to
    // extend until the point lies on an edge.
    if POINT_CUTS {
        for &t in &ts {
            if out.iter().any(|&(t0, t1)| t >= t0 - eps && t <= t1 + eps) {
                continue;
            }
            if meets(t) {
                out.push((t - 2.0 * eps, t + 2.0 * eps));
            }
        }
    }
    out.sort_by(|x, y| x.0.total_cmp(&y.0));
    out.into_iter()
        .map(|(t0, t1)| (p0 + dir * t0, p0 + dir * t1))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(pts: [[f64; 3]; 4]) -> FaceGeom {
        FaceGeom::new(vec![pts.iter().map(|p| DVec3::from_array(*p)).collect()]).unwrap()
    }

    const EPS: f64 = 1e-9;

    fn floor() -> FaceGeom {
        quad([[0., 0., 0.], [4., 0., 0.], [4., 4., 0.], [0., 4., 0.]])
    }

    #[test]
    fn crossing_quads_intersect() {
        let wall = quad([[2., -1., -1.], [2., 5., -1.], [2., 5., 1.], [2., -1., 1.]]);
        assert_eq!(relate(&floor(), &wall, EPS), Relation::Intersect);
        assert_eq!(relate(&wall, &floor(), EPS), Relation::Intersect);
    }

    #[test]
    fn wall_standing_inside_floor_intersects() {
        let wall = quad([[1., 1., 0.], [3., 1., 0.], [3., 1., 2.], [1., 1., 2.]]);
        assert_eq!(relate(&floor(), &wall, EPS), Relation::Intersect);
    }

    #[test]
    fn wall_on_floor_edge_touches() {
        let wall = quad([[0., 0., 0.], [4., 0., 0.], [4., 0., 2.], [0., 0., 2.]]);
        assert_eq!(relate(&floor(), &wall, EPS), Relation::Touch);
        let corner = quad([[4., 4., 0.], [5., 4., 0.], [5., 4., 2.], [4., 4., 2.]]);
        assert_eq!(relate(&floor(), &corner, EPS), Relation::Touch);
    }

    #[test]
    fn separated_and_coplanar() {
        let above = quad([[0., 0., 1.], [1., 0., 1.], [1., 0., 2.], [0., 0., 2.]]);
        assert_eq!(relate(&floor(), &above, EPS), Relation::Disjoint);
        let flat = quad([[1., 1., 0.], [2., 1., 0.], [2., 2., 0.], [1., 2., 0.]]);
        assert_eq!(relate(&floor(), &flat, EPS), Relation::Coplanar);
        // A wall whose foot lies outside the floor, in the floor's plane line.
        let outside = quad([[5., 0., -1.], [5., 4., -1.], [5., 4., 1.], [5., 0., 1.]]);
        assert_eq!(relate(&floor(), &outside, EPS), Relation::Disjoint);
    }

    #[test]
    fn crossing_through_a_hole_is_disjoint() {
        let mut hole = vec![
            DVec3::new(1., 1., 0.),
            DVec3::new(3., 1., 0.),
            DVec3::new(3., 3., 0.),
            DVec3::new(1., 3., 0.),
        ];
        hole.reverse();
        let outer = vec![
            DVec3::new(0., 0., 0.),
            DVec3::new(4., 0., 0.),
            DVec3::new(4., 4., 0.),
            DVec3::new(0., 4., 0.),
        ];
        let ring = FaceGeom::new(vec![outer, hole]).unwrap();
        let pole = quad([[1.5, 2., -1.], [2.5, 2., -1.], [2.5, 2., 1.], [1.5, 2., 1.]]);
        assert_eq!(relate(&ring, &pole, EPS), Relation::Disjoint);
        let wide = quad([[0.5, 2., -1.], [2.5, 2., -1.], [2.5, 2., 1.], [0.5, 2., 1.]]);
        assert_eq!(relate(&ring, &wide, EPS), Relation::Intersect);
    }

    #[test]
    fn cuts_are_where_both_faces_are() {
        // A wall standing on a floor, its foot inside: the cut is the foot.
        let wall = quad([[1., 1., 0.], [3., 1., 0.], [3., 1., 2.], [1., 1., 2.]]);
        let c = cut_segments(&floor(), &wall, EPS);
        assert_eq!(c.len(), 1);
        let (p, q) = c[0];
        let (lo, hi) = if p.x < q.x { (p, q) } else { (q, p) };
        assert!((lo - DVec3::new(1., 1., 0.)).length() < 1e-12);
        assert!((hi - DVec3::new(3., 1., 0.)).length() < 1e-12);
        // A wall crossing the floor beyond its edge: cut only inside the floor.
        let long = quad([[-1., 2., -1.], [6., 2., -1.], [6., 2., 1.], [-1., 2., 1.]]);
        let c = cut_segments(&floor(), &long, EPS);
        assert_eq!(c.len(), 1);
        let (p, q) = c[0];
        assert!(((p - q).length() - 4.0).abs() < 1e-12);
        // Touching along the boundary only: no cut.
        let edge = quad([[0., 0., 0.], [4., 0., 0.], [4., 0., 2.], [0., 0., 2.]]);
        assert!(cut_segments(&floor(), &edge, EPS).is_empty());
        // Through a hole: two pieces.
        let mut hole = vec![
            DVec3::new(1., 1., 0.),
            DVec3::new(3., 1., 0.),
            DVec3::new(3., 3., 0.),
            DVec3::new(1., 3., 0.),
        ];
        hole.reverse();
        let outer = vec![
            DVec3::new(0., 0., 0.),
            DVec3::new(4., 0., 0.),
            DVec3::new(4., 4., 0.),
            DVec3::new(0., 4., 0.),
        ];
        let ring = FaceGeom::new(vec![outer, hole]).unwrap();
        let wide = quad([[-1., 2., -1.], [5., 2., -1.], [5., 2., 1.], [-1., 2., 1.]]);
        let c = cut_segments(&ring, &wide, EPS);
        assert_eq!(c.len(), 2);
        for (p, q) in c {
            assert!(((p - q).length() - 1.0).abs() < 1e-12);
        }
    }
}
