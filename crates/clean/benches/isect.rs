//! Benchmark: ugisect on generated buildings whose furniture boxes stand on
//! the floors (each box's four sides intersect its room's floor), at 1k and
//! 10k faces, to show how the time grows with faces plus intersections.

use criterion::{Criterion, criterion_group, criterion_main};

fn model(faces: usize) -> ug::Model {
    let dirt = building::Dirt {
        furniture: 2,
        ..building::Dirt::default()
    };
    let (rx, ry) = building::rooms_for_faces(faces, &dirt);
    building::generate(rx, ry, &dirt, 7)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("ugisect");
    g.sample_size(10);
    for faces in [1_000, 10_000] {
        let m = model(faces);
        let eps = cli::epsilon(None, &m);
        let (_, st) = clean::isect::isect(&m, eps).expect("flat model");
        eprintln!(
            "{} faces: {} intersecting pairs, {} faces cut into {} pieces",
            m.faces.len(),
            st.pairs,
            st.faces_cut,
            st.pieces
        );
        g.bench_function(
            format!("isect_{}_faces_{}_pairs", m.faces.len(), st.pairs),
            |b| b.iter(|| clean::isect::isect(&m, eps)),
        );
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
