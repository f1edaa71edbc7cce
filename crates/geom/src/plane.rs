//! Planes, Newell normals and 2-D frames for projecting planar polygons.

use glam::{DVec2, DVec3};

/// Newell's normal of a closed polygon: its direction follows the right-hand
/// rule of the vertex order and its length is twice the polygon's area
/// (for a planar polygon). Robust for non-convex and slightly non-planar contours.
pub fn newell_normal(pts: &[DVec3]) -> DVec3 {
    newell_and_reach(pts).0
}

/// [`newell_normal`], and in the same pass the squared distance of the
/// point farthest from the first.
fn newell_and_reach(pts: &[DVec3]) -> (DVec3, f64) {
    let n = pts.len();
    if n < 3 {
        return (DVec3::ZERO, 0.0);
    }
    // Relative to the first point for accuracy far from the origin.
    let o = pts[0];
    let mut acc = DVec3::ZERO;
    let mut r2 = 0.0f64;
    for i in 0..n {
        let a = pts[i] - o;
        let b = pts[(i + 1) % n] - o;
        acc += a.cross(b);
        r2 = r2.max(a.length_squared());
    }
    (acc, r2)
}

/// A normal of the plane that a contour's points span, from three of its
/// points far apart (the first, the one farthest from it, and the one
/// farthest from the line through those two); its length is twice their
/// triangle's area, zero when every point lies on one line. Unlike
/// [`newell_normal`] it does not depend on the winding: a contour that
/// crosses itself into lobes of opposite winding and equal area (a
/// bow-tie, a quad exported with two corners swapped, a figure eight) has a
/// Newell normal of nothing, but spans a plane.
pub fn spread_normal(pts: &[DVec3]) -> DVec3 {
    let Some(&a) = pts.first() else {
        return DVec3::ZERO;
    };
    let far = |key: &dyn Fn(DVec3) -> f64| {
        pts.iter()
            .copied()
            .fold((a, f64::NEG_INFINITY), |best, p| {
                let k = key(p);
                if k > best.1 { (p, k) } else { best }
            })
            .0
    };
    let b = far(&|p| (p - a).length_squared());
    let ab = b - a;
    let c = far(&|p| ab.cross(p - a).length_squared());
    ab.cross(c - a)
}

/// The normal of a contour ([`newell_normal`]), or, where its lobes cancel
/// (a Newell normal under 1e-9 of [`spread_normal`]), the spread normal,
/// turned to agree with whatever the Newell normal has. The same as
/// `newell_normal` for every contour whose winding encloses area.
pub fn contour_normal(pts: &[DVec3]) -> DVec3 {
    // The spread normal is at most r² long (r: the farthest point from the
    // first), so a Newell normal above 1e-9 r² needs no more.
    let (n, r2) = newell_and_reach(pts);
    let len = n.length();
    if len.is_finite() && len > 1e-9 * r2 {
        return n;
    }
    let s = spread_normal(pts);
    if len.is_finite() && len > 1e-9 * s.length() {
        return n;
    }
    if s.dot(n) < 0.0 { -s } else { s }
}

/// A plane `n·p = d` with unit normal `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub n: DVec3,
    pub d: f64,
}

impl Plane {
    /// The best-fit plane of a contour: Newell normal through the centroid.
    /// `None` when the contour has no area (degenerate).
    pub fn fit(pts: &[DVec3]) -> Option<Plane> {
        let n = contour_normal(pts);
        let len = n.length();
        if len.is_nan() || len <= 0.0 || pts.is_empty() {
            return None;
        }
        let n = n / len;
        let c = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
        Some(Plane { n, d: n.dot(c) })
    }

    /// A face's planarity: its best-fit plane (the outer contour's normal,
    /// as [`Plane::fit`], through the centroid of all its contours' points)
    /// and the largest distance of any of the points from it. The one
    /// measure of every tool and of `ugcheck`, so that a face a tool passes
    /// on as planar is planar to the check.
    pub fn face_deviation(contours: &[Vec<DVec3>]) -> Option<(f64, Plane)> {
        let n = Plane::fit(contours.first()?)?.n;
        let count: usize = contours.iter().map(Vec::len).sum();
        let c = contours.iter().flatten().copied().sum::<DVec3>() / count as f64;
        let plane = Plane { n, d: n.dot(c) };
        let dev = contours
            .iter()
            .flatten()
            .map(|&p| plane.dist(p).abs())
            .fold(0.0, f64::max);
        Some((dev, plane))
    }

    /// Signed distance of a point from the plane (positive on the normal's side).
    pub fn dist(&self, p: DVec3) -> f64 {
        self.n.dot(p) - self.d
    }

    /// The plane with the opposite orientation.
    pub fn flipped(&self) -> Plane {
        Plane {
            n: -self.n,
            d: -self.d,
        }
    }
}

/// An orthonormal frame (u, v, n) for projecting points of a plane to 2-D.
/// (u, v, n) is right-handed, so counter-clockwise seen from the front of the
/// plane (from +n) stays counter-clockwise in (u, v).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub origin: DVec3,
    pub u: DVec3,
    pub v: DVec3,
    pub n: DVec3,
}

impl Frame {
    /// A frame with normal `n` (need not be unit) at `origin`.
    pub fn new(origin: DVec3, n: DVec3) -> Frame {
        let n = n.normalize_or_zero();
        let n = if n == DVec3::ZERO { DVec3::Z } else { n };
        // The axis least aligned with n gives a stable u.
        let a = if n.x.abs() <= n.y.abs() && n.x.abs() <= n.z.abs() {
            DVec3::X
        } else if n.y.abs() <= n.z.abs() {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let u = a.cross(n).normalize();
        let v = n.cross(u);
        Frame { origin, u, v, n }
    }

    /// A frame whose u axis follows `dir` (projected into the plane).
    pub fn with_u(origin: DVec3, n: DVec3, dir: DVec3) -> Frame {
        let f = Frame::new(origin, n);
        let d = dir - f.n * dir.dot(f.n);
        if d.length_squared() == 0.0 {
            return f;
        }
        let u = d.normalize();
        Frame {
            origin,
            u,
            v: f.n.cross(u),
            n: f.n,
        }
    }

    /// The point in the frame's coordinates. Coordinates below 1e-40 in
    /// magnitude (rounding residue of points at the origin) are exactly 0:
    /// the triangulator refuses such tiny values, and they mean nothing.
    pub fn to_2d(&self, p: DVec3) -> DVec2 {
        let d = p - self.origin;
        let flush = |x: f64| if x.abs() < 1e-40 { 0.0 } else { x };
        DVec2::new(flush(d.dot(self.u)), flush(d.dot(self.v)))
    }

    pub fn to_3d(&self, p: DVec2) -> DVec3 {
        self.origin + self.u * p.x + self.v * p.y
    }
}
