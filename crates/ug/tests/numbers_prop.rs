//! Numbers: the parser reads every decimal exactly as Rust's `str::parse`
//! does (it has a fast path of its own for short decimals), and the writer's
//! fast formatting gives exactly ryu's shortest round-trip text.

use proptest::prelude::*;

fn parse_x(text: &str) -> Option<f64> {
    ug::parse(format!("v a {text} 0 0;").as_bytes(), "t.ug")
        .ok()
        .map(|p| p.model.vertices[0].pos.x)
}

fn written(v: f64) -> String {
    let mut out = Vec::new();
    ug::push_f64(&mut out, v, &mut ryu::Buffer::new());
    String::from_utf8(out).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn decimals_read_as_str_parse_reads_them(
        sign in prop::sample::select(vec!["", "-", "+"]),
        int in "[0-9]{0,22}",
        frac in proptest::option::of("[0-9]{0,22}"),
        exp in proptest::option::of(-330i32..330),
    ) {
        let mut s = format!("{sign}{int}");
        if let Some(f) = &frac {
            s.push('.');
            s.push_str(f);
        }
        if let Some(e) = exp {
            s.push_str(&format!("e{e}"));
        }
        let want = s.parse::<f64>().ok().filter(|v| v.is_finite());
        let got = parse_x(&s);
        prop_assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{}", s);
    }

    #[test]
    fn the_writer_formats_as_ryu_and_reads_back(bits in any::<u64>()) {
        let v = f64::from_bits(bits);
        prop_assume!(v.is_finite());
        let mut buf = ryu::Buffer::new();
        let want = ug::fmt_f64(v, &mut buf).to_string();
        prop_assert_eq!(written(v), want.clone());
        prop_assert_eq!(parse_x(&want).map(f64::to_bits), Some(if v == 0.0 { 0f64.to_bits() } else { v.to_bits() }));
    }

    #[test]
    fn short_decimals_format_as_ryu(n in -10_000_000_000_000i64..10_000_000_000_000, scale in 0u32..9) {
        // The values the fast writer path is for: a few decimals.
        let v = n as f64 / 10f64.powi(scale as i32);
        let mut buf = ryu::Buffer::new();
        let want = ug::fmt_f64(v, &mut buf).to_string();
        prop_assert_eq!(written(v), want.clone());
        prop_assert_eq!(parse_x(&want), Some(if v == 0.0 { 0.0 } else { v }));
    }
}

#[test]
fn writer_edge_values() {
    let mut buf = ryu::Buffer::new();
    for v in [
        1e-4,
        -1e-4,
        0.000099999,
        0.00001,
        1e-5,
        9.999999e-5,
        1e9,
        999999999.999999,
        999999999.9999999,
        1e15,
        1e16,
        0.1,
        0.123456,
        0.1234567,
        123.000001,
        -0.0,
        5e-324,
        f64::MAX,
        2f64.powi(50) / 1e6,
    ] {
        assert_eq!(written(v), ug::fmt_f64(v, &mut buf), "{v:e}");
    }
}
