//! Areas of overlap of two planar regions (polygons with holes and islands,
//! even-odd rule), from the snap-rounded arrangement of their contours
//! ([`crate::arrange`]): the same decisions `ugcopl` cuts by, so the checker
//! and the cutter never disagree about what overlaps.

use glam::DVec2;

use crate::arrange::{Options, Segment, Tag, arrange};

/// The areas of two regions and of their common part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coverage {
    pub a: f64,
    pub b: f64,
    pub common: f64,
    /// Area in `a` and not in `b`, and the other way round.
    pub only_a: f64,
    pub only_b: f64,
}

/// Areas of `a`, `b` and `a ∩ b` (contour lists, even-odd), with features
/// closer than `snap` taken as one.
pub fn coverage(a: &[Vec<DVec2>], b: &[Vec<DVec2>], snap: f64) -> Coverage {
    let mut pts = Vec::new();
    let mut segs = Vec::new();
    for (tag, region) in [(0u32, a), (1u32, b)] {
        for c in region {
            if c.len() < 3 {
                continue;
            }
            let base = pts.len() as u32;
            pts.extend(c.iter().copied());
            let n = c.len() as u32;
            segs.extend((0..n).map(|i| Segment {
                a: base + i,
                b: base + (i + 1) % n,
                tag: Tag::Toggle(tag),
            }));
        }
    }
    let arr = arrange(&pts, &segs, &Options::new(snap));
    let mut cov = Coverage {
        a: 0.0,
        b: 0.0,
        common: 0.0,
        only_a: 0.0,
        only_b: 0.0,
    };
    for f in &arr.faces {
        let (ia, ib) = (f.has(0), f.has(1));
        if ia {
            cov.a += f.area;
        }
        if ib {
            cov.b += f.area;
        }
        match (ia, ib) {
            (true, true) => cov.common += f.area,
            (true, false) => cov.only_a += f.area,
            (false, true) => cov.only_b += f.area,
            _ => {}
        }
    }
    cov
}

/// [`coverage`] of the parts of `a` and `b` near their common bounding
/// box (grown by 4 `snap`): contours reaching beyond it are clipped to it
/// first (Sutherland–Hodgman, even-odd area kept inside the box), so that a
/// big floor against a rug costs what the rug costs. `common` is exact;
/// when anything was clipped (`.1` is true) `a` and `b` are the areas inside
/// the box, and the regions are certainly not the same.
pub fn coverage_near(a: &[Vec<DVec2>], b: &[Vec<DVec2>], snap: f64) -> (Coverage, bool) {
    let bounds = |r: &[Vec<DVec2>]| {
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for p in r.iter().flatten() {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        (lo, hi)
    };
    let (alo, ahi) = bounds(a);
    let (blo, bhi) = bounds(b);
    let pad = DVec2::splat(4.0 * snap);
    let (ilo, ihi) = (alo.max(blo), ahi.min(bhi));
    let (lo, hi) = (ilo - pad, ihi + pad);
    let empty = Coverage {
        a: 0.0,
        b: 0.0,
        common: 0.0,
        only_a: 0.0,
        only_b: 0.0,
    };
    // Boxes that meet in a strip no wider than snap: what they share is
    // narrower than snap, which the arrangement would drop.
    if ihi.x - ilo.x <= snap || ihi.y - ilo.y <= snap {
        return (empty, true);
    }
    let inside = |l: DVec2, h: DVec2| l.cmpge(lo).all() && h.cmple(hi).all();
    let clip = |r: &[Vec<DVec2>]| -> Vec<Vec<DVec2>> {
        r.iter()
            .map(|c| clip_to_box(c, lo, hi))
            .filter(|c| c.len() >= 3)
            .collect()
    };
    let (ca, cb) = (inside(alo, ahi), inside(blo, bhi));
    let a2: Vec<Vec<DVec2>> = if ca { a.to_vec() } else { clip(a) };
    let b2: Vec<Vec<DVec2>> = if cb { b.to_vec() } else { clip(b) };
    (coverage(&a2, &b2, snap), !(ca && cb))
}

/// A closed contour clipped to the box [lo, hi] (Sutherland–Hodgman): the
/// even-odd region inside the box is kept; a contour outside it is empty.
pub fn clip_to_box(c: &[DVec2], lo: DVec2, hi: DVec2) -> Vec<DVec2> {
    let ring: Vec<(DVec2, ())> = c.iter().map(|&p| (p, ())).collect();
    clip_ring_to_box(&ring, lo, hi, ())
        .into_iter()
        .map(|(p, _)| p)
        .collect()
}

/// [`clip_to_box`] for points that carry something (a vertex id): points
/// inside keep theirs, points made on the box get `made`.
pub fn clip_ring_to_box<T: Copy>(
    ring: &[(DVec2, T)],
    lo: DVec2,
    hi: DVec2,
    made: T,
) -> Vec<(DVec2, T)> {
    let mut pts = ring.to_vec();
    // (axis, bound, keep values >= bound?)
    for (axis, bound, keep_above) in [
        (0, lo.x, true),
        (0, hi.x, false),
        (1, lo.y, true),
        (1, hi.y, false),
    ] {
        if pts.is_empty() {
            break;
        }
        let val = |p: DVec2| if axis == 0 { p.x } else { p.y };
        let ins = |p: DVec2| {
            if keep_above {
                val(p) >= bound
            } else {
                val(p) <= bound
            }
        };
        let mut out = Vec::with_capacity(pts.len() + 4);
        for i in 0..pts.len() {
            let (p, q) = (pts[i], pts[(i + 1) % pts.len()]);
            let (pi, qi) = (ins(p.0), ins(q.0));
            if pi {
                out.push(p);
            }
            if pi != qi {
                let t = (bound - val(p.0)) / (val(q.0) - val(p.0));
                let mut x = p.0 + (q.0 - p.0) * t;
                if axis == 0 {
                    x.x = bound;
                } else {
                    x.y = bound;
                }
                out.push((x, made));
            }
        }
        pts = out;
    }
    pts
}

/// Unsigned area of the intersection of two regions given as contour lists.
pub fn overlap_area(a: &[Vec<DVec2>], b: &[Vec<DVec2>], snap: f64) -> f64 {
    coverage(a, b, snap).common
}

/// Unsigned area of a region given as contours (even-odd rule).
pub fn region_area(a: &[Vec<DVec2>], snap: f64) -> f64 {
    coverage(a, &[], snap).a
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
        assert!((overlap_area(&[sq(0., 0., 2.)], &[sq(1., 1., 2.)], 1e-12) - 1.0).abs() < 1e-12);
        assert_eq!(
            overlap_area(&[sq(0., 0., 1.)], &[sq(1., 0., 1.)], 1e-12),
            0.0
        );
        // Clockwise input is the same region.
        let mut cw = sq(1., 1., 2.);
        cw.reverse();
        assert!((overlap_area(&[sq(0., 0., 2.)], &[cw], 1e-12) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn holes_and_islands() {
        let mut hole = sq(2., 2., 6.);
        hole.reverse();
        let face = vec![sq(0., 0., 10.), hole, sq(4., 4., 2.)];
        assert!((region_area(&face, 1e-12) - 68.0).abs() < 1e-9);
        // A square inside the hole but outside the island overlaps nothing.
        assert!(overlap_area(&face, &[sq(2.5, 2.5, 1.0)], 1e-12) < 1e-12);
        assert!((overlap_area(&face, &[sq(4.5, 4.5, 1.0)], 1e-12) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn clipping_to_the_common_box_keeps_the_common_area() {
        let mut hole = sq(2., 2., 6.);
        hole.reverse();
        let big = vec![sq(0., 0., 100.), hole];
        for (small, want) in [
            (sq(1.5, 1.5, 1.0), 0.75),
            (sq(3.0, 3.0, 1.0), 0.0),
            (sq(50.0, 50.0, 2.0), 4.0),
        ] {
            let (c, clipped) = coverage_near(&big, std::slice::from_ref(&small), 1e-9);
            assert!(clipped);
            assert!((c.common - want).abs() < 1e-9, "{c:?}");
            assert!((c.common - coverage(&big, &[small], 1e-9).common).abs() < 1e-9);
        }
        let (c, clipped) = coverage_near(&[sq(0., 0., 1.)], &[sq(0., 0., 1.)], 1e-9);
        assert!(!clipped && (c.common - 1.0).abs() < 1e-12 && c.only_a == 0.0);
    }

    #[test]
    fn a_small_triangle_at_a_holes_corner() {
        // The kind of pair the boolean library missed: a face with a hole
        // whose corner is cut off, and the small triangle in that corner.
        let outer = sq(0., 0., 4.);
        let hole = vec![
            DVec2::new(1., 1.),
            DVec2::new(1., 2.),
            DVec2::new(1.9, 2.),
            DVec2::new(2., 1.9),
            DVec2::new(2., 1.),
        ];
        let tri = vec![DVec2::new(2., 1.9), DVec2::new(2., 2.), DVec2::new(1.9, 2.)];
        let c = coverage(&[outer, hole], &[tri], 1e-9);
        assert!((c.common - 0.005).abs() < 1e-12, "{c:?}");
        assert!((c.a - (16.0 - 1.0 + 0.005)).abs() < 1e-12);
    }

    /// Two patches of one facade, in the larger one's frame (property seed
    /// 170590 to 1 mm, epsilon 2.1 mm): a triangle whose top corner lies
    /// 2e-31 above the line of the other's top edge, 3.2 mm beyond that
    /// edge's end. The ray placing the second component crossed both of
    /// the first's sides from that corner at one rounded x, took the wrong
    /// one, and put the second inside the first: 0.059 m² of overlap
    /// where there is none.
    #[test]
    fn a_component_beside_a_corner_a_hair_above_its_ray_is_outside() {
        let a = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(-4.638337116478427, 0.0),
            DVec2::new(-1.9892182254263848, -0.6999999999999997),
        ];
        let b = vec![
            DVec2::new(-4.641509192661563, 1.9721522630525295e-31),
            DVec2::new(-4.641509192661563, -2.8),
            DVec2::new(-3.9784364508527683, -1.3999999999999995),
        ];
        let c = coverage(std::slice::from_ref(&a), std::slice::from_ref(&b), 0.0021);
        assert_eq!(c.common, 0.0, "{c:?}");
        assert!((c.a - 1.6234179907674489).abs() < 1e-9, "{c:?}");
        assert!((c.b - 0.9283018385323129).abs() < 1e-9, "{c:?}");
        let (c, _) = coverage_near(&[a], &[b], 0.0021);
        assert_eq!(c.common, 0.0, "{c:?}");
    }
}
