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

/// Cuts the region of `a` by each of `others` in turn: every piece is split
/// into its part inside and its part outside the next region. Returns the
/// pieces as polygons with holes (outer contour counter-clockwise, holes
/// clockwise; islands are separate pieces), dropping slivers with area below
/// `min_area`. Pieces that lie in the same set of `others` are the same region
/// for every face cut this way, which is what makes a coplanar overlap a
/// separate face in each face it belongs to.
pub fn split_by(
    a: &[Vec<DVec2>],
    others: &[Vec<Vec<DVec2>>],
    min_area: f64,
) -> Vec<Vec<Vec<DVec2>>> {
    let mut pieces = vec![region(a)];
    for o in others {
        let ro = region(o);
        if ro.0.is_empty() {
            continue;
        }
        let mut next = Vec::with_capacity(pieces.len() * 2);
        for p in pieces {
            for part in [p.intersection(&ro), p.difference(&ro)] {
                if part.unsigned_area() > min_area {
                    next.push(part);
                }
            }
        }
        pieces = next;
    }
    let ring = |ls: &LineString<f64>, ccw: bool| -> Vec<DVec2> {
        let mut pts: Vec<DVec2> = ls.0.iter().map(|c| DVec2::new(c.x, c.y)).collect();
        if pts.len() > 1 && pts.first() == pts.last() {
            pts.pop();
        }
        let s: f64 = (0..pts.len())
            .map(|i| pts[i].perp_dot(pts[(i + 1) % pts.len()]))
            .sum();
        if (s > 0.0) != ccw {
            pts.reverse();
        }
        pts
    };
    let mut out = Vec::new();
    for mp in pieces {
        for poly in mp.0 {
            if poly.unsigned_area() <= min_area {
                continue;
            }
            let mut contours = vec![ring(poly.exterior(), true)];
            contours.extend(poly.interiors().iter().map(|h| ring(h, false)));
            out.push(contours);
        }
    }
    out
}

/// Moves a point that polygon booleans computed (they round to a fixed-point
/// grid internally, ~1e-9 of the extent) back onto the exact intersection of
/// the features it was made from: among `segments`, those whose lines pass
/// within `tol` of the point (and that reach it, within `tol`), the two that
/// cross at the largest angle are intersected in f64; with one, the point is
/// projected onto it; with none it stays.
pub fn refine_point(p: DVec2, segments: &[(DVec2, DVec2)], tol: f64) -> DVec2 {
    let mut near: Vec<(DVec2, DVec2)> = Vec::new();
    for &(a, b) in segments {
        let d = b - a;
        let l2 = d.length_squared();
        if l2 == 0.0 {
            continue;
        }
        let t = (p - a).dot(d) / l2;
        let l = l2.sqrt();
        if t * l < -tol || (t - 1.0) * l > tol {
            continue;
        }
        if (p - a).perp_dot(d).abs() / l <= tol {
            near.push((a, d / l));
        }
    }
    let mut best: Option<(f64, DVec2)> = None;
    for i in 0..near.len() {
        for j in i + 1..near.len() {
            let (a, u) = near[i];
            let (b, v) = near[j];
            let s = u.perp_dot(v);
            if s.abs() < 1e-9 {
                continue;
            }
            let x = a + u * ((b - a).perp_dot(v) / s);
            if (x - p).length() <= 2.0 * tol && best.is_none_or(|(bs, _)| s.abs() > bs) {
                best = Some((s.abs(), x));
            }
        }
    }
    if let Some((_, x)) = best {
        return x;
    }
    if let Some(&(a, u)) = near.first() {
        return a + u * (p - a).dot(u);
    }
    p
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
    fn split_by_makes_the_overlap_a_piece() {
        let pieces = split_by(&[sq(0., 0., 2.)], &[vec![sq(1., 1., 2.)]], 1e-12);
        assert_eq!(pieces.len(), 2);
        let areas: Vec<f64> = pieces.iter().map(|p| region_area(p)).collect();
        assert!(
            (areas[0] - 1.0).abs() < 1e-12 && (areas[1] - 3.0).abs() < 1e-12,
            "{areas:?}"
        );
        // A square cut by a smaller one inside it: a piece with a hole and the inner piece.
        let pieces = split_by(&[sq(0., 0., 4.)], &[vec![sq(1., 1., 1.)]], 1e-12);
        assert_eq!(pieces.len(), 2);
        assert_eq!(pieces.iter().map(|p| p.len()).collect::<Vec<_>>(), [1, 2]);
        assert!(crate::polygon::signed_area_2d(&pieces[1][0]) > 0.0);
        assert!(crate::polygon::signed_area_2d(&pieces[1][1]) < 0.0);
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
