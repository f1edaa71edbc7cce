//! The current mesh as a UniGrafix model.

use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Face, Item, Model, Vertex, VertexId};

use crate::{Mesh, NONE, VertId};

impl Mesh {
    /// The mesh as a model: the anchored pieces of every leaf as faces.
    ///
    /// * `src` must be the model the mesh was built from. Its materials are
    ///   copied (same ids), and its comments, lights, cameras, escapes,
    ///   includes and unknown statements are kept in order; its vertices,
    ///   faces and wires are replaced (wires are dropped).
    /// * Vertex `k` of the result is mesh vertex `VertId(k)` (so callers can
    ///   set colours by vertex id). A surface's copy of an input vertex keeps
    ///   the input name (and colour) in the first surface that uses it; other
    ///   surfaces' copies are named `NAME.k`; a vertex made by a split is
    ///   named after its first parent, `PARENT.k`, with the first `k ≥ 1`
    ///   that no input vertex and no earlier vertex uses.
    /// * Faces follow patch order, each patch's leaves depth first, each
    ///   leaf's anchored pieces in order, with the patch face's material. A
    ///   patch that is still one piece keeps its face's name; otherwise its
    ///   pieces are named `NAME.1`, `NAME.2`, … skipping names in use; unnamed
    ///   patches give unnamed faces.
    pub fn to_model(&self, src: &Model) -> Model {
        let mut out = Model {
            materials: src.materials.clone(),
            ..Model::default()
        };
        for it in &src.items {
            match it {
                Item::Material(_)
                | Item::Comment(_)
                | Item::Light(_)
                | Item::Camera(_)
                | Item::Include(_)
                | Item::Escape(_)
                | Item::Unknown(_) => out.items.push(it.clone()),
                Item::Vertex(_)
                | Item::Face(_)
                | Item::Wire(_)
                | Item::Def(_)
                | Item::Instance(_) => {}
            }
        }

        // Vertices.
        let mut taken: FxHashSet<String> = src.vertices.iter().map(|v| v.name.clone()).collect();
        let nv = self.pos.len();
        let mut names: Vec<String> = Vec::with_capacity(nv);
        let mut count = vec![0u32; nv];
        let mut first_copy: FxHashMap<u32, u32> = FxHashMap::default();
        let mut derive = |base: usize, names: &[String], count: &mut [u32]| loop {
            count[base] += 1;
            let cand = format!("{}.{}", names[base], count[base]);
            if !taken.contains(&cand) {
                taken.insert(cand.clone());
                break cand;
            }
        };
        for v in 0..nv {
            let [a, b] = self.vparent[v];
            let (name, color) = if b == NONE {
                let input = src.vertices.get(a as usize);
                match first_copy.get(&a) {
                    Some(&base) => (
                        derive(base as usize, &names, &mut count),
                        input.and_then(|x| x.color),
                    ),
                    None => {
                        first_copy.insert(a, v as u32);
                        match input {
                            Some(x) => (x.name.clone(), x.color),
                            None => (format!("v{a}"), None),
                        }
                    }
                }
            } else {
                (derive(a as usize, &names, &mut count), None)
            };
            names.push(name.clone());
            out.add_vertex(Vertex {
                name,
                pos: self.pos[v],
                color,
            });
        }

        // Faces.
        let mut taken: FxHashSet<String> = src
            .faces
            .iter()
            .filter_map(|f| f.name.clone())
            .chain(src.wires.iter().filter_map(|w| w.name.clone()))
            .collect();
        let vid = |v: &VertId| VertexId(v.0);
        for p in self.patches() {
            let face = src.faces.get(self.patch_face(p).idx());
            let name = face.and_then(|f| f.name.clone());
            let material = self.patch_material(p);
            let mut pieces: Vec<Vec<VertexId>> = Vec::new();
            for e in self.patch_leaves(p) {
                self.for_each_anchored(e, |q| pieces.push(q.iter().map(vid).collect()));
            }
            let whole = pieces.len() == 1;
            let mut k = 0;
            for contour in pieces {
                let name = name.as_ref().map(|n| {
                    if whole {
                        return n.clone();
                    }
                    loop {
                        k += 1;
                        let cand = format!("{n}.{k}");
                        if !taken.contains(&cand) {
                            taken.insert(cand.clone());
                            break cand;
                        }
                    }
                });
                out.add_face(Face {
                    name,
                    contours: vec![contour],
                    material,
                });
            }
        }
        out
    }
}
