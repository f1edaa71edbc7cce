//! Cutting faces into pieces in their planes and writing the model back
//! (shared by `ugisect` and `ugcopl`).
//!
//! Each face to cut is laid out in its plane with what divides it (cut
//! segments, or the contours of coplanar faces) and put through the
//! snap-rounded arrangement of `geom::arrange` (in parallel: it depends only
//! on positions). Its pieces come back as loops of points; [`Rebuild`] then
//! writes the model in statement order, making new points into vertices
//! (reusing any vertex within epsilon, so a crossing found in two faces is
//! one vertex) just before the first piece that uses them.

use geom::{DVec3, Plane};
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Face, FaceId, Item, Model, Vertex, VertexId};
use winged::pieces::{Point, to_contours};

pub use check::face_geoms;

/// How far (in epsilons) an end of a cut segment reuses a vertex that lies
/// on both faces' planes: one crossing found by two pairs (a pipe's facet
/// through a pier and through the lintel beside it, at 11°) comes out a
/// little more than epsilon apart where the planes meet at a shallow
/// angle, and the two vertices, 1.05 epsilon apart, left the facet's
/// corner 1.05 epsilon inside the wall (property seed 8627). A segment's
/// two ends never become one vertex so (a floor's cut across a column
/// face's tip 2 epsilon wide stays a cut).
const SNAP_EPSILONS: f64 = 2.0;

/// The output model under construction.
pub struct Rebuild {
    pub out: Model,
    eps: f64,
    cell: f64,
    grid: FxHashMap<(i64, i64, i64), Vec<VertexId>>,
    fnames: FxHashSet<String>,
    vnames: FxHashSet<String>,
    emitted: usize,
    /// Vertices created so far.
    pub new_vertices: usize,
    /// The id of the first vertex created here.
    first_new: usize,
}

impl Rebuild {
    /// Starts from `m`'s arenas with no statements.
    pub fn new(m: &Model, eps: f64) -> Rebuild {
        let mut out = m.clone();
        out.items.clear();
        out.faces.clear();
        let mut r = Rebuild {
            out,
            eps,
            cell: (2.0 * eps).max(f64::MIN_POSITIVE),
            grid: FxHashMap::default(),
            fnames: m.faces.iter().filter_map(|f| f.name.clone()).collect(),
            vnames: m.vertices.iter().map(|v| v.name.clone()).collect(),
            emitted: m.vertices.len(),
            new_vertices: 0,
            first_new: m.vertices.len(),
        };
        for (k, v) in m.vertices.iter().enumerate() {
            let key = r.key(v.pos);
            r.grid.entry(key).or_default().push(VertexId(k as u32));
        }
        r
    }

    fn key(&self, p: DVec3) -> (i64, i64, i64) {
        let k = (p / self.cell).floor();
        (k.x as i64, k.y as i64, k.z as i64)
    }

    /// The nearest vertex within `r` of `p` (at most the grid's cell)
    /// that `accept` takes, given its id and position (lowest id on ties).
    fn nearest(
        &self,
        p: DVec3,
        r: f64,
        accept: impl Fn(VertexId, DVec3) -> bool,
    ) -> Option<VertexId> {
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
                        let q = self.out.vertices[v.idx()].pos;
                        let d = (q - p).length();
                        if d <= r
                            && best.is_none_or(|(b, w)| d < b || (d == b && v < w))
                            && accept(v, q)
                        {
                            best = Some((d, v));
                        }
                    }
                }
            }
        }
        best.map(|b| b.1)
    }

    /// The nearest vertex within epsilon (lowest id on ties).
    pub fn find(&self, p: DVec3) -> Option<VertexId> {
        self.nearest(p, self.eps, |_, _| true)
    }

    /// The nearest vertex created here within [`SNAP_EPSILONS`]·epsilon of
    /// `p` but `not` that lies within epsilon of every plane of `planes`
    /// (lowest id on ties). Only new ones: the reuse is for one crossing
    /// found by two pairs; snapped so onto the faces' own corners, a cut
    /// 1.2 epsilon off a shared edge became that edge, and cut nothing
    /// (property seed 23054).
    fn find_wide(&self, p: DVec3, planes: &[&Plane], not: Option<VertexId>) -> Option<VertexId> {
        self.nearest(p, SNAP_EPSILONS * self.eps, |v, q| {
            v.idx() >= self.first_new
                && Some(v) != not
                && planes.iter().all(|pl| pl.dist(q).abs() <= self.eps)
        })
    }

    /// The vertex within epsilon of `p`, else one within
    /// [`SNAP_EPSILONS`]·epsilon on all of `planes` (the planes of the
    /// faces the point lies on; none: no such reuse) other than `not`, or
    /// a new one named `BASE.TAGvK`.
    pub fn vertex(
        &mut self,
        p: DVec3,
        base: &str,
        tag: &str,
        planes: &[&Plane],
        not: Option<VertexId>,
    ) -> VertexId {
        if let Some(v) = self.find(p) {
            return v;
        }
        if !planes.is_empty()
            && let Some(v) = self.find_wide(p, planes, not)
        {
            return v;
        }
        let mut k = self.new_vertices;
        let name = loop {
            k += 1;
            let cand = format!("{base}.{tag}v{k}");
            if self.vnames.insert(cand.clone()) {
                break cand;
            }
        };
        let id = VertexId(self.out.vertices.len() as u32);
        self.out.vertices.push(Vertex {
            name,
            pos: p,
            color: None,
        });
        let key = self.key(p);
        self.grid.entry(key).or_default().push(id);
        self.new_vertices += 1;
        id
    }

    /// Passes a statement through.
    pub fn pass(&mut self, it: &Item) {
        self.out.items.push(it.clone());
    }

    /// Writes a face.
    pub fn face(&mut self, face: Face) {
        self.flush_vertices();
        let id = FaceId(self.out.faces.len() as u32);
        self.out.faces.push(face);
        self.out.items.push(Item::Face(id));
    }

    fn flush_vertices(&mut self) {
        for v in self.emitted..self.out.vertices.len() {
            self.out.items.push(Item::Vertex(VertexId(v as u32)));
        }
        self.emitted = self.out.vertices.len();
    }

    /// Writes the pieces of `face` (loops of points) as faces, each
    /// preceded by `annotation(k)` when given: one piece keeps the face's
    /// name, several are named `BASE.TAGk`. Returns how many were written.
    pub fn pieces(
        &mut self,
        face: &Face,
        base: &str,
        tag: &str,
        pieces: &[Vec<Vec<Point>>],
        annotation: Option<&str>,
    ) -> usize {
        let mut contours: Vec<Vec<Vec<VertexId>>> = Vec::with_capacity(pieces.len());
        for loops in pieces {
            let c = to_contours(loops, |p| self.vertex(p, base, tag, &[], None));
            if !c.is_empty() {
                contours.push(c);
            }
        }
        let whole = contours.len() == 1;
        let mut piece_no = 0usize;
        let mut written = 0;
        for c in contours {
            let name = face.name.as_ref().map(|n| {
                if whole {
                    return n.clone();
                }
                loop {
                    piece_no += 1;
                    let cand = format!("{base}.{tag}{piece_no}");
                    if self.fnames.insert(cand.clone()) {
                        break cand;
                    }
                }
            });
            self.flush_vertices();
            if let Some(a) = annotation {
                self.out.items.push(Item::Comment(a.to_string()));
            }
            self.face(Face {
                name,
                contours: c,
                material: face.material,
            });
            written += 1;
        }
        written
    }
}
