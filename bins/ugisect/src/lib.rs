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

use geom::intersect::FaceGeom;
use geom::overlap::split_by;
use geom::{DVec2, DVec3};
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Face, FaceId, Item, Model, Vertex, VertexId};
use ugcheck::PairKind;

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
    let faces: Vec<FaceId> = m.top_faces().collect();
    let points3 = |f: FaceId| -> Vec<Vec<DVec3>> {
        m.faces[f.idx()]
            .contours
            .iter()
            .map(|c| c.iter().map(|&v| m.pos(v)).collect())
            .collect()
    };
    let geoms: Vec<Option<FaceGeom>> = faces.iter().map(|&f| FaceGeom::new(points3(f))).collect();
    let pairs: Vec<(usize, usize)> = ugcheck::classify_pairs(&geoms, eps)
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
    let mut out = m.clone();
    out.items.clear();
    out.faces.clear();
    let cell = (2.0 * eps).max(f64::MIN_POSITIVE);
    let key = |p: DVec3| {
        let k = (p / cell).floor();
        (k.x as i64, k.y as i64, k.z as i64)
    };
    let mut grid: FxHashMap<(i64, i64, i64), Vec<VertexId>> = FxHashMap::default();
    for (k, v) in m.vertices.iter().enumerate() {
        grid.entry(key(v.pos)).or_default().push(VertexId(k as u32));
    }
    let mut names: FxHashSet<String> = m.faces.iter().filter_map(|f| f.name.clone()).collect();
    let mut vnames: FxHashSet<String> = m.vertices.iter().map(|v| v.name.clone()).collect();
    let mut emitted = m.vertices.len();
    let mut order = vec![usize::MAX; m.faces.len()];
    for (k, &f) in faces.iter().enumerate() {
        order[f.idx()] = k;
    }
    for it in &m.items {
        let Item::Face(f) = it else {
            out.items.push(it.clone());
            continue;
        };
        let k = order[f.idx()];
        let face = &m.faces[f.idx()];
        let push = |out: &mut Model, face: Face| {
            let id = FaceId(out.faces.len() as u32);
            out.faces.push(face);
            out.items.push(Item::Face(id));
        };
        let (Some(g), false) = (geoms[k].as_ref(), lines[k].is_empty()) else {
            push(&mut out, face.clone());
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
        let perim: f64 = g
            .contours_2d
            .iter()
            .map(|c| {
                (0..c.len())
                    .map(|i| (c[(i + 1) % c.len()] - c[i]).length())
                    .sum::<f64>()
            })
            .sum();
        let pieces = split_by(&g.contours_2d, &halves, eps * perim);
        // Exact f64 positions for the points the booleans rounded: on the
        // face's edges and the cutting lines.
        let mut features: Vec<(DVec2, DVec2)> = g
            .contours_2d
            .iter()
            .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
            .collect();
        features.extend(
            seen.iter()
                .map(|&(q, d)| (q - d * 2.0 * r, q + d * 2.0 * r)),
        );
        let tol = 1e-7 * (hi - lo).length().max(eps);
        if pieces.len() <= 1 {
            push(&mut out, face.clone());
            continue;
        }
        stats.faces_cut += 1;
        let base = face.name.clone().unwrap_or_else(|| format!("f{}", k + 1));
        let mut nv = 0usize;
        let mut piece_no = 0usize;
        for piece in pieces {
            let mut contours: Vec<Vec<VertexId>> = Vec::new();
            for ring in piece {
                let mut c: Vec<VertexId> = Vec::with_capacity(ring.len());
                for p2 in ring {
                    let p = g
                        .frame
                        .to_3d(geom::overlap::refine_point(p2, &features, tol));
                    let (x, y, z) = key(p);
                    let mut found: Option<(f64, VertexId)> = None;
                    for dx in -1..=1 {
                        for dy in -1..=1 {
                            for dz in -1..=1 {
                                for &v in grid.get(&(x + dx, y + dy, z + dz)).into_iter().flatten()
                                {
                                    let dd = (out.vertices[v.idx()].pos - p).length();
                                    if dd <= eps
                                        && found.is_none_or(|(b, w)| dd < b || (dd == b && v < w))
                                    {
                                        found = Some((dd, v));
                                    }
                                }
                            }
                        }
                    }
                    let v = match found {
                        Some((_, v)) => v,
                        None => {
                            nv += 1;
                            let mut name = format!("{base}.y{nv}");
                            while vnames.contains(&name) {
                                nv += 1;
                                name = format!("{base}.y{nv}");
                            }
                            vnames.insert(name.clone());
                            let id = VertexId(out.vertices.len() as u32);
                            out.vertices.push(Vertex {
                                name,
                                pos: p,
                                color: None,
                            });
                            grid.entry(key(p)).or_default().push(id);
                            stats.new_vertices += 1;
                            id
                        }
                    };
                    if c.last() != Some(&v) {
                        c.push(v);
                    }
                }
                while c.len() > 1 && c.first() == c.last() {
                    c.pop();
                }
                if c.len() >= 3 {
                    contours.push(c);
                }
            }
            if contours.is_empty() {
                continue;
            }
            for v in emitted..out.vertices.len() {
                out.items.push(Item::Vertex(VertexId(v as u32)));
            }
            emitted = out.vertices.len();
            let name = face.name.as_ref().map(|_| {
                loop {
                    piece_no += 1;
                    let cand = format!("{base}.i{piece_no}");
                    if names.insert(cand.clone()) {
                        break cand;
                    }
                }
            });
            push(
                &mut out,
                Face {
                    name,
                    contours,
                    material: face.material,
                },
            );
            stats.pieces += 1;
        }
    }
    let opts = ugvlmerge::Options {
        merge_faces: false,
        ..ugvlmerge::Options::new(eps)
    };
    let (out, vst) = ugvlmerge::vlmerge(out, &opts)?;
    stats.tvertices = vst.tvertices;
    Ok((out, stats))
}
