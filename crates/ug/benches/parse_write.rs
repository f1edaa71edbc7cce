//! Parse and write throughput on a generated ~20 MB UG text: materials,
//! vertices (some coloured), faces (some with holes, names and colours),
//! wires and comments, in the proportions of an architectural model.
//! Coordinates are written the way CAD exports write them: mostly short
//! decimals (millimetres, 0–3 decimals), a tenth of them full 17-digit values
//! (as after rotations).
//!
//!     cargo bench -p ug --features bench --bench parse_write
//!     cargo bench -p ug --features bench --bench parse_write -- --quick      (a fast estimate)

use std::fmt::Write as _;
use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};

/// A deterministic pseudo-random generator (no dependency needed).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    /// Appends a coordinate like the ones CAD exports contain.
    fn coord(&mut self, s: &mut String) {
        let n = (self.next() % 2_000_000) as i64 - 1_000_000;
        match self.next() % 10 {
            // Full precision, as after a rotation.
            0 => {
                let _ = write!(s, "{}", n as f64 / 1000.0 * std::f64::consts::FRAC_1_SQRT_2);
            }
            // Whole numbers.
            1 | 2 => {
                let _ = write!(s, "{}", n / 1000);
            }
            // Up to three decimals, trailing zeros dropped.
            _ => {
                let _ = write!(s, "{}", n as f64 / 1000.0);
            }
        }
    }
}

/// Generates UG text of at least `target` bytes.
fn generate(target: usize) -> String {
    let mut s = String::with_capacity(target + 4096);
    let mut r = Lcg(0x5eed);
    s.push_str("{ generated benchmark model: a grid of rooms }\n");
    for k in 0..64 {
        let _ = writeln!(
            s,
            "c_rgb mat{k} {} {} {};",
            (k % 7) as f64 / 7.0,
            (k % 5) as f64 / 5.0,
            (k % 3) as f64 / 3.0
        );
    }
    s.push_str("defmat lamp;\n  diffuse_rgb 0.8 0.8 0.8;\n  emission_rgb 20 20 18;\nend;\n");
    let mut block = 0usize;
    while s.len() < target {
        // A block of 64 vertices and the faces over them.
        let _ = writeln!(s, "{{ block {block} }}");
        for v in 0..64 {
            let _ = write!(s, "v b{block}v{v}");
            for _ in 0..3 {
                s.push(' ');
                r.coord(&mut s);
            }
            if v % 8 == 0 {
                let _ = writeln!(s, " mat{};", r.next() % 64);
            } else {
                s.push_str(";\n");
            }
        }
        for f in 0..40usize {
            let a = |k: usize| (f + k * 7) % 64;
            match f % 10 {
                0 => {
                    let _ = writeln!(
                        s,
                        "f b{block}f{f} (b{block}v{} b{block}v{} b{block}v{} b{block}v{}) (b{block}v{} b{block}v{} b{block}v{}) mat{};",
                        a(0),
                        a(1),
                        a(2),
                        a(3),
                        a(4),
                        a(5),
                        a(6),
                        f % 64
                    );
                }
                1 => {
                    let _ = writeln!(s, "w (b{block}v{} b{block}v{});", a(0), a(1));
                }
                2..=5 => {
                    let _ = writeln!(
                        s,
                        "f (b{block}v{} b{block}v{} b{block}v{} b{block}v{}) mat{};",
                        a(0),
                        a(1),
                        a(2),
                        a(3),
                        f % 64
                    );
                }
                _ => {
                    let _ = writeln!(
                        s,
                        "f (b{block}v{} b{block}v{} b{block}v{});",
                        a(0),
                        a(1),
                        a(2)
                    );
                }
            }
        }
        block += 1;
    }
    s
}

fn bench(c: &mut Criterion) {
    let text = generate(20 << 20);
    let model = ug::parse(text.as_bytes(), "bench.ug")
        .expect("the generated text parses")
        .model;
    let written = ug::write_string(&model);
    eprintln!(
        "input: {:.1} MB, {} vertices, {} faces; canonical output {:.1} MB",
        text.len() as f64 / 1e6,
        model.vertices.len(),
        model.faces.len(),
        written.len() as f64 / 1e6
    );

    let mut g = c.benchmark_group("ug");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(10));
    g.throughput(Throughput::Bytes(text.len() as u64));
    g.bench_function("parse", |b| {
        b.iter(|| ug::parse(black_box(text.as_bytes()), "bench.ug").unwrap())
    });
    g.throughput(Throughput::Bytes(written.len() as u64));
    g.bench_function("write", |b| {
        b.iter(|| {
            let mut out = Vec::with_capacity(written.len());
            ug::write(black_box(&model), &mut out).unwrap();
            out
        })
    });
    g.throughput(Throughput::Bytes(text.len() as u64));
    g.bench_function("parse+write", |b| {
        b.iter(|| {
            let m = ug::parse(black_box(text.as_bytes()), "bench.ug")
                .unwrap()
                .model;
            let mut out = Vec::with_capacity(text.len());
            ug::write(&m, &mut out).unwrap();
            out
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
