//! ug2ply: a UniGrafix model as PLY.
//!
//! The model is flattened first. Faces without holes are written as polygons
//! (`--triangles` splits them), faces with holes are triangulated (PLY has no
//! holes). Every written vertex carries `uchar red green blue` display colours:
//!
//! * **lit models** (after `ugrad`: vertices name a `c_rgb` colour holding the
//!   radiosity B) also get `float radiosity_r/g/b` with the raw values, and the
//!   display colour is the sRGB encoding of the radiance B/π × 2^exposure,
//!   clamped to [0, 1];
//! * **unlit models** show the face material's diffuse reflectance (sRGB
//!   encoded; faces without a material are mid grey, 0.5, as `ugrad` takes
//!   them). A vertex shared by faces of different materials is written once
//!   per material.
//!
//! The mesh extraction ([`Mesh::build`]) and the colour helpers are shared
//! with `ug2obj`.

use std::fmt::Write as _;

use glam::DVec3;
use rustc_hash::FxHashMap;
use ug::{FaceId, MaterialId, Model, VertexId};

/// The reflectance shown for faces without a material (as `ugrad` takes them).
pub const NO_MATERIAL_GREY: f64 = 0.5;

/// The sRGB transfer function of a linear value in [0, 1] (clamped; NaN is 0).
pub fn srgb_encode(linear: f64) -> f64 {
    let c = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// A linear value as an 8-bit sRGB component.
pub fn srgb_u8(linear: f64) -> u8 {
    (srgb_encode(linear) * 255.0).round().clamp(0.0, 255.0) as u8
}

/// The display value of a radiosity B: radiance B/π scaled by 2^exposure (linear, unclamped).
pub fn radiance_display(b: f64, exposure: f64) -> f64 {
    b / std::f64::consts::PI * exposure.exp2()
}

/// Options of the mesh extraction.
#[derive(Clone, Debug)]
pub struct MeshOptions {
    /// Triangulate every face (not only those with holes).
    pub triangles: bool,
    /// Polygons with more vertices than this are triangulated.
    pub max_polygon: usize,
    /// Write a vertex once per material of the faces using it (unlit display colours).
    pub split_by_material: bool,
    /// Exposure in stops for the display colours of lit models.
    pub exposure: f64,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions {
            triangles: false,
            max_polygon: usize::MAX,
            split_by_material: false,
            exposure: 0.0,
        }
    }
}

/// One written polygon: the face it comes from and indices into [`Mesh::vertices`].
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    pub face: FaceId,
    pub verts: Vec<usize>,
}

/// One written vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshVertex {
    pub source: VertexId,
    pub pos: DVec3,
    /// Radiosity B per channel (lit models only; 0 for a vertex without colour).
    pub radiosity: Option<[f64; 3]>,
    /// Linear display colour in [0, 1] before sRGB encoding.
    pub display: [f64; 3],
}

impl MeshVertex {
    /// The display colour as 8-bit sRGB.
    pub fn display_u8(&self) -> [u8; 3] {
        self.display.map(srgb_u8)
    }
}

/// A flat model as an indexed polygon mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<MeshVertex>,
    pub polygons: Vec<Polygon>,
    /// True when the model has per-vertex colours (radiosity).
    pub lit: bool,
    /// Messages for stderr (faces that could not be triangulated, …).
    pub warnings: Vec<String>,
}

/// The name a face is reported by: its name, or `#k` (k-th face, from 1).
pub fn face_label(m: &Model, f: FaceId) -> String {
    match &m.face(f).name {
        Some(n) => format!("'{n}'"),
        None => format!("#{}", f.idx() + 1),
    }
}

/// A material's diffuse reflectance, or mid grey for none.
pub fn material_diffuse(m: &Model, mat: Option<MaterialId>) -> [f64; 3] {
    mat.and_then(|id| m.materials.get(id.idx()))
        .map_or([NO_MATERIAL_GREY; 3], |x| x.diffuse())
}

/// The polygons (vertex lists) a face is written as: its outer contour when
/// it has no holes and needs no split, else triangles wound like the face.
/// `None` with a reason when a face with holes cannot be triangulated (then
/// its outer contour is returned as the second element).
fn face_polygons(
    m: &Model,
    f: FaceId,
    opts: &MeshOptions,
) -> (Vec<Vec<VertexId>>, Option<&'static str>) {
    let face = m.face(f);
    let Some(outer) = face.contours.first() else {
        return (Vec::new(), None);
    };
    let simple = face.contours.len() == 1;
    let n = outer.len();
    if simple && n <= opts.max_polygon && (!opts.triangles || n <= 3) {
        return (vec![outer.clone()], None);
    }
    let pts: Vec<Vec<DVec3>> = face
        .contours
        .iter()
        .map(|c| c.iter().map(|&v| m.pos(v)).collect())
        .collect();
    let ids: Vec<VertexId> = face.contours.iter().flatten().copied().collect();
    if let Some(tris) = geom::triangulate::fold_triangles(&pts) {
        return (
            tris.iter()
                .map(|t| t.iter().map(|&i| ids[i]).collect())
                .collect(),
            None,
        );
    }
    // Could not triangulate (degenerate or self-crossing): fall back to the outer contour.
    let fan = |c: &Vec<VertexId>| -> Vec<Vec<VertexId>> {
        (1..c.len().saturating_sub(1))
            .map(|i| vec![c[0], c[i], c[i + 1]])
            .collect()
    };
    let polys = if n <= opts.max_polygon && !opts.triangles {
        vec![outer.clone()]
    } else {
        fan(outer)
    };
    let why = if simple {
        "could not be triangulated; written as a fan of its outline"
    } else {
        "has holes but could not be triangulated; written without its holes"
    };
    (polys, Some(why))
}

impl Mesh {
    /// Extracts the faces of a flat model (flatten it first) as polygons.
    pub fn build(m: &Model, opts: &MeshOptions) -> Mesh {
        let faces: Vec<FaceId> = m.top_faces().collect();
        let lit = faces.iter().any(|&f| {
            m.face(f)
                .contours
                .iter()
                .flatten()
                .any(|&v| m.vertex(v).color.is_some())
        });
        let mut mesh = Mesh {
            lit,
            ..Default::default()
        };
        let mut index: FxHashMap<(VertexId, Option<MaterialId>), usize> = FxHashMap::default();
        let mut uncoloured = 0usize;
        for f in faces {
            let face = m.face(f);
            let (polys, why) = face_polygons(m, f, opts);
            if let Some(why) = why {
                mesh.warnings
                    .push(format!("warning: face {} {why}", face_label(m, f)));
            }
            let mat_key = if opts.split_by_material && !lit {
                face.material
            } else {
                None
            };
            for poly in polys {
                let mut verts = Vec::with_capacity(poly.len());
                for v in poly {
                    let next = mesh.vertices.len();
                    let k = *index.entry((v, mat_key)).or_insert(next);
                    if k == next {
                        let vx = m.vertex(v);
                        let (radiosity, display) = if lit {
                            let b = match vx.color.and_then(|c| m.materials.get(c.idx())) {
                                Some(c) => c.diffuse(),
                                None => {
                                    uncoloured += 1;
                                    [0.0; 3]
                                }
                            };
                            (Some(b), b.map(|x| radiance_display(x, opts.exposure)))
                        } else {
                            (None, material_diffuse(m, face.material))
                        };
                        mesh.vertices.push(MeshVertex {
                            source: v,
                            pos: vx.pos,
                            radiosity,
                            display,
                        });
                    }
                    verts.push(k);
                }
                mesh.polygons.push(Polygon { face: f, verts });
            }
        }
        if uncoloured > 0 {
            mesh.warnings.push(format!(
                "warning: {uncoloured} vertices have no colour in a lit model; written with radiosity 0"
            ));
        }
        mesh
    }
}

/// Options of the PLY writer.
#[derive(Clone, Debug, Default)]
pub struct PlyOptions {
    /// binary_little_endian instead of ASCII.
    pub binary: bool,
    /// Triangulate every face.
    pub triangles: bool,
    /// Exposure in stops for the display colours of lit models.
    pub exposure: f64,
}

/// The result: the PLY bytes, counts and warnings.
pub struct PlyOutput {
    pub bytes: Vec<u8>,
    pub vertices: usize,
    pub faces: usize,
    pub lit: bool,
    pub warnings: Vec<String>,
}

/// Writes a flat model as PLY.
pub fn to_ply(m: &Model, opts: &PlyOptions) -> PlyOutput {
    let mesh = Mesh::build(
        m,
        &MeshOptions {
            triangles: opts.triangles,
            max_polygon: 255, // the vertex count is a uchar
            split_by_material: true,
            exposure: opts.exposure,
        },
    );
    let mut header = String::new();
    header.push_str("ply\n");
    header.push_str(if opts.binary {
        "format binary_little_endian 1.0\n"
    } else {
        "format ascii 1.0\n"
    });
    header.push_str("comment written by ug2ply\n");
    if mesh.lit {
        let mut b = ryu::Buffer::new();
        let _ = writeln!(
            header,
            "comment radiosity_r/g/b: radiosity B per vertex; red/green/blue: sRGB of B/pi at exposure {}",
            ug::fmt_f64(opts.exposure, &mut b)
        );
    } else {
        header
            .push_str("comment red/green/blue: sRGB of the face material's diffuse reflectance\n");
    }
    let _ = writeln!(header, "element vertex {}", mesh.vertices.len());
    header.push_str("property double x\nproperty double y\nproperty double z\n");
    if mesh.lit {
        header.push_str(
            "property float radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n",
        );
    }
    header.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    let _ = writeln!(header, "element face {}", mesh.polygons.len());
    header.push_str("property list uchar int vertex_indices\nend_header\n");
    let mut out = header.into_bytes();
    if opts.binary {
        for v in &mesh.vertices {
            for c in v.pos.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
            if let Some(b) = v.radiosity {
                for c in b {
                    out.extend_from_slice(&(c as f32).to_le_bytes());
                }
            }
            out.extend_from_slice(&v.display_u8());
        }
        for p in &mesh.polygons {
            out.push(p.verts.len() as u8);
            for &i in &p.verts {
                out.extend_from_slice(&(i as i32).to_le_bytes());
            }
        }
    } else {
        let mut b = ryu::Buffer::new();
        for v in &mesh.vertices {
            for (k, c) in v.pos.to_array().into_iter().enumerate() {
                if k > 0 {
                    out.push(b' ');
                }
                ug::push_f64(&mut out, c, &mut b);
            }
            if let Some(rad) = v.radiosity {
                for c in rad {
                    out.push(b' ');
                    ug::push_f64(&mut out, c, &mut b);
                }
            }
            for c in v.display_u8() {
                out.push(b' ');
                out.extend_from_slice(c.to_string().as_bytes());
            }
            out.push(b'\n');
        }
        for p in &mesh.polygons {
            out.extend_from_slice(p.verts.len().to_string().as_bytes());
            for &i in &p.verts {
                out.push(b' ');
                out.extend_from_slice(i.to_string().as_bytes());
            }
            out.push(b'\n');
        }
    }
    PlyOutput {
        bytes: out,
        vertices: mesh.vertices.len(),
        faces: mesh.polygons.len(),
        lit: mesh.lit,
        warnings: mesh.warnings,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(src: &str) -> Model {
        ug::parse(src.as_bytes(), "<test>")
            .unwrap()
            .model
            .flatten()
            .unwrap()
    }

    fn text(m: &Model, opts: &PlyOptions) -> String {
        String::from_utf8(to_ply(m, opts).bytes).unwrap()
    }

    #[test]
    fn srgb_curve() {
        assert_eq!(srgb_u8(0.0), 0);
        assert_eq!(srgb_u8(1.0), 255);
        assert_eq!(srgb_u8(2.0), 255);
        assert_eq!(srgb_u8(-1.0), 0);
        assert_eq!(srgb_u8(f64::NAN), 0);
        assert_eq!(srgb_u8(0.5), 188);
        assert_eq!(srgb_u8(0.18), 118);
    }

    #[test]
    fn unlit_square_is_one_polygon_with_material_colour() {
        let m = parse(
            "c_rgb red 1 0 0; v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; f sq (a b c d) red;",
        );
        let t = text(&m, &PlyOptions::default());
        assert!(t.starts_with("ply\nformat ascii 1.0\n"), "{t}");
        assert!(t.contains("element vertex 4\n"), "{t}");
        assert!(t.contains("element face 1\n"), "{t}");
        assert!(!t.contains("radiosity"), "{t}");
        assert!(t.contains("\n0 0 0 255 0 0\n"), "{t}");
        assert!(t.ends_with("4 0 1 2 3\n"), "{t}");
    }

    #[test]
    fn shared_vertices_are_split_by_material() {
        let m = parse(
            "c_rgb r 1 0 0; c_rgb g 0 1 0; v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\
             f (a b c) r; f (a c d) g;",
        );
        let out = to_ply(&m, &PlyOptions::default());
        assert_eq!((out.vertices, out.faces), (6, 2));
    }

    #[test]
    fn holes_are_triangulated() {
        let m = parse(
            "v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 0 4 0;\
             v e 1 1 0; v f 1 3 0; v g 3 3 0; v h 3 1 0; f w (a b c d) (e f g h);",
        );
        let out = to_ply(&m, &PlyOptions::default());
        assert_eq!(out.vertices, 8);
        assert_eq!(out.faces, 8, "a square ring is 8 triangles");
        assert!(out.warnings.is_empty());
        // Triangles keep the face's orientation (+z) and cover 16 - 4.
        let mesh = Mesh::build(&m, &MeshOptions::default());
        let mut area = 0.0;
        for p in &mesh.polygons {
            let q: Vec<DVec3> = p.verts.iter().map(|&i| mesh.vertices[i].pos).collect();
            let n = (q[1] - q[0]).cross(q[2] - q[0]);
            assert!(n.z > 0.0);
            area += n.length() / 2.0;
        }
        assert!((area - 12.0).abs() < 1e-12);
    }

    #[test]
    fn lit_models_have_radiosity_and_exposed_colours() {
        let m = parse(
            "c_rgb _rad0 3.14159265358979 0 0; c_rgb _rad1 0 0 0;\
             v a 0 0 0 _rad0; v b 1 0 0 _rad1; v c 0 1 0 _rad1; f (a b c);",
        );
        let t = text(&m, &PlyOptions::default());
        assert!(t.contains("property float radiosity_r\n"), "{t}");
        assert!(t.contains("\n0 0 0 3.14159265358979 0 0 255 0 0\n"), "{t}");
        let t = text(
            &m,
            &PlyOptions {
                exposure: -1.0,
                ..Default::default()
            },
        );
        assert!(t.contains("3.14159265358979 0 0 188 0 0\n"), "{t}");
    }

    #[test]
    fn binary_layout() {
        let m = parse("v a 0 0 0; v b 1 0 0; v c 0 1 0; f (a b c);");
        let out = to_ply(
            &m,
            &PlyOptions {
                binary: true,
                ..Default::default()
            },
        );
        let bytes = out.bytes;
        let end = b"end_header\n";
        let at = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        // 3 vertices × (3 doubles + 3 uchar) + 1 face × (1 + 3 ints)
        assert_eq!(bytes.len() - at, 3 * 27 + 13);
        let x1 = f64::from_le_bytes(bytes[at + 27..at + 35].try_into().unwrap());
        assert_eq!(x1, 1.0);
        assert_eq!(bytes[bytes.len() - 13], 3);
    }

    #[test]
    fn triangles_option_and_big_polygons() {
        let mut src = String::new();
        let n = 300;
        for i in 0..n {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            src += &format!("v p{i} {} {} 0;", a.cos(), a.sin());
        }
        src += "f (";
        for i in 0..n {
            src += &format!("p{i} ");
        }
        src += ");";
        let m = parse(&src);
        let out = to_ply(&m, &PlyOptions::default());
        assert_eq!(out.faces, n - 2, "more than 255 vertices: triangulated");
        let sq = parse("v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; f (a b c d);");
        let out = to_ply(
            &sq,
            &PlyOptions {
                triangles: true,
                ..Default::default()
            },
        );
        assert_eq!(out.faces, 2);
    }
}
