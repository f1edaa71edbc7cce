//! Planar arrangements of segments with snap rounding: the robust core that
//! decides how contours and cuts divide a face into pieces (`ugisect`,
//! `ugcopl`, `ugcut`, `ugplanar`).
//!
//! # What it computes
//!
//! Given points and segments between them in a plane, [`arrange`] returns
//! the planar graph they form — no two edges cross, every crossing is a
//! vertex — and its bounded faces, each with its boundary loops and a
//! **label**: the set of tags toggled an odd number of times on the way from
//! the unbounded face (the even-odd rule, per tag). A face's own contours
//! tagged `Toggle(0)` give the faces inside it; a coplanar neighbour's
//! contours tagged `Toggle(k)` tell which pieces it covers; `Cut` segments
//! divide without toggling anything.
//!
//! # Snap rounding
//!
//! Every decision is made with exact predicates (`orient2d`) on f64
//! coordinates; the only constructions are crossing points. Iterated snap
//! rounding to *hot points* makes the result consistent and sliver-free
//! (Hobby 1999; Halperin and Packer 2002, with discs of radius `snap`
//! instead of pixels):
//!
//! 1. input points within `snap` of each other are one point (the first);
//! 2. every proper crossing of two segments becomes a hot point (or joins
//!    one within `snap`);
//! 3. a segment passing within `snap` of a hot point is rerouted through it
//!    (a polyline through all such points, in order along the segment);
//! 4. the rerouted edges are checked again (steps 2–3) until nothing
//!    changes.
//!
//! So in the result no vertex lies within `snap` of another vertex or of an
//! edge it is not an end of: no piece is narrower than `snap`, no contour
//! touches itself, no edge has zero length. Collinear overlapping segments
//! become one edge (their tags add up: two contours along the same line
//! cancel). A segment's drift is bounded by `snap` per iteration.
//!
//! # Faces
//!
//! Half-edges are sorted around each vertex by exact angle comparison and
//! traced into cycles (interior on the left); counter-clockwise cycles bound
//! faces, clockwise ones are the outer boundaries of components, placed in
//! the face that contains them by an exact horizontal ray. Labels spread
//! from the unbounded face across edges. Edges that toggle nothing and are
//! not cuts (two contours along one line) are dropped, so they never split a
//! face. A face's loops are split where they visit a vertex twice (a hole
//! touching the outer contour at a vertex becomes a separate loop through
//! it), so no loop revisits a vertex.
//!
//! With [`Options::extend_cuts`], a cut that does not separate two faces (it
//! ends inside a face, or runs from the boundary to a hole) is extended along
//! its line from its free end to the next edge, repeatedly, until every cut
//! separates: the face could not be written with it otherwise.

use glam::{DVec2, DVec3};
use rustc_hash::FxHashMap;

use crate::index::BoxIndex;

/// Boxes to query: an R*-tree for many, a plain list for a few (most faces
/// have a handful of edges, and building a tree costs more than scanning).
enum Boxes {
    Tree(BoxIndex),
    List(Vec<(DVec3, DVec3, u32)>),
}

impl Boxes {
    fn new(boxes: impl IntoIterator<Item = (DVec3, DVec3, u32)>) -> Boxes {
        let v: Vec<(DVec3, DVec3, u32)> = boxes.into_iter().collect();
        if v.len() > 48 {
            Boxes::Tree(BoxIndex::new(v))
        } else {
            Boxes::List(v)
        }
    }

    /// Ids of the boxes that overlap [lo, hi], ascending.
    fn query(&self, lo: DVec3, hi: DVec3) -> Vec<u32> {
        match self {
            Boxes::Tree(t) => t.query(lo, hi),
            Boxes::List(v) => {
                let mut ids: Vec<u32> = v
                    .iter()
                    .filter(|(l, h, _)| l.cmple(hi).all() && h.cmpge(lo).all())
                    .map(|b| b.2)
                    .collect();
                ids.sort_unstable();
                ids
            }
        }
    }
}
use crate::predicates::orient2d;

/// What a segment does to the faces on its two sides.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Tag {
    /// A contour of region `k`: crossing it toggles membership of `k`.
    Toggle(u32),
    /// A cut: it divides faces and toggles nothing.
    Cut,
}

/// A segment between two of the input points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub a: u32,
    pub b: u32,
    pub tag: Tag,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Snap radius: points closer than this are one, and an edge passing
    /// this close to a point goes through it.
    pub snap: f64,
    /// Extend cuts that end inside a face until they separate faces.
    pub extend_cuts: bool,
    /// Most snap-rounding rounds (each finds crossings and reroutes).
    pub max_rounds: usize,
}

impl Options {
    pub fn new(snap: f64) -> Options {
        Options {
            snap,
            extend_cuts: false,
            max_rounds: 24,
        }
    }
}

/// A bounded face of the arrangement.
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// Boundary loops as point indices: the outer loop first
    /// (counter-clockwise), then the holes (clockwise). No loop visits a
    /// point twice; two loops may share a point.
    pub loops: Vec<Vec<u32>>,
    /// The tags `Toggle(k)` crossed an odd number of times from the
    /// unbounded face (sorted `k`s).
    pub label: Vec<u32>,
    /// Area (positive).
    pub area: f64,
}

impl Face {
    /// Whether tag `k` covers this face (odd parity).
    pub fn has(&self, k: u32) -> bool {
        self.label.binary_search(&k).is_ok()
    }
}

/// The result of [`arrange`].
#[derive(Clone, Debug)]
pub struct Arrangement {
    /// Every point: the input points (same indices), then the new ones
    /// (crossings and cut extensions).
    pub points: Vec<DVec2>,
    /// How many of `points` were input.
    pub inputs: usize,
    /// For each input point, the point it was merged into (itself when kept).
    pub rep: Vec<u32>,
    /// The edges of the final graph (`a < b`), with what they toggle.
    pub edges: Vec<(u32, u32)>,
    /// Bounded faces, in a deterministic order (by their lowest half-edge).
    pub faces: Vec<Face>,
    /// Snap-rounding rounds used.
    pub rounds: usize,
    /// False when `max_rounds` ran out before the graph settled (the result
    /// may then have crossings; never seen in practice).
    pub converged: bool,
    /// Cut extensions added.
    pub extensions: usize,
}

/// Tags on one edge: what it toggles (odd multiplicity) and whether a cut lies on it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
struct Tags {
    toggles: Vec<u32>,
    cut: bool,
}

impl Tags {
    fn from(t: Tag) -> Tags {
        match t {
            Tag::Toggle(k) => Tags {
                toggles: vec![k],
                cut: false,
            },
            Tag::Cut => Tags {
                toggles: Vec::new(),
                cut: true,
            },
        }
    }

    /// Adds another segment's tags (toggles cancel in pairs).
    fn add(&mut self, o: &Tags) {
        for &k in &o.toggles {
            match self.toggles.binary_search(&k) {
                Ok(i) => {
                    self.toggles.remove(i);
                }
                Err(i) => self.toggles.insert(i, k),
            }
        }
        self.cut |= o.cut;
    }

    fn is_void(&self) -> bool {
        self.toggles.is_empty() && !self.cut
    }
}

/// Points with a uniform grid for "which point is within r".
struct Hot {
    pts: Vec<DVec2>,
    /// False for input points merged into an earlier one (never hot).
    real: Vec<bool>,
    cell: f64,
    grid: FxHashMap<(i64, i64), Vec<u32>>,
    r: f64,
    /// Points merged by [`snap_round`] (a cluster too tight to route edges
    /// through): the point each went into.
    alias: FxHashMap<u32, u32>,
}

impl Hot {
    fn new(r: f64) -> Hot {
        Hot {
            pts: Vec::new(),
            real: Vec::new(),
            cell: (2.0 * r).max(f64::MIN_POSITIVE),
            grid: FxHashMap::default(),
            r,
            alias: FxHashMap::default(),
        }
    }

    fn key(&self, p: DVec2) -> (i64, i64) {
        let k = (p / self.cell).floor();
        (k.x as i64, k.y as i64)
    }

    /// The lowest-index point within `r` of `p`.
    fn near(&self, p: DVec2) -> Option<u32> {
        let (x, y) = self.key(p);
        let mut best: Option<u32> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(v) = self.grid.get(&(x + dx, y + dy)) {
                    for &i in v {
                        if (self.pts[i as usize] - p).length() <= self.r
                            && best.is_none_or(|b| i < b)
                        {
                            best = Some(i);
                        }
                    }
                }
            }
        }
        best
    }

    fn push(&mut self, p: DVec2) -> u32 {
        let id = self.pts.len() as u32;
        self.pts.push(p);
        self.real.push(true);
        let k = self.key(p);
        self.grid.entry(k).or_default().push(id);
        id
    }

    /// Merges point `k` into point `into` (neither hot again nor found).
    fn merge(&mut self, k: u32, into: u32) {
        self.real[k as usize] = false;
        self.alias.insert(k, into);
        let key = self.key(self.pts[k as usize]);
        if let Some(v) = self.grid.get_mut(&key) {
            v.retain(|&i| i != k);
        }
    }

    /// The point that `k` was merged into, or `k`.
    fn find(&self, mut k: u32) -> u32 {
        while let Some(&n) = self.alias.get(&k) {
            k = n;
        }
        k
    }

    /// The point within `r` of `p`, or a new one.
    fn snap(&mut self, p: DVec2) -> (u32, bool) {
        match self.near(p) {
            Some(i) => (i, false),
            None => (self.push(p), true),
        }
    }
}

fn seg_box(a: DVec2, b: DVec2, pad: f64) -> (DVec3, DVec3) {
    (
        (a.min(b) - DVec2::splat(pad)).extend(0.0),
        (a.max(b) + DVec2::splat(pad)).extend(0.0),
    )
}

/// Distance from `p` to the segment [a, b] and the parameter of the closest point.
fn seg_dist(p: DVec2, a: DVec2, b: DVec2) -> (f64, f64) {
    let d = b - a;
    let l2 = d.length_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((a + d * t - p).length(), t)
}

/// The crossing point of two segments that cross properly.
fn crossing(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> DVec2 {
    let r = b - a;
    let s = d - c;
    let den = r.perp_dot(s);
    if den == 0.0 {
        return (a + b + c + d) / 4.0;
    }
    let t = ((c - a).perp_dot(s) / den).clamp(0.0, 1.0);
    let u = ((c - a).perp_dot(r) / den).clamp(0.0, 1.0);
    // Average the two parametrisations (they agree up to rounding).
    (a + r * t + c + s * u) / 2.0
}

/// Whether the segments cross at one point interior to both (exactly).
fn proper(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let o1 = orient2d(a, b, c);
    let o2 = orient2d(a, b, d);
    let o3 = orient2d(c, d, a);
    let o4 = orient2d(c, d, b);
    o1 * o2 < 0 && o3 * o4 < 0
}

/// Builds the arrangement of `segments` over `points` (see the module docs).
pub fn arrange(points: &[DVec2], segments: &[Segment], opts: &Options) -> Arrangement {
    let r = opts.snap.max(0.0);
    let mut hot = Hot::new(r);
    // 1. Input points, merged within r (the first one stays).
    let mut rep = Vec::with_capacity(points.len());
    for &p in points {
        match hot.near(p) {
            Some(i) => {
                // Keeps the index space: a placeholder, never hot.
                hot.pts.push(p);
                hot.real.push(false);
                rep.push(rep[i as usize]);
            }
            None => {
                let id = hot.push(p);
                rep.push(id);
            }
        }
    }
    let inputs = points.len();
    let mut edges: Vec<(u32, u32, Tags)> = Vec::new();
    for s in segments {
        let (a, b) = (rep[s.a as usize], rep[s.b as usize]);
        if a != b {
            edges.push((a, b, Tags::from(s.tag)));
        }
    }
    let mut edges = dedup(edges);
    let mut rounds = 0;
    let mut converged = false;
    let mut extensions = 0;
    loop {
        while rounds < opts.max_rounds {
            rounds += 1;
            let (next, changed) = snap_round(&mut hot, &edges, r);
            edges = next;
            if !changed {
                converged = true;
                break;
            }
        }
        if !opts.extend_cuts || extensions > 2 * segments.len() + 16 {
            break;
        }
        // A cut that does not separate faces: from a free end, extend it
        // to the next edge; a cut with no free end (from the boundary to a
        // hole) gets its whole line, which always separates.
        let g = Graph::build(&hot.pts, &edges);
        let Some(loose) = g.first_loose_cut(&hot.pts, &edges) else {
            break;
        };
        let added = match loose {
            Loose::End(from, dir) => g.shoot(&hot.pts, &edges, from, dir).and_then(|hit| {
                let (h, _) = hot.snap(hit);
                (h != from).then_some((from, h))
            }),
            Loose::Bridge(a, b) => {
                let (pa, pb) = (hot.pts[a as usize], hot.pts[b as usize]);
                let (lo, hi) = crate::index::bbox(hot.pts.iter().map(|p| p.extend(0.0)), 0.0);
                let reach = (hi - lo).length() + 1.0;
                let d = (pb - pa).normalize();
                let (p, q) = (pa - d * reach, pb + d * reach);
                let (i, _) = hot.snap(p);
                let (j, _) = hot.snap(q);
                (i != j).then_some((i, j))
            }
        };
        let Some((i, j)) = added else {
            break;
        };
        extensions += 1;
        edges.push((i.min(j), i.max(j), Tags::from(Tag::Cut)));
        edges = dedup(edges);
        converged = false;
    }
    let g = Graph::build(&hot.pts, &edges);
    let faces = g.faces(&hot.pts, &edges);
    for r in rep.iter_mut() {
        *r = hot.find(*r);
    }
    Arrangement {
        points: hot.pts,
        inputs,
        rep,
        edges: edges.iter().map(|e| (e.0, e.1)).collect(),
        faces,
        rounds,
        converged,
        extensions,
    }
}

/// Merges edges with the same end points (their tags add up) and drops the
/// ones left toggling nothing (two contours along one line).
fn dedup(mut edges: Vec<(u32, u32, Tags)>) -> Vec<(u32, u32, Tags)> {
    for e in edges.iter_mut() {
        if e.0 > e.1 {
            std::mem::swap(&mut e.0, &mut e.1);
        }
    }
    edges.sort_by_key(|x| (x.0, x.1));
    let mut out: Vec<(u32, u32, Tags)> = Vec::with_capacity(edges.len());
    for e in edges {
        match out.last_mut() {
            Some(l) if l.0 == e.0 && l.1 == e.1 => l.2.add(&e.2),
            _ => out.push(e),
        }
    }
    out.retain(|e| !e.2.is_void());
    out
}

/// Queries along a long diagonal segment are made in pieces no longer than
/// this (1/64 of the points' extent), so that it does not collect half the
/// arrangement.
fn query_step(pts: &[DVec2]) -> f64 {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in pts {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let d = (hi - lo).length();
    if d > 0.0 { d / 64.0 } else { f64::INFINITY }
}

/// Ids of the boxes near the segment [a, b] (grown by `pad`), ascending.
fn along(index: &Boxes, a: DVec2, b: DVec2, pad: f64, step: f64) -> Vec<u32> {
    let ext = (b - a).abs();
    if ext.x.min(ext.y) <= step {
        let (lo, hi) = seg_box(a, b, pad);
        return index.query(lo, hi);
    }
    let pieces = ((ext.x.max(ext.y) / step).ceil() as usize).clamp(2, 256);
    let mut ids = Vec::new();
    for k in 0..pieces {
        let p = a.lerp(b, k as f64 / pieces as f64);
        let q = a.lerp(b, (k + 1) as f64 / pieces as f64);
        let (lo, hi) = seg_box(p, q, pad);
        ids.extend(index.query(lo, hi));
    }
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// One round: new hot points at crossings, then every edge through the hot
/// points within `r` of it. Returns the new edges and whether anything changed.
fn snap_round(hot: &mut Hot, edges: &[(u32, u32, Tags)], r: f64) -> (Vec<(u32, u32, Tags)>, bool) {
    let pts = |hot: &Hot, e: &(u32, u32, Tags)| (hot.pts[e.0 as usize], hot.pts[e.1 as usize]);
    let mut changed = false;
    // Crossings.
    if edges.len() > 1 {
        let index = Boxes::new(edges.iter().enumerate().map(|(k, e)| {
            let (a, b) = pts(hot, e);
            let (lo, hi) = seg_box(a, b, 0.0);
            (lo, hi, k as u32)
        }));
        let mut found: Vec<DVec2> = Vec::new();
        let step = query_step(&hot.pts);
        for (i, e) in edges.iter().enumerate() {
            let (a, b) = pts(hot, e);
            for j in along(&index, a, b, 0.0, step) {
                let j = j as usize;
                if j <= i {
                    continue;
                }
                let f = &edges[j];
                if f.0 == e.0 || f.0 == e.1 || f.1 == e.0 || f.1 == e.1 {
                    continue;
                }
                let (c, d) = pts(hot, f);
                if proper(a, b, c, d) {
                    found.push(crossing(a, b, c, d));
                }
            }
        }
        for p in found {
            if hot.snap(p).1 {
                changed = true;
            }
        }
    }
    // Rerouting through hot points within r.
    let index = Boxes::new(
        hot.pts
            .iter()
            .enumerate()
            .filter(|(k, _)| hot.real[*k])
            .map(|(k, p)| {
                let q = p.extend(0.0);
                (q, q, k as u32)
            }),
    );
    let step = query_step(&hot.pts);
    let mut out: Vec<(u32, u32, Tags)> = Vec::with_capacity(edges.len());
    let mut merges: Vec<(u32, u32)> = Vec::new();
    for e in edges {
        let (a, b) = pts(hot, e);
        let mut on: Vec<(f64, u32)> = Vec::new();
        for k in along(&index, a, b, r, step) {
            if k == e.0 || k == e.1 {
                continue;
            }
            if !hot.real[k as usize] {
                continue;
            }
            let (d, t) = seg_dist(hot.pts[k as usize], a, b);
            if d <= r {
                on.push((t, k));
            }
        }
        if on.is_empty() {
            out.push(e.clone());
            continue;
        }
        changed = true;
        on.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        // Three points, each more than r from the others, where each edge
        // between two of them passes within r of the third: no route
        // through them settles (the edge goes through the third point,
        // and one of the new edges passes within r of the first edge's
        // end), so the closest two are merged.
        for &(_, k) in &on {
            let pk = hot.pts[k as usize];
            if seg_dist(a, pk, b).0 <= r || seg_dist(b, a, pk).0 <= r {
                let (da, db, dab) = (a.distance(pk), b.distance(pk), a.distance(b));
                let (x, y) = if dab <= da.min(db) {
                    (e.0, e.1)
                } else if da <= db {
                    (e.0, k)
                } else {
                    (e.1, k)
                };
                merges.push((x.min(y), x.max(y)));
            }
        }
        let mut prev = e.0;
        for (_, k) in on {
            if k != prev {
                out.push((prev, k, e.2.clone()));
                prev = k;
            }
        }
        if prev != e.1 {
            out.push((prev, e.1, e.2.clone()));
        }
    }
    // The tight clusters merged (into the lower point), edges renamed: one
    // pair per point and round, so that a cluster loses one point at a
    // time and two that settle stay apart.
    merges.sort_unstable();
    merges.dedup();
    let mut touched: Vec<u32> = Vec::new();
    for (x, y) in merges {
        if touched.contains(&x) || touched.contains(&y) {
            continue;
        }
        hot.merge(y, x);
        touched.extend([x, y]);
    }
    if !hot.alias.is_empty() {
        for e in out.iter_mut() {
            e.0 = hot.find(e.0);
            e.1 = hot.find(e.1);
        }
        out.retain(|e| e.0 != e.1);
    }
    let out = dedup(out);
    if !changed && out.len() != edges.len() {
        changed = true;
    }
    (out, changed)
}

/// Half-edge structure over the final edges: half-edge 2k goes a→b of edge
/// k, 2k+1 goes b→a.
struct Graph {
    /// Outgoing half-edges of point v, counter-clockwise by angle:
    /// `list[start[v]..start[v + 1]]`.
    start: Vec<u32>,
    list: Vec<u32>,
    /// Position of each half-edge in its origin's list.
    slot: Vec<u32>,
}

impl Graph {
    fn origin(edges: &[(u32, u32, Tags)], h: u32) -> u32 {
        let e = &edges[(h / 2) as usize];
        if h.is_multiple_of(2) { e.0 } else { e.1 }
    }

    fn dest(edges: &[(u32, u32, Tags)], h: u32) -> u32 {
        Graph::origin(edges, h ^ 1)
    }

    fn build(pts: &[DVec2], edges: &[(u32, u32, Tags)]) -> Graph {
        let n = pts.len();
        let mut start = vec![0u32; n + 1];
        for h in 0..(2 * edges.len()) as u32 {
            start[Graph::origin(edges, h) as usize + 1] += 1;
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut list = vec![0u32; 2 * edges.len()];
        for h in 0..(2 * edges.len()) as u32 {
            let v = Graph::origin(edges, h) as usize;
            list[fill[v] as usize] = h;
            fill[v] += 1;
        }
        let mut slot = vec![0u32; 2 * edges.len()];
        for v in 0..n {
            let (a, b) = (start[v] as usize, start[v + 1] as usize);
            if b - a > 1 {
                let o = pts[v];
                list[a..b].sort_by(|&x, &y| {
                    let p = pts[Graph::dest(edges, x) as usize];
                    let q = pts[Graph::dest(edges, y) as usize];
                    angle_cmp(o, p, q).then(x.cmp(&y))
                });
            }
            for i in a..b {
                slot[list[i] as usize] = (i - a) as u32;
            }
        }
        Graph { start, list, slot }
    }

    fn degree(&self, v: u32) -> usize {
        (self.start[v as usize + 1] - self.start[v as usize]) as usize
    }

    /// The half-edge after `h` on its face (the face on the left): at h's
    /// destination, the outgoing half-edge just clockwise of h's twin.
    fn next(&self, edges: &[(u32, u32, Tags)], h: u32) -> u32 {
        let t = h ^ 1;
        let v = Graph::origin(edges, t) as usize;
        let list = &self.list[self.start[v] as usize..self.start[v + 1] as usize];
        let i = self.slot[t as usize] as usize;
        list[(i + list.len() - 1) % list.len()]
    }

    /// Cycles of half-edges (each half-edge in exactly one).
    fn cycles(&self, edges: &[(u32, u32, Tags)]) -> (Vec<Vec<u32>>, Vec<u32>) {
        let n = 2 * edges.len();
        let mut cyc = vec![u32::MAX; n];
        let mut cycles = Vec::new();
        for s in 0..n as u32 {
            if cyc[s as usize] != u32::MAX {
                continue;
            }
            let id = cycles.len() as u32;
            let mut c = Vec::new();
            let mut h = s;
            loop {
                cyc[h as usize] = id;
                c.push(h);
                h = self.next(edges, h);
                if h == s || c.len() > n {
                    break;
                }
            }
            cycles.push(c);
        }
        (cycles, cyc)
    }

    /// Twice the signed area of a cycle.
    fn area2(pts: &[DVec2], edges: &[(u32, u32, Tags)], c: &[u32]) -> f64 {
        let o = pts[Graph::origin(edges, c[0]) as usize];
        c.iter()
            .map(|&h| {
                let a = pts[Graph::origin(edges, h) as usize] - o;
                let b = pts[Graph::dest(edges, h) as usize] - o;
                a.perp_dot(b)
            })
            .sum()
    }

    /// Face of every cycle: a counter-clockwise cycle is a face of its own;
    /// any other cycle belongs to the face that contains it (`u32::MAX`:
    /// the unbounded face). Returns (face per cycle, bounded cycles).
    fn assign(
        &self,
        pts: &[DVec2],
        edges: &[(u32, u32, Tags)],
        cycles: &[Vec<u32>],
        cyc: &[u32],
    ) -> Vec<u32> {
        let areas: Vec<f64> = cycles.iter().map(|c| Graph::area2(pts, edges, c)).collect();
        let mut face = vec![u32::MAX - 1; cycles.len()];
        for (k, a) in areas.iter().enumerate() {
            if *a > 0.0 {
                face[k] = k as u32;
            }
        }
        let index = Boxes::new(edges.iter().enumerate().map(|(k, e)| {
            let (lo, hi) = seg_box(pts[e.0 as usize], pts[e.1 as usize], 0.0);
            (lo, hi, k as u32)
        }));
        let (lo_all, _) = crate::index::bbox(pts.iter().map(|p| p.extend(0.0)), 1.0);
        // The cycle to the left of each non-positive cycle.
        let mut left_of = vec![u32::MAX; cycles.len()];
        for (k, c) in cycles.iter().enumerate() {
            if areas[k] > 0.0 {
                continue;
            }
            // Its lowest-leftmost point.
            let mut p = pts[Graph::origin(edges, c[0]) as usize];
            let mut pv = Graph::origin(edges, c[0]);
            for &h in c {
                let v = Graph::origin(edges, h);
                let q = pts[v as usize];
                if (q.x, q.y) < (p.x, p.y) {
                    p = q;
                    pv = v;
                }
            }
            let _ = pv;
            // Nearest edge crossed by the ray from p towards −x (the ray
            // taken infinitesimally above p).
            let hits = index.query(DVec3::new(lo_all.x, p.y, 0.0), DVec3::new(p.x, p.y, 0.0));
            let mut best: Option<(u32, f64)> = None;
            for e in hits {
                let ed = &edges[e as usize];
                if cyc[2 * e as usize] == k as u32 && cyc[2 * e as usize + 1] == k as u32 {
                    continue;
                }
                let (a, b) = (pts[ed.0 as usize], pts[ed.1 as usize]);
                // Straddles y = p.y + δ: one end at or below, one above.
                let (lo, hi) = if a.y <= b.y { (a, b) } else { (b, a) };
                if !(lo.y <= p.y && hi.y > p.y) {
                    continue;
                }
                // Left of p: p lies right of the upward edge lo→hi.
                let o = orient2d(lo, hi, p);
                if o > 0 {
                    continue;
                }
                if o == 0 && !(lo.y == p.y && lo.x < p.x) {
                    // p on the edge itself (cannot be, but be safe).
                    continue;
                }
                let x = if hi.y == lo.y {
                    lo.x.max(hi.x)
                } else {
                    lo.x + (p.y - lo.y) * (hi.x - lo.x) / (hi.y - lo.y)
                };
                let better = match best {
                    None => true,
                    Some((b, bx)) => {
                        let bd = &edges[b as usize];
                        let (blo, bhi) = {
                            let (a2, b2) = (pts[bd.0 as usize], pts[bd.1 as usize]);
                            if a2.y <= b2.y { (a2, b2) } else { (b2, a2) }
                        };
                        if bhi == hi {
                            // Two edges sharing their upper end (above the
                            // ray): the one leaning further right below it
                            // is nearer, decided exactly. Their crossings of
                            // the ray may round to one value, or even the
                            // wrong way round: a triangle's two sides from a
                            // corner 2e-31 above the ray, the ray from a
                            // point of another face 3 mm away along the same
                            // line (two patches of one facade that ugcheck
                            // found overlapping by 0.059 m², the second
                            // placed inside the first; property seed 170590
                            // to 1 mm).
                            orient2d(hi, blo, lo) > 0
                        } else if x > bx {
                            true
                        } else if x < bx {
                            false
                        } else if blo == lo {
                            // Same crossing (a shared end at p's height):
                            // the edge leaning further right is nearer just above.
                            orient2d(lo, bhi, hi) < 0
                        } else {
                            e < b
                        }
                    }
                };
                if better {
                    best = Some((e, x));
                }
            }
            if let Some((e, _)) = best {
                let ed = &edges[e as usize];
                let (a, b) = (pts[ed.0 as usize], pts[ed.1 as usize]);
                // The half-edge with p on its left.
                let h = if orient2d(a, b, p) > 0 || (orient2d(a, b, p) == 0 && a.y < b.y) {
                    2 * e
                } else {
                    2 * e + 1
                };
                left_of[k] = cyc[h as usize];
            }
        }
        // Resolve chains of non-positive cycles.
        for k in 0..cycles.len() {
            if face[k] != u32::MAX - 1 {
                continue;
            }
            let mut chain = vec![k];
            let mut cur = k;
            let result = loop {
                let l = left_of[cur];
                if l == u32::MAX {
                    break u32::MAX;
                }
                let l = l as usize;
                if face[l] != u32::MAX - 1 {
                    break face[l];
                }
                if chain.contains(&l) {
                    break u32::MAX;
                }
                chain.push(l);
                cur = l;
            };
            for c in chain {
                face[c] = result;
            }
        }
        face
    }

    /// The faces: loops, labels and areas.
    fn faces(&self, pts: &[DVec2], edges: &[(u32, u32, Tags)]) -> Vec<Face> {
        if edges.is_empty() {
            return Vec::new();
        }
        let (cycles, cyc) = self.cycles(edges);
        let face = self.assign(pts, edges, &cycles, &cyc);
        // Face of each half-edge (faces are numbered by their
        // counter-clockwise cycle; `nc` is the unbounded face).
        let nc = cycles.len() as u32;
        let fof = |h: u32| {
            let f = face[cyc[h as usize] as usize];
            if f == u32::MAX { nc } else { f }
        };
        // Labels: breadth-first from the unbounded face.
        let mut adj: Vec<Vec<(u32, u32)>> = vec![Vec::new(); cycles.len() + 1];
        for (k, _) in edges.iter().enumerate() {
            let (f0, f1) = (fof(2 * k as u32), fof(2 * k as u32 + 1));
            if f0 != f1 {
                adj[f0 as usize].push((f1, k as u32));
                adj[f1 as usize].push((f0, k as u32));
            }
        }
        let mut label: Vec<Option<Vec<u32>>> = vec![None; cycles.len() + 1];
        label[nc as usize] = Some(Vec::new());
        let mut queue = std::collections::VecDeque::from([nc]);
        while let Some(f) = queue.pop_front() {
            let here = label[f as usize].clone().unwrap_or_default();
            let mut list = std::mem::take(&mut adj[f as usize]);
            list.sort_unstable();
            for (g, e) in list {
                if label[g as usize].is_some() {
                    continue;
                }
                let mut t = Tags {
                    toggles: here.clone(),
                    cut: false,
                };
                t.add(&edges[e as usize].2);
                label[g as usize] = Some(t.toggles);
                queue.push_back(g);
            }
        }
        // Loops of each bounded face: its half-edges, less those whose twin
        // is on the same face (a cut that separates nothing), traced again.
        // Cycles of each face, and whether it has half-edges whose twin is
        // on the same face (then its loops are traced again without them).
        let mut face_cycles: Vec<Vec<u32>> = vec![Vec::new(); cycles.len() + 1];
        let mut bridged = vec![false; cycles.len() + 1];
        for (k, c) in cycles.iter().enumerate() {
            let f = fof(c[0]);
            if f == nc {
                continue;
            }
            face_cycles[f as usize].push(k as u32);
            if c.iter().any(|&h| fof(h ^ 1) == f) {
                bridged[f as usize] = true;
            }
        }
        let mut out = Vec::new();
        for f in 0..cycles.len() {
            if face_cycles[f].is_empty() {
                continue;
            }
            let loops = if bridged[f] {
                let hs: Vec<u32> = face_cycles[f]
                    .iter()
                    .flat_map(|&k| cycles[k as usize].iter().copied())
                    .filter(|&h| fof(h ^ 1) != f as u32)
                    .collect();
                trace(pts, edges, &hs)
            } else {
                let mut loops = Vec::new();
                for &k in &face_cycles[f] {
                    let seq: Vec<u32> = cycles[k as usize]
                        .iter()
                        .map(|&h| Graph::origin(edges, h))
                        .collect();
                    split_repeats(seq, &mut loops);
                }
                order_loops(pts, &mut loops);
                loops
            };
            if loops.is_empty() {
                continue;
            }
            let area: f64 = loops
                .iter()
                .map(|l| {
                    crate::polygon::signed_area_2d(
                        &l.iter().map(|&v| pts[v as usize]).collect::<Vec<_>>(),
                    )
                })
                .sum();
            if area <= 0.0 {
                continue;
            }
            out.push(Face {
                loops,
                label: label[f].clone().unwrap_or_default(),
                area,
            });
        }
        out
    }

    /// A cut that does not separate faces (the same bounded face on both
    /// sides): preferably a free end of one, with the direction to extend
    /// in. `None` when every cut separates.
    fn first_loose_cut(&self, pts: &[DVec2], edges: &[(u32, u32, Tags)]) -> Option<Loose> {
        let (cycles, cyc) = self.cycles(edges);
        let face = self.assign(pts, edges, &cycles, &cyc);
        let fof = |h: u32| face[cyc[h as usize] as usize];
        let deg = |v: u32| self.degree(v);
        let mut bridge = None;
        for (k, e) in edges.iter().enumerate() {
            if !e.2.cut || !e.2.toggles.is_empty() {
                continue;
            }
            let h = 2 * k as u32;
            if fof(h) != fof(h + 1) || fof(h) == u32::MAX {
                continue;
            }
            let (a, b) = (e.0, e.1);
            for (from, other) in [(b, a), (a, b)] {
                if deg(from) == 1 {
                    let d = pts[from as usize] - pts[other as usize];
                    if d.length_squared() > 0.0 {
                        return Some(Loose::End(from, d.normalize()));
                    }
                }
            }
            if bridge.is_none() {
                bridge = Some(Loose::Bridge(a, b));
            }
        }
        bridge
    }

    /// The first point where the ray from point `from` along `dir` meets an
    /// edge not incident to `from`.
    fn shoot(
        &self,
        pts: &[DVec2],
        edges: &[(u32, u32, Tags)],
        from: u32,
        dir: DVec2,
    ) -> Option<DVec2> {
        let o = pts[from as usize];
        let mut best: Option<(f64, DVec2)> = None;
        for e in edges {
            if e.0 == from || e.1 == from {
                continue;
            }
            let (a, b) = (pts[e.0 as usize], pts[e.1 as usize]);
            let s = b - a;
            let den = dir.perp_dot(s);
            if den == 0.0 {
                continue;
            }
            let t = (a - o).perp_dot(s) / den;
            let u = (a - o).perp_dot(dir) / den;
            if t > 0.0 && (0.0..=1.0).contains(&u) && best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, a + s * u));
            }
        }
        best.map(|b| b.1)
    }
}

/// A cut that separates nothing.
enum Loose {
    /// Its free end and the direction away from the cut.
    End(u32, DVec2),
    /// Both ends are on other edges (from the boundary to a hole).
    Bridge(u32, u32),
}

/// Exact comparison of the directions o→a and o→b by angle from +x,
/// counter-clockwise, in [0, 2π).
fn angle_cmp(o: DVec2, a: DVec2, b: DVec2) -> std::cmp::Ordering {
    use std::cmp::Ordering;
    let half = |p: DVec2| {
        let d = p - o;
        // Upper half (angle in [0, π)) is 0, lower half 1.
        if d.y > 0.0 || (d.y == 0.0 && d.x > 0.0) {
            0
        } else {
            1
        }
    };
    let (ha, hb) = (half(a), half(b));
    if ha != hb {
        return ha.cmp(&hb);
    }
    match orient2d(o, a, b) {
        1 => Ordering::Less,
        -1 => Ordering::Greater,
        _ => Ordering::Equal,
    }
}

/// Traces half-edges of one face into loops, turning at each point the way
/// the face's boundary does, and splits loops where they revisit a point.
fn trace(pts: &[DVec2], edges: &[(u32, u32, Tags)], hs: &[u32]) -> Vec<Vec<u32>> {
    // Outgoing half-edges of this face per point, sorted by angle.
    let mut out: FxHashMap<u32, Vec<u32>> = FxHashMap::default();
    for &h in hs {
        out.entry(Graph::origin(edges, h)).or_default().push(h);
    }
    for (v, list) in out.iter_mut() {
        let o = pts[*v as usize];
        list.sort_by(|&x, &y| {
            let a = pts[Graph::dest(edges, x) as usize];
            let b = pts[Graph::dest(edges, y) as usize];
            angle_cmp(o, a, b).then(x.cmp(&y))
        });
    }
    let mut used: FxHashMap<u32, bool> = hs.iter().map(|&h| (h, false)).collect();
    let mut sorted: Vec<u32> = hs.to_vec();
    sorted.sort_unstable();
    let mut loops: Vec<Vec<u32>> = Vec::new();
    for &s in &sorted {
        if used[&s] {
            continue;
        }
        let mut seq: Vec<u32> = Vec::new();
        let mut h = s;
        let limit = hs.len() + 1;
        loop {
            used.insert(h, true);
            seq.push(Graph::origin(edges, h));
            // At the destination: among this face's outgoing half-edges,
            // the first one clockwise from the twin of h.
            let v = Graph::dest(edges, h);
            let Some(list) = out.get(&v) else { break };
            let back = pts[Graph::origin(edges, h) as usize];
            let o = pts[v as usize];
            // Candidates unused; choose the one just clockwise of `back`.
            let mut best: Option<u32> = None;
            for &c in list {
                if used[&c] && c != s {
                    continue;
                }
                let cand = pts[Graph::dest(edges, c) as usize];
                best = Some(match best {
                    None => c,
                    Some(b) => {
                        let bp = pts[Graph::dest(edges, b) as usize];
                        // Clockwise angle from `back` to the candidate: smaller is better.
                        if cw_before(o, back, cand, bp) { c } else { b }
                    }
                });
            }
            match best {
                Some(n) if n == s => break,
                Some(n) => h = n,
                None => break,
            }
            if seq.len() > limit {
                break;
            }
        }
        // Split where the loop revisits a point.
        split_repeats(seq, &mut loops);
    }
    order_loops(pts, &mut loops);
    loops
}

/// Drops loops without area and puts the outer loop (the largest positive
/// area) first, the others keeping their order.
fn order_loops(pts: &[DVec2], loops: &mut Vec<Vec<u32>>) {
    let area = |l: &Vec<u32>| {
        crate::polygon::signed_area_2d(&l.iter().map(|&v| pts[v as usize]).collect::<Vec<_>>())
    };
    loops.retain(|l| l.len() >= 3 && area(l) != 0.0);
    if let Some((k, _)) = loops
        .iter()
        .enumerate()
        .filter(|(_, l)| area(l) > 0.0)
        .max_by(|x, y| area(x.1).total_cmp(&area(y.1)).then(y.0.cmp(&x.0)))
    {
        let outer = loops.remove(k);
        loops.insert(0, outer);
    }
}

/// Whether, turning clockwise around `o` from the direction of `back`,
/// `a` comes strictly before `b` (the direction of `back` itself comes
/// last): the larger counter-clockwise angle from `back` wins.
fn cw_before(o: DVec2, back: DVec2, a: DVec2, b: DVec2) -> bool {
    ccw_cmp(o, back, a, b) == std::cmp::Ordering::Greater
}

/// Compares the counter-clockwise angles from `back` of o→a and o→b.
fn ccw_cmp(o: DVec2, back: DVec2, a: DVec2, b: DVec2) -> std::cmp::Ordering {
    // Rotate the frame so that `back` is at angle 0: the half test relative to back.
    use std::cmp::Ordering;
    let half = |x: DVec2| {
        let s = orient2d(o, back, x);
        let d = (back - o).dot(x - o);
        if s > 0 || (s == 0 && d > 0.0) { 0 } else { 1 }
    };
    let (ha, hb) = (half(a), half(b));
    if ha != hb {
        return ha.cmp(&hb);
    }
    match orient2d(o, a, b) {
        1 => Ordering::Less,
        -1 => Ordering::Greater,
        _ => Ordering::Equal,
    }
}

/// Splits a closed sequence of points at every point it visits twice.
fn split_repeats(seq: Vec<u32>, loops: &mut Vec<Vec<u32>>) {
    let mut stack: Vec<u32> = Vec::with_capacity(seq.len());
    let mut pos: FxHashMap<u32, usize> = FxHashMap::default();
    for v in seq {
        if let Some(&i) = pos.get(&v) {
            // The part since the first visit is a loop of its own.
            let inner: Vec<u32> = stack.drain(i + 1..).collect();
            for w in &inner {
                pos.remove(w);
            }
            let mut l = vec![v];
            l.extend(inner);
            if l.len() >= 3 {
                loops.push(l);
            }
        } else {
            pos.insert(v, stack.len());
            stack.push(v);
        }
    }
    if stack.len() >= 3 {
        loops.push(stack);
    }
}

#[cfg(test)]
mod tests;
