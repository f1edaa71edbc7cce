//! Progressive radiosity (Smith 1991, §5–6) over a `libmesh` element mesh.
//!
//! Quantities (DESIGN.md §6): `emission_rgb` E is exitance, `diffuse_rgb` ρ is
//! reflectance; every element vertex holds irradiance H, and radiosity
//! B = E + ρH. A patch shoots its unshot energy ΔΦ (emitted plus reflected,
//! measured from its elements' vertex averages, minus what it shot before)
//! as a uniform unshot radiosity ΔB = ΔΦ/A; a visible vertex v gains
//! ΔB·F(v), F the exact point-to-polygon form factor of the shooting
//! element, clipped to v's horizon.

mod cube;
pub mod formfactor;
pub mod solver;
mod tail;
pub mod visibility;

pub use solver::{DIVERGED, Options, Output, ShotStats, Solver, Stop, TailStats};
pub use visibility::{PairCache, RayVisibility, Visibility};
