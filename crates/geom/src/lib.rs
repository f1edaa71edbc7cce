//! f64 geometry shared by the UG tools.
//!
//! Topological decisions (orientation, side of a plane, point on a segment,
//! segment crossings) go through the exact predicates of the `robust` crate
//! (Shewchuk's adaptive arithmetic); constructions are plain f64.

pub mod arrange;
pub mod bvh;
pub mod index;
pub mod intersect;
pub mod overlap;
pub mod plane;
pub mod polygon;
pub mod predicates;
pub mod triangulate;

pub use glam::{DVec2, DVec3};
pub use index::BoxIndex;
pub use plane::{Frame, Plane, contour_normal, newell_normal, spread_normal};
pub use polygon::*;
pub use predicates::*;
