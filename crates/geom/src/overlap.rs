//! Area of overlap of two planar regions (polygons with holes and islands),
//! through the polygon boolean operations of the `geo` crate.

use geo::{Area, BooleanOps, Coord, LineString, MultiPolygon, Polygon};
use glam::DVec2;

/// The region of a face under the even-odd rule: the XOR of its contours.
pub fn region(contours: &[Vec<DVec2>]) -> MultiPolygon<f64> {
    let mut acc = MultiPolygon::<f64>::new(vec![]);
    for c in contours {
        if c.len() < 3 {
            continue;
        }
        let ring: Vec<Coord<f64>> = c.iter().map(|p| Coord { x: p.x, y: p.y }).collect();
        let poly = MultiPolygon::new(vec![Polygon::new(LineString::new(ring), vec![])]);
        acc = if acc.0.is_empty() {
            poly
        } else {
            acc.xor(&poly)
        };
    }
    acc
}

/// Unsigned area of the intersection of two regions given as contour lists.
pub fn overlap_area(a: &[Vec<DVec2>], b: &[Vec<DVec2>]) -> f64 {
    let (ra, rb) = (region(a), region(b));
    if ra.0.is_empty() || rb.0.is_empty() {
        return 0.0;
    }
    ra.intersection(&rb).unsigned_area()
}

/// Unsigned area of a region given as contours (even-odd rule).
pub fn region_area(a: &[Vec<DVec2>]) -> f64 {
    region(a).unsigned_area()
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
    fn overlap_of_squares() {
        assert!((overlap_area(&[sq(0., 0., 2.)], &[sq(1., 1., 2.)]) - 1.0).abs() < 1e-12);
        assert_eq!(overlap_area(&[sq(0., 0., 1.)], &[sq(1., 0., 1.)]), 0.0);
        // Clockwise input is the same region.
        let mut cw = sq(1., 1., 2.);
        cw.reverse();
        assert!((overlap_area(&[sq(0., 0., 2.)], &[cw]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn holes_and_islands() {
        let mut hole = sq(2., 2., 6.);
        hole.reverse();
        let face = vec![sq(0., 0., 10.), hole, sq(4., 4., 2.)];
        assert!((region_area(&face) - 68.0).abs() < 1e-9);
        // A square inside the hole but outside the island overlaps nothing.
        assert!(overlap_area(&face, &[sq(2.5, 2.5, 1.0)]) < 1e-12);
        assert!((overlap_area(&face, &[sq(4.5, 4.5, 1.0)]) - 1.0).abs() < 1e-12);
    }
}
