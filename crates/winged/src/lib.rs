//! Winged-edge topology over a flat UniGrafix [`ug::Model`] (DESIGN section 5).
//!
//! A [`Mesh`] owns the model and adds topology to its top-level faces:
//!
//! - **faces → contours → edges**: every contour position `(face, contour,
//!   index)` names the [`EdgeId`] from its vertex to the next one
//!   ([`Mesh::contour_edges`], [`Mesh::face_edges`]); contour 0 is the outer
//!   boundary, the others are holes and islands;
//! - **edges → every use**: an [`Edge`] joins two vertices (`v[0] < v[1]`) and
//!   lists each contour position that walks it ([`EdgeUse`], with the direction).
//!   Any number of faces may share an edge (architectural models are often
//!   non-manifold: three walls along one edge), and so may two contours of one face;
//! - **vertices → edges**: [`Mesh::vertex_edges`], sorted.
//!
//! Storage is index arenas with typed ids, no reference counting. Removed
//! faces and edges are tombstoned, never renumbered, so ids stay valid across
//! edits; an edge that survives an edit keeps its id. Statement order is a
//! linked list of the model's items, so new faces go right after their parent
//! in O(1); [`Mesh::into_model`] compacts everything back into a [`ug::Model`]
//! that keeps names, materials, wires and the other statements in place.
//!
//! Edits ([`Mesh::split_edge`], [`Mesh::merge_faces`], [`Mesh::remove_face`],
//! [`Mesh::flip_face`], [`Mesh::set_face_contours`], [`Mesh::replace_vertex`],
//! [`Mesh::add_face`], [`Mesh::add_vertex`]) keep the topology exact;
//! [`Mesh::validate`] checks every invariant and is what tests call after
//! every edit. Nothing iterates a hash map in a way that reaches results, so
//! every edit is deterministic.
//!
//! ```
//! let src = b"v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 2 0 0; v f 2 1 0;
//!             f left (a b c d); f right (b e f c);";
//! let model = ug::parse(src, "<doc>").unwrap().model;
//! let mut mesh = winged::Mesh::from_model(model);
//! let (left, right) = (ug::FaceId(0), ug::FaceId(1));
//! assert_eq!(mesh.face_neighbors(left), vec![right]);
//! let merged = mesh.merge_faces(left, right).unwrap();
//! assert_eq!(mesh.face_area(merged), 2.0);
//! mesh.validate().unwrap();
//! assert_eq!(ug::write_string(&mesh.into_model()).lines().last(), Some("f left (a b e f c d);"));
//! ```

mod merge;
mod mesh;
mod order;
pub mod pieces;
pub mod trace;
mod validate;
pub mod weld;

#[cfg(test)]
mod tests;

pub use mesh::Mesh;
pub use trace::{HalfEdge, outer_first, trace_loops};
pub use ug::{FaceId, MaterialId, VertexId};

/// Index of an edge in a [`Mesh`]. Stable across edits; an edge that loses
/// all its uses is tombstoned and its id is not reused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EdgeId(pub u32);

impl EdgeId {
    #[inline]
    pub fn idx(self) -> usize {
        self.0 as usize
    }
}

/// One use of an edge by a face contour: contour `contour` of `face` goes from
/// its vertex at position `index` to the next one (index+1 mod len).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EdgeUse {
    pub face: FaceId,
    pub contour: u32,
    pub index: u32,
    /// True when the contour walks the edge from `v[0]` to `v[1]`.
    pub forward: bool,
}

/// An edge between two distinct vertices and every contour position that walks it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Edge {
    /// The end points, `v[0] < v[1]`.
    pub v: [VertexId; 2],
    /// Sorted by (face, contour, index); empty only for a removed edge.
    pub uses: Vec<EdgeUse>,
}

impl Edge {
    /// False for a removed (tombstoned) edge.
    pub fn is_live(&self) -> bool {
        !self.uses.is_empty()
    }

    /// The end point that is not `v`, or `None` when `v` is not an end point.
    pub fn other(&self, v: VertexId) -> Option<VertexId> {
        if v == self.v[0] {
            Some(self.v[1])
        } else if v == self.v[1] {
            Some(self.v[0])
        } else {
            None
        }
    }

    /// The faces that use the edge, sorted, without repeats.
    pub fn faces(&self) -> Vec<FaceId> {
        let mut fs: Vec<FaceId> = self.uses.iter().map(|u| u.face).collect();
        fs.dedup(); // uses are sorted by face first
        fs
    }
}

/// Why [`Mesh::merge_faces`] refused; the mesh is unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MergeError {
    /// Both arguments name the same face.
    SameFace,
    /// The face was removed (or never was a top-level face).
    DeadFace(FaceId),
    /// The faces share no edge that they walk in opposite directions.
    NotAdjacent,
    /// Nothing with area would be left (e.g. a face merged with its own mirror image).
    Degenerate,
}

impl std::fmt::Display for MergeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MergeError::SameFace => write!(f, "cannot merge a face with itself"),
            MergeError::DeadFace(x) => write!(f, "face {} has been removed", x.0),
            MergeError::NotAdjacent => write!(f, "the faces share no edge"),
            MergeError::Degenerate => write!(f, "the merged face would have no area"),
        }
    }
}

impl std::error::Error for MergeError {}

/// What [`Mesh::from_model`] had to change to make the model's faces valid
/// topology (a parsed model of clean geometry needs none of these).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Repair {
    /// A contour named a vertex id outside the model; the reference was dropped.
    DroppedVertexRef { face: FaceId, contour: usize },
    /// `count` consecutive repeats of a vertex were removed from a contour
    /// (including a last vertex repeating the first).
    RemovedRepeats {
        face: FaceId,
        contour: usize,
        count: usize,
    },
    /// A contour with fewer than three distinct vertices was dropped
    /// (`contour` is its index in the input face).
    DroppedContour { face: FaceId, contour: usize },
    /// A face with no valid contour left was removed.
    DroppedFace { face: FaceId },
    /// A face listed twice among the top-level statements; the second
    /// statement was ignored.
    RepeatedStatement { face: FaceId },
}
