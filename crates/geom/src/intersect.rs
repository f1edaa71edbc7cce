//! How two planar faces meet in space: disjoint, touching along their
//! boundaries only, intersecting (some common point lies in the interior of
//! one of them), or coplanar (left to the 2-D tests).

use glam::{DVec2, DVec3};

use crate::index::BoxIndex;
use crate::plane::{Frame, Plane};
use crate::polygon::{Location, locate_2d};
use crate::predicates::on_segment_2d;

/// A face prepared for pair tests: contours, best-fit plane and its 2-D
/// projection; faces with many edges also get an index of their edges, so
/// that locating a point costs a query, not a pass over every edge.
#[derive(Clone)]
pub struct FaceGeom {
    pub contours: Vec<Vec<DVec3>>,
    pub plane: Plane,
    pub frame: Frame,
    pub contours_2d: Vec<Vec<DVec2>>,
    /// The bounding box of each contour.
    pub contour_boxes: Vec<(DVec3, DVec3)>,
    edges: Option<std::sync::Arc<EdgeIndex>>,
}

impl std::fmt::Debug for FaceGeom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FaceGeom")
            .field("contours", &self.contours)
            .field("plane", &self.plane)
            .finish()
    }
}

/// Edges of a big face in an R*-tree: (contour, index) per entry.
struct EdgeIndex {
    tree: BoxIndex,
    ids: Vec<(u32, u32)>,
}

/// Faces with more edges than this get an [`EdgeIndex`].
const INDEX_EDGES: usize = 32;

impl FaceGeom {
    /// `None` for a degenerate face (no area, or no contour).
    pub fn new(contours: Vec<Vec<DVec3>>) -> Option<FaceGeom> {
        let outer = contours.first()?;
        let plane = Plane::fit(outer)?;
        let frame = Frame::new(outer[0], plane.n);
        let contours_2d: Vec<Vec<DVec2>> = contours
            .iter()
            .map(|c| c.iter().map(|&p| frame.to_2d(p)).collect())
            .collect();
        let total: usize = contours_2d.iter().map(Vec::len).sum();
        let edges = (total > INDEX_EDGES).then(|| {
            let mut ids = Vec::with_capacity(total);
            let mut boxes = Vec::with_capacity(total);
            for (ci, c) in contours_2d.iter().enumerate() {
                for i in 0..c.len() {
                    let (a, b) = (c[i], c[(i + 1) % c.len()]);
                    boxes.push((a.min(b).extend(0.0), a.max(b).extend(0.0), ids.len() as u32));
                    ids.push((ci as u32, i as u32));
                }
            }
            std::sync::Arc::new(EdgeIndex {
                tree: BoxIndex::new(boxes),
                ids,
            })
        });
        let contour_boxes = contours
            .iter()
            .map(|c| crate::index::bbox(c.iter().copied(), 0.0))
            .collect();
        Some(FaceGeom {
            contours,
            plane,
            frame,
            contours_2d,
            contour_boxes,
            edges,
        })
    }

    /// Location of a 3-D point (assumed in or near the plane) with tolerance
    /// `eps`: within `eps` of an edge counts as the boundary.
    pub fn locate(&self, p: DVec3, eps: f64) -> Location {
        self.locate_2d(self.frame.to_2d(p), eps)
    }

    /// [`FaceGeom::locate`] for a point already in the face's frame.
    pub fn locate_2d(&self, q: DVec2, eps: f64) -> Location {
        let Some(ix) = &self.edges else {
            return locate_eps(q, &self.contours_2d, eps);
        };
        let edge = |k: u32| {
            let (ci, i) = ix.ids[k as usize];
            let c = &self.contours_2d[ci as usize];
            (c[i as usize], c[(i as usize + 1) % c.len()])
        };
        let pad = DVec2::splat(eps);
        for k in ix.tree.query((q - pad).extend(0.0), (q + pad).extend(0.0)) {
            let (a, b) = edge(k);
            if seg_dist(q, a, b) <= eps {
                return Location::Boundary;
            }
        }
        // Even-odd crossings of the ray towards +x, exactly as locate_2d.
        let mut inside = false;
        let far = DVec3::new(f64::INFINITY, q.y, 0.0);
        for k in ix.tree.query(q.extend(0.0), far) {
            let (a, b) = edge(k);
            if on_segment_2d(q, a, b) {
                return Location::Boundary;
            }
            if crate::polygon::crosses_ray(q, a, b) {
                inside = !inside;
            }
        }
        if inside {
            Location::Inside
        } else {
            Location::Outside
        }
    }
}

fn seg_dist(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length()
}

/// Point location in 2-D where anything within `eps` of an edge is the boundary.
pub fn locate_eps(p: DVec2, contours: &[Vec<DVec2>], eps: f64) -> Location {
    for c in contours {
        let n = c.len();
        for i in 0..n {
            let (a, b) = (c[i], c[(i + 1) % n]);
            let ab = b - a;
            let len2 = ab.length_squared();
            let t = if len2 > 0.0 {
                ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if (a + ab * t - p).length() <= eps {
                return Location::Boundary;
            }
        }
    }
    locate_2d(p, contours)
}

/// How two faces meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Relation {
    Disjoint,
    /// They meet only where both have boundary (a shared vertex or edge, edge on edge).
    Touch,
    /// A common point lies in the interior of at least one face (crossing faces,
    /// or an edge or vertex of one resting inside the other).
    Intersect,
    /// All of one face's vertices lie within `eps` of the other's plane.
    Coplanar,
}

fn snap(d: f64, eps: f64) -> f64 {
    if d.abs() <= eps { 0.0 } else { d }
}

/// How far from each other's planes two faces may be and still count as
/// coplanar, in epsilons. Welding vertices within epsilon can tilt two
/// faces a hair more than epsilon apart (two wall tops at nearly the same
/// height whose corners were merged): they must still be one plane, not a
/// crossing at a vanishing angle that no cut can resolve. Partial welding
/// happens only at distances up to about epsilon, so twice that covers it.
pub const COPLANAR_EPSILONS: f64 = 2.0;

/// Whether all of one face's vertices lie within `COPLANAR_EPSILONS × eps`
/// of the other's plane, the planes within about 25° of parallel. The angle
/// rules out only a strip a few epsilons wide standing across a face (its
/// vertices are all near the plane too, but it projects to nothing). It is
/// loose on purpose: a face only a few epsilons wide, with its vertices
/// jittered by a fraction of epsilon, has a normal tilted by degrees, and
/// it still lies in the plane within tolerance.
pub fn coplanar(a: &FaceGeom, b: &FaceGeom, eps: f64) -> bool {
    coplanar_within(a, b, COPLANAR_EPSILONS * eps)
}

/// How far apart the tools that resolve coplanar faces (`ugcopl`,
/// `ugclean`) still take two faces as coplanar, in epsilons: more than the
/// [`COPLANAR_EPSILONS`] that `ugcheck` judges by. The test looks at every
/// vertex of a face, and a piece of a face has fewer: two parallel faces
/// 1.9 to 2.04 epsilon apart (a wall's end and the facade a hair behind
/// it, jittered) are not coplanar as wholes, but some of their pieces after
/// `ugcut` are, and they overlap. Resolving every pair within 3 epsilon
/// leaves none that a later cut can bring within 2.
pub const CLEAN_COPLANAR_EPSILONS: f64 = 3.0;

/// The coplanar tests' angle: two faces whose unit normals' dot product is
/// below this in magnitude (about 25.8° apart) are never coplanar.
pub const COPLANAR_COS: f64 = 0.9;

/// [`coplanar`] with the distance tolerance `tol` (absolute).
pub fn coplanar_within(a: &FaceGeom, b: &FaceGeom, tol: f64) -> bool {
    if a.plane.n.dot(b.plane.n).abs() < COPLANAR_COS {
        return false;
    }
    let within = |g: &FaceGeom, other: &FaceGeom| {
        g.contours
            .iter()
            .flatten()
            .all(|&p| other.plane.dist(p).abs() <= tol)
    };
    within(b, a) || within(a, b)
}

const POINT_CUTS: bool = false;

/// Where `b` lies on one side of `a`'s plane but for vertices within
/// `eps` of it, no two of them adjacent (a sphere's pole or a cone's apex
/// resting on a face, a box balanced on a corner), the two meet at most at
/// those points: a contact no cut can resolve and none needs (no edge of
/// either lies along the other). `Touch` where such a vertex lies in `a`
/// (within `eps`), else `Disjoint`; `None` for any other pair. (Found
/// with round columns and globe lamps added to a CAD building: a globe's
/// pole touching a column's top inside it was 20 intersecting pairs,
/// one per cap triangle, after the whole chain.)
fn point_contact(a: &FaceGeom, b: &FaceGeom, eps: f64) -> Option<Relation> {
    let (mut pos, mut neg) = (false, false);
    let mut points = Vec::new();
    for c in &b.contours {
        let n = c.len();
        let d: Vec<f64> = c.iter().map(|&p| snap(a.plane.dist(p), eps)).collect();
        for i in 0..n {
            if d[i] > 0.0 {
                pos = true;
            } else if d[i] < 0.0 {
                neg = true;
            } else if d[(i + 1) % n] == 0.0 || d[(i + n - 1) % n] == 0.0 {
                return None;
            } else {
                points.push(c[i]);
            }
        }
    }
    if points.is_empty() || pos == neg {
        return None;
    }
    Some(
        if points
            .iter()
            .any(|&p| a.locate(p, eps) != Location::Outside)
        {
            Relation::Touch
        } else {
            Relation::Disjoint
        },
    )
}

/// Classifies the pair (a, b) with distance tolerance `eps`.
pub fn relate(a: &FaceGeom, b: &FaceGeom, eps: f64) -> Relation {
    // (The point contact is asked only of pairs that would intersect: it
    // reads every vertex of both faces, which the line's box test spares
    // most pairs. And it holds only where the cutter finds nothing to cut
    // either: at a shallow angle a corner within epsilon of the plane
    // meets it along a stretch eps / sin θ long, which is cut.)
    match relate_on_line(a, b, eps) {
        Relation::Intersect => point_contact(a, b, eps)
            .or_else(|| point_contact(b, a, eps))
            .filter(|_| cut_segments(a, b, eps).is_empty())
            .unwrap_or(Relation::Intersect),
        r => r,
    }
}

/// The point tried for the stretch of the planes' line between boundary
/// events `k` and `k + 1`: at a steep angle the middle of their points as
/// tried (`near`), else `on_line`, the middle of the stretch on the line.
fn stretch_middle(steep: bool, near: &[DVec3], k: usize, on_line: DVec3) -> DVec3 {
    if steep {
        (near[k] + near[k + 1]) / 2.0
    } else {
        on_line
    }
}

/// [`relate`] by the line where the planes meet, point contacts taken as
/// intersections.
fn relate_on_line(a: &FaceGeom, b: &FaceGeom, eps: f64) -> Relation {
    let (p0, dir, ts, near, steep) = match line_of(a, b, eps) {
        LineCase::Coplanar => return Relation::Coplanar,
        LineCase::Disjoint => return Relation::Disjoint,
        LineCase::Line {
            p0,
            dir,
            ts,
            near,
            steep,
            ..
        } => (p0, dir, ts, near, steep),
    };
    // Each boundary point, and the middle of each stretch of the line
    // between them, as `cut_segments` tries it. A vertex within epsilon
    // of the other plane is tried where it is, not at its foot on the
    // line: at a shallow angle the foot may lie epsilon / sin θ away (a
    // ramp at 6.4° sharing a zigzag edge with tiles, whose joint's vertex
    // was 1.05 epsilon from the line and its foot inside the ramp:
    // property seed 8666 with stairs); at a steep one, a hair away, which
    // decides when the vertex lies about epsilon from the other face's
    // edge (a ramp's corner 1.0001 epsilon from a floor's edge, its foot
    // a hair more than epsilon inside the floor, a pair that no cut could
    // resolve: ugisect's snap rounding measures the corner itself). Only
    // where the line is the planes' line at a shallow angle (vertices on
    // both planes spanning an area: a rug on a tile) the foot is tried.
    // At a steep angle the middle of a stretch is the middle of its end
    // points as tried (see `cut_segments`).
    // A stretch that only fans out of a point on both boundaries is no
    // evidence (`corner_fan`).
    let mut touch = false;
    for (k, &t) in ts.iter().enumerate() {
        // The boundary point, then the middle of the stretch after it.
        let middle = ts
            .get(k + 1)
            .map(|&t2| stretch_middle(steep, &near, k, p0 + dir * ((t + t2) / 2.0)));
        for (s, middle) in std::iter::once((near[k], false)).chain(middle.map(|m| (m, true))) {
            let la = a.locate(s, eps);
            if la == Location::Outside {
                continue;
            }
            let lb = b.locate(s, eps);
            match (la, lb) {
                (_, Location::Outside) => {}
                (Location::Inside, _) | (_, Location::Inside)
                    if !(middle && steep && corner_fan(a, b, eps, &near, k, la, lb)) =>
                {
                    return Relation::Intersect;
                }
                _ => touch = true,
            }
        }
    }
    if touch {
        Relation::Touch
    } else {
        Relation::Disjoint
    }
}

/// Whether the stretch of the planes' line between boundary points `k`
/// and `k + 1` (as tried, `near`), its middle found within one face's
/// boundary zone and inside the other (`la`, `lb`), is only the fan of
/// the two faces' epsilon zones about a point where their boundaries meet:
/// under 4 epsilon long, one end on both boundaries and the other outside
/// the face whose edge the middle is near. In exact terms the faces meet
/// at that point and part there; within epsilon the first epsilon / sin φ
/// of the line past the point lies within epsilon of the face's edge (φ
/// the angle between edge and line), and if the other face's interior
/// begins sooner, its middle reads as both. A pendant light's cone facet
/// and the pipe stem's face sharing an edge 28 epsilon long, the stem's
/// face cut by `ugcut` into a triangle whose chord through the facet's
/// plane ran 2.5 epsilon from the shared corner, the facet's edge leaving
/// the line at 26° (property seed 77213 with oblique wings): no cut could
/// resolve it, and no light leaks through 2 epsilon of a corner. A
/// stretch along which the edge stays within epsilon for longer (a wall
/// whose foot is half an epsilon above a floor) is a contact, as before.
fn corner_fan(
    a: &FaceGeom,
    b: &FaceGeom,
    eps: f64,
    near: &[DVec3],
    k: usize,
    la: Location,
    lb: Location,
) -> bool {
    let zone = match (la, lb) {
        (Location::Boundary, Location::Inside) => a,
        (Location::Inside, Location::Boundary) => b,
        _ => return false,
    };
    let (p, q) = (near[k], near[k + 1]);
    let on_both =
        |s: DVec3| a.locate(s, eps) == Location::Boundary && b.locate(s, eps) == Location::Boundary;
    let outside = |s: DVec3| zone.locate(s, eps) == Location::Outside;
    let (from, to) = if on_both(p) && outside(q) {
        (p, q)
    } else if on_both(q) && outside(p) {
        (q, p)
    } else {
        return false;
    };
    if (to - from).length() < 4.0 * eps {
        return true;
    }
    // A longer stretch: the zone face's edge leaves the line at a smaller
    // angle φ, and its epsilon zone reaches epsilon / sin φ along it. Where
    // the zone lies on the stretch, bisected between the stretch's middle
    // (in it) and the far end (outside): a fan when it ends within
    // `FAN_MAX` epsilons of the point the faces meet at (the edge leaves
    // at 0.9° or more), and the zone face is nowhere inside along the
    // stretch (a lamp box's side leaving a round column's facet at 5.4°
    // from the corner where its cut ends, its epsilon zone over the facet
    // for 10.6 epsilon; `ugcut` cut the facet so that the stretch was 17
    // epsilon and its middle in the zone: an intersecting pair no cut
    // could resolve, property seed 122093 with curved things, stairs,
    // tilted, at the default epsilon; a pendant's metal face leaving a
    // vault's piece at under 2.6°, seed 127095, 22 to 64 epsilon).
    let (mut lo, mut hi) = ((from + to) / 2.0, to);
    for _ in 0..40 {
        let m = (lo + hi) / 2.0;
        if outside(m) {
            hi = m;
        } else {
            lo = m;
        }
    }
    let reach = (lo - from).length();
    const FAN_MAX: f64 = 64.0;
    const SAMPLES: usize = 16;
    reach <= FAN_MAX * eps
        && (1..SAMPLES).all(|i| {
            let s = from + (to - from) * (i as f64 / SAMPLES as f64);
            zone.locate(s, eps) != Location::Inside
        })
}

/// The line where two faces' planes meet, and the parameters along it where
/// either face's boundary meets the other's plane (sorted, merged within
/// eps): where the line can enter or leave the faces.
enum LineCase {
    Coplanar,
    Disjoint,
    /// The line through `p0` along `dir`, and where the faces' boundaries
    /// meet it: `ts` along the line, and `at` the points themselves (a
    /// vertex on the other plane, or an edge's crossing of it).
    Line {
        p0: DVec3,
        dir: DVec3,
        ts: Vec<f64>,
        at: Vec<DVec3>,
        /// Where `relate` tries each boundary point: a vertex on the
        /// other plane itself, except at a shallow angle where the line
        /// is the planes' line (there its foot, as `at`); a crossing as
        /// `at`.
        near: Vec<DVec3>,
        /// At least 14.5° between the planes (sin θ ≥ 1/4).
        steep: bool,
    },
}

impl FaceGeom {
    /// The edges (contour, index) that may reach the 3-D box [lo, hi]:
    /// every edge of a small face, the indexed ones near the box's
    /// projection for a big one.
    fn edges_near(&self, lo: DVec3, hi: DVec3) -> Vec<(u32, u32)> {
        match &self.edges {
            None => self
                .contours
                .iter()
                .enumerate()
                .flat_map(|(ci, c)| (0..c.len()).map(move |i| (ci as u32, i as u32)))
                .collect(),
            Some(ix) => {
                let mut l2 = DVec2::splat(f64::INFINITY);
                let mut h2 = DVec2::splat(f64::NEG_INFINITY);
                for k in 0..8 {
                    let c = DVec3::new(
                        if k & 1 == 0 { lo.x } else { hi.x },
                        if k & 2 == 0 { lo.y } else { hi.y },
                        if k & 4 == 0 { lo.z } else { hi.z },
                    );
                    let q = self.frame.to_2d(c);
                    l2 = l2.min(q);
                    h2 = h2.max(q);
                }
                ix.tree
                    .query(l2.extend(0.0), h2.extend(0.0))
                    .into_iter()
                    .map(|k| ix.ids[k as usize])
                    .collect()
            }
        }
    }

    pub fn bounds(&self) -> (DVec3, DVec3) {
        crate::index::bbox(self.contours.iter().flatten().copied(), 0.0)
    }
}

fn line_of(a: &FaceGeom, b: &FaceGeom, eps: f64) -> LineCase {
    if coplanar(a, b, eps) {
        return LineCase::Coplanar;
    }
    // Only what lies in both bounding boxes can matter: every stretch of
    // the line inside both faces begins and ends at a boundary crossing
    // inside both boxes.
    let (alo, ahi) = a.bounds();
    let (blo, bhi) = b.bounds();
    let pad = DVec3::splat(2.0 * eps);
    let (lo, hi) = (alo.max(blo) - pad, ahi.min(bhi) + pad);
    if lo.cmpgt(hi).any() {
        return LineCase::Disjoint;
    }
    let ea = a.edges_near(lo, hi);
    let eb = b.edges_near(lo, hi);
    // A face all on one side of the other's plane (decided on the whole
    // face, so only for faces whose edges are all at hand).
    let one_side = |g: &FaceGeom, other: &FaceGeom, edges: &[(u32, u32)]| {
        let total: usize = g.contours.iter().map(Vec::len).sum();
        if edges.len() != total {
            return false;
        }
        let d = g
            .contours
            .iter()
            .flatten()
            .map(|&p| snap(other.plane.dist(p), eps));
        let (mut pos, mut neg, mut zero) = (false, false, false);
        for x in d {
            if x > 0.0 {
                pos = true;
            } else if x < 0.0 {
                neg = true;
            } else {
                zero = true;
            }
        }
        !zero && (pos != neg)
    };
    if one_side(b, a, &eb) || one_side(a, b, &ea) {
        return LineCase::Disjoint;
    }
    let (n1, n2) = (a.plane.n, b.plane.n);
    let u = n1.cross(n2);
    let uu = u.length_squared();
    if uu < 1e-24 {
        return LineCase::Disjoint; // parallel planes that are not within eps
    }
    let mut p0 = (n2.cross(u) * a.plane.d + u.cross(n1) * b.plane.d) / uu;
    let mut dir = u / uu.sqrt();
    // Where the planes meet at a shallow angle, their line is off by up to
    // epsilon / sin θ: several epsilons (a table leg standing on a
    // column's face tilted by 0.4°, the two sharing an edge: the planes'
    // line ran 2 epsilon inside both faces, an intersection no cut could
    // resolve). A vertex of either face within epsilon of both planes lies
    // on the line within tolerance, so the line runs through such
    // vertices (their feet on the other face's plane, so that a cut stays
    // in the plane of the face it cuts), the two farthest apart along it,
    // when they all lie within 16 epsilon of one line.
    // Only below 14.5° (sin θ < 1/4): at steeper angles the planes' line
    // is within 4 plane errors of where one face really crosses the
    // other's plane, and that is where it must be cut (a wing's side face
    // resting on a wall's end at 56°, the end poking 3 epsilon through the
    // side: cut along the side's edge instead, the end's piece still
    // crossed it; dirty-building seeds 10015, 10354, 11293, 11335, 11822).
    let mut anchored = false;
    let steep = uu >= 1.0 / 16.0;
    if !steep {
        let mut on_both: Vec<(f64, DVec3)> = Vec::new();
        for (g, other, edges) in [(a, b, &ea), (b, a, &eb)] {
            for &(ci, i) in edges.iter() {
                let p = g.contours[ci as usize][i as usize];
                let d = other.plane.dist(p);
                if d.abs() <= eps && g.plane.dist(p).abs() <= eps {
                    let q = p - other.plane.n * d;
                    on_both.push(((q - p0).dot(dir), q));
                }
            }
        }
        // Only those inside both boxes where they span more than 16
        // epsilon: the faces meet there, and a vertex far outside may lie
        // on the planes' line within epsilon at its end and not where they
        // meet (a ceiling's vertex 2.4 m away, on the extension of a cut
        // along a globe's facet 0.7 epsilon below the ceiling piece's edge
        // it shares with the facet's tip: the line through it ran 3
        // epsilon off that edge, inside both faces; property seed 116001 at
        // 10 times the default epsilon). Where those inside span less, the
        // far ones fix the direction.
        let inside: Vec<(f64, DVec3)> = on_both
            .iter()
            .copied()
            .filter(|&(_, q)| q.cmpge(lo).all() && q.cmple(hi).all())
            .collect();
        let span = |v: &[(f64, DVec3)]| {
            let (a, b) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(x.0), b.max(x.0))
                });
            b - a
        };
        if inside.len() < on_both.len() && span(&inside) > 16.0 * eps {
            on_both = inside;
        }
        // The first found of each extreme.
        let mut ends: Option<((f64, DVec3), (f64, DVec3))> = None;
        for &(t, q) in &on_both {
            let (lo, hi) = ends.get_or_insert(((t, q), (t, q)));
            if t < lo.0 {
                *lo = (t, q);
            }
            if t > hi.0 {
                *hi = (t, q);
            }
        }
        if let Some((lo, hi)) = ends {
            let dir2 = if hi.0 - lo.0 > 2.0 * eps {
                (hi.1 - lo.1).normalize()
            } else {
                dir
            };
            // They must lie along one line: vertices on both planes that
            // span an area (a rug's piece sharing a triangle 6.8 mm wide,
            // 63 epsilon, with the tile under it, tilted apart by jitter)
            // make the faces coplanar there, which is ugcopl's to resolve;
            // the planes' line is kept. Within 16 epsilon: such vertices
            // may lie eps / sin θ from the line, and snapped pieces where a
            // ramp at 4.2° meets its landing have them 5.7 epsilon apart
            // (property seed 2664 with stairs, which failed with 4).
            let off = |q: DVec3| (q - lo.1).reject_from_normalized(dir2).length();
            if on_both.iter().all(|&(_, q)| off(q) <= 16.0 * eps) {
                dir = dir2;
                p0 = lo.1;
                anchored = true;
            }
        }
    }
    // Each boundary event: where along the line, and the point: an edge's
    // crossing of the other plane itself, computed from the edge with its
    // end points in one order, so the faces that share the edge find the
    // same point.
    let mut ev: Vec<Event> = Vec::new();
    // At 30° or more, each face's edges lying in the other's plane (both
    // ends within epsilon of it), as (t, point) at either end: where the
    // other face's boundary crosses this face's plane *outside* this face
    // but along such an edge, the two meet on the edge, not on the planes'
    // line (see below). (Not below 30°: there the faces lie within
    // epsilon of each other along a band several epsilons wide, which is
    // the coplanar tests' business; moving the cuts there onto the edge
    // changed where a pendant's pipe and a globe's cap at about 23° were
    // cut, and ugcut's pieces then overlapped: property seed 170320 to 1
    // mm.)
    let lying = |g: &FaceGeom, other: &FaceGeom, edges: &[(u32, u32)]| {
        let mut out: Vec<((f64, DVec3), (f64, DVec3))> = Vec::new();
        if uu < 0.25 {
            return out;
        }
        for &(ci, i) in edges {
            let c = &g.contours[ci as usize];
            let (p, q) = (c[i as usize], c[(i as usize + 1) % c.len()]);
            if snap(other.plane.dist(p), eps) == 0.0 && snap(other.plane.dist(q), eps) == 0.0 {
                let (tp, tq) = ((p - p0).dot(dir), (q - p0).dot(dir));
                if (tq - tp).abs() > eps {
                    out.push(if tp <= tq {
                        ((tp, p), (tq, q))
                    } else {
                        ((tq, q), (tp, p))
                    });
                }
            }
        }
        // Only a face that leaves the plane: one lying in it within
        // epsilon all over (a sliver triangle of a wall's end, its
        // corners 0 to 1 epsilon off a slab's side) has no edge of its
        // own there, and its tilt, so the planes' line, is rounding.
        let leaves = || {
            g.contours
                .iter()
                .flatten()
                .any(|&p| snap(other.plane.dist(p), eps) != 0.0)
        };
        if !out.is_empty() && !leaves() {
            out.clear();
        }
        out
    };
    let lying_a = lying(a, b, &ea);
    let lying_b = lying(b, a, &eb);
    for (g, other, edges, lying_other, of_b) in
        [(a, b, &ea, &lying_b, false), (b, a, &eb, &lying_a, true)]
    {
        for &(ci, i) in edges {
            let c = &g.contours[ci as usize];
            let j = (i as usize + 1) % c.len();
            let (p, q) = (c[i as usize], c[j]);
            let (dp, dq) = (
                snap(other.plane.dist(p), eps),
                snap(other.plane.dist(q), eps),
            );
            if dp == 0.0 {
                // A vertex within epsilon of the other plane: its foot on
                // the line (where two faces meet at a shallow angle, the
                // line is several epsilons along the face from a vertex
                // only an epsilon off the plane).
                let t = (p - p0).dot(dir);
                let foot = p0 + dir * t;
                ev.push((
                    t,
                    foot,
                    if anchored || steep { p } else { foot },
                    Some((p, of_b)),
                ));
            } else if dp * dq < 0.0 {
                let (p, q, dp, dq) = if p.to_array() <= q.to_array() {
                    (p, q, dp, dq)
                } else {
                    (q, p, dq, dp)
                };
                let x = p + (q - p) * (dp / (dp - dq));
                let t = (x - p0).dot(dir);
                // The crossing lies in `other`'s plane; where it is
                // outside `other` but `other` has an edge lying in `g`'s
                // plane across it, the faces meet on that edge: within
                // epsilon of `g`'s plane, the edge runs up to
                // epsilon / sin θ from the planes' line, beyond epsilon
                // from it below 90° (a pier's edge 0.998 epsilon in front
                // of an oblique facade at 48°, the line 1.34 epsilon
                // outside the pier: the pair read as disjoint, and its
                // pieces after ugcut, with vertices on that edge, as
                // intersecting; property seed 170098 to 3 decimals). The
                // event is tried, and a cut ends, at the edge's point.
                let on_edge = lying_other
                    .iter()
                    .filter(|((t0, _), (t1, _))| t >= *t0 && t <= *t1)
                    .map(|&((t0, e0), (t1, e1))| e0 + (e1 - e0) * ((t - t0) / (t1 - t0)))
                    .min_by(|u, v| (*u - x).length().total_cmp(&(*v - x).length()))
                    .filter(|_| other.locate(x, eps) == Location::Outside);
                ev.push((t, x, on_edge.unwrap_or(x), None));
            }
        }
    }
    if ev.is_empty() {
        return LineCase::Disjoint;
    }
    ev.sort_by(|x, y| x.0.total_cmp(&y.0));
    let ev = merge_events(ev, eps, steep, a, b);
    let ts = ev.iter().map(|e| e.0).collect();
    let at = ev.iter().map(|e| e.1).collect();
    let near = ev.iter().map(|e| e.2).collect();
    LineCase::Line {
        p0,
        dir,
        ts,
        at,
        near,
        steep,
    }
}

/// A boundary event of [`line_of`]: where along the line, the point on it,
/// the point tried (`near`), and, for an event at a vertex, the vertex and
/// whether it is the second face's.
type Event = (f64, DVec3, DVec3, Option<(DVec3, bool)>);

/// The boundary events of [`line_of`] (sorted along the line) merged where
/// they lie within epsilon along it, each run of them (within epsilon of
/// its first) standing as one. At a steep angle the one that stands is not
/// the first found but, in this order, a vertex of both faces (found from
/// each), then the event whose point lies nearest both planes (the sum of
/// its distances), then the first: the events of the two faces are found
/// one face after the other, and which came first decided where a stretch
/// ended. A ceiling ending on a wall along a chord between two of the
/// wall's vertices, the wall's top corner 1.0 epsilon above the chord's
/// end: with the wall first, its corner stood for that end, the stretch's
/// middle ran along the wall's top edge, and the wall was not cut along
/// the chord; with the ceiling first it was (property seed 170449 to 1 mm:
/// ugcut's patches of the two faces intersected).
fn merge_events(ev: Vec<Event>, eps: f64, steep: bool, a: &FaceGeom, b: &FaceGeom) -> Vec<Event> {
    let mut out = Vec::with_capacity(ev.len());
    let mut i = 0;
    while i < ev.len() {
        let mut j = i + 1;
        while j < ev.len() && (ev[j].0 - ev[i].0).abs() <= eps {
            j += 1;
        }
        let run = &ev[i..j];
        let pick = if steep && run.len() > 1 {
            let shared = |e: &Event| {
                e.3.is_some_and(|(p, of_b)| {
                    run.iter()
                        .any(|f| f.3.is_some_and(|(q, f_of_b)| q == p && f_of_b != of_b))
                })
            };
            // (Shared first, then nearest both planes; the first on a tie.)
            let score = |e: &Event| {
                (
                    u8::from(!shared(e)),
                    a.plane.dist(e.2).abs() + b.plane.dist(e.2).abs(),
                )
            };
            let mut best = 0;
            let mut key = score(&run[0]);
            for (k, e) in run.iter().enumerate().skip(1) {
                let s = score(e);
                if s.0 < key.0 || (s.0 == key.0 && s.1 < key.1) {
                    (best, key) = (k, s);
                }
            }
            best
        } else {
            0
        };
        out.push(run[pick]);
        i = j;
    }
    out
}

/// Where two faces that are not coplanar cut each other: the segments of
/// the line where their planes meet that lie in both (closed) faces and in
/// the interior of at least one, in 3-D, ordered along the line. A segment
/// that ends where an edge crosses the other face's plane ends at that
/// crossing itself, not at its projection on the line: the planes of faces
/// that are planar only within epsilon (a long, thin end face of a slab,
/// jittered) meet in slightly different lines, and the faces sharing an
/// edge then found its crossing of a third face's plane at points up to a
/// few epsilons apart, which became a needle. (A vertex within epsilon of
/// the other plane still ends a segment at its foot on the line: where the
/// faces meet at a shallow angle, the line lies several epsilons along the
/// face from it, and the face must be cut there.) Where a
/// face only rests on the other's boundary (edge on edge) there is no cut.
/// Where they meet at a single point inside one of them (a tip resting on a
/// face), a cut of 4 `eps` along the line through the point stands for it.
/// Empty for disjoint, touching or coplanar faces.
pub fn cut_segments(a: &FaceGeom, b: &FaceGeom, eps: f64) -> Vec<(DVec3, DVec3)> {
    let (p0, dir, ts, at, near, steep) = match line_of(a, b, eps) {
        LineCase::Line {
            p0,
            dir,
            ts,
            at,
            near,
            steep,
        } => (p0, dir, ts, at, near, steep),
        _ => return Vec::new(),
    };
    // Stretches between boundary events, as indices into `ts`.
    let mut out: Vec<(usize, usize)> = Vec::new();
    let meets_at = |s: DVec3| {
        let la = a.locate(s, eps);
        let lb = b.locate(s, eps);
        la != Location::Outside
            && lb != Location::Outside
            && (la == Location::Inside || lb == Location::Inside)
    };
    for (k, w) in ts.windows(2).enumerate() {
        // At a steep angle, between the ends as tried: where the faces
        // share an edge whose vertices lie within epsilon of both planes,
        // the planes' line may run 1.08 epsilon inside both faces (a roof
        // at 20° on a slab's eave, both planar only within epsilon;
        // property seed 27265), and its middle is no point of either
        // boundary, while the edge's middle is.
        let s = stretch_middle(steep, &near, k, p0 + dir * ((w[0] + w[1]) / 2.0));
        let la = a.locate(s, eps);
        if la == Location::Outside {
            continue;
        }
        let lb = b.locate(s, eps);
        if lb == Location::Outside || (steep && corner_fan(a, b, eps, &near, k, la, lb)) {
            continue;
        }
        // Within epsilon of both boundaries along its middle: a cut only
        // if one of its ends lies inside a face (a short stretch, under
        // 2 epsilon, from one face's edge to the other's corner just
        // inside it: the pair intersects there, as `relate` finds), and
        // the faces meet at an angle: for nearly parallel faces the line
        // moves by epsilon / sin θ when a face moves by epsilon, so which
        // end is inside is rounding (a rug on a tile, tilted apart by
        // jitter, cut again in every round: such overlaps are ugcopl's).
        // The ends are tried where `relate` tries them (a vertex within
        // epsilon of the other plane as itself, at a steep angle): a slab's
        // side face perpendicular to it whose top edge zigzags 1.05
        // epsilon either side of the slab's edge (tile corners welded to
        // it or not), the corners just inside the slab, while the planes'
        // line runs between, within epsilon of both edges (plain property
        // seed 15361: an intersecting pair `relate` found and no cut).
        if la == Location::Boundary
            && lb == Location::Boundary
            && !(steep && (meets_at(near[k]) || meets_at(near[k + 1])))
        {
            continue;
        }
        match out.last_mut() {
            Some(last) if last.1 == k && !(steep && near[k] != at[k]) => last.1 = k + 1,
            _ => out.push((k, k + 1)),
        }
    }
    // Where they meet at a point only (a corner resting inside a face):
    // a cut of 4 epsilon along the line through it, for the cutter to
    // extend until the point lies on an edge.
    // At a steep angle a cut runs through the vertices within epsilon of
    // the other plane themselves, one segment between each two, not along
    // the planes' line past them: where a face is planar only within
    // epsilon, its edge lying in the other face's plane zigzags up to
    // about epsilon either side of the planes' line (plain property seed
    // 15361, a slab's side face under a floor, its top edge through tile
    // corners 1.05 epsilon apart across: the corners 1.05 epsilon inside
    // the floor were left off a cut along the line). The edge itself is
    // where the faces meet.
    let end = |i: usize| if steep { near[i] } else { at[i] };
    let mut segs: Vec<(f64, DVec3, DVec3)> = out
        .into_iter()
        .map(|(i, j)| (ts[i], end(i), end(j)))
        .collect();
    if POINT_CUTS {
        for (&t, &x) in ts.iter().zip(&at) {
            if segs.iter().any(|&(t0, p, q)| {
                let t1 = t0 + (q - p).dot(dir);
                t >= t0 - eps && t <= t1 + eps
            }) {
                continue;
            }
            if meets_at(p0 + dir * t) {
                segs.push((t - 2.0 * eps, x - dir * (2.0 * eps), x + dir * (2.0 * eps)));
            }
        }
    }
    segs.sort_by(|x, y| x.0.total_cmp(&y.0));
    segs.into_iter().map(|(_, p, q)| (p, q)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(pts: [[f64; 3]; 4]) -> FaceGeom {
        FaceGeom::new(vec![pts.iter().map(|p| DVec3::from_array(*p)).collect()]).unwrap()
    }

    const EPS: f64 = 1e-9;

    fn floor() -> FaceGeom {
        quad([[0., 0., 0.], [4., 0., 0.], [4., 4., 0.], [0., 4., 0.]])
    }

    #[test]
    fn crossing_quads_intersect() {
        let wall = quad([[2., -1., -1.], [2., 5., -1.], [2., 5., 1.], [2., -1., 1.]]);
        assert_eq!(relate(&floor(), &wall, EPS), Relation::Intersect);
        assert_eq!(relate(&wall, &floor(), EPS), Relation::Intersect);
    }

    /// A ceiling ending on a wall along a chord between two of the wall's
    /// vertices, 1.0 to 1.4 epsilon below the wall's top edge (the wall
    /// goes on into the slab above): the pair intersects and the wall is
    /// cut along the chord, whichever face is asked first (property seed
    /// 170449 to 1 mm; with the wall first the wall's top corner stood for
    /// the chord's end, and there was no cut).
    #[test]
    fn a_chord_cut_does_not_depend_on_the_order() {
        let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let (c0, c1) = (
            v(3.5699999343787043, 2.98188523706414, 2.799080966793545),
            v(8.974999968766856, 2.4640066868579353, 2.7990811492975776),
        );
        let wall = FaceGeom::new(vec![vec![
            v(3.57, 2.9818855067450714, 2.801193442030125),
            c0,
            v(3.57, 2.9818855067450714, 0.0),
            v(8.975000000000001, 2.4640076098235904, 3.469446951953614e-18),
            c1,
            v(8.975, 2.4640076098235904, 2.802),
        ]])
        .unwrap();
        let ceiling = FaceGeom::new(vec![
            vec![
                v(3.57, 1.427, 2.802),
                v(3.57, 2.627, 2.802),
                c0,
                c1,
                v(8.975, -0.11738754503345333, 2.802),
                v(3.57, 0.40002367472979916, 2.800676576900425),
            ],
            vec![
                v(6.173, 1.203, 2.800377431977565),
                v(6.473, 1.174, 2.8003775250595178),
                v(6.492945246002003, 1.481978098400801, 2.8002769485825136),
                v(6.173820978586864, 1.502920638736603, 2.8002800646881845),
            ],
        ])
        .unwrap();
        let eps = 0.0021;
        for (a, b) in [(&wall, &ceiling), (&ceiling, &wall)] {
            assert_eq!(relate(a, b, eps), Relation::Intersect);
            let cuts = cut_segments(a, b, eps);
            assert_eq!(cuts.len(), 1, "{cuts:?}");
            let (p, q) = cuts[0];
            let ends = if p.x < q.x { (p, q) } else { (q, p) };
            assert_eq!(ends, (c0, c1));
        }
    }

    #[test]
    fn wall_standing_inside_floor_intersects() {
        let wall = quad([[1., 1., 0.], [3., 1., 0.], [3., 1., 2.], [1., 1., 2.]]);
        assert_eq!(relate(&floor(), &wall, EPS), Relation::Intersect);
    }

    /// A slab's side face under a floor, its top edge lying in the floor's
    /// plane and zigzagging 1.05 epsilon across the floor's edge (tile
    /// corners welded to the edge or not; plain property seed 15361). The
    /// corners off the edge lie inside the floor, so the pair intersects,
    /// and the floor is cut through those corners themselves: the planes'
    /// line runs between the zigzag's sides, within epsilon of both
    /// faces' edges, and a cut along it (none, before) left the corners
    /// 1.05 epsilon inside a piece.
    #[test]
    fn a_zigzag_edge_resting_in_a_face_is_cut_through_its_corners() {
        let d = 1.05 * EPS;
        let floor = quad([[2., 0., 0.], [4., 0., 0.], [4., 4., 0.], [2., 4., 0.]]);
        let side = FaceGeom::new(vec![vec![
            DVec3::new(2.0, 0.0, -0.2),
            DVec3::new(2.0, 4.0, -0.2),
            DVec3::new(2.0, 4.0, 0.0),
            DVec3::new(2.0 + d, 3.0, 0.0),
            DVec3::new(2.0 + d, 2.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
        ]])
        .unwrap();
        assert_eq!(relate(&floor, &side, EPS), Relation::Intersect);
        for (a, b) in [(&floor, &side), (&side, &floor)] {
            let cuts = cut_segments(a, b, EPS);
            for y in [3.0, 2.0] {
                let p = DVec3::new(2.0 + d, y, 0.0);
                assert!(
                    cuts.iter()
                        .any(|&(q, r)| q.distance(p) < 1e-3 * EPS || r.distance(p) < 1e-3 * EPS),
                    "{cuts:?}"
                );
            }
        }
    }

    /// A roof piece at 20° on a slab piece's eave, the two sharing that
    /// edge, both planar only within epsilon (property seed 27265): the
    /// planes' line runs 1.08 epsilon inside both faces, so its middle
    /// between the edge's ends was inside both, an intersection, while
    /// the only cut through the ends was the shared edge itself. The
    /// middle of a stretch between vertices is now taken between them:
    /// they touch.
    #[test]
    fn faces_sharing_an_edge_off_the_planes_line_touch() {
        let eps = 1.3031225921596104e-5;
        let slab = FaceGeom::new(vec![vec![
            DVec3::new(5.015846397000653, 0.14999976254880565, 2.9999992099778825),
            DVec3::new(4.765917246387643, 0.2867807285092018, 3.000000968946496),
            DVec3::new(4.765917187974574, 4.1916393959123495, 3.000000577908634),
            DVec3::new(4.765846532445101, 4.1916382472938025, 3.000001083333685),
            DVec3::new(4.765844397034348, 0.03345045587952828, 3.0000001319028233),
            DVec3::new(5.015846400432814, 0.033450314559720695, 2.999999156740722),
        ]])
        .unwrap();
        let roof = FaceGeom::new(vec![vec![
            DVec3::new(4.802890352433134, 4.191639410839906, 3.000000573402579),
            DVec3::new(5.015846277982049, 4.19163811627445, 3.000001056107174),
            DVec3::new(5.015845751847234, 2.1125446049388095, 3.766037905694291),
            DVec3::new(4.765846652101182, 2.112544613577388, 3.7660378957905727),
            DVec3::new(4.765846532445101, 4.1916382472938025, 3.000001083333685),
            DVec3::new(4.765917187974574, 4.1916393959123495, 3.000000577908634),
        ]])
        .unwrap();
        assert_eq!(relate(&slab, &roof, eps), Relation::Touch);
        assert_eq!(relate(&roof, &slab, eps), Relation::Touch);
        assert!(cut_segments(&slab, &roof, eps).is_empty());
    }

    /// A pyramid's apex resting inside a floor touches it: the faces meet
    /// at that point only, which no cut resolves. Pushed a hair through,
    /// the faces cross along short segments, and they intersect.
    #[test]
    fn an_apex_resting_inside_a_face_touches_it() {
        let tri = |z: f64| {
            FaceGeom::new(vec![vec![
                DVec3::new(2.0, 2.0, z),
                DVec3::new(3.0, 2.0, 1.0),
                DVec3::new(3.0, 3.0, 1.0),
            ]])
            .unwrap()
        };
        assert_eq!(relate(&floor(), &tri(0.0), EPS), Relation::Touch);
        assert_eq!(relate(&tri(0.0), &floor(), EPS), Relation::Touch);
        assert_eq!(relate(&floor(), &tri(-0.01), EPS), Relation::Intersect);
        // Its apex outside the floor: they do not meet.
        let out = FaceGeom::new(vec![vec![
            DVec3::new(5.0, 2.0, 0.0),
            DVec3::new(6.0, 2.0, 1.0),
            DVec3::new(6.0, 3.0, 1.0),
        ]])
        .unwrap();
        assert_eq!(relate(&floor(), &out, EPS), Relation::Disjoint);
        // An edge resting in the floor still intersects it.
        let leaning = FaceGeom::new(vec![vec![
            DVec3::new(1.0, 2.0, 0.0),
            DVec3::new(3.0, 2.0, 0.0),
            DVec3::new(2.0, 3.0, 1.0),
        ]])
        .unwrap();
        assert_eq!(relate(&floor(), &leaning, EPS), Relation::Intersect);
    }

    #[test]
    fn wall_on_floor_edge_touches() {
        let wall = quad([[0., 0., 0.], [4., 0., 0.], [4., 0., 2.], [0., 0., 2.]]);
        assert_eq!(relate(&floor(), &wall, EPS), Relation::Touch);
        let corner = quad([[4., 4., 0.], [5., 4., 0.], [5., 4., 2.], [4., 4., 2.]]);
        assert_eq!(relate(&floor(), &corner, EPS), Relation::Touch);
    }

    /// A face resting on another's plane at a shallow angle: the line
    /// they meet in runs through the vertices on both planes (the edge
    /// they share), not along the planes' line (2 epsilon off here, which
    /// made the pair of dirty building seed 11847, a table leg on a column
    /// face tilted by 0.4° sharing an edge with it, seem to intersect).
    #[test]
    fn resting_at_a_shallow_angle() {
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let column = FaceGeom::new(vec![vec![
            p(2.0221591960159784, 3.7959141620002286, 0.7200000398355576),
            p(2.01707272061008, 3.7170764491920893, 4.910310253715411e-8),
            p(2.0170726962841456, 3.821801289820118, -2.13086588881234e-7),
            p(2.0207552565476017, 3.821801185408786, 0.521271372836174),
            p(2.020755474443979, 3.871802199486966, 0.5213038518070988),
            p(2.0170726846697025, 3.8718022474669236, -2.21681809486411e-7),
            p(2.017072651308243, 4.015425515473827, -2.1834360135891684e-9),
            p(2.0368534602698993, 4.025314156095974, 2.8000003458066054),
            p(2.03685346065031, 4.023667590990537, 2.800000345797973),
            p(2.0224417791905918, 3.800294053651479, 0.7600002102614042),
            p(2.0224417543199973, 3.9068022828116358, 0.760000173495152),
            p(2.022159172501155, 3.9068007467802808, 0.7200003381889988),
        ]])
        .unwrap();
        let leg = FaceGeom::new(vec![vec![
            p(2.020755474443979, 3.871802199486966, 0.5213038518070988),
            p(2.0207552565476017, 3.821801185408786, 0.521271372836174),
            p(2.0207548914622695, 3.8218011635295843, 0.720000038429558),
            p(2.0207556214977163, 3.871802175084057, 0.7200000360013729),
        ]])
        .unwrap();
        let eps = 9.314923e-6;
        assert_eq!(relate(&column, &leg, eps), Relation::Touch);
        assert_eq!(relate(&leg, &column, eps), Relation::Touch);
        assert!(cut_segments(&column, &leg, eps).is_empty());
        // A panel leaning at 0.5° with its foot inside the floor: it
        // intersects, and the cut is the foot itself, to 1e-12.
        let tilt = 0.5f64.to_radians();
        let lean = quad([
            [1., 1., 0.],
            [3., 1., 0.],
            [3., 1. + 2. * tilt.cos(), 2. * tilt.sin()],
            [1., 1. + 2. * tilt.cos(), 2. * tilt.sin()],
        ]);
        let eps = 1e-6;
        assert_eq!(relate(&floor(), &lean, eps), Relation::Intersect);
        let c = cut_segments(&floor(), &lean, eps);
        assert_eq!(c.len(), 1);
        let (a, b) = if c[0].0.x < c[0].1.x {
            c[0]
        } else {
            (c[0].1, c[0].0)
        };
        assert!((a - p(1., 1., 0.)).length() < 1e-12, "{a}");
        assert!((b - p(3., 1., 0.)).length() < 1e-12, "{b}");
    }

    /// Seed 2615 (with stairs): a ramp's slope at 4° and the piece of a
    /// box's bottom it was cut from, which wraps round the ramp's side, so
    /// that neither lies on one side of the other. They share an edge and
    /// touch; the planes' line is 1.4 epsilon off that edge.
    #[test]
    fn sharing_an_edge_at_a_shallow_angle_when_neither_rests() {
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let bottom = FaceGeom::new(vec![vec![
            p(0.10499917237331989, 0.25989685733555684, 2.9911432228350265),
            p(0.10499894965394609, 1.1598980704468014, 2.991143856501989),
            p(0.12423570220526307, 1.1598980964237116, 2.991143865576042),
            p(0.12423540759829599, 0.2708302096577228, 2.991143659007495),
            p(0.605000286623535, 0.270849296576645, 2.9911450407049296),
            p(0.6050003017826061, 0.25989854792122286, 2.991145052386116),
        ]])
        .unwrap();
        let ramp = FaceGeom::new(vec![vec![
            p(0.12423540461668287, 0.22500070118119836, 2.987921140232155),
            p(1.170105269107447, 0.2250006548221171, 2.987921175223919),
            p(1.1701052736166762, 0.3967810679949891, 2.9999999098961223),
            p(0.6050001139147175, 0.3967780996976585, 2.999999549756932),
            p(0.605000286623535, 0.270849296576645, 2.9911450407049296),
            p(0.12423540759829599, 0.2708302096577228, 2.991143659007495),
        ]])
        .unwrap();
        let eps = 1.1036686653305318e-5;
        assert_eq!(relate(&bottom, &ramp, eps), Relation::Touch);
        assert_eq!(relate(&ramp, &bottom, eps), Relation::Touch);
        assert!(cut_segments(&bottom, &ramp, eps).is_empty());
    }

    #[test]
    fn separated_and_coplanar() {
        let above = quad([[0., 0., 1.], [1., 0., 1.], [1., 0., 2.], [0., 0., 2.]]);
        assert_eq!(relate(&floor(), &above, EPS), Relation::Disjoint);
        let flat = quad([[1., 1., 0.], [2., 1., 0.], [2., 2., 0.], [1., 2., 0.]]);
        assert_eq!(relate(&floor(), &flat, EPS), Relation::Coplanar);
        // A wall whose foot lies outside the floor, in the floor's plane line.
        let outside = quad([[5., 0., -1.], [5., 4., -1.], [5., 4., 1.], [5., 0., 1.]]);
        assert_eq!(relate(&floor(), &outside, EPS), Relation::Disjoint);
    }

    #[test]
    fn crossing_through_a_hole_is_disjoint() {
        let mut hole = vec![
            DVec3::new(1., 1., 0.),
            DVec3::new(3., 1., 0.),
            DVec3::new(3., 3., 0.),
            DVec3::new(1., 3., 0.),
        ];
        hole.reverse();
        let outer = vec![
            DVec3::new(0., 0., 0.),
            DVec3::new(4., 0., 0.),
            DVec3::new(4., 4., 0.),
            DVec3::new(0., 4., 0.),
        ];
        let ring = FaceGeom::new(vec![outer, hole]).unwrap();
        let pole = quad([[1.5, 2., -1.], [2.5, 2., -1.], [2.5, 2., 1.], [1.5, 2., 1.]]);
        assert_eq!(relate(&ring, &pole, EPS), Relation::Disjoint);
        let wide = quad([[0.5, 2., -1.], [2.5, 2., -1.], [2.5, 2., 1.], [0.5, 2., 1.]]);
        assert_eq!(relate(&ring, &wide, EPS), Relation::Intersect);
    }

    #[test]
    fn cuts_are_where_both_faces_are() {
        // A wall standing on a floor, its foot inside: the cut is the foot.
        let wall = quad([[1., 1., 0.], [3., 1., 0.], [3., 1., 2.], [1., 1., 2.]]);
        let c = cut_segments(&floor(), &wall, EPS);
        assert_eq!(c.len(), 1);
        let (p, q) = c[0];
        let (lo, hi) = if p.x < q.x { (p, q) } else { (q, p) };
        assert!((lo - DVec3::new(1., 1., 0.)).length() < 1e-12);
        assert!((hi - DVec3::new(3., 1., 0.)).length() < 1e-12);
        // A wall crossing the floor beyond its edge: cut only inside the floor.
        let long = quad([[-1., 2., -1.], [6., 2., -1.], [6., 2., 1.], [-1., 2., 1.]]);
        let c = cut_segments(&floor(), &long, EPS);
        assert_eq!(c.len(), 1);
        let (p, q) = c[0];
        assert!(((p - q).length() - 4.0).abs() < 1e-12);
        // Touching along the boundary only: no cut.
        let edge = quad([[0., 0., 0.], [4., 0., 0.], [4., 0., 2.], [0., 0., 2.]]);
        assert!(cut_segments(&floor(), &edge, EPS).is_empty());
        // Through a hole: two pieces.
        let mut hole = vec![
            DVec3::new(1., 1., 0.),
            DVec3::new(3., 1., 0.),
            DVec3::new(3., 3., 0.),
            DVec3::new(1., 3., 0.),
        ];
        hole.reverse();
        let outer = vec![
            DVec3::new(0., 0., 0.),
            DVec3::new(4., 0., 0.),
            DVec3::new(4., 4., 0.),
            DVec3::new(0., 4., 0.),
        ];
        let ring = FaceGeom::new(vec![outer, hole]).unwrap();
        let wide = quad([[-1., 2., -1.], [5., 2., -1.], [5., 2., 1.], [-1., 2., 1.]]);
        let c = cut_segments(&ring, &wide, EPS);
        assert_eq!(c.len(), 2);
        for (p, q) in c {
            assert!(((p - q).length() - 1.0).abs() < 1e-12);
        }
    }
    /// Seed 8666 (3 × 2 rooms with stairs): a sunk ramp's slope at 6.4°
    /// and the tile beside it share an edge that zigzags by 1 epsilon (the
    /// tiles' jittered joints snapped into it). The joint's vertex lies
    /// 1.05 epsilon off the line, its foot inside the ramp: it is tried
    /// where it is, a vertex of both.
    #[test]
    fn a_zigzag_edge_at_a_shallow_angle_is_touched_at_its_vertices() {
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let tile = FaceGeom::new(vec![vec![
            p(5.210182455286792, 3.724999759608996, 1.6928552673438776e-6),
            p(5.810179976732396, 3.725001832092634, 5.2601993146256396e-8),
            p(5.810181404438861, 3.9508202350427557, 1.3063250919804747e-6),
            p(4.911667225236716, 3.950820622159642, -4.091659438729043e-7),
            p(
                4.615513138425262,
                3.9508206398479584,
                -4.0784917340608295e-7,
            ),
            p(4.6101805698079845, 3.9508211050959607, -9.84780366146047e-7),
            p(
                4.610182213639535,
                3.9491621195024043,
                -4.0771756149027283e-7,
            ),
            p(4.610180629502439, 3.7170624424613363, -8.095069061531819e-7),
            p(4.699894183508592, 3.7170584033215697, -3.763839943545435e-7),
            p(5.210182426927702, 3.717035382475538, 1.6754777382987164e-6),
        ]])
        .unwrap();
        let ramp = FaceGeom::new(vec![vec![
            p(
                5.6845235771963205,
                3.7170493726834897,
                -3.973921736122321e-7,
            ),
            p(5.684523642684133, 3.850821089209664, -0.01505292154925709),
            p(4.610182371284238, 3.850820197539395, -0.015051695358403495),
            p(4.610180629502439, 3.7170624424613363, -8.095069061531819e-7),
            p(4.699894183508592, 3.7170584033215697, -3.763839943545435e-7),
            p(5.210182426927702, 3.717035382475538, 1.6754777382987164e-6),
        ]])
        .unwrap();
        let eps = 1.892096550653604e-5;
        assert_eq!(relate(&tile, &ramp, eps), Relation::Touch);
        assert_eq!(relate(&ramp, &tile, eps), Relation::Touch);
        assert!(cut_segments(&tile, &ramp, eps).is_empty());
    }

    /// A ramp's side (steep, 90°) and the floor piece it stands through
    /// share an edge; the ramp's corner at the end of it lies 1.0001
    /// epsilon from the floor's edge in the floor's plane, but its foot on
    /// the planes' line lies a hair more than epsilon inside the floor
    /// (the 100,000-face CAD building with stairs: an intersecting pair
    /// that ugisect's snap rounding, which measures the corner itself,
    /// could not cut). A vertex on the other plane is tried where it is.
    #[test]
    fn a_corner_on_the_other_plane_is_tried_where_it_is() {
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let floor = FaceGeom::new(vec![vec![
            p(72.95385610684355, 9.356581197876707, 5.9999993960673095),
            p(72.95384288116097, 7.576948102062931, 5.999994541242828),
            p(73.08384772393735, 7.576937151346673, 6.000001778430269),
            p(73.08385002299785, 7.621848696019912, 5.999999271086049),
            p(73.10356257356385, 7.6218487800704615, 6.000003445725445),
            p(73.1035619321696, 7.79885623573579, 5.999999284801479),
            p(73.10356569901141, 9.072299689024376, 6.0000065173394495),
            p(73.10384142521168, 9.072346334613076, 6.000007808536367),
            p(73.1038524415452, 9.356599024469334, 5.999999400585212),
        ]])
        .unwrap();
        let ramp = FaceGeom::new(vec![vec![
            p(73.1035654811911, 9.269953766892776, 5.9871895511976145),
            p(73.10357683943732, 5.549952478647611, 5.9872061995327135),
            p(73.10357686079888, 5.549952015804269, 5.999999117732252),
            p(73.10356775840829, 6.006900427082299, 5.999990141357699),
            p(73.10356780454903, 6.028455444561275, 6.000000198132573),
            p(73.10356063446102, 6.7218509056726425, 6.000003378852994),
            p(73.10356942838851, 6.721850912999633, 5.995614923007768),
            p(73.1035713679374, 7.621848777250633, 5.9955958330242565),
            p(73.10356257356385, 7.6218487800704615, 6.000003445725445),
            p(73.1035619321696, 7.79885623573579, 5.999999284801479),
            p(73.10356569901141, 9.072299689024376, 6.0000065173394495),
            p(73.10356569889011, 9.072409764284313, 5.99999937946051),
        ]])
        .unwrap();
        let eps = 1.08547e-4;
        assert_eq!(relate(&floor, &ramp, eps), Relation::Touch);
        assert_eq!(relate(&ramp, &floor, eps), Relation::Touch);
    }
    /// A pendant light's cone facet and the stem's triangle sharing a
    /// corner (`corner_fan`; property seed 77213 with oblique wings): the
    /// triangle's chord through the facet's plane runs 2.5 epsilon from
    /// the corner, outside the facet but within epsilon of its edge for
    /// half of that. They touch at the corner; nothing to cut.
    #[test]
    fn a_chord_fanning_out_of_a_shared_corner_touches() {
        let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let eps = 1.425445052772243e-05;
        let corner = v(5.474884564789721, 1.2138694301319009, 2.43058693322533);
        let facet = FaceGeom::new(vec![vec![
            corner,
            v(5.4748746320647, 1.2134549066514242, 2.430511698422146),
            v(5.459008394822072, 1.2521973622474345, 2.430586822024978),
        ]])
        .unwrap();
        let stem = FaceGeom::new(vec![vec![
            v(5.47486695401017, 1.2138706543843534, 2.4305215512384697),
            corner,
            v(5.476804547936362, 1.2174458273737667, 2.438080699785843),
        ]])
        .unwrap();
        assert_eq!(relate(&facet, &stem, eps), Relation::Touch);
        assert_eq!(relate(&stem, &facet, eps), Relation::Touch);
        assert!(cut_segments(&facet, &stem, eps).is_empty());
        assert!(cut_segments(&stem, &facet, eps).is_empty());
        // The same shape in round numbers, its chord once out of the
        // facet past its corner (a fan: touch) and once into it (cut).
        let eps = 0.01;
        let facet = FaceGeom::new(vec![vec![
            DVec3::ZERO,
            v(1.0, 0.0, 0.0),
            v(-0.9, 0.44, 0.0),
        ]])
        .unwrap();
        let stem = |deg: f64| {
            let c = 2.5 * eps * DVec3::new(deg.to_radians().cos(), deg.to_radians().sin(), 0.0);
            FaceGeom::new(vec![vec![
                DVec3::ZERO,
                c + DVec3::Z * 0.3,
                c - DVec3::Z * 0.3,
            ]])
            .unwrap()
        };
        assert_eq!(relate(&facet, &stem(180.0), eps), Relation::Touch);
        assert_eq!(relate(&stem(180.0), &facet, eps), Relation::Touch);
        assert_eq!(relate(&facet, &stem(100.0), eps), Relation::Intersect);
        assert_eq!(relate(&stem(100.0), &facet, eps), Relation::Intersect);
        assert!(!cut_segments(&facet, &stem(100.0), eps).is_empty());
    }

    /// A wall whose foot runs half an epsilon above a floor, across it:
    /// the floor's interior meets the wall's boundary zone all along, a
    /// contact to cut (not a fan out of a corner).
    #[test]
    fn a_foot_half_an_epsilon_above_a_floor_intersects() {
        let h = 0.5 * EPS;
        let wall = quad([[1., 2., h], [3., 2., h], [3., 2., 2.], [1., 2., 2.]]);
        assert_eq!(relate(&floor(), &wall, EPS), Relation::Intersect);
        assert_eq!(relate(&wall, &floor(), EPS), Relation::Intersect);
        assert_eq!(cut_segments(&floor(), &wall, EPS).len(), 1);
    }

    /// A pier's edge 0.998 epsilon in front of an oblique facade at 48°,
    /// reaching past the facade's top and bottom (property seed 170098 to 3
    /// decimals, eps 2.1 mm): the planes' line runs 1.34 epsilon outside
    /// the pier, but the edge lies on the facade within epsilon, so the
    /// two meet along it and the cut runs along the edge, from the
    /// facade's bottom to its top. 1.5 epsilon away they are apart.
    #[test]
    fn an_edge_within_epsilon_of_an_oblique_face_meets_it() {
        let eps = 0.0021;
        let (ax, ay, bx, by) = (3.447, 0.14919534802378343, 8.708, -4.539199173695988);
        let facade = quad([[ax, ay, 0.], [bx, by, 0.], [bx, by, 2.8], [ax, ay, 2.8]]);
        let n = DVec2::new(by - ay, -(bx - ax)).normalize();
        let pier = |gap: f64| {
            // The edge's foot on the facade, 24 mm along it, moved `gap`
            // off the facade towards the pier's side.
            let along = DVec2::new(bx - ax, by - ay).normalize();
            let e = DVec2::new(ax, ay) + along * 0.0241 + n * gap;
            let (x, y) = (e.x, e.y);
            quad([
                [x, y - 0.25, -0.025],
                [x, y, -0.025],
                [x, y, 2.815],
                [x, y - 0.25, 2.815],
            ])
        };
        let near = pier(0.998 * eps);
        // The edge 0.998 epsilon off the facade's plane, the rest of the
        // pier far on the same side.
        let d = |p: DVec3| facade.plane.dist(p) * facade.plane.dist(near.contours[0][1]).signum();
        assert!((d(near.contours[0][1]) - 0.998 * eps).abs() < 1e-9);
        assert!(d(near.contours[0][0]) > 50.0 * eps);
        assert_eq!(relate(&facade, &near, eps), Relation::Intersect);
        assert_eq!(relate(&near, &facade, eps), Relation::Intersect);
        for (f, g) in [(&facade, &near), (&near, &facade)] {
            let segs = cut_segments(f, g, eps);
            assert_eq!(segs.len(), 1, "{segs:?}");
            let (p, q) = segs[0];
            let (lo, hi) = if p.z < q.z { (p, q) } else { (q, p) };
            assert!(lo.z.abs() < eps && (hi.z - 2.8).abs() < eps, "{segs:?}");
            // On the pier's edge, not on the planes' line.
            let edge = near.contours[0][1];
            for e in [lo, hi] {
                assert!(
                    DVec2::new(e.x - edge.x, e.y - edge.y).length() < 1e-9,
                    "{e}"
                );
            }
        }
        let far = pier(1.5 * eps);
        assert_eq!(relate(&facade, &far, eps), Relation::Disjoint);
        assert_eq!(relate(&far, &facade, eps), Relation::Disjoint);
        assert!(cut_segments(&facade, &far, eps).is_empty());
    }
}
