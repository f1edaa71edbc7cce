//! Milliseconds per shot of each hemi-cube method and of CPU ray casting on
//! generated room grids of about 10k, 100k and 1M triangles.
//!
//!     cargo run --release -p hemicube --example bench [-- TRIANGLES… [--shots K] [--res N] [--methods depth,points,decal,ray]]
//!
//! Each room is 4 × 5 × 3 with a table, cut into square patches sized to
//! reach the triangle count; shooters are patch centres spread over the
//! scene; the candidates are the vertices in front of the shooter that face
//! it (what the solver asks about). Times are the `Visibility::visible` call
//! alone (after one warm-up shot).

use glam::DVec3;
use hemicube::{Hemicube, Method, Options};
use libmesh::{Mesh, VertId};
use radiosity::{RayVisibility, Visibility};
use std::fmt::Write as _;
use std::time::Instant;

fn scene(target_tris: usize) -> String {
    let rooms_per_side = ((target_tris as f64 / 1.0e5).sqrt().ceil() as usize).max(1);
    let rooms = rooms_per_side * rooms_per_side;
    // Area per room: 94 m² of shell and 2 × 3 m² of table; 2 triangles per cell.
    let cell = ((94.0 + 6.0) * rooms as f64 * 2.0 / target_tris as f64).sqrt();
    let mut out = String::from("c_rgb w 0.7 0.7 0.7;\n");
    let mut count = 0usize;
    let mut grid = |out: &mut String, o: DVec3, a: DVec3, b: DVec3| {
        let n = ((a.length() / cell).round() as usize).max(1);
        let m = ((b.length() / cell).round() as usize).max(1);
        for i in 0..n {
            for j in 0..m {
                let p = |di: usize, dj: usize| {
                    o + a * ((i + di) as f64 / n as f64) + b * ((j + dj) as f64 / m as f64)
                };
                let mut names = Vec::with_capacity(4);
                for q in [p(0, 0), p(1, 0), p(1, 1), p(0, 1)] {
                    count += 1;
                    let _ = writeln!(out, "v v{count} {} {} {};", q.x, q.y, q.z);
                    names.push(format!("v{count}"));
                }
                let _ = writeln!(out, "f ({}) w;", names.join(" "));
            }
        }
    };
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    for r in 0..rooms {
        let o = DVec3::new(
            (r % rooms_per_side) as f64 * 4.2,
            (r / rooms_per_side) as f64 * 5.2,
            0.0,
        );
        grid(&mut out, o, x * 4.0, y * 5.0);
        grid(&mut out, o + z * 3.0, y * 5.0, x * 4.0);
        grid(&mut out, o, z * 3.0, x * 4.0);
        grid(&mut out, o + y * 5.0, x * 4.0, z * 3.0);
        grid(&mut out, o, y * 5.0, z * 3.0);
        grid(&mut out, o + x * 4.0, z * 3.0, y * 5.0);
        let t = o + DVec3::new(1.0, 1.5, 0.8);
        grid(&mut out, t, x * 2.0, y * 1.5);
        grid(&mut out, t, y * 1.5, x * 2.0);
    }
    out
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut sizes = Vec::new();
    let mut shots = 5usize;
    let mut res = 512u32;
    let mut methods = vec![
        "ray".to_string(),
        "depth".into(),
        "points".into(),
        "decal".into(),
    ];
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--shots" => {
                shots = args[i + 1].parse().expect("--shots K");
                i += 1;
            }
            "--res" => {
                res = args[i + 1].parse().expect("--res N");
                i += 1;
            }
            "--methods" => {
                methods = args[i + 1].split(',').map(String::from).collect();
                i += 1;
            }
            t => sizes.push(t.parse::<usize>().expect("a triangle count")),
        }
        i += 1;
    }
    if sizes.is_empty() {
        sizes = vec![10_000, 100_000, 1_000_000];
    }
    // SAFETY: before any thread exists.
    unsafe { gpu::prepare_env() };
    println!("| triangles | vertices | candidates/shot | method | ms per shot | questionable |");
    println!("|---:|---:|---:|---|---:|---:|");
    for &n in &sizes {
        let text = scene(n);
        let model = ug::parse(text.as_bytes(), "bench.ug")
            .expect("scene parses")
            .model;
        let mesh = Mesh::from_model(&model, 1e-6).expect("scene meshes");
        drop(model);
        let tris: usize = mesh
            .patches()
            .map(|p| mesh.patch_corners(p).len() - 2)
            .sum();
        let patches: Vec<_> = mesh.patches().collect();
        let step = (patches.len() / (shots + 1)).max(1);
        let shooters: Vec<_> = (0..=shots)
            .map(|k| patches[(k * step + step / 2) % patches.len()])
            .collect();
        let jobs: Vec<(DVec3, libmesh::SurfaceId, Vec<VertId>)> = shooters
            .iter()
            .map(|&p| {
                let c = mesh.patch_corners(p);
                let from = c.iter().map(|&v| mesh.vertex_pos(v)).sum::<DVec3>() / c.len() as f64;
                let s = mesh.patch_surface(p);
                let nrm = mesh.surface_normal(s);
                let cand = (0..mesh.num_vertices() as u32)
                    .map(VertId)
                    .filter(|&v| {
                        let d = mesh.vertex_pos(v) - from;
                        mesh.vertex_surface(v) != s
                            && d.dot(nrm) >= 0.0
                            && -d.dot(mesh.vertex_normal(v)) > 0.0
                    })
                    .collect();
                (from, s, cand)
            })
            .collect();
        let mean_cand = jobs.iter().skip(1).map(|j| j.2.len()).sum::<usize>() / shots.max(1);
        for m in &methods {
            let ray;
            let mut hc: Option<Hemicube> = None;
            let vis: &dyn Visibility = if m == "ray" {
                ray = RayVisibility::new(&mesh);
                &ray
            } else {
                let method = Method::parse(m).expect("method: depth, points, decal or ray");
                let g = match gpu::open(&gpu::Request {
                    optional: hemicube::POINTS_FEATURE,
                    ..Default::default()
                }) {
                    Ok(g) => g,
                    Err(e) => {
                        println!(
                            "| {tris} | {} | {mean_cand} | {m} | no GPU: {e} | |",
                            mesh.num_vertices()
                        );
                        continue;
                    }
                };
                match Hemicube::new(
                    g,
                    &mesh,
                    Options {
                        res,
                        method,
                        ..Default::default()
                    },
                ) {
                    Ok(h) => hc.insert(h),
                    Err(e) => {
                        println!(
                            "| {tris} | {} | {mean_cand} | {m} | {e} | |",
                            mesh.num_vertices()
                        );
                        continue;
                    }
                }
            };
            let mut total = 0.0;
            for (k, (from, s, cand)) in jobs.iter().enumerate() {
                let t = Instant::now();
                let r = vis.visible(&mesh, *from, *s, cand);
                let dt = t.elapsed().as_secs_f64();
                assert_eq!(r.len(), cand.len());
                if k > 0 {
                    total += dt;
                }
            }
            let q = match &hc {
                None => String::new(),
                Some(h) => {
                    let st = h.stats();
                    format!(
                        "{:.1}%",
                        100.0 * st.questionable as f64 / st.candidates.max(1) as f64
                    )
                }
            };
            println!(
                "| {tris} | {} | {mean_cand} | {m} | {:.1} | {q} |",
                mesh.num_vertices(),
                1e3 * total / shots.max(1) as f64
            );
        }
    }
}
