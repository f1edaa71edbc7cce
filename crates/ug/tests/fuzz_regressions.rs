//! Inputs found by the fuzzer (`fuzz/fuzz_targets/parse.rs`), kept as tests.
//! Each runs the fuzz target's checks: parsing returns; on success the model
//! round-trips through the writer, writing is idempotent, and flattening with
//! small limits returns a flat model that round-trips too.

use ug::{FlattenLimits, IncludeMode, ParseOptions};

fn opts() -> ParseOptions {
    ParseOptions {
        strict: false,
        includes: IncludeMode::Keep,
        limits: false,
    }
}

/// The fuzz target's body; returns the parse error message, if any.
fn check(data: &[u8]) -> Option<String> {
    // (The fast/general comparison of the fuzz target lives in tests/fast_paths.rs,
    // where no other test runs concurrently with the global switch.)
    let m = match ug::parse_with(data, "fuzz.ug", None, &opts()) {
        Ok(p) => p.model,
        Err(e) => return Some(e.to_string()),
    };
    let text = ug::write_string(&m);
    let back = ug::parse_with(text.as_bytes(), "written.ug", None, &opts())
        .unwrap_or_else(|e| panic!("written model does not parse: {e}\n--- text\n{text}"))
        .model;
    assert_eq!(back, m, "parse(write(m)) != m\n--- text\n{text}");
    assert_eq!(ug::write_string(&back), text);
    let limits = FlattenLimits {
        max_vertices: 10_000,
        max_faces: 10_000,
    };
    if let Ok(flat) = m.flatten_with(limits) {
        assert!(flat.is_flat());
        let text = ug::write_string(&flat);
        let back = ug::parse_with(text.as_bytes(), "flat.ug", None, &opts())
            .unwrap_or_else(|e| panic!("flattened model does not parse: {e}\n--- text\n{text}"))
            .model;
        assert_eq!(back, flat);
    }
    None
}

#[test]
fn byte_order_mark_inside_the_file_starting_an_unknown_keyword() {
    // `;` BOM `@ floor.ug;`: the BOM was part of the unknown keyword, the writer put
    // it first in the file, where the lexer skips a BOM, so the keyword changed.
    // Unknown keywords must now be printable ASCII like every other name.
    let e = check(b";\xef\xbb\xbf@ floor.ug;\n").expect("an error");
    assert_eq!(
        e,
        r"fuzz.ug:1:2: error: invalid statement keyword '\u{feff}@': names are printable ASCII"
    );
    // Non-ASCII bytes elsewhere in an unknown statement are kept.
    assert_eq!(check("zz \u{feff}é;".as_bytes()), None);
}

#[test]
fn twenty_digit_number_overflowed_the_fast_number_path() {
    // `v 1a 22222222222200000115 0 0;`: twenty digits overflowed the u64
    // mantissa of the fast decimal path (a panic with overflow checks, a wrong
    // value without). Numbers must read exactly as Rust's `str::parse` reads them.
    let src = b"v 1a 22222222222200000115 0 0;\nioclf.ug;\n;\n";
    assert_eq!(check(src), None);
    let m = ug::parse(src, "t.ug").unwrap().model;
    assert_eq!(m.vertices[0].pos.x, 22222222222200000115f64);
    for s in [
        "99999999999999999999",
        "18446744073709551615",
        "18446744073709551616",
        "1844674407370955161.6",
        "9007199254740993",
        "9007199254740992.5",
        "0.1234567890123456789",
        "-1234567890123456789",
    ] {
        let m = ug::parse(format!("v a {s} 0 0;").as_bytes(), "t.ug")
            .unwrap()
            .model;
        assert_eq!(m.vertices[0].pos.x, s.parse::<f64>().unwrap(), "{s}");
    }
}

#[test]
fn empty_quoted_include_name() {
    // `include '';` kept the empty name, which was written as `include ;`.
    let src = b";1 / \xa6\x80=\x000;\n\ninclude '';\nc 0+1 000;\n";
    assert_eq!(
        check(src).as_deref(),
        Some("fuzz.ug:3:9: error: empty include file name ''''")
    );
    assert_eq!(
        check(b"include \"\";").as_deref(),
        Some("fuzz.ug:1:9: error: empty include file name '\"\"'")
    );
    // Names that are themselves quoted keep their quotes through a round trip.
    for name in ["\"\"a\"\"", "''a''", "'\"'", "\"'\"", "'x\"", "\"", "'"] {
        assert_eq!(check(format!("include {name};").as_bytes()), None, "{name}");
    }
    let m = ug::parse_with(b"include '\"a\"';", "t.ug", None, &opts())
        .unwrap()
        .model;
    assert_eq!(m.items, vec![ug::Item::Include("\"a\"".into())]);
    assert_eq!(ug::write_string(&m), "include '\"a\"';\n");
}
