//! Benchmark: the grouper on a generated ~10,000-face building with the
//! defects it removes.
//!
//! `building::building(n)` (crates/building): a grid of n × n rooms
//! (4 × 5 × 3). Each room's floor is 2 × 2 coplanar quads (joined into one
//! face per room; their mid-edge vertices are T-vertices on the walls' feet);
//! each wall segment is a lower and an upper quad (joined), the upper one
//! with its own copies of the middle vertices, offset by 1e-10; each ceiling
//! has its own copies of the room's corners, offset by up to 2e-10 (merged).

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let m = building::building(33); // 4·33² floors + 4·33·34 walls + 33² ceilings = 9,933 faces
    // UGVLMERGE_BENCH_MODEL=FILE writes the generated model, to try the tools on it.
    if let Some(p) = std::env::var_os("UGVLMERGE_BENCH_MODEL") {
        std::fs::write(p, ug::write_string(&m)).expect("write the model");
    }
    assert!(m.faces.len() > 9_900, "{}", m.faces.len());
    let eps = cli::epsilon(None, &m);
    let opts = clean::group::Options::new(eps);
    let (out, st) = clean::group::vlmerge(m.clone(), &opts).expect("flat model");
    assert!(st.vertices_merged > 0 && st.tvertices > 0 && st.faces_joined > 0);
    assert!(out.faces.len() < m.faces.len());
    let mut g = c.benchmark_group("ugvlmerge");
    g.sample_size(10);
    g.bench_function("vlmerge_10k_faces", |b| {
        b.iter_batched(
            || m.clone(),
            |m| clean::group::vlmerge(m, &opts),
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
