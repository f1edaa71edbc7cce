//! Streaming the mesh as UG text: the bytes `ug::write(&mesh.to_model(src))`
//! gives, without building the output model (no `String` per vertex or face,
//! no copy of the whole text in memory).
//!
//! Vertex names are not stored: each is its base vertex's name (an input
//! name, or recursively another vertex's) followed by `.k`, so only `k` is
//! kept per vertex and a name is spelled out when it is written. A derived
//! name `P.k` can only clash with an input name: two derived names `P.k` and
//! `Q.j` are equal only when the names `P` and `Q` (everything before the
//! last dot) and `k`, `j` are, and names are unique by induction. So the
//! uniqueness check needs the input names only, as in [`Mesh::to_model`],
//! which checks against the input names and every earlier derived name.
//! The same holds for face names `NAME.k`, whose counter is kept per base
//! name (patches sharing a name continue where the previous one stopped,
//! which is what skipping the names already taken does).

use std::io::{self, Write};

use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Item, MaterialId, Model};

use crate::{Mesh, NONE, VertId};

/// What [`Mesh::write_ug_with`] writes besides the mesh: statements just
/// before the first vertex, and a colour on each vertex.
pub trait VertexColours {
    /// Writes whole statements (each ending with a newline) that go after the
    /// input's kept statements and before the first vertex.
    fn write_before_vertices(&mut self, out: &mut dyn Write) -> io::Result<()>;

    /// Appends the name of vertex `v`'s colour material to `line` and returns
    /// true, or returns false to keep the input vertex's colour.
    fn colour_name(&mut self, v: VertId, line: &mut Vec<u8>) -> bool;
}

/// No extra statements; input vertices keep their colours.
struct InputColours;

impl VertexColours for InputColours {
    fn write_before_vertices(&mut self, _: &mut dyn Write) -> io::Result<()> {
        Ok(())
    }
    fn colour_name(&mut self, _: VertId, _: &mut Vec<u8>) -> bool {
        false
    }
}

/// Output vertex names, computed once (4 bytes per vertex) and spelled on demand.
struct VertexNames<'a> {
    mesh: &'a Mesh,
    src: &'a Model,
    /// The `k` of a derived name `BASE.k`; 0 for a vertex that keeps an input name.
    k: Vec<u32>,
    /// Per input vertex: the mesh vertex that is its first copy (`NONE` if none).
    first_copy: Vec<u32>,
}

/// Appends the decimal digits of `n`.
fn push_u64(out: &mut Vec<u8>, mut n: u64) {
    let mut digits = [0u8; 20];
    let mut k = digits.len();
    loop {
        k -= 1;
        digits[k] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[k..]);
}

impl<'a> VertexNames<'a> {
    /// Assigns the names as [`Mesh::to_model`] does. `None` when the input
    /// has duplicate vertex names (then the uniqueness argument fails).
    fn new(mesh: &'a Mesh, src: &'a Model) -> Option<VertexNames<'a>> {
        let mut taken: FxHashSet<&str> = FxHashSet::default();
        taken.reserve(src.vertices.len());
        for v in &src.vertices {
            if !taken.insert(v.name.as_str()) {
                return None;
            }
        }
        // Only a name with a dot can equal a derived name.
        let dotted = src.vertices.iter().any(|v| v.name.contains('.'));
        let nv = mesh.pos.len();
        let n_input = mesh
            .vparent
            .iter()
            .filter(|p| p[1] == NONE)
            .map(|p| p[0] as usize + 1)
            .max()
            .unwrap_or(0);
        let mut names = VertexNames {
            mesh,
            src,
            k: vec![0; nv],
            first_copy: vec![NONE; n_input],
        };
        let mut count = vec![0u32; nv];
        let mut line = Vec::new();
        let mut scratch = Vec::new();
        for v in 0..nv {
            let [a, b] = mesh.vparent[v];
            let base = if b == NONE {
                let f = &mut names.first_copy[a as usize];
                if *f == NONE {
                    *f = v as u32;
                    continue;
                }
                *f
            } else {
                a
            };
            let k = loop {
                count[base as usize] += 1;
                let k = count[base as usize];
                if !dotted {
                    break k;
                }
                line.clear();
                names.spell(base, &mut line, &mut scratch);
                line.push(b'.');
                push_u64(&mut line, k as u64);
                let free = std::str::from_utf8(&line).map_or(true, |s| !taken.contains(s));
                if free {
                    break k;
                }
            };
            names.k[v] = k;
        }
        Some(names)
    }

    /// Appends the name of vertex `v` to `out` (`scratch` is working space).
    fn spell(&self, v: u32, out: &mut Vec<u8>, scratch: &mut Vec<u32>) {
        scratch.clear();
        let mut x = v;
        loop {
            let [a, b] = self.mesh.vparent[x as usize];
            if b == NONE {
                let f = self.first_copy[a as usize];
                if f == x {
                    match self.src.vertices.get(a as usize) {
                        Some(iv) => out.extend_from_slice(iv.name.as_bytes()),
                        None => {
                            out.push(b'v');
                            push_u64(out, a as u64);
                        }
                    }
                    break;
                }
                scratch.push(self.k[x as usize]);
                x = f;
            } else {
                scratch.push(self.k[x as usize]);
                x = a;
            }
        }
        for &k in scratch.iter().rev() {
            out.push(b'.');
            push_u64(out, k as u64);
        }
    }
}

impl Mesh {
    /// Writes `ug::write(&self.to_model(src))` to `out` without building the
    /// model: the same bytes, in a fraction of the memory.
    ///
    /// Of `src` (the model the mesh was built from) only the materials, the
    /// statements [`Mesh::to_model`] keeps, the vertices' names and colours
    /// and the faces' and wires' names are read: its geometry (vertex
    /// positions, face contours, wire polylines, the vertex and face items)
    /// may have been dropped after meshing.
    pub fn write_ug(&self, src: &Model, out: &mut dyn Write) -> io::Result<()> {
        self.write_ug_with(src, &mut InputColours, out)
    }

    /// [`Mesh::write_ug`] with extra statements before the first vertex and
    /// vertex colours chosen by `colours`: the bytes of writing the model
    /// [`Mesh::to_model`] gives after inserting those statements before its
    /// first vertex and setting those colours.
    pub fn write_ug_with(
        &self,
        src: &Model,
        colours: &mut dyn VertexColours,
        out: &mut dyn Write,
    ) -> io::Result<()> {
        let mut out = io::BufWriter::with_capacity(1 << 16, out);
        // The input's kept statements, through the canonical writer.
        let head = Model {
            materials: src.materials.clone(),
            items: src
                .items
                .iter()
                .filter(|it| {
                    matches!(
                        it,
                        Item::Material(_)
                            | Item::Comment(_)
                            | Item::Light(_)
                            | Item::Camera(_)
                            | Item::Include(_)
                            | Item::Escape(_)
                            | Item::Unknown(_)
                    )
                })
                .cloned()
                .collect(),
            ..Model::default()
        };
        ug::write(&head, &mut out)?;
        drop(head);

        // Names before colours: the names' working counts are freed before
        // the colours' tables are built.
        let names = VertexNames::new(self, src);
        colours.write_before_vertices(&mut out)?;
        let Some(names) = names else {
            // Duplicate input names: the general (memory-hungry) path.
            let mut m = self.to_model(src);
            let mut line = Vec::new();
            for v in 0..m.vertices.len() {
                line.clear();
                if colours.colour_name(VertId(v as u32), &mut line) {
                    let name = String::from_utf8_lossy(&line).into_owned();
                    let id = MaterialId(m.materials.len() as u32);
                    m.materials.push(ug::Material {
                        name,
                        def: ug::MaterialDef::Rgb([0.0; 3]),
                    });
                    m.vertices[v].color = Some(id);
                }
            }
            m.items
                .retain(|it| matches!(it, Item::Vertex(_) | Item::Face(_)));
            ug::write(&m, &mut out)?;
            return out.flush();
        };
        let mat_name = |m: MaterialId| src.materials[m.idx()].name.as_bytes();
        let mut ryu = ryu::Buffer::new();
        let mut line: Vec<u8> = Vec::with_capacity(256);
        let mut scratch = Vec::new();

        // Vertices.
        for v in 0..self.pos.len() {
            line.clear();
            line.extend_from_slice(b"v ");
            names.spell(v as u32, &mut line, &mut scratch);
            for x in self.pos[v].to_array() {
                line.push(b' ');
                ug::push_f64(&mut line, x, &mut ryu);
            }
            let mark = line.len();
            line.push(b' ');
            if !colours.colour_name(VertId(v as u32), &mut line) {
                line.truncate(mark);
                let [a, b] = self.vparent[v];
                if b == NONE
                    && let Some(c) = src.vertices.get(a as usize).and_then(|x| x.color)
                {
                    line.push(b' ');
                    line.extend_from_slice(mat_name(c));
                }
            }
            line.extend_from_slice(b";\n");
            out.write_all(&line)?;
        }

        // Faces.
        let taken: FxHashSet<&str> = src
            .faces
            .iter()
            .filter_map(|f| f.name.as_deref())
            .chain(src.wires.iter().filter_map(|w| w.name.as_deref()))
            .collect();
        let mut next_k: FxHashMap<&str, u32> = FxHashMap::default();
        let mut pieces: Vec<VertId> = Vec::new();
        let mut ends: Vec<usize> = Vec::new();
        for p in self.patches() {
            let face = src.faces.get(self.patch_face(p).idx());
            let name = face.and_then(|f| f.name.as_deref());
            let material = self.patch_material(p);
            pieces.clear();
            ends.clear();
            for e in self.patch_leaves(p) {
                self.for_each_anchored(e, |q| {
                    pieces.extend_from_slice(q);
                    ends.push(pieces.len());
                });
            }
            let whole = ends.len() == 1;
            let mut start = 0;
            for &end in &ends {
                line.clear();
                line.push(b'f');
                if let Some(n) = name {
                    line.push(b' ');
                    line.extend_from_slice(n.as_bytes());
                    if !whole {
                        let k = next_k.entry(n).or_insert(0);
                        let mut cand = String::new();
                        loop {
                            *k += 1;
                            cand.clear();
                            use std::fmt::Write as _;
                            let _ = write!(cand, "{n}.{k}");
                            if !taken.contains(cand.as_str()) {
                                break;
                            }
                        }
                        line.push(b'.');
                        push_u64(&mut line, *k as u64);
                    }
                }
                line.extend_from_slice(b" (");
                for (i, v) in pieces[start..end].iter().enumerate() {
                    if i > 0 {
                        line.push(b' ');
                    }
                    names.spell(v.0, &mut line, &mut scratch);
                }
                line.push(b')');
                if let Some(m) = material {
                    line.push(b' ');
                    line.extend_from_slice(mat_name(m));
                }
                line.extend_from_slice(b";\n");
                out.write_all(&line)?;
                start = end;
            }
        }
        out.flush()
    }
}
