//! Every statement kind parses into the expected Model.

mod common;

use common::parse;
use common::*;
use glam::DVec3;
use ug::*;

fn raw(keyword: &str, text: &str) -> Raw {
    Raw {
        keyword: keyword.into(),
        text: text.into(),
    }
}

#[test]
fn empty_input_is_an_empty_model() {
    assert_eq!(parse(""), Model::default());
    assert_eq!(parse(" \n\t;;\n"), Model::default());
}

#[test]
fn c_rgb() {
    let m = parse("c_rgb red 0.9 0.2 0.1;");
    assert_eq!(
        m.materials,
        vec![Material {
            name: "red".into(),
            def: MaterialDef::Rgb([0.9, 0.2, 0.1]),
        }]
    );
    assert_eq!(m.items, vec![Item::Material(MaterialId(0))]);
    assert_eq!(m.materials[0].diffuse(), [0.9, 0.2, 0.1]);
    assert_eq!(m.materials[0].emission(), [0.0; 3]);
    assert!(!m.materials[0].is_emitter());
}

#[test]
fn c_with_one_to_four_values() {
    let m = parse("c g1 0.5; c g2 0.5 120; c g3 0.5 120 1; c g4 0.5 120 1 0.3;");
    let vals: Vec<Vec<f64>> = m
        .materials
        .iter()
        .map(|mat| match &mat.def {
            MaterialDef::Lhs(v) => v.clone(),
            other => panic!("not a c colour: {other:?}"),
        })
        .collect();
    assert_eq!(
        vals,
        vec![
            vec![0.5],
            vec![0.5, 120.0],
            vec![0.5, 120.0, 1.0],
            vec![0.5, 120.0, 1.0, 0.3],
        ]
    );
    // Lightness only (or no saturation) is grey; hue 120 at full saturation is green;
    // translucency is ignored.
    assert_eq!(m.materials[0].diffuse(), [0.5; 3]);
    assert_eq!(m.materials[1].diffuse(), [0.5; 3]);
    assert_eq!(m.materials[2].diffuse(), [0.0, 1.0, 0.0]);
    assert_eq!(m.materials[3].diffuse(), [0.0, 1.0, 0.0]);
}

#[test]
fn c_hsl_conversion() {
    let close = |a: [f64; 3], b: [f64; 3]| {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12) || panic!("{a:?} != {b:?}")
    };
    close(lhs_to_rgb(&[0.5, 0.0, 1.0]), [1.0, 0.0, 0.0]);
    close(lhs_to_rgb(&[0.5, 240.0, 1.0]), [0.0, 0.0, 1.0]);
    close(lhs_to_rgb(&[0.5, 60.0, 1.0]), [1.0, 1.0, 0.0]);
    close(lhs_to_rgb(&[0.5, 360.0 + 180.0, 1.0]), [0.0, 1.0, 1.0]);
    close(lhs_to_rgb(&[0.5, -120.0, 1.0]), [0.0, 0.0, 1.0]);
    close(lhs_to_rgb(&[0.75, 0.0, 1.0]), [1.0, 0.5, 0.5]);
    close(lhs_to_rgb(&[0.25, 0.0, 0.5]), [0.375, 0.125, 0.125]);
    close(lhs_to_rgb(&[1.0, 200.0, 1.0]), [1.0, 1.0, 1.0]);
    close(lhs_to_rgb(&[0.0, 200.0, 1.0]), [0.0, 0.0, 0.0]);
    // Out-of-range lightness and saturation are clamped.
    close(lhs_to_rgb(&[2.0]), [1.0; 3]);
    close(lhs_to_rgb(&[0.5, 0.0, 7.0]), [1.0, 0.0, 0.0]);
    close(lhs_to_rgb(&[]), [0.0; 3]);
}

#[test]
fn defmat_with_diffuse_emission_and_unknown_properties() {
    let m = parse(
        "defmat lamp;\n  diffuse_rgb 0.1 0.2 0.3;\n  emission_rgb 5 6 7;\n  specular 0.5 {c} shiny;\n  flag;\nend;",
    );
    assert_eq!(
        m.materials,
        vec![Material {
            name: "lamp".into(),
            def: MaterialDef::Defmat(Defmat {
                diffuse: Some([0.1, 0.2, 0.3]),
                emission: Some([5.0, 6.0, 7.0]),
                other: vec![
                    ("specular".into(), vec!["0.5".into(), "shiny".into()]),
                    ("flag".into(), vec![]),
                ],
            }),
        }]
    );
    assert_eq!(m.materials[0].diffuse(), [0.1, 0.2, 0.3]);
    assert_eq!(m.materials[0].emission(), [5.0, 6.0, 7.0]);
    assert!(m.materials[0].is_emitter());
}

#[test]
fn defmat_defaults_are_zero() {
    let m = parse("defmat black; end; defmat glow; emission_rgb 1 0 0; end;");
    assert_eq!(m.materials[0].def, MaterialDef::Defmat(Defmat::default()));
    assert_eq!(m.materials[0].diffuse(), [0.0; 3]);
    assert_eq!(m.materials[0].emission(), [0.0; 3]);
    assert!(!m.materials[0].is_emitter());
    assert_eq!(m.materials[1].diffuse(), [0.0; 3]);
    assert!(m.materials[1].is_emitter());
}

#[test]
fn vertices_with_and_without_colour() {
    let m = parse("v a 1 2 3;\nv b -1.5 2e3 .5 red;\nc_rgb red 1 0 0;\nv c +4 -0 1E-3 red;");
    assert_eq!(
        m.vertices,
        vec![
            Vertex {
                name: "a".into(),
                pos: DVec3::new(1.0, 2.0, 3.0),
                color: None
            },
            Vertex {
                name: "b".into(),
                pos: DVec3::new(-1.5, 2000.0, 0.5),
                color: Some(MaterialId(0))
            },
            Vertex {
                name: "c".into(),
                pos: DVec3::new(4.0, 0.0, 0.001),
                color: Some(MaterialId(0))
            },
        ]
    );
    assert_eq!(
        m.items,
        vec![
            Item::Vertex(VertexId(0)),
            Item::Vertex(VertexId(1)),
            Item::Material(MaterialId(0)),
            Item::Vertex(VertexId(2)),
        ]
    );
}

#[test]
fn names_use_printable_ascii() {
    let m = parse(
        "v a:b_c#d.e-f+g/h'i\"j~ 0 0 0; v 123 1 0 0; v v 0 1 0; f end (a:b_c#d.e-f+g/h'i\"j~ 123 v);",
    );
    assert_eq!(m.vertices[0].name, "a:b_c#d.e-f+g/h'i\"j~");
    assert_eq!(m.vertices[1].name, "123");
    assert_eq!(m.vertices[2].name, "v");
    assert_eq!(m.faces[0].name.as_deref(), Some("end"));
}

#[test]
fn faces_and_wires_with_and_without_names() {
    let m = parse(
        "c_rgb red 1 0 0;\n\
         v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\n\
         v e .2 .2 0; v f .2 .4 0; v g .4 .4 0;\n\
         f (a b c);\n\
         f named (a b c d) (e f g) red;\n\
         w (a b);\n\
         w edge (a b c) (c d) red;\n",
    );
    let (a, b, c, d, e, f, g) = (
        VertexId(0),
        VertexId(1),
        VertexId(2),
        VertexId(3),
        VertexId(4),
        VertexId(5),
        VertexId(6),
    );
    assert_eq!(
        m.faces,
        vec![
            Face {
                name: None,
                contours: vec![vec![a, b, c]],
                material: None
            },
            Face {
                name: Some("named".into()),
                contours: vec![vec![a, b, c, d], vec![e, f, g]],
                material: Some(MaterialId(0))
            },
        ]
    );
    assert_eq!(
        m.wires,
        vec![
            Wire {
                name: None,
                polylines: vec![vec![a, b]],
                material: None
            },
            Wire {
                name: Some("edge".into()),
                polylines: vec![vec![a, b, c], vec![c, d]],
                material: Some(MaterialId(0))
            },
        ]
    );
    assert_eq!(
        &m.items[8..],
        &[
            Item::Face(FaceId(0)),
            Item::Face(FaceId(1)),
            Item::Wire(WireId(0)),
            Item::Wire(WireId(1)),
        ]
    );
    assert_eq!(
        m.top_faces().collect::<Vec<_>>(),
        vec![FaceId(0), FaceId(1)]
    );
}

#[test]
fn vertices_may_be_named_before_they_are_defined() {
    let m = parse("f t (a b c) red; v a 0 0 0; v b 1 0 0; v c 0 1 0; c_rgb red 1 0 0;");
    assert_eq!(
        m.faces[0].contours,
        vec![vec![VertexId(0), VertexId(1), VertexId(2)]]
    );
    assert_eq!(m.faces[0].material, Some(MaterialId(0)));
}

#[test]
fn a_keyword_as_trailing_colour_before_semicolon_is_a_colour() {
    // `v` right before `;` can only be a colour name.
    let m = parse("c_rgb v 1 1 1; v a 0 0 0 v;");
    assert_eq!(m.vertices[0].color, Some(MaterialId(0)));
}

#[test]
fn nested_defs_and_scopes() {
    let m = parse(
        "v p 9 9 9;\n\
         def outer;\n\
           v p 0 0 0;\n\
           def inner;\n\
             v p 1 1 1; v q 2 2 2; v r 3 3 3;\n\
             f t (p q r);\n\
           end;\n\
           i x (inner);\n\
           f t (p p2 p3);\n\
           v p2 1 0 0; v p3 0 1 0;\n\
         end;\n\
         i (outer);\n",
    );
    assert_eq!(m.defs.len(), 2);
    // Defs are stored when their `end` is read: inner first.
    assert_eq!(m.defs[0].name, "inner");
    assert_eq!(m.defs[1].name, "outer");
    assert_eq!(
        m.items,
        vec![
            Item::Vertex(VertexId(0)),
            Item::Def(DefId(1)),
            Item::Instance(InstanceId(1))
        ]
    );
    let outer = &m.defs[1];
    assert!(matches!(outer.items[1], Item::Def(DefId(0))));
    // Each def has its own vertex and face namespaces: `p` and `t` are reused.
    let names: Vec<&str> = m.vertices.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["p", "p", "p", "q", "r", "p2", "p3"]);
    assert_eq!(
        m.faces[1].contours[0],
        vec![VertexId(1), VertexId(5), VertexId(6)]
    );
    assert_eq!(m.instances[0].def, DefId(0));
    assert_eq!(m.instances[0].name.as_deref(), Some("x"));
    assert_eq!(m.instances[1].def, DefId(1));
    // Only top-level vertices count as the model's top vertices.
    assert_eq!(m.top_vertices().collect::<Vec<_>>(), vec![VertexId(0)]);
    assert!(!m.is_flat());
}

#[test]
fn instances_with_every_transform_flag() {
    let mut src = String::from("def d; end; c_rgb red 1 0 0;\ni x (d red");
    let mut expected = Vec::new();
    for (k, op) in TransformOp::ALL.into_iter().enumerate() {
        let args: Vec<f64> = if op == TransformOp::M4 {
            vec![
                1.0, 0.0, 0.0, 4.0, 0.0, 1.0, 0.0, 5.0, 0.0, 0.0, 1.0, 6.0, 0.0, 0.0, 0.0, 2.0,
            ]
        } else {
            (0..op.arity()).map(|j| (k * 20 + j) as f64 + 0.5).collect()
        };
        src.push(' ');
        src.push_str(op.flag());
        for a in &args {
            src.push_str(&format!(" {a}"));
        }
        expected.push(Transform { op, args });
    }
    src.push_str(");\n");
    let m = parse(&src);
    assert_eq!(
        m.instances,
        vec![Instance {
            name: Some("x".into()),
            def: DefId(0),
            color: Some(MaterialId(0)),
            transforms: expected,
            array: None,
        }]
    );
    // Flags and their arities.
    for op in TransformOp::ALL {
        assert_eq!(TransformOp::from_flag(op.flag().as_bytes()), Some(op));
    }
    assert_eq!(TransformOp::from_flag(b"-q"), None);
}

#[test]
fn arrays() {
    let m = parse(
        "def d; v p 0 0 0; end;\n\
         a row (d -tx 1) 5 -ty 2 -rz 90;\n\
         a (d) 0;\n\
         a plain (d) 3;\n",
    );
    assert_eq!(
        m.instances[0],
        Instance {
            name: Some("row".into()),
            def: DefId(0),
            color: None,
            transforms: vec![Transform {
                op: TransformOp::Tx,
                args: vec![1.0]
            }],
            array: Some(ArraySpec {
                count: 5,
                step: vec![
                    Transform {
                        op: TransformOp::Ty,
                        args: vec![2.0]
                    },
                    Transform {
                        op: TransformOp::Rz,
                        args: vec![90.0]
                    },
                ],
            }),
        }
    );
    assert_eq!(
        m.instances[1].array,
        Some(ArraySpec {
            count: 0,
            step: vec![]
        })
    );
    assert_eq!(m.instances[1].name, None);
    assert_eq!(
        m.instances[2].array,
        Some(ArraySpec {
            count: 3,
            step: vec![]
        })
    );
}

#[test]
fn instance_names_are_per_scope() {
    let m = parse("def d; end;\ndef e; i x (d); end;\ni x (d);\ni y (e);");
    assert_eq!(m.instances.len(), 3);
    let e = parse_err("def d; end;\ni x (d); a x (d) 2;");
    assert_eq!(e.to_string(), "t.ug:2:12: error: duplicate array name 'x'");
}

#[test]
fn lights_and_cameras_are_kept_as_words() {
    let m = parse("l sun 1 1 {dropped} 1 (0 0 1);\ncam eye   -pos 0 0 10 -look (1 2 3);\nl;");
    assert_eq!(
        m.items,
        vec![
            Item::Light(raw("l", "sun 1 1 1 ( 0 0 1 )")),
            Item::Camera(raw("cam", "eye -pos 0 0 10 -look ( 1 2 3 )")),
            Item::Light(raw("l", "")),
        ]
    );
}

#[test]
fn escapes_keep_nested_parentheses_verbatim() {
    let m = parse("(shade (a (b)) ; c {x})\n(second)\n{ after }\nv a 0 0 0;\n(third);");
    assert_eq!(
        m.items,
        vec![
            Item::Escape("shade (a (b)) ; c {x}".into()),
            Item::Escape("second".into()),
            Item::Comment(" after ".into()),
            Item::Vertex(VertexId(0)),
            Item::Escape("third".into()),
        ]
    );
}

#[test]
fn an_escape_followed_directly_by_a_comment_keeps_the_comment() {
    // Regression: the optional ';' after an escape was looked for with a
    // look-ahead that dropped comments.
    let m = parse("(esc){c1}{c2};v a 0 0 0;");
    assert_eq!(
        m.items,
        vec![
            Item::Escape("esc".into()),
            Item::Comment("c1".into()),
            Item::Comment("c2".into()),
            Item::Vertex(VertexId(0)),
        ]
    );
    assert_round_trip(&m);
}

#[test]
fn comments_nest_and_are_kept_only_between_statements() {
    let m = parse(
        "{ a { nested { deeper } } comment }\n\
         v {inside} a {also inside} 0 0 0 {and here};\n\
         def d; {in a def} end;\n\
         {last}",
    );
    assert_eq!(
        m.items,
        vec![
            Item::Comment(" a { nested { deeper } } comment ".into()),
            Item::Vertex(VertexId(0)),
            Item::Def(DefId(0)),
            Item::Comment("last".into()),
        ]
    );
    assert_eq!(m.defs[0].items, vec![Item::Comment("in a def".into())]);
    assert_eq!(m.vertices[0].pos, DVec3::ZERO);
}

#[test]
fn unknown_keywords_warn_with_their_position() {
    let p = parsed("v a 0 0 0;\n  frob x (1 2) y;\nv b 1 1 1;");
    assert_eq!(p.model.items[1], Item::Unknown(raw("frob", "x ( 1 2 ) y")));
    assert_eq!(p.warnings.len(), 1);
    let w = &p.warnings[0];
    assert_eq!(w.level, Level::Warning);
    assert_eq!(
        w.to_string(),
        "t.ug:2:3: warning: unknown statement 'frob' passed through"
    );
    assert_eq!(
        w.pos,
        Some(Pos {
            file: "t.ug".into(),
            line: 2,
            col: 3
        })
    );
}

#[test]
fn unknown_keywords_are_errors_when_strict() {
    let opts = ParseOptions {
        strict: true,
        ..Default::default()
    };
    let e = parse_opts("v a 0 0 0;\n  frob x;", &opts).unwrap_err();
    assert_eq!(e.level, Level::Error);
    assert_eq!(
        e.to_string(),
        "t.ug:2:3: error: unknown statement 'frob' (--strict)"
    );
    // Known statements are fine under --strict.
    assert!(parse_opts("l sun 1; cam c 1; (esc)", &opts).is_ok());
}

#[test]
fn include_resolves_relative_to_the_including_file() {
    let top = root().join("fixtures/ug/include/top.ug");
    let p = parse_file(&top, &ParseOptions::default()).expect("parse top.ug");
    let m = p.model;
    let names: Vec<&str> = m.vertices.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "c"]);
    // The included statements are spliced in place, in the including scope.
    assert!(matches!(m.items[0], Item::Comment(_)));
    assert_eq!(
        &m.items[1..],
        &[
            Item::Material(MaterialId(0)),
            Item::Vertex(VertexId(0)),
            Item::Vertex(VertexId(1)),
            Item::Vertex(VertexId(2)),
            Item::Face(FaceId(0)),
        ]
    );
    assert_eq!(
        m.faces[0].contours[0],
        vec![VertexId(0), VertexId(1), VertexId(2)]
    );
}

#[test]
fn include_kept_with_include_mode_keep() {
    let opts = ParseOptions {
        includes: IncludeMode::Keep,
        ..Default::default()
    };
    let p = parse_opts(
        "v a 0 0 0;\ninclude parts/walls.ug;\ninclude \"no/such/file.ug\";",
        &opts,
    )
    .unwrap();
    // The files are not read (the second does not exist); quotes are dropped.
    assert_eq!(
        p.model.items,
        vec![
            Item::Vertex(VertexId(0)),
            Item::Include("parts/walls.ug".into()),
            Item::Include("no/such/file.ug".into()),
        ]
    );
    let text = assert_round_trip_keep(&p.model);
    assert_eq!(
        text,
        "v a 0 0 0;\ninclude parts/walls.ug;\ninclude no/such/file.ug;\n"
    );
}

fn assert_round_trip_keep(m: &Model) -> String {
    let opts = ParseOptions {
        includes: IncludeMode::Keep,
        ..Default::default()
    };
    let text = write_string(m);
    assert_eq!(&parse_opts(&text, &opts).unwrap().model, m);
    text
}

#[test]
fn include_names_may_be_quoted() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("part.ug"), "v b 1 0 0;").unwrap();
    std::fs::write(
        dir.path().join("top.ug"),
        "v a 0 0 0;\ninclude \"part.ug\";\ninclude 'part.ug';",
    )
    .unwrap();
    // The same file included twice in a row is not a cycle, but it defines `b` twice.
    let e = parse_file(&dir.path().join("top.ug"), &ParseOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .ends_with("part.ug:1:3: error: duplicate vertex name 'b'"),
        "{e}"
    );
    std::fs::write(
        dir.path().join("top.ug"),
        "v a 0 0 0;\ninclude \"part.ug\";",
    )
    .unwrap();
    let m = parse_file(&dir.path().join("top.ug"), &ParseOptions::default())
        .unwrap()
        .model;
    assert_eq!(m.vertices.len(), 2);
}

#[test]
fn included_files_report_errors_in_their_own_name() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    std::fs::write(dir.path().join("sub/part.ug"), "v b 1 0 0;\nv c 1 x 0;").unwrap();
    std::fs::write(dir.path().join("top.ug"), "include sub/part.ug;").unwrap();
    let e = parse_file(&dir.path().join("top.ug"), &ParseOptions::default()).unwrap_err();
    let file = dir.path().join("sub/part.ug");
    assert_eq!(
        e.to_string(),
        format!(
            "{}:2:7: error: bad number 'x' (expected y coordinate)",
            file.display()
        )
    );
}

#[test]
fn include_cycles_and_self_includes_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.ug"), "v a 0 0 0;\ninclude b.ug;").unwrap();
    std::fs::write(dir.path().join("b.ug"), "v b 0 0 0;\ninclude a.ug;").unwrap();
    std::fs::write(dir.path().join("self.ug"), "include self.ug;").unwrap();
    let e = parse_file(&dir.path().join("a.ug"), &ParseOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("b.ug:2:9: error: include cycle: "), "{msg}");
    assert!(msg.ends_with("a.ug' is already being read"), "{msg}");
    let e = parse_file(&dir.path().join("self.ug"), &ParseOptions::default()).unwrap_err();
    assert!(
        e.to_string().contains("self.ug:1:9: error: include cycle"),
        "{e}"
    );
}

#[test]
fn includes_nest_at_most_32_deep() {
    let dir = tempfile::tempdir().unwrap();
    let write_chain = |n: usize| {
        for k in 0..n {
            let body = if k + 1 < n {
                format!("include f{}.ug;", k + 1)
            } else {
                "v last 0 0 0;".to_string()
            };
            std::fs::write(dir.path().join(format!("f{k}.ug")), body).unwrap();
        }
    };
    // f0 includes f1 … f32: 32 nested includes are fine.
    write_chain(33);
    let m = parse_file(&dir.path().join("f0.ug"), &ParseOptions::default())
        .unwrap()
        .model;
    assert_eq!(m.vertices.len(), 1);
    // One more is too deep.
    write_chain(34);
    let e = parse_file(&dir.path().join("f0.ug"), &ParseOptions::default()).unwrap_err();
    assert!(e.to_string().contains("nested more than 32 deep"), "{e}");
}

#[test]
fn missing_include_file_is_an_error_at_its_name() {
    let e = parse_err("v a 0 0 0;\ninclude  no/such/file.ug;");
    let msg = e.to_string();
    assert!(
        msg.starts_with("t.ug:2:10: error: cannot read include file 'no/such/file.ug': "),
        "{msg}"
    );
}

#[test]
fn defs_nest_at_most_100_deep() {
    let deep = |n: usize| {
        let mut s = String::new();
        for k in 0..n {
            s.push_str(&format!("def d{k};\n"));
        }
        s.push_str(&"end;\n".repeat(n));
        s
    };
    assert_eq!(parse(&deep(100)).defs.len(), 100);
    let e = parse_err(&deep(101));
    assert_eq!(
        e.to_string(),
        "t.ug:101:5: error: defs nested more than 100 deep"
    );
}

#[test]
fn a_byte_order_mark_is_skipped() {
    let m = parse("\u{feff}v a 0 0 0;");
    assert_eq!(m.vertices[0].name, "a");
    let e = parse_err("\u{feff}v a 0 0 x;");
    assert_eq!(
        e.to_string(),
        "t.ug:1:9: error: bad number 'x' (expected z coordinate)"
    );
}

#[test]
fn columns_count_characters_not_bytes() {
    let e = parse_err("{ é }v a 0 0 x;");
    assert_eq!(
        e.to_string(),
        "t.ug:1:14: error: bad number 'x' (expected z coordinate)"
    );
    let e = parse_err("{ multi\nline é comment } v a\t0 0 x;");
    assert_eq!(
        e.to_string(),
        "t.ug:2:26: error: bad number 'x' (expected z coordinate)"
    );
}

#[test]
fn numbers_are_finite_decimals() {
    for ok in [
        "1", "-1", "+1", ".5", "5.", "1e3", "1E-3", "-0", "0.000001", "1e308",
    ] {
        let m = parse(&format!("v a {ok} 0 0;"));
        assert_eq!(m.vertices[0].pos.x, ok.parse::<f64>().unwrap(), "{ok}");
    }
    for bad in [
        "nan",
        "NaN",
        "inf",
        "-inf",
        "+Infinity",
        "1e309",
        "0x1",
        "1.2.3",
        "1e",
        "e1",
        "1_0",
        "--1",
        ".",
    ] {
        let e = parse_err(&format!("v a {bad} 0 0;"));
        assert_eq!(e.pos.as_ref().map(|p| p.col), Some(5), "{bad}: {e}");
        assert!(e.message.contains("number"), "{bad}: {e}");
    }
    // Finite, but beyond ug::MAX_COORDINATE: the geometry would overflow.
    // With the geometry tools' limits.
    let limits = ParseOptions {
        limits: true,
        ..Default::default()
    };
    for big in ["1e308", "-1.1e40", "4e78"] {
        assert!(parse_opts(&format!("v a 0 {big} 0;"), &ParseOptions::default()).is_ok());
        let e = parse_opts(&format!("v a 0 {big} 0;"), &limits).unwrap_err();
        assert_eq!(e.pos.as_ref().map(|p| p.col), Some(7), "{big}: {e}");
        assert!(
            e.message.contains("y coordinate") && e.message.contains("beyond"),
            "{big}: {e}"
        );
    }
}

#[test]
fn error_format_is_file_line_col() {
    let e = ug::parse(b"v a 0 0 0\n", "<stdin>").unwrap_err();
    assert_eq!(
        e.to_string(),
        "<stdin>:1:10: error: expected ';' to end the vertex statement, found end of file"
    );
    let d = Diagnostic::plain("no position");
    assert_eq!(d.to_string(), "error: no position");
}

#[test]
fn long_offending_text_is_shortened_in_messages() {
    let long = "x".repeat(100);
    let e = parse_err(&format!("v a 0 0 {long};"));
    assert_eq!(
        e.message,
        format!("bad number '{}…' (expected z coordinate)", "x".repeat(40))
    );
}

#[test]
fn parse_errors_of_various_statements() {
    let cases: &[(&str, &str)] = &[
        (
            "i (d);",
            "1:4: error: undefined def 'd' (a def must precede its instances)",
        ),
        (
            "def d; end; i (d 5);",
            "1:18: error: unexpected number '5' in the instance: expected a colour name or a transform flag",
        ),
        (
            "def d; end; a (d) 2 -tx 1 2;",
            "1:27: error: unexpected number '2' in the array: -tx takes 1 number",
        ),
        (
            "def d; end; a (d) 2 7;",
            "1:21: error: unexpected number '7' in the array: expected a transform flag",
        ),
        (
            "def d; end; a (d) 2 -tx 1\nv a 0 0 0;",
            "1:26: error: expected ';' to end the array statement, found 'v'",
        ),
        (
            "def d; end; a (d) 2 -tx 1)",
            "1:26: error: unbalanced ')': no '(' is open",
        ),
        (
            "def d; end; i (d -ra 1 2 3 4 5);",
            "1:30: error: unexpected number '5' in the instance: -ra takes 4 numbers",
        ),
        (
            "v a 0 0 0 1;",
            "1:11: error: unexpected number '1' in vertex statement",
        ),
        (
            "f;",
            "1:2: error: expected '(' to start a contour of the face, found ';'",
        ),
        (
            "include;",
            "1:8: error: expected a file name after 'include', found ';'",
        ),
        (
            "defmat m; (x) end;",
            "1:11: error: expected a material property or 'end', found '('",
        ),
        (
            "defmat m; specular 1 (2); end;",
            "1:21: error: expected ';' to end the material property statement, found '('",
        ),
        (
            "c_rgb r 1 1 1 extra;",
            "1:14: error: expected ';' to end the c_rgb statement, found 'extra'",
        ),
        (
            "c x 0.5 1 2 3 4;",
            "1:14: error: expected ';' to end the c statement, found '4'",
        ),
        (
            "def d;\nv a 0 0 0;\n",
            "2:11: error: end of file inside 'def d' (opened at t.ug:1:5): missing 'end;'",
        ),
        (
            "w (a b;",
            "1:3: error: unbalanced '(': the wire contour is not closed before ';'",
        ),
        (
            "v a 0 0 0; w (a\n",
            "1:14: error: unbalanced '(': the wire contour is not closed before end of file",
        ),
        (
            "cam c (1 2",
            "1:7: error: unbalanced '(': the cam statement is not closed before end of file",
        ),
        ("l x 1 2)", "1:8: error: unbalanced ')': no '(' is open"),
        (
            "v é 0 0 0;",
            "1:3: error: invalid vertex name 'é': names are printable ASCII",
        ),
        (
            "c_rgb é 0 0 0;",
            "1:7: error: invalid material name 'é': names are printable ASCII",
        ),
        (
            "def d; end; i é (d);",
            "1:15: error: invalid instance name 'é'",
        ),
        (
            "defmat m; emission_rgb -1 0 0; end;",
            "1:24: error: negative emission_rgb red '-1': emission_rgb must not be negative",
        ),
    ];
    for (src, want) in cases {
        let e = parse_err(src);
        assert_eq!(e.to_string(), format!("t.ug:{want}"), "source: {src:?}");
    }
}

#[test]
fn diffuse_may_be_negative_or_above_one_as_written() {
    // Only emission is checked; reflectances are kept as written.
    let m = parse("defmat m; diffuse_rgb -1 2 0.5; end; c_rgb n 2 -1 0;");
    assert_eq!(m.materials[0].diffuse(), [-1.0, 2.0, 0.5]);
    assert_eq!(m.materials[1].diffuse(), [2.0, -1.0, 0.0]);
}

#[test]
fn material_by_name_and_bounds() {
    let m =
        parse("c_rgb a 1 1 1; c_rgb b 0 0 0; v p -1 2 3; v q 4 -5 6; def d; v r 100 100 100; end;");
    assert_eq!(m.material_by_name("b"), Some(MaterialId(1)));
    assert_eq!(m.material_by_name("c"), None);
    assert_eq!(
        m.bounds(),
        Some((DVec3::new(-1.0, -5.0, 3.0), DVec3::new(4.0, 2.0, 6.0)))
    );
    assert_eq!(Model::new().bounds(), None);
}
