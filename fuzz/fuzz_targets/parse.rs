//! Fuzz target: the UG parser on arbitrary bytes.
//!
//! Whatever the input, parsing must return (no panic, no hang, no abort), with
//! the same result whether the parser's fast paths for plain statements are on
//! or off. When it succeeds, the model written back must parse to the same model, writing
//! must be idempotent, and flattening (with small limits) must return and give
//! a flat model that also round-trips.

#![no_main]

use libfuzzer_sys::fuzz_target;
use ug::{FlattenLimits, IncludeMode, ParseOptions};

fuzz_target!(|data: &[u8]| {
    // Includes are kept, not read: the fuzzer must not read files.
    let opts = ParseOptions {
        strict: false,
        includes: IncludeMode::Keep,
    };
    let result = ug::parse_with(data, "fuzz.ug", None, &opts);
    // The fast paths for plain statements agree with the general parser,
    // errors included.
    ug::parser::set_fast_paths(false);
    let general = ug::parse_with(data, "fuzz.ug", None, &opts);
    ug::parser::set_fast_paths(true);
    match (&result, &general) {
        (Ok(a), Ok(b)) => {
            assert_eq!(a.model, b.model, "fast and general parsers differ");
            assert_eq!(
                a.warnings, b.warnings,
                "fast and general parsers warn differently"
            );
        }
        (Err(a), Err(b)) => assert_eq!(a, b, "fast and general parsers report different errors"),
        _ => panic!("fast and general parsers differ: {result:?} vs {general:?}"),
    }
    let Ok(parsed) = result else {
        return;
    };
    let m = parsed.model;
    let text = ug::write_string(&m);
    let back = match ug::parse_with(text.as_bytes(), "written.ug", None, &opts) {
        Ok(p) => p.model,
        Err(e) => panic!("written model does not parse: {e}\n--- text\n{text}"),
    };
    assert_eq!(back, m, "parse(write(m)) != m\n--- text\n{text}");
    assert_eq!(ug::write_string(&back), text, "writing is not idempotent");

    let limits = FlattenLimits {
        max_vertices: 10_000,
        max_faces: 10_000,
    };
    if let Ok(flat) = m.flatten_with(limits) {
        assert!(flat.is_flat());
        let text = ug::write_string(&flat);
        match ug::parse_with(text.as_bytes(), "flat.ug", None, &opts) {
            Ok(p) => assert_eq!(
                p.model, flat,
                "flattened model does not round-trip\n--- text\n{text}"
            ),
            Err(e) => panic!("flattened model does not parse: {e}\n--- text\n{text}"),
        }
    }
});
