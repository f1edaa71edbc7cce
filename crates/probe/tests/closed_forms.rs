//! The estimator against closed forms: each estimate within 3 standard
//! errors of the exact value (and the standard error small enough for the
//! test to mean something).

use glam::DVec3;
use probe::{Estimate, Options, Receiver, Scene};

/// A UG quadrilateral `name` with corners `c` (any order around it),
/// written so that its front (counter-clockwise side) faces `front`.
fn quad(out: &mut String, name: &str, c: [DVec3; 4], front: DVec3, mat: &str) {
    let n = geom::newell_normal(&c);
    let c = if n.dot(front) > 0.0 {
        c
    } else {
        [c[3], c[2], c[1], c[0]]
    };
    for (i, p) in c.iter().enumerate() {
        out.push_str(&format!("v {name}{i} {} {} {};\n", p.x, p.y, p.z));
    }
    out.push_str(&format!(
        "f {name} ({name}0 {name}1 {name}2 {name}3) {mat};\n"
    ));
}

fn scene(src: &str) -> Scene {
    let m = ug::parse(src.as_bytes(), "test.ug").expect("parses").model;
    Scene::new(&m).expect("a scene")
}

fn estimate_at(s: &Scene, p: DVec3, n: DVec3, opts: &Options, stream: u64) -> Estimate {
    let at = s
        .locate(p, n, 1e-6 * s.diagonal())
        .unwrap_or_else(|| panic!("{p} is on a face facing {n}"));
    s.estimate(&s.receiver(&at), opts, stream)
}

/// Asserts every channel within 3 standard errors of `want`, and the
/// standard error below `max_rel_se` of it.
fn assert_within_3_se(what: &str, e: &Estimate, want: [f64; 3], max_rel_se: f64) {
    println!(
        "{what}: estimate {:?} reference {want:?} se {:?} ({} paths)",
        e.b, e.se, e.samples
    );
    for (c, &w) in want.iter().enumerate() {
        let (b, se) = (e.b[c], e.se[c]);
        let dev = (b - w).abs();
        assert!(
            dev <= 3.0 * se,
            "{what}, channel {c}: {b} vs {w} ({:.2} standard errors of {se})",
            dev / se
        );
        assert!(
            se <= max_rel_se * w.abs(),
            "{what}, channel {c}: standard error {se} too large for {w}"
        );
    }
}

/// The unit cube, every face facing inward, all of one material.
fn furnace(mat: &str) -> String {
    let mut s = String::from(mat);
    let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let mut c = [DVec3::ZERO; 4];
            for (i, (u, v)) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                .into_iter()
                .enumerate()
            {
                c[i] = match axis {
                    0 => p(side, u, v),
                    1 => p(u, side, v),
                    _ => p(u, v, side),
                };
            }
            let mut inward = DVec3::ZERO;
            inward[axis] = if side == 0.0 { 1.0 } else { -1.0 };
            quad(&mut s, &format!("f{axis}{side}"), c, inward, "glow");
        }
    }
    s
}

/// (a) The closed furnace: B = E + ρH and H = B everywhere (every face
/// sees only the others, form factors summing to 1), so B = E / (1 − ρ).
#[test]
fn closed_furnace_gives_e_over_one_minus_rho() {
    let s = scene(&furnace(
        "defmat glow; diffuse_rgb 0.5 0.5 0.5; emission_rgb 1 2 0.5; end;\n",
    ));
    let want = [2.0, 4.0, 1.0];
    // Paths that sample the emitters and those that hit them are weighed
    // by multiple importance (ugprobe's README): points next to an edge
    // (the last one, 0.05 from two faces) no longer have the heavy tail
    // of the light sample's 1/r² (a point 1e-5 from a glowing ceiling read
    // 2.68 ± 1.0 at 20,000 paths; now 1.993 ± 0.003).
    let opts = Options {
        samples: 32768,
        ..Options::default()
    };
    for (k, (p, n)) in [
        (DVec3::new(0.5, 0.5, 0.0), DVec3::Z),
        (DVec3::new(0.3, 0.8, 1.0), -DVec3::Z),
        (DVec3::new(1.0, 0.1, 0.9), -DVec3::X),
        (DVec3::new(0.95, 0.0, 0.05), DVec3::Y),
        (DVec3::new(0.5, 0.99999, 0.0), DVec3::Z),
    ]
    .into_iter()
    .enumerate()
    {
        let e = estimate_at(&s, p, n, &opts, k as u64);
        assert_within_3_se(&format!("furnace at {p}"), &e, want, 0.005);
    }
}

/// The form factor from a differential area to a parallel a × b rectangle
/// at distance h, the area lying on the normal through one corner:
///
///   F = 1/π ∫₀ᵃ∫₀ᵇ h² / (x² + y² + h²)² dy dx
///
/// (cos θ₁ = cos θ₂ = h/r, r² = x² + y² + h²). With c² = x² + h²,
/// ∫₀ᵇ dy / (c² + y²)² = b / (2c²(c² + b²)) + atan(b/c) / (2c³), and the
/// outer integral gives the standard closed form, with A = a/h, B = b/h:
///
///   F = 1/(2π) [ A/√(1+A²) · atan(B/√(1+A²)) + B/√(1+B²) · atan(A/√(1+B²)) ]
///
/// Checks: as A, B → ∞ the rectangle becomes a quadrant of the plane, a
/// quarter of the hemisphere by symmetry: A/√(1+A²) → 1, B/√(1+B²) → 1 and
/// atan(B/A) + atan(A/B) = π/2, so F → 1/4. For small A, B, F ≈ AB/π (a
/// small patch straight above: cos θ₁ cos θ₂ / (π r²) · ab = ab / (π h²)).
/// `corner_form_factor_matches_quadrature` checks these limits and the
/// formula against a midpoint quadrature of the integral.
fn corner(a: f64, b: f64, h: f64) -> f64 {
    let (a, b) = (a / h, b / h);
    let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
    (a / sa * (b / sa).atan() + b / sb * (a / sb).atan()) / (2.0 * std::f64::consts::PI)
}

/// Form factor to the rectangle [x1, x2] × [y1, y2] (coordinates relative to
/// the foot of the normal through the receiving point), by inclusion and
/// exclusion of signed corner rectangles [0, x] × [0, y].
fn rect(x1: f64, x2: f64, y1: f64, y2: f64, h: f64) -> f64 {
    let g = |x: f64, y: f64| x.signum() * y.signum() * corner(x.abs(), y.abs(), h);
    g(x2, y2) - g(x1, y2) - g(x2, y1) + g(x1, y1)
}

#[test]
fn corner_form_factor_matches_quadrature() {
    for (a, b, h) in [(0.5, 0.5, 1.0), (0.3, 0.7, 1.0), (2.0, 0.4, 0.5)] {
        let k = 1000;
        let (dx, dy) = (a / k as f64, b / k as f64);
        let mut sum = 0.0;
        for i in 0..k {
            for j in 0..k {
                let (x, y) = ((i as f64 + 0.5) * dx, (j as f64 + 0.5) * dy);
                let r2 = x * x + y * y + h * h;
                sum += h * h / (r2 * r2);
            }
        }
        let q = sum * dx * dy / std::f64::consts::PI;
        let f = corner(a, b, h);
        assert!((q - f).abs() < 1e-6 * f, "{a} {b} {h}: {q} vs {f}");
    }
    // The limits.
    assert!((corner(1e6, 1e6, 1.0) - 0.25).abs() < 1e-5);
    let small = corner(1e-3, 2e-3, 1.0);
    assert!((small - 2e-6 / std::f64::consts::PI).abs() < 1e-5 * small);
}

/// A black square emitter (side 1, facing down) at height 1 over a large
/// grey floor: nothing reflects light back to the floor, so B = ρ E F.
fn lamp_over_floor(lamp_faces_down: bool) -> Scene {
    let mut s = String::from(
        "defmat lamp; diffuse_rgb 0 0 0; emission_rgb 10 5 2; end;\n\
         c_rgb floor 0.5 0.25 0.8;\n",
    );
    let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    quad(
        &mut s,
        "floor",
        [
            p(-50., -50., 0.),
            p(50., -50., 0.),
            p(50., 50., 0.),
            p(-50., 50., 0.),
        ],
        DVec3::Z,
        "floor",
    );
    quad(
        &mut s,
        "lamp",
        [
            p(-0.5, -0.5, 1.),
            p(0.5, -0.5, 1.),
            p(0.5, 0.5, 1.),
            p(-0.5, 0.5, 1.),
        ],
        if lamp_faces_down { -DVec3::Z } else { DVec3::Z },
        "lamp",
    );
    scene(&s)
}

#[test]
fn floor_under_a_square_emitter_gets_rho_e_f() {
    let s = lamp_over_floor(true);
    let opts = Options {
        samples: 4096,
        ..Options::default()
    };
    let (e, rho) = ([10.0, 5.0, 2.0], [0.5, 0.25, 0.8]);
    for (k, (x, y)) in [(0.0, 0.0), (0.2, 0.1), (0.4, -0.3), (1.0, 0.5)]
        .into_iter()
        .enumerate()
    {
        let f = rect(-0.5 - x, 0.5 - x, -0.5 - y, 0.5 - y, 1.0);
        if (x, y) == (0.0, 0.0) {
            // The centre: four corners of 0.5 × 0.5.
            assert!((f - 4.0 * corner(0.5, 0.5, 1.0)).abs() < 1e-15);
        }
        if (x, y) == (0.2, 0.1) {
            let four = corner(0.3, 0.4, 1.0)
                + corner(0.3, 0.6, 1.0)
                + corner(0.7, 0.4, 1.0)
                + corner(0.7, 0.6, 1.0);
            assert!((f - four).abs() < 1e-15);
        }
        let want = [0, 1, 2].map(|c| rho[c] * e[c] * f);
        let est = estimate_at(&s, DVec3::new(x, y, 0.0), DVec3::Z, &opts, k as u64);
        assert_within_3_se(
            &format!("floor at ({x}, {y}), F = {f:.6}"),
            &est,
            want,
            0.02,
        );
    }
}

#[test]
fn light_from_the_back_of_an_emitter_or_to_the_back_of_a_face_is_nothing() {
    // The lamp faces up: the floor sees only its back.
    let s = lamp_over_floor(false);
    let opts = Options {
        samples: 512,
        ..Options::default()
    };
    let e = estimate_at(&s, DVec3::ZERO, DVec3::Z, &opts, 0);
    assert_eq!(e.b, [0.0; 3]);
    // The underside of the floor is no face; a bare receiver there sees nothing.
    let s = lamp_over_floor(true);
    assert!(s.locate(DVec3::ZERO, -DVec3::Z, 1e-6).is_none());
    let r = Receiver::bare(DVec3::new(0.0, 0.0, -1e-3), -DVec3::Z);
    assert_eq!(s.estimate(&r, &opts, 0).b, [0.0; 3]);
}

#[test]
fn estimates_are_the_same_on_any_number_of_threads() {
    let s = scene(&furnace(
        "defmat glow; diffuse_rgb 0.6 0.5 0.4; emission_rgb 1 1 1; end;\n",
    ));
    let receivers: Vec<Receiver> = (0..12)
        .map(|i| {
            let at = s
                .locate(DVec3::new(0.05 + 0.07 * i as f64, 0.5, 0.0), DVec3::Z, 1e-9)
                .unwrap();
            s.receiver(&at)
        })
        .collect();
    let opts = Options {
        samples: 64,
        seed: 9,
        ..Options::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| s.estimate_all(&receivers, &opts, &|| {}))
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert_eq!(one[5], s.estimate(&receivers[5], &opts, 5));
    // Another seed, other numbers.
    let other = Options { seed: 10, ..opts };
    assert_ne!(one[5], s.estimate(&receivers[5], &other, 5));
}

#[test]
fn target_se_adds_batches_until_the_relative_error_is_reached() {
    let s = lamp_over_floor(true);
    let at = s.locate(DVec3::ZERO, DVec3::Z, 1e-6).unwrap();
    let opts = Options {
        samples: 256,
        target_se: Some(0.002),
        ..Options::default()
    };
    let e = s.estimate(&s.receiver(&at), &opts, 0);
    assert!(e.se_y <= 0.002 * e.y, "{e:?}");
    assert!(e.samples > 256 && e.samples.is_multiple_of(256), "{e:?}");
    let capped = Options {
        max_samples: 512,
        target_se: Some(1e-9),
        ..opts
    };
    assert_eq!(s.estimate(&s.receiver(&at), &capped, 0).samples, 512);
}

#[test]
fn random_points_keep_clear_of_edges_and_emitters() {
    let s = lamp_over_floor(true);
    let pts = s.sample_points(200, 4, 0.01).unwrap();
    assert_eq!(pts.len(), 200);
    for p in &pts {
        let f = &s.faces()[p.face];
        assert_eq!(f.label, "floor");
        assert!(p.point.x.abs() <= 49.0 && p.point.y.abs() <= 49.0);
        assert_eq!(p.normal, DVec3::Z);
    }
    let again = s.sample_points(200, 4, 0.01).unwrap();
    assert!(pts.iter().zip(&again).all(|(a, b)| a.point == b.point));
    let other = s.sample_points(200, 5, 0.01).unwrap();
    assert!(pts[0].point != other[0].point);
    // A margin wider than the faces: no point can be placed.
    assert!(s.sample_points(3, 4, 0.6).is_err());
}

#[test]
fn faces_with_holes_are_triangulated_and_the_hole_lets_light_through() {
    // A lamp at height 2 over a screen at height 1 with a square hole under
    // it, over a floor: the floor below the hole is lit, elsewhere shaded.
    let src = "\
defmat lamp; diffuse_rgb 0 0 0; emission_rgb 1 1 1; end;
c_rgb black 0 0 0;
c_rgb grey 0.5 0.5 0.5;
v l0 -1 -1 2; v l1 -1 1 2; v l2 1 1 2; v l3 1 -1 2;
f lamp (l0 l1 l2 l3) lamp;
v s0 -10 -10 1; v s1 10 -10 1; v s2 10 10 1; v s3 -10 10 1;
v h0 -0.2 -0.2 1; v h1 -0.2 0.2 1; v h2 0.2 0.2 1; v h3 0.2 -0.2 1;
f screen (s0 s1 s2 s3) (h0 h1 h2 h3) black;
v g0 -10 -10 0; v g1 10 -10 0; v g2 10 10 0; v g3 -10 10 0;
f floor (g0 g1 g2 g3) grey;
";
    let s = scene(src);
    let screen = s.faces().iter().find(|f| f.label == "screen").unwrap();
    assert!((screen.area - (400.0 - 0.16)).abs() < 1e-9);
    let opts = Options {
        samples: 256,
        ..Options::default()
    };
    let lit = estimate_at(&s, DVec3::ZERO, DVec3::Z, &opts, 0);
    let dark = estimate_at(&s, DVec3::new(3.0, 0.0, 0.0), DVec3::Z, &opts, 1);
    assert!(lit.y > 0.0);
    assert_eq!(dark.b, [0.0; 3]);
    // The screen's front faces up (counter-clockwise from above): found
    // there, but not in its hole.
    assert!(
        s.locate(DVec3::new(5.0, 5.0, 1.0), DVec3::Z, 1e-9)
            .is_some()
    );
    assert!(
        s.locate(DVec3::new(0.0, 0.0, 1.0), DVec3::Z, 1e-9)
            .is_none()
    );
}
