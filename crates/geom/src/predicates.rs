//! Exact predicates (Shewchuk's adaptive arithmetic via the `robust` crate).

use glam::{DVec2, DVec3};

#[inline]
fn c2(p: DVec2) -> robust::Coord<f64> {
    robust::Coord { x: p.x, y: p.y }
}

#[inline]
fn c3(p: DVec3) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// Exact sign of the signed area of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear.
#[inline]
pub fn orient2d(a: DVec2, b: DVec2, c: DVec2) -> i32 {
    sign(robust::orient2d(c2(a), c2(b), c2(c)))
}

/// Exact position of `d` against the circle through a, b, c: +1 inside,
/// -1 outside, 0 on it, whichever way a, b, c turn (the Delaunay test).
#[inline]
pub fn incircle(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> i32 {
    sign(robust::incircle(c2(a), c2(b), c2(c), c2(d))) * orient2d(a, b, c)
}

/// Exact side of `d` relative to the plane through a, b, c:
/// +1 when d lies below (a, b, c counter-clockwise seen from above), -1 above, 0 coplanar
/// (Shewchuk's convention).
#[inline]
pub fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> i32 {
    sign(robust::orient3d(c3(a), c3(b), c3(c), c3(d)))
}

#[inline]
fn sign(v: f64) -> i32 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// Whether `p` lies on the closed segment [a, b] in 2-D (exactly).
pub fn on_segment_2d(p: DVec2, a: DVec2, b: DVec2) -> bool {
    orient2d(a, b, p) == 0
        && p.x >= a.x.min(b.x)
        && p.x <= a.x.max(b.x)
        && p.y >= a.y.min(b.y)
        && p.y <= a.y.max(b.y)
}

/// How two closed 2-D segments meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentContact {
    /// No common point.
    None,
    /// They cross at one point interior to both.
    Proper,
    /// They share a point that is an endpoint of at least one of them, or they overlap collinearly.
    Touch,
}

/// Exact classification of two closed 2-D segments.
pub fn segments_2d(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> SegmentContact {
    let o1 = orient2d(a, b, c);
    let o2 = orient2d(a, b, d);
    let o3 = orient2d(c, d, a);
    let o4 = orient2d(c, d, b);
    if o1 * o2 < 0 && o3 * o4 < 0 {
        return SegmentContact::Proper;
    }
    if (o1 == 0 && on_segment_2d(c, a, b))
        || (o2 == 0 && on_segment_2d(d, a, b))
        || (o3 == 0 && on_segment_2d(a, c, d))
        || (o4 == 0 && on_segment_2d(b, c, d))
    {
        return SegmentContact::Touch;
    }
    SegmentContact::None
}

/// Distance from `p` to the segment [a, b] and the parameter t ∈ [0, 1] of the closest point.
pub fn point_segment_distance(p: DVec3, a: DVec3, b: DVec3) -> (f64, f64) {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((a + ab * t - p).length(), t)
}

/// Where `p` lies on the interior of the edge [a, b] within `eps`: the
/// parameter of its nearest point when it is within `eps` of the segment
/// and farther than `eps` from both ends (a T-vertex, as ugcheck counts
/// them and the weld inserts them), else `None`.
pub fn on_edge_interior(p: DVec3, a: DVec3, b: DVec3, eps: f64) -> Option<f64> {
    if p.distance(a) <= eps || p.distance(b) <= eps {
        return None;
    }
    let (d, t) = point_segment_distance(p, a, b);
    (d <= eps).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn incircle_is_inside_either_way_round() {
        let (a, b, c) = (
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, 2.0),
        );
        // The circle's centre is (1, 1), its radius √2.
        for (d, want) in [
            (DVec2::new(1.0, 1.0), 1),
            (DVec2::new(2.0, 2.0), 0),
            (DVec2::new(2.5, 2.5), -1),
            (DVec2::new(1.0, 1.0 + 2f64.sqrt() * 0.999), 1),
        ] {
            assert_eq!(incircle(a, b, c, d), want, "{d}");
            assert_eq!(incircle(a, c, b, d), want, "{d}, clockwise");
        }
        // Collinear: no circle, nothing inside.
        let e = DVec2::new(4.0, 0.0);
        assert_eq!(incircle(a, b, e, DVec2::new(1.0, 0.5)), 0);
    }

    #[test]
    fn orient2d_is_exact_near_degenerate() {
        // Classic failure of naive arithmetic: points nearly on a line.
        let a = DVec2::new(0.5, 0.5);
        let b = DVec2::new(12.0, 12.0);
        let c = DVec2::new(24.0, 24.0);
        assert_eq!(orient2d(a, b, c), 0);
        let c2 = DVec2::new(24.0, 24.0 + f64::EPSILON * 32.0);
        assert_eq!(orient2d(a, b, c2), 1);
    }

    #[test]
    fn orient3d_sides() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_eq!(orient3d(a, b, c, DVec3::Z), -1);
        assert_eq!(orient3d(a, b, c, -DVec3::Z), 1);
        assert_eq!(orient3d(a, b, c, DVec3::new(3.0, 4.0, 0.0)), 0);
    }

    #[test]
    fn segment_classification() {
        let p = DVec2::new;
        assert_eq!(
            segments_2d(p(0., 0.), p(2., 2.), p(0., 2.), p(2., 0.)),
            SegmentContact::Proper
        );
        assert_eq!(
            segments_2d(p(0., 0.), p(2., 0.), p(1., 0.), p(1., 5.)),
            SegmentContact::Touch
        );
        assert_eq!(
            segments_2d(p(0., 0.), p(1., 0.), p(2., 0.), p(3., 0.)),
            SegmentContact::None
        );
        assert_eq!(
            segments_2d(p(0., 0.), p(2., 0.), p(1., 0.), p(3., 0.)),
            SegmentContact::Touch
        );
    }

    #[test]
    fn point_segment() {
        let (d, t) = point_segment_distance(
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
        );
        assert!((d - 1.0).abs() < 1e-15 && (t - 0.5).abs() < 1e-15);
    }
}
