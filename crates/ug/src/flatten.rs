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

/// How deep instances may nest (an instance of a def that holds an instance of …).
pub const MAX_INSTANCE_DEPTH: usize = 100;

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
        Rx => rotation(DVec3::X, a[0]),
        Ry => rotation(DVec3::Y, a[0]),
        Rz => rotation(DVec3::Z, a[0]),
        Ra => {
            let axis = v3(0);
            if axis.length_squared() == 0.0 {
                DAffine3::IDENTITY
            } else {
                rotation(axis.normalize(), a[3])
            }
        }
        Rv => {
            let v = v3(0);
            let deg = v.length();
            if deg == 0.0 {
                DAffine3::IDENTITY
            } else {
                rotation(v / deg, deg)
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
            // I - 2 n nᵀ / (n·n): exact for axis-aligned and diagonal normals.
            let k = 2.0 / n.length_squared();
            let m = DMat3::IDENTITY - DMat3::from_cols(n * (k * n.x), n * (k * n.y), n * (k * n.z));
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

/// Sine and cosine of an angle in degrees, exact at multiples of 90°
/// (so that `-rz 90` maps grid points to grid points).
fn sin_cos_deg(deg: f64) -> (f64, f64) {
    let r = deg.rem_euclid(360.0);
    if r == 0.0 {
        (0.0, 1.0)
    } else if r == 90.0 {
        (1.0, 0.0)
    } else if r == 180.0 {
        (0.0, -1.0)
    } else if r == 270.0 {
        (-1.0, 0.0)
    } else {
        deg.to_radians().sin_cos()
    }
}

/// Right-handed rotation by `deg` degrees about the unit vector `k` (Rodrigues).
fn rotation(k: DVec3, deg: f64) -> DAffine3 {
    let (s, c) = sin_cos_deg(deg);
    let t = 1.0 - c;
    let m = DMat3::from_cols(
        DVec3::new(
            c + t * k.x * k.x,
            t * k.x * k.y + s * k.z,
            t * k.x * k.z - s * k.y,
        ),
        DVec3::new(
            t * k.x * k.y - s * k.z,
            c + t * k.y * k.y,
            t * k.y * k.z + s * k.x,
        ),
        DVec3::new(
            t * k.x * k.z + s * k.y,
            t * k.y * k.z - s * k.x,
            c + t * k.z * k.z,
        ),
    );
    DAffine3::from_mat3(m)
}

struct Flattener<'m> {
    src: &'m Model,
    out: Model,
    vnames: FxHashSet<String>,
    fnames: FxHashSet<String>,
    unnamed: Vec<u32>,
    limits: FlattenLimits,
    /// What one plain instance of each def creates.
    sizes: Vec<Size>,
}

/// How many vertices, faces and wires some statements create when flattened.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Size {
    vertices: u64,
    faces: u64,
    wires: u64,
}

impl Size {
    fn is_empty(self) -> bool {
        self.vertices == 0 && self.faces == 0 && self.wires == 0
    }
    fn add(self, o: Size) -> Size {
        Size {
            vertices: self.vertices.saturating_add(o.vertices),
            faces: self.faces.saturating_add(o.faces),
            wires: self.wires.saturating_add(o.wires),
        }
    }
    fn times(self, n: u64) -> Size {
        Size {
            vertices: self.vertices.saturating_mul(n),
            faces: self.faces.saturating_mul(n),
            wires: self.wires.saturating_mul(n),
        }
    }
}

fn too_large(limits: &FlattenLimits, s: Size) -> Diagnostic {
    let count = |n: u64| {
        if n == u64::MAX {
            "too many".to_string()
        } else {
            n.to_string()
        }
    };
    Diagnostic::plain(format!(
        "flattening would create {} vertices and {} faces, more than the limit of {} vertices or {} faces; the instances or arrays are too large",
        count(s.vertices),
        count(s.faces),
        limits.max_vertices,
        limits.max_faces
    ))
}

/// The size of `items` flattened, given the size of each def.
fn items_size(m: &Model, items: &[Item], sizes: &[Size]) -> Size {
    let mut s = Size::default();
    for it in items {
        match it {
            Item::Vertex(_) => s.vertices = s.vertices.saturating_add(1),
            Item::Face(_) => s.faces = s.faces.saturating_add(1),
            Item::Wire(_) => s.wires = s.wires.saturating_add(1),
            Item::Instance(i) => {
                let inst = &m.instances[i.idx()];
                let copies = inst.array.as_ref().map_or(1, |a| u64::from(a.count));
                let one = sizes.get(inst.def.idx()).copied().unwrap_or_default();
                s = s.add(one.times(copies));
            }
            _ => {}
        }
    }
    s
}

/// The flattened size of every def. Defs may only instantiate defs that precede
/// them in the parser's output, but a model built in code might not, so a def
/// that (indirectly) instantiates itself is an error here rather than a hang.
fn def_sizes(m: &Model) -> Result<Vec<Size>, Diagnostic> {
    #[derive(Clone, Copy, PartialEq)]
    enum State {
        New,
        Busy,
        Done,
    }
    fn visit(
        m: &Model,
        d: usize,
        state: &mut [State],
        sizes: &mut [Size],
    ) -> Result<(), Diagnostic> {
        // An explicit stack instead of recursion: deep chains of defs cannot overflow it.
        let mut stack: Vec<(usize, bool)> = vec![(d, false)];
        while let Some((d, children_done)) = stack.pop() {
            if children_done {
                sizes[d] = items_size(m, &m.defs[d].items, sizes);
                state[d] = State::Done;
                continue;
            }
            match state[d] {
                State::Done => continue,
                State::Busy => {
                    return Err(Diagnostic::plain(format!(
                        "def '{}' instantiates itself",
                        m.defs[d].name
                    )));
                }
                State::New => {}
            }
            state[d] = State::Busy;
            stack.push((d, true));
            for it in &m.defs[d].items {
                if let Item::Instance(i) = it {
                    let c = m.instances[i.idx()].def.idx();
                    match state.get(c) {
                        Some(State::New) => stack.push((c, false)),
                        Some(State::Busy) => {
                            return Err(Diagnostic::plain(format!(
                                "def '{}' instantiates itself",
                                m.defs[c].name
                            )));
                        }
                        _ => {}
                    }
                }
            }
        }
        Ok(())
    }
    let mut state = vec![State::New; m.defs.len()];
    let mut sizes = vec![Size::default(); m.defs.len()];
    for d in 0..m.defs.len() {
        visit(m, d, &mut state, &mut sizes)?;
    }
    Ok(sizes)
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
        // Count what flattening would create before creating any of it, so that
        // an instance bomb (arrays of arrays of …) is refused without allocating it.
        let sizes = def_sizes(self)?;
        let total = items_size(self, &self.items, &sizes);
        if total.vertices > limits.max_vertices as u64 || total.faces > limits.max_faces as u64 {
            return Err(too_large(&limits, total));
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
            sizes,
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
        f.expand(&self.items, DAffine3::IDENTITY, None, None, 0)?;
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
            let s = Size {
                vertices: self.out.vertices.len() as u64,
                faces: self.out.faces.len() as u64,
                wires: self.out.wires.len() as u64,
            };
            return Err(too_large(&self.limits, s));
        }
        Ok(())
    }

    /// Emits the materials defined inside a def (materials are global), and
    /// those of the defs nested in it.
    fn hoist_materials(&mut self, items: &[Item]) {
        for it in items {
            match it {
                Item::Material(id) => self.out.items.push(Item::Material(*id)),
                Item::Def(d) => {
                    let src = self.src;
                    self.hoist_materials(&src.defs[d.idx()].items);
                }
                _ => {}
            }
        }
    }

    /// Emits the statements `items` (top level when `top`), transformed by `m`.
    fn expand(
        &mut self,
        items: &[Item],
        m: DAffine3,
        prefix: Option<&str>,
        color: Option<MaterialId>,
        depth: usize,
    ) -> Result<(), Diagnostic> {
        let src = self.src;
        let top = depth == 0;
        if depth > MAX_INSTANCE_DEPTH {
            return Err(Diagnostic::plain(format!(
                "instances nested more than {MAX_INSTANCE_DEPTH} deep (at '{}')",
                prefix.unwrap_or("")
            )));
        }
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
                    let pos = m.transform_point3(sv.pos);
                    if !pos.is_finite() {
                        return Err(Diagnostic::plain(format!(
                            "flattening moves vertex '{name}' to a non-finite position (the instance transforms overflow)"
                        )));
                    }
                    let id = VertexId(self.out.vertices.len() as u32);
                    self.out.vertices.push(Vertex {
                        name,
                        pos,
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
                    if self.sizes[inst.def.idx()].is_empty() {
                        // Nothing to create (only comments, lights, … or nothing at all).
                        continue;
                    }
                    let base = name_of(prefix, &base);
                    let own = transform_matrix(&inst.transforms);
                    let col = inst.color.or(color);
                    match &inst.array {
                        None => self.expand(&def.items, m * own, Some(&base), col, depth + 1)?,
                        Some(a) => {
                            let step = transform_matrix(&a.step);
                            let mut acc = own;
                            for k in 0..a.count {
                                let p = format!("{base}.{k}");
                                self.expand(&def.items, m * acc, Some(&p), col, depth + 1)?;
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
                Item::Def(d) => {
                    if top {
                        self.hoist_materials(&src.defs[d.idx()].items);
                    }
                }
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
