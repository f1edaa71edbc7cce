//! Faces cut into pieces in their own plane, assembled back into the mesh:
//! what `ugisect`, `ugcopl` and `ugcut` share.
//!
//! A face's contours (and whatever else divides it: cuts, a coplanar
//! neighbour's contours) go into a snap-rounded planar arrangement
//! ([`geom::arrange`]) in the face's frame; its faces become the pieces.
//! Points of the arrangement map back to vertices: the face's own vertices,
//! vertices given with the extra segments, and new points (crossings) made
//! into vertices through a [`Snapper`], which reuses any vertex of the mesh
//! within epsilon, so that the same crossing found in two faces is one
//! vertex.

use geom::arrange::{Arrangement, Options, Segment, Tag, arrange};
use geom::{DVec2, DVec3, Frame};
use rustc_hash::FxHashMap;
use ug::{Face, FaceId, VertexId};

use crate::Mesh;

/// The vertices of a mesh on a grid, for "the vertex within epsilon".
pub struct Snapper {
    eps: f64,
    cell: f64,
    grid: FxHashMap<(i64, i64, i64), Vec<VertexId>>,
    /// Vertices created.
    pub created: usize,
}

impl Snapper {
    /// Every live vertex of the mesh.
    pub fn new(mesh: &Mesh, eps: f64) -> Snapper {
        Snapper::new_in(mesh, eps, None)
    }

    /// Every live vertex of `region` (all with `None`).
    pub fn new_in(mesh: &Mesh, eps: f64, region: Option<&crate::weld::Region>) -> Snapper {
        let mut s = Snapper {
            eps,
            cell: (2.0 * eps).max(f64::MIN_POSITIVE),
            grid: FxHashMap::default(),
            created: 0,
        };
        for v in mesh.vertices() {
            if crate::weld::vertex_in(region, v) {
                s.insert(v, mesh.pos(v));
            }
        }
        s
    }

    fn key(&self, p: DVec3) -> (i64, i64, i64) {
        let k = (p / self.cell).floor();
        (k.x as i64, k.y as i64, k.z as i64)
    }

    fn insert(&mut self, v: VertexId, p: DVec3) {
        let k = self.key(p);
        self.grid.entry(k).or_default().push(v);
    }

    /// The nearest live vertex within epsilon (the lowest id on ties).
    pub fn find(&self, mesh: &Mesh, p: DVec3) -> Option<VertexId> {
        let (x, y, z) = self.key(p);
        let mut best: Option<(f64, VertexId)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &v in self
                        .grid
                        .get(&(x + dx, y + dy, z + dz))
                        .into_iter()
                        .flatten()
                    {
                        if !mesh.is_vertex_live(v) {
                            continue;
                        }
                        let d = mesh.pos(v).distance(p);
                        if d <= self.eps && best.is_none_or(|(b, w)| d < b || (d == b && v < w)) {
                            best = Some((d, v));
                        }
                    }
                }
            }
        }
        best.map(|b| b.1)
    }

    /// The vertex within epsilon of `p`, or a new one named after `name`.
    pub fn vertex(&mut self, mesh: &mut Mesh, p: DVec3, name: &str) -> VertexId {
        if let Some(v) = self.find(mesh, p) {
            return v;
        }
        let v = mesh.add_vertex(Some(name), p);
        self.insert(v, p);
        self.created += 1;
        v
    }
}

/// A point of a piece: a vertex given to the layout, or a new point
/// (a crossing, a cut's extension) at this position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Point {
    Vertex(VertexId),
    New(DVec3),
}

/// A face laid out for an arrangement: its frame, the vertices given to it
/// as points, and segments between them.
#[derive(Clone, Debug)]
pub struct Layout {
    pub frame: Frame,
    /// The vertex of each input point (`None` for a point that is no
    /// vertex: a neighbour's contour clipped to a box, a projected outline).
    pub ids: Vec<Option<VertexId>>,
    pub points: Vec<DVec2>,
    pub segments: Vec<Segment>,
    index: FxHashMap<VertexId, u32>,
}

impl Layout {
    /// An empty layout in `frame`.
    pub fn new(frame: Frame) -> Layout {
        Layout {
            frame,
            ids: Vec::new(),
            points: Vec::new(),
            segments: Vec::new(),
            index: FxHashMap::default(),
        }
    }

    /// The frame of a face's outer contour (Newell normal through its first
    /// vertex), `None` for a face without a normal.
    pub fn frame_of(pts: &[Vec<DVec3>]) -> Option<Frame> {
        let n = geom::face_normal(pts)?;
        Some(Frame::new(pts[0][0], n))
    }

    /// A face of the mesh, its contour edges as `Toggle(0)` segments.
    pub fn of_face(mesh: &Mesh, f: FaceId) -> Option<Layout> {
        let frame = Layout::frame_of(&mesh.face_points(f))?;
        let mut l = Layout::new(frame);
        l.contours(&mesh.face(f).contours, Tag::Toggle(0), |v| mesh.pos(v));
        Some(l)
    }

    /// Adds closed contours as segments with `tag`.
    pub fn contours(
        &mut self,
        contours: &[Vec<VertexId>],
        tag: Tag,
        pos: impl Fn(VertexId) -> DVec3,
    ) {
        for c in contours {
            let n = c.len();
            for i in 0..n {
                let (a, b) = (c[i], c[(i + 1) % n]);
                self.segment(a, pos(a), b, pos(b), tag);
            }
        }
    }

    /// Adds a closed ring of points, each a vertex or not: a neighbour's
    /// contour clipped to a box around the face ([`clip_ring`]); its points
    /// on the box lie away from the face and never become corners of its
    /// pieces.
    pub fn ring(&mut self, pts: &[(DVec2, Option<VertexId>)], tag: Tag) {
        if pts.len() < 3 {
            return;
        }
        let ks: Vec<u32> = pts
            .iter()
            .map(|&(p, v)| match v {
                Some(v) => {
                    if let Some(&k) = self.index.get(&v) {
                        return k;
                    }
                    let k = self.ids.len() as u32;
                    self.ids.push(Some(v));
                    self.points.push(p);
                    self.index.insert(v, k);
                    k
                }
                None => {
                    let k = self.ids.len() as u32;
                    self.ids.push(None);
                    self.points.push(p);
                    k
                }
            })
            .collect();
        for i in 0..ks.len() {
            let (a, b) = (ks[i], ks[(i + 1) % ks.len()]);
            if a != b {
                self.segments.push(Segment { a, b, tag });
            }
        }
    }

    /// The input point of vertex `v` at `p` (added on first use).
    pub fn point(&mut self, v: VertexId, p: DVec3) -> u32 {
        if let Some(&k) = self.index.get(&v) {
            return k;
        }
        let k = self.ids.len() as u32;
        self.ids.push(Some(v));
        self.points.push(self.frame.to_2d(p));
        self.index.insert(v, k);
        k
    }

    /// Adds the segment between two vertices with `tag`.
    pub fn segment(&mut self, a: VertexId, pa: DVec3, b: VertexId, pb: DVec3, tag: Tag) {
        let (a, b) = (self.point(a, pa), self.point(b, pb));
        if a != b {
            self.segments.push(Segment { a, b, tag });
        }
    }

    /// The arrangement of everything added, snapped at `eps`.
    pub fn arrange(&self, eps: f64, extend_cuts: bool) -> Arrangement {
        let mut o = Options::new(eps);
        o.extend_cuts = extend_cuts;
        arrange(&self.points, &self.segments, &o)
    }

    /// The loops of an arrangement face as points: input points are their
    /// vertices (merged ones their representative's), the others (and input
    /// points given without a vertex) new points in 3-D (on the frame's
    /// plane).
    pub fn loops(&self, arr: &Arrangement, face: &geom::arrange::Face) -> Vec<Vec<Point>> {
        face.loops
            .iter()
            .map(|l| {
                l.iter()
                    .map(|&k| {
                        let id = (k as usize) < arr.inputs;
                        match id.then(|| self.ids[arr.rep[k as usize] as usize]).flatten() {
                            Some(v) => Point::Vertex(v),
                            None => Point::New(self.frame.to_3d(arr.points[k as usize])),
                        }
                    })
                    .collect()
            })
            .collect()
    }
}

/// A closed ring clipped to the box [lo, hi] (Sutherland–Hodgman): points
/// inside keep their vertex, points made on the box have none. Empty when
/// the ring misses the box.
pub fn clip_ring(
    ring: &[(DVec2, Option<VertexId>)],
    lo: DVec2,
    hi: DVec2,
) -> Vec<(DVec2, Option<VertexId>)> {
    geom::overlap::clip_ring_to_box(ring, lo, hi, None)
}

/// Loops of points as contours of vertices: `vertex` makes (or finds) the
/// vertex of a new point. Consecutive repeats (two points that became one
/// vertex) are dropped; loops left with fewer than three vertices go.
pub fn to_contours(
    loops: &[Vec<Point>],
    mut vertex: impl FnMut(DVec3) -> VertexId,
) -> Vec<Vec<VertexId>> {
    let mut out = Vec::new();
    for l in loops {
        let mut c: Vec<VertexId> = Vec::with_capacity(l.len());
        for p in l {
            let v = match *p {
                Point::Vertex(v) => v,
                Point::New(q) => vertex(q),
            };
            if c.last() != Some(&v) {
                c.push(v);
            }
        }
        while c.len() > 1 && c.first() == c.last() {
            c.pop();
        }
        if c.len() >= 3 {
            out.push(c);
        }
    }
    out
}

/// Whether two contour lists describe the same face: the same loops, each up
/// to rotation, in any order.
pub fn same_contours(a: &[Vec<VertexId>], b: &[Vec<VertexId>]) -> bool {
    fn canon(c: &[VertexId]) -> Vec<VertexId> {
        let k = (0..c.len()).min_by_key(|&i| c[i]).unwrap_or(0);
        c[k..].iter().chain(&c[..k]).copied().collect()
    }
    if a.len() != b.len() {
        return false;
    }
    let mut x: Vec<Vec<VertexId>> = a.iter().map(|c| canon(c)).collect();
    let mut y: Vec<Vec<VertexId>> = b.iter().map(|c| canon(c)).collect();
    x.sort();
    y.sort();
    x == y
}

/// What [`repair`] did to a face.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Repair {
    /// Its contours were sound already.
    Sound,
    /// Replaced by these faces (the first keeps the face's id).
    Pieces(Vec<FaceId>),
    /// Nothing with area was left; the face was removed.
    Removed,
}

/// Makes a face's contours sound: snap-rounded at `eps` in its plane,
/// crossings become vertices, the even-odd region is kept and split into
/// its connected pieces (a contour that crosses itself, touches itself, a
/// spike, collinear runs one ulp off the line, a hole touching the outer
/// contour, contours meeting at a point). The first piece keeps the face
/// (its name, id and place), the others follow it named `NAME.rK`.
pub fn repair(
    mesh: &mut Mesh,
    f: FaceId,
    eps: f64,
    snap: &mut Snapper,
    name: &str,
    frame: impl Fn(&[Vec<DVec3>]) -> Option<Frame>,
) -> Repair {
    let Some(frame) = frame(&mesh.face_points(f)) else {
        mesh.remove_face(f);
        return Repair::Removed;
    };
    let mut layout = Layout::new(frame);
    layout.contours(&mesh.face(f).contours, Tag::Toggle(0), |v| mesh.pos(v));
    let arr = layout.arrange(eps, false);
    let inside: Vec<Vec<Vec<Point>>> = arr
        .faces
        .iter()
        .filter(|a| a.has(0))
        .map(|a| layout.loops(&arr, a))
        .collect();
    let mut k = 0;
    let mut pieces: Vec<Vec<Vec<VertexId>>> = Vec::new();
    for l in &inside {
        let c = to_contours(l, |p| {
            k += 1;
            snap.vertex(mesh, p, &format!("{name}.x{k}"))
        });
        if !c.is_empty() {
            pieces.push(c);
        }
    }
    if pieces.len() == 1 && same_contours(&pieces[0], &mesh.face(f).contours) {
        return Repair::Sound;
    }
    replace(mesh, f, pieces, name, "r")
}

/// Replaces face `f` by `pieces` (contour lists), keeping its material; the
/// first piece keeps the face's id, name and place, the others follow it
/// named `NAME.TAGk` (unnamed faces give unnamed pieces).
pub fn replace(
    mesh: &mut Mesh,
    f: FaceId,
    pieces: Vec<Vec<Vec<VertexId>>>,
    name: &str,
    tag: &str,
) -> Repair {
    if pieces.is_empty() {
        mesh.remove_face(f);
        return Repair::Removed;
    }
    let face = mesh.face(f).clone();
    let mut it = pieces.into_iter();
    let first = it.next().expect("one piece");
    let mut ids = Vec::new();
    if mesh.set_face_contours(f, first) {
        ids.push(f);
    }
    let _ = name;
    let mut last = f;
    for (k, c) in (2..).zip(it) {
        let pname = face.name.as_ref().map(|n| format!("{n}.{tag}{k}"));
        let g = mesh.add_face(
            Some(last),
            Face {
                name: pname,
                contours: c,
                material: face.material,
            },
        );
        if mesh.is_face_live(g) {
            ids.push(g);
            last = g;
        }
    }
    if ids.is_empty() {
        Repair::Removed
    } else {
        Repair::Pieces(ids)
    }
}

/// An edge (lower vertex id first) that a face's contours walk twice, in
/// either direction: a hole lying along the outer contour, or two holes
/// along each other. The face's boundary touches itself there.
pub fn edge_walked_twice(contours: &[Vec<VertexId>]) -> Option<(VertexId, VertexId)> {
    let mut pairs: Vec<(VertexId, VertexId)> = contours
        .iter()
        .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    pairs.sort_unstable();
    pairs.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
}

/// Whether a face's contours are sound in `frame`: no vertex visited twice,
/// no edge walked twice, no edge crossing another, no vertex within `eps`
/// of an edge it is not an end of. Cheap for the small faces that are most
/// of a model; faces with many vertices use an index of their edges.
pub fn sound(mesh: &Mesh, f: FaceId, frame: &Frame, eps: f64) -> bool {
    use geom::{SegmentContact, segments_2d};
    let face = mesh.face(f);
    let mut ids: Vec<VertexId> = face.contours.iter().flatten().copied().collect();
    let n = ids.len();
    ids.sort_unstable();
    ids.dedup();
    // A vertex shared by two contours (a hole hung on the outer contour) is
    // fine; one contour visiting a vertex twice is not.
    for c in &face.contours {
        let mut s = c.clone();
        s.sort_unstable();
        if s.windows(2).any(|w| w[0] == w[1]) || c.len() < 3 {
            return false;
        }
    }
    let mut edges: Vec<(VertexId, VertexId, DVec2, DVec2)> = Vec::with_capacity(n);
    for c in &face.contours {
        for i in 0..c.len() {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            edges.push((a, b, frame.to_2d(mesh.pos(a)), frame.to_2d(mesh.pos(b))));
        }
    }
    // An edge walked twice (a hole lying along the outer contour, which
    // ugclean's sharing of a coincident pair's records can make: the
    // mesher covered part of the hole) is not sound either: the repair's
    // arrangement drops it and joins the two contours.
    if edge_walked_twice(&face.contours).is_some() {
        return false;
    }
    let index = (edges.len() > 24).then(|| {
        geom::BoxIndex::new(edges.iter().enumerate().map(|(k, e)| {
            (
                (e.2.min(e.3) - DVec2::splat(eps)).extend(0.0),
                (e.2.max(e.3) + DVec2::splat(eps)).extend(0.0),
                k as u32,
            )
        }))
    });
    let near = |lo: DVec2, hi: DVec2| -> Vec<usize> {
        match &index {
            Some(ix) => ix
                .query(lo.extend(0.0), hi.extend(0.0))
                .into_iter()
                .map(|k| k as usize)
                .collect(),
            None => (0..edges.len()).collect(),
        }
    };
    // Lengths and distances in space, as the weld and the T-vertex step
    // measure them: a pair the weld kept apart (over epsilon) is not made
    // one here because the plane's frame brings it a hair closer (two cut
    // points 1.004 epsilon apart, 0.9997 in the plane, made T-vertices of
    // each other again by the repair).
    for (i, e) in edges.iter().enumerate() {
        if mesh.pos(e.0).distance(mesh.pos(e.1)) <= eps {
            return false;
        }
        for j in near(e.2.min(e.3), e.2.max(e.3)) {
            if j <= i {
                continue;
            }
            let g = &edges[j];
            if e.0 == g.0 || e.0 == g.1 || e.1 == g.0 || e.1 == g.1 {
                continue;
            }
            if segments_2d(e.2, e.3, g.2, g.3) != SegmentContact::None {
                return false;
            }
        }
    }
    for &v in &ids {
        let p = frame.to_2d(mesh.pos(v));
        for k in near(p - DVec2::splat(eps), p + DVec2::splat(eps)) {
            let e = &edges[k];
            if e.0 == v || e.1 == v {
                continue;
            }
            // (The frame's distance is at most the distance in space: the
            // box query above finds every edge within epsilon in space.)
            let (d, _) = geom::point_segment_distance(mesh.pos(v), mesh.pos(e.0), mesh.pos(e.1));
            if d <= eps {
                return false;
            }
        }
    }
    true
}

/// What [`settle`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Settled {
    /// Vertices welded into an earlier one within epsilon.
    pub welded: usize,
    /// Vertices inserted into edges (T-vertices removed).
    pub tvertices: usize,
    /// Faces whose contours were repaired (split, snapped), by id before repair.
    pub repaired: Vec<FaceId>,
    /// Faces dropped: nothing with area was left.
    pub removed: Vec<FaceId>,
    /// New vertices the repairs made (crossings).
    pub created: usize,
}

/// Brings a mesh to the state every cleaning tool leaves it in: vertices
/// within `eps` welded, T-vertices inserted, and every face sound in its
/// plane ([`sound`]; a face that is not is [`repair`]ed in the frame `frame`
/// gives it). Repairs can make vertices (crossings) that lie on other faces'
/// edges, so T-vertices are inserted again and the faces that changed are
/// checked again, until nothing changes (a few rounds at most). Faces are
/// processed in id order: the result is deterministic.
pub fn settle(
    mesh: &mut Mesh,
    eps: f64,
    frame: &dyn Fn(&[Vec<DVec3>]) -> Option<Frame>,
    skip_repair: &dyn Fn(FaceId) -> bool,
) -> Settled {
    let mut st = Settled::default();
    let (welded, dropped) = crate::weld::merge_vertices(mesh, eps);
    st.welded = welded;
    st.removed.extend(dropped.into_iter().map(|(f, _)| f));
    st.tvertices += crate::weld::split_edges(mesh, eps).inserted;
    repair_all(mesh, eps, frame, skip_repair, &mut st);
    st
}

/// The repair part of [`settle`], on a mesh already welded and without
/// T-vertices.
pub fn repair_all(
    mesh: &mut Mesh,
    eps: f64,
    frame: &dyn Fn(&[Vec<DVec3>]) -> Option<Frame>,
    skip_repair: &dyn Fn(FaceId) -> bool,
    st: &mut Settled,
) {
    repair_all_in(mesh, eps, frame, skip_repair, st, None)
}

/// [`repair_all`] on the faces of `region`, snapping to its vertices (see
/// [`crate::weld::Region`]).
pub fn repair_all_in(
    mesh: &mut Mesh,
    eps: f64,
    frame: &dyn Fn(&[Vec<DVec3>]) -> Option<Frame>,
    skip_repair: &dyn Fn(FaceId) -> bool,
    st: &mut Settled,
    region: Option<&crate::weld::Region>,
) {
    let mut snap = Snapper::new_in(mesh, eps, region);
    let mut dirty: Vec<FaceId> = mesh
        .faces()
        .filter(|&f| crate::weld::face_in(region, f))
        .collect();
    for _ in 0..4 {
        let created = snap.created;
        for &f in &dirty {
            if !mesh.is_face_live(f) || skip_repair(f) {
                continue;
            }
            let mut work = vec![(f, 0usize)];
            while let Some((g, round)) = work.pop() {
                let Some(fr) = frame(&mesh.face_points(g)) else {
                    mesh.remove_face(g);
                    st.removed.push(g);
                    continue;
                };
                if sound(mesh, g, &fr, eps) {
                    continue;
                }
                let name = mesh
                    .face(g)
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("f{}", g.0 + 1));
                match repair(mesh, g, eps, &mut snap, &name, |p| frame(p)) {
                    Repair::Sound => {}
                    Repair::Pieces(v) => {
                        if round == 0 {
                            st.repaired.push(g);
                        }
                        if round < 3 {
                            work.extend(v.into_iter().rev().map(|h| (h, round + 1)));
                        }
                    }
                    Repair::Removed => st.removed.push(g),
                }
            }
        }
        if snap.created == created {
            break;
        }
        let before: FxHashMap<FaceId, usize> = mesh
            .faces()
            .map(|f| (f, mesh.face(f).contours.iter().map(Vec::len).sum()))
            .collect();
        st.tvertices += crate::weld::split_edges_in(mesh, eps, region).inserted;
        dirty = mesh
            .faces()
            .filter(|f| {
                before.get(f).copied() != Some(mesh.face(*f).contours.iter().map(Vec::len).sum())
            })
            .collect();
        if dirty.is_empty() {
            break;
        }
    }
    st.created += snap.created;
    st.repaired.sort_unstable();
    st.repaired.dedup();
}
