//! Anchoring: the T-vertex-free triangles and quads of a leaf (see the crate docs).

use glam::DVec3;

use crate::{ElemId, Mesh, VertId};

/// Relative sine below which three points count as collinear when merging
/// zipper triangles into quads.
const STRAIGHT: f64 = 1e-9;

impl Mesh {
    /// The vertices strictly inside edge `a`–`b` (hanging midpoints and
    /// stitched vertices, at any depth), in order from `a` to `b`.
    pub fn edge_vertices(&self, a: VertId, b: VertId) -> Vec<VertId> {
        let mut out = Vec::new();
        self.expand(a.0, b.0, &mut out);
        out
    }

    pub(crate) fn expand(&self, a: u32, b: u32, out: &mut Vec<VertId>) {
        if let Some(m) = self.mid_of(a, b) {
            self.expand(a, m, out);
            out.push(VertId(m));
            self.expand(m, b, out);
        }
    }

    /// The leaf's full boundary: its corners with every vertex lying on its
    /// edges, counter-clockwise from corner 0.
    pub fn elem_contour(&self, e: ElemId) -> Vec<VertId> {
        let c = self.elem_corners(e);
        let n = c.len();
        let mut out = Vec::with_capacity(2 * n);
        for k in 0..n {
            out.push(c[k]);
            self.expand(c[k].0, c[(k + 1) % n].0, &mut out);
        }
        out
    }

    /// The anchored pieces of a leaf: triangles and convex quads, counter-
    /// clockwise, that tile it using its corners and the vertices on its edges
    /// (see the crate docs for the decomposition). A leaf without vertices on
    /// its edges is its own single piece. Empty for an element that is not a
    /// leaf.
    pub fn anchored(&self, e: ElemId) -> Vec<Vec<VertId>> {
        let mut out = Vec::new();
        self.for_each_anchored(e, |p| out.push(p.to_vec()));
        out
    }

    /// Calls `f` with each anchored piece of leaf `e` (nothing for a split element).
    pub fn for_each_anchored(&self, e: ElemId, mut f: impl FnMut(&[VertId])) {
        let el = &self.elems[e.idx()];
        if !el.is_leaf() {
            return;
        }
        let n = el.n();
        let v = &el.v[..n];
        // Vertices on each edge.
        let mut single: [Option<VertId>; 4] = [None; 4];
        let mut chains: Vec<Vec<VertId>> = Vec::new();
        let mut general = false;
        for k in 0..n {
            let (a, b) = (v[k].0, v[(k + 1) % n].0);
            if let Some(m) = self.mid_of(a, b) {
                single[k] = Some(VertId(m));
                if self.mid_of(a, m).is_some() || self.mid_of(m, b).is_some() {
                    general = true;
                }
            }
        }
        if general {
            for k in 0..n {
                let mut c = Vec::new();
                self.expand(v[k].0, v[(k + 1) % n].0, &mut c);
                chains.push(c);
            }
            self.zipper(e, v, &chains, &mut f);
            return;
        }
        let mask = (0..n).fold(0u8, |m, k| m | ((single[k].is_some() as u8) << k));
        let vv = |k: usize| v[k % n];
        let mm = |k: usize| single[k % n].expect("table case has this midpoint");
        if mask == 0 {
            f(v);
            return;
        }
        if n == 3 {
            match mask.count_ones() {
                1 => {
                    let k = mask.trailing_zeros() as usize;
                    f(&[mm(k), vv(k + 1), vv(k + 2)]);
                    f(&[mm(k), vv(k + 2), vv(k)]);
                }
                2 => {
                    let k = (!mask & 7).trailing_zeros() as usize; // the edge without
                    f(&[mm(k + 1), vv(k + 2), mm(k + 2)]);
                    f(&[vv(k), vv(k + 1), mm(k + 1), mm(k + 2)]);
                }
                _ => {
                    f(&[vv(0), mm(0), mm(2)]);
                    f(&[mm(0), vv(1), mm(1)]);
                    f(&[mm(2), mm(1), vv(2)]);
                    f(&[mm(1), mm(2), mm(0)]);
                }
            }
            return;
        }
        let has = |k: usize| mask & (1 << (k % 4)) != 0;
        match mask.count_ones() {
            1 => {
                let k = mask.trailing_zeros() as usize;
                f(&[mm(k), vv(k + 1), vv(k + 2)]);
                f(&[mm(k), vv(k + 2), vv(k + 3)]);
                f(&[mm(k), vv(k + 3), vv(k)]);
            }
            2 => {
                let k = (0..4).find(|&k| has(k)).expect("two bits set");
                if has(k + 2) {
                    f(&[vv(k), mm(k), mm(k + 2), vv(k + 3)]);
                    f(&[mm(k), vv(k + 1), vv(k + 2), mm(k + 2)]);
                } else {
                    // Adjacent: k and k + 1 (k = 0 with edges 0, 3 gives k = 3).
                    let k = if has(k + 1) { k } else { k + 3 };
                    f(&[mm(k), vv(k + 1), mm(k + 1)]);
                    f(&[mm(k + 1), vv(k + 2), vv(k + 3)]);
                    f(&[vv(k), mm(k), mm(k + 1), vv(k + 3)]);
                }
            }
            3 => {
                let k = ((!mask & 15).trailing_zeros() as usize + 1) % 4; // edge after the empty one
                f(&[mm(k), vv(k + 1), mm(k + 1)]);
                f(&[mm(k + 1), vv(k + 2), mm(k + 2)]);
                f(&[mm(k), mm(k + 1), mm(k + 2)]);
                f(&[vv(k), mm(k), mm(k + 2), vv(k + 3)]);
            }
            _ => {
                for k in 0..4 {
                    f(&[mm(k + 3), vv(k), mm(k)]);
                }
                f(&[mm(0), mm(1), mm(2), mm(3)]);
            }
        }
    }

    /// The general case (an edge with two or more vertices, from stitching):
    /// zipper triangulation between the two boundary chains from a corner to
    /// the opposite one, then merging of consecutive triangles into strictly
    /// convex quads.
    fn zipper(
        &self,
        e: ElemId,
        v: &[VertId],
        chains: &[Vec<VertId>],
        f: &mut impl FnMut(&[VertId]),
    ) {
        let n = v.len();
        // Poles s (= corner k) and t. Chain L runs counter-clockwise from s to
        // t, chain R clockwise; both must hold a vertex strictly between them.
        let k = if n == 4 {
            0
        } else {
            // The triangle's edge with most vertices forms L on its own.
            (0..3)
                .max_by_key(|&k| (chains[k].len(), 3 - k))
                .unwrap_or(0)
        };
        let mut l: Vec<VertId> = Vec::new();
        let mut r: Vec<VertId> = Vec::new();
        let span = if n == 4 { 2 } else { 1 };
        l.push(v[k]);
        for s in 0..span {
            let i = (k + s) % n;
            l.extend_from_slice(&chains[i]);
            l.push(v[(i + 1) % n]);
        }
        r.push(v[k]);
        for s in 0..(n - span) {
            let i = (k + n - 1 - s) % n; // edges walked backwards from corner k
            r.extend(chains[i].iter().rev());
            r.push(v[i]);
        }
        debug_assert_eq!(l.last(), r.last());
        let p = |x: VertId| self.pos[x.idx()];
        let (nl, nr) = (l.len() - 1, r.len() - 1); // index of t in each
        let mut tris: Vec<[VertId; 3]> = Vec::with_capacity(nl + nr);
        tris.push([l[0], l[1], r[1]]);
        let (mut i, mut j) = (1, 1);
        while i < nl - 1 || j < nr - 1 {
            let adv_l = if i >= nl - 1 {
                false
            } else if j >= nr - 1 {
                true
            } else {
                p(l[i + 1]).distance_squared(p(r[j])) <= p(l[i]).distance_squared(p(r[j + 1]))
            };
            if adv_l {
                tris.push([l[i], l[i + 1], r[j]]);
                i += 1;
            } else {
                tris.push([l[i], r[j + 1], r[j]]);
                j += 1;
            }
        }
        tris.push([l[i], l[nl], r[j]]);
        // Merge neighbours into strictly convex quads.
        let normal =
            self.surfaces[self.patches[self.elems[e.idx()].patch as usize].surface as usize].normal;
        let mut t = 0;
        while t < tris.len() {
            if t + 1 < tris.len()
                && let Some(q) = merge(tris[t], tris[t + 1])
                && strictly_convex(&q.map(p), normal)
            {
                f(&q);
                t += 2;
            } else {
                f(&tris[t]);
                t += 1;
            }
        }
    }
}

/// The quad made of two triangles (both counter-clockwise) sharing an edge.
fn merge(a: [VertId; 3], b: [VertId; 3]) -> Option<[VertId; 4]> {
    for i in 0..3 {
        let (x, y) = (a[i], a[(i + 1) % 3]);
        for j in 0..3 {
            if b[j] == y && b[(j + 1) % 3] == x {
                // a: x y z, b: y x w → quad x w y z.
                let z = a[(i + 2) % 3];
                let w = b[(j + 2) % 3];
                return Some([x, w, y, z]);
            }
        }
    }
    None
}

/// Whether a quad turns left by a clear margin at every corner.
pub(crate) fn strictly_convex(q: &[DVec3; 4], normal: DVec3) -> bool {
    (0..4).all(|i| {
        let (a, b, c) = (q[i], q[(i + 1) % 4], q[(i + 2) % 4]);
        let (u, w) = (b - a, c - b);
        u.cross(w).dot(normal) > STRAIGHT * u.length() * w.length()
    })
}
