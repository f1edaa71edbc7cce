//! The element meshing library (§3.2 of the seed report): balanced, anchored
//! quadtrees over the triangle and convex-quadrilateral patches that `ugcut`
//! produces, stitched across surface boundaries. The radiosity solver builds a
//! [`Mesh`] from the patch model, [`Mesh::split`]s elements where the
//! radiosity gradient is steep, and writes the result with [`Mesh::to_model`].
//!
//! ```
//! let src = b"c_rgb grey 0.5 0.5 0.5;
//!     v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;
//!     f floor (a b c d) grey;";
//! let model = ug::parse(src, "<doc>").unwrap().model;
//! let mut mesh = libmesh::Mesh::from_model(&model, 1e-9).unwrap();
//! let root = mesh.patch_leaves(libmesh::PatchId(0))[0];
//! let split = mesh.split(root);
//! assert_eq!(split.refined, vec![root]);
//! assert_eq!(split.new_vertices.len(), 5); // four edge midpoints and the centre
//! assert_eq!(mesh.leaves().count(), 4);
//! mesh.validate().unwrap();
//! let out = mesh.to_model(&model);
//! assert_eq!(out.faces.len(), 4);
//! ```
//!
//! # Hierarchy
//!
//! * A **surface** is a maximal set of patches connected through shared edges
//!   that are coplanar (within the build epsilon), of the same material and
//!   orientation, and that no face out of their plane also uses (the foot of
//!   a wall standing between two floor pieces separates them: light is
//!   discontinuous there). Each surface has its own copy of every vertex it
//!   uses (a corner shared by a floor and a wall exists twice, once per
//!   surface, since each copy carries its surface's normal and, in the
//!   solver, its own value), and one copy per *sector* of a point: the
//!   corners at that point connected through joined edges. A floor joined
//!   around a partition's free end (or through a doorway) is one surface,
//!   but the points on the partition's foot have one copy per side.
//! * Each vertex on its surface's boundary (outline, holes, and edges that
//!   other faces use) has a **receiver point** a hair inside its surface
//!   ([`Mesh::receiver_pos`]), where the solver evaluates what it sees.
//! * A **patch** is one input face: a triangle or a convex quadrilateral. It is
//!   the root element of a quadtree.
//! * An **element** is a node of a patch's quadtree. Splitting puts a vertex
//!   at the midpoint of each edge (and, for a quadrilateral, one at its
//!   centre) and makes four children of the same shape:
//!
//!   ```text
//!    quad  v3──m2──v2         triangle     v2
//!          │ c3 │ c2 │                     / c2\
//!          m3───C───m1                   m2────m1
//!          │ c0 │ c1 │                  / c0\c3/c1\
//!          v0──m0──v1                  v0────m0────v1
//!   ```
//!
//!   Child `c` of a corner keeps corner `c` of its parent at its own corner
//!   index `c`; the triangle's centre child `c3` is `(m1, m2, m0)`.
//!   Corner order (and so the front side) is the parent's.
//!
//! # Storage
//!
//! Everything lives in flat arenas indexed by dense `u32` ids that are never
//! reused: elements are 32-byte records (corners, parent, first child, patch,
//! level, and which patch edge each element edge lies on) with the four
//! children of a split at consecutive ids, and no per-element heap
//! allocation. Vertices are a position, a surface, two parent ids and the
//! step to the receiver point (48 bytes). Edge midpoints are found through one hash table of vertex ids keyed
//! by the edge's two vertex ids (smaller first; the key is not stored: it is
//! the midpoint's parents), which is also how a leaf finds the hanging
//! midpoints and stitched vertices on its edges. Patch roots are elements
//! `0..num_patches`, so `ElemId(p)` is the root of `PatchId(p)`. Callers keep
//! per-vertex data (irradiance, radiosity) in their own flat arrays indexed by
//! [`VertId`]; [`Split::new_vertices`] says which entries to append.
//!
//! # Balance
//!
//! No leaf is two or more levels deeper than a leaf sharing (part of) an edge
//! with it, inside a surface, across patch boundaries too. Splitting a leaf
//! at level `L` first splits, recursively, every edge neighbour at level
//! `L - 1` (report figure 10). Neighbours are found by walking up the tree to
//! the ancestor whose edge carries the queried edge and back down the
//! neighbour's tree (across patches through the patch adjacency built from
//! shared edges), so no neighbour pointers are stored.
//!
//! # Anchoring
//!
//! A leaf whose edge carries vertices of finer neighbours (hanging midpoints)
//! or stitched vertices is presented by [`Mesh::anchored`] as triangles and
//! convex quadrilaterals that use exactly the leaf's corners and those
//! vertices, tile the leaf and have no T-vertex (report figure 11). With
//! `m_k` the vertex on edge `k` (from corner `k` to corner `k + 1`), indices
//! taken cyclically, the decomposition of a leaf with at most one vertex per
//! edge is:
//!
//! | leaf | vertices on edges | pieces |
//! |------|-------------------|--------|
//! | quad | none | the quad |
//! | quad | edge k | triangles fanned from `m_k`: `(m_k v_k+1 v_k+2)`, `(m_k v_k+2 v_k+3)`, `(m_k v_k+3 v_k)` |
//! | quad | edges k, k+1 | triangles `(m_k v_k+1 m_k+1)`, `(m_k+1 v_k+2 v_k+3)`, quad `(v_k m_k m_k+1 v_k+3)` |
//! | quad | edges k, k+2 | quads `(v_k m_k m_k+2 v_k+3)`, `(m_k v_k+1 v_k+2 m_k+2)` |
//! | quad | all but k+3 | triangles `(m_k v_k+1 m_k+1)`, `(m_k+1 v_k+2 m_k+2)`, `(m_k m_k+1 m_k+2)`, quad `(v_k m_k m_k+2 v_k+3)` |
//! | quad | all four | corner triangles `(m_k-1 v_k m_k)` and the quad `(m_0 m_1 m_2 m_3)` |
//! | triangle | none | the triangle |
//! | triangle | edge k | `(m_k v_k+1 v_k+2)`, `(m_k v_k+2 v_k)` |
//! | triangle | edges k+1, k+2 | triangle `(m_k+1 v_k+2 m_k+2)`, quad `(v_k v_k+1 m_k+1 m_k+2)` |
//! | triangle | all three | the four triangles a split would make |
//!
//! Balance guarantees at most one vertex per edge where no other surface
//! meets the edge (a single stitched vertex also takes the table). Stitching
//! can put any number of vertices on an edge at a surface boundary; such a leaf
//! is triangulated by a zipper between the two chains of its boundary running
//! from one corner to the opposite one (each step adds the triangle whose new
//! diagonal is shorter), and consecutive triangles that form a strictly convex
//! quadrilateral are merged. Both decompositions use only the leaf's boundary
//! vertices, so all pieces are triangles or convex quads with no T-vertex.
//!
//! # Stitching
//!
//! Surfaces do not share vertices, so balance stops at surface boundaries.
//! When a split creates a vertex on a patch edge that another surface's patch
//! also has (same end positions; `ugcut` guarantees patch edges match across
//! surfaces), the neighbour surface gets its own copy of the vertex at the same
//! position, registered as the midpoint of the corresponding dyadic piece of
//! its patch edge; the neighbour's leaf then shows it in its anchored contour
//! instead of being split (report figure 13), and when the neighbour later
//! splits there it reuses that vertex. The copy is reported in
//! [`Split::new_vertices`] with the neighbour surface's own vertices at the
//! ends of that edge piece as parents. Midpoints are computed as
//! `(p + q) / 2` of identical positions on both sides, so copies coincide
//! exactly.
//!
//! # Memory
//!
//! An element is 32 bytes, a vertex 48 (position, surface, parents, receiver step) plus,
//! for an edge midpoint, one hash-table entry (a 4-byte vertex id and a
//! control byte, at most 7/8 full). Uniform refinement of quads makes 4/3 elements and
//! about one vertex per leaf (two thirds of them edge midpoints): measured
//! on a 100 × 100 patch grid refined three levels, 84 bytes of heap per
//! element (112 per leaf), vector growth slack included, before the 12-byte
//! receiver step was added (about one vertex per leaf: some 124 per leaf).
//!
//! # Use from the solver
//!
//! ```text
//! mesh = Mesh::from_model(&patches, eps)?
//! values: Vec<_> sized mesh.num_vertices(), indexed by VertId
//! loop: shoot … ; for e in elements to refine (mesh.elem_longest_edge(e) > min):
//!     split = mesh.split(e)                  // e may have been split by balance already: no-op
//!     for nv in split.new_vertices:          // in id order, parents first
//!         values.push(mean(values[nv.parents]))   // parents: pre-shot values, or set just above
//!     reshoot the current shooter at the new vertices
//! energy of a patch: Σ over mesh.patch_leaves(p), mesh.for_each_anchored(e, …) of mean × area
//! out = mesh.to_model(&patches)               // vertex k is VertId(k): set its colour
//! ```
//!
//! # Determinism
//!
//! Ids are assigned in a fixed order (input face order at build time, then
//! split order); no hash-map iteration reaches any output or id.

use glam::DVec3;

mod anchor;
mod build;
mod output;
pub mod patch;
mod refine;
mod validate;
mod write;

#[cfg(test)]
mod tests;

pub use build::{BuildError, not_patches};
pub use write::{VertexColours, write_in_parallel, write_in_parallel_by};

macro_rules! id_type {
    ($(#[$m:meta])* $name:ident) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[repr(transparent)]
        pub struct $name(pub u32);
        impl $name {
            /// The id as an index into flat arrays.
            #[inline]
            pub fn idx(self) -> usize {
                self.0 as usize
            }
        }
    };
}

id_type!(
    /// A mesh vertex (one surface's copy of a point). Dense, never reused:
    /// new vertices get the next ids.
    VertId
);
id_type!(
    /// An element (a quadtree node). Dense, never reused; `ElemId(p)` is the
    /// root of `PatchId(p)`.
    ElemId
);
id_type!(
    /// A patch: one input face, in the order of the model's top-level faces.
    PatchId
);
id_type!(
    /// A surface: a connected coplanar group of patches.
    SurfaceId
);

/// "No such id" in the `u32` fields.
pub(crate) const NONE: u32 = u32::MAX;
/// `pedge` value of an element edge that lies inside its patch.
pub(crate) const INTERIOR: u16 = 7;

/// Elements at this level are not split further (their size is 2⁻³⁰ of their
/// patch's, far below any useful element size, and well above f64 precision).
pub const MAX_LEVEL: u32 = 30;

/// A split's children are at least this many build epsilons across: an
/// element whose shortest edge or width is below twice this is not split,
/// nor is one whose split would need such an element split first (balance)
/// or would fan a neighbour into triangles narrower than a quarter of it
/// ([`Mesh::can_split`]).
/// Without it a sliver beside a refined element is halved until its edges
/// are below epsilon (zero-length edges in the output).
pub const MIN_CHILD_EPS: f64 = 16.0;

/// One quadtree node: 32 bytes, no heap allocation.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(crate) struct Elem {
    /// Corners, counter-clockwise seen from the front; `v[3]` is `NONE` for a triangle.
    pub v: [VertId; 4],
    /// First of the four consecutive children, `NONE` for a leaf.
    pub children: u32,
    /// `NONE` for a patch root.
    pub parent: u32,
    pub patch: u32,
    /// For each edge k (bits 3k..3k+3): the patch edge it lies on, or `INTERIOR`.
    pub pedge: u16,
    pub level: u8,
}

impl Elem {
    #[inline]
    pub fn n(&self) -> usize {
        if self.v[3].0 == NONE { 3 } else { 4 }
    }
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.children == NONE
    }
    #[inline]
    pub fn pedge(&self, k: usize) -> u16 {
        (self.pedge >> (3 * k)) & 7
    }
}

#[derive(Clone, Debug)]
pub(crate) struct Patch {
    pub surface: u32,
    pub face: ug::FaceId,
    pub area: f64,
    /// For each edge: `q * 4 + j` when edge j of patch q (same surface) is
    /// across it, else `NONE`.
    pub adj: [u32; 4],
}

#[derive(Clone, Debug)]
pub(crate) struct Surface {
    pub normal: DVec3,
    pub material: Option<ug::MaterialId>,
    pub patches: Vec<PatchId>,
}

/// Balanced, anchored, stitched quadtrees over a patch model. See the crate
/// documentation for the structure.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub(crate) pos: Vec<DVec3>,
    pub(crate) vsurf: Vec<u32>,
    /// `[input vertex, NONE]` for a copy of an input vertex, else the two
    /// parent vertices (ends of the edge it was put on; for a quad centre the
    /// midpoints of two opposite edges).
    pub(crate) vparent: Vec<[u32; 2]>,
    /// The step from each vertex to its receiver point (zero inside its
    /// surface; see [`Mesh::receiver_pos`]).
    pub(crate) nudge: Vec<[f32; 3]>,
    /// Edge (smaller vertex id, larger) → the vertex at its midpoint.
    pub(crate) mid: MidMap,
    pub(crate) elems: Vec<Elem>,
    pub(crate) n_leaves: usize,
    pub(crate) patches: Vec<Patch>,
    /// Patch edge `p * 4 + j` has twins `twin_verts[twin_start[i]..twin_start[i + 1]]`:
    /// another surface's copies of its start and end corners.
    pub(crate) twin_start: Vec<u32>,
    pub(crate) twin_verts: Vec<[VertId; 2]>,
    /// Patch edge `p * 4 + j` (on its surface's boundary) is also edge `e & 3`
    /// of patch `e >> 2` for each `e` in
    /// `twin_edge[twin_edge_start[i]..twin_edge_start[i + 1]]`.
    pub(crate) twin_edge_start: Vec<u32>,
    pub(crate) twin_edge: Vec<u32>,
    pub(crate) surfaces: Vec<Surface>,
    /// The epsilon the mesh was built with.
    pub(crate) eps: f64,
    /// Input faces left out as degenerate: (label, reason).
    pub(crate) degenerate: Vec<(String, String)>,
}

/// What a [`Mesh::split`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Split {
    /// Elements that were split: the requested one first, then those balance
    /// forced, in the order they were split. Empty when nothing was split.
    pub refined: Vec<ElemId>,
    /// Every vertex created, in id order (balance and stitching included).
    /// A vertex's parents were created before it or existed already, so
    /// initialising values in this order (each the mean of its parents) gives
    /// edge vertices the mean of their edge's ends and quad centres the mean
    /// of the four corners.
    pub new_vertices: Vec<NewVertex>,
}

impl Split {
    /// Empties both lists, keeping their capacity.
    pub fn clear(&mut self) {
        self.refined.clear();
        self.new_vertices.clear();
    }
}

/// A vertex created by a split.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NewVertex {
    pub v: VertId,
    /// The ends of the edge it was put on, in `v`'s surface. For a stitched
    /// copy these are the neighbour surface's own vertices at the ends of the
    /// edge piece; for a quad centre, the midpoints of edges 0 and 2.
    pub parents: [VertId; 2],
}

/// Where a vertex came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexOrigin {
    /// This surface's copy of an input vertex.
    Input(ug::VertexId),
    /// Created by refinement or stitching, halfway between two vertices.
    Split([VertId; 2]),
}

impl Mesh {
    // ------------------------------------------------------------------
    // Vertices
    // ------------------------------------------------------------------

    pub fn num_vertices(&self) -> usize {
        self.pos.len()
    }

    pub fn vertex_pos(&self, v: VertId) -> DVec3 {
        self.pos[v.idx()]
    }

    /// Where the vertex receives light: its position, or for a vertex on its
    /// surface's boundary (the outline and holes of the surface, and every
    /// edge another face also uses, such as a wall's foot) a point a hair
    /// inside the surface: 10⁻⁴ of the boundary edge it was made on (the
    /// shortest at a corner), at least 10 build epsilons, along the inward
    /// normal of that edge (at a corner, of both). Light is discontinuous
    /// across such an edge, and from the edge itself both sides are seen: a
    /// floor vertex at the foot of a partition wall would see the lamps of
    /// both rooms. Visibility and form factors are evaluated here, so each
    /// copy takes the limit from inside its own surface.
    pub fn receiver_pos(&self, v: VertId) -> DVec3 {
        self.pos[v.idx()] + glam::Vec3::from_array(self.nudge[v.idx()]).as_dvec3()
    }

    /// Whether the vertex's receiver point is not the vertex itself (it
    /// lies on its surface's boundary).
    pub fn receiver_stepped(&self, v: VertId) -> bool {
        self.nudge[v.idx()] != [0.0; 3]
    }

    pub fn vertex_surface(&self, v: VertId) -> SurfaceId {
        SurfaceId(self.vsurf[v.idx()])
    }

    /// The unit front normal of the vertex's surface.
    pub fn vertex_normal(&self, v: VertId) -> DVec3 {
        self.surfaces[self.vsurf[v.idx()] as usize].normal
    }

    /// The ends of the edge a vertex was made on, for a vertex made by a
    /// split (`None` for an input vertex).
    pub fn split_parents(&self, v: VertId) -> Option<[VertId; 2]> {
        match self.vertex_origin(v) {
            VertexOrigin::Split(ab) => Some(ab),
            VertexOrigin::Input(_) => None,
        }
    }

    pub fn vertex_origin(&self, v: VertId) -> VertexOrigin {
        let [a, b] = self.vparent[v.idx()];
        if b == NONE {
            VertexOrigin::Input(ug::VertexId(a))
        } else {
            VertexOrigin::Split([VertId(a), VertId(b)])
        }
    }

    /// The vertex at the midpoint of the edge `a`–`b` (either order), if any.
    pub fn edge_midpoint(&self, a: VertId, b: VertId) -> Option<VertId> {
        self.mid_of(a.0, b.0).map(VertId)
    }

    /// The midpoint vertex of the edge `a`–`b` (either order), if any.
    #[inline]
    pub(crate) fn mid_of(&self, a: u32, b: u32) -> Option<u32> {
        self.mid.get(&self.vparent, key(a, b))
    }

    // ------------------------------------------------------------------
    // Surfaces and patches
    // ------------------------------------------------------------------

    pub fn num_surfaces(&self) -> usize {
        self.surfaces.len()
    }

    pub fn surfaces(&self) -> impl Iterator<Item = SurfaceId> + use<> {
        (0..self.surfaces.len() as u32).map(SurfaceId)
    }

    /// Unit normal on the front side (area-weighted over the surface's patches).
    pub fn surface_normal(&self, s: SurfaceId) -> DVec3 {
        self.surfaces[s.idx()].normal
    }

    pub fn surface_material(&self, s: SurfaceId) -> Option<ug::MaterialId> {
        self.surfaces[s.idx()].material
    }

    /// The surface's patches, in input order.
    pub fn surface_patches(&self, s: SurfaceId) -> &[PatchId] {
        &self.surfaces[s.idx()].patches
    }

    pub fn num_patches(&self) -> usize {
        self.patches.len()
    }

    pub fn patches(&self) -> impl Iterator<Item = PatchId> + use<> {
        (0..self.patches.len() as u32).map(PatchId)
    }

    pub fn patch_surface(&self, p: PatchId) -> SurfaceId {
        SurfaceId(self.patches[p.idx()].surface)
    }

    /// The input face the patch was built from.
    pub fn patch_face(&self, p: PatchId) -> ug::FaceId {
        self.patches[p.idx()].face
    }

    pub fn patch_material(&self, p: PatchId) -> Option<ug::MaterialId> {
        self.surfaces[self.patches[p.idx()].surface as usize].material
    }

    /// The patch's corners (3 or 4), in the face's order.
    pub fn patch_corners(&self, p: PatchId) -> &[VertId] {
        self.elem_corners(self.patch_root(p))
    }

    pub fn patch_area(&self, p: PatchId) -> f64 {
        self.patches[p.idx()].area
    }

    /// The root element of the patch's quadtree (`ElemId(p.0)`).
    pub fn patch_root(&self, p: PatchId) -> ElemId {
        ElemId(p.0)
    }

    /// The patch's leaves, depth first with children in order.
    /// Calls `f` on each leaf element of patch `p`, in the order of
    /// [`Mesh::patch_leaves`] and [`Mesh::leaves`], without allocating.
    #[inline]
    pub fn for_each_patch_leaf(&self, p: PatchId, mut f: impl FnMut(ElemId)) {
        let mut stack = [0u32; 4 * (MAX_LEVEL as usize + 1)];
        let mut sp = 1;
        stack[0] = p.0;
        while sp > 0 {
            sp -= 1;
            let e = stack[sp];
            let el = &self.elems[e as usize];
            if el.is_leaf() {
                f(ElemId(e));
            } else {
                for c in (0..4).rev() {
                    stack[sp] = el.children + c;
                    sp += 1;
                }
            }
        }
    }

    pub fn patch_leaves(&self, p: PatchId) -> Vec<ElemId> {
        let mut out = Vec::new();
        let mut stack = vec![p.0];
        while let Some(e) = stack.pop() {
            let el = &self.elems[e as usize];
            if el.is_leaf() {
                out.push(ElemId(e));
            } else {
                stack.extend((0..4).rev().map(|c| el.children + c));
            }
        }
        out
    }

    // ------------------------------------------------------------------
    // Elements
    // ------------------------------------------------------------------

    /// All elements ever made (leaves and split ones).
    pub fn num_elements(&self) -> usize {
        self.elems.len()
    }

    pub fn num_leaves(&self) -> usize {
        self.n_leaves
    }

    /// All leaves: patch by patch, each depth first with children in order
    /// (the order of [`Mesh::patch_leaves`]).
    pub fn leaves(&self) -> impl Iterator<Item = ElemId> + '_ {
        Leaves {
            mesh: self,
            next_patch: 0,
            stack: Vec::with_capacity(4 * (MAX_LEVEL as usize + 1)),
        }
    }

    /// The element's corners (3 or 4), counter-clockwise seen from the front;
    /// hanging midpoints and stitched vertices are not corners.
    pub fn elem_corners(&self, e: ElemId) -> &[VertId] {
        let el = &self.elems[e.idx()];
        &el.v[..el.n()]
    }

    pub fn elem_patch(&self, e: ElemId) -> PatchId {
        PatchId(self.elems[e.idx()].patch)
    }

    pub fn elem_surface(&self, e: ElemId) -> SurfaceId {
        SurfaceId(self.patches[self.elems[e.idx()].patch as usize].surface)
    }

    /// Depth in its patch's quadtree (a patch root is level 0).
    pub fn elem_level(&self, e: ElemId) -> u32 {
        self.elems[e.idx()].level as u32
    }

    pub fn elem_is_leaf(&self, e: ElemId) -> bool {
        self.elems[e.idx()].is_leaf()
    }

    pub fn elem_parent(&self, e: ElemId) -> Option<ElemId> {
        let p = self.elems[e.idx()].parent;
        (p != NONE).then_some(ElemId(p))
    }

    /// The four children of a split element (child c at corner c; for a
    /// triangle the fourth is the centre one).
    pub fn elem_children(&self, e: ElemId) -> Option<[ElemId; 4]> {
        let c = self.elems[e.idx()].children;
        (c != NONE).then(|| [ElemId(c), ElemId(c + 1), ElemId(c + 2), ElemId(c + 3)])
    }

    /// Area of the element's polygon.
    pub fn elem_area(&self, e: ElemId) -> f64 {
        let el = &self.elems[e.idx()];
        let p = |k: usize| self.pos[el.v[k].idx()];
        if el.n() == 3 {
            0.5 * (p(1) - p(0)).cross(p(2) - p(0)).length()
        } else {
            0.5 * (p(2) - p(0)).cross(p(3) - p(1)).length()
        }
    }

    /// Length of the element's longest edge (between corners).
    pub fn elem_longest_edge(&self, e: ElemId) -> f64 {
        let el = &self.elems[e.idx()];
        let n = el.n();
        (0..n)
            .map(|k| self.pos[el.v[k].idx()].distance(self.pos[el.v[(k + 1) % n].idx()]))
            .fold(0.0, f64::max)
    }

    /// The element's width: the least, over its edges, of the farthest
    /// corner's distance from the edge's line, or its shortest edge when that
    /// is less.
    pub fn elem_width(&self, e: ElemId) -> f64 {
        let el = &self.elems[e.idx()];
        let n = el.n();
        let p = |k: usize| self.pos[el.v[k % n].idx()];
        let mut w = f64::INFINITY;
        for k in 0..n {
            let (a, b) = (p(k), p(k + 1));
            let d = b - a;
            let len = d.length();
            w = w.min(len);
            if len == 0.0 {
                continue;
            }
            let far = (2..n)
                .map(|i| d.cross(p(k + i) - a).length() / len)
                .fold(0.0, f64::max);
            w = w.min(far);
        }
        w
    }

    /// Whether [`Mesh::split`] would split leaf `e`: it is a leaf below
    /// [`MAX_LEVEL`], neither it nor any element balance would split first
    /// is narrower than `2 ×` [`MIN_CHILD_EPS`] build epsilons, and no
    /// midpoint it makes would fan a neighbouring leaf (in its surface, or
    /// across a surface boundary) into output triangles narrower than a
    /// quarter of that.
    pub fn can_split(&self, e: ElemId) -> bool {
        match self.elems.get(e.idx()) {
            Some(el) if el.is_leaf() && (el.level as u32) < MAX_LEVEL => self.splittable(e.0),
            _ => false,
        }
    }

    pub(crate) fn splittable(&self, e: u32) -> bool {
        let floor = MIN_CHILD_EPS * self.eps;
        if self.elem_width(ElemId(e)) < 2.0 * floor {
            return false;
        }
        let el = &self.elems[e as usize];
        let n = el.n();
        let pos = |v: VertId| self.pos[v.idx()];
        let mut along = Vec::new();
        (0..n).all(|k| {
            let (a, b) = (pos(el.v[k]), pos(el.v[(k + 1) % n]));
            let half = 0.5 * a.distance(b);
            match self.across(e, k) {
                Some((q, j)) => {
                    let qe = &self.elems[q as usize];
                    if !qe.is_leaf() {
                        return true;
                    }
                    self.fan_wide_enough(q, j, half, floor)
                        && (qe.level >= el.level || self.splittable(q))
                }
                None => {
                    // On the surface's boundary: the midpoint is stitched
                    // into the other surfaces' patches on this edge.
                    let j = el.pedge(k);
                    if j == INTERIOR {
                        return true;
                    }
                    let t = el.patch as usize * 4 + j as usize;
                    let m = (a + b) * 0.5;
                    let (lo, hi) = (self.twin_edge_start[t], self.twin_edge_start[t + 1]);
                    (lo..hi).all(|i| {
                        let pe = self.twin_edge[i as usize];
                        let (pt, kt) = (pe >> 2, (pe & 3) as usize);
                        along.clear();
                        self.leaves_along(pt, kt, &mut along);
                        along.iter().all(|&q| {
                            let qe = &self.elems[q.idx()];
                            let (qa, qb) = (pos(qe.v[kt]), pos(qe.v[(kt + 1) % qe.n()]));
                            let d = qb - qa;
                            let s = (m - qa).dot(d) / d.length_squared().max(f64::MIN_POSITIVE);
                            !(0.0..=1.0).contains(&s) || self.fan_wide_enough(q.0, kt, half, floor)
                        })
                    })
                }
            }
        })
    }

    /// Whether leaf `q`, given a vertex on its edge `j` at `half` from the
    /// nearest vertex there, still fans into output triangles at least
    /// `floor / 4` wide: half × its apex's height over edge `j` ÷ its
    /// longest edge bounds their width from below.
    fn fan_wide_enough(&self, q: u32, j: usize, half: f64, floor: f64) -> bool {
        let qe = &self.elems[q as usize];
        let m = qe.n();
        let pos = |v: VertId| self.pos[v.idx()];
        let (a, b) = (pos(qe.v[j]), pos(qe.v[(j + 1) % m]));
        let d = (b - a).normalize_or_zero();
        let apex = (2..m)
            .map(|i| d.cross(pos(qe.v[(j + i) % m]) - a).length())
            .fold(f64::INFINITY, f64::min);
        half * apex >= 0.25 * floor * self.elem_longest_edge(ElemId(q))
    }

    /// Mean of the element's corners.
    pub fn elem_centroid(&self, e: ElemId) -> DVec3 {
        let c = self.elem_corners(e);
        c.iter().map(|v| self.pos[v.idx()]).sum::<DVec3>() / c.len() as f64
    }

    /// The leaves sharing (part of) an edge with this element, inside its
    /// surface: edge by edge, along each edge; no duplicates.
    pub fn elem_neighbors(&self, e: ElemId) -> Vec<ElemId> {
        let mut out = Vec::new();
        let n = self.elems[e.idx()].n();
        for k in 0..n {
            if let Some((q, j)) = self.across(e.0, k) {
                self.leaves_along(q, j, &mut out);
            }
        }
        let mut seen: Vec<ElemId> = Vec::with_capacity(out.len());
        for x in out {
            if !seen.contains(&x) {
                seen.push(x);
            }
        }
        seen
    }

    /// Input faces [`Mesh::from_model`] left out as degenerate (zero area, or
    /// two corners within epsilon): (label, reason), in input order.
    pub fn degenerate_faces(&self) -> &[(String, String)] {
        &self.degenerate
    }

    /// The epsilon the mesh was built with.
    pub fn epsilon(&self) -> f64 {
        self.eps
    }

    /// Approximate heap memory held by the mesh, in bytes.
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.pos.capacity() * size_of::<DVec3>()
            + self.vsurf.capacity() * 4
            + self.vparent.capacity() * 8
            + self.nudge.capacity() * 12
            + self.elems.capacity() * size_of::<Elem>()
            // hashbrown: one entry plus one control byte per bucket.
            + self.mid.capacity() * 8 / 7 * (size_of::<u32>() + 1)
            + self.patches.capacity() * size_of::<Patch>()
            + self.twin_start.capacity() * 4
            + self.twin_verts.capacity() * 8
            + self.twin_edge_start.capacity() * 4
            + self.twin_edge.capacity() * 4
            + self
                .surfaces
                .iter()
                .map(|s| size_of::<Surface>() + s.patches.capacity() * 4)
                .sum::<usize>()
    }

    /// Number of edge-midpoint map entries (edge midpoints and stitched vertices).
    pub fn num_edge_midpoints(&self) -> usize {
        self.mid.len()
    }

    /// Bytes of the fixed-size records: (per element, per vertex, per midpoint-map entry).
    pub fn record_sizes() -> (usize, usize, usize) {
        use std::mem::size_of;
        (
            size_of::<Elem>(),
            size_of::<DVec3>() + 4 + 8 + 12,
            size_of::<u32>() + 1,
        )
    }
}

/// Hash-map key of an undirected edge.
#[inline]
pub(crate) fn key(a: u32, b: u32) -> (u32, u32) {
    if a < b { (a, b) } else { (b, a) }
}

/// The edge-midpoint map: a hash table of midpoint vertex ids alone (4 bytes
/// and a control byte per bucket instead of 12 and one), the key of an entry
/// being its vertex's parents (the ends of the edge it was put on), read from
/// `vparent` when needed.
#[derive(Clone, Debug, Default)]
pub(crate) struct MidMap {
    table: hashbrown::HashTable<u32>,
}

#[inline]
fn hash_edge(k: (u32, u32)) -> u64 {
    use std::hash::BuildHasher;
    rustc_hash::FxBuildHasher.hash_one(k)
}

impl MidMap {
    /// The vertex whose parents are the edge `k` (a [`key`]).
    #[inline]
    pub(crate) fn get(&self, vparent: &[[u32; 2]], k: (u32, u32)) -> Option<u32> {
        self.table
            .find(hash_edge(k), |&m| {
                let [a, b] = vparent[m as usize];
                key(a, b) == k
            })
            .copied()
    }

    /// Registers vertex `m` (already in `vparent`, not yet in the map) as the
    /// midpoint of the edge between its parents.
    pub(crate) fn insert(&mut self, vparent: &[[u32; 2]], m: u32) {
        let [a, b] = vparent[m as usize];
        let h = |&v: &u32| {
            let [a, b] = vparent[v as usize];
            hash_edge(key(a, b))
        };
        self.table.insert_unique(hash_edge(key(a, b)), m, h);
    }

    pub(crate) fn len(&self) -> usize {
        self.table.len()
    }

    pub(crate) fn capacity(&self) -> usize {
        self.table.capacity()
    }

    /// The midpoint vertices, in no particular order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.table.iter().copied()
    }
}

struct Leaves<'a> {
    mesh: &'a Mesh,
    next_patch: u32,
    stack: Vec<u32>,
}

impl Iterator for Leaves<'_> {
    type Item = ElemId;
    fn next(&mut self) -> Option<ElemId> {
        loop {
            let e = match self.stack.pop() {
                Some(e) => e,
                None => {
                    if self.next_patch as usize >= self.mesh.patches.len() {
                        return None;
                    }
                    self.next_patch += 1;
                    self.next_patch - 1
                }
            };
            let el = &self.mesh.elems[e as usize];
            if el.is_leaf() {
                return Some(ElemId(e));
            }
            self.stack.extend((0..4).rev().map(|c| el.children + c));
        }
    }
}
