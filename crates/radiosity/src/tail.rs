//! The indirect tail: the light still unshot once no patch carries a
//! noticeable share of it, moved patch to patch-corner until it converges.
//!
//! Progressive shooting converges slowly once the emitters have shot: the
//! reflected light is spread over all patches, and every shot still costs
//! a pass over the whole model (a building of 380 rooms and 71k patches
//! needed hundreds of thousands of shots). Indirect light is smooth, and the
//! report's adaptive subdivision is driven by the bright shooters, so the
//! tail works at the patch level:
//!
//! * **Receivers** are the patch corners (every surface's copies of the input
//!   vertices); an element vertex takes the tail's irradiance interpolated
//!   from its patch's corners (each split vertex the mean of its parents:
//!   linear along edges, bilinear in quads).
//! * **Transport** from patch `p` to corner `r` is `F(p → r)·V(p, r)`: the
//!   same exact point-to-polygon form factor (with the §5.4 offset) and the
//!   same visibility ray from `p`'s centre that a progressive shot of the
//!   unrefined patch uses. The weights are computed once and stored per
//!   receiver (8 bytes a pair); each iteration is then a sparse
//!   matrix–vector product, so all patches shoot at once (Jacobi) in a few
//!   milliseconds.
//! * **Which patches a corner sees** is found by casting `rays`
//!   cosine-distributed rays from it (stratified, jittered by a hash of the
//!   corner's id: deterministic) and taking each patch hit together with
//!   its neighbours on the same surface (the ring fills the gaps between
//!   rays). A patch no ray comes near is left out: its form factor is below
//!   about 1/`rays`. With `rays` = 0 every patch is tried (exact up to the
//!   interpolation; used for small models).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use geom::bvh::{Bvh, Triangle};
use glam::DVec3;
use libmesh::{Mesh, PatchId, VertId, VertexOrigin};
use rayon::prelude::*;

use crate::formfactor::point_to_polygon;

const NONE: u32 = u32::MAX;

/// The patch-to-corner transport of the tail.
pub(crate) struct Transport {
    /// Receiver vertices (patch corners), in id order.
    pub recv: Vec<VertId>,
    /// Row `i` (receiver `recv[i]`) is `patch[start[i]..start[i + 1]]`
    /// with `weight[..]` = F·V.
    pub start: Vec<usize>,
    pub patch: Vec<u32>,
    pub weight: Vec<f32>,
    /// Per patch, its corners as receiver indices: `corner[corner_start[p]..corner_start[p + 1]]`.
    pub corner_start: Vec<u32>,
    pub corner: Vec<u32>,
}

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

impl Transport {
    /// Builds the transport; `None` when `cancel` was raised meanwhile.
    pub fn build(
        mesh: &Mesh,
        offset: f64,
        rays: usize,
        cancel: &(dyn Fn() -> bool + Sync),
    ) -> Option<Transport> {
        let nv = mesh.num_vertices();
        let np = mesh.num_patches();
        // Receivers: vertices that are some patch's corner.
        let mut index = vec![NONE; nv];
        for p in mesh.patches() {
            for &v in mesh.patch_corners(p) {
                if matches!(mesh.vertex_origin(v), VertexOrigin::Input(_)) {
                    index[v.idx()] = 0;
                }
            }
        }
        let mut recv = Vec::new();
        for (v, slot) in index.iter_mut().enumerate() {
            if *slot != NONE {
                *slot = recv.len() as u32;
                recv.push(VertId(v as u32));
            }
        }
        // Patch corners as receiver indices, and the patches at each receiver.
        let mut corner_start = Vec::with_capacity(np + 1);
        let mut corner = Vec::with_capacity(np * 4);
        corner_start.push(0u32);
        for p in mesh.patches() {
            for &v in mesh.patch_corners(p) {
                corner.push(index[v.idx()]);
            }
            corner_start.push(corner.len() as u32);
        }
        drop(index);
        let mut at_start = vec![0u32; recv.len() + 1];
        for &r in &corner {
            if r != NONE {
                at_start[r as usize + 1] += 1;
            }
        }
        for i in 0..recv.len() {
            at_start[i + 1] += at_start[i];
        }
        let mut fill = at_start.clone();
        let mut at = vec![0u32; corner.len()];
        for p in 0..np {
            for &r in &corner[corner_start[p] as usize..corner_start[p + 1] as usize] {
                if r != NONE {
                    at[fill[r as usize] as usize] = p as u32;
                    fill[r as usize] += 1;
                }
            }
        }
        drop(fill);
        let at_patch = |r: usize| &at[at_start[r] as usize..at_start[r + 1] as usize];

        // Shooters and their corner positions.
        let mut pts: Vec<DVec3> = Vec::with_capacity(corner.len());
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
        let poly = |p: usize| {
            let s = &shooters[p];
            &pts[s.first as usize..(s.first + s.n) as usize]
        };
        let surf: Vec<u32> = shooters.iter().map(|s| s.surface).collect();
        let mut tris = Vec::new();
        for (p, _) in shooters.iter().enumerate() {
            let c = poly(p);
            for k in 1..c.len() - 1 {
                tris.push(Triangle {
                    p: [c[0], c[k], c[k + 1]],
                    id: p as u32,
                });
            }
        }
        let bvh = Bvh::new(tris);
        let index = geom::index::BoxIndex::new((0..np).map(|p| {
            let (lo, hi) = geom::index::bbox(poly(p).iter().copied(), 0.0);
            (lo, hi, p as u32)
        }));
        // Rays per side of the stratification grid.
        let side = (rays as f64).sqrt().ceil() as usize;

        let row = |i: usize| -> Vec<(u32, f32)> {
            let v = recv[i];
            let x0 = mesh.vertex_pos(v);
            let n = mesh.vertex_normal(v);
            let s = mesh.vertex_surface(v).0;
            // Into the receiver's own surface: toward the centres of its patches.
            let inward = at_patch(i)
                .iter()
                .map(|&p| (shooters[p as usize].centre - x0).normalize_or_zero())
                .sum::<DVec3>()
                .normalize_or_zero();
            let mut cand: Vec<u32> = Vec::new();
            let mut hits: Vec<(u32, u32, DVec3)> = Vec::new();
            if rays == 0 {
                cand.extend(0..np as u32);
            } else {
                let (t1, t2) = n.any_orthonormal_pair();
                let seed = mix(v.0 as u64);
                // From a point just inside the receiver's patches and off its
                // plane: from the exact corner of a room, the walls that meet
                // there lie edge-on (rays along them hit at t = 0), though
                // the limit from inside sees them as half the hemisphere.
                let size = at_patch(i)
                    .iter()
                    .map(|&p| shooters[p as usize].size)
                    .fold(0.0, f64::max);
                let o = x0 + (inward + n) * (1e-4 * size);
                for a in 0..side {
                    for b in 0..side {
                        let z = mix(seed ^ (((a * side + b) as u64) << 20));
                        let u1 = (a as f64 + unit(z)) / side as f64;
                        let u2 = (b as f64 + unit(mix(z))) / side as f64;
                        let (r, phi) = (u1.sqrt(), std::f64::consts::TAU * u2);
                        let d = t1 * (r * phi.cos())
                            + t2 * (r * phi.sin())
                            + n * (1.0 - u1).max(0.0).sqrt();
                        if let Some(h) =
                            bvh.intersect(o, d, 0.0, f64::INFINITY, |id| surf[id as usize] != s)
                        {
                            hits.push((surf[h.id as usize], h.id, o + d * h.t));
                        }
                    }
                }
                // Per surface hit: its patches near the hit points (their box,
                // grown by a quarter of its diagonal and the largest patch
                // hit), so the parts of a surface between and just beyond
                // the rays are tried too.
                hits.sort_unstable_by_key(|h| (h.0, h.1));
                for group in hits.chunk_by(|a, b| a.0 == b.0) {
                    let (lo, hi) = geom::index::bbox(group.iter().map(|h| h.2), 0.0);
                    let grow = 0.25 * (hi - lo).length()
                        + group
                            .iter()
                            .map(|h| shooters[h.1 as usize].size)
                            .fold(0.0, f64::max);
                    let pad = DVec3::splat(grow);
                    cand.extend(
                        index
                            .query(lo - pad, hi + pad)
                            .into_iter()
                            .filter(|&p| surf[p as usize] == group[0].0),
                    );
                }
                hits.clear();
                cand.sort_unstable();
                cand.dedup();
            }
            let mut out = Vec::new();
            for p in cand {
                let sh = &shooters[p as usize];
                if sh.surface == s {
                    continue;
                }
                let (c, delta) = (sh.centre, sh.delta);
                // In front of the shooter's plane and facing it (as a shot tests).
                let d = sh.normal.dot(x0 - c);
                if d <= -delta || n.dot(c - x0) <= 0.0 {
                    continue;
                }
                let dir = x0 - c;
                if bvh.occluded(c, dir, 1e-7, 1.0 - 1e-7, |id| {
                    let t = surf[id as usize];
                    t != sh.surface && t != s
                }) {
                    continue;
                }
                let mut x = x0;
                if d < delta {
                    x += inward * delta;
                    let d2 = sh.normal.dot(x - c);
                    if d2 < 0.01 * delta {
                        x += sh.normal * (0.01 * delta - d2);
                    }
                }
                let f = point_to_polygon(x, n, poly(p as usize));
                if f > 0.0 {
                    out.push((p, f as f32));
                }
            }
            out
        };

        let mut start = Vec::with_capacity(recv.len() + 1);
        start.push(0usize);
        let mut patch = Vec::new();
        let mut weight = Vec::new();
        const CHUNK: usize = 2048;
        let mut i0 = 0;
        while i0 < recv.len() {
            if cancel() {
                return None;
            }
            let i1 = (i0 + CHUNK).min(recv.len());
            let rows: Vec<Vec<(u32, f32)>> = (i0..i1).into_par_iter().map(row).collect();
            for r in rows {
                for (p, w) in r {
                    patch.push(p);
                    weight.push(w);
                }
                start.push(patch.len());
            }
            i0 = i1;
        }
        patch.shrink_to_fit();
        weight.shrink_to_fit();
        Some(Transport {
            recv,
            start,
            patch,
            weight,
            corner_start,
            corner,
        })
    }

    /// Irradiance added at each receiver by patches of unshot radiosity `u`.
    pub fn gather(&self, u: &[[f64; 3]]) -> Vec<[f64; 3]> {
        (0..self.recv.len())
            .into_par_iter()
            .map(|i| {
                let mut h = [0.0; 3];
                for k in self.start[i]..self.start[i + 1] {
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

    /// A patch's corners as receiver indices (`NONE` for a corner that is not one).
    pub fn corners(&self, p: PatchId) -> &[u32] {
        &self.corner[self.corner_start[p.idx()] as usize..self.corner_start[p.idx() + 1] as usize]
    }

    pub fn pairs(&self) -> usize {
        self.patch.len()
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.recv.capacity() * 4
            + self.start.capacity() * 8
            + self.patch.capacity() * 4
            + self.weight.capacity() * 4
            + self.corner_start.capacity() * 4
            + self.corner.capacity() * 4
    }
}

/// `cancel` for [`Transport::build`] from an interrupt flag and a deadline.
pub(crate) fn canceller(
    interrupt: Option<Arc<AtomicBool>>,
    deadline: Option<std::time::Instant>,
) -> impl Fn() -> bool + Sync {
    move || {
        interrupt
            .as_ref()
            .is_some_and(|i| i.load(Ordering::Relaxed))
            || deadline.is_some_and(|d| std::time::Instant::now() >= d)
    }
}

pub(crate) const NO_RECEIVER: u32 = NONE;
