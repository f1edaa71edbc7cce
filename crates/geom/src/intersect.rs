//! How two planar faces meet in space: disjoint, touching along their
//! boundaries only, intersecting (some common point lies in the interior of
//! one of them), or coplanar (left to the 2-D tests).

use glam::{DVec2, DVec3};

use crate::plane::{Frame, Plane};
use crate::polygon::{Location, locate_2d};

/// A face prepared for pair tests: contours, best-fit plane and its 2-D projection.
#[derive(Clone, Debug)]
pub struct FaceGeom {
    pub contours: Vec<Vec<DVec3>>,
    pub plane: Plane,
    pub frame: Frame,
    pub contours_2d: Vec<Vec<DVec2>>,
}

impl FaceGeom {
    /// `None` for a degenerate face (no area, or no contour).
    pub fn new(contours: Vec<Vec<DVec3>>) -> Option<FaceGeom> {
        let outer = contours.first()?;
        let plane = Plane::fit(outer)?;
        let frame = Frame::new(outer[0], plane.n);
        let contours_2d = contours
            .iter()
            .map(|c| c.iter().map(|&p| frame.to_2d(p)).collect())
            .collect();
        Some(FaceGeom {
            contours,
            plane,
            frame,
            contours_2d,
        })
    }

    /// Location of a 3-D point (assumed in or near the plane) with tolerance
    /// `eps`: within `eps` of an edge counts as the boundary.
    pub fn locate(&self, p: DVec3, eps: f64) -> Location {
        locate_eps(self.frame.to_2d(p), &self.contours_2d, eps)
    }
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
    if all(&db, &|x| x == 0.0) || all(&da, &|x| x == 0.0) {
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
}
