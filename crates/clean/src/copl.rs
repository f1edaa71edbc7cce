//! Coplanar face intersection (Smith 1991, §2.5).
//!
//! Faces that are coplanar (within epsilon, either orientation) and partly
//! overlap are cut in their plane so that every overlap region becomes a
//! face of its own in each face it belongs to. A face overlapped by faces
//! G₁…Gₖ is divided by all their contours at once: its contours (tag 0) and
//! theirs (tags 1…k) go into a snap-rounded arrangement ([`geom::arrange`]),
//! and each face of the arrangement inside it is a piece, labelled with the
//! set of Gᵢ that cover it (even-odd, decided topologically). The same
//! region comes out as a piece of every face it belongs to, on the same
//! vertices, so `ugclean` can drop one of each coincident pair.
//!
//! Faces count as coplanar here up to
//! [`geom::intersect::CLEAN_COPLANAR_EPSILONS`] (3) epsilon apart, more than
//! the 2 that `ugcheck` judges by: pieces of a face have fewer vertices than
//! the face, so a pair that is not coplanar as wholes may be after a cut.
//!
//! Piece corners within epsilon of an existing vertex reuse it (a
//! neighbour's vertex only when it lies within epsilon of this face's
//! plane: one further off would tilt the piece); new corners
//! (crossings of the faces' edges) are shared between all faces that find
//! them. Each piece keeps its face's material and orientation, is named
//! `NAME.c1`, `NAME.c2`, …, and is preceded by the origin annotation
//! `{ugcopl origin NAME area A}` (A is the area of the original face's
//! connected coplanar surface of its material), which `ugclean` reads to
//! remove the piece of the larger surface. Finally vertices within epsilon
//! are merged and the points where the cuts meet neighbouring faces' edges
//! are inserted into those edges, so no T-vertex is left.
//!
//! **Contact cuts.** A face is also cut along the outline of a parallel
//! face lying a small gap in front of it and strictly inside it (the gap
//! more than the coplanar tolerance and at most `contact` times the
//! covering face's size, √area): a lamp hung a hair below the ceiling, a
//! rug, a picture, papers on a desk. The part behind such a face sits in a
//! slit that light hardly reaches; unless the face is cut along the
//! covering face's outline its patches interpolate lit corners across the
//! dark part (the Cornell box's lamp hangs 0.1 mm below the ceiling: the
//! ceiling behind it came out lit where the reference is 0). Only a face
//! whose **front** faces the other is cut (what is behind a face's back is
//! never seen), in its own plane, with the covering face's contours
//! projected onto it as fresh points: the pieces stay planar and no vertex
//! is shared across the gap. A second cut follows the outline grown by ten
//! gaps ([`ring`]), so that the lit part's edge is lit. The cover must lie
//! strictly inside the face, so the cuts never touch the face's boundary
//! (no T-vertex for a neighbour). The pieces are ordinary `ugcopl` pieces,
//! not coincident with anything: `ugclean` keeps them.

use check::PairKind;
use geom::arrange::Tag;
use rayon::prelude::*;
use ug::{Item, Model};
use winged::pieces::{Layout, Point};

use crate::pieces::{Rebuild, face_geoms};

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub pairs: usize,
    pub faces_cut: usize,
    pub pieces: usize,
    pub new_vertices: usize,
    pub tvertices: usize,
    /// Contact pairs (a face and a parallel face a small gap in front of it).
    pub contacts: usize,
    /// Faces that the welding of new vertices (within epsilon) bent off
    /// their plane by more than epsilon, folded into triangles at the end.
    pub folded: usize,
    /// Rounds of cutting (pairs looked for again after each).
    pub rounds: usize,
    /// Pairs that the cuts in the plane made intersect, cut as `ugisect`
    /// cuts them.
    pub recut_pairs: usize,
}

/// The default contact ratio: a parallel face in front of another is a
/// contact cover when its gap is at most this fraction of its own size
/// (√area): 5.8 mm under the Cornell box's 130 × 105 mm lamp, 5 cm under
/// a 1 m light panel, 8 cm under a 3 m² rug. Under such a cover even the
/// middle sees the room only within about 6° of the plane: a slit, not a
/// shadow that the radiosity mesh would resolve by itself.
pub const DEFAULT_CONTACT: f64 = 0.05;

/// Cuts the coplanar overlapping faces of a flat model (no contact cuts).
pub fn copl(m: &Model, eps: f64) -> Result<(Model, Stats), ug::Diagnostic> {
    copl_contact(m, eps, 0.0)
}

/// The area of a face's projection on its own plane.
fn area_2d(g: &geom::intersect::FaceGeom) -> f64 {
    g.contours_2d
        .iter()
        .map(|c| geom::polygon::signed_area_2d(c))
        .sum::<f64>()
        .abs()
}

/// Most cosine between two faces' normals for a contact pair: within
/// about 2.6° of parallel (a lamp, rug or picture lies flat on its face).
const CONTACT_PARALLEL: f64 = 0.999;

/// A contact pair: the face to cut, the covering face's contours
/// projected into the cut face's frame, and that outline grown for the
/// second cut (when it fits).
struct Contact {
    k: usize,
    outline: Vec<Vec<geom::DVec2>>,
    grown: Option<Vec<geom::DVec2>>,
}

/// The contact pairs: a face `j` lying entirely in front of face `k`, more
/// than the coplanar tolerance and at most `ratio` × √(its area) from
/// `k`'s plane, the two nearly parallel, `j` strictly inside `k` in
/// projection. Face `k` is the one to cut. In face order, then `j`
/// ascending.
fn contact_pairs(
    geoms: &[Option<geom::intersect::FaceGeom>],
    eps: f64,
    ratio: f64,
) -> Vec<Contact> {
    let tol = geom::intersect::CLEAN_COPLANAR_EPSILONS * eps;
    if ratio <= 0.0 {
        return Vec::new();
    }
    let boxes: Vec<(geom::DVec3, geom::DVec3, u32)> = geoms
        .iter()
        .enumerate()
        .filter_map(|(k, g)| {
            g.as_ref().map(|g| {
                let (lo, hi) = g.bounds();
                (lo, hi, k as u32)
            })
        })
        .collect();
    let index = geom::index::BoxIndex::new(boxes.iter().copied());
    let size: Vec<f64> = geoms
        .iter()
        .map(|g| g.as_ref().map_or(0.0, |g| area_2d(g).sqrt()))
        .collect();
    let per: Vec<Vec<Contact>> = boxes
        .par_iter()
        .map(|&(lo, hi, k)| {
            let gk = geoms[k as usize]
                .as_ref()
                .expect("indexed faces have geometry");
            // A cover lies inside `k`, so its gap is at most ratio × √(k's area).
            let gap = ratio * size[k as usize];
            if gap <= tol {
                return Vec::new();
            }
            let pad = geom::DVec3::splat(gap);
            let mut out = Vec::new();
            for j in index.query(lo - pad, hi + pad) {
                if j == k {
                    continue;
                }
                let gj = geoms[j as usize]
                    .as_ref()
                    .expect("indexed faces have geometry");
                if gk.plane.n.dot(gj.plane.n).abs() < CONTACT_PARALLEL {
                    continue;
                }
                let mut far = 0.0f64;
                let in_gap = gj.contours.iter().flatten().all(|&p| {
                    let d = gk.plane.dist(p);
                    far = far.max(d);
                    d > tol && d <= gap
                });
                if !in_gap || far > ratio * size[j as usize] {
                    continue;
                }
                let outline: Vec<Vec<geom::DVec2>> = gj
                    .contours
                    .iter()
                    .map(|c| c.iter().map(|&p| gk.frame.to_2d(p)).collect())
                    .collect();
                if !inside_2d(gk, &outline, eps) {
                    continue;
                }
                let delta = RING_GAPS * far;
                let grown = (delta > 4.0 * eps)
                    .then(|| ring(&outline[0], delta))
                    .flatten()
                    .filter(|g| inside_2d(gk, std::slice::from_ref(g), eps));
                out.push(Contact {
                    k: k as usize,
                    outline,
                    grown,
                });
            }
            out
        })
        .collect();
    per.into_iter().flatten().collect()
}

/// Whether the polygon `j2` (in `k`'s frame) lies strictly inside `k`:
/// every vertex more than a few epsilons inside `k`, and no contour of `k`
/// reaching into it (no vertex of `k` in or on it, no edges touching).
/// Only then is `k` cut along it: the cut makes no vertex on `k`'s
/// boundary, so no neighbour gains a T-vertex and orientation across `k`'s
/// edges is untouched. A covering face that straddles `k`'s edge (a
/// cupboard across two wall pieces) is left alone.
fn inside_2d(gk: &geom::intersect::FaceGeom, j2: &[Vec<geom::DVec2>], eps: f64) -> bool {
    use geom::polygon::Location;
    let margin = 4.0 * eps;
    if !j2
        .iter()
        .flatten()
        .all(|&p| gk.locate_2d(p, margin) == Location::Inside)
    {
        return false;
    }
    let bbox = |pts: &mut dyn Iterator<Item = &geom::DVec2>| {
        let (lo, hi) = geom::index::bbox(pts.map(|p| p.extend(0.0)), margin);
        (lo.truncate(), hi.truncate())
    };
    let (jlo, jhi) = bbox(&mut j2.iter().flatten());
    for c in &gk.contours_2d {
        let (lo, hi) = bbox(&mut c.iter());
        if !(lo.cmple(jhi).all() && hi.cmpge(jlo).all()) {
            continue;
        }
        for i in 0..c.len() {
            let (a, bb) = (c[i], c[(i + 1) % c.len()]);
            if geom::intersect::locate_eps(a, j2, margin) != Location::Outside {
                return false;
            }
            for jc in j2 {
                for t in 0..jc.len() {
                    let (p, q) = (jc[t], jc[(t + 1) % jc.len()]);
                    if geom::predicates::segments_2d(a, bb, p, q)
                        != geom::predicates::SegmentContact::None
                    {
                        return false;
                    }
                }
            }
        }
    }
    true
}

/// How far outside a covering face's outline the second, outer cut goes,
/// in gaps (see [`ring`]).
const RING_GAPS: f64 = 10.0;

/// The outer contour of a convex covering face grown by `delta` (mitred
/// corners, in `k`'s frame), when that is well defined: the contour convex
/// and counter-clockwise or clockwise throughout, no corner sharper than
/// the miter limit. The cut along it separates the lit part of `k` from
/// the thin ring next to the outline: a point of `k` on the outline itself
/// sees the covering face edge-on over half its hemisphere and gets about
/// a quarter of the light a point a few gaps outside gets, so the patches
/// outside would interpolate that dark value over a whole element. On the
/// grown outline, `RING_GAPS` gaps out, the covering face hides only
/// directions within atan(1/10) ≈ 6° of the plane (under 1% of the light).
fn ring(outer: &[geom::DVec2], delta: f64) -> Option<Vec<geom::DVec2>> {
    let n = outer.len();
    if n < 3 {
        return None;
    }
    let area = geom::polygon::signed_area_2d(outer);
    if area == 0.0 {
        return None;
    }
    let sign = area.signum();
    // Outward normal of edge i (from i to i + 1).
    let normal = |i: usize| {
        let d = (outer[(i + 1) % n] - outer[i]).normalize_or_zero();
        geom::DVec2::new(d.y, -d.x) * sign
    };
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (a, b, c) = (outer[(i + n - 1) % n], outer[i], outer[(i + 1) % n]);
        // Convex at every corner (collinear corners allowed).
        if (b - a).perp_dot(c - b) * sign < 0.0 {
            return None;
        }
        let (n1, n2) = (normal((i + n - 1) % n), normal(i));
        let m = n1 + n2;
        let k = 1.0 + n1.dot(n2);
        if n1 == geom::DVec2::ZERO || n2 == geom::DVec2::ZERO || k < 0.125 {
            return None; // a sharp corner: the miter would reach far out
        }
        out.push(b + m * (delta / k));
    }
    Some(out)
}

/// Cuts the coplanar overlapping faces of a flat model, and cuts each face
/// along the outlines of the parallel faces lying in front of it at most
/// `contact` times their size (√area) away (see the module's "Contact
/// cuts"; 0: none).
///
/// Like `ugisect`, in rounds (at most [`MAX_ROUNDS`]; the later ones
/// without contact cuts) until a round finds no overlapping pair: welding
/// the new vertices (within `eps`) can bend a face off its plane, and it is
/// folded into triangles, which may overlap a face the bent one was not
/// found to overlap (a non-planar face takes part in no pair); and a cut
/// can leave a piece overlapping what the whole face did not. A later
/// round looks only at the pairs with a face that the round before did not
/// have as it is (same material, same points in the same order): two faces
/// it had were looked at then. On the 100k CAD building the first round
/// folds 7 faces and leaves 16 overlapping pairs, the second none.
pub fn copl_contact(m: &Model, eps: f64, contact: f64) -> Result<(Model, Stats), ug::Diagnostic> {
    let (mut out, mut stats) = copl_once(m, eps, contact, None)?;
    let mut rounds = 1;
    let mut last = stats.pairs + stats.contacts;
    // (Hashed only when a second round will look.)
    let mut before: rustc_hash::FxHashSet<u64> = if last > 0 {
        face_keys(m).into_iter().flatten().collect()
    } else {
        Default::default()
    };
    while last > 0 && rounds < MAX_ROUNDS {
        let now = face_keys(&out);
        let among: Vec<bool> = now
            .iter()
            .map(|k| k.is_none_or(|k| !before.contains(&k)))
            .collect();
        let (next, st) = copl_once(&out, eps, 0.0, Some(&among))?;
        before = now.into_iter().flatten().collect();
        rounds += 1;
        last = st.pairs;
        if st.pairs == 0 {
            break;
        }
        stats.faces_cut += st.faces_cut;
        stats.pieces += st.pieces;
        stats.new_vertices += st.new_vertices;
        stats.tvertices += st.tvertices;
        stats.folded += st.folded;
        out = next;
    }
    stats.rounds = rounds;
    if stats.pairs + stats.contacts > 0 {
        out = recut(m, out, eps, &mut stats)?;
    }
    Ok((out, stats))
}

/// Where `copl_contact`'s cuts made a face cross another that is not
/// coplanar with it, that pair is cut as `ugisect` cuts it (only pairs
/// with a face that is not in `m` as it is are looked at), and what that
/// cut leaves overlapping is cut in the plane again (one round each).
/// A piece's corner taken from a coplanar neighbour up to 3 epsilon off
/// its plane is a fresh point in the piece's plane, so the piece's edge
/// can run up to 3 epsilon from where the neighbour's edge, and the edge
/// of a face standing on it, run: a wing's ceiling cut under the top of a
/// wall got a corner 1.5 epsilon below the wall's top corner, and the wall
/// then stood 1.5 epsilon through the ceiling along that stretch, an
/// intersecting pair that `ugisect` had not seen before the cut
/// (dirty-building seed 1042, a triangle export with a wing).
fn recut(m: &Model, out: Model, eps: f64, stats: &mut Stats) -> Result<Model, ug::Diagnostic> {
    let changed = |before: &Model, now: &Model| -> Vec<bool> {
        let was: rustc_hash::FxHashSet<u64> = face_keys(before).into_iter().flatten().collect();
        face_keys(now)
            .into_iter()
            .map(|k| k.is_none_or(|k| !was.contains(&k)))
            .collect()
    };
    let among = changed(m, &out);
    let (cut, st) = crate::isect::isect_once(&out, eps, Some(&among))?;
    if st.pairs == 0 {
        return Ok(out);
    }
    stats.recut_pairs = st.pairs;
    stats.faces_cut += st.faces_cut;
    stats.pieces += st.pieces;
    stats.new_vertices += st.new_vertices;
    stats.tvertices += st.tvertices;
    stats.folded += st.folded;
    let among = changed(&out, &cut);
    let (next, st) = copl_once(&cut, eps, 0.0, Some(&among))?;
    if st.pairs == 0 {
        return Ok(cut);
    }
    stats.rounds += 1;
    stats.faces_cut += st.faces_cut;
    stats.pieces += st.pieces;
    stats.new_vertices += st.new_vertices;
    stats.tvertices += st.tvertices;
    stats.folded += st.folded;
    Ok(next)
}

/// Least |cos| between a face's normal and its group's for the face to be
/// laid out in the group's frame (about 5°).
const GROUP_FRAME_COS: f64 = 0.996;

/// The frame each face of an overlapping pair is laid out in: that of the
/// largest face of its group (faces joined by overlapping pairs), its
/// normal turned to agree with the face's own (a mirror image: the pieces
/// keep the face's orientation). `None` for a face in no pair, for the
/// group's largest face itself, and for a face turned more than about 5°
/// from it (a small face counts as coplanar at a larger angle; laid out
/// in a plane so far from its own, a globe's facet at 11° to a ceiling
/// piece made a cut that crossed another ceiling piece: property seed
/// 400851 at 1 mm): they use their own frame, and (the second vector)
/// measure a neighbour's point where the group's normal (turned to agree
/// with theirs) through it meets their plane, not at its foot: a point of
/// the group's plane then lies no nearer to the line where the two planes
/// meet (the face's edge along the group's face) than in the group's
/// plane (farther by 1/cos θ), where its foot lies nearer (by cos θ, and
/// more for a point off the group's plane towards the face). (One turned
/// further than the coplanar test's angle, through a chain of pairs,
/// measures at the foot: property seed 173086 at 4 decimals, a pipe's
/// cap round a globe.)
/// A globe facet at 12° to a ceiling ring, the ring's point 1.08 epsilon
/// beyond the facet's edge in the ring's plane and 1.9 mm off the
/// facet's: at its foot 0.91 epsilon from the edge, and the facet's edge
/// was rerouted through it while the ring's stayed (the CAD building of
/// seed 2 at 1 mm).
///
/// Why one frame: a face's arrangement measures its neighbours' points in
/// its own plane, projected; a neighbour's vertex up to 3 epsilon off that
/// plane measures nearer to an edge there than in its own face's plane. A
/// ceiling triangle and a light facet sharing an edge, the facet's next
/// vertex 1.1 epsilon from that edge in space and 0.97 mm off the
/// triangle's plane (1 mm rounding, epsilon 2.1 mm): in the triangle's
/// frame the vertex was 0.999 epsilon from the edge and the triangle's edge
/// was rerouted through it; in the facet's frame 1.1 epsilon, and the
/// facet's notch stayed: the two pieces overlapped (property seed 400830
/// at 1 mm). Measured in one frame, both arrangements decide alike.
fn group_frames(
    geoms: &[Option<geom::intersect::FaceGeom>],
    pairs: &[(usize, usize)],
) -> (Vec<Option<geom::plane::Frame>>, Vec<Option<geom::DVec3>>) {
    let n = geoms.len();
    let mut parent: Vec<usize> = (0..n).collect();
    for &(i, j) in pairs {
        crate::join(&mut parent, i, j);
    }
    let mut frames = vec![None; n];
    let mut lean = vec![None; n];
    if pairs.is_empty() {
        return (frames, lean);
    }
    let area: Vec<f64> = geoms
        .iter()
        .map(|g| g.as_ref().map_or(0.0, area_2d))
        .collect();
    // The largest face of each group (the first of equal ones).
    let mut best: rustc_hash::FxHashMap<usize, usize> = Default::default();
    let mut members = Vec::new();
    for &(i, j) in pairs {
        members.push(i);
        members.push(j);
    }
    members.sort_unstable();
    members.dedup();
    for &k in &members {
        let r = crate::root(&mut parent, k);
        let b = best.entry(r).or_insert(k);
        if area[k] > area[*b] {
            *b = k;
        }
    }
    for &k in &members {
        let b = best[&crate::root(&mut parent, k)];
        if b == k {
            continue;
        }
        let (Some(g), Some(gb)) = (geoms[k].as_ref(), geoms[b].as_ref()) else {
            continue;
        };
        let f = gb.frame;
        let c = f.n.dot(g.frame.n);
        if c.abs() < GROUP_FRAME_COS {
            // (A face further turned, through a chain of pairs, measures
            // at the foot; see above.)
            if c.abs() >= geom::intersect::COPLANAR_COS {
                lean[k] = Some(if c > 0.0 { f.n } else { -f.n });
            }
            continue;
        }
        frames[k] = Some(if c > 0.0 {
            f
        } else {
            geom::plane::Frame {
                origin: f.origin,
                u: f.u,
                v: -f.v,
                n: -f.n,
            }
        });
    }
    (frames, lean)
}

/// New points of two overlapping faces' pieces, the faces' normals more
/// than about 5° apart ([`GROUP_FRAME_COS`], the angle below which faces
/// mostly share a frame, their crossings one point already), within 2 epsilon of
/// each other (the check's coplanar tolerance), each the other's nearest,
/// become one point, at their midpoint. Each such face's new points lie
/// in its own plane; where the two planes are more than epsilon apart
/// there, the pieces of one region got corners 1 to 2 epsilon apart, too
/// far for the welding at epsilon, and overlapped instead of coinciding
/// (the CAD building of seed 2 at 1 mm: a pipe's end cap, a chord across
/// a round column's hole facets 3.7 mm inside them, cut at the same
/// crossings in both). The midpoint is within epsilon of both planes.
fn share_near_new_points(
    mut results: Vec<(usize, Vec<Vec<Vec<Point>>>)>,
    others: &[Vec<usize>],
    geoms: &[Option<geom::intersect::FaceGeom>],
    eps: f64,
) -> Vec<(usize, Vec<Vec<Vec<Point>>>)> {
    use geom::DVec3;
    let reach = 2.0 * eps;
    if reach.is_nan() || reach <= 0.0 {
        return results;
    }
    // Each face's distinct new points: (point, face).
    let mut pts: Vec<(DVec3, usize)> = Vec::new();
    for (k, pieces) in &results {
        let mut seen: rustc_hash::FxHashSet<[u64; 3]> = Default::default();
        for p in pieces.iter().flatten().flatten() {
            if let Point::New(q) = p
                && seen.insert(q.to_array().map(f64::to_bits))
            {
                pts.push((*q, *k));
            }
        }
    }
    if pts.len() < 2 {
        return results;
    }
    let index = geom::index::BoxIndex::new(
        pts.iter()
            .enumerate()
            .map(|(i, &(p, _))| (p - DVec3::splat(reach), p + DVec3::splat(reach), i as u32)),
    );
    // The nearest new point of an overlapping face within reach.
    let nearest = |i: usize| -> Option<usize> {
        let (p, k) = pts[i];
        let mut best: Option<(f64, usize)> = None;
        for j in index.query(p, p) {
            let (q, kj) = pts[j as usize];
            if kj == k || !others[k].contains(&kj) {
                continue;
            }
            // Faces within about 5° of each other share a frame: their
            // crossings are one point already, and points 1 to 2 epsilon
            // apart there are different corners (slivers of an oblique
            // wall's pieces, property seed 170692 at 1 mm).
            if let (Some(a), Some(b)) = (geoms[k].as_ref(), geoms[kj].as_ref())
                && a.plane.n.dot(b.plane.n).abs() >= GROUP_FRAME_COS
            {
                continue;
            }
            let d = p.distance(q);
            if d > reach || d == 0.0 {
                continue;
            }
            if best.is_none_or(|(bd, bj)| d < bd || (d == bd && (j as usize) < bj)) {
                best = Some((d, j as usize));
            }
        }
        best.map(|b| b.1)
    };
    let near: Vec<Option<usize>> = (0..pts.len()).map(nearest).collect();
    let mut moved: rustc_hash::FxHashMap<(usize, [u64; 3]), DVec3> = Default::default();
    for (i, &n) in near.iter().enumerate() {
        let Some(j) = n else {
            continue;
        };
        if near[j] != Some(i) {
            continue;
        }
        let (p, q) = (pts[i].0, pts[j].0);
        // (p + q is q + p to the bit: both copies move to the same point.)
        moved.insert((pts[i].1, p.to_array().map(f64::to_bits)), (p + q) * 0.5);
    }
    if moved.is_empty() {
        return results;
    }
    for (k, pieces) in &mut results {
        for p in pieces.iter_mut().flatten().flatten() {
            if let Point::New(q) = p
                && let Some(&m) = moved.get(&(*k, q.to_array().map(f64::to_bits)))
            {
                *q = m;
            }
        }
    }
    results
}

/// Most rounds of [`copl_contact`].
pub const MAX_ROUNDS: usize = 3;

/// Per face (by `FaceId` index; `None` for faces that are not top-level):
/// a hash of its material and its points' bits in order.
pub(crate) fn face_keys(m: &Model) -> Vec<Option<u64>> {
    use std::hash::{BuildHasher, Hash, Hasher};
    let mut keys = vec![None; m.faces.len()];
    for f in m.top_faces() {
        let face = &m.faces[f.idx()];
        let mut h = rustc_hash::FxBuildHasher.build_hasher();
        face.material.map(|x| x.idx()).hash(&mut h);
        for c in &face.contours {
            c.len().hash(&mut h);
            for &v in c {
                for x in m.pos(v).to_array() {
                    x.to_bits().hash(&mut h);
                }
            }
        }
        keys[f.idx()] = Some(h.finish());
    }
    keys
}

/// One round of [`copl_contact`]; with `among` (by `FaceId` index), only
/// the overlapping pairs with a face marked.
fn copl_once(
    m: &Model,
    eps: f64,
    contact: f64,
    among: Option<&[bool]>,
) -> Result<(Model, Stats), ug::Diagnostic> {
    let (faces, geoms) = face_geoms(m);
    let among: Option<Vec<bool>> = among.map(|a| {
        faces
            .iter()
            .map(|f| a.get(f.idx()).copied().unwrap_or(true))
            .collect()
    });
    let pairs: Vec<(usize, usize)> = check::coplanar_pairs_with(
        &geoms,
        eps,
        among.as_deref(),
        geom::intersect::CLEAN_COPLANAR_EPSILONS,
    )
    .into_iter()
    .filter(|p| matches!(p.2, PairKind::Overlap(_)))
    .map(|(i, j, _)| (i, j))
    .collect();
    let contacts = contact_pairs(&geoms, eps, contact);
    let mut stats = Stats {
        pairs: pairs.len(),
        contacts: contacts.len(),
        ..Stats::default()
    };
    if pairs.is_empty() && contacts.is_empty() {
        return Ok((m.clone(), stats));
    }
    let mut others: Vec<Vec<usize>> = vec![Vec::new(); faces.len()];
    for &(i, j) in &pairs {
        others[i].push(j);
        others[j].push(i);
    }
    let mut covers: Vec<Vec<Contact>> = (0..faces.len()).map(|_| Vec::new()).collect();
    for c in contacts {
        let k = c.k;
        covers[k].push(c);
    }
    let (frames, lean) = group_frames(&geoms, &pairs);
    let pos = |v: ug::VertexId| m.vertices[v.idx()].pos;
    let work: Vec<usize> = (0..faces.len())
        .filter(|&k| !others[k].is_empty() || !covers[k].is_empty())
        .collect();
    let results: Vec<(usize, Vec<Vec<Vec<Point>>>)> = work
        .par_iter()
        .filter_map(|&k| {
            let g = geoms[k].as_ref()?;
            let fr = frames[k].unwrap_or(g.frame);
            let mut layout = Layout::new(fr);
            layout.contours(&m.faces[faces[k].idx()].contours, Tag::Toggle(0), pos);
            // A neighbour much bigger than this face (a storey's floor
            // with hundreds of holes under a rug) is clipped to a box around
            // this face first: only its part there can cut it.
            let (lo, hi) = geom::index::bbox(
                g.contours
                    .iter()
                    .flatten()
                    .map(|&p| fr.to_2d(p).extend(0.0)),
                4.0 * eps,
            );
            let (lo, hi) = (lo.truncate(), hi.truncate());
            // A neighbour's vertex is a corner of this face's pieces only
            // when it lies within epsilon of this face's plane (or is this
            // face's own): "coplanar" reaches 2 epsilon, and a corner taken
            // from a neighbour 2 epsilon off would tilt the piece (a wall's
            // end 2 epsilon past a slab's end, its piece on the slab's
            // vertices, crossed the thin strip of the wall's side between
            // the two ends; seed 367 of the dirty-building property). Such
            // a point is a fresh one in this face's plane.
            let own: rustc_hash::FxHashSet<ug::VertexId> = m.faces[faces[k].idx()]
                .contours
                .iter()
                .flatten()
                .copied()
                .collect();
            for (t, &j) in others[k].iter().enumerate() {
                let tag = Tag::Toggle(t as u32 + 1);
                let cs = &m.faces[faces[j].idx()].contours;
                for c in cs {
                    let ring: Vec<(geom::DVec2, Option<ug::VertexId>)> = c
                        .iter()
                        .map(|&v| {
                            let p = pos(v);
                            let near = own.contains(&v) || g.plane.dist(p).abs() <= eps;
                            // A face turned from its group's plane measures a
                            // neighbour's point where the group's normal
                            // through it meets this face's plane.
                            let q = match lean[k] {
                                Some(nb) => p - nb * (g.plane.dist(p) / g.plane.n.dot(nb)),
                                None => p,
                            };
                            (fr.to_2d(q), near.then_some(v))
                        })
                        .collect();
                    if ring
                        .iter()
                        .all(|p| p.0.cmpge(lo).all() && p.0.cmple(hi).all())
                    {
                        layout.ring(&ring, tag);
                    } else {
                        layout.ring(&winged::pieces::clip_ring(&ring, lo, hi), tag);
                    }
                }
            }
            // Covering faces in front: their contours projected onto this
            // face's plane as fresh points (never their vertices, which lie
            // across the gap), and the grown outline.
            let mut tag = others[k].len() as u32 + 1;
            // (Made in this face's own frame: moved into the layout's.)
            let fresh = |pts: &[geom::DVec2]| -> Vec<(geom::DVec2, Option<ug::VertexId>)> {
                pts.iter()
                    .map(|&p| match frames[k] {
                        Some(_) => (fr.to_2d(g.frame.to_3d(p)), None),
                        None => (p, None),
                    })
                    .collect()
            };
            for c in &covers[k] {
                for contour in &c.outline {
                    layout.ring(&fresh(contour), Tag::Toggle(tag));
                }
                tag += 1;
                if let Some(grown) = &c.grown {
                    layout.ring(&fresh(grown), Tag::Toggle(tag));
                    tag += 1;
                }
            }
            let arr = layout.arrange(eps, false);
            let pieces: Vec<Vec<Vec<Point>>> = arr
                .faces
                .iter()
                .filter(|f| f.has(0))
                .map(|f| {
                    let mut loops = layout.loops(&arr, f);
                    if frames[k].is_some() {
                        // New points lie on the group's plane: moved along
                        // its normal onto this face's own plane.
                        for p in loops.iter_mut().flatten() {
                            if let Point::New(q) = p {
                                let t = g.plane.dist(*q) / g.plane.n.dot(fr.n);
                                *q -= fr.n * t;
                            }
                        }
                    }
                    loops
                })
                .collect();
            Some((k, pieces))
        })
        .collect();
    let results = share_near_new_points(results, &others, &geoms, eps);
    let mut cut_of: Vec<Option<usize>> = vec![None; faces.len()];
    for (r, (k, _)) in results.iter().enumerate() {
        cut_of[*k] = Some(r);
    }
    // Found only when a face is cut (for the origin surfaces' areas).
    let surfaces = std::cell::OnceCell::new();
    let mut order = vec![usize::MAX; m.faces.len()];
    for (k, &f) in faces.iter().enumerate() {
        order[f.idx()] = k;
    }
    let mut rb = Rebuild::new(m, eps);
    for it in &m.items {
        let Item::Face(f) = it else {
            rb.pass(it);
            continue;
        };
        let k = order[f.idx()];
        let face = &m.faces[f.idx()];
        let Some(r) = cut_of.get(k).copied().flatten() else {
            rb.face(face.clone());
            continue;
        };
        let pieces = &results[r].1;
        let base = face.name.clone().unwrap_or_else(|| format!("f{}", k + 1));
        if pieces.len() <= 1 {
            // Overlapped only along its boundary within epsilon: the face
            // keeps its shape (it may gain vertices).
            if pieces.is_empty() {
                rb.face(face.clone());
            } else {
                rb.pieces(face, &base, "c", pieces, None);
            }
            continue;
        }
        stats.faces_cut += 1;
        let note = format!(
            "ugcopl origin {base} area {}",
            surfaces.get_or_init(|| {
                crate::coincident::surface_areas(&winged::Mesh::from_model(m.clone()), eps)
            })[f.idx()]
        );
        stats.pieces += rb.pieces(face, &base, "c", pieces, Some(&note));
    }
    stats.new_vertices = rb.new_vertices;
    // Where the cuts meet neighbouring edges: insert the points (no T-vertex).
    let opts = crate::group::Options {
        merge_faces: false,
        ..crate::group::Options::new(eps)
    };
    let (out, vst) = crate::group::vlmerge(rb.out, &opts)?;
    stats.tvertices = vst.tvertices;
    let (out, folded) = crate::planar::refold(out, eps);
    stats.folded = folded;
    Ok((out, stats))
}
