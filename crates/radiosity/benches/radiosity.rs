//! Benchmarks of the radiosity solver:
//!
//! * `form_factor_quads`: exact point-to-polygon form factors
//!   ([`radiosity::formfactor::point_to_polygon`]) from random receivers to
//!   random quads (some partly behind the receiver, so clipped), per second;
//! * `cornell_len50_first_20_shots`: the Cornell box (fixtures/cornell-box.ug
//!   after `ugplanar` and `ugcut -l 50`): the first 20 shots of a fresh
//!   solution (the light's patches and the brightest walls, with penumbra
//!   and gradient subdivision), in shots per second;
//! * `cornell_len100_converge_1e-3`: the whole solution of the box at patch
//!   length 100 down to 1e-3 of the emitted energy unshot (about a minute
//!   each, so over ten minutes for criterion's ten samples: it runs only
//!   with `RADIOSITY_BENCH_CONVERGE=1` in the environment).

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use radiosity::{Options, RayVisibility, Solver, Stop};

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// Receivers (point, unit normal) and planar convex quads around them.
fn ff_cases(n: usize) -> Vec<(DVec3, DVec3, [DVec3; 4])> {
    let mut r = Rng(0x9E37_79B9_7F4A_7C15);
    (0..n)
        .map(|_| {
            let x = r.vec(-1.0, 1.0);
            let nrm = r.vec(-1.0, 1.0).normalize_or(DVec3::Z);
            let centre = x + r.vec(-3.0, 3.0);
            let u = r.vec(-1.0, 1.0).normalize_or(DVec3::X);
            let v = u.any_orthonormal_vector();
            let (a, b) = (r.range(0.2, 1.5), r.range(0.2, 1.5));
            let q = [
                centre - u * a - v * b,
                centre + u * a - v * b,
                centre + u * a + v * b,
                centre - u * a + v * b,
            ];
            (x, nrm, q)
        })
        .collect()
}

fn cornell(len: f64) -> (ug::Model, libmesh::Mesh) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/cornell-box.ug");
    let src = std::fs::read(path).expect("fixtures/cornell-box.ug");
    let m = ug::parse(&src, "cornell-box.ug")
        .expect("the Cornell box parses")
        .model;
    let eps = cli::epsilon(None, &m);
    let (m, _) = clean::planar::planarize(&m, eps);
    let (m, _) = libmesh::patch::cut(
        &m,
        libmesh::patch::Options {
            len,
            eps,
            angle: 25.0,
            quads: true,
        },
    )
    .expect("meshed");
    let mesh = libmesh::Mesh::from_model(&m, eps).expect("patches");
    (m, mesh)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("radiosity");

    let cases = ff_cases(1024);
    g.throughput(Throughput::Elements(cases.len() as u64));
    g.bench_function("form_factor_quads", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for (x, n, q) in &cases {
                s += radiosity::formfactor::point_to_polygon(*x, *n, black_box(q));
            }
            s
        })
    });

    let shots = 20;
    let (model, mesh) = cornell(50.0);
    let vis = RayVisibility::new(&mesh);
    let opts = Options {
        max_shots: Some(shots),
        ..Options::default()
    };
    {
        let mut s = Solver::new(mesh.clone(), &model.materials, &vis, opts.clone());
        assert_eq!(s.solve(None, |_| {}), Stop::MaxShots);
        eprintln!(
            "Cornell box, len 50: {} patches, {} vertices before; after {shots} shots {} leaf elements, {} vertices, unshot {:.3e}",
            mesh.num_patches(),
            mesh.num_vertices(),
            s.mesh.num_leaves(),
            s.mesh.num_vertices(),
            s.shots.last().map_or(1.0, |x| x.unshot)
        );
    }
    g.sample_size(10);
    g.throughput(Throughput::Elements(shots as u64));
    g.bench_function("cornell_len50_first_20_shots", |b| {
        b.iter_batched(
            || Solver::new(mesh.clone(), &model.materials, &vis, opts.clone()),
            |mut s| {
                s.solve(None, |_| {});
                s
            },
            BatchSize::LargeInput,
        )
    });

    // One convergence takes about a minute (2 cores): criterion's ten
    // samples are over ten minutes, so it runs only when asked for.
    if std::env::var_os("RADIOSITY_BENCH_CONVERGE").is_none() {
        eprintln!(
            "cornell_len100_converge_1e-3 skipped (about 10 minutes); RADIOSITY_BENCH_CONVERGE=1 runs it"
        );
        g.finish();
        return;
    }
    let (model, mesh) = cornell(100.0);
    let vis = RayVisibility::new(&mesh);
    let opts = Options::default();
    {
        let mut s = Solver::new(mesh.clone(), &model.materials, &vis, opts.clone());
        assert_eq!(s.solve(None, |_| {}), Stop::Converged);
        eprintln!(
            "Cornell box, len 100: {} patches; converged to 1e-3 in {} shots: {} leaf elements, {} vertices",
            mesh.num_patches(),
            s.shots.len(),
            s.mesh.num_leaves(),
            s.mesh.num_vertices()
        );
    }
    g.throughput(Throughput::Elements(1));
    g.bench_function("cornell_len100_converge_1e-3", |b| {
        b.iter_batched(
            || Solver::new(mesh.clone(), &model.materials, &vis, opts.clone()),
            |mut s| {
                s.solve(None, |_| {});
                s
            },
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
