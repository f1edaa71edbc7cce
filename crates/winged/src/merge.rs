//! Merging two faces across their shared edges (the grouper, §2.4).
//!
//! 1. Collect the directed half-edges of both faces' contours (`b` reversed
//!    when most shared edges are walked the same way by both).
//! 2. Cancel pairs of an `a` half-edge and a `b` half-edge walking the same
//!    edge in opposite directions.
//! 3. At each vertex, pair every incoming half-edge with an outgoing one,
//!    turning as far left as possible in the projection on `a`'s plane
//!    (so traced contours never cross; exact U-turns come last).
//! 4. Follow the pairing into closed loops, split loops where they visit a
//!    vertex twice, drop loops without three distinct vertices.
//! 5. The loop with the largest area wound like `a`'s outer contour is the
//!    outer contour; the others are holes and islands.

use geom::newell_normal;
use glam::DVec3;
use rustc_hash::FxHashMap;
use ug::{FaceId, VertexId};

use crate::mesh::Mesh;
use crate::trace::{HalfEdge, outer_first, trace_loops};
use crate::{EdgeId, MergeError};

#[derive(Clone, Copy, Debug)]
struct Half {
    from: VertexId,
    to: VertexId,
    /// (0 for a / 1 for b, contour, index): the deterministic order of half-edges.
    key: (u8, u32, u32),
    edge: EdgeId,
}

pub(crate) fn merge(mesh: &mut Mesh, a: FaceId, b: FaceId) -> Result<FaceId, MergeError> {
    if a == b {
        return Err(MergeError::SameFace);
    }
    for f in [a, b] {
        if !mesh.is_face_live(f) {
            return Err(MergeError::DeadFace(f));
        }
    }

    // 1. Half-edges, in key order.
    let mut halves: Vec<Half> = Vec::new();
    for (src, f) in [(0u8, a), (1u8, b)] {
        let face = &mesh.model.faces[f.idx()];
        for (ci, c) in face.contours.iter().enumerate() {
            let n = c.len();
            for i in 0..n {
                halves.push(Half {
                    from: c[i],
                    to: c[(i + 1) % n],
                    key: (src, ci as u32, i as u32),
                    edge: mesh.contour_edges[f.idx()][ci][i],
                });
            }
        }
    }
    let edges_of = |f: FaceId| {
        let mut es = mesh.face_edges(f);
        es.sort_unstable();
        es.dedup();
        es
    };
    let (ea, eb) = (edges_of(a), edges_of(b));
    let shared: Vec<EdgeId> = ea
        .iter()
        .copied()
        .filter(|e| eb.binary_search(e).is_ok())
        .collect();
    if shared.is_empty() {
        return Err(MergeError::NotAdjacent);
    }
    let (mut same, mut opposite) = (0usize, 0usize);
    for &e in &shared {
        let uses = &mesh.edge(e).uses;
        for ua in uses.iter().filter(|u| u.face == a) {
            for ub in uses.iter().filter(|u| u.face == b) {
                if ua.forward == ub.forward {
                    same += 1;
                } else {
                    opposite += 1;
                }
            }
        }
    }
    if same > opposite {
        for h in halves.iter_mut().filter(|h| h.key.0 == 1) {
            std::mem::swap(&mut h.from, &mut h.to);
        }
    }

    // 2. Cancel opposite a/b pairs on shared edges.
    let mut dead = vec![false; halves.len()];
    let mut by_edge: FxHashMap<EdgeId, Vec<usize>> = FxHashMap::default(); // lookup only
    for (i, h) in halves.iter().enumerate() {
        if shared.binary_search(&h.edge).is_ok() {
            by_edge.entry(h.edge).or_default().push(i);
        }
    }
    let mut cancelled = 0usize;
    for e in &shared {
        let Some(list) = by_edge.get(e) else { continue };
        // Four classes: (face, walks v0 → v1); `list` is in key order.
        let class = |src: u8, fwd: bool| -> Vec<usize> {
            list.iter()
                .copied()
                .filter(|&i| halves[i].key.0 == src && (halves[i].from < halves[i].to) == fwd)
                .collect()
        };
        for fwd in [true, false] {
            let (xa, xb) = (class(0, fwd), class(1, !fwd));
            for (&i, &j) in xa.iter().zip(&xb) {
                dead[i] = true;
                dead[j] = true;
                cancelled += 1;
            }
        }
    }
    if cancelled == 0 {
        return Err(MergeError::NotAdjacent);
    }

    // The plane: a's outer contour, else everything, else z.
    let pos = |v: VertexId| mesh.pos(v);
    let contour_normal = |f: FaceId, c: usize| {
        let pts: Vec<DVec3> = mesh.model.faces[f.idx()].contours[c]
            .iter()
            .map(|&v| pos(v))
            .collect();
        newell_normal(&pts)
    };
    let mut n = contour_normal(a, 0);
    if !(n.length() > 0.0 && n.is_finite()) {
        n = (0..mesh.model.faces[a.idx()].contours.len())
            .map(|c| contour_normal(a, c))
            .sum();
    }
    let n = if n.length() > 0.0 && n.is_finite() {
        n.normalize()
    } else {
        DVec3::Z
    };

    // 3–5. Trace the remaining half-edges into contours, outer first.
    let live: Vec<HalfEdge> = halves
        .iter()
        .enumerate()
        .filter(|&(i, _)| !dead[i])
        .map(|(_, h)| HalfEdge {
            from: h.from,
            to: h.to,
            key: (h.key.0 as u32, h.key.1, h.key.2),
        })
        .collect();
    let loops = trace_loops(&live, &pos, n).ok_or(MergeError::Degenerate)?;
    if loops.is_empty() {
        return Err(MergeError::Degenerate);
    }
    let result = outer_first(loops, &pos, n, true).ok_or(MergeError::Degenerate)?;

    // Apply.
    mesh.detach(a);
    mesh.detach(b);
    mesh.kill_face(b);
    mesh.model.faces[a.idx()].contours = result;
    mesh.attach(a);
    mesh.finish();
    Ok(a)
}
