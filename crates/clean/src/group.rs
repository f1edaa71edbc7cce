//! The grouper, `ugvlmerge` (Smith 1991, §2.4): from the common
//! representation of a model (convex polygons with T-vertices and duplicated
//! vertices) to the ideal one (connected, complex faces).
//!
//! Three steps, each on the winged-edge [`Mesh`], each of which can be skipped:
//!
//! 1. [`merge_vertices`]: vertices within epsilon of an earlier vertex (in
//!    statement order) are replaced by it, found with an R*-tree. Faces left
//!    without area are dropped (the caller warns).
//! 2. [`split_edges`]: every vertex of a face that lies within epsilon of the
//!    interior of an edge is inserted into that edge, in every face that uses
//!    it, in order along the edge (no T-vertex remains). Edges are looked up
//!    in an R*-tree of the vertices, one query per edge.
//! 3. [`merge_faces`]: faces of the same material that share an edge, face the
//!    same way and lie in one plane are joined into one face, which may have
//!    holes (a wall around a window). Groups grow from their first face in
//!    statement order, which keeps its name and place. Boundary vertices the
//!    join left between two collinear edges of the joined face, and used by
//!    nothing else, are dropped.
//!
//! Everything is deterministic (no hash-map order reaches the output) and
//! near-linear: spatial-index queries, no all-pairs loops.

use std::time::{Duration, Instant};

use geom::{DVec3, Plane, point_segment_distance};
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{FaceId, Model, VertexId};
use winged::weld::Points;
pub use winged::weld::{Split, degeneracy, merge_vertices, split_edges};
use winged::{EdgeId, HalfEdge, Mesh, Repair, outer_first, trace_loops};

/// Default largest angle between the normals of faces that are joined, in degrees.
pub const DEFAULT_ANGLE: f64 = 1.0;

/// Longest run of collinear boundary vertices dropped between two kept ones.
const MAX_COLLINEAR_RUN: usize = 64;

/// What to do.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// The distance tolerance (model units).
    pub eps: f64,
    /// Largest angle between the normals of joined faces, in degrees.
    pub angle: f64,
    pub merge_vertices: bool,
    pub split_edges: bool,
    pub merge_faces: bool,
    /// Make every face sound in its plane after the vertex steps (see
    /// [`winged::pieces::settle`]): a contour that crosses or touches
    /// itself, or is narrower than epsilon somewhere, is repaired.
    pub repair: bool,
}

impl Options {
    /// All three steps, the default angle.
    pub fn new(eps: f64) -> Options {
        Options {
            eps,
            angle: DEFAULT_ANGLE,
            merge_vertices: true,
            split_edges: true,
            merge_faces: true,
            repair: true,
        }
    }
}

/// A face that was dropped, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dropped {
    /// Its UG name, or `#k` for the k-th face of the input (from 1).
    pub face: String,
    pub reason: String,
}

/// What the grouper did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    pub faces_in: usize,
    pub vertices_in: usize,
    /// Vertices replaced by an earlier one within epsilon.
    pub vertices_merged: usize,
    /// Faces dropped for having no area, in statement order.
    pub dropped: Vec<Dropped>,
    /// Triangles of a twisted quad triangulated twice given the other
    /// copy's diagonal ([`one_triangulation`]).
    pub retriangulated: usize,
    /// Vertices inserted into edges (T-vertices removed).
    pub tvertices: usize,
    /// Faces whose contours crossed or touched themselves, repaired.
    pub repaired: Vec<String>,
    /// Edges split (an edge with several T-vertices counts once per pass).
    pub edges_split: usize,
    /// Faces joined into an earlier face (and so removed).
    pub faces_joined: usize,
    /// Joined faces written (each made of at least two input faces).
    pub groups: usize,
    /// Holes and islands of the joined faces.
    pub holes: usize,
    /// Collinear boundary vertices dropped from joined faces.
    pub collinear: usize,
    /// Vertices no face used any more (merged, dropped or inside joined faces), removed.
    pub unused_removed: usize,
    pub faces_out: usize,
    pub vertices_out: usize,
    /// Time per step: merge vertices, split edges, merge faces.
    pub times: [Duration; 3],
}

/// Runs the enabled steps on a model (flattened first if needed).
pub fn vlmerge(model: Model, opts: &Options) -> Result<(Model, Stats), ug::Diagnostic> {
    let model = if model.is_flat() {
        model
    } else {
        model.flatten()?
    };
    let labels = face_labels(&model);
    let label = |f: FaceId| labels.get(f.idx()).cloned().flatten().unwrap_or_default();
    let mut st = Stats {
        faces_in: model.top_faces().count(),
        vertices_in: model.top_vertices().count(),
        ..Stats::default()
    };
    let mut mesh = Mesh::try_from_model(model)?;
    let nv = mesh.model().vertices.len();
    let used_before: Vec<bool> = (0..nv)
        .map(|v| !mesh.vertex_edges(VertexId(v as u32)).is_empty())
        .collect();
    for r in mesh.repairs() {
        if let Repair::DroppedFace { face } = r {
            st.dropped.push(Dropped {
                face: label(*face),
                reason: "fewer than 3 distinct vertices".to_string(),
            });
        }
    }

    let t = Instant::now();
    if opts.merge_vertices {
        let (merged, dropped) = merge_vertices(&mut mesh, opts.eps);
        st.vertices_merged = merged;
        st.dropped
            .extend(dropped.into_iter().map(|(f, reason)| Dropped {
                face: label(f),
                reason,
            }));
    }
    if opts.merge_vertices && opts.merge_faces {
        st.retriangulated = one_triangulation(&mut mesh, opts.eps);
    }
    st.times[0] = t.elapsed();

    let t = Instant::now();
    if opts.split_edges {
        let s = split_edges(&mut mesh, opts.eps);
        st.tvertices = s.inserted;
        st.edges_split = s.edges;
    }
    if opts.repair {
        let mut settled = winged::pieces::Settled::default();
        winged::pieces::repair_all(
            &mut mesh,
            opts.eps,
            &winged::pieces::Layout::frame_of,
            &|_| false,
            &mut settled,
        );
        st.tvertices += settled.tvertices;
        st.repaired = settled.repaired.iter().map(|&f| label(f)).collect();
        st.dropped.extend(settled.removed.iter().map(|&f| Dropped {
            face: label(f),
            reason: "no area left once its contours were made sound".to_string(),
        }));
    }
    st.times[1] = t.elapsed();

    let t = Instant::now();
    if opts.merge_faces {
        let j = merge_faces(&mut mesh, opts.eps, opts.angle);
        st.groups = j.groups;
        st.faces_joined = j.joined;
        st.holes = j.holes;
        st.collinear = j.collinear;
    }
    st.times[2] = t.elapsed();

    // Vertices that faces used before and no face uses now go.
    for (v, &was) in used_before.iter().enumerate() {
        let v = VertexId(v as u32);
        if was && mesh.vertex_edges(v).is_empty() && mesh.remove_vertex(v) {
            st.unused_removed += 1;
        }
    }
    let out = mesh.into_model();
    st.faces_out = out.top_faces().count();
    st.vertices_out = out.top_vertices().count();
    Ok((out, st))
}

/// Joins a point just beyond epsilon of a corner, within epsilon of an
/// edge leaving it, to the corner ([`winged::weld::near_corner_joins`]),
/// puts every point that lies within epsilon of another face's edge into
/// it ([`split_edges`]), then joins every tent's tip to its nearer neighbour
/// ([`winged::weld::collapse_tents`]: a contour vertex within epsilon of
/// the chord, under 2 epsilon long, between its neighbours, which `ugcheck`
/// counts as degenerate and no mesher covers without a sliver), in every
/// face that uses it, puts the points that now lie on other faces' edges
/// into them, and repairs a contour that now passes a vertex twice
/// ([`settle`]). ugclean's last step, so that the chain writes neither.
/// (The first split: ugcopl can leave a point 0.9 epsilon from a sliver's
/// edge that another piece, enclosed and then removed, had used: property
/// seed 95032 rounded to 1 mm, 2 T-vertices after the chain.) A model
/// with none of these comes back as it was.
///
/// First the faces in `bent` (the coincident step's
/// [`crate::coincident::Stats::bent`]) are folded into triangles where
/// still more than epsilon off their plane.
///
/// Joining a tip can make two faces coincident (the same corners, or the
/// same region): a facade piece and a wall piece whose contours differed
/// only by the tips of two tents (property seed 400363 on 3 × 2 rooms at
/// 4 decimals with oblique wings and curved things: two coincident pairs
/// after the chain). Where it moved anything, the coincident step
/// ([`crate::coincident::clean`]) runs again, and where that removes a
/// face, this step too (two more rounds at most). Returns the model, the
/// tips joined and what the coincident step removed.
pub fn collapse_tents(model: Model, eps: f64, bent: &[String]) -> (Model, Tents) {
    // Each of the coincident step's moves keeps the faces it bends within
    // half an epsilon of their plane, but a kept face that took its twin's
    // contour and then records of other pairs can end further off (a wall
    // top 3 epsilon off its plane: property seed 400805 on 3 × 2 rooms at
    // 1 mm, with `--keep-enclosed`). As `ugisect` and `ugcopl` do, such a
    // face is folded into triangles: no tool passes a non-planar face on
    // (one that came in so stays as it was). Here, after the enclosed
    // faces went (most such faces lie inside a slab), not before: folded,
    // a face 3 epsilon off its plane may cross a neighbour, and a face
    // crossed stays (seed 170845).
    let (model, folded) = crate::planar::refold_named(model, eps, bent);
    // The faces as they were (material and points), to find those a round
    // changed: a second coincident pass over every face of a building of
    // 300,000 cost a third of ugclean's time.
    let mut before: FxHashSet<u64> = crate::copl::face_keys(&model)
        .into_iter()
        .flatten()
        .collect();
    let (mut corners, mut dropped) = (0, Vec::new());
    let (mut out, mut joined, mut moved) =
        collapse_tents_once(model, eps, &mut corners, &mut dropped);
    let mut coincident = crate::coincident::Stats::default();
    for _ in 0..2 {
        if !moved {
            break;
        }
        let among: Vec<bool> = crate::copl::face_keys(&out)
            .iter()
            .map(|k| k.is_some_and(|k| !before.contains(&k)))
            .collect();
        let (next, st) = crate::coincident::clean_near(&out, eps, &among);
        if st.removed.is_empty() {
            break;
        }
        coincident.pairs += st.pairs;
        coincident.removed.extend(st.removed);
        coincident.area_removed += st.area_removed;
        coincident.dropped.extend(st.dropped);
        before = crate::copl::face_keys(&next)
            .into_iter()
            .flatten()
            .collect();
        let (o, j, m) = collapse_tents_once(next, eps, &mut corners, &mut dropped);
        (out, moved) = (o, m);
        joined += j;
    }
    (
        out,
        Tents {
            joined,
            coincident,
            folded,
            corners,
            dropped,
        },
    )
}

/// What [`collapse_tents`] did.
#[derive(Clone, Debug, Default)]
pub struct Tents {
    /// Tips joined to a neighbour.
    pub joined: usize,
    /// Coincident pairs the joins made, and the faces removed of them.
    pub coincident: crate::coincident::Stats,
    /// Faces more than epsilon off their plane, folded into triangles
    /// first.
    pub folded: usize,
    /// Points just beyond epsilon of a corner and within epsilon of an
    /// edge leaving it, joined to the corner first.
    pub corners: usize,
    /// Faces the joins left without area (all their vertices on a line, or
    /// fewer than three), dropped: their name (`#k` for the k-th face of
    /// the step's input, from 1) and why.
    pub dropped: Vec<Dropped>,
}

/// One round of [`collapse_tents`]: the model, the tips joined, and
/// whether anything moved; the points it joined to a corner are added to
/// `corners`, the faces it dropped to `dropped`.
fn collapse_tents_once(
    model: Model,
    eps: f64,
    corners: &mut usize,
    dropped: &mut Vec<Dropped>,
) -> (Model, usize, bool) {
    let labels = face_labels(&model);
    let label = |f: FaceId| labels.get(f.idx()).cloned().flatten().unwrap_or_default();
    let stated = stated_names(&model);
    let mut mesh = Mesh::from_model(model);
    // A point just beyond epsilon of a corner and within epsilon of an
    // edge leaving it joins the corner, as in ugcut: put into the edge, it
    // would make a spike with the corner's other edge, which it lies as
    // near, and the repair would take it out again (property seed 95021
    // rounded to 1 mm, with `--keep-enclosed`: a slab's cut point 1.002
    // epsilon from a desk foot's corner, 0.99 epsilon from both its edges).
    // (A corner takes one point a round: a few rounds.)
    let mut changed = false;
    for _ in 0..TENT_ROUNDS {
        let near = winged::weld::near_corner_joins(mesh.model(), mesh.model(), eps);
        if near.is_empty() {
            break;
        }
        let (n, gone) = winged::weld::join_vertices(&mut mesh, &near, eps);
        *corners += n;
        for (f, reason) in gone {
            dropped.push(Dropped {
                face: label(f),
                reason,
            });
        }
        if n == 0 {
            break;
        }
        changed = true;
    }
    changed |= split_edges(&mut mesh, eps).inserted > 0;
    // Putting the points back into the edges can make a tent again: a
    // second vertex on a short edge (under 2 epsilon) whose first one
    // the collapse joined to an end (property seed 2010 on 3 × 2 rooms,
    // placed and turned: a ramp's and a railing's corners either side of
    // a desk's ledge 1.87 epsilon long). Again, a few times at most.
    let mut joined = 0;
    for _ in 0..TENT_ROUNDS {
        let keeps = |mesh: &Mesh, v: VertexId, to: VertexId| join_keeps_pairs(mesh, v, to, eps);
        let split =
            |mesh: &Mesh, v: VertexId, ends: [VertexId; 2]| split_keeps_pairs(mesh, v, ends, eps);
        let (j, gone) = winged::weld::collapse_tents_split(&mut mesh, eps, &keeps, &split);
        for (f, reason) in gone {
            dropped.push(Dropped {
                face: label(f),
                reason,
            });
        }
        joined += j;
        if j == 0 {
            break;
        }
        split_edges(&mut mesh, eps);
    }
    let mut out = mesh.into_model();
    keep_stated(&mut out, &stated);
    // A tip joined to a vertex that another contour through it already
    // passes makes that contour visit it twice: the repair splits it there.
    if joined > 0 || changed {
        let gone;
        (out, gone) = settle_stated(out, eps);
        dropped.extend(gone);
    }
    (out, joined, joined > 0 || changed)
}

/// Whether moving `v` onto `to` leaves every pair of faces near `v` (those
/// through it, and those sharing a vertex with them or through `to`)
/// crossing or overlapping (as ugcheck judges) only where it did: a
/// tent's tip joined to a neighbour sweeps the faces through it across a
/// sliver, which may lie over a face coplanar with one of them.
fn join_keeps_pairs(mesh: &Mesh, v: VertexId, to: VertexId, eps: f64) -> bool {
    let each: Vec<(FaceId, VertexId)> = mesh.vertex_faces(v).into_iter().map(|f| (f, to)).collect();
    NearTip::new(mesh, v, &[to], eps).keeps(&each)
}

/// Where neither of a tent's ends keeps the pairs as a join
/// ([`join_keeps_pairs`]), the end each face through the tip `v` takes
/// so that, all moved together, every pair of faces near `v` crosses or
/// overlaps only where it did: each face the first of `ends` (the nearer
/// first) whose move alone keeps its pairs (a face the move leaves
/// without a plane, a triangle falling onto its edge, keeps them: it
/// goes; a table leg's bottom 1.4 epsilon under a floor, property seed
/// 400811 on 3 × 2 rooms at 1 mm). `None` where a face has none, or where
/// all take the same end (a join, which did not keep them).
/// See [`winged::weld::collapse_tents_split`].
fn split_keeps_pairs(
    mesh: &Mesh,
    v: VertexId,
    ends: [VertexId; 2],
    eps: f64,
) -> Option<Vec<(FaceId, VertexId)>> {
    let through = mesh.vertex_faces(v);
    if through.len() < 2 {
        return None;
    }
    let near = NearTip::new(mesh, v, &ends, eps);
    if !through
        .iter()
        .all(|f| near.before.iter().any(|(g, _)| g == f))
    {
        return None; // (a face through the tip with no shape to judge)
    }
    let each: Vec<(FaceId, VertexId)> = through
        .iter()
        .map(|&f| {
            let fits = |t: VertexId| near.keeps(&[(f, t)]);
            Some((f, ends.into_iter().find(|&t| fits(t))?))
        })
        .collect::<Option<_>>()?;
    if each.iter().all(|e| e.1 == each[0].1) {
        return None;
    }
    near.keeps(&each).then_some(each)
}

/// The faces near a tent's tip `v` (those through it, those sharing a
/// vertex with them, and those through the ends it may move to), each as
/// it is, to judge the tip's moves by.
struct NearTip<'a> {
    mesh: &'a Mesh,
    v: VertexId,
    eps: f64,
    before: Vec<(FaceId, geom::intersect::FaceGeom)>,
}

impl<'a> NearTip<'a> {
    fn new(mesh: &'a Mesh, v: VertexId, ends: &[VertexId], eps: f64) -> Self {
        let mut near: Vec<FaceId> = ends.iter().flat_map(|&t| mesh.vertex_faces(t)).collect();
        for f in mesh.vertex_faces(v) {
            for &u in mesh.face(f).contours.iter().flatten() {
                near.extend(mesh.vertex_faces(u));
            }
        }
        near.sort_unstable();
        near.dedup();
        let mut tip = NearTip {
            mesh,
            v,
            eps,
            before: Vec::new(),
        };
        tip.before = near
            .into_iter()
            .filter_map(|g| Some((g, tip.shape(g, None)?)))
            .collect();
        tip
    }

    /// Face `f` with the tip at vertex `to`'s place, or as it is.
    fn shape(&self, f: FaceId, to: Option<VertexId>) -> Option<geom::intersect::FaceGeom> {
        let moved = to.map(|t| (self.v, self.mesh.pos(t)));
        check::face_geom(self.mesh.model(), f, moved)
    }

    /// Whether moving the tip in each face of `each` to that face's vertex
    /// leaves every pair of a moved face with another near face crossing
    /// or overlapping (as ugcheck judges) only where it did.
    fn keeps(&self, each: &[(FaceId, VertexId)]) -> bool {
        use geom::intersect::FaceGeom;
        let overlap: fn(check::PairKind) -> bool = |k| matches!(k, check::PairKind::Overlap(_));
        let kind = |a: &FaceGeom, b: &FaceGeom| check::meeting(a, b, self.eps, Some(overlap));
        // Each near face before and, where it moves, after (a moved face
        // left without a plane is not judged).
        let after: Vec<(FaceId, &FaceGeom, Option<FaceGeom>)> = self
            .before
            .iter()
            .filter_map(|(g, gb)| match each.iter().find(|e| e.0 == *g) {
                Some(&(_, t)) => Some((*g, gb, Some(self.shape(*g, Some(t))?))),
                None => Some((*g, gb, None)),
            })
            .collect();
        fn now<'x>(e: &'x (FaceId, &'x FaceGeom, Option<FaceGeom>)) -> &'x FaceGeom {
            e.2.as_ref().unwrap_or(e.1)
        }
        after
            .iter()
            .filter(|(f, _, _)| each.iter().any(|e| e.0 == *f))
            .all(|x| {
                after
                    .iter()
                    .filter(|y| y.0 != x.0)
                    .all(|y| kind(now(x), now(y)) <= kind(x.1, y.1))
            })
    }
}

/// Rounds of collapsing tents and putting points back into edges in
/// [`collapse_tents`].
const TENT_ROUNDS: usize = 4;

/// The names of the vertices that have a statement.
fn stated_names(m: &Model) -> rustc_hash::FxHashSet<String> {
    m.top_vertices()
        .map(|v| m.vertices[v.idx()].name.clone())
        .collect()
}

/// Drops the statements of vertices not named in `stated`. A winged mesh
/// gives a statement to every vertex of a model's arena, those whose
/// statements were removed before (vertices only removed faces used)
/// included; joining, splitting and repairing make no new vertex.
fn keep_stated(m: &mut Model, stated: &rustc_hash::FxHashSet<String>) {
    let keep: Vec<bool> = m
        .vertices
        .iter()
        .map(|v| stated.contains(&v.name))
        .collect();
    m.items
        .retain(|it| !matches!(it, ug::Item::Vertex(v) if !keep[v.idx()]));
}

/// [`settle`] on a model whose arena may hold vertices without a
/// statement, which stay without one; on an error, the model as it was.
/// Also the faces it dropped (no area left), with why.
pub fn settle_stated(model: Model, eps: f64) -> (Model, Vec<Dropped>) {
    let stated = stated_names(&model);
    match settle(model.clone(), eps) {
        Ok((mut out, st)) => {
            keep_stated(&mut out, &stated);
            (out, st.dropped)
        }
        Err(_) => (model, Vec::new()),
    }
}

/// Makes every face sound before a tool works on the model: [`vlmerge`]
/// with its repair alone (no welding, no T-vertices, no joining). A
/// repeated vertex goes, a face with no area (collinear vertices, fewer
/// than three distinct ones) is dropped, and a contour that crosses or
/// touches itself (a bow-tie, a spike) is split into its even-odd region;
/// a model whose faces are all sound comes back as it was. ugplanar,
/// ugflip, ugisect, ugcopl and ugclean run it first, so that none of them
/// hands a degenerate face on (each tool of the chain must work in any
/// order, on raw exports); it costs about 3% of ugisect's time on the
/// 8.6k messy building.
pub fn settle(model: Model, eps: f64) -> Result<(Model, Stats), ug::Diagnostic> {
    vlmerge(
        model,
        &Options {
            merge_vertices: false,
            split_edges: false,
            merge_faces: false,
            repair: true,
            ..Options::new(eps)
        },
    )
}

/// [`settle`] for a command-line tool: its warnings go to stderr unless
/// `quiet` (every repaired face when `all`, else ten).
pub fn settle_warned(
    model: Model,
    eps: f64,
    quiet: bool,
    all: bool,
) -> Result<Model, ug::Diagnostic> {
    let (model, st) = settle(model, eps)?;
    if !quiet {
        for w in warnings(&st, all) {
            eprintln!("{w}");
        }
    }
    Ok(model)
}

/// The warnings for what [`vlmerge`] or [`settle`] dropped and repaired:
/// a line per face (at most ten repaired ones unless `all`).
pub fn warnings(st: &Stats, all: bool) -> Vec<String> {
    let mut out: Vec<String> = st
        .dropped
        .iter()
        .map(|d| format!("warning: face {}: {}; dropped", d.face, d.reason))
        .collect();
    let limit = if all { usize::MAX } else { 10 };
    out.extend(st.repaired.iter().take(limit).map(|f| {
        format!(
            "warning: face {f}: its contours cross or touch themselves, or it is narrower than epsilon somewhere; repaired"
        )
    }));
    if st.repaired.len() > limit {
        out.push(format!(
            "warning: {} more faces repaired (-v lists them)",
            st.repaired.len() - limit
        ));
    }
    out
}

/// Per face id: its name, or `#k` for the k-th top-level face (from 1), as `ugcheck` names it.
pub(crate) fn face_labels(m: &Model) -> Vec<Option<String>> {
    let mut labels = vec![None; m.faces.len()];
    for (k, f) in m.top_faces().enumerate() {
        if let Some(l) = labels.get_mut(f.idx())
            && l.is_none()
        {
            *l = Some(
                m.faces[f.idx()]
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("#{}", k + 1)),
            );
        }
    }
    labels
}

/// What [`merge_faces`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Join {
    /// Joined faces (groups of two or more input faces).
    pub groups: usize,
    /// Faces joined into an earlier one (removed).
    pub joined: usize,
    /// Holes and islands of the joined faces.
    pub holes: usize,
    /// Collinear boundary vertices dropped.
    pub collinear: usize,
}

/// Largest angle between the normals of the four triangles of a quad
/// triangulated twice for [`one_triangulation`] to take them as one
/// twisted surface (a real tetrahedron's faces are 70° or more apart).
const TWICE_ANGLE_DEG: f64 = 30.0;

/// Step 1b: a twisted quadrilateral triangulated twice, once along each
/// diagonal, is given one triangulation.
///
/// A duplicated non-planar quad `z x w y` exported as triangles (an OBJ or
/// STL export, a CAD program triangulating a flipped duplicate from its
/// first vertex) comes as the triangles `x y z`, `x y w` (diagonal `x y`)
/// and `z w x`, `z w y` (diagonal `z w`): the four faces of a thin
/// tetrahedron. Each pair folds onto the other at a few degrees, so near
/// their shared edges the faces are within epsilon of each other, which no
/// later step can resolve (ugcheck finds them intersecting, and after
/// meshing overlapping). Once the vertices are welded, the later pair in
/// statement order takes the earlier pair's diagonal, each face keeping its
/// own orientation: the two copies are then duplicates (or back to back)
/// as ugplanar makes them from the same quad in one piece, which ugclean
/// resolves. Only when all four triangles have one material, the four
/// vertices are not within `eps` of one plane (a planar quad's two
/// triangulations are joined by [`merge_faces`] as they are), both diagonals
/// are used by these triangles alone, and the four triangles' normals
/// (oriented round the quad) are within [`TWICE_ANGLE_DEG`] of each other
/// (the quad is convex seen along them, and thin). The later pair's area
/// changes by the difference of the two triangulations' (second order in
/// the twist). Returns the number of faces given the other diagonal.
pub fn one_triangulation(mesh: &mut Mesh, eps: f64) -> usize {
    let faces: Vec<FaceId> = mesh.faces().collect();
    let nf = mesh.model().faces.len();
    let mut rank = vec![u32::MAX; nf];
    for (k, &f) in faces.iter().enumerate() {
        rank[f.idx()] = k as u32;
    }
    let tri_of = |mesh: &Mesh, f: FaceId| -> Option<[VertexId; 3]> {
        let c = &mesh.face(f).contours;
        (c.len() == 1 && c[0].len() == 3).then(|| [c[0][0], c[0][1], c[0][2]])
    };
    let key = |a: VertexId, b: VertexId, c: VertexId| {
        let mut t = [a, b, c];
        t.sort_unstable();
        t
    };
    // Triangles by their sorted vertices, in statement order.
    let mut by_key: FxHashMap<[VertexId; 3], Vec<FaceId>> = FxHashMap::default();
    for &f in &faces {
        if let Some([a, b, c]) = tri_of(mesh, f) {
            by_key.entry(key(a, b, c)).or_default().push(f);
        }
    }
    if by_key.len() < 4 {
        return 0;
    }
    let cos_tol = TWICE_ANGLE_DEG.to_radians().cos();
    let mut taken = vec![false; nf];
    let mut swaps: Vec<(FaceId, [VertexId; 3])> = Vec::new();
    for &f in &faces {
        if taken[f.idx()] {
            continue;
        }
        let Some(tf) = tri_of(mesh, f) else { continue };
        let mat = mesh.face(f).material;
        for i in 0..3 {
            let (x, y, z) = (tf[i], tf[(i + 1) % 3], tf[(i + 2) % 3]);
            let Some(e) = mesh.edge_between(x, y) else {
                continue;
            };
            // The other triangle on this diagonal.
            let Some((g, w)) = mesh.edge(e).uses.iter().find_map(|u| {
                let g = u.face;
                if g == f || taken[g.idx()] || mesh.face(g).material != mat {
                    return None;
                }
                let tg = tri_of(mesh, g)?;
                let w = *tg.iter().find(|&&v| v != x && v != y)?;
                (w != z).then_some((g, w))
            }) else {
                continue;
            };
            // The other diagonal's two triangles.
            let pick = |k: [VertexId; 3]| {
                by_key.get(&k).and_then(|l| {
                    l.iter().copied().find(|&h| {
                        !taken[h.idx()] && h != f && h != g && mesh.face(h).material == mat
                    })
                })
            };
            let (Some(h1), Some(h2)) = (pick(key(z, w, x)), pick(key(z, w, y))) else {
                continue;
            };
            // Both diagonals used by triangles of these four vertices alone.
            let quad = [z, x, w, y];
            let inside = |a: VertexId, b: VertexId| {
                mesh.edge_between(a, b).is_some_and(|e| {
                    mesh.edge(e).uses.iter().all(|u| {
                        tri_of(mesh, u.face).is_some_and(|t| t.iter().all(|v| quad.contains(v)))
                    })
                })
            };
            if !inside(x, y) || !inside(z, w) {
                continue;
            }
            let p = quad.map(|v| mesh.pos(v));
            // Not planar within eps (else merge_faces joins each pair).
            let off = (0..4).any(|k| {
                let (a, b, c) = (p[(k + 1) % 4], p[(k + 2) % 4], p[(k + 3) % 4]);
                let n = (b - a).cross(c - a);
                let l = n.length();
                l > 0.0 && (n.dot(p[k] - a) / l).abs() > eps
            });
            if !off {
                continue;
            }
            // Round the quad z x w y: the four triangles' normals agree.
            let tri_n = |a: usize, b: usize, c: usize| (p[b] - p[a]).cross(p[c] - p[a]);
            let ns = [
                tri_n(0, 1, 3),
                tri_n(1, 2, 3),
                tri_n(0, 1, 2),
                tri_n(0, 2, 3),
            ];
            let agree = ns.iter().enumerate().all(|(a, na)| {
                ns[a + 1..].iter().all(|nb| {
                    na.dot(*nb) >= cos_tol * na.length() * nb.length() && na.dot(*nb) > 0.0
                })
            });
            if !agree {
                continue;
            }
            for v in [f, g, h1, h2] {
                taken[v.idx()] = true;
            }
            // The later pair takes the earlier pair's diagonal (f, the
            // first of the four in statement order, is in the earlier pair
            // unless ranks say otherwise).
            let first = |a: FaceId, b: FaceId| rank[a.idx()].min(rank[b.idx()]);
            let (redo, diag) = if first(f, g) <= first(h1, h2) {
                ([h1, h2], (x, y))
            } else {
                ([f, g], (z, w))
            };
            // The new triangles: the diagonal with each of the other two corners.
            let others: Vec<VertexId> = quad
                .iter()
                .copied()
                .filter(|&v| v != diag.0 && v != diag.1)
                .collect();
            let mut redo = redo;
            redo.sort_by_key(|h| rank[h.idx()]);
            for (h, &o) in redo.iter().zip(&others) {
                // Its orientation round the quad (the cycle z → x → w → y).
                let old = tri_of(mesh, *h).expect("a triangle");
                let with = (0..3).any(|k| {
                    let (a, b) = (old[k], old[(k + 1) % 3]);
                    (0..4).any(|q| quad[q] == a && quad[(q + 1) % 4] == b)
                });
                let mut t = [diag.0, diag.1, o];
                t.sort_by_key(|v| quad.iter().position(|q| q == v));
                if !with {
                    t.reverse();
                }
                swaps.push((*h, t));
            }
            break;
        }
    }
    for (h, t) in &swaps {
        mesh.set_face_contours(*h, vec![t.to_vec()]);
    }
    swaps.len()
}

/// An edge two different faces walk in opposite directions, used by nothing else.
fn is_seam(mesh: &Mesh, e: EdgeId) -> bool {
    let u = &mesh.edge(e).uses;
    u.len() == 2 && u[0].face != u[1].face && u[0].forward != u[1].forward
}

/// The face across edge `e` from face `f` that the grouper may join `f`
/// to: the other face of a seam; or, where the edge's faces are two faces
/// and their copies (the same vertices and material: a face exported twice
/// as triangles, each copy split along the same diagonal, so the diagonal
/// has four uses and is no seam), the copy of the other face paired with
/// `f`: the k-th by id of those walking `e` against `f`, when `f` is the
/// k-th of its own copies walking it as `f` does. The pairing is
/// symmetric, so each copy joins its own layer.
fn partner(mesh: &Mesh, e: EdgeId, f: FaceId) -> Option<FaceId> {
    let u = &mesh.edge(e).uses;
    if u.len() == 2 {
        return (is_seam(mesh, e) && (u[0].face == f || u[1].face == f))
            .then(|| if u[0].face == f { u[1].face } else { u[0].face });
    }
    if u.len() < 4 || u.len() % 2 == 1 || u.iter().filter(|x| x.face == f).count() != 1 {
        return None;
    }
    let sig = |g: FaceId| {
        let face = mesh.face(g);
        let mut v: Vec<VertexId> = face.contours.iter().flatten().copied().collect();
        v.sort_unstable();
        (face.material, v)
    };
    let mine = sig(f);
    let fwd = u.iter().find(|x| x.face == f)?.forward;
    let mut other = None;
    let (mut same, mut opp, mut n_mine) = (Vec::new(), Vec::new(), 0usize);
    for x in u {
        let s = sig(x.face);
        if s == mine {
            n_mine += 1;
            if x.forward == fwd {
                same.push(x.face);
            }
        } else {
            match &other {
                None => other = Some(s),
                Some(o) if *o == s => {}
                _ => return None,
            }
            if x.forward != fwd {
                opp.push(x.face);
            }
        }
    }
    if 2 * n_mine != u.len() || same.len() != opp.len() {
        return None;
    }
    same.sort_unstable();
    opp.sort_unstable();
    let k = same.iter().position(|&g| g == f)?;
    Some(opp[k])
}

/// The plane of a sound face all of whose vertices lie within `eps` of it.
fn flat_plane(mesh: &Mesh, f: FaceId, eps: f64) -> Option<Plane> {
    if degeneracy(mesh, f, eps).is_some() {
        return None;
    }
    let pl = mesh.face_plane(f)?;
    within(mesh, f, &pl, eps).then_some(pl)
}

/// Whether every vertex of `f` lies within `eps` of `pl`.
fn within(mesh: &Mesh, f: FaceId, pl: &Plane, eps: f64) -> bool {
    mesh.face(f)
        .contours
        .iter()
        .flatten()
        .all(|&v| pl.dist(mesh.pos(v)).abs() <= eps)
}

/// Step 3: joins coplanar faces of the same material that share edges.
///
/// Faces are taken in statement order; each face not yet in a group starts
/// one (its *seed*) and the group grows across seams (edges used by exactly
/// two faces walking them in opposite directions, so facing the same way) to
/// faces that have the seed's material, a normal within `angle_deg` degrees
/// of the seed's, all vertices within `eps` of the seed's plane and the
/// seed's vertices within `eps` of theirs. Where a face and its copy (the
/// same vertices and material) both come split along the same diagonal,
/// that diagonal has four uses: each copy is joined across it to its own
/// other half ([`partner`]), so the copies become two copies of one face.
/// A face sharing any other edge with the group (a non-manifold edge: three
/// walls along one line) is not taken, so no edge another face uses
/// disappears inside a joined face. When the
/// joined face would leave inside it a vertex that a face outside the group
/// uses (a pyramid's apex on a floor), the group's faces around that vertex
/// join nothing and the group grows again without them.
///
/// Each group's boundary is traced into contours (outer counter-clockwise
/// seen from the front, holes clockwise); the seed keeps them, its name and
/// place, the other faces are removed. Vertices left between two collinear
/// edges of a joined face (within `eps`), used by nothing else, are dropped
/// when the new edge would not pass through another vertex.
pub fn merge_faces(mesh: &mut Mesh, eps: f64, angle_deg: f64) -> Join {
    const NONE: u32 = u32::MAX;
    let faces: Vec<FaceId> = mesh.faces().collect();
    let nf = mesh.model().faces.len();
    let mut rank = vec![u32::MAX; nf];
    for (k, &f) in faces.iter().enumerate() {
        rank[f.idx()] = k as u32;
    }
    let cos_tol = angle_deg.clamp(0.0, 180.0).to_radians().cos();
    let mut planes: Vec<Option<Plane>> = vec![None; nf];
    for &f in &faces {
        planes[f.idx()] = flat_plane(mesh, f, eps);
    }
    let mut group = vec![NONE; nf];
    let mut excluded = vec![false; nf];
    let mut next_gid = 0u32;
    let mut groups: Vec<(Vec<FaceId>, Vec<Vec<VertexId>>)> = Vec::new();
    let grow = Grow {
        planes: &planes,
        rank: &rank,
        eps,
        cos_tol,
    };
    for &s in &faces {
        if group[s.idx()] != NONE || planes[s.idx()].is_none() || excluded[s.idx()] {
            continue;
        }
        loop {
            let gid = next_gid;
            next_gid += 1;
            let members = grow.group(mesh, s, gid, &mut group, &excluded);
            if members.len() < 2 {
                break;
            }
            let n = planes[s.idx()].expect("seeds are flat").n;
            let in_group = |f: FaceId| group[f.idx()] == gid;
            let halves = boundary_halves(mesh, &members, &in_group);
            let Some(contours) = trace_group(mesh, &halves, n) else {
                break; // left as they are
            };
            let mut bad = swallowing(mesh, &members, &contours, &in_group);
            if bad.is_empty()
                && let Some(f) = overlapping_member(mesh, &members, &halves, &contours, n)
            {
                if f == s {
                    break; // only the seed's own edges: left as they are
                }
                bad.push(f);
            }
            if bad.is_empty() {
                groups.push((members, contours));
                break;
            }
            // Keep vertices that other faces use on a boundary: the faces
            // around them join nothing; grow again without them.
            for f in &members {
                group[f.idx()] = NONE;
            }
            for f in bad {
                excluded[f.idx()] = true;
            }
            if excluded[s.idx()] {
                break;
            }
        }
    }

    let mut st = Join::default();
    let mut joined_faces = Vec::new();
    for (members, contours) in groups {
        let seed = members[0];
        for &g in &members[1..] {
            mesh.remove_face(g);
        }
        st.holes += contours.len() - 1;
        mesh.set_face_contours(seed, contours);
        st.groups += 1;
        st.joined += members.len() - 1;
        joined_faces.push(seed);
    }

    if !joined_faces.is_empty() {
        let used: Vec<VertexId> = mesh
            .vertices()
            .filter(|&v| !mesh.vertex_edges(v).is_empty())
            .collect();
        let index = Points::new(mesh, &used);
        let in_wire: FxHashSet<VertexId> = mesh
            .model()
            .wires
            .iter()
            .flat_map(|w| w.polylines.iter().flatten().copied())
            .collect();
        for &f in &joined_faces {
            st.collinear += drop_collinear(mesh, f, eps, &index, &in_wire);
        }
    }
    st
}

/// What growing a group needs to know.
struct Grow<'a> {
    planes: &'a [Option<Plane>],
    rank: &'a [u32],
    eps: f64,
    cos_tol: f64,
}

impl Grow<'_> {
    /// Grows group `gid` from seed `s` across seams to joinable faces that
    /// are in no group and not excluded; returns its faces in statement order.
    fn group(
        &self,
        mesh: &Mesh,
        s: FaceId,
        gid: u32,
        group: &mut [u32],
        excluded: &[bool],
    ) -> Vec<FaceId> {
        const NONE: u32 = u32::MAX;
        let ps = self.planes[s.idx()].expect("seeds are flat");
        group[s.idx()] = gid;
        let mut members = vec![s];
        let mut qi = 0;
        while qi < members.len() {
            let f = members[qi];
            qi += 1;
            for e in mesh.face_edges(f) {
                let Some(g) = partner(mesh, e, f) else {
                    continue;
                };
                if group[g.idx()] != NONE || excluded[g.idx()] {
                    continue;
                }
                let Some(pg) = self.planes[g.idx()] else {
                    continue;
                };
                let joinable = mesh.face(g).material == mesh.face(s).material
                    && ps.n.dot(pg.n) >= self.cos_tol
                    && within(mesh, g, &ps, self.eps)
                    && within(mesh, s, &pg, self.eps)
                    && !mesh.face_edges(g).into_iter().any(|e2| {
                        let p = partner(mesh, e2, g);
                        mesh.edge(e2)
                            .uses
                            .iter()
                            .any(|u| u.face != g && group[u.face.idx()] == gid && Some(u.face) != p)
                    });
                if joinable {
                    group[g.idx()] = gid;
                    members.push(g);
                }
            }
        }
        members.sort_by_key(|f| self.rank[f.idx()]);
        members
    }
}

/// The faces of a group that use a vertex the joined contours would leave
/// inside the joined face although a face outside the group uses it (say
/// the apex of a pyramid standing on a floor: swallowed, it would make the
/// pair intersect). Sorted, without repeats.
fn swallowing(
    mesh: &Mesh,
    members: &[FaceId],
    contours: &[Vec<VertexId>],
    in_group: &dyn Fn(FaceId) -> bool,
) -> Vec<FaceId> {
    let kept: FxHashSet<VertexId> = contours.iter().flatten().copied().collect(); // lookup only
    let mut bad = Vec::new();
    for &f in members {
        for &v in mesh.face(f).contours.iter().flatten() {
            if kept.contains(&v) {
                continue;
            }
            let fs = mesh.vertex_faces(v);
            if fs.iter().any(|&g| !in_group(g)) {
                bad.extend(fs.into_iter().filter(|&g| in_group(g)));
            }
        }
    }
    bad.sort_unstable();
    bad.dedup();
    bad
}

/// A member of a group whose faces overlap, not only meet along seams: the
/// latest (in statement order) of those owning the edges of a traced
/// contour that runs the outer contour's way round, or of two edges of the
/// traced contours that properly cross; the seed only when all of them are
/// its own. `None` when the traced contours are sound.
/// Joined across seams, faces that also overlap trace a boundary that
/// crosses itself: two tiles of a running bond turned by 4.6° and rounded
/// to millimetres, the one above sharing the corner of the one below and
/// its edge running 0.5 mm below that one's top corner, joined with a third
/// into a face whose contour crossed itself (property seed 170770 rounded
/// to 1 mm, at the relative epsilon: ugisect then lost 0.0015 m² of tile).
/// Left out of the group, such a face stays as it is, and the overlap is
/// ugcopl's.
fn overlapping_member(
    mesh: &Mesh,
    members: &[FaceId],
    halves: &[HalfEdge],
    contours: &[Vec<VertexId>],
    n: DVec3,
) -> Option<FaceId> {
    // Which member a contour edge came from (looked up only once a fault
    // is found).
    let of = |e: [VertexId; 2]| {
        halves
            .iter()
            .find(|h| h.from == e[0] && h.to == e[1])
            .map_or(0, |h| h.key.0 as usize)
    };
    // A contour after the first (the outer one) that runs the outer one's
    // way round encloses ground the faces cover twice, not a hole: rows of
    // running-bond tiles whose shared lines differ by 0.5 mm (seed 170770
    // again) traced a sliver 1.8 m long so. Its latest face goes.
    for c in &contours[1..] {
        let pts: Vec<DVec3> = c.iter().map(|&v| mesh.pos(v)).collect();
        if geom::newell_normal(&pts).dot(n) > 0.0 {
            let k = c.len();
            let latest = (0..k)
                .map(|i| of([c[i], c[(i + 1) % k]]))
                .max()
                .unwrap_or(0);
            return Some(members[latest]);
        }
    }
    let frame = geom::Frame::new(DVec3::ZERO, n);
    let mut edges: Vec<([VertexId; 2], geom::DVec2, geom::DVec2)> = Vec::new();
    for c in contours {
        let k = c.len();
        for i in 0..k {
            let (a, b) = (c[i], c[(i + 1) % k]);
            edges.push(([a, b], frame.to_2d(mesh.pos(a)), frame.to_2d(mesh.pos(b))));
        }
    }
    let index = geom::index::BoxIndex::new(
        edges
            .iter()
            .enumerate()
            .map(|(k, &(_, a, b))| (a.min(b).extend(0.0), a.max(b).extend(0.0), k as u32)),
    );
    let near = |lo: geom::DVec2, hi: geom::DVec2| -> Vec<usize> {
        index
            .query(lo.extend(0.0), hi.extend(0.0))
            .into_iter()
            .map(|k| k as usize)
            .collect()
    };
    geom::first_proper_crossing(&edges, &near)
        .map(|(i, j)| members[of(edges[i].0).max(of(edges[j].0))])
}

/// The half-edges of a group's boundary: those of all its faces' contours
/// less the seams inside the group, keyed (member, contour, index).
fn boundary_halves(
    mesh: &Mesh,
    members: &[FaceId],
    in_group: &dyn Fn(FaceId) -> bool,
) -> Vec<HalfEdge> {
    let mut halves: Vec<HalfEdge> = Vec::new();
    for (mi, &f) in members.iter().enumerate() {
        for (ci, c) in mesh.face(f).contours.iter().enumerate() {
            let es = mesh.contour_edges(f, ci);
            let k = c.len();
            for i in 0..k {
                let e = es[i];
                if partner(mesh, e, f).is_some_and(in_group) {
                    continue;
                }
                halves.push(HalfEdge {
                    from: c[i],
                    to: c[(i + 1) % k],
                    key: (mi as u32, ci as u32, i as u32),
                });
            }
        }
    }
    halves
}

/// The contours of the union of a group of faces from its boundary
/// half-edges ([`boundary_halves`]), paired at each vertex turning as far
/// left as possible (in the plane of normal `n`, so traced contours never
/// cross), followed into loops, split where a loop visits a vertex twice.
/// The loop with the largest area along `n` comes first; the others follow
/// in the order of their first half-edge. `None` when the boundary does not
/// close or nothing with area is left.
fn trace_group(mesh: &Mesh, halves: &[HalfEdge], n: DVec3) -> Option<Vec<Vec<VertexId>>> {
    let pos = |v: VertexId| mesh.pos(v);
    let loops = trace_loops(halves, &pos, n)?;
    outer_first(loops, &pos, n, false)
}

/// Drops, from every contour of face `f`, vertices that only `f` uses (two
/// edges, one use each, no wire) and that lie within `eps` of the segment
/// joining their kept neighbours, together with the others dropped between
/// the same two. A drop is refused when the new edge exists already or
/// would pass within `eps` of another vertex in use (which would make a
/// T-vertex). Returns the number of vertices dropped.
fn drop_collinear(
    mesh: &mut Mesh,
    f: FaceId,
    eps: f64,
    index: &Points,
    in_wire: &FxHashSet<VertexId>,
) -> usize {
    if !mesh.is_face_live(f) {
        return 0;
    }
    let only_here = |mesh: &Mesh, v: VertexId| {
        let es = mesh.vertex_edges(v);
        !in_wire.contains(&v)
            && es.len() == 2
            && es.iter().all(|&e| {
                let u = &mesh.edge(e).uses;
                u.len() == 1 && u[0].face == f
            })
    };
    let between = |w: DVec3, a: DVec3, c: DVec3| {
        let (d, _) = point_segment_distance(w, a, c);
        d <= eps && w.distance(a) > eps && w.distance(c) > eps
    };
    let mut dropped = 0;
    let mut contours = mesh.face(f).contours.clone();
    for c in &mut contours {
        let k = c.len();
        // Start at a corner that stays.
        let Some(s) = (0..k).find(|&i| {
            let (a, b, d) = (c[(i + k - 1) % k], c[i], c[(i + 1) % k]);
            !only_here(mesh, b) || !between(mesh.pos(b), mesh.pos(a), mesh.pos(d))
        }) else {
            continue;
        };
        c.rotate_left(s);
        let mut kept: Vec<VertexId> = vec![c[0]];
        let mut run: Vec<VertexId> = Vec::new();
        for i in 1..k {
            let (a, b, d) = (*kept.last().expect("not empty"), c[i], c[(i + 1) % k]);
            let (pa, pd) = (mesh.pos(a), mesh.pos(d));
            let ok = only_here(mesh, b)
                && run.len() < MAX_COLLINEAR_RUN
                && mesh.edge_between(a, d).is_none()
                && between(mesh.pos(b), pa, pd)
                && run.iter().all(|&w| between(mesh.pos(w), pa, pd))
                && {
                    !index.along(pa, pd, eps).iter().any(|&id| {
                        let u = VertexId(id);
                        u != a
                            && u != d
                            && u != b
                            && !run.contains(&u)
                            && !mesh.vertex_edges(u).is_empty()
                            && between(mesh.pos(u), pa, pd)
                    })
                };
            if ok {
                run.push(b);
            } else {
                kept.push(b);
                run.clear();
            }
        }
        if kept.len() >= 3 && kept.len() < k {
            dropped += k - kept.len();
            *c = kept;
        }
    }
    if dropped > 0 {
        mesh.set_face_contours(f, contours);
    }
    dropped
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::newell_normal;

    fn mesh(src: &str) -> Mesh {
        Mesh::from_model(ug::parse(src.as_bytes(), "t").unwrap().model)
    }

    fn text(mesh: &Mesh) -> String {
        ug::write_string(&mesh.to_model())
    }

    fn face_lines(mesh: &Mesh) -> Vec<String> {
        text(mesh)
            .lines()
            .filter(|l| l.starts_with("f "))
            .map(String::from)
            .collect()
    }

    fn run(src: &str, eps: f64) -> (String, Stats) {
        let m = ug::parse(src.as_bytes(), "t").unwrap().model;
        let (out, st) = vlmerge(m, &Options::new(eps)).unwrap();
        (ug::write_string(&out), st)
    }

    // ---- step 1 -------------------------------------------------------

    #[test]
    fn near_vertices_merge_into_the_first_in_statement_order() {
        let mut m = mesh(
            "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0;\
             v b2 1.0000001 0 0; v e 2 0 0; v f 2 1 0; v c2 1 1.00000005 0;\
             f l (a b c d); f r (b2 e f c2);",
        );
        let (merged, dropped) = merge_vertices(&mut m, 1e-6);
        m.validate().unwrap();
        assert_eq!(merged, 2);
        assert!(dropped.is_empty());
        assert_eq!(face_lines(&m), ["f l (a b c d);", "f r (b e f c);"]);
        assert!(!text(&m).contains("b2"), "merged vertices are removed");
    }

    #[test]
    fn merging_is_greedy_and_never_chains_beyond_epsilon() {
        // a–b within eps, b–c within eps, a–c not: b joins a, c stays.
        let mut m = mesh(
            "v a 0 0 0; v b 0.6 0 0; v c 1.2 0 0; v x 5 0 0; v y 5 5 0;\
             f t1 (a x y); f t2 (b x y); f t3 (c y x);",
        );
        let (merged, _) = merge_vertices(&mut m, 1.0);
        m.validate().unwrap();
        assert_eq!(merged, 1);
        let t = text(&m);
        assert!(t.contains("v c "), "{t}");
        assert!(!t.contains("v b "), "{t}");
    }

    #[test]
    fn faces_that_collapse_are_dropped_and_reported() {
        let mut m = mesh(
            "v a 0 0 0; v b 4 0 0; v c 4 3 0; v d 0 3 0;\
             v a2 0 1e-9 0; v b2 4 1e-9 0;\
             f wall (a b c d); f sliver (a b b2 a2); f tri (a b2 c);",
        );
        let (merged, dropped) = merge_vertices(&mut m, 1e-6);
        m.validate().unwrap();
        assert_eq!(merged, 2);
        assert_eq!(dropped.len(), 1);
        assert_eq!(m.face(dropped[0].0).name, Some("sliver".into()));
        assert!(dropped[0].1.contains("fewer than 3"), "{:?}", dropped);
        assert_eq!(face_lines(&m), ["f wall (a b c d);", "f tri (a b c);"]);
    }

    #[test]
    fn zero_area_faces_are_dropped_after_merging() {
        // Collinear but distinct vertices: no merge, still no area.
        let mut m = mesh(
            "v a 0 0 0; v b 4 0 0; v c 4 3 0; v m 2 0 0;\
             f t (a b c); f flat (a m b);",
        );
        let (_, dropped) = merge_vertices(&mut m, 1e-6);
        m.validate().unwrap();
        assert_eq!(dropped.len(), 1);
        assert!(dropped[0].1.contains("zero area"));
        assert_eq!(m.num_faces(), 1);
    }

    #[test]
    fn wires_follow_merged_vertices() {
        let mut m = mesh(
            "v a 0 0 0; v b 1 0 0; v c 0 1 0; v a2 1e-9 0 0;\
             f t (a b c); w wire (a2 b);",
        );
        merge_vertices(&mut m, 1e-6);
        m.validate().unwrap();
        let t = text(&m);
        assert!(t.contains("w wire (a b);"), "{t}");
        assert!(!t.contains("a2"), "{t}");
    }

    // ---- step 2 -------------------------------------------------------

    #[test]
    fn t_vertex_is_inserted_into_the_edge() {
        // Figure 3: the big face walks A–E; C lies on that edge.
        let mut m = mesh(
            "v a 0 0 0; v c 1 0 0; v e 2 0 0; v t 2 -1 0; v u 0 -1 0;\
             v p 0 1 0; v q 1 1 0; v r 2 1 0;\
             f big (u t e a); f l (a c q p); f r (c e r q);",
        );
        let s = split_edges(&mut m, 1e-6);
        m.validate().unwrap();
        assert_eq!((s.inserted, s.edges), (1, 1));
        assert_eq!(face_lines(&m)[0], "f big (u t e c a);");
        assert!(m.edge_between(VertexId(0), VertexId(2)).is_none());
    }

    /// A sliver 1.8 epsilon wide is a face to `ugcheck` (wider than
    /// epsilon), so a vertex on its edge is a T-vertex to insert, though
    /// its area is under epsilon times its size (dirty-building seed 8628
    /// with stairs: a wall's side under a ramp's corner 1.8 epsilon above
    /// the wall's bottom, whose piece had the corner's projection).
    #[test]
    fn a_vertex_on_a_sliver_wider_than_epsilon_is_inserted() {
        let mut m = mesh(
            "v a 0 0 0; v b 10 0 0; v top 5 0.018 0;\
             v m 5 0 0; v c 10 -1 0; v d 0 -1 0;\
             f sliver (a b top); f low (d c b m a);",
        );
        let s = split_edges(&mut m, 0.01);
        m.validate().unwrap();
        assert_eq!((s.inserted, s.edges), (1, 1), "{s:?}");
        assert_eq!(face_lines(&m)[0], "f sliver (a m b top);");
        // One epsilon wide, it is degenerate: nothing goes into it.
        let mut m = mesh(
            "v a 0 0 0; v b 10 0 0; v top 5 0.0099 0;\
             v m 5 0 0; v c 10 -1 0; v d 0 -1 0;\
             f sliver (a b top); f low (d c b m a);",
        );
        let s = split_edges(&mut m, 0.01);
        assert_eq!(s.inserted, 0, "{s:?}");
    }

    /// Two corners 1 epsilon either side of a short edge (2 epsilon long),
    /// each within epsilon of its interior, with the edge's ends within
    /// epsilon of the segment between them (property seed 2010, placed: a
    /// ramp's and a railing's pieces at a desk side's ledge; the points
    /// are theirs, in epsilons). Both in, the edge would zig-zag and the
    /// passes brought its ends back into it until they ran out, leaving
    /// spikes and a T-vertex; one goes in, and the other is then farther
    /// than epsilon from both new edges.
    #[test]
    fn corners_that_would_make_an_edge_zig_zag_go_in_one_at_most() {
        let e = 0.01;
        let p = |x: f64, y: f64, z: f64| format!("{} {} {}", x * e, y * e, z * e);
        let src = format!(
            "v p0 {}; v p1 {}; v p2 {}; v p3 {};\
             v q0 {}; v q3 {}; v r1 {}; v r2 {}; v s1 {}; v s2 {};\
             f side (p0 p3 q3 q0); f rail (p1 r1 r2); f ramp (p2 s2 s1);",
            p(0.0, 0.0, 0.0),
            p(1.0306, 0.5986, 0.1016),
            p(-0.8164, 1.4071, 0.0),
            p(0.2145, 2.0052, 0.1017),
            p(0.0, 0.0, -100.0),
            p(0.2145, 2.0052, -99.9),
            p(101.0, 0.6, 0.1),
            p(101.0, 0.6, 100.0),
            p(-100.8, 1.4, 0.0),
            p(-100.8, 1.4, 100.0),
        );
        let mut m = mesh(&src);
        let s = split_edges(&mut m, e);
        m.validate().unwrap();
        assert_eq!((s.inserted, s.edges), (1, 1), "{s:?}");
        let out = m.to_model();
        let mut used: Vec<VertexId> = Vec::new();
        for f in out.top_faces() {
            for c in &out.faces[f.idx()].contours {
                let mut seen = c.clone();
                seen.sort_unstable();
                seen.dedup();
                assert_eq!(seen.len(), c.len(), "{}", text(&m));
                used.extend(c);
            }
        }
        // No T-vertex is left.
        for f in out.top_faces() {
            for c in &out.faces[f.idx()].contours {
                for i in 0..c.len() {
                    let (a, b) = (c[i], c[(i + 1) % c.len()]);
                    for &v in &used {
                        if v != a && v != b {
                            let on = geom::on_edge_interior(out.pos(v), out.pos(a), out.pos(b), e);
                            assert!(on.is_none(), "{}", text(&m));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn several_t_vertices_along_one_edge_go_in_order_in_every_face() {
        let mut m = mesh(
            "v a 0 0 0; v b 10 0 0; v c 10 -1 0; v d 0 -1 0;\
             v p 0 1 0; v q 10 1 0;\
             v m7 7 0 0; v m2 2 0 0; v m5 5 0 0;\
             f low (d c b a); f up (a b q p);\
             f t1 (m2 m5 q); f t2 (m5 m7 q);",
        );
        let s = split_edges(&mut m, 1e-6);
        m.validate().unwrap();
        assert_eq!((s.inserted, s.edges), (3, 1), "{s:?}");
        let f = face_lines(&m);
        assert_eq!(f[0], "f low (d c b m7 m5 m2 a);");
        assert_eq!(f[1], "f up (a m2 m5 m7 b q p);");
    }

    #[test]
    fn vertices_of_degenerate_faces_are_not_t_vertices() {
        let mut m = mesh(
            "v a 0 0 0; v b 4 0 0; v c 4 3 0; v m 2 0 0; v n 3 0 0;\
             f t (a b c); f flat (m n a);",
        );
        let s = split_edges(&mut m, 1e-6);
        assert_eq!(s.inserted, 0);
    }

    #[test]
    fn splitting_a_clean_mesh_changes_nothing() {
        let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 2 0 0; v f 2 1 0;\
                   f l (a b c d); f r (b e f c);";
        let mut m = mesh(src);
        let before = text(&m);
        assert_eq!(split_edges(&mut m, 1e-6).inserted, 0);
        assert_eq!(text(&m), before);
    }

    // ---- step 3 -------------------------------------------------------

    /// A 6×3 wall in the x–z plane (front towards −y) around a 2×1 window
    /// at x 2..4, z 1..2, as 8 quads (outer CCW seen from −y).
    const WALL8: &str = "c_rgb w 0.8 0.8 0.8;\
        v p00 0 0 0; v p10 2 0 0; v p20 4 0 0; v p30 6 0 0;\
        v p01 0 0 1; v p11 2 0 1; v p21 4 0 1; v p31 6 0 1;\
        v p02 0 0 2; v p12 2 0 2; v p22 4 0 2; v p32 6 0 2;\
        v p03 0 0 3; v p13 2 0 3; v p23 4 0 3; v p33 6 0 3;\
        f w1 (p00 p10 p11 p01) w; f w2 (p10 p20 p21 p11) w; f w3 (p20 p30 p31 p21) w;\
        f w4 (p01 p11 p12 p02) w; f w6 (p21 p31 p32 p22) w;\
        f w7 (p02 p12 p13 p03) w; f w8 (p12 p22 p23 p13) w; f w9 (p22 p32 p33 p23) w;";

    #[test]
    fn wall_around_a_window_becomes_one_face_with_one_hole() {
        let mut m = mesh(WALL8);
        let j = merge_faces(&mut m, 1e-6, DEFAULT_ANGLE);
        m.validate().unwrap();
        assert_eq!((j.groups, j.joined, j.holes), (1, 7, 1));
        let f = m.faces().next().unwrap();
        assert_eq!(m.face(f).name.as_deref(), Some("w1"));
        let c = &m.face(f).contours;
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].len(), 4, "collinear boundary vertices dropped: {c:?}");
        assert_eq!(c[1].len(), 4);
        // Outer CCW and hole CW seen from the front (−y).
        let pts = m.face_points(f);
        let front = DVec3::new(0.0, -1.0, 0.0);
        assert!(newell_normal(&pts[0]).dot(front) > 0.0);
        assert!(newell_normal(&pts[1]).dot(front) < 0.0);
        assert!((m.face_area(f) - 16.0).abs() < 1e-12);
        assert_eq!(
            face_lines(&m),
            ["f w1 (p00 p30 p33 p03) (p21 p11 p12 p22) w;"]
        );
    }

    #[test]
    fn joining_is_deterministic_and_keeps_the_first_face() {
        // Same wall, statements in another order: the first statement names the result.
        let src = WALL8.replace("f w1 (p00 p10 p11 p01) w;", "") + "f w1 (p00 p10 p11 p01) w;";
        let mut m = mesh(&src);
        merge_faces(&mut m, 1e-6, DEFAULT_ANGLE);
        m.validate().unwrap();
        let lines = face_lines(&m);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].starts_with("f w2 "), "{lines:?}");
        let mut again = mesh(&src);
        merge_faces(&mut again, 1e-6, DEFAULT_ANGLE);
        assert_eq!(text(&again), text(&m));
    }

    #[test]
    fn different_materials_orientations_and_planes_stay_apart() {
        let base = "c_rgb a 1 0 0; c_rgb b 0 1 0;\
                    v p 0 0 0; v q 1 0 0; v r 1 1 0; v s 0 1 0; v t 2 0 0; v u 2 1 0;";
        // Different material.
        let mut m = mesh(&format!("{base} f x (p q r s) a; f y (q t u r) b;"));
        assert_eq!(merge_faces(&mut m, 1e-6, DEFAULT_ANGLE).joined, 0);
        // Facing the other way (the shared edge walked the same way).
        let mut m = mesh(&format!("{base} f x (p q r s) a; f y (q r u t) a;"));
        assert_eq!(merge_faces(&mut m, 1e-6, DEFAULT_ANGLE).joined, 0);
        // Folded by 2 degrees.
        let z = 1.0f64 * 2f64.to_radians().tan();
        let folded = format!(
            "c_rgb a 1 0 0; v p 0 0 0; v q 1 0 0; v r 1 1 0; v s 0 1 0; v t 2 0 {z}; v u 2 1 {z};\
             f x (p q r s) a; f y (q t u r) a;"
        );
        let mut m = mesh(&folded);
        assert_eq!(merge_faces(&mut m, 1e-6, DEFAULT_ANGLE).joined, 0);
        // …but joined with a looser angle and epsilon.
        let mut m = mesh(&folded);
        assert_eq!(merge_faces(&mut m, 0.1, 5.0).joined, 1);
        m.validate().unwrap();
        // Same material and plane: joined, keeping the collinear vertices
        // that are corners (here none is left between collinear edges).
        let mut m = mesh(&format!("{base} f x (p q r s) a; f y (q t u r) a;"));
        assert_eq!(merge_faces(&mut m, 1e-6, DEFAULT_ANGLE).joined, 1);
        m.validate().unwrap();
        assert_eq!(face_lines(&m), ["f x (p t u s) a;"]);
    }

    #[test]
    fn non_manifold_edges_are_not_joined_across() {
        // Walls x and y are coplanar and meet at the edge q–r, which a third
        // wall z also uses (a T in plan).
        let mut m = mesh(
            "v p 0 0 0; v q 1 0 0; v t 2 0 0; v p1 0 0 1; v q1 1 0 1; v t1 2 0 1;\
             v z0 1 1 0; v z1 1 1 1;\
             f x (p q q1 p1); f y (q t t1 q1); f z (q z0 z1 q1);",
        );
        assert_eq!(merge_faces(&mut m, 1e-6, DEFAULT_ANGLE).joined, 0);
        m.validate().unwrap();
        assert_eq!(m.num_faces(), 3);
    }

    #[test]
    fn boundary_vertices_used_elsewhere_stay() {
        // Two floor quads joined; the middle vertices carry a wall: kept.
        let mut m = mesh(
            "v a 0 0 0; v b 1 0 0; v c 2 0 0; v d 2 1 0; v e 1 1 0; v f 0 1 0;\
             v b1 1 0 1; v e1 1 1 1; v g 1 -1 0; v g1 1 -1 1;\
             f l (a b e f); f r (b c d e); f wall (g b b1 g1);",
        );
        let j = merge_faces(&mut m, 1e-6, DEFAULT_ANGLE);
        m.validate().unwrap();
        assert_eq!((j.joined, j.collinear), (1, 1));
        assert_eq!(face_lines(&m)[0], "f l (a b c d f);");
    }

    /// Faces that overlap where they do not share a seam stay out of the
    /// group (`overlapping_member`): three running-bond tiles rounded to
    /// millimetres (property seed 170770), the upper left one's bottom edge
    /// running 0.5 mm under the lower one's top corner, whose joined
    /// contour crossed itself; and a face whose bottom dips 1 cm into the
    /// face it meets at two points, joined through a third, whose traced
    /// contours held a loop running the outer one's way round.
    #[test]
    fn faces_overlapping_off_their_seams_are_not_joined() {
        let tiles = "c_rgb tile 0.7 0.7 0.6;\
             v a0 5.424 2.345 0; v a1 6.624 2.441 0; v a2 6.624 3.041 0; v a3 5.424 2.945 0;\
             v b0 4.824 2.896 0; v b1 6.024 2.993 0; v b2 6.024 3.335 0; v b3 4.824 3.239 0;\
             v c1 7.224 3.089 0; v c2 7.224 3.431 0;\
             f t14 (a0 a1 a2 a3) tile; f t17 (b0 b1 b2 b3) tile; f t18 (b1 c1 c2 b2) tile;";
        let (out, st) = run(tiles, 9.4e-6);
        assert_eq!((st.groups, st.faces_joined), (1, 1), "{out}");
        assert!(out.contains("f t17 (b0 b1 b2 b3) tile;"), "{out}");
        let m = ug::parse(out.as_bytes(), "t").unwrap().model;
        let r = check::check(&m, 9.4e-6);
        assert_eq!(r.count("degenerate"), 0, "{out}");
        let dip = "v a0 0 0 0; v a1 2 0 0; v a2 2 1 0; v q 1.5 1 0; v p 0.5 1 0; v a3 0 1 0;\
             v b1 4 0 0; v b2 4 1 0; v m 3 1 0; v r 1 0.99 0; v c2 3 2 0; v c3 0.5 2 0;\
             f a (a0 a1 a2 q p a3); f b (a1 b1 b2 m a2); f c (p r q a2 m c2 c3);";
        let (out, st) = run(dip, 1e-6);
        assert_eq!((st.groups, st.faces_joined), (1, 1), "{out}");
        assert!(out.contains("f c (p r q a2 m c2 c3);"), "{out}");
    }

    #[test]
    fn floor_of_quads_merges_and_the_rug_stays() {
        let mut src = String::from("c_rgb floor 0.5 0.5 0.5; c_rgb rug 0.8 0.1 0.1;");
        for i in 0..=3 {
            for j in 0..=3 {
                src += &format!("v g{i}{j} {i} {j} 0;");
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                src += &format!(
                    "f q{i}{j} (g{i}{j} g{}{j} g{}{} g{i}{}) floor;",
                    i + 1,
                    i + 1,
                    j + 1,
                    j + 1
                );
            }
        }
        src += "v r0 1.2 1.2 0.001; v r1 1.8 1.2 0.001; v r2 1.8 1.8 0.001; v r3 1.2 1.8 0.001;\
                f rug (r0 r1 r2 r3) rug;";
        let mut m = mesh(&src);
        let j = merge_faces(&mut m, 1e-6, DEFAULT_ANGLE);
        m.validate().unwrap();
        assert_eq!((j.groups, j.joined, j.holes), (1, 8, 0));
        assert_eq!(
            face_lines(&m),
            ["f q00 (g00 g30 g33 g03) floor;", "f rug (r0 r1 r2 r3) rug;"]
        );
    }

    #[test]
    fn vertices_other_faces_use_are_not_swallowed() {
        // A 3×3 floor; a triangle stands on it touching only the inner grid
        // vertex g11. The four quads around g11 join nothing (joined, g11
        // would lie inside the floor: the triangle would intersect it); the
        // other five join into one face.
        let mut src = String::new();
        for i in 0..=3 {
            for j in 0..=3 {
                src += &format!("v g{i}{j} {i} {j} 0;");
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                src += &format!(
                    "f q{i}{j} (g{i}{j} g{}{j} g{}{} g{i}{});",
                    i + 1,
                    i + 1,
                    j + 1,
                    j + 1
                );
            }
        }
        src += "v t0 0.5 1 1; v t1 1.5 1 1; f tri (g11 t1 t0);";
        let mut m = mesh(&src);
        let j = merge_faces(&mut m, 1e-6, DEFAULT_ANGLE);
        m.validate().unwrap();
        assert_eq!((j.groups, j.joined), (1, 4));
        let names: Vec<String> = m.faces().map(|f| m.face(f).name.clone().unwrap()).collect();
        assert_eq!(names, ["q00", "q01", "q02", "q10", "q11", "tri"]);
        let g11 = VertexId(5);
        assert!(m.vertex_faces(g11).len() == 5);
        // A second pass changes nothing.
        let before = text(&m);
        assert_eq!(merge_faces(&mut m, 1e-6, DEFAULT_ANGLE), Join::default());
        assert_eq!(text(&m), before);
        // Without the triangle all nine join.
        let mut m = mesh(&src.replace("f tri (g11 t1 t0);", ""));
        assert_eq!(merge_faces(&mut m, 1e-6, DEFAULT_ANGLE).joined, 8);
    }

    #[test]
    fn trace_splits_pinched_boundaries() {
        // A 3×3 block of squares without the centre and the (2, 2) corner:
        // the hole touches the notch at one vertex, which the union's
        // boundary visits twice; the traced contours keep it once each.
        let mut src = String::new();
        for i in 0..=3 {
            for j in 0..=3 {
                src += &format!("v g{i}{j} {i} {j} 0;");
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                if (i, j) != (1, 1) && (i, j) != (2, 2) {
                    src += &format!(
                        "f q{i}{j} (g{i}{j} g{}{j} g{}{} g{i}{});",
                        i + 1,
                        i + 1,
                        j + 1,
                        j + 1
                    );
                }
            }
        }
        let mut m = mesh(&src);
        let j = merge_faces(&mut m, 1e-6, DEFAULT_ANGLE);
        m.validate().unwrap();
        assert_eq!((j.groups, j.joined, j.holes), (1, 6, 1));
        let f = m.faces().next().unwrap();
        assert!((m.face_area(f) - 7.0).abs() < 1e-12);
        let c = &m.face(f).contours;
        assert_eq!(c[1].len(), 4, "the hole: {c:?}");
        let g22 = VertexId(10);
        assert!(
            c.iter()
                .all(|c| c.iter().filter(|&&v| v == g22).count() == 1)
        );
    }

    // ---- all together -------------------------------------------------

    #[test]
    fn wall_of_four_quads_with_defects_becomes_one_face_with_one_hole() {
        // Left and right strips, a lintel and a sill; the strips' inner edges
        // carry the window corners as T-vertices; the lintel's vertices are
        // duplicated with tiny offsets.
        let src = "c_rgb w 0.8 0.8 0.8;\
            v a 0 0 0; v b 2 0 0; v c 2 0 3; v d 0 0 3;\
            v e 4 0 0; v f 6 0 0; v g 6 0 3; v h 4 0 3;\
            v s0 2 0 1; v s1 4 0 1; v t0 2.0000000001 0 2; v t1 4 0 2.0000000001;\
            v c2 2 0 3.0000000001; v h2 3.9999999999 0 3;\
            f left (a b c d) w; f right (e f g h) w;\
            f sill (b e s1 s0) w; f lintel (t0 t1 h2 c2) w;";
        let (out, st) = run(src, 1e-6);
        assert_eq!(st.vertices_merged, 2);
        assert_eq!(st.tvertices, 4);
        assert_eq!((st.groups, st.faces_joined, st.holes), (1, 3, 1));
        let faces: Vec<&str> = out.lines().filter(|l| l.starts_with("f ")).collect();
        assert_eq!(faces, ["f left (a f g d) (s0 t0 t1 s1) w;"], "{out}");
        let m = Mesh::from_model(ug::parse(out.as_bytes(), "o").unwrap().model);
        m.validate().unwrap();
        let f = m.faces().next().unwrap();
        assert!((m.face_area(f) - 16.0).abs() < 1e-8);
        // A second pass changes nothing.
        assert_eq!(run(&out, 1e-6).0, out);
    }

    #[test]
    fn steps_can_be_disabled() {
        let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 1 0; v e 2 0 0; v f 2 1 0;\
                   v b2 1 1e-9 0; f l (a b c d); f r (b2 e f c);";
        let m = ug::parse(src.as_bytes(), "t").unwrap().model;
        let opts = Options {
            merge_vertices: false,
            split_edges: false,
            merge_faces: false,
            ..Options::new(1e-6)
        };
        let (out, st) = vlmerge(m.clone(), &opts).unwrap();
        assert_eq!(out, m);
        assert_eq!(st.faces_out, 2);
        let opts = Options {
            merge_faces: false,
            ..Options::new(1e-6)
        };
        let (out, st) = vlmerge(m.clone(), &opts).unwrap();
        assert_eq!((st.vertices_merged, st.faces_out), (1, 2));
        assert_eq!(out.vertices.len(), 6);
        let (out, st) = vlmerge(m, &Options::new(1e-6)).unwrap();
        assert_eq!((st.faces_joined, st.faces_out), (1, 1));
        assert_eq!(
            ug::write_string(&out).lines().last(),
            Some("f l (a e f d);")
        );
    }

    #[test]
    fn dropped_faces_are_named_like_ugcheck_names_them() {
        let src = "v a 0 0 0; v b 1 0 0; v c 1 1 0; v a2 0 1e-9 0;\
                   f (a b c); f (a b a2); f named (a a2 b);";
        let (_, st) = run(src, 1e-6);
        let names: Vec<&str> = st.dropped.iter().map(|d| d.face.as_str()).collect();
        assert_eq!(names, ["#2", "named"]);
    }
}
