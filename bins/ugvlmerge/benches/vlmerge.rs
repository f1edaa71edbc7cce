//! Benchmark: the grouper on a generated ~10,000-face building with the
//! defects it removes.
//!
//! A grid of n × n rooms (4 × 5 × 3). Each room's floor is 2 × 2 coplanar
//! quads (joined into one face per room; their mid-edge vertices are
//! T-vertices on the walls' feet); each wall segment is a lower and an upper
//! quad (joined), the upper one with its own copies of the middle vertices,
//! offset by 1e-10; each ceiling has its own copies of the room's corners,
//! offset by up to 2e-10 (merged).

use std::fmt::Write as _;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};

fn building(n: usize) -> ug::Model {
    let (w, d, h) = (4.0, 5.0, 3.0);
    let mut s = String::new();
    s.push_str("c_rgb floor 0.5 0.4 0.3;\nc_rgb wall 0.8 0.8 0.8;\nc_rgb ceiling 0.9 0.9 0.9;\n");
    // Floor grid at half-room spacing; wall corners at mid height.
    for i in 0..=2 * n {
        for j in 0..=2 * n {
            let (x, y) = (i as f64 * w / 2.0, j as f64 * d / 2.0);
            let _ = writeln!(s, "v g{i}_{j} {x} {y} 0;");
            if i % 2 == 0 && j % 2 == 0 {
                let _ = writeln!(s, "v m{i}_{j} {x} {y} {};", h / 2.0);
                let _ = writeln!(s, "v m{i}_{j}b {x} {} {};", y + 1e-10, h / 2.0);
                let _ = writeln!(s, "v t{i}_{j} {x} {y} {h};");
            }
        }
    }
    let g = |i: usize, j: usize| format!("g{i}_{j}");
    // Floors: 2 × 2 quads per room, facing up.
    for ri in 0..n {
        for rj in 0..n {
            for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (i, j) = (2 * ri + di, 2 * rj + dj);
                let _ = writeln!(
                    s,
                    "f ({} {} {} {}) floor;",
                    g(i, j),
                    g(i + 1, j),
                    g(i + 1, j + 1),
                    g(i, j + 1)
                );
            }
        }
    }
    // Walls: a lower and an upper quad per segment; the upper one uses the
    // offset copies of the middle vertices.
    let wall = |s: &mut String, (i0, j0): (usize, usize), (i1, j1): (usize, usize)| {
        let _ = writeln!(
            s,
            "f ({} {} m{i1}_{j1} m{i0}_{j0}) wall;",
            g(i0, j0),
            g(i1, j1)
        );
        let _ = writeln!(s, "f (m{i0}_{j0}b m{i1}_{j1}b t{i1}_{j1} t{i0}_{j0}) wall;");
    };
    // Inner walls face +x or +y; the outer ones face into the building.
    for i in 0..=n {
        for j in 0..n {
            let (a, b) = ((2 * i, 2 * j), (2 * i, 2 * j + 2));
            if i == n {
                wall(&mut s, b, a);
            } else {
                wall(&mut s, a, b);
            }
        }
    }
    for j in 0..=n {
        for i in 0..n {
            let (a, b) = ((2 * i + 2, 2 * j), (2 * i, 2 * j));
            if j == n {
                wall(&mut s, b, a);
            } else {
                wall(&mut s, a, b);
            }
        }
    }
    // Ceilings, facing down, with their own corner vertices.
    for ri in 0..n {
        for rj in 0..n {
            let off = 1e-10 * ((ri + rj) % 3) as f64;
            let mut names = Vec::new();
            for (k, (di, dj)) in [(0, 0), (0, 1), (1, 1), (1, 0)].iter().enumerate() {
                let (x, y) = ((ri + di) as f64 * w, (rj + dj) as f64 * d);
                let name = format!("c{ri}_{rj}_{k}");
                let _ = writeln!(s, "v {name} {} {y} {h};", x + off);
                names.push(name);
            }
            let _ = writeln!(s, "f ({}) ceiling;", names.join(" "));
        }
    }
    ug::parse(s.as_bytes(), "building")
        .expect("generated model parses")
        .model
}

fn bench(c: &mut Criterion) {
    let m = building(33); // 4·33² floors + 4·33·34 walls + 33² ceilings = 9,933 faces
    // UGVLMERGE_BENCH_MODEL=FILE writes the generated model, to try the tools on it.
    if let Some(p) = std::env::var_os("UGVLMERGE_BENCH_MODEL") {
        std::fs::write(p, ug::write_string(&m)).expect("write the model");
    }
    assert!(m.faces.len() > 9_900, "{}", m.faces.len());
    let eps = cli::epsilon(None, &m);
    let opts = ugvlmerge::Options::new(eps);
    let (out, st) = ugvlmerge::vlmerge(m.clone(), &opts).expect("flat model");
    assert!(st.vertices_merged > 0 && st.tvertices > 0 && st.faces_joined > 0);
    assert!(out.faces.len() < m.faces.len());
    let mut g = c.benchmark_group("ugvlmerge");
    g.sample_size(10);
    g.bench_function("vlmerge_10k_faces", |b| {
        b.iter_batched(
            || m.clone(),
            |m| ugvlmerge::vlmerge(m, &opts),
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
