//! The canonical writer: golden output, round trips and idempotence.

mod common;

use common::*;
use ug::{Model, ParseOptions};

fn fixture_model(rel: &str) -> Model {
    let p = root().join(rel);
    ug::parse_file(&p, &ParseOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .model
}

#[test]
fn canonical_output_of_the_sample_matches_its_golden_file() {
    let m = fixture_model("fixtures/ug/sample.ug");
    let text = ug::write_string(&m);
    assert_golden("fixtures/ug/sample.canonical.ug", &text);
}

#[test]
fn flattened_sample_matches_its_golden_file() {
    let m = fixture_model("fixtures/ug/sample.ug").flatten().unwrap();
    let text = assert_round_trip(&m);
    assert_golden("fixtures/ug/sample.flat.ug", &text);
}

#[test]
fn sample_round_trips_and_writing_is_idempotent() {
    let m = fixture_model("fixtures/ug/sample.ug");
    let text = assert_round_trip(&m);
    // The canonical text is a fixed point of parse-then-write.
    let again = ug::write_string(&parse(&text));
    assert_eq!(again, text);
}

#[test]
fn every_fixture_round_trips() {
    let mut n = 0;
    for dir in ["fixtures/ug", "fixtures/ug/include"] {
        for e in std::fs::read_dir(root().join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "ug") {
                let m = ug::parse_file(&p, &ParseOptions::default())
                    .unwrap_or_else(|e| panic!("{e}"))
                    .model;
                assert_round_trip(&m);
                if !m.is_flat() {
                    assert_round_trip(&m.flatten().unwrap());
                }
                n += 1;
            }
        }
    }
    assert!(n >= 3, "only {n} fixtures");
}

#[test]
fn canonical_form_of_small_statements() {
    let cases: &[(&str, &str)] = &[
        ("c_rgb  r  1.0  0.50 0.25 ;", "c_rgb r 1 0.5 0.25;\n"),
        ("c g .5 120.0;", "c g 0.5 120;\n"),
        ("v a -0 +1 1e3;", "v a 0 1 1000;\n"),
        (
            "v a 1e-7 1e21 123456789012345680000;",
            "v a 1e-7 1e21 1.2345678901234568e20;\n",
        ),
        (
            "v a 0.1 0.2 0.30000000000000004;",
            "v a 0.1 0.2 0.30000000000000004;\n",
        ),
        (
            "v a 0 0 0;v b 1 0 0;v c 0 1 0;f(a b c);w n(a  b)(b c);",
            "v a 0 0 0;\nv b 1 0 0;\nv c 0 1 0;\nf (a b c);\nw n (a b) (b c);\n",
        ),
        (
            "def d;v p 0 0 0;end;i(d -tx 1.50);a r(d)2 -rz 90.0;",
            "def d;\n  v p 0 0 0;\nend;\ni (d -tx 1.5);\na r (d) 2 -rz 90;\n",
        ),
        ("defmat m;end;", "defmat m;\nend;\n"),
        (
            "def d; defmat m; emission_rgb 1 1 1; end; end;",
            "def d;\n  defmat m;\n    emission_rgb 1 1 1;\n  end;\nend;\n",
        ),
        ("l   s  1  ( 2 3 ) ;", "l s 1 ( 2 3 );\n"),
        ("cam;", "cam;\n"),
        ("(  raw  (text)  );", "(  raw  (text)  )\n"),
        ("{c}{d}", "{c}\n{d}\n"),
        ("zz 1 2;", "zz 1 2;\n"),
    ];
    for (src, want) in cases {
        let m = parse(src);
        assert_eq!(&ug::write_string(&m), want, "source: {src:?}");
        assert_round_trip(&m);
    }
}

#[test]
fn numbers_are_written_shortest_and_read_back_exactly() {
    let mut buf = ryu_buffer();
    for v in [
        0.0,
        -0.0,
        1.0,
        -1.5,
        0.1,
        1.0 / 3.0,
        1e300,
        -1e-300,
        f64::MIN_POSITIVE,
        5e-324,
        f64::MAX,
        f64::MIN,
        123456789.0,
        2f64.powi(53),
    ] {
        let s = ug::fmt_f64(v, &mut buf).to_string();
        assert!(!s.ends_with(".0"), "{s}");
        assert!(
            !s.starts_with("-0") || s.len() > 2 && !s.starts_with("-0."),
            "{s}"
        );
        let back: f64 = s.parse().unwrap();
        assert_eq!(back, v, "{v} written as {s}");
        let m = parse(&format!("v a {s} {s} {s};"));
        assert_eq!(m.vertices[0].pos.x, v);
    }
    assert_eq!(ug::fmt_f64(-0.0, &mut buf), "0");
    assert_eq!(ug::fmt_f64(2.0, &mut buf), "2");
}

fn ryu_buffer() -> ryu::Buffer {
    ryu::Buffer::new()
}

#[test]
fn write_to_an_io_writer() {
    let m = parse("v a 1 2 3;");
    let mut out = Vec::new();
    ug::write(&m, &mut out).unwrap();
    assert_eq!(out, b"v a 1 2 3;\n");
}

#[test]
fn a_model_built_in_code_is_written_and_read_back() {
    use glam::DVec3;
    use ug::*;
    let mut m = Model::new();
    let red = m.add_material(Material {
        name: "red".into(),
        def: MaterialDef::Rgb([1.0, 0.0, 0.0]),
    });
    let vs: Vec<VertexId> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]
        .iter()
        .enumerate()
        .map(|(k, &(x, y))| {
            m.add_vertex(Vertex {
                name: format!("v{k}"),
                pos: DVec3::new(x, y, 0.0),
                color: (k == 0).then_some(red),
            })
        })
        .collect();
    m.add_face(Face {
        name: Some("t".into()),
        contours: vec![vs.clone()],
        material: Some(red),
    });
    let text = assert_round_trip(&m);
    assert_eq!(
        text,
        "c_rgb red 1 0 0;\nv v0 0 0 0 red;\nv v1 1 0 0;\nv v2 0 1 0;\nf t (v0 v1 v2) red;\n"
    );
}

#[test]
fn vertices_are_written_before_the_first_face_that_names_them() {
    // The parser accepts forward references; the writer never emits them,
    // so one-pass readers can stream its output.
    let src = b"c_rgb m 1 1 1;\nf t (a b c) m;\nv a 0 0 0;\nw e (c d);\nv b 1 0 0;\nv c 0 1 0;\nv d 5 5 5;\nf u (a b d);\n";
    let m = ug::parse(src, "<t>").unwrap().model;
    let text = ug::write_string(&m);
    assert_eq!(
        text,
        "c_rgb m 1 1 1;\nv a 0 0 0;\nv b 1 0 0;\nv c 0 1 0;\nf t (a b c) m;\nv d 5 5 5;\nw e (c d);\nf u (a b d);\n"
    );
    // Idempotent, and the same model.
    let back = ug::parse(text.as_bytes(), "<t>").unwrap().model;
    assert_eq!(ug::write_string(&back), text);
    assert_eq!(back.faces.len(), 2);
}
