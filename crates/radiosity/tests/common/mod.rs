//! Helpers shared by the solver's integration tests.

/// A UG text cut into patches of edge length about `len` (ugcut, epsilon 1e-9).
pub fn patches(src: &str, len: f64) -> ug::Model {
    let m = ug::parse(src.as_bytes(), "test").unwrap().model;
    let opts = libmesh::patch::Options {
        len,
        eps: 1e-9,
        angle: 25.0,
        quads: true,
    };
    libmesh::patch::cut(&m, opts).expect("meshed").0
}
