//! Tracing the boundary of a union of faces into contours — used by
//! [`Mesh::merge_faces`](crate::Mesh::merge_faces) and by the grouper, which
//! joins whole groups of faces at once.

use std::f64::consts::TAU;

use geom::{Frame, newell_normal};
use glam::{DVec2, DVec3};
use rustc_hash::FxHashMap;
use ug::VertexId;

/// A directed piece of boundary, `from` → `to`, with a key that orders
/// half-edges deterministically (e.g. face, contour, index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HalfEdge {
    pub from: VertexId,
    pub to: VertexId,
    pub key: (u32, u32, u32),
}

/// Clockwise angle from `r` to `d`, in (0, 2π]; 2π for the same direction.
fn cw_angle(r: DVec2, d: DVec2) -> f64 {
    let cw = -r.perp_dot(d).atan2(r.dot(d));
    if cw <= 0.0 { cw + TAU } else { cw }
}

/// Follows half-edges into closed loops. At a vertex with several ways on,
/// each incoming half-edge takes the outgoing one that turns as far left as
/// possible in the plane of normal `n` (so loops never cross; ties by key).
/// Loops that visit a vertex twice are split there, loops of fewer than three
/// vertices dropped; each loop starts at its smallest key and the loops are
/// sorted by it. `None` when the half-edges do not close (a vertex with more
/// ways in than out).
pub fn trace_loops(
    halves: &[HalfEdge],
    pos: &dyn Fn(VertexId) -> DVec3,
    n: DVec3,
) -> Option<Vec<Vec<VertexId>>> {
    let first = halves.first()?;
    let frame = Frame::new(pos(first.from), n);
    let p2 = |v: VertexId| frame.to_2d(pos(v));
    let mut incoming: Vec<(VertexId, usize)> =
        halves.iter().enumerate().map(|(i, h)| (h.to, i)).collect();
    let mut outgoing: Vec<(VertexId, usize)> = halves
        .iter()
        .enumerate()
        .map(|(i, h)| (h.from, i))
        .collect();
    incoming.sort_unstable();
    outgoing.sort_unstable();
    let mut next = vec![usize::MAX; halves.len()];
    let (mut a, mut b) = (0, 0);
    while a < incoming.len() {
        let v = incoming[a].0;
        let a_end = a + incoming[a..].iter().take_while(|x| x.0 == v).count();
        if b >= outgoing.len() || outgoing[b].0 != v {
            return None;
        }
        let b_end = b + outgoing[b..].iter().take_while(|x| x.0 == v).count();
        let (ins, outs) = (&incoming[a..a_end], &outgoing[b..b_end]);
        if ins.len() != outs.len() {
            return None;
        }
        if ins.len() == 1 {
            next[ins[0].1] = outs[0].1;
        } else {
            let pv = p2(v);
            let mut used = vec![false; outs.len()];
            for &(_, hi) in ins {
                let r = p2(halves[hi].from) - pv;
                let mut best: Option<(f64, bool, usize)> = None;
                for (k, &(_, ho)) in outs.iter().enumerate() {
                    if used[k] {
                        continue;
                    }
                    let d = p2(halves[ho].to) - pv;
                    let cand = (cw_angle(r, d), halves[ho].to == halves[hi].from, k);
                    let better = best.is_none_or(|bb| {
                        cand.0
                            .total_cmp(&bb.0)
                            .then(cand.1.cmp(&bb.1))
                            .then(halves[outs[cand.2].1].key.cmp(&halves[outs[bb.2].1].key))
                            .is_lt()
                    });
                    if better {
                        best = Some(cand);
                    }
                }
                let k = best?.2;
                used[k] = true;
                next[hi] = outs[k].1;
            }
        }
        a = a_end;
        b = b_end;
    }
    if b != outgoing.len() {
        return None;
    }
    let mut visited = vec![false; halves.len()];
    let mut loops: Vec<Vec<usize>> = Vec::new();
    for start in 0..halves.len() {
        if visited[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut h = start;
        while !visited[h] {
            visited[h] = true;
            lp.push(h);
            h = next[h];
        }
        split_loop(halves, lp, &mut loops);
    }
    loops.retain(|lp| lp.len() >= 3);
    for lp in &mut loops {
        let k = (0..lp.len()).min_by_key(|&i| halves[lp[i]].key)?;
        lp.rotate_left(k);
    }
    loops.sort_by_key(|lp| halves[lp[0]].key);
    Some(
        loops
            .iter()
            .map(|lp| lp.iter().map(|&h| halves[h].from).collect())
            .collect(),
    )
}

/// Splits a closed loop of half-edges into loops that visit each vertex once.
fn split_loop(halves: &[HalfEdge], lp: Vec<usize>, out: &mut Vec<Vec<usize>>) {
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

/// Puts the outer contour first: the loop with the largest area along `n`
/// (positive: wound counter-clockwise seen from the front). Without such a
/// loop, the one with the largest |area| when `any_sign`, else `None`.
pub fn outer_first(
    mut contours: Vec<Vec<VertexId>>,
    pos: &dyn Fn(VertexId) -> DVec3,
    n: DVec3,
    any_sign: bool,
) -> Option<Vec<Vec<VertexId>>> {
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
    let outer = pick(&|ar| ar > 0.0, &|ar| ar).or_else(|| {
        if any_sign {
            pick(&|_| true, &|ar| ar.abs())
        } else {
            None
        }
    })?;
    let first = contours.remove(outer);
    contours.insert(0, first);
    Some(contours)
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
