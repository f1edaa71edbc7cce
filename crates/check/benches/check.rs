//! Benchmark: ugcheck on a generated ~10,000-face building-like model.

use criterion::{Criterion, criterion_group, criterion_main};

/// A grid of rooms: each room a floor, a ceiling and four walls (quads), with
/// shared corner vertices between neighbours, like a real floor plan.
fn rooms(n: usize) -> ug::Model {
    let mut src = String::new();
    let h = 3.0;
    for i in 0..=n {
        for j in 0..=n {
            for (k, z) in [0.0, h].iter().enumerate() {
                src.push_str(&format!(
                    "v p{i}_{j}_{k} {} {} {z};\n",
                    i as f64 * 4.0,
                    j as f64 * 5.0
                ));
            }
        }
    }
    src.push_str("c_rgb w 0.7 0.7 0.7;\n");
    let p = |i: usize, j: usize, k: usize| format!("p{i}_{j}_{k}");
    for i in 0..n {
        for j in 0..n {
            src.push_str(&format!(
                "f ({} {} {} {}) w;\n",
                p(i, j, 0),
                p(i + 1, j, 0),
                p(i + 1, j + 1, 0),
                p(i, j + 1, 0)
            ));
            src.push_str(&format!(
                "f ({} {} {} {}) w;\n",
                p(i, j, 1),
                p(i, j + 1, 1),
                p(i + 1, j + 1, 1),
                p(i + 1, j, 1)
            ));
        }
    }
    for i in 0..=n {
        for j in 0..n {
            src.push_str(&format!(
                "f ({} {} {} {}) w;\n",
                p(i, j, 0),
                p(i, j + 1, 0),
                p(i, j + 1, 1),
                p(i, j, 1)
            ));
        }
    }
    for j in 0..=n {
        for i in 0..n {
            src.push_str(&format!(
                "f ({} {} {} {}) w;\n",
                p(i, j, 0),
                p(i, j, 1),
                p(i + 1, j, 1),
                p(i + 1, j, 0)
            ));
        }
    }
    ug::parse(src.as_bytes(), "rooms")
        .expect("generated model parses")
        .model
}

fn bench(c: &mut Criterion) {
    let m = rooms(50); // 2·50² + 2·51·50 = 10,100 faces
    assert!(m.faces.len() > 10_000);
    let eps = cli::epsilon(None, &m);
    let mut g = c.benchmark_group("ugcheck");
    g.sample_size(10);
    g.bench_function("check_10k_faces", |b| b.iter(|| check::check(&m, eps)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
