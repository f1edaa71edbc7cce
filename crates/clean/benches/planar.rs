//! Benchmark: `clean::planar::planarize` on a generated ~10,000-face building
//! (crates/building) with 20% of its faces non-planar (floor quads with a
//! corner 1 cm off), in faces per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let dirt = building::Dirt {
        nonplanar: 0.2,
        ..building::Dirt::default()
    };
    let (x, y) = building::rooms_for_faces(10_000, &dirt);
    let m = building::generate(x, y, &dirt, 1);
    let eps = cli::epsilon(None, &m);
    let (_, st) = clean::planar::planarize(&m, eps);
    let expect = (0.2 * m.faces.len() as f64).round() as usize;
    assert_eq!(st.nonplanar, expect);
    assert!(st.failed.is_empty());
    eprintln!(
        "ugplanar: {} faces ({x} × {y} rooms), {} non-planar, {} triangles written",
        st.faces, st.nonplanar, st.triangles
    );
    let mut g = c.benchmark_group("ugplanar");
    g.throughput(Throughput::Elements(m.faces.len() as u64));
    g.bench_function("planarize_10k_faces_20pct_nonplanar", |b| {
        b.iter(|| clean::planar::planarize(&m, eps))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
