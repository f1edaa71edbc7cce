//! Which vertices a shooter sees: the [`Visibility`] trait and its CPU
//! ray-cast implementation (the reference, and the fallback without a GPU).

use geom::bvh::{
    Node, RayFrame, Shaft, ShaftTri, Triangle, Wide, build_nodes, ray_triangle_with,
    shaft_triangles,
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
    /// shooter piece at once (a penumbra's cells). Every point lies in the
    /// convex hull of `piece` (the piece's corners), which an
    /// implementation may use to cull, keeping what it finds per receiver
    /// in `cache` (one cache per piece: the caller asks again with more
    /// points of the same piece). The default asks
    /// [`Visibility::visible_few`] pair by pair.
    fn visible_pairs(
        &self,
        mesh: &Mesh,
        shooter: SurfaceId,
        piece: &[DVec3],
        pairs: &[(DVec3, VertId)],
        cache: &mut PairCache,
    ) -> Vec<bool> {
        let _ = (piece, cache);
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
    /// The same tree four-wide, for the rays.
    wide: Wide,
    /// What the nodes' boxes are measured from ([`build_nodes`]).
    base: DVec3,
    /// The shafts' slack ([`geom::bvh::shaft_slack`]).
    tol: f64,
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
        let (nodes, base) = build_nodes(&mut tris, |t| t.v.map(|v| pts[v as usize]));
        let tol = geom::bvh::shaft_slack(&pts);
        let wide = Wide::new(&nodes);
        RayVisibility {
            pts,
            tris,
            nodes,
            wide,
            base,
            tol,
        }
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
            + self.wide.heap_bytes()
    }

    /// The triangles (indices into `tris`) of surfaces other than `a` and
    /// `b` that may meet the convex hull of `piece` and `to`; `None` when
    /// there are so many that rays through the BVH are cheaper.
    fn in_shaft(
        &self,
        piece: &[DVec3],
        to: DVec3,
        a: SurfaceId,
        b: SurfaceId,
    ) -> Option<Vec<ShaftTri>> {
        let shaft = Shaft::new(piece, to, &[], self.tol);
        shaft_triangles(&self.nodes, self.base, &shaft, SHAFT_MAX, self.tol, |k| {
            let t = &self.tris[k as usize];
            (t.surface != a.0 && t.surface != b.0).then(|| t.v.map(|v| self.pts[v as usize]))
        })
    }

    /// Whether the segment from → to (within a shaft whose triangles are
    /// `list`) is clear: [`RayVisibility::clear`]'s test on those alone.
    fn clear_among(&self, list: &[ShaftTri], from: DVec3, to: DVec3) -> bool {
        let Some(frame) = RayFrame::new(to - from) else {
            return true;
        };
        !list.iter().any(|t| {
            t.may_cross(from, to)
                && ray_triangle_with(from, &frame, &self.triangle(&self.tris[t.k as usize]))
                    .is_some_and(|t| t > 1e-7 && t < 1.0 - 1e-7)
        })
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
        let inv = DVec3::ONE / dir;
        let frame = RayFrame::new(dir)?;
        // The boxes are measured from `base`; the triangles are not.
        // Nearer boxes first: a ray toward a vertex in another room is
        // usually stopped by a wall near its start, so the boxes near the
        // origin are the likely place of a hit. Whether anything is hit
        // does not depend on the order, so the answers do not change.
        let rel = origin - self.base;
        let mut best = None;
        self.wide
            .walk(rel, inv, tmin, &mut tmax, |first, count, tmax| {
                for t in &self.tris[first as usize..(first + count) as usize] {
                    if !keep(t.surface) {
                        continue;
                    }
                    if let Some(tt) = ray_triangle_with(origin, &frame, &self.triangle(t))
                        && tt > tmin
                        && tt < *tmax
                    {
                        best = Some(t);
                        if !nearest {
                            return true;
                        }
                        *tmax = tt;
                    }
                }
                false
            });
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

    /// Pairs are answered per receiver: the first time a receiver comes
    /// with at least [`SHAFT_PAIRS`] sample points of the piece, the
    /// triangles that may meet the convex hull of the piece and its
    /// receiving point (a shaft, Haines and Wallace 1994) are collected and
    /// kept in `cache`; each of its segments is then tried against those
    /// alone, with the same triangle test (after a test of the segment's
    /// ends against the triangle's plane, with slack). A segment lies in
    /// the hull, so the triangles it crosses are all in the list, and the
    /// answers are those of a ray through the BVH.
    fn visible_pairs(
        &self,
        mesh: &Mesh,
        shooter: SurfaceId,
        piece: &[DVec3],
        pairs: &[(DVec3, VertId)],
        cache: &mut PairCache,
    ) -> Vec<bool> {
        if piece.len() < 3 {
            return pairs
                .par_iter()
                .map(|&(from, v)| {
                    self.clear(from, mesh.receiver_pos(v), shooter, mesh.vertex_surface(v))
                })
                .collect();
        }
        // The pairs by receiver.
        let mut order: Vec<u32> = (0..pairs.len() as u32).collect();
        order.sort_unstable_by_key(|&i| (pairs[i as usize].1, i));
        let groups: Vec<&[u32]> = order
            .chunk_by(|&a, &b| pairs[a as usize].1 == pairs[b as usize].1)
            .collect();
        // New shafts for the receivers with enough points.
        let fresh: Vec<VertId> = groups
            .iter()
            .map(|g| pairs[g[0] as usize].1)
            .zip(&groups)
            .filter(|(v, g)| g.len() >= SHAFT_PAIRS && !cache.lists.contains_key(v))
            .map(|(v, _)| v)
            .collect();
        let made: Vec<Option<Vec<ShaftTri>>> = fresh
            .par_iter()
            .map(|&v| self.in_shaft(piece, mesh.receiver_pos(v), shooter, mesh.vertex_surface(v)))
            .collect();
        cache.lists.extend(fresh.into_iter().zip(made));
        let cache = &*cache;
        let answers: Vec<Vec<bool>> = groups
            .par_iter()
            .map(|g| {
                let v = pairs[g[0] as usize].1;
                let (to, surface) = (mesh.receiver_pos(v), mesh.vertex_surface(v));
                let list = cache.lists.get(&v).and_then(|l| l.as_deref());
                g.iter()
                    .map(|&i| {
                        let from = pairs[i as usize].0;
                        match list {
                            Some(list) => self.clear_among(list, from, to),
                            None => self.clear(from, to, shooter, surface),
                        }
                    })
                    .collect()
            })
            .collect();
        let mut out = vec![false; pairs.len()];
        for (g, a) in groups.iter().zip(answers) {
            for (&i, x) in g.iter().zip(a) {
                out[i as usize] = x;
            }
        }
        out
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

/// What [`Visibility::visible_pairs`] keeps for one piece between calls:
/// per receiver, the triangles of its shaft (`None`: too many, rays).
#[derive(Default)]
pub struct PairCache {
    lists: rustc_hash::FxHashMap<VertId, Option<Vec<ShaftTri>>>,
}

/// A receiver with at least this many sample points of one piece gets a
/// shaft ([`RayVisibility::visible_pairs`]).
const SHAFT_PAIRS: usize = 4;
/// A shaft with more triangles than this is given up for rays.
const SHAFT_MAX: usize = 256;

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

    /// Shafts answer as rays do: a lamp piece over a floor of 12 × 12
    /// patches with blockers of every kind between (a slab, a thin post, a
    /// tilted plate that pierces the shaft's side, a wall edge-on), at the
    /// origin and far from it; each receiver asked in two calls, so the
    /// second uses the cached shaft.
    #[test]
    fn shafts_answer_as_rays() {
        for shift in [DVec3::ZERO, DVec3::new(312345.678, 4123456.789, 87.0)] {
            let mut src = String::from("c_rgb g 0.5 0.5 0.5;\n");
            let mut k = 0;
            let mut quad = |src: &mut String, p: [DVec3; 4]| {
                let names: Vec<String> = p
                    .iter()
                    .map(|q| {
                        let q = *q + shift;
                        k += 1;
                        src.push_str(&format!("v p{k} {} {} {};\n", q.x, q.y, q.z));
                        format!("p{k}")
                    })
                    .collect();
                src.push_str(&format!("f ({}) g;\n", names.join(" ")));
            };
            let n = 12;
            for i in 0..n {
                for j in 0..n {
                    let (x0, y0) = (i as f64 / n as f64 * 3.0, j as f64 / n as f64 * 3.0);
                    let (x1, y1) = (x0 + 0.25, y0 + 0.25);
                    quad(
                        &mut src,
                        [
                            DVec3::new(x0, y0, 0.0),
                            DVec3::new(x1, y0, 0.0),
                            DVec3::new(x1, y1, 0.0),
                            DVec3::new(x0, y1, 0.0),
                        ],
                    );
                }
            }
            let v = DVec3::new;
            // The lamp, facing down.
            let lamp = [
                v(1.2, 1.2, 2.5),
                v(1.2, 1.8, 2.5),
                v(1.8, 1.8, 2.5),
                v(1.8, 1.2, 2.5),
            ];
            quad(&mut src, lamp);
            // A slab, a post, a tilted plate, a wall edge-on to the lamp's edge.
            for q in [
                [
                    (0.5, 0.5, 1.0),
                    (1.5, 0.5, 1.0),
                    (1.5, 1.5, 1.0),
                    (0.5, 1.5, 1.0),
                ],
                [
                    (2.0, 2.0, 0.5),
                    (2.05, 2.0, 0.5),
                    (2.05, 2.0, 2.0),
                    (2.0, 2.0, 2.0),
                ],
                [
                    (1.9, 0.3, 0.4),
                    (2.8, 0.3, 1.3),
                    (2.8, 1.1, 1.3),
                    (1.9, 1.1, 0.4),
                ],
                [
                    (1.8, 1.2, 0.2),
                    (1.8, 2.9, 0.2),
                    (1.8, 2.9, 2.0),
                    (1.8, 1.2, 2.0),
                ],
            ] {
                quad(&mut src, q.map(|(x, y, z)| v(x, y, z)));
            }
            let model = ug::parse(src.as_bytes(), "t").unwrap().model;
            let mesh = Mesh::from_model(&model, 1e-9).unwrap();
            let vis = RayVisibility::new(&mesh);
            let shooter = (0..mesh.num_surfaces() as u32)
                .map(SurfaceId)
                .find(|&s| {
                    mesh.patches().any(|p| {
                        mesh.patch_surface(p) == s
                            && mesh
                                .patch_corners(p)
                                .iter()
                                .all(|&c| (mesh.vertex_pos(c).z - shift.z - 2.5).abs() < 1e-9)
                    })
                })
                .expect("the lamp");
            let piece: Vec<DVec3> = lamp.iter().map(|&p| p + shift).collect();
            let mut pairs = Vec::new();
            for vtx in (0..mesh.num_vertices() as u32).map(VertId) {
                if mesh.vertex_surface(vtx) == shooter {
                    continue;
                }
                for a in 0..=4 {
                    for b in 0..=4 {
                        let (u, w) = (a as f64 / 4.0, b as f64 / 4.0);
                        let p = piece[0] * ((1.0 - u) * (1.0 - w))
                            + piece[1] * (u * (1.0 - w))
                            + piece[2] * (u * w)
                            + piece[3] * ((1.0 - u) * w);
                        pairs.push((p, vtx));
                    }
                }
            }
            let want: Vec<bool> = pairs
                .iter()
                .map(|&(from, x)| {
                    vis.clear(from, mesh.receiver_pos(x), shooter, mesh.vertex_surface(x))
                })
                .collect();
            let mut cache = PairCache::default();
            let half = pairs.len() / 2;
            let mut got = vis.visible_pairs(&mesh, shooter, &piece, &pairs[..half], &mut cache);
            got.extend(vis.visible_pairs(&mesh, shooter, &piece, &pairs[half..], &mut cache));
            assert_eq!(got, want, "shift {shift}");
            let seen = want.iter().filter(|&&x| x).count();
            assert!(
                seen > pairs.len() / 4 && seen < pairs.len() * 9 / 10,
                "{seen} of {}",
                pairs.len()
            );
            assert!(
                cache
                    .lists
                    .values()
                    .any(|l| l.as_ref().is_some_and(|l| !l.is_empty()))
            );
        }
    }
}
