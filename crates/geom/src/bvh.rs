//! A bounding-volume hierarchy over triangles for ray casting (f64).
//!
//! Built top-down, binary, by the surface area heuristic ([`build_nodes`]);
//! leaves hold at most four triangles. Box queries and shafts walk the
//! binary tree; rays walk the same tree collapsed four-wide ([`Wide`]),
//! four boxes a step. Rays are intersected with the watertight test of
//! Woop, Benthin and Wald in f64 ([`ray_triangle`]).

use glam::DVec3;

use crate::polygon::Projected;
use crate::triangulate::triangulate_polygon;

mod wide;
pub use wide::Wide;

/// A triangle tagged with the id of what it belongs to (e.g. a face).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub p: [DVec3; 3],
    pub id: u32,
}

/// The nearest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter: the hit point is `origin + t·dir`.
    pub t: f64,
    /// The id of the triangle that was hit.
    pub id: u32,
}

/// A BVH node: 32 bytes, its box in f32 rounded outward (so it holds
/// every point of the f64 box it stands for), so that a node's two
/// children share one 64-byte cache line. The box test is done in f64 on
/// the widened box: it is only a filter, and a larger box lets more rays
/// reach the exact triangle test, so whether a ray hits anything does not
/// change. (A ray lying exactly in a box face's plane with a zero
/// direction component there is inside that slab, see
/// [`slab_entry_general`]; with the f64 boxes of old, rounding them
/// outward had changed such rays' answers, which no longer happens.)
/// Against f64 boxes: the 2k-face messy building's transport build and
/// `ugclean`'s enclosed-face rays ran faster (docs/performance.md).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Node {
    lo: [f32; 3],
    hi: [f32; 3],
    /// Leaf: index of the first triangle; inner node: index of the left child (right = left + 1).
    pub first: u32,
    /// Number of triangles in a leaf; 0 for an inner node.
    pub count: u32,
}

impl Node {
    /// The box's low corner (outside or on the f64 box it was built from).
    #[inline(always)]
    pub fn lo(&self) -> DVec3 {
        DVec3::new(self.lo[0] as f64, self.lo[1] as f64, self.lo[2] as f64)
    }

    /// The box's high corner.
    #[inline(always)]
    pub fn hi(&self) -> DVec3 {
        DVec3::new(self.hi[0] as f64, self.hi[1] as f64, self.hi[2] as f64)
    }

    fn set_box(&mut self, lo: DVec3, hi: DVec3) {
        self.lo = lo.to_array().map(f32_down);
        self.hi = hi.to_array().map(f32_up);
    }
}

/// The largest f32 at or below `x`.
fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// The smallest f32 at or above `x`.
fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// A BVH over triangles.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// The same tree four-wide, for the ray walks.
    wide: Wide,
    tris: Vec<Triangle>,
    /// What the nodes' boxes are measured from ([`build_nodes`]).
    base: DVec3,
}

/// At most this many triangles in a leaf.
pub const LEAF: usize = 4;

impl Bvh {
    pub fn new(mut tris: Vec<Triangle>) -> Bvh {
        let (nodes, base) = build_nodes(&mut tris, |t| t.p);
        let wide = Wide::new(&nodes);
        Bvh {
            nodes,
            wide,
            tris,
            base,
        }
    }

    pub fn len(&self) -> usize {
        self.tris.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The nearest hit with `tmin < t < tmax` among triangles whose id passes `keep`.
    pub fn intersect(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
        keep: impl Fn(u32) -> bool,
    ) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut tmax = tmax;
        self.walk(origin, dir, tmin, &mut tmax, &keep, &mut |h| {
            best = Some(h);
            false
        });
        best
    }

    /// Calls `f` with the id of every triangle in a leaf whose box meets
    /// the closed box [lo, hi] (a triangle's id may come more than once,
    /// and a triangle whose own box misses [lo, hi] may come too: the
    /// nodes' boxes are what is tested; the caller tests its own box).
    /// A box query without an index of its own: the transport's candidate
    /// patches (`radiosity::tail`) took it from an R-tree at a sixth of
    /// the tail's time.
    pub fn for_each_in_box(&self, lo: DVec3, hi: DVec3, mut f: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let (lo, hi) = measured_from(lo, hi, self.base);
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(ni) = stack.pop() {
            let n = &self.nodes[ni as usize];
            if n.lo().cmpgt(hi).any() || n.hi().cmplt(lo).any() {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
                continue;
            }
            for t in &self.tris[n.first as usize..(n.first + n.count) as usize] {
                f(t.id);
            }
        }
    }

    /// Whether anything (passing `keep`) is hit with `tmin < t < tmax`.
    pub fn occluded(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
        keep: impl Fn(u32) -> bool,
    ) -> bool {
        let mut any = false;
        let mut tmax = tmax;
        self.walk(origin, dir, tmin, &mut tmax, &keep, &mut |_| {
            any = true;
            true
        });
        any
    }

    /// Every hit with `tmin < t < tmax` (passing `keep`), in no particular order
    /// (for parity tests: a point is inside a closed surface when a ray from it
    /// crosses the surface an odd number of times).
    pub fn all_hits(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
        keep: impl Fn(u32) -> bool,
    ) -> Vec<Hit> {
        let mut hits = Vec::new();
        let mut tmax = tmax;
        self.walk_with(origin, dir, tmin, &mut tmax, false, &keep, &mut |h| {
            hits.push(h);
            false
        });
        hits
    }

    fn walk(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: &mut f64,
        keep: &dyn Fn(u32) -> bool,
        on_hit: &mut dyn FnMut(Hit) -> bool,
    ) {
        self.walk_with(origin, dir, tmin, tmax, true, keep, on_hit)
    }

    /// Visits hits in no particular order (shrinking `tmax` to each hit when
    /// `shrink`); stops when `on_hit` returns true.
    #[allow(clippy::too_many_arguments)]
    fn walk_with(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: &mut f64,
        shrink: bool,
        keep: &dyn Fn(u32) -> bool,
        on_hit: &mut dyn FnMut(Hit) -> bool,
    ) {
        let inv = DVec3::ONE / dir;
        let Some(frame) = RayFrame::new(dir) else {
            return; // no triangle can be hit
        };
        // The boxes are measured from `base`; the triangles are not.
        let rel = origin - self.base;
        self.wide.walk(rel, inv, tmin, tmax, |first, count, tmax| {
            for t in &self.tris[first as usize..(first + count) as usize] {
                if !keep(t.id) {
                    continue;
                }
                if let Some(tt) = ray_triangle_with(origin, &frame, t)
                    && tt > tmin
                    && tt < *tmax
                {
                    if shrink {
                        *tmax = tt;
                    }
                    if on_hit(Hit { t: tt, id: t.id }) {
                        return true;
                    }
                }
            }
            false
        });
    }
}

#[inline]
/// Builds BVH nodes over triangles given by their corners, top-down, each
/// node split by the surface area heuristic over 16 bins of the centroids
/// along each axis (the median along the longest axis when the centroids
/// fall in one bin); reorders `items` so that each leaf's triangles are
/// contiguous. Deterministic. Against the median split alone, the tail's
/// discovery rays in a 26,000-patch building took about half the time:
/// an architectural model mixes floors and walls metres long with tiles
/// and trims of centimetres, which a median split cuts through.
///
/// The boxes are measured from the point [`build_nodes`] returns with them
/// (the walks subtract it from a ray's origin): the origin, or, for items
/// far from it (their middle more than 16 times their extent away: a
/// building on a site 4·10⁶ m from the origin), their middle, so that the
/// f32 boxes are as tight there as near the origin (rounded outward from
/// 4·10⁶ m they were half a metre wide: a one-room building converged 10%
/// slower). Near the origin the boxes are the same bits as before.
pub fn build_nodes<T>(items: &mut [T], corners: impl Fn(&T) -> [DVec3; 3]) -> (Vec<Node>, DVec3) {
    const BINS: usize = 16;
    let mut nodes = Vec::with_capacity(2 * items.len() / LEAF + 2);
    if items.is_empty() {
        return (nodes, DVec3::ZERO);
    }
    let empty = Node {
        lo: [0.0; 3],
        hi: [0.0; 3],
        first: 0,
        count: 0,
    };
    // Per item: its box and centroid (computed once).
    let boxes: Vec<(DVec3, DVec3)> = items
        .iter()
        .map(|t| {
            let p = corners(t);
            (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
        })
        .collect();
    let (lo, hi) = boxes.iter().fold(
        (DVec3::INFINITY, DVec3::NEG_INFINITY),
        |(lo, hi), &(a, b)| (lo.min(a), hi.max(b)),
    );
    let base = far_base(lo, hi);
    let mut order: Vec<u32> = (0..items.len() as u32).collect();
    let centroid = |k: u32| {
        let (lo, hi) = boxes[k as usize];
        (lo + hi) * 0.5
    };
    let area = |lo: DVec3, hi: DVec3| {
        let d = (hi - lo).max(DVec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    // The root, and an unused node so that every pair of children starts
    // at an even index (one cache line when the array is 64-byte aligned).
    nodes.push(empty);
    nodes.push(empty);
    // (node index, start, end)
    let mut stack = vec![(0usize, 0usize, items.len())];
    while let Some((ni, s, e)) = stack.pop() {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        for &k in &order[s..e] {
            let (a, b) = boxes[k as usize];
            lo = lo.min(a);
            hi = hi.max(b);
            let c = centroid(k);
            clo = clo.min(c);
            chi = chi.max(c);
        }
        let (blo, bhi) = measured_from(lo, hi, base);
        nodes[ni].set_box(blo, bhi);
        let ext = chi - clo;
        if e - s <= LEAF || ext.max_element() <= 0.0 {
            nodes[ni].first = s as u32;
            nodes[ni].count = (e - s) as u32;
            continue;
        }
        // The cheapest split plane over the bins of the three axes.
        let bin_of = |c: f64, axis: usize| {
            let f = (c - clo[axis]) / ext[axis] * BINS as f64;
            (f as usize).min(BINS - 1)
        };
        let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, first bin on the right)
        for axis in 0..3 {
            if ext[axis] <= 0.0 {
                continue;
            }
            let mut count = [0usize; BINS];
            let mut blo = [DVec3::splat(f64::INFINITY); BINS];
            let mut bhi = [DVec3::splat(f64::NEG_INFINITY); BINS];
            for &k in &order[s..e] {
                let b = bin_of(centroid(k)[axis], axis);
                let (a, z) = boxes[k as usize];
                count[b] += 1;
                blo[b] = blo[b].min(a);
                bhi[b] = bhi[b].max(z);
            }
            // Areas and counts of the bins left of each plane.
            let mut left = [(0.0, 0usize); BINS];
            let (mut l, mut h, mut n) = (
                DVec3::splat(f64::INFINITY),
                DVec3::splat(f64::NEG_INFINITY),
                0,
            );
            for b in 0..BINS - 1 {
                l = l.min(blo[b]);
                h = h.max(bhi[b]);
                n += count[b];
                left[b + 1] = (if n > 0 { area(l, h) } else { 0.0 }, n);
            }
            let (mut l, mut h, mut n) = (
                DVec3::splat(f64::INFINITY),
                DVec3::splat(f64::NEG_INFINITY),
                0,
            );
            for b in (1..BINS).rev() {
                l = l.min(blo[b]);
                h = h.max(bhi[b]);
                n += count[b];
                let (al, nl) = left[b];
                if nl == 0 || n == 0 {
                    continue;
                }
                let cost = al * nl as f64 + area(l, h) * n as f64;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, b));
                }
            }
        }
        let mid = match best {
            Some((_, axis, b)) => {
                // In-place partition: the bins left of the plane first.
                let (mut i, mut j) = (s, e);
                while i < j {
                    if bin_of(centroid(order[i])[axis], axis) < b {
                        i += 1;
                    } else {
                        j -= 1;
                        order.swap(i, j);
                    }
                }
                i
            }
            None => {
                let axis = if ext.x >= ext.y && ext.x >= ext.z {
                    0
                } else if ext.y >= ext.z {
                    1
                } else {
                    2
                };
                let mid = (s + e) / 2;
                order[s..e].select_nth_unstable_by(mid - s, |&a, &b| {
                    centroid(a)[axis].total_cmp(&centroid(b)[axis])
                });
                mid
            }
        };
        let left = nodes.len();
        nodes.push(empty);
        nodes.push(empty);
        nodes[ni].first = left as u32;
        nodes[ni].count = 0;
        stack.push((left, s, mid));
        stack.push((left + 1, mid, e));
    }
    // Put the items in leaf order.
    permute(items, &order);
    (nodes, base)
}

/// Where boxes spanning [lo, hi] are measured from ([`build_nodes`]).
fn far_base(lo: DVec3, hi: DVec3) -> DVec3 {
    let mid = (lo + hi) * 0.5;
    let extent = (hi - lo).max_element();
    if mid.is_finite() && extent.is_finite() && mid.abs().max_element() > 16.0 * extent {
        mid
    } else {
        DVec3::ZERO
    }
}

/// The box [lo, hi] measured from `base`: as it is from the origin, else
/// shifted and widened on each side by four units in the last place of the
/// largest coordinate, which covers the rounding of the shift (of a box's
/// corners, of a query box, of a ray's origin).
fn measured_from(lo: DVec3, hi: DVec3, base: DVec3) -> (DVec3, DVec3) {
    if base == DVec3::ZERO {
        return (lo, hi);
    }
    let big = lo.abs().max(hi.abs()).max(base.abs()).max_element();
    let pad = DVec3::splat(4.0 * big * f64::EPSILON);
    (lo - base - pad, hi - base + pad)
}

/// Reorders `items` so that `items[i]` becomes the old `items[order[i]]`.
fn permute<T>(items: &mut [T], order: &[u32]) {
    let mut done = vec![false; items.len()];
    for i in 0..items.len() {
        if done[i] {
            continue;
        }
        // Follow the cycle through i.
        let mut j = i;
        loop {
            done[j] = true;
            let k = order[j] as usize;
            if k == i {
                break;
            }
            items.swap(j, k);
            j = k;
        }
    }
}

/// Whether the ray `o + t d` (`inv` = 1/d per component) meets the closed
/// box [lo, hi] for some t in [tmin, tmax].
#[inline]
pub fn slab(lo: DVec3, hi: DVec3, o: DVec3, inv: DVec3, tmin: f64, tmax: f64) -> bool {
    slab_entry(lo, hi, o, inv, tmin, tmax).is_some()
}

/// Each slab's far parameter is scaled by this (1 + 2γ₃, γₙ = nu/(1 − nu),
/// u = 2⁻⁵³: Ize 2013, "Robust BVH ray traversal"): the rounding of
/// `(lo − o) · inv` can put a slab's far end before its near end when the
/// ray meets the box only on its boundary. A ray through the edge shared by
/// two patches of a wall, lying exactly on the plane that splits two BVH
/// boxes, met both boxes in an empty interval and passed through the wall.
const SLAB_FAR: f64 = 1.0 + 2.0 * (3.0 * f64::EPSILON / 2.0) / (1.0 - 3.0 * f64::EPSILON / 2.0);

/// [`slab`] with the entry parameter: `Some(t)` (the first t ≥ `tmin` in
/// the box) when the ray meets the box for some t in [tmin, tmax]
/// (conservatively: a box met only within rounding counts as met).
#[inline(always)]
pub fn slab_entry(lo: DVec3, hi: DVec3, o: DVec3, inv: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
    if inv.is_finite() {
        return slab_entry_finite(lo, hi, o, inv, tmin, tmax);
    }
    slab_entry_general(lo, hi, o, inv, tmin, tmax)
}

/// [`slab_entry`] for any ray (a component of `inv` may be infinite).
fn slab_entry_general(
    lo: DVec3,
    hi: DVec3,
    o: DVec3,
    inv: DVec3,
    tmin: f64,
    tmax: f64,
) -> Option<f64> {
    let (mut tn, mut tf) = (tmin, tmax);
    for k in 0..3 {
        let a = (lo[k] - o[k]) * inv[k];
        let b = (hi[k] - o[k]) * inv[k];
        // NaN is 0 · ∞: the ray is parallel to this slab and starts on one of
        // its faces, so it stays inside the (closed) slab: no constraint.
        // (Through `f64::min`, which ignores NaN, such a ray used to be
        // rejected, and could miss a box it lies in.)
        if a.is_nan() || b.is_nan() {
            continue;
        }
        let far = a.max(b);
        tn = tn.max(a.min(b));
        // (Widened either side of 0; ±∞, from a ray parallel to the slab,
        // stays as it is.)
        tf = tf.min(widen(far));
    }
    (tn <= tf).then_some(tn)
}

/// What a negative far parameter is scaled by: at most 1 / [`SLAB_FAR`]
/// (`(2 − s)·s = 1 − (s − 1)² ≤ 1`), so at least as wide as dividing.
const SLAB_FAR_NEG: f64 = 2.0 - SLAB_FAR;

/// A slab's far parameter widened by [`SLAB_FAR`] away from the near end.
/// (A multiplication either way: the division it used to be for a
/// negative far end stalled the box test, most of a ray's time.)
#[inline(always)]
fn widen(far: f64) -> f64 {
    far * if far > 0.0 { SLAB_FAR } else { SLAB_FAR_NEG }
}

/// [`slab_entry`] for a ray with a finite `inv` (no component of the
/// direction zero): no product is NaN, so plain comparisons take the
/// place of `f64::min`'s NaN handling and the three axes need no branch.
/// The same result, bit for bit (min and max of numbers are exact in any
/// order); the box test is most of a ray's cost in a large model (the
/// enclosed-face rays of `ugclean` on the 100k building: about 70%).
#[inline(always)]
fn slab_entry_finite(
    lo: DVec3,
    hi: DVec3,
    o: DVec3,
    inv: DVec3,
    tmin: f64,
    tmax: f64,
) -> Option<f64> {
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let near = [lt_min(a.x, b.x), lt_min(a.y, b.y), lt_min(a.z, b.z)];
    let far = [
        widen(gt_max(a.x, b.x)),
        widen(gt_max(a.y, b.y)),
        widen(gt_max(a.z, b.z)),
    ];
    let tn = gt_max(gt_max(tmin, near[0]), gt_max(near[1], near[2]));
    let tf = lt_min(lt_min(tmax, far[0]), lt_min(far[1], far[2]));
    (tn <= tf).then_some(tn)
}

/// The lesser of two numbers that are not NaN (a plain comparison: no NaN
/// handling, no branch once compiled).
#[inline(always)]
fn lt_min(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// The greater of two numbers that are not NaN.
#[inline(always)]
fn gt_max(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// The ray parameter of the hit, if the ray meets the triangle (either
/// side): the watertight test of Woop, Benthin and Wald (2013). The
/// triangle is moved into a frame where the ray runs along +z from the
/// origin, and the ray meets it when the three edge functions (twice the
/// signed areas of the sub-triangles around the ray) have one sign, zero
/// counted as either. An edge's function depends only on its two corners,
/// and is exactly negated for the neighbour that runs it the other way, so
/// a ray through an edge or corner shared by triangles of one surface hits
/// at least one of them: no cracks between a surface's triangles. (With
/// Möller–Trumbore, rays through shared edges could pass between the two
/// triangles: a blocker's own surface leaked light to points it hides.)
#[inline]
pub fn ray_triangle(o: DVec3, d: DVec3, t: &Triangle) -> Option<f64> {
    ray_triangle_with(o, &RayFrame::new(d)?, t)
}

/// What [`ray_triangle`] needs of a ray's direction, computed once a ray
/// rather than once a triangle (three divisions and the choice of axes):
/// the same arithmetic, so the same answers bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct RayFrame {
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f64,
    sy: f64,
    sz: f64,
}

impl RayFrame {
    /// The frame of direction `d`; `None` when the ray can hit nothing
    /// (a zero or non-finite direction).
    #[inline]
    pub fn new(d: DVec3) -> Option<RayFrame> {
        // The axis along which the direction is largest becomes z.
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky); // keep the frame's handedness
        }
        if d[kz] == 0.0 || !d[kz].is_finite() {
            return None;
        }
        Some(RayFrame {
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        })
    }
}

/// [`ray_triangle`] for a ray from `o` whose direction's frame is `f`.
#[inline]
pub fn ray_triangle_with(o: DVec3, f: &RayFrame, t: &Triangle) -> Option<f64> {
    let (kx, ky, kz) = (f.kx, f.ky, f.kz);
    let (sx, sy, sz) = (f.sx, f.sy, f.sz);
    let rel = |p: DVec3| (p - o).to_array();
    let (pa, pb, pc) = (rel(t.p[0]), rel(t.p[1]), rel(t.p[2]));
    let (ax, ay) = (pa[kx] - sx * pa[kz], pa[ky] - sy * pa[kz]);
    let (bx, by) = (pb[kx] - sx * pb[kz], pb[ky] - sy * pb[kz]);
    let (cx, cy) = (pc[kx] - sx * pc[kz], pc[ky] - sy * pc[kz]);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let tt = (u * pa[kz] + v * pb[kz] + w * pc[kz]) * sz;
    Some(tt / det)
}

/// Triangles covering a planar face with holes (constrained Delaunay in the
/// face's plane; a fan of the outer contour when that fails), as indices into
/// the contours' points numbered contour after contour.
pub fn face_triangles(contours: &[Vec<DVec3>]) -> Vec<[usize; 3]> {
    if contours.len() == 1 && contours[0].len() == 3 {
        return vec![[0, 1, 2]];
    }
    if let Some(pr) = Projected::new(contours)
        && let Some(t) = triangulate_polygon(&pr.contours)
    {
        return t;
    }
    let n = contours.first().map_or(0, Vec::len);
    (1..n.saturating_sub(1)).map(|i| [0, i, i + 1]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shaft's triangle is 32 bytes, and its plane test never rules out
    /// a segment that meets the triangle, however the f32 normal rounds:
    /// segments through random points of random triangles, far from the
    /// origin too, with both ends a hair off the plane on either side.
    #[test]
    fn a_shaft_triangle_is_small_and_its_plane_test_conservative() {
        assert_eq!(std::mem::size_of::<ShaftTri>(), 32);
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for shift in [0.0, 4.1e6] {
            for _ in 0..2000 {
                let o = DVec3::splat(shift);
                let p = [0; 3].map(|_| o + DVec3::new(rnd(), rnd(), rnd()) * 10.0);
                let t = ShaftTri::new(0, &p, 1e-9);
                let (u, v) = (rnd() + 0.5, rnd() + 0.5);
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                let q = p[0] + (p[1] - p[0]) * u + (p[2] - p[0]) * v;
                let d = DVec3::new(rnd(), rnd(), rnd());
                assert!(t.may_cross(q + d, q - d), "{p:?} {q:?}");
                assert!(t.may_cross(q, q + d), "{p:?} {q:?}");
            }
        }
    }

    fn grid(n: usize) -> Vec<Triangle> {
        // n×n unit squares in the plane z = k for k in 0..3, two triangles each.
        let mut v = Vec::new();
        for k in 0..3 {
            for i in 0..n {
                for j in 0..n {
                    let p = |x: usize, y: usize| DVec3::new(x as f64, y as f64, k as f64);
                    let id = (k * n * n + i * n + j) as u32;
                    v.push(Triangle {
                        p: [p(i, j), p(i + 1, j), p(i + 1, j + 1)],
                        id,
                    });
                    v.push(Triangle {
                        p: [p(i, j), p(i + 1, j + 1), p(i, j + 1)],
                        id,
                    });
                }
            }
        }
        v
    }

    /// Nearest hits of 500 random rays upward through the grid `tris`
    /// (moved by `off`) agree with brute force to `tol`.
    fn assert_nearest_hits_agree(tris: &[Triangle], off: DVec3, seed: u64, tol: f64) {
        let bvh = Bvh::new(tris.to_vec());
        let mut seed = seed;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let o = off + DVec3::new(rnd() * 12.0 - 1.0, rnd() * 12.0 - 1.0, -1.0 + rnd() * 0.5);
            let d = DVec3::new(rnd() - 0.5, rnd() - 0.5, 1.0).normalize();
            let brute = tris
                .iter()
                .filter_map(|t| {
                    ray_triangle(o, d, t)
                        .filter(|&x| x > 1e-9)
                        .map(|x| (x, t.id))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let got = bvh.intersect(o, d, 1e-9, f64::INFINITY, |_| true);
            match (brute, got) {
                (None, None) => {}
                (Some((t, _)), Some(h)) => assert!((t - h.t).abs() < tol),
                other => panic!("mismatch {other:?}"),
            }
        }
    }

    #[test]
    fn nearest_hit_matches_brute_force() {
        assert_nearest_hits_agree(&grid(10), DVec3::ZERO, 7, 1e-12);
    }

    /// Every triangle whose box meets the query box comes (touching
    /// counts), and what comes lies in a leaf whose box meets it: against
    /// a brute-force filter over random boxes, some degenerate (a point, a
    /// plane) and some touching the grid's planes exactly.
    #[test]
    fn box_queries_find_every_triangle_whose_box_meets_the_box() {
        let tris = grid(12);
        let bvh = Bvh::new(tris.clone());
        let mut seed = 11u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut total = 0;
        for k in 0..400 {
            let a = DVec3::new(rnd() * 14.0 - 1.0, rnd() * 14.0 - 1.0, rnd() * 3.0 - 0.5);
            let size = DVec3::new(rnd() * 3.0, rnd() * 3.0, rnd() * 1.5);
            let (mut lo, mut hi) = (a, a + size);
            match k % 4 {
                1 => hi = lo,                   // a point
                2 => (lo.z, hi.z) = (1.0, 1.0), // the plane z = 1 exactly
                3 => hi.z = lo.z,               // a flat box
                _ => {}
            }
            let want: Vec<usize> = (0..tris.len())
                .filter(|&i| {
                    let p = tris[i].p;
                    let (tlo, thi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                    tlo.cmple(hi).all() && thi.cmpge(lo).all()
                })
                .collect();
            let mut got: Vec<u32> = Vec::new();
            bvh.for_each_in_box(lo, hi, |id| got.push(id));
            got.sort_unstable();
            got.dedup();
            for &i in &want {
                assert!(
                    got.binary_search(&tris[i].id).is_ok(),
                    "box {lo}–{hi}: triangle {i} (id {}) missing",
                    tris[i].id
                );
            }
            // Not the whole model each time: the tree prunes.
            assert!(got.len() < 3 * 144 || want.len() > 200, "{}", got.len());
            total += want.len();
        }
        assert!(total > 1000, "the boxes met too little: {total}");
    }

    /// The same grid on a site 4·10⁶ units from the origin, where the boxes
    /// are measured from the model's middle ([`build_nodes`]): nearest hits
    /// and box queries agree with brute force, and rays through the grid's
    /// shared edges and corners (on the boxes' planes) are all stopped.
    #[test]
    fn far_from_the_origin_the_boxes_are_measured_from_the_middle() {
        let off = DVec3::new(512_345.5, 4_187_654.25, 120.0);
        let tris: Vec<Triangle> = grid(10)
            .into_iter()
            .map(|t| Triangle {
                p: t.p.map(|p| p + off),
                id: t.id,
            })
            .collect();
        let bvh = Bvh::new(tris.clone());
        assert_ne!(bvh.base, DVec3::ZERO);
        assert_nearest_hits_agree(&tris, off, 17, 1e-9);
        let mut seed = 17u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        // Straight down through every grid point and edge midpoint of the
        // top layer: the top layer stops each.
        for i in 0..=20 {
            for j in 0..=20 {
                let q = off + DVec3::new(i as f64 * 0.5, j as f64 * 0.5, 2.0);
                let o = q + DVec3::Z;
                let h = bvh.intersect(o, -DVec3::Z, 0.0, f64::INFINITY, |_| true);
                assert!(
                    h.is_some_and(|h| (h.t - 1.0).abs() < 1e-9),
                    "through {q}: {h:?}"
                );
            }
        }
        for k in 0..200 {
            let a = off + DVec3::new(rnd() * 12.0 - 1.0, rnd() * 12.0 - 1.0, rnd() * 3.0 - 0.5);
            let mut hi = a + DVec3::new(rnd() * 3.0, rnd() * 3.0, rnd() * 1.5);
            if k % 2 == 1 {
                hi = a; // a point
            }
            let want: Vec<u32> = tris
                .iter()
                .filter(|t| {
                    let (tlo, thi) = (
                        t.p[0].min(t.p[1]).min(t.p[2]),
                        t.p[0].max(t.p[1]).max(t.p[2]),
                    );
                    tlo.cmple(hi).all() && thi.cmpge(a).all()
                })
                .map(|t| t.id)
                .collect();
            let mut got: Vec<u32> = Vec::new();
            bvh.for_each_in_box(a, hi, |id| got.push(id));
            got.sort_unstable();
            for id in want {
                assert!(got.binary_search(&id).is_ok(), "box {a}–{hi}: {id} missing");
            }
        }
    }

    #[test]
    fn occlusion_and_filtering() {
        let bvh = Bvh::new(grid(4));
        let o = DVec3::new(1.5, 1.5, -1.0);
        let up = DVec3::Z;
        assert!(bvh.occluded(o, up, 0.0, 10.0, |_| true));
        assert!(!bvh.occluded(o, up, 0.0, 0.5, |_| true));
        let h = bvh.intersect(o, up, 0.0, 10.0, |id| id >= 16).unwrap();
        assert!((h.t - 2.0).abs() < 1e-12);
        assert!(!bvh.occluded(o, -up, 0.0, 10.0, |_| true));
        // Three planes above: three crossings (each square is two triangles; one is hit
        // when the ray misses their common diagonal).
        let o2 = DVec3::new(1.3, 1.6, -1.0);
        assert_eq!(bvh.all_hits(o2, up, 0.0, 10.0, |_| true).len(), 3);
    }

    #[test]
    fn face_with_hole_triangulates() {
        let outer = vec![
            DVec3::new(0., 0., 1.),
            DVec3::new(3., 0., 1.),
            DVec3::new(3., 3., 1.),
            DVec3::new(0., 3., 1.),
        ];
        let hole = vec![
            DVec3::new(1., 1., 1.),
            DVec3::new(1., 2., 1.),
            DVec3::new(2., 2., 1.),
            DVec3::new(2., 1., 1.),
        ];
        let t = face_triangles(&[outer, hole]);
        assert_eq!(t.len(), 8);
    }
}

#[cfg(test)]
mod slab_tests {
    use super::*;

    /// Uniform numbers in [0, 1) from a xorshift generator seeded `z`.
    fn xorshift(mut z: u64) -> impl FnMut() -> f64 {
        move || {
            z ^= z << 13;
            z ^= z >> 7;
            z ^= z << 17;
            (z >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Rays aimed at points of the edges shared by a surface's triangles
    /// (a fan around an off-centre point of a skewed, tilted polygon) hit
    /// at least one of them: no cracks. Möller–Trumbore, the test before,
    /// let 4,949 of these 196,000 rays through (checked when this test was
    /// written).
    #[test]
    fn rays_through_shared_edges_do_not_pass_between_triangles() {
        let mut rnd = xorshift(0x2545_f491_4f6c_dd1d);
        let mut missed = 0;
        for _ in 0..2000 {
            // A polygon of 7 corners in a random plane, fanned from a point.
            let origin = DVec3::new(rnd() * 10.0, rnd() * 10.0, rnd() * 3.0);
            let (u, v) = DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5)
                .normalize()
                .any_orthonormal_pair();
            // (Near enough to `origin` for the fan not to fold.)
            let centre = origin + u * (rnd() * 0.01) + v * (rnd() * 0.01);
            let ring: Vec<DVec3> = (0..7)
                .map(|k| {
                    let a = std::f64::consts::TAU * (k as f64 + rnd() * 0.5) / 7.0;
                    let r = 0.5 + rnd();
                    origin + u * (a.cos() * r) + v * (a.sin() * r)
                })
                .collect();
            let tris: Vec<Triangle> = (0..7)
                .map(|k| Triangle {
                    p: [centre, ring[k], ring[(k + 1) % 7]],
                    id: k as u32,
                })
                .collect();
            let eye = origin + (u.cross(v) * (1.0 + rnd())) + u * (rnd() - 0.5);
            for &corner in &ring {
                for _ in 0..14 {
                    // A point of the spoke centre → corner, shared by two triangles.
                    let s = rnd();
                    let aim = centre + (corner - centre) * s;
                    let d = aim - eye;
                    if !tris.iter().any(|t| ray_triangle(eye, d, t).is_some()) {
                        missed += 1;
                    }
                }
            }
        }
        assert_eq!(missed, 0, "rays passed between triangles");
    }

    /// Rays through the edge shared by two patches of a wall, where the
    /// BVH splits the wall between two boxes, are stopped by the wall: the
    /// slab test widened by the rounding bound (`SLAB_FAR`). Without it,
    /// the exact ray below (a light on a ceiling 3 units up to a floor
    /// point behind a box's side) met both boxes in an empty interval and
    /// went through (checked with the factor set to 1: some of these do).
    #[test]
    fn rays_through_an_edge_on_a_box_boundary_are_stopped() {
        let quad = |y0: f64, y1: f64, z0: f64, z1: f64| {
            let c = [
                DVec3::new(2.0, y0, z0),
                DVec3::new(2.0, y1, z0),
                DVec3::new(2.0, y1, z1),
                DVec3::new(2.0, y0, z1),
            ];
            [[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
        };
        let mut tris = Vec::new();
        for (k, q) in [
            quad(1.0, 1.5, 0.001, 0.5005),
            quad(1.5, 2.0, 0.001, 0.5005),
            quad(1.0, 1.5, 0.5005, 1.0),
            quad(1.5, 2.0, 0.5005, 1.0),
        ]
        .into_iter()
        .enumerate()
        {
            for p in q {
                tris.push(Triangle { p, id: k as u32 });
            }
        }
        let bvh = Bvh::new(tris);
        let from = DVec3::new(2.25, 3.25, 3.0);
        let mut passed = 0;
        for k in 0..20 {
            // Points along one ray beyond the wall: it crosses x = 2 on the
            // line y = 1.5 (the first is the floor point itself).
            let s = 1.0 + k as f64 * 0.05;
            let to = from + (DVec3::new(1.9375, 1.0625, 0.0) - from) * s;
            if !bvh.occluded(from, to - from, 1e-7, 1.0 - 1e-7, |_| true) {
                passed += 1;
            }
        }
        assert_eq!(passed, 0, "rays passed through the wall");
    }

    #[test]
    fn a_ray_in_the_plane_of_a_box_face_enters_the_box() {
        let (lo, hi) = (DVec3::ZERO, DVec3::ONE);
        // Along +x in the plane z = 0 (the box's lower z face), from outside.
        let o = DVec3::new(-1.0, 0.5, 0.0);
        let d = DVec3::X;
        assert!(slab(lo, hi, o, d.recip(), 0.0, 10.0));
        // In the plane z = 1 (upper face) too, and not when beside the box.
        assert!(slab(
            lo,
            hi,
            DVec3::new(-1.0, 0.5, 1.0),
            d.recip(),
            0.0,
            10.0
        ));
        assert!(!slab(
            lo,
            hi,
            DVec3::new(-1.0, 0.5, 1.5),
            d.recip(),
            0.0,
            10.0
        ));
        assert!(!slab(
            lo,
            hi,
            DVec3::new(-1.0, 0.5, 0.5),
            d.recip(),
            0.0,
            0.5
        ));
    }

    /// The branch-free box test gives the general one's answers bit for bit,
    /// on boxes the rays meet, miss and graze (origins on a box's faces and
    /// rays through its edges included).
    #[test]
    fn finite_slab_test_matches_the_general_one() {
        let mut rnd = xorshift(0x9e37_79b9_7f4a_7c15);
        let (mut met, mut missed) = (0, 0);
        for _ in 0..200_000 {
            let lo = DVec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0;
            let hi = lo + DVec3::new(rnd(), rnd(), rnd()) * 2.0;
            let mut o = DVec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0;
            // Now and then on a face or at a corner of the box.
            if rnd() < 0.2 {
                o.x = lo.x;
            }
            if rnd() < 0.1 {
                o.y = hi.y;
            }
            let to = if rnd() < 0.5 {
                // Toward a point of the box's boundary.
                DVec3::new(lo.x, hi.y, lo.z + rnd() * (hi.z - lo.z))
            } else {
                DVec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0
            };
            let d = (to - o).normalize();
            if !d.is_finite() || d.x == 0.0 || d.y == 0.0 || d.z == 0.0 {
                continue;
            }
            let inv = DVec3::ONE / d;
            let (tmin, tmax) = (
                rnd() * 0.1,
                if rnd() < 0.5 {
                    f64::INFINITY
                } else {
                    rnd() * 6.0
                },
            );
            let a = slab_entry_finite(lo, hi, o, inv, tmin, tmax);
            let b = slab_entry_general(lo, hi, o, inv, tmin, tmax);
            assert_eq!(
                a.map(f64::to_bits),
                b.map(f64::to_bits),
                "{lo} {hi} {o} {d}"
            );
            if a.is_some() { met += 1 } else { missed += 1 }
        }
        assert!(
            met > 10_000 && missed > 10_000,
            "{met} met, {missed} missed"
        );
    }
}

/// The slack of shaft tests over points `pts` (a model's): 1e-9 of their
/// largest coordinate and of their extent, far above the rounding of a
/// plane test anywhere among them, and far below any feature a model
/// resolves.
pub fn shaft_slack(pts: &[DVec3]) -> f64 {
    if pts.is_empty() {
        return 0.0;
    }
    let (lo, hi) = pts
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    1e-9 * (lo.abs().max(hi.abs()).max_element() + (hi - lo).length())
}

/// A shaft (Haines and Wallace 1994): the convex hull of a convex polygon
/// (a shooter piece, or a rectangle around points on one plane) and a
/// point, as the half-spaces of the polygon's plane and of the planes
/// through the point and each of the polygon's edges, each with a slack
/// that covers every corner of the hull and every point of `inside`
/// (measured, so the hull satisfies them whatever the planes'
/// conditioning, even when the polygon is not quite planar or the point
/// lies in its plane) and rounding; and its box. What lies wholly outside
/// one half-space or the box misses the hull, and so misses every segment
/// between two of its points.
pub struct Shaft {
    lo: DVec3,
    hi: DVec3,
    /// (normal, offset, slack): outside where `n·y − d > slack`.
    planes: Vec<(DVec3, f64, f64)>,
}

impl Shaft {
    /// The hull of `polygon` and `apex`, with the points `inside` (which
    /// should lie in it, within rounding) covered too; `tol`: see
    /// [`shaft_slack`].
    pub fn new(polygon: &[DVec3], apex: DVec3, inside: &[DVec3], tol: f64) -> Shaft {
        let n = polygon.len();
        let hull = || {
            polygon
                .iter()
                .chain(inside)
                .copied()
                .chain(std::iter::once(apex))
        };
        let (mut lo, mut hi) = (apex, apex);
        for p in hull() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let mut planes = Vec::with_capacity(n + 1);
        if n >= 3 {
            let c = polygon.iter().copied().sum::<DVec3>() / n as f64;
            let mut add = |nrm: DVec3, at: DVec3, towards: DVec3| {
                let nrm = if nrm.dot(towards - at) > 0.0 {
                    -nrm
                } else {
                    nrm
                };
                let d = nrm.dot(at);
                let excess = hull().map(|p| nrm.dot(p) - d).fold(0.0, f64::max);
                planes.push((nrm, d, excess + tol * nrm.length()));
            };
            // The polygon's plane (its Newell normal), the apex inside.
            let mut nb = DVec3::ZERO;
            for i in 0..n {
                nb += polygon[i].cross(polygon[(i + 1) % n]);
            }
            add(nb, c, apex);
            for i in 0..n {
                let (a, b) = (polygon[i], polygon[(i + 1) % n]);
                add((b - a).cross(apex - a), a, c);
            }
        }
        Shaft {
            lo: lo - DVec3::splat(tol),
            hi: hi + DVec3::splat(tol),
            planes,
        }
    }

    /// Whether the box [lo, hi] lies wholly outside the shaft.
    pub fn misses_box(&self, lo: DVec3, hi: DVec3) -> bool {
        if lo.cmpgt(self.hi).any() || hi.cmplt(self.lo).any() {
            return true;
        }
        self.planes.iter().any(|&(n, d, slack)| {
            // The box's corner least far along n.
            let y = DVec3::select(n.cmpgt(DVec3::ZERO), lo, hi);
            n.dot(y) - d > slack
        })
    }

    /// Whether the triangle lies wholly outside the shaft.
    pub fn misses_triangle(&self, p: &[DVec3; 3]) -> bool {
        let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
        if lo.cmpgt(self.hi).any() || hi.cmplt(self.lo).any() {
            return true;
        }
        self.planes
            .iter()
            .any(|&(n, d, slack)| p.iter().all(|&y| n.dot(y) - d > slack))
    }
}

/// A triangle found in a shaft: its index among the BVH's items, and its
/// plane, for a quick test of a segment's ends.
///
/// 32 bytes: the normal is kept in `f32` (a penumbra's shaft lists for a
/// luminous ceiling's piece were 45% of ugrad's heap at its peak, with 48
/// bytes each). The plane is the one with that rounded normal through the
/// first corner, and the slack covers the corners' distances from it as
/// computed, so the test stays conservative: only the exact ray test
/// decides, and the answers are those of the `f64` normal.
#[derive(Clone, Copy, Debug)]
pub struct ShaftTri {
    pub k: u32,
    n: glam::Vec3,
    d: f64,
    /// A point farther than this from the plane (`|n·y − d|`) is off it.
    slack: f64,
}

impl ShaftTri {
    fn new(k: u32, p: &[DVec3; 3], tol: f64) -> ShaftTri {
        let n32 = (p[1] - p[0]).cross(p[2] - p[0]).as_vec3();
        let n = n32.as_dvec3();
        let d = n.dot(p[0]);
        // The corners' own distance from the plane (rounding, and the
        // normal's), and rounding of a test point's.
        let off = p.iter().map(|&y| (n.dot(y) - d).abs()).fold(0.0, f64::max);
        ShaftTri {
            k,
            n: n32,
            d,
            slack: off + tol * n.length(),
        }
    }

    /// False when the segment a–b certainly does not cross the triangle's
    /// plane (both ends beyond it on one side, by more than the slack).
    #[inline]
    pub fn may_cross(&self, a: DVec3, b: DVec3) -> bool {
        let n = self.n.as_dvec3();
        let (x, y) = (n.dot(a) - self.d, n.dot(b) - self.d);
        !((x > self.slack && y > self.slack) || (x < -self.slack && y < -self.slack))
    }
}

/// The items of a BVH (`nodes` and `base`, built by [`build_nodes`])
/// whose triangle may meet the shaft: `tri(k)` gives item `k`'s corners,
/// or `None` to leave it out. `None` when more than `max` are found (rays are then the
/// cheaper way).
pub fn shaft_triangles(
    nodes: &[Node],
    base: DVec3,
    shaft: &Shaft,
    max: usize,
    tol: f64,
    tri: impl Fn(u32) -> Option<[DVec3; 3]>,
) -> Option<Vec<ShaftTri>> {
    let mut list = Vec::new();
    if nodes.is_empty() {
        return Some(list);
    }
    let mut stack = vec![0u32];
    while let Some(ni) = stack.pop() {
        let n = &nodes[ni as usize];
        if shaft.misses_box(n.lo() + base, n.hi() + base) {
            continue;
        }
        if n.count == 0 {
            stack.push(n.first);
            stack.push(n.first + 1);
            continue;
        }
        for k in n.first..n.first + n.count {
            let Some(p) = tri(k) else {
                continue;
            };
            if !shaft.misses_triangle(&p) {
                list.push(ShaftTri::new(k, &p, tol));
                if list.len() > max {
                    return None;
                }
            }
        }
    }
    Some(list)
}

impl Bvh {
    /// [`shaft_triangles`] over this BVH's triangles whose id passes `keep`.
    pub fn shaft_triangles(
        &self,
        shaft: &Shaft,
        max: usize,
        tol: f64,
        keep: impl Fn(u32) -> bool,
    ) -> Option<Vec<ShaftTri>> {
        shaft_triangles(&self.nodes, self.base, shaft, max, tol, |k| {
            let t = &self.tris[k as usize];
            keep(t.id).then_some(t.p)
        })
    }

    /// Whether the segment `from + t (to − from)`, `tmin < t < tmax`, within
    /// a shaft whose triangles (those passing the caller's filter) are
    /// `list`, meets none of them: [`Bvh::occluded`]'s answer.
    pub fn clear_among(
        &self,
        list: &[ShaftTri],
        from: DVec3,
        to: DVec3,
        tmin: f64,
        tmax: f64,
    ) -> bool {
        let Some(frame) = RayFrame::new(to - from) else {
            return true;
        };
        !list.iter().any(|s| {
            s.may_cross(from, to)
                && ray_triangle_with(from, &frame, &self.tris[s.k as usize])
                    .is_some_and(|t| t > tmin && t < tmax)
        })
    }
}
