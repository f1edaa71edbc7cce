//! ugview's command line, and pictures checked pixel by pixel. The GPU tests
//! skip (with a note) when no adapter exists, unless `UG_REQUIRE_GPU=1`
//! (CI installs lavapipe and sets it).

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

const EXE: &str = env!("CARGO_BIN_EXE_ugview");

fn fixture(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(rel)
}

fn ugview(args: &[&str]) -> Output {
    cli::testkit::run_with_stdin(EXE, args, b"")
}

/// An RGB8 picture.
struct Pic {
    w: u32,
    h: u32,
    px: Vec<u8>,
}

impl Pic {
    fn at(&self, x: u32, y: u32) -> [u8; 3] {
        let i = ((y * self.w + x) * 3) as usize;
        [self.px[i], self.px[i + 1], self.px[i + 2]]
    }
}

/// Runs ugview writing PNG to stdout; None when the GPU test must skip.
fn render(args: &[&str]) -> Option<(Pic, Vec<u8>)> {
    let out = ugview(args);
    if out.status.code() == Some(1) {
        let err = String::from_utf8_lossy(&out.stderr);
        if std::env::var("UG_REQUIRE_GPU").is_ok_and(|v| v == "1") {
            panic!("UG_REQUIRE_GPU=1 but ugview failed: {err}");
        }
        eprintln!("skipping GPU test: {err}");
        return None;
    }
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let img = image::load_from_memory(&out.stdout).expect("PNG").to_rgb8();
    let (w, h) = img.dimensions();
    Some((
        Pic {
            w,
            h,
            px: img.into_raw(),
        },
        out.stdout,
    ))
}

#[test]
fn help_has_examples_and_version_names_the_tool() {
    cli::testkit::assert_help_and_version(EXE, "ugview", env!("CARGO_PKG_VERSION"));
}

#[test]
fn usage_errors_exit_2_with_nothing_on_stdout() {
    for args in [
        vec!["--no-such-option"],
        vec!["--size", "0x10"],
        vec!["--msaa", "3"],
        vec!["--top", "--eye", "1,2,3"],
        vec!["--range", "1,2"],
    ] {
        let out = ugview(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(out.stdout.is_empty());
    }
    let bad = fixture("bad/01-unclosed-comment.ug");
    if bad.exists() {
        let out = ugview(&[bad.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2));
        assert!(out.stdout.is_empty());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(":1:"), "{err}");
    }
}

#[test]
fn a_missing_adapter_is_a_clean_runtime_error() {
    let out = Command::new(EXE)
        .arg(fixture("red-cube.ug"))
        .env("WGPU_ADAPTER_NAME", "no such adapter anywhere")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: no "), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn radiance_becomes_exact_srgb_pixels() {
    let f = fixture("view/lit-quads.ug");
    let Some((p, _)) = render(&[f.to_str().unwrap(), "--exposure", "0", "--size", "300x200"])
    else {
        return;
    };
    assert_eq!((p.w, p.h), (300, 200));
    // The camera 'front' (fov 30°, 10 units away, aspect 1.5) sees x in ±4.02
    // at z = 0 across 300 pixels: the 'flat' quad (x -3..-1) covers pixels
    // 38..113, the 'ramp' (x 0..3) pixels 150..262.
    let flat = p.at(75, 118);
    // Radiance 0.5 at exposure 0: sRGB(0.5) = 188.
    assert!(flat.iter().all(|&v| (187..=189).contains(&v)), "{flat:?}");
    // The ramp rises monotonically left to right.
    let row: Vec<u8> = (155..260).map(|x| p.at(x, 118)[0]).collect();
    assert!(row.windows(2).all(|w| w[1] >= w[0]), "{row:?}");
    // x = 0.13 → radiance 0.045 → sRGB 60; x = 2.95 → 0.98 → 253.
    assert!(row[0] < 70 && *row.last().unwrap() > 245, "{row:?}");
    // 'away' faces away: culled, background black.
    assert_eq!(p.at(150, 40), [0, 0, 0]);
    // One stop more doubles radiance: 1.0 → white.
    let (p2, _) = render(&[f.to_str().unwrap(), "--exposure", "1", "--size", "300x200"]).unwrap();
    assert_eq!(p2.at(75, 118), [255, 255, 255]);
}

#[test]
fn back_faces_are_magenta_on_request() {
    let f = fixture("view/lit-quads.ug");
    let Some((p, _)) = render(&[f.to_str().unwrap(), "--backfaces", "--size", "300x200"]) else {
        return;
    };
    assert_eq!(p.at(150, 40), [255, 0, 255]);
    assert_ne!(p.at(75, 118), [255, 0, 255]);
}

#[test]
fn auto_exposure_and_determinism() {
    let f = fixture("view/lit-quads.ug");
    let args = [f.to_str().unwrap(), "--size", "300x200"];
    let Some((a, bytes_a)) = render(&args) else {
        return;
    };
    let (_, bytes_b) = render(&args).unwrap();
    assert_eq!(bytes_a, bytes_b, "same input and options, same bytes");
    // Auto exposure puts the log-average of the covered pixels at middle grey.
    let lin = |v: u8| {
        let c = f64::from(v) / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let covered: Vec<f64> = (20..180)
        .flat_map(|y| (0..300).map(move |x| (x, y)))
        .map(|(x, y)| a.at(x, y)[0])
        .filter(|&v| v > 0)
        .map(lin)
        .collect();
    let log_avg =
        (covered.iter().map(|l| (l + 1e-4).ln()).sum::<f64>() / covered.len() as f64).exp();
    assert!((log_avg - 0.18).abs() < 0.02, "{log_avg}");
}

#[test]
fn mesh_overlay_draws_the_edges() {
    let f = fixture("view/lit-quads.ug");
    let Some((plain, _)) = render(&[f.to_str().unwrap(), "--exposure", "0", "--size", "300x200"])
    else {
        return;
    };
    let (mesh, _) = render(&[
        f.to_str().unwrap(),
        "--exposure",
        "0",
        "--size",
        "300x200",
        "--mesh",
    ])
    .unwrap();
    let changed: Vec<(u32, u32)> = (0..200)
        .flat_map(|y| (0..300).map(move |x| (x, y)))
        .filter(|&(x, y)| plain.at(x, y) != mesh.at(x, y))
        .collect();
    // Two quad outlines, each about 2 × (60 + 60..105) pixels long.
    assert!(
        changed.len() > 300 && changed.len() < 3000,
        "{}",
        changed.len()
    );
    // Lines are dark; the quads' insides are untouched.
    assert!(mesh.at(75, 118) == plain.at(75, 118));
    // Over the lit quads (not the black background) lines darken.
    let over: Vec<_> = changed
        .iter()
        .filter(|&&(x, y)| plain.at(x, y)[0] > 100)
        .collect();
    assert!(over.len() > 100);
    assert!(
        over.iter()
            .all(|&&(x, y)| mesh.at(x, y)[0] < plain.at(x, y)[0])
    );
}

#[test]
fn plan_view_cuts_away_the_roof() {
    let f = fixture("view/plan.ug");
    let Some((cut, _)) = render(&[f.to_str().unwrap(), "--top", "--size", "160x120"]) else {
        return;
    };
    // Floor grey 0.6, seen straight on: sRGB 203.
    assert_eq!(cut.at(80, 60), [203, 203, 203]);
    let (roof, _) = render(&[
        f.to_str().unwrap(),
        "--top",
        "--cut-z",
        "10",
        "--size",
        "160x120",
    ])
    .unwrap();
    let c = roof.at(80, 60);
    assert!(c[0] > 200 && c[1] < 120 && c[2] < 120, "{c:?}");
}

#[test]
fn false_colour_adds_a_legend_strip() {
    let f = fixture("view/lit-quads.ug");
    let Some((p, _)) = render(&[
        f.to_str().unwrap(),
        "--false-colour",
        "--range",
        "0,1",
        "--size",
        "300x200",
    ]) else {
        return;
    };
    assert_eq!((p.w, p.h), (300 + 96, 200));
    // Radiance 0.5 on a 0..1 linear scale: the middle of the ramp (green).
    let c = p.at(75, 118);
    assert!(c[1] > c[0] && c[1] > c[2], "{c:?}");
}

#[test]
fn unknown_camera_names_are_usage_errors() {
    let f = fixture("view/lit-quads.ug");
    let out = ugview(&[f.to_str().unwrap(), "--cam", "nope", "-o", "/dev/null"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no camera named 'nope'; the model has: front"),
        "{err}"
    );
}
