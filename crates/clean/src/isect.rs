//! Face intersection (Smith 1991, §2.5).
//!
//! Every pair of faces whose interiors intersect (`ugcheck`'s test: a common
//! point inside one of them — crossing faces, or a wall standing on an uncut
//! floor) is cut along the line where their planes meet: each face is split
//! by that line, across its whole extent, into its parts on either side
//! (polygon booleans, so holes and non-convex faces work; a line that crosses
//! a non-convex face several times cuts it each time). A face whose boundary
//! already runs along the line is left whole. The points where one face's cut
//! meets the other face's boundary are then inserted into the edges they lie
//! on (the grouper's T-vertex step, which also merges corners that the cuts
//! of different faces computed within epsilon of each other), so that the
//! line of intersection becomes edges shared by both faces and no T-vertex
//! is left. Pieces keep their face's material and orientation and are named
//! `NAME.i1`, `NAME.i2`, …
//!
//! Coplanar pairs are left to `ugcopl`.

use crate::pieces::{Rebuild, face_geoms, perimeter, segments};
use check::PairKind;
use geom::intersect::FaceGeom;
use geom::overlap::split_by;
use geom::{DVec2, DVec3};
use ug::{Item, Model};

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub pairs: usize,
    pub faces_cut: usize,
    pub pieces: usize,
    pub new_vertices: usize,
    pub tvertices: usize,
}

/// The line where two planes meet: a point and a unit direction.
fn plane_line(a: &FaceGeom, b: &FaceGeom) -> Option<(DVec3, DVec3)> {
    let (n1, n2) = (a.plane.n, b.plane.n);
    let u = n1.cross(n2);
    let uu = u.length_squared();
    if uu < 1e-24 {
        return None;
    }
    let p0 = (n2.cross(u) * a.plane.d + u.cross(n1) * b.plane.d) / uu;
    Some((p0, u / uu.sqrt()))
}

/// Cuts the intersecting faces of a flat model.
pub fn isect(m: &Model, eps: f64) -> Result<(Model, Stats), ug::Diagnostic> {
    let (faces, geoms) = face_geoms(m);
    let pairs: Vec<(usize, usize)> = check::classify_pairs(&geoms, eps)
        .into_iter()
        .filter(|p| p.2 == PairKind::Intersect)
        .map(|(i, j, _)| (i, j))
        .collect();
    let mut stats = Stats {
        pairs: pairs.len(),
        ..Stats::default()
    };
    if pairs.is_empty() {
        return Ok((m.clone(), stats));
    }
    let mut lines: Vec<Vec<(DVec3, DVec3)>> = vec![Vec::new(); faces.len()];
    for &(i, j) in &pairs {
        let (Some(a), Some(b)) = (geoms[i].as_ref(), geoms[j].as_ref()) else {
            continue;
        };
        if let Some(l) = plane_line(a, b) {
            lines[i].push(l);
            lines[j].push(l);
        }
    }
    let mut order = vec![usize::MAX; m.faces.len()];
    for (k, &f) in faces.iter().enumerate() {
        order[f.idx()] = k;
    }
    let mut rb = Rebuild::new(m, eps);
    for it in &m.items {
        let Item::Face(f) = it else {
            rb.pass(it);
            continue;
        };
        let k = order[f.idx()];
        let face = &m.faces[f.idx()];
        let (Some(g), false) = (geoms[k].as_ref(), lines[k].is_empty()) else {
            rb.face(face.clone());
            continue;
        };
        // Each cutting line as a half-plane polygon covering the face generously.
        let (lo, hi) =
            geom::index::bbox(g.contours_2d.iter().flatten().map(|p| p.extend(0.0)), 0.0);
        let (lo, hi) = (lo.truncate(), hi.truncate());
        let r = 4.0 * (hi - lo).length().max(eps);
        let centre = (lo + hi) / 2.0;
        let mut seen: Vec<(DVec2, DVec2)> = Vec::new();
        let mut halves: Vec<Vec<Vec<DVec2>>> = Vec::new();
        for &(p0, dir) in &lines[k] {
            let (q, d) = (
                g.frame.to_2d(p0),
                DVec2::new(dir.dot(g.frame.u), dir.dot(g.frame.v)),
            );
            let dl = d.length();
            if dl < 1e-12 {
                continue;
            }
            let d = d / dl;
            // Same line as one already used (within eps): skip.
            if seen.iter().any(|(q2, d2)| {
                d.perp_dot(*d2).abs() * r <= eps && (q - *q2).perp_dot(*d2).abs() <= eps
            }) {
                continue;
            }
            seen.push((q, d));
            let n = d.perp();
            // The foot of the centre on the line, then a square on the left of it.
            let base = q + d * (centre - q).dot(d);
            halves.push(vec![vec![
                base - d * r,
                base + d * r,
                base + d * r + n * r,
                base - d * r + n * r,
            ]]);
        }
        let pieces = split_by(&g.contours_2d, &halves, eps * perimeter(&g.contours_2d));
        if pieces.len() <= 1 {
            rb.face(face.clone());
            continue;
        }
        // Exact f64 positions for the points the booleans rounded: on the
        // face's edges and the cutting lines.
        let mut features = segments(&g.contours_2d);
        features.extend(
            seen.iter()
                .map(|&(q, d)| (q - d * 2.0 * r, q + d * 2.0 * r)),
        );
        let tol = 1e-7 * (hi - lo).length().max(eps);
        stats.faces_cut += 1;
        let base = face.name.clone().unwrap_or_else(|| format!("f{}", k + 1));
        stats.pieces += rb.pieces(face, &base, "i", pieces, &g.frame, &features, tol, None);
    }
    stats.new_vertices = rb.new_vertices;
    let opts = crate::group::Options {
        merge_faces: false,
        ..crate::group::Options::new(eps)
    };
    let (out, vst) = crate::group::vlmerge(rb.out, &opts)?;
    stats.tvertices = vst.tvertices;
    Ok((out, stats))
}
