//! Consistency checks of a [`Mesh`] (for tests and debugging).

use rustc_hash::FxHashSet;

use crate::anchor::strictly_convex;
use crate::{ElemId, Mesh, NONE, PatchId, VertId, key};

/// Relative tolerance of the area sums.
const AREA_TOL: f64 = 1e-9;

impl Mesh {
    /// Checks every invariant: tree structure and midpoints; vertices in their
    /// element's surface; balance; anchored pieces that are non-degenerate
    /// counter-clockwise triangles or convex quads, tile their leaf exactly
    /// (edge matching and area) and use exactly the leaf's contour; no
    /// T-vertex inside a surface (each leaf edge piece is matched by a
    /// neighbour's); matching vertex positions on both sides of every stitched
    /// surface boundary; leaf areas summing to the patch area. Returns the
    /// first problem found.
    pub fn validate(&self) -> Result<(), String> {
        self.check_vertices()?;
        self.check_tree()?;
        let mut segments: FxHashSet<(u32, u32)> = FxHashSet::default();
        for e in self.leaves() {
            let c = self.elem_contour(e);
            for i in 0..c.len() {
                segments.insert((c[i].0, c[(i + 1) % c.len()].0));
            }
        }
        for e in self.leaves() {
            self.check_leaf(e, &segments)?;
        }
        self.check_stitching()?;
        for p in self.patches() {
            let a: f64 = self
                .patch_leaves(p)
                .iter()
                .map(|&e| self.elem_area(e))
                .sum();
            let want = self.patch_area(p);
            // Rounding in the cross products is relative to the patch's
            // extent, not its area (a sliver's area is all cancellation).
            let ext = self.elem_longest_edge(self.patch_root(p));
            if (a - want).abs() > AREA_TOL * want + 1e-14 * ext * ext {
                return Err(format!(
                    "patch {}: leaf areas sum to {a}, patch area {want}",
                    p.0
                ));
            }
        }
        Ok(())
    }

    fn check_vertices(&self) -> Result<(), String> {
        let nv = self.pos.len();
        if self.vsurf.len() != nv || self.vparent.len() != nv {
            return Err("vertex arrays differ in length".into());
        }
        for v in 0..nv {
            let [a, b] = self.vparent[v];
            if b == NONE {
                continue;
            }
            if a as usize >= v || b as usize >= v {
                return Err(format!("vertex {v}: parents {a}, {b} are not older"));
            }
            if self.vsurf[a as usize] != self.vsurf[v] || self.vsurf[b as usize] != self.vsurf[v] {
                return Err(format!("vertex {v}: parents in another surface"));
            }
            let want = (self.pos[a as usize] + self.pos[b as usize]) * 0.5;
            if self.pos[v] != want {
                return Err(format!("vertex {v} is not halfway between its parents"));
            }
        }
        for m in self.mid.iter() {
            // Order-independent: any failure is reported, and all must pass.
            if m as usize >= nv {
                return Err("a midpoint-map entry is inconsistent".into());
            }
            let [a, b] = self.vparent[m as usize];
            let (a, b) = key(a, b);
            if a >= b
                || b == NONE
                || self.vsurf[a as usize] != self.vsurf[m as usize]
                || self.mid_of(a, b) != Some(m)
            {
                return Err("a midpoint-map entry is inconsistent".into());
            }
        }
        Ok(())
    }

    fn check_tree(&self) -> Result<(), String> {
        let mut leaves = 0;
        for (i, el) in self.elems.iter().enumerate() {
            let n = el.n();
            let s = self.patches[el.patch as usize].surface;
            if el.v[..n].iter().any(|v| self.vsurf[v.idx()] != s) {
                return Err(format!("element {i}: a corner in another surface"));
            }
            if (i < self.patches.len()) != (el.parent == NONE)
                || (el.parent == NONE) != (el.level == 0)
            {
                return Err(format!("element {i}: root/parent/level mismatch"));
            }
            if el.is_leaf() {
                leaves += 1;
                continue;
            }
            let m: Vec<Option<u32>> = (0..n)
                .map(|k| self.mid_of(el.v[k].0, el.v[(k + 1) % n].0))
                .collect();
            if m.iter().any(|x| x.is_none()) {
                return Err(format!("element {i}: split without edge midpoints"));
            }
            for c in 0..4 {
                let ch = &self.elems[(el.children + c) as usize];
                if ch.parent != i as u32
                    || ch.level != el.level + 1
                    || ch.patch != el.patch
                    || ch.n() != n
                {
                    return Err(format!("element {i}: child {c} inconsistent"));
                }
                if (c as usize) < n {
                    let c = c as usize;
                    if ch.v[c] != el.v[c]
                        || Some(ch.v[(c + 1) % n].0) != m[c]
                        || Some(ch.v[(c + n - 1) % n].0) != m[(c + n - 1) % n]
                    {
                        return Err(format!("element {i}: child {c} corners wrong"));
                    }
                }
            }
        }
        if leaves != self.n_leaves {
            return Err(format!("{} leaves counted, {leaves} found", self.n_leaves));
        }
        Ok(())
    }

    fn check_leaf(&self, e: ElemId, segments: &FxHashSet<(u32, u32)>) -> Result<(), String> {
        let el = &self.elems[e.idx()];
        let n = el.n();
        let normal = self.surfaces[self.patches[el.patch as usize].surface as usize].normal;
        // Balance and conformity with the neighbours.
        for k in 0..n {
            let Some((q, _)) = self.across(e.0, k) else {
                continue;
            };
            let qe = &self.elems[q as usize];
            if qe.is_leaf() && qe.level + 1 < el.level {
                return Err(format!(
                    "unbalanced: leaf {} (level {}) next to leaf {q} (level {})",
                    e.0, el.level, qe.level
                ));
            }
            let mut chain = vec![el.v[k]];
            self.expand(el.v[k].0, el.v[(k + 1) % n].0, &mut chain);
            chain.push(el.v[(k + 1) % n]);
            for w in chain.windows(2) {
                if !segments.contains(&(w[1].0, w[0].0)) {
                    return Err(format!(
                        "T-vertex: edge piece {}-{} of leaf {} has no matching neighbour edge",
                        w[0].0, w[1].0, e.0
                    ));
                }
            }
        }
        // Anchored pieces.
        let contour = self.elem_contour(e);
        let bound: Vec<(u32, u32)> = (0..contour.len())
            .map(|i| (contour[i].0, contour[(i + 1) % contour.len()].0))
            .collect();
        let pieces = self.anchored(e);
        let mut piece_edges: Vec<(u32, u32)> = Vec::new();
        let mut area = 0.0;
        for p in &pieces {
            if p.len() != 3 && p.len() != 4 {
                return Err(format!("leaf {}: a piece with {} vertices", e.0, p.len()));
            }
            let mut d: Vec<VertId> = p.clone();
            d.sort_unstable();
            d.dedup();
            if d.len() != p.len() || !p.iter().all(|v| contour.contains(v)) {
                return Err(format!(
                    "leaf {}: piece {:?} not made of its contour",
                    e.0, p
                ));
            }
            let pts: Vec<_> = p.iter().map(|v| self.pos[v.idx()]).collect();
            let a2 = geom::newell_normal(&pts).dot(normal);
            if p.len() == 4 {
                if !strictly_convex(&[pts[0], pts[1], pts[2], pts[3]], normal) {
                    return Err(format!("leaf {}: piece {:?} is not a convex quad", e.0, p));
                }
            } else {
                let (u, w) = (pts[1] - pts[0], pts[2] - pts[0]);
                let turn = u.cross(w).dot(normal);
                if turn.is_nan() || turn <= 1e-9 * u.length() * w.length() {
                    return Err(format!(
                        "leaf {}: piece {:?} is degenerate or reversed",
                        e.0, p
                    ));
                }
            }
            area += a2 / 2.0;
            for i in 0..p.len() {
                piece_edges.push((p[i].0, p[(i + 1) % p.len()].0));
            }
        }
        let leaf_area = self.elem_area(e);
        if (area - leaf_area).abs() > AREA_TOL * leaf_area {
            return Err(format!(
                "leaf {}: anchored areas sum to {area}, leaf area {leaf_area}",
                e.0
            ));
        }
        // Each boundary segment once, every other piece edge paired with its reverse.
        for &(a, b) in &piece_edges {
            let on_bound = bound.contains(&(a, b));
            let paired = piece_edges.contains(&(b, a));
            if on_bound == paired || piece_edges.iter().filter(|&&x| x == (a, b)).count() != 1 {
                return Err(format!(
                    "leaf {}: anchored pieces do not tile it (edge {a}-{b})",
                    e.0
                ));
            }
        }
        if let Some(&(a, b)) = bound.iter().find(|s| !piece_edges.contains(s)) {
            return Err(format!(
                "leaf {}: contour piece {a}-{b} is in no anchored piece",
                e.0
            ));
        }
        Ok(())
    }

    /// Both sides of every twin patch edge carry vertices at the same positions.
    fn check_stitching(&self) -> Result<(), String> {
        for p in 0..self.patches.len() {
            let root = &self.elems[p];
            let n = root.n();
            for j in 0..n {
                let t = p * 4 + j;
                let (p0, p1) = (root.v[j], root.v[(j + 1) % n]);
                let mut own = Vec::new();
                self.expand(p0.0, p1.0, &mut own);
                for i in self.twin_start[t]..self.twin_start[t + 1] {
                    let [x, y] = self.twin_verts[i as usize];
                    let mut other = Vec::new();
                    self.expand(x.0, y.0, &mut other);
                    let same = own.len() == other.len()
                        && own
                            .iter()
                            .zip(&other)
                            .all(|(a, b)| self.pos[a.idx()] == self.pos[b.idx()]);
                    if !same {
                        return Err(format!(
                            "patch {p} edge {j}: {} vertices, its twin in surface {} has {} (not stitched)",
                            own.len(),
                            self.vsurf[x.idx()],
                            other.len()
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Leaves of a patch whose level differs by two or more from an edge
    /// neighbour's (empty when balanced). For tests.
    pub fn unbalanced_pairs(&self, p: PatchId) -> Vec<(ElemId, ElemId)> {
        let mut out = Vec::new();
        for e in self.patch_leaves(p) {
            for q in self.elem_neighbors(e) {
                if self.elem_level(e).abs_diff(self.elem_level(q)) >= 2 {
                    out.push((e, q));
                }
            }
        }
        out
    }
}
