//! Which vertices a shooter sees: the [`Visibility`] trait and its CPU
//! ray-cast implementation (the reference, and the fallback without a GPU).

use geom::bvh::{Bvh, Triangle};
use glam::DVec3;
use libmesh::{Mesh, SurfaceId, VertId};
use rayon::prelude::*;

/// Answers "which of these vertices does a point on the shooter see".
pub trait Visibility: Sync {
    /// For each candidate vertex, whether the segment from `from` (a point on
    /// surface `shooter`) to the vertex is unobstructed.
    fn visible(
        &self,
        mesh: &Mesh,
        from: DVec3,
        shooter: SurfaceId,
        candidates: &[VertId],
    ) -> Vec<bool>;

    /// A short name for messages (`ray`, `hemicube`).
    fn name(&self) -> &'static str;
}

/// Ray casting against a BVH of the patches (the geometry does not change
/// when elements are refined, so it is built once). A ray from the shooter
/// point to a vertex ignores the shooter's and the receiver's own surfaces
/// (a planar surface cannot hide a point of its own plane) and stops short of
/// the vertex by a relative 1e-7, so grazing contacts at shared corners do not count.
pub struct RayVisibility {
    bvh: Bvh,
}

impl RayVisibility {
    pub fn new(mesh: &Mesh) -> RayVisibility {
        let mut tris = Vec::new();
        for p in mesh.patches() {
            let s = mesh.patch_surface(p).0;
            let c: Vec<DVec3> = mesh
                .patch_corners(p)
                .iter()
                .map(|&v| mesh.vertex_pos(v))
                .collect();
            for k in 1..c.len() - 1 {
                tris.push(Triangle {
                    p: [c[0], c[k], c[k + 1]],
                    id: s,
                });
            }
        }
        RayVisibility {
            bvh: Bvh::new(tris),
        }
    }

    /// Whether the segment from → to is clear of every surface but the two named.
    pub fn clear(&self, from: DVec3, to: DVec3, a: SurfaceId, b: SurfaceId) -> bool {
        !self.bvh.occluded(from, to - from, 1e-7, 1.0 - 1e-7, |id| {
            id != a.0 && id != b.0
        })
    }
}

impl Visibility for RayVisibility {
    fn visible(
        &self,
        mesh: &Mesh,
        from: DVec3,
        shooter: SurfaceId,
        candidates: &[VertId],
    ) -> Vec<bool> {
        candidates
            .par_iter()
            .map(|&v| self.clear(from, mesh.vertex_pos(v), shooter, mesh.vertex_surface(v)))
            .collect()
    }

    fn name(&self) -> &'static str {
        "ray"
    }
}
