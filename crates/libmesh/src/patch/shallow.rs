//! Shallow contacts: patches that lie in another face's plane near the line
//! where the two meet at a small angle.
//!
//! Two faces meeting along a line at an angle θ under the coplanar tests'
//! 25.8° (a globe's cap facet against the ceiling it passes through at
//! 12–15°, a table top on a desk at 3.6°) lie within 2 epsilon of each
//! other's plane over a band 2·eps / sin θ wide along that line. As wholes
//! they are not coplanar (their far vertices are farther), so the chain's
//! output has no defect there; but a patch lying wholly in the band is
//! coplanar with the other face and overlaps its patches, which `ugcheck`
//! reports. The mesher makes such patches where the face is finely divided
//! at the line (the ceiling around a globe's hole of 20 edges 3.4 epsilon
//! long: triangles of that size).
//!
//! After meshing, the patches of faces in such a contact are paired as the
//! check pairs them. Where a patch lies in the other's plane and overlaps
//! it, the points the mesher put inside its face that lie in that plane
//! there (and those reached from them through their patches that also
//! do) are taken out, and the region their patches cover is triangulated
//! again without them (constrained Delaunay, its boundary kept): the new
//! triangles reach out of the band. Where no point can go, one is moved
//! out of the band within its star ([`relocate`]), or else a side of a
//! triangle is flipped with the triangle of its face across it. Each is
//! kept only where it leaves fewer such pairs and no triangle narrower than
//! epsilon. The face's boundary and area stay, and a point inside a face
//! is no other face's, so no T-vertex can appear. (Found with property
//! seeds at 1 mm: globe caps under ceilings, a table top on a desk, a
//! table leg against a column at 0.4°; docs/decisions.md.)

use check::PairKind;
use geom::intersect::{COPLANAR_COS, COPLANAR_EPSILONS, FaceGeom};
use geom::{BoxIndex, DVec2, DVec3};
use rustc_hash::FxHashMap;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
use ug::{Model, VertexId};

/// Rounds of repairs at most (each looks at every pair left).
const ROUNDS: usize = 4;

/// What [`repair`] did.
#[derive(Clone, Debug, Default)]
pub struct Shallow {
    /// Diagonals flipped.
    pub flips: usize,
    /// Points inside faces taken out.
    pub removed: usize,
    /// Points inside faces moved out of a band (where none could go).
    pub moved: usize,
}

/// The faces (by index into `m.faces`) in a shallow contact with another:
/// planes within the coplanar tests' angle, not coplanar as wholes, and a
/// vertex of one within the check's coplanar distance of the other's
/// plane, inside its box.
fn in_contact(m: &Model, eps: f64) -> Vec<bool> {
    use rayon::prelude::*;
    let tol = COPLANAR_EPSILONS * eps;
    // Per top-level face: its points, its plane (as the check fits it)
    // and its box.
    struct Flat {
        pts: Vec<DVec3>,
        plane: geom::Plane,
        lo: DVec3,
        hi: DVec3,
    }
    let top: Vec<usize> = m.top_faces().map(|f| f.idx()).collect();
    let flats: Vec<Option<Flat>> = top
        .par_iter()
        .map(|&k| {
            let f = &m.faces[k];
            let plane = geom::Plane::fit(
                &f.contours
                    .first()?
                    .iter()
                    .map(|&v| m.pos(v))
                    .collect::<Vec<_>>(),
            )?;
            let pts: Vec<DVec3> = f.contours.iter().flatten().map(|&v| m.pos(v)).collect();
            let (lo, hi) = geom::index::bbox(pts.iter().copied(), 0.0);
            Some(Flat { pts, plane, lo, hi })
        })
        .collect();
    let index = BoxIndex::new(flats.iter().enumerate().filter_map(|(i, f)| {
        let f = f.as_ref()?;
        Some((f.lo - DVec3::splat(tol), f.hi + DVec3::splat(tol), i as u32))
    }));
    let within = |g: &Flat, o: &Flat| g.pts.iter().all(|&p| o.plane.dist(p).abs() <= tol);
    let touches = |g: &Flat, o: &Flat| {
        let (lo, hi) = (o.lo - DVec3::splat(tol), o.hi + DVec3::splat(tol));
        g.pts
            .iter()
            .any(|&p| o.plane.dist(p).abs() <= tol && p.cmpge(lo).all() && p.cmple(hi).all())
    };
    let pairs: Vec<(u32, u32)> = (0..flats.len())
        .into_par_iter()
        .flat_map_iter(|a| {
            let mut found = Vec::new();
            if let Some(fa) = flats[a].as_ref() {
                let (lo, hi) = (fa.lo - DVec3::splat(tol), fa.hi + DVec3::splat(tol));
                for b in index.query(lo, hi) {
                    let b = b as usize;
                    let Some(fb) = flats[b].as_ref().filter(|_| b > a) else {
                        continue;
                    };
                    // Planes within the angle, not coplanar as wholes (the
                    // check's test), and touching.
                    if fa.plane.n.dot(fb.plane.n).abs() < COPLANAR_COS
                        || within(fa, fb)
                        || within(fb, fa)
                    {
                        continue;
                    }
                    if touches(fa, fb) || touches(fb, fa) {
                        found.push((a as u32, b as u32));
                    }
                }
            }
            found
        })
        .collect();
    let mut marked = vec![false; m.faces.len()];
    for (a, b) in pairs {
        marked[top[a as usize]] = true;
        marked[top[b as usize]] = true;
    }
    marked
}

fn geom_of(out: &Model, k: usize) -> Option<FaceGeom> {
    check::face_geom(out, ug::FaceId(k as u32), None)
}

/// Whether the pair is one the check reports (overlapping or coincident).
fn bad(ga: &FaceGeom, gb: &FaceGeom, eps: f64) -> bool {
    geom::intersect::coplanar(ga, gb, eps)
        && matches!(
            check::coplanar_kind(ga, gb, eps),
            Some(PairKind::Overlap(_) | PairKind::Coincident)
        )
}

/// What the repair keeps of the patches: per output face its geometry
/// (faces in a contact only), whether it is gone, and per vertex the live
/// patches at it.
struct State<'a> {
    /// The meshed model (its vertices come first in `out`'s).
    m: &'a Model,
    out: &'a mut Model,
    /// Per patch, the face of the meshed model it was made from (patches
    /// added by the repairs too).
    parent: Vec<u32>,
    /// Patches added, each after the patch (of its face) it follows.
    added: Vec<(usize, usize)>,
    /// The patches' names, made when a patch is first added.
    names: Option<rustc_hash::FxHashSet<String>>,
    geoms: Vec<Option<FaceGeom>>,
    gone: Vec<bool>,
    at: FxHashMap<VertexId, Vec<usize>>,
    index: BoxIndex,
    /// Slots whose patch the repairs replaced (and per slot whether so).
    changed: Vec<usize>,
    moved: Vec<bool>,
    eps: f64,
}

impl State<'_> {
    /// The patches whose box comes within the coplanar distance of `g`'s:
    /// the index's (boxes as meshed), and those the repairs changed since
    /// (a slot's new triangle may lie elsewhere in its region).
    fn near(&self, g: &FaceGeom) -> Vec<usize> {
        let tol = COPLANAR_EPSILONS * self.eps;
        let (lo, hi) = geom::index::bbox(g.contours.iter().flatten().copied(), tol);
        let mut found: Vec<usize> = self
            .index
            .query(lo, hi)
            .into_iter()
            .map(|j| j as usize)
            .collect();
        for &k in &self.changed {
            if let Some(gk) = self.geoms[k].as_ref() {
                let (a, b) = gk.bounds();
                if a.cmple(hi).all() && b.cmpge(lo).all() && !found.contains(&k) {
                    found.push(k);
                }
            }
        }
        found
    }

    /// The bad pairs face `k`'s patch would be in with shape `g`, with
    /// the live patches of other faces.
    fn bad_count(&self, k: usize, g: &FaceGeom) -> usize {
        self.near(g)
            .into_iter()
            .filter(|&j| !self.gone[j] && self.parent[j] != self.parent[k])
            .filter(|&j| {
                self.geoms[j]
                    .as_ref()
                    .is_some_and(|gj| bad(g, gj, self.eps))
            })
            .count()
    }

    fn geom(&self, t: &[VertexId]) -> Option<FaceGeom> {
        FaceGeom::new(vec![t.iter().map(|&v| self.out.pos(v)).collect()])
    }

    fn width_ok(&self, frame: &geom::Frame, t: &[VertexId; 3]) -> bool {
        let p = t.map(|v| frame.to_2d(self.out.pos(v)));
        super::width(p, self.eps) > self.eps
    }

    /// A new patch of face `face` after patch `after`: its slot.
    fn add(&mut self, face: u32, after: usize, t: [VertexId; 3]) -> usize {
        let names = self.names.get_or_insert_with(|| {
            self.out
                .faces
                .iter()
                .filter_map(|f| f.name.clone())
                .collect()
        });
        let name = self.m.faces[face as usize].name.as_ref().map(|b| {
            (1..)
                .map(|k| format!("{b}.{k}"))
                .find(|n| !names.contains(n))
                .expect("a free name")
        });
        if let Some(n) = &name {
            names.insert(n.clone());
        }
        let material = self.out.faces[after].material;
        let k = self.out.faces.len();
        self.out.faces.push(ug::Face {
            name,
            contours: vec![t.to_vec()],
            material,
        });
        self.parent.push(face);
        self.gone.push(false);
        self.moved.push(false);
        self.geoms.push(None);
        self.added.push((after, k));
        k
    }

    /// Replaces patches `old` (of one face) by triangles `new`, the first
    /// taking the first's place, and so on; more triangles than patches
    /// are added after the first.
    fn replace(&mut self, old: &[usize], new: &[[VertexId; 3]]) {
        for &k in old {
            for &v in &self.out.faces[k].contours[0] {
                if let Some(list) = self.at.get_mut(&v) {
                    list.retain(|&x| x != k);
                }
            }
        }
        for (i, &k) in old.iter().enumerate() {
            match new.get(i) {
                Some(t) => {
                    self.out.faces[k].contours = vec![t.to_vec()];
                    for &v in t {
                        self.at.entry(v).or_default().push(k);
                    }
                    self.geoms[k] = geom_of(self.out, k);
                    self.mark_moved(k);
                }
                None => {
                    self.gone[k] = true;
                    self.geoms[k] = None;
                }
            }
        }
        for t in new.iter().skip(old.len()) {
            let k = self.add(self.parent[old[0]], old[0], *t);
            for &v in t {
                self.at.entry(v).or_default().push(k);
            }
            self.geoms[k] = geom_of(self.out, k);
            self.mark_moved(k);
        }
    }

    fn mark_moved(&mut self, k: usize) {
        if !self.moved[k] {
            self.moved[k] = true;
            self.changed.push(k);
        }
    }

    /// The live triangle of the same face as `p` across its side a–b.
    fn across(&self, p: usize, a: VertexId, b: VertexId) -> Option<usize> {
        self.at.get(&a)?.iter().copied().find(|&q| {
            q != p && self.parent[q] == self.parent[p] && !self.gone[q] && {
                let c = &self.out.faces[q].contours[0];
                c.len() == 3 && (0..3).any(|i| c[i] == b && c[(i + 1) % 3] == a)
            }
        })
    }

    /// Vertex `v`'s patches when it lies inside their face, in order
    /// around it, with the polygon they make (their corners but `v`);
    /// `None` where `v` is on the face's boundary or not the mesher's.
    fn star(&self, v: VertexId, face: u32) -> Option<(Vec<usize>, Vec<VertexId>)> {
        if v.idx() < self.m.vertices.len() {
            return None;
        }
        let around = self.at.get(&v)?;
        if around
            .iter()
            .any(|&k| self.parent[k] != face || self.out.faces[k].contours.len() != 1)
        {
            return None;
        }
        // Each patch's corners after v, in its order: a chain from the
        // corner after v to the one before.
        let chain = |k: usize| -> Vec<VertexId> {
            let c = &self.out.faces[k].contours[0];
            let i = c.iter().position(|&x| x == v).expect("at v");
            (1..c.len()).map(|j| c[(i + j) % c.len()]).collect()
        };
        let first = *around.first()?;
        let mut order = vec![first];
        let mut poly: Vec<VertexId> = Vec::new();
        let mut k = first;
        loop {
            let ch = chain(k);
            poly.extend_from_slice(&ch[..ch.len() - 1]);
            let end = *ch.last()?;
            // The next patch starts where this one ends.
            let next = around
                .iter()
                .copied()
                .find(|&j| j != k && chain(j).first() == Some(&end))?;
            if next == first {
                break;
            }
            if order.contains(&next) || order.len() > around.len() {
                return None;
            }
            order.push(next);
            k = next;
        }
        (order.len() == around.len()).then_some((order, poly))
    }
}

/// Flips diagonals and takes out points inside faces of `out` (the
/// patches of `m`, each made from face `parent[k]` of `m`) so that fewer
/// patches of faces in a shallow contact overlap the other face's (see
/// the module documentation). Faces marked `twinned` (whose patches
/// another face copies, or that copy another's) are left alone: the copies
/// must stay the same. Patches taken out are dropped from `out`, and so
/// are the points.
pub(super) fn repair(
    m: &Model,
    out: &mut Model,
    parent: &[u32],
    twinned: &[bool],
    eps: f64,
) -> Shallow {
    let mut st = Shallow::default();
    if !out.defs.is_empty() {
        return st; // (a flat model has none; patches are renumbered below)
    }
    let contact = in_contact(m, eps);
    if !contact.iter().any(|&c| c) {
        return st;
    }
    let tol = COPLANAR_EPSILONS * eps;
    let n = out.faces.len();
    let live: Vec<bool> = (0..n)
        .map(|k| contact[parent[k] as usize] && !twinned[parent[k] as usize])
        .collect();
    let geoms: Vec<Option<FaceGeom>> = (0..n)
        .map(|k| if live[k] { geom_of(out, k) } else { None })
        .collect();
    // Boxes of the patches as meshed: the repairs keep new triangles
    // inside the union of the patches they replace, so a query with a new
    // triangle's box finds every patch near it.
    let index = BoxIndex::new((0..n).filter_map(|k| {
        let g = geoms[k].as_ref()?;
        let (lo, hi) = geom::index::bbox(g.contours.iter().flatten().copied(), tol);
        Some((lo, hi, k as u32))
    }));
    let mut at: FxHashMap<VertexId, Vec<usize>> = FxHashMap::default();
    for k in (0..n).filter(|&k| live[k]) {
        for &v in out.faces[k].contours.iter().flatten() {
            at.entry(v).or_default().push(k);
        }
    }
    let mut s = State {
        m,
        out,
        parent: parent.to_vec(),
        added: Vec::new(),
        names: None,
        geoms,
        gone: vec![false; n],
        at,
        index,
        changed: Vec::new(),
        moved: vec![false; n],
        eps,
    };
    let mut removed: Vec<VertexId> = Vec::new();
    for _ in 0..ROUNDS {
        // The bad pairs now, in order.
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        for k in 0..s.geoms.len() {
            let Some(g) = s.geoms[k].as_ref() else {
                continue;
            };
            for j in s.near(g) {
                if j > k
                    && s.parent[j] != s.parent[k]
                    && s.geoms[j].as_ref().is_some_and(|gj| bad(g, gj, eps))
                {
                    pairs.push((k, j));
                }
            }
        }
        let mut changed = false;
        for (a, b) in pairs {
            for (p, o) in [(a, b), (b, a)] {
                let in_band = match (s.geoms[p].as_ref(), s.geoms[o].as_ref()) {
                    (Some(gp), Some(go)) if !s.gone[p] && !s.gone[o] => {
                        gp.contours[0]
                            .iter()
                            .all(|&x| go.plane.dist(x).abs() <= tol)
                            && bad(gp, go, eps)
                    }
                    _ => false,
                };
                if !in_band {
                    continue;
                }
                if let Some(vs) = remesh(&mut s, p, o) {
                    st.removed += vs.len();
                    removed.extend(vs);
                    changed = true;
                    break;
                }
                if relocate(&mut s, p, o) {
                    st.moved += 1;
                    changed = true;
                    break;
                }
                if s.out.faces[p].contours[0].len() == 3 && flip(&mut s, p) {
                    st.flips += 1;
                    changed = true;
                    break;
                }
            }
        }
        if !changed {
            break;
        }
    }
    // Drop the patches and points taken out; put the patches added after
    // those they follow (their points are all defined before).
    if !removed.is_empty() || !s.added.is_empty() || s.gone.iter().any(|&g| g) {
        let gone = std::mem::take(&mut s.gone);
        let mut after: FxHashMap<usize, Vec<usize>> = FxHashMap::default();
        for &(a, k) in &s.added {
            after.entry(a).or_default().push(k);
        }
        let out = &mut *s.out;
        let total = out.faces.len();
        let removed: rustc_hash::FxHashSet<VertexId> = removed.into_iter().collect();
        // The statements in order, each face by its old slot.
        let mut items = Vec::with_capacity(out.items.len() + s.added.len());
        for it in std::mem::take(&mut out.items) {
            match it {
                ug::Item::Face(f) => {
                    items.push(ug::Item::Face(f));
                    for &k in after.get(&f.idx()).map_or(&[][..], |v| v.as_slice()) {
                        items.push(ug::Item::Face(ug::FaceId(k as u32)));
                    }
                }
                ug::Item::Vertex(v) if removed.contains(&v) => {}
                other => items.push(other),
            }
        }
        // Faces renumbered in statement order, the gone left out.
        let mut new_id = vec![u32::MAX; total];
        let mut old_faces: Vec<Option<ug::Face>> = std::mem::take(&mut out.faces)
            .into_iter()
            .map(Some)
            .collect();
        let mut faces = Vec::with_capacity(total);
        for it in &items {
            if let ug::Item::Face(f) = it
                && !gone[f.idx()]
                && new_id[f.idx()] == u32::MAX
            {
                new_id[f.idx()] = faces.len() as u32;
                faces.push(old_faces[f.idx()].take().expect("each face once"));
            }
        }
        // (Faces not in the statements: none in a mesher's output.)
        for (k, f) in old_faces.into_iter().enumerate() {
            if let Some(f) = f
                && !gone[k]
            {
                new_id[k] = faces.len() as u32;
                faces.push(f);
            }
        }
        out.faces = faces;
        items.retain_mut(|it| match it {
            ug::Item::Face(f) => {
                let id = new_id[f.idx()];
                *f = ug::FaceId(id);
                id != u32::MAX
            }
            _ => true,
        });
        out.items = items;
    }
    st
}

/// Takes out the points the mesher put inside patch `p`'s face that lie
/// in the plane of patch `o` (of the face in contact) at `p` and around
/// it, and triangulates the region their patches cover again without
/// them (constrained Delaunay), where that leaves fewer bad pairs and no
/// triangle narrower than epsilon. The points taken out, if any.
fn remesh(s: &mut State<'_>, p: usize, o: usize) -> Option<Vec<VertexId>> {
    let face = s.parent[p];
    let plane = s.geoms[o].as_ref()?.plane;
    let tol = COPLANAR_EPSILONS * s.eps;
    let mut gone_pts: Vec<VertexId> = Vec::new();
    let mut region: Vec<usize> = Vec::new();
    let mut todo: Vec<VertexId> = s.out.faces[p].contours[0].clone();
    let mut looked: rustc_hash::FxHashSet<VertexId> = Default::default();
    while let Some(v) = todo.pop() {
        if !looked.insert(v) || region.len() > 64 {
            continue;
        }
        if plane.dist(s.out.pos(v)).abs() > tol {
            continue;
        }
        let Some((star, _)) = s.star(v, face) else {
            continue;
        };
        gone_pts.push(v);
        for k in star {
            if !region.contains(&k) {
                region.push(k);
                todo.extend(s.out.faces[k].contours[0].iter().copied());
            }
        }
    }
    if gone_pts.is_empty() {
        return None;
    }
    region.sort_unstable();
    // The frame of the region's largest patch (a small one's plane is
    // tilted by its points' wander within epsilon).
    let frame = region
        .iter()
        .filter_map(|&k| s.geoms[k].as_ref())
        .map(|g| (geom::signed_area_2d(&g.contours_2d[0]).abs(), g.frame))
        .max_by(|x, y| x.0.total_cmp(&y.0))?
        .1;
    // The region's boundary: sides of its patches not shared within it.
    let mut sides: rustc_hash::FxHashSet<(VertexId, VertexId)> = Default::default();
    for &k in &region {
        let c = &s.out.faces[k].contours[0];
        for i in 0..c.len() {
            sides.insert((c[i], c[(i + 1) % c.len()]));
        }
    }
    let boundary: Vec<(VertexId, VertexId)> = {
        let mut b: Vec<_> = sides
            .iter()
            .copied()
            .filter(|&(a, b)| !sides.contains(&(b, a)))
            .collect();
        b.sort_unstable();
        b
    };
    let mut keep: Vec<VertexId> = region
        .iter()
        .flat_map(|&k| s.out.faces[k].contours[0].iter().copied())
        .filter(|v| !gone_pts.contains(v))
        .collect();
    keep.sort_unstable();
    keep.dedup();
    let to2 = |v: VertexId| frame.to_2d(s.out.pos(v));
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> =
        ConstrainedDelaunayTriangulation::new();
    let mut handle: FxHashMap<VertexId, spade::handles::FixedVertexHandle> = FxHashMap::default();
    let mut ids: Vec<VertexId> = Vec::new();
    for &v in &keep {
        let q = to2(v);
        let h = cdt.insert(Point2::new(q.x, q.y)).ok()?;
        if h.index() != ids.len() {
            return None; // two points at one position
        }
        ids.push(v);
        handle.insert(v, h);
    }
    for &(a, b) in &boundary {
        let (ha, hb) = (*handle.get(&a)?, *handle.get(&b)?);
        if ha == hb || !cdt.can_add_constraint(ha, hb) {
            return None;
        }
        cdt.add_constraint(ha, hb);
    }
    // The region's patches in the frame, and their turn there.
    let polys: Vec<Vec<DVec2>> = region
        .iter()
        .map(|&k| s.out.faces[k].contours[0].iter().map(|&v| to2(v)).collect())
        .collect();
    let signed = |q: &[DVec2]| geom::signed_area_2d(q);
    let sign = signed(&polys[0]).signum();
    let inside = |c: DVec2| {
        polys.iter().any(|q| {
            (0..q.len()).all(|i| (q[(i + 1) % q.len()] - q[i]).perp_dot(c - q[i]) * sign > 0.0)
        })
    };
    let mut tris: Vec<[VertexId; 3]> = Vec::new();
    for t in cdt.inner_faces() {
        let vs = t.vertices();
        let q = vs.map(|v| DVec2::new(v.position().x, v.position().y));
        if !inside((q[0] + q[1] + q[2]) / 3.0) {
            continue;
        }
        let mut t = vs.map(|v| ids[v.fix().index()]);
        if signed(&q) * sign < 0.0 {
            t.swap(1, 2);
        }
        if super::width(q, s.eps) <= s.eps {
            return None;
        }
        tris.push(t);
    }
    // The same area, or a triangle fell outside (or inside a hole).
    let area = |q: &[DVec2]| signed(q).abs();
    let before: f64 = polys.iter().map(|q| area(q)).sum();
    let after_area: f64 = tris.iter().map(|t| area(&t.map(to2))).sum();
    if (before - after_area).abs() > 1e-9 * before.max(s.eps * s.eps) {
        return None;
    }
    let now: usize = region
        .iter()
        .map(|&k| s.geoms[k].as_ref().map_or(0, |g| s.bad_count(k, g)))
        .sum();
    let mut after = 0;
    for t in &tris {
        after += s.bad_count(p, &s.geom(t)?);
    }
    if after >= now {
        return None;
    }
    s.replace(&region, &tris);
    for v in &gone_pts {
        s.at.remove(v);
    }
    Some(gone_pts)
}

/// Where no point of patch `p` in `o`'s band can be taken out (the
/// triangles without it would be narrower than epsilon: a foot 5 mm
/// along a notch's side that only the point reaches across), a point of
/// `p` inside its face, in the band, and all of whose patches are
/// triangles, moves towards the middle of its star (the mean of the
/// polygon round it; a whole, three quarters or half of the way), lifted
/// onto its face's plane: where the new place is out of the band, every
/// triangle of the star keeps its turn in the face's frame and is wider
/// than epsilon, and fewer of them are in pairs the check reports. The
/// star's outline stays, so the face's area does, and the point is no
/// other face's. (A ramp's sloped top meeting its flat bottom at 3.9° at
/// the toe, rounded to 1 mm: a refinement point 3.4 mm above the bottom's
/// plane, 5 cm from the toe, one overlapping pair after ugcut.)
fn relocate(s: &mut State<'_>, p: usize, o: usize) -> bool {
    let face = s.parent[p];
    let Some(plane) = s.geoms[o].as_ref().map(|g| g.plane) else {
        return false;
    };
    let Some(own) = geom_of(s.m, face as usize) else {
        return false;
    };
    let tol = COPLANAR_EPSILONS * s.eps;
    let corners = s.out.faces[p].contours[0].clone();
    for v in corners {
        let at = s.out.pos(v);
        if plane.dist(at).abs() > tol {
            continue;
        }
        let Some((star, poly)) = s.star(v, face) else {
            continue;
        };
        if star.iter().any(|&k| s.out.faces[k].contours[0].len() != 3) || poly.is_empty() {
            continue;
        }
        let before: usize = star
            .iter()
            .map(|&k| s.geoms[k].as_ref().map_or(0, |g| s.bad_count(k, g)))
            .sum();
        let to2 = |x: DVec3| own.frame.to_2d(x);
        let turn = |t: [DVec2; 3]| (t[1] - t[0]).perp_dot(t[2] - t[0]);
        let tri = |s: &State<'_>, k: usize, q: DVec3| -> [DVec2; 3] {
            let c = &s.out.faces[k].contours[0];
            [0, 1, 2].map(|i| to2(if c[i] == v { q } else { s.out.pos(c[i]) }))
        };
        let mid = poly.iter().map(|&u| s.out.pos(u)).sum::<DVec3>() / poly.len() as f64;
        for t in [1.0, 0.75, 0.5] {
            let q = at + (mid - at) * t;
            let q = q - own.plane.n * own.plane.dist(q);
            if plane.dist(q).abs() <= tol {
                continue;
            }
            let sound = star.iter().all(|&k| {
                let (old, new) = (tri(s, k, at), tri(s, k, q));
                turn(old) * turn(new) > 0.0 && super::width(new, s.eps) > s.eps
            });
            if !sound {
                continue;
            }
            let geoms: Vec<Option<FaceGeom>> = star
                .iter()
                .map(|&k| check::face_geom(s.out, ug::FaceId(k as u32), Some((v, q))))
                .collect();
            let after: usize = star
                .iter()
                .zip(&geoms)
                .map(|(&k, g)| g.as_ref().map_or(0, |g| s.bad_count(k, g)))
                .sum();
            if after >= before {
                continue;
            }
            s.out.vertices[v.idx()].pos = q;
            for (&k, g) in star.iter().zip(geoms) {
                s.geoms[k] = g;
                s.mark_moved(k);
            }
            return true;
        }
    }
    false
}

/// Flips the side of triangle `p` whose flip (with the triangle of the
/// same face across it) leaves the fewest bad pairs, if that is fewer
/// than now.
fn flip(s: &mut State<'_>, p: usize) -> bool {
    let c = s.out.faces[p].contours[0].clone();
    let Some(frame) = s.geoms[p].as_ref().map(|g| g.frame) else {
        return false;
    };
    let to2 = |v: VertexId| -> DVec2 { frame.to_2d(s.out.pos(v)) };
    let turn = |t: &[VertexId; 3]| {
        let (a, b, c) = (to2(t[0]), to2(t[1]), to2(t[2]));
        (b - a).perp_dot(c - a)
    };
    let mut best: Option<(usize, usize, [VertexId; 3], [VertexId; 3])> = None;
    for i in 0..3 {
        let (x, y, z) = (c[i], c[(i + 1) % 3], c[(i + 2) % 3]);
        // Side y–z, with q = (z, y, w) across it.
        let Some(q) = s.across(p, y, z) else {
            continue;
        };
        let Some(w) = s.out.faces[q].contours[0]
            .iter()
            .copied()
            .find(|&v| v != y && v != z)
        else {
            continue;
        };
        if w == x {
            continue;
        }
        let (t1, t2) = ([x, y, w], [x, w, z]);
        let sign = turn(&[x, y, z]).signum();
        if turn(&t1) * sign <= 0.0
            || turn(&t2) * sign <= 0.0
            || !s.width_ok(&frame, &t1)
            || !s.width_ok(&frame, &t2)
        {
            continue;
        }
        let now = [p, q]
            .iter()
            .map(|&k| s.geoms[k].as_ref().map_or(0, |g| s.bad_count(k, g)))
            .sum::<usize>();
        let (Some(g1), Some(g2)) = (s.geom(&t1), s.geom(&t2)) else {
            continue;
        };
        let after = s.bad_count(p, &g1) + s.bad_count(q, &g2);
        if after < now && best.as_ref().is_none_or(|b| after < b.1) {
            best = Some((q, after, t1, t2));
        }
    }
    let Some((q, _, t1, t2)) = best else {
        return false;
    };
    s.replace(&[p, q], &[t1, t2]);
    true
}
