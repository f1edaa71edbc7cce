//! Splitting: neighbour search, balance, midpoints and stitching.

use glam::DVec3;

use crate::build::{edge_inward, nudge_of};
use crate::{Elem, ElemId, INTERIOR, MAX_LEVEL, Mesh, NONE, NewVertex, Split, VertId};

/// Where edge `k` of child `c` lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ChildEdge {
    /// On the parent's edge `j`: half 0 runs from the parent's corner `j` to
    /// the edge's midpoint, half 1 from the midpoint to corner `j + 1`.
    Parent { j: usize, half: u8 },
    /// Shared with edge `edge` of sibling `child`.
    Sibling { child: usize, edge: usize },
}

/// The child-edge table of the split layout (see the crate docs):
/// `n` is 3 (triangle) or 4 (quad).
#[inline]
pub(crate) fn child_edge(n: usize, c: usize, k: usize) -> ChildEdge {
    if n == 4 {
        if k == c {
            ChildEdge::Parent { j: c, half: 0 }
        } else if k == (c + 3) % 4 {
            ChildEdge::Parent { j: k, half: 1 }
        } else if k == (c + 1) % 4 {
            ChildEdge::Sibling {
                child: (c + 1) % 4,
                edge: (c + 3) % 4,
            }
        } else {
            ChildEdge::Sibling {
                child: (c + 3) % 4,
                edge: c,
            }
        }
    } else if c == 3 {
        ChildEdge::Sibling {
            child: (k + 2) % 3,
            edge: k,
        }
    } else if k == c {
        ChildEdge::Parent { j: c, half: 0 }
    } else if k == (c + 2) % 3 {
        ChildEdge::Parent { j: k, half: 1 }
    } else {
        ChildEdge::Sibling { child: 3, edge: k }
    }
}

impl Mesh {
    /// The element across edge `k` of element `e`, inside the surface: the
    /// deepest element of level ≤ `level(e)` whose edge contains `e`'s edge
    /// `k`, with the index of that edge. `None` at a surface boundary.
    pub(crate) fn across(&self, e: u32, k: usize) -> Option<(u32, usize)> {
        let el = &self.elems[e as usize];
        if el.parent == NONE {
            let a = self.patches[el.patch as usize].adj[k];
            return (a != NONE).then_some((a >> 2, (a & 3) as usize));
        }
        let pe = &self.elems[el.parent as usize];
        let c = (e - pe.children) as usize;
        match child_edge(pe.n(), c, k) {
            ChildEdge::Sibling { child, edge } => Some((pe.children + child as u32, edge)),
            ChildEdge::Parent { j, half } => {
                let (q, jq) = self.across(el.parent, j)?;
                let qe = &self.elems[q as usize];
                if qe.is_leaf() || qe.level < pe.level {
                    return Some((q, jq));
                }
                // Same level as the parent and split: q's edge jq runs the other
                // way, so our first half is its second half.
                let child = if half == 0 { (jq + 1) % qe.n() } else { jq };
                Some((qe.children + child as u32, jq))
            }
        }
    }

    /// The leaves of `q`'s subtree that lie along `q`'s edge `j`, in the
    /// edge's order.
    pub(crate) fn leaves_along(&self, q: u32, j: usize, out: &mut Vec<ElemId>) {
        let qe = &self.elems[q as usize];
        if qe.is_leaf() {
            out.push(ElemId(q));
            return;
        }
        let n = qe.n();
        self.leaves_along(qe.children + j as u32, j, out);
        self.leaves_along(qe.children + ((j + 1) % n) as u32, j, out);
    }

    /// Splits leaf `e` into four, first splitting (recursively) every edge
    /// neighbour that would end up two levels coarser than `e`'s children, and
    /// stitching every vertex put on a surface boundary into the neighbouring
    /// surfaces. Does nothing for an element that is not a leaf (or not an
    /// element), a leaf at [`MAX_LEVEL`], or one [`Mesh::can_split`] refuses
    /// (too narrow, or a neighbour balance would split is).
    pub fn split(&mut self, e: ElemId) -> Split {
        let mut s = Split::default();
        self.split_into(e, &mut s);
        s
    }

    /// [`Mesh::split`] into a reused [`Split`] (cleared first).
    pub fn split_into(&mut self, e: ElemId, out: &mut Split) {
        out.clear();
        match self.elems.get(e.idx()) {
            Some(el) if el.is_leaf() && (el.level as u32) < MAX_LEVEL => {}
            _ => return,
        }
        if !self.splittable(e.0) {
            return;
        }
        self.refine(e.0, out);
        // `e` was split last, after the neighbours balance required.
        out.refined.rotate_right(1);
    }

    fn refine(&mut self, e: u32, out: &mut Split) {
        let n = self.elems[e as usize].n();
        let level = self.elems[e as usize].level;
        for k in 0..n {
            if let Some((q, _)) = self.across(e, k) {
                let qe = &self.elems[q as usize];
                if qe.level < level {
                    debug_assert!(qe.is_leaf());
                    self.refine(q, out);
                }
            }
        }
        self.subdivide(e, out);
    }

    /// Makes the four children of leaf `e` (whose neighbours are balanced).
    fn subdivide(&mut self, e: u32, out: &mut Split) {
        let el = self.elems[e as usize];
        let n = el.n();
        let mut m = [VertId(NONE); 4];
        for (k, mk) in m.iter_mut().enumerate().take(n) {
            *mk = self.midpoint(&el, k, out);
        }
        let base = self.elems.len() as u32;
        assert!(base < NONE - 4, "libmesh: more than 2^32 elements");
        let level = el.level + 1;
        let mk_child = |v: [VertId; 4], pedge: u16| Elem {
            v,
            children: NONE,
            parent: e,
            patch: el.patch,
            pedge,
            level,
        };
        // pedge of corner child c: its edge c and its edge c-1 lie on the
        // parent's edges of the same index, the others are interior.
        let corner_pedge = |c: usize| -> u16 {
            let mut p = 0u16;
            for k in 0..4 {
                let v = if k < n && (k == c || k == (c + n - 1) % n) {
                    el.pedge(k)
                } else {
                    INTERIOR
                };
                p |= v << (3 * k);
            }
            p
        };
        let none = VertId(NONE);
        if n == 4 {
            let c = self.new_vertex(
                (self.pos[m[0].idx()] + self.pos[m[2].idx()]) * 0.5,
                self.vsurf[m[0].idx()],
                [m[0].0, m[2].0],
                [0.0; 3],
                out,
            );
            for ci in 0..4 {
                let mut v = [none; 4];
                v[ci] = el.v[ci];
                v[(ci + 1) % 4] = m[ci];
                v[(ci + 2) % 4] = c;
                v[(ci + 3) % 4] = m[(ci + 3) % 4];
                self.elems.push(mk_child(v, corner_pedge(ci)));
            }
        } else {
            for ci in 0..3 {
                let mut v = [none; 4];
                v[ci] = el.v[ci];
                v[(ci + 1) % 3] = m[ci];
                v[(ci + 2) % 3] = m[(ci + 2) % 3];
                self.elems.push(mk_child(v, corner_pedge(ci)));
            }
            let all_interior = INTERIOR | (INTERIOR << 3) | (INTERIOR << 6) | (INTERIOR << 9);
            self.elems
                .push(mk_child([m[1], m[2], m[0], none], all_interior));
        }
        self.elems[e as usize].children = base;
        self.n_leaves += 3;
        out.refined.push(ElemId(e));
    }

    fn new_vertex(
        &mut self,
        p: DVec3,
        surface: u32,
        parents: [u32; 2],
        nudge: [f32; 3],
        out: &mut Split,
    ) -> VertId {
        let id = self.pos.len() as u32;
        assert!(id < NONE, "libmesh: more than 2^32 - 1 vertices");
        self.pos.push(p);
        self.nudge.push(nudge);
        self.vsurf.push(surface);
        self.vparent.push(parents);
        if parents[1] != NONE {
            out.new_vertices.push(NewVertex {
                v: VertId(id),
                parents: [VertId(parents[0]), VertId(parents[1])],
            });
        }
        VertId(id)
    }

    /// The vertex at the midpoint of edge `k` of `el`, made (and stitched into
    /// neighbouring surfaces) when missing.
    fn midpoint(&mut self, el: &Elem, k: usize, out: &mut Split) -> VertId {
        let n = el.n();
        let (a, b) = (el.v[k], el.v[(k + 1) % n]);
        if let Some(m) = self.mid_of(a.0, b.0) {
            return VertId(m);
        }
        let p = (self.pos[a.idx()] + self.pos[b.idx()]) * 0.5;
        let j = el.pedge(k);
        // On the surface's boundary: a step in along the edge's inward normal.
        let nudge = if j != INTERIOR && self.patches[el.patch as usize].adj[j as usize] == NONE {
            let (pa, pb) = (self.pos[a.idx()], self.pos[b.idx()]);
            let n = self.surfaces[self.vsurf[a.idx()] as usize].normal;
            nudge_of(edge_inward(n, pa, pb), pa.distance(pb), self.eps)
        } else {
            [0.0; 3]
        };
        let m = self.new_vertex(p, self.vsurf[a.idx()], [a.0, b.0], nudge, out);
        self.mid.insert(&self.vparent, m.0);
        if j != INTERIOR {
            let t = el.patch as usize * 4 + j as usize;
            let (lo, hi) = (self.twin_start[t], self.twin_start[t + 1]);
            if lo < hi {
                let root = &self.elems[el.patch as usize];
                let rn = root.n();
                let (p0, p1) = (root.v[j as usize], root.v[(j as usize + 1) % rn]);
                for i in lo..hi {
                    let [x, y] = self.twin_verts[i as usize];
                    self.stitch([p0, p1], [x, y], [a, b], p, out);
                }
            }
        }
        m
    }

    /// Gives the twin surface the vertex at position `target` (the midpoint of
    /// `ab`, a dyadic piece of the patch edge `own`), whose ends in the twin
    /// surface are `twin`: walks the dyadic subdivision of both edges down to
    /// `ab`, making any missing twin midpoint on the way.
    fn stitch(
        &mut self,
        own: [VertId; 2],
        twin: [VertId; 2],
        ab: [VertId; 2],
        target: DVec3,
        out: &mut Split,
    ) {
        let [mut x, mut y] = own;
        let [mut xt, mut yt] = twin;
        for _ in 0..=MAX_LEVEL + 1 {
            let tm = self.twin_midpoint(xt, yt, out);
            if (x == ab[0] && y == ab[1]) || (x == ab[1] && y == ab[0]) {
                return;
            }
            let Some(mo) = self.mid_of(x.0, y.0) else {
                debug_assert!(false, "stitch: missing own midpoint above the target");
                return;
            };
            let mo = VertId(mo);
            let dir = self.pos[y.idx()] - self.pos[x.idx()];
            if (target - self.pos[mo.idx()]).dot(dir) < 0.0 {
                y = mo;
                yt = tm;
            } else {
                x = mo;
                xt = tm;
            }
        }
        debug_assert!(false, "stitch: target not found");
    }

    /// The midpoint of `x`–`y` in the twin surface, made as a stitched vertex
    /// when missing.
    fn twin_midpoint(&mut self, x: VertId, y: VertId, out: &mut Split) -> VertId {
        if let Some(m) = self.mid_of(x.0, y.0) {
            return VertId(m);
        }
        let p = (self.pos[x.idx()] + self.pos[y.idx()]) * 0.5;
        // A twin edge is on its surface's boundary: step in along its inward
        // normal, the side its ends step to.
        let (px, py) = (self.pos[x.idx()], self.pos[y.idx()]);
        let n = self.surfaces[self.vsurf[x.idx()] as usize].normal;
        let mut inward = edge_inward(n, px, py);
        let ends = glam::Vec3::from_array(self.nudge[x.idx()]).as_dvec3()
            + glam::Vec3::from_array(self.nudge[y.idx()]).as_dvec3();
        let side = inward.dot(ends);
        if side < 0.0 {
            inward = -inward;
        }
        let nudge = if side == 0.0 {
            [0.0; 3]
        } else {
            nudge_of(inward, px.distance(py), self.eps)
        };
        let m = self.new_vertex(p, self.vsurf[x.idx()], [x.0, y.0], nudge, out);
        self.mid.insert(&self.vparent, m.0);
        m
    }
}
