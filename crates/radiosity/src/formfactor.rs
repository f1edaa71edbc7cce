//! The exact form factor from a differential receiver to a polygon
//! (Lambert's contour integral; Baum, Rushmeier and Winget 1989), in f64.
//!
//! For a receiver at `x` with unit normal `n` and a polygon p₀…pₖ₋₁:
//!
//! F = 1/(2π) · Σᵢ γᵢ · n · (Rᵢ × Rᵢ₊₁)/|Rᵢ × Rᵢ₊₁|,  Rᵢ = pᵢ − x,
//!
//! where γᵢ is the angle between Rᵢ and Rᵢ₊₁. The polygon is first clipped
//! to the receiver's front half-space (only what lies above the receiver's
//! horizon is seen). The sign follows the polygon's winding as seen from `x`;
//! the absolute value is returned.

use glam::DVec3;

/// Whether a receiver at `x` (unit normal `n`) can take light from a
/// shooter centred at `c` whose plane has unit normal `m`: the receiver in
/// front of the shooter's plane (or within the §5.4 offset `delta` behind
/// it) and the shooter's centre in front of the receiver.
#[inline]
pub fn receives(x: DVec3, n: DVec3, c: DVec3, m: DVec3, delta: f64) -> bool {
    m.dot(x - c) > -delta && n.dot(c - x) > 0.0
}

/// §5.4: the point at which a receiver at `x` takes the form factor of a
/// shooter centred at `c` (plane normal `m`, offset `delta`). A receiver on
/// (or just behind) the shooter's plane is moved a little in front of it —
/// and first a little into its own surface (`inward()`, asked only then), so
/// that at a corner where several shooters meet it takes the limit from
/// inside the receiving surface (moving it off one plane only would leave
/// it on the other). The same nudged point serves every shooter, so the
/// pieces of the hemisphere that neighbouring shooters share add up.
#[inline]
pub fn offset_receiver(
    x: DVec3,
    inward: impl FnOnce() -> DVec3,
    c: DVec3,
    m: DVec3,
    delta: f64,
) -> DVec3 {
    let mut x = x;
    if m.dot(x - c) < delta {
        x += inward() * delta;
        let d = m.dot(x - c);
        if d < 0.01 * delta {
            x += m * (0.01 * delta - d);
        }
    }
    x
}

/// Clips a polygon to the half-space `n · (p − x) ≥ 0` (Sutherland–Hodgman).
pub fn clip_to_front(poly: &[DVec3], x: DVec3, n: DVec3, out: &mut Vec<DVec3>) {
    out.clear();
    let k = poly.len();
    if k == 0 {
        return;
    }
    for i in 0..k {
        let a = poly[i];
        let b = poly[(i + 1) % k];
        let (da, db) = (n.dot(a - x), n.dot(b - x));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out.push(a + (b - a) * t);
        }
    }
}

/// Form factor from the point `x` (unit normal `n`) to the polygon, the
/// polygon being clipped to the point's front half-space first.
pub fn point_to_polygon(x: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    let mut clipped = Vec::with_capacity(poly.len() + 2);
    clip_to_front(poly, x, n, &mut clipped);
    contour_integral(x, n, &clipped)
}

/// The contour integral itself, without clipping (the polygon must lie in the
/// receiver's front half-space).
pub fn contour_integral(x: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    let k = poly.len();
    if k < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..k {
        let a = poly[i] - x;
        let b = poly[(i + 1) % k] - x;
        let c = a.cross(b);
        let cl = c.length();
        if cl == 0.0 {
            continue; // x on the line of this edge: the term vanishes (γ = 0) or x is on it
        }
        let gamma = cl.atan2(a.dot(b));
        sum += gamma * n.dot(c) / cl;
    }
    (sum / (2.0 * std::f64::consts::PI)).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64) -> Vec<DVec3> {
        vec![
            DVec3::new(0., 0., z),
            DVec3::new(1., 0., z),
            DVec3::new(1., 1., z),
            DVec3::new(0., 1., z),
        ]
    }

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    #[test]
    fn parallel_unit_square_at_the_corner() {
        // Howell's catalogue (C-11 with a = b = c = 1): 0.138531605994893.
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &square(1.0));
        assert!(rel(f, 0.138531605994893) < 1e-12, "{f}");
        // Orientation of the polygon does not matter.
        let mut rev = square(1.0);
        rev.reverse();
        assert!(
            rel(
                point_to_polygon(DVec3::ZERO, DVec3::Z, &rev),
                0.138531605994893
            ) < 1e-12
        );
    }

    #[test]
    fn perpendicular_unit_square_at_the_corner() {
        // Receiver at the origin facing +z; a unit square at distance 1 in the
        // perpendicular plane x = 1, 0 ≤ y ≤ 1, 0 ≤ z ≤ 1, its corner opposite
        // the receiver (Howell C-14 with X = Y = 1): 0.0557341970025535.
        let sq = vec![
            DVec3::new(1., 0., 0.),
            DVec3::new(1., 1., 0.),
            DVec3::new(1., 1., 1.),
            DVec3::new(1., 0., 1.),
        ];
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &sq);
        assert!(rel(f, 0.0557341970025535) < 1e-12, "{f}");
    }

    #[test]
    fn coaxial_disk() {
        // A disk of radius 1 at height 1: F = r²/(r² + h²) = 0.5; a 4000-gon
        // inscribed in it has area smaller by the factor sin(2π/n)/(2π/n).
        let n = 4000;
        let poly: Vec<DVec3> = (0..n)
            .map(|k| {
                let t = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
                DVec3::new(t.cos(), t.sin(), 1.0)
            })
            .collect();
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &poly);
        assert!((f - 0.5).abs() < 1e-6, "{f}");
    }

    #[test]
    fn below_the_horizon_is_clipped() {
        // A square straddling the receiver's horizon: only the upper half counts,
        // which is the perpendicular square of the test above, doubled by symmetry.
        let half = vec![
            DVec3::new(1., 0., 0.),
            DVec3::new(1., 1., 0.),
            DVec3::new(1., 1., 1.),
            DVec3::new(1., 0., 1.),
        ];
        let full = vec![
            DVec3::new(1., 0., -1.),
            DVec3::new(1., 1., -1.),
            DVec3::new(1., 1., 1.),
            DVec3::new(1., 0., 1.),
        ];
        let a = point_to_polygon(DVec3::ZERO, DVec3::Z, &half);
        let b = point_to_polygon(DVec3::ZERO, DVec3::Z, &full);
        assert!(
            rel(a, b) < 1e-12 && rel(a, 0.0557341970025535) < 1e-12,
            "{a} {b}"
        );
        // Entirely below: nothing.
        let below: Vec<DVec3> = square(-1.0);
        assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &below), 0.0);
    }

    #[test]
    fn sum_over_a_closed_box_is_one() {
        // A receiver at the centre of the floor of a closed box sees the other
        // five faces; the form factors sum to 1.
        let x = DVec3::new(0.5, 0.5, 0.0);
        let p = |a: f64, b: f64, c: f64| DVec3::new(a, b, c);
        let faces = [
            vec![p(0., 0., 1.), p(1., 0., 1.), p(1., 1., 1.), p(0., 1., 1.)],
            vec![p(0., 0., 0.), p(1., 0., 0.), p(1., 0., 1.), p(0., 0., 1.)],
            vec![p(0., 1., 0.), p(1., 1., 0.), p(1., 1., 1.), p(0., 1., 1.)],
            vec![p(0., 0., 0.), p(0., 1., 0.), p(0., 1., 1.), p(0., 0., 1.)],
            vec![p(1., 0., 0.), p(1., 1., 0.), p(1., 1., 1.), p(1., 0., 1.)],
        ];
        let total: f64 = faces.iter().map(|f| point_to_polygon(x, DVec3::Z, f)).sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
    }
}
