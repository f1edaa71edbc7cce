//! Enclosed face removal: faces that no light can reach and no one see.
//!
//! After `ugisect` a building of box-slab walls, sunk furniture and tiled
//! floors holds many pieces inside solids: the part of a wall face inside
//! the wall that crosses it, the floor under every wall foot, the ceiling
//! above it, the parts of walls and table legs sunk into a floor slab. In a
//! model of one-sided faces such a piece can never receive light and is
//! never seen. On the 8,600-face CAD building they are 16,500 of the
//! 23,200 faces the chain leaves; they only cost patches.
//!
//! **The test.** From points just in front of every face (the centroids of
//! its largest triangles, slivers under `20·eps` wide left out, `10·eps`
//! off its plane, or half-way to the back of a face nearer than that; a
//! point within `4·eps` of such a back counts as a ray that met it where
//! faces cover its face whole) rays
//! go out over the
//! front hemisphere (a fixed Fibonacci set). Each ray meets a face's front,
//! a face's back, or nothing. Faces joined by front-to-front sight form
//! components (union–find). A component is **enclosed** — all its faces go —
//! when
//! * no ray of it escaped the model (the outside is live),
//! * it holds no emitter, and
//! * at least a quarter of its rays met backs: the inside of solids. A
//!   closed dark room (all fronts) stays. (The inside of boxes that
//!   interpenetrate, a flight of steps pushed into a pier, is bounded by
//!   the pier's faces' fronts as well as the steps' backs: 43% backs in
//!   the 100,000-face building with stairs, which half kept.)
//!
//! A face that another face crosses or partly covers (`check`'s Intersect
//! and Overlap pairs; none after ugisect and ugcopl) may be enclosed in part
//! only, so it stays, as do emitters and degenerate faces; it links no
//! faces either (it casts no ray, and a ray that meets it counts neither as
//! a back nor as a link), so that one face half in a room and half inside a
//! wall does not join the wall's inside to the room. A back met first
//! counts as a front when the face back to back with it (a zero-thickness
//! wall's other side) is met within `eps`; a front met within `eps` at an
//! angle is a ray through a corner (where a floor meets a wall) and does
//! not count. Components are found with 16 rays a point (a face whose first
//! point met only fronts is in open space, one whose first point met only
//! backs is alone in a solid, and neither casts from more points); the faces
//! found enclosed cast 32 more a point and 16 grazing ones (0.3° above the
//! plane: a slit 1 cm high a metre away, between a ceiling and a lamp hung
//! below it, lets them out), and stop at the first front of a
//! face whose component is lit (an emitter's or one that escaped). Decisions
//! are per component and the rays fixed, so the result does not depend on
//! the order of faces or the number of threads.
//!
//! **Why removing them changes no light.** Light reaching an enclosed face
//! would have come from a front that some live face or emitter lights; the
//! rays found none. A ray that such a face stopped from behind goes on into
//! the enclosure and stops at the backs around it. Not exact — a finite set
//! of rays can miss a slit — so `tests/ugclean.rs` checks it independently
//! with the path tracer of `ugprobe`: with every kept face an emitter and
//! the removed ones grey, no path from a removed face reaches an emitter.
//! `ugclean --keep-enclosed` turns the step off (the area per material is
//! then kept).

use geom::bvh::{Bvh, Triangle, face_triangles};
use geom::{DVec3, Frame};
use rayon::prelude::*;
use ug::{FaceId, Model};

/// Rays per sample point in the first pass (a Fibonacci hemisphere, uniform
/// in solid angle), and in the second, for the faces the first found
/// enclosed.
pub const RAYS: [usize; 2] = [16, 32];
/// Grazing directions added to the second pass, and their height (sine of
/// the elevation) above the face's plane.
pub const GRAZING: usize = 16;
pub const GRAZE: f64 = 0.005;
/// Sample points per face (the centroids of its largest triangles).
pub const POINTS: usize = 4;
/// A triangle other than a face's largest gives a sample point only when
/// it is at least twice this many epsilons wide (the lift of the points
/// off the face: 10 epsilon).
const SAMPLE_WIDTH: f64 = 10.0;
/// The least lift, in epsilons: a point whose lift would pass through the
/// back of another face is lifted half-way to it, unless that is less.
const MIN_LIFT: f64 = 2.0;

/// What one face's rays met.
#[derive(Default)]
struct Seen {
    /// A ray escaped the model.
    escapes: bool,
    /// Faces whose front a ray met first.
    fronts: Vec<u32>,
    /// Rays that met the back of a face first, and rays cast.
    backs: usize,
    rays: usize,
}

/// What [`remove`] removed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Names (or `#k`, the face's place among the faces) of the faces removed.
    pub removed: Vec<String>,
    pub area_removed: f64,
    /// Enclosed faces kept because removing them would leave an edge
    /// walked the same way by the two faces left on it (see [`spare`]).
    pub spared: usize,
}

/// The model without its enclosed faces (and the vertices only they used).
pub fn remove(m: &Model, eps: f64) -> (Model, Stats) {
    let mut sealed = enclosed(m, eps);
    let mut stats = Stats {
        spared: spare(m, &mut sealed),
        ..Stats::default()
    };
    for (k, f) in m.top_faces().enumerate() {
        if sealed[f.idx()] {
            let face = &m.faces[f.idx()];
            stats.area_removed += face_area(m, f);
            stats
                .removed
                .push(face.name.clone().unwrap_or_else(|| format!("#{}", k + 1)));
        }
    }
    if stats.removed.is_empty() {
        return (m.clone(), stats);
    }
    (crate::coincident::remove_faces(m, &sealed), stats)
}

/// The area of face `f` of `m` (holes taken out).
fn face_area(m: &Model, f: FaceId) -> f64 {
    let pts: Vec<Vec<DVec3>> = m.faces[f.idx()]
        .contours
        .iter()
        .map(|c| c.iter().map(|&v| m.pos(v)).collect())
        .collect();
    geom::face_area(&pts).abs()
}

/// Keeps enclosed faces whose removal would leave an edge walked the same
/// way by the two faces left on it: an inconsistently oriented edge where
/// the model had none (property seed 13847, a triangle export: a slab's
/// end and a facade piece beyond it on an edge where an enclosed facade
/// piece walked the other way). Of the enclosed faces on such an edge
/// walking it the other way, the first in the file whose return makes no
/// such edge elsewhere stays. Hidden faces cost only area and time; an
/// inconsistent edge is a defect. Returns the faces kept.
fn spare(m: &Model, sealed: &mut [bool]) -> usize {
    use crate::coincident::{edge_uses, walked_edges, walked_twice_one_way};
    let uses = edge_uses(m, |_| true);
    // Whether an edge's uses by kept faces are two walking it one way.
    let bad = |u: &[(FaceId, bool)], sealed: &[bool]| walked_twice_one_way(u, |f| !sealed[f.idx()]);
    let mut keys: Vec<crate::coincident::Edge> = uses
        .iter()
        .filter(|(_, u)| u.iter().any(|(f, _)| sealed[f.idx()]) && bad(u, sealed))
        .map(|(&k, _)| k)
        .collect();
    keys.sort_unstable();
    let mut spared = 0;
    for key in keys {
        let u = &uses[&key];
        if !bad(u, sealed) {
            continue;
        }
        let way = u
            .iter()
            .find(|(f, _)| !sealed[f.idx()])
            .is_some_and(|x| x.1);
        // The smallest first (then the first in the file): the least of
        // the hidden area stays. (Property seed 170502 at 1 mm: with a
        // globe's cap pieces buried in the slab gone, see `enclosed`, the
        // first in the file was the ceiling's piece inside the globe, 80
        // cm², whose patches then overlapped the cap's below it; a buried
        // piece of the globe of 0.4 cm² does no harm.)
        let mut cands: Vec<(f64, FaceId)> = u
            .iter()
            .filter(|(f, w)| sealed[f.idx()] && *w != way)
            .map(|(f, _)| (face_area(m, *f), *f))
            .collect();
        cands.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (_, f) in cands {
            sealed[f.idx()] = false;
            let harmless =
                walked_edges(&m.faces[f.idx()].contours).all(|(e, _)| !bad(&uses[&e], sealed));
            if harmless {
                spared += 1;
                break;
            }
            sealed[f.idx()] = true;
        }
    }
    spared
}

/// Which top-level faces are enclosed (indexed by `FaceId`; false for faces
/// that are not top-level).
pub fn enclosed(m: &Model, eps: f64) -> Vec<bool> {
    let faces: Vec<FaceId> = m.top_faces().collect();
    let nf = faces.len();
    // The faces' points and planes, once: for the rays and for the pairs.
    let (_, geoms) = check::face_geoms(m);
    let mut normals = vec![DVec3::ZERO; nf];
    let mut tris = Vec::new();
    // Per face: the centroids of its largest triangles.
    let mut samples: Vec<Vec<DVec3>> = vec![Vec::new(); nf];
    for (k, g) in geoms.iter().enumerate() {
        let Some(g) = g else {
            continue;
        };
        normals[k] = g.plane.n;
        let flat: Vec<DVec3> = g.contours.iter().flatten().copied().collect();
        let mut cand = Vec::new();
        for t in face_triangles(&g.contours) {
            let p = [flat[t[0]], flat[t[1]], flat[t[2]]];
            let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
            if area.is_finite() && area > 0.0 {
                let longest = (0..3)
                    .map(|i| p[i].distance(p[(i + 1) % 3]))
                    .fold(0.0, f64::max);
                cand.push((area, (p[0] + p[1] + p[2]) / 3.0, 2.0 * area / longest));
            }
            tris.push(Triangle { p, id: k as u32 });
        }
        cand.sort_by(|a, b| b.0.total_cmp(&a.0));
        // The largest triangle's centroid, and those of the next largest
        // that are wide enough: a sliver along the boundary (narrower than
        // the lift) has its centroid within rounding of the edge, perhaps
        // past the face it meets there (seed 1101 of the dirty-building
        // property: a wall end poking 0.8 epsilon through a facade, whose
        // sliver's centroid lay outside the building and let rays escape).
        samples[k] = cand
            .iter()
            .enumerate()
            .filter(|(i, c)| *i == 0 || c.2 >= 2.0 * SAMPLE_WIDTH * eps)
            .take(POINTS)
            .map(|(_, c)| c.1)
            .collect();
    }
    let bvh = Bvh::new(tris);
    let twins = may_have_twin(&geoms, &normals, eps);
    // A face that another face crosses or partly covers may be enclosed in
    // part only (ugisect and ugcopl leave none): it stays, and links
    // nothing (it casts no ray, and a ray that meets it joins nothing):
    // half in a room and half inside a wall, it would join the wall's
    // inside to the room. (Live by itself, as it was, three such faces
    // in the 100,000-face building with stairs, a ramp's side crossing a
    // floor piece and the wall bottom on it by a hair, kept 27,003
    // hidden faces.)
    let mut mixed = vec![false; nf];
    for (i, j, kind) in check::classify_pairs(&geoms, eps) {
        if matches!(
            kind,
            check::PairKind::Intersect | check::PairKind::Overlap(_)
        ) {
            mixed[i] = true;
            mixed[j] = true;
        }
    }
    let emitter: Vec<bool> = faces
        .iter()
        .map(|&f| {
            m.faces[f.idx()]
                .material
                .is_some_and(|mat| m.material(mat).is_emitter())
        })
        .collect();
    let mut live0: Vec<bool> = (0..nf)
        .map(|k| normals[k] == DVec3::ZERO || samples[k].is_empty() || emitter[k])
        .collect();
    let lift = SAMPLE_WIDTH * eps;
    // A face's rays from `points`; with `live`, it stops at the first
    // front of a face known to be lit (an emitter's or escaping component:
    // as if it escaped).
    let cast = |k: usize,
                points: &[DVec3],
                dirs: &[DVec3],
                live: Option<&[bool]>,
                live0: Option<&[bool]>|
     -> Seen {
        let mut seen = Seen::default();
        if live0.is_some_and(|l| l[k]) || mixed[k] {
            return seen;
        }
        let n = normals[k];
        let frame = Frame::new(DVec3::ZERO, n);
        // Points cast from so far, and points too near a back to cast from.
        let (mut used, mut near) = (0, 0);
        // The distance to the first back in front of `c`, within the lift.
        let back_within = |c: DVec3| {
            bvh.intersect(c, n, 0.0, lift, |id| {
                id != k as u32 && normals[id as usize].dot(n) > 0.0
            })
            .map(|h| h.t)
        };
        for &c in points {
            // A face whose first point met only fronts is in open space
            // (a room, the outside): its other points add nothing. One
            // whose first point met only backs is alone inside a solid: if
            // it is found enclosed, the second pass casts from every point.
            if used == 1 && live.is_none() && (seen.backs == 0 || seen.fronts.is_empty()) {
                break;
            }
            // A point whose lift would pass through the back of another
            // face is lifted half-way to it: a sunk ramp's slope 0.3 mm
            // under the floor, lifted by 10 epsilon (0.5 mm), cast its
            // rays from the room above, and joined the inside of the slab
            // and of every wall that meets it to the lit rooms (a building
            // of 40,000 faces with stairs kept 20% more faces). Not used
            // at all, it left faces with no ray, and they stayed (a box's
            // side 8.5 epsilon behind a step's, inside the step and the
            // floor). Half-way less than `MIN_LIFT` epsilon, it is not
            // used; where faces cover the face whole it counts as a ray
            // that met a back (below). (Through a front the lift goes on, as before: a
            // wall's bottom standing on a floor lifts through the floor
            // into the slab.)
            let mut up = lift;
            if let Some(t) = back_within(c) {
                if t < 2.0 * MIN_LIFT * eps {
                    near += 1;
                    continue;
                }
                up = 0.5 * t;
            }
            used += 1;
            let o = c + n * up;
            for d in dirs {
                let d = frame.u * d.x + frame.v * d.y + frame.n * d.z;
                seen.rays += 1;
                match first_hit(&bvh, &normals, &twins, k as u32, o, d, eps) {
                    None => {
                        seen.escapes = true;
                        return seen;
                    }
                    Some((_, false)) => seen.backs += 1,
                    // A face that another crosses links nothing: it may
                    // be half in a room and half inside a wall.
                    Some((id, true)) if mixed[id as usize] => {}
                    Some((id, true)) => {
                        if live.is_some_and(|l| l[id as usize]) {
                            seen.escapes = true;
                            return seen;
                        }
                        seen.fronts.push(id)
                    }
                }
            }
        }
        // Points too near a back: where faces cover the whole face (every
        // corner of its triangles, moved a hundredth of the way to the
        // triangle's centroid, has one in front within the lift), the face
        // lies inside a solid there, and each such point counts as a ray
        // that met a back (a ramp's piece 0 to 4 epsilon under the floor
        // stayed: property seed 95014 at 1 mm). A face only partly covered
        // (a floor under a rug 3.5 epsilon above it, too far for ugcopl to
        // cut it, whose points all fall under the rug) is judged by its
        // other points as before, and with none casts no ray and stays.
        if near > 0 {
            let covered = geoms[k].as_ref().is_some_and(|g| {
                let flat: Vec<DVec3> = g.contours.iter().flatten().copied().collect();
                face_triangles(&g.contours).iter().all(|t| {
                    let p = [flat[t[0]], flat[t[1]], flat[t[2]]];
                    let mid = (p[0] + p[1] + p[2]) / 3.0;
                    p.iter().all(|&q| {
                        // From epsilon behind: where the face meets its
                        // cover, the two lie within epsilon either way.
                        let q = q + (mid - q) * 0.01 - n * eps;
                        bvh.intersect(q, n, 0.0, lift + eps, |id| id != k as u32)
                            .is_some()
                    })
                })
            });
            if covered {
                seen.rays += near;
                seen.backs += near;
            }
        }
        seen.fronts.sort_unstable();
        seen.fronts.dedup();
        seen
    };
    let mut fine = hemisphere(RAYS[1]);
    fine.extend(grazing(GRAZING));
    // An emitter is live by itself, unless it is buried: every ray of the
    // second pass's set from every point of it meets a back first (the
    // disc of a flush ceiling panel inside a globe lamp whose pole pokes
    // through it, facing into the globe, and the globe's cap above it,
    // facing into the slab: light that nothing can receive, whose patches
    // lay within epsilon of each other; a 1 mm export of a CAD building
    // with stairs kept dozens of such pairs). It is then judged as any
    // face.
    let buried: Vec<usize> = (0..nf)
        .into_par_iter()
        .filter(|&k| {
            emitter[k] && normals[k] != DVec3::ZERO && !samples[k].is_empty() && !mixed[k] && {
                let s = cast(k, &samples[k], &fine, None, None);
                !s.escapes && s.fronts.is_empty() && s.rays > 0 && s.backs == s.rays
            }
        })
        .collect();
    for &k in &buried {
        live0[k] = false;
    }
    let live0 = live0;
    // First pass: every face, few rays.
    let coarse = hemisphere(RAYS[0]);
    let mut seen: Vec<Seen> = (0..nf)
        .into_par_iter()
        .map(|k| cast(k, &samples[k], &coarse, None, Some(&live0)))
        .collect();
    let (dead, live) = dead_faces(&seen, &live0);
    // Second pass: the faces found enclosed, more rays; what they find can
    // only join them to more faces, so it only keeps more.
    let again: Vec<usize> = (0..nf).filter(|&k| dead[k]).collect();
    let redo: Vec<Seen> = again
        .par_iter()
        .map(|&k| cast(k, &samples[k], &fine, Some(&live), Some(&live0)))
        .collect();
    for (k, s) in again.into_iter().zip(redo) {
        seen[k] = s;
    }
    let (dead, _) = dead_faces(&seen, &live0);
    let mut out = vec![false; m.faces.len()];
    for (k, &f) in faces.iter().enumerate() {
        out[f.idx()] = dead[k] && !mixed[k];
    }
    out
}

/// Faces joined by front-to-front sight form components; a component is
/// dead when no face of it is live by itself (an emitter, a face without a
/// normal), none of its rays escaped and at least a quarter of its rays
/// met the backs of faces (the inside of solids; a dark closed room, all
/// fronts, stays). Also which faces are surely live: in a component with a face
/// live by itself or a ray that escaped.
fn dead_faces(seen: &[Seen], live0: &[bool]) -> (Vec<bool>, Vec<bool>) {
    let n = seen.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for (k, s) in seen.iter().enumerate() {
        for &j in &s.fronts {
            let (a, b) = (root(&mut parent, k as u32), root(&mut parent, j));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut live = vec![false; n];
    let mut backs = vec![0usize; n];
    let mut rays = vec![0usize; n];
    for (k, s) in seen.iter().enumerate() {
        let r = root(&mut parent, k as u32) as usize;
        live[r] |= live0[k] || s.escapes;
        backs[r] += s.backs;
        rays[r] += s.rays;
    }
    (0..n)
        .map(|k| {
            let r = root(&mut parent, k as u32) as usize;
            (!live[r] && rays[r] > 0 && 4 * backs[r] >= rays[r], live[r])
        })
        .unzip()
}

/// The first face the ray from `o` along `d` meets, and whether it meets
/// its front; `None` when the ray escapes. A back met first counts as a
/// front when a face back to back with it (coplanar, facing the other way)
/// is met within `eps` of it: the two sides of a zero-thickness wall. A
/// front within `eps` at an angle to it is a corner (a ray through the edge
/// where a floor meets a wall) and does not count.
fn first_hit(
    bvh: &Bvh,
    normals: &[DVec3],
    twins: &[bool],
    me: u32,
    o: DVec3,
    d: DVec3,
    eps: f64,
) -> Option<(u32, bool)> {
    let h = bvh.intersect(o, d, 0.0, f64::INFINITY, |id| id != me)?;
    let facing = |id: u32| normals[id as usize].dot(d) <= 0.0;
    if facing(h.id) {
        return Some((h.id, true));
    }
    if !twins[h.id as usize] {
        return Some((h.id, false));
    }
    let nb = normals[h.id as usize];
    let twin = |id: u32| id != me && facing(id) && normals[id as usize].dot(nb) < -TWIN_DOT;
    match bvh.intersect(o, d, 0.0, h.t + eps, twin) {
        Some(f) => Some((f.id, true)),
        None => Some((h.id, false)),
    }
}

/// Per face: whether some other face could be its twin in [`first_hit`]
/// (facing the other way, normals within the twin test's angle, boxes
/// within `eps`). A twin met within `eps` beyond a back lies within `eps`
/// of it, so a face with none needs no second ray: the same answers, and
/// a quarter of the rays' time on the 100k building (most faces have no
/// twin; a back met first is the common case inside solids).
fn may_have_twin(
    geoms: &[Option<geom::intersect::FaceGeom>],
    normals: &[DVec3],
    eps: f64,
) -> Vec<bool> {
    let boxes: Vec<(DVec3, DVec3, u32)> = geoms
        .iter()
        .enumerate()
        .filter_map(|(k, g)| {
            let g = g.as_ref()?;
            let (lo, hi) = geom::index::bbox(g.contours.iter().flatten().copied(), eps);
            Some((lo, hi, k as u32))
        })
        .collect();
    let index = geom::index::BoxIndex::new(boxes.iter().copied());
    let mut twins = vec![false; geoms.len()];
    let found: Vec<bool> = boxes
        .par_iter()
        .map(|&(lo, hi, k)| {
            let n = normals[k as usize];
            index
                .query(lo, hi)
                .into_iter()
                .any(|j| j != k && normals[j as usize].dot(n) < -TWIN_DOT)
        })
        .collect();
    for (&(_, _, k), f) in boxes.iter().zip(found) {
        twins[k as usize] = f;
    }
    twins
}

/// Two faces are back to back when their normals' dot product is below
/// minus this.
const TWIN_DOT: f64 = 0.999_999;

/// `n` directions `GRAZE` above the plane, evenly around it: the hemisphere's
/// lowest direction is 1/(2n) high, so it misses a slit between a face and
/// a lamp hung 1 cm below it that opens 1 m away; these find it (a rise of
/// 0.5 cm a metre).
fn grazing(n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * (k as f64 + 0.5) / n as f64;
            let r = (1.0 - GRAZE * GRAZE).sqrt();
            DVec3::new(r * a.cos(), r * a.sin(), GRAZE)
        })
        .collect()
}

/// `n` unit directions with z > 0, spread evenly in solid angle (a
/// Fibonacci spiral: z = 1 − (k + ½)/n, azimuth k times the golden angle).
fn hemisphere(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|k| {
            let z = 1.0 - (k as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let a = golden * k as f64;
            DVec3::new(r * a.cos(), r * a.sin(), z)
        })
        .collect()
}

#[cfg(test)]
mod spare_tests {
    use super::*;

    fn model(src: &str) -> Model {
        ug::parse(src.as_bytes(), "t").unwrap().model
    }

    fn face(m: &Model, name: &str) -> usize {
        m.faces
            .iter()
            .position(|f| f.name.as_deref() == Some(name))
            .unwrap()
    }

    const V: &str = "v a 0 0 0; v b 1 0 0; v c 1 1 0; v d 0 -1 0; v e 0 0 1; v g 1 0 1;\n";

    /// Three faces on edge a–b: `up` and `flat` walk it a→b, `down` b→a.
    /// Removing `down` would leave the other two walking it the same way.
    #[test]
    fn an_enclosed_face_stays_where_its_removal_leaves_an_edge_walked_twice_one_way() {
        let m = model(&format!(
            "{V}f flat (a b c); f up (a b g e); f down (b a d);\n"
        ));
        let mut sealed = vec![false; m.faces.len()];
        sealed[face(&m, "down")] = true;
        assert_eq!(spare(&m, &mut sealed), 1);
        assert!(!sealed[face(&m, "down")]);
        // Removing it where the two left walk it both ways: it goes.
        let m = model(&format!(
            "{V}f flat (a b c); f up (b a e g); f down (b a d);\n"
        ));
        let mut sealed = vec![false; m.faces.len()];
        sealed[face(&m, "down")] = true;
        assert_eq!(spare(&m, &mut sealed), 0);
        assert!(sealed[face(&m, "down")]);
        // Two could stay: the smaller does (`down2`, half `down`'s area),
        // whichever comes first in the file.
        for order in [
            "f down (b a d); f down2 (b a h);",
            "f down2 (b a h); f down (b a d);",
        ] {
            let m = model(&format!(
                "{V}v h 0.5 -0.5 0;\nf flat (a b c); f up (a b g e); {order}\n"
            ));
            let mut sealed = vec![false; m.faces.len()];
            sealed[face(&m, "down")] = true;
            sealed[face(&m, "down2")] = true;
            assert_eq!(spare(&m, &mut sealed), 1);
            assert!(!sealed[face(&m, "down2")], "{order}");
            assert!(sealed[face(&m, "down")], "{order}");
        }
    }

    /// The face that would stay walks another edge the same way as the one
    /// kept face there: keeping it would only move the defect, so it goes.
    #[test]
    fn a_face_whose_return_makes_another_such_edge_goes() {
        let m = model(&format!(
            "{V}f flat (a b c); f up (a b g e); f down (b a d); f side (d b e);\n"
        ));
        // (`down` and `side` both walk d→b.)
        let mut sealed = vec![false; m.faces.len()];
        sealed[face(&m, "down")] = true;
        assert_eq!(spare(&m, &mut sealed), 0);
        assert!(sealed[face(&m, "down")]);
    }
}
