//! ugrad end to end: the Cornell box through the cleaning chain, bad input,
//! options, determinism.

use std::process::Command;

use ugkit::{assert_golden, bin, clean_chain, fixture, run, run_ok};

/// ugplanar | ugcut -l LEN of a fixture.
fn patches(name: &str, len: &str) -> String {
    let planar = run_ok("ugplanar", &[fixture(name).to_str().unwrap()], None);
    run_ok("ugcut", &["-l", len], Some(planar.as_bytes()))
}

fn colours(m: &ug::Model) -> Vec<[f64; 3]> {
    m.vertices
        .iter()
        .map(|v| {
            m.material(v.color.expect("every vertex has a colour"))
                .diffuse()
        })
        .collect()
}

/// Area-weighted mean vertex colour per material, one line each (for a golden file).
fn means(m: &ug::Model) -> String {
    let col = colours(m);
    let mut acc: Vec<(String, f64, [f64; 3])> = Vec::new();
    for f in m.top_faces() {
        let face = m.face(f);
        let Some(mat) = face.material else { continue };
        let name = m.material(mat).name.clone();
        let c = &face.contours[0];
        let p: Vec<glam::DVec3> = c.iter().map(|&v| m.pos(v)).collect();
        let area = (1..p.len() - 1)
            .map(|k| (p[k] - p[0]).cross(p[k + 1] - p[0]).length() / 2.0)
            .sum::<f64>();
        let mut mean = [0.0; 3];
        for &v in c {
            for k in 0..3 {
                mean[k] += col[v.idx()][k] / c.len() as f64;
            }
        }
        let slot = match acc.iter().position(|a| a.0 == name) {
            Some(i) => i,
            None => {
                acc.push((name, 0.0, [0.0; 3]));
                acc.len() - 1
            }
        };
        acc[slot].1 += area;
        for (sum, m) in acc[slot].2.iter_mut().zip(mean) {
            *sum += m * area;
        }
    }
    acc.iter()
        .map(|(n, a, s)| format!("{n} {:.6e} {:.6e} {:.6e}\n", s[0] / a, s[1] / a, s[2] / a))
        .collect()
}

/// Compares two `means` texts value by value within a relative tolerance.
fn assert_close(expected: &str, actual: &str, rel: f64) {
    let (e, a): (Vec<&str>, Vec<&str>) = (expected.lines().collect(), actual.lines().collect());
    assert_eq!(e.len(), a.len(), "expected\n{expected}actual\n{actual}");
    for (x, y) in e.iter().zip(&a) {
        let (xs, ys): (Vec<&str>, Vec<&str>) = (x.split(' ').collect(), y.split(' ').collect());
        assert_eq!(xs[0], ys[0]);
        for k in 1..4 {
            let (p, q): (f64, f64) = (xs[k].parse().unwrap(), ys[k].parse().unwrap());
            assert!((p - q).abs() <= rel * p.abs().max(q.abs()), "{x} vs {y}");
        }
    }
}

#[test]
fn cornell_box_converges_with_shadows_and_refined_shadow_edges() {
    let input = patches("cornell-box.ug", "120");
    let out = run(
        "ugrad",
        // The golden means are the ray caster's (a GPU hemi-cube, which
        // `auto` picks on hardware GPUs, differs within 0.2%: tests/hemicube.rs).
        &["-v", "--converge", "0.01", "--visibility", "ray"],
        Some(input.as_bytes()),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("stopped (Converged)"), "{err}");
    let text = String::from_utf8(out.stdout).unwrap();
    let m = ug::parse(text.as_bytes(), "lit").unwrap().model;
    let col = colours(&m);
    // The output is a clean patch mesh.
    let r: serde_json::Value =
        serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(text.as_bytes()))).unwrap();
    for key in ["tvertices", "degenerate", "inconsistent", "nonpatch"] {
        assert_eq!(r[key].as_array().unwrap().len(), 0, "{key}");
    }
    // Walls colour the light they reflect.
    let mean_of = |mat: &str| {
        let id = m.material_by_name(mat).unwrap();
        let vs: Vec<usize> = m
            .top_faces()
            .filter(|&f| m.face(f).material == Some(id))
            .flat_map(|f| {
                m.face(f).contours[0]
                    .iter()
                    .map(|v| v.idx())
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut s = [0.0; 3];
        for &v in &vs {
            for k in 0..3 {
                s[k] += col[v][k] / vs.len() as f64;
            }
        }
        s
    };
    let (red, green, white) = (mean_of("red"), mean_of("green"), mean_of("white"));
    assert!(red[0] > 3.0 * red[1], "red wall {red:?}");
    assert!(green[1] > 1.5 * green[0], "green wall {green:?}");
    assert!(white.iter().all(|&x| x > 0.0));
    // The floor under the short block is enclosed by it: no light reaches it
    // directly; vertices made by subdivision start from the mean of their
    // parents (§6.2), so a little light spreads in from lit neighbours.
    let inside_short = |x: f64, z: f64| {
        let q = [(130.0, 65.0), (82.0, 225.0), (240.0, 272.0), (290.0, 114.0)];
        (0..4).all(|i| {
            let (a, b) = (q[i], q[(i + 1) % 4]);
            (b.0 - a.0) * (z - a.1) - (b.1 - a.1) * (x - a.0) < -1.0
        })
    };
    let floor: Vec<usize> = (0..m.vertices.len())
        .filter(|&v| m.vertices[v].pos.y == 0.0)
        .collect();
    let under: Vec<usize> = floor
        .iter()
        .copied()
        .filter(|&v| inside_short(m.vertices[v].pos.x, m.vertices[v].pos.z))
        .collect();
    assert!(!under.is_empty());
    let open: Vec<f64> = floor
        .iter()
        .filter(|&&v| !inside_short(m.vertices[v].pos.x, m.vertices[v].pos.z))
        .map(|&v| col[v].iter().sum::<f64>())
        .collect();
    let open_mean = open.iter().sum::<f64>() / open.len() as f64;
    for &v in &under {
        let b: f64 = col[v].iter().sum();
        assert!(
            b < 0.25 * open_mean,
            "floor vertex {} under the block: {b} vs open floor {open_mean}",
            m.vertices[v].name
        );
    }
    let exact_dark = under.iter().filter(|&&v| col[v] == [0.0; 3]).count();
    assert!(
        2 * exact_dark >= under.len(),
        "{exact_dark} of {} vertices under the block are black",
        under.len()
    );
    // Adaptive subdivision puts the small elements where the light changes
    // steeply: the floor elements with the steepest 10% of corner differences
    // are smaller on average than the rest.
    let mut rows: Vec<(f64, f64)> = Vec::new();
    for f in m.top_faces() {
        let c = &m.face(f).contours[0];
        let p: Vec<glam::DVec3> = c.iter().map(|&v| m.pos(v)).collect();
        if p.iter().any(|q| q.y != 0.0) {
            continue;
        }
        let b: Vec<f64> = c.iter().map(|v| col[v.idx()].iter().sum::<f64>()).collect();
        let spread =
            b.iter().copied().fold(f64::MIN, f64::max) - b.iter().copied().fold(f64::MAX, f64::min);
        let area = (1..p.len() - 1)
            .map(|k| (p[k] - p[0]).cross(p[k + 1] - p[0]).length() / 2.0)
            .sum::<f64>();
        rows.push((spread, area));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let cut = rows.len() * 9 / 10;
    let mean = |r: &[(f64, f64)]| r.iter().map(|x| x.1).sum::<f64>() / r.len() as f64;
    let (steep, smooth) = (mean(&rows[cut..]), mean(&rows[..cut]));
    eprintln!(
        "floor elements: {}; mean area of the steepest 10%: {steep:.1}, of the rest: {smooth:.1}",
        rows.len()
    );
    assert!(steep < 0.8 * smooth, "steep {steep} vs smooth {smooth}");
    // Tolerance-aware golden: area-weighted mean colour per material within 1e-6 relative.
    let actual = means(&m);
    let golden = "fixtures/rad/cornell-box.means";
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        assert_golden(golden, &actual);
    } else {
        let expected = std::fs::read_to_string(ugkit::root().join(golden)).expect("golden file");
        assert_close(&expected, &actual, 1e-6);
    }
}

/// The Cornell box's patches moved 4·10⁶ units from the origin (where CAD
/// exports put buildings on a site) light the same: every material's mean
/// within 1e-3 of the box at the origin (measured: 1.9e-4 here, 6e-6 at
/// `-l 120 --converge 0.01`; the coordinates round differently there, and
/// so do a few form factors and refinement decisions; a lost sign or a
/// collapsed offset would be per cent).
#[test]
fn far_from_the_origin_the_light_is_the_same() {
    let near = patches("cornell-box.ug", "200");
    let mut m = ug::parse(near.as_bytes(), "near").unwrap().model;
    for v in &mut m.vertices {
        v.pos += glam::DVec3::new(512_345.6, 4_187_654.3, 120.5);
    }
    let far = ug::write_string(&m);
    let args = ["--converge", "0.02", "--visibility", "ray"];
    let lit = |text: &str| {
        let out = run_ok("ugrad", &args, Some(text.as_bytes()));
        means(&ug::parse(out.as_bytes(), "lit").unwrap().model)
    };
    let (a, b) = (lit(&near), lit(&far));
    eprintln!("at the origin:\n{a}far from it:\n{b}");
    assert_close(&a, &b, 1e-3);
}

#[test]
fn options_change_what_is_written() {
    let input = patches("red-cube.ug", "0.5");
    let full = run_ok("ugrad", &["--max-shots", "5"], Some(input.as_bytes()));
    let irr = run_ok(
        "ugrad",
        &["--max-shots", "5", "--output", "irradiance"],
        Some(input.as_bytes()),
    );
    let amb = run_ok(
        "ugrad",
        &["--max-shots", "5", "--ambient"],
        Some(input.as_bytes()),
    );
    assert_ne!(full, irr);
    assert_ne!(full, amb);
    // The light's own vertices: radiosity includes its emission, irradiance does not.
    let light_b = |t: &str| {
        let m = ug::parse(t.as_bytes(), "o").unwrap().model;
        let v = m.vertices.iter().find(|v| v.name == "l1").unwrap();
        m.material(v.color.unwrap()).diffuse()
    };
    assert!(light_b(&full)[0] >= 5.0);
    assert!(light_b(&irr)[0] < 5.0);
    // A dark model: an error (exit 1, nothing on stdout, how to fix it)...
    let dark = patches("check/clean-box.ug", "1");
    let out = run("ugrad", &[], Some(dark.as_bytes()));
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nothing in the model emits light"), "{err}");
    assert!(
        err.contains("emission_rgb") && err.contains("--allow-dark"),
        "{err}"
    );
    // ... unless --allow-dark: a warning, every vertex black, exit 0.
    let out = run("ugrad", &["--allow-dark"], Some(dark.as_bytes()));
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nothing in the model emits light"));
    let m = ug::parse(&out.stdout[..], "o").unwrap().model;
    assert!(!m.vertices.is_empty());
    assert!(
        m.vertices
            .iter()
            .all(|v| v.color.is_some_and(|c| m.material(c).diffuse() == [0.0; 3]))
    );
}

/// Faces that are not patches (a pentagon, a face with a hole, a concave
/// quad) are meshed as ugcut would, with one warning: `ugvlmerge | ugrad`
/// works. The result has every input face's area, lit.
#[test]
fn meshes_faces_that_are_not_patches() {
    let input = "\
defmat lamp; diffuse_rgb 0.5 0.5 0.5; emission_rgb 10 10 10; end;
c_rgb white 0.8 0.8 0.8;
v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 2 5 0; v e 0 4 0;
v h1 1 1 0; v h2 1 2 0; v h3 2 2 0; v h4 2 1 0;
v l1 1 1 3; v l2 1 3 3; v l3 3 3 3; v l4 3 1 3;
f floor (a b c d e) (h1 h2 h3 h4) white;
v q1 5 0 0; v q2 7 0 0; v q3 6 1 0; v q4 6 3 0;
f concave (q1 q2 q3 q4) white;
f light (l1 l2 l3 l4) lamp;
";
    let out = run("ugrad", &["--max-shots", "4"], Some(input.as_bytes()));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.matches("warning:").count(), 1, "{err}");
    assert!(err.contains("2 faces are not patches"), "{err}");
    let m = ug::parse(&out.stdout[..], "o").unwrap().model;
    let mut area = 0.0;
    let mut lit = 0;
    for f in m.top_faces() {
        let c = &m.faces[f.idx()].contours;
        assert_eq!(c.len(), 1);
        assert!(c[0].len() == 3 || c[0].len() == 4);
        let pts: Vec<glam::DVec3> = c[0].iter().map(|&v| m.pos(v)).collect();
        if pts.iter().all(|p| p.z == 0.0) {
            area += geom::newell_normal(&pts).length() / 2.0;
        }
        lit += c[0]
            .iter()
            .filter(|&&v| {
                m.vertices[v.idx()]
                    .color
                    .is_some_and(|k| m.material(k).diffuse()[0] > 0.0)
            })
            .count();
    }
    // The pentagon 4 × 4 + 4 × 1 / 2 less the 1 × 1 hole, and the concave
    // quad's 2.
    assert!((area - 19.0).abs() < 1e-9, "{area}");
    assert!(lit > 0);
}

#[test]
fn deterministic_at_any_thread_count() {
    let input = patches("red-cube.ug", "0.5");
    let path = std::env::temp_dir().join(format!("ugrad-det-{}.ug", std::process::id()));
    std::fs::write(&path, &input).unwrap();
    let go = |threads: &str| {
        let out = Command::new(bin("ugrad"))
            .args(["--max-shots", "30", path.to_str().unwrap()])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(out.status.success());
        out.stdout
    };
    let (a, b) = (go("1"), go("2"));
    let _ = std::fs::remove_file(&path);
    assert!(a == b, "output differs between 1 and 2 threads");
}

#[cfg(unix)]
#[test]
fn ctrl_c_writes_the_solution_so_far() {
    use std::io::Write as _;
    use std::process::Stdio;
    let input = patches("cornell-box.ug", "50");
    let mut child = Command::new(bin("ugrad"))
        .args(["--converge", "1e-9", "--tail", "0"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{:?}", out.status);
    assert!(String::from_utf8_lossy(&out.stderr).contains("interrupted"));
    let text = String::from_utf8(out.stdout).unwrap();
    let m = ug::parse(text.as_bytes(), "partial").unwrap().model;
    assert!(m.faces.len() > 700);
    assert!(m.vertices.iter().all(|v| v.color.is_some()));
}

#[test]
fn time_limit_stops_and_writes() {
    let input = patches("cornell-box.ug", "50");
    let out = run(
        "ugrad",
        &[
            "-v",
            "--converge",
            "1e-9",
            "--tail",
            "0",
            "--time-limit",
            "1",
        ],
        Some(input.as_bytes()),
    );
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("stopped (TimeLimit)"));
    assert!(ug::parse(&out.stdout, "partial").is_ok());
}

#[test]
fn degenerate_slivers_are_left_out_with_a_warning() {
    // A zero-area triangle, as a cutter can leave where two input points lie
    // a hair apart: lit, it would carry no energy; it is dropped, not refused.
    let input = "c_rgb w 0.5 0.5 0.5;
        defmat lamp; emission_rgb 1 1 1; end;
        v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 2 0 0;
        f floor (a b c d) w; f sliver (a b e) w;
        v p 0 0 1; v q 0 1 1; v r 1 1 1; v s 1 0 1; f light (p q r s) lamp;";
    let out = run(
        "ugrad",
        &["--max-shots", "3", "--visibility", "ray"],
        Some(input.as_bytes()),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("warning: face sliver: zero area"), "{err}");
    let m = ug::parse(&out.stdout, "lit").unwrap().model;
    assert!(
        m.faces
            .iter()
            .all(|f| !f.name.as_deref().unwrap_or("").starts_with("sliver"))
    );
    assert!(
        m.faces
            .iter()
            .any(|f| f.name.as_deref().unwrap_or("").starts_with("floor"))
    );
}

/// ugbuilding | the cleaning chain | ugcut -l LEN.
fn building(args: &[&str], len: &str) -> Vec<u8> {
    let b = run("ugbuilding", args, None);
    assert!(b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    clean_chain(b.stdout, len)
}

/// 16 messy rooms (3,234 patches): shooting patch by patch to 1e-3 takes
/// 19,831 shots (7 minutes in release); once the lights have shot, the
/// indirect tail converges in seconds, with the same bytes at any thread count.
#[test]
fn a_building_converges_through_the_indirect_tail() {
    let input = building(&["--rooms", "4", "--messy", "--seed", "3"], "0.7");
    let path = std::env::temp_dir().join(format!("ugrad-tail-{}.ug", std::process::id()));
    std::fs::write(&path, &input).unwrap();
    let go = |threads: &str| {
        let out = Command::new(bin("ugrad"))
            // 256 discovery rays (the default is 512): the test is about
            // the tail converging a building, and more rays cost CI time.
            .args(["-v", "--tail-rays", "256", path.to_str().unwrap()])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(out.status.success());
        (out.stdout, String::from_utf8(out.stderr).unwrap())
    };
    let (a, log) = go("1");
    let (b, _) = go("2");
    let _ = std::fs::remove_file(&path);
    assert!(a == b, "output differs between 1 and 2 threads");
    let tail = log
        .lines()
        .find(|l| l.starts_with("indirect tail after shot"))
        .unwrap_or_else(|| panic!("no tail in\n{log}"));
    // Sixteen lights shot one by one (a light is one or more patches), then the tail.
    let shots: usize = tail["indirect tail after shot ".len()..]
        .split(':')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((16..400).contains(&shots), "{tail}");
    assert!(tail.contains("256 rays per point"), "{tail}");
    let stopped = log
        .lines()
        .find(|l| l.starts_with("stopped (Converged)"))
        .unwrap_or_else(|| panic!("not converged:\n{log}"));
    let unshot: f64 = stopped
        .rsplit("unshot ")
        .next()
        .and_then(|x| x.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(unshot <= 1e-3, "{stopped}");
    let m = ug::parse(&a, "lit").unwrap().model;
    assert!(m.vertices.iter().all(|v| v.color.is_some()));
}

/// `--tail 0` shoots patch by patch; the tail's answer on the Cornell box at
/// 50 mm (about 800 patches, where it starts after 71 shots instead of
/// converging after 3,600) is within 1% per material (0.6% measured). Both
/// at `--gradient-scale 2`: at the default the shots' run, refined to
/// 13,000 vertices, took half a minute of CI (0.4% measured there).
#[test]
fn the_tail_agrees_with_shooting_patch_by_patch_on_the_cornell_box() {
    let input = patches("cornell-box.ug", "50");
    let tail = run(
        "ugrad",
        &["-v", "--gradient-scale", "2"],
        Some(input.as_bytes()),
    );
    assert!(tail.status.success());
    let log = String::from_utf8_lossy(&tail.stderr);
    assert!(log.contains("indirect tail after shot"), "{log}");
    assert!(log.contains("every patch tried"), "{log}");
    // (§6's mean for new vertices, as when the figures were measured: the
    // re-shot costs this 3,600-shot run half a minute in a debug build.)
    let shots = run(
        "ugrad",
        &[
            "-v",
            "--tail",
            "0",
            "--no-regather",
            "--gradient-scale",
            "2",
        ],
        Some(input.as_bytes()),
    );
    assert!(shots.status.success());
    let log = String::from_utf8_lossy(&shots.stderr);
    assert!(!log.contains("indirect tail"), "{log}");
    let (t, s) = (
        means(&ug::parse(&tail.stdout, "tail").unwrap().model),
        means(&ug::parse(&shots.stdout, "shots").unwrap().model),
    );
    assert_close(&s, &t, 0.01);
    // … and the comparison can fail: the tail is not the same solution.
    assert_ne!(s, t);
}

/// In one furnished room every patch sees most others: far from a
/// receiver the tail's patches shoot in clusters (`--tail-far`), which
/// must store far fewer pairs and light the room as every patch alone
/// does (per material within 1%; measured against ugprobe in
/// docs/decisions.md, "The tail's far field shoots in clusters").
#[test]
fn far_clusters_light_a_room_as_its_patches_do() {
    let input = building(
        &[
            "--rooms",
            "1",
            "--lights",
            "--furniture",
            "3",
            "--seed",
            "1",
        ],
        "3%",
    );
    let pairs = |log: &str| -> usize {
        log.split(" pairs stored")
            .next()
            .and_then(|t| t.rsplit('(').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("no pairs figure in {log}"))
    };
    let grouped = run("ugrad", &["-v", "--visibility", "ray"], Some(&input));
    let alone = run(
        "ugrad",
        &["-v", "--visibility", "ray", "--tail-far", "0"],
        Some(&input),
    );
    assert!(grouped.status.success() && alone.status.success());
    let (lg, la) = (
        String::from_utf8_lossy(&grouped.stderr),
        String::from_utf8_lossy(&alone.stderr),
    );
    assert!(
        lg.contains("far-field clusters") && !la.contains("far-field clusters"),
        "{lg}"
    );
    let (pg, pa) = (pairs(&lg), pairs(&la));
    assert!(pg * 3 < pa, "{pg} pairs against {pa}");
    let (g, a) = (
        means(&ug::parse(&grouped.stdout, "grouped").unwrap().model),
        means(&ug::parse(&alone.stdout, "alone").unwrap().model),
    );
    assert_close(&a, &g, 0.01);
    assert_ne!(a, g);
}

/// `-v` gives the set-up and final statistics, `-vv` also a line per shot.
#[test]
fn shot_lines_only_with_vv() {
    let input = patches("red-cube.ug", "0.5");
    let shot_lines = |flag: &str| {
        let out = run("ugrad", &[flag, "--max-shots", "3"], Some(input.as_bytes()));
        assert!(out.status.success());
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(err.contains("stopped ("), "{err}");
        err.lines().filter(|l| l.starts_with("shot ")).count()
    };
    assert_eq!(shot_lines("-v"), 0);
    assert_eq!(shot_lines("-vv"), 3);
}

/// The closed furnace: a cube whose six inward faces all emit E = 1 and
/// reflect ρ = 0.5 has B = E / (1 − ρ) = 2 everywhere. Re-shooting earlier
/// shots at new vertices (the default) keeps it at the refined vertices
/// (within 0.1%); §6's mean of the parents (`--no-regather`) leaves ±8% at
/// the refined edges (measured 1.84–2.12).
#[test]
fn the_closed_furnace_is_uniform() {
    let furnace = "\
defmat glow; diffuse_rgb 0.5 0.5 0.5; emission_rgb 1 1 1; end;
v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;
v e 0 0 1; v f 1 0 1; v g 1 1 1; v h 0 1 1;
f bottom (a b c d) glow; f top (e h g f) glow; f front (a e f b) glow;
f back (c g h d) glow; f left (a d h e) glow; f right (b f g c) glow;
";
    let patches = run_ok("ugcut", &["-q", "-l", "0.25"], Some(furnace.as_bytes()));
    // Shaped shooters (the default): each shot is shared as the unshot
    // light lies, which in the furnace is uneven until the end (a face's
    // edge has more from the faces that shot first), and the linear
    // elements carry that shape a little off at the cube's edges (2.0041
    // measured at worst).
    let out = run_ok(
        "ugrad",
        &["-q", "--converge", "1e-4", "--visibility", "ray"],
        Some(patches.as_bytes()),
    );
    let m = ug::parse(out.as_bytes(), "lit").unwrap().model;
    for v in &m.vertices {
        let b = m.material(v.color.unwrap()).diffuse();
        for c in b {
            assert!((c - 2.0).abs() <= 5e-3, "{}: {b:?}", v.name);
        }
    }
    // Uniform shooters: uniform to 1e-3.
    let out = run_ok(
        "ugrad",
        &[
            "-q",
            "--converge",
            "1e-4",
            "--visibility",
            "ray",
            "--uniform-shooters",
        ],
        Some(patches.as_bytes()),
    );
    let m = ug::parse(out.as_bytes(), "lit").unwrap().model;
    let patch_vertices = ug::parse(patches.as_bytes(), "p")
        .unwrap()
        .model
        .vertices
        .len();
    // Refinement did happen (the test is about the vertices it makes).
    assert!(
        m.vertices.len() > patch_vertices + 100,
        "{} vertices",
        m.vertices.len()
    );
    for v in &m.vertices {
        let b = m.material(v.color.unwrap()).diffuse();
        for c in b {
            assert!((c - 2.0).abs() <= 2e-3, "{}: {b:?}", v.name);
        }
    }
    // §6's rule is measurably wrong there (so the test above can fail).
    let out = run_ok(
        "ugrad",
        &[
            "-q",
            "--no-regather",
            "--converge",
            "1e-4",
            "--visibility",
            "ray",
        ],
        Some(patches.as_bytes()),
    );
    let m = ug::parse(out.as_bytes(), "lit").unwrap().model;
    let worst = m
        .vertices
        .iter()
        .map(|v| (m.material(v.color.unwrap()).diffuse()[0] - 2.0).abs())
        .fold(0.0, f64::max);
    assert!(worst > 0.02, "--no-regather: worst {worst}");
}

/// A closed 3 m box (ρ = 0.7) lit by a 0.2 m lamp in its ceiling (writing
/// the irradiance H): all the power the lamp emits is absorbed, so
/// Σ (1 − ρ) ∫H must equal the emitted power less what is left unshot.
/// The lamp's direct light is taken from its closed form, so the balance
/// measures what the solver moved and not the output's linear
/// interpolation of a peaked field. Each patch's reflected power was the
/// trapezoid rule over its elements' corners, short under the lamp's
/// peaked light (docs/performance.md, "The dark bias has a cause").
#[test]
fn a_closed_box_absorbs_what_its_lamp_emits() {
    // Measured: −0.32% when the solver took every patch's energy by the
    // trapezoid rule over its corners (the lamp's first light, peaked,
    // came out short), +0.09% with the centre sample (`quadrature`).
    let balance = closed_box_balance(&[]);
    assert!(balance.abs() < 2e-3, "{balance}");
}

/// The same balance with every shooter's light taken as uniform over it
/// (`--uniform-shooters`, the report's rule; the default shares it as it
/// lies, which moves light between receivers near a shooter and must not
/// make or lose any: −0.10% measured, +0.09% uniform).
#[test]
fn uniform_shooters_keep_the_closed_box_balance() {
    let balance = closed_box_balance(&["--uniform-shooters"]);
    assert!(balance.abs() < 2e-3, "{balance}");
}

/// The same box with every patch written twice (a second face on the same
/// vertices, as a CAD program writes a face for each side or twice over):
/// each copy would receive every shot's light, the energy growing with
/// every bounce. ugrad leaves one of each coincident pair out with a
/// warning, and the box balances as before.
#[test]
fn coincident_copies_are_left_out_and_the_closed_box_balances() {
    let balance = closed_box_balance_with(&[], true);
    assert!(balance.abs() < 2e-3, "{balance}");
}

/// Faces lying on one another that are not copies (each wall written once
/// whole and once as four pieces): the light grows without end, and ugrad
/// stops with an error (exit 1) and writes nothing, instead of running on.
#[test]
fn overlapping_faces_stop_with_an_error() {
    let out = run(
        "ugrad",
        &["--max-shots", "2000"],
        Some(&std::fs::read(fixture("rad/walls-written-twice.ug")).unwrap()),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("grows without end") && err.contains("ugclean"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}

fn closed_box_balance(extra: &[&str]) -> f64 {
    closed_box_balance_with(extra, false)
}

fn closed_box_balance_with(extra: &[&str], twice: bool) -> f64 {
    let xs = [0.0, 1.4, 1.6, 3.0];
    let mut s = String::from(
        "c_rgb grey 0.7 0.7 0.7;\n\
         defmat lamp; diffuse_rgb 0.5 0.5 0.5; emission_rgb 10 10 10; end;\n",
    );
    for (i, x) in xs.iter().enumerate() {
        for (j, z) in xs.iter().enumerate() {
            s += &format!("v c{i}{j} {x} 3 {z}; v f{i}{j} {x} 0 {z};\n");
        }
    }
    // Floor (one face, facing up), ceiling as 3 × 3 faces (facing down, the
    // middle one the lamp), four walls facing in; ugvlmerge removes the
    // T-vertices where the ceiling's grid meets the walls.
    s += "f floor (f00 f03 f33 f30) grey;\n";
    for i in 0..3 {
        for j in 0..3 {
            let mat = if (i, j) == (1, 1) { "lamp" } else { "grey" };
            s += &format!(
                "f c_{i}{j} (c{i}{j} c{}{j} c{}{} c{i}{}) {mat};\n",
                i + 1,
                i + 1,
                j + 1,
                j + 1
            );
        }
    }
    s += "f w0 (f00 f30 c30 c00) grey; f w1 (f03 c03 c33 f33) grey;\n\
          f w2 (f00 c00 c03 f03) grey; f w3 (f30 f33 c33 c30) grey;\n";
    let merged = run_ok("ugvlmerge", &["-q"], Some(s.as_bytes()));
    let check = run_ok("ugcheck", &["-q"], Some(merged.as_bytes()));
    assert!(check.contains("defects: 0"), "{check}");
    let mut patches = run_ok("ugcut", &["-q", "-l", "6%"], Some(merged.as_bytes()));
    if twice {
        let copies: String = patches
            .lines()
            .filter_map(|l| l.strip_prefix("f "))
            .map(|rest| format!("f copy.{rest}\n"))
            .collect();
        assert!(!copies.is_empty());
        patches += &copies;
    }
    let mut args = vec!["-v", "--output", "irradiance", "--visibility", "ray"];
    args.extend_from_slice(extra);
    let out = run("ugrad", &args, Some(patches.as_bytes()));
    assert!(out.status.success());
    let log = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        twice,
        log.contains("coincident faces left out"),
        "{}",
        log.lines().next().unwrap_or("")
    );
    let unshot: f64 = log
        .split("unshot ")
        .last()
        .and_then(|t| t.split_whitespace().next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no unshot figure in {log}"));
    let m = ug::parse(&out.stdout, "lit").unwrap().model;
    let col = colours(&m);
    // The lamp's direct light has a closed form (the box is empty): the
    // irradiance 10·F at a point, F the point-to-polygon form factor
    // (Lambert's contour integral; 0 in the lamp's plane). All of it lands on grey faces, so
    // exactly 0.3 of the emitted energy is absorbed from it; the rest of
    // what the output holds, H − H_direct, is reflected light, smooth
    // enough for the trapezoid rule over the output's triangles. So the
    // balance measures the energy the solver moved, not the trapezoid
    // rule's error over the lamp's peaked direct light in the output.
    let lamp = [
        [1.4, 3.0, 1.4],
        [1.6, 3.0, 1.4],
        [1.6, 3.0, 1.6],
        [1.4, 3.0, 1.6],
    ]
    .map(glam::DVec3::from_array);
    let direct = |x: glam::DVec3, n: glam::DVec3| {
        if (x.y - 3.0).abs() < 1e-9 {
            return 0.0; // in the lamp's plane
        }
        let mut f = 0.0;
        for i in 0..4 {
            let (r0, r1) = (lamp[i] - x, lamp[(i + 1) % 4] - x);
            let c = r0.cross(r1);
            if c.length() > 0.0 {
                f += r0.angle_between(r1) * n.dot(c / c.length());
            }
        }
        10.0 * f.abs() / (2.0 * std::f64::consts::PI)
    };
    let emitted = 10.0 * 0.2 * 0.2;
    let mut absorbed = 0.3 * emitted;
    let mut absorbed_total = 0.0;
    for f in m.top_faces() {
        let face = m.face(f);
        let rho = match m.material(face.material.unwrap()).name.as_str() {
            "lamp" => 0.5,
            _ => 0.7,
        };
        let c = &face.contours[0];
        let [a, b, d] = [c[0], c[1], c[2]].map(|v| m.pos(v));
        let n = (b - a).cross(d - a).normalize();
        for k in 1..c.len() - 1 {
            let t = [c[0], c[k], c[k + 1]];
            let [a, b, d] = t.map(|v| m.pos(v));
            let area = (b - a).cross(d - a).length() / 2.0;
            let h: f64 = t.iter().map(|v| col[v.idx()][0]).sum::<f64>() / 3.0;
            let hd: f64 = t.iter().map(|&v| direct(m.pos(v), n)).sum::<f64>() / 3.0;
            absorbed += (1.0 - rho) * area * (h - hd);
            absorbed_total += (1.0 - rho) * area * h;
        }
    }
    let balance = (absorbed + unshot * emitted) / emitted - 1.0;
    let output = (absorbed_total + unshot * emitted) / emitted - 1.0;
    eprintln!(
        "absorbed {absorbed}, unshot {unshot}: balance {balance:+.5} \
         (the output's trapezoid rule over all of H: {output:+.5})"
    );
    balance
}

#[test]
fn a_dim_little_emitter_does_not_hold_back_the_tail() {
    // Once the panel has shot, every reflector carries more energy than the
    // 2 cm dot, so shooting by energy alone left the dot to the end: the
    // tail waited for every emitter, and 8,960 reflectors shot first (52 s;
    // 13,060 at ugcut's default length, 105 s). The emitters still unshot
    // go first once the reflected light is spread thin enough: 41 shots.
    let input = patches("rad/room-with-a-dim-dot.ug", "0.2");
    let emitting = input
        .lines()
        .filter(|l| l.starts_with("f ") && (l.ends_with(" panel;") || l.ends_with(" dot;")))
        .count();
    assert_eq!(emitting, 26, "the panel's 25 patches and the dot");
    let out = run(
        "ugrad",
        &["-v", "--visibility", "ray"],
        Some(input.as_bytes()),
    );
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    let after: usize = err
        .lines()
        .find_map(|l| l.strip_prefix("indirect tail after shot "))
        .and_then(|r| r.split(':').next())
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("no tail: {err}"));
    assert!(
        (emitting..=3 * emitting).contains(&after),
        "the tail started after {after} shots: {err}"
    );
}

/// `--gradient-scale` scales the automatic gradient threshold (printed with
/// -v) and refines more: more leaf elements at half the threshold.
#[test]
fn gradient_scale_scales_the_automatic_threshold() {
    let input = patches("cornell-box.ug", "100");
    let solve = |scale: &str| {
        let out = run(
            "ugrad",
            &[
                "-v",
                "--converge",
                "0.05",
                "--tail",
                "0",
                "--gradient-scale",
                scale,
            ],
            Some(input.as_bytes()),
        );
        assert!(out.status.success());
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        let num = |key: &str, after: bool| -> f64 {
            let line = err.lines().find(|l| l.contains(key)).expect(key);
            let words: Vec<&str> = line
                .split([' ', ',', ';'])
                .filter(|w| !w.is_empty())
                .collect();
            let i = words.iter().position(|w| *w == key).expect(key);
            let w = if after { words[i + 1] } else { words[i - 1] };
            w.parse().unwrap_or_else(|_| panic!("{key}: {w}"))
        };
        (num("gradient", true), num("leaf", false))
    };
    let (g1, leaves1) = solve("1");
    let (g2, leaves2) = solve("0.5");
    assert!((g2 / g1 - 0.5).abs() < 1e-3, "gradient {g1} -> {g2}");
    assert!(leaves2 > leaves1, "leaf elements {leaves1} -> {leaves2}");
}
