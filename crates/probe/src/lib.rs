//! An independent estimator of radiosity at points of a UniGrafix model.
//!
//! `ugrad` (crates/radiosity) computes radiosity by progressive shooting of
//! patch energy with analytic form factors. This crate checks it by a
//! different method that shares none of that machinery (no meshing, no form
//! factors, no hemi-cube, no visibility decisions of the solver): a Monte
//! Carlo path tracer with next-event estimation, on the faces of the model
//! itself (triangulated, ray cast with `geom::bvh`).
//!
//! The model is read as ugrad reads it:
//!
//! * faces are one-sided Lambertian reflectors, opaque on both sides; the
//!   front is the side from which the outer contour runs counter-clockwise
//!   (the outer contour's Newell normal points to it); light reaching a
//!   back is absorbed;
//! * `emission_rgb` E is exitance (W/m², from the front only), `diffuse_rgb`
//!   or `c_rgb` is the reflectance ρ (clamped to [0, 1]); a face without a
//!   material is grey (ρ = 0.5, no emission);
//! * radiosity B = E + ρ H, with H the irradiance on the front.
//!
//! H at a point is estimated by paths: at every vertex of a path the light
//! arriving straight from the emitters is sampled (an emitter triangle
//! chosen in proportion to a bound of its unoccluded irradiance at the
//! vertex, a uniform point on it, a shadow ray, divided by the
//! probability of the choice), then the path continues in a
//! cosine-distributed direction;
//! when it reaches the front of a face its throughput is multiplied by that
//! face's ρ, and the face's own emission is added weighed against the
//! next-event estimate of the vertex before by multiple importance
//! sampling (the power heuristic: each strategy's share of a direction is
//! its density squared over the sum of both densities squared, so nothing
//! is counted twice and neither the light sample's 1/r² next to an
//! emitter nor the cosine sample's misses of a small lamp dominate); at a
//! back it ends. After [`Options::rr_depth`] bounces Russian
//! roulette ends paths with probability 1 − q, q = min(max throughput,
//! 0.95), and reweights survivors by 1/q (unbiased). Each path gives one
//! independent sample of B = E + ρ H; the estimate is their mean and the
//! standard error their standard deviation over √N.
//!
//! The choice of emitter (module `lights`): every emitter triangle gets
//! the weight E × area × cos θ_x × cos θ_e / (π d²) toward its centroid,
//! the cosines widened to bounds over the whole triangle (at least 0.05),
//! d² at least the triangle's radius², the form factor at most 1; zero only
//! when the whole triangle is behind the vertex's tangent plane or the
//! vertex behind the triangle, so every triangle that can contribute keeps
//! a positive probability and the estimate stays unbiased. Occlusion is
//! not known: a lamp in the next room keeps its weight, but in a building
//! the lamps of the vertex's own room, near it and facing it, get most of
//! the choices, where choosing by emitted power spent nearly all of them on
//! the other rooms' lamps (the standard error at 4,096 paths on a 10k-face
//! building with 442 ceiling lights: 31% by power, 2.7% now). Up to 96
//! emitter triangles all are weighed at every vertex; above, a binary tree
//! over them (a box, a cone of normals and the power per node) is
//! descended from the root, one child at a time in proportion to a bound of
//! what it holds, in O(log emitters).
//!
//! Every point has its own random stream, derived from (seed, point index),
//! so results do not depend on the number of threads.

mod lights;
pub mod lit;
pub mod points;
pub mod rng;

use std::f64::consts::PI;
use std::ops::Range;

use geom::bvh::{Bvh, Triangle};
use glam::DVec3;
use lights::{Light, LightTree, Selection};
use rayon::prelude::*;
use ug::Model;

pub use rng::Rng;

/// Red, green, blue.
pub type Rgb = [f64; 3];

/// Luminance of a linear RGB value (Rec. 709 weights).
pub fn luminance(c: Rgb) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// A face of the model as the estimator sees it.
#[derive(Clone, Debug)]
pub struct Face {
    /// The face's name, or `#K` (its position among the top-level faces, from 1).
    pub label: String,
    /// Reflectance ρ, each channel in [0, 1].
    pub rho: Rgb,
    /// Emitted exitance E.
    pub emission: Rgb,
    /// Unit normal of the front (the outer contour's Newell normal).
    pub normal: DVec3,
    /// Area (of its triangles).
    pub area: f64,
    /// √area: the face's size, for margins.
    pub size: f64,
    /// Its triangles in [`Scene::triangles`].
    pub tris: Range<usize>,
    /// Every edge of every contour.
    pub edges: Vec<[DVec3; 2]>,
}

impl Face {
    /// Whether the face emits light (any channel of E non-zero).
    pub fn emits(&self) -> bool {
        self.emission.iter().any(|&e| e != 0.0)
    }
}

/// A triangle of a face, wound so that its normal is the face's front.
#[derive(Clone, Copy, Debug)]
pub struct Tri {
    pub p: [DVec3; 3],
    /// Unit normal of the front.
    pub normal: DVec3,
    pub area: f64,
    /// Index into [`Scene::faces`].
    pub face: u32,
}

/// Where a query point lies: a triangle of a face.
#[derive(Clone, Copy, Debug)]
pub struct Location {
    pub tri: usize,
    pub face: usize,
    /// The query point projected onto the triangle's plane.
    pub point: DVec3,
    /// How far the query point was from that plane.
    pub distance: f64,
}

/// A point at which B is estimated: B = E + ρ H with H the irradiance on
/// the side `normal` points to.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub point: DVec3,
    /// Unit normal of the side that receives.
    pub normal: DVec3,
    pub rho: Rgb,
    pub emission: Rgb,
}

impl Receiver {
    /// A bare receiver (ρ = 1, E = 0): its B is the irradiance H.
    pub fn bare(point: DVec3, normal: DVec3) -> Receiver {
        Receiver {
            point,
            normal: normal.normalize_or_zero(),
            rho: [1.0; 3],
            emission: [0.0; 3],
        }
    }
}

/// How many paths, and how they are drawn.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Paths per point; with `target_se`, the size of each batch of paths.
    pub samples: u64,
    /// Keep adding batches until the standard error of the luminance of B
    /// is at most this fraction of it (or `max_samples`).
    pub target_se: Option<f64>,
    /// The most paths per point with `target_se`.
    pub max_samples: u64,
    /// The seed of every point's random stream.
    pub seed: u64,
    /// Path vertices at most (a path is cut there; with ρ < 1 Russian
    /// roulette ends paths long before).
    pub max_depth: u32,
    /// Bounces before Russian roulette starts.
    pub rr_depth: u32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            samples: 4096,
            target_se: None,
            max_samples: 1 << 20,
            seed: 1,
            max_depth: 256,
            rr_depth: 3,
        }
    }
}

/// The estimate of B at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Radiosity B per channel.
    pub b: Rgb,
    /// Standard error of each channel of B.
    pub se: Rgb,
    /// Luminance of B.
    pub y: f64,
    /// Standard error of the luminance (from the per-path luminances).
    pub se_y: f64,
    /// Paths drawn.
    pub samples: u64,
}

/// A random point on a face (see [`Scene::sample_points`]).
#[derive(Clone, Copy, Debug)]
pub struct SamplePoint {
    pub point: DVec3,
    pub normal: DVec3,
    pub face: usize,
    pub tri: usize,
}

/// The model, ready for ray casting.
pub struct Scene {
    faces: Vec<Face>,
    tris: Vec<Tri>,
    bvh: Bvh,
    /// Triangles of emitting faces.
    emitters: Vec<u32>,
    /// Per triangle, its index in `emitters` (`u32::MAX`: it does not emit).
    light_of: Vec<u32>,
    /// Cumulative emitter weights (Σ|E| × area); the last is the total.
    cdf: Vec<f64>,
    /// What next-event estimation needs of each emitter, as `emitters`.
    lights: Vec<Light>,
    /// A binary tree over `lights`, for [`Selection::Tree`].
    tree: LightTree,
    /// How next-event estimation chooses an emitter triangle.
    selection: Selection,
    /// Ray origins are moved this far along their surface's normal.
    offset: f64,
    diagonal: f64,
    skipped: Vec<(String, String)>,
}

/// Triangles of a face's contours (outer first), as indices into the
/// contours' points numbered contour after contour: as ugplanar folds it
/// (`geom::triangulate::fold_triangles`: a lone quadrilateral along the
/// diagonal that folds it least, else a constrained Delaunay triangulation),
/// else `geom::bvh::face_triangles`.
pub fn triangulate(contours: &[Vec<DVec3>]) -> Vec<[usize; 3]> {
    if contours.len() == 1 && contours[0].len() == 3 {
        return vec![[0, 1, 2]];
    }
    geom::triangulate::fold_triangles(contours)
        .unwrap_or_else(|| geom::bvh::face_triangles(contours))
}

/// The model's bounding-box diagonal (0 when it has no vertices).
pub fn diagonal(m: &Model) -> f64 {
    m.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length())
}

/// The label of a face in messages.
pub fn face_label(m: &Model, f: ug::FaceId, k: usize) -> String {
    m.face(f)
        .name
        .clone()
        .unwrap_or_else(|| format!("#{}", k + 1))
}

impl Scene {
    /// Builds the scene from a model (flattened first when it has instances).
    /// Faces with fewer than three vertices or without area are left out
    /// (see [`Scene::skipped`]); an error when no face is left.
    pub fn new(model: &Model) -> Result<Scene, String> {
        let flat;
        let m = if model.is_flat() {
            model
        } else {
            flat = model.flatten().map_err(|d| d.to_string())?;
            &flat
        };
        let diag = diagonal(m);
        // Degenerate faces as ugrad (libmesh) leaves them out at its default
        // epsilon: area at most 1e-6 of the diagonal times the face's size.
        let eps = if diag > 0.0 { 1e-6 * diag } else { 1e-9 };
        let mut faces = Vec::new();
        let mut tris = Vec::new();
        let mut skipped = Vec::new();
        for (k, f) in m.top_faces().enumerate() {
            let face = m.face(f);
            let label = face_label(m, f, k);
            let pts: Vec<Vec<DVec3>> = face
                .contours
                .iter()
                .map(|c| c.iter().map(|&v| m.pos(v)).collect())
                .collect();
            if pts.first().is_none_or(|c| c.len() < 3) {
                skipped.push((label, "fewer than three vertices".to_string()));
                continue;
            }
            let newell = geom::newell_normal(&pts[0]);
            let (lo, hi) = pts[0].iter().fold((pts[0][0], pts[0][0]), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
            let size = (hi - lo).length();
            let newell_area = newell.length() / 2.0;
            if !newell_area.is_finite() || newell_area <= eps * size {
                skipped.push((label, "zero area".to_string()));
                continue;
            }
            let normal = newell.normalize();
            let all: Vec<DVec3> = pts.iter().flatten().copied().collect();
            let first = tris.len();
            let mut area = 0.0;
            for t in triangulate(&pts) {
                let mut p = t.map(|i| all[i]);
                let c = (p[1] - p[0]).cross(p[2] - p[0]);
                let len = c.length();
                if !(len > 0.0 && len.is_finite()) {
                    continue;
                }
                let mut n = c / len;
                if n.dot(normal) < 0.0 {
                    p.swap(1, 2);
                    n = -n;
                }
                tris.push(Tri {
                    p,
                    normal: n,
                    area: len / 2.0,
                    face: faces.len() as u32,
                });
                area += len / 2.0;
            }
            if tris.len() == first {
                skipped.push((label, "no triangle with area".to_string()));
                continue;
            }
            let (rho, emission) = match face.material.and_then(|id| m.materials.get(id.idx())) {
                Some(mat) => (mat.diffuse().map(|x| x.clamp(0.0, 1.0)), mat.emission()),
                None => ([0.5; 3], [0.0; 3]),
            };
            let mut edges = Vec::new();
            for c in &pts {
                for i in 0..c.len() {
                    edges.push([c[i], c[(i + 1) % c.len()]]);
                }
            }
            faces.push(Face {
                label,
                rho,
                emission,
                normal,
                area,
                size: area.sqrt(),
                tris: first..tris.len(),
                edges,
            });
        }
        if tris.is_empty() {
            return Err("the model has no face with area".to_string());
        }
        let mut emitters = Vec::new();
        let mut cdf = Vec::new();
        let mut lights = Vec::new();
        let mut total = 0.0;
        for (i, t) in tris.iter().enumerate() {
            let e = faces[t.face as usize].emission;
            let exitance = e[0].abs() + e[1].abs() + e[2].abs();
            let w = exitance * t.area;
            if w > 0.0 && w.is_finite() {
                total += w;
                emitters.push(i as u32);
                cdf.push(total);
                lights.push(Light::new(t, exitance));
            }
        }
        let mut light_of = vec![u32::MAX; tris.len()];
        for (k, &t) in emitters.iter().enumerate() {
            light_of[t as usize] = k as u32;
        }
        let selection = Selection::for_count(lights.len());
        let tree = LightTree::new(&lights);
        let bvh = Bvh::new(
            tris.iter()
                .enumerate()
                .map(|(i, t)| Triangle {
                    p: t.p,
                    id: i as u32,
                })
                .collect(),
        );
        Ok(Scene {
            faces,
            tris,
            bvh,
            emitters,
            light_of,
            cdf,
            lights,
            tree,
            selection,
            offset: if diag > 0.0 { 1e-6 * diag } else { 1e-9 },
            diagonal: diag,
            skipped,
        })
    }

    pub fn faces(&self) -> &[Face] {
        &self.faces
    }

    pub fn triangles(&self) -> &[Tri] {
        &self.tris
    }

    /// The bounding-box diagonal of the model.
    pub fn diagonal(&self) -> f64 {
        self.diagonal
    }

    /// Faces left out, with the reason.
    pub fn skipped(&self) -> &[(String, String)] {
        &self.skipped
    }

    /// Whether anything emits light.
    pub fn has_emitters(&self) -> bool {
        !self.emitters.is_empty()
    }

    /// The triangle that `p` lies on, seen from the side `n` points to:
    /// among triangles whose front normal is within about 25° of `n` and
    /// whose plane passes within `tol` of `p` with `p`'s projection inside,
    /// the nearest plane (then the first face). `None` when there is none.
    pub fn locate(&self, p: DVec3, n: DVec3, tol: f64) -> Option<Location> {
        let found = nearest_triangle(
            &self.bvh,
            self.tris.len(),
            |i| (self.tris[i].p, self.tris[i].normal),
            p,
            n,
            tol,
        )?;
        Some(Location {
            tri: found.index,
            face: self.tris[found.index].face as usize,
            point: found.point,
            distance: found.distance,
        })
    }

    /// The receiver at a location: its face's normal, ρ and E.
    pub fn receiver(&self, at: &Location) -> Receiver {
        let f = &self.faces[at.face];
        Receiver {
            point: at.point,
            normal: self.tris[at.tri].normal,
            rho: f.rho,
            emission: f.emission,
        }
    }

    /// `n` points on the faces that do not emit, uniformly by area, each at
    /// least `margin` × its face's size (√area) from every edge of the
    /// face's contours; deterministic for the seed. An error when too few
    /// tries land far enough from the edges (faces too thin for the margin).
    pub fn sample_points(
        &self,
        n: usize,
        seed: u64,
        margin: f64,
    ) -> Result<Vec<SamplePoint>, String> {
        let mut eligible = Vec::new();
        let mut cdf = Vec::new();
        let mut total = 0.0;
        for (i, t) in self.tris.iter().enumerate() {
            if !self.faces[t.face as usize].emits() {
                total += t.area;
                eligible.push(i);
                cdf.push(total);
            }
        }
        if n == 0 {
            return Ok(Vec::new());
        }
        if eligible.is_empty() {
            return Err("the model has no face that does not emit light".to_string());
        }
        // A stream of its own: point estimates use streams 0, 1, 2, ….
        let mut rng = Rng::new(seed, u64::MAX);
        let mut out = Vec::with_capacity(n);
        let max_tries = 1000 * n as u64 + 10_000;
        let mut tries = 0u64;
        while out.len() < n {
            tries += 1;
            if tries > max_tries {
                return Err(format!(
                    "could not place {n} points at least {}% of a face's size from its edges ({} placed in {max_tries} tries)",
                    margin * 100.0,
                    out.len()
                ));
            }
            let k = pick(&cdf, rng.f64() * total);
            let ti = eligible[k];
            let t = &self.tris[ti];
            let p = uniform_on(&t.p, &mut rng);
            let f = &self.faces[t.face as usize];
            let clear = margin * f.size;
            if f.edges.iter().all(|e| segment_distance(p, e) >= clear) {
                out.push(SamplePoint {
                    point: p,
                    normal: t.normal,
                    face: t.face as usize,
                    tri: ti,
                });
            }
        }
        Ok(out)
    }

    /// Estimates B at a receiver with random stream `stream` of `opts.seed`.
    pub fn estimate(&self, r: &Receiver, opts: &Options, stream: u64) -> Estimate {
        let mut rng = Rng::new(opts.seed, stream);
        let mut acc = Welford::default();
        let n = r.normal.normalize_or_zero();
        let batch = opts.samples.max(1);
        // Scratch for the cumulative weights of the emitters (one per call:
        // nothing shared between threads).
        let mut cum = Vec::new();
        loop {
            for _ in 0..batch {
                let h = self.path(r.point, n, opts, &mut rng, &mut cum);
                let b = [0, 1, 2].map(|c| r.emission[c] + r.rho[c] * h[c]);
                acc.add([b[0], b[1], b[2], luminance(b)]);
            }
            let Some(target) = opts.target_se else { break };
            if acc.n >= opts.max_samples.max(batch) {
                break;
            }
            let (mean, se) = (acc.mean[3], acc.se(3));
            if acc.n >= 2 && se <= target * mean.abs() {
                break;
            }
        }
        Estimate {
            b: [acc.mean[0], acc.mean[1], acc.mean[2]],
            se: [acc.se(0), acc.se(1), acc.se(2)],
            y: acc.mean[3],
            se_y: acc.se(3),
            samples: acc.n,
        }
    }

    /// Estimates every receiver, in parallel (rayon); receiver `i` uses
    /// stream `i`, so the results do not depend on the thread count.
    /// `done` is called once per finished receiver (for a progress bar).
    pub fn estimate_all(
        &self,
        receivers: &[Receiver],
        opts: &Options,
        done: &(dyn Fn() + Sync),
    ) -> Vec<Estimate> {
        receivers
            .par_iter()
            .enumerate()
            .map(|(i, r)| {
                let e = self.estimate(r, opts, i as u64);
                done();
                e
            })
            .collect()
    }

    /// One path from `x` (front normal `n`): a sample of the irradiance H.
    fn path(&self, x: DVec3, n: DVec3, opts: &Options, rng: &mut Rng, cum: &mut Vec<f64>) -> Rgb {
        let mut h = [0.0; 3];
        let mut t = [1.0; 3];
        let (mut x, mut n) = (x, n);
        for depth in 0..opts.max_depth {
            let d = self.direct(x, n, rng, cum);
            for c in 0..3 {
                h[c] += t[c] * d[c];
            }
            let dir = cosine_direction(n, rng);
            let o = x + n * self.offset;
            let Some(hit) = self.bvh.intersect(o, dir, 0.0, f64::INFINITY, |_| true) else {
                break;
            };
            let tri = &self.tris[hit.id as usize];
            if tri.normal.dot(dir) >= 0.0 {
                break; // the back of a face: absorbed
            }
            // An emitter met by the cosine-sampled direction: its light,
            // weighed against next-event estimation's chance of the same
            // direction (the power heuristic). Next to an emitter (a wall
            // at a glowing ceiling) the light sample's 1/r² has an
            // unbounded variance; the cosine sample covers it.
            if let Some(&k) = self.light_of.get(hit.id as usize)
                && k != u32::MAX
            {
                let w = if hit.t > 2.0 * self.offset {
                    let ce = -tri.normal.dot(dir);
                    let p_light =
                        self.light_probability(k as usize, o, n) / tri.area * hit.t * hit.t / ce;
                    let p_cos = n.dot(dir) / PI;
                    power_heuristic(p_cos, p_light)
                } else {
                    1.0 // next-event estimation leaves these out
                };
                let e = self.faces[tri.face as usize].emission;
                for c in 0..3 {
                    h[c] += t[c] * e[c] * w;
                }
            }
            let rho = self.faces[tri.face as usize].rho;
            for c in 0..3 {
                t[c] *= rho[c];
            }
            let tmax = t[0].max(t[1]).max(t[2]);
            if tmax <= 0.0 {
                break;
            }
            if depth + 1 >= opts.rr_depth {
                let q = tmax.min(0.95);
                if rng.f64() >= q {
                    break;
                }
                for c in t.iter_mut() {
                    *c /= q;
                }
            }
            x = o + dir * hit.t;
            n = tri.normal;
        }
        h
    }

    /// One next-event sample of the irradiance at `x` (front normal `n`)
    /// straight from the emitters: E_e cosθ_x cosθ_e / (π r²) / pdf, pdf =
    /// P(triangle) / area, P as [`Scene::selection`] says: ∝ Σ|E| × area
    /// ([`Selection::Power`]), ∝ [`Light::weight`] at `x` among all
    /// ([`Selection::Flat`]; `cum` is scratch for the cumulative weights) or
    /// by the light tree ([`Selection::Tree`]). P is positive for every
    /// triangle that can contribute, so the estimate is unbiased.
    fn direct(&self, x: DVec3, n: DVec3, rng: &mut Rng, cum: &mut Vec<f64>) -> Rgb {
        if self.lights.is_empty() {
            return [0.0; 3];
        }
        let o = x + n * self.offset;
        let (k, p) = match self.selection {
            Selection::Power => {
                let total = self.cdf[self.cdf.len() - 1];
                let k = pick(&self.cdf, rng.f64() * total);
                let l = &self.lights[k];
                (k, l.power() / total)
            }
            Selection::Flat => {
                cum.clear();
                let mut total = 0.0;
                for l in &self.lights {
                    total += l.weight(o, n);
                    cum.push(total);
                }
                if !(total > 0.0 && total.is_finite()) {
                    // No emitter can reach x (every weight is zero only
                    // where the contribution is zero).
                    return [0.0; 3];
                }
                let k = pick(cum, rng.f64() * total);
                // The probability of k is the length of its interval.
                let below = if k > 0 { cum[k - 1] } else { 0.0 };
                (k, (cum[k] - below) / total)
            }
            Selection::Tree => match self.tree.pick(&self.lights, o, n, rng) {
                Some(kp) => kp,
                None => return [0.0; 3],
            },
        };
        if p <= 0.0 || p.is_nan() {
            return [0.0; 3];
        }
        let ti = self.emitters[k];
        let tri = &self.tris[ti as usize];
        let y = uniform_on(&tri.p, rng);
        let w = y - o;
        let r2 = w.length_squared();
        let r = r2.sqrt();
        if r <= 2.0 * self.offset {
            return [0.0; 3];
        }
        let dir = w / r;
        let cx = n.dot(dir);
        let ce = -tri.normal.dot(dir);
        if cx <= 0.0 || ce <= 0.0 {
            return [0.0; 3];
        }
        if self
            .bvh
            .occluded(o, dir, 0.0, r - self.offset, |id| id != ti)
        {
            return [0.0; 3];
        }
        let e = self.faces[tri.face as usize].emission;
        let g = cx * ce / (PI * r2) * tri.area / p;
        // Weighed against the cosine-sampled direction (see `path`).
        let w = power_heuristic(p / tri.area * r2 / ce, cx / PI);
        e.map(|v| v * g * w)
    }

    /// The probability that next-event estimation at `o` (front normal
    /// `n`) chooses emitter `k`, as [`Scene::direct`] draws it.
    fn light_probability(&self, k: usize, o: DVec3, n: DVec3) -> f64 {
        match self.selection {
            Selection::Power => self.lights[k].power() / self.cdf[self.cdf.len() - 1],
            Selection::Flat => {
                let total: f64 = self.lights.iter().map(|l| l.weight(o, n)).sum();
                if total > 0.0 && total.is_finite() {
                    self.lights[k].weight(o, n) / total
                } else {
                    0.0
                }
            }
            Selection::Tree => self.tree.probability(&self.lights, k, o, n),
        }
    }
}

/// The power heuristic's weight (Veach 1997, β = 2) of a sample drawn with
/// density `a` against another strategy's density `b` for the same
/// direction (both per solid angle).
fn power_heuristic(a: f64, b: f64) -> f64 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && (a2 + b2).is_finite() {
        a2 / (a2 + b2)
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// The index of the first cumulative weight above `u` (clamped to the last).
fn pick(cdf: &[f64], u: f64) -> usize {
    cdf.partition_point(|&c| c <= u).min(cdf.len() - 1)
}

/// A uniform point on a triangle.
fn uniform_on(p: &[DVec3; 3], rng: &mut Rng) -> DVec3 {
    let (mut u, mut v) = (rng.f64(), rng.f64());
    if u + v > 1.0 {
        u = 1.0 - u;
        v = 1.0 - v;
    }
    p[0] + (p[1] - p[0]) * u + (p[2] - p[0]) * v
}

/// A cosine-distributed direction about the unit normal `n`.
fn cosine_direction(n: DVec3, rng: &mut Rng) -> DVec3 {
    let (u1, u2) = (rng.f64(), rng.f64());
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (s, c) = phi.sin_cos();
    // An orthonormal basis about n (Duff et al. 2017).
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t1 = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let t2 = DVec3::new(b, sign + n.y * n.y * a, -n.y);
    (t1 * (r * c) + t2 * (r * s) + n * (1.0 - u1).max(0.0).sqrt()).normalize()
}

/// Distance from `p` to the segment `e`.
fn segment_distance(p: DVec3, e: &[DVec3; 2]) -> f64 {
    let d = e[1] - e[0];
    let l2 = d.length_squared();
    let t = if l2 > 0.0 {
        ((p - e[0]).dot(d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (e[0] + d * t)).length()
}

/// Running mean and variance (Welford) of four quantities.
#[derive(Default)]
struct Welford {
    n: u64,
    mean: [f64; 4],
    m2: [f64; 4],
}

impl Welford {
    fn add(&mut self, x: [f64; 4]) {
        self.n += 1;
        let n = self.n as f64;
        for (k, &xk) in x.iter().enumerate() {
            let d = xk - self.mean[k];
            self.mean[k] += d / n;
            self.m2[k] += d * (xk - self.mean[k]);
        }
    }

    /// Standard error of the mean of quantity `k` (infinite below 2 samples).
    fn se(&self, k: usize) -> f64 {
        if self.n < 2 {
            return f64::INFINITY;
        }
        let n = self.n as f64;
        (self.m2[k].max(0.0) / (n - 1.0) / n).sqrt()
    }
}

/// The triangle found by [`nearest_triangle`].
pub(crate) struct Found {
    pub index: usize,
    pub point: DVec3,
    pub bary: [f64; 3],
    pub distance: f64,
}

/// Cosine of the largest angle between a query normal and a triangle's.
const NORMAL_AGREEMENT: f64 = 0.9;

/// The triangle of `bvh` (`get(i)`: corners and unit front normal) that `p`
/// lies on seen from `n`: front normal within about 25° of `n`, plane
/// within `tol` of `p`, `p`'s projection inside; the nearest plane, then
/// the lowest index. Found by a ray along −n through `p` (from `p + tol·n`
/// to `p − tol·n`), or, when that slips between triangles (a shared edge),
/// by trying every triangle with a small tolerance on the barycentrics.
pub(crate) fn nearest_triangle(
    bvh: &Bvh,
    count: usize,
    get: impl Fn(usize) -> ([DVec3; 3], DVec3),
    p: DVec3,
    n: DVec3,
    tol: f64,
) -> Option<Found> {
    let n = n.normalize_or_zero();
    if n == DVec3::ZERO || !p.is_finite() {
        return None;
    }
    let tol = tol.max(0.0);
    let consider = |best: &mut Option<Found>, i: usize, slack: f64| {
        let (q, tn) = get(i);
        if tn.dot(n) < NORMAL_AGREEMENT {
            return;
        }
        let d = tn.dot(p - q[0]);
        if d.abs() > tol {
            return;
        }
        let x = p - tn * d;
        let Some(bary) = barycentric(&q, x) else {
            return;
        };
        if bary.iter().any(|&b| b < -slack) {
            return;
        }
        let better = match best {
            None => true,
            Some(b) => d.abs() < b.distance || (d.abs() == b.distance && i < b.index),
        };
        if better {
            let bary = bary.map(|b| b.max(0.0));
            let s = bary[0] + bary[1] + bary[2];
            *best = Some(Found {
                index: i,
                point: x,
                bary: bary.map(|b| b / s),
                distance: d.abs(),
            });
        }
    };
    let mut best: Option<Found> = None;
    let reach = tol.max(1e-300);
    for h in bvh.all_hits(p + n * reach, -n, 0.0, 2.0 * reach, |_| true) {
        consider(&mut best, h.id as usize, 1e-12);
    }
    if best.is_none() {
        for i in 0..count {
            consider(&mut best, i, 1e-9);
        }
    }
    best
}

/// Barycentric coordinates of `x` (in the triangle's plane) in `q`.
fn barycentric(q: &[DVec3; 3], x: DVec3) -> Option<[f64; 3]> {
    let (e1, e2, w) = (q[1] - q[0], q[2] - q[0], x - q[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (dw1, dw2) = (w.dot(e1), w.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    let u = (d22 * dw1 - d12 * dw2) / det;
    let v = (d11 * dw2 - d12 * dw1) / det;
    Some([1.0 - u - v, u, v])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_are_in_the_hemisphere_with_mean_cosine_two_thirds() {
        let mut rng = Rng::new(3, 0);
        for n in [DVec3::Z, -DVec3::Z, DVec3::new(1.0, 2.0, -0.5).normalize()] {
            let mut sum = 0.0;
            let k = 20_000;
            for _ in 0..k {
                let d = cosine_direction(n, &mut rng);
                assert!((d.length() - 1.0).abs() < 1e-12);
                let c = d.dot(n);
                assert!(c >= -1e-12);
                sum += c;
            }
            // E[cos θ] under p = cos θ / π is 2/3 (sd of cos ≈ 0.24).
            assert!((sum / k as f64 - 2.0 / 3.0).abs() < 0.01);
        }
    }

    #[test]
    fn barycentrics_and_segment_distance() {
        let q = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let b = barycentric(&q, DVec3::new(0.25, 0.25, 0.0)).unwrap();
        assert!((b[0] - 0.5).abs() < 1e-15 && (b[1] - 0.25).abs() < 1e-15);
        let e = [DVec3::ZERO, DVec3::X];
        assert!((segment_distance(DVec3::new(0.5, 2.0, 0.0), &e) - 2.0).abs() < 1e-15);
        assert!((segment_distance(DVec3::new(-3.0, 4.0, 0.0), &e) - 5.0).abs() < 1e-15);
    }

    /// A UG quadrilateral `name` with corners `c` (in order around it),
    /// written so that its front faces `front`.
    fn quad(out: &mut String, name: &str, c: [DVec3; 4], front: DVec3, mat: &str) {
        let c = if geom::newell_normal(&c).dot(front) > 0.0 {
            c
        } else {
            [c[3], c[2], c[1], c[0]]
        };
        for (i, p) in c.iter().enumerate() {
            out.push_str(&format!("v {name}{i} {} {} {};\n", p.x, p.y, p.z));
        }
        out.push_str(&format!(
            "f {name} ({name}0 {name}1 {name}2 {name}3) {mat};\n"
        ));
    }

    /// The closed box `lo`..`hi` of material `mat`, every face facing inward.
    fn room(out: &mut String, name: &str, lo: DVec3, hi: DVec3, mat: &str) {
        for axis in 0..3 {
            for side in 0..2 {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let mut c = [DVec3::ZERO; 4];
                for (i, (a, b)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                    c[i][axis] = if side == 0 { lo[axis] } else { hi[axis] };
                    c[i][u] = if a == 0 { lo[u] } else { hi[u] };
                    c[i][v] = if b == 0 { lo[v] } else { hi[v] };
                }
                let mut inward = DVec3::ZERO;
                inward[axis] = if side == 0 { 1.0 } else { -1.0 };
                quad(out, &format!("{name}w{axis}{side}"), c, inward, mat);
            }
        }
    }

    /// A square lamp of side `s` centred at `c`, facing down.
    fn lamp(out: &mut String, name: &str, c: DVec3, s: f64) {
        let h = s / 2.0;
        let corners = [(-h, -h), (h, -h), (h, h), (-h, h)].map(|(x, y)| c + DVec3::new(x, y, 0.0));
        quad(out, name, corners, -DVec3::Z, "lamp");
    }

    /// Two closed rooms side by side: a small one with one lamp, and a long
    /// one with twenty lamps that together emit eighteen times as much. No
    /// light of the long room reaches the small one, but the power
    /// distribution spends 18/19 of its choices there.
    fn two_rooms() -> Scene {
        let mut s = String::from(
            "c_rgb wall 0.6 0.5 0.4;\n\
             defmat lamp; diffuse_rgb 0 0 0; emission_rgb 10 10 10; end;\n",
        );
        room(&mut s, "a", DVec3::ZERO, DVec3::new(2.0, 2.0, 2.0), "wall");
        lamp(&mut s, "la", DVec3::new(1.0, 1.0, 1.98), 0.5);
        room(
            &mut s,
            "b",
            DVec3::new(2.5, 0.0, 0.0),
            DVec3::new(12.5, 2.0, 2.0),
            "wall",
        );
        for i in 0..20 {
            let c = DVec3::new(2.75 + 0.5 * i as f64, 0.5 + (i % 2) as f64, 1.98);
            lamp(&mut s, &format!("lb{i}"), c, 0.45);
        }
        let m = ug::parse(s.as_bytes(), "two-rooms.ug")
            .expect("parses")
            .model;
        Scene::new(&m).expect("a scene")
    }

    #[test]
    fn choosing_lamps_by_their_contribution_agrees_with_the_power_distribution_at_a_smaller_error()
    {
        let mut s = two_rooms();
        assert_eq!(s.lights.len(), 42);
        assert_eq!(s.selection, Selection::Flat);
        let opts = Options {
            samples: 40_000,
            ..Options::default()
        };
        let mut run = |sel: Selection, p: DVec3, n: DVec3, stream: u64| {
            s.selection = sel;
            let at = s.locate(p, n, 1e-9).expect("on a face");
            s.estimate(&s.receiver(&at), &opts, stream)
        };
        for (k, (p, n)) in [
            (DVec3::new(0.6, 1.3, 0.0), DVec3::Z),
            (DVec3::new(2.0, 0.4, 1.5), -DVec3::X),
        ]
        .into_iter()
        .enumerate()
        {
            let power = run(Selection::Power, p, n, 3 * k as u64);
            for (i, sel) in [Selection::Flat, Selection::Tree].into_iter().enumerate() {
                let e = run(sel, p, n, 3 * k as u64 + 1 + i as u64);
                println!(
                    "{p} {sel:?}: {} ± {} against the power distribution's {} ± {}",
                    e.y, e.se_y, power.y, power.se_y
                );
                let combined = (e.se_y * e.se_y + power.se_y * power.se_y).sqrt();
                assert!(
                    (e.y - power.y).abs() <= 3.0 * combined,
                    "{sel:?} at {p}: {} vs {} ({:.2} combined standard errors)",
                    e.y,
                    power.y,
                    (e.y - power.y).abs() / combined
                );
                assert!(
                    e.se_y <= 0.5 * power.se_y,
                    "{sel:?} at {p}: standard error {} against {}",
                    e.se_y,
                    power.se_y
                );
            }
        }
    }

    /// Every selection in a closed furnace (every triangle emits, each
    /// sees the others at every angle): B = E / (1 − ρ) within 3 standard
    /// errors and 1%. Path vertices near an edge see the next face's 1/r²
    /// up close; before multiple importance sampling that made every
    /// selection heavy-tailed here (hence the 1%, ρ = 0.3 and the points at
    /// the middles of faces, kept).
    #[test]
    fn every_selection_gives_the_furnace_e_over_one_minus_rho() {
        let mut src =
            String::from("defmat glow; diffuse_rgb 0.3 0.3 0.3; emission_rgb 0.7 1.4 0.35; end;\n");
        room(
            &mut src,
            "f",
            DVec3::ZERO,
            DVec3::new(1.0, 1.5, 1.0),
            "glow",
        );
        let m = ug::parse(src.as_bytes(), "furnace.ug")
            .expect("parses")
            .model;
        let mut s = Scene::new(&m).expect("a scene");
        let opts = Options {
            samples: 16384,
            ..Options::default()
        };
        let want = [1.0, 2.0, 0.5];
        for sel in [Selection::Power, Selection::Flat, Selection::Tree] {
            s.selection = sel;
            for (k, (p, n)) in [
                (DVec3::new(0.5, 0.5, 0.0), DVec3::Z),
                (DVec3::new(0.4, 1.0, 1.0), -DVec3::Z),
                (DVec3::new(0.0, 0.75, 0.5), DVec3::X),
            ]
            .into_iter()
            .enumerate()
            {
                let at = s.locate(p, n, 1e-9).expect("on a face");
                let e = s.estimate(&s.receiver(&at), &opts, k as u64);
                for (c, &w) in want.iter().enumerate() {
                    let (b, se) = (e.b[c], e.se[c]);
                    assert!(
                        (b - w).abs() <= 3.0 * se + 0.01 * w && se < 0.05 * w,
                        "{sel:?} at {p}, channel {c}: {b} ± {se} against {w}"
                    );
                }
            }
        }
    }
}
