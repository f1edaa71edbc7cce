//! ug2obj: a UniGrafix model as Wavefront OBJ with an MTL material library.
//!
//! * The model is flattened first. Vertices are written in order of first
//!   use (faces, then wires); unused vertices are left out.
//! * Each face is preceded by `g NAME` when it has a name (a bare `g` ends
//!   the group for an unnamed face after a named one), and by `usemtl NAME`
//!   when its material differs from the previous face's (a bare `usemtl` for
//!   a face without a material). Faces without holes are written as
//!   polygons; faces with holes (OBJ has none) as triangles wound like the face.
//! * Wires are written as `l` polylines after the faces.
//! * Materials used by faces go to the MTL in order of first use:
//!   `newmtl NAME`, `Kd` (diffuse reflectance) and `Ke` (emission).
//! * Lit models (per-vertex colours from `ugrad`) get the widely supported
//!   `v x y z r g b` extension, with display colours as in `ug2ply`: sRGB of
//!   B/π × 2^exposure, clamped, written with 4 decimals; with
//!   [`ObjOptions::radiosity`] (`--radiosity`) the colours are the raw
//!   radiosity B instead, written exactly (shortest round-trip decimals), for
//!   `obj2ug --vertex-colours` to read back.

use std::io::Write as _;

use crate::ply::write::{Mesh, MeshOptions, srgb_encode};
use rustc_hash::FxHashMap;
use ug::{MaterialId, Model, VertexId};

/// Options of the OBJ writer.
#[derive(Clone, Debug, Default)]
pub struct ObjOptions {
    /// Triangulate every face.
    pub triangles: bool,
    /// Exposure in stops for the display colours of lit models.
    pub exposure: f64,
    /// The `mtllib` line's file name (none: no `mtllib` line).
    pub mtllib: Option<String>,
    /// Vertex colours of lit models are the raw radiosity B, not display colours.
    pub radiosity: bool,
}

/// The OBJ and MTL texts, counts and warnings.
#[derive(Debug)]
pub struct ObjOutput {
    pub obj: Vec<u8>,
    pub mtl: Vec<u8>,
    pub vertices: usize,
    pub faces: usize,
    pub materials: usize,
    pub warnings: Vec<String>,
}

/// A name as OBJ/MTL can carry it: OBJ comments begin with `#`, so a leading `#` becomes `_`.
fn obj_name(name: &str) -> String {
    match name.strip_prefix('#') {
        Some(rest) => format!("_{rest}"),
        None => name.to_string(),
    }
}

fn push_num(out: &mut Vec<u8>, v: f64, b: &mut ryu::Buffer) {
    out.push(b' ');
    ug::push_f64(out, v, b);
}

/// The current group and material of the OBJ being written.
struct State<'a> {
    group: Option<&'a str>,
    /// `None` before the first face; `Some(None)` after a bare `usemtl`.
    material: Option<Option<MaterialId>>,
    used: Vec<MaterialId>,
    seen: Vec<bool>,
}

impl<'a> State<'a> {
    /// Writes the `g` and `usemtl` lines an item needs.
    fn set(
        &mut self,
        m: &Model,
        obj: &mut Vec<u8>,
        name: Option<&'a str>,
        mat: Option<MaterialId>,
        new_item: bool,
    ) {
        if new_item && (name.is_some() || self.group.is_some()) {
            match name {
                Some(n) => {
                    let _ = writeln!(obj, "g {}", obj_name(n));
                }
                None => obj.extend_from_slice(b"g\n"),
            }
            self.group = name;
        }
        // The very first item without a material needs no `usemtl`.
        if self.material.is_none() && mat.is_none() {
            self.material = Some(None);
        }
        if self.material != Some(mat) {
            match mat {
                Some(id) => {
                    let _ = writeln!(obj, "usemtl {}", obj_name(&m.material(id).name));
                    if !self.seen[id.idx()] {
                        self.seen[id.idx()] = true;
                        self.used.push(id);
                    }
                }
                None => obj.extend_from_slice(b"usemtl\n"),
            }
            self.material = Some(mat);
        }
    }
}

/// A wire as written: name, material, polylines of mesh vertex indices.
type WireOut<'a> = (Option<&'a str>, Option<MaterialId>, Vec<Vec<usize>>);

/// Writes a flat model as OBJ + MTL.
pub fn to_obj(m: &Model, opts: &ObjOptions) -> ObjOutput {
    let mut mesh = Mesh::build(
        m,
        &MeshOptions {
            triangles: opts.triangles,
            max_polygon: usize::MAX,
            split_by_material: false,
            exposure: opts.exposure,
        },
    );
    // Wire vertices after the faces' vertices.
    let mut index: FxHashMap<VertexId, usize> = mesh
        .vertices
        .iter()
        .enumerate()
        .map(|(i, v)| (v.source, i))
        .collect();
    let mut wires: Vec<WireOut> = Vec::new();
    for it in &m.items {
        let ug::Item::Wire(w) = it else { continue };
        let w = &m.wires[w.idx()];
        let mut lines = Vec::new();
        for pl in &w.polylines {
            let mut l = Vec::with_capacity(pl.len());
            for &v in pl {
                let next = mesh.vertices.len();
                let k = *index.entry(v).or_insert(next);
                if k == next {
                    let vx = m.vertex(v);
                    let b = vx
                        .color
                        .and_then(|c| m.materials.get(c.idx()))
                        .map_or([0.0; 3], |c| c.diffuse());
                    mesh.vertices.push(crate::ply::write::MeshVertex {
                        source: v,
                        pos: vx.pos,
                        radiosity: mesh.lit.then_some(b),
                        display: b.map(|x| crate::ply::write::radiance_display(x, opts.exposure)),
                    });
                }
                l.push(k);
            }
            lines.push(l);
        }
        wires.push((w.name.as_deref(), w.material, lines));
    }

    let mut obj = Vec::new();
    let mut b = ryu::Buffer::new();
    obj.extend_from_slice(b"# written by ug2obj\n");
    if mesh.lit && opts.radiosity {
        obj.extend_from_slice(
            b"# vertex colours: radiosity B (ug2obj --radiosity; read back with obj2ug --vertex-colours)\n",
        );
    }
    if let Some(lib) = &opts.mtllib {
        let _ = writeln!(obj, "mtllib {lib}");
    }
    for v in &mesh.vertices {
        obj.push(b'v');
        for c in v.pos.to_array() {
            push_num(&mut obj, c, &mut b);
        }
        match v.radiosity {
            Some(rad) if opts.radiosity => {
                for c in rad {
                    push_num(&mut obj, c, &mut b);
                }
            }
            _ if mesh.lit => {
                for c in v.display {
                    let _ = write!(obj, " {:.4}", srgb_encode(c));
                }
            }
            _ => {}
        }
        obj.push(b'\n');
    }
    if opts.radiosity && !mesh.lit {
        mesh.warnings
            .push("warning: --radiosity: the model has no vertex colours (it is not lit)".into());
    }
    let mut st = State {
        group: None,
        material: None,
        used: Vec::new(),
        seen: vec![false; m.materials.len()],
    };
    let mut last_face = None;
    for p in &mesh.polygons {
        let face = m.face(p.face);
        let first = last_face != Some(p.face);
        last_face = Some(p.face);
        st.set(m, &mut obj, face.name.as_deref(), face.material, first);
        obj.push(b'f');
        for &i in &p.verts {
            let _ = write!(obj, " {}", i + 1);
        }
        obj.push(b'\n');
    }
    for (name, mat, lines) in &wires {
        st.set(m, &mut obj, *name, *mat, true);
        for l in lines {
            obj.push(b'l');
            for &i in l {
                let _ = write!(obj, " {}", i + 1);
            }
            obj.push(b'\n');
        }
    }
    let used = st.used;

    let mut mtl = Vec::new();
    mtl.extend_from_slice(b"# written by ug2obj\n");
    for &id in &used {
        let mat = m.material(id);
        let _ = writeln!(mtl, "newmtl {}", obj_name(&mat.name));
        mtl.extend_from_slice(b"Kd");
        for c in mat.diffuse() {
            push_num(&mut mtl, c, &mut b);
        }
        mtl.extend_from_slice(b"\nKe");
        for c in mat.emission() {
            push_num(&mut mtl, c, &mut b);
        }
        mtl.push(b'\n');
    }
    ObjOutput {
        obj,
        mtl,
        vertices: mesh.vertices.len(),
        faces: mesh.polygons.len(),
        materials: used.len(),
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

    #[test]
    fn groups_materials_and_faces() {
        let m = parse(
            "c_rgb white 0.8 0.8 0.8; defmat lamp; diffuse_rgb 0.5 0.5 0.5; emission_rgb 10 9 8; end;\
             v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\
             f floor (a b c d) white; f lamp1 (a c d) lamp; f (a b c) lamp;",
        );
        let out = to_obj(
            &m,
            &ObjOptions {
                mtllib: Some("x.mtl".into()),
                ..Default::default()
            },
        );
        let obj = String::from_utf8(out.obj).unwrap();
        assert_eq!(
            obj,
            "# written by ug2obj\nmtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
             g floor\nusemtl white\nf 1 2 3 4\ng lamp1\nusemtl lamp\nf 1 3 4\ng\nf 1 2 3\n"
        );
        let mtl = String::from_utf8(out.mtl).unwrap();
        assert_eq!(
            mtl,
            "# written by ug2obj\nnewmtl white\nKd 0.8 0.8 0.8\nKe 0 0 0\n\
             newmtl lamp\nKd 0.5 0.5 0.5\nKe 10 9 8\n"
        );
    }

    #[test]
    fn holes_become_triangles_in_one_group() {
        let m = parse(
            "v a 0 0 0; v b 4 0 0; v c 4 4 0; v d 0 4 0;\
             v e 1 1 0; v f 1 3 0; v g 3 3 0; v h 3 1 0; f w (a b c d) (e f g h);",
        );
        let out = to_obj(&m, &ObjOptions::default());
        let obj = String::from_utf8(out.obj).unwrap();
        assert_eq!(obj.matches("\nf ").count(), 8);
        assert_eq!(obj.matches("\ng w\n").count(), 1);
        assert!(!obj.contains("usemtl"), "{obj}");
        assert!(!obj.contains("mtllib"), "{obj}");
    }

    #[test]
    fn lit_vertices_have_colours_and_wires_are_lines() {
        let m = parse(
            "c_rgb _rad0 3.141592653589793 0 0; v a 0 0 0 _rad0; v b 1 0 0 _rad0; v c 0 1 0 _rad0;\
             v p 5 5 5; v q 6 6 6; f (a b c); w edge (p q);",
        );
        let out = to_obj(&m, &ObjOptions::default());
        let obj = String::from_utf8(out.obj).unwrap();
        assert!(obj.contains("v 0 0 0 1.0000 0.0000 0.0000\n"), "{obj}");
        assert!(obj.contains("g edge\nl 4 5\n"), "{obj}");
        let out = to_obj(
            &m,
            &ObjOptions {
                radiosity: true,
                ..Default::default()
            },
        );
        let obj = String::from_utf8(out.obj).unwrap();
        assert!(obj.contains("v 0 0 0 3.141592653589793 0 0\n"), "{obj}");
        // Wire vertices without a colour get B = 0.
        assert!(obj.contains("v 5 5 5 0 0 0\n"), "{obj}");
        assert!(obj.starts_with("# written by ug2obj\n# vertex colours: radiosity B"));
        assert!(out.warnings.is_empty());
        let unlit = parse("v a 0 0 0; v b 1 0 0; v c 0 1 0; f (a b c);");
        let out = to_obj(
            &unlit,
            &ObjOptions {
                radiosity: true,
                ..Default::default()
            },
        );
        assert!(String::from_utf8(out.obj).unwrap().contains("v 1 0 0\n"));
        assert_eq!(out.warnings.len(), 1);
    }

    #[test]
    fn leading_hash_is_replaced() {
        assert_eq!(obj_name("#1"), "_1");
        assert_eq!(obj_name("a#1"), "a#1");
    }
}
