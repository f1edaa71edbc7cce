//! The parser reads plain `v`, `f` and `w` statements through fast paths; it
//! must give exactly the same results as the general parser, errors (message
//! and position) and warnings included. This file compares the two on random
//! near-UG text (one test only: the switch is global to the process).

use proptest::prelude::*;

/// Parses `src` with the fast paths on and off; both results as text.
fn both(src: &[u8]) -> (String, String) {
    let run = |fast: bool| {
        ug::parser::set_fast_paths(fast);
        let r = ug::parse(src, "t.ug");
        ug::parser::set_fast_paths(true);
        match r {
            Ok(p) => {
                let w: Vec<String> = p.warnings.iter().map(ToString::to_string).collect();
                format!("{:?}\n{w:?}", p.model)
            }
            Err(e) => e.to_string(),
        }
    };
    (run(true), run(false))
}

fn token() -> BoxedStrategy<String> {
    prop_oneof![
        // Names, some odd.
        3 => prop::sample::select(vec!["a", "b", "c", "d", "ab", "x:1", "#", "v", "f", "w", "end", "red", "-x", "é", "1"]).prop_map(String::from),
        // Numbers, some bad.
        3 => prop::sample::select(vec![
            "0", "-1.5", "1e3", "2.", ".5", "+7", "0.30000000000000004", "123456789012345678901234",
            "1.2.3", "nan", "inf", "1e400", "-0", "0x1", "9007199254740993", "0.0000001",
        ]).prop_map(String::from),
        2 => prop::sample::select(vec!["(", ")", ";", ";", "{c}", "{", "}"]).prop_map(String::from),
        1 => prop::sample::select(vec!["v", "f", "w", "c_rgb", "i", "def", "l"]).prop_map(String::from),
    ]
    .boxed()
}

fn sep() -> BoxedStrategy<&'static str> {
    prop::sample::select(vec![
        " ", " ", " ", "  ", "\t", "\n", "\r\n", " {c} ", "{x\ny}", "", "\x0b",
    ])
    .boxed()
}

/// A statement shaped like a vertex or face, with random separators and
/// occasional wrong tokens.
fn statement() -> BoxedStrategy<String> {
    let vertex = (
        prop::sample::select(vec!["a", "b", "c", "d", "é", "1", "v"]),
        proptest::collection::vec(token(), 3..=3),
        proptest::option::of(prop::sample::select(vec!["red", "blue", "v", "1", "é"])),
        proptest::collection::vec(sep(), 7),
        any::<bool>(),
    )
        .prop_map(|(name, nums, color, seps, semi)| {
            let mut s = format!("v{}{name}", seps[0]);
            for (k, n) in nums.iter().enumerate() {
                s.push_str(seps[k + 1]);
                s.push_str(n);
            }
            if let Some(c) = color {
                s.push_str(seps[4]);
                s.push_str(c);
            }
            s.push_str(seps[5]);
            if semi {
                s.push(';');
            }
            s.push_str(seps[6]);
            s
        });
    let face = (
        prop::sample::select(vec!["f", "w"]),
        proptest::option::of(prop::sample::select(vec!["t", "u", "é", "v"])),
        proptest::collection::vec(proptest::collection::vec(token(), 0..5), 1..3),
        proptest::option::of(prop::sample::select(vec!["red", "blue", "v", "1"])),
        proptest::collection::vec(sep(), 6),
        any::<bool>(),
    )
        .prop_map(|(kw, name, contours, color, seps, semi)| {
            let mut s = kw.to_string();
            if let Some(n) = name {
                s.push_str(seps[0]);
                s.push_str(n);
            }
            s.push_str(seps[1]);
            for c in contours {
                s.push('(');
                let words: Vec<String> = c;
                s.push_str(&words.join(seps[2]));
                s.push(')');
                s.push_str(seps[3]);
            }
            if let Some(c) = color {
                s.push_str(c);
                s.push_str(seps[4]);
            }
            if semi {
                s.push(';');
            }
            s.push_str(seps[5]);
            s
        });
    let noise = proptest::collection::vec((token(), sep()), 1..6).prop_map(|ts| {
        ts.into_iter()
            .map(|(t, s)| format!("{t}{s}"))
            .collect::<String>()
    });
    prop_oneof![4 => vertex, 4 => face, 1 => noise].boxed()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

    #[test]
    fn fast_paths_agree_with_the_general_parser(
        prefix in prop::sample::select(vec!["", "c_rgb red 1 0 0;\n", "v a 0 0 0; v b 1 0 0; v c 0 1 0;\n", "def d;\n"]),
        stmts in proptest::collection::vec(statement(), 1..8),
        suffix in prop::sample::select(vec!["", "\nend;", "\nc_rgb blue 0 0 1;\n", "\nv d 1 1 1;"]),
    ) {
        let src = format!("{prefix}{}{suffix}", stmts.concat());
        let (fast, general) = both(src.as_bytes());
        prop_assert_eq!(fast, general, "source:\n{}", src);
    }
}
