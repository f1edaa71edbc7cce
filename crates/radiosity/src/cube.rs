//! A conservative occlusion cube: from one point, which directions are
//! covered whole by one convex occluder, and how far away that occluder is
//! at most. A point whose direction falls in a covered cell and that lies
//! beyond the occluder's farthest depth over the cell is hidden: the segment
//! from the centre to it crosses the occluder's interior, so the ray caster
//! would say the same, without the ray.
//!
//! Each of the six faces of a cube around the centre is a `res × res` grid
//! of direction cells. An occluder (a convex polygon: a surface's convex
//! outline, or one patch) is clipped to the face's half-space, projected,
//! and marks the cells whose four corner directions all fall inside it
//! (inner-conservative rasterization: a convex cell inside a convex polygon
//! has its corners inside, and conversely). A cell keeps, of the occluders
//! covering it, the one nearest at its farthest corner: the depth of a plane
//! along the directions of a convex cell is largest at one of the corners
//! (it is 1 / (a linear function) there, positive). A cell that only a union
//! of occluders covers (along the edges between two patches) stays open: its
//! points are ray cast as before. So the cube never hides a point the ray
//! caster sees, and its cost follows the occluders drawn, not the model.

use glam::DVec3;

/// The hit must lie this fraction of the segment from its start (the ray
/// caster ignores hits within 1e-7 of a segment's ends).
const NEAR_MARGIN: f64 = 1e-6;

/// Relative margin of the inside test, in projected units.
const INSIDE_MARGIN: f64 = 1e-9;

/// One cell: of the occluders covering it, the one whose farthest depth
/// (along the face's axis) over the cell is least, and that depth;
/// `far` is infinite when none covers it.
#[derive(Clone, Copy)]
struct Cell {
    far: f64,
    occluder: u32,
}

pub(crate) struct OcclusionCube {
    c: DVec3,
    res: usize,
    /// How far beyond an occluder's plane a point must lie to be hidden by
    /// it: the model's coplanar surfaces lie within the epsilon of each
    /// other, so a floor never hides its neighbour.
    margin: f64,
    /// Per occluder, its plane n·x = k, x relative to the centre (k ≠ 0).
    planes: Vec<(DVec3, f64)>,
    /// Six faces of `res × res` cells, row by row.
    faces: Vec<Vec<Cell>>,
}

/// The face's axis (0..3) and sign, its u and v axes.
fn frame(face: usize) -> (usize, f64, usize, usize) {
    let a = face / 2;
    let s = if face.is_multiple_of(2) { 1.0 } else { -1.0 };
    (a, s, (a + 1) % 3, (a + 2) % 3)
}

/// The face a direction falls on (its largest coordinate; ties to the
/// first axis).
fn face_of(d: DVec3) -> usize {
    let m = d.abs();
    let a = if m.x >= m.y && m.x >= m.z {
        0
    } else if m.y >= m.z {
        1
    } else {
        2
    };
    2 * a + usize::from(d[a] < 0.0)
}

/// The plane n·x = k of a polygon, x relative to `c` (Newell's normal, k
/// the mean over the corners); n = 0 for a polygon with fewer than three
/// corners, no area, or whose plane passes (nearly) through the centre: it
/// covers nothing.
fn plane(c: DVec3, poly: &[DVec3]) -> (DVec3, f64) {
    if poly.len() < 3 {
        return (DVec3::ZERO, 0.0);
    }
    let rel: Vec<DVec3> = poly.iter().map(|&p| p - c).collect();
    let mut n = DVec3::ZERO;
    for i in 0..rel.len() {
        n += rel[i].cross(rel[(i + 1) % rel.len()]);
    }
    let n = n.normalize_or_zero();
    let k = rel.iter().map(|&x| n.dot(x)).sum::<f64>() / rel.len() as f64;
    let size = rel.iter().map(|x| x.length()).fold(0.0, f64::max);
    if n == DVec3::ZERO || k.abs() <= 1e-9 * size {
        return (DVec3::ZERO, 0.0);
    }
    (n, k)
}

/// Draws the convex polygon `poly` (plane n·x = k relative to `c`, index
/// `id`) on face `face` of a cube around `c`.
#[allow(clippy::too_many_arguments)]
fn draw(
    c: DVec3,
    res: usize,
    cells: &mut [Cell],
    face: usize,
    poly: &[DVec3],
    n: DVec3,
    k: f64,
    id: u32,
) {
    let rel: Vec<DVec3> = poly.iter().map(|&p| p - c).collect();
    let (a, s, iu, iv) = frame(face);
    // Face coordinates (u, v, z) of the polygon, clipped to z ≥ zmin.
    let pts: Vec<(f64, f64, f64)> = rel.iter().map(|x| (x[iu], x[iv], s * x[a])).collect();
    let zmax = pts.iter().map(|p| p.2).fold(f64::NEG_INFINITY, f64::max);
    if zmax <= 0.0 {
        return;
    }
    let zmin = 1e-6 * zmax;
    let mut clipped: Vec<(f64, f64, f64)> = Vec::with_capacity(pts.len() + 1);
    for i in 0..pts.len() {
        let (p, q) = (pts[i], pts[(i + 1) % pts.len()]);
        if p.2 >= zmin {
            clipped.push(p);
        }
        if (p.2 >= zmin) != (q.2 >= zmin) {
            let t = (zmin - p.2) / (q.2 - p.2);
            clipped.push((p.0 + t * (q.0 - p.0), p.1 + t * (q.1 - p.1), zmin));
        }
    }
    if clipped.len() < 3 {
        return;
    }
    let proj: Vec<(f64, f64)> = clipped.iter().map(|p| (p.0 / p.2, p.1 / p.2)).collect();
    // Orientation and edge functions: inside when every one is ≥ 0.
    let mut area = 0.0;
    for i in 0..proj.len() {
        let (p, q) = (proj[i], proj[(i + 1) % proj.len()]);
        area += p.0 * q.1 - q.0 * p.1;
    }
    if area == 0.0 || !area.is_finite() {
        return;
    }
    let sign = area.signum();
    let edges: Vec<(f64, f64, f64)> = (0..proj.len())
        .filter_map(|i| {
            let (p, q) = (proj[i], proj[(i + 1) % proj.len()]);
            let (ex, ey) = (q.0 - p.0, q.1 - p.1);
            let len = (ex * ex + ey * ey).sqrt();
            if len == 0.0 {
                return None;
            }
            // inside: sign · (ex (y − py) − ey (x − px)) ≥ margin · len
            let (ax, ay) = (-sign * ey, sign * ex);
            let b = -(ax * p.0 + ay * p.1) - INSIDE_MARGIN * len * (1.0 + p.0.abs() + p.1.abs());
            Some((ax, ay, b))
        })
        .collect();
    let to_cell = |x: f64| ((x + 1.0) * 0.5 * res as f64).floor();
    let (mut lo_u, mut hi_u, mut lo_v, mut hi_v) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(u, v) in &proj {
        lo_u = lo_u.min(u);
        hi_u = hi_u.max(u);
        lo_v = lo_v.min(v);
        hi_v = hi_v.max(v);
    }
    let i0 = to_cell(lo_u).max(0.0) as usize;
    let i1 = (to_cell(hi_u) + 1.0).min(res as f64) as usize;
    let j0 = to_cell(lo_v).max(0.0) as usize;
    let j1 = (to_cell(hi_v) + 1.0).min(res as f64) as usize;
    if i0 >= i1 || j0 >= j1 {
        return;
    }
    // Inside flags and depths at the grid corners of the box.
    let w = i1 - i0 + 1;
    let corner = |i: usize| -1.0 + 2.0 * i as f64 / res as f64;
    let mut inside = vec![false; w * (j1 - j0 + 1)];
    let mut depth = vec![0.0f64; w * (j1 - j0 + 1)];
    let mut any = false;
    for j in j0..=j1 {
        let y = corner(j);
        for i in i0..=i1 {
            let x = corner(i);
            let ins = edges.iter().all(|&(ax, ay, b)| ax * x + ay * y + b >= 0.0);
            let idx = (j - j0) * w + (i - i0);
            inside[idx] = ins;
            if ins {
                // Depth along the face axis of the plane n·X = k on the
                // ray X = z (x, y, 1) in face coordinates.
                let mut d = DVec3::ZERO;
                d[iu] = x;
                d[iv] = y;
                d[a] = s;
                let den = n.dot(d);
                let z = if den * k > 0.0 {
                    k / den
                } else {
                    f64::INFINITY
                };
                depth[idx] = z;
                any |= z.is_finite();
            }
        }
    }
    if !any {
        return;
    }
    for j in j0..j1 {
        for i in i0..i1 {
            let ids = [
                (j - j0) * w + (i - i0),
                (j - j0) * w + (i - i0 + 1),
                (j - j0 + 1) * w + (i - i0),
                (j - j0 + 1) * w + (i - i0 + 1),
            ];
            if !ids.iter().all(|&q| inside[q]) {
                continue;
            }
            let far = ids.iter().map(|&q| depth[q]).fold(0.0, f64::max);
            if !far.is_finite() {
                continue;
            }
            let cell = &mut cells[j * res + i];
            if far < cell.far {
                *cell = Cell { far, occluder: id };
            }
        }
    }
}

impl OcclusionCube {
    /// The cube around `c` with the convex polygons `polys` drawn (each
    /// planar within `margin`, at least three corners; `polys[k]` is
    /// `pts[starts[k]..starts[k + 1]]`), the six faces in parallel.
    pub fn build(
        c: DVec3,
        res: usize,
        margin: f64,
        pts: &[DVec3],
        starts: &[usize],
    ) -> OcclusionCube {
        use rayon::prelude::*;
        let res = res.max(1);
        let n_polys = starts.len().saturating_sub(1);
        let planes: Vec<(DVec3, f64)> = (0..n_polys)
            .into_par_iter()
            .map(|k| plane(c, &pts[starts[k]..starts[k + 1]]))
            .collect();
        // The faces each polygon may show on: the one face of all its
        // corners when they agree (a small polygon), else every face some
        // corner lies in front of.
        let masks: Vec<u8> = (0..n_polys)
            .into_par_iter()
            .map(|k| {
                let poly = &pts[starts[k]..starts[k + 1]];
                let faces: Vec<usize> = poly.iter().map(|&p| face_of(p - c)).collect();
                if faces.iter().all(|&f| f == faces[0]) {
                    return 1 << faces[0];
                }
                let mut m = 0u8;
                for f in 0..6 {
                    let (a, s, _, _) = frame(f);
                    if poly.iter().any(|&p| s * (p - c)[a] > 0.0) {
                        m |= 1 << f;
                    }
                }
                m
            })
            .collect();
        let faces = (0..6)
            .into_par_iter()
            .map(|face| {
                let mut cells = vec![
                    Cell {
                        far: f64::INFINITY,
                        occluder: 0,
                    };
                    res * res
                ];
                for (k, &(n, d)) in planes.iter().enumerate() {
                    if n != DVec3::ZERO && masks[k] & (1 << face) != 0 {
                        let poly = &pts[starts[k]..starts[k + 1]];
                        draw(c, res, &mut cells, face, poly, n, d, k as u32);
                    }
                }
                cells
            })
            .collect();
        OcclusionCube {
            c,
            res,
            margin,
            planes,
            faces,
        }
    }

    /// Whether every point of the box [lo, hi] is hidden ([`Self::hides`]):
    /// every cell its projection may touch is covered, and every corner of
    /// the box lies beyond that cell's occluder by the margin (the tests
    /// are linear in the point, so the corners decide for the whole box).
    pub fn hides_box(&self, lo: DVec3, hi: DVec3) -> bool {
        // (Arrays: this runs for every surface in front of every shot.)
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            ) - self.c
        });
        let res = self.res as f64;
        for face in 0..6 {
            let (a, s, iu, iv) = frame(face);
            let z: [f64; 8] = corners.map(|d| s * d[a]);
            // No point of the box in this face's pyramid (z ≥ |u|, z ≥ |v|,
            // each two linear conditions, all false at every corner of the
            // box for one of them): its directions are on other faces.
            let outside = [(iu, 1.0), (iu, -1.0), (iv, 1.0), (iv, -1.0)]
                .iter()
                .any(|&(i, sg)| corners.iter().zip(&z).all(|(d, &z)| z - sg * d[i] < 0.0));
            if outside || z.iter().all(|&z| z <= 0.0) {
                continue;
            }
            // The cells the box may show in: its corners' projected box, or
            // the whole face when a corner lies behind the face's plane.
            let (mut i0, mut i1, mut j0, mut j1) = (0, self.res - 1, 0, self.res - 1);
            if z.iter().all(|&z| z > 0.0) {
                let cell =
                    |x: f64| (((x + 1.0) * 0.5 * res).floor()).clamp(0.0, res - 1.0) as usize;
                let us = corners.iter().zip(&z).map(|(d, &z)| d[iu] / z);
                let vs = corners.iter().zip(&z).map(|(d, &z)| d[iv] / z);
                let (ulo, uhi) = us.fold((f64::MAX, f64::MIN), |(l, h), u| (l.min(u), h.max(u)));
                let (vlo, vhi) = vs.fold((f64::MAX, f64::MIN), |(l, h), v| (l.min(v), h.max(v)));
                if ulo > 1.0 || uhi < -1.0 || vlo > 1.0 || vhi < -1.0 {
                    continue;
                }
                (i0, i1, j0, j1) = (cell(ulo), cell(uhi), cell(vlo), cell(vhi));
            }
            let mut last = u32::MAX;
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let cell = self.faces[face][j * self.res + i];
                    if !cell.far.is_finite() {
                        return false;
                    }
                    if cell.occluder == last {
                        continue;
                    }
                    if !corners.iter().all(|&d| self.beyond(cell.occluder, d)) {
                        return false;
                    }
                    last = cell.occluder;
                }
            }
        }
        true
    }

    /// Whether the segment from the centre to `p` surely crosses an
    /// occluder drawn: its direction falls in a cell the occluder covers,
    /// and `p` lies beyond the occluder's plane by more than the margin
    /// (and the crossing is not within 1e-6 of the segment's start).
    pub fn hides(&self, p: DVec3) -> bool {
        let d = p - self.c;
        let face = face_of(d);
        let (a, _, iu, iv) = frame(face);
        let z = d[a].abs();
        if z <= 0.0 || !z.is_finite() {
            return false;
        }
        let res = self.res as f64;
        let cell = |x: f64| (((x / z + 1.0) * 0.5 * res).floor()).clamp(0.0, res - 1.0) as usize;
        let (i, j) = (cell(d[iu]), cell(d[iv]));
        let cell = self.faces[face][j * self.res + i];
        if !cell.far.is_finite() {
            return false;
        }
        self.beyond(cell.occluder, d)
    }

    /// Whether the point at `d` from the centre lies beyond occluder `occ`'s
    /// plane by the margin, the segment to it meeting the plane at
    /// t = k / h beyond its start.
    fn beyond(&self, occ: u32, d: DVec3) -> bool {
        let (n, k) = self.planes[occ as usize];
        let h = n.dot(d);
        h * k > 0.0 && (h.abs() - k.abs()) > self.margin && k / h > NEAR_MARGIN
    }

    /// The fraction of cells covered (for statistics and tests).
    #[cfg(test)]
    pub fn covered(&self) -> f64 {
        let n = self
            .faces
            .iter()
            .flatten()
            .filter(|c| c.far.is_finite())
            .count();
        n as f64 / (6 * self.res * self.res) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square far wall seen from the origin: points behind it hidden,
    /// points in front of it, beside it or behind the centre not.
    #[test]
    fn a_wall_hides_what_lies_behind_it() {
        let wall = [
            DVec3::new(2.0, -1.0, -1.0),
            DVec3::new(2.0, 1.0, -1.0),
            DVec3::new(2.0, 1.0, 1.0),
            DVec3::new(2.0, -1.0, 1.0),
        ];
        let cube = OcclusionCube::build(DVec3::ZERO, 64, 1e-9, &wall, &[0, 4]);
        assert!(cube.covered() > 0.035); // a quarter of one face: 1/24
        assert!(cube.hides(DVec3::new(3.0, 0.1, 0.2)));
        assert!(cube.hides(DVec3::new(10.0, 3.0, -3.0)));
        assert!(!cube.hides(DVec3::new(1.9, 0.1, 0.2)));
        assert!(!cube.hides(DVec3::new(2.0, 0.1, 0.2)));
        assert!(!cube.hides(DVec3::new(3.0, 2.0, 0.0)));
        assert!(!cube.hides(DVec3::new(-3.0, 0.0, 0.0)));
        // A box wholly behind the wall, one reaching past its edge, one
        // straddling its plane, one behind the centre.
        assert!(cube.hides_box(DVec3::new(3.0, -0.5, -0.5), DVec3::new(4.0, 0.5, 0.5)));
        assert!(!cube.hides_box(DVec3::new(3.0, -0.5, -0.5), DVec3::new(4.0, 2.5, 0.5)));
        assert!(!cube.hides_box(DVec3::new(1.5, -0.2, -0.2), DVec3::new(3.0, 0.2, 0.2)));
        assert!(!cube.hides_box(DVec3::new(-4.0, -0.5, -0.5), DVec3::new(-3.0, 0.5, 0.5)));
    }

    /// Against exact segment–polygon tests: random convex occluders around
    /// random centres, random points; the cube never hides a point whose
    /// segment misses every occluder, and hides most of those well behind one.
    #[test]
    fn never_hides_a_visible_point() {
        let mut state = 0x9e3779b97f4a7c15u64;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut hidden, mut behind) = (0, 0);
        for _ in 0..40 {
            let c = DVec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0;
            let mut polys = Vec::new();
            for _ in 0..6 {
                // A random triangle or parallelogram.
                let o = DVec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0;
                let e1 = DVec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0;
                let e2 = DVec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0;
                let poly = if rnd() < 0.5 {
                    vec![o, o + e1, o + e2]
                } else {
                    vec![o, o + e1, o + e1 + e2, o + e2]
                };
                polys.push(poly);
            }
            let mut starts = vec![0];
            for poly in &polys {
                starts.push(starts.last().unwrap() + poly.len());
            }
            let pts: Vec<DVec3> = polys.iter().flatten().copied().collect();
            let cube = OcclusionCube::build(c, 32, 1e-9, &pts, &starts);
            for _ in 0..2000 {
                let p = DVec3::new(rnd(), rnd(), rnd()) * 16.0 - 8.0;
                let crosses = polys.iter().any(|poly| {
                    let tri = |a: DVec3, b: DVec3, q: DVec3| {
                        let t = geom::bvh::Triangle {
                            p: [a, b, q],
                            id: 0,
                        };
                        geom::bvh::ray_triangle(c, p - c, &t)
                            .is_some_and(|t| t > 1e-7 && t < 1.0 - 1e-7)
                    };
                    (1..poly.len() - 1).any(|k| tri(poly[0], poly[k], poly[k + 1]))
                });
                if cube.hides(p) {
                    hidden += 1;
                    assert!(crosses, "{p} hidden from {c} but its segment is clear");
                }
                // A small box around the point: hidden whole only if the
                // point is.
                let r = DVec3::splat(0.05);
                if cube.hides_box(p - r, p + r) {
                    assert!(cube.hides(p), "a box around {p} hidden, not the point");
                    assert!(
                        crosses,
                        "a box around {p} hidden from {c}, its segment clear"
                    );
                }
                behind += usize::from(crosses);
            }
        }
        assert!(
            hidden * 2 > behind,
            "{hidden} hidden of {behind} behind an occluder"
        );
    }
}
