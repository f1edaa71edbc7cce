//! Welding within a tolerance: the first two steps of the grouper (Smith
//! 1991, §2.4), on the winged-edge mesh, for every tool that needs shared
//! vertices and no T-vertices (`ugvlmerge`, `ugisect`, `ugcopl`, `ugcut`,
//! `ugflip` for adjacency):
//!
//! 1. [`merge_vertices`]: vertices within `eps` of an earlier vertex (in
//!    statement order) are replaced by it, found with an R*-tree; faces left
//!    without area are dropped;
//! 2. [`split_edges`]: every vertex of a face that lies within `eps` of the
//!    interior of an edge is inserted into that edge, in every face that
//!    uses it, in order along the edge (no T-vertex remains).
//!
//! And, for the patch mesher, [`collapse_tents`]: a contour vertex within
//! `eps` of the short chord between its neighbours joins the nearer one.

use std::collections::hash_map::Entry;

use geom::{BoxIndex, DVec3, newell_normal, on_edge_interior, point_segment_distance};
use rustc_hash::{FxHashMap, FxHashSet};

use crate::{EdgeId, FaceId, Mesh, VertexId};
use ug::Model;

/// The part of a mesh an operation is limited to (the `_in` versions of
/// [`merge_vertices`], [`split_edges`], [`collapse_tents`],
/// [`join_vertices`] and `pieces::repair_all`): its faces and vertices by
/// id; faces and vertices made after it was (ids past its ends) are in it.
/// On a mesh that the operation leaves unchanged outside the region (one
/// already welded, split and repaired, changed only inside the region
/// since), the limited operation does what the whole one does, at the
/// region's cost. Faces outside it that share a vertex or edge it changes
/// are still rewritten.
pub struct Region {
    faces: Vec<bool>,
    verts: Vec<bool>,
}

impl Region {
    /// Faces and vertices by id (true: in the region).
    pub fn new(faces: Vec<bool>, verts: Vec<bool>) -> Region {
        Region { faces, verts }
    }

    pub fn has_face(&self, f: FaceId) -> bool {
        self.faces.get(f.idx()).copied().unwrap_or(true)
    }

    pub fn has_vertex(&self, v: VertexId) -> bool {
        self.verts.get(v.idx()).copied().unwrap_or(true)
    }
}

/// Whether face `f` is in `region` (every face is in none).
pub fn face_in(region: Option<&Region>, f: FaceId) -> bool {
    region.is_none_or(|r| r.has_face(f))
}

/// Whether vertex `v` is in `region` (every vertex is in none).
pub fn vertex_in(region: Option<&Region>, v: VertexId) -> bool {
    region.is_none_or(|r| r.has_vertex(v))
}

/// Edge splitting repeats on the edges it created until nothing changes, at most this often.
const MAX_SPLIT_PASSES: usize = 16;

/// Why a live face has no usable area, decided as `ugcheck` does: an edge no
/// longer than `eps`, or an outer contour whose area is at most `eps` times
/// the face's size. `None` for a sound face.
pub fn degeneracy(mesh: &Mesh, f: FaceId, eps: f64) -> Option<&'static str> {
    degeneracy_within(mesh, f, eps, NoArea::Sliver)
}

/// What "no area" means to [`degeneracy_within`].
#[derive(Clone, Copy, PartialEq, Eq)]
enum NoArea {
    /// At most `eps` times the face's size (its bounding box's diagonal):
    /// also a sliver up to about 2 epsilon wide.
    Sliver,
    /// At most half that: a sliver up to about epsilon wide, as narrow as
    /// `ugcheck` takes a face to be degenerate (a triangle whose corner
    /// lies within epsilon of the opposite edge).
    Narrow,
    /// At most ε², `ugcheck`'s own limit for a face's area.
    Strict,
}

/// [`degeneracy`], with "no area" as `no_area` says.
fn degeneracy_within(mesh: &Mesh, f: FaceId, eps: f64, no_area: NoArea) -> Option<&'static str> {
    let pts = mesh.face_points(f);
    if pts.is_empty() {
        return Some("no contour");
    }
    for c in &pts {
        let n = c.len();
        if (0..n).any(|i| c[i].distance(c[(i + 1) % n]) <= eps) {
            return Some("a zero-length edge");
        }
    }
    let (lo, hi) = geom::index::bbox(pts.iter().flatten().copied(), 0.0);
    let size = (hi - lo).length();
    let area = newell_normal(&pts[0]).length() / 2.0;
    // NaN counts as no area.
    let limit = match no_area {
        NoArea::Sliver => eps * size,
        NoArea::Narrow => 0.5 * eps * size,
        NoArea::Strict => eps * eps,
    };
    let none = |a: f64| a.partial_cmp(&limit) != Some(std::cmp::Ordering::Greater);
    // A contour whose lobes cancel (a bow-tie: a quad with two corners
    // swapped) has no Newell area but spans a plane: it is not degenerate
    // but self-crossing, and the repair splits it into its lobes.
    if none(area) && none(geom::spread_normal(&pts[0]).length() / 2.0) {
        return Some("zero area (its vertices are collinear)");
    }
    None
}

/// An R*-tree of vertex positions (point boxes).
fn point_index(mesh: &Mesh, verts: &[VertexId]) -> BoxIndex {
    BoxIndex::new(verts.iter().map(|&v| {
        let p = mesh.pos(v);
        (p, p, v.0)
    }))
}

/// Vertex positions in an R*-tree, queried along segments.
pub struct Points {
    tree: BoxIndex,
    /// Segments whose box is wide in two or more directions are queried in
    /// pieces no wider than this (1/256 of the points' bounding-box diagonal),
    /// so that a long diagonal edge does not look at half the model.
    step: f64,
}

impl Points {
    pub fn new(mesh: &Mesh, verts: &[VertexId]) -> Points {
        let (lo, hi) = geom::index::bbox(verts.iter().map(|&v| mesh.pos(v)), 0.0);
        let diag = (hi - lo).length();
        Points {
            tree: point_index(mesh, verts),
            step: if diag > 0.0 {
                diag / 256.0
            } else {
                f64::INFINITY
            },
        }
    }

    /// Ids of the points in the boxes around the segment [a, b] grown by
    /// `eps` (a superset of those within `eps` of it), ascending.
    pub fn along(&self, a: DVec3, b: DVec3, eps: f64) -> Vec<u32> {
        let pad = DVec3::splat(eps);
        let mut ext = (b - a).abs().to_array();
        ext.sort_by(f64::total_cmp);
        let pieces = if ext[1] > self.step {
            (ext[1] / self.step).ceil().min(1024.0) as usize
        } else {
            1
        };
        if pieces == 1 {
            return self.tree.query(a.min(b) - pad, a.max(b) + pad);
        }
        let mut ids = Vec::new();
        for k in 0..pieces {
            let p = a.lerp(b, k as f64 / pieces as f64);
            let q = a.lerp(b, (k + 1) as f64 / pieces as f64);
            ids.extend(self.tree.query(p.min(q) - pad, p.max(q) + pad));
        }
        ids.sort_unstable();
        ids.dedup();
        ids
    }
}

/// Step 1: replaces every vertex that lies within `eps` of an earlier vertex
/// (statement order) that is itself kept, by the earliest such vertex, in
/// faces and wires, and removes it. Then drops faces that are left without
/// area. Returns the number of vertices merged and the dropped faces with
/// the reason, in statement order.
pub fn merge_vertices(mesh: &mut Mesh, eps: f64) -> (usize, Vec<(FaceId, String)>) {
    merge_vertices_in(mesh, eps, None)
}

/// [`merge_vertices`] among the vertices of `region` (see [`Region`]).
pub fn merge_vertices_in(
    mesh: &mut Mesh,
    eps: f64,
    region: Option<&Region>,
) -> (usize, Vec<(FaceId, String)>) {
    let order: Vec<VertexId> = mesh.vertices().filter(|&v| vertex_in(region, v)).collect();
    let nv = mesh.model().vertices.len();
    let mut rank = vec![u32::MAX; nv];
    for (k, &v) in order.iter().enumerate() {
        rank[v.idx()] = k as u32;
    }
    // Exact repeats follow the first vertex at their position (which is kept
    // or follows the same earlier vertex as they would); only the first
    // vertex at each position goes into the R*-tree.
    let key = |p: DVec3| (p + DVec3::ZERO).to_array().map(f64::to_bits); // -0 == 0
    let mut first_at: FxHashMap<[u64; 3], VertexId> = FxHashMap::default(); // lookup only
    let mut exact: Vec<Option<VertexId>> = vec![None; nv];
    let mut distinct: Vec<VertexId> = Vec::with_capacity(order.len());
    for &v in &order {
        match first_at.entry(key(mesh.pos(v))) {
            Entry::Occupied(e) => exact[v.idx()] = Some(*e.get()),
            Entry::Vacant(e) => {
                e.insert(v);
                distinct.push(v);
            }
        }
    }
    let index = point_index(mesh, &distinct);
    let mut rep: Vec<VertexId> = (0..nv as u32).map(VertexId).collect();
    let pad = DVec3::splat(eps);
    let mut merged = 0;
    for &v in &order {
        if let Some(first) = exact[v.idx()] {
            rep[v.idx()] = rep[first.idx()];
            merged += 1;
            continue;
        }
        let p = mesh.pos(v);
        let mut best: Option<VertexId> = None;
        for id in index.query(p - pad, p + pad) {
            let u = VertexId(id);
            if rank[u.idx()] >= rank[v.idx()] || rep[u.idx()] != u {
                continue;
            }
            if mesh.pos(u).distance(p) > eps {
                continue;
            }
            if best.is_none_or(|b| rank[u.idx()] < rank[b.idx()]) {
                best = Some(u);
            }
        }
        if let Some(u) = best {
            rep[v.idx()] = u;
            merged += 1;
        }
    }

    let dropped = apply_merges(mesh, &order, &rep, merged > 0, eps, region);
    (merged, dropped)
}

/// Replaces every vertex `v` by `rep[v]` in faces and wires and removes
/// the replaced vertices (when `any`), then drops the faces left without
/// area (checked on every face, or every face of `region` and every face
/// at a replaced vertex: see below). Returns the dropped faces with the
/// reason, in statement order.
fn apply_merges(
    mesh: &mut Mesh,
    order: &[VertexId],
    rep: &[VertexId],
    any: bool,
    eps: f64,
    region: Option<&Region>,
) -> Vec<(FaceId, String)> {
    let faces: Vec<FaceId> = match region {
        None => mesh.faces().collect(),
        Some(r) => {
            let mut at: FxHashSet<FaceId> = FxHashSet::default();
            for &v in order {
                if rep.get(v.idx()).is_some_and(|&r| r != v) {
                    for &e in mesh.vertex_edges(v) {
                        at.extend(mesh.edge(e).faces());
                    }
                }
            }
            mesh.faces()
                .filter(|f| r.has_face(*f) || at.contains(f))
                .collect()
        }
    };
    let mut dropped = Vec::new();
    let mut touched = vec![false; mesh.model().faces.len()];
    if any {
        for &f in &faces {
            let face = mesh.face(f);
            if !face.contours.iter().flatten().any(|&v| rep[v.idx()] != v) {
                continue;
            }
            touched[f.idx()] = true;
            let contours: Vec<Vec<VertexId>> = face
                .contours
                .iter()
                .map(|c| c.iter().map(|&v| rep[v.idx()]).collect())
                .collect();
            if distinct_after_cleaning(&contours[0]) < 3 {
                mesh.remove_face(f);
                dropped.push((
                    f,
                    "fewer than 3 distinct vertices after merging nearly coincident vertices"
                        .to_string(),
                ));
            } else {
                // Holes left without three distinct vertices are dropped here.
                mesh.set_face_contours(f, contours);
            }
        }
        let in_wire: FxHashSet<VertexId> = mesh
            .model()
            .wires
            .iter()
            .flat_map(|w| w.polylines.iter().flatten().copied())
            .collect();
        for &v in order {
            let r = rep[v.idx()];
            if r != v {
                if in_wire.contains(&v) {
                    mesh.replace_vertex(v, r); // faces no longer use v: only wires change
                }
                mesh.remove_vertex(v);
            }
        }
    }
    // A face the merges changed goes when it is thinner than about 2
    // epsilon; one they did not, only when it has no area as ugcheck
    // measures it (a sliver 1–2 epsilon wide that ugcopl's arrangement
    // made, dropped here, left its neighbours' edges unmatched).
    for &f in &faces {
        if mesh.is_face_live(f)
            && let Some(reason) = degeneracy_within(
                mesh,
                f,
                eps,
                if touched[f.idx()] {
                    NoArea::Sliver
                } else {
                    NoArea::Strict
                },
            )
        {
            mesh.remove_face(f);
            dropped.push((f, reason.to_string()));
        }
    }
    let mut frank = vec![u32::MAX; mesh.model().faces.len()];
    for (k, &f) in faces.iter().enumerate() {
        frank[f.idx()] = k as u32;
    }
    dropped.sort_by_key(|(f, _)| frank[f.idx()]);
    dropped
}

/// A tent's chord is shorter than this many epsilons (see [`collapse_tents`]).
const TENT_CHORD: f64 = 2.0;

/// Whether contour vertex `v` between neighbours `u` and `w` is a tent
/// (see [`collapse_tents`]): `u` and `w` less than [`TENT_CHORD`]·`eps`
/// apart (but not one point), and the triangle `u v w` degenerate as
/// `ugcheck` measures it: `v` within `eps` of the segment between them,
/// or the triangle's area at most ε².
pub fn is_tent(u: DVec3, v: DVec3, w: DVec3, eps: f64) -> bool {
    let chord = u.distance(w);
    if !(chord > 0.0 && chord < TENT_CHORD * eps) {
        return false;
    }
    let h = point_segment_distance(v, u, w).0;
    h <= eps || chord * h / 2.0 <= eps * eps
}

/// Collapses tents: a contour vertex `v` whose two neighbours `u` and `w`
/// are less than [`TENT_CHORD`]·`eps` apart, with the triangle `u v w`
/// degenerate as `ugcheck` measures it (`v` within `eps` of the segment
/// between them, or the triangle's area at most ε²), is replaced by the
/// nearer of the two (the earlier in statement order on a tie; the farther
/// where only it keeps the faces through `v` flat: a corner's point between
/// two folds' points), in every face and wire. The triangle is a piece of
/// its face that no mesher can cover without a degenerate triangle, and so
/// is any triangle that would take `v` with `u` or `w` (its sides there are
/// about an epsilon long).
/// Seen after the cleaning chain on CAD buildings: a floor's or tile's
/// corner with a wall's foot cut 1.3 epsilon either side of it (area 0.9
/// ε²), and a bump 0.75 epsilon high on a tile's side where a desk's feet
/// meet it. `v` moves by at most √5 epsilon (in the cases seen, 1.1 to
/// 1.4), as a weld moves a vertex by up to epsilon. Repeats while tents
/// are found, at most a few times. Returns the number of vertices replaced
/// and the faces dropped as in [`merge_vertices`].
pub fn collapse_tents(mesh: &mut Mesh, eps: f64) -> (usize, Vec<(FaceId, String)>) {
    collapse_tents_in(mesh, eps, None)
}

/// Whether joining a tent's tip (the first vertex) to a neighbour (the
/// second) is acceptable beyond keeping faces planar: see
/// [`collapse_tents_with`].
pub type AcceptJoin<'a> = dyn Fn(&Mesh, VertexId, VertexId) -> bool + 'a;

/// [`collapse_tents`], a tip joining the neighbour that keeps the faces
/// through it planar and that `accept` takes (the nearer first); where
/// neither is both, as [`collapse_tents`] chooses. ugclean's last step
/// passes a test that the join makes no two faces cross or overlap that
/// did not (property seeds 95031 rounded to 1 mm and 105079 to 0.1 mm:
/// a tip 1.1 epsilon from its nearer neighbour swept a sliver 2 epsilon
/// wide along a long edge over a face coplanar with its own).
pub fn collapse_tents_with(
    mesh: &mut Mesh,
    eps: f64,
    accept: &AcceptJoin<'_>,
) -> (usize, Vec<(FaceId, String)>) {
    collapse_tents_impl(mesh, eps, None, Some((accept, None)))
}

/// Where a tent's tip may leave the faces through it for different
/// neighbours (the first vertex, the tip; the second, its two neighbours
/// in the tent): `Some` of the neighbour each face through the tip takes,
/// or `None`.
pub type SplitTip<'a> =
    dyn Fn(&Mesh, VertexId, [VertexId; 2]) -> Option<Vec<(FaceId, VertexId)>> + 'a;

/// [`collapse_tents_with`], and where neither neighbour fits (keeps the
/// faces flat and passes `accept`), the tip is split as `split` says:
/// each face through it takes the neighbour `split` gives it (in the tent
/// itself, either: the tip just goes), where that keeps the face flat. A
/// strip narrower than 2 epsilon between two faces sharing an edge along
/// its middle, the strip's tents at that edge's ends: the face above takes
/// the strip's upper corner, the face below its lower one (property seed
/// 400886 on 3 × 2 rooms at 1 mm: a wall's foot strip 4 mm high on a
/// slab's side, the slab's two pieces meeting 2 mm from either edge).
/// Returns the tips joined or split, and the faces dropped.
pub fn collapse_tents_split(
    mesh: &mut Mesh,
    eps: f64,
    accept: &AcceptJoin<'_>,
    split: &SplitTip<'_>,
) -> (usize, Vec<(FaceId, String)>) {
    collapse_tents_impl(mesh, eps, None, Some((accept, Some(split))))
}

/// [`collapse_tents`] on the faces of `region` (see [`Region`]).
pub fn collapse_tents_in(
    mesh: &mut Mesh,
    eps: f64,
    region: Option<&Region>,
) -> (usize, Vec<(FaceId, String)>) {
    collapse_tents_impl(mesh, eps, region, None)
}

/// Passes of [`collapse_tents`] at most.
const TENT_PASSES: usize = 4;

type Tests<'a, 'b> = (&'a AcceptJoin<'b>, Option<&'a SplitTip<'b>>);

fn collapse_tents_impl(
    mesh: &mut Mesh,
    eps: f64,
    region: Option<&Region>,
    tests: Option<Tests<'_, '_>>,
) -> (usize, Vec<(FaceId, String)>) {
    let accept = tests.map(|t| t.0);
    let split = tests.and_then(|t| t.1);
    let mut replaced = 0;
    let mut dropped = Vec::new();
    if eps.is_nan() || eps <= 0.0 {
        return (replaced, dropped);
    }
    for pass in 0..TENT_PASSES {
        let order: Vec<VertexId> = mesh.vertices().collect();
        let nv = mesh.model().vertices.len();
        let mut rank = vec![u32::MAX; nv];
        for (k, &v) in order.iter().enumerate() {
            rank[v.idx()] = k as u32;
        }
        let mut joins: Vec<(VertexId, VertexId)> = Vec::new();
        // Tips split (see [`collapse_tents_split`]): the face, the tip and
        // the neighbour it takes there.
        let mut splits: Vec<(FaceId, VertexId, VertexId)> = Vec::new();
        let mut touched = vec![false; nv];
        // A join that, with the joins of this pass before it, would bend
        // a face they also move waits for the next pass, where it is
        // judged on the faces as they are then (property seed 103186 at
        // 10 times epsilon: two tips of one wing slab piece, joined in one
        // pass, bent it 1.1 epsilon where each alone did not).
        let mut moved = vec![false; mesh.model().faces.len()];
        let mut pending: FxHashMap<VertexId, DVec3> = FxHashMap::default();
        let faces: Vec<FaceId> = mesh.faces().filter(|&f| face_in(region, f)).collect();
        for f in faces {
            for c in &mesh.face(f).contours {
                let n = c.len();
                if n < 4 {
                    continue; // a triangle that thin is degenerate as a whole
                }
                for i in 0..n {
                    let (u, v, w) = (c[(i + n - 1) % n], c[i], c[(i + 1) % n]);
                    if u == w || u == v || v == w {
                        continue;
                    }
                    if touched[u.idx()] || touched[v.idx()] || touched[w.idx()] {
                        continue;
                    }
                    let (pu, pv, pw) = (mesh.pos(u), mesh.pos(v), mesh.pos(w));
                    if !is_tent(pu, pv, pw, eps) {
                        continue;
                    }
                    let through = mesh.vertex_faces(v);
                    let (du, dw) = (pv.distance(pu), pv.distance(pw));
                    let (near, far) = if du < dw || (du == dw && rank[u.idx()] < rank[w.idx()]) {
                        (u, w)
                    } else {
                        (w, u)
                    };
                    // The nearer neighbour, unless joining there would
                    // bend a face through the tip out of its plane by
                    // more than epsilon and joining the other would not
                    // (property seed 89021 at 10 times epsilon, oblique
                    // and curved: a column's face, 1.01 epsilon).
                    // With `accept`, the first that also passes it; where
                    // neither does, as without.
                    let flat = |t: VertexId| !bends(mesh, v, t, eps);
                    let fits = |t: VertexId| flat(t) && accept.is_none_or(|a| a(mesh, v, t));
                    // Of two that fit, the farther where it keeps every face
                    // through the tip flat (within a tenth of epsilon) and
                    // the nearer would bend one by a quarter epsilon more
                    // (property seed 180121 at 0.1 mm: a column's corner
                    // sunk 11 epsilon into the floor, cut there 1.2 epsilon
                    // from the two folds either side of it; the fold's
                    // point, a tip between the corner's and the other
                    // fold's, joined the nearer, the other fold's, 0.8
                    // epsilon off its own side's plane: that side then
                    // reached round the corner, a wedge 1.8 epsilon wide up
                    // the column that both sides covered, two overlapping
                    // patches after ugcut. The corner's point lies on both
                    // sides.)
                    let flatter = |a: VertexId, b: VertexId| {
                        let da = deviation_joined(mesh, v, a);
                        da <= 0.1 * eps && da + 0.25 * eps < deviation_joined(mesh, v, b)
                    };
                    // (The flatness first: `fits` runs the caller's test,
                    // the dearer, and the farther rarely is flatter.)
                    let to = if fits(near) && !(flatter(far, near) && fits(far)) {
                        near
                    } else if fits(far) || (!flat(near) && flat(far)) {
                        far
                    } else {
                        // Neither fits: split the tip where that fits, in
                        // a pass that moved none of its faces (the next,
                        // where this one moved some: a strip's two tips).
                        if split.is_some()
                            && pass + 1 < TENT_PASSES
                            && through.iter().any(|g| moved[g.idx()])
                        {
                            continue;
                        }
                        let each = split
                            .and_then(|sp| sp(mesh, v, [near, far]))
                            .filter(|each| {
                                each.iter().all(|&(g, t)| {
                                    !bends_with(mesh, &[g], &FxHashMap::default(), v, t, eps)
                                })
                            });
                        if let Some(each) = each {
                            for &(g, t) in &each {
                                splits.push((g, v, t));
                                touched[t.idx()] = true;
                            }
                            for x in [u, v, w] {
                                touched[x.idx()] = true;
                            }
                            for g in through {
                                moved[g.idx()] = true;
                            }
                            continue;
                        }
                        near
                    };
                    let shared: Vec<FaceId> =
                        through.iter().copied().filter(|g| moved[g.idx()]).collect();
                    if !shared.is_empty() && bends_with(mesh, &shared, &pending, v, to, eps) {
                        continue; // the next pass
                    }
                    joins.push((v, to));
                    pending.insert(v, mesh.pos(to));
                    for x in [u, v, w] {
                        touched[x.idx()] = true;
                    }
                    for g in through {
                        moved[g.idx()] = true;
                    }
                }
            }
        }
        if joins.is_empty() && splits.is_empty() {
            break;
        }
        // A split tip leaves each face for its own neighbour; then the
        // tip is used by none.
        for &(g, v, t) in &splits {
            if !mesh.is_face_live(g) {
                continue;
            }
            let contours: Vec<Vec<VertexId>> = mesh
                .face(g)
                .contours
                .iter()
                .map(|c| c.iter().map(|&x| if x == v { t } else { x }).collect())
                .collect();
            if !mesh.set_face_contours(g, contours) {
                dropped.push((
                    g,
                    "fewer than 3 distinct vertices after splitting a tent's tip".to_string(),
                ));
            }
        }
        let mut tips: Vec<VertexId> = splits.iter().map(|s| s.1).collect();
        tips.dedup();
        replaced += tips.len();
        for &v in &tips {
            mesh.remove_vertex(v); // (kept where a wire still passes it)
        }
        // Tents touch none of each other's vertices: every join is made.
        let (joined, d) = join_vertices_in(mesh, &joins, eps, region);
        replaced += joined;
        dropped.extend(d);
    }
    (replaced, dropped)
}

/// Whether joining vertex `v` to vertex `to` would leave a face through
/// `v` further than `eps` from its plane (as `ugcheck` measures it) where
/// it was not before.
fn bends(mesh: &Mesh, v: VertexId, to: VertexId, eps: f64) -> bool {
    bends_with(
        mesh,
        &mesh.vertex_faces(v),
        &FxHashMap::default(),
        v,
        to,
        eps,
    )
}

/// Whether joining `v` to `to`, after the moves of `pending` (vertex →
/// new place), leaves one of `faces` further than `eps` from its plane
/// where the moves of `pending` alone did not.
fn bends_with(
    mesh: &Mesh,
    faces: &[FaceId],
    pending: &FxHashMap<VertexId, DVec3>,
    v: VertexId,
    to: VertexId,
    eps: f64,
) -> bool {
    let pt = mesh.pos(to);
    faces.iter().any(|&f| {
        let after = deviation(mesh, f, pending, Some((v, pt)));
        after > eps && after > deviation(mesh, f, pending, None)
    })
}

/// Face `f`'s deviation from its plane (as `ugcheck` measures it) with
/// the moves of `pending` and, when given, vertex `v` at `pt` (a point
/// repeated next to itself counted once, as in the joined contour).
fn deviation(
    mesh: &Mesh,
    f: FaceId,
    pending: &FxHashMap<VertexId, DVec3>,
    moved: Option<(VertexId, DVec3)>,
) -> f64 {
    let pts: Vec<Vec<DVec3>> = mesh
        .face(f)
        .contours
        .iter()
        .map(|c| {
            let mut out: Vec<DVec3> = Vec::with_capacity(c.len());
            for &u in c {
                let p = match (moved, pending.get(&u)) {
                    (Some((v, pt)), _) if u == v => pt,
                    (_, Some(&p)) => p,
                    _ => mesh.pos(u),
                };
                if out.last() != Some(&p) {
                    out.push(p);
                }
            }
            if out.len() > 1 && out.first() == out.last() {
                out.pop();
            }
            out
        })
        .collect();
    geom::Plane::face_deviation(&pts).map_or(0.0, |(d, _)| d)
}

/// How far the faces through `v` lie from their planes once `v` is
/// joined to `to`: the largest deviation among them.
fn deviation_joined(mesh: &Mesh, v: VertexId, to: VertexId) -> f64 {
    let pt = mesh.pos(to);
    mesh.vertex_faces(v)
        .iter()
        .map(|&f| deviation(mesh, f, &FxHashMap::default(), Some((v, pt))))
        .fold(0.0, f64::max)
}

/// Joins vertex `from` to vertex `to` for each pair of `joins`, in every
/// face and wire, as [`collapse_tents`] does (a pair whose vertices an
/// earlier pair moved or kept is skipped). For the patch mesher: the ends
/// of a boundary edge a little longer than epsilon on which no triangle
/// is wider than epsilon. Returns the number of vertices joined and the
/// faces dropped as in [`merge_vertices`].
pub fn join_vertices(
    mesh: &mut Mesh,
    joins: &[(VertexId, VertexId)],
    eps: f64,
) -> (usize, Vec<(FaceId, String)>) {
    join_vertices_in(mesh, joins, eps, None)
}

/// [`join_vertices`], checking for faces left without area only in
/// `region` and at the joined vertices (see [`Region`]).
pub fn join_vertices_in(
    mesh: &mut Mesh,
    joins: &[(VertexId, VertexId)],
    eps: f64,
    region: Option<&Region>,
) -> (usize, Vec<(FaceId, String)>) {
    let order: Vec<VertexId> = mesh.vertices().collect();
    let nv = mesh.model().vertices.len();
    let mut rep: Vec<VertexId> = (0..nv as u32).map(VertexId).collect();
    let mut touched = vec![false; nv];
    let mut joined = 0;
    for &(from, to) in joins {
        if from == to || from.idx() >= nv || to.idx() >= nv {
            continue;
        }
        if touched[from.idx()] || touched[to.idx()] {
            continue;
        }
        rep[from.idx()] = to;
        touched[from.idx()] = true;
        touched[to.idx()] = true;
        joined += 1;
    }
    if joined == 0 {
        return (0, Vec::new());
    }
    let dropped = apply_merges(mesh, &order, &rep, true, eps, region);
    (joined, dropped)
}

/// Distinct vertices of a contour once consecutive repeats are removed.
fn distinct_after_cleaning(c: &[VertexId]) -> usize {
    let mut d: Vec<VertexId> = c.to_vec();
    d.sort_unstable();
    d.dedup();
    d.len()
}

/// What [`split_edges`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Split {
    /// Vertices inserted into edges.
    pub inserted: usize,
    /// Edges split.
    pub edges: usize,
    /// Passes made (the later ones check only the edges the previous one made).
    pub passes: usize,
}

/// Whether the chain of points `pts` (an edge's ends with the vertices to
/// go into it between them) leaves a point within `eps` of the interior of
/// a chain segment it is not an end of, or one of `left` (vertices on the
/// edge left out) within `eps` of the interior of any segment: splitting
/// the segments again would bring the point back.
fn zig_zags(pts: &[DVec3], left: &[DVec3], eps: f64) -> bool {
    let on = |p: DVec3, j: usize| on_edge_interior(p, pts[j], pts[j + 1], eps).is_some();
    (0..pts.len() - 1).any(|j| {
        (0..pts.len()).any(|i| i != j && i != j + 1 && on(pts[i], j))
            || left.iter().any(|&p| on(p, j))
    })
}

/// At most this many vertices on one edge are tried in subsets when all
/// of them together would make it zig-zag (see [`split_edges`]).
const ZIG_ZAG_SUBSETS: usize = 4;

/// The vertices of `on` (within `eps` of the interior of the edge from `a`
/// to `b`, in order along it) to insert: all of them, unless the edge
/// through them would zig-zag; then the largest subset (the first in
/// order among those as large) that leaves no zig-zag and none of the
/// others within `eps` of the new edges, when there is one.
fn insertable(mesh: &Mesh, a: VertexId, b: VertexId, on: Vec<VertexId>, eps: f64) -> Vec<VertexId> {
    let chain = |keep: &[VertexId]| -> Vec<DVec3> {
        std::iter::once(a)
            .chain(keep.iter().copied())
            .chain([b])
            .map(|v| mesh.pos(v))
            .collect()
    };
    if on.len() < 2 || on.len() > ZIG_ZAG_SUBSETS || !zig_zags(&chain(&on), &[], eps) {
        return on;
    }
    // The proper subsets, largest first; as large, in lexicographic order
    // of their positions: with position i as bit k - 1 - i, that is
    // descending order of the masks (a stable sort keeps it).
    let k = on.len();
    let bit = |i: usize| 1u32 << (k - 1 - i);
    let mut masks: Vec<u32> = (1..(1u32 << k) - 1).rev().collect();
    masks.sort_by_key(|m| std::cmp::Reverse(m.count_ones()));
    for m in masks {
        let (keep, left): (Vec<usize>, Vec<usize>) = (0..k).partition(|&i| m & bit(i) != 0);
        let keep: Vec<VertexId> = keep.into_iter().map(|i| on[i]).collect();
        let left: Vec<DVec3> = left.into_iter().map(|i| mesh.pos(on[i])).collect();
        if !zig_zags(&chain(&keep), &left, eps) {
            return keep;
        }
    }
    on
}

/// The vertices of `index` that lie within `eps` of the interior of edge `e`
/// (farther than `eps` from both ends), still used by a face, in order from
/// `e.v[0]` to `e.v[1]`.
fn vertices_on_edge(mesh: &Mesh, index: &Points, e: EdgeId, eps: f64) -> Vec<VertexId> {
    let ed = mesh.edge(e);
    let (a, b) = (mesh.pos(ed.v[0]), mesh.pos(ed.v[1]));
    let mut on: Vec<(f64, VertexId)> = Vec::new();
    for id in index.along(a, b, eps) {
        let v = VertexId(id);
        if v == ed.v[0] || v == ed.v[1] || mesh.vertex_edges(v).is_empty() {
            continue;
        }
        if let Some(t) = on_edge_interior(mesh.pos(v), a, b, eps) {
            on.push((t, v));
        }
    }
    on.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    on.into_iter().map(|(_, v)| v).collect()
}

/// Step 2: inserts every vertex of a sound face (no edge of `eps` or
/// less, and wider than about `eps`: `ugcheck`'s measure, so that no face
/// it checks keeps a T-vertex; a sliver 1.8 epsilon wide, which
/// [`degeneracy`] takes as without area, kept one in dirty-building seed
/// 8628 with stairs) that
/// lies within `eps` of the interior of an edge of a sound face into that
/// edge, in every face that uses the edge, several along one edge in order.
/// Each face is rewritten once per pass; later passes check only the edges
/// the previous one created (a vertex inserted slightly off the line can
/// bring another within reach), until nothing changes.
///
/// Where all the vertices on an edge would make it zig-zag (an end or one
/// of them within `eps` of the interior of a new edge), inserting them
/// cannot end: each pass brings the points back into the new edges. Seen
/// on property seed 2010 (placed): a ramp's and a railing's coincident
/// pieces, 1.6 epsilon apart, cornered 1 epsilon either side of a desk
/// side's ledge, an edge 2 epsilon long, whose ends lay within epsilon of
/// the edge between the two corners; the passes ran out with the contours
/// full of spikes, and a T-vertex was left. Then the largest subset of
/// them that leaves no zig-zag and none of the others within `eps` of
/// the new edges goes in ([`insertable`]; there one corner: the other is
/// then farther than epsilon from both new edges).
pub fn split_edges(mesh: &mut Mesh, eps: f64) -> Split {
    split_edges_in(mesh, eps, None)
}

/// [`split_edges`] for the vertices and edges of the faces of `region`
/// (see [`Region`]).
pub fn split_edges_in(mesh: &mut Mesh, eps: f64, region: Option<&Region>) -> Split {
    let faces: Vec<FaceId> = mesh.faces().filter(|&f| face_in(region, f)).collect();
    let mut sound = vec![false; mesh.model().faces.len()];
    for &f in &faces {
        sound[f.idx()] = degeneracy_within(mesh, f, eps, NoArea::Narrow).is_none();
    }
    let mut verts: Vec<VertexId> = faces
        .iter()
        .filter(|f| sound[f.idx()])
        .flat_map(|&f| mesh.face(f).contours.iter().flatten().copied())
        .collect();
    verts.sort_unstable();
    verts.dedup();
    let index = Points::new(mesh, &verts);
    let uses_sound = |mesh: &Mesh, e: EdgeId| {
        mesh.edge(e)
            .uses
            .iter()
            .any(|u| sound.get(u.face.idx()).copied().unwrap_or(false))
    };
    let mut work: Vec<EdgeId> = mesh.edges().filter(|&e| uses_sound(mesh, e)).collect();
    let mut st = Split::default();
    while !work.is_empty() && st.passes < MAX_SPLIT_PASSES {
        st.passes += 1;
        let mut plan: FxHashMap<EdgeId, Vec<VertexId>> = FxHashMap::default(); // lookup only
        let mut touched: Vec<FaceId> = Vec::new();
        for &e in &work {
            if !mesh.is_edge_live(e) {
                continue;
            }
            let on = vertices_on_edge(mesh, &index, e, eps);
            if on.is_empty() {
                continue;
            }
            let [a, b] = mesh.edge(e).v;
            let on = insertable(mesh, a, b, on, eps);
            st.inserted += on.len();
            st.edges += 1;
            touched.extend(mesh.edge(e).faces());
            plan.insert(e, on);
        }
        if plan.is_empty() {
            break;
        }
        touched.sort_unstable();
        touched.dedup();
        let newest = mesh.edges().map(|e| e.0).max().unwrap_or(0);
        for &f in &touched {
            let face = mesh.face(f);
            let contours: Vec<Vec<VertexId>> = face
                .contours
                .iter()
                .enumerate()
                .map(|(ci, c)| {
                    let es = mesh.contour_edges(f, ci);
                    let mut out = Vec::with_capacity(c.len() + 2);
                    for (i, &v) in c.iter().enumerate() {
                        out.push(v);
                        if let Some(list) = plan.get(&es[i]) {
                            if v == mesh.edge(es[i]).v[0] {
                                out.extend(list.iter().copied());
                            } else {
                                out.extend(list.iter().rev().copied());
                            }
                        }
                    }
                    out
                })
                .collect();
            mesh.set_face_contours(f, contours);
        }
        work = touched
            .iter()
            .filter(|&&f| mesh.is_face_live(f))
            .flat_map(|&f| mesh.face_edges(f))
            .filter(|&e| e.0 > newest && uses_sound(mesh, e))
            .collect();
        work.sort_unstable();
        work.dedup();
    }
    st
}

/// For each of `used` (vertices of `model`, in id order) that has any, the
/// others of `used` more than `min` and at most `max` from it, found in
/// cells of `max` (each cell's vertices latest first).
fn records_near(
    model: &Model,
    used: &[VertexId],
    min: f64,
    max: f64,
) -> FxHashMap<VertexId, Vec<VertexId>> {
    let key = |p: DVec3| {
        let q = (p / max).floor();
        (q.x as i64, q.y as i64, q.z as i64)
    };
    // Cells, each a list through `next` (index into `used`).
    const NONE: u32 = u32::MAX;
    let mut head: FxHashMap<(i64, i64, i64), u32> = FxHashMap::default();
    let mut next = vec![NONE; used.len()];
    for (i, &v) in used.iter().enumerate() {
        let h = head.entry(key(model.pos(v))).or_insert(NONE);
        next[i] = *h;
        *h = i as u32;
    }
    let mut partners: FxHashMap<VertexId, Vec<VertexId>> = FxHashMap::default();
    for &v in used {
        let p = model.pos(v);
        let (x, y, z) = key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let mut i = head.get(&(x + dx, y + dy, z + dz)).copied().unwrap_or(NONE);
                    while i != NONE {
                        let w = used[i as usize];
                        let d = model.pos(w).distance(p);
                        if w != v && d > min && d <= max {
                            partners.entry(v).or_default().push(w);
                        }
                        i = next[i as usize];
                    }
                }
            }
        }
    }
    partners
}

/// The joins that remove T-vertices an edge of `out` (a patch mesh, or
/// `model` itself) makes where it leaves a corner: a vertex of `model`
/// more than epsilon and at most 2 epsilon from the corner (the weld left
/// the two apart) that lies within epsilon of the edge's interior joins
/// the corner. Such pairs are rare, so this looks only at the edges
/// leaving a vertex that has one. (ugcut after meshing, with `out` its
/// patches; ugclean's last step, on the model itself.)
pub fn near_corner_joins(model: &Model, out: &Model, eps: f64) -> Vec<(VertexId, VertexId)> {
    if !(eps.is_finite() && eps > 0.0) {
        return Vec::new(); // no pair is more than 0 and at most 0 apart
    }
    let used: Vec<VertexId> = {
        let mut v: Vec<VertexId> = model
            .faces
            .iter()
            .flat_map(|f| f.contours.iter().flatten().copied())
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let partners = records_near(model, &used, eps, 2.0 * eps);
    if partners.is_empty() {
        return Vec::new();
    }
    let mut has = vec![false; out.vertices.len()];
    for v in partners.keys() {
        has[v.idx()] = true;
    }
    let mut joins = Vec::new();
    for f in &out.faces {
        for c in &f.contours {
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                for (x, y) in [(a, b), (b, a)] {
                    if !has[x.idx()] {
                        continue;
                    }
                    for &w in &partners[&x] {
                        if w != y
                            && on_edge_interior(out.pos(w), out.pos(x), out.pos(y), eps).is_some()
                        {
                            joins.push((w, x));
                        }
                    }
                }
            }
        }
    }
    joins
}

/// Back-to-back near twins: two faces facing opposite ways whose vertices
/// pair off one to one within 2 epsilon, not all on the same records (a
/// stair step's bottom 4 mm below the floor it is sunk into, at 1 mm with
/// epsilon 2.1 mm; a table leg's foot, property seed 400840 on 3 × 2
/// rooms; a globe's facets against the ceiling panel cut round them). To
/// `ugcheck` they are one region back to back, which is sound; but meshed
/// apart (their edges divided and their insides triangulated each on its
/// own) their patches overlap. Joined, they share their records, and the
/// mesher gives the second the first's patches.
///
/// Returns the joins `(from, to)` of each pair: the vertices of one face to
/// their partners in the other. The face that moves is the one whose move
/// bends the faces at its vertices less (a step's sides take its bottom's
/// move along their own planes, the floor's other pieces would bend); on
/// a tie the later face. A pair is left alone where, with every pair's
/// move made, a face at a moved vertex would end more than half an
/// epsilon off its plane and further than it was (a wedge's thin end, its
/// two faces within 2 epsilon: joined, its end face would bend). (ugcut
/// before meshing again; ugclean's last step.)
pub fn near_twin_joins(model: &Model, eps: f64) -> Vec<Vec<(VertexId, VertexId)>> {
    if !(eps.is_finite() && eps > 0.0) {
        return Vec::new();
    }
    let reach = 2.0 * eps;
    let faces: Vec<u32> = model.top_faces().map(|f| f.0).collect();
    let verts_of = |f: u32| -> Vec<VertexId> {
        let mut vs: Vec<VertexId> = model.faces[f as usize]
            .contours
            .iter()
            .flatten()
            .copied()
            .collect();
        vs.sort_unstable();
        vs.dedup();
        vs
    };
    // The faces at each vertex.
    let mut at: FxHashMap<VertexId, Vec<u32>> = FxHashMap::default();
    for &f in &faces {
        for v in verts_of(f) {
            at.entry(v).or_default().push(f);
        }
    }
    // The other records within 2 epsilon of each vertex that has any (at
    // any distance: -1 is below every one).
    let mut used: Vec<VertexId> = at.keys().copied().collect();
    used.sort_unstable();
    let near = records_near(model, &used, -1.0, reach);
    let normal = |f: u32| -> Option<DVec3> {
        let c = model.faces[f as usize].contours.first()?;
        let pts: Vec<DVec3> = c.iter().map(|&v| model.pos(v)).collect();
        newell_normal(&pts).try_normalize()
    };
    let deviation = |g: u32, to: &FxHashMap<VertexId, VertexId>| -> f64 {
        let pts: Vec<Vec<DVec3>> = model.faces[g as usize]
            .contours
            .iter()
            .map(|c| {
                c.iter()
                    .map(|v| model.pos(*to.get(v).unwrap_or(v)))
                    .collect()
            })
            .collect();
        geom::Plane::face_deviation(&pts).map_or(0.0, |(d, _)| d)
    };
    let unmoved = FxHashMap::default();
    // How much further off their planes the faces at the moved vertices
    // end (the largest increase).
    let faces_at = |moves: &[(VertexId, VertexId)]| -> Vec<u32> {
        let mut gs: Vec<u32> = moves
            .iter()
            .flat_map(|(u, _)| at[u].iter().copied())
            .collect();
        gs.sort_unstable();
        gs.dedup();
        gs
    };
    let bend = |moves: &[(VertexId, VertexId)]| -> f64 {
        let to: FxHashMap<VertexId, VertexId> = moves.iter().copied().collect();
        faces_at(moves)
            .iter()
            .map(|&g| deviation(g, &to) - deviation(g, &unmoved))
            .fold(0.0, f64::max)
    };
    // Each pair once: its moves.
    let mut chosen: Vec<Vec<(VertexId, VertexId)>> = Vec::new();
    let mut seen: FxHashSet<(u32, u32)> = FxHashSet::default();
    for &b in &faces {
        let vb = verts_of(b);
        // A partner face has a record near one of b's vertices at least
        // (not all shared); most faces have none.
        let partners: Vec<VertexId> = vb
            .iter()
            .filter_map(|u| near.get(u))
            .flatten()
            .copied()
            .collect();
        if partners.is_empty() {
            continue;
        }
        let mut cands: Vec<u32> = partners
            .iter()
            .flat_map(|w| at.get(w).into_iter().flatten().copied())
            .filter(|&a| a != b)
            .collect();
        cands.sort_unstable();
        cands.dedup();
        for a in cands {
            if !seen.insert((a.min(b), a.max(b))) {
                continue;
            }
            let va = verts_of(a);
            if va == vb {
                continue;
            }
            let (Some(na), Some(nb)) = (normal(a), normal(b)) else {
                continue;
            };
            if na.dot(nb) > -geom::intersect::COPLANAR_COS {
                continue;
            }
            // The vertices paired off: each the other's nearest within 2
            // epsilon. One left over must lie on the other face's boundary
            // (a point put into an edge for a neighbour: the join puts it
            // into the other face's edge too).
            let nearest = |u: VertexId, among: &[VertexId]| -> Option<VertexId> {
                let p = model.pos(u);
                among
                    .iter()
                    .map(|&w| (model.pos(w).distance(p), w))
                    .filter(|&(d, _)| d <= reach)
                    .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
                    .map(|(_, w)| w)
            };
            let mut pairs: Vec<(VertexId, VertexId)> = Vec::with_capacity(vb.len());
            let mut left_b: Vec<VertexId> = Vec::new();
            for &u in &vb {
                match nearest(u, &va) {
                    Some(w) if nearest(w, &vb) == Some(u) => pairs.push((u, w)),
                    _ => left_b.push(u),
                }
            }
            if pairs.len() < 3 {
                continue;
            }
            let left_a: Vec<VertexId> = va
                .iter()
                .copied()
                .filter(|w| !pairs.iter().any(|p| p.1 == *w))
                .collect();
            // A vertex left over stays where it is; the other face's
            // vertices move to its face, so it must lie on their moved
            // boundary.
            if !left_a.is_empty() && !left_b.is_empty() {
                continue;
            }
            let on_boundary = |x: VertexId, f: u32, to: &dyn Fn(VertexId) -> VertexId| {
                let p = model.pos(x);
                model.faces[f as usize].contours.iter().any(|c| {
                    (0..c.len()).any(|i| {
                        let (s, t) = (model.pos(to(c[i])), model.pos(to(c[(i + 1) % c.len()])));
                        point_segment_distance(p, s, t).0 <= eps
                    })
                })
            };
            let to_a = |v: VertexId| pairs.iter().find(|p| p.0 == v).map_or(v, |p| p.1);
            let to_b = |v: VertexId| pairs.iter().find(|p| p.1 == v).map_or(v, |p| p.0);
            if !left_a.iter().all(|&x| on_boundary(x, b, &to_a))
                || !left_b.iter().all(|&x| on_boundary(x, a, &to_b))
            {
                continue;
            }
            pairs.retain(|(u, w)| u != w);
            let back: Vec<(VertexId, VertexId)> = pairs.iter().map(|&(u, w)| (w, u)).collect();
            // b moves onto a unless b has a vertex left over; on a tie in
            // bending, the later face moves.
            let b_moves = if !left_b.is_empty() {
                false
            } else if !left_a.is_empty() {
                true
            } else {
                let (from_b, from_a) = (bend(&pairs), bend(&back));
                from_b < from_a || (from_b == from_a && b > a)
            };
            chosen.push(if b_moves { pairs } else { back });
        }
    }
    // With every pair's move made (a vertex moves once: the first pair
    // that moves it, or that keeps it as a target, decides), the pairs
    // bending a face past half an epsilon go, until none does.
    let tol = 0.5 * eps;
    let mut live = vec![true; chosen.len()];
    let mut settled = false;
    for _ in 0..8 {
        let mut to: FxHashMap<VertexId, VertexId> = FxHashMap::default();
        let mut fixed: FxHashSet<VertexId> = FxHashSet::default();
        for (k, moves) in chosen.iter().enumerate() {
            if !live[k] {
                continue;
            }
            let clash = moves.iter().any(|(u, w)| {
                fixed.contains(u) || to.contains_key(w) || to.get(u).is_some_and(|x| x != w)
            });
            if clash {
                live[k] = false;
                continue;
            }
            for &(u, w) in moves {
                to.insert(u, w);
                fixed.insert(w);
            }
        }
        let all: Vec<(VertexId, VertexId)> = to.iter().map(|(&u, &w)| (u, w)).collect();
        let bent: FxHashSet<u32> = faces_at(&all)
            .into_iter()
            .filter(|&g| {
                let d = deviation(g, &to);
                d > tol && d > deviation(g, &unmoved)
            })
            .collect();
        if bent.is_empty() {
            settled = true;
            break;
        }
        let mut dropped = false;
        for (k, moves) in chosen.iter().enumerate() {
            if live[k]
                && moves
                    .iter()
                    .any(|(u, _)| at[u].iter().any(|g| bent.contains(g)))
            {
                live[k] = false;
                dropped = true;
            }
        }
        if !dropped {
            break;
        }
    }
    if !settled {
        return Vec::new();
    }
    chosen
        .into_iter()
        .zip(live)
        .filter(|(m, l)| *l && !m.is_empty())
        .map(|(m, _)| m)
        .collect()
}
