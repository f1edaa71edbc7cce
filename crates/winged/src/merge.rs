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

use std::collections::BTreeMap;
use std::f64::consts::TAU;

use geom::{Frame, newell_normal};
use glam::{DVec2, DVec3};
use rustc_hash::FxHashMap;
use ug::{FaceId, VertexId};

use crate::mesh::Mesh;
use crate::{EdgeId, MergeError};

#[derive(Clone, Copy, Debug)]
struct Half {
    from: VertexId,
    to: VertexId,
    /// (0 for a / 1 for b, contour, index): the deterministic order of half-edges.
    key: (u8, u32, u32),
    edge: EdgeId,
}

/// Clockwise angle from `r` to `d`, in (0, 2π]; 2π for the same direction.
fn cw_angle(r: DVec2, d: DVec2) -> f64 {
    let cw = -r.perp_dot(d).atan2(r.dot(d));
    if cw <= 0.0 { cw + TAU } else { cw }
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
    let origin = pos(halves[0].from);
    let frame = Frame::new(origin, n);
    let p2 = |v: VertexId| frame.to_2d(pos(v));

    // 3. Pair incoming with outgoing half-edges at each vertex.
    let mut at_vertex: BTreeMap<VertexId, (Vec<usize>, Vec<usize>)> = BTreeMap::new();
    for (i, h) in halves.iter().enumerate() {
        if !dead[i] {
            at_vertex.entry(h.to).or_default().0.push(i);
            at_vertex.entry(h.from).or_default().1.push(i);
        }
    }
    let mut next = vec![usize::MAX; halves.len()];
    for (&v, (incoming, outgoing)) in &at_vertex {
        if incoming.len() != outgoing.len() {
            // Cannot happen for closed contours; refuse rather than corrupt.
            return Err(MergeError::Degenerate);
        }
        if outgoing.len() == 1 {
            next[incoming[0]] = outgoing[0];
            continue;
        }
        let pv = p2(v);
        let mut used = vec![false; outgoing.len()];
        for &hi in incoming {
            let r = p2(halves[hi].from) - pv;
            let mut best: Option<(f64, bool, usize)> = None;
            for (k, &ho) in outgoing.iter().enumerate() {
                if used[k] {
                    continue;
                }
                let d = p2(halves[ho].to) - pv;
                let cand = (cw_angle(r, d), halves[ho].to == halves[hi].from, k);
                let better = match best {
                    None => true,
                    Some(b) => cand
                        .0
                        .total_cmp(&b.0)
                        .then(cand.1.cmp(&b.1))
                        .then(halves[outgoing[cand.2]].key.cmp(&halves[outgoing[b.2]].key))
                        .is_lt(),
                };
                if better {
                    best = Some(cand);
                }
            }
            let k = best.expect("as many outgoing as incoming").2;
            used[k] = true;
            next[hi] = outgoing[k];
        }
    }

    // 4. Trace loops from the first unvisited half-edge, split at repeated vertices.
    let mut visited = vec![false; halves.len()];
    let mut loops: Vec<Vec<usize>> = Vec::new();
    for start in 0..halves.len() {
        if dead[start] || visited[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut h = start;
        while !visited[h] {
            visited[h] = true;
            lp.push(h);
            h = next[h];
        }
        split_loop(&halves, lp, &mut loops);
    }
    for lp in &mut loops {
        let k = (0..lp.len())
            .min_by_key(|&i| halves[lp[i]].key)
            .expect("loops are not empty");
        lp.rotate_left(k);
    }
    loops.retain(|lp| lp.len() >= 3); // vertices are distinct after splitting
    if loops.is_empty() {
        return Err(MergeError::Degenerate);
    }
    loops.sort_by_key(|lp| halves[lp[0]].key);

    // 5. Classify.
    let contours: Vec<Vec<VertexId>> = loops
        .iter()
        .map(|lp| lp.iter().map(|&h| halves[h].from).collect())
        .collect();
    let areas: Vec<f64> = contours
        .iter()
        .map(|c| {
            let pts: Vec<DVec3> = c.iter().map(|&v| pos(v)).collect();
            newell_normal(&pts).dot(n) / 2.0
        })
        .collect();
    let pick = |filter: &dyn Fn(f64) -> bool, measure: &dyn Fn(f64) -> f64| {
        let mut best: Option<usize> = None;
        for (i, &ar) in areas.iter().enumerate() {
            if filter(ar) && best.is_none_or(|b| measure(ar) > measure(areas[b])) {
                best = Some(i);
            }
        }
        best
    };
    let outer = pick(&|ar| ar > 0.0, &|ar| ar)
        .or_else(|| pick(&|_| true, &|ar| ar.abs()))
        .expect("there is a loop");
    let mut result = Vec::with_capacity(contours.len());
    let mut rest = contours;
    result.push(rest.remove(outer));
    result.extend(rest);

    // Apply.
    mesh.detach(a);
    mesh.detach(b);
    mesh.kill_face(b);
    mesh.model.faces[a.idx()].contours = result;
    mesh.attach(a);
    mesh.finish();
    Ok(a)
}

/// Splits a closed loop of half-edges into loops that visit each vertex once.
fn split_loop(halves: &[Half], lp: Vec<usize>, out: &mut Vec<Vec<usize>>) {
    let mut stack: Vec<usize> = Vec::with_capacity(lp.len());
    let mut at: FxHashMap<VertexId, usize> = FxHashMap::default(); // lookup only
    for h in lp {
        let v = halves[h].from;
        if let Some(&p) = at.get(&v) {
            let sub = stack.split_off(p);
            for &x in &sub {
                at.remove(&halves[x].from);
            }
            out.push(sub);
        }
        at.insert(v, stack.len());
        stack.push(h);
    }
    if !stack.is_empty() {
        out.push(stack);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cw_angles() {
        let r = DVec2::new(0.0, -1.0);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(cw_angle(r, DVec2::new(-1.0, 0.0)), TAU / 4.0));
        assert!(close(cw_angle(r, DVec2::new(0.0, 1.0)), TAU / 2.0));
        assert!(close(cw_angle(r, DVec2::new(1.0, 0.0)), 3.0 * TAU / 4.0));
        assert_eq!(cw_angle(r, DVec2::new(0.0, -2.0)), TAU);
    }
}
