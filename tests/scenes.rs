//! Scenes unlike the dirty buildings, as public MGF and OBJ files have
//! them, through the binaries (the dirty-building generator makes only
//! boxes and twisted quads, in UG):
//! * curved things crossing a room and each other: `cyl`, `sph`, `cone`,
//!   `torus` and `prism` entities that `mgf2ug` tessellates (columns
//!   through the floor and ceiling, balls sunk into the floor, cones and
//!   rings passing through each other): many thin facets meeting at small
//!   angles, intersections along curves;
//! * OBJ prisms on concave n-gons (caps as single n-gons, extra collinear
//!   vertices on edges, caps duplicated as fresh vertex records) crossing
//!   each other and the room, some standing on the floor or reaching the
//!   ceiling exactly or 1e-6 off it, 20% of faces reversed, 5% repeating a
//!   vertex, jitter of 1e-7, materials from an MTL file with an emitter.
//!
//! Per seed: the full chain passes `ugcheck --deny defects`, ugcut then
//! leaves only patches with no defect, the user's pipeline leaves only
//! patches, and ugrad lights both.

use ugkit::{pipe, run, run_ok};

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

/// The corners of a room `w` × `d` × `h` standing at the origin.
fn room_corners(w: f64, d: f64, h: f64) -> [[f64; 3]; 8] {
    [
        [0.0, 0.0, 0.0],
        [w, 0.0, 0.0],
        [w, d, 0.0],
        [0.0, d, 0.0],
        [0.0, 0.0, h],
        [w, 0.0, h],
        [w, d, h],
        [0.0, d, h],
    ]
}

/// The room's faces as corners of [`room_corners`], each facing in.
const ROOM_FACES: [[usize; 4]; 6] = [
    [0, 1, 2, 3],
    [4, 7, 6, 5],
    [0, 4, 5, 1],
    [1, 5, 6, 2],
    [2, 6, 7, 3],
    [3, 7, 4, 0],
];

/// The MGF text of seed `seed`'s curved room (metres, z up, faces facing in).
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
    let c: Vec<String> = room_corners(w, d, h)
        .into_iter()
        .map(|p| v(&mut out, p))
        .collect();
    out.push_str("m wall\n");
    for q in ROOM_FACES {
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

fn report(data: &[u8]) -> serde_json::Value {
    serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(data))).unwrap()
}

fn count(r: &serde_json::Value, key: &str) -> usize {
    r[key].as_array().map_or(0, Vec::len)
}

/// The seeds: 1 to 12 (80 curved rooms and 80 OBJ rooms passed when this
/// was written; 12 keep CI quick), or `UG_SCENE_SEEDS=A..B` by hand.
fn seeds() -> std::ops::Range<u64> {
    std::env::var("UG_SCENE_SEEDS")
        .ok()
        .and_then(|s| {
            let (a, b) = s.split_once("..")?;
            Some(a.parse().ok()?..b.parse().ok()?)
        })
        .unwrap_or(1..13)
}

/// The checks of the module's notes on one converted scene (`what` names
/// it in failures).
fn assert_goes_through(ug: &[u8], what: &str) {
    let faces = |d: &[u8]| ug::parse(d, "m").unwrap().model.faces.len();
    assert!(faces(ug) > 20, "{what}: the scene has its things");
    let clean = pipe(
        ug,
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
        "{what}: {}",
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
        assert_eq!(count(&r, key), 0, "{what}: {key}: {}", r[key]);
    }
    let user = pipe(
        ug,
        &[
            ("ugvlmerge", &["-q"]),
            ("ugisect", &["-q"]),
            ("ugcut", &["-q", "-l", "0.1"]),
        ],
    );
    assert_eq!(
        count(&report(&user), "nonpatch"),
        0,
        "{what}: user's pipeline"
    );
    for (how, data) in [("chain", &patches), ("user's", &user)] {
        let lit = pipe(data, &[("ugrad", &["-q", "--max-shots", "3"])]);
        let m = ug::parse(&lit[..], "lit").unwrap().model;
        assert!(
            m.vertices.iter().all(|v| v.color.is_some()),
            "{what} ({how}): a vertex without a colour"
        );
    }
}

#[test]
fn curved_things_crossing_a_room_go_through_the_chain() {
    for seed in seeds() {
        let ug = run_ok("mgf2ug", &["-q"], Some(scene(seed).as_bytes())).into_bytes();
        assert_goes_through(&ug, &format!("curved room, seed {seed}"));
    }
}

/// The OBJ text of seed `seed`'s room of concave prisms (see the module's
/// notes), naming the MTL file `d.mtl`.
fn obj_scene(seed: u64) -> String {
    let mut rng = Rng(seed.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ 0x0b1);
    let mut v: Vec<[f64; 3]> = Vec::new();
    let mut faces: Vec<(&str, Vec<usize>)> = Vec::new();
    let vert = |v: &mut Vec<[f64; 3]>, p: [f64; 3]| {
        v.push(p);
        v.len()
    };
    let (w, d, h) = (6.0, 5.0, 3.0);
    let c: Vec<usize> = room_corners(w, d, h)
        .into_iter()
        .map(|p| vert(&mut v, p))
        .collect();
    for q in ROOM_FACES {
        faces.push(("wall", q.iter().map(|&i| c[i]).collect()));
    }
    let lamp = [(2.5, 2.0), (2.5, 3.0), (3.5, 3.0), (3.5, 2.0)]
        .into_iter()
        .map(|(x, y)| vert(&mut v, [x, y, h - 0.001]))
        .collect();
    faces.push(("lamp", lamp));
    let prisms = 2 + (rng.unit() * 5.0) as usize;
    for _ in 0..prisms {
        let (cx, cy) = (rng.range(0.5, w - 0.5), rng.range(0.5, d - 0.5));
        let n = 5 + (rng.unit() * 8.0) as usize;
        let turn = rng.unit();
        let mut ring: Vec<(f64, f64)> = Vec::new();
        let corners: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let r = rng.range(0.2, 0.8)
                    * if i % 2 == 1 && rng.unit() < 0.6 {
                        0.45
                    } else {
                        1.0
                    };
                let a = turn + std::f64::consts::TAU * i as f64 / n as f64;
                (cx + r * a.cos(), cy + r * a.sin())
            })
            .collect();
        for i in 0..n {
            let (a, b) = (corners[i], corners[(i + 1) % n]);
            ring.push(a);
            if rng.unit() < 0.3 {
                let t = rng.range(0.2, 0.8);
                ring.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
            }
        }
        let z0 = [0.0, 1e-6, -1e-6, 2e-5, rng.range(-0.3, 0.5)][(rng.unit() * 5.0) as usize];
        let z1 = [h, h - 1e-6, 1.0, 1.0 + 3e-6, z0 + rng.range(0.3, h + 0.5)]
            [(rng.unit() * 5.0) as usize];
        let bot: Vec<usize> = ring
            .iter()
            .map(|&(x, y)| vert(&mut v, [x, y, z0]))
            .collect();
        let mut top: Vec<usize> = ring
            .iter()
            .map(|&(x, y)| vert(&mut v, [x, y, z1]))
            .collect();
        if rng.unit() < 0.5 {
            // The top's corners again, as fresh vertex records.
            top = top
                .iter()
                .map(|&k| {
                    let p = v[k - 1];
                    vert(&mut v, p)
                })
                .collect();
        }
        faces.push(("stone", bot.iter().rev().copied().collect()));
        faces.push(("stone", top.clone()));
        let m = ring.len();
        for i in 0..m {
            let j = (i + 1) % m;
            faces.push(("stone", vec![bot[i], bot[j], top[j], top[i]]));
        }
    }
    let mut out = String::from("mtllib d.mtl\n");
    for p in &v {
        let j = |x: f64, r: &mut Rng| x + r.range(-1e-7, 1e-7);
        let p = [j(p[0], &mut rng), j(p[1], &mut rng), j(p[2], &mut rng)];
        out.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
    }
    let mut current = "";
    for (mat, mut idx) in faces {
        if rng.unit() < 0.2 {
            idx.reverse();
        }
        if rng.unit() < 0.05 && idx.len() > 3 {
            let i = (rng.unit() * idx.len() as f64) as usize;
            idx.insert(i, idx[i]);
        }
        if mat != current {
            out.push_str(&format!("usemtl {mat}\n"));
            current = mat;
        }
        let list: Vec<String> = idx.iter().map(usize::to_string).collect();
        out.push_str(&format!("f {}\n", list.join(" ")));
    }
    out
}

#[test]
fn concave_obj_prisms_crossing_a_room_go_through_the_chain() {
    let dir = std::env::temp_dir().join(format!("ugkit-scenes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("d.mtl"),
        "newmtl wall\nKd 0.7 0.7 0.7\nnewmtl stone\nKd 0.5 0.5 0.5\n\
         newmtl lamp\nKd 0.8 0.8 0.8\nKe 20 20 20\n",
    )
    .unwrap();
    for seed in seeds() {
        let path = dir.join(format!("room{seed}.obj"));
        std::fs::write(&path, obj_scene(seed)).unwrap();
        let ug = run_ok("obj2ug", &["-q", path.to_str().unwrap()], None).into_bytes();
        assert_goes_through(&ug, &format!("OBJ room, seed {seed}"));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
