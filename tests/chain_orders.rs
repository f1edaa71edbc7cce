//! The cleaning tools in other orders and subsets than the recommended
//! chain, on small dirty CAD buildings (`ugbuilding --cad`, with curved
//! things, stairs or a triangle export by seed).
//!
//! - In any order and subset every tool succeeds, and what it writes is
//!   read back (vertices defined before use).
//! - In every order where ugvlmerge (if it runs) comes before ugisect and
//!   ugcopl, and ugclean after ugflip, ugisect and ugcopl, the model ends
//!   clean after ugcut: no defect and only patches. (ugvlmerge joins the
//!   coplanar pieces of a material again, so after ugcopl it undoes its
//!   cuts; ugclean removes what ugflip turns and ugcopl cuts into
//!   coincident pairs, and ugflip never removes a face.)

use ugkit::{CHAIN_TOOLS as TOOLS, DEFECT_KEYS, run_ok};

struct Rng(u64);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) % n as u64) as usize
    }
}

fn building(seed: u64) -> Vec<u8> {
    let s = seed.to_string();
    let mut args = vec!["--cad", "--faces", "600", "--seed", &s];
    match seed % 4 {
        1 => args.push("--curved"),
        2 => args.push("--stairs"),
        3 => args.push("--triangles"),
        _ => {}
    }
    run_ok("ugbuilding", &args, None).into_bytes()
}

fn run_chain(input: &[u8], order: &[&str]) -> Vec<u8> {
    let mut text = input.to_vec();
    for tool in order {
        text = run_ok(tool, &["-q"], Some(&text)).into_bytes();
    }
    text
}

/// ugcheck's defect counts (and faces that are not patches), the non-zero ones.
fn defects(text: &[u8]) -> Vec<(String, usize)> {
    let r: serde_json::Value =
        serde_json::from_str(&run_ok("ugcheck", &["--json"], Some(text))).unwrap();
    DEFECT_KEYS
        .iter()
        .chain(&["nonpatch"])
        .map(|k| (k.to_string(), r[*k].as_array().unwrap().len()))
        .filter(|(_, n)| *n > 0)
        .collect()
}

#[test]
fn any_order_and_subset_runs() {
    for seed in 0..4u64 {
        let mut r = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1));
        let input = building(seed);
        // A random subset in a random order (with repeats allowed).
        let n = 1 + r.below(6);
        let order: Vec<&str> = (0..n).map(|_| TOOLS[r.below(6)]).collect();
        let out = run_chain(&input, &order);
        let out = run_ok("ugcut", &["-q"], Some(&out));
        // ugcheck reads it (a vertex named before its definition is an error).
        let r: serde_json::Value = serde_json::from_str(&run_ok(
            "ugcheck",
            &["--json", "--strict"],
            Some(out.as_bytes()),
        ))
        .unwrap();
        assert!(
            r["counts"]["faces"].as_u64().unwrap() > 0,
            "seed {seed} {order:?}"
        );
        assert!(
            r["nonpatch"].as_array().unwrap().is_empty(),
            "seed {seed} {order:?}: ugcut left faces that are not patches"
        );
    }
}

#[test]
fn orders_that_keep_the_dependencies_end_clean() {
    for seed in 0..8u64 {
        let mut r = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(7));
        let input = building(seed);
        // ugisect, ugcopl and ugflip in a random order, ugplanar anywhere
        // (or not), ugvlmerge before ugisect and ugcopl (or not), ugclean
        // after the three.
        let mut order: Vec<&str> = Vec::new();
        for t in ["ugisect", "ugcopl", "ugflip"] {
            let at = r.below(order.len() + 1);
            order.insert(at, t);
        }
        if r.below(2) == 0 {
            let first = order
                .iter()
                .position(|t| *t == "ugisect" || *t == "ugcopl")
                .unwrap();
            let at = r.below(first + 1);
            order.insert(at, "ugvlmerge");
        }
        order.push("ugclean");
        if r.below(2) == 0 {
            let at = r.below(order.len() + 1);
            order.insert(at, "ugplanar");
        }
        let out = run_chain(&input, &order);
        let cut = run_ok("ugcut", &["-q"], Some(&out));
        let d = defects(cut.as_bytes());
        assert!(d.is_empty(), "seed {seed}, {order:?} | ugcut: {d:?}");
    }
}
