//! Coplanar face intersection (Smith 1991, §2.5).
//!
//! Faces that are coplanar (within epsilon, either orientation) and partly
//! overlap are cut in their plane so that every overlap region becomes a
//! face of its own in each face it belongs to: a face overlapped by faces
//! G₁…Gₖ is split by each in turn into its parts inside and outside
//! (polygon booleans of the `geo` crate, holes and islands respected), so the
//! pieces lying in the same set of faces are the same region in every face,
//! and `ugclean` can then drop one of each coincident pair.
//!
//! Piece corners within epsilon of an existing vertex reuse it; new corners
//! are shared between all faces that need them. Each piece keeps its face's
//! material and orientation, is named `NAME.c1`, `NAME.c2`, …, and is
//! preceded by the origin annotation `{ugcopl origin NAME area A}` (A is the
//! area of the original face's connected coplanar surface of its material),
//! which `ugclean` reads to remove the piece of the larger surface. Finally
//! the points where the cuts meet neighbouring faces' edges are inserted into
//! those edges (the grouper's T-vertex step), so no T-vertex is left.

use check::PairKind;
use geom::DVec2;
use geom::overlap::split_by;
use ug::{Item, Model};

use crate::pieces::{Rebuild, face_geoms, perimeter, segments};

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub pairs: usize,
    pub faces_cut: usize,
    pub pieces: usize,
    pub new_vertices: usize,
    pub tvertices: usize,
}

/// Cuts the coplanar overlapping faces of a flat model.
pub fn copl(m: &Model, eps: f64) -> Result<(Model, Stats), ug::Diagnostic> {
    let (faces, geoms) = face_geoms(m);
    let pairs: Vec<(usize, usize)> = check::classify_pairs(&geoms, eps)
        .into_iter()
        .filter(|p| matches!(p.2, PairKind::Overlap(_)))
        .map(|(i, j, _)| (i, j))
        .collect();
    let mut stats = Stats {
        pairs: pairs.len(),
        ..Stats::default()
    };
    if pairs.is_empty() {
        return Ok((m.clone(), stats));
    }
    let mut others: Vec<Vec<usize>> = vec![Vec::new(); faces.len()];
    for &(i, j) in &pairs {
        others[i].push(j);
        others[j].push(i);
    }
    // Built only when a face is cut (for the origin surface's area).
    let mesh = std::cell::OnceCell::new();
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
        let (Some(g), false) = (geoms[k].as_ref(), others[k].is_empty()) else {
            rb.face(face.clone());
            continue;
        };
        let cutters: Vec<Vec<Vec<DVec2>>> = others[k]
            .iter()
            .filter_map(|&j| geoms[j].as_ref())
            .map(|o| {
                o.contours
                    .iter()
                    .map(|c| c.iter().map(|&p| g.frame.to_2d(p)).collect())
                    .collect()
            })
            .collect();
        let pieces = split_by(&g.contours_2d, &cutters, eps * perimeter(&g.contours_2d));
        if pieces.len() <= 1 {
            rb.face(face.clone());
            continue;
        }
        // Exact f64 positions for the points the booleans rounded: on the
        // face's edges and the other faces' edges.
        let features = segments(g.contours_2d.iter().chain(cutters.iter().flatten()));
        let (lo, hi) =
            geom::index::bbox(g.contours_2d.iter().flatten().map(|p| p.extend(0.0)), 0.0);
        let tol = 1e-7 * (hi - lo).length().max(eps);
        stats.faces_cut += 1;
        let base = face.name.clone().unwrap_or_else(|| format!("f{}", k + 1));
        let note = format!(
            "ugcopl origin {base} area {}",
            crate::coincident::surface_area(
                mesh.get_or_init(|| winged::Mesh::from_model(m.clone())),
                *f,
                eps
            )
        );
        stats.pieces += rb.pieces(
            face,
            &base,
            "c",
            pieces,
            &g.frame,
            &features,
            tol,
            Some(&note),
        );
    }
    stats.new_vertices = rb.new_vertices;
    // Where the cuts meet neighbouring edges: insert the points (no T-vertex).
    let opts = crate::group::Options {
        merge_faces: false,
        ..crate::group::Options::new(eps)
    };
    let (out, vst) = crate::group::vlmerge(rb.out, &opts)?;
    stats.tvertices = vst.tvertices;
    Ok((out, stats))
}
