use super::*;
use proptest::prelude::*;

fn conv(src: &[u8]) -> Result<Converted, PlyError> {
    convert(src, "t.ply", &Options::default())
}

fn ug_text(c: &Converted) -> String {
    ug::write_string(&c.model)
}

fn err(src: &[u8]) -> String {
    conv(src).unwrap_err().to_string()
}

const LIT: &str = "ply\nformat ascii 1.0\ncomment lit\nelement vertex 4\n\
    property double x\nproperty double y\nproperty double z\n\
    property float radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n\
    property uchar red\nproperty uchar green\nproperty uchar blue\n\
    element face 1\nproperty list uchar int vertex_indices\nend_header\n\
    0 0 0 3.141592653589793 3.141592653589793 3.141592653589793 255 255 255\n\
    1 0 0 0.5 0.25 0.125 150 111 79\n\
    1 1 0 0.5 0.25 0.125 150 111 79\n\
    0 1 0 0 0 0 0 0 0\n\
    4 0 1 2 3\n";

#[test]
fn ascii_lit_square_gives_rad_colours() {
    let c = conv(LIT.as_bytes()).unwrap();
    assert!(c.lit);
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    assert_eq!(
        ug_text(&c),
        "c_rgb _rad0 3.141592653589793 3.141592653589793 3.141592653589793;\n\
         c_rgb _rad1 0.5 0.25 0.125;\nc_rgb _rad2 0 0 0;\n\
         v v1 0 0 0 _rad0;\nv v2 1 0 0 _rad1;\nv v3 1 1 0 _rad1;\nv v4 0 1 0 _rad2;\n\
         f (v1 v2 v3 v4);\n"
    );
}

/// A binary PLY: header text, then the body built by `body`.
fn binary(big: bool, header: &str, body: impl FnOnce(&mut dyn FnMut(&[u8]))) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_{}_endian 1.0\n{header}end_header\n",
        if big { "big" } else { "little" }
    )
    .into_bytes();
    let mut push = |b: &[u8]| {
        let mut b = b.to_vec();
        if big {
            b.reverse();
        }
        out.extend_from_slice(&b);
    };
    body(&mut push);
    out
}

#[test]
fn binary_floats_are_their_shortest_decimals_in_both_byte_orders() {
    let header = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                  property float radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n\
                  element face 1\nproperty list uchar uint vertex_indices\n";
    for big in [false, true] {
        let bytes = binary(big, header, |p| {
            for (x, y) in [(0.0f32, 0.0f32), (0.1, 0.0), (0.0, 0.7)] {
                for c in [x, y, 0.0, 0.8, 0.1, 1e-3] {
                    p(&c.to_le_bytes());
                }
            }
            p(&[3]);
            for i in 0u32..3 {
                p(&i.to_le_bytes());
            }
        });
        let c = conv(&bytes).unwrap();
        assert_eq!(
            ug_text(&c),
            "c_rgb _rad0 0.8 0.1 0.001;\nv v1 0 0 0 _rad0;\nv v2 0.1 0 0 _rad0;\nv v3 0 0.7 0 _rad0;\n\
             f (v1 v2 v3);\n",
            "big endian: {big}"
        );
    }
    assert_eq!(f32_value(0.8), 0.8);
    assert_eq!(f32_value(f32::INFINITY), f64::INFINITY);
}

#[test]
fn unlit_display_colours_become_face_materials() {
    let src = "ply\nformat ascii 1.0\nelement vertex 5\n\
        property float x\nproperty float y\nproperty float z\n\
        property uchar red\nproperty uchar green\nproperty uchar blue\n\
        element face 3\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 255 0 0\n1 0 0 255 0 0\n0 1 0 255 0 0\n1 1 0 0 0 255\n2 2 0 188 188 188\n\
        3 0 1 2\n3 1 3 2\n3 0 1 4\n";
    let c = conv(src.as_bytes()).unwrap();
    let t = ug_text(&c);
    assert!(
        t.starts_with("c_rgb rgb_ff0000 1 0 0;\nv v1 0 0 0;\n"),
        "{t}"
    );
    assert!(
        t.ends_with("f (v1 v2 v3) rgb_ff0000;\nf (v2 v4 v3);\nf (v1 v2 v5);\n"),
        "{t}"
    );
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    assert!(c.warnings[0].contains("2 faces have vertices of different colours"));
    // sRGB 188 is linear 0.5 to 8 bits.
    assert!((srgb_decode(188.0 / 255.0) - 0.5).abs() < 3e-3);
    let ignored = convert(
        src.as_bytes(),
        "t.ply",
        &Options {
            ignore_colours: true,
        },
    )
    .unwrap();
    assert!(ignored.model.materials.is_empty());
    assert!(ignored.warnings.is_empty());
}

#[test]
fn face_colours_float_colours_and_other_elements() {
    let src = "ply\nformat ascii 1.0\nobj_info x\nelement camera 1\nproperty float view_px\n\
        element vertex 3\nproperty double z\nproperty double y\nproperty double x\n\
        property float red\nproperty float green\nproperty float blue\nproperty list int int extra\n\
        element face 2\nproperty list int uint vertex_index\nproperty uchar red\nproperty uchar green\n\
        property uchar blue\nelement edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
        \n7.5\n0 0 0 1 1 1 2 5 6\n0 0 1 1 1 1 0\n\n0 1 0 0.5 1 1 1 9\n\
        3 0 1 2 0 255 0\n3 2 1 0 0 255 0\n0 1\nend 1\n";
    let c = conv(src.as_bytes()).unwrap();
    let t = ug_text(&c);
    assert_eq!(
        t,
        "c_rgb rgb_00ff00 0 1 0;\nv v1 0 0 0;\nv v2 1 0 0;\nv v3 0 1 0;\n\
         f (v1 v2 v3) rgb_00ff00;\nf (v3 v2 v1) rgb_00ff00;\n"
    );
    // The trailing `end 1` line is data after the last element.
    assert_eq!(c.warnings.len(), 1, "{:?}", c.warnings);
    assert!(
        c.warnings[0].starts_with("t.ply:32:1: warning: data after"),
        "{:?}",
        c.warnings
    );
}

#[test]
fn degenerate_faces_and_unused_vertices() {
    let src = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
        property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\n1 0 0\n0 1 0\n1 1 0\n5 5 5\n\
        3 0 1 1\n4 0 1 2 0\n4 0 1 0 2\n4 3 1 1 2\n";
    let c = conv(src.as_bytes()).unwrap();
    assert_eq!(c.model.faces.len(), 2);
    assert_eq!(c.dropped, 2);
    assert_eq!(c.unused, 1);
    assert!(
        c.warnings[0].starts_with("t.ply:15:1: warning: face with fewer than 3"),
        "{:?}",
        c.warnings
    );
    assert!(
        c.warnings
            .iter()
            .any(|w| w.starts_with("t.ply:16:1: warning: face: consecutive")),
        "{:?}",
        c.warnings
    );
}

#[test]
fn header_and_ascii_errors_have_positions() {
    let h = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    assert_eq!(
        err(b"PLY\n"),
        "t.ply:1:1: error: not a PLY file (the first line must be 'ply')"
    );
    assert_eq!(
        err(b""),
        "t.ply:1:1: error: empty file (expected a PLY header)"
    );
    assert_eq!(
        err(b"ply\nformat ascii 1.0\n"),
        "t.ply:3:1: error: the header has no 'end_header' line"
    );
    assert_eq!(
        err(b"ply\nformat binary 1.0\n"),
        "t.ply:2:8: error: unknown format 'binary' (expected ascii, binary_little_endian or binary_big_endian)"
    );
    assert_eq!(
        err(b"ply\nformat ascii 1.0\nelement vertex x\n"),
        "t.ply:3:16: error: bad element count 'x'"
    );
    assert_eq!(
        err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float32 x\nproperty real y\n"),
        "t.ply:5:10: error: unknown property type 'real'"
    );
    assert_eq!(
        err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n"),
        "t.ply:3:1: error: element 'vertex' has no property 'y'"
    );
    assert_eq!(
        err(b"ply\nformat ascii 1.0\nelement face 0\nend_header\n"),
        "t.ply:4:1: error: the header has no 'vertex' element"
    );
    assert_eq!(
        err(b"ply\nformat ascii 1.0\nproperty float x\n"),
        "t.ply:3:1: error: 'property' before any 'element'"
    );
    assert_eq!(
        err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float radiosity_r\nend_header\n"),
        "t.ply:3:1: error: element 'vertex' has some of radiosity_r/radiosity_g/radiosity_b but no 'radiosity_g'"
    );
    let e = |body: &str| err(format!("{h}{body}").as_bytes());
    assert_eq!(
        e("0 0 0\n1 1 1\n3 0 1 2\n"),
        "t.ply:12:7: error: vertex index 2 is out of range (2 vertices)"
    );
    assert_eq!(
        e("0 0 0\n1 1 1\n3 0 -1 1\n"),
        "t.ply:12:5: error: vertex index -1 is out of range (2 vertices)"
    );
    assert_eq!(
        e("0 0 0\n1 x 1\n3 0 1 1\n"),
        "t.ply:11:3: error: bad number 'x' (property 'y' of element 'vertex')"
    );
    assert_eq!(
        e("0 0 0\n1 1\n"),
        "t.ply:11:4: error: missing value for property 'z' of element 'vertex'"
    );
    assert_eq!(
        e("0 0 0 0\n"),
        "t.ply:10:7: error: unexpected '0' after the values of element 'vertex' (one per line)"
    );
    assert_eq!(
        e("0 0 0\n1 1 1\n"),
        "t.ply:12:1: error: the data ends in element 'face' (0 of 1 read)"
    );
    assert_eq!(
        e("0 0 0\n1 1 nan\n"),
        "t.ply:11:5: error: non-finite coordinate in element 'vertex'"
    );
    assert_eq!(
        e("0 0 0\n1 1 1\n3.0 0 1 1\n"),
        "t.ply:12:1: error: bad uchar '3.0' (property 'vertex_indices' of element 'face')"
    );
}

#[test]
fn binary_errors_give_byte_offsets() {
    let header = "element vertex 1\nproperty double x\nproperty double y\nproperty double z\n\
                  element face 1\nproperty list uchar int vertex_indices\n";
    let bytes = binary(false, header, |p| {
        for c in [0.0f64, 1.0] {
            p(&c.to_le_bytes());
        }
    });
    let start = bytes.len() - 16;
    assert_eq!(
        err(&bytes),
        format!(
            "t.ply:byte {}: error: truncated data: it ends in property 'z' of element 'vertex' 1 of 1",
            start + 16
        )
    );
    let bytes = binary(false, header, |p| {
        for c in [0.0f64, 1.0, 2.0] {
            p(&c.to_le_bytes());
        }
        p(&[200]);
        p(&0i32.to_le_bytes());
    });
    let at = bytes.len() - 4;
    assert_eq!(
        err(&bytes),
        format!(
            "t.ply:byte {at}: error: truncated data: it ends in property 'vertex_indices' of element 'face' 1 of 1"
        )
    );
    let bytes = binary(false, header, |p| {
        for c in [0.0f64, 1.0, 2.0] {
            p(&c.to_le_bytes());
        }
        p(&[3]);
        for i in [0i32, 0, 7] {
            p(&i.to_le_bytes());
        }
    });
    assert_eq!(
        err(&bytes),
        format!(
            "t.ply:byte {}: error: vertex index 7 is out of range (1 vertices)",
            bytes.len() - 4
        )
    );
}

#[test]
fn round_trips_ug2ply_output() {
    let src = "c_rgb floor 0.8 0.8 0.8;\n\
        c_rgb _rad0 3.141592653589793 3.141592653589793 3.141592653589793;\n\
        c_rgb _rad1 0.1 0.2 0.30000000000000004;\nc_rgb _rad2 0 0 0;\n\
        v a 0 0 0 _rad0;\nv b 1.1 0 0 _rad1;\nv c 1 1 0 _rad1;\nv d 0 1 0.3 _rad2;\n\
        f floor (a b c d) floor;\nf (a d c) floor;\n";
    let m = ug::parse(src.as_bytes(), "<t>").unwrap().model;
    for binary in [false, true] {
        let ply = crate::ply::write::to_ply(
            &m,
            &crate::ply::write::PlyOptions {
                binary,
                ..Default::default()
            },
        );
        let c = conv(&ply.bytes).unwrap();
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        let back = &c.model;
        assert_eq!(back.faces.len(), 2);
        for (f, g) in m.faces.iter().zip(&back.faces) {
            assert_eq!(f.contours[0].len(), g.contours[0].len());
            for (&u, &v) in f.contours[0].iter().zip(&g.contours[0]) {
                assert_eq!(m.pos(u), back.pos(v));
                let cu = m.material(m.vertex(u).color.unwrap()).diffuse();
                let cv = back.material(back.vertex(v).color.unwrap()).diffuse();
                for k in 0..3 {
                    let tol = if binary { 1e-7 * cu[k].abs() } else { 0.0 };
                    assert!((cu[k] - cv[k]).abs() <= tol, "{cu:?} {cv:?}");
                }
            }
        }
    }
    // Unlit: the materials' colours come back to 8 bits.
    let m = ug::parse(
        b"c_rgb red 0.63 0.065 0.05; v a 0 0 0; v b 1 0 0; v c 0 1 0; f (a b c) red;",
        "<t>",
    )
    .unwrap()
    .model;
    let ply = crate::ply::write::to_ply(&m, &Default::default());
    let c = conv(&ply.bytes).unwrap();
    let got = c.model.materials[0].diffuse();
    for (a, b) in got.iter().zip([0.63, 0.065, 0.05]) {
        assert!((a - b).abs() < 0.01 * b + 1e-3, "{got:?}");
    }
}

const HEADERS: [&str; 3] = [
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
     property float radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n\
     element face 3\nproperty list uchar int vertex_indices\nend_header\n",
    "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
     property double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
     element face 3\nproperty list uint int vertex_indices\nelement other 2\n\
     property list int double stuff\nend_header\n",
    "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty short x\nproperty ushort y\n\
     property char z\nelement face 3\nproperty list uchar uchar vertex_indices\n\
     property float red\nproperty float green\nproperty float blue\nend_header\n",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = conv(&bytes);
    }

    #[test]
    fn random_data_after_a_header_never_panics(
        h in 0usize..3,
        body in proptest::collection::vec(any::<u8>(), 0..300),
    ) {
        let mut bytes = HEADERS[h].as_bytes().to_vec();
        bytes.extend_from_slice(&body);
        if let Ok(c) = conv(&bytes) {
            let text = ug::write_string(&c.model);
            prop_assert!(ug::parse(text.as_bytes(), "<out>").is_ok(), "{}", text);
        }
    }

    #[test]
    fn random_ascii_values_never_panic(
        words in proptest::collection::vec(
            prop_oneof![
                Just("0".to_string()), Just("1".to_string()), Just("3".to_string()),
                Just("-1".to_string()), Just("0.5".to_string()), Just("nan".to_string()),
                Just("\n".to_string()), Just("4294967295".to_string()), Just("x".to_string()),
            ], 0..80)
    ) {
        let mut src = HEADERS[0].to_string();
        src.push_str(&words.join(" "));
        if let Ok(c) = conv(src.as_bytes()) {
            let text = ug::write_string(&c.model);
            prop_assert!(ug::parse(text.as_bytes(), "<out>").is_ok(), "{}", text);
        }
    }

    #[test]
    fn mangled_headers_never_panic(cut in 0usize..400, byte in any::<u8>()) {
        let mut bytes = HEADERS[1].as_bytes().to_vec();
        let k = cut % bytes.len();
        bytes[k] = byte;
        let _ = conv(&bytes);
    }
}

/// An ASCII integer beyond its type's range is an error at the word (a
/// `uchar` of 300 was read as 300).
#[test]
fn ascii_integers_out_of_their_range_are_errors() {
    let src = |x: &str| {
        format!(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty uchar x\nproperty uchar y\n\
             property char z\nend_header\n{x}\n"
        )
    };
    assert!(conv(src("255 0 -128").as_bytes()).is_ok());
    assert_eq!(
        err(src("300 0 0").as_bytes()),
        "t.ply:8:1: error: uchar '300' out of range 0..=255 (property 'x' of element 'vertex')"
    );
    assert_eq!(
        err(src("0 0 -129").as_bytes()),
        "t.ply:8:5: error: char '-129' out of range -128..=127 (property 'z' of element 'vertex')"
    );
}
