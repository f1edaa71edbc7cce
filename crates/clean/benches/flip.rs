//! Benchmark: automatic orientation (`clean::orient::orient`, default options) on a
//! generated ~10,000-face building (crates/building): rooms, a ceiling light
//! and two furniture boxes per room, 30% of all faces reversed. In faces per
//! second.

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let dirt = building::Dirt {
        flipped: 0.3,
        lights: true,
        furniture: 2,
        ..building::Dirt::default()
    };
    let (x, y) = building::rooms_for_faces(10_000, &dirt);
    let m = building::generate(x, y, &dirt, 1);
    let opts = clean::orient::Options {
        eps: cli::epsilon(None, &m),
        viewpoints: clean::orient::camera_eyes(&m),
        ..clean::orient::Options::default()
    };
    let (out, r) = clean::orient::orient(m.clone(), &opts).expect("no names asked for");
    assert!(r.flipped() > 0);
    // How many faces end as the generator meant them (a face's cycle may start elsewhere).
    let meant = building::generate(
        x,
        y,
        &building::Dirt {
            flipped: 0.0,
            ..dirt.clone()
        },
        1,
    );
    let same_way = |a: &[ug::VertexId], b: &[ug::VertexId]| {
        let k = b.iter().position(|v| *v == a[0]);
        k.is_some_and(|k| (0..a.len()).all(|i| a[i] == b[(k + i) % b.len()]))
    };
    let right = out
        .faces
        .iter()
        .zip(&meant.faces)
        .filter(|(o, w)| same_way(&o.contours[0], &w.contours[0]))
        .count();
    eprintln!(
        "ugflip: {} faces ({x} × {y} rooms), {} reversed by the generator; {} components, {} flipped ({} consistency, {} outward, {} inward, {} toward the scene), {} ambiguous; {right} faces end as the generator meant them",
        m.faces.len(),
        (0.3 * m.faces.len() as f64).round(),
        r.components,
        r.flipped(),
        r.consistency,
        r.outward,
        r.inward,
        r.toward_scene,
        r.ambiguous.len()
    );
    let mut g = c.benchmark_group("ugflip");
    g.sample_size(10);
    g.throughput(Throughput::Elements(m.faces.len() as u64));
    g.bench_function("orient_10k_faces_30pct_flipped", |b| {
        b.iter_batched(
            || m.clone(),
            |m| clean::orient::orient(m, &opts),
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
