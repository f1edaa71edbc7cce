//! ugrad with the GPU hemi-cube against the CPU ray-cast reference on the
//! Cornell box, and the hemi-cube's failure modes. GPU tests skip without an
//! adapter unless `UG_REQUIRE_GPU=1`.

use std::collections::BTreeMap;
use ugkit::{fixture, run};

fn require_gpu() -> bool {
    std::env::var("UG_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

fn patches() -> Vec<u8> {
    let m = std::fs::read(fixture("cornell-box.ug")).unwrap();
    let planar = run("ugplanar", &[], Some(&m));
    assert!(planar.status.success());
    let cut = run("ugcut", &["-l", "100"], Some(&planar.stdout));
    assert!(cut.status.success());
    cut.stdout
}

/// Mean vertex colour per face material.
fn means(ug_text: &[u8]) -> BTreeMap<String, [f64; 3]> {
    let m = ug::parse(ug_text, "lit.ug").unwrap().model;
    let mut sums: BTreeMap<String, [f64; 4]> = BTreeMap::new();
    for f in &m.faces {
        let mat = f
            .material
            .map(|id| m.materials[id.idx()].name.clone())
            .unwrap_or_default();
        for &v in f.contours.iter().flatten() {
            if let Some(c) = m.vertices[v.idx()].color {
                let c = m.materials[c.idx()].diffuse();
                let s = sums.entry(mat.clone()).or_default();
                for k in 0..3 {
                    s[k] += c[k];
                }
                s[3] += 1.0;
            }
        }
    }
    sums.into_iter()
        .map(|(k, s)| (k, [s[0] / s[3], s[1] / s[3], s[2] / s[3]]))
        .collect()
}

#[test]
fn hemicube_solution_matches_ray_casting_on_the_cornell_box() {
    let input = patches();
    let hc = run(
        "ugrad",
        &["--visibility", "hemicube", "--converge", "1e-2", "-q"],
        Some(&input),
    );
    if hc.status.code() == Some(1) && !require_gpu() {
        eprintln!("skipping GPU test: {}", String::from_utf8_lossy(&hc.stderr));
        return;
    }
    assert!(
        hc.status.success(),
        "{}",
        String::from_utf8_lossy(&hc.stderr)
    );
    let ray = run(
        "ugrad",
        &["--visibility", "ray", "--converge", "1e-2", "-q"],
        Some(&input),
    );
    assert!(ray.status.success());
    let (a, b) = (means(&hc.stdout), means(&ray.stdout));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (mat, x) in &a {
        let y = b[mat];
        for k in 0..3 {
            // Measured: within 0.2% (the refinement differs a little where a
            // shadow edge falls between hemi-cube pixels).
            let rel = (x[k] - y[k]).abs() / y[k].abs().max(1e-9);
            assert!(
                rel < 0.01,
                "{mat} channel {k}: hemicube {} ray {}",
                x[k],
                y[k]
            );
        }
    }
}

#[test]
fn bad_hemicube_resolution_is_a_usage_error() {
    let out = run("ugrad", &["--hemicube-res", "100"], Some(b""));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("multiple of 64"));
}

#[test]
fn missing_adapter_fails_hemicube_and_falls_back_under_auto() {
    let input = patches();
    let bin = ugkit::bin("ugrad");
    let go = |vis: &str| {
        let mut child = std::process::Command::new(&bin)
            .args(["--visibility", vis, "--max-shots", "3"])
            .env("WGPU_ADAPTER_NAME", "no such adapter anywhere")
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        use std::io::Write;
        let mut si = child.stdin.take().unwrap();
        si.write_all(&input).unwrap();
        drop(si);
        child.wait_with_output().unwrap()
    };
    let hc = go("hemicube");
    assert_eq!(hc.status.code(), Some(1));
    assert!(hc.stdout.is_empty());
    let err = String::from_utf8_lossy(&hc.stderr);
    assert!(
        err.starts_with("error: --visibility hemicube: no "),
        "{err}"
    );
    let auto = go("auto");
    assert!(
        auto.status.success(),
        "{}",
        String::from_utf8_lossy(&auto.stderr)
    );
    assert!(!auto.stdout.is_empty());
    let err = String::from_utf8_lossy(&auto.stderr);
    assert!(err.contains("visibility by CPU ray casting"), "{err}");
}
