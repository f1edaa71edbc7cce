//! Polygons with holes and islands, in 3-D (faces) and projected to 2-D.
//!
//! A face is a list of contours; the first is the outer boundary, the others
//! are holes (wound opposite to it) or islands inside holes (wound like it).
//! Inside/outside uses the even-odd rule over all contours, so nesting works
//! to any depth.

use glam::{DVec2, DVec3};

use crate::plane::{Frame, newell_normal};
use crate::predicates::{on_segment_2d, orient2d};

/// Signed area of a 2-D contour (positive counter-clockwise).
pub fn signed_area_2d(c: &[DVec2]) -> f64 {
    let n = c.len();
    if n < 3 {
        return 0.0;
    }
    let o = c[0];
    let mut s = 0.0;
    for i in 1..n - 1 {
        s += (c[i] - o).perp_dot(c[i + 1] - o);
    }
    s / 2.0
}

/// Area of a face with holes and islands, measured along its outer contour's
/// normal: holes (wound the other way) subtract, islands add.
pub fn face_area(contours: &[Vec<DVec3>]) -> f64 {
    let Some(outer) = contours.first() else {
        return 0.0;
    };
    let n = newell_normal(outer);
    let len = n.length();
    if len == 0.0 {
        return 0.0;
    }
    let n = n / len;
    contours.iter().map(|c| newell_normal(c).dot(n) / 2.0).sum()
}

/// Unit normal of a face (Newell, from the outer contour; the plane its
/// points span where its lobes cancel: [`crate::plane::contour_normal`]),
/// or `None` when degenerate.
pub fn face_normal(contours: &[Vec<DVec3>]) -> Option<DVec3> {
    let n = crate::plane::contour_normal(contours.first()?);
    let len = n.length();
    (len > 0.0 && len.is_finite()).then(|| n / len)
}

/// Where a point lies relative to a polygon.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    Inside,
    Outside,
    Boundary,
}

/// Whether the edge a→b crosses the ray from `p` towards +x: the half-open
/// rule on y, the side decided exactly (an edge going up crosses when `p`
/// is left of it). The step of every even-odd point location.
pub fn crosses_ray(p: DVec2, a: DVec2, b: DVec2) -> bool {
    if (a.y > p.y) == (b.y > p.y) {
        return false;
    }
    let o = orient2d(a, b, p);
    (b.y > a.y && o > 0) || (b.y < a.y && o < 0)
}

/// Exact point-in-polygon test (even-odd over all contours) with exact boundary detection.
pub fn locate_2d(p: DVec2, contours: &[Vec<DVec2>]) -> Location {
    let mut inside = false;
    for c in contours {
        let n = c.len();
        for i in 0..n {
            let a = c[i];
            let b = c[(i + 1) % n];
            if on_segment_2d(p, a, b) {
                return Location::Boundary;
            }
            if crosses_ray(p, a, b) {
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

/// A face projected into its own plane.
#[derive(Clone, Debug)]
pub struct Projected {
    pub frame: Frame,
    pub contours: Vec<Vec<DVec2>>,
}

impl Projected {
    /// Projects contours into the frame of their outer contour's Newell normal.
    pub fn new(contours: &[Vec<DVec3>]) -> Option<Projected> {
        let n = face_normal(contours)?;
        let frame = Frame::new(contours[0][0], n);
        Some(Self::in_frame(frame, contours))
    }

    /// Projects contours into a given frame.
    pub fn in_frame(frame: Frame, contours: &[Vec<DVec3>]) -> Projected {
        Projected {
            frame,
            contours: contours
                .iter()
                .map(|c| c.iter().map(|&p| frame.to_2d(p)).collect())
                .collect(),
        }
    }

    pub fn locate(&self, p: DVec2) -> Location {
        locate_2d(p, &self.contours)
    }

    /// Signed area in the frame (outer contour counter-clockwise in the frame gives positive).
    pub fn area(&self) -> f64 {
        self.contours.iter().map(|c| signed_area_2d(c)).sum()
    }
}

/// The first two edges (in index order) that properly cross without
/// sharing an end: edges as their ends' keys and 2-D points, `near(lo, hi)`
/// the edges whose boxes may meet the box [lo, hi] (all of them, or an
/// index's answer). `ugcheck`'s "edges … cross" and the grouper's test of
/// a joined face use it.
pub fn first_proper_crossing<K: PartialEq + Copy>(
    edges: &[([K; 2], DVec2, DVec2)],
    near: &dyn Fn(DVec2, DVec2) -> Vec<usize>,
) -> Option<(usize, usize)> {
    for (i, &(ev, a, b)) in edges.iter().enumerate() {
        for j in near(a.min(b), a.max(b)) {
            if j <= i {
                continue;
            }
            let (fv, c, d) = edges[j];
            if ev.iter().any(|v| fv.contains(v)) {
                continue;
            }
            if crate::segments_2d(a, b, c, d) == crate::SegmentContact::Proper {
                return Some((i, j));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sq(x0: f64, y0: f64, s: f64) -> Vec<DVec2> {
        vec![
            DVec2::new(x0, y0),
            DVec2::new(x0 + s, y0),
            DVec2::new(x0 + s, y0 + s),
            DVec2::new(x0, y0 + s),
        ]
    }

    #[test]
    fn area_with_hole_and_island() {
        let outer: Vec<DVec3> = sq(0.0, 0.0, 10.0).iter().map(|p| p.extend(0.0)).collect();
        let mut hole: Vec<DVec3> = sq(2.0, 2.0, 6.0).iter().map(|p| p.extend(0.0)).collect();
        hole.reverse();
        let island: Vec<DVec3> = sq(4.0, 4.0, 2.0).iter().map(|p| p.extend(0.0)).collect();
        assert_eq!(face_area(std::slice::from_ref(&outer)), 100.0);
        assert_eq!(face_area(&[outer.clone(), hole.clone()]), 64.0);
        assert_eq!(face_area(&[outer, hole, island]), 68.0);
    }

    #[test]
    fn locate_with_hole() {
        let mut hole = sq(2.0, 2.0, 6.0);
        hole.reverse();
        let poly = vec![sq(0.0, 0.0, 10.0), hole];
        assert_eq!(locate_2d(DVec2::new(1.0, 1.0), &poly), Location::Inside);
        assert_eq!(locate_2d(DVec2::new(5.0, 5.0), &poly), Location::Outside);
        assert_eq!(locate_2d(DVec2::new(2.0, 5.0), &poly), Location::Boundary);
        assert_eq!(locate_2d(DVec2::new(10.0, 10.0), &poly), Location::Boundary);
        assert_eq!(locate_2d(DVec2::new(11.0, 5.0), &poly), Location::Outside);
        // A vertex exactly at the ray's height.
        assert_eq!(locate_2d(DVec2::new(-1.0, 0.0), &poly), Location::Outside);
        assert_eq!(locate_2d(DVec2::new(5.0, 0.0), &poly), Location::Boundary);
    }

    #[test]
    fn frame_keeps_ccw() {
        let pts = [
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(0.0, 1.0, 5.0),
            DVec3::new(0.0, 0.0, 6.0),
        ];
        let pr = Projected::new(&[pts.to_vec()]).unwrap();
        assert!(pr.area() > 0.0);
        assert!((pr.area() - 0.5).abs() < 1e-12);
    }
}
