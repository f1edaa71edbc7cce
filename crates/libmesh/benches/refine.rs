//! Refinement throughput, in elements made per second.
//!
//! * `uniform`: a 100 × 100 grid of quad patches refined uniformly three
//!   levels (840 000 elements made, no balancing needed).
//! * `random`: random leaves of a 30 × 30 grid of triangles and quads (a floor
//!   and a wall, so stitching too) split until 200 000 elements exist,
//!   balancing as needed.
//!
//! Also prints the memory per element of the structures.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use libmesh::{ElemId, Mesh, Split};

/// An `n` × `n` grid of unit quads at z = 0.
fn grid(n: usize) -> ug::Model {
    let mut s = String::from("c_rgb grey 0.5 0.5 0.5;\n");
    for j in 0..=n {
        for i in 0..=n {
            s += &format!("v g{i}_{j} {i} {j} 0;\n");
        }
    }
    for j in 0..n {
        for i in 0..n {
            s += &format!(
                "f (g{i}_{j} g{}_{j} g{}_{} g{i}_{}) grey;\n",
                i + 1,
                i + 1,
                j + 1,
                j + 1
            );
        }
    }
    ug::parse(s.as_bytes(), "<bench>").unwrap().model
}

/// A floor of `n` × `n` cells (each two triangles or a quad) and an `n` × `n`
/// quad wall standing on its y = 0 edge.
fn room(n: usize) -> ug::Model {
    let mut s = String::from("c_rgb grey 0.5 0.5 0.5;\n");
    for j in 0..=n {
        for i in 0..=n {
            s += &format!("v f{i}_{j} {i} {j} 0;\n");
            if j > 0 {
                s += &format!("v w{i}_{j} {i} 0 {j};\n");
            }
        }
    }
    let w = |i: usize, j: usize| {
        if j == 0 {
            format!("f{i}_0")
        } else {
            format!("w{i}_{j}")
        }
    };
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (
                format!("f{i}_{j}"),
                format!("f{}_{j}", i + 1),
                format!("f{}_{}", i + 1, j + 1),
                format!("f{i}_{}", j + 1),
            );
            if (i + j) % 3 == 0 {
                s += &format!("f ({a} {b} {c}) grey;\nf ({a} {c} {d}) grey;\n");
            } else {
                s += &format!("f ({a} {b} {c} {d}) grey;\n");
            }
            // Wall cell, facing +y.
            s += &format!(
                "f ({} {} {} {}) grey;\n",
                w(i, j),
                w(i, j + 1),
                w(i + 1, j + 1),
                w(i + 1, j)
            );
        }
    }
    ug::parse(s.as_bytes(), "<bench>").unwrap().model
}

fn uniform(mesh: &mut Mesh, levels: usize) {
    let mut s = Split::default();
    for _ in 0..levels {
        let leaves: Vec<ElemId> = mesh.leaves().collect();
        for e in leaves {
            mesh.split_into(e, &mut s);
        }
    }
}

fn random(mesh: &mut Mesh, target: usize) {
    let mut s = Split::default();
    let mut k = 0x2545_f491u64;
    while mesh.num_elements() < target {
        k = k
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        // Any element: split only leaves, up to level 8.
        let e = ElemId(((k >> 33) % mesh.num_elements() as u64) as u32);
        if mesh.elem_is_leaf(e) && mesh.elem_level(e) < 8 {
            mesh.split_into(e, &mut s);
        }
    }
}

fn bench(c: &mut Criterion) {
    let g = grid(100);
    let base = Mesh::from_model(&g, 1e-9).unwrap();
    let mut m = base.clone();
    uniform(&mut m, 3);
    let made = (m.num_elements() - base.num_elements()) as u64;
    let (elem, vert, entry) = Mesh::record_sizes();
    eprintln!(
        "uniform: {} elements ({} leaves), {} vertices, {} midpoint entries; \
         records: element {elem} B, vertex {vert} B, midpoint entry {entry} B; \
         heap {:.1} B per element, {:.1} B per leaf",
        m.num_elements(),
        m.num_leaves(),
        m.num_vertices(),
        m.num_edge_midpoints(),
        m.heap_bytes() as f64 / m.num_elements() as f64,
        m.heap_bytes() as f64 / m.num_leaves() as f64,
    );
    let exact = (m.num_elements() * elem
        + m.num_vertices() * vert
        + m.num_edge_midpoints() * entry * 8 / 7) as f64;
    eprintln!(
        "uniform: records alone (no vector slack, map 7/8 full): {:.1} B per element, {:.1} B per leaf",
        exact / m.num_elements() as f64,
        exact / m.num_leaves() as f64
    );
    let mut grp = c.benchmark_group("refine");
    grp.throughput(Throughput::Elements(made));
    grp.bench_function("uniform_100x100_3_levels", |b| {
        b.iter_batched(
            || base.clone(),
            |mut m| {
                uniform(&mut m, 3);
                black_box(m.num_elements())
            },
            BatchSize::LargeInput,
        )
    });

    let r = room(30);
    let base = Mesh::from_model(&r, 1e-9).unwrap();
    let target = 200_000;
    let mut m = base.clone();
    random(&mut m, target);
    m.validate().unwrap();
    eprintln!(
        "random: {} elements ({} leaves), {} vertices, max level {}; heap {:.1} B per element",
        m.num_elements(),
        m.num_leaves(),
        m.num_vertices(),
        m.leaves().map(|e| m.elem_level(e)).max().unwrap_or(0),
        m.heap_bytes() as f64 / m.num_elements() as f64,
    );
    grp.throughput(Throughput::Elements(
        (m.num_elements() - base.num_elements()) as u64,
    ));
    grp.bench_function("random_room_30", |b| {
        b.iter_batched(
            || base.clone(),
            |mut m| {
                random(&mut m, target);
                black_box(m.num_elements())
            },
            BatchSize::LargeInput,
        )
    });

    // Reading the mesh: anchored pieces of every leaf.
    let mut pieces = 0usize;
    m.leaves()
        .for_each(|e| m.for_each_anchored(e, |_| pieces += 1));
    grp.throughput(Throughput::Elements(m.num_leaves() as u64));
    grp.bench_function("anchored_all_leaves", |b| {
        b.iter(|| {
            let mut n = 0usize;
            for e in m.leaves() {
                m.for_each_anchored(e, |p| n += p.len());
            }
            black_box(n)
        })
    });
    grp.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
