//! Curved things crossing a room and each other, as public MGF scenes have
//! them: `cyl`, `sph`, `cone`, `torus` and `prism` entities that `mgf2ug`
//! tessellates (columns through the floor and ceiling, balls sunk into
//! the floor, cones and rings passing through each other), in a room
//! with a lamp. The dirty-building generator makes only boxes and twisted
//! quads; these make many thin facets meeting at small angles and
//! intersections along curves. Through the binaries, per seed: the full
//! chain passes `ugcheck --deny defects`, ugcut then leaves only patches
//! with no defect, the user's pipeline leaves only patches, and ugrad
//! lights both.

use ugkit::{run, run_ok};

/// A small deterministic generator (an LCG; the scene only needs to vary).
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }
}

/// The MGF text of seed `seed`'s room (metres, z up, faces facing in).
fn scene(seed: u64) -> String {
    let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x5151);
    let mut out = String::new();
    let mut nv = 0;
    let mut v = |out: &mut String, p: [f64; 3]| -> String {
        nv += 1;
        out.push_str(&format!("v p{nv} =\n\tp {} {} {}\n", p[0], p[1], p[2]));
        format!("p{nv}")
    };
    for (name, rd, ed) in [
        ("wall", 0.7, None),
        ("lamp", 0.8, Some(20.0)),
        ("stone", 0.5, None),
    ] {
        out.push_str(&format!("m {name} =\n\tc\n\trd {rd}\n\tsides 1\n"));
        if let Some(ed) = ed {
            out.push_str(&format!("\ted {ed}\n"));
        }
    }
    let (w, d, h) = (rng.range(4.0, 5.0), rng.range(3.0, 4.0), 2.7);
    let c: Vec<String> = [
        [0.0, 0.0, 0.0],
        [w, 0.0, 0.0],
        [w, d, 0.0],
        [0.0, d, 0.0],
        [0.0, 0.0, h],
        [w, 0.0, h],
        [w, d, h],
        [0.0, d, h],
    ]
    .into_iter()
    .map(|p| v(&mut out, p))
    .collect();
    out.push_str("m wall\n");
    for q in [
        [0, 1, 2, 3],
        [4, 7, 6, 5],
        [0, 4, 5, 1],
        [1, 5, 6, 2],
        [2, 6, 7, 3],
        [3, 7, 4, 0],
    ] {
        out.push_str(&format!(
            "f {} {} {} {}\n",
            c[q[0]], c[q[1]], c[q[2]], c[q[3]]
        ));
    }
    out.push_str("m lamp\n");
    let l: Vec<String> = [(-0.3, 0.3), (0.3, 0.3), (0.3, -0.3), (-0.3, -0.3)]
        .into_iter()
        .map(|(x, y)| v(&mut out, [w / 2.0 + x, d / 2.0 + y, h - 0.01]))
        .collect();
    out.push_str(&format!("f {} {} {} {}\n", l[0], l[1], l[2], l[3]));
    out.push_str("m stone\n");
    let things = 2 + (rng.unit() * 4.0) as usize;
    for k in 0..things {
        let (x, y) = (rng.range(0.3, w - 0.3), rng.range(0.3, d - 0.3));
        match k % 5 {
            0 => {
                let a = v(&mut out, [x, y, rng.range(-0.3, -0.1)]);
                let top = [
                    x + rng.range(-0.2, 0.2),
                    y + rng.range(-0.2, 0.2),
                    h + rng.range(0.0, 0.1),
                ];
                let b = v(&mut out, top);
                out.push_str(&format!("cyl {a} {} {b}\n", rng.range(0.05, 0.3)));
            }
            1 => {
                let a = v(&mut out, [x, y, rng.range(-0.2, 0.5)]);
                out.push_str(&format!("sph {a} {}\n", rng.range(0.1, 0.6)));
            }
            2 => {
                let a = v(&mut out, [x, y, rng.range(-0.1, 0.3)]);
                let b = v(&mut out, [x, y, rng.range(0.8, h + 0.2)]);
                let (r0, r1) = (rng.range(0.1, 0.4), rng.range(0.0, 0.1));
                out.push_str(&format!("cone {a} {r0} {b} {r1}\n"));
            }
            3 => {
                let (nx, ny) = (rng.range(-0.3, 0.3), rng.range(-0.3, 0.3));
                out.push_str(&format!(
                    "v n{k} =\n\tp {x} {y} {}\n\tn {nx} {ny} 1\n",
                    rng.range(0.0, 1.0)
                ));
                let (r0, r1) = (rng.range(0.05, 0.15), rng.range(0.2, 0.5));
                out.push_str(&format!("torus n{k} {r0} {r1}\n"));
            }
            _ => {
                let p: Vec<String> = [0.0, 2.1, 4.2]
                    .into_iter()
                    .map(|t: f64| v(&mut out, [x + 0.3 * t.cos(), y + 0.3 * t.sin(), -0.05]))
                    .collect();
                out.push_str(&format!(
                    "prism {} {} {} {}\n",
                    p[0],
                    p[1],
                    p[2],
                    rng.range(0.3, 3.0)
                ));
            }
        }
    }
    out
}

/// Runs the stages in order on `input`; every stage must succeed.
fn pipe(input: &[u8], stages: &[(&str, &[&str])]) -> Vec<u8> {
    let mut data = input.to_vec();
    for (name, args) in stages {
        let out = run(name, args, Some(&data));
        assert!(
            out.status.success(),
            "{name} {args:?} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        data = out.stdout;
    }
    data
}

fn report(data: &[u8]) -> serde_json::Value {
    serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(data))).unwrap()
}

fn count(r: &serde_json::Value, key: &str) -> usize {
    r[key].as_array().map_or(0, Vec::len)
}

/// The seeds: 1 to 12 (80 passed when this was written; 12 keep CI
/// quick), or `UG_CURVED_SEEDS=A..B` by hand.
fn seeds() -> std::ops::Range<u64> {
    std::env::var("UG_CURVED_SEEDS")
        .ok()
        .and_then(|s| {
            let (a, b) = s.split_once("..")?;
            Some(a.parse().ok()?..b.parse().ok()?)
        })
        .unwrap_or(1..13)
}

#[test]
fn curved_things_crossing_a_room_go_through_the_chain() {
    for seed in seeds() {
        let mgf = scene(seed);
        let ug = run_ok("mgf2ug", &["-q"], Some(mgf.as_bytes())).into_bytes();
        let faces = |d: &[u8]| ug::parse(d, "m").unwrap().model.faces.len();
        assert!(faces(&ug) > 20, "seed {seed}: the scene has its things");
        let clean = pipe(
            &ug,
            &[
                ("ugplanar", &["-q"]),
                ("ugvlmerge", &["-q"]),
                ("ugflip", &["-q"]),
                ("ugisect", &["-q"]),
                ("ugcopl", &["-q"]),
                ("ugclean", &["-q"]),
            ],
        );
        let out = run("ugcheck", &["--deny", "defects"], Some(&clean));
        assert!(
            out.status.success(),
            "seed {seed}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
        let patches = pipe(&clean, &[("ugcut", &["-q"])]);
        let r = report(&patches);
        for key in [
            "nonpatch",
            "tvertices",
            "degenerate",
            "overlapping",
            "intersecting",
            "inconsistent",
        ] {
            assert_eq!(count(&r, key), 0, "seed {seed}: {key}: {}", r[key]);
        }
        let user = pipe(
            &ug,
            &[
                ("ugvlmerge", &["-q"]),
                ("ugisect", &["-q"]),
                ("ugcut", &["-q", "-l", "0.1"]),
            ],
        );
        assert_eq!(
            count(&report(&user), "nonpatch"),
            0,
            "seed {seed}: user's pipeline"
        );
        for (what, data) in [("chain", &patches), ("user's", &user)] {
            let lit = pipe(data, &[("ugrad", &["-q", "--max-shots", "3"])]);
            let m = ug::parse(&lit[..], "lit").unwrap().model;
            assert!(
                m.vertices.iter().all(|v| v.color.is_some()),
                "seed {seed} ({what}): a vertex without a colour"
            );
        }
    }
}
