//! The in-memory form of a UniGrafix file.
//!
//! Entities live in arenas indexed by typed ids; `items` (and each `Def`'s
//! `items`) keep the statement order, so that writing a parsed model gives
//! back the same statements in the same order.

use glam::DVec3;

macro_rules! id_type {
    ($(#[$m:meta])* $name:ident) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(pub u32);
        impl $name {
            #[inline]
            pub fn idx(self) -> usize {
                self.0 as usize
            }
        }
    };
}

id_type!(
    /// Index into `Model::materials`.
    MaterialId
);
id_type!(
    /// Index into `Model::vertices`.
    VertexId
);
id_type!(
    /// Index into `Model::faces`.
    FaceId
);
id_type!(
    /// Index into `Model::wires`.
    WireId
);
id_type!(
    /// Index into `Model::defs`.
    DefId
);
id_type!(
    /// Index into `Model::instances`.
    InstanceId
);

/// How a material was written.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialDef {
    /// `c_rgb NAME r g b;` — a diffuse reflectance.
    Rgb([f64; 3]),
    /// `c NAME lightness [hue [saturation [translucency]]];` (hue in degrees).
    Lhs(Vec<f64>),
    /// `defmat NAME; … end;`
    Defmat(Defmat),
}

/// The properties of a `defmat` block.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Defmat {
    pub diffuse: Option<[f64; 3]>,
    pub emission: Option<[f64; 3]>,
    /// Properties this toolkit does not interpret: keyword and its words, in order.
    pub other: Vec<(String, Vec<String>)>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub def: MaterialDef,
}

impl Material {
    /// Diffuse reflectance ρ per channel (see docs/format.md for `c`).
    pub fn diffuse(&self) -> [f64; 3] {
        match &self.def {
            MaterialDef::Rgb(c) => *c,
            MaterialDef::Lhs(v) => lhs_to_rgb(v),
            MaterialDef::Defmat(d) => d.diffuse.unwrap_or([0.0; 3]),
        }
    }

    /// Emitted exitance E per channel (zero for everything but `defmat` with `emission_rgb`).
    pub fn emission(&self) -> [f64; 3] {
        match &self.def {
            MaterialDef::Defmat(d) => d.emission.unwrap_or([0.0; 3]),
            _ => [0.0; 3],
        }
    }

    pub fn is_emitter(&self) -> bool {
        self.emission().iter().any(|&e| e > 0.0)
    }
}

/// Converts UniGrafix `c` values (lightness, hue in degrees, saturation) to RGB.
/// Missing values default to hue 0 and saturation 0 (grey); translucency is ignored.
pub fn lhs_to_rgb(v: &[f64]) -> [f64; 3] {
    let l = v.first().copied().unwrap_or(0.0).clamp(0.0, 1.0);
    let h = v.get(1).copied().unwrap_or(0.0).rem_euclid(360.0);
    let s = v.get(2).copied().unwrap_or(0.0).clamp(0.0, 1.0);
    // HSL to RGB.
    let c = (1.0 - (2.0 * l - 1.0).abs()) * s;
    let hp = h / 60.0;
    let x = c * (1.0 - (hp.rem_euclid(2.0) - 1.0).abs());
    let (r, g, b) = match hp as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = l - c / 2.0;
    [r + m, g + m, b + m]
}

#[derive(Clone, Debug, PartialEq)]
pub struct Vertex {
    pub name: String,
    pub pos: DVec3,
    pub color: Option<MaterialId>,
}

/// A face: outer contour first, then holes (clockwise) and islands (counter-clockwise).
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    pub name: Option<String>,
    pub contours: Vec<Vec<VertexId>>,
    pub material: Option<MaterialId>,
}

/// A wire: one or more open polylines.
#[derive(Clone, Debug, PartialEq)]
pub struct Wire {
    pub name: Option<String>,
    pub polylines: Vec<Vec<VertexId>>,
    pub material: Option<MaterialId>,
}

/// `def NAME; … end;` — its statements, in order, referring to the model's arenas.
#[derive(Clone, Debug, PartialEq)]
pub struct Def {
    pub name: String,
    pub items: Vec<Item>,
}

/// A transform flag of an instance or array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransformOp {
    Sx,
    Sy,
    Sz,
    Sa,
    Sv,
    Tx,
    Ty,
    Tz,
    Ta,
    Rx,
    Ry,
    Rz,
    Ra,
    Rv,
    Mx,
    My,
    Mz,
    Ma,
    Mv,
    M3,
    M4,
}

impl TransformOp {
    pub const ALL: [TransformOp; 21] = [
        TransformOp::Sx,
        TransformOp::Sy,
        TransformOp::Sz,
        TransformOp::Sa,
        TransformOp::Sv,
        TransformOp::Tx,
        TransformOp::Ty,
        TransformOp::Tz,
        TransformOp::Ta,
        TransformOp::Rx,
        TransformOp::Ry,
        TransformOp::Rz,
        TransformOp::Ra,
        TransformOp::Rv,
        TransformOp::Mx,
        TransformOp::My,
        TransformOp::Mz,
        TransformOp::Ma,
        TransformOp::Mv,
        TransformOp::M3,
        TransformOp::M4,
    ];

    pub fn flag(self) -> &'static str {
        use TransformOp::*;
        match self {
            Sx => "-sx",
            Sy => "-sy",
            Sz => "-sz",
            Sa => "-sa",
            Sv => "-sv",
            Tx => "-tx",
            Ty => "-ty",
            Tz => "-tz",
            Ta => "-ta",
            Rx => "-rx",
            Ry => "-ry",
            Rz => "-rz",
            Ra => "-ra",
            Rv => "-rv",
            Mx => "-mx",
            My => "-my",
            Mz => "-mz",
            Ma => "-ma",
            Mv => "-mv",
            M3 => "-M3",
            M4 => "-M4",
        }
    }

    pub fn from_flag(s: &[u8]) -> Option<Self> {
        Self::ALL.into_iter().find(|op| op.flag().as_bytes() == s)
    }

    /// How many numbers follow the flag.
    pub fn arity(self) -> usize {
        use TransformOp::*;
        match self {
            Sx | Sy | Sz | Sa | Tx | Ty | Tz | Rx | Ry | Rz => 1,
            Sv | Ta | Rv | Mv => 3,
            Ra => 4,
            Mx | My | Mz | Ma => 0,
            M3 => 9,
            M4 => 16,
        }
    }
}

/// One transform flag with its numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Transform {
    pub op: TransformOp,
    pub args: Vec<f64>,
}

/// `a` arrays: `count` copies, copy k transformed by the instance transform, then `step` k times.
#[derive(Clone, Debug, PartialEq)]
pub struct ArraySpec {
    pub count: u32,
    pub step: Vec<Transform>,
}

/// `i [NAME] (DEF [COLOR] transforms);` or `a [NAME] (DEF [COLOR] transforms) N transforms;`
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub name: Option<String>,
    pub def: DefId,
    pub color: Option<MaterialId>,
    pub transforms: Vec<Transform>,
    pub array: Option<ArraySpec>,
}

/// A statement kept verbatim (normalised spacing): lights, cameras, unknown keywords.
#[derive(Clone, Debug, PartialEq)]
pub struct Raw {
    pub keyword: String,
    /// The words between the keyword and the `;`, joined by single spaces.
    pub text: String,
}

/// One statement, in file order.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    /// `{ … }` between statements (the text between the outer braces).
    Comment(String),
    Material(MaterialId),
    Vertex(VertexId),
    Face(FaceId),
    Wire(WireId),
    Def(DefId),
    Instance(InstanceId),
    /// `l NAME …;`
    Light(Raw),
    /// `cam NAME …;`
    Camera(Raw),
    /// `include FILE;` kept unresolved (only when parsing with includes kept).
    Include(String),
    /// `( … )` escape (the text between the outer parentheses).
    Escape(String),
    /// A statement with an unknown keyword, passed through.
    Unknown(Raw),
}

/// A parsed UniGrafix file.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Model {
    pub materials: Vec<Material>,
    pub vertices: Vec<Vertex>,
    pub faces: Vec<Face>,
    pub wires: Vec<Wire>,
    pub defs: Vec<Def>,
    pub instances: Vec<Instance>,
    /// Top-level statements in order.
    pub items: Vec<Item>,
}

impl Model {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn vertex(&self, v: VertexId) -> &Vertex {
        &self.vertices[v.idx()]
    }
    pub fn face(&self, f: FaceId) -> &Face {
        &self.faces[f.idx()]
    }
    pub fn material(&self, m: MaterialId) -> &Material {
        &self.materials[m.idx()]
    }
    pub fn pos(&self, v: VertexId) -> DVec3 {
        self.vertices[v.idx()].pos
    }

    /// The material with this name, if any.
    pub fn material_by_name(&self, name: &str) -> Option<MaterialId> {
        self.materials
            .iter()
            .position(|m| m.name == name)
            .map(|i| MaterialId(i as u32))
    }

    /// True when the model has no `def`, instance or array (geometry is all top-level).
    pub fn is_flat(&self) -> bool {
        self.defs.is_empty() && self.instances.is_empty()
    }

    /// Faces reachable from the top level, in statement order (for a flat model: all faces).
    pub fn top_faces(&self) -> impl Iterator<Item = FaceId> + '_ {
        self.items.iter().filter_map(|it| match it {
            Item::Face(f) => Some(*f),
            _ => None,
        })
    }

    /// Vertices defined at the top level, in statement order.
    pub fn top_vertices(&self) -> impl Iterator<Item = VertexId> + '_ {
        self.items.iter().filter_map(|it| match it {
            Item::Vertex(v) => Some(*v),
            _ => None,
        })
    }

    /// Appends a material statement and returns its id.
    pub fn add_material(&mut self, m: Material) -> MaterialId {
        let id = MaterialId(self.materials.len() as u32);
        self.materials.push(m);
        self.items.push(Item::Material(id));
        id
    }

    /// Appends a vertex statement and returns its id.
    pub fn add_vertex(&mut self, v: Vertex) -> VertexId {
        let id = VertexId(self.vertices.len() as u32);
        self.vertices.push(v);
        self.items.push(Item::Vertex(id));
        id
    }

    /// Appends a face statement and returns its id.
    pub fn add_face(&mut self, f: Face) -> FaceId {
        let id = FaceId(self.faces.len() as u32);
        self.faces.push(f);
        self.items.push(Item::Face(id));
        id
    }

    /// Bounding box (min, max) of the top-level vertices, or `None` when there are none.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut it = self.top_vertices().map(|v| self.pos(v));
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }
}
