//! Instance flattening: transform maths per flag, arrays, nesting, mirrors,
//! colours, derived names and limits.

mod common;

use std::time::{Duration, Instant};

use common::parse;
use common::*;
use glam::DVec3;
use ug::*;

const EPS: f64 = 1e-12;

/// The position of `p = (1, 2, 3)` in a def after `i x (d FLAGS);` is flattened.
fn moved(flags: &str) -> DVec3 {
    moved_point(flags, DVec3::new(1.0, 2.0, 3.0))
}

fn moved_point(flags: &str, p: DVec3) -> DVec3 {
    let src = format!("def d; v p {} {} {}; end; i x (d {flags});", p.x, p.y, p.z);
    let m = parse(&src).flatten().unwrap();
    assert!(m.is_flat());
    vertex(&m, "x.p").pos
}

#[test]
fn each_transform_flag_moves_points_as_documented() {
    let s2 = std::f64::consts::SQRT_2;
    let cases: &[(&str, DVec3)] = &[
        ("", DVec3::new(1.0, 2.0, 3.0)),
        ("-sx 2", DVec3::new(2.0, 2.0, 3.0)),
        ("-sy 2", DVec3::new(1.0, 4.0, 3.0)),
        ("-sz -2", DVec3::new(1.0, 2.0, -6.0)),
        ("-sa 2", DVec3::new(2.0, 4.0, 6.0)),
        ("-sv 2 3 4", DVec3::new(2.0, 6.0, 12.0)),
        ("-tx 10", DVec3::new(11.0, 2.0, 3.0)),
        ("-ty 10", DVec3::new(1.0, 12.0, 3.0)),
        ("-tz 10", DVec3::new(1.0, 2.0, 13.0)),
        ("-ta 10 20 30", DVec3::new(11.0, 22.0, 33.0)),
        // Right-handed rotations in degrees.
        ("-rx 90", DVec3::new(1.0, -3.0, 2.0)),
        ("-ry 90", DVec3::new(3.0, 2.0, -1.0)),
        ("-rz 90", DVec3::new(-2.0, 1.0, 3.0)),
        ("-rz -90", DVec3::new(2.0, -1.0, 3.0)),
        ("-rz 180", DVec3::new(-1.0, -2.0, 3.0)),
        ("-rz 450", DVec3::new(-2.0, 1.0, 3.0)),
        ("-rz 45", DVec3::new(-1.0 / s2, 3.0 / s2, 3.0)),
        // -ra: axis (normalised) and angle.
        ("-ra 0 0 5 90", DVec3::new(-2.0, 1.0, 3.0)),
        ("-ra 1 0 0 90", DVec3::new(1.0, -3.0, 2.0)),
        ("-ra 1 1 1 120", DVec3::new(3.0, 1.0, 2.0)),
        ("-ra 0 0 0 90", DVec3::new(1.0, 2.0, 3.0)),
        // -rv: the vector's direction is the axis, its length the angle in degrees.
        ("-rv 0 0 90", DVec3::new(-2.0, 1.0, 3.0)),
        ("-rv 0 0 -90", DVec3::new(2.0, -1.0, 3.0)),
        ("-rv 90 0 0", DVec3::new(1.0, -3.0, 2.0)),
        ("-rv 0 180 0", DVec3::new(-1.0, 2.0, -3.0)),
        ("-rv 0 0 0", DVec3::new(1.0, 2.0, 3.0)),
        // Mirrors.
        ("-mx", DVec3::new(-1.0, 2.0, 3.0)),
        ("-my", DVec3::new(1.0, -2.0, 3.0)),
        ("-mz", DVec3::new(1.0, 2.0, -3.0)),
        ("-ma", DVec3::new(-1.0, -2.0, -3.0)),
        ("-mv 1 0 0", DVec3::new(-1.0, 2.0, 3.0)),
        ("-mv 0 0 -7", DVec3::new(1.0, 2.0, -3.0)),
        // Plane through the origin with normal (1, 1, 0): p - 2 (p·n) n / (n·n).
        ("-mv 1 1 0", DVec3::new(-2.0, -1.0, 3.0)),
        ("-mv 0 0 0", DVec3::new(1.0, 2.0, 3.0)),
        // Matrices are row-major; -M4's fourth column is the translation.
        ("-M3 0 1 0  1 0 0  0 0 2", DVec3::new(2.0, 1.0, 6.0)),
        ("-M3 1 2 3  4 5 6  7 8 9", DVec3::new(14.0, 32.0, 50.0)),
        (
            "-M4 1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1",
            DVec3::new(6.0, 8.0, 10.0),
        ),
        (
            "-M4 1 2 3 4  5 6 7 8  9 10 11 12  0 0 0 1",
            DVec3::new(18.0, 46.0, 74.0),
        ),
        // A homogeneous w divides the whole matrix.
        (
            "-M4 2 0 0 4  0 2 0 0  0 0 2 0  0 0 0 2",
            DVec3::new(3.0, 2.0, 3.0),
        ),
        // Flags apply left to right.
        ("-tx 1 -sx 2", DVec3::new(4.0, 2.0, 3.0)),
        ("-sx 2 -tx 1", DVec3::new(3.0, 2.0, 3.0)),
        ("-rz 90 -tx 1", DVec3::new(-1.0, 1.0, 3.0)),
        ("-tx 1 -rz 90", DVec3::new(-2.0, 2.0, 3.0)),
        ("-mx -rz 90", DVec3::new(-2.0, -1.0, 3.0)),
        ("-rz 90 -mx", DVec3::new(2.0, 1.0, 3.0)),
    ];
    for (flags, want) in cases {
        let got = moved(flags);
        assert!(
            (got - *want).abs().max_element() <= EPS,
            "{flags}: got {got:?}, want {want:?}"
        );
    }
}

#[test]
fn quarter_turns_are_exact() {
    // Multiples of 90° give exact results, so grid points stay on the grid.
    for flags in [
        "-rz 90",
        "-rx 270",
        "-ry -90",
        "-ra 0 1 0 180",
        "-rv 0 0 90",
    ] {
        let p = moved(flags);
        for c in p.to_array() {
            assert_eq!(c, c.round(), "{flags}: {p:?}");
        }
    }
}

#[test]
fn transform_matrix_matches_flattening() {
    let ts = parse("def d; end; i (d -sx 2 -rz 30 -ta 1 2 3 -mv 1 2 3);").instances[0]
        .transforms
        .clone();
    let a = transform_matrix(&ts);
    let p = DVec3::new(0.5, -0.25, 2.0);
    assert_close(
        a.transform_point3(p),
        moved_point("-sx 2 -rz 30 -ta 1 2 3 -mv 1 2 3", p),
        EPS,
    );
    assert_eq!(transform_matrix(&[]), glam::DAffine3::IDENTITY);
}

#[test]
fn arrays_make_count_copies_with_cumulative_steps() {
    let m = parse("def d; v p 1 0 0; end;\na row (d -tx 10) 4 -ty 1;\na rot (d) 3 -rz 90 -tz 1;")
        .flatten()
        .unwrap();
    for k in 0..4 {
        assert_close(
            vertex(&m, &format!("row.{k}.p")).pos,
            DVec3::new(11.0, k as f64, 0.0),
            EPS,
        );
    }
    assert!(m.vertices.iter().all(|v| v.name != "row.4.p"));
    // Copy k is the instance transform followed by the step k times.
    assert_close(vertex(&m, "rot.0.p").pos, DVec3::new(1.0, 0.0, 0.0), EPS);
    assert_close(vertex(&m, "rot.1.p").pos, DVec3::new(0.0, 1.0, 1.0), EPS);
    assert_close(vertex(&m, "rot.2.p").pos, DVec3::new(-1.0, 0.0, 2.0), EPS);
    assert_eq!(m.vertices.len(), 7);
}

#[test]
fn array_step_follows_the_instance_transform() {
    // Copy 1 = -sx 2 (instance) then -tx 1 (step): (1*2) + 1.
    let m = parse("def d; v p 1 0 0; end; a r (d -sx 2) 3 -tx 1;")
        .flatten()
        .unwrap();
    assert_close(vertex(&m, "r.1.p").pos, DVec3::new(3.0, 0.0, 0.0), EPS);
    assert_close(vertex(&m, "r.2.p").pos, DVec3::new(4.0, 0.0, 0.0), EPS);
    // Scaling steps compound too.
    let m = parse("def d; v p 1 0 0; end; a r (d) 4 -sa 2;")
        .flatten()
        .unwrap();
    assert_close(vertex(&m, "r.3.p").pos, DVec3::new(8.0, 0.0, 0.0), EPS);
}

#[test]
fn an_empty_array_creates_nothing() {
    let m = parse("def d; v p 1 0 0; end; a r (d) 0 -tx 1; v q 0 0 0;")
        .flatten()
        .unwrap();
    let names: Vec<&str> = m.vertices.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["q"]);
}

#[test]
fn nested_instances_compose_inner_first() {
    let m = parse(
        "def inner; v p 1 0 0; end;\n\
         def outer; i in (inner -tx 1); a arr (inner) 2 -ty 1; end;\n\
         i out (outer -sx 2 -tz 5);",
    )
    .flatten()
    .unwrap();
    // Inner transform first, then the outer one: ((1 + 1) * 2, 0, 5).
    assert_close(vertex(&m, "out.in.p").pos, DVec3::new(4.0, 0.0, 5.0), EPS);
    assert_close(
        vertex(&m, "out.arr.0.p").pos,
        DVec3::new(2.0, 0.0, 5.0),
        EPS,
    );
    assert_close(
        vertex(&m, "out.arr.1.p").pos,
        DVec3::new(2.0, 1.0, 5.0),
        EPS,
    );
    assert!(m.defs.is_empty() && m.instances.is_empty());
}

/// A def with one triangle facing `normal`'s side, instanced with `flags`.
fn flattened_face_normal(flags: &str) -> (Model, DVec3) {
    // Counter-clockwise seen from +z, at z = 1: its front (Newell normal) is +z.
    let src =
        format!("def d; v a 0 0 1; v b 1 0 1; v c 0 1 1; f t (a b c); end;\ni x (d {flags});");
    let m = parse(&src).flatten().unwrap();
    let n = newell(&outer(&m, FaceId(0)));
    (m, n)
}

#[test]
fn mirrors_reverse_contours_so_the_front_faces_the_mirrored_side() {
    // Unmirrored: +z.
    let (_, n) = flattened_face_normal("");
    assert!(n.normalize().abs_diff_eq(DVec3::Z, EPS), "{n:?}");
    for (flags, want) in [
        ("-mz", -DVec3::Z),
        ("-ma", -DVec3::Z),
        ("-sz -1", -DVec3::Z),
        ("-mv 0 0 1", -DVec3::Z),
        ("-mx", DVec3::Z),
        ("-my", DVec3::Z),
        ("-M3 1 0 0 0 1 0 0 0 -3", -DVec3::Z),
        ("-mv 0 1 1", -DVec3::Y),
        ("-rx 90 -mz", -DVec3::Y),
        ("-rx 90 -my", DVec3::Y),
    ] {
        let (m, n) = flattened_face_normal(flags);
        // The mirrored geometry's front is the mirror image of the original front.
        assert!(
            n.normalize().abs_diff_eq(want, EPS),
            "{flags}: normal {n:?}, want {want:?}"
        );
        // Every vertex of the triangle sits on the mirrored side too.
        let c = outer(&m, FaceId(0)).iter().sum::<DVec3>() / 3.0;
        assert!(c.dot(want) > 0.0, "{flags}: centroid {c:?}");
        // The first vertex of the contour is kept.
        assert_eq!(m.vertices[m.faces[0].contours[0][0].idx()].name, "x.a");
    }
    // Two mirrors make a rotation: no reversal.
    let (m, n) = flattened_face_normal("-mx -my");
    assert!(n.normalize().abs_diff_eq(DVec3::Z, EPS), "{n:?}");
    let names: Vec<&str> = m.faces[0].contours[0]
        .iter()
        .map(|v| m.vertices[v.idx()].name.as_str())
        .collect();
    assert_eq!(names, ["x.a", "x.b", "x.c"]);
}

#[test]
fn mirrors_reverse_holes_and_nested_mirrors_cancel() {
    let src = "def d;\n\
                 v a 0 0 0; v b 4 0 0; v c 4 4 0; v e 0 4 0;\n\
                 v h1 1 1 0; v h2 1 2 0; v h3 2 2 0; v h4 2 1 0;\n\
                 f (a b c e) (h1 h2 h3 h4);\n\
               end;\n\
               def m; i (d -mx); end;\n\
               i one (d -mx);\n\
               i two (m -my);\n";
    let m = parse(src).flatten().unwrap();
    let outer_n = |f: usize, c: usize| {
        newell(
            &m.faces[f].contours[c]
                .iter()
                .map(|&v| m.pos(v))
                .collect::<Vec<_>>(),
        )
    };
    // One mirror: the outer contour now faces +z again after reversal
    // (a mirror in x turns +z faces into +z faces with reversed winding, which the
    // reversal undoes), and the hole keeps facing opposite to the outer contour.
    assert!(outer_n(0, 0).z > 0.0);
    assert!(outer_n(0, 1).z < 0.0);
    // Two nested mirrors: a rotation, nothing reversed.
    let names: Vec<&str> = m.faces[1].contours[0]
        .iter()
        .map(|v| m.vertices[v.idx()].name.as_str())
        .collect();
    assert_eq!(names, ["two.d1.a", "two.d1.b", "two.d1.c", "two.d1.e"]);
    assert!(outer_n(1, 0).z > 0.0);
    assert!(outer_n(1, 1).z < 0.0);
}

#[test]
fn instance_colour_applies_to_faces_and_wires_without_one() {
    let m = parse(
        "c_rgb red 1 0 0; c_rgb blue 0 0 1; c_rgb own 0 1 0;\n\
         def d;\n\
           v a 0 0 0 own; v b 1 0 0; v c 0 1 0;\n\
           f plain (a b c); f coloured (a b c) own;\n\
           w (a b); w (b c) own;\n\
         end;\n\
         def outer; i inner (d blue); i bare (d); end;\n\
         i x (d red);\n\
         i y (d);\n\
         i z (outer red);\n",
    )
    .flatten()
    .unwrap();
    let face = |name: &str| {
        m.faces
            .iter()
            .find(|f| f.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no face {name}"))
            .material
            .map(|id| m.material(id).name.as_str())
    };
    assert_eq!(face("x.plain"), Some("red"));
    assert_eq!(face("x.coloured"), Some("own"));
    assert_eq!(face("y.plain"), None);
    assert_eq!(face("y.coloured"), Some("own"));
    // The nearest instance's colour wins; an uncoloured inner instance takes the outer one.
    assert_eq!(face("z.inner.plain"), Some("blue"));
    assert_eq!(face("z.bare.plain"), Some("red"));
    let wire_mats: Vec<Option<&str>> = m
        .wires
        .iter()
        .take(2)
        .map(|w| w.material.map(|id| m.material(id).name.as_str()))
        .collect();
    assert_eq!(wire_mats, [Some("red"), Some("own")]);
    // Vertex colours are not replaced.
    assert_eq!(vertex(&m, "x.b").color, None);
    assert_eq!(vertex(&m, "x.a").color, m.material_by_name("own"));
    assert_round_trip(&m);
}

#[test]
fn derived_names_are_unique_and_never_collide() {
    let m = parse(
        "v x.p 0 0 0; v box1.p 0 0 0; v a 0 0 0; v b 1 0 0; v c 0 1 0;\n\
         f x.t (a b c); w box1.t (a b);\n\
         def box; v p 1 1 1; v q 2 1 1; v r 1 2 1; f t (p q r); w (p q); end;\n\
         i x (box);\n\
         i (box);\n\
         i (box);\n\
         a arr (box) 2;\n\
         i arr.0 (box);\n",
    )
    .flatten()
    .unwrap();
    let names: Vec<&str> = m.vertices.iter().map(|v| v.name.as_str()).collect();
    // Existing names are kept as they are.
    assert_eq!(&names[..5], ["x.p", "box1.p", "a", "b", "c"]);
    let mut sorted = names.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(
        sorted.len(),
        names.len(),
        "duplicate vertex names: {names:?}"
    );
    for expect in [
        "x.p.2",
        "box1.p.2",
        "box2.p",
        "arr.0.p",
        "arr.1.p",
        "arr.0.p.2",
        "x.q",
    ] {
        assert!(names.contains(&expect), "{expect} missing from {names:?}");
    }
    let fnames: Vec<&str> = m
        .faces
        .iter()
        .filter_map(|f| f.name.as_deref())
        .chain(m.wires.iter().filter_map(|w| w.name.as_deref()))
        .collect();
    let mut fs = fnames.clone();
    fs.sort();
    fs.dedup();
    assert_eq!(
        fs.len(),
        fnames.len(),
        "duplicate face/wire names: {fnames:?}"
    );
    assert!(
        fnames.contains(&"x.t.2") && fnames.contains(&"box1.t.2"),
        "{fnames:?}"
    );
    // The result is a valid model: it writes and reads back.
    assert_round_trip(&m);
}

#[test]
fn materials_inside_defs_are_kept_and_comments_lights_cameras_dropped() {
    let m = parse(
        "{top}\nl sun 1;\n\
         def d;\n\
           {inside} l lamp 1; cam c 1; (esc) frob 1;\n\
           c_rgb wood 1 0 0;\n\
           def e; c lgt 0.5; v p 0 0 0; end;\n\
           v a 0 0 0; v b 1 0 0; v c 0 1 0; f (a b c) wood;\n\
           i (e);\n\
         end;\n\
         i (d); i (d);\ncam top 1;",
    );
    let p = parsed("def d; frob; end;");
    assert_eq!(p.warnings.len(), 1);
    let flat = m.flatten().unwrap();
    let kinds: Vec<String> = flat
        .items
        .iter()
        .map(|it| match it {
            Item::Comment(c) => format!("comment {c}"),
            Item::Light(r) => format!("l {}", r.text),
            Item::Camera(r) => format!("cam {}", r.text),
            Item::Material(id) => format!("material {}", flat.material(*id).name),
            Item::Vertex(v) => format!("v {}", flat.vertex(*v).name),
            Item::Face(_) => "f".into(),
            other => format!("{other:?}"),
        })
        .collect();
    assert_eq!(
        kinds,
        [
            "comment top",
            "l sun 1",
            "material wood",
            "material lgt",
            "v d1.a",
            "v d1.b",
            "v d1.c",
            "f",
            "v d1.e1.p",
            "v d2.a",
            "v d2.b",
            "v d2.c",
            "f",
            "v d2.e2.p",
            "cam top 1",
        ]
    );
    assert_round_trip(&flat);
}

#[test]
fn a_flat_model_flattens_to_itself() {
    let m = parse("c_rgb r 1 0 0; v a 0 0 0 r; {c} l x;");
    assert_eq!(m.flatten().unwrap(), m);
}

#[test]
fn an_array_bomb_is_refused_quickly_without_allocating_it() {
    // 1000 x 1000 x 1000 copies of a vertex: refused before creating any.
    let src = "def a; v p 0 0 0; end;\n\
               def b; a (a) 1000 -tx 1; end;\n\
               def c; a (b) 1000 -ty 1; end;\n\
               a (c) 1000 -tz 1;\n";
    let m = parse(src);
    let t = Instant::now();
    let e = m.flatten().unwrap_err();
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "took {:?}",
        t.elapsed()
    );
    assert_eq!(
        e.to_string(),
        "error: flattening would create 1000000000 vertices and 0 faces, more than the limit of 50000000 vertices or 50000000 faces; the instances or arrays are too large"
    );
    // Small limits apply the same way.
    let limits = FlattenLimits {
        max_vertices: 999,
        max_faces: 10,
    };
    let e = parse("def a; v p 0 0 0; end; a (a) 1000;")
        .flatten_with(limits)
        .unwrap_err();
    assert!(e.message.contains("1000 vertices"), "{e}");
    let ok = parse("def a; v p 0 0 0; end; a (a) 999;")
        .flatten_with(limits)
        .unwrap();
    assert_eq!(ok.vertices.len(), 999);
    // Faces have their own limit.
    let e = parse("def a; v p 0 0 0; v q 1 0 0; v r 0 1 0; f (p q r); end; a (a) 11;")
        .flatten_with(FlattenLimits {
            max_vertices: 1000,
            max_faces: 10,
        })
        .unwrap_err();
    assert!(e.message.contains("33 vertices and 11 faces"), "{e}");
}

#[test]
fn counts_that_overflow_are_refused() {
    let mut src = String::from("def d0; v p 0 0 0; end;\n");
    for k in 1..8 {
        src.push_str(&format!("def d{k}; a (d{}) 4294967295; end;\n", k - 1));
    }
    src.push_str("i (d7);\n");
    let e = parse(&src).flatten().unwrap_err();
    assert!(e.message.contains("too many vertices"), "{e}");
}

#[test]
fn huge_arrays_of_empty_defs_take_no_time() {
    let m = parse(
        "def empty; {nothing} l x 1; end; def e2; a (empty) 4000000000; end; a (e2) 4000000000; v a 0 0 0;",
    );
    let t = Instant::now();
    let flat = m.flatten().unwrap();
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "took {:?}",
        t.elapsed()
    );
    assert_eq!(flat.vertices.len(), 1);
}

#[test]
fn transforms_that_overflow_are_an_error() {
    let e = parse("def d; v p 1 1 1; end; i (d -sa 1e200 -sa 1e200);")
        .flatten()
        .unwrap_err();
    assert!(e.message.contains("non-finite"), "{e}");
    let e = parse("def d; v p 1 1 1; end; i (d -M4 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1e-320);")
        .flatten()
        .unwrap_err();
    assert!(e.message.contains("non-finite"), "{e}");
}

#[test]
fn instances_nest_at_most_100_deep() {
    let chain = |n: usize| {
        let mut s = String::from("def d0; v p 0 0 0; end;\n");
        for k in 1..n {
            s.push_str(&format!("def d{k}; i (d{} -tx 1); end;\n", k - 1));
        }
        s.push_str(&format!("i top (d{});\n", n - 1));
        s
    };
    let m = parse(&chain(100)).flatten().unwrap();
    assert_eq!(m.vertices.len(), 1);
    assert_eq!(m.vertices[0].pos.x, 99.0);
    let e = parse(&chain(101)).flatten().unwrap_err();
    assert!(e.message.contains("nested more than 100 deep"), "{e}");
}

#[test]
fn a_self_instantiating_def_built_in_code_is_an_error_not_a_hang() {
    let mut m = parse("def d; v p 0 0 0; end; def e; i (d); end; i (e);");
    // Point d's body at e (d now instantiates e, which instantiates d).
    let inst = InstanceId(m.instances.len() as u32);
    m.instances.push(Instance {
        name: None,
        def: DefId(1),
        color: None,
        transforms: vec![],
        array: None,
    });
    m.defs[0].items.push(Item::Instance(inst));
    let e = m.flatten().unwrap_err();
    assert!(e.message.contains("instantiates itself"), "{e}");
}
