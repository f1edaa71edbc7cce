//! Ray casting through `geom::bvh::Bvh` in a building-like scene: a grid
//! of rooms (box-slab walls with door gaps, floor tiles, a furniture box
//! a room), about 100,000 triangles.
//!
//! * `nearest`: rays from points inside the rooms in random directions,
//!   nearest hit (what `ugclean`'s enclosed-face test and `ugflip` cast);
//! * `occluded`: segments between random points of a room and of a room
//!   up to two away (what `ugrad`'s shots and tail cast), any hit.
//!
//! `cargo bench -p geom --features bench`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use geom::DVec3;
use geom::bvh::{Bvh, Triangle};

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
}

/// The 12 triangles of the box [lo, hi].
fn cuboid(lo: DVec3, hi: DVec3, id: u32, out: &mut Vec<Triangle>) {
    let c = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    for q in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        out.push(Triangle {
            p: [c(q[0]), c(q[1]), c(q[2])],
            id,
        });
        out.push(Triangle {
            p: [c(q[0]), c(q[2]), c(q[3])],
            id,
        });
    }
}

const ROOM: f64 = 4.0;
const ROOMS: usize = 24;

fn scene() -> Vec<Triangle> {
    let mut r = Rng(0x9E37_79B9_7F4A_7C15);
    let mut tris = Vec::new();
    let mut id = 0;
    let t = 0.15;
    for i in 0..ROOMS {
        for j in 0..ROOMS {
            let (x, y) = (i as f64 * ROOM, j as f64 * ROOM);
            // Walls along x and y, each in two runs around a door gap.
            for (a, b) in [(0.0, 1.5), (2.4, ROOM)] {
                cuboid(
                    DVec3::new(x + a, y, 0.0),
                    DVec3::new(x + b, y + t, 2.8),
                    id,
                    &mut tris,
                );
                cuboid(
                    DVec3::new(x, y + a, 0.0),
                    DVec3::new(x + t, y + b, 2.8),
                    id + 1,
                    &mut tris,
                );
            }
            id += 2;
            // Floor tiles of 0.5 m and a ceiling slab.
            for u in 0..8 {
                for v in 0..8 {
                    let (tx, ty) = (x + u as f64 * 0.5, y + v as f64 * 0.5);
                    let p = [
                        DVec3::new(tx, ty, 0.0),
                        DVec3::new(tx + 0.5, ty, 0.0),
                        DVec3::new(tx + 0.5, ty + 0.5, 0.0),
                        DVec3::new(tx, ty + 0.5, 0.0),
                    ];
                    tris.push(Triangle {
                        p: [p[0], p[1], p[2]],
                        id,
                    });
                    tris.push(Triangle {
                        p: [p[0], p[2], p[3]],
                        id,
                    });
                }
            }
            cuboid(
                DVec3::new(x, y, 2.8),
                DVec3::new(x + ROOM, y + ROOM, 3.0),
                id + 1,
                &mut tris,
            );
            // A table.
            let (cx, cy) = (x + r.range(0.8, 3.0), y + r.range(0.8, 3.0));
            cuboid(
                DVec3::new(cx, cy, 0.7),
                DVec3::new(cx + 0.8, cy + 0.6, 0.75),
                id + 2,
                &mut tris,
            );
            id += 3;
        }
    }
    tris
}

fn inside(r: &mut Rng, i: usize, j: usize) -> DVec3 {
    DVec3::new(
        i as f64 * ROOM + r.range(0.3, ROOM - 0.3),
        j as f64 * ROOM + r.range(0.3, ROOM - 0.3),
        r.range(0.1, 2.7),
    )
}

fn rays(c: &mut Criterion) {
    let bvh = Bvh::new(scene());
    let n = 4096;
    let mut r = Rng(7);
    let nearest: Vec<(DVec3, DVec3)> = (0..n)
        .map(|_| {
            let (i, j) = (
                (r.unit() * ROOMS as f64) as usize,
                (r.unit() * ROOMS as f64) as usize,
            );
            let o = inside(&mut r, i, j);
            let d = DVec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0));
            (o, d)
        })
        .collect();
    let segments: Vec<(DVec3, DVec3)> = (0..n)
        .map(|_| {
            let (i, j) = (
                2 + (r.unit() * (ROOMS - 4) as f64) as usize,
                2 + (r.unit() * (ROOMS - 4) as f64) as usize,
            );
            let a = inside(&mut r, i, j);
            let (di, dj) = ((r.unit() * 5.0) as usize, (r.unit() * 5.0) as usize);
            let b = inside(&mut r, i + di - 2, j + dj - 2);
            (a, b - a)
        })
        .collect();
    let mut g = c.benchmark_group("bvh");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("nearest", |b| {
        b.iter(|| {
            nearest
                .iter()
                .filter(|(o, d)| {
                    bvh.intersect(*o, *d, 0.0, f64::INFINITY, |_| true)
                        .is_some()
                })
                .count()
        })
    });
    g.bench_function("occluded", |b| {
        b.iter(|| {
            segments
                .iter()
                .filter(|(o, d)| bvh.occluded(*o, *d, 1e-7, 1.0 - 1e-7, |_| true))
                .count()
        })
    });
    g.finish();
    black_box(&bvh);
}

criterion_group!(benches, rays);
criterion_main!(benches);
