//! Expanding `def` instances and arrays into plain top-level geometry.

use glam::{DAffine3, DMat3, DVec3};
use rustc_hash::FxHashSet;

use crate::error::Diagnostic;
use crate::model::*;

/// Guards against instance bombs (arrays of arrays of …).
#[derive(Clone, Copy, Debug)]
pub struct FlattenLimits {
    pub max_vertices: usize,
    pub max_faces: usize,
}

impl Default for FlattenLimits {
    fn default() -> Self {
        FlattenLimits {
            max_vertices: 50_000_000,
            max_faces: 50_000_000,
        }
    }
}

/// The affine map of a transform list; flags apply left to right.
pub fn transform_matrix(ts: &[Transform]) -> DAffine3 {
    ts.iter()
        .fold(DAffine3::IDENTITY, |acc, t| op_matrix(t) * acc)
}

fn op_matrix(t: &Transform) -> DAffine3 {
    use TransformOp::*;
    let a = &t.args;
    let v3 = |k: usize| DVec3::new(a[k], a[k + 1], a[k + 2]);
    match t.op {
        Sx => DAffine3::from_scale(DVec3::new(a[0], 1.0, 1.0)),
        Sy => DAffine3::from_scale(DVec3::new(1.0, a[0], 1.0)),
        Sz => DAffine3::from_scale(DVec3::new(1.0, 1.0, a[0])),
        Sa => DAffine3::from_scale(DVec3::splat(a[0])),
        Sv => DAffine3::from_scale(v3(0)),
        Tx => DAffine3::from_translation(DVec3::new(a[0], 0.0, 0.0)),
        Ty => DAffine3::from_translation(DVec3::new(0.0, a[0], 0.0)),
        Tz => DAffine3::from_translation(DVec3::new(0.0, 0.0, a[0])),
        Ta => DAffine3::from_translation(v3(0)),
        Rx => DAffine3::from_rotation_x(a[0].to_radians()),
        Ry => DAffine3::from_rotation_y(a[0].to_radians()),
        Rz => DAffine3::from_rotation_z(a[0].to_radians()),
        Ra => {
            let axis = v3(0);
            if axis.length_squared() == 0.0 {
                DAffine3::IDENTITY
            } else {
                DAffine3::from_axis_angle(axis.normalize(), a[3].to_radians())
            }
        }
        Rv => {
            let v = v3(0);
            let deg = v.length();
            if deg == 0.0 {
                DAffine3::IDENTITY
            } else {
                DAffine3::from_axis_angle(v / deg, deg.to_radians())
            }
        }
        Mx => DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0)),
        My => DAffine3::from_scale(DVec3::new(1.0, -1.0, 1.0)),
        Mz => DAffine3::from_scale(DVec3::new(1.0, 1.0, -1.0)),
        Ma => DAffine3::from_scale(DVec3::splat(-1.0)),
        Mv => {
            let n = v3(0);
            if n.length_squared() == 0.0 {
                return DAffine3::IDENTITY;
            }
            let n = n.normalize();
            let m = DMat3::IDENTITY - 2.0 * DMat3::from_cols(n * n.x, n * n.y, n * n.z);
            DAffine3::from_mat3(m)
        }
        M3 => DAffine3::from_mat3(DMat3::from_cols_array(&[
            a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8],
        ])),
        M4 => {
            let w = a[15];
            let m =
                DMat3::from_cols_array(&[a[0], a[4], a[8], a[1], a[5], a[9], a[2], a[6], a[10]])
                    * (1.0 / w);
            DAffine3::from_mat3_translation(m, DVec3::new(a[3], a[7], a[11]) / w)
        }
    }
}

struct Flattener<'m> {
    src: &'m Model,
    out: Model,
    vnames: FxHashSet<String>,
    fnames: FxHashSet<String>,
    unnamed: Vec<u32>,
    limits: FlattenLimits,
}

impl Model {
    /// Expands every instance and array into plain geometry (default limits).
    /// Defs and instances disappear; materials, comments and other top-level
    /// statements stay in place. See docs/format.md for naming and colours.
    pub fn flatten(&self) -> Result<Model, Diagnostic> {
        self.flatten_with(FlattenLimits::default())
    }

    pub fn flatten_with(&self, limits: FlattenLimits) -> Result<Model, Diagnostic> {
        if self.is_flat() {
            return Ok(self.clone());
        }
        let mut f = Flattener {
            src: self,
            out: Model {
                materials: self.materials.clone(),
                ..Model::default()
            },
            vnames: FxHashSet::default(),
            fnames: FxHashSet::default(),
            unnamed: vec![0; self.defs.len()],
            limits,
        };
        for it in &self.items {
            match it {
                Item::Vertex(v) => {
                    f.vnames.insert(self.vertices[v.idx()].name.clone());
                }
                Item::Face(x) => {
                    if let Some(n) = &self.faces[x.idx()].name {
                        f.fnames.insert(n.clone());
                    }
                }
                Item::Wire(x) => {
                    if let Some(n) = &self.wires[x.idx()].name {
                        f.fnames.insert(n.clone());
                    }
                }
                _ => {}
            }
        }
        f.expand(&self.items, DAffine3::IDENTITY, None, None, true)?;
        Ok(f.out)
    }
}

impl Flattener<'_> {
    fn unique(set: &mut FxHashSet<String>, base: String) -> String {
        if !set.contains(&base) {
            set.insert(base.clone());
            return base;
        }
        let mut k = 2u64;
        loop {
            let cand = format!("{base}.{k}");
            if !set.contains(&cand) {
                set.insert(cand.clone());
                return cand;
            }
            k += 1;
        }
    }

    fn check(&self) -> Result<(), Diagnostic> {
        if self.out.vertices.len() > self.limits.max_vertices
            || self.out.faces.len() > self.limits.max_faces
        {
            return Err(Diagnostic::plain(format!(
                "flattening would create more than {} vertices or {} faces; the instances or arrays are too large",
                self.limits.max_vertices, self.limits.max_faces
            )));
        }
        Ok(())
    }

    /// Emits the statements `items` (top level when `top`), transformed by `m`.
    fn expand(
        &mut self,
        items: &[Item],
        m: DAffine3,
        prefix: Option<&str>,
        color: Option<MaterialId>,
        top: bool,
    ) -> Result<(), Diagnostic> {
        let src = self.src;
        let flip = m.matrix3.determinant() < 0.0;
        let mut map: rustc_hash::FxHashMap<u32, VertexId> = Default::default();
        let mut faces_to_fix: Vec<FaceId> = Vec::new();
        let mut wires_to_fix: Vec<WireId> = Vec::new();
        let name_of = |p: Option<&str>, n: &str| match p {
            Some(p) => format!("{p}.{n}"),
            None => n.to_string(),
        };
        for it in items {
            match it {
                Item::Vertex(v) => {
                    let sv = &src.vertices[v.idx()];
                    let name = if top {
                        sv.name.clone()
                    } else {
                        Self::unique(&mut self.vnames, name_of(prefix, &sv.name))
                    };
                    let id = VertexId(self.out.vertices.len() as u32);
                    self.out.vertices.push(Vertex {
                        name,
                        pos: m.transform_point3(sv.pos),
                        color: sv.color,
                    });
                    self.out.items.push(Item::Vertex(id));
                    map.insert(v.0, id);
                    self.check()?;
                }
                Item::Face(x) => {
                    let sf = &src.faces[x.idx()];
                    let name = match (&sf.name, top) {
                        (Some(n), true) => Some(n.clone()),
                        (Some(n), false) => {
                            Some(Self::unique(&mut self.fnames, name_of(prefix, n)))
                        }
                        (None, _) => None,
                    };
                    let mut contours = sf.contours.clone();
                    if flip {
                        for c in &mut contours {
                            c[1..].reverse();
                        }
                    }
                    let id = self.out.add_face(Face {
                        name,
                        contours,
                        material: sf.material.or(color),
                    });
                    faces_to_fix.push(id);
                    self.check()?;
                }
                Item::Wire(x) => {
                    let sw = &src.wires[x.idx()];
                    let name = match (&sw.name, top) {
                        (Some(n), true) => Some(n.clone()),
                        (Some(n), false) => {
                            Some(Self::unique(&mut self.fnames, name_of(prefix, n)))
                        }
                        (None, _) => None,
                    };
                    let id = WireId(self.out.wires.len() as u32);
                    self.out.wires.push(Wire {
                        name,
                        polylines: sw.polylines.clone(),
                        material: sw.material.or(color),
                    });
                    self.out.items.push(Item::Wire(id));
                    wires_to_fix.push(id);
                }
                Item::Instance(i) => {
                    let inst = &src.instances[i.idx()];
                    let def = &src.defs[inst.def.idx()];
                    let base = match &inst.name {
                        Some(n) => n.clone(),
                        None => {
                            self.unnamed[inst.def.idx()] += 1;
                            format!("{}{}", def.name, self.unnamed[inst.def.idx()])
                        }
                    };
                    let base = name_of(prefix, &base);
                    let own = crate::flatten::transform_matrix(&inst.transforms);
                    let col = inst.color.or(color);
                    match &inst.array {
                        None => self.expand(&def.items, m * own, Some(&base), col, false)?,
                        Some(a) => {
                            let step = transform_matrix(&a.step);
                            let mut acc = own;
                            for k in 0..a.count {
                                let p = format!("{base}.{k}");
                                self.expand(&def.items, m * acc, Some(&p), col, false)?;
                                acc = step * acc;
                            }
                        }
                    }
                }
                Item::Material(id) => {
                    if top {
                        self.out.items.push(Item::Material(*id));
                    }
                }
                Item::Def(_) => {}
                other => {
                    // Comments, lights, cameras, escapes and unknown statements
                    // stay at the top level; inside defs they are dropped.
                    if top {
                        self.out.items.push(other.clone());
                    }
                }
            }
        }
        for f in faces_to_fix {
            for c in &mut self.out.faces[f.idx()].contours {
                for v in c.iter_mut() {
                    *v = map[&v.0];
                }
            }
        }
        for w in wires_to_fix {
            for c in &mut self.out.wires[w.idx()].polylines {
                for v in c.iter_mut() {
                    *v = map[&v.0];
                }
            }
        }
        Ok(())
    }
}
