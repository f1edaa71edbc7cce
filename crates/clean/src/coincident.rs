//! Coincident face removal (Smith 1991, §2.6).
//!
//! Two faces are coincident when they are coplanar, cover the same region
//! and face the same way (`ugcheck`'s definition, coplanar meaning within
//! [`geom::intersect::CLEAN_COPLANAR_EPSILONS`] as in `ugcopl`; faces back to back — the
//! two sides of a zero-thickness wall — are not). Of every coincident pair
//! one face is removed:
//!
//! * same material: the later one in the file;
//! * different materials: the piece that came from the larger original
//!   surface (the floor under the rug, the desk under the paper), so that
//!   what lies on top stays visible. The original surface's area is read from
//!   an origin annotation — a comment `{ugcopl origin NAME area A}` just
//!   before the face, which `ugcopl` writes for the pieces it cuts — and
//!   otherwise measured: the area of the face's surface, the faces connected
//!   to it through shared edges that are coplanar with it, of its material
//!   and facing its way. Equal areas remove the later face.
//!
//! Vertices that only removed faces used are removed too.

use check::PairKind;
use geom::DVec3;
use ug::{FaceId, Item, Model};
use winged::Mesh;

/// What was removed and why.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    pub pairs: usize,
    /// (removed face, kept face, reason)
    pub removed: Vec<(String, String, String)>,
    pub area_removed: f64,
}

fn label(m: &Model, k: usize, f: FaceId) -> String {
    m.faces[f.idx()]
        .name
        .clone()
        .unwrap_or_else(|| format!("#{}", k + 1))
}

/// The origin annotations: face → original surface area.
fn origins(m: &Model) -> Vec<Option<f64>> {
    let mut out = vec![None; m.faces.len()];
    let mut pending: Option<f64> = None;
    for it in &m.items {
        match it {
            Item::Comment(c) => {
                let w: Vec<&str> = c.split_whitespace().collect();
                pending = match w.as_slice() {
                    ["ugcopl", "origin", _, "area", a] => {
                        a.parse::<f64>().ok().filter(|x| x.is_finite())
                    }
                    _ => None,
                };
            }
            Item::Face(f) => {
                out[f.idx()] = pending.take();
            }
            _ => pending = None,
        }
    }
    out
}

/// Area of the connected coplanar same-material surface every face belongs
/// to (indexed by face id; 0 for removed faces): faces reached through
/// shared edges with the same material and orientation and all vertices
/// within `eps` of the plane of the surface's first face (in statement
/// order), found once for the whole model.
pub fn surface_areas(mesh: &Mesh, eps: f64) -> Vec<f64> {
    let n = mesh.model().faces.len();
    let mut group = vec![usize::MAX; n];
    let mut areas: Vec<f64> = Vec::new();
    for f in mesh.faces() {
        if group[f.idx()] != usize::MAX {
            continue;
        }
        let g = areas.len();
        group[f.idx()] = g;
        let mut total = mesh.face_area(f).abs();
        let (Some(plane), mat) = (mesh.face_plane(f), mesh.face(f).material) else {
            areas.push(total);
            continue;
        };
        let same = |h: FaceId| -> bool {
            if mesh.face(h).material != mat {
                return false;
            }
            let Some(ph) = mesh.face_plane(h) else {
                return false;
            };
            ph.n.dot(plane.n) > 0.0
                && mesh
                    .face_points(h)
                    .iter()
                    .flatten()
                    .all(|&p| plane.dist(p).abs() <= eps)
        };
        let mut stack = vec![f];
        while let Some(x) = stack.pop() {
            for h in mesh.face_neighbors(x) {
                if group[h.idx()] == usize::MAX && same(h) {
                    group[h.idx()] = g;
                    total += mesh.face_area(h).abs();
                    stack.push(h);
                }
            }
        }
        areas.push(total);
    }
    (0..n)
        .map(|i| areas.get(group[i]).copied().unwrap_or(0.0))
        .collect()
}

/// Removes one face of every coincident pair of a flat model.
pub fn clean(m: &Model, eps: f64) -> (Model, Stats) {
    let (faces, geoms) = check::face_geoms(m);
    let points = |f: FaceId| -> Vec<Vec<DVec3>> {
        m.faces[f.idx()]
            .contours
            .iter()
            .map(|c| c.iter().map(|&v| m.pos(v)).collect())
            .collect()
    };
    let pairs: Vec<(usize, usize)> =
        check::coplanar_pairs(&geoms, eps, geom::intersect::CLEAN_COPLANAR_EPSILONS)
            .into_iter()
            .filter(|p| p.2 == PairKind::Coincident)
            .map(|(i, j, _)| (i, j))
            .collect();
    let mut stats = Stats {
        pairs: pairs.len(),
        ..Stats::default()
    };
    if pairs.is_empty() {
        return (m.clone(), stats);
    }
    let origin = origins(m);
    let mesh = Mesh::from_model(m.clone());
    let surfaces = std::cell::OnceCell::new();
    let mut removed = vec![false; m.faces.len()];
    for (i, j) in pairs {
        let (a, b) = (faces[i], faces[j]);
        if removed[a.idx()] || removed[b.idx()] {
            continue;
        }
        let (ma, mb) = (m.faces[a.idx()].material, m.faces[b.idx()].material);
        let (loser, winner, reason) = if ma == mb {
            (j, i, "same material: the later face goes".to_string())
        } else {
            let area = |_: usize, f: FaceId| {
                origin[f.idx()]
                    .unwrap_or_else(|| surfaces.get_or_init(|| surface_areas(&mesh, eps))[f.idx()])
            };
            let (sa, sb) = (area(i, a), area(j, b));
            if sa > sb {
                (i, j, format!("its surface is larger ({sa} > {sb})"))
            } else {
                (
                    j,
                    i,
                    format!("its surface is larger or as large ({sb} ≥ {sa})"),
                )
            }
        };
        let lf = faces[loser];
        removed[lf.idx()] = true;
        stats.area_removed += geom::face_area(&points(lf)).abs();
        stats
            .removed
            .push((label(m, loser, lf), label(m, winner, faces[winner]), reason));
    }
    (remove_faces(m, &removed), stats)
}

/// The model without the faces marked in `removed` (indexed by `FaceId`),
/// the vertices that only they used, and their `ugcopl origin` annotations.
pub fn remove_faces(m: &Model, removed: &[bool]) -> Model {
    let faces: Vec<FaceId> = m.top_faces().collect();
    // Vertices still used by a face or wire.
    let mut used = vec![false; m.vertices.len()];
    let mut was_used = vec![false; m.vertices.len()];
    for &f in &faces {
        for &v in m.faces[f.idx()].contours.iter().flatten() {
            was_used[v.idx()] = true;
            if !removed[f.idx()] {
                used[v.idx()] = true;
            }
        }
    }
    for w in &m.wires {
        for &v in w.polylines.iter().flatten() {
            used[v.idx()] = true;
        }
    }
    let mut out = m.clone();
    out.items.retain(|it| match it {
        Item::Face(f) => !removed[f.idx()],
        Item::Vertex(v) => used[v.idx()] || !was_used[v.idx()],
        _ => true,
    });
    // Origin annotations of removed faces go too.
    let keep: Vec<bool> = out
        .items
        .iter()
        .enumerate()
        .map(|(k, it)| match it {
            Item::Comment(c) if c.trim_start().starts_with("ugcopl origin") => {
                matches!(out.items.get(k + 1), Some(Item::Face(_)))
            }
            _ => true,
        })
        .collect();
    let mut k = 0;
    out.items.retain(|_| {
        k += 1;
        keep[k - 1]
    });
    out
}
