//! Choosing the emitter triangle that next-event estimation samples.
//!
//! At a shading point x (front normal n) every emitter triangle gets a
//! weight that bounds its unoccluded irradiance there ([`Light::weight`]):
//! zero only where no point of it can contribute (all of it behind x's
//! tangent plane, or x behind it), positive anywhere else, so that dividing
//! by the probability of the choice keeps the estimate unbiased. Up to
//! [`FLAT_MAX`] emitter triangles one is chosen in proportion to the
//! weights of all ([`Selection::Flat`], O(emitters) a path vertex); above,
//! by a descent of a binary tree over them whose inner nodes bound the
//! irradiance of everything below ([`Selection::Tree`], O(log emitters)).
//! Occlusion is not known to either: a lamp behind a wall keeps its weight,
//! but the lamps near x, in front of it and facing it, get most of the
//! choices instead of a share of the power of the whole model (the power
//! distribution, [`Selection::Power`], is kept as the tests' reference).

use std::f64::consts::PI;

use glam::DVec3;

use crate::{Rng, Tri};

/// Up to this many emitter triangles next-event estimation weighs every
/// one at every path vertex ([`Selection::Flat`]); above, it descends the
/// light tree ([`Selection::Tree`]). Measured on `ugbuilding --lights
/// --furniture 2` buildings (50 points, 4,096 paths): the tree's standard
/// error is 1.0–1.5 times the flat one's (18 to 884 emitter triangles),
/// at the same time up to ~70 emitter triangles but at a fifth of it at
/// 884 (1.9 s against 9–18 s on one core); the tree is the better buy
/// from about 100.
pub(crate) const FLAT_MAX: usize = 96;

/// The least cosine the bounds of [`Light::weight`] give a triangle that
/// may contribute (so that no such triangle gets a vanishing weight).
const COS_FLOOR: f64 = 0.05;

/// Relative tolerance of the zero-weight tests (of a distance, or of an
/// angle in radians): a test fails only this far beyond its boundary.
const SLACK: f64 = 1e-9;

/// How next-event estimation chooses the emitter triangle it samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Selection {
    /// In proportion to emitted power, Σ|E| × area, the same everywhere
    /// (the estimator before the two below; kept as the tests' reference).
    #[cfg_attr(not(test), allow(dead_code))]
    Power,
    /// In proportion to a bound of each triangle's unoccluded irradiance at
    /// the shading point ([`Light::weight`]), every triangle weighed.
    Flat,
    /// By a descent of the light tree ([`LightTree::pick`]).
    Tree,
}

impl Selection {
    /// The selection for a scene with `count` emitter triangles.
    pub(crate) fn for_count(count: usize) -> Selection {
        if count <= FLAT_MAX {
            Selection::Flat
        } else {
            Selection::Tree
        }
    }
}

/// An emitter triangle, for choosing one at a shading point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Light {
    corners: [DVec3; 3],
    centroid: DVec3,
    /// Unit normal of the front.
    normal: DVec3,
    /// Largest distance from the centroid to a corner.
    radius: f64,
    area: f64,
    /// Σ|E|: the exitance summed over the channels.
    exitance: f64,
}

impl Light {
    pub(crate) fn new(t: &Tri, exitance: f64) -> Light {
        let centroid = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
        let radius =
            t.p.iter()
                .map(|&p| (p - centroid).length())
                .fold(0.0, f64::max);
        Light {
            corners: t.p,
            centroid,
            normal: t.normal,
            radius,
            area: t.area,
            exitance,
        }
    }

    /// Σ|E| × area: the weight of [`Selection::Power`].
    pub(crate) fn power(&self) -> f64 {
        self.exitance * self.area
    }

    /// The weight of this triangle at the ray origin `o` (on a surface with
    /// front normal `n`): about its unoccluded irradiance there,
    ///
    ///   Σ|E| × min(1, area × c_x × c_e / (π max(d², radius²))),
    ///
    /// d the distance to the centroid, c_x and c_e upper bounds of the
    /// cosines at `o` and at the triangle over the whole triangle (the
    /// cosine toward the centroid widened by the half-angle of the
    /// triangle's bounding sphere seen from `o`), at least [`COS_FLOOR`];
    /// the form factor of one triangle is at most 1.
    ///
    /// Zero only when no point of the triangle can contribute: every
    /// corner on or behind the tangent plane at `o`, or `o` on or behind
    /// the triangle's plane at every corner (both tests are linear over the
    /// triangle, so the corners decide them; "on" within [`SLACK`] of the
    /// distance, so that rounding never zeroes a grazing triangle that
    /// `Scene::direct` could count). Anywhere else the weight is positive,
    /// which keeps the estimator unbiased.
    pub(crate) fn weight(&self, o: DVec3, n: DVec3) -> f64 {
        // Positive, or zero within rounding (|w|₁ ≥ |w|).
        let ahead = |m: DVec3, w: DVec3| m.dot(w) > -SLACK * (w.x.abs() + w.y.abs() + w.z.abs());
        let front = self.corners.iter().any(|&p| ahead(n, p - o));
        let facing = self.corners.iter().any(|&p| ahead(self.normal, o - p));
        if !(front && facing) {
            return 0.0;
        }
        let v = self.centroid - o;
        let d2 = v.length_squared();
        if d2 <= self.radius * self.radius {
            // o is within the bounding sphere: no useful bound.
            return self.exitance;
        }
        let d = d2.sqrt();
        // The bounding sphere's half-angle θ_b seen from o.
        let sin_b = self.radius / d;
        let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
        // cos(max(θ − θ_b, 0)) bounds the cosine of angle θ at the centroid
        // over the sphere.
        let widen = |c: f64| {
            let c = c.clamp(-1.0, 1.0);
            if c >= cos_b {
                1.0
            } else {
                c * cos_b + (1.0 - c * c).sqrt() * sin_b
            }
        };
        let cx = widen(n.dot(v) / d).max(COS_FLOOR);
        let ce = widen(-self.normal.dot(v) / d).max(COS_FLOOR);
        let f = (self.area * cx * ce / (PI * d2)).min(1.0);
        let w = self.exitance * f;
        if w > 0.0 && w.is_finite() {
            w
        } else {
            self.exitance
        }
    }
}

/// A binary tree over the emitter triangles (the leaves), for choosing
/// one at a shading point in O(log emitters): from the root down, one
/// child of each inner node in proportion to the children's importance at
/// the point (an inner node's [`LightNode::importance`], a leaf's
/// [`Light::weight`]). The probability of an emitter is the product of the
/// choices on its way, positive wherever it can contribute (every bound
/// above it is), so the estimate stays unbiased.
#[derive(Clone, Debug, Default)]
pub(crate) struct LightTree {
    /// The root first; empty without emitters.
    nodes: Vec<LightNode>,
    /// Each node's parent (`u32::MAX` at the root) and each light's leaf.
    parent: Vec<u32>,
    leaf_of: Vec<u32>,
}

impl LightTree {
    /// The tree over `lights`: median splits of the centroids along the
    /// longest axis of their box, down to one emitter a leaf.
    pub(crate) fn new(lights: &[Light]) -> LightTree {
        let mut nodes = Vec::with_capacity(2 * lights.len());
        let mut order: Vec<u32> = (0..lights.len() as u32).collect();
        if !order.is_empty() {
            Self::build(lights, &mut order, &mut nodes);
        }
        let mut parent = vec![u32::MAX; nodes.len()];
        let mut leaf_of = vec![u32::MAX; lights.len()];
        for (i, node) in nodes.iter().enumerate() {
            match node.kind {
                NodeKind::Leaf(k) => leaf_of[k as usize] = i as u32,
                NodeKind::Inner(a, b) => {
                    parent[a as usize] = i as u32;
                    parent[b as usize] = i as u32;
                }
            }
        }
        LightTree {
            nodes,
            parent,
            leaf_of,
        }
    }

    /// The importance of node `i` at `o` (front normal `n`).
    fn importance(&self, lights: &[Light], i: usize, o: DVec3, n: DVec3) -> f64 {
        let node = &self.nodes[i];
        match node.kind {
            NodeKind::Leaf(k) => lights[k as usize].weight(o, n),
            NodeKind::Inner(..) => node.importance(o, n),
        }
    }

    /// An emitter (an index into `lights`) and its probability. `None`
    /// when both children of a node on the way have no importance (no
    /// emitter below can contribute) or there are no emitters.
    pub(crate) fn pick(
        &self,
        lights: &[Light],
        o: DVec3,
        n: DVec3,
        rng: &mut Rng,
    ) -> Option<(usize, f64)> {
        let mut i = 0;
        let mut p = 1.0;
        loop {
            match self.nodes.get(i)?.kind {
                NodeKind::Leaf(k) => return Some((k as usize, p)),
                NodeKind::Inner(a, b) => {
                    let (a, b) = (a as usize, b as usize);
                    let ia = self.importance(lights, a, o, n);
                    let ib = self.importance(lights, b, o, n);
                    let t = ia + ib;
                    if !(t > 0.0 && t.is_finite()) {
                        return None;
                    }
                    let u = rng.f64() * t;
                    if ib <= 0.0 || (ia > 0.0 && u < ia) {
                        i = a;
                        p *= ia / t;
                    } else {
                        i = b;
                        p *= ib / t;
                    }
                }
            }
        }
    }

    /// The probability that [`LightTree::pick`] at `o` (front normal `n`)
    /// returns light `k`: the product, from the root down to `k`'s leaf,
    /// of the share of each node's importance that the branch towards `k`
    /// holds. O(depth); what a BSDF-sampled path that hits emitter `k`
    /// needs for its multiple-importance weight.
    pub(crate) fn probability(&self, lights: &[Light], k: usize, o: DVec3, n: DVec3) -> f64 {
        let Some(&leaf) = self.leaf_of.get(k) else {
            return 0.0;
        };
        let mut p = 1.0;
        let mut c = leaf as usize;
        while let Some(&up) = self.parent.get(c) {
            if up == u32::MAX {
                break;
            }
            let NodeKind::Inner(a, b) = self.nodes[up as usize].kind else {
                return 0.0;
            };
            let ia = self.importance(lights, a as usize, o, n);
            let ib = self.importance(lights, b as usize, o, n);
            let t = ia + ib;
            if !(t > 0.0 && t.is_finite()) {
                return 0.0;
            }
            p *= if c == a as usize { ia } else { ib } / t;
            c = up as usize;
        }
        p
    }

    /// Builds the subtree over `order` into `nodes`; returns its root.
    fn build(lights: &[Light], order: &mut [u32], nodes: &mut Vec<LightNode>) -> usize {
        let ls = || order.iter().map(|&k| &lights[k as usize]);
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for l in ls() {
            for &p in &l.corners {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        let sum: DVec3 = ls().map(|l| l.normal).sum();
        let axis = sum.normalize_or_zero();
        let spread = if axis == DVec3::ZERO {
            PI
        } else {
            ls().map(|l| l.normal.dot(axis).clamp(-1.0, 1.0).acos())
                .fold(0.0, f64::max)
        };
        let power = ls().map(Light::power).sum();
        let size = ls().map(|l| l.radius).fold(0.0, f64::max);
        let at = nodes.len();
        nodes.push(LightNode {
            center: (lo + hi) / 2.0,
            half: (hi - lo) / 2.0,
            radius: (hi - lo).length() / 2.0,
            axis: if axis == DVec3::ZERO { DVec3::Z } else { axis },
            spread,
            power,
            size,
            kind: NodeKind::Leaf(order[0]),
        });
        if order.len() > 1 {
            let (mut clo, mut chi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for l in ls() {
                clo = clo.min(l.centroid);
                chi = chi.max(l.centroid);
            }
            let ext = chi - clo;
            let dim = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |&a, &b| {
                lights[a as usize].centroid[dim]
                    .total_cmp(&lights[b as usize].centroid[dim])
                    .then(a.cmp(&b))
            });
            let (left, right) = order.split_at_mut(mid);
            let a = Self::build(lights, left, nodes);
            let b = Self::build(lights, right, nodes);
            nodes[at].kind = NodeKind::Inner(a as u32, b as u32);
        }
        at
    }
}

/// A node of the light tree: a box around the emitter triangles below, a
/// cone around their normals and their power.
#[derive(Clone, Copy, Debug)]
struct LightNode {
    /// Centre and half-extents of the bounding box of every corner below.
    center: DVec3,
    half: DVec3,
    /// Half the box's diagonal: the radius of a sphere around it.
    radius: f64,
    /// Every front normal below is within `spread` (radians) of `axis`.
    axis: DVec3,
    spread: f64,
    /// Σ|E| × area below.
    power: f64,
    /// The largest `radius` of an emitter below.
    size: f64,
    kind: NodeKind,
}

#[derive(Clone, Copy, Debug)]
enum NodeKind {
    /// One emitter: an index into the lights.
    Leaf(u32),
    /// Two children: indices into [`LightTree::nodes`].
    Inner(u32, u32),
}

impl LightNode {
    /// About the largest irradiance the emitters below can give `o` (front
    /// normal `n`), on the scale of [`Light::weight`]:
    ///
    ///   power × c_x × c_e / (π max(δ², size²)),
    ///
    /// δ the distance from `o` to the box (0 inside), c_x and c_e upper
    /// bounds of the cosines at `o` and at the emitters over every point of
    /// the box and every normal of the cone (the angles toward the box's
    /// centre narrowed by the half-angle of its bounding sphere seen from
    /// `o`, and by the cone's spread; 1 inside the sphere), at least
    /// [`COS_FLOOR`]. Measuring to the box rather than to its centre sends
    /// the descent toward the emitters around `o` (the lamps of its room),
    /// which a centre distance does not tell apart from those of the next
    /// rooms. Zero only when no emitter below can contribute: the whole box
    /// behind the tangent plane at `o`, or `o` behind every emitter (with a
    /// margin for rounding).
    fn importance(&self, o: DVec3, n: DVec3) -> f64 {
        let v = self.center - o;
        let d2 = v.length_squared();
        let r2 = self.radius * self.radius;
        // The furthest point of the box along n.
        let ahead = n.dot(v) + n.abs().dot(self.half);
        let scale = d2.sqrt() + self.radius;
        if ahead < -SLACK * scale {
            return 0.0;
        }
        let out = (v.abs() - self.half).max(DVec3::ZERO);
        let near = out.length_squared().max(self.size * self.size);
        if d2 <= r2 {
            // o is within the sphere: no bound of the cosines.
            return finite(self.power / (PI * near));
        }
        let d = d2.sqrt();
        let theta_u = (self.radius / d).min(1.0).asin();
        let theta_x = (n.dot(v) / d).clamp(-1.0, 1.0).acos();
        let theta_e = (-self.axis.dot(v) / d).clamp(-1.0, 1.0).acos();
        let tx = (theta_x - theta_u).max(0.0);
        let te = (theta_e - self.spread - theta_u).max(0.0);
        // Wider than the corner tests' slack, which is of |w|₁ ≤ √3 |w|.
        const RIGHT: f64 = std::f64::consts::FRAC_PI_2 + 4.0 * SLACK;
        if tx >= RIGHT || te >= RIGHT {
            return 0.0;
        }
        let cx = tx.cos().max(COS_FLOOR);
        let ce = te.cos().max(COS_FLOOR);
        finite(self.power * cx * ce / (PI * near))
    }
}

/// `w`, or a large weight that two can be added without overflow when it
/// is not finite.
fn finite(w: f64) -> f64 {
    if w.is_finite() { w } else { 1e300 }
}

#[cfg(test)]
mod tests_support {
    use super::*;
    /// The probability of every light under the tree at `o`, by visiting
    /// every node (what [`LightTree::pick`] draws from).
    pub(super) fn tree_probabilities(
        tree: &LightTree,
        lights: &[Light],
        o: DVec3,
        n: DVec3,
    ) -> Vec<f64> {
        let mut out = vec![0.0; lights.len()];
        let mut stack = vec![(0usize, 1.0)];
        while let Some((i, p)) = stack.pop() {
            match tree.nodes[i].kind {
                NodeKind::Leaf(k) => out[k as usize] += p,
                NodeKind::Inner(a, b) => {
                    let ia = tree.importance(lights, a as usize, o, n);
                    let ib = tree.importance(lights, b as usize, o, n);
                    if ia + ib > 0.0 {
                        stack.push((a as usize, p * ia / (ia + ib)));
                        stack.push((b as usize, p * ib / (ia + ib)));
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::tree_probabilities;
    use super::*;
    use crate::uniform_on;

    /// A triangle with corners `p` (front by their winding).
    fn tri(p: [DVec3; 3]) -> Tri {
        let c = (p[1] - p[0]).cross(p[2] - p[0]);
        Tri {
            p,
            normal: c.normalize(),
            area: c.length() / 2.0,
            face: 0,
        }
    }

    fn random_in(rng: &mut Rng, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(rng.f64(), rng.f64(), rng.f64()) * (hi - lo) + DVec3::splat(lo)
    }

    fn random_unit(rng: &mut Rng) -> DVec3 {
        loop {
            let v = random_in(rng, -1.0, 1.0);
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    /// Lights of every size and orientation, and shading points around and
    /// among them (some on the lights' own planes, some close to them).
    fn scatter(rng: &mut Rng) -> (Vec<Light>, Vec<(DVec3, DVec3)>) {
        let mut lights = Vec::new();
        for k in 0..150 {
            let c = random_in(rng, 0.0, 10.0);
            let s = if k % 3 == 0 { 3.0 } else { 0.4 };
            let p = [0, 1, 2].map(|_| c + random_in(rng, -s, s));
            let t = tri(p);
            if t.area > 1e-3 {
                lights.push(Light::new(&t, 0.5 + 2.0 * rng.f64()));
            }
        }
        let mut points = Vec::new();
        for _ in 0..200 {
            points.push((random_in(rng, -2.0, 12.0), random_unit(rng)));
        }
        for l in lights.iter().take(40) {
            // On the light's plane (grazing), a little in front of and behind it.
            let y = uniform_on(&l.corners, rng);
            let side = l.corners[1] - l.corners[0];
            points.push((y + side * 0.7, random_unit(rng)));
            points.push((y + l.normal * 1e-3, -l.normal));
            points.push((y + l.normal * 0.05, random_unit(rng)));
            points.push((y - l.normal * 0.05, random_unit(rng)));
        }
        (lights, points)
    }

    #[test]
    fn weights_and_tree_probabilities_are_positive_wherever_a_light_can_contribute() {
        let mut rng = Rng::new(17, 0);
        let (lights, points) = scatter(&mut rng);
        let tree = LightTree::new(&lights);
        assert_eq!(tree.nodes.len(), 2 * lights.len() - 1);
        let mut contributing = 0;
        for &(o, n) in &points {
            let probs = tree_probabilities(&tree, &lights, o, n);
            let sum: f64 = probs.iter().sum();
            assert!(sum <= 1.0 + 1e-12, "{sum}");
            for (k, l) in lights.iter().enumerate() {
                let w = l.weight(o, n);
                assert!(w >= 0.0 && w.is_finite());
                // Whether some point of the light sends light to o's front:
                // the corners and random points.
                let mut ys: Vec<DVec3> = l.corners.to_vec();
                ys.extend((0..64).map(|_| uniform_on(&l.corners, &mut rng)));
                let can = ys
                    .iter()
                    .any(|&y| n.dot(y - o) > 0.0 && l.normal.dot(o - y) > 0.0);
                if can {
                    contributing += 1;
                    assert!(w > 0.0, "light {k} can reach {o} ({n}) but weighs 0");
                    assert!(
                        probs[k] > 0.0,
                        "light {k} can reach {o} ({n}) but the tree never picks it"
                    );
                }
                if w == 0.0 {
                    assert_eq!(probs[k], 0.0);
                }
            }
        }
        assert!(contributing > 1000, "{contributing}");
    }

    #[test]
    fn tree_picks_follow_the_probabilities_it_reports() {
        let mut rng = Rng::new(5, 0);
        let (lights, points) = scatter(&mut rng);
        let tree = LightTree::new(&lights);
        for &(o, n) in points.iter().step_by(40) {
            let probs = tree_probabilities(&tree, &lights, o, n);
            let draws = 200_000;
            let mut count = vec![0u32; lights.len()];
            for _ in 0..draws {
                if let Some((k, p)) = tree.pick(&lights, o, n, &mut rng) {
                    assert!(
                        (p - probs[k]).abs() <= 1e-12 * probs[k],
                        "{p} vs {}",
                        probs[k]
                    );
                    count[k] += 1;
                }
            }
            for (k, &c) in count.iter().enumerate() {
                let want = probs[k] * draws as f64;
                // Binomial: within 5 standard deviations (and a few draws).
                let sd = (want * (1.0 - probs[k])).sqrt();
                assert!(
                    (c as f64 - want).abs() <= 5.0 * sd + 3.0,
                    "light {k}: {c} draws, {want:.1} expected"
                );
            }
        }
    }
}
