//! Randomised test of the cleaning chain (ugvlmerge | ugisect | ugcopl |
//! ugclean) on seeded random boxes that overlap, touch exactly (coordinates on
//! a half-unit lattice) or nearly (a lattice coordinate moved by 1e-7, below
//! the model epsilon): afterwards `ugcheck` finds no intersecting pair, no
//! coplanar overlap, no coincident faces, no T-vertex and no degenerate face,
//! and ugisect and ugcopl keep the area of every material to 1e-9 (1e-6 when
//! a coordinate sat within epsilon of another: such points are snapped).

use ugkit::run_ok;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn pick(&mut self, options: &[f64]) -> f64 {
        options[((self.next() * options.len() as f64) as usize).min(options.len() - 1)]
    }
}

/// Three random boxes, and whether a coordinate was moved off the lattice by
/// less than epsilon.
fn boxes(seed: u64) -> (String, bool) {
    let mut r = Rng(seed.wrapping_mul(0x9E3779B97F4A7C15) | 1);
    let mut near = false;
    let mut s =
        String::from("c_rgb m0 0.5 0.5 0.5;\nc_rgb m1 0.6 0.2 0.2;\nc_rgb m2 0.2 0.6 0.2;\n");
    for k in 0..3 {
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for i in 0..3 {
            let lattice = r.pick(&[0.0, 0.5, 1.0, 1.5, 2.0, 3.0]);
            lo[i] = match (r.next() * 3.0) as u32 {
                0 => lattice,
                1 => {
                    near = true;
                    lattice + 1e-7
                }
                _ => r.next() * 3.0,
            };
            let free = 0.2 + 1.8 * r.next();
            hi[i] = lo[i] + r.pick(&[0.5, 1.0, 2.0, free]);
        }
        let c = |x: usize, y: usize, z: usize| {
            [[lo[0], hi[0]][x], [lo[1], hi[1]][y], [lo[2], hi[2]][z]]
        };
        let corners = [
            c(0, 0, 0),
            c(1, 0, 0),
            c(1, 1, 0),
            c(0, 1, 0),
            c(0, 0, 1),
            c(1, 0, 1),
            c(1, 1, 1),
            c(0, 1, 1),
        ];
        for (n, p) in corners.iter().enumerate() {
            s.push_str(&format!("v b{k}_{n} {:?} {:?} {:?};\n", p[0], p[1], p[2]));
        }
        for (name, q) in [
            ("bottom", [0, 3, 2, 1]),
            ("top", [4, 5, 6, 7]),
            ("front", [0, 1, 5, 4]),
            ("right", [1, 2, 6, 5]),
            ("back", [2, 3, 7, 6]),
            ("left", [3, 0, 4, 7]),
        ] {
            let v: Vec<String> = q.iter().map(|i| format!("b{k}_{i}")).collect();
            s.push_str(&format!("f b{k}_{name} ({}) m{k};\n", v.join(" ")));
        }
    }
    (s, near)
}

fn check(text: &str) -> serde_json::Value {
    serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(text.as_bytes()))).unwrap()
}

#[test]
fn random_boxes_come_out_clean() {
    for seed in 0..60 {
        let (src, near) = boxes(seed);
        let merged = run_ok("ugvlmerge", &["-q"], Some(src.as_bytes()));
        let cut = run_ok("ugisect", &["-q"], Some(merged.as_bytes()));
        let copl = run_ok("ugcopl", &["-q"], Some(cut.as_bytes()));
        let clean = run_ok("ugclean", &["-q"], Some(copl.as_bytes()));
        let r = check(&clean);
        for key in [
            "intersecting",
            "overlapping",
            "coincident",
            "tvertices",
            "degenerate",
        ] {
            assert_eq!(
                r[key].as_array().unwrap().len(),
                0,
                "seed {seed}: {key} {}\n{src}",
                r[key]
            );
        }
        let (a, b) = (check(&merged), check(&copl));
        for (x, y) in a["area_by_material"]
            .as_array()
            .unwrap()
            .iter()
            .zip(b["area_by_material"].as_array().unwrap())
        {
            let (x, y) = (x["area"].as_f64().unwrap(), y["area"].as_f64().unwrap());
            // Where a coordinate sits within epsilon of another, cut points fall
            // within epsilon of each other and are snapped together, moving
            // them by up to epsilon; otherwise area is kept to 1e-9.
            let tol = if near { 1e-6 } else { 1e-9 };
            assert!(
                (x - y).abs() <= tol * x,
                "seed {seed}: area {x} → {y}\n{src}"
            );
        }
    }
}
