//! The indirect tail: the light still unshot once no patch carries a
//! noticeable share of it, moved patch to patch until it converges.
//!
//! Progressive shooting converges slowly once the emitters have shot: the
//! reflected light is spread over all patches, and every shot still costs
//! a pass over the whole model (a building of 380 rooms and 71k patches
//! needed hundreds of thousands of shots). Indirect light is smooth, and the
//! report's adaptive subdivision is driven by the bright shooters, so the
//! tail works at the patch level:
//!
//! * **Transport** from patch `p` to a receiving point `x` is `F(p → x)·V(p, x)`:
//!   the same exact point-to-polygon form factor (with the §5.4 offset) and
//!   the same visibility ray from `p`'s centre that a progressive shot of
//!   the unrefined patch uses.
//! * **The iteration** receives at patch centres: a patch's reflected power
//!   is ρ × its area × the irradiance at its centre (the midpoint rule).
//!   Corners would be the wrong sample: the cleaning chain cuts faces
//!   exactly along what covers them (a wall slab standing on a floor, a
//!   box on a desk), so patch corners lie on the edges of hidden regions,
//!   and a hidden patch would reflect the light its lit corners see. The
//!   centre rows are computed once and stored (8 bytes a pair); each
//!   iteration is a sparse matrix–vector product, all patches shooting at
//!   once (Jacobi).
//! * **The picture** receives at patch corners: once the iteration has
//!   converged, each corner gathers once from every patch the total
//!   radiosity that patch shot during the tail (the transport is linear, so
//!   one gather of the sum equals the sum of the gathers); its row is
//!   computed, used and dropped. An element vertex takes the tail's
//!   irradiance interpolated from its patch's corners (each split vertex the
//!   mean of its parents: linear along edges, bilinear in quads), and is
//!   then checked: the vertices of each patch's first split gather exactly,
//!   and level by level, so do the vertices below one whose exact value
//!   differed from the mean by more than 0.5% of its irradiance (on the
//!   Cornell box at `-l 3%` a floor vertex beside the short block was 10%
//!   dark from the mean; 2,817 of 7,728 split vertices gathered).
//! * **Refinement** (§6 for the tail's light): then every leaf element
//!   across one of whose edges the tail's reflected light (ρ × its
//!   irradiance) is steep by the gradient rule is split, down to the
//!   minimum edge, the steepest first and within a budget (`tail_refine`
//!   times the corners gathered), and each new vertex gathers the tail
//!   exactly ([`Transport::at`]) instead of taking the mean of its parents.
//!   Without it reflected light was resolved at patch size: a furnished
//!   room's ceiling next to its lamp came out 17% dark at `-l 3%`.
//! * **Which patches a vertex sees** (a corner, or a split vertex that
//!   gathers): those seen from the centres of the patches that share a
//!   corner with its own (on its own surface), whose rows are kept, delta-coded,
//!   once the iteration is over. Nearby centres together see nearly what
//!   the vertex sees, and many of them miss less than one point's discovery
//!   rays: on a nine-room building at `-l 2%` the answer was 0.11% below the
//!   one with every patch tried (rms 0.18% at 370 points), the rays' 0.19%
//!   (rms 1.8%, −29% at worst), and the corners and split vertices gathered
//!   in a tenth of the time (the rays were three quarters of the tail's
//!   time on a 26,000-patch building). A vertex stitched onto another
//!   surface's edge without a patch of its own surface at hand still casts
//!   rays.
//! * **The far field shoots in clusters.** Each surface's patches form a
//!   binary tree (split at the median centre along the longest axis). A
//!   cluster shoots as one at a receiver at least 1/`far` of its radius
//!   away (`ugrad --tail-far`, 0.25 by default: a cluster then subtends at
//!   most about 30°) and wholly on one side of the receiver's plane. Its
//!   form factor is exact: the contour integral over its outline (its
//!   patches' edges less those two of them share) is their summed form
//!   factor. Its visibility is the share of its quarters' (its
//!   grandchildren's) point form factors whose sample patch (the one
//!   nearest the quarter's centre) sends a clear ray to the receiver. Its
//!   radiosity is its seen quarters' weighted by those shares, each
//!   quarter's area mean tilted by its first moment towards the side the
//!   receiver weights more ([`NodeLight`]): with the cluster's area mean
//!   alone a furnished room's tail came out 2.7% dark (the near side of a
//!   cluster weighs more, and is also nearer the lamp and the room's
//!   middle). A row's candidates are raised to their highest such
//!   ancestor, a cluster that is not such is opened, and no node of a row
//!   lies inside another. A row then grows with the log of the patches a
//!   point sees, not their number: in one room of 21,202 patches (the
//!   Cornell box at `-l 1%`) the stored rows went from 210 million pairs
//!   (1.7 GB) to 5.3 million, the solve from 390 s to 49 s; every patch
//!   alone (`--tail-far 0`) gives the former bytes (docs/decisions.md,
//!   "The tail's far field shoots in clusters").
//! * **Which patches a patch centre sees** is found by casting `rays`
//!   cosine-distributed rays from it (stratified, jittered by a hash of the
//!   receiver: deterministic); for each surface hit, its patches within the
//!   box of the hit points (grown by a quarter of its diagonal and the
//!   largest patch hit), and those there of the surfaces whose boxes touch
//!   its box, are tried, each with its own visibility ray. A surface no ray
//!   hits and touching none hit is left out: its form factor is below about
//!   1/`rays`. With `rays` = 0 every patch is tried: the automatic choice
//!   where there are at most 2,048 patches or where the rays of a sample of
//!   receivers find most of the patches anyway (a single room), for it is
//!   then no slower.

use geom::bvh::{Bvh, Triangle};
use glam::DVec3;
use libmesh::{Mesh, VertId, VertexOrigin};
use rayon::prelude::*;

use crate::formfactor::{edges_integral, offset_receiver, point_to_polygon, receives};

type Rgb = [f64; 3];

/// A stored centre row whose F·V sum passes this is scaled back to 1 (see
/// [`Transport::build`]): patches lying on one another, not approximation.
const ROW_OVERLAP: f64 = 1.5;

/// The shaped form factors of one patch at a point (see [`Near`]).
pub type ShapedPair<'a> = dyn Fn(u32, DVec3, DVec3) -> (Option<f64>, Option<f64>) + Sync + 'a;

/// The tail's light shaped as it lies on each patch: for a receiver near
/// patch `p` (at `x`, normal `n`), `ff` gives the form factor weighted by
/// the first bounce (the patch's unshot radiosity at the tail's start,
/// relative to its mean) and, once the corners have gathered, the one
/// weighted by the later bounces (the tail's own light); `None` where the
/// light is uniform or not known. `first`: per patch, the radiosity of the
/// first bounce.
pub struct Near<'a> {
    pub ff: &'a ShapedPair<'a>,
    pub first: &'a [Rgb],
}

/// Per patch corner (in [`Transport::corners`]' order), the patches near
/// it that it sees, with F·V: `pairs[start[i]..start[i + 1]]`.
pub struct NearPairs {
    start: Vec<u32>,
    pairs: Vec<(u32, f32)>,
}

/// Receivers nearer a patch's centre than this many patch sizes take its
/// first bounce shaped ([`Near`]).
const NEAR: f64 = 2.0;

/// Geometry of one patch as a shooter.
struct Shooter {
    first: u32,
    n: u32,
    centre: DVec3,
    normal: DVec3,
    surface: u32,
    /// The §5.4 offset distance.
    delta: f64,
    /// Longest edge.
    size: f64,
}

/// A receiving point.
struct Receiver {
    x: DVec3,
    n: DVec3,
    surface: u32,
    /// Into the receiver's own surface (zero for a patch centre, which is inside it).
    inward: DVec3,
    /// Size of the receiver's patches (for the discovery rays' start point).
    size: f64,
    seed: u64,
}

/// A 64-bit mix (SplitMix64's finaliser): jitter that depends only on its input.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn unit(z: u64) -> f64 {
    (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Discovery rays per receiving point when not every patch is tried.
/// 256 missed small surfaces (furniture): the tail was 2.2% dark in a
/// furnished room against ugprobe (median); 512: 0.98%, 1024: 0.78%, every
/// patch 0.75%. 1024 doubled a 10k-face building's solve (130 s → 258 s),
/// 512 costs 24%.
const AUTO_RAYS: usize = 512;
/// A patch centre with neighbours on its surface casts at most this many
/// times fewer discovery rays, and takes their hits too. On a 26,583-patch
/// building: the centre rows built in 7.6 s instead of 10.4 s, finding 0.6%
/// more pairs; on the nine-room building at `-l 2%` the answer came 0.02%
/// nearer the one with every patch tried.
const SHARED: usize = 4;
/// Up to this many patches every patch is tried.
const ALL_PATCHES: usize = 2048;
/// Patch centres sampled to judge whether the scene is dense.
const DENSITY_SAMPLE: usize = 64;

/// Receivers handled per parallel batch.
const CHUNK: usize = 2048;

/// The patch-to-patch transport of the tail.
pub(crate) struct Transport {
    shooters: Vec<Shooter>,
    pts: Vec<DVec3>,
    surf: Vec<u32>,
    bvh: Bvh,
    /// Per patch, its bounding box (for the candidates' box queries).
    boxes: Vec<(DVec3, DVec3)>,
    /// Per surface, the surfaces whose boxes touch its box (sorted; itself
    /// included): `touch[touch_start[s]..touch_start[s + 1]]`.
    touch_start: Vec<u32>,
    touch: Vec<u32>,
    rays: usize,
    /// Row `q` (patch `q`'s centre) is `patch[start[q]..start[q + 1]]`
    /// with `weight[..]` = F·V.
    start: Vec<usize>,
    patch: Vec<u32>,
    weight: Vec<f32>,
    /// Per stored pair whose shooter is a cluster, in row order, the
    /// shares of its quarters ([`Transport::cluster_weight`]).
    vis: Vec<Shares>,
    /// Row `q`'s cluster pairs' shares start at `vis[vis_start[q]]` (in
    /// the row's order; pairs whose shooter is a patch have none).
    vis_start: Vec<u32>,
    /// Per patch, the patches of its surface sharing a corner with it
    /// (itself included), sorted: `near[near_start[p]..near_start[p + 1]]`.
    near_start: Vec<u32>,
    near: Vec<u32>,
    /// Once the iteration is over ([`Transport::compact_rows`]), row `q`'s
    /// patches, their differences coded as LEB128 varints:
    /// `seen[seen_start[q]..seen_start[q + 1]]`. Empty when every patch is
    /// tried.
    seen_start: Vec<usize>,
    seen: Vec<u8>,
    /// The far field's clusters of patches.
    clusters: Clusters,
}

impl Transport {
    /// Builds the transport; `None` when `cancel` was raised meanwhile.
    pub fn build(
        mesh: &Mesh,
        offset: f64,
        rays: Option<usize>,
        far: f64,
        cancel: &(dyn Fn() -> bool + Sync),
    ) -> Option<Transport> {
        let np = mesh.num_patches();
        let mut pts: Vec<DVec3> = Vec::with_capacity(np * 4);
        let shooters: Vec<Shooter> = mesh
            .patches()
            .map(|p| {
                let first = pts.len() as u32;
                pts.extend(mesh.patch_corners(p).iter().map(|&v| mesh.vertex_pos(v)));
                let poly = &pts[first as usize..];
                let centre = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
                let size = (0..poly.len())
                    .map(|i| (poly[(i + 1) % poly.len()] - poly[i]).length())
                    .fold(0.0, f64::max);
                let s = mesh.patch_surface(p);
                Shooter {
                    first,
                    n: poly.len() as u32,
                    centre,
                    normal: mesh.surface_normal(s),
                    surface: s.0,
                    delta: offset * size,
                    size,
                }
            })
            .collect();
        let surf: Vec<u32> = shooters.iter().map(|s| s.surface).collect();
        let poly = |s: &Shooter| &pts[s.first as usize..(s.first + s.n) as usize];
        let mut tris = Vec::new();
        for (p, s) in shooters.iter().enumerate() {
            let c = poly(s);
            for k in 1..c.len() - 1 {
                tris.push(Triangle {
                    p: [c[0], c[k], c[k + 1]],
                    id: p as u32,
                });
            }
        }
        let bvh = Bvh::new(tris);
        let boxes: Vec<(DVec3, DVec3)> = shooters
            .iter()
            .map(|s| geom::index::bbox(poly(s).iter().copied(), 0.0))
            .collect();
        let (touch_start, touch) = touching_surfaces(&shooters, &pts);
        let (near_start, near) = patches_sharing_a_corner(mesh);
        let mut clusters = Clusters::build(mesh, &shooters, &pts, far);
        clusters.set_boxes(&boxes);
        let mut tr = Transport {
            shooters,
            pts,
            surf,
            bvh,
            boxes,
            touch_start,
            touch,
            rays: rays.unwrap_or(AUTO_RAYS),
            start: vec![0],
            patch: Vec::new(),
            weight: Vec::new(),
            vis: Vec::new(),
            vis_start: vec![0],
            near_start,
            near,
            seen_start: Vec::new(),
            seen: Vec::new(),
            clusters,
        };
        if rays.is_none() && tr.dense() {
            tr.rays = 0;
        }
        let mut q0 = 0;
        while q0 < np {
            if cancel() {
                return None;
            }
            // (Smaller batches where the rays' hits are kept for the batch:
            // 32 bytes a hit.)
            let q1 = (q0 + if tr.rays == 0 { CHUNK } else { CHUNK / 4 }).min(np);
            let rows: Vec<Vec<(u32, f32, Shares)>> = if tr.rays == 0 {
                (q0..q1)
                    .into_par_iter()
                    .map(|q| {
                        let r = tr.centre_receiver(q);
                        tr.row_seen(&r, tr.candidates(&r), |p| tr.sees_centre(p, q, q0))
                    })
                    .collect()
            } else {
                // Each centre's candidates come from its own rays and those
                // of its own surface's neighbours in this batch (their
                // rays land elsewhere: more of the scene is found): with k
                // neighbours, 1/min(k + 1, 4) of the rays each, so that
                // every centre draws on at least `rays` of them.
                let mates = |q: usize| -> Vec<usize> {
                    tr.near_patches(&[q as u32], 1)
                        .into_iter()
                        .map(|nb| nb as usize)
                        .filter(|&nb| nb != q && (q0..q1).contains(&nb))
                        .collect()
                };
                let own: Vec<Vec<(u32, u32, DVec3)>> = (q0..q1)
                    .into_par_iter()
                    .map(|q| {
                        let share = (mates(q).len() + 1).min(SHARED);
                        tr.hits(&tr.centre_receiver(q), tr.rays.div_ceil(share))
                    })
                    .collect();
                (q0..q1)
                    .into_par_iter()
                    .map(|q| {
                        let mut h = own[q - q0].clone();
                        for nb in mates(q) {
                            h.extend_from_slice(&own[nb - q0]);
                        }
                        let r = tr.centre_receiver(q);
                        tr.row_seen(&r, tr.found_by(h, &r), |p| tr.sees_centre(p, q, q0))
                    })
                    .collect()
            };
            for r in rows {
                // A centre cannot take more than its whole hemisphere. A
                // row whose F·V sum passes ROW_OVERLAP comes from patches
                // lying on one another (coincident or overlapping faces
                // that raw input may have: a helper's turned 2 × 2 rooms
                // meshed by ugrad itself had rows up to 2.5, and the
                // iteration reached 1e253, then NaN and a panic); it is
                // scaled back to 1. Sums a little over 1 are the far
                // field's and the shaped form factors' approximation
                // (the 8,600-face building: 36% of the rows, median 1.01,
                // largest 1.22) and are left as they are.
                let total: f64 = r.iter().map(|&(_, w, _)| w as f64).sum();
                let k = if total > ROW_OVERLAP {
                    1.0 / total
                } else {
                    1.0
                };
                for (p, w, m) in r {
                    tr.patch.push(p);
                    tr.weight.push((w as f64 * k) as f32);
                    if p as usize >= np {
                        tr.vis.push(m);
                    }
                }
                tr.start.push(tr.patch.len());
                tr.vis_start.push(tr.vis.len() as u32);
            }
            q0 = q1;
        }
        tr.patch.shrink_to_fit();
        tr.weight.shrink_to_fit();
        tr.vis.shrink_to_fit();
        tr.vis_start.shrink_to_fit();
        Some(tr)
    }

    /// Rays per receiving point that find its patches (0: every patch is tried).
    pub fn rays(&self) -> usize {
        self.rays
    }

    /// Whether trying every patch is the better way to find the patches a
    /// point sees: few patches, or a scene where the discovery rays of a
    /// sample of patch centres find candidates among at least a third of
    /// them (a single room, the Cornell box: each receiver sees most of
    /// the scene). Then every patch costs about as much as the rays and
    /// their candidates (Cornell box at `-l 2%`, 5,533 patches: 8.9 s
    /// against 11.3 s; at 1.5%, 9,581 patches: 28 s against 33 s) and
    /// misses nothing. In a building a point sees a room's patches, a
    /// small fraction of all.
    fn dense(&self) -> bool {
        let np = self.shooters.len();
        if np <= ALL_PATCHES {
            return true;
        }
        let step = np.div_ceil(DENSITY_SAMPLE);
        let found: Vec<usize> = (0..np)
            .step_by(step)
            .collect::<Vec<_>>()
            .par_iter()
            .map(|&q| {
                let r = self.centre_receiver(q);
                self.found_patches(self.hits(&r, self.rays), None).len()
            })
            .collect();
        let mean = found.iter().sum::<usize>() as f64 / found.len() as f64;
        mean >= np as f64 / 3.0
    }

    /// Patch `q`'s centre as a receiver.
    fn centre_receiver(&self, q: usize) -> Receiver {
        let s = &self.shooters[q];
        Receiver {
            x: s.centre,
            n: s.normal,
            surface: s.surface,
            inward: DVec3::ZERO,
            size: s.size,
            seed: mix(q as u64 ^ 0x5bd1_e995_0000_0000),
        }
    }

    /// The surfaces whose boxes touch surface `s`'s box.
    fn touching(&self, s: u32) -> &[u32] {
        let s = s as usize;
        &self.touch[self.touch_start[s] as usize..self.touch_start[s + 1] as usize]
    }

    /// The nodes a receiver may see: every patch, or those found by
    /// [`Transport::rays`] discovery rays (see the module's notes), each
    /// raised to the cluster that shoots for it ([`Clusters::resolve`]).
    fn candidates(&self, r: &Receiver) -> Nodes {
        if self.rays == 0 {
            Nodes(self.clusters.resolve(r.x, r.n, self.clusters.roots.clone()))
        } else {
            self.found_by(self.hits(r, self.rays), r)
        }
    }

    /// What `rays` discovery rays from the receiver hit: (surface, patch,
    /// point) each.
    fn hits(&self, r: &Receiver, rays: usize) -> Vec<(u32, u32, DVec3)> {
        let (x0, n, s) = (r.x, r.n, r.surface);
        let surf = &self.surf;
        let side = (rays as f64).sqrt().ceil() as usize;
        let (t1, t2) = n.any_orthonormal_pair();
        // From a point just inside the receiver's patches and off its
        // plane: from the exact corner of a room, the walls that meet
        // there lie edge-on (rays along them hit at t = 0), though the
        // limit from inside sees them as half the hemisphere.
        let o = x0 + (r.inward + n) * (1e-4 * r.size);
        let mut hits: Vec<(u32, u32, DVec3)> = Vec::with_capacity(side * side);
        for a in 0..side {
            for b in 0..side {
                let z = mix(r.seed ^ (((a * side + b) as u64) << 20));
                let u1 = (a as f64 + unit(z)) / side as f64;
                let u2 = (b as f64 + unit(mix(z))) / side as f64;
                let (rr, phi) = (u1.sqrt(), std::f64::consts::TAU * u2);
                let d =
                    t1 * (rr * phi.cos()) + t2 * (rr * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt();
                if let Some(h) = self
                    .bvh
                    .intersect(o, d, 0.0, f64::INFINITY, |id| surf[id as usize] != s)
                {
                    hits.push((surf[h.id as usize], h.id, o + d * h.t));
                }
            }
        }
        hits
    }

    /// The nodes that discovery rays' `hits` make the candidates of the
    /// receiver `r`, resolved for it ([`Clusters::resolve`]).
    fn found_by(&self, hits: Vec<(u32, u32, DVec3)>, r: &Receiver) -> Nodes {
        Nodes(self.found_patches(hits, Some((r.x, r.n))))
    }

    /// The box queries that discovery rays' `hits` make: per surface hit,
    /// the box of its hits grown by a quarter of its diagonal and the
    /// largest patch hit (so the parts of a surface between and just
    /// beyond the rays are tried too), for its patches and those of the
    /// surfaces whose boxes touch its box (a strip, a reveal, a block's
    /// side beside a floor: small surfaces next to big ones that no ray
    /// hit. On the Cornell box at `-l 3%` the rays alone missed 0.2% of
    /// the patch centres' form factors, and the tail came out 0.3% dark;
    /// with these 0.05%).
    fn queries(&self, mut hits: Vec<(u32, u32, DVec3)>) -> Vec<(u32, DVec3, DVec3)> {
        hits.sort_unstable_by_key(|h| (h.0, h.1));
        hits.chunk_by(|a, b| a.0 == b.0)
            .map(|group| {
                let (lo, hi) = geom::index::bbox(group.iter().map(|h| h.2), 0.0);
                let grow = 0.25 * (hi - lo).length()
                    + group
                        .iter()
                        .map(|h| self.shooters[h.1 as usize].size)
                        .fold(0.0, f64::max);
                let pad = DVec3::splat(grow);
                (group[0].0, lo - pad, hi + pad)
            })
            .collect()
    }

    /// The patches whose boxes meet the [`Transport::queries`] of `hits`,
    /// or, with `raise` (a receiver's point and normal), each raised to its
    /// highest ancestor that is far from the receiver, as
    /// [`Clusters::resolve`] would: walking each surface's tree from its
    /// root, the first far node on the way to a patch is that patch's
    /// highest far ancestor, so the walk stops there, and no node it gives
    /// lies inside another. (With every patch alone there are no trees and
    /// nothing to raise: a box query over the triangles. The walk replaced
    /// that query, which returned every surface's triangles in the box,
    /// and a walk up from each patch found: the 8.6k building's rows the
    /// same, built in 12.9 s instead of 23.9 s.)
    fn found_patches(
        &self,
        hits: Vec<(u32, u32, DVec3)>,
        raise: Option<(DVec3, DVec3)>,
    ) -> Vec<u32> {
        let surf = &self.surf;
        let mut cand: Vec<u32> = Vec::new();
        let mut stack: Vec<u32> = Vec::new();
        for (s, qlo, qhi) in self.queries(hits) {
            let meets = |(plo, phi): (DVec3, DVec3)| plo.cmple(qhi).all() && phi.cmpge(qlo).all();
            let touching = self.touching(s);
            if self.clusters.root_of.is_empty() {
                self.bvh.for_each_in_box(qlo, qhi, |p| {
                    if meets(self.boxes[p as usize])
                        && touching.binary_search(&surf[p as usize]).is_ok()
                    {
                        cand.push(p);
                    }
                });
                continue;
            }
            // Each surface's tree: the nodes whose boxes meet the query's.
            for &t in touching {
                let Some(&root) = self.clusters.root_of.get(t as usize) else {
                    continue;
                };
                if root == NONE {
                    continue;
                }
                stack.push(root);
                while let Some(k) = stack.pop() {
                    if !meets(self.clusters.node_box(k, &self.boxes)) {
                        continue;
                    }
                    match self.clusters.get(k) {
                        Some(c) if !raise.is_some_and(|(x, n)| self.clusters.far_from(k, x, n)) => {
                            stack.extend_from_slice(&c.children);
                        }
                        // (A far cluster's box may meet the query's where
                        // none of its patches' boxes does.)
                        Some(_) if !self.clusters.any_patch_meets(k, &self.boxes, &meets) => {}
                        _ => cand.push(k),
                    }
                }
            }
        }
        cand.sort_unstable();
        cand.dedup();
        cand
    }

    /// The candidates of a point of the patches `at` (a patch corner, or a
    /// split vertex inside or on the edge of a patch): the patches seen from
    /// the centres of the patches that share a corner with them. A point
    /// sees, nearly, what the patch centres around it see; this replaces
    /// its discovery rays (three quarters of the tail's time on a 26k-patch
    /// building). (What [`Transport::near_nodes`] resolves.)
    #[cfg(test)]
    fn near_candidates(&self, at: &[u32]) -> Vec<u32> {
        let hint = self.near_patches(at, 1);
        let mut cand = Vec::new();
        for q in hint {
            let q = q as usize;
            let mut prev = 0u32;
            let mut bytes = self.seen[self.seen_start[q]..self.seen_start[q + 1]].iter();
            while let Some(d) = read_varint(&mut bytes) {
                prev += d;
                cand.push(prev);
            }
        }
        cand.sort_unstable();
        cand.dedup();
        cand
    }

    /// [`Transport::near_candidates`] resolved for a receiver at `x`
    /// (normal `n`), as [`Clusters::resolve`] would, without sorting their
    /// union: the candidates and their ancestors are marked in a per-thread
    /// table, then each tree they lie in is walked from its root through
    /// the marked nodes (and the whole of each candidate a receiver opens),
    /// stopping at the first far cluster. The same nodes, so the same
    /// bytes out; the 8.6k building solved in 57.8 s instead of 61.0 s
    /// (the union of about ten rows sorted, and every candidate's
    /// ancestors asked whether they are far, once per candidate).
    fn near_nodes(&self, x: DVec3, n: DVec3, at: &[u32]) -> Vec<u32> {
        const CAND: u8 = 1;
        const NEEDED: u8 = 2;
        let cl = &self.clusters;
        let nodes = cl.parent.len();
        MARKS.with(|m| {
            let mut m = m.borrow_mut();
            if m.stamp.len() < nodes {
                m.stamp.resize(nodes, 0);
                m.flags.resize(nodes, 0);
            }
            m.generation = m.generation.wrapping_add(1);
            if m.generation == 0 {
                // (Wrapped: every stamp is stale.)
                m.stamp.fill(0);
                m.generation = 1;
            }
            let g = m.generation;
            let Marks { stamp, flags, .. } = &mut *m;
            let mut cands = Vec::new();
            for q in self.near_patches(at, 1) {
                let q = q as usize;
                let mut prev = 0u32;
                let mut bytes = self.seen[self.seen_start[q]..self.seen_start[q + 1]].iter();
                while let Some(d) = read_varint(&mut bytes) {
                    prev += d;
                    let k = prev as usize;
                    if stamp[k] != g {
                        stamp[k] = g;
                        flags[k] = 0;
                    }
                    if flags[k] & CAND == 0 {
                        flags[k] |= CAND;
                        cands.push(prev);
                    }
                }
            }
            // Each candidate's ancestors, up to one marked already.
            let mut roots = Vec::new();
            for &k in &cands {
                let mut u = k;
                loop {
                    let i = u as usize;
                    if stamp[i] != g {
                        stamp[i] = g;
                        flags[i] = 0;
                    }
                    if flags[i] & NEEDED != 0 {
                        break;
                    }
                    flags[i] |= NEEDED;
                    match cl.parent[i] {
                        NONE => {
                            roots.push(u);
                            break;
                        }
                        up => u = up,
                    }
                }
            }
            let mut out = Vec::with_capacity(cands.len());
            let mut stack: Vec<(u32, bool)> = roots.into_iter().map(|r| (r, false)).collect();
            while let Some((k, opened)) = stack.pop() {
                let i = k as usize;
                let marked = if stamp[i] == g { flags[i] } else { 0 };
                if !opened && marked & NEEDED == 0 {
                    continue;
                }
                match cl.get(k) {
                    Some(c) if !cl.far_from(k, x, n) => {
                        let open = opened || marked & CAND != 0;
                        stack.extend(c.children.iter().map(|&ch| (ch, open)));
                    }
                    _ => out.push(k),
                }
            }
            out.sort_unstable();
            out
        })
    }

    /// The patches within `rings` steps of `at` (a step: to a patch that
    /// shares a corner), sorted. (Two rings instead of one at the vertices:
    /// 5% slower on a nine-room building at `-l 2%`, and its mean 0.01%
    /// nearer the answer with every patch tried, −0.11% against −0.12%.)
    fn near_patches(&self, at: &[u32], rings: usize) -> Vec<u32> {
        let mut hint = at.to_vec();
        for _ in 0..rings {
            hint = hint
                .iter()
                .flat_map(|&p| {
                    let p = p as usize;
                    &self.near[self.near_start[p] as usize..self.near_start[p + 1] as usize]
                })
                .copied()
                .collect();
            hint.sort_unstable();
            hint.dedup();
        }
        hint
    }

    /// Whether patch `p`'s stored row (a centre row of an earlier batch:
    /// `p < q0`) holds patch `q`: then the segment between the two centres
    /// is clear, for that row cast the ray along it (the other way).
    fn sees_centre(&self, p: u32, q: usize, q0: usize) -> bool {
        let p = p as usize;
        p < q0
            && self.patch[self.start[p]..self.start[p + 1]]
                .binary_search(&(q as u32))
                .is_ok()
    }

    /// The candidates `cand` that a receiver sees, with F·V of each.
    fn row(&self, r: &Receiver, cand: Nodes) -> Vec<(u32, f32, Shares)> {
        self.row_seen(r, cand, |_| false)
    }

    /// [`Transport::row`], with no visibility ray for the candidates that
    /// `seen` knows to be visible: a patch centre receiving from a patch
    /// whose own centre row, stored already, holds it (the segment between
    /// the centres is the same; its ray was cast once, from the other end).
    /// Visibility between centres is symmetric (the same segment, the
    /// same surfaces left out), so the answers are the rays': the same
    /// output, and the 8.6k building's rows built in 29.6 s instead of
    /// 31.5 s.
    fn row_seen(
        &self,
        r: &Receiver,
        cand: Nodes,
        seen: impl Fn(u32) -> bool,
    ) -> Vec<(u32, f32, Shares)> {
        let mut out = Vec::new();
        for p in cand.0 {
            let w = match self.clusters.get(p) {
                Some(_) => self.cluster_weight(r, p),
                None => self.patch_weight(r, p, seen(p)).map(|w| (w, [0; 4])),
            };
            if let Some((w, shares)) = w {
                out.push((p, w, shares));
            }
        }
        out
    }

    /// F·V of patch `p` at a receiver (`seen`: known to see it, no ray).
    fn patch_weight(&self, r: &Receiver, p: u32, seen: bool) -> Option<f32> {
        let (x0, n, s) = (r.x, r.n, r.surface);
        let sh = &self.shooters[p as usize];
        if sh.surface == s {
            return None;
        }
        let (c, delta) = (sh.centre, sh.delta);
        // In front of the shooter's plane and facing it (as a shot tests).
        if !receives(x0, n, c, sh.normal, delta) {
            return None;
        }
        let surf = &self.surf;
        if !seen
            && self.bvh.occluded(c, x0 - c, 1e-7, 1.0 - 1e-7, |id| {
                let t = surf[id as usize];
                t != sh.surface && t != s
            })
        {
            return None;
        }
        let x = offset_receiver(x0, || r.inward, c, sh.normal, delta);
        let f = point_to_polygon(
            x,
            n,
            &self.pts[sh.first as usize..(sh.first + sh.n) as usize],
        );
        (f > 0.0).then_some(f as f32)
    }

    /// F·V of cluster `c` at a receiver, and which of its quarters the
    /// receiver sees (bit `i`: quarter `i`): the exact form factor of its
    /// hull times the share of the hull its patches cover, times the
    /// visible share of its quarters' point form factors (each seen when
    /// the ray from its sample patch's centre reaches the receiver).
    fn cluster_weight(&self, r: &Receiver, k: u32) -> Option<(f32, Shares)> {
        let c = self.clusters.get(k)?;
        let (x0, n, s) = (r.x, r.n, r.surface);
        if c.surface == s || c.normal.dot(x0 - c.centre) <= -c.delta {
            return None;
        }
        let hull = &self.clusters.hull[c.hull_first as usize..(c.hull_first + c.hull_n) as usize];
        if hull.iter().all(|&q| n.dot(q - x0) <= 0.0) {
            return None;
        }
        let x = offset_receiver(x0, || r.inward, c.centre, c.normal, c.delta);
        let f = self.node_ff(k, x, n);
        if f.is_nan() || f <= 0.0 {
            return None;
        }
        // The quarters weighted by their point form factors (the exact
        // ones cost as much again, and gave the same answers).
        let surf = &self.surf;
        let (mut all, mut seen) = (0.0, [0.0; 4]);
        let ns = c.nsamples as usize;
        for ((seen, &q), &sample) in seen.iter_mut().zip(&c.quarters[..ns]).zip(&c.samples[..ns]) {
            let omega = self.clusters.point_ff(q, c.normal, x, n, &self.shooters);
            if omega <= 0.0 {
                continue;
            }
            all += omega;
            let sc = self.shooters[sample as usize].centre;
            if !self.bvh.occluded(sc, x0 - sc, 1e-7, 1.0 - 1e-7, |id| {
                let t = surf[id as usize];
                t != c.surface && t != s
            }) {
                *seen = omega;
            }
        }
        let vis: f64 = seen.iter().sum();
        if vis <= 0.0 {
            return None;
        }
        // Each seen quarter's share of the pair, in 255ths (at least 1).
        let shares = seen.map(|o| {
            if o > 0.0 {
                ((255.0 * o / vis).round() as u8).max(1)
            } else {
                0
            }
        });
        Some(((f * vis / all) as f32, shares))
    }

    /// The form factor of node `k` (a patch, or a cluster by its outline)
    /// at the point `x` (normal `n`).
    fn node_ff(&self, k: u32, x: DVec3, n: DVec3) -> f64 {
        match self.clusters.get(k) {
            None => {
                let sh = &self.shooters[k as usize];
                point_to_polygon(
                    x,
                    n,
                    &self.pts[sh.first as usize..(sh.first + sh.n) as usize],
                )
            }
            Some(c) => {
                let hull =
                    &self.clusters.hull[c.hull_first as usize..(c.hull_first + c.hull_n) as usize];
                if c.fill >= 1.0 - 1e-9 {
                    // Its patches tile their hull (a grid's block): the
                    // hull's few edges give the same number.
                    point_to_polygon(x, n, hull)
                } else if hull.iter().all(|&q| n.dot(q - x) >= 0.0) {
                    let e = &self.clusters.edges
                        [c.edges_first as usize..(c.edges_first + c.edges_n) as usize];
                    edges_integral(x, n, &self.pts, e)
                } else {
                    // (Across the receiver's plane: the hull's clipped
                    // form factor, scaled to the patches' area.)
                    point_to_polygon(x, n, hull) * c.fill
                }
            }
        }
    }

    /// What shaping the first bounce ([`Near`]) changes in the irradiance
    /// that patch centres gather from it: per centre, over its stored row's
    /// patches near it, (shaped − uniform form factor) × first bounce.
    pub fn first_bounce_correction(&self, near: &Near) -> Vec<Rgb> {
        (0..self.shooters.len())
            .into_par_iter()
            .map(|q| {
                let r = self.centre_receiver(q);
                let mut h = [0.0; 3];
                for k in self.start[q]..self.start[q + 1] {
                    let p = self.patch[k];
                    let Some(sh) = self.shooters.get(p as usize) else {
                        continue; // a cluster: far
                    };
                    let x = offset_receiver(r.x, || r.inward, sh.centre, sh.normal, sh.delta);
                    if x.distance_squared(sh.centre) >= (NEAR * sh.size).powi(2) {
                        continue;
                    }
                    let Some(f) = (near.ff)(p, x, r.n).0 else {
                        continue;
                    };
                    let d = f - self.weight[k] as f64;
                    let u = near.first[p as usize];
                    for c in 0..3 {
                        h[c] += d * u[c];
                    }
                }
                h
            })
            .collect()
    }

    /// Irradiance added at each patch centre by patches of unshot radiosity `u`.
    pub fn gather(&self, u: &[Rgb]) -> Vec<Rgb> {
        let u = &self.clusters.values(u, &self.shooters);
        (0..self.shooters.len())
            .into_par_iter()
            .map(|q| {
                let mut h = [0.0; 3];
                let sh = &self.shooters[q];
                let mut shares = self.vis[self.vis_start[q] as usize..].iter();
                for k in self.start[q]..self.start[q + 1] {
                    let w = self.weight[k] as f64;
                    let p = self.patch[k];
                    let b = match self.clusters.get(p) {
                        Some(c) => {
                            let m = *shares.next().expect("a cluster pair's shares");
                            self.clusters.light(u, c, sh.centre, sh.normal, m)
                        }
                        None => u.mean[p as usize],
                    };
                    h[0] += w * b[0];
                    h[1] += w * b[1];
                    h[2] += w * b[2];
                }
                h
            })
            .collect()
    }

    /// The irradiance at every patch corner (the mesh's input-vertex copies
    /// that are some patch's corner) from patches of radiosity `s`: the
    /// corners, in id order, their irradiance, and (with `near`) the
    /// patches near each that it sees, for [`Transport::rest_corrections`].
    /// `None` when `cancel` was raised meanwhile.
    pub fn corners(
        &self,
        mesh: &Mesh,
        s: &NodeLight,
        near: Option<&Near>,
        cancel: &(dyn Fn() -> bool + Sync),
    ) -> Option<(Vec<VertId>, Vec<Rgb>, NearPairs)> {
        let nv = mesh.num_vertices();
        // The patches at each corner (for its inward direction and size).
        let (count, at) = patches_at_corners(mesh);
        let recv: Vec<VertId> = (0..nv)
            .filter(|&v| {
                count[v + 1] > count[v]
                    && matches!(mesh.vertex_origin(VertId(v as u32)), VertexOrigin::Input(_))
            })
            .map(|v| VertId(v as u32))
            .collect();
        let mut out = Vec::with_capacity(recv.len());
        let mut kept = NearPairs {
            start: vec![0],
            pairs: Vec::new(),
        };
        for chunk in recv.chunks(CHUNK) {
            if cancel() {
                return None;
            }
            let part: Vec<(Rgb, Vec<(u32, f32)>)> = chunk
                .par_iter()
                .map(|&v| {
                    let patches = &at[count[v.idx()] as usize..count[v.idx() + 1] as usize];
                    let (inward, size) = self.corner_frame(mesh.receiver_pos(v), patches);
                    let mut keep = Vec::new();
                    let h = self.at_keeping(
                        mesh,
                        v,
                        inward,
                        size,
                        patches,
                        s,
                        near,
                        near.is_some().then_some(&mut keep),
                    );
                    (h, keep)
                })
                .collect();
            for (h, keep) in part {
                out.push(h);
                kept.pairs.extend(keep);
                kept.start.push(kept.pairs.len() as u32);
            }
        }
        kept.pairs.shrink_to_fit();
        Some((recv, out, kept))
    }

    /// What shaping the later bounces changes at each of the corners `recv`
    /// (as [`Transport::corners`] returned them, with the patches near each
    /// that it sees, `kept`), from those patches only: a second, cheap pass
    /// over the corners once their first gather has given the tail's light
    /// its shape.
    pub fn rest_corrections(
        &self,
        mesh: &Mesh,
        recv: &[VertId],
        kept: &NearPairs,
        s: &NodeLight,
        near: &Near,
    ) -> Vec<Rgb> {
        let (count, at) = patches_at_corners(mesh);
        recv.par_iter()
            .enumerate()
            .map(|(i, &v)| {
                let patches = &at[count[v.idx()] as usize..count[v.idx() + 1] as usize];
                let (inward, size) = self.corner_frame(mesh.receiver_pos(v), patches);
                let r = self.vertex_as_receiver(mesh, v, inward, size);
                let mut h = [0.0; 3];
                let pairs = &kept.pairs[kept.start[i] as usize..kept.start[i + 1] as usize];
                for &(p, w) in pairs {
                    let sh = &self.shooters[p as usize];
                    let x = offset_receiver(r.x, || r.inward, sh.centre, sh.normal, sh.delta);
                    if x.distance_squared(sh.centre) >= (NEAR * sh.size).powi(2) {
                        continue;
                    }
                    let Some(f) = (near.ff)(p, x, r.n).1 else {
                        continue;
                    };
                    let (b, u) = (s.mean[p as usize], near.first[p as usize]);
                    for k in 0..3 {
                        h[k] += (f - w as f64) * (b[k] - u[k]);
                    }
                }
                h
            })
            .collect()
    }

    /// The longest edge of patch `p`.
    pub fn patch_size(&self, p: libmesh::PatchId) -> f64 {
        self.shooters[p.idx()].size
    }

    /// Frees the stored centre rows (the iteration is over; the geometry
    /// stays for [`Transport::at`]), keeping, when not every patch is
    /// tried, each row's patches as the candidates of the points near that
    /// centre (delta-coded: about 1.3 bytes a pair instead of 8).
    pub fn compact_rows(&mut self) {
        if self.rays > 0 {
            let np = self.shooters.len();
            let mut seen = Vec::new();
            let mut seen_start = Vec::with_capacity(np + 1);
            seen_start.push(0);
            for q in 0..np {
                let mut prev = 0;
                for &p in &self.patch[self.start[q]..self.start[q + 1]] {
                    write_varint(&mut seen, p - prev);
                    prev = p;
                }
                seen_start.push(seen.len());
            }
            seen.shrink_to_fit();
            self.seen = seen;
            self.seen_start = seen_start;
        }
        self.start = Vec::new();
        self.patch = Vec::new();
        self.weight = Vec::new();
        self.vis = Vec::new();
        self.vis_start = Vec::new();
    }

    /// Mesh vertex `v` as a receiver (see [`Transport::at`]), and the
    /// patches to try for it: those seen from the patch centres `at`
    /// around it, when they all lie on its own surface (a vertex stitched
    /// onto a neighbour's edge may be named by that neighbour's element),
    /// else those its rays find.
    fn vertex_receiver(
        &self,
        mesh: &Mesh,
        v: VertId,
        inward: DVec3,
        size: f64,
        at: &[u32],
    ) -> (Receiver, Nodes) {
        let r = self.vertex_as_receiver(mesh, v, inward, size);
        let cand = if self.seen_start.is_empty()
            || !at
                .iter()
                .all(|&p| self.surf.get(p as usize) == Some(&r.surface))
        {
            self.candidates(&r)
        } else {
            Nodes(self.near_nodes(r.x, r.n, at))
        };
        (r, cand)
    }

    /// Mesh vertex `v` as a receiver.
    fn vertex_as_receiver(&self, mesh: &Mesh, v: VertId, inward: DVec3, size: f64) -> Receiver {
        Receiver {
            x: mesh.receiver_pos(v),
            n: mesh.vertex_normal(v),
            surface: mesh.vertex_surface(v).0,
            inward,
            size,
            seed: mix(v.0 as u64),
        }
    }

    /// A patch corner's inward direction (towards the centres of the
    /// patches `at` it is a corner of) and size (their longest edge).
    fn corner_frame(&self, x: DVec3, at: &[u32]) -> (DVec3, f64) {
        let inward = at
            .iter()
            .map(|&p| (self.shooters[p as usize].centre - x).normalize_or_zero())
            .sum::<DVec3>()
            .normalize_or_zero();
        let size = at
            .iter()
            .map(|&p| self.shooters[p as usize].size)
            .fold(0.0, f64::max);
        (inward, size)
    }

    /// The irradiance at the mesh vertex `v` from patches of radiosity `s`
    /// (a patch corner, or a vertex made by the refinement after the tail):
    /// its row, computed, used and dropped. `inward` points from `v` into
    /// its surface; `size` is the size of its patches; `at` are the patches
    /// it lies in (or on): after [`Transport::compact_rows`], their
    /// neighbours' centre rows are its candidates.
    #[allow(clippy::too_many_arguments)]
    pub fn at(
        &self,
        mesh: &Mesh,
        v: VertId,
        inward: DVec3,
        size: f64,
        at: &[u32],
        s: &NodeLight,
        near: Option<&Near>,
    ) -> Rgb {
        self.at_keeping(mesh, v, inward, size, at, s, near, None)
    }

    /// [`Transport::at`], keeping in `keep` the patches it sees whose
    /// centre lies within `NEAR` + 1 of their sizes (those whose shaped
    /// light [`Transport::rest_corrections`] may take), with their F·V.
    #[allow(clippy::too_many_arguments)]
    fn at_keeping(
        &self,
        mesh: &Mesh,
        v: VertId,
        inward: DVec3,
        size: f64,
        at: &[u32],
        s: &NodeLight,
        near: Option<&Near>,
        mut keep: Option<&mut Vec<(u32, f32)>>,
    ) -> Rgb {
        let (r, cand) = self.vertex_receiver(mesh, v, inward, size, at);
        let row = self.row(&r, cand);
        let mut h = [0.0; 3];
        for (p, w, shares) in row {
            if let Some(c) = self.clusters.get(p) {
                // A cluster (far): its radiosity as the receiver sees it.
                let b = self.clusters.light(s, c, r.x, r.n, shares);
                for k in 0..3 {
                    h[k] += w as f64 * b[k];
                }
                continue;
            }
            if let Some(keep) = keep.as_deref_mut() {
                let sh = &self.shooters[p as usize];
                if r.x.distance_squared(sh.centre) < (NEAR * sh.size + sh.size).powi(2) {
                    keep.push((p, w));
                }
            }
            let b = s.mean[p as usize];
            // The first bounce (and the later ones) shaped, near the patch.
            let (fu, fr) = self.near_ff(&r, p, w as f64, near);
            let u = near.map_or([0.0; 3], |nr| nr.first[p as usize]);
            for k in 0..3 {
                h[k] += fu * u[k] + fr * (b[k] - u[k]);
            }
        }
        h
    }

    /// The form factors a receiver takes for patch `p`'s first bounce and
    /// for its later ones: `w` (uniform) unless `near` shapes them there.
    fn near_ff(&self, r: &Receiver, p: u32, w: f64, near: Option<&Near>) -> (f64, f64) {
        let (Some(nr), Some(sh)) = (near, self.shooters.get(p as usize)) else {
            return (w, w);
        };
        let x = offset_receiver(r.x, || r.inward, sh.centre, sh.normal, sh.delta);
        if x.distance_squared(sh.centre) >= (NEAR * sh.size).powi(2) {
            return (w, w);
        }
        let (fu, fr) = (nr.ff)(p, x, r.n);
        (fu.unwrap_or(w), fr.unwrap_or(w))
    }

    /// Per node (patch, then cluster), the area-weighted mean of `b` (per
    /// patch): what [`Transport::at`] and [`Transport::corners`] take.
    pub fn node_values(&self, b: &[Rgb]) -> NodeLight {
        self.clusters.values(b, &self.shooters)
    }

    /// Clusters of patches that may shoot as one.
    pub fn clusters(&self) -> usize {
        self.clusters.list.len()
    }

    pub fn pairs(&self) -> usize {
        self.patch.len()
    }

    /// Heap bytes held (the stored rows and the geometry).
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.start.capacity() * 8
            + self.patch.capacity() * 4
            + self.weight.capacity() * 4
            + self.vis.capacity() * 4
            + self.vis_start.capacity() * 4
            + self.shooters.capacity() * size_of::<Shooter>()
            + self.pts.capacity() * size_of::<DVec3>()
            + self.surf.capacity() * 4
            + self.boxes.capacity() * std::mem::size_of::<(DVec3, DVec3)>()
            + self.bvh.len() * size_of::<Triangle>()
            + self.near_start.capacity() * 4
            + self.near.capacity() * 4
            + self.seen_start.capacity() * 8
            + self.seen.capacity()
            + self.clusters.list.capacity() * size_of::<Cluster>()
            + self.clusters.hull.capacity() * size_of::<DVec3>()
            + self.clusters.edges.capacity() * 8
            + self.clusters.canon.capacity() * 4
            + (self.clusters.parent.capacity()
                + self.clusters.roots.capacity()
                + self.clusters.reps.capacity())
                * 4
            + self.clusters.patch_area.capacity() * 8
            + self.clusters.boxes.capacity() * std::mem::size_of::<(DVec3, DVec3)>()
            + self.clusters.root_of.capacity() * 4
    }
}

/// Light per node of the transport: per patch and per cluster the
/// area-weighted mean radiosity, and per cluster its first moment about
/// its centre, Σ A (B − B̄)(x − c) / A, per channel.
pub struct NodeLight {
    np: usize,
    pub mean: Vec<Rgb>,
    tilt: Vec<[DVec3; 3]>,
}

impl NodeLight {
    /// Cluster `c` (node `k`)'s radiosity weighted as a receiver at `x`
    /// (normal `n`) weights it: the form factor's density over the
    /// cluster's plane is larger on its near side, and where the light
    /// is brighter there (a wall's upper half, nearer the lamp and the
    /// middle of the room) the area mean would come out dark: 2.7% over
    /// a furnished room at `--tail-far 0.25`. To first order the density
    /// weights B by 1 + ∇ln f · (x' − c), with, over the plane, ∇ln f =
    /// n / (n·(c − x)) − 4 (c − x) / |c − x|² (the shooter's cosine only
    /// moves along its normal); so B̄ + tilt · ∇ln f, kept within 0 and
    /// twice the mean.
    fn tilted(&self, c: &Cluster, k: u32, x: DVec3, n: DVec3) -> Rgb {
        let mean = self.mean[k as usize];
        let d = c.centre - x;
        let (h, d2) = (n.dot(d), d.length_squared());
        if h <= 0.0 || d2 <= 0.0 {
            return mean;
        }
        let g = n / h - d * (4.0 / d2);
        let g = g - c.normal * g.dot(c.normal);
        let t = &self.tilt[k as usize - self.np];
        [0, 1, 2].map(|j| (mean[j] + t[j].dot(g)).clamp(0.0, 2.0 * mean[j]))
    }
}

/// A pair's split among a cluster's quarters: in 255ths of its F·V, each
/// the quarter's form factor if its sample patch sees the receiver, else
/// 0.
type Shares = [u8; 4];

/// Nodes of the far field's trees (patches and clusters) that a receiver
/// takes as they are: resolved for it ([`Clusters::resolve`]).
struct Nodes(Vec<u32>);

/// Per thread, marks over the nodes for [`Transport::near_nodes`]: a
/// node's flags hold for the call whose generation its stamp holds.
struct Marks {
    generation: u32,
    stamp: Vec<u32>,
    flags: Vec<u8>,
}

thread_local! {
    static MARKS: std::cell::RefCell<Marks> = const {
        std::cell::RefCell::new(Marks {
            generation: 0,
            stamp: Vec::new(),
            flags: Vec::new(),
        })
    };
}

/// No node: the parent of a surface's root.
const NONE: u32 = u32::MAX;

/// Patches of one surface grouped for the far field (see the module
/// notes): node `np + k` of [`Clusters`].
struct Cluster {
    /// Area-weighted centroid, and the largest distance from it to the hull.
    centre: DVec3,
    radius: f64,
    normal: DVec3,
    surface: u32,
    /// Its patches' area, and that over its convex hull's (at most 1).
    area: f64,
    fill: f64,
    /// The hull: `hull[hull_first..hull_first + hull_n]`.
    hull_first: u32,
    hull_n: u32,
    /// The outline of its patches (less the edges they share): `edges[..]`.
    edges_first: u32,
    edges_n: u32,
    /// The §5.4 offset distance (of its largest patch).
    delta: f64,
    children: [u32; 2],
    /// Patches whose centres cast its visibility rays (one per grandchild).
    samples: [u32; 4],
    nsamples: u32,
    /// The nodes the samples stand for: its grandchildren (a child that
    /// is a patch stands for itself).
    quarters: [u32; 4],
}

/// Per surface, a binary tree over its patches, split at the median
/// centre along the longest axis: nodes `0..np` are the patches (leaves),
/// `np..` the clusters, children before parents.
struct Clusters {
    np: usize,
    /// A cluster shoots as one at receivers at least `1 / far` of its
    /// radius away (0: never).
    far: f64,
    list: Vec<Cluster>,
    hull: Vec<DVec3>,
    /// The clusters' outlines, as indices into the transport's `pts`.
    edges: Vec<[u32; 2]>,
    /// Per entry of `pts`, the first entry at the same mesh vertex (while
    /// the outlines are built).
    canon: Vec<u32>,
    /// Per node, its parent (`NONE` at a root).
    parent: Vec<u32>,
    /// Per surface with patches, its root.
    roots: Vec<u32>,
    /// Per cluster, the patch whose centre is nearest its centre (while
    /// the tree is built: its grandparent's samples).
    reps: Vec<u32>,
    /// Per patch, its area.
    patch_area: Vec<f64>,
    /// Per cluster, the box of its patches' boxes.
    boxes: Vec<(DVec3, DVec3)>,
    /// Per surface id, the root of its tree (`NONE` without patches);
    /// empty when every patch is alone.
    root_of: Vec<u32>,
}

/// What [`Clusters::subtree`] returns about a subtree.
struct Sub {
    node: u32,
    /// Its outline's directed edges (indices into `pts`, canonical).
    edges: Vec<[u32; 2]>,
    hull: Vec<glam::DVec2>,
    area: f64,
    centre: DVec3,
}

impl Clusters {
    fn build(mesh: &Mesh, shooters: &[Shooter], pts: &[DVec3], far: f64) -> Clusters {
        let np = shooters.len();
        let mut cl = Clusters {
            np,
            far,
            list: Vec::new(),
            hull: Vec::new(),
            edges: Vec::new(),
            canon: Vec::new(),
            parent: vec![NONE; np],
            roots: Vec::new(),
            reps: Vec::new(),
            patch_area: Vec::new(),
            boxes: Vec::new(),
            root_of: Vec::new(),
        };
        let mut by_surface: Vec<(u32, u32)> = shooters
            .iter()
            .enumerate()
            .map(|(p, s)| (s.surface, p as u32))
            .collect();
        by_surface.sort_unstable();
        if far <= 0.0 {
            // Every patch alone: each its own root.
            cl.roots = (0..np as u32).collect();
            return cl;
        }
        let area: Vec<f64> = mesh.patches().map(|p| mesh.patch_area(p)).collect();
        cl.patch_area = area.clone();
        // Each corner as the first entry of `pts` at its mesh vertex, so
        // that an edge two patches share is the same pair of indices.
        let mut first = vec![u32::MAX; mesh.num_vertices()];
        cl.canon = Vec::with_capacity(pts.len());
        for p in mesh.patches() {
            for &v in mesh.patch_corners(p) {
                let k = cl.canon.len() as u32;
                let f = &mut first[v.idx()];
                if *f == u32::MAX {
                    *f = k;
                }
                cl.canon.push(*f);
            }
        }
        for group in by_surface.chunk_by(|a, b| a.0 == b.0) {
            let mut members: Vec<u32> = group.iter().map(|g| g.1).collect();
            let s0 = &shooters[members[0] as usize];
            let frame = geom::Frame::new(pts[s0.first as usize], s0.normal);
            let root = cl.subtree(&mut members, shooters, pts, &area, &frame);
            cl.roots.push(root.node);
            let k = group[0].0 as usize;
            if cl.root_of.len() <= k {
                cl.root_of.resize(k + 1, NONE);
            }
            cl.root_of[k] = root.node;
        }
        cl.canon = Vec::new();
        cl.reps = Vec::new();
        cl
    }

    /// The tree over `members` (one surface's patches): its root, its
    /// hull (2-D, in `frame`), area, area-weighted centroid and the patch
    /// nearest that centroid.
    fn subtree(
        &mut self,
        members: &mut [u32],
        shooters: &[Shooter],
        pts: &[DVec3],
        area: &[f64],
        frame: &geom::Frame,
    ) -> Sub {
        if members.len() == 1 {
            let p = members[0];
            let s = &shooters[p as usize];
            let hull = convex_hull(
                pts[s.first as usize..(s.first + s.n) as usize]
                    .iter()
                    .map(|&q| frame.to_2d(q))
                    .collect(),
            );
            let c = &self.canon[s.first as usize..(s.first + s.n) as usize];
            return Sub {
                node: p,
                hull,
                area: area[p as usize],
                centre: s.centre,
                edges: (0..c.len()).map(|i| [c[i], c[(i + 1) % c.len()]]).collect(),
            };
        }
        let (lo, hi) = geom::index::bbox(members.iter().map(|&p| shooters[p as usize].centre), 0.0);
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        members.sort_unstable_by(|&a, &b| {
            let (ca, cb) = (shooters[a as usize].centre, shooters[b as usize].centre);
            ca[axis].total_cmp(&cb[axis]).then(a.cmp(&b))
        });
        let mid = members.len() / 2;
        let (left, right) = members.split_at_mut(mid);
        let a = self.subtree(left, shooters, pts, area, frame);
        let b = self.subtree(right, shooters, pts, area, frame);
        let total = a.area + b.area;
        let centre = if total > 0.0 {
            (a.centre * a.area + b.centre * b.area) / total
        } else {
            (a.centre + b.centre) / 2.0
        };
        let mut both = a.hull.clone();
        both.extend_from_slice(&b.hull);
        let edges = outline(&a.edges, &b.edges);
        let hull = convex_hull(both);
        let hull_area = geom::polygon::signed_area_2d(&hull).abs();
        let members: &[u32] = members;
        let rep = *members
            .iter()
            .min_by(|&&p, &&q| {
                let (dp, dq) = (
                    shooters[p as usize].centre.distance_squared(centre),
                    shooters[q as usize].centre.distance_squared(centre),
                );
                dp.total_cmp(&dq).then(p.cmp(&q))
            })
            .expect("two members at least");
        // One visibility ray from the patch nearest each grandchild's centre.
        let mut samples = [0u32; 4];
        let mut quarters = [0u32; 4];
        let mut nsamples = 0;
        for sub in [&a, &b] {
            match sub.node as usize >= self.np {
                true => {
                    for &g in &self.list[sub.node as usize - self.np].children {
                        samples[nsamples] = self.rep_of(g);
                        quarters[nsamples] = g;
                        nsamples += 1;
                    }
                }
                false => {
                    samples[nsamples] = sub.node;
                    quarters[nsamples] = sub.node;
                    nsamples += 1;
                }
            }
        }
        let hull3: Vec<DVec3> = hull.iter().map(|&q| frame.to_3d(q)).collect();
        let radius = hull3.iter().map(|q| q.distance(centre)).fold(0.0, f64::max);
        let delta = members
            .iter()
            .map(|&p| shooters[p as usize].delta)
            .fold(0.0, f64::max);
        let node = (self.np + self.list.len()) as u32;
        self.list.push(Cluster {
            centre,
            radius,
            normal: shooters[members[0] as usize].normal,
            surface: shooters[members[0] as usize].surface,
            area: total,
            fill: if hull_area > 0.0 {
                (total / hull_area).min(1.0)
            } else {
                0.0
            },
            hull_first: self.hull.len() as u32,
            hull_n: hull3.len() as u32,
            edges_first: self.edges.len() as u32,
            edges_n: edges.len() as u32,
            delta,
            children: [a.node, b.node],
            samples,
            nsamples: nsamples as u32,
            quarters,
        });
        self.reps.push(rep);
        self.hull.extend(hull3);
        self.edges.extend_from_slice(&edges);
        self.parent.push(NONE);
        self.parent[a.node as usize] = node;
        self.parent[b.node as usize] = node;
        Sub {
            node,
            hull,
            area: total,
            centre,
            edges,
        }
    }
}

/// The outline of two regions of one plane given by their directed
/// boundary edges: both sets, less the edges one walks one way and the
/// other (or itself) the other way. Sorted: the same set in any order.
fn outline(a: &[[u32; 2]], b: &[[u32; 2]]) -> Vec<[u32; 2]> {
    let mut keyed: Vec<([u32; 2], i32)> = a
        .iter()
        .chain(b)
        .map(|&[i, j]| if i < j { ([i, j], 1) } else { ([j, i], -1) })
        .collect();
    keyed.sort_unstable();
    let mut out = Vec::new();
    for g in keyed.chunk_by(|x, y| x.0 == y.0) {
        let net: i32 = g.iter().map(|e| e.1).sum();
        let [i, j] = g[0].0;
        for _ in 0..net.unsigned_abs() {
            out.push(if net > 0 { [i, j] } else { [j, i] });
        }
    }
    out
}

impl Clusters {
    /// Sets each cluster's box from its patches' `boxes`.
    fn set_boxes(&mut self, boxes: &[(DVec3, DVec3)]) {
        let mut out: Vec<(DVec3, DVec3)> = Vec::with_capacity(self.list.len());
        for c in &self.list {
            let b = c.children.map(|k| match (k as usize).checked_sub(self.np) {
                Some(i) => out[i],
                None => boxes[k as usize],
            });
            out.push((b[0].0.min(b[1].0), b[0].1.max(b[1].1)));
        }
        self.boxes = out;
    }

    /// Node `k`'s box.
    fn node_box(&self, k: u32, boxes: &[(DVec3, DVec3)]) -> (DVec3, DVec3) {
        match (k as usize).checked_sub(self.np) {
            Some(i) => self.boxes[i],
            None => boxes[k as usize],
        }
    }

    /// Whether the box of some patch under node `k` passes `meets`.
    fn any_patch_meets(
        &self,
        k: u32,
        boxes: &[(DVec3, DVec3)],
        meets: &impl Fn((DVec3, DVec3)) -> bool,
    ) -> bool {
        let mut stack = vec![k];
        while let Some(k) = stack.pop() {
            if meets(self.node_box(k, boxes)) {
                match self.get(k) {
                    Some(c) => stack.extend_from_slice(&c.children),
                    None => return true,
                }
            }
        }
        false
    }

    /// The patch whose centre is nearest node `k`'s centre.
    fn rep_of(&self, k: u32) -> u32 {
        if (k as usize) < self.np {
            k
        } else {
            self.reps[k as usize - self.np]
        }
    }

    fn get(&self, k: u32) -> Option<&Cluster> {
        (k as usize).checked_sub(self.np).map(|i| &self.list[i])
    }

    /// Cluster `c`'s radiosity as a receiver at `x` (normal `n`) that
    /// sees the quarters in `mask` weights it: the quarters' lights
    /// ([`NodeLight::tilted`] for a quarter that is a cluster) weighted by
    /// their point form factors.
    fn light(&self, light: &NodeLight, c: &Cluster, x: DVec3, n: DVec3, shares: Shares) -> Rgb {
        let (mut sum, mut all) = ([0.0; 3], 0.0);
        let k = c.nsamples as usize;
        for (&share, &q) in shares[..k].iter().zip(&c.quarters[..k]) {
            if share == 0 {
                continue;
            }
            let b = match self.get(q) {
                Some(qc) => light.tilted(qc, q, x, n),
                None => light.mean[q as usize],
            };
            let w = share as f64;
            all += w;
            for j in 0..3 {
                sum[j] += w * b[j];
            }
        }
        if all > 0.0 {
            sum.map(|v| v / all)
        } else {
            [0.0; 3]
        }
    }

    /// Node `k`'s area and centre as a point source's form factor (up to
    /// π) at `x` (normal `n`); `m`: the node's plane normal.
    fn point_ff(&self, k: u32, m: DVec3, x: DVec3, n: DVec3, shooters: &[Shooter]) -> f64 {
        let (a, y) = match self.get(k) {
            Some(c) => (c.area, c.centre),
            None => (self.patch_area[k as usize], shooters[k as usize].centre),
        };
        let d = x - y;
        let d2 = d.length_squared();
        if d2 <= 0.0 {
            return 0.0;
        }
        a * m.dot(d).max(0.0) * (-n.dot(d)).max(0.0) / (d2 * d2)
    }

    /// Whether cluster `k` shoots as one at `x`: far enough, and filling
    /// its hull. (A patch: never asked.)
    fn far_from(&self, k: u32, x: DVec3, n: DVec3) -> bool {
        self.get(k).is_some_and(|c| {
            if c.radius > self.far * x.distance(c.centre) {
                return false;
            }
            // Wholly in front of the receiver's plane or wholly behind it.
            let hull = &self.hull[c.hull_first as usize..(c.hull_first + c.hull_n) as usize];
            // (A point on the plane is on either side: a wall's foot seen
            // from the floor.)
            let d = |q: &DVec3| n.dot(*q - x);
            hull.iter().all(|q| d(q) >= 0.0) || hull.iter().all(|q| d(q) <= 0.0)
        })
    }

    /// Per node, the area-weighted mean of `b` (per patch) over it, and
    /// per cluster its first moment about its centre.
    fn values(&self, b: &[Rgb], shooters: &[Shooter]) -> NodeLight {
        let np = self.np;
        let mut mean = Vec::with_capacity(np + self.list.len());
        mean.extend_from_slice(&b[..np]);
        // Per cluster, the sum of area × b × position over its patches.
        let mut sum: Vec<[DVec3; 3]> = Vec::with_capacity(self.list.len());
        let own = |k: usize, sum: &[[DVec3; 3]]| -> [DVec3; 3] {
            if k < np {
                let (a, x) = (self.patch_area[k], shooters[k].centre);
                b[k].map(|v| x * (a * v))
            } else {
                sum[k - np]
            }
        };
        let mut tilt = Vec::with_capacity(self.list.len());
        for c in &self.list {
            let (x, y) = (c.children[0] as usize, c.children[1] as usize);
            let (ax, ay) = (self.area_of(x), self.area_of(y));
            let t = ax + ay;
            let v = if t > 0.0 {
                [0, 1, 2].map(|i| (mean[x][i] * ax + mean[y][i] * ay) / t)
            } else {
                [0, 1, 2].map(|i| 0.5 * (mean[x][i] + mean[y][i]))
            };
            let (sx, sy) = (own(x, &sum), own(y, &sum));
            let s3 = [0, 1, 2].map(|i| sx[i] + sy[i]);
            // Σ A b (x − centre) / A: the centre is the area centroid.
            tilt.push(if t > 0.0 {
                [0, 1, 2].map(|i| (s3[i] - c.centre * (v[i] * t)) / t)
            } else {
                [DVec3::ZERO; 3]
            });
            sum.push(s3);
            mean.push(v);
        }
        NodeLight { np, mean, tilt }
    }

    fn area_of(&self, k: usize) -> f64 {
        match k.checked_sub(self.np) {
            Some(i) => self.list[i].area,
            None => self.patch_area[k],
        }
    }

    /// The nodes that stand for the candidates `cand` (patches or
    /// clusters) at `x`: each raised to its highest ancestor far from `x`,
    /// a cluster not far from `x` opened to its children; sorted, none
    /// inside another.
    fn resolve(&self, x: DVec3, n: DVec3, cand: Vec<u32>) -> Vec<u32> {
        if self.list.is_empty() {
            return cand;
        }
        let mut out = Vec::with_capacity(cand.len());
        let mut stack = cand;
        while let Some(k) = stack.pop() {
            if let Some(c) = self.get(k)
                && !self.far_from(k, x, n)
            {
                stack.extend_from_slice(&c.children);
                continue;
            }
            // (An ancestor may straddle the receiver's plane where one
            // above it does not.)
            let (mut top, mut up) = (k, self.parent[k as usize]);
            while up != NONE {
                if self.far_from(up, x, n) {
                    top = up;
                }
                up = self.parent[up as usize];
            }
            out.push(top);
        }
        out.sort_unstable();
        out.dedup();
        if out.last().is_some_and(|&k| k as usize >= self.np) {
            let inside: Vec<bool> = out
                .iter()
                .map(|&k| {
                    let mut a = self.parent[k as usize];
                    while a != NONE {
                        if out.binary_search(&a).is_ok() {
                            return true;
                        }
                        a = self.parent[a as usize];
                    }
                    false
                })
                .collect();
            let mut i = 0;
            out.retain(|_| {
                i += 1;
                !inside[i - 1]
            });
        }
        out
    }
}

/// The convex hull of `pts`, counter-clockwise, without collinear points
/// (Andrew's monotone chain).
fn convex_hull(mut pts: Vec<glam::DVec2>) -> Vec<glam::DVec2> {
    pts.sort_unstable_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: glam::DVec2, a: glam::DVec2, b: glam::DVec2| (a - o).perp_dot(b - o);
    let chain = |it: &mut dyn Iterator<Item = glam::DVec2>| {
        let mut h: Vec<glam::DVec2> = Vec::new();
        for p in it {
            while h.len() >= 2 && cross(h[h.len() - 2], h[h.len() - 1], p) <= 0.0 {
                h.pop();
            }
            h.push(p);
        }
        h.pop();
        h
    };
    let mut h = chain(&mut pts.iter().copied());
    h.extend(chain(&mut pts.iter().rev().copied()));
    h
}

/// Appends `x` as an LEB128 varint.
fn write_varint(out: &mut Vec<u8>, mut x: u32) {
    while x >= 0x80 {
        out.push((x as u8) | 0x80);
        x >>= 7;
    }
    out.push(x as u8);
}

/// Reads one LEB128 varint (`None` at the end).
fn read_varint<'a>(bytes: &mut impl Iterator<Item = &'a u8>) -> Option<u32> {
    let (mut x, mut shift) = (0u32, 0);
    loop {
        let b = *bytes.next()?;
        x |= ((b & 0x7f) as u32) << shift;
        if b < 0x80 {
            return Some(x);
        }
        shift += 7;
    }
}

/// Per vertex, the patches it is a corner of, as a compressed list:
/// `at[count[v]..count[v + 1]]`.
fn patches_at_corners(mesh: &Mesh) -> (Vec<u32>, Vec<u32>) {
    let nv = mesh.num_vertices();
    let mut count = vec![0u32; nv + 1];
    for p in mesh.patches() {
        for &v in mesh.patch_corners(p) {
            count[v.idx() + 1] += 1;
        }
    }
    for i in 0..nv {
        count[i + 1] += count[i];
    }
    let mut fill = count.clone();
    let mut at = vec![0u32; count[nv] as usize];
    for p in mesh.patches() {
        for &v in mesh.patch_corners(p) {
            at[fill[v.idx()] as usize] = p.0;
            fill[v.idx()] += 1;
        }
    }
    (count, at)
}

/// Per patch, the patches of its surface that share a corner vertex with
/// it (itself included; vertices are per surface), as a compressed list
/// (see `Transport::near`).
fn patches_sharing_a_corner(mesh: &Mesh) -> (Vec<u32>, Vec<u32>) {
    let (count, at) = patches_at_corners(mesh);
    let mut start = Vec::with_capacity(mesh.num_patches() + 1);
    start.push(0);
    let mut near = Vec::new();
    let mut row = Vec::new();
    for p in mesh.patches() {
        row.clear();
        for &v in mesh.patch_corners(p) {
            row.extend_from_slice(&at[count[v.idx()] as usize..count[v.idx() + 1] as usize]);
        }
        row.sort_unstable();
        row.dedup();
        near.extend_from_slice(&row);
        start.push(near.len() as u32);
    }
    (start, near)
}

/// Per surface, the surfaces whose bounding boxes touch its own (within a
/// millionth of the scene's size), as a compressed list (see
/// `Transport::touch`).
fn touching_surfaces(shooters: &[Shooter], pts: &[DVec3]) -> (Vec<u32>, Vec<u32>) {
    let ns = shooters
        .iter()
        .map(|s| s.surface as usize + 1)
        .max()
        .unwrap_or(0);
    let mut lo = vec![DVec3::INFINITY; ns];
    let mut hi = vec![DVec3::NEG_INFINITY; ns];
    for s in shooters {
        let k = s.surface as usize;
        for &p in &pts[s.first as usize..(s.first + s.n) as usize] {
            lo[k] = lo[k].min(p);
            hi[k] = hi[k].max(p);
        }
    }
    let (slo, shi) = geom::index::bbox(pts.iter().copied(), 0.0);
    let pad = DVec3::splat(1e-6 * (shi - slo).length());
    let index = geom::index::BoxIndex::new(
        (0..ns)
            .filter(|&k| lo[k].x <= hi[k].x)
            .map(|k| (lo[k], hi[k], k as u32)),
    );
    let lists: Vec<Vec<u32>> = (0..ns)
        .into_par_iter()
        .map(|k| {
            if lo[k].x > hi[k].x {
                return Vec::new();
            }
            let mut l = index.query(lo[k] - pad, hi[k] + pad);
            l.sort_unstable();
            l.dedup();
            l
        })
        .collect();
    let mut start = Vec::with_capacity(ns + 1);
    start.push(0u32);
    let mut all = Vec::new();
    for l in lists {
        all.extend(l);
        start.push(all.len() as u32);
    }
    (start, all)
}

/// `cancel` for [`Transport::build`] from an interrupt flag and a deadline.
pub(crate) fn canceller(
    interrupt: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    deadline: Option<std::time::Instant>,
) -> impl Fn() -> bool + Sync {
    move || {
        interrupt
            .as_ref()
            .is_some_and(|i| i.load(std::sync::atomic::Ordering::Relaxed))
            || deadline.is_some_and(|d| std::time::Instant::now() >= d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A UG text cut into patches of edge `len`, as a mesh.
    fn mesh(src: &str, len: f64) -> Mesh {
        crate::solver::tests::patched(src, len).1
    }

    fn transport(m: &Mesh, far: f64) -> Transport {
        Transport::build(m, 1e-3, Some(0), far, &|| false).unwrap()
    }

    /// A point facing `n` on no surface of the model.
    fn receiver(x: DVec3, n: DVec3) -> Receiver {
        Receiver {
            x,
            n,
            surface: u32::MAX,
            inward: DVec3::ZERO,
            size: 0.1,
            seed: 1,
        }
    }

    /// Every patch under exactly one node of `nodes`.
    fn covers_once(t: &Transport, nodes: &[u32]) -> bool {
        let mut leaves = Vec::new();
        let mut stack = nodes.to_vec();
        while let Some(k) = stack.pop() {
            match t.clusters.get(k) {
                Some(c) => stack.extend_from_slice(&c.children),
                None => leaves.push(k),
            }
        }
        leaves.sort_unstable();
        leaves == (0..t.shooters.len() as u32).collect::<Vec<_>>()
    }

    const FLOOR: &str = "c_rgb g 0.5 0.5 0.5;
        v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 0 4 0;
        f floor (a b c d) g;";

    /// A room with a box on the floor.
    const ROOM: &str = "c_rgb g 0.5 0.5 0.5;
             v a 0 0 0; v b 4 0 0; v c 4 3 0; v d 0 3 0;
             v e 0 0 2.5; v f 4 0 2.5; v g 4 3 2.5; v h 0 3 2.5;
             v i 1 1 0.001; v j 2 1 0.001; v k 2 2 0.001; v l 1 2 0.001;
             v i2 1 1 0.7; v j2 2 1 0.7; v k2 2 2 0.7; v l2 1 2 0.7;
             f floor (a b c d) g; f ceil (e h g f) g; f w1 (a e f b) g;
             f w2 (b f g c) g; f w3 (c g h d) g; f w4 (d h e a) g;
             f top (i2 j2 k2 l2) g; f s1 (i j j2 i2) g; f s2 (j k k2 j2) g;
             f s3 (k l l2 k2) g; f s4 (l i i2 l2) g;";

    /// A vertex's nodes marked and walked down from the roots are those
    /// that resolving the union of its neighbours' rows gives, at every
    /// corner and at points inside the patches, with clusters and without.
    #[test]
    fn near_nodes_resolve_the_neighbours_rows() {
        let m = mesh(ROOM, 0.3);
        for far in [0.25, 0.0] {
            let mut t = Transport::build(&m, 1e-3, Some(64), far, &|| false).unwrap();
            t.compact_rows();
            let np = t.shooters.len();
            let (mut raised, mut tried) = (0, 0);
            for p in 0..np {
                let sh = &t.shooters[p];
                let corners = &t.pts[sh.first as usize..(sh.first + sh.n) as usize];
                for x in corners
                    .iter()
                    .map(|&c| c * 0.999 + sh.centre * 0.001)
                    .chain([sh.centre])
                {
                    let at = [p as u32];
                    let union = t.near_candidates(&at);
                    let expect = t.clusters.resolve(x, sh.normal, union.clone());
                    assert_eq!(t.near_nodes(x, sh.normal, &at), expect, "patch {p} at {x}");
                    raised += usize::from(expect.len() < union.len());
                    tried += 1;
                }
            }
            assert!(tried > 1000);
            assert_eq!(raised > tried / 4, far > 0.0, "{raised} of {tried}");
        }
    }

    /// The walk down the surfaces' trees finds the patches whose boxes
    /// meet the discovery hits' queries, as a scan of every patch does,
    /// and raised, the nodes [`Clusters::resolve`] makes of them.
    #[test]
    fn the_tree_walk_finds_the_patches_the_queries_meet() {
        let m = mesh(ROOM, 0.3);
        let t = transport(&m, 0.25);
        assert!(t.clusters.list.len() > 100);
        let np = t.shooters.len();
        let mut raised_some = 0;
        for q in (0..np).step_by(7) {
            let r = t.centre_receiver(q);
            let hits = t.hits(&r, 256);
            // Every patch whose box meets a query, of a surface it asks for.
            let mut brute: Vec<u32> = Vec::new();
            for (s, lo, hi) in t.queries(hits.clone()) {
                for p in 0..np as u32 {
                    let (plo, phi) = t.boxes[p as usize];
                    if plo.cmple(hi).all()
                        && phi.cmpge(lo).all()
                        && t.touching(s).contains(&t.surf[p as usize])
                    {
                        brute.push(p);
                    }
                }
            }
            brute.sort_unstable();
            brute.dedup();
            assert!(!brute.is_empty());
            assert_eq!(t.found_patches(hits.clone(), None), brute);
            let raised = t.found_patches(hits, Some((r.x, r.n)));
            raised_some += usize::from(raised.len() < brute.len());
            assert_eq!(raised, t.clusters.resolve(r.x, r.n, brute));
        }
        assert!(raised_some > 20, "{raised_some}");
    }

    /// A far cluster of a grid's patches fills its hull, so its form
    /// factor is its patches' summed (contour integrals add up): the row
    /// of a point above a floor of 256 patches is a few dozen nodes with
    /// the same total; nearer points open more clusters; every patch is
    /// under exactly one node of every row.
    #[test]
    fn far_clusters_shoot_what_their_patches_shoot() {
        let m = mesh(FLOOR, 0.25);
        let (alone, grouped) = (transport(&m, 0.0), transport(&m, 0.25));
        assert_eq!(alone.shooters.len(), 256);
        assert_eq!(alone.clusters.list.len(), 0);
        assert_eq!(grouped.clusters.list.len(), 255);
        let mut lengths = Vec::new();
        for (x, n) in [
            (DVec3::new(2.0, 2.0, 3.0), DVec3::NEG_Z),
            (DVec3::new(0.3, 3.1, 1.0), DVec3::NEG_Z),
            (
                DVec3::new(5.0, 2.0, 0.5),
                DVec3::new(-1.0, 0.0, -0.2).normalize(),
            ),
            (
                DVec3::new(1.0, 1.0, 0.05),
                DVec3::new(0.0, 1.0, -1.0).normalize(),
            ),
        ] {
            let r = receiver(x, n);
            let exact = alone.row(&r, alone.candidates(&r));
            let row = grouped.row(&r, grouped.candidates(&r));
            let nodes: Vec<u32> = grouped.candidates(&r).0;
            assert!(covers_once(&grouped, &nodes), "{x}");
            let sum =
                |row: &[(u32, f32, Shares)]| row.iter().map(|&(_, w, _)| w as f64).sum::<f64>();
            let (e, g) = (sum(&exact), sum(&row));
            assert!(e > 0.01, "{x}: {e}");
            assert!((g - e).abs() <= 1e-5 * e, "{x}: grouped {g} against {e}");
            assert!(row.len() < exact.len(), "{x}: {} nodes", row.len());
            lengths.push(row.len());
        }
        assert!(lengths[0] <= 40, "{lengths:?}");
        assert!(lengths[3] > lengths[0], "{lengths:?}");
    }

    /// A plate hiding half a far cluster from the receiver halves its
    /// visibility (two of its four sample patches see the point); a
    /// cluster round a hole shoots what its patches shoot.
    #[test]
    fn far_clusters_see_through_their_sample_patches() {
        let src = format!(
            "{FLOOR}
            v p0 -1 -1 1; v p1 2 -1 1; v p2 2 5 1; v p3 -1 5 1;
            f plate (p0 p3 p2 p1) g;"
        );
        let m = mesh(&src, 1.0);
        let t = transport(&m, 0.5);
        let r = receiver(DVec3::new(2.0, 2.0, 10.0), DVec3::NEG_Z);
        let nodes = t.candidates(&r).0;
        assert!(covers_once(&t, &nodes));
        let root = *nodes
            .iter()
            .find(|&&k| t.clusters.get(k).is_some_and(|c| c.area > 15.0))
            .expect("the floor shoots as one");
        let c = t.clusters.get(root).unwrap();
        assert_eq!(c.nsamples, 4);
        // The plate covers x < 2 at z = 1: seen from (2, 2, 10), a ray from a
        // floor patch centre at x < 2 passes under it.
        let (w, shares) = t.cluster_weight(&r, root).unwrap();
        let w = w as f64;
        assert_eq!(shares.iter().filter(|&&s| s > 0).count(), 2, "{shares:?}");
        let hull = &t.clusters.hull[c.hull_first as usize..(c.hull_first + c.hull_n) as usize];
        let open = point_to_polygon(r.x, r.n, hull);
        assert!((w / open - 0.5).abs() < 1e-6, "{w} of {open}");
        // Patch by patch (each its own ray), about the same share is seen.
        let alone = transport(&m, 0.0);
        let seen: f64 = alone
            .row(&r, alone.candidates(&r))
            .iter()
            .filter(|&&(p, _, _)| alone.surf[p as usize] == c.surface)
            .map(|&(_, w, _)| w as f64)
            .sum();
        assert!((0.4..0.6).contains(&(seen / open)), "{seen} of {open}");

        // A cluster round a hole shoots what its patches shoot: its
        // outline is the face's two contours.
        let holed = "c_rgb g 0.5 0.5 0.5;
            v h0 0 0 0; v h1 4 0 0; v h2 4 4 0; v h3 0 4 0;
            v i0 0.5 0.5 0; v i1 0.5 3.5 0; v i2 3.5 3.5 0; v i3 3.5 0.5 0;
            f holed (h0 h1 h2 h3) (i0 i1 i2 i3) g;";
        let m = mesh(holed, 0.5);
        let (alone, t) = (transport(&m, 0.0), transport(&m, 0.25));
        let r = receiver(
            DVec3::new(1.0, 3.0, 30.0),
            DVec3::new(0.1, 0.0, -1.0).normalize(),
        );
        let nodes = t.candidates(&r).0;
        assert_eq!(nodes, t.clusters.roots, "one node: the face");
        assert!(t.clusters.get(nodes[0]).unwrap().fill < 0.5);
        let sum = |row: Vec<(u32, f32, Shares)>| row.iter().map(|e| e.1 as f64).sum::<f64>();
        let (e, g) = (
            sum(alone.row(&r, alone.candidates(&r))),
            sum(t.row(&r, t.candidates(&r))),
        );
        assert!((g - e).abs() <= 1e-5 * e, "{g} against {e}");
    }

    /// Light that grows across a far cluster reaches a receiver weighted
    /// by the form factor, which is larger on the cluster's near side:
    /// the cluster's area mean would miss that (a room's tail came out
    /// 2.7% dark); its quarters' lights weighted by their point form
    /// factors, each tilted by its first moment, come within 0.3%.
    #[test]
    fn a_far_clusters_light_is_weighted_towards_its_near_side() {
        let m = mesh(FLOOR, 0.25);
        let (alone, grouped) = (transport(&m, 0.0), transport(&m, 0.25));
        let b: Vec<Rgb> = alone
            .shooters
            .iter()
            .map(|s| {
                [
                    1.0 + s.centre.x,
                    5.0 - s.centre.x,
                    1.0 + s.centre.y * s.centre.y,
                ]
            })
            .collect();
        let light = grouped.node_values(&b);
        for (x, n) in [
            (
                DVec3::new(-1.0, 2.0, 1.5),
                DVec3::new(1.0, 0.0, -1.0).normalize(),
            ),
            (
                DVec3::new(6.0, -1.0, 3.0),
                DVec3::new(-1.0, 0.5, -1.0).normalize(),
            ),
            (DVec3::new(2.0, 2.0, 9.0), DVec3::NEG_Z),
        ] {
            let r = receiver(x, n);
            let mut exact = [0.0; 3];
            for (p, w, _) in alone.row(&r, alone.candidates(&r)) {
                for j in 0..3 {
                    exact[j] += w as f64 * b[p as usize][j];
                }
            }
            let (mut got, mut naive) = ([0.0; 3], [0.0; 3]);
            let row = grouped.row(&r, grouped.candidates(&r));
            assert!(row.iter().any(|e| e.0 as usize >= 256), "{x}: no cluster");
            for (p, w, shares) in row {
                let (l, mean) = match grouped.clusters.get(p) {
                    Some(c) => (
                        grouped.clusters.light(&light, c, x, n, shares),
                        light.mean[p as usize],
                    ),
                    None => (light.mean[p as usize], light.mean[p as usize]),
                };
                for j in 0..3 {
                    got[j] += w as f64 * l[j];
                    naive[j] += w as f64 * mean[j];
                }
            }
            for j in 0..3 {
                let (e, g, a) = (exact[j], got[j], naive[j]);
                assert!(
                    (g - e).abs() <= 3e-3 * e,
                    "{x} channel {j}: {g} against {e} (area means {a})"
                );
            }
            // The area means alone are further off on the slopes.
            if x.z < 5.0 {
                assert!(
                    (naive[0] - exact[0]).abs() > 3.0 * (got[0] - exact[0]).abs(),
                    "{x}"
                );
            }
        }
    }
}
