//! The indirect tail (`tail.rs`) against closed forms and against
//! progressive shooting to the end.

use radiosity::{Options, RayVisibility, Solver};

mod common;
use common::patches;

/// An axis-aligned box as six faces, facing inward (`inward`) or outward.
fn boxed(s: &mut String, name: &str, lo: [f64; 3], hi: [f64; 3], inward: bool, mat: &str) {
    let c = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    for i in 0..8 {
        let p = c(i);
        s.push_str(&format!("v {name}{i} {} {} {};\n", p[0], p[1], p[2]));
    }
    // Outward counter-clockwise.
    for (k, f) in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ]
    .iter()
    .enumerate()
    {
        let mut f = f.to_vec();
        if inward {
            f.reverse();
        }
        let v: Vec<String> = f.iter().map(|i| format!("{name}{i}")).collect();
        s.push_str(&format!("f {name}f{k} ({}) {mat};\n", v.join(" ")));
    }
}

/// A unit cube facing inward, ρ = 0.5 and E = 1 everywhere.
fn enclosure() -> String {
    let mut s = String::from("defmat wall; diffuse_rgb 0.5 0.5 0.5; emission_rgb 1 1 1; end;\n");
    boxed(&mut s, "c", [0.0; 3], [1.0; 3], true, "wall");
    s
}

/// A 4 × 3 × 2.5 room lit by a ceiling panel, with a block on the floor.
fn room() -> String {
    let mut s = String::from(
        "defmat wall; diffuse_rgb 0.7 0.6 0.5; end;
         defmat block; diffuse_rgb 0.2 0.5 0.8; end;
         defmat lamp; diffuse_rgb 0.5 0.5 0.5; emission_rgb 10 10 10; end;
         v l0 1.5 1 2.45; v l1 2.5 1 2.45; v l2 2.5 2 2.45; v l3 1.5 2 2.45;
         f lamp (l0 l3 l2 l1) lamp;\n",
    );
    boxed(&mut s, "r", [0.0; 3], [4.0, 3.0, 2.5], true, "wall");
    boxed(
        &mut s,
        "b",
        [2.3, 0.8, 0.0],
        [3.3, 1.8, 0.8],
        false,
        "block",
    );
    s
}

fn solve(model: &ug::Model, opts: Options) -> Solver<'static> {
    let mesh = libmesh::Mesh::from_model(model, 1e-9).unwrap();
    let vis: &'static RayVisibility = Box::leak(Box::new(RayVisibility::new(&mesh)));
    let mut solver = Solver::new(mesh, &model.materials, vis, opts);
    solver.solve(None, |_| {});
    solver
}

/// Area-weighted mean radiosity per surface (sum of channels).
fn surface_means(s: &Solver) -> Vec<f64> {
    let m = &s.mesh;
    let mut acc = vec![(0.0, 0.0); m.num_surfaces()];
    for e in m.leaves() {
        let c = m.elem_corners(e);
        let b: f64 = c
            .iter()
            .map(|&v| s.radiosity(v).iter().sum::<f64>())
            .sum::<f64>()
            / c.len() as f64;
        let a = m.elem_area(e);
        let k = m.elem_surface(e).idx();
        acc[k].0 += a * b;
        acc[k].1 += a;
    }
    acc.iter().map(|(x, a)| x / a).collect()
}

#[test]
fn the_tail_gives_e_over_one_minus_rho_in_a_closed_enclosure() {
    let model = patches(&enclosure(), 0.25);
    // Uniform shooters (the report's rule) once, shaped ones (the default)
    // with and without rays.
    for (shape, rays, tol) in [
        (false, Some(0), 5e-3),
        (true, Some(0), 1e-2),
        (true, Some(256), 1e-2),
    ] {
        let opts = Options {
            converge: 1e-6,
            gradient: Some(1e30),
            tail: 1.0,
            tail_rays: rays,
            shape,
            ..Options::default()
        };
        let s = solve(&model, opts);
        let t = s.tail.clone().expect("the tail ran");
        // It started once every patch (all emit) had shot.
        assert!(t.after_shots >= s.mesh.num_patches(), "{t:?}");
        assert_eq!(t.rays, rays.unwrap());
        assert!(t.unshot_after <= 1e-6 && t.iterations > 5, "{t:?}");
        // The bookkeeping agrees with the tail's own figure.
        assert!(
            (s.unshot_fraction() - t.unshot_after).abs() <= 1e-9,
            "{t:?}"
        );
        // Energy: every wall's mean is 2 (E / (1 − ρ)), whatever the rule.
        for (k, m) in surface_means(&s).iter().enumerate() {
            assert!(
                (m / 3.0 - 2.0).abs() < 2e-3,
                "shape {shape}, rays {rays:?}, wall {k}: mean {}",
                m / 3.0
            );
        }
        // Vertex by vertex: shooting patch by patch reaches 2 within 2e-3;
        // the tail's patches reflect what their centres receive while the
        // shots' leftovers were measured over their elements, which costs a
        // little more (2.0036 at worst). Shaped shooters, 4 × 4 patches a
        // wall and no subdivision, measured +0.9% at the box's corners and
        // −0.6% beside them, and as much with 8 × 8 patches: a corner sees
        // the adjacent walls' light at the corner, linear over each patch,
        // and feeds it back (docs/decisions.md, "Shaped shooters").
        for v in 0..s.mesh.num_vertices() {
            let b = s.radiosity(libmesh::VertId(v as u32));
            for x in b {
                assert!(
                    (x - 2.0).abs() < tol,
                    "shape {shape}, rays {rays:?}, vertex {v}: B = {x}"
                );
            }
        }
    }
}

/// Against progressive shooting to 1e-4, in a room lit by a ceiling panel
/// with a block on the floor (13 surfaces, 688 patch corners at 0.35): the
/// tail starts right after the lamp has shot (tail fraction 1), so it
/// carries all of the reflected light. Measured per surface, area-weighted
/// mean radiosity: walls, floor and ceiling within 0.9%, the block's sides
/// within 2.3% (reflected light at patch resolution), whether every patch
/// is tried or 256 rays find them; 16 rays miss 6–7%. (Patches of 0.25,
/// 1,257 corners, measured 0.95% and 2.0%, but the reference's 8,500
/// shots took CI over a minute; at 0.5 the tail's patches are too coarse
/// for the room's 1%: 3.0%.)
#[test]
fn the_tail_agrees_with_shooting_to_the_end_in_a_lit_room() {
    let model = patches(&room(), 0.35);
    let base = Options {
        converge: 1e-4,
        ..Options::default()
    };
    let exact = solve(
        &model,
        Options {
            tail: 0.0,
            // §6's mean for new vertices, as when the figures were measured
            // (the re-shot would cost this 5,000-shot run a quarter minute).
            regather: false,
            ..base.clone()
        },
    );
    assert!(exact.tail.is_none());
    assert!(exact.shots.len() > 4000, "{}", exact.shots.len());
    let want = surface_means(&exact);
    // Surfaces: the lamp, the room's six faces, the block's six (one on the floor, dark).
    assert_eq!(want.len(), 13);
    let mut errors = Vec::new();
    for rays in [0, 256, 16] {
        let s = solve(
            &model,
            Options {
                tail: 1.0,
                tail_rays: Some(rays),
                ..base.clone()
            },
        );
        let t = s.tail.clone().expect("the tail ran");
        assert_eq!(t.after_shots, s.shots.len());
        assert!(t.after_shots <= 20, "{t:?}");
        assert!(t.unshot_after <= 1e-4, "{t:?}");
        let got = surface_means(&s);
        let rel: Vec<f64> = want
            .iter()
            .zip(&got)
            .map(|(a, b)| if *a > 0.0 { (b - a) / a } else { *b })
            .collect();
        let room = rel[..7].iter().map(|x| x.abs()).fold(0.0, f64::max);
        let all = rel.iter().map(|x| x.abs()).fold(0.0, f64::max);
        eprintln!("rays {rays}: {t:?}; worst room surface {room:.4}, worst surface {all:.4}");
        errors.push((room, all));
    }
    // Every patch tried.
    assert!(errors[0].0 < 0.012 && errors[0].1 < 0.04, "{errors:?}");
    // 256 rays: about the same.
    assert!(errors[1].0 < 0.012 && errors[1].1 < 0.04, "{errors:?}");
    // Far fewer rays miss more: the test can tell. (At 64 rays the room
    // was within 1%: the corners try what the patch centres around them
    // found; at 16 it is 6–8% off.)
    assert!(errors[2].0 > errors[1].0 + 0.01, "{errors:?}");
}

/// Interrupted while the tail builds its transport: nothing of the tail is
/// applied, the solution is the shots' so far, and the solver says why.
#[test]
fn an_interrupt_during_the_tail_keeps_the_shots_solution() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let model = patches(&room(), 0.5);
    let mesh = libmesh::Mesh::from_model(&model, 1e-9).unwrap();
    let vis = RayVisibility::new(&mesh);
    let opts = Options {
        tail: 1.0,
        batch: 1,
        ..Options::default()
    };
    let mut solver = Solver::new(mesh, &model.materials, &vis, opts);
    let flag = Arc::new(AtomicBool::new(false));
    let f = flag.clone();
    let mut before = None;
    let stop = solver.solve(Some(flag.clone()), |s| {
        // The lamp's four patches shoot first; the tail starts after them.
        assert!(s.shot <= 4, "shot {} after the lamp", s.shot);
        before = Some(s.unshot);
        if s.shot == 4 {
            f.store(true, Ordering::Relaxed);
        }
    });
    assert_eq!(stop, radiosity::Stop::Interrupted);
    let t = solver.tail.clone().expect("the tail started");
    assert_eq!((t.receivers, t.pairs, t.iterations), (0, 0, 0), "{t:?}");
    let before = before.unwrap();
    assert!((solver.unshot_fraction() - before).abs() < 1e-12);
    assert!(before > 0.3);
}
