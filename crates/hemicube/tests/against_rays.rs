//! The hemi-cube against the ray-cast reference on a furnished room: the
//! same answers for every vertex from many shooter points. Skips without a
//! GPU adapter unless `UG_REQUIRE_GPU=1`.

use glam::DVec3;
use hemicube::{Hemicube, Method, Options};
use libmesh::{Mesh, VertId};
use radiosity::{RayVisibility, Visibility};

/// A 6 × 5 × 3 room (faces inward) cut into 0.5 patches, with a table (a
/// floating slab), a free-standing screen and a box on the floor.
fn room() -> String {
    let mut s = String::from("c_rgb w 0.7 0.7 0.7;\n");
    let mut nv = 0;
    let mut quad = |s: &mut String, o: DVec3, a: DVec3, b: DVec3, n: usize, m: usize| {
        // An n × m grid of quads spanning o + [0,1]a + [0,1]b, facing a × b.
        for i in 0..n {
            for j in 0..m {
                let p = |di: usize, dj: usize| {
                    o + a * ((i + di) as f64 / n as f64) + b * ((j + dj) as f64 / m as f64)
                };
                let c = [p(0, 0), p(1, 0), p(1, 1), p(0, 1)];
                let names: Vec<String> = c
                    .iter()
                    .map(|q| {
                        nv += 1;
                        s.push_str(&format!("v p{nv} {} {} {};\n", q.x, q.y, q.z));
                        format!("p{nv}")
                    })
                    .collect();
                s.push_str(&format!("f ({}) w;\n", names.join(" ")));
            }
        }
    };
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    let (lx, ly, lz) = (6.0, 5.0, 3.0);
    // Floor faces up, ceiling down, walls inward.
    quad(&mut s, DVec3::ZERO, x * lx, y * ly, 12, 10);
    quad(&mut s, z * lz, y * ly, x * lx, 10, 12);
    quad(&mut s, DVec3::ZERO, z * lz, x * lx, 6, 12);
    quad(&mut s, y * ly, x * lx, z * lz, 12, 6);
    quad(&mut s, DVec3::ZERO, y * ly, z * lz, 10, 6);
    quad(&mut s, x * lx, z * lz, y * ly, 6, 10);
    // Table top at 0.8 (both sides), a screen at x = 4, a box.
    let t = DVec3::new(1.5, 1.5, 0.8);
    quad(&mut s, t, x * 2.0, y * 1.5, 4, 3);
    quad(&mut s, t, y * 1.5, x * 2.0, 3, 4);
    let sc = DVec3::new(4.0, 0.5, 0.2);
    quad(&mut s, sc, y * 2.0, z * 1.6, 4, 3);
    quad(&mut s, sc, z * 1.6, y * 2.0, 3, 4);
    let b = DVec3::new(4.5, 3.5, 0.0);
    quad(&mut s, b + z * 0.7, x * 0.8, y * 0.8, 2, 2);
    quad(&mut s, b, x * 0.8, z * 0.7, 2, 2);
    quad(&mut s, b + y * 0.8, z * 0.7, x * 0.8, 2, 2);
    quad(&mut s, b, z * 0.7, y * 0.8, 2, 2);
    quad(&mut s, b + x * 0.8, y * 0.8, z * 0.7, 2, 2);
    s
}

fn mesh() -> Mesh {
    let m = ug::parse(room().as_bytes(), "room.ug").unwrap().model;
    Mesh::from_model(&m, 1e-6).unwrap()
}

/// Opens a device with the optional features the methods use.
fn device() -> Option<gpu::Gpu> {
    match gpu::open(&gpu::Request {
        optional: hemicube::POINTS_FEATURE,
        ..Default::default()
    }) {
        Ok(g) => Some(g),
        Err(e) if !gpu::require_gpu() => {
            eprintln!("skipping GPU test: {e}");
            None
        }
        Err(e) => panic!("UG_REQUIRE_GPU=1 but no GPU device: {e}"),
    }
}

/// (tests, hidden by rays, wrong before ray casting, wrong after, questionable).
fn agreement(method: Method) -> Option<(usize, usize, usize, usize, usize)> {
    let g = device()?;
    if method == Method::Points && !g.features.contains(hemicube::POINTS_FEATURE) {
        eprintln!(
            "skipping points: {} lacks SHADER_EARLY_DEPTH_TEST",
            g.describe()
        );
        return None;
    }
    let mesh = mesh();
    let hc = match Hemicube::new(
        g,
        &mesh,
        Options {
            method,
            ..Default::default()
        },
    ) {
        Ok(hc) => hc,
        // (An OpenGL adapter, where Vulkan's driver is missing, cannot
        // build every method's shaders.)
        Err(e) if !gpu::require_gpu() => {
            eprintln!("skipping GPU test: {e}");
            return None;
        }
        Err(e) => panic!("{e}"),
    };
    let ray = RayVisibility::new(&mesh);
    let all: Vec<VertId> = (0..mesh.num_vertices() as u32).map(VertId).collect();
    let (mut total, mut hidden, mut before, mut after, mut questionable) = (0, 0, 0, 0, 0);
    let patches: Vec<_> = mesh.patches().collect();
    // Shooters spread over every surface: every 23rd patch's centre.
    for &p in patches.iter().step_by(23) {
        let c = mesh.patch_corners(p);
        let from = c.iter().map(|&v| mesh.vertex_pos(v)).sum::<DVec3>() / c.len() as f64;
        let s = mesh.patch_surface(p);
        // The candidates the solver asks about: not on the shooter's surface,
        // in front of (or on) its plane, and facing it. (Behind it the form
        // factor is zero, and the ray caster, which ignores the shooter's own
        // surface, says visible.)
        let n = mesh.surface_normal(s);
        let cand: Vec<VertId> = all
            .iter()
            .copied()
            .filter(|&v| {
                let d = mesh.vertex_pos(v) - from;
                mesh.vertex_surface(v) != s
                    && d.dot(n) >= 0.0
                    && -d.dot(mesh.vertex_normal(v)) > 0.0
            })
            .collect();
        let raw = hc.classify(&mesh, from, s, &cand).unwrap();
        let a = hc.visible(&mesh, from, s, &cand);
        let b = ray.visible(&mesh, from, s, &cand);
        assert_eq!(a.len(), b.len());
        total += a.len();
        hidden += b.iter().filter(|&&x| !x).count();
        before += raw.raw.iter().zip(&b).filter(|(x, y)| x != y).count();
        after += a.iter().zip(&b).filter(|(x, y)| x != y).count();
        if std::env::var("HC_RAW").is_ok() {
            for (k, (x, y)) in raw.raw.iter().zip(&b).enumerate() {
                if x != y {
                    let v = cand[k];
                    eprintln!(
                        "RAW from {from} n {n} to {} (n {}) q {}: hemicube {x} ray {y}",
                        mesh.vertex_pos(v),
                        mesh.vertex_normal(v),
                        raw.questionable[k]
                    );
                }
            }
        }
        if std::env::var("HC_DEBUG").is_ok() {
            for (k, (x, y)) in a.iter().zip(&b).enumerate() {
                if x != y {
                    let v = cand[k];
                    eprintln!(
                        "from {from} n {n} to {} (n {}): hemicube {x} ray {y}",
                        mesh.vertex_pos(v),
                        mesh.vertex_normal(v)
                    );
                }
            }
        }
        questionable += raw.questionable.iter().filter(|&&q| q).count();
    }
    let st = hc.stats();
    assert_eq!(st.fallbacks, 0, "{:?}", hc.last_error());
    eprintln!(
        "{}: {total} vertex tests, {hidden} hidden by rays; wrong before ray casting {before} ({:.3}%), after {after} ({:.3}%); {questionable} questionable",
        method.name(),
        100.0 * before as f64 / total as f64,
        100.0 * after as f64 / total as f64
    );
    Some((total, hidden, before, after, questionable))
}

#[test]
fn depth_method_matches_ray_casting_on_a_furnished_room() {
    let Some((total, hidden, _before, after, questionable)) = agreement(Method::Depth) else {
        return;
    };
    assert!(hidden > total / 20, "the scene must hide something");
    // The goal: at most 0.1% misclassified after ray casting the questionable.
    assert!(
        (after as f64) <= 1e-3 * total as f64,
        "{after} of {total} differ"
    );
    // Most answers come from the GPU, not from the ray-cast fallback. (In
    // this coarse room most vertices lie on a surface's boundary, where they
    // receive a hair inside their surface, within a pixel of the face
    // standing there: those are ray cast. 44% measured; 26% before receiver
    // points were stepped in. A refined mesh has far fewer.)
    assert!(questionable < total / 2, "{questionable} of {total}");
}

#[test]
fn points_method_matches_ray_casting_on_a_furnished_room() {
    let Some((total, _, _, after, questionable)) = agreement(Method::Points) else {
        return;
    };
    assert!(
        (after as f64) <= 1e-3 * total as f64,
        "{after} of {total} differ"
    );
    assert!(questionable < total / 2, "{questionable} of {total}");
}

#[test]
fn decal_method_agrees_with_ray_casting_on_a_furnished_room() {
    let Some((total, _, before, after, _)) = agreement(Method::Decal) else {
        return;
    };
    // The decal algorithm as written loses vertices on the edges where
    // surfaces meet (a later surface's colour pass covers them); ray casting
    // the questionable ones repairs that.
    assert!(before > after, "{after} >= {before}");
    assert!(
        (after as f64) <= 1e-3 * total as f64,
        "{after} of {total} differ"
    );
}

#[test]
fn bad_resolutions_are_refused() {
    let Some(g) = device() else { return };
    let mesh = mesh();
    let e = Hemicube::new(
        g,
        &mesh,
        Options {
            res: 100,
            ..Default::default()
        },
    )
    .err()
    .unwrap();
    assert!(e.0.contains("multiple of 64"), "{e}");
}
