//! Meshing again after joins without meshing everything again.
//!
//! When a round of [`super::cut`] asks for joins (a short boundary edge no
//! triangle can take, a vertex just over epsilon from a corner), the model
//! is prepared again and meshed again. The joins change a few faces; the
//! other faces would be meshed exactly as before. So each round records,
//! per face, what meshing it did to the shared state (a [`Record`]: the
//! vertices of its own it made, in order, and its patches; the divisions
//! of the edges are kept for the whole round), and the next round replays
//! the record of every face that nothing it depends on has changed
//! (dividing its edges, making its vertices under the same names, giving
//! the same patches) instead of triangulating it again. The output is the
//! same, byte for byte, as meshing every face again: `ugcut`'s tests and
//! the dirty-building property test compare the two wherever a join was
//! made. On the 100k-face building after the chain, one join made the
//! second round mesh all 70,011 faces again; now it replays all but a few.
//!
//! What a face's meshing reads: its own contours and their positions, the
//! division of its edges (which reads the edge's ends, the feet and thin
//! partners of the faces that have the edge, the edges and faces at its
//! ends), the faces across its edges (fold points), and the vertices of
//! other faces resting inside it. So a face is replayed only when
//! - it is in both rounds, with the same name, material and contours on
//!   vertices of the same names at the same positions;
//! - no face sharing a vertex with it has changed;
//! - no vertex that moved, went or came lies within 64 epsilon of its
//!   bounding box;
//! - the vertices resting inside it are the same;
//! - it asked for no join, and the divisions of its edges come out the
//!   same (checked as they are made, before any other change).
//!
//! Vertex ids must keep their order between the rounds (an edge is divided
//! from its lower id); when they do not, nothing is replayed.

use super::{Ctx, Patches, Stats};
use geom::index::bbox;
use geom::{BoxIndex, DVec3};
use rustc_hash::{FxHashMap, FxHashSet, FxHasher};
use std::hash::{Hash, Hasher};
use ug::{FaceId, MaterialId, Model, VertexId};

/// What meshing one face did to the shared state besides dividing its
/// edges (`Ctx::divided`, which divides an edge on first use; meshing a
/// face divides all its contour edges, in order, before anything else):
/// the vertices of its own it made, in order, (k, id) for the vertex
/// named `FACE.vk`; and how it was meshed.
#[derive(Default)]
pub(super) struct Trace {
    pub(super) vertices: Vec<(u32, VertexId)>,
    /// Grid cells it added to [`Stats::grid_cells`].
    pub(super) grid_cells: usize,
    /// Meshed by the plain triangulation (listed in [`Stats::plain`]).
    pub(super) plain: bool,
    /// It asked for joins.
    pub(super) stuck: bool,
}

/// What meshing one face did and gave, as ranges of [`Memo`]'s arenas
/// (start, length).
#[derive(Clone, Copy)]
struct Record {
    /// Its own vertices, in `Memo::inner`.
    inner: (u32, u32),
    /// The patches' vertices, one contour after the other, in `Memo::ids`.
    ids: (u32, u32),
    /// Per patch its number of contours, then each contour's length, in
    /// `Memo::shape`.
    shape: (u32, u32),
    /// The vertices resting inside it (see `resting_points`), in
    /// `Memo::ids`.
    resting: (u32, u32),
    /// Grid cells it added to [`Stats::grid_cells`].
    grid_cells: u32,
    /// Meshed by the plain triangulation (listed in [`Stats::plain`]).
    plain: bool,
    /// It asked for joins.
    stuck: bool,
}

fn range<T>(v: &[T], r: (u32, u32)) -> &[T] {
    &v[r.0 as usize..(r.0 + r.1) as usize]
}

/// A round's records, for the next round.
#[derive(Default)]
pub(super) struct Memo {
    /// Per face of the round's model, what meshing it did (none for a
    /// twin, which copied an earlier face's patches).
    records: Vec<Option<Record>>,
    /// The records' arenas.
    inner: Vec<(u32, VertexId)>,
    ids: Vec<VertexId>,
    shape: Vec<u32>,
    /// The edges' divisions (lower vertex id first).
    div: FxHashMap<(VertexId, VertexId), Vec<VertexId>>,
    /// The positions of the vertices the round made (ids from `n_model`).
    pos: Vec<DVec3>,
    /// How many vertices are the model's.
    n_model: usize,
}

impl Memo {
    /// Keeps what meshing face `f` of the round's model did and gave (the
    /// first record for a face; later ones are ignored).
    pub(super) fn record(
        &mut self,
        f: FaceId,
        trace: &Trace,
        patches: &Patches,
        resting: &[VertexId],
    ) {
        if self.records.len() <= f.idx() {
            self.records.resize_with(f.idx() + 1, || None);
        }
        if self.records[f.idx()].is_some() {
            return;
        }
        let at = |n: usize, len: usize| (n as u32, (len - n) as u32);
        let (i0, s0, n0) = (self.ids.len(), self.shape.len(), self.inner.len());
        for p in patches {
            self.shape.push(p.len() as u32);
            for c in p {
                self.shape.push(c.len() as u32);
                self.ids.extend_from_slice(c);
            }
        }
        let ids = at(i0, self.ids.len());
        let shape = at(s0, self.shape.len());
        self.inner.extend_from_slice(&trace.vertices);
        let inner = at(n0, self.inner.len());
        let r0 = self.ids.len();
        self.ids.extend_from_slice(resting);
        let resting = at(r0, self.ids.len());
        self.records[f.idx()] = Some(Record {
            inner,
            ids,
            shape,
            resting,
            grid_cells: trace.grid_cells as u32,
            plain: trace.plain,
            stuck: trace.stuck,
        });
    }

    /// The patches of `rec`, each vertex through `tr`.
    fn patches(&self, rec: &Record, tr: impl Fn(VertexId) -> VertexId) -> Patches {
        let (shape, ids) = (range(&self.shape, rec.shape), range(&self.ids, rec.ids));
        let mut out = Vec::new();
        let (mut i, mut k) = (0, 0);
        while i < shape.len() {
            let n = shape[i] as usize;
            i += 1;
            let mut p = Vec::with_capacity(n);
            for _ in 0..n {
                let l = shape[i] as usize;
                i += 1;
                p.push(ids[k..k + l].iter().map(|&v| tr(v)).collect());
                k += l;
            }
            out.push(p);
        }
        out
    }

    /// The round's shared state at its end: the divisions, the positions
    /// of all vertices, how many are the model's.
    pub(super) fn finish(
        &mut self,
        div: FxHashMap<(VertexId, VertexId), Vec<VertexId>>,
        pos: Vec<DVec3>,
        n_model: usize,
    ) {
        self.div = div;
        self.pos = pos;
        self.n_model = n_model;
    }

    /// The position of vertex `v` made by the round.
    fn made_pos(&self, v: VertexId) -> Option<DVec3> {
        v.idx()
            .checked_sub(self.n_model)
            .and_then(|i| self.pos.get(i))
            .copied()
    }
}

/// A face's name, material and contours (each vertex through `id`), hashed.
fn sig_hash(
    name: &Option<String>,
    material: &Option<MaterialId>,
    contours: &[Vec<VertexId>],
    id: impl Fn(VertexId) -> Option<VertexId>,
) -> Option<u64> {
    let mut h = FxHasher::default();
    name.hash(&mut h);
    material.hash(&mut h);
    contours.len().hash(&mut h);
    for c in contours {
        c.len().hash(&mut h);
        for &v in c {
            id(v)?.hash(&mut h);
        }
    }
    Some(h.finish())
}

/// What the next round may replay.
pub(super) struct Reuse<'a> {
    memo: &'a Memo,
    /// Last round's model vertex → this round's, where it is the same.
    fwd: Vec<Option<VertexId>>,
    /// This round's model vertex → last round's, where it is the same.
    back: Vec<Option<VertexId>>,
    /// Per face of this round's model, last round's face to replay:
    /// the same face, and nothing it depends on changed (but its resting
    /// vertices and divisions, checked in [`Reuse::replay`]).
    from: Vec<Option<FaceId>>,
}

fn key(a: VertexId, b: VertexId) -> (VertexId, VertexId) {
    if a < b { (a, b) } else { (b, a) }
}

impl<'a> Reuse<'a> {
    /// Compares `before` (the model `memo` was made on) with `after` (the
    /// model about to be meshed); `None` where nothing can be replayed.
    pub(super) fn new(
        memo: &'a Memo,
        before: &Model,
        after: &Model,
        eps: f64,
    ) -> Option<Reuse<'a>> {
        if !(eps.is_finite() && eps > 0.0) || memo.n_model != before.vertices.len() {
            return None;
        }
        let names: FxHashMap<&str, u32> = before
            .vertices
            .iter()
            .enumerate()
            .map(|(i, v)| (v.name.as_str(), i as u32))
            .collect();
        let same_pos = |a: DVec3, b: DVec3| {
            a.to_array()
                .iter()
                .zip(b.to_array())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let mut fwd = vec![None; before.vertices.len()];
        let mut back = vec![None; after.vertices.len()];
        for (i2, v) in after.vertices.iter().enumerate() {
            if let Some(&i1) = names.get(v.name.as_str())
                && same_pos(before.vertices[i1 as usize].pos, v.pos)
            {
                fwd[i1 as usize] = Some(VertexId(i2 as u32));
                back[i2] = Some(VertexId(i1));
            }
        }
        drop(names);
        // The ids' order kept.
        let mut last: Option<VertexId> = None;
        for v in fwd.iter().flatten() {
            if last.is_some_and(|l| l >= *v) {
                return None;
            }
            last = Some(*v);
        }
        // Last round's faces by their hash (the first of identical ones).
        let mut by_sig: FxHashMap<u64, FaceId> = FxHashMap::default();
        for f in before.top_faces() {
            let face = &before.faces[f.idx()];
            if let Some(h) = sig_hash(&face.name, &face.material, &face.contours, Some) {
                by_sig.entry(h).or_insert(f);
            }
        }
        // This round's faces found there; the vertices of those that are not.
        let mut touched = vec![false; after.vertices.len()];
        let mut from = vec![None; after.faces.len()];
        for f in after.top_faces() {
            let face = &after.faces[f.idx()];
            let old = sig_hash(&face.name, &face.material, &face.contours, |v| {
                back[v.idx()]
            })
            .and_then(|h| by_sig.get(&h).copied())
            .filter(|g| {
                let o = &before.faces[g.idx()];
                o.name == face.name
                    && o.material == face.material
                    && o.contours.len() == face.contours.len()
                    && o.contours.iter().zip(&face.contours).all(|(a, b)| {
                        a.len() == b.len()
                            && a.iter().zip(b).all(|(&x, &y)| back[y.idx()] == Some(x))
                    })
            });
            match old {
                Some(g) => from[f.idx()] = Some(g),
                None => {
                    for v in face.contours.iter().flatten() {
                        touched[v.idx()] = true;
                    }
                }
            }
        }
        // Vertices that moved, went or came.
        let dirty: Vec<DVec3> = (0..before.vertices.len())
            .filter(|&i| fwd[i].is_none())
            .map(|i| before.vertices[i].pos)
            .chain(
                (0..after.vertices.len())
                    .filter(|&i| back[i].is_none())
                    .map(|i| after.vertices[i].pos),
            )
            .collect();
        let index = BoxIndex::new(dirty.iter().enumerate().map(|(k, &p)| (p, p, k as u32)));
        let reach = 64.0 * eps;
        for f in after.top_faces() {
            let face = &after.faces[f.idx()];
            if from[f.idx()].is_none() {
                continue;
            }
            let near = face.contours.iter().flatten().any(|v| touched[v.idx()]) || {
                let (lo, hi) = bbox(face.contours.iter().flatten().map(|&v| after.pos(v)), reach);
                !dirty.is_empty() && !index.query(lo, hi).is_empty()
            };
            if near {
                from[f.idx()] = None;
            }
        }
        Some(Reuse {
            memo,
            fwd,
            back,
            from,
        })
    }

    /// Replays last round's meshing of face `f` into `cx` and `stats`
    /// and records it in `next` for the next round: its patches, or `None`
    /// (and nothing changed but edges divided as meshing it would divide
    /// them first) where it must be meshed again. The second value: it
    /// was meshed by the plain triangulation.
    pub(super) fn replay(
        &self,
        cx: &mut Ctx<'_>,
        f: FaceId,
        stats: &mut Stats,
        next: &mut Memo,
    ) -> Option<(Patches, bool)> {
        let memo = self.memo;
        let g = self.from.get(f.idx()).copied().flatten()?;
        let rec = *memo.records.get(g.idx())?.as_ref()?;
        if rec.stuck {
            return None;
        }
        let now: Vec<VertexId> = cx.resting.get(&f).cloned().unwrap_or_default();
        let was = range(&memo.ids, rec.resting);
        if now.len() != was.len()
            || now
                .iter()
                .zip(was)
                .any(|(&a, &b)| self.back[a.idx()] != Some(b))
        {
            return None;
        }
        let n1 = memo.n_model;
        // The face's contour edges, last round's ids and this round's.
        let face = &cx.m.faces[f.idx()];
        let edges: Vec<((VertexId, VertexId), (VertexId, VertexId))> = face
            .contours
            .iter()
            .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
            .map(|(a, b)| Some(((self.back[a.idx()]?, self.back[b.idx()]?), (a, b))))
            .collect::<Option<_>>()?;
        // Every vertex of the patches is the model's or made by the face.
        let inner = range(&memo.inner, rec.inner);
        let mut made: FxHashSet<VertexId> = FxHashSet::default();
        for &((a, b), _) in &edges {
            made.extend(memo.div.get(&key(a, b))?.iter().copied());
        }
        made.extend(inner.iter().map(|x| x.1));
        let known = |v: VertexId| {
            if v.idx() < n1 {
                self.fwd[v.idx()].is_some()
            } else {
                made.contains(&v) && memo.made_pos(v).is_some()
            }
        };
        if !range(&memo.ids, rec.ids).iter().all(|&v| known(v))
            || !made.iter().all(|&v| memo.made_pos(v).is_some())
        {
            return None;
        }
        // The divisions, as meshing the face would make them first; each
        // must come out as last round's.
        let mut map: FxHashMap<VertexId, VertexId> = FxHashMap::default();
        for &((a, b), (a2, b2)) in &edges {
            cx.divided(a2, b2);
            let (l1, l2) = (memo.div.get(&key(a, b))?, cx.div.map.get(&key(a2, b2))?);
            if l1.len() != l2.len()
                || l1
                    .iter()
                    .zip(l2)
                    .any(|(&x, &y)| memo.made_pos(x) != Some(cx.pos(y)))
            {
                return None;
            }
            map.extend(l1.iter().copied().zip(l2.iter().copied()));
        }
        // Its own vertices, in order, named as meshing it names them.
        let fname = face.name.clone().unwrap_or_else(|| format!("f{}", f.0 + 1));
        let mut trace = Trace {
            vertices: Vec::with_capacity(inner.len()),
            grid_cells: rec.grid_cells as usize,
            plain: rec.plain,
            stuck: false,
        };
        for &(k, v) in inner {
            let p = memo.made_pos(v).expect("checked above");
            let w = cx.new_vertex(format!("{fname}.v{k}"), p);
            map.insert(v, w);
            trace.vertices.push((k, w));
        }
        let tr = |v: VertexId| {
            if v.idx() < n1 {
                self.fwd[v.idx()].expect("checked above")
            } else {
                map[&v]
            }
        };
        let patches = memo.patches(&rec, tr);
        stats.grid_cells += rec.grid_cells as usize;
        next.record(f, &trace, &patches, &now);
        Some((patches, rec.plain))
    }
}
