//! ugview end to end: pictures of the fixtures compared with golden PNGs
//! (within a stated tolerance: rasterisers may differ in the last bit of
//! edge coverage), and the whole chain from a dirty model to a picture.
//! GPU tests skip when no adapter exists unless `UG_REQUIRE_GPU=1`.

use std::path::Path;
use ugkit::{fixture, root, run};

/// Pictures may differ from the golden one by this much: mean absolute
/// difference per channel (0..255), and the share of pixels off by more than 24.
const MEAN_TOLERANCE: f64 = 1.5;
const OUTLIER_SHARE: f64 = 0.005;

fn gpu_skip(out: &std::process::Output) -> bool {
    if out.status.code() == Some(1) {
        let err = String::from_utf8_lossy(&out.stderr);
        if std::env::var("UG_REQUIRE_GPU").is_ok_and(|v| v == "1") {
            panic!("UG_REQUIRE_GPU=1 but ugview failed: {err}");
        }
        eprintln!("skipping GPU test: {err}");
        return true;
    }
    false
}

fn assert_image_golden(rel: &str, png: &[u8]) {
    let p = root().join(rel);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&p, png).expect("write golden picture");
        return;
    }
    let want = image::open(&p)
        .unwrap_or_else(|e| panic!("{}: {e}; run with UPDATE_GOLDEN=1", p.display()))
        .to_rgb8();
    let got = image::load_from_memory(png).expect("PNG").to_rgb8();
    assert_eq!(want.dimensions(), got.dimensions(), "{rel}");
    let mut sum = 0u64;
    let mut outliers = 0usize;
    for (a, b) in want.pixels().zip(got.pixels()) {
        let d: Vec<u64> = (0..3).map(|k| u64::from(a[k].abs_diff(b[k]))).collect();
        sum += d.iter().sum::<u64>();
        if d.iter().any(|&x| x > 24) {
            outliers += 1;
        }
    }
    let n = (want.width() * want.height()) as f64;
    let mean = sum as f64 / (3.0 * n);
    let share = outliers as f64 / n;
    if mean > MEAN_TOLERANCE || share > OUTLIER_SHARE {
        // The actual picture and a difference picture (per channel, ×4) for review.
        let name = Path::new(rel)
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let dump = std::env::temp_dir().join(format!("{name}.actual.png"));
        let _ = std::fs::write(&dump, png);
        let diff = image::RgbImage::from_fn(want.width(), want.height(), |x, y| {
            let (a, b) = (want.get_pixel(x, y), got.get_pixel(x, y));
            image::Rgb([0, 1, 2].map(|k| a[k].abs_diff(b[k]).saturating_mul(4)))
        });
        let diff_path = std::env::temp_dir().join(format!("{name}.diff.png"));
        let _ = diff.save(&diff_path);
        panic!(
            "{rel}: mean difference {mean:.3} (≤ {MEAN_TOLERANCE}), outliers {:.3}% (≤ {}%); actual picture written to {}, difference ×4 to {}",
            share * 100.0,
            OUTLIER_SHARE * 100.0,
            dump.display(),
            diff_path.display()
        );
    }
}

#[test]
fn golden_comparison_fails_on_a_different_picture_and_writes_a_diff() {
    // The tolerance must not accept everything: a picture with a bright
    // square where the golden one has none fails, and the diff is written.
    let Some(golden) = image::open(root().join("fixtures/view/cornell-unlit.png")).ok() else {
        panic!("fixtures/view/cornell-unlit.png missing");
    };
    let mut img = golden.to_rgb8();
    for y in 100..140 {
        for x in 100..140 {
            img.put_pixel(x, y, image::Rgb([255, 0, 255]));
        }
    }
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png).unwrap();
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        return;
    }
    let r = std::panic::catch_unwind(|| {
        assert_image_golden("fixtures/view/cornell-unlit.png", png.get_ref())
    });
    let msg = match r {
        Ok(()) => panic!("a 40 × 40 magenta square passed the comparison"),
        Err(e) => e.downcast_ref::<String>().cloned().unwrap_or_default(),
    };
    assert!(msg.contains("difference ×4 to"), "{msg}");
    assert!(std::env::temp_dir().join("cornell-unlit.diff.png").exists());
}

#[test]
fn cornell_box_unlit_from_its_camera() {
    let f = fixture("cornell-box.ug");
    let out = run("ugview", &[f.to_str().unwrap(), "--size", "240x240"], None);
    if gpu_skip(&out) {
        return;
    }
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_image_golden("fixtures/view/cornell-unlit.png", &out.stdout);
}

#[test]
fn dirty_cornell_box_through_the_whole_chain_to_a_picture() {
    // ugplanar | ugvlmerge | ugflip | ugisect | ugcopl | ugclean | ugcut | ugrad | ugview
    let mut model = std::fs::read(fixture("cornell-box.ug")).unwrap();
    for (tool, args) in [
        ("ugplanar", vec![]),
        ("ugvlmerge", vec![]),
        ("ugflip", vec![]),
        ("ugisect", vec![]),
        ("ugcopl", vec![]),
        ("ugclean", vec![]),
        ("ugcut", vec!["-l", "100"]),
        (
            "ugrad",
            vec!["--converge", "1e-2", "-q", "--visibility", "ray"],
        ),
    ] {
        let out = run(tool, &args, Some(&model));
        assert!(
            out.status.success(),
            "{tool}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        model = out.stdout;
    }
    let out = run("ugview", &["--size", "240x240"], Some(&model));
    if gpu_skip(&out) {
        return;
    }
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_image_golden("fixtures/view/cornell-lit.png", &out.stdout);
    // With the element mesh over it (the report's colour plate 2b).
    let mesh = run("ugview", &["--size", "240x240", "--mesh"], Some(&model));
    assert!(mesh.status.success());
    assert_image_golden("fixtures/view/cornell-lit-mesh.png", &mesh.stdout);
    assert_ne!(mesh.stdout, out.stdout);
    // The light (ceiling centre, top of the picture) is the brightest thing in it.
    let img = image::load_from_memory(&out.stdout).unwrap().to_rgb8();
    let lum = |p: &image::Rgb<u8>| {
        0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
    };
    let (x, y, _) = img
        .enumerate_pixels()
        .map(|(x, y, p)| (x, y, lum(p)))
        .fold((0, 0, -1.0), |best, c| if c.2 > best.2 { c } else { best });
    assert!(
        (95..145).contains(&x) && (20..45).contains(&y),
        "brightest pixel at {x},{y}"
    );
}
