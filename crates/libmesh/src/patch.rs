//! The patch mesher (Smith 1991, §3.1): every surface becomes triangles and
//! convex quadrilaterals of about a given edge length, without T-vertices.
//!
//! It meshes whatever it is given ([`prepare`]): vertices within epsilon are
//! welded and T-vertices inserted (the grouper's first two steps), faces
//! that are not planar are folded into triangles as `ugplanar` would, and
//! every face's contours are made sound in its plane by a snap-rounded
//! arrangement ([`winged::pieces::repair`]: collinear runs a ulp off the
//! line, spikes, a hole touching the outer contour, contours meeting at a
//! point; a contour that crosses itself is split at its crossings and keeps
//! its even-odd region). Faces with no area left are dropped. Then, for each
//! face (a surface: run `ugvlmerge` first so that coplanar faces of one
//! material are joined; otherwise each face is meshed on its own, still
//! without T-vertices):
//!
//! 1. every boundary edge is divided into the whole number of equal segments
//!    nearest to `len` (7.6 with len 2 → 4 segments of 1.9). The division
//!    depends only on the edge, so an edge shared by several faces is divided
//!    identically in all of them (computed once, from its lower vertex id);
//! 2. a grid of rectangles is laid in the face's plane, aligned with its
//!    longest outer edge and fitted to its bounding box in that frame (the
//!    whole number of cells nearest to `len` each way). Every cell that lies
//!    inside the face with the boundary keeping clear of it (within a quarter
//!    cell there is no boundary point but at its corners, and no boundary
//!    segment but its own edges or segments leaving a corner along a grid
//!    line) becomes a rectangular patch; a rectangle therefore becomes only
//!    rectangles, and no thin gaps are left for the triangles;
//! 3. the rest is a constrained Delaunay triangulation (spade) of the boundary
//!    points and the corners along the cells' outline, refined (Ruppert-style,
//!    minimum angle `angle`, area at most 0.6·len²) with boundary segments and
//!    cell edges kept whole; needles (a corner within epsilon of the
//!    opposite side) are flipped away or split by a point inside, and one
//!    left on a boundary edge shorter than 8 epsilon (a jog), or whose
//!    shortest side is a boundary edge, gets a point straight across that
//!    edge, and the triangulation is read again; then
//!    pairs of triangles that form a well-shaped convex quadrilateral are
//!    joined;
//! 4. where a face meets another at a small angle (a globe's cap facet and
//!    the ceiling it passes through), no patch may lie wholly in the other
//!    face's plane over it ([`shallow`]): the points inside the face that
//!    lie there are taken out and their patches triangulated again, or a
//!    diagonal is flipped.
//!
//! Where no triangle wider than epsilon fits on a short boundary edge, or
//! a patch edge leaving a corner passes within epsilon of another face's
//! vertex just over epsilon from that corner, the vertices are joined and
//! the model meshed again ([`cut`]).
//!
//! Patches keep the face's material and orientation and are named `NAME.1`,
//! `NAME.2`, … (unnamed faces give unnamed patches). New vertices are named
//! after their edge (`a:b.1`) or their face (`NAME.v1`), and written just
//! before the first patch that uses them.

use geom::index::bbox;
use geom::{BoxIndex, DVec2, DVec3, Frame, Plane};
use rustc_hash::{FxHashMap, FxHashSet};
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};
use ug::{Face, FaceId, Item, Model, Vertex, VertexId};
use winged::pieces::replace;

mod reuse;
mod shallow;

/// A face's patches: each a list of contours (one, for a patch).
type Patches = Vec<Vec<Vec<VertexId>>>;

#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Desired patch edge length (model units).
    pub len: f64,
    /// Distance tolerance.
    pub eps: f64,
    /// Minimum triangle angle aimed at by the refinement, degrees.
    pub angle: f64,
    /// Join pairs of triangles into convex quads.
    pub quads: bool,
}

/// Figures about the result.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    pub faces: usize,
    pub patches: usize,
    pub quads: usize,
    pub triangles: usize,
    pub grid_cells: usize,
    pub min_edge: f64,
    pub mean_edge: f64,
    pub max_edge: f64,
    /// Smallest interior angle of any triangle, degrees.
    pub worst_angle: f64,
    /// Vertices welded into an earlier one within epsilon.
    pub welded: usize,
    /// Boundary edges a little longer than epsilon on which no triangle
    /// could be wider than epsilon, their ends joined (see [`cut`]).
    pub joined: usize,
    /// T-vertices inserted into edges.
    pub tvertices: usize,
    /// Non-planar faces folded into triangles first.
    pub tessellated: Vec<String>,
    /// Faces whose contours crossed or touched themselves (repaired; the
    /// count of pieces is not kept: 0).
    pub repaired: Vec<(String, usize)>,
    /// Faces left out, and why (no area).
    pub dropped: Vec<(String, String)>,
    /// Faces on the same vertices as an earlier face, given its patches
    /// (mirrored when they face the other way).
    pub twins: usize,
    /// Faces meshed by the plain triangulation because the grid and the
    /// refinement could not be fitted (triangles of poorer shape).
    pub plain: Vec<String>,
    /// After joins, faces meshed again, and faces replayed from the round
    /// before (the joins changed nothing they depend on; see [`cut`]).
    pub remeshed: usize,
    pub replayed: usize,
    /// Vertices of other faces resting inside a face (within epsilon of
    /// its plane, more than epsilon inside its contours), made corners of
    /// its patches (see [`resting_points`]).
    pub resting: usize,
    /// Diagonals flipped inside faces so that fewer patches lie in the
    /// plane of a face meeting theirs at a small angle (see [`shallow`]).
    pub shallow_flips: usize,
    /// Points inside faces taken out for the same reason, their patches
    /// triangulated again.
    pub shallow_points: usize,
    /// Points inside faces moved out of the band where none could be taken
    /// out.
    pub shallow_moved: usize,
}

/// The default patch length: 2% of the model's bounding-box diagonal.
pub fn default_len(m: &Model) -> f64 {
    0.02 * m.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length())
}

/// Labels of faces as `ugcheck` gives them: the name, or `#k` for the k-th
/// top-level face (from 1).
fn labels(m: &Model) -> Vec<String> {
    let mut l = vec![String::new(); m.faces.len()];
    for (k, f) in m.top_faces().enumerate() {
        l[f.idx()] = m.faces[f.idx()]
            .name
            .clone()
            .unwrap_or_else(|| format!("#{}", k + 1));
    }
    l
}

/// The frame a face is meshed in: its outer contour's Newell normal, u
/// along its longest outer edge (so the grid is aligned with it). The
/// preparation repairs each face in this same frame, so that every
/// decision about its contours is made on the same coordinates.
pub fn mesh_frame(pts: &[Vec<DVec3>]) -> Option<Frame> {
    let n = geom::face_normal(pts)?;
    let outer = &pts[0];
    let (mut best, mut dir) = (0.0, DVec3::X);
    for i in 0..outer.len() {
        let d = outer[(i + 1) % outer.len()] - outer[i];
        if d.length() > best {
            best = d.length();
            dir = d;
        }
    }
    Some(Frame::with_u(outer[0], n, dir))
}

/// Makes any flat model meshable: welds vertices within `eps`, inserts
/// T-vertices, folds non-planar faces into triangles, repairs every face's
/// contours in its plane (see the module documentation) and drops faces
/// without area, recording each in `stats`.
pub fn prepare(m: &Model, eps: f64, stats: &mut Stats) -> Model {
    prepare_joining(m, eps, stats, &[], false)
}

/// Faces whose bounding box comes within this many epsilons of an edge a
/// join changes are prepared again after the joins (see [`join_region`]).
const JOIN_REACH: f64 = 64.0;

/// The faces (and their vertices) that joining `joins` in prepared model
/// `m` can change: those whose bounding box comes within [`JOIN_REACH`]
/// epsilon of an edge at a joined vertex, taken from both its old and its
/// new end. Welding, splitting, tents and repairs after the joins reach
/// only a few epsilons from where the joins moved edges (`m` is a fixed
/// point of [`prepare`] elsewhere: preparing the 100k-face building's
/// chain output or its user's pipeline output again gives the same bytes).
fn join_region(m: &Model, eps: f64, joins: &[(VertexId, VertexId)]) -> winged::weld::Region {
    let nv = m.vertices.len();
    let mut partner: FxHashMap<VertexId, Vec<VertexId>> = FxHashMap::default();
    for &(a, b) in joins {
        if a.idx() < nv && b.idx() < nv {
            partner.entry(a).or_default().push(b);
            partner.entry(b).or_default().push(a);
        }
    }
    // Boxes of the edges at joined vertices, each stretched to the other
    // end of its join.
    let mut boxes: Vec<(DVec3, DVec3)> = Vec::new();
    for f in m.top_faces() {
        for c in &m.faces[f.idx()].contours {
            let n = c.len();
            for i in 0..n {
                let Some(others) = partner.get(&c[i]) else {
                    continue;
                };
                for w in [c[(i + n - 1) % n], c[(i + 1) % n]] {
                    let pts = std::iter::once(m.pos(c[i]))
                        .chain(std::iter::once(m.pos(w)))
                        .chain(others.iter().map(|&o| m.pos(o)));
                    boxes.push(bbox(pts, JOIN_REACH * eps));
                }
            }
        }
    }
    for (&a, others) in &partner {
        boxes.push(bbox(
            std::iter::once(m.pos(a)).chain(others.iter().map(|&o| m.pos(o))),
            JOIN_REACH * eps,
        ));
    }
    let index = BoxIndex::new(
        boxes
            .iter()
            .enumerate()
            .map(|(k, &(lo, hi))| (lo, hi, k as u32)),
    );
    let mut faces = vec![false; m.faces.len()];
    let mut verts = vec![false; nv];
    for f in m.top_faces() {
        let face = &m.faces[f.idx()];
        let (lo, hi) = bbox(face.contours.iter().flatten().map(|&v| m.pos(v)), 0.0);
        if !index.query(lo, hi).is_empty() {
            faces[f.idx()] = true;
            for &v in face.contours.iter().flatten() {
                verts[v.idx()] = true;
            }
        }
    }
    winged::weld::Region::new(faces, verts)
}

/// [`prepare`], first joining each pair `(from, to)` of `joins` (vertices
/// of `m`) as [`winged::weld::join_vertices`] does. `local`: `m` is
/// prepared already, and only the faces the joins can reach are prepared
/// again ([`join_region`]).
fn prepare_joining(
    m: &Model,
    eps: f64,
    stats: &mut Stats,
    joins: &[(VertexId, VertexId)],
    local: bool,
) -> Model {
    let region = (local && !joins.is_empty() && eps.is_finite() && eps > 0.0)
        .then(|| join_region(m, eps, joins));
    let region = region.as_ref();
    let labels = labels(m);
    let label = |f: FaceId| {
        labels
            .get(f.idx())
            .cloned()
            .unwrap_or_else(|| format!("#{}", f.0 + 1))
    };
    let mut mesh = winged::Mesh::from_model(m.clone());
    for r in mesh.repairs() {
        if let winged::Repair::DroppedFace { face } = r {
            stats
                .dropped
                .push((label(*face), "fewer than 3 distinct vertices".into()));
        }
    }
    if !joins.is_empty() {
        let (joined, dropped) = winged::weld::join_vertices_in(&mut mesh, joins, eps, region);
        stats.joined += joined;
        stats
            .dropped
            .extend(dropped.into_iter().map(|(f, why)| (label(f), why)));
    }
    let (welded, dropped) = winged::weld::merge_vertices_in(&mut mesh, eps, region);
    stats.welded += welded;
    stats
        .dropped
        .extend(dropped.into_iter().map(|(f, why)| (label(f), why)));
    stats.tvertices += winged::weld::split_edges_in(&mut mesh, eps, region).inserted;
    // Tents (a vertex within epsilon of the short chord between its
    // neighbours) cannot be meshed without a sliver: the vertex joins the
    // nearer neighbour, and the edges that changed are split again.
    let (tents, dropped) = winged::weld::collapse_tents_in(&mut mesh, eps, region);
    if tents > 0 {
        stats.welded += tents;
        stats
            .dropped
            .extend(dropped.into_iter().map(|(f, why)| (label(f), why)));
        stats.tvertices += winged::weld::split_edges_in(&mut mesh, eps, region).inserted;
    }
    let faces: Vec<FaceId> = mesh
        .faces()
        .filter(|&f| winged::weld::face_in(region, f))
        .collect();
    for f in faces {
        let name = mesh
            .face(f)
            .name
            .clone()
            .unwrap_or_else(|| format!("f{}", f.0 + 1));
        // Not planar: the triangles ugplanar would make.
        let pts = mesh.face_points(f);
        let off = Plane::face_deviation(&pts).map_or(0.0, |(d, _)| d);
        if off > eps
            && let Some(tris) = geom::triangulate::fold_triangles(&pts)
        {
            let ids: Vec<VertexId> = mesh.face(f).contours.iter().flatten().copied().collect();
            let pieces = tris
                .iter()
                .map(|t| vec![t.iter().map(|&i| ids[i]).collect()])
                .collect();
            stats.tessellated.push(label(f));
            replace(&mut mesh, f, pieces, &name, "t");
        }
    }
    // Every face sound in the frame it is meshed in (see `mesh_frame`).
    let mut settled = winged::pieces::Settled::default();
    winged::pieces::repair_all_in(
        &mut mesh,
        eps,
        &mesh_frame,
        &|_| false,
        &mut settled,
        region,
    );
    stats.tvertices += settled.tvertices;
    for f in &settled.repaired {
        stats.repaired.push((label(*f), 0));
    }
    for f in &settled.removed {
        stats
            .dropped
            .push((label(*f), "no area (its contours enclose nothing)".into()));
    }
    mesh.into_model()
}

/// The division points (interior, from the lower vertex id to the higher) of every edge.
struct Divisions {
    map: FxHashMap<(VertexId, VertexId), Vec<VertexId>>,
    /// Where the edge must also be divided (parameters from the lower
    /// vertex id): the feet of the face's own vertices that lie across a
    /// thin part of it (see [`feet`]).
    feet: FxHashMap<(VertexId, VertexId), Vec<f64>>,
    /// Every edge of the faces (lower vertex id first), sorted, and per
    /// vertex the edges that end there: `edges[ends[start[v]..start[v + 1]]]`
    /// (see [`Ctx::divided`]).
    edges: Vec<(VertexId, VertexId)>,
    start: Vec<u32>,
    ends: Vec<u32>,
    /// Per edge, the other edges of its faces that come within
    /// [`THIN`]·eps of it without sharing an end (see [`feet_and_thin`]).
    thin: FxHashMap<(VertexId, VertexId), Vec<(VertexId, VertexId)>>,
}

/// Every edge of the top-level faces, lower vertex id first, sorted, and
/// per vertex the indices of the edges that end there (CSR: `start` has
/// one entry per vertex and one more).
fn edges_at_vertices(m: &Model) -> (Vec<(VertexId, VertexId)>, Vec<u32>, Vec<u32>) {
    let n: usize = m
        .top_faces()
        .map(|f| {
            m.faces[f.idx()]
                .contours
                .iter()
                .map(Vec::len)
                .sum::<usize>()
        })
        .sum();
    let mut edges: Vec<(VertexId, VertexId)> = Vec::with_capacity(n);
    for f in m.top_faces() {
        for c in &m.faces[f.idx()].contours {
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                if a != b {
                    edges.push(if a < b { (a, b) } else { (b, a) });
                }
            }
        }
    }
    edges.sort_unstable();
    edges.dedup();
    edges.shrink_to_fit();
    let nv = m.vertices.len();
    let mut start = vec![0u32; nv + 1];
    for &(a, b) in &edges {
        start[a.idx() + 1] += 1;
        start[b.idx() + 1] += 1;
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut ends = vec![0u32; start[nv] as usize];
    for (k, &(a, b)) in edges.iter().enumerate() {
        for v in [a, b] {
            ends[fill[v.idx()] as usize] = k as u32;
            fill[v.idx()] += 1;
        }
    }
    (edges, start, ends)
}

/// Across this many epsilons a face is thin: a vertex nearer than this to
/// a boundary edge of its own face (not its own) gets its foot on that
/// edge as a division point. (8 left a needle in a wall's end 13.8
/// epsilon wide: fixtures/cut/narrow-wall-end.ug; 32 cost the 100k
/// building 0.8% more patches and gained nothing over 16.)
const THIN: f64 = 16.0;

/// A strip narrower than this many epsilons gets the feet on one side
/// carried across to the other ([`carry_across_strips`]): fanned from a
/// corner, it would be cut into triangles narrower than epsilon. Wider
/// strips (a round column's facets, 9 epsilon wide at 100 times the
/// default) mesh well without, and carrying feet into them (up to
/// [`THIN`]) put patch corners within epsilon of the facets' own cell
/// points (property seed 199 at 100 times epsilon: 28 more defects).
const NARROW: f64 = 4.0;

/// A face's edges (in contour order, zero-length ones left out) and, for a
/// face of many, a box index of them widened by `reach`: which edges may
/// lie within `reach` of a point ([`FaceEdges::near`]).
struct FaceEdges {
    edges: Vec<(VertexId, VertexId)>,
    index: Option<BoxIndex>,
    reach: f64,
}

impl FaceEdges {
    fn new(m: &Model, face: &Face, reach: f64) -> FaceEdges {
        let edges: Vec<(VertexId, VertexId)> = face
            .contours
            .iter()
            .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
            .filter(|(a, b)| a != b)
            .collect();
        let index = (edges.len() > 24).then(|| {
            BoxIndex::new(edges.iter().enumerate().map(|(k, &(a, b))| {
                let (p, q) = (m.pos(a), m.pos(b));
                (
                    p.min(q) - DVec3::splat(reach),
                    p.max(q) + DVec3::splat(reach),
                    k as u32,
                )
            }))
        });
        FaceEdges {
            edges,
            index,
            reach,
        }
    }

    /// The indices of the edges that may lie within `reach` of `x`.
    fn near(&self, x: DVec3) -> Vec<usize> {
        match &self.index {
            Some(ix) => ix
                .query(x - DVec3::splat(self.reach), x + DVec3::splat(self.reach))
                .into_iter()
                .map(|k| k as usize)
                .collect(),
            None => (0..self.edges.len()).collect(),
        }
    }
}

/// Per edge (lower vertex id first), the feet on it (parameters from its
/// lower vertex).
type Feet = FxHashMap<(VertexId, VertexId), Vec<f64>>;
/// Per edge (lower vertex id first), its thin partners.
type Thin = FxHashMap<(VertexId, VertexId), Vec<(VertexId, VertexId)>>;
/// A thin strip of a face: one side, the other side (edges, lower vertex
/// id first), the face.
type Strip = ((VertexId, VertexId), (VertexId, VertexId), FaceId);

/// The feet of thin parts: for every face, each vertex that lies within
/// [`THIN`]·`eps` (and more than `eps`) of one of the face's boundary edges,
/// its foot on that edge if it falls more than 2·`eps` from the edge's ends.
/// In a strip a few epsilons wide (a wall's end left between two cuts, a
/// neck between a notch and the opposite side) the triangles can only join
/// a vertex on one side to points on the other; without a point right
/// across from it they are needles much narrower than epsilon (a 1 mm step
/// on one side of a 0.3 mm strip 2.8 m tall gave one 0.01 epsilon wide).
/// With the feet, the strip is cut across into pieces as wide as it is.
/// The feet divide the edge for every face that has it, so no T-vertex.
///
/// And the thin strips' partners: per edge of a face (lower vertex id
/// first), the face's other edges that come within [`THIN`]·`eps` of it
/// without sharing an end: the two sides of a strip a few epsilons wide.
/// (Two segments of one plane that do not cross are nearest at an end of
/// one of them, so it is enough to look from each vertex at the edges
/// near it: the same look as the feet's, made once.) A division point on
/// one side of such a strip would be joined only to points far along the
/// other: a needle (property seed 13621, a wall's end 1.7 to 2.6 epsilon
/// wide and 2.8 m tall whose one side was divided and the other, along a
/// neighbour's edge, was not).
///
/// Nor across a corner from the vertex's own edge to that corner where
/// another face is folded back onto this one along that edge by under
/// 30° (sine s) and the foot lies within 3 epsilon / s of the edge: the
/// corner's triangle would lie within 2 epsilon of that face's plane, on
/// its patches (property seed 42050 with curved things: a globe's facet
/// hanging from the ceiling at 24°, its cut line meeting a light panel's
/// edge in the ceiling at 67°; the foot of the line's next vertex on the
/// panel's edge, 4.6 epsilon from the corner, made a triangle there that
/// overlapped the globe's). Nor where the foot lies within such a fold's
/// band of one of the face's edges next to the foot's own edge
/// ([`folded_beside`]).
fn feet_and_thin(m: &Model, eps: f64, planes: &FacePlanes) -> (Feet, Thin) {
    let (mut out, mut thin) = (Feet::default(), Thin::default());
    if eps.is_nan() || eps <= 0.0 {
        return (out, thin);
    }
    let mut strips: Vec<Strip> = Vec::new();
    let reach = THIN * eps;
    let key = |a: VertexId, b: VertexId| if a < b { (a, b) } else { (b, a) };
    let parallel = 5f64.to_radians().cos();
    for f in m.top_faces() {
        let face = &m.faces[f.idx()];
        let fe = FaceEdges::new(m, face, reach);
        let edges = &fe.edges;
        // The two sides of a needle corner are a strip too: a face's edges
        // leaving one vertex within 5° of each other (they share that end,
        // so the look below passes them by). Where a needle triangle is
        // between 1 and [`NARROW`] epsilon wide, a foot on one side needs
        // its partner on the other (property seed 95007 rounded to 1 mm: a round column's facet
        // halved into triangles 2.8 m long and 2.7 cm wide at one end; a
        // pipe's hole in the other half put feet 2.75 epsilon apart on the
        // long diagonal where this one was 2.7 epsilon wide, and the point
        // across their jog made a triangle 0.75 epsilon wide and a T-vertex).
        for c in &face.contours {
            let n = c.len();
            for i in 0..n {
                let (u, v, w) = (c[(i + n - 1) % n], c[i], c[(i + 1) % n]);
                if u == v || v == w || u == w {
                    continue;
                }
                let x = m.pos(v);
                let (a, b) = (
                    (m.pos(u) - x).normalize_or_zero(),
                    (m.pos(w) - x).normalize_or_zero(),
                );
                if a.dot(b) >= parallel {
                    let (e, g) = (key(u, v), key(v, w));
                    strips.push((e, g, f));
                    strips.push((g, e, f));
                }
            }
        }
        // The face's edges at each vertex, by vertex.
        let mut at: Vec<(VertexId, (VertexId, VertexId))> = edges
            .iter()
            .flat_map(|&(a, b)| [(a, key(a, b)), (b, key(a, b))])
            .collect();
        at.sort_unstable();
        at.dedup();
        let mut verts: Vec<VertexId> = face.contours.iter().flatten().copied().collect();
        verts.sort_unstable();
        verts.dedup();
        for &v in &verts {
            let x = m.pos(v);
            let from = at.partition_point(|&(u, _)| u < v);
            let mine = at[from..]
                .iter()
                .take_while(|&&(u, _)| u == v)
                .map(|&(_, e)| e);
            for k in fe.near(x) {
                let (a, b) = edges[k];
                if a == v || b == v {
                    continue;
                }
                let g = key(a, b);
                let (p, q) = (m.pos(g.0), m.pos(g.1));
                // The foot's parameter, clamped: a foot at an end fails the test.
                let (d, t) = geom::point_segment_distance(x, p, q);
                if d > reach {
                    continue;
                }
                for e in mine.clone() {
                    if e.0 != g.0 && e.0 != g.1 && e.1 != g.0 && e.1 != g.1 {
                        thin.entry(e).or_default().push(g);
                        thin.entry(g).or_default().push(e);
                        strips.push((e, g, f));
                        strips.push((g, e, f));
                    }
                }
                let l = (q - p).length();
                if t * l <= 2.0 * eps || (1.0 - t) * l <= 2.0 * eps {
                    continue;
                }
                // Not across a corner from its own short edge to the
                // corner (an edge under JOG epsilon from the vertex to an end
                // of g): the foot would make a triangle of that edge and the
                // corner only a few epsilons across (a pipe's face ending in
                // a corner of 24° on a globe, its end edge 2.6 epsilon long:
                // the triangle lay on the globe's patch, folded at 25°,
                // property seed 13674). The corner's triangle reaches along
                // the side instead (or gets a point across its jog).
                // Nor where a face is folded back onto this one along that
                // edge and the foot lies within 3 epsilon / sin of it (see
                // above).
                let folded =
                    |e: (VertexId, VertexId)| folded_near(m, planes, f, e, p + (q - p) * t, eps);
                let corner = |e: (VertexId, VertexId)| {
                    (e.0 == g.0 || e.0 == g.1 || e.1 == g.0 || e.1 == g.1)
                        && (m.pos(e.0).distance(m.pos(e.1)) < JOG * eps || folded(e))
                };
                if d > eps
                    && !mine.clone().any(corner)
                    && !folded_beside(m, planes, f, g, p + (q - p) * t, eps)
                {
                    out.entry(g).or_default().push(t);
                }
            }
        }
    }
    for v in thin.values_mut() {
        v.sort_unstable();
        v.dedup();
    }
    strips.sort_unstable();
    strips.dedup();
    carry_across_strips(m, eps, planes, &strips, &mut out);
    if out.is_empty() {
        return (out, thin);
    }
    // A foot within eps of another edge (one nearly along its own, from a
    // shared end) would be a T-vertex there: it is left out.
    let mut keys: Vec<(VertexId, VertexId)> = out.keys().copied().collect();
    keys.sort_unstable();
    let mut spots: Vec<(usize, usize, DVec3)> = Vec::new();
    for (i, key) in keys.iter().enumerate() {
        let (p, q) = (m.pos(key.0), m.pos(key.1));
        for (j, &t) in out[key].iter().enumerate() {
            spots.push((i, j, p + (q - p) * t));
        }
    }
    let index = BoxIndex::new(
        spots
            .iter()
            .enumerate()
            .map(|(k, &(_, _, x))| (x - DVec3::splat(eps), x + DVec3::splat(eps), k as u32)),
    );
    let mut drop = vec![false; spots.len()];
    for f in m.top_faces() {
        for c in &m.faces[f.idx()].contours {
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                if a == b {
                    continue;
                }
                let key = if a < b { (a, b) } else { (b, a) };
                let (pa, pb) = (m.pos(a), m.pos(b));
                for k in index.query(pa.min(pb), pa.max(pb)) {
                    let (ki, _, x) = spots[k as usize];
                    if keys[ki] == key {
                        continue;
                    }
                    if geom::point_segment_distance(x, pa, pb).0 <= eps {
                        drop[k as usize] = true;
                    }
                }
            }
        }
    }
    for (k, &(ki, j, _)) in spots.iter().enumerate().rev() {
        if drop[k] {
            out.get_mut(&keys[ki]).unwrap().remove(j);
        }
    }
    out.retain(|_, ts| !ts.is_empty());
    (out, thin)
}

/// Whether a foot at `x` on face `f`'s contour edge `g` lies within the
/// fold band of one of `f`'s edges next to `g` ([`folded_near`]): `f`'s
/// triangle on that folded edge would take the foot as its apex and lie
/// within 2 epsilon of the other face's plane, on its patches. (Property
/// seed 170565 at 1 mm: a pipe's strip facet ending on a round column
/// along two of the column's edges, the first folded back onto the column
/// at 24°; the far end vertex put a foot on the strip's long side 10 mm
/// from the column, and the triangle of the folded edge and that foot
/// overlapped the column's patch.) Only `f`'s own edges count: in another
/// face that has `g` the foot is what keeps a needle out of a narrow strip
/// (seed 170320: a pipe facet tapering to a point, whose feet on the side
/// it shares with the next facet lay in that facet's fold band).
fn folded_beside(
    m: &Model,
    planes: &FacePlanes,
    f: FaceId,
    g: (VertexId, VertexId),
    x: DVec3,
    eps: f64,
) -> bool {
    let key = |a: VertexId, b: VertexId| if a < b { (a, b) } else { (b, a) };
    m.faces[f.idx()].contours.iter().any(|c| {
        let n = c.len();
        (0..n).any(|i| {
            key(c[i], c[(i + 1) % n]) == g
                && [
                    key(c[(i + n - 1) % n], c[i]),
                    key(c[(i + 1) % n], c[(i + 2) % n]),
                ]
                .into_iter()
                .any(|e| e != g && e.0 != e.1 && folded_near(m, planes, f, e, x, eps))
        })
    })
}

/// Whether another face is folded back onto face `f` along its contour
/// edge `e` ([`fold_sin`]) by so little that the point `x` in `f`, at
/// distance h from the edge's line, lies within 3 epsilon of that face's
/// plane (h·sin < 3·`eps`).
fn folded_near(
    m: &Model,
    planes: &FacePlanes,
    f: FaceId,
    e: (VertexId, VertexId),
    x: DVec3,
    eps: f64,
) -> bool {
    let (a, b) = (m.pos(e.0), m.pos(e.1));
    let dir = (b - a).normalize_or_zero();
    let w = x - a;
    let across = w - dir * w.dot(dir);
    let h = across.length();
    h > 0.0
        && fold_sin(m, planes, &|g| fold_normal(m, g), f, e, across / h)
            .is_some_and(|s| h * s < 3.0 * eps)
}

/// Carries each foot across the narrow strips of a face whose sides run
/// parallel: a foot on one side of a strip of face `f` (within 5° of
/// parallel to the other side, more than `eps` and under [`NARROW`]·`eps`
/// away) is a foot on the other side too (more than 2·`eps` from its
/// ends, none there yet within 2·`eps`), and so on, strip by strip (at
/// most 4 strips on). A foot divides its edge for every face that has it,
/// so a strip on its other side got a division point on one side only and
/// was fanned into needles (property seed 181 at 100 times epsilon: a
/// slab's end in two strips 5.2 and 2.6 epsilon wide, one above the
/// other; the upper one's vertices put feet on the edge between them, and
/// the lower one was fanned from one corner into a triangle 0.94 epsilon
/// wide). As for the feet themselves ([`feet_and_thin`]), not where
/// another face is folded back onto `f` along either side by so little
/// that the strip lies within 3 epsilon of its plane; nor where the cut
/// across the strip passes within 2·`eps` of one of the face's vertices
/// (a needle beside that vertex). (Both guards changed nothing on the
/// seeds and buildings tried; the width limit is what kept seed 199 at
/// 100 times epsilon clean: docs/decisions.md.)
fn carry_across_strips(
    m: &Model,
    eps: f64,
    planes: &FacePlanes,
    strips: &[Strip],
    feet: &mut Feet,
) {
    let parallel = 5f64.to_radians().cos();
    let mut keys: Vec<(VertexId, VertexId)> = feet.keys().copied().collect();
    keys.sort_unstable();
    let mut todo: Vec<((VertexId, VertexId), f64)> = keys
        .iter()
        .flat_map(|k| feet[k].iter().map(move |&t| (*k, t)))
        .collect();
    for _ in 0..4 {
        if todo.is_empty() {
            break;
        }
        let mut next = Vec::new();
        for (e, t) in todo {
            let from = strips.partition_point(|s| s.0 < e);
            for &(_, g, f) in strips[from..].iter().take_while(|s| s.0 == e) {
                let (a, b) = (m.pos(e.0), m.pos(e.1));
                let (p, q) = (m.pos(g.0), m.pos(g.1));
                let cos = (b - a).normalize_or_zero().dot((q - p).normalize_or_zero());
                if cos.abs() < parallel {
                    continue;
                }
                let x = a + (b - a) * t;
                let (d, s) = geom::point_segment_distance(x, p, q);
                let l = (q - p).length();
                if d <= eps || d > NARROW * eps || s * l <= 2.0 * eps || (1.0 - s) * l <= 2.0 * eps
                {
                    continue;
                }
                let y = p + (q - p) * s;
                if folded_near(m, planes, f, e, y, eps) || folded_near(m, planes, f, g, x, eps) {
                    continue;
                }
                // Nor where the cut across passes within 2·eps of a
                // vertex of the face (the strip is not clear there: a
                // notch's corner; seed 199 at 100 times epsilon).
                let near_vertex = m.faces[f.idx()]
                    .contours
                    .iter()
                    .flatten()
                    .any(|&v| geom::point_segment_distance(m.pos(v), x, y).0 <= 2.0 * eps);
                if near_vertex {
                    continue;
                }
                let on = feet.entry(g).or_default();
                if on.iter().any(|&u| ((u - s) * l).abs() <= 2.0 * eps) {
                    continue;
                }
                on.push(s);
                next.push((g, s));
            }
        }
        todo = next;
    }
}

/// A set of names, kept as 64-bit SipHash values (with fixed keys, so the
/// same every run): a name is new when its hash is. Two different names
/// with one hash would only make the second take the next free suffix;
/// no name is ever given twice. A set of the strings themselves cost
/// about 100 MB and a second of copying and freeing on the user's 100k
/// pipeline.
#[derive(Default)]
struct Names(FxHashSet<u64>);

impl Names {
    fn hash(name: &str) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::hash::DefaultHasher::new();
        name.hash(&mut h);
        h.finish()
    }

    fn contains(&self, name: &str) -> bool {
        self.0.contains(&Names::hash(name))
    }

    /// Adds `name`; false if it was there.
    fn insert(&mut self, name: &str) -> bool {
        self.0.insert(Names::hash(name))
    }
}

impl<'a> FromIterator<&'a str> for Names {
    fn from_iter<I: IntoIterator<Item = &'a str>>(it: I) -> Names {
        Names(it.into_iter().map(Names::hash).collect())
    }
}

struct Ctx<'m> {
    m: &'m Model,
    opts: Options,
    vertices: Vec<Vertex>,
    vnames: Names,
    fnames: Names,
    div: Divisions,
    /// Joins asked for by [`jog_points`]: (from, to), vertices of `m`.
    stuck: Vec<(VertexId, VertexId)>,
    /// Vertices of other faces resting inside each face ([`resting_points`]).
    resting: FxHashMap<FaceId, Vec<VertexId>>,
    /// The faces, for asking whether a division point rests inside one.
    planes: FacePlanes,
    /// Faces' unit normals and their contours' signed areas about them,
    /// made when [`fold_points`] first asks.
    fold_normals: std::cell::RefCell<FxHashMap<FaceId, Option<FoldNormal>>>,
    /// While a face is meshed, what it does to the shared state (see
    /// [`reuse`]).
    trace: Option<reuse::Trace>,
}

impl Ctx<'_> {
    fn new_vertex(&mut self, base: String, pos: DVec3) -> VertexId {
        let mut name = base.clone();
        let mut k = 2;
        while self.vnames.contains(&name) {
            name = format!("{base}.{k}");
            k += 1;
        }
        self.vnames.insert(&name);
        let id = VertexId(self.vertices.len() as u32);
        self.vertices.push(Vertex {
            name,
            pos,
            color: None,
        });
        id
    }

    /// The `k`th vertex of face `fname`'s own (not a division point),
    /// named `fname.vk`.
    fn inner_vertex(&mut self, fname: &str, k: usize, pos: DVec3) -> VertexId {
        let v = self.new_vertex(format!("{fname}.v{k}"), pos);
        if let Some(t) = &mut self.trace {
            t.vertices.push((k as u32, v));
        }
        v
    }

    fn pos(&self, v: VertexId) -> DVec3 {
        self.vertices[v.idx()].pos
    }

    /// The vertices along edge a→b, a first, b excluded.
    fn divided(&mut self, a: VertexId, b: VertexId) -> Vec<VertexId> {
        let key = if a < b { (a, b) } else { (b, a) };
        if !self.div.map.contains_key(&key) {
            let (p, q) = (self.pos(key.0), self.pos(key.1));
            let l = (q - p).length();
            let k = segments(l, self.opts.len);
            let base = format!(
                "{}:{}",
                self.vertices[key.0.idx()].name,
                self.vertices[key.1.idx()].name
            );
            // The equal division, and the feet of thin parts: feet within
            // 2·eps of each other are one; a division point within a
            // quarter segment of a foot gives way to it.
            let mut feet = self.div.feet.remove(&key).unwrap_or_default();
            feet.sort_by(f64::total_cmp);
            let gap = 2.0 * self.opts.eps / l;
            feet.dedup_by(|b, a| *b - *a <= gap);
            let clear = (0.25 / k as f64).max(gap);
            // Two edges that leave one vertex nearly along each other (a
            // wall's end face tilted by welding across a strip a few
            // epsilons wide) stay within epsilon of each other for metres:
            // a division point on one would be a T-vertex on the other, and
            // the strip between them, divided on one side only, would be
            // cut into needles. A division point within THIN epsilons of an
            // edge sharing an end with its own is left out (the feet
            // already are, in `feet`): such edges are not divided there.
            // Nor is one within THIN epsilons of another edge of its faces
            // across a strip (see `feet_and_thin`).
            let reach = THIN * self.opts.eps;
            let thin = self.div.thin.get(&key);
            let clear_of_others = |t: f64| {
                let x = p + (q - p) * t;
                thin.into_iter().flatten().all(|&(a, b)| {
                    geom::point_segment_distance(x, self.pos(a), self.pos(b)).0 > reach
                }) && [key.0, key.1].iter().all(|v| {
                    let d = &self.div;
                    d.ends[d.start[v.idx()] as usize..d.start[v.idx() + 1] as usize]
                        .iter()
                        .all(|&j| {
                            let other = d.edges[j as usize];
                            other == key || {
                                let (a, b) = (self.pos(other.0), self.pos(other.1));
                                geom::point_segment_distance(x, a, b).0 > reach
                            }
                        })
                })
            };
            let mut ts: Vec<(f64, bool)> = (1..k)
                .map(|i| i as f64 / k as f64)
                .filter(|t| feet.iter().all(|f| (f - t).abs() > clear))
                .filter(|&t| clear_of_others(t))
                .map(|t| (t, false))
                .chain(feet.iter().map(|&t| (t, true)))
                .collect();
            ts.sort_by(|a, b| a.0.total_cmp(&b.0));
            // Nor a point resting inside a face that does not have the edge
            // (within epsilon of its plane, more than epsilon inside) while
            // the edge leaves that plane: a patch edge of that face would
            // pass within epsilon of it. (A
            // globe's cap piece hanging from the ceiling at 22°, a light
            // panel's edge leaving the cap's top corner: a foot 2.08
            // epsilon along the panel's edge was 0.8 epsilon from the cap,
            // a T-vertex; property seed 23003 on 3 × 2 rooms.)
            let m = self.m;
            let eps = self.opts.eps;
            // An edge lying in the face's plane (a box's bottom edge
            // standing on a floor, without ugisect) rests in it all along,
            // an intersection: its points are kept.
            // In a model without intersections such a face has one of
            // the edge's ends (its plane meets the edge there at a small
            // angle); any other would be crossed by the edge.
            let ends = [key.0, key.1];
            ts.retain(|&(t, _)| {
                let x = p + (q - p) * t;
                !(0..2).any(|s| {
                    self.planes.around_range(ends[s]).any(|i| {
                        let k = self.planes.at[i];
                        // Not a face with the edge (it has both ends and
                        // walks from one to the other). One with both ends
                        // but not the edge is asked, and a point within
                        // epsilon of its boundary is left out too: a vault
                        // piece walking round a pipe from one end of the
                        // pipe's edge through a third vertex to the other
                        // had the foot of that vertex on the edge 1.14
                        // epsilon from it, within epsilon of the vault's
                        // edge from it and so of the vault's patch edges
                        // from it, a T-vertex (property seed 80023 on 3 ×
                        // 2 rooms with the wing, the roof and curved
                        // things).
                        let both = self.planes.around(ends[1 - s]).binary_search(&k).is_ok();
                        if both && has_edge(&m.faces[self.planes.faces[k as usize].idx()], key) {
                            return false;
                        }
                        // Nor one the edge lies in, unless the face has
                        // both its ends (the pipe's edge above lay in the
                        // vault's plane, 1.14 epsilon from the vault's
                        // third vertex along it).
                        let Some((n, c)) = self.planes.plane_of(m, k) else {
                            return false;
                        };
                        if !both && (p - c).dot(n).abs() <= eps && (q - c).dot(n).abs() <= eps {
                            return false;
                        }
                        match self.planes.locate(m, x, eps, k) {
                            Some(geom::Location::Inside) => true,
                            Some(geom::Location::Boundary) => both,
                            _ => false,
                        }
                    })
                })
            });
            let pts: Vec<VertexId> = ts
                .iter()
                .enumerate()
                .map(|(i, &(t, foot))| {
                    let name = if foot {
                        format!("{base}.f{}", i + 1)
                    } else {
                        format!("{base}.{}", i + 1)
                    };
                    self.new_vertex(name, p + (q - p) * t)
                })
                .collect();
            self.div.map.insert(key, pts);
        }
        let inner = &self.div.map[&key];
        let mut out = Vec::with_capacity(inner.len() + 1);
        out.push(a);
        if a == key.0 {
            out.extend(inner.iter().copied());
        } else {
            out.extend(inner.iter().rev().copied());
        }
        out
    }
}

/// Whether one of `face`'s contours walks from one end of `edge` to the
/// other.
fn has_edge(face: &ug::Face, edge: (VertexId, VertexId)) -> bool {
    face.contours.iter().any(|c| {
        (0..c.len()).any(|i| {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            (a, b) == edge || (b, a) == edge
        })
    })
}

/// The whole number of segments (at least 1) nearest to `length / len`.
pub fn segments(length: f64, len: f64) -> usize {
    ((length / len).round() as usize).max(1)
}

/// Cuts every top-level face of a flat model into patches (after
/// [`prepare`]). Fails only if a face could not be triangulated at all,
/// which the preparation is meant to make impossible.
pub fn cut(m: &Model, opts: Options) -> Result<(Model, Stats), String> {
    cut_rounds(m, opts, true)
}

/// [`cut`] meshing every face again in every round, where [`cut`] replays
/// the faces that the joins did not change (see [`reuse`]): the same
/// output, for tests to compare.
#[doc(hidden)]
pub fn cut_without_reuse(m: &Model, opts: Options) -> Result<(Model, Stats), String> {
    cut_rounds(m, opts, false)
}

fn cut_rounds(m: &Model, opts: Options, replay: bool) -> Result<(Model, Stats), String> {
    let mut stats = Stats {
        min_edge: f64::INFINITY,
        worst_angle: 180.0,
        ..Stats::default()
    };
    let mut model = prepare(m, opts.eps, &mut stats);
    // Joins asked for make the model prepared and meshed again; each round
    // can ask for more where the first ones moved vertices (three rounds
    // at most). Faces the joins did not change are replayed from the round
    // before ([`reuse`]).
    let mut memo: Option<reuse::Memo> = None;
    let mut before: Option<Model> = None;
    for round in 0.. {
        // (The model before the joins is dropped once compared.)
        let again = match (&memo, before.take()) {
            (Some(memo), Some(before)) if replay => {
                reuse::Reuse::new(memo, &before, &model, opts.eps)
            }
            _ => None,
        };
        let (mut out, mut done, mut joins, next, origins) =
            mesh_all(&model, opts, stats.clone(), again.as_ref())?;
        drop(again);
        // A boundary edge a little longer than epsilon that no triangle
        // can take without being narrower than epsilon (its face is too
        // narrow there for an apex far enough across): its ends are
        // joined, as a weld would (CAD building 8600 seed 10, the user's
        // pipeline: a column's strip 9.3 epsilon high whose foot has two
        // vertices 1.0017 epsilon apart, cut points of the slab at the
        // column's two faces).
        // And a vertex of another face just over epsilon from a corner,
        // which a patch edge leaving that corner passes within epsilon of
        // (a T-vertex): it joins the corner (property seed 3327, a ramp's
        // needle piece 1.02 epsilon wide at a floor piece's corner).
        joins.extend(winged::weld::near_corner_joins(&model, &out, opts.eps));
        // Back-to-back faces whose vertices pair off within 2 epsilon
        // share their records, so the second takes the first's patches
        // (see `near_twin_joins`).
        joins.extend(
            winged::weld::near_twin_joins(&model, opts.eps)
                .into_iter()
                .flatten(),
        );
        // A vertex asked to join several others joins the nearest (the
        // first of its pairs is taken): property seed 9742, a triangle
        // export with a wing, where a facade sliver's corner 1.17 epsilon
        // from one end of its short edges and 1.73 from the other went to
        // the farther by vertex order, across the other facade's strip
        // lying on it, and the two patches overlapped.
        joins.sort_by(|x, y| {
            let d = |(a, b): (VertexId, VertexId)| model.pos(a).distance(model.pos(b));
            x.0.cmp(&y.0)
                .then(d(*x).total_cmp(&d(*y)))
                .then(x.1.cmp(&y.1))
        });
        joins.dedup();
        orient_joins(&model, &mut joins, opts.eps);
        if joins.is_empty() || round == 3 {
            let sh = shallow::repair(
                &model,
                &mut out,
                &origins.parent,
                &origins.twinned,
                opts.eps,
            );
            if sh.flips + sh.removed + sh.moved > 0 {
                done.shallow_flips = sh.flips;
                done.shallow_points = sh.removed;
                done.shallow_moved = sh.moved;
                recount(&out, &mut done);
            }
            return Ok((out, done));
        }
        let joined = prepare_joining(&model, opts.eps, &mut stats, &joins, replay);
        memo = Some(next);
        before = Some(std::mem::replace(&mut model, joined));
    }
    unreachable!()
}

/// Turns a join round (`a → b` to `b → a`) where moving `a` onto `b`
/// makes two faces cross or overlap (as ugcheck judges them: faces
/// through `a` against those near them) that did not, and moving `b` onto
/// `a` does not. Property seed 170449 at 1 mm: a slab's side piece's
/// corner, joined to a wall's corner 2 mm off on the facade (a short edge
/// no triangle wider than epsilon fits on), tilted the slab piece through
/// the facade piece below it (one intersecting pair after ugcut); the
/// wall's corner joined to the slab's crosses nothing.
fn orient_joins(m: &Model, joins: &mut [(VertexId, VertexId)], eps: f64) {
    use geom::intersect::FaceGeom;
    if joins.is_empty() || eps.is_nan() || eps <= 0.0 {
        return;
    }
    let faces: Vec<FaceId> = m.top_faces().collect();
    let mut at: FxHashMap<VertexId, Vec<FaceId>> = FxHashMap::default();
    for &(a, b) in joins.iter() {
        at.entry(a).or_default();
        at.entry(b).or_default();
    }
    for &f in &faces {
        for &v in m.faces[f.idx()].contours.iter().flatten() {
            if let Some(list) = at.get_mut(&v)
                && list.last() != Some(&f)
            {
                list.push(f);
            }
        }
    }
    let boxes: Vec<(DVec3, DVec3)> = faces
        .iter()
        .map(|&f| {
            bbox(
                m.faces[f.idx()]
                    .contours
                    .iter()
                    .flatten()
                    .map(|&v| m.pos(v)),
                2.0 * eps,
            )
        })
        .collect();
    let index = BoxIndex::new(
        boxes
            .iter()
            .enumerate()
            .map(|(k, &(lo, hi))| (lo, hi, k as u32)),
    );
    let shape = |f: FaceId, moved: Option<(VertexId, DVec3)>| check::face_geom(m, f, moved);
    let overlap: fn(check::PairKind) -> bool = |k| matches!(k, check::PairKind::Overlap(_));
    let kind = |a: &FaceGeom, b: &FaceGeom| check::meeting(a, b, eps, Some(overlap));
    // Whether moving `a` onto `b`'s place makes a pair worse.
    let worsens = |a: VertexId, b: VertexId| -> bool {
        let through = &at[&a];
        let to = Some((a, m.pos(b)));
        through.iter().any(|&f| {
            let (Some(fb), Some(fa)) = (shape(f, None), shape(f, to)) else {
                return false;
            };
            let (lo, hi) = bbox(
                m.faces[f.idx()]
                    .contours
                    .iter()
                    .flatten()
                    .map(|&v| m.pos(v))
                    .chain([m.pos(b)]),
                2.0 * eps,
            );
            index.query(lo, hi).into_iter().any(|k| {
                let g = faces[k as usize];
                if g == f {
                    return false;
                }
                let (Some(gb), Some(ga)) = (
                    shape(g, None),
                    shape(g, if through.contains(&g) { to } else { None }),
                ) else {
                    return false;
                };
                kind(&fa, &ga) > kind(&fb, &gb)
            })
        })
    };
    for j in joins.iter_mut() {
        let (a, b) = *j;
        if a != b && worsens(a, b) && !worsens(b, a) {
            *j = (b, a);
        }
    }
}

/// The model's top-level faces for point queries: the faces at each
/// vertex, and each face's plane (unit normal, centre of its vertices),
/// mesh frame and contours in the frame, made when first asked for.
struct FacePlanes {
    faces: Vec<FaceId>,
    /// Per face: not made yet, or its plane (unit normal, centre), if any.
    plane: Vec<Option<Option<(DVec3, DVec3)>>>,
    flat: FxHashMap<u32, Option<Flat>>,
    /// The faces at each vertex: `at[start[v]..start[v + 1]]`.
    start: Vec<u32>,
    at: Vec<u32>,
}

/// (frame, contours in the frame)
type Flat = (Frame, Vec<Vec<DVec2>>);

impl FacePlanes {
    fn new(m: &Model) -> FacePlanes {
        let faces: Vec<FaceId> = m.top_faces().collect();
        let mut pairs: Vec<(u32, u32)> = faces
            .iter()
            .enumerate()
            .flat_map(|(k, &f)| {
                m.faces[f.idx()]
                    .contours
                    .iter()
                    .flatten()
                    .map(move |v| (v.0, k as u32))
            })
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        let mut start = vec![0u32; m.vertices.len() + 1];
        for &(v, _) in &pairs {
            start[v as usize + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        FacePlanes {
            plane: vec![None; faces.len()],
            faces,
            flat: FxHashMap::default(),
            start,
            at: pairs.into_iter().map(|(_, k)| k).collect(),
        }
    }

    /// The faces (indices into `faces`) that have vertex `v`.
    fn around(&self, v: VertexId) -> &[u32] {
        &self.at[self.around_range(v)]
    }

    /// Where [`FacePlanes::around`]'s faces lie in `at`.
    fn around_range(&self, v: VertexId) -> std::ops::Range<usize> {
        match self.start.get(v.idx()..v.idx() + 2) {
            Some(&[a, b]) => a as usize..b as usize,
            _ => 0..0,
        }
    }

    /// The plane of face `k` (an index into `faces`): its unit normal and
    /// the centre of its vertices, made when first asked for.
    fn plane_of(&mut self, m: &Model, k: u32) -> Option<(DVec3, DVec3)> {
        let face = &m.faces[self.faces[k as usize].idx()];
        *self.plane[k as usize].get_or_insert_with(|| {
            let pts = face_points(m, face);
            let n = geom::face_normal(&pts)?.normalize();
            let count: usize = pts.iter().map(Vec::len).sum();
            Some((
                n,
                pts.iter().flatten().copied().sum::<DVec3>() / count as f64,
            ))
        })
    }

    /// Whether `p` rests inside face `k` (an index into `faces`): within
    /// `eps` of its plane and inside its contours by more than `eps`, in
    /// its mesh frame.
    fn rests_in(&mut self, m: &Model, p: DVec3, eps: f64, k: u32) -> bool {
        self.locate(m, p, eps, k) == Some(geom::Location::Inside)
    }

    /// Where `p` lies in face `k`'s contours (in its mesh frame), if
    /// within `eps` of its plane.
    fn locate(&mut self, m: &Model, p: DVec3, eps: f64, k: u32) -> Option<geom::Location> {
        // The plane first (cheap), then the contours in the face's frame.
        let (n, centre) = self.plane_of(m, k)?;
        if (p - centre).dot(n).abs() > eps {
            return None;
        }
        let face = &m.faces[self.faces[k as usize].idx()];
        let (frame, c2) = self
            .flat
            .entry(k)
            .or_insert_with(|| {
                let pts = face_points(m, face);
                let frame = mesh_frame(&pts)?;
                let c2 = pts
                    .iter()
                    .map(|c| c.iter().map(|&q| frame.to_2d(q)).collect())
                    .collect();
                Some((frame, c2))
            })
            .as_ref()?;
        Some(geom::intersect::locate_eps(frame.to_2d(p), c2, eps))
    }
}

/// For each face, the vertices of other faces resting inside it: within
/// epsilon of its plane and inside its contours by more than epsilon, in
/// the face's mesh frame. After `ugisect` only isolated point contacts are
/// left so (a globe's pole on a ceiling, a cone's apex on a floor: a touch,
/// nothing to cut); a patch edge of the face passing within epsilon of
/// such a vertex would be a T-vertex (property seed 9033), so the mesher
/// takes them as corners. Only isolated contacts count: a vertex with a
/// neighbour within epsilon of the plane is left alone. Of vertices within
/// epsilon of each other only the first is taken (they are one point to
/// every check).
fn resting_points(
    planes: &mut FacePlanes,
    m: &Model,
    eps: f64,
    (edges, estart, ends): (&[(VertexId, VertexId)], &[u32], &[u32]),
) -> FxHashMap<FaceId, Vec<VertexId>> {
    let mut out: FxHashMap<FaceId, Vec<VertexId>> = FxHashMap::default();
    if eps.is_nan() || eps <= 0.0 || planes.faces.is_empty() {
        return out;
    }
    // Each vertex's neighbours along the contours (`edges_at_vertices`).
    let neighbours = |v: u32| {
        ends[estart[v as usize] as usize..estart[v as usize + 1] as usize]
            .iter()
            .map(move |&j| {
                let (a, b) = edges[j as usize];
                if a.0 == v { b } else { a }
            })
    };
    // The vertices on faces in a grid of cells about 1/256 of the model.
    let used: Vec<u32> = (0..m.vertices.len() as u32)
        .filter(|&v| estart[v as usize] < estart[v as usize + 1])
        .collect();
    let (lo, hi) = bbox(used.iter().map(|&v| m.pos(VertexId(v))), 0.0);
    let cell = ((hi - lo).length() / 256.0).max(4.0 * eps);
    let key = |p: DVec3| {
        let q = ((p - lo) / cell).floor();
        (q.x as i64, q.y as i64, q.z as i64)
    };
    let mut grid: FxHashMap<(i64, i64, i64), Vec<u32>> = FxHashMap::default();
    for &v in &used {
        grid.entry(key(m.pos(VertexId(v)))).or_default().push(v);
    }
    let mut found: Vec<(u32, u32)> = Vec::new();
    for k in 0..planes.faces.len() {
        let face = &m.faces[planes.faces[k].idx()];
        let Some((n, centre)) = planes.plane_of(m, k as u32) else {
            continue;
        };
        let (flo, fhi) = bbox(face.contours.iter().flatten().map(|&w| m.pos(w)), eps);
        let (a, b) = (key(flo), key(fhi));
        let cells = (b.0 - a.0 + 1) as f64 * (b.1 - a.1 + 1) as f64 * (b.2 - a.2 + 1) as f64;
        let mut cand: Vec<u32> = Vec::new();
        let mut take = |vs: &Vec<u32>| {
            for &v in vs {
                let p = m.pos(VertexId(v));
                if p.cmpge(flo).all() && p.cmple(fhi).all() && (p - centre).dot(n).abs() <= eps {
                    cand.push(v);
                }
            }
        };
        if cells > grid.len() as f64 {
            for (c, vs) in &grid {
                if (a.0..=b.0).contains(&c.0)
                    && (a.1..=b.1).contains(&c.1)
                    && (a.2..=b.2).contains(&c.2)
                {
                    take(vs);
                }
            }
        } else {
            for x in a.0..=b.0 {
                for y in a.1..=b.1 {
                    for z in a.2..=b.2 {
                        if let Some(vs) = grid.get(&(x, y, z)) {
                            take(vs);
                        }
                    }
                }
            }
        }
        for v in cand {
            // Not the face's own, and only isolated contacts: a vertex with
            // an edge lying in the face's plane (a box's corner standing on
            // a floor) has that edge resting in the face too, an
            // intersection that ugisect cuts; taking its corner alone would
            // only change the mesh (the Cornell box's blocks on their
            // floor, without ugisect).
            if planes
                .around(VertexId(v))
                .binary_search(&(k as u32))
                .is_ok()
            {
                continue;
            }
            if neighbours(v).any(|w| (m.pos(w) - centre).dot(n).abs() <= eps) {
                continue;
            }
            if planes.rests_in(m, m.pos(VertexId(v)), eps, k as u32) {
                found.push((v, k as u32));
            }
        }
    }
    found.sort_unstable();
    for (v, k) in found {
        let v = VertexId(v);
        let p = m.pos(v);
        let list = out.entry(planes.faces[k as usize]).or_default();
        if list.iter().all(|&w| m.pos(w).distance(p) > eps) {
            list.push(v);
        }
    }
    out
}

/// A face's contours as positions.
fn face_points(m: &Model, face: &Face) -> Vec<Vec<DVec3>> {
    face.contours
        .iter()
        .map(|c| c.iter().map(|&v| m.pos(v)).collect())
        .collect()
}

/// A boundary segment (its ends, lower first) and the contour edge it is
/// part of (lower end first).
type SegmentOf = ((VertexId, VertexId), (VertexId, VertexId));

/// A face's unit normal and its contours' signed areas about it.
type FoldNormal = (DVec3, Vec<f64>);

/// The faces using the contour edge `(a, b)` (`a < b`), each once: (the
/// face, its first contour with the edge, whether that contour walks it
/// from `a`), in face order. Found among the faces at `a` and `b`
/// ([`FacePlanes::around`]), so no model-wide edge table is built for the
/// few edges [`fold_points`] asks about.
fn edge_uses(m: &Model, planes: &FacePlanes, a: VertexId, b: VertexId) -> Vec<(FaceId, u32, bool)> {
    let (fa, fb) = (planes.around(a), planes.around(b));
    let mut out = Vec::new();
    for &k in fa {
        if fb.binary_search(&k).is_err() {
            continue;
        }
        let f = planes.faces[k as usize];
        let mut first: Option<(u32, bool)> = None;
        for (ci, c) in m.faces[f.idx()].contours.iter().enumerate() {
            for i in 0..c.len() {
                let (x, y) = (c[i], c[(i + 1) % c.len()]);
                if (x.min(y), x.max(y)) == (a, b) {
                    let u = (ci as u32, x < y);
                    first = Some(first.map_or(u, |o: (u32, bool)| o.min(u)));
                }
            }
        }
        if let Some((ci, forward)) = first {
            out.push((f, ci, forward));
        }
    }
    out.sort_unstable();
    out
}

/// Vertex joins, (from, to).
type Joins = Vec<(VertexId, VertexId)>;

/// The meshing of a prepared model; also the joins [`jog_points`] asked
/// for and what the next round may replay ([`reuse`]). Faces that `reuse`
/// allows are replayed from the last round instead of meshed.
fn mesh_all(
    m: &Model,
    opts: Options,
    mut stats: Stats,
    reuse: Option<&reuse::Reuse<'_>>,
) -> Result<(Model, Stats, Joins, reuse::Memo, Origins), String> {
    let (edges, start, ends) = edges_at_vertices(m);
    let mut origins = Origins {
        parent: Vec::new(),
        twinned: vec![false; m.faces.len()],
    };
    let mut planes = FacePlanes::new(m);
    let resting = resting_points(&mut planes, m, opts.eps, (&edges, &start, &ends));
    let mut cx = Ctx {
        m,
        opts,
        vertices: m.vertices.clone(),
        vnames: m.vertices.iter().map(|v| v.name.as_str()).collect(),
        fnames: m
            .faces
            .iter()
            .filter_map(|f| f.name.as_deref())
            .chain(m.wires.iter().filter_map(|w| w.name.as_deref()))
            .collect(),
        div: {
            let (feet, thin) = feet_and_thin(m, opts.eps, &planes);
            Divisions {
                map: FxHashMap::default(),
                feet,
                thin,
                edges,
                start,
                ends,
            }
        },
        stuck: Vec::new(),
        resting,
        planes,
        fold_normals: Default::default(),
        trace: None,
    };
    let mut memo = reuse::Memo::default();
    stats.resting = cx.resting.values().map(Vec::len).sum();
    let mut out = Model {
        materials: m.materials.clone(),
        wires: m.wires.clone(),
        defs: m.defs.clone(),
        instances: m.instances.clone(),
        ..Model::default()
    };
    let mut emitted = m.vertices.len(); // vertices of cx.vertices already written
    // A face's sorted vertices → (its normal, its patches, the face).
    let mut twins: FxHashMap<Vec<VertexId>, (Option<DVec3>, Patches, FaceId)> =
        FxHashMap::default();
    for it in &m.items {
        match it {
            Item::Face(f) => {
                stats.faces += 1;
                let face = &m.faces[f.idx()];
                let label = face
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("#{}", stats.faces));
                // A face on the same vertices as an earlier one (the other
                // side of a zero-thickness wall, a box standing exactly on
                // a floor) gets the same patches, mirrored when it faces
                // the other way: the two sides stay coincident patch by patch.
                let mut key: Vec<VertexId> = face.contours.iter().flatten().copied().collect();
                key.sort_unstable();
                key.dedup();
                let normal = geom::face_normal(
                    &face
                        .contours
                        .iter()
                        .map(|c| c.iter().map(|&v| cx.pos(v)).collect::<Vec<_>>())
                        .collect::<Vec<_>>(),
                );
                let twin =
                    twins
                        .get(&key)
                        .and_then(|(n0, p0, f0): &(Option<DVec3>, Patches, FaceId)| {
                            let same = match (n0, normal) {
                                (Some(a), Some(b)) => a.dot(b) > 0.0,
                                _ => return None,
                            };
                            origins.twinned[f0.idx()] = true;
                            origins.twinned[f.idx()] = true;
                            Some(if same {
                                p0.clone()
                            } else {
                                p0.iter()
                                    .map(|cs| {
                                        cs.iter()
                                            .map(|c| c.iter().rev().copied().collect())
                                            .collect()
                                    })
                                    .collect()
                            })
                        });
                let patches = match twin {
                    Some(p) => {
                        stats.twins += 1;
                        p
                    }
                    None => {
                        let replayed =
                            reuse.and_then(|r| r.replay(&mut cx, *f, &mut stats, &mut memo));
                        let p = match replayed {
                            Some((p, plain)) => {
                                stats.replayed += 1;
                                if plain {
                                    stats.plain.push(label.clone());
                                }
                                p
                            }
                            None => {
                                if reuse.is_some() {
                                    stats.remeshed += 1;
                                }
                                cx.trace = Some(reuse::Trace::default());
                                let (cells, stuck) = (stats.grid_cells, cx.stuck.len());
                                let (p, plain) = match mesh_face(&mut cx, *f, &mut stats, true) {
                                    Some(p) => (p, false),
                                    None => match mesh_face(&mut cx, *f, &mut stats, false) {
                                        Some(p) => {
                                            stats.plain.push(label.clone());
                                            (p, true)
                                        }
                                        None => {
                                            return Err(format!(
                                                "face {label} could not be triangulated (please report this model)"
                                            ));
                                        }
                                    },
                                };
                                let mut trace = cx.trace.take().unwrap_or_default();
                                trace.grid_cells = stats.grid_cells - cells;
                                trace.plain = plain;
                                trace.stuck = cx.stuck.len() > stuck;
                                memo.record(
                                    *f,
                                    &trace,
                                    &p,
                                    cx.resting.get(f).map_or(&[], Vec::as_slice),
                                );
                                p
                            }
                        };
                        twins.entry(key).or_insert((normal, p.clone(), *f));
                        p
                    }
                };
                // New vertices made for this face go just before its patches.
                flush_vertices(&cx, &mut out, &mut emitted);
                let mut k = 0;
                for contours in patches {
                    let name = face.name.as_ref().map(|n| {
                        loop {
                            k += 1;
                            let cand = format!("{n}.{k}");
                            if cx.fnames.insert(&cand) {
                                break cand;
                            }
                        }
                    });
                    let id = FaceId(out.faces.len() as u32);
                    out.faces.push(Face {
                        name,
                        contours,
                        material: face.material,
                    });
                    origins.parent.push(f.0);
                    out.items.push(Item::Face(id));
                }
            }
            other => out.items.push(other.clone()),
        }
    }
    flush_vertices(&cx, &mut out, &mut emitted);
    memo.finish(
        std::mem::take(&mut cx.div.map),
        cx.vertices[m.vertices.len()..]
            .iter()
            .map(|v| v.pos)
            .collect(),
        m.vertices.len(),
    );
    out.vertices = cx.vertices;
    recount(&out, &mut stats);
    let mut stuck = cx.stuck;
    stuck.sort_unstable();
    stuck.dedup();
    Ok((out, stats, stuck, memo, origins))
}

/// Where [`mesh_all`]'s patches came from.
struct Origins {
    /// Per patch, the index of its face in the meshed model.
    parent: Vec<u32>,
    /// Per face of the meshed model, whether its patches are another's
    /// copied or were copied (faces on the same vertices).
    twinned: Vec<bool>,
}

/// The patches' counts and shape figures of `stats` (patches, quads,
/// triangles, edge lengths, worst angle), from `out`.
fn recount(out: &Model, stats: &mut Stats) {
    let (mut quads, mut triangles, mut patches) = (0, 0, 0);
    let (mut lo, mut hi, mut sum, mut count) = (f64::INFINITY, 0.0f64, 0.0, 0usize);
    let mut worst = 180.0f64;
    for f in out.top_faces() {
        let face = &out.faces[f.idx()];
        patches += 1;
        if face.contours.len() != 1 {
            continue;
        }
        let c = &face.contours[0];
        for i in 0..c.len() {
            let l = out.pos(c[(i + 1) % c.len()]).distance(out.pos(c[i]));
            lo = lo.min(l);
            hi = hi.max(l);
            sum += l;
            count += 1;
        }
        if c.len() == 3 {
            triangles += 1;
            worst = worst.min(min_angle(&[out.pos(c[0]), out.pos(c[1]), out.pos(c[2])]));
        } else {
            quads += 1;
        }
    }
    stats.patches = patches;
    stats.quads = quads;
    stats.triangles = triangles;
    stats.worst_angle = worst;
    stats.min_edge = if count > 0 { lo } else { 0.0 };
    stats.max_edge = hi;
    stats.mean_edge = if count > 0 { sum / count as f64 } else { 0.0 };
}

/// Writes vertex statements for the vertices created since the last call.
fn flush_vertices(cx: &Ctx<'_>, out: &mut Model, emitted: &mut usize) {
    for k in *emitted..cx.vertices.len() {
        out.items.push(Item::Vertex(VertexId(k as u32)));
    }
    *emitted = cx.vertices.len();
}

fn min_angle(p: &[DVec3; 3]) -> f64 {
    (0..3)
        .map(|i| {
            let a = p[(i + 1) % 3] - p[i];
            let b = p[(i + 2) % 3] - p[i];
            a.angle_between(b).to_degrees()
        })
        .fold(180.0, f64::min)
}

/// Patches (as contour lists of one contour each) for one face, or `None` if
/// it cannot be meshed. `full`: the grid of rectangles and the refinement;
/// otherwise the plain constrained triangulation of the divided boundary.
fn mesh_face(
    cx: &mut Ctx<'_>,
    f: FaceId,
    stats: &mut Stats,
    full: bool,
) -> Option<Vec<Vec<Vec<VertexId>>>> {
    let m = cx.m;
    let face = &m.faces[f.idx()];
    let pts = face_points(m, face);
    let n = geom::face_normal(&pts)?;
    let frame = mesh_frame(&pts)?;
    let len = cx.opts.len;
    let eps = cx.opts.eps;

    // 1. Boundary: contours with division points.
    let mut bcontours: Vec<Vec<VertexId>> = Vec::new();
    // Each boundary segment's contour edge (both sorted).
    let mut borig: Vec<SegmentOf> = Vec::new();
    for c in &face.contours {
        let mut bc = Vec::new();
        for i in 0..c.len() {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            let from = bc.len();
            bc.extend(cx.divided(a, b));
            for k in from..bc.len() {
                let (u, v) = (bc[k], if k + 1 < bc.len() { bc[k + 1] } else { b });
                borig.push(((u.min(v), u.max(v)), (a.min(b), a.max(b))));
            }
        }
        bcontours.push(bc);
    }
    let b2: Vec<Vec<DVec2>> = bcontours
        .iter()
        .map(|c| c.iter().map(|&v| frame.to_2d(cx.pos(v))).collect())
        .collect();
    let segs: Vec<(DVec2, DVec2)> = b2
        .iter()
        .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
        .collect();
    let seg_index = BoxIndex::new(segs.iter().enumerate().map(|(k, &(a, b))| {
        let (lo, hi) = (a.min(b), a.max(b));
        (lo.extend(0.0), hi.extend(0.0), k as u32)
    }));
    let mut bpoints: Vec<(DVec2, VertexId)> = b2
        .iter()
        .zip(&bcontours)
        .flat_map(|(c2, c)| c2.iter().copied().zip(c.iter().copied()))
        .collect();
    // Vertices of other faces resting inside this one become corners of
    // its patches: any patch edge passing within epsilon of one would be a
    // T-vertex. They count as boundary points for the grid (no cell around
    // one; a cell corner within epsilon is one) and for the triangulation,
    // but constrain nothing.
    if let Some(rest) = cx.resting.get(&f) {
        bpoints.extend(rest.iter().map(|&v| (frame.to_2d(cx.pos(v)), v)));
    }
    let point_index = BoxIndex::new(
        bpoints
            .iter()
            .enumerate()
            .map(|(k, (p, _))| (p.extend(0.0), p.extend(0.0), k as u32)),
    );

    // 2. Grid.
    let (lo, hi) = bbox(b2[0].iter().map(|p| p.extend(0.0)), 0.0);
    let (lo, hi) = (lo.truncate(), hi.truncate());
    let nx = segments(hi.x - lo.x, len);
    let ny = segments(hi.y - lo.y, len);
    let (du, dv) = ((hi.x - lo.x) / nx as f64, (hi.y - lo.y) / ny as f64);
    let corner = |i: usize, j: usize| {
        DVec2::new(
            if i == nx { hi.x } else { lo.x + du * i as f64 },
            if j == ny { hi.y } else { lo.y + dv * j as f64 },
        )
    };
    let mut accepted = vec![false; nx * ny];
    let margin = 0.25 * du.min(dv);
    if full && nx * ny <= 50_000_000 {
        for j in 0..ny {
            let y = lo.y + dv * (j as f64 + 0.5);
            // Crossings of the row's centre line (half-open rule).
            let mut xs: Vec<f64> = segs
                .iter()
                .filter(|(a, b)| (a.y > y) != (b.y > y))
                .map(|(a, b)| a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y))
                .collect();
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                let i0 = (((pair[0] - lo.x) / du).floor().max(0.0)) as usize;
                let i1 = ((((pair[1] - lo.x) / du).ceil()) as usize).min(nx);
                for i in i0..i1 {
                    let cx_ = lo.x + du * (i as f64 + 0.5);
                    if cx_ > pair[0] && cx_ < pair[1] {
                        let (a, b) = (corner(i, j), corner(i + 1, j + 1));
                        accepted[j * nx + i] =
                            cell_ok(a, b, eps, margin, &segs, &seg_index, &bpoints, &point_index);
                    }
                }
            }
        }
    }
    stats.grid_cells += accepted.iter().filter(|&&a| a).count();

    // Corner vertices of accepted cells (snapped to boundary points).
    let mut corner_ids: FxHashMap<(usize, usize), VertexId> = FxHashMap::default();
    let fname = face.name.clone().unwrap_or_else(|| format!("f{}", f.0 + 1));
    let mut next_inner = 1usize;
    let mut corner_vertex =
        |cx: &mut Ctx<'_>, i: usize, j: usize, next_inner: &mut usize| -> VertexId {
            if let Some(&v) = corner_ids.get(&(i, j)) {
                return v;
            }
            let p = corner(i, j);
            let near = point_index.query(
                (p - DVec2::splat(eps)).extend(0.0),
                (p + DVec2::splat(eps)).extend(0.0),
            );
            let v = match near.first() {
                Some(&k) => bpoints[k as usize].1,
                None => {
                    let v = cx.inner_vertex(&fname, *next_inner, frame.to_3d(p));
                    *next_inner += 1;
                    v
                }
            };
            corner_ids.insert((i, j), v);
            v
        };
    let mut quads = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            if accepted[j * nx + i] {
                let q = [
                    corner_vertex(cx, i, j, &mut next_inner),
                    corner_vertex(cx, i + 1, j, &mut next_inner),
                    corner_vertex(cx, i + 1, j + 1, &mut next_inner),
                    corner_vertex(cx, i, j + 1, &mut next_inner),
                ];
                quads.push(q);
            }
        }
    }
    let is_acc = |i: isize, j: isize| {
        i >= 0
            && j >= 0
            && (i as usize) < nx
            && (j as usize) < ny
            && accepted[j as usize * nx + i as usize]
    };
    // Outline of the accepted cells: cell edges with an accepted cell on one side only.
    let mut outline: Vec<(VertexId, VertexId)> = Vec::new();
    for j in 0..ny as isize {
        for i in 0..nx as isize {
            if !is_acc(i, j) {
                continue;
            }
            let c = |a: isize, b: isize| corner_ids[&(a as usize, b as usize)];
            if !is_acc(i, j - 1) {
                outline.push((c(i, j), c(i + 1, j)));
            }
            if !is_acc(i + 1, j) {
                outline.push((c(i + 1, j), c(i + 1, j + 1)));
            }
            if !is_acc(i, j + 1) {
                outline.push((c(i + 1, j + 1), c(i, j + 1)));
            }
            if !is_acc(i - 1, j) {
                outline.push((c(i, j + 1), c(i, j)));
            }
        }
    }

    // 3. Constrained Delaunay triangulation of the rest, refined.
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> =
        ConstrainedDelaunayTriangulation::new();
    let mut ids: Vec<VertexId> = Vec::new();
    let mut handle: FxHashMap<VertexId, spade::handles::FixedVertexHandle> = FxHashMap::default();
    let mut insert = |cdt: &mut ConstrainedDelaunayTriangulation<Point2<f64>>,
                      ids: &mut Vec<VertexId>,
                      v: VertexId,
                      p: DVec2|
     -> Option<()> {
        if handle.contains_key(&v) {
            return Some(());
        }
        let h = cdt.insert(Point2::new(p.x, p.y)).ok()?;
        if h.index() != ids.len() {
            return None; // two vertices at one position
        }
        ids.push(v);
        handle.insert(v, h);
        Some(())
    };
    for (p, v) in &bpoints {
        insert(&mut cdt, &mut ids, *v, *p)?;
    }
    for &(a, b) in &outline {
        for v in [a, b] {
            let p = frame.to_2d(cx.pos(v));
            insert(&mut cdt, &mut ids, v, p)?;
        }
    }
    let constrain = |cdt: &mut ConstrainedDelaunayTriangulation<Point2<f64>>,
                     a: VertexId,
                     b: VertexId|
     -> Option<()> {
        let (ha, hb) = (handle[&a], handle[&b]);
        if ha == hb || !cdt.can_add_constraint(ha, hb) {
            return None;
        }
        cdt.add_constraint(ha, hb);
        Some(())
    };
    for c in &bcontours {
        for i in 0..c.len() {
            constrain(&mut cdt, c[i], c[(i + 1) % c.len()])?;
        }
    }
    for &(a, b) in &outline {
        constrain(&mut cdt, a, b)?;
    }
    let before = cdt.num_vertices();
    let params = RefinementParameters::<f64>::new()
        .exclude_outer_faces(true)
        .keep_constraint_edges()
        .with_angle_limit(AngleLimit::from_deg(cx.opts.angle))
        .with_max_allowed_area(0.6 * len * len)
        .with_min_required_area(1e-4 * len * len)
        .with_max_additional_vertices(20 * before + 1000);
    if full {
        cdt.refine(params);
        drop_crowded(&mut cdt, before, eps);
    }
    let in_cell = |p: DVec2| {
        let i = ((p.x - lo.x) / du).floor();
        let j = ((p.y - lo.y) / dv).floor();
        is_acc(i as isize, j as isize)
    };
    let key = |a: usize, b: usize| (a.min(b), a.max(b));
    let fixed: FxHashSet<(VertexId, VertexId)> = bcontours
        .iter()
        .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
        .chain(outline.iter().copied())
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    // Twice at most: a second time with a point across each jog that the
    // first left a needle on (see `jog_points`).
    let mut jogs_done = false;
    let (tris, steiner) = loop {
        let added: Vec<Point2<f64>> = cdt
            .vertices()
            .skip(ids.len())
            .map(|v| v.position())
            .collect();
        for p in added {
            let v = cx.inner_vertex(&fname, next_inner, frame.to_3d(DVec2::new(p.x, p.y)));
            next_inner += 1;
            ids.push(v);
        }
        // Inside or outside, decided topologically: a flood fill over the
        // triangles from the convex hull, switching sides at every boundary
        // segment (cell outlines do not count). Point location would be fooled
        // by boundary points that are collinear only up to rounding.
        let boundary: FxHashSet<(usize, usize)> = bcontours
            .iter()
            .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
            .map(|(a, b)| key(handle[&a].index(), handle[&b].index()))
            .collect();
        let mut inside: Vec<Option<bool>> = vec![None; cdt.num_all_faces()];
        let mut queue = std::collections::VecDeque::new();
        for tri in cdt.inner_faces() {
            for e in tri.adjacent_edges() {
                if e.rev().face().is_outer() && inside[tri.fix().index()].is_none() {
                    let crossing =
                        boundary.contains(&key(e.from().fix().index(), e.to().fix().index()));
                    inside[tri.fix().index()] = Some(crossing);
                    queue.push_back(tri.fix());
                }
            }
        }
        while let Some(fh) = queue.pop_front() {
            let tri = cdt.face(fh);
            let here = inside[fh.index()].unwrap_or(false);
            for e in tri.adjacent_edges() {
                let Some(g) = e.rev().face().as_inner() else {
                    continue;
                };
                if inside[g.fix().index()].is_some() {
                    continue;
                }
                let crossing =
                    boundary.contains(&key(e.from().fix().index(), e.to().fix().index()));
                inside[g.fix().index()] = Some(here ^ crossing);
                queue.push_back(g.fix());
            }
        }
        let mut tris: Vec<[VertexId; 3]> = Vec::new();
        for tri in cdt.inner_faces() {
            if inside[tri.fix().index()] != Some(true) {
                continue;
            }
            let vs = tri.vertices();
            let p = vs.map(|v| DVec2::new(v.position().x, v.position().y));
            if in_cell((p[0] + p[1] + p[2]) / 3.0) {
                continue;
            }
            tris.push(vs.map(|v| ids[v.fix().index()]));
        }
        // Slivers: a boundary vertex on a nearly straight run (within epsilon
        // of the line through its neighbours) makes a triangle of no width with
        // them; flipping its long side away fixes it.
        let at = |v: VertexId| frame.to_2d(cx.pos(v));
        let steiner = remove_slivers(&mut tris, &fixed, &at, eps);
        if !jogs_done {
            jogs_done = true;
            let (mut jogs, stuck) =
                jog_points(&tris, &steiner, &at, &bcontours, &segs, &seg_index, eps);
            for q in fold_points(
                cx, f, frame, &tris, &steiner, &at, &borig, &segs, &seg_index,
            ) {
                if jogs.iter().all(|o| o.distance(q) > 2.0 * eps) {
                    jogs.push(q);
                }
            }
            let known = cx.m.vertices.len();
            cx.stuck.extend(
                stuck
                    .into_iter()
                    .filter(|(a, b)| a.idx() < known && b.idx() < known),
            );
            if !jogs.is_empty() {
                let first = cdt.num_vertices();
                for q in jogs {
                    cdt.insert(Point2::new(q.x, q.y)).ok()?;
                }
                drop_crowded(&mut cdt, first, eps);
                continue;
            }
        }
        break (tris, steiner);
    };
    let mut tris = tris;
    if !steiner.is_empty() {
        let ids: Vec<VertexId> = steiner
            .iter()
            .map(|&q| {
                let v = cx.inner_vertex(&fname, next_inner, frame.to_3d(q));
                next_inner += 1;
                v
            })
            .collect();
        for t in tris.iter_mut() {
            for v in t.iter_mut() {
                if v.0 > u32::MAX - 1_000_000 && ((u32::MAX - v.0) as usize) < ids.len() {
                    *v = ids[(u32::MAX - v.0) as usize];
                }
            }
        }
    }
    let mut patches: Vec<Vec<Vec<VertexId>>> =
        quads.into_iter().map(|q| vec![q.to_vec()]).collect();
    let joined = if cx.opts.quads {
        join_pairs(cx, &tris, n)
    } else {
        tris.iter().map(|t| t.to_vec()).collect()
    };
    patches.extend(joined.into_iter().map(|c| vec![c]));
    Some(patches)
}

/// Removes slivers: triangles with a vertex within `eps` of the opposite
/// side. The long side of a sliver is flipped away when it is not a fixed
/// edge, the two triangles across it form a strictly convex quadrilateral
/// and neither new triangle is a sliver; otherwise the quadrilateral gets a
/// point inside it (the best of a few candidates, by the smallest height of
/// the four triangles it makes), so that a short boundary edge nearly along
/// a thin strip (two cuts a millimetre apart) still gets triangles of some
/// width. Returns the new points, in order; their ids in `tris` are
/// `VertexId(u32::MAX - k)` for the k-th.
fn remove_slivers(
    tris: &mut Vec<[VertexId; 3]>,
    fixed: &FxHashSet<(VertexId, VertexId)>,
    at: &dyn Fn(VertexId) -> DVec2,
    eps: f64,
) -> Vec<DVec2> {
    use geom::orient2d;
    let mut steiner: Vec<DVec2> = Vec::new();
    let pos = |v: VertexId, st: &[DVec2]| {
        if v.0 > u32::MAX - 1_000_000 && ((u32::MAX - v.0) as usize) < st.len() {
            st[(u32::MAX - v.0) as usize]
        } else {
            at(v)
        }
    };
    let key = |a: VertexId, b: VertexId| (a.min(b), a.max(b));
    // Height over the longest side, and that side's position.
    let shape = |p: [DVec2; 3]| -> (f64, usize) {
        let (mut best, mut len) = (0, 0.0);
        for i in 0..3 {
            let l = (p[(i + 1) % 3] - p[i]).length();
            if l > len {
                (best, len) = (i, l);
            }
        }
        (width(p, eps), best)
    };
    let ccw = |p: [DVec2; 3]| orient2d(p[0], p[1], p[2]) > 0;
    let mut by_edge: FxHashMap<(VertexId, VertexId), usize> = FxHashMap::default();
    for (k, t) in tris.iter().enumerate() {
        for i in 0..3 {
            by_edge.insert((t[i], t[(i + 1) % 3]), k);
        }
    }
    let mut work: Vec<usize> = (0..tris.len()).rev().collect();
    let mut budget = 8 * tris.len() + 16;
    while let Some(k) = work.pop() {
        if budget == 0 {
            break;
        }
        let t = tris[k];
        let p = t.map(|v| pos(v, &steiner));
        let (h, i) = shape(p);
        if h > eps {
            continue;
        }
        let (a, b, m) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
        if fixed.contains(&key(a, b)) {
            continue;
        }
        let Some(&o) = by_edge.get(&(b, a)) else {
            continue;
        };
        let ot = tris[o];
        let Some(x) = ot.iter().copied().find(|&v| v != a && v != b) else {
            continue;
        };
        let (pa, pb, pm, px) = (
            pos(a, &steiner),
            pos(b, &steiner),
            pos(m, &steiner),
            pos(x, &steiner),
        );
        budget -= 1;
        // Quad a → x → b → m (counter-clockwise).
        let convex = orient2d(pm, px, pa) < 0 && orient2d(pm, px, pb) > 0;
        let flipped = [[m, a, x], [m, x, b]];
        let flip_ok = convex
            && flipped.iter().all(|nt| {
                let q = nt.map(|v| pos(v, &steiner));
                ccw(q) && shape(q).0 > eps
            });
        let replace: Vec<[VertexId; 3]> = if flip_ok {
            flipped.to_vec()
        } else {
            // A point inside the quad: the best candidate.
            let quad = [pa, px, pb, pm];
            let mut best: Option<(f64, DVec2)> = None;
            let mut consider = |q: DVec2| {
                let hmin = (0..4)
                    .map(|j| {
                        let tri = [quad[j], quad[(j + 1) % 4], q];
                        if ccw(tri) { shape(tri).0 } else { -1.0 }
                    })
                    .fold(f64::INFINITY, f64::min);
                if best.is_none_or(|(bh, _)| hmin > bh) {
                    best = Some((hmin, q));
                }
            };
            for wa in [1.0, 2.0, 4.0] {
                for wx in [1.0, 2.0, 4.0] {
                    for wb in [1.0, 4.0, 16.0] {
                        for wm in [1.0, 4.0, 16.0] {
                            consider((pa * wa + px * wx + pb * wb + pm * wm) / (wa + wx + wb + wm));
                        }
                    }
                }
            }
            // In a long thin quad the good point sits off a short side,
            // about that side's length inside: the averages above land
            // near the far end.
            // And where the quad is narrower than a short side is long
            // (a 1 mm step on one side of a strip 0.2 mm wide), those
            // overshoot the far side: fractions of the way across from
            // the side's midpoint to the quad's far boundary.
            for j in 0..4 {
                let (u, w) = (quad[j], quad[(j + 1) % 4]);
                let inward = (w - u).perp();
                let mid = (u + w) / 2.0;
                for t in [0.25, 0.5, 1.0, 2.0] {
                    consider(mid + inward * t);
                }
                let across = (1..4)
                    .filter_map(|s| {
                        let (c, d) = (quad[(j + s) % 4], quad[(j + s + 1) % 4]);
                        ray_segment(mid, inward, c, d)
                    })
                    .fold(f64::INFINITY, f64::min);
                if across.is_finite() {
                    for f in [0.25, 0.5, 0.75] {
                        consider(mid + inward * (across * f));
                    }
                }
            }
            match best {
                Some((hmin, q)) if hmin > eps => {
                    let id = VertexId(u32::MAX - steiner.len() as u32);
                    steiner.push(q);
                    vec![[a, x, id], [x, b, id], [b, m, id], [m, a, id]]
                }
                _ => continue,
            }
        };
        for tt in [t, ot] {
            for j in 0..3 {
                by_edge.remove(&(tt[j], tt[(j + 1) % 3]));
            }
        }
        let mut slots = vec![k, o];
        while slots.len() < replace.len() {
            tris.push(replace[0]);
            slots.push(tris.len() - 1);
        }
        for (&slot, nt) in slots.iter().zip(&replace) {
            tris[slot] = *nt;
            for j in 0..3 {
                by_edge.insert((nt[j], nt[(j + 1) % 3]), slot);
            }
            work.push(slot);
        }
    }
    steiner
}

/// Whether the grid cell [a, b] can be a patch: it lies inside the face (its
/// centre was found inside by the caller), and the boundary keeps away from
/// it — within `margin` of it there is no boundary point but at its corners,
/// and no boundary segment but its own edges and segments that leave a corner
/// along the line of one of its edges. So the triangles around the cells never
/// have to fill a thin gap.
#[allow(clippy::too_many_arguments)]
fn cell_ok(
    a: DVec2,
    b: DVec2,
    eps: f64,
    margin: f64,
    segs: &[(DVec2, DVec2)],
    seg_index: &BoxIndex,
    bpoints: &[(DVec2, VertexId)],
    point_index: &BoxIndex,
) -> bool {
    let corners = [a, DVec2::new(b.x, a.y), b, DVec2::new(a.x, b.y)];
    let corner_of = |p: DVec2| corners.iter().position(|c| (*c - p).length() <= eps);
    let (lo, hi) = (
        (a - DVec2::splat(margin)).extend(0.0),
        (b + DVec2::splat(margin)).extend(0.0),
    );
    for k in point_index.query(lo, hi) {
        if corner_of(bpoints[k as usize].0).is_none() {
            return false;
        }
    }
    // A segment leaving corner c along a grid line, away from the cell (not
    // along one of the cell's own edges, which would put the cell's next
    // corner inside the segment).
    let on_edge_line = |c: usize, q: DVec2| {
        let p = corners[c];
        let d = q - p;
        let along = (d.x).abs() <= eps || (d.y).abs() <= eps;
        let outward =
            d.dot(corners[(c + 1) % 4] - p) <= 0.0 && d.dot(corners[(c + 3) % 4] - p) <= 0.0;
        along && outward
    };
    for k in seg_index.query(lo, hi) {
        let (p, q) = segs[k as usize];
        match (corner_of(p), corner_of(q)) {
            // One of the cell's own edges.
            (Some(i), Some(j)) if (i + 1) % 4 == j || (j + 1) % 4 == i => continue,
            (Some(i), None)
                if on_edge_line(i, q)
                    && !clips(p, q, a + DVec2::splat(eps), b - DVec2::splat(eps)) =>
            {
                continue;
            }
            (None, Some(j))
                if on_edge_line(j, p)
                    && !clips(p, q, a + DVec2::splat(eps), b - DVec2::splat(eps)) =>
            {
                continue;
            }
            _ => {}
        }
        // Any other segment must stay `margin` away from the cell.
        if clips(p, q, a - DVec2::splat(margin), b + DVec2::splat(margin)) {
            return false;
        }
    }
    true
}

/// Removes the points the refinement added, or those put across jogs
/// (those from index `first` on), that lie within `eps` of another vertex
/// or of the far side of one of their triangles, later ones first: an edge
/// between them would have no length. (The 100,000-face building exported
/// as triangles, the user's pipeline: a floor with hundreds of holes got
/// three refinement points within 0.4 epsilon of each other, and patches
/// with zero-length edges.) In a Delaunay triangulation a point's nearest
/// vertex is one of its neighbours, so only those are looked at; removal
/// swaps the last vertex into the removed one's place, so the boundary's
/// handles (before `first`) stay valid.
fn drop_crowded(cdt: &mut ConstrainedDelaunayTriangulation<Point2<f64>>, first: usize, eps: f64) {
    use spade::handles::FixedVertexHandle;
    if eps.is_nan() || eps <= 0.0 {
        return;
    }
    let mut i = cdt.num_vertices();
    while i > first {
        i -= 1;
        let h = FixedVertexHandle::from_index(i);
        let v = cdt.vertex(h);
        let p = v.position();
        let crowded = v.out_edges().any(|e| {
            let q = e.to().position();
            (q.x - p.x).hypot(q.y - p.y) <= eps
        });
        // … or within `eps` of the far side of one of its triangles, its
        // foot inside that side: a sliver with it as apex that
        // `remove_slivers` may find no way to mend. (Property seed 95021
        // rounded to 1 mm: a round column's facet 13 epsilon wide, beside
        // a pipe's hole in the next facet, got five points across the
        // jogs on their shared edge; one lay 0.02 epsilon off the line
        // through two others 7.6 and 37 mm away. Seed 95000 at 270 times
        // the default: a refinement point 0.69 epsilon from the far side
        // of its triangle in a facade strip divided near one end. Neither
        // a flip nor a point inside gave triangles wider than epsilon, and
        // ugcut wrote triangles narrower than epsilon and T-vertices.)
        let apex = || {
            let pos = |w: Point2<f64>| DVec3::new(w.x, w.y, 0.0);
            let at = pos(p);
            v.out_edges().any(|e| {
                e.face().as_inner().is_some() && {
                    let (a, b) = (pos(e.to().position()), pos(e.next().to().position()));
                    // (A foot outside the side puts the point within
                    // `eps` of an end, a neighbour: crowded already.)
                    geom::point_segment_distance(at, a, b).0 <= eps
                }
            })
        };
        if crowded || apex() {
            Triangulation::remove(cdt, h);
        }
    }
}

/// Boundary edges shorter than this many epsilons are jogs (see
/// [`jog_points`]). 2 until placed seed 3871: a step of 4 epsilon in a
/// strip's side had the strip's far corner as its Delaunay apex (a needle,
/// with the next vertex up the side 0.5 epsilon from it). Only needles on
/// such edges (and needles whose shortest side is a boundary edge) get a
/// point, so faces without a needle mesh as before.
const JOG: f64 = 8.0;

/// Points for the jogs of a face's boundary: an edge shorter than
/// [`JOG`]·`eps` (a step of about epsilon in a straight run, left where
/// two cuts a little more than epsilon apart meet it) makes a triangle
/// higher than epsilon only with its apex nearly straight across it. The
/// Delaunay apex may be a far vertex along the run: a needle, and no flip
/// across its long side mends it (the quadrilateral there is as thin).
/// For each such needle left in `tris` (after [`remove_slivers`], whose
/// points are `steiner`), the best point near the line straight across
/// the edge (by the least of the triangle's height and the point's
/// distance from the rest of the boundary), when that is more than
/// epsilon; inserted into the triangulation, it becomes the apex. (CAD
/// building of seed 2999: a rug's side with a step of 1.03 epsilon.)
fn jog_points(
    tris: &[[VertexId; 3]],
    steiner: &[DVec2],
    at: &dyn Fn(VertexId) -> DVec2,
    bcontours: &[Vec<VertexId>],
    segs: &[(DVec2, DVec2)],
    seg_index: &BoxIndex,
    eps: f64,
) -> (Vec<DVec2>, Vec<(VertexId, VertexId)>) {
    let mut out: Vec<DVec2> = Vec::new();
    let mut stuck: Vec<(VertexId, VertexId)> = Vec::new();
    if eps.is_nan() || eps <= 0.0 {
        return (out, stuck);
    }
    let pos = |v: VertexId| {
        if v.0 > u32::MAX - 1_000_000 && ((u32::MAX - v.0) as usize) < steiner.len() {
            steiner[(u32::MAX - v.0) as usize]
        } else {
            at(v)
        }
    };
    // The needles left; a face without one meshes as it is.
    let needles: Vec<([VertexId; 3], [DVec2; 3])> = tris
        .iter()
        .map(|t| (*t, t.map(pos)))
        .filter(|&(_, p)| width(p, eps) <= eps)
        .collect();
    if needles.is_empty() {
        return (out, stuck);
    }
    // Boundary edges (lower vertex first) and whether each is a jog.
    let boundary: FxHashMap<(VertexId, VertexId), bool> = bcontours
        .iter()
        .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
        .map(|(a, b)| {
            let l = (at(b) - at(a)).length();
            ((a.min(b), a.max(b)), l > 0.0 && l < JOG * eps)
        })
        .collect();
    // The distance from q to the boundary but segment `skip`.
    let clearance =
        |q: DVec2, skip: (DVec2, DVec2)| clearance(q, segs, seg_index, 64.0 * eps, Some(skip));
    let inside = |q: DVec2| inside_of(q, segs);
    for (t, p) in needles {
        // A needle's shortest side, when it is a boundary edge, is treated
        // as a jog too, however long: a contour vertex within epsilon of the
        // line through its neighbours, with the face's far side nearly in
        // line as well, leaves a needle that no flip or point inside its
        // quadrilateral mends (CAD building 8600 seed 9: a rug's edge 85
        // epsilon from a tile hole's side that bends by 0.66 epsilon).
        let shortest = (0..3)
            .min_by(|&i, &j| {
                let l = |k: usize| (p[(k + 1) % 3] - p[k]).length();
                l(i).total_cmp(&l(j))
            })
            .unwrap_or(0);
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let edge = (a.min(b), a.max(b));
            let Some(&jog) = boundary.get(&edge) else {
                continue;
            };
            if !(jog || i == shortest) {
                continue;
            }
            let (pa, pb, po) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
            let l = (pb - pa).length();
            // Straight across, towards the triangle's side.
            let mut n = (pb - pa).perp() / l;
            if n.dot(po - pa) < 0.0 {
                n = -n;
            }
            let mid = (pa + pb) / 2.0;
            // The point becomes the apex only inside the needle's
            // circumcircle (else the Delaunay triangulation keeps the
            // needle): such points come first, then the widest. (The
            // 100,000-face building exported as triangles: a slab's side
            // strip with a jog of 1.1 epsilon at a corner whose other
            // neighbour, a foot, is 2.5 epsilon up the next side; the widest
            // point straight across lay outside the circle.)
            let breaks = |q: DVec2| geom::incircle(pa, pb, po, q) > 0;
            let mut best: Option<(bool, f64, DVec2)> = None;
            // Nearly straight across first; where nothing there is wider
            // than epsilon, further round towards either side (a jog
            // nearly in line with its face's long side, at a sharp
            // corner: straight across from it lies outside the face;
            // property seed 86103 at 10 times epsilon, a pipe's end with
            // a jog of 2.9 epsilon at a corner of 52°).
            let fans: [&[f64]; 2] = [
                &[0.0, 4.0, -4.0, 8.0, -8.0, 12.0, -12.0],
                &[
                    20.0, -20.0, 30.0, -30.0, 40.0, -40.0, 50.0, -50.0, 60.0, -60.0,
                ],
            ];
            for fan in fans {
                if best.is_some_and(|(_, s, _)| s > eps) {
                    break;
                }
                for &deg in fan {
                    let (sn, cs) = deg.to_radians().sin_cos();
                    let d = DVec2::new(n.x * cs - n.y * sn, n.x * sn + n.y * cs);
                    for k in [2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0] {
                        let q = mid + d * (k * eps);
                        let score = width([pa, pb, q], eps).min(clearance(q, (pa, pb)));
                        let b = breaks(q) && score > eps;
                        let better = best.is_none_or(|(bb, s, _)| (b, score) > (bb, s));
                        if better && inside(q) {
                            best = Some((b, score, q));
                        }
                    }
                }
            }
            match best.map(|(_, s, q)| (s, q)) {
                Some((score, q))
                    if score > eps && out.iter().all(|o| o.distance(q) > 2.0 * eps) =>
                {
                    out.push(q);
                }
                Some((score, _)) if score > eps => {}
                // No apex across an edge under 3 epsilon is wider than
                // epsilon: the face is too narrow there. Its straighter end
                // (the one nearer the line through its other neighbour and
                // the far end) joins the other.
                _ if l < JOIN * eps => {
                    if let Some(j) = join_of(a, b, bcontours, at) {
                        stuck.push(j);
                    }
                }
                _ => {}
            }
        }
    }
    (out, stuck)
}

/// A face's unit normal and its contours' signed areas about it (see
/// [`fold_sin`]).
fn fold_normal(m: &Model, g: FaceId) -> Option<FoldNormal> {
    let pts = face_points(m, &m.faces[g.idx()]);
    let gn = geom::face_normal(&pts)?.normalize();
    let gframe = Frame::new(DVec3::ZERO, gn);
    let areas = pts
        .iter()
        .map(|c| {
            let c2: Vec<DVec2> = c.iter().map(|&q| gframe.to_2d(q)).collect();
            geom::signed_area_2d(&c2)
        })
        .collect::<Vec<f64>>();
    Some((gn, areas))
}

/// The smallest sine of the angle at which a face across contour edge
/// `(oa, ob)` (`oa < ob`) of face `f` is folded back onto `f`, by
/// [`FOLD_MIN_DEG`] to 30°: its inside on the side of `inward`, `f`'s
/// inward direction at the edge (a unit vector in `f`'s plane). Faces on
/// the same vertices as `f` (twins, which get the same patches) do not
/// count. `normal` gives a face's [`fold_normal`].
fn fold_sin(
    m: &Model,
    planes: &FacePlanes,
    normal: &dyn Fn(FaceId) -> Option<FoldNormal>,
    f: FaceId,
    (oa, ob): (VertexId, VertexId),
    inward: DVec3,
) -> Option<f64> {
    let min_sin = FOLD_MIN_DEG.to_radians().sin();
    let dir = (m.pos(ob) - m.pos(oa)).normalize_or_zero();
    let mut own: Option<Vec<VertexId>> = None;
    let mut sin_fold: Option<f64> = None;
    for (g, ci, forward) in edge_uses(m, planes, oa, ob) {
        if g == f {
            continue;
        }
        let gface = &m.faces[g.idx()];
        // Its normal and its contours' signed areas about it.
        let Some((gn, area)) = normal(g).map(|(n, areas)| (n, areas[ci as usize])) else {
            continue;
        };
        // Where g walks the edge (`forward`: from the lower vertex),
        // and on which side its inside is: left of the walk for an
        // outer contour walked counter-clockwise about its normal
        // or a hole walked clockwise.
        if area == 0.0 {
            continue;
        }
        let walk = if forward { dir } else { -dir };
        let mut gin = gn.cross(walk);
        if (ci == 0) != (area > 0.0) {
            gin = -gin;
        }
        // Folded back by under 30° (the overlap test takes faces
        // within about 26° of parallel as coplanar).
        if gin.dot(inward) <= 0.0 {
            continue;
        }
        // Under 1° the faces lie on each other (coincident faces
        // sharing an edge): no point across mends that, and such
        // overlaps are ugcopl's and ugclean's.
        let s = gin.cross(inward).length();
        if !(min_sin..0.5).contains(&s) {
            continue;
        }
        if sin_fold.is_some_and(|x| x <= s) {
            continue;
        }
        let own = own.get_or_insert_with(|| {
            let mut k: Vec<VertexId> = m.faces[f.idx()]
                .contours
                .iter()
                .flatten()
                .copied()
                .collect();
            k.sort_unstable();
            k.dedup();
            k
        });
        let mut gk: Vec<VertexId> = gface.contours.iter().flatten().copied().collect();
        gk.sort_unstable();
        gk.dedup();
        if gk == *own {
            continue;
        }
        sin_fold = Some(s);
    }
    sin_fold
}

/// Below this angle two faces folded onto each other along an edge lie on
/// each other (coincident faces sharing it): [`fold_points`] leaves them
/// to ugcopl and ugclean. It also sets how near an apex is looked at.
const FOLD_MIN_DEG: f64 = 1.0;

/// Points that keep a face's patches along a fold from lying on the other
/// face's: where the face meets another along a contour edge at a small
/// angle θ, folded back onto it (a ramp running under a floor slab at
/// 3.3°, the two sharing the edge where it comes up through the floor),
/// a patch on that edge whose apex lies less than 3 epsilon / sin θ from
/// it has every corner within 2 epsilon of the other face's plane: it is
/// coplanar with the patch across, and overlaps it (property seed 25191
/// with stairs and curved things: a ramp piece's corner 1.27 epsilon
/// under its top edge, the apex of a triangle 1 m long, one overlapping
/// pair after ugcut). For each such triangle, the best point straight
/// across the edge at 6 epsilon / sin θ (and some farther), inside the
/// face and clear of its boundary, becomes its apex. Only folds under 30°
/// count: `ugcheck` takes faces more than about 26° apart as crossing, not
/// coplanar, however close. Faces on the same
/// vertices (twins, which get the same patches) do not count.
#[allow(clippy::too_many_arguments)]
fn fold_points(
    cx: &Ctx<'_>,
    f: FaceId,
    frame: Frame,
    tris: &[[VertexId; 3]],
    steiner: &[DVec2],
    at: &dyn Fn(VertexId) -> DVec2,
    borig: &[SegmentOf],
    segs: &[(DVec2, DVec2)],
    seg_index: &BoxIndex,
) -> Vec<DVec2> {
    let eps = cx.opts.eps;
    let mut out: Vec<DVec2> = Vec::new();
    if eps.is_nan() || eps <= 0.0 {
        return out;
    }
    let m = cx.m;
    let pos = |v: VertexId| {
        if v.0 > u32::MAX - 1_000_000 && ((u32::MAX - v.0) as usize) < steiner.len() {
            steiner[(u32::MAX - v.0) as usize]
        } else {
            at(v)
        }
    };
    let min_sin = FOLD_MIN_DEG.to_radians().sin();
    let reach = 3.0 * eps / min_sin;
    let to3 = |w: DVec2| frame.u * w.x + frame.v * w.y;
    // The triangles' edges with an apex that near (most faces have none;
    // only then are the boundary segments looked up).
    let mut low: Vec<(usize, usize, f64)> = Vec::new();
    for (ti, t) in tris.iter().enumerate() {
        let p = t.map(pos);
        for i in 0..3 {
            let (pa, pb, po) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
            let l = (pb - pa).length();
            if l > 0.0 {
                let h = (pb - pa).perp_dot(po - pa).abs() / l;
                if h < reach {
                    low.push((ti, i, h));
                }
            }
        }
    }
    if low.is_empty() {
        return out;
    }
    let borig: FxHashMap<(VertexId, VertexId), (VertexId, VertexId)> =
        borig.iter().copied().collect();
    for (ti, i, h) in low {
        let t = &tris[ti];
        let p = t.map(pos);
        let (a, b) = (t[i], t[(i + 1) % 3]);
        let Some(&(oa, ob)) = borig.get(&(a.min(b), a.max(b))) else {
            continue;
        };
        let (pa, pb, po) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
        let l = (pb - pa).length();
        // The face's inward direction at the edge, and the other faces'.
        let d2 = (pb - pa) / l;
        let mut n = d2.perp();
        if n.dot(po - pa) < 0.0 {
            n = -n;
        }
        let inward = to3(n).normalize_or_zero();
        let normal = |g: FaceId| {
            cx.fold_normals
                .borrow_mut()
                .entry(g)
                .or_insert_with(|| fold_normal(m, g))
                .clone()
        };
        let sin_fold = fold_sin(m, &cx.planes, &normal, f, (oa, ob), inward);
        let Some(s) = sin_fold else {
            continue;
        };
        if h * s >= 3.0 * eps {
            continue;
        }
        let target = 6.0 * eps / s;
        let clearance = |q: DVec2| clearance(q, segs, seg_index, target.max(64.0 * eps), None);
        let inside = |q: DVec2| inside_of(q, segs);
        let breaks = |q: DVec2| geom::incircle(pa, pb, po, q) > 0;
        let mut best: Option<(bool, f64, DVec2)> = None;
        for along in [0.5, 0.35, 0.65, 0.2, 0.8] {
            for k in [1.0, 1.5, 2.0, 3.0] {
                let q = pa + (pb - pa) * along + n * (k * target);
                let score = width([pa, pb, q], eps).min(clearance(q));
                let b = breaks(q) && score > eps;
                if best.is_none_or(|(bb, sc, _)| (b, score) > (bb, sc)) && inside(q) {
                    best = Some((b, score, q));
                }
            }
        }
        if let Some((_, score, q)) = best
            && score > eps
            && out.iter().all(|o| o.distance(q) > 2.0 * eps)
        {
            out.push(q);
        }
    }
    out
}

/// The distance from `q` to the nearest boundary segment (but `skip`,
/// either way round), at most `r`.
fn clearance(
    q: DVec2,
    segs: &[(DVec2, DVec2)],
    seg_index: &BoxIndex,
    r: f64,
    skip: Option<(DVec2, DVec2)>,
) -> f64 {
    seg_index
        .query(
            (q - DVec2::splat(r)).extend(0.0),
            (q + DVec2::splat(r)).extend(0.0),
        )
        .into_iter()
        .map(|k| segs[k as usize])
        .filter(|&(s0, s1)| {
            skip.is_none_or(|(a, b)| !((s0 == a && s1 == b) || (s0 == b && s1 == a)))
        })
        .map(|(s0, s1)| {
            geom::point_segment_distance(q.extend(0.0), s0.extend(0.0), s1.extend(0.0)).0
        })
        .fold(r, f64::min)
}

/// Whether `q` lies inside the boundary segments (even-odd, half-open).
fn inside_of(q: DVec2, segs: &[(DVec2, DVec2)]) -> bool {
    segs.iter()
        .filter(|(s0, s1)| {
            (s0.y > q.y) != (s1.y > q.y)
                && q.x < s0.x + (q.y - s0.y) * (s1.x - s0.x) / (s1.y - s0.y)
        })
        .count()
        % 2
        == 1
}

/// Boundary edges shorter than this many epsilons whose needle no point
/// mends have their ends joined (see [`jog_points`]): the vertex moves by
/// under 3 epsilon. 2, as for tents, until property seed 170842 rounded to
/// 1 mm: a wall end's piece, a thin triangle with one more vertex on its
/// short side, had an edge 2.4 epsilon long where it was 1.1 epsilon wide;
/// nothing across it was wider than epsilon, and ugcut wrote a triangle
/// 0.26 epsilon wide and a T-vertex
/// (fixtures/cut/short-edge-on-a-neck-under-two-epsilon-wide.ug).
const JOIN: f64 = 3.0;

/// For the boundary edge (a, b): (the straighter end, the other). An end's
/// straightness: its distance from the line through its other contour
/// neighbour and the edge's far end. The higher vertex id moves on a tie.
fn join_of(
    a: VertexId,
    b: VertexId,
    bcontours: &[Vec<VertexId>],
    at: &dyn Fn(VertexId) -> DVec2,
) -> Option<(VertexId, VertexId)> {
    for c in bcontours {
        let n = c.len();
        for i in 0..n {
            let (x, y) = (c[i], c[(i + 1) % n]);
            if !((x == a && y == b) || (x == b && y == a)) {
                continue;
            }
            let before = c[(i + n - 1) % n];
            let after = c[(i + 2) % n];
            let off = |v: VertexId, other: VertexId, far: VertexId| {
                geom::point_segment_distance(
                    at(v).extend(0.0),
                    at(other).extend(0.0),
                    at(far).extend(0.0),
                )
                .0
            };
            // x's other neighbour is `before`, y's is `after`.
            let (dx, dy) = (off(x, before, y), off(y, after, x));
            let x_moves = dx < dy || (dx == dy && x > y);
            return Some(if x_moves { (x, y) } else { (y, x) });
        }
    }
    None
}

/// How wide a triangle is, as the sliver tests measure it against
/// epsilon: its height over its longest side, or its area over epsilon
/// where that is less. ugcheck calls a triangle degenerate when either is
/// at most epsilon (height: narrower than epsilon; area: at most ε²), and
/// a triangle all of whose sides are under 2 epsilon can pass the first
/// and not the second (property seed 2499, placed: a point 1.6 epsilon
/// across a side 1.2 epsilon long, area 0.96 ε²).
fn width(p: [DVec2; 3], eps: f64) -> f64 {
    let longest = (0..3)
        .map(|i| (p[(i + 1) % 3] - p[i]).length())
        .fold(0.0, f64::max);
    if longest <= 0.0 {
        return 0.0;
    }
    let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]).abs();
    let h = area2 / longest;
    if eps > 0.0 {
        h.min(area2 / (2.0 * eps))
    } else {
        h
    }
}

/// Where the ray `o + t·d` (t > 0) first meets segment c–d, as `t`.
fn ray_segment(o: DVec2, dir: DVec2, c: DVec2, d: DVec2) -> Option<f64> {
    let e = d - c;
    let den = dir.perp_dot(e);
    if den == 0.0 {
        return None;
    }
    let t = (c - o).perp_dot(e) / den;
    let s = (c - o).perp_dot(dir) / den;
    (t > 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
}

/// Whether segment p–q meets the open box (lo, hi) (Liang–Barsky).
fn clips(p: DVec2, q: DVec2, lo: DVec2, hi: DVec2) -> bool {
    if lo.x >= hi.x || lo.y >= hi.y {
        return false;
    }
    let d = q - p;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (pk, qk) in [
        (-d.x, p.x - lo.x),
        (d.x, hi.x - p.x),
        (-d.y, p.y - lo.y),
        (d.y, hi.y - p.y),
    ] {
        if pk == 0.0 {
            if qk <= 0.0 {
                return false;
            }
        } else {
            let r = qk / pk;
            if pk < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    t0 < t1
}

/// Greedily joins pairs of triangles sharing an edge into convex quads whose
/// angles all lie within 45° of a right angle (best pairs first).
fn join_pairs(cx: &Ctx<'_>, tris: &[[VertexId; 3]], n: DVec3) -> Vec<Vec<VertexId>> {
    let mut by_edge: FxHashMap<(VertexId, VertexId), usize> = FxHashMap::default();
    for (k, t) in tris.iter().enumerate() {
        for i in 0..3 {
            by_edge.insert((t[i], t[(i + 1) % 3]), k);
        }
    }
    let mut cands: Vec<(f64, usize, usize, [VertexId; 4])> = Vec::new();
    for (k, t) in tris.iter().enumerate() {
        for i in 0..3 {
            let (a, b, c) = (t[i], t[(i + 1) % 3], t[(i + 2) % 3]);
            let Some(&o) = by_edge.get(&(b, a)) else {
                continue;
            };
            if o <= k {
                continue;
            }
            let ot = tris[o];
            let Some(d) = ot.iter().copied().find(|&x| x != a && x != b) else {
                continue;
            };
            // Quad a, d, b, c (the shared edge a–b removed).
            let q = [a, d, b, c];
            let p = q.map(|v| cx.pos(v));
            let mut worst: f64 = 0.0;
            let mut convex = true;
            for j in 0..4 {
                let e1 = p[(j + 1) % 4] - p[j];
                let e0 = p[j] - p[(j + 3) % 4];
                if e0.cross(e1).dot(n) <= 0.0 {
                    convex = false;
                }
                let ang = (-e0).angle_between(e1).to_degrees();
                worst = worst.max((ang - 90.0).abs());
            }
            // Nor a quadrilateral bent out of its own plane (as ugcheck
            // measures it) by more than half an epsilon: a face a little
            // off planar (a keyhole wall at georeferenced coordinates
            // rounded to 0.1 mm, 0.9 epsilon) gave quads of a boundary
            // vertex and three points on the face's plane 1.3 epsilon
            // off their own. Its two triangles are planar.
            let flat =
                Plane::face_deviation(&[p.to_vec()]).is_some_and(|(d, _)| d <= 0.5 * cx.opts.eps);
            if convex && worst < 45.0 && flat {
                cands.push((worst, k, o, q));
            }
        }
    }
    cands.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut used = vec![false; tris.len()];
    let mut out: Vec<Vec<VertexId>> = Vec::new();
    let mut quads_at: Vec<Option<[VertexId; 4]>> = vec![None; tris.len()];
    for (_, k, o, q) in cands {
        if used[k] || used[o] {
            continue;
        }
        used[k] = true;
        used[o] = true;
        quads_at[k.min(o)] = Some(q);
    }
    for (k, t) in tris.iter().enumerate() {
        if let Some(q) = quads_at[k] {
            out.push(q.to_vec());
        } else if !used[k] {
            out.push(t.to_vec());
        }
    }
    out
}
