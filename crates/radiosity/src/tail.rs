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

use crate::formfactor::{offset_receiver, point_to_polygon, receives};

type Rgb = [f64; 3];

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
}

impl Transport {
    /// Builds the transport; `None` when `cancel` was raised meanwhile.
    pub fn build(
        mesh: &Mesh,
        offset: f64,
        rays: Option<usize>,
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
            near_start,
            near,
            seen_start: Vec::new(),
            seen: Vec::new(),
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
            let rows: Vec<Vec<(u32, f32)>> = if tr.rays == 0 {
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
                        tr.row_seen(&tr.centre_receiver(q), tr.found_by(h), |p| {
                            tr.sees_centre(p, q, q0)
                        })
                    })
                    .collect()
            };
            for r in rows {
                for (p, w) in r {
                    tr.patch.push(p);
                    tr.weight.push(w);
                }
                tr.start.push(tr.patch.len());
            }
            q0 = q1;
        }
        tr.patch.shrink_to_fit();
        tr.weight.shrink_to_fit();
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
            .map(|&q| self.candidates(&self.centre_receiver(q)).len())
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

    /// The patches a receiver may see: every patch, or those found by
    /// [`Transport::rays`] discovery rays (see the module's notes).
    fn candidates(&self, r: &Receiver) -> Vec<u32> {
        if self.rays == 0 {
            (0..self.shooters.len() as u32).collect()
        } else {
            self.found_by(self.hits(r, self.rays))
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

    /// The patches that discovery rays' `hits` make candidates.
    fn found_by(&self, mut hits: Vec<(u32, u32, DVec3)>) -> Vec<u32> {
        let surf = &self.surf;
        let mut cand: Vec<u32> = Vec::new();
        // Per surface hit: its patches near the hit points (their box,
        // grown by a quarter of its diagonal and the largest patch hit), so
        // the parts of a surface between and just beyond the rays are
        // tried too; and there, those of the surfaces whose boxes touch its
        // box (a strip, a reveal, a block's side beside a floor: small
        // surfaces next to big ones that no ray hit. On the Cornell box at
        // `-l 3%` the rays alone missed 0.2% of the patch centres' form
        // factors, and the tail came out 0.3% dark; with these 0.05%).
        hits.sort_unstable_by_key(|h| (h.0, h.1));
        for group in hits.chunk_by(|a, b| a.0 == b.0) {
            let (lo, hi) = geom::index::bbox(group.iter().map(|h| h.2), 0.0);
            let grow = 0.25 * (hi - lo).length()
                + group
                    .iter()
                    .map(|h| self.shooters[h.1 as usize].size)
                    .fold(0.0, f64::max);
            let pad = DVec3::splat(grow);
            let (qlo, qhi) = (lo - pad, hi + pad);
            let touching = self.touching(group[0].0);
            self.bvh.for_each_in_box(qlo, qhi, |p| {
                let (plo, phi) = self.boxes[p as usize];
                if plo.cmple(qhi).all() && phi.cmpge(qlo).all() {
                    let t = surf[p as usize];
                    if t == group[0].0 || touching.binary_search(&t).is_ok() {
                        cand.push(p);
                    }
                }
            });
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
    /// building).
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
    fn row(&self, r: &Receiver, cand: Vec<u32>) -> Vec<(u32, f32)> {
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
        cand: Vec<u32>,
        seen: impl Fn(u32) -> bool,
    ) -> Vec<(u32, f32)> {
        let (x0, n, s) = (r.x, r.n, r.surface);
        let surf = &self.surf;
        let mut out = Vec::new();
        for p in cand {
            let sh = &self.shooters[p as usize];
            if sh.surface == s {
                continue;
            }
            let (c, delta) = (sh.centre, sh.delta);
            // In front of the shooter's plane and facing it (as a shot tests).
            if !receives(x0, n, c, sh.normal, delta) {
                continue;
            }
            if !seen(p)
                && self.bvh.occluded(c, x0 - c, 1e-7, 1.0 - 1e-7, |id| {
                    let t = surf[id as usize];
                    t != sh.surface && t != s
                })
            {
                continue;
            }
            let x = offset_receiver(x0, || r.inward, c, sh.normal, delta);
            let f = point_to_polygon(
                x,
                n,
                &self.pts[sh.first as usize..(sh.first + sh.n) as usize],
            );
            if f > 0.0 {
                out.push((p, f as f32));
            }
        }
        out
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
                    let sh = &self.shooters[p as usize];
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
        (0..self.shooters.len())
            .into_par_iter()
            .map(|q| {
                let mut h = [0.0; 3];
                for k in self.start[q]..self.start[q + 1] {
                    let w = self.weight[k] as f64;
                    let b = u[self.patch[k] as usize];
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
        s: &[Rgb],
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
        s: &[Rgb],
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
                    let (b, u) = (s[p as usize], near.first[p as usize]);
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
    ) -> (Receiver, Vec<u32>) {
        let r = self.vertex_as_receiver(mesh, v, inward, size);
        let cand = if self.seen_start.is_empty()
            || !at
                .iter()
                .all(|&p| self.surf.get(p as usize) == Some(&r.surface))
        {
            self.candidates(&r)
        } else {
            self.near_candidates(at)
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
        s: &[Rgb],
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
        s: &[Rgb],
        near: Option<&Near>,
        mut keep: Option<&mut Vec<(u32, f32)>>,
    ) -> Rgb {
        let (r, cand) = self.vertex_receiver(mesh, v, inward, size, at);
        let row = self.row(&r, cand);
        let mut h = [0.0; 3];
        for (p, w) in row {
            if let Some(keep) = keep.as_deref_mut() {
                let sh = &self.shooters[p as usize];
                if r.x.distance_squared(sh.centre) < (NEAR * sh.size + sh.size).powi(2) {
                    keep.push((p, w));
                }
            }
            let b = s[p as usize];
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
        let Some(nr) = near else {
            return (w, w);
        };
        let sh = &self.shooters[p as usize];
        let x = offset_receiver(r.x, || r.inward, sh.centre, sh.normal, sh.delta);
        if x.distance_squared(sh.centre) >= (NEAR * sh.size).powi(2) {
            return (w, w);
        }
        let (fu, fr) = (nr.ff)(p, x, r.n);
        (fu.unwrap_or(w), fr.unwrap_or(w))
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
            + self.shooters.capacity() * size_of::<Shooter>()
            + self.pts.capacity() * size_of::<DVec3>()
            + self.surf.capacity() * 4
            + self.boxes.capacity() * std::mem::size_of::<(DVec3, DVec3)>()
            + self.bvh.len() * size_of::<Triangle>()
            + self.near_start.capacity() * 4
            + self.near.capacity() * 4
            + self.seen_start.capacity() * 8
            + self.seen.capacity()
    }
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
