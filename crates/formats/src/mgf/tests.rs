use super::*;
use proptest::prelude::*;

fn conv_files(src: &str, files: &[(&str, &str)], opts: &Options) -> Result<Converted, Diagnostic> {
    let files: Vec<(PathBuf, Vec<u8>)> = files
        .iter()
        .map(|(n, t)| (PathBuf::from(n), t.as_bytes().to_vec()))
        .collect();
    convert_with(src.as_bytes(), "t.mgf", Path::new("d"), opts, &mut |p| {
        files
            .iter()
            .find(|(n, _)| n == p)
            .map(|(_, t)| t.clone())
            .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "not found"))
    })
}

fn conv(src: &str) -> Converted {
    conv_files(src, &[], &Options::default()).unwrap()
}

fn conv_opts(src: &str, opts: &Options) -> Converted {
    conv_files(src, &[], opts).unwrap()
}

fn err(src: &str) -> String {
    conv_files(src, &[], &Options::default())
        .unwrap_err()
        .to_string()
}

const SQUARE: &str = "v a =\np 0 0 0\nv b =\np 1 0 0\nv c =\np 1 1 0\nv d =\np 0 1 0\n";

fn face_points(m: &Model, k: usize) -> Vec<Vec<DVec3>> {
    m.faces[k]
        .contours
        .iter()
        .map(|c| c.iter().map(|&v| m.pos(v)).collect())
        .collect()
}

/// Signed volume enclosed by all faces (positive when they face outward).
fn volume(m: &Model) -> f64 {
    let mut v = 0.0;
    for f in &m.faces {
        for c in &f.contours {
            let p: Vec<DVec3> = c.iter().map(|&x| m.pos(x)).collect();
            for i in 1..p.len() - 1 {
                v += p[0].dot(p[i].cross(p[i + 1])) / 6.0;
            }
        }
    }
    v
}

fn area(m: &Model) -> f64 {
    m.faces
        .iter()
        .map(|f| {
            let cs: Vec<Vec<DVec3>> = f
                .contours
                .iter()
                .map(|c| c.iter().map(|&v| m.pos(v)).collect())
                .collect();
            geom::face_area(&cs)
        })
        .sum()
}

#[test]
fn face_with_coloured_material() {
    let c = conv(&format!(
        "{SQUARE}m red =\n  c\n  cxy .64 .33\n  rd .5\n  c\n  sides 1\no floor\nf a b c d\no\nm\nf a c d\n"
    ));
    let t = ug::write_string(&c.model);
    let mat = &c.model.materials[0];
    assert_eq!(mat.name, "red");
    let d = mat.diffuse();
    assert!(
        d[0] > 0.5 && d[1].abs() < 1e-9 && d[2].abs() < 1e-9,
        "{d:?}"
    );
    assert!(t.contains("v a 0 0 0;\nv b 1 0 0;\nv c 1 1 0;\nv d 0 1 0;\nf floor (a b c d) red;\nf (a c d) default;\n"), "{t}");
    assert!(
        t.contains("defmat default;\n  diffuse_rgb 0 0 0;\n  sides 2;\nend;"),
        "{t}"
    );
}

#[test]
fn neutral_reflectance_and_emission() {
    let c = conv(&format!(
        "{SQUARE}m lamp =\n  rd .25\n  ed 100\nf a b c d\n"
    ));
    let m = &c.model.materials[0];
    assert_eq!(m.diffuse(), [0.25; 3]);
    assert_eq!(m.emission(), [100.0; 3]);
    let c = conv_opts(
        &format!("{SQUARE}m lamp =\n  c\n  cct 3000\n  ed 100\nf a b c d\n"),
        &Options {
            emission_scale: 0.01,
            ..Default::default()
        },
    );
    let e = c.model.materials[0].emission();
    assert!(
        e[0] > e[1] && e[1] > e[2] && e[0] < 2.0,
        "warm light: {e:?}"
    );
}

#[test]
fn material_state_at_use() {
    // Changing a material after use gives a second UG material; earlier faces keep theirs.
    let c = conv(&format!(
        "{SQUARE}m x =\n  rd .5\nf a b c\nrd .7\nf a c d\nm x\nf a b d\n"
    ));
    let names: Vec<&str> = c.model.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["x", "x.2"]);
    assert_eq!(c.model.faces[2].material, c.model.faces[1].material);
}

#[test]
fn seams_become_holes() {
    let src = "v v1 =\np 0 0 0\nv v2 =\np 4 0 0\nv v3 =\np 4 4 0\nv v4 =\np 0 4 0\n\
               v v5 =\np 1 3 0\nv v6 =\np 3 3 0\nv v7 =\np 3 1 0\nv v8 =\np 1 1 0\n\
               f v1 v2 v3 v4 v5 v6 v7 v8 v5 v4\n";
    let c = conv(src);
    let f = &c.model.faces[0];
    assert_eq!(f.contours.len(), 2);
    let names = |k: usize| -> Vec<&str> {
        f.contours[k]
            .iter()
            .map(|&v| c.model.vertex(v).name.as_str())
            .collect()
    };
    assert_eq!(names(0), ["v4", "v1", "v2", "v3"]);
    assert_eq!(names(1), ["v5", "v6", "v7", "v8"]);
    assert!((area(&c.model) - 12.0).abs() < 1e-12);
    // A hole walked the same way as the outline is turned round.
    let c = conv(&src.replace(
        "f v1 v2 v3 v4 v5 v6 v7 v8 v5 v4",
        "f v1 v2 v3 v4 v5 v8 v7 v6 v5 v4",
    ));
    assert!((area(&c.model) - 12.0).abs() < 1e-12);
    // A loop through a vertex twice whose second loop lies outside the
    // first: two faces meeting at that corner.
    let c = conv(&src.replace("f v1 v2 v3 v4 v5 v6 v7 v8 v5 v4", "f v1 v2 v3 v1 v5 v6"));
    assert_eq!(c.model.faces.len(), 2);
    assert!(c.model.faces.iter().all(|f| f.contours.len() == 1));
    assert!((area(&c.model) - 11.0).abs() < 1e-12);
}

/// A hole hung on the outline at one repeated vertex (the seam is the
/// vertex v4 alone, as real exports write it): a face with a hole that
/// touches the outline there.
#[test]
fn one_vertex_seam_becomes_a_hole() {
    let src = "v v1 =\np 0 0 0\nv v2 =\np 4 0 0\nv v3 =\np 4 4 0\nv v4 =\np 0 4 0\n\
               v v5 =\np 1 3 0\nv v6 =\np 3 3 0\nv v7 =\np 3 1 0\n\
               f v1 v2 v3 v4 v5 v6 v7 v4\n";
    let c = conv(src);
    assert_eq!(c.model.faces.len(), 1);
    let f = &c.model.faces[0];
    assert_eq!(f.contours.len(), 2);
    // 16 less the hole v4 v5 v6 v7 (2).
    assert!((area(&c.model) - 14.0).abs() < 1e-12, "{}", area(&c.model));
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
}

#[test]
fn pinch_splitting() {
    assert_eq!(split_pinches(vec![0, 1, 2]), vec![vec![0, 1, 2]]);
    let mut l = split_pinches(vec![0, 1, 2, 3, 4, 2, 5]);
    l.sort();
    assert_eq!(l, vec![vec![2, 3, 4], vec![2, 5, 0, 1]]);
    // Twice through one vertex: three loops.
    let mut l = split_pinches(vec![0, 1, 2, 0, 3, 4, 0, 5, 6]);
    l.sort();
    assert_eq!(l, vec![vec![0, 1, 2], vec![0, 3, 4], vec![0, 5, 6]]);
}

/// Measured spectra dip below zero by noise: clamped, one warning per
/// material however many samples or statements.
#[test]
fn negative_spectral_samples_are_clamped() {
    let src = "m paint =\n c\n cspec 400 700 1 0 -0.8 -1.6 -2.6 3 5\n rd 0.5\n\
               c\n cspec 400 700 -1 2 2 2\n\
               v v1 =\np 0 0 0\nv v2 =\np 1 0 0\nv v3 =\np 0 1 0\nf v1 v2 v3\n\
               m other =\n c\n cspec 400 700 2 -0.1 2\n rd 0.5\nf v1 v3 v2\n";
    let c = conv(src);
    let w: Vec<&String> = c
        .warnings
        .iter()
        .filter(|w| w.contains("negative spectral"))
        .collect();
    assert_eq!(w.len(), 2, "{:?}", c.warnings);
    assert!(
        w[0].contains("'paint'") && w[0].contains("-2.6"),
        "{}",
        w[0]
    );
    assert!(w[1].contains("'other'"), "{}", w[1]);
    // The clamped spectrum is the one with zeros there.
    let same = conv(&src.replace("1 0 -0.8 -1.6 -2.6 3 5", "1 0 0 0 0 3 5"));
    assert_eq!(
        c.model.materials[0].diffuse(),
        same.model.materials[0].diffuse()
    );
}

#[test]
fn seam_splitting() {
    assert_eq!(split_seams(vec![0, 1, 2]), vec![vec![0, 1, 2]]);
    // Two holes chained by seams.
    let loops = split_seams(vec![0, 1, 2, 3, 4, 5, 6, 7, 4, 8, 9, 10, 8, 4, 3]);
    let mut sorted: Vec<Vec<usize>> = loops.into_iter().filter(|l| l.len() >= 3).collect();
    sorted.sort();
    assert_eq!(
        sorted,
        vec![vec![3, 0, 1, 2], vec![4, 5, 6, 7], vec![8, 9, 10]]
    );
}

#[test]
fn face_with_holes_entity() {
    let src = "v v1 =\np 0 0 0\nv v2 =\np 4 0 0\nv v3 =\np 4 4 0\nv v4 =\np 0 4 0\n\
               v v5 =\np 1 1 0\nv v6 =\np 3 1 0\nv v7 =\np 3 3 0\nv v8 =\np 1 3 0\n\
               fh v1 v2 v3 v4 - v5 v6 v7 v8\n";
    let c = conv(src);
    assert_eq!(c.model.faces[0].contours.len(), 2);
    assert!((area(&c.model) - 12.0).abs() < 1e-12);
}

#[test]
fn transforms_nest_and_mirror() {
    let c = conv(&format!(
        "{SQUARE}xf -t 10 0 0\nxf -rz 90\nf a b c d\nxf\nxf -mx\nf a b c d\nxf\nxf -s 2 -t 1 0 0\nf a b c d\nxf\nxf\n"
    ));
    let m = &c.model;
    // Inner transforms first: rotate, then translate.
    assert_eq!(
        face_points(m, 0)[0],
        vec![
            DVec3::new(10.0, 0.0, 0.0),
            DVec3::new(10.0, 1.0, 0.0),
            DVec3::new(9.0, 1.0, 0.0),
            DVec3::new(9.0, 0.0, 0.0)
        ]
    );
    // The mirrored copy is reversed so that it still faces +z.
    let p = &face_points(m, 1)[0];
    let n = geom::newell_normal(p);
    assert!(n.z > 0.0, "{p:?}");
    assert_eq!(p[0], DVec3::new(10.0, 0.0, 0.0));
    // Scale, then translate.
    assert_eq!(face_points(m, 2)[0][2], DVec3::new(13.0, 2.0, 0.0));
    // Vertices get one UG vertex per transformed position, named after the MGF vertex.
    assert_eq!(m.vertex(m.faces[1].contours[0][1]).name, "d.2");
}

#[test]
fn arrays_and_repeats() {
    let c = conv(&format!(
        "{SQUARE}o row\nxf -a 3 -t 2 0 0 -a 2 -t 0 0 5\nf a b c d\nxf\no\n"
    ));
    let m = &c.model;
    assert_eq!(m.faces.len(), 6);
    let names: Vec<&str> = m.faces.iter().map(|f| f.name.as_deref().unwrap()).collect();
    assert_eq!(
        names,
        [
            "row.a0.0", "row.a0.1", "row.a1.0", "row.a1.1", "row.a2.0", "row.a2.1"
        ]
    );
    assert_eq!(face_points(m, 5)[0][0], DVec3::new(4.0, 0.0, 5.0));
    // -i N repeats the following transforms; a final transform after -i 1.
    let c = conv(&format!(
        "{SQUARE}xf -i 3 -t 1 0 0 -i 1 -rz 180\nf a b c d\nxf\n"
    ));
    assert_eq!(face_points(&c.model, 0)[0][0], DVec3::new(-3.0, 0.0, 0.0));
}

#[test]
fn includes_with_transforms_resolve_relative_to_the_file() {
    let inc = "v p =\np 0 0 0\nv q =\np 1 0 0\nv r =\np 0 1 0\nf p q r\ni sub/tri.mgf -t 0 0 1\n";
    let sub = "v s =\np 0 0 0\nv t =\np 1 0 0\nv u =\np 0 1 0\nf s t u\n";
    let c = conv_files(
        "o top\ni lib/part.mgf -t 5 0 0 -a 2 -t 0 10 0\no\n",
        &[("d/lib/part.mgf", inc), ("d/lib/sub/tri.mgf", sub)],
        &Options::default(),
    )
    .unwrap();
    let m = &c.model;
    assert_eq!(m.faces.len(), 4);
    assert_eq!(face_points(m, 3)[0][0], DVec3::new(5.0, 10.0, 1.0));
    assert_eq!(m.faces[3].name.as_deref(), Some("top.a1.2"));
    let e = conv_files("i lib/none.mgf\n", &[], &Options::default())
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "t.mgf:1:3: error: cannot read 'd/lib/none.mgf': not found"
    );
    let e = conv_files(
        "i a.mgf\n",
        &[("d/a.mgf", "i a.mgf\n")],
        &Options::default(),
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "d/a.mgf:1:3: error: include cycle: 'a.mgf' is already being read"
    );
    let e = conv_files(
        "i a.mgf\n",
        &[("d/a.mgf", "xf -t 1 2 3\n")],
        &Options::default(),
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "d/a.mgf:1:1: error: transform context not ended in this file (missing 'xf')"
    );
}

#[test]
fn primitives_are_closed_and_face_outward() {
    let opts = Options {
        segments: 8,
        ..Default::default()
    };
    let pts = "v c =\np 1 2 3\nn 0 0 1\nv e =\np 1 2 5\n";
    let sph = conv_opts(&format!("{pts}sph c 2\n"), &opts);
    assert_eq!(sph.model.faces.len(), 32);
    assert_eq!(sph.model.vertices.len(), 2 + 3 * 8);
    let v = volume(&sph.model);
    assert!(
        v > 0.6 * 4.0 / 3.0 * std::f64::consts::PI * 8.0 && v < 33.6,
        "{v}"
    );
    let inward = conv_opts(&format!("{pts}sph c -2\n"), &opts);
    assert!((volume(&inward.model) + v).abs() < 1e-9);
    let torus = conv_opts(&format!("{pts}torus c 1 3\n"), &opts);
    assert_eq!(torus.model.faces.len(), 64);
    assert!(volume(&torus.model) > 0.0);
    let inward = conv_opts(&format!("{pts}torus c 0 -3\n"), &opts);
    assert!(volume(&inward.model) < 0.0);
    // A cylinder with its two end rings is closed.
    let cyl = conv_opts(
        &format!(
            "{pts}v e2 = e\nn 0 0 1\nv c2 = c\nn 0 0 -1\ncyl c 1 e\nring e2 0 1\nring c2 0 1\n"
        ),
        &opts,
    );
    assert_eq!(cyl.model.faces.len(), 24);
    let v = volume(&cyl.model);
    assert!(
        v > 0.8 * std::f64::consts::PI * 2.0 && v < std::f64::consts::TAU,
        "{v}"
    );
    let cone = conv_opts(&format!("{pts}cone c 1 e 0\n"), &opts);
    assert_eq!(cone.model.faces.len(), 8);
    assert!(cone.model.faces.iter().all(|f| f.contours[0].len() == 3));
    let ring = conv_opts(&format!("{pts}ring c 1 2\n"), &opts);
    let a = area(&ring.model);
    assert!(
        a > 0.8 * 3.0 * std::f64::consts::PI && a < 3.0 * std::f64::consts::PI,
        "{a}"
    );
    for k in 0..ring.model.faces.len() {
        assert!(geom::newell_normal(&face_points(&ring.model, k)[0]).z > 0.0);
    }
    let prism = conv_opts(&format!("{SQUARE}prism a b c d 2\n"), &opts);
    assert_eq!(prism.model.faces.len(), 6);
    assert!((volume(&prism.model) - 2.0).abs() < 1e-12);
    let inward = conv_opts(&format!("{SQUARE}prism a b c d -2\n"), &opts);
    assert!((volume(&inward.model) + 2.0).abs() < 1e-12);
}

#[test]
fn two_sided_faces_are_doubled_on_request() {
    let src = format!("{SQUARE}m w =\n  rd .5\no wall\nf a b c d\n");
    assert_eq!(conv(&src).model.faces.len(), 1);
    let c = conv_opts(
        &src,
        &Options {
            two_sided: true,
            ..Default::default()
        },
    );
    let names: Vec<&str> = c
        .model
        .faces
        .iter()
        .map(|f| f.name.as_deref().unwrap())
        .collect();
    assert_eq!(names, ["wall", "wall.back"]);
    assert!(volume(&c.model).abs() < 1e-12);
}

#[test]
fn errors_have_positions() {
    assert_eq!(err("f a b c\n"), "t.mgf:1:3: error: undefined vertex 'a'");
    assert_eq!(
        err("v a =\np 0 x 0\n"),
        "t.mgf:2:5: error: bad number 'x' (expected y)"
    );
    assert_eq!(
        err("v a =\np 0 0\n"),
        "t.mgf:2:6: error: missing arguments: usage 'p x y z'"
    );
    assert_eq!(
        err("xf -q 1\nxf\n"),
        "t.mgf:1:4: error: unknown transform '-q'"
    );
    assert_eq!(
        err("xf -t 1 2\nxf\n"),
        "t.mgf:1:4: error: transform '-t' needs 3 number(s)"
    );
    assert_eq!(
        err("xf\n"),
        "t.mgf:1:1: error: 'xf' ends a transform context that was not begun in this file"
    );
    assert_eq!(
        err("o\n"),
        "t.mgf:1:1: error: 'o' ends an object context, but none is open"
    );
    assert_eq!(err("m x\n"), "t.mgf:1:3: error: undefined material 'x'");
    assert_eq!(
        err("sides 3\n"),
        "t.mgf:1:7: error: bad number of sides '3' (expected a whole number from 1 to 2)"
    );
    assert_eq!(
        err("cxy .8 .8\n"),
        "t.mgf:1:5: error: chromaticity outside the CIE diagram (need x ≥ 0, y > 0, x + y ≤ 1)"
    );
    assert_eq!(
        err("v c =\np 0 0 0\nring c 0 1\n"),
        "t.mgf:3:6: error: ring needs a vertex with a normal"
    );
    assert_eq!(
        err("xf -a 0\nxf\n"),
        "t.mgf:1:7: error: bad array count '0' (expected a whole number from 1 to 1000000000)"
    );
}

#[test]
fn unknown_entities_warn_once_or_fail_strictly() {
    let src = "frob 1\nfrob 2\nies lamp.ies\nrs .1 .02\n";
    let c = conv(src);
    assert_eq!(
        c.warnings,
        [
            "t.mgf:1:1: warning: unknown entity 'frob' ignored",
            "t.mgf:3:1: warning: unsupported entity 'ies' ignored"
        ]
    );
    assert_eq!(
        c.notes,
        ["t.mgf:4:1: note: 'rs' ignored (UG materials are diffuse)"]
    );
    let strict = Options {
        strict: true,
        ..Default::default()
    };
    let e = conv_files(src, &[], &strict).unwrap_err().to_string();
    assert_eq!(e, "t.mgf:1:1: error: unknown entity 'frob'");
}

#[test]
fn array_bombs_stop() {
    let opts = Options {
        max_faces: 1000,
        ..Default::default()
    };
    let e = conv_files(
        &format!("{SQUARE}xf -a 100 -a 100\nf a b c\nxf\n"),
        &[],
        &opts,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("more than 1000 faces"), "{e}");
    let opts = Options {
        max_steps: 10_000,
        ..Default::default()
    };
    let e = conv_files("xf -a 1000 -a 1000\nxf\n", &[], &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("more than 10000 statements"), "{e}");
}

#[test]
fn output_is_valid_ug() {
    let c = conv(&format!(
        "{SQUARE}m lamp =\n  ed 10\no a;b(c)\nf a b c d\nsph a 1\no\n"
    ));
    let text = ug::write_string(&c.model);
    let back = ug::parse(text.as_bytes(), "<out>").unwrap().model;
    assert_eq!(back, c.model);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = convert_with(&bytes, "r.mgf", Path::new("."), &Options::default(), &mut |_| Err(std::io::Error::other("no")));
    }

    #[test]
    fn random_statements_never_panic(lines in proptest::collection::vec(
        prop_oneof![
            Just("v a =".to_string()),
            Just("v b =".to_string()),
            Just("v c = a".to_string()),
            (-3i32..3, -3i32..3, -3i32..3).prop_map(|(x, y, z)| format!("p {x} {y} {z}")),
            (-1i32..2, -1i32..2, -1i32..2).prop_map(|(x, y, z)| format!("n {x} {y} {z}")),
            Just("f a b c".to_string()),
            Just("f a b c b a".to_string()),
            Just("fh a b c - a b c".to_string()),
            (-2i32..3).prop_map(|r| format!("sph a {r}")),
            (-2i32..3, -2i32..3).prop_map(|(r, s)| format!("cone a {r} b {s}")),
            (-2i32..3, -2i32..3).prop_map(|(r, s)| format!("torus a {r} {s}")),
            (-2i32..3, -2i32..3).prop_map(|(r, s)| format!("ring c {r} {s}")),
            (-2i32..3).prop_map(|l| format!("prism a b c {l}")),
            Just("xf -a 2 -t 1 0 0 -mx".to_string()),
            Just("xf -rz 45 -s -2".to_string()),
            Just("xf".to_string()),
            Just("o x".to_string()),
            Just("o".to_string()),
            Just("m w =".to_string()),
            Just("c k =".to_string()),
            Just("cxy .3 .4".to_string()),
            Just("cct 0".to_string()),
            Just("cspec 400 700 0 1 0".to_string()),
            Just("rd .5".to_string()),
            Just("ed 3".to_string()),
            Just("i x.mgf".to_string()),
        ], 0..25)) {
        let src = lines.join("\n");
        let opts = Options { segments: 4, ..Default::default() };
        if let Ok(c) = convert_with(src.as_bytes(), "r.mgf", Path::new("."), &opts, &mut |_| Err(std::io::Error::other("no"))) {
            let text = ug::write_string(&c.model);
            prop_assert!(ug::parse(text.as_bytes(), "<out>").is_ok(), "{}", text);
        }
    }
}
