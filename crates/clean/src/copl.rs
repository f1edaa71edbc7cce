//! Coplanar face intersection (Smith 1991, §2.5).
//!
//! Faces that are coplanar (within epsilon, either orientation) and partly
//! overlap are cut in their plane so that every overlap region becomes a
//! face of its own in each face it belongs to. A face overlapped by faces
//! G₁…Gₖ is divided by all their contours at once: its contours (tag 0) and
//! theirs (tags 1…k) go into a snap-rounded arrangement ([`geom::arrange`]),
//! and each face of the arrangement inside it is a piece, labelled with the
//! set of Gᵢ that cover it (even-odd, decided topologically). The same
//! region comes out as a piece of every face it belongs to, on the same
//! vertices, so `ugclean` can drop one of each coincident pair.
//!
//! Piece corners within epsilon of an existing vertex reuse it; new corners
//! (crossings of the faces' edges) are shared between all faces that find
//! them. Each piece keeps its face's material and orientation, is named
//! `NAME.c1`, `NAME.c2`, …, and is preceded by the origin annotation
//! `{ugcopl origin NAME area A}` (A is the area of the original face's
//! connected coplanar surface of its material), which `ugclean` reads to
//! remove the piece of the larger surface. Finally vertices within epsilon
//! are merged and the points where the cuts meet neighbouring faces' edges
//! are inserted into those edges, so no T-vertex is left.

use check::PairKind;
use geom::arrange::Tag;
use rayon::prelude::*;
use ug::{Item, Model};
use winged::pieces::{Layout, Point};

use crate::pieces::{Rebuild, face_geoms};

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
    let pairs: Vec<(usize, usize)> = check::coplanar_pairs(&geoms, eps)
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
    let pos = |v: ug::VertexId| m.vertices[v.idx()].pos;
    let work: Vec<usize> = (0..faces.len())
        .filter(|&k| !others[k].is_empty())
        .collect();
    let results: Vec<(usize, Vec<Vec<Vec<Point>>>)> = work
        .par_iter()
        .filter_map(|&k| {
            let g = geoms[k].as_ref()?;
            let mut layout = Layout::new(g.frame);
            layout.contours(&m.faces[faces[k].idx()].contours, Tag::Toggle(0), pos);
            // A neighbour much bigger than this face (a storey's floor
            // with hundreds of holes under a rug) is clipped to a box around
            // this face first: only its part there can cut it.
            let (lo, hi) = geom::index::bbox(
                g.contours_2d.iter().flatten().map(|p| p.extend(0.0)),
                4.0 * eps,
            );
            let (lo, hi) = (lo.truncate(), hi.truncate());
            for (t, &j) in others[k].iter().enumerate() {
                let tag = Tag::Toggle(t as u32 + 1);
                let cs = &m.faces[faces[j].idx()].contours;
                for c in cs {
                    let ring: Vec<(geom::DVec2, Option<ug::VertexId>)> = c
                        .iter()
                        .map(|&v| (g.frame.to_2d(pos(v)), Some(v)))
                        .collect();
                    if ring
                        .iter()
                        .all(|p| p.0.cmpge(lo).all() && p.0.cmple(hi).all())
                    {
                        layout.contours(std::slice::from_ref(c), tag, pos);
                    } else {
                        layout.ring(&winged::pieces::clip_ring(&ring, lo, hi), tag);
                    }
                }
            }
            let arr = layout.arrange(eps, false);
            let pieces: Vec<Vec<Vec<Point>>> = arr
                .faces
                .iter()
                .filter(|f| f.has(0))
                .map(|f| layout.loops(&arr, f))
                .collect();
            Some((k, pieces))
        })
        .collect();
    let mut cut_of: Vec<Option<usize>> = vec![None; faces.len()];
    for (r, (k, _)) in results.iter().enumerate() {
        cut_of[*k] = Some(r);
    }
    // Found only when a face is cut (for the origin surfaces' areas).
    let surfaces = std::cell::OnceCell::new();
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
        let Some(r) = cut_of.get(k).copied().flatten() else {
            rb.face(face.clone());
            continue;
        };
        let pieces = &results[r].1;
        let base = face.name.clone().unwrap_or_else(|| format!("f{}", k + 1));
        if pieces.len() <= 1 {
            // Overlapped only along its boundary within epsilon: the face
            // keeps its shape (it may gain vertices).
            if pieces.is_empty() {
                rb.face(face.clone());
            } else {
                rb.pieces(face, &base, "c", pieces, None);
            }
            continue;
        }
        stats.faces_cut += 1;
        let note = format!(
            "ugcopl origin {base} area {}",
            surfaces.get_or_init(|| {
                crate::coincident::surface_areas(&winged::Mesh::from_model(m.clone()), eps)
            })[f.idx()]
        );
        stats.pieces += rb.pieces(face, &base, "c", pieces, Some(&note));
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
