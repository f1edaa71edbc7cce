//! Benchmarks of the patch mesher, in patches made per second:
//!
//! * `building_10k_faces`: a clean generated ~10,000-face building
//!   (crates/building) with the patch length chosen for about 100,000
//!   patches (floors, pentagonal wall feet, ceilings: grids and triangles);
//! * `wall_100k_cells`: one 500 × 200 rectangle with length 1 — a grid of
//!   100,000 rectangular cells.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn opts(len: f64, eps: f64) -> libmesh::patch::Options {
    libmesh::patch::Options {
        len,
        eps,
        angle: 25.0,
        quads: true,
    }
}

fn bench(c: &mut Criterion) {
    let dirt = building::Dirt::default();
    let (x, y) = building::rooms_for_faces(10_000, &dirt);
    let m = building::generate(x, y, &dirt, 1);
    let eps = cli::epsilon(None, &m);
    // Patches go about as 1/len² (edges are divided in whole numbers): a
    // few trial cuts set the length for ~100,000.
    let mut len = 1.0;
    let mut best = (usize::MAX, len);
    for _ in 0..4 {
        let (_, trial) = libmesh::patch::cut(&m, opts(len, eps)).expect("meshed");
        if trial.patches.abs_diff(100_000) < best.0 {
            best = (trial.patches.abs_diff(100_000), len);
        }
        len *= (trial.patches as f64 / 100_000.0).sqrt();
    }
    let len = best.1;
    let (_, st) = libmesh::patch::cut(&m, opts(len, eps)).expect("meshed");
    assert!(st.plain.is_empty());
    eprintln!(
        "ugcut building: {} faces ({x} × {y} rooms), len {len:.4} → {} patches ({} quads, {} triangles, {} grid cells), edges {:.3}..{:.3}, worst angle {:.1}°",
        m.faces.len(),
        st.patches,
        st.quads,
        st.triangles,
        st.grid_cells,
        st.min_edge,
        st.max_edge,
        st.worst_angle
    );

    let wall = ug::parse(
        b"c_rgb wall 0.8 0.8 0.8;\nv a 0 0 0; v b 500 0 0; v c 500 0 200; v d 0 0 200;\nf wall (a b c d) wall;\n".as_slice(),
        "wall",
    )
    .expect("parses")
    .model;
    let weps = cli::epsilon(None, &wall);
    let (_, ws) = libmesh::patch::cut(&wall, opts(1.0, weps)).expect("meshed");
    assert_eq!(ws.grid_cells, 100_000);
    assert_eq!(ws.patches, 100_000);
    eprintln!("ugcut wall: 500 × 200, len 1 → {} patches", ws.patches);

    let mut g = c.benchmark_group("ugcut");
    g.sample_size(10);
    g.throughput(Throughput::Elements(st.patches as u64));
    g.bench_function("building_10k_faces_100k_patches", |b| {
        b.iter(|| libmesh::patch::cut(&m, opts(len, eps)))
    });
    g.throughput(Throughput::Elements(ws.patches as u64));
    g.bench_function("wall_100k_cells", |b| {
        b.iter(|| libmesh::patch::cut(&wall, opts(1.0, weps)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
