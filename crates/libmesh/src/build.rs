//! Building a [`Mesh`] from a patch model: patches, surfaces, vertex copies,
//! patch adjacency and twin edges.

use std::fmt;

use glam::DVec3;
use rustc_hash::FxHashMap;
use ug::{FaceId, Model};

use crate::{Elem, INTERIOR, Mesh, NONE, Patch, PatchId, Surface, VertId};

/// Why a model cannot be meshed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BuildError {
    /// A top-level face is not a triangle or a planar convex quadrilateral.
    /// `face` is its name, or `#k` for the k-th top-level face (from 1).
    NotPatch { face: String, reason: String },
    /// The model has instances or arrays (flatten it first).
    NotFlat,
    /// More patches, vertices or elements than `u32` ids can number.
    TooLarge,
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::NotPatch { face, .. } => write!(
                f,
                "face {face} is not a triangle or convex quadrilateral (run ugcut first)"
            ),
            BuildError::NotFlat => {
                write!(f, "the model has instances or arrays (flatten it first)")
            }
            BuildError::TooLarge => write!(f, "the model is too large to mesh (over 2^32 items)"),
        }
    }
}

impl std::error::Error for BuildError {}

/// Why `face` cannot be a patch by its shape alone (contours, corner count,
/// coordinates), or None.
fn shape_problem(m: &Model, face: &ug::Face) -> Option<String> {
    if face.contours.len() != 1 {
        return Some(format!(
            "{} contours (holes or islands)",
            face.contours.len()
        ));
    }
    let c = &face.contours[0];
    if c.len() != 3 && c.len() != 4 {
        return Some(format!("{} vertices", c.len()));
    }
    if !c.iter().all(|&v| m.pos(v).is_finite()) {
        return Some("non-finite coordinates".into());
    }
    None
}

/// Why the quadrilateral `pts` is not a patch (not planar within `eps`, or
/// not strictly convex), or None (also for a triangle or no area).
fn quad_problem(pts: &[DVec3], eps: f64) -> Option<&'static str> {
    if pts.len() != 4 {
        return None;
    }
    let unit = geom::newell_normal(pts).normalize_or_zero();
    if unit == DVec3::ZERO {
        return None;
    }
    let centroid = pts.iter().copied().sum::<DVec3>() / 4.0;
    if pts.iter().any(|&p| (p - centroid).dot(unit).abs() > eps) {
        return Some("quadrilateral is not planar");
    }
    let convex = (0..4).all(|i| {
        let u = pts[(i + 1) % 4] - pts[i];
        let w = pts[(i + 2) % 4] - pts[(i + 1) % 4];
        u.cross(w).dot(unit) > 1e-12 * u.length() * w.length()
    });
    (!convex).then_some("quadrilateral is not convex")
}

/// The top-level faces of `m` that are not patches (triangles or planar
/// convex quadrilaterals within `eps`), with the reason, in file order:
/// what [`Mesh::from_model`] would refuse. Faces it would drop as degenerate
/// are not listed.
pub fn not_patches(m: &Model, eps: f64) -> Vec<(String, String)> {
    m.top_faces()
        .enumerate()
        .filter_map(|(k, f)| {
            let face = &m.faces[f.idx()];
            let reason = shape_problem(m, face).or_else(|| {
                let pts: Vec<DVec3> = face.contours[0].iter().map(|&v| m.pos(v)).collect();
                quad_problem(&pts, eps).map(str::to_string)
            })?;
            Some((label(m, f, k), reason))
        })
        .collect()
}

/// A patch as read from its face, before surfaces are known.
struct RawPatch {
    face: FaceId,
    /// Position classes of the corners (`NONE` for a triangle's fourth).
    cls: [u32; 4],
    n: usize,
    /// Newell normal (twice the area).
    newell: DVec3,
    centroid: DVec3,
    material: Option<ug::MaterialId>,
}

impl RawPatch {
    fn unit(&self) -> DVec3 {
        self.newell.normalize_or_zero()
    }
}

/// Union-find over patches.
struct Dsu(Vec<u32>);

impl Dsu {
    fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let p = self.0[x as usize];
            self.0[x as usize] = self.0[p as usize];
            x = p;
        }
        x
    }
    fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            // The smaller root wins, for a stable representative.
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            self.0[hi as usize] = lo;
        }
    }
}

/// Groups input vertices by position: two vertices within `eps` of each
/// other's class representative share a class (the first one met represents it).
struct Classes {
    cell: f64,
    grid: FxHashMap<[i64; 3], Vec<u32>>,
    /// Representative input vertex of each class.
    reps: Vec<u32>,
    rep_pos: Vec<DVec3>,
    /// Class of each input vertex (`NONE` until met).
    of: Vec<u32>,
}

impl Classes {
    fn new(nv: usize, eps: f64) -> Classes {
        Classes {
            cell: eps,
            grid: FxHashMap::default(),
            reps: Vec::new(),
            rep_pos: Vec::new(),
            of: vec![NONE; nv],
        }
    }

    fn cell_of(&self, p: DVec3) -> [i64; 3] {
        let c = |x: f64| (x / self.cell).floor() as i64;
        [c(p.x), c(p.y), c(p.z)]
    }

    fn class(&mut self, v: ug::VertexId, p: DVec3) -> u32 {
        if self.of[v.idx()] != NONE {
            return self.of[v.idx()];
        }
        let c = self.cell_of(p);
        let mut found = NONE;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = self.grid.get(&[
                        c[0].saturating_add(dx),
                        c[1].saturating_add(dy),
                        c[2].saturating_add(dz),
                    ]) else {
                        continue;
                    };
                    for &k in list {
                        if k < found && self.rep_pos[k as usize].distance(p) <= self.cell {
                            found = k;
                        }
                    }
                }
            }
        }
        if found == NONE {
            found = self.reps.len() as u32;
            self.reps.push(v.0);
            self.rep_pos.push(p);
            self.grid.entry(c).or_default().push(found);
        }
        self.of[v.idx()] = found;
        found
    }
}

/// The least distance from a corner of a polygon to a side not its own.
fn width(pts: &[DVec3]) -> f64 {
    let n = pts.len();
    let mut w = f64::INFINITY;
    for (i, &x) in pts.iter().enumerate() {
        for j in 0..n {
            let k = (j + 1) % n;
            if j == i || k == i {
                continue;
            }
            w = w.min(geom::point_segment_distance(x, pts[j], pts[k]).0);
        }
    }
    w
}

fn label(m: &Model, f: FaceId, k: usize) -> String {
    m.faces[f.idx()]
        .name
        .clone()
        .unwrap_or_else(|| format!("#{}", k + 1))
}

impl Mesh {
    /// Builds the mesh of a patch model (the output of `ugcut`): every
    /// top-level face becomes a patch and must be a triangle or a planar
    /// convex quadrilateral. Surfaces are the maximal groups of patches
    /// connected through shared edges (same end positions within `eps`) whose
    /// patches are coplanar within `eps`, of the same material and facing the
    /// same way. Each surface gets its own copies of its vertices, created in
    /// face order. `eps` is a distance; when it is not positive it defaults to
    /// 10⁻⁶ of the bounding-box diagonal. Degenerate faces (zero area, or two
    /// corners within `eps`) are left out and listed by
    /// [`Mesh::degenerate_faces`].
    pub fn from_model(m: &Model, eps: f64) -> Result<Mesh, BuildError> {
        if !m.instances.is_empty() {
            return Err(BuildError::NotFlat);
        }
        let faces: Vec<FaceId> = m.top_faces().collect();
        if faces.len() >= (NONE as usize) / 4 || m.vertices.len() >= NONE as usize {
            return Err(BuildError::TooLarge);
        }
        let eps = if eps.is_finite() && eps > 0.0 {
            eps
        } else {
            let diag = m.bounds().map_or(1.0, |(lo, hi)| (hi - lo).length());
            (diag * 1e-6).max(f64::MIN_POSITIVE)
        };

        // Patches.
        let mut classes = Classes::new(m.vertices.len(), eps);
        let mut raw: Vec<RawPatch> = Vec::with_capacity(faces.len());
        let mut degenerate: Vec<(String, String)> = Vec::new();
        for (k, &f) in faces.iter().enumerate() {
            let face = &m.faces[f.idx()];
            let not_patch = |reason: String| BuildError::NotPatch {
                face: label(m, f, k),
                reason,
            };
            if let Some(reason) = shape_problem(m, face) {
                return Err(not_patch(reason));
            }
            let c = &face.contours[0];
            let pts: Vec<DVec3> = c.iter().map(|&v| m.pos(v)).collect();
            let mut cls = [NONE; 4];
            for (i, &v) in c.iter().enumerate() {
                cls[i] = classes.class(v, m.pos(v));
            }
            let n = c.len();
            // Degenerate patches (slivers a cutter can leave where two input
            // points lie within a hair of each other) carry no area and no
            // energy: they are dropped and reported, not refused.
            if (0..n).any(|i| (i + 1..n).any(|j| cls[i] == cls[j])) {
                degenerate.push((label(m, f, k), "repeats a vertex (or two coincide)".into()));
                continue;
            }
            let newell = geom::newell_normal(&pts);
            let area = newell.length() / 2.0;
            // Narrower than eps: a corner within eps of a side not its own
            // (ugcheck's test, so that what ugcheck passes is a patch here).
            if area.is_nan() || area <= 0.0 || width(&pts) <= eps {
                degenerate.push((
                    label(m, f, k),
                    "zero area (narrower than epsilon: its vertices are nearly collinear)".into(),
                ));
                continue;
            }
            let centroid = pts.iter().copied().sum::<DVec3>() / n as f64;
            if let Some(reason) = quad_problem(&pts, eps) {
                return Err(not_patch(reason.into()));
            }
            raw.push(RawPatch {
                face: f,
                cls,
                n,
                newell,
                centroid,
                material: face.material,
            });
        }

        // Patch edges, sorted by their end classes.
        // (smaller class, larger class, patch, edge index)
        let mut edges: Vec<(u32, u32, u32, u8)> = Vec::new();
        for (p, r) in raw.iter().enumerate() {
            for k in 0..r.n {
                let (a, b) = (r.cls[k], r.cls[(k + 1) % r.n]);
                edges.push((a.min(b), a.max(b), p as u32, k as u8));
            }
        }
        edges.sort_unstable();
        let groups: Vec<&[(u32, u32, u32, u8)]> = edges
            .chunk_by(|x, y| (x.0, x.1) == (y.0, y.1))
            .filter(|g| g.len() > 1)
            .collect();
        let forward = |p: u32, k: u8| {
            let r = &raw[p as usize];
            r.cls[k as usize] < r.cls[(k as usize + 1) % r.n]
        };
        // Every corner of `b` within eps of `a`'s plane.
        let in_plane = |a: &RawPatch, b: &RawPatch| {
            let n = a.unit();
            b.cls[..b.n]
                .iter()
                .all(|&k| (classes.rep_pos[k as usize] - a.centroid).dot(n).abs() <= eps)
        };
        let coplanar = |a: &RawPatch, b: &RawPatch| {
            a.unit().dot(b.unit()) > 0.0 && in_plane(a, b) && in_plane(b, a)
        };
        let joins = |x: &(u32, u32, u32, u8), y: &(u32, u32, u32, u8)| {
            let (a, b) = (&raw[x.2 as usize], &raw[y.2 as usize]);
            x.2 != y.2
                && forward(x.2, x.3) != forward(y.2, y.3)
                && a.material == b.material
                && coplanar(a, b)
        };

        // Adjacency: an edge joins two patches that join (same material,
        // coplanar, opposite directions) when no face out of their plane
        // uses it. An edge that a third face also uses — the foot of a wall
        // standing between two floor pieces, a partition meeting a wall — is
        // a boundary on both sides: the light differs across it, so neither
        // side's vertices may be shared with the other's.
        // (Patches lying in the plane of the pair — the back of a two-sided
        // wall sharing its vertices — do not break the join.)
        let mut adjacent: Vec<[(u32, u8); 2]> = Vec::new();
        for g in &groups {
            let a = &raw[g[0].2 as usize];
            if !g.iter().all(|x| in_plane(a, &raw[x.2 as usize])) {
                continue;
            }
            let mut used = vec![false; g.len()];
            for i in 0..g.len() {
                for j in i + 1..g.len() {
                    if !used[i] && !used[j] && joins(&g[i], &g[j]) {
                        used[i] = true;
                        used[j] = true;
                        adjacent.push([(g[i].2, g[i].3), (g[j].2, g[j].3)]);
                    }
                }
            }
        }

        // Surfaces: patches connected through adjacent edges.
        let mut dsu = Dsu((0..raw.len() as u32).collect());
        for [(pi, _), (pj, _)] in &adjacent {
            dsu.union(*pi, *pj);
        }
        let mut surf_of_root: FxHashMap<u32, u32> = FxHashMap::default();
        let mut surfaces: Vec<Surface> = Vec::new();
        let mut psurf = vec![0u32; raw.len()];
        for (p, r) in raw.iter().enumerate() {
            let root = dsu.find(p as u32);
            let s = *surf_of_root.entry(root).or_insert_with(|| {
                surfaces.push(Surface {
                    normal: DVec3::ZERO,
                    material: r.material,
                    patches: Vec::new(),
                });
                surfaces.len() as u32 - 1
            });
            psurf[p] = s;
            surfaces[s as usize].patches.push(PatchId(p as u32));
            surfaces[s as usize].normal += r.newell;
        }
        for s in &mut surfaces {
            s.normal = s.normal.normalize_or_zero();
        }

        // Vertex copies: one per sector, a set of corners (patch, corner
        // index) of one class connected through adjacent edges. A surface
        // usually has one copy of a point; a point on a wall's foot has one
        // per side of the wall, even when the two sides' floors are one
        // surface (joined through a doorway). Copies are made in face order.
        let mut corners = Dsu((0..raw.len() as u32 * 4).collect());
        for [(pi, ki), (pj, kj)] in &adjacent {
            let (ni, nj) = (raw[*pi as usize].n as u32, raw[*pj as usize].n as u32);
            let (ki, kj) = (*ki as u32, *kj as u32);
            // The edges run opposite ways: i's start is j's end.
            corners.union(pi * 4 + ki, pj * 4 + (kj + 1) % nj);
            corners.union(pi * 4 + (ki + 1) % ni, pj * 4 + kj);
        }
        let mut vmap: FxHashMap<u32, u32> = FxHashMap::default();
        let mut pos = Vec::new();
        let mut vsurf = Vec::new();
        let mut vparent = Vec::new();
        let mut elems = Vec::with_capacity(raw.len());
        let mut patches = Vec::with_capacity(raw.len());
        for (p, r) in raw.iter().enumerate() {
            let s = psurf[p];
            let mut v = [VertId(NONE); 4];
            for (i, &c) in r.cls[..r.n].iter().enumerate() {
                let root = corners.find(p as u32 * 4 + i as u32);
                let id = *vmap.entry(root).or_insert_with(|| {
                    pos.push(classes.rep_pos[c as usize]);
                    vsurf.push(s);
                    vparent.push([classes.reps[c as usize], NONE]);
                    pos.len() as u32 - 1
                });
                v[i] = VertId(id);
            }
            let mut pedge = 0u16;
            for k in 0..4 {
                pedge |= (if k < r.n { k as u16 } else { INTERIOR }) << (3 * k);
            }
            elems.push(Elem {
                v,
                children: NONE,
                parent: NONE,
                patch: p as u32,
                pedge,
                level: 0,
            });
            patches.push(Patch {
                surface: s,
                face: r.face,
                area: r.newell.length() / 2.0,
                adj: [NONE; 4],
            });
        }
        if pos.len() >= NONE as usize {
            return Err(BuildError::TooLarge);
        }
        for [(pi, ki), (pj, kj)] in &adjacent {
            patches[*pi as usize].adj[*ki as usize] = pj * 4 + *kj as u32;
            patches[*pj as usize].adj[*kj as usize] = pi * 4 + *ki as u32;
        }

        // Twins: every other patch using an edge that is not adjacent.
        let copy_at = |p: u32, c: u32| -> VertId {
            let r = &raw[p as usize];
            let i = r.cls[..r.n]
                .iter()
                .position(|&x| x == c)
                .expect("an edge's end is a corner of its patch");
            elems[p as usize].v[i]
        };
        let mut twins: Vec<Vec<[VertId; 2]>> = vec![Vec::new(); raw.len() * 4];
        let mut twin_edges: Vec<Vec<u32>> = vec![Vec::new(); raw.len() * 4];
        for g in &groups {
            for i in 0..g.len() {
                let (pi, ki) = (g[i].2, g[i].3 as usize);
                if patches[pi as usize].adj[ki] != NONE {
                    continue;
                }
                twin_edges[pi as usize * 4 + ki].extend(
                    g.iter()
                        .filter(|gj| gj.2 != pi)
                        .map(|gj| gj.2 * 4 + gj.3 as u32),
                );
                let ri = &raw[pi as usize];
                let (c0, c1) = (ri.cls[ki], ri.cls[(ki + 1) % ri.n]);
                let own = [copy_at(pi, c0), copy_at(pi, c1)];
                for gj in g.iter() {
                    let pj = gj.2;
                    if pi == pj {
                        continue;
                    }
                    let t = [copy_at(pj, c0), copy_at(pj, c1)];
                    let list = &mut twins[pi as usize * 4 + ki];
                    if t != own && !list.contains(&t) {
                        list.push(t);
                    }
                }
            }
        }
        let nudge = boundary_nudges(&pos, &vsurf, &surfaces, &elems, &patches, eps);
        let mut twin_start = Vec::with_capacity(twins.len() + 1);
        let mut twin_verts = Vec::new();
        twin_start.push(0u32);
        for t in twins {
            twin_verts.extend(t);
            twin_start.push(twin_verts.len() as u32);
        }
        let mut twin_edge_start = Vec::with_capacity(twin_edges.len() + 1);
        let mut twin_edge = Vec::new();
        twin_edge_start.push(0u32);
        for mut t in twin_edges {
            t.sort_unstable();
            t.dedup();
            twin_edge.extend(t);
            twin_edge_start.push(twin_edge.len() as u32);
        }

        Ok(Mesh {
            pos,
            vsurf,
            vparent,
            nudge,
            mid: Default::default(),
            n_leaves: elems.len(),
            elems,
            patches,
            twin_start,
            twin_verts,
            twin_edge_start,
            twin_edge,
            surfaces,
            eps,
            degenerate,
        })
    }
}

/// Relative size of the step a receiver on its surface's boundary takes into
/// its surface (see [`Mesh::receiver_pos`]): this fraction of the boundary
/// edge it lies on (the shortest, at a corner) …
pub(crate) const NUDGE_REL: f64 = 1e-4;
/// … and at least this many build epsilons, so that a ray from across a wall
/// standing on the boundary (within epsilon of it) meets the wall.
pub(crate) const NUDGE_EPS: f64 = 10.0;

/// The step of length `NUDGE_REL · len` (within the bounds above) along `dir`.
pub(crate) fn nudge_of(dir: DVec3, len: f64, eps: f64) -> [f32; 3] {
    if dir == DVec3::ZERO || len.is_nan() || len <= 0.0 {
        return [0.0; 3];
    }
    let d = (NUDGE_REL * len).max(NUDGE_EPS * eps).min(0.25 * len);
    (dir * d).as_vec3().to_array()
}

/// The inward unit normal, in the plane of normal `n`, of the boundary edge
/// a → b of an element whose corners run counter-clockwise seen from the front.
#[inline]
pub(crate) fn edge_inward(n: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    n.cross(b - a).normalize_or_zero()
}

/// Each input vertex copy's step into its surface: along the sum of the
/// inward normals of the surface-boundary patch edges through it (zero
/// inside the surface, or where they cancel).
fn boundary_nudges(
    pos: &[DVec3],
    vsurf: &[u32],
    surfaces: &[Surface],
    elems: &[Elem],
    patches: &[Patch],
    eps: f64,
) -> Vec<[f32; 3]> {
    let mut dir = vec![DVec3::ZERO; pos.len()];
    let mut len = vec![f64::INFINITY; pos.len()];
    for (p, patch) in patches.iter().enumerate() {
        let el = &elems[p];
        let n = el.n();
        for k in 0..n {
            if patch.adj[k] != NONE {
                continue;
            }
            let (a, b) = (el.v[k].idx(), el.v[(k + 1) % n].idx());
            let d = edge_inward(surfaces[vsurf[a] as usize].normal, pos[a], pos[b]);
            let l = pos[a].distance(pos[b]);
            for v in [a, b] {
                dir[v] += d;
                len[v] = len[v].min(l);
            }
        }
    }
    dir.iter()
        .zip(&len)
        .map(|(&d, &l)| {
            if d.length() > 1e-6 {
                nudge_of(d.normalize(), l, eps)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}
