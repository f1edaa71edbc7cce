//! Helpers shared by the ug crate's integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use glam::DVec3;
use ug::{Diagnostic, Model, ParseOptions, Parsed};

/// The workspace root (where `fixtures/` lives).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Parses `src` (named `t.ug`) with default options and panics on an error.
pub fn parse(src: &str) -> Model {
    parsed(src).model
}

/// Parses `src` and returns the model with its warnings.
pub fn parsed(src: &str) -> Parsed {
    match ug::parse(src.as_bytes(), "t.ug") {
        Ok(p) => p,
        Err(e) => panic!("parse failed: {e}\n--- source\n{src}"),
    }
}

/// Parses `src` and returns the error.
pub fn parse_err(src: &str) -> Diagnostic {
    match ug::parse(src.as_bytes(), "t.ug") {
        Ok(_) => panic!("parse unexpectedly succeeded\n--- source\n{src}"),
        Err(e) => e,
    }
}

/// Parses with options.
pub fn parse_opts(src: &str, opts: &ParseOptions) -> Result<Parsed, Diagnostic> {
    ug::parse_with(src.as_bytes(), "t.ug", None, opts)
}

/// Writes a model and parses the text back; asserts equality and that writing is idempotent.
pub fn assert_round_trip(m: &Model) -> String {
    let text = ug::write_string(m);
    let back = match ug::parse(text.as_bytes(), "written.ug") {
        Ok(p) => p.model,
        Err(e) => panic!("written text does not parse: {e}\n--- text\n{text}"),
    };
    assert_eq!(&back, m, "parse(write(m)) != m\n--- text\n{text}");
    assert_eq!(ug::write_string(&back), text, "write is not idempotent");
    text
}

/// Compares with a golden file under the workspace root; `UPDATE_GOLDEN=1` rewrites it.
pub fn assert_golden(rel: &str, actual: &str) {
    let p = root().join(rel);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d).expect("create golden directory");
        }
        std::fs::write(&p, actual).expect("write golden file");
        return;
    }
    let expected = std::fs::read_to_string(&p).unwrap_or_else(|e| {
        panic!(
            "missing golden file {} ({e}); run with UPDATE_GOLDEN=1",
            p.display()
        )
    });
    assert!(
        expected == actual,
        "output differs from golden file {}\n--- expected\n{expected}\n--- actual\n{actual}",
        p.display()
    );
}

/// Newell's normal (not normalised) of a contour of points.
pub fn newell(pts: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (k, a) in pts.iter().enumerate() {
        let b = pts[(k + 1) % pts.len()];
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    n
}

/// The positions of a face's outer contour.
pub fn outer(m: &Model, f: ug::FaceId) -> Vec<DVec3> {
    m.face(f).contours[0].iter().map(|&v| m.pos(v)).collect()
}

/// The vertex with this name (panics when there is none).
pub fn vertex<'m>(m: &'m Model, name: &str) -> &'m ug::Vertex {
    m.vertices
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| {
            let names: Vec<&str> = m.vertices.iter().map(|v| v.name.as_str()).collect();
            panic!("no vertex {name}; have {names:?}")
        })
}

/// Asserts two points are equal within `eps` per coordinate.
#[track_caller]
pub fn assert_close(a: DVec3, b: DVec3, eps: f64) {
    assert!(
        (a - b).abs().max_element() <= eps,
        "{a:?} is not within {eps} of {b:?}"
    );
}
