//! Which vertices a shooter sees: the [`Visibility`] trait and its CPU
//! ray-cast implementation (the reference, and the fallback without a GPU).

use geom::bvh::{
    Node, RayFrame, Triangle, build_nodes, push_children, ray_triangle_with, slab_entry,
};
use glam::DVec3;
use libmesh::{Mesh, SurfaceId, VertId};
use rayon::prelude::*;

/// Answers "which of these vertices does a point on the shooter see".
pub trait Visibility: Sync {
    /// For each candidate vertex, whether the segment from `from` (a point on
    /// surface `shooter`) to the vertex's receiver point
    /// ([`Mesh::receiver_pos`]) is unobstructed.
    fn visible(
        &self,
        mesh: &Mesh,
        from: DVec3,
        shooter: SurfaceId,
        candidates: &[VertId],
    ) -> Vec<bool>;

    /// [`Visibility::visible`] for a short list of candidates (a shot's
    /// penumbra, seen from the centres of sub-pieces): an implementation
    /// whose set-up per query is costly (a hemi-cube rendering) may answer
    /// by rays. The default is `visible`.
    fn visible_few(
        &self,
        mesh: &Mesh,
        from: DVec3,
        shooter: SurfaceId,
        candidates: &[VertId],
    ) -> Vec<bool> {
        self.visible(mesh, from, shooter, candidates)
    }

    /// For each (point on surface `shooter`, vertex) pair, whether the
    /// segment between them is unobstructed: many sample points of one
    /// shooter at once (a penumbra's cells). The default asks
    /// [`Visibility::visible_few`] pair by pair.
    fn visible_pairs(
        &self,
        mesh: &Mesh,
        shooter: SurfaceId,
        pairs: &[(DVec3, VertId)],
    ) -> Vec<bool> {
        pairs
            .iter()
            .map(|&(from, v)| self.visible_few(mesh, from, shooter, &[v])[0])
            .collect()
    }

    /// A short name for messages (`ray`, `hemicube`).
    fn name(&self) -> &'static str;

    /// Whether [`Visibility::blocker`] names blocking triangles; only then
    /// does the solver skip whole patches hidden behind one (its answers
    /// must be the implementation's own). The default: no.
    fn names_blockers(&self) -> bool {
        false
    }

    /// A triangle (of a surface other than `a` and `b`) that the open
    /// segment from → to crosses, if the implementation can name one: the
    /// solver uses it to find whole patches hidden behind one triangle (the
    /// ray caster names the nearest to `from`: from a light the nearest
    /// blocker casts the widest shadow, as a rule), and its surface.
    /// The default names none.
    fn blocker(
        &self,
        _from: DVec3,
        _to: DVec3,
        _a: SurfaceId,
        _b: SurfaceId,
    ) -> Option<([DVec3; 3], SurfaceId)> {
        None
    }
}

/// Ray casting against a BVH of the patches (the geometry does not change
/// when elements are refined, so it is built once). A ray from the shooter
/// point to a vertex ignores the shooter's and the receiver's own surfaces
/// (a planar surface cannot hide a point of its own plane) and stops short of
/// the vertex by a relative 1e-7, so grazing contacts at shared corners do not count.
///
/// The BVH is compact (about 44 bytes a triangle and the corner positions,
/// instead of 108 bytes a triangle for `geom::bvh`): triangles are three
/// indices into a shared corner array and a surface id. Nodes (f32 boxes
/// rounded outward, 32 bytes) and the box test are `geom::bvh`'s, and the
/// triangle test is `geom::bvh::ray_triangle` in f64 on the same corners in
/// the same order; "is anything hit" does not depend on the order in which
/// triangles are tried, so the answers are `geom::bvh`'s.
pub struct RayVisibility {
    /// Patch corner positions (indexed by corner vertex id).
    pts: Vec<DVec3>,
    tris: Vec<Tri>,
    nodes: Vec<Node>,
}

#[derive(Clone, Copy, Debug)]
struct Tri {
    v: [u32; 3],
    surface: u32,
}

impl RayVisibility {
    pub fn new(mesh: &Mesh) -> RayVisibility {
        // Patch corners are the mesh's first vertices; keep their positions.
        let n_pts = mesh
            .patches()
            .flat_map(|p| mesh.patch_corners(p).iter().map(|v| v.idx() + 1))
            .max()
            .unwrap_or(0);
        let pts: Vec<DVec3> = (0..n_pts)
            .map(|v| mesh.vertex_pos(VertId(v as u32)))
            .collect();
        let n_tris: usize = mesh
            .patches()
            .map(|p| mesh.patch_corners(p).len() - 2)
            .sum();
        let mut tris = Vec::with_capacity(n_tris);
        for p in mesh.patches() {
            let s = mesh.patch_surface(p).0;
            let c = mesh.patch_corners(p);
            for k in 1..c.len() - 1 {
                tris.push(Tri {
                    v: [c[0].0, c[k].0, c[k + 1].0],
                    surface: s,
                });
            }
        }
        let nodes = build_nodes(&mut tris, |t| t.v.map(|v| pts[v as usize]));
        RayVisibility { pts, tris, nodes }
    }

    /// Whether the segment from → to is clear of every surface but the two named.
    pub fn clear(&self, from: DVec3, to: DVec3, a: SurfaceId, b: SurfaceId) -> bool {
        !self.occluded(from, to - from, 1e-7, 1.0 - 1e-7, |id| {
            id != a.0 && id != b.0
        })
    }

    /// Approximate heap memory held, in bytes.
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.pts.capacity() * size_of::<DVec3>()
            + self.tris.capacity() * size_of::<Tri>()
            + self.nodes.capacity() * size_of::<Node>()
    }

    fn triangle(&self, t: &Tri) -> Triangle {
        Triangle {
            p: t.v.map(|v| self.pts[v as usize]),
            id: t.surface,
        }
    }

    /// Whether a triangle whose surface passes `keep` is hit with `tmin < t < tmax`.
    fn occluded(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
        keep: impl Fn(u32) -> bool,
    ) -> bool {
        self.first_hit(origin, dir, tmin, tmax, false, keep)
            .is_some()
    }

    /// The first triangle found (in traversal order; the nearest when
    /// `nearest`) whose surface passes `keep` and that is hit with
    /// `tmin < t < tmax`.
    fn first_hit(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        mut tmax: f64,
        nearest: bool,
        keep: impl Fn(u32) -> bool,
    ) -> Option<&Tri> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = DVec3::ONE / dir;
        let frame = RayFrame::new(dir)?;
        let root = &self.nodes[0];
        let t0 = slab_entry(root.lo(), root.hi(), origin, inv, tmin, tmax)?;
        // Nearer child first: a ray toward a vertex in another room is
        // usually stopped by a wall near its start, so the boxes near the
        // origin are the likely place of a hit. Whether anything is hit
        // does not depend on the order, so the answers do not change.
        let mut stack = [(0u32, 0.0f64); 64];
        stack[0] = (0, t0);
        let mut sp = 1usize;
        let mut best = None;
        while sp > 0 {
            sp -= 1;
            let (ni, entry) = stack[sp];
            if entry > tmax {
                continue;
            }
            let n = &self.nodes[ni as usize];
            if n.count > 0 {
                for t in &self.tris[n.first as usize..(n.first + n.count) as usize] {
                    if !keep(t.surface) {
                        continue;
                    }
                    if let Some(tt) = ray_triangle_with(origin, &frame, &self.triangle(t))
                        && tt > tmin
                        && tt < tmax
                    {
                        if !nearest {
                            return Some(t);
                        }
                        best = Some(t);
                        tmax = tt;
                    }
                }
            } else {
                assert!(sp + 2 <= stack.len(), "BVH deeper than its traversal stack");
                push_children(&self.nodes, n, origin, inv, tmin, tmax, &mut stack, &mut sp);
            }
        }
        best
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
            .map(|&v| self.clear(from, mesh.receiver_pos(v), shooter, mesh.vertex_surface(v)))
            .collect()
    }

    fn visible_pairs(
        &self,
        mesh: &Mesh,
        shooter: SurfaceId,
        pairs: &[(DVec3, VertId)],
    ) -> Vec<bool> {
        pairs
            .par_iter()
            .map(|&(from, v)| {
                self.clear(from, mesh.receiver_pos(v), shooter, mesh.vertex_surface(v))
            })
            .collect()
    }

    fn name(&self) -> &'static str {
        "ray"
    }

    fn names_blockers(&self) -> bool {
        true
    }

    fn blocker(
        &self,
        from: DVec3,
        to: DVec3,
        a: SurfaceId,
        b: SurfaceId,
    ) -> Option<([DVec3; 3], SurfaceId)> {
        self.first_hit(from, to - from, 1e-7, 1.0 - 1e-7, true, |id| {
            id != a.0 && id != b.0
        })
        .map(|t| (self.triangle(t).p, SurfaceId(t.surface)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The compact BVH answers exactly as `geom::bvh` over the same triangles.
    #[test]
    fn same_answers_as_geom_bvh() {
        let src = "c_rgb g 0.5 0.5 0.5;
            v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;
            v e 0.2 0.2 0.5; v f 0.8 0.2 0.5; v g 0.8 0.8 0.5; v h 0.2 0.8 0.5;
            v i 0 0 1; v j 1 0 1; v k 1 1 1; v l 0 1 1;
            v m 0.3 0.1 0.7; v n 0.9 0.6 0.7; v o 0.1 0.9 0.7;
            f floor (a b c d) g; f mid (e f g h) g; f top (l k j i) g; f tri (m n o) g;";
        let model = ug::parse(src.as_bytes(), "t").unwrap().model;
        let mesh = Mesh::from_model(&model, 1e-9).unwrap();
        let vis = RayVisibility::new(&mesh);
        let mut tris = Vec::new();
        for p in mesh.patches() {
            let c: Vec<DVec3> = mesh
                .patch_corners(p)
                .iter()
                .map(|&v| mesh.vertex_pos(v))
                .collect();
            for k in 1..c.len() - 1 {
                tris.push(Triangle {
                    p: [c[0], c[k], c[k + 1]],
                    id: mesh.patch_surface(p).0,
                });
            }
        }
        let reference = geom::bvh::Bvh::new(tris);
        let mut n = 0;
        for i in 0..11 {
            for j in 0..11 {
                for (z0, z1) in [(0.0, 1.0), (0.0, 0.6), (0.25, 0.9), (1.0, 0.0)] {
                    let from = DVec3::new(i as f64 / 10.0, j as f64 / 10.0, z0);
                    let to = DVec3::new(1.0 - j as f64 / 10.0, i as f64 / 10.0, z1);
                    let (a, b) = (SurfaceId(0), SurfaceId(2));
                    let want = !reference.occluded(from, to - from, 1e-7, 1.0 - 1e-7, |id| {
                        id != a.0 && id != b.0
                    });
                    assert_eq!(vis.clear(from, to, a, b), want, "{from} → {to}");
                    n += usize::from(want);
                }
            }
        }
        assert!(n > 0 && n < 11 * 11 * 4);
    }
}
