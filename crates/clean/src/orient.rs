//! Face orientation (Smith 1991, §2.3), made automatic and scriptable.
//!
//! **Automatic mode** (the default):
//! 1. Within each connected component (faces joined by manifold edges —
//!    edges with exactly two uses), orientation is made consistent by a
//!    breadth-first walk from the component's first face; the component's
//!    reference orientation is that of the majority of its faces, so the
//!    fewest faces are flipped for consistency.
//!    Two open components that together form a closed surface (every
//!    edge of their faces used exactly twice by them, one orientation for
//!    both possible) are joined into one closed component: a slab's top
//!    face, cut off from the rest of the slab box by the walls standing
//!    flush on its edges, and the open tray of the rest.
//! 2. Each component then gets its outside:
//!    * a **closed** component (every edge of its faces has exactly two
//!      uses among them; uses by other components do not count)
//!      with volume faces outward (positive signed volume) like a solid object,
//!      unless it encloses other geometry — a point of another component
//!      (furniture, a light), a camera eye or a light bomb lies inside it (ray
//!      parity) — in which case it is a room or a shell and faces inward;
//!    * an **open** component (a box missing a side, a lone wall, a floor)
//!      faces the side from which more of the rest of the scene is seen:
//!      rays are cast from both sides of every face (a fixed, deterministic
//!      cosine-weighted set); a hit at distance t counts t² (the surface a
//!      ray's solid angle covers there), weighted by face area; surface of
//!      other components and the component's own faces both count (a box
//!      missing a side faces inward, a building floor faces its rooms). When the two sides differ
//!      by less than 5% the component is *ambiguous*: it is left as it is (or
//!      made double-sided with `double_sided_ambiguous`) and reported. The
//!      closed components are decided first, and a ray that meets the back
//!      of one's face sees nothing (it started inside a solid), unless the
//!      fronts seen do not decide.
//! 3. An open component lying on a larger one's surface (most of its sample
//!    points within about 2 epsilon of that one's faces) faces like it.
//!
//! A face is sampled at points, and its rays cast in a frame, that do not
//! depend on the way its contour runs, so ugflip run on its own output
//! flips nothing.
//!
//! **Explicit operations** run after the automatic step when asked for:
//! light bombs (every face visible from the point whose front faces away from
//! it is flipped; bombs apply in order), `--flip NAME`, `--double-sided NAME`
//! (adds the reversed twin `NAME.back` right after the face).

use geom::bvh::{Bvh, Triangle, face_triangles};
use geom::{DVec3, Frame};
use rayon::prelude::*;
use ug::{Face, FaceId, Model};
use winged::Mesh;

/// What to do.
#[derive(Clone, Debug)]
pub struct Options {
    /// Run automatic orientation.
    pub auto: bool,
    pub bombs: Vec<DVec3>,
    pub flip: Vec<String>,
    pub double_sided: Vec<String>,
    pub double_sided_ambiguous: bool,
    /// Rays per face side for the visibility vote.
    pub rays: usize,
    /// Distance tolerance (ray offsets, flatness of closed components).
    pub eps: f64,
    /// Extra points known to be inside rooms (camera eyes).
    pub viewpoints: Vec<DVec3>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            auto: true,
            bombs: vec![],
            flip: vec![],
            double_sided: vec![],
            double_sided_ambiguous: false,
            rays: 32,
            eps: 1e-9,
            viewpoints: vec![],
        }
    }
}

/// How many faces were flipped, and why.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Report {
    pub components: usize,
    /// Flipped to agree with their component's neighbours.
    pub consistency: usize,
    /// Flipped so a closed solid faces outward.
    pub outward: usize,
    /// Flipped so a closed room or shell faces what it encloses.
    pub inward: usize,
    /// Flipped so an open component faces the side that sees more of the scene.
    pub toward_scene: usize,
    pub by_bombs: usize,
    pub by_name: usize,
    pub doubled: usize,
    /// Duplicate faces flipped to face like the face they duplicate.
    pub duplicates: usize,
    /// Components whose outside could not be decided (named by their first face).
    pub ambiguous: Vec<String>,
    /// Components that cannot be oriented consistently (Möbius-like), by first face.
    pub nonorientable: Vec<String>,
}

impl Report {
    pub fn flipped(&self) -> usize {
        self.consistency
            + self.outward
            + self.inward
            + self.toward_scene
            + self.by_bombs
            + self.by_name
            + self.duplicates
    }
}

/// A named face that does not exist.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownFace(pub String);

/// Face label: name or `#k` (k-th live face from 1).
fn labels(mesh: &Mesh) -> Vec<(FaceId, String)> {
    mesh.faces()
        .enumerate()
        .map(|(k, f)| {
            (
                f,
                mesh.face(f)
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("#{}", k + 1)),
            )
        })
        .collect()
}

/// A point well inside a face (centroid of its largest triangle), points
/// spread over the face for the visibility vote, its unit normal and area.
struct Sample {
    p: DVec3,
    /// Up to [`SPREAD`] points spread over the face by area (stratified): a
    /// big floor is judged by what all its parts see, not by one point
    /// that may lie under a wall standing on it.
    spread: Vec<DVec3>,
    n: DVec3,
    area: f64,
}

/// Most points a face is sampled at for the vote.
const SPREAD: usize = 8;

fn sample(mesh: &Mesh, f: FaceId) -> Option<Sample> {
    let pts = mesh.face_points(f);
    let n = mesh.face_normal(f)?;
    let flat: Vec<DVec3> = pts.iter().flatten().copied().collect();
    // Each triangle's corners, and the triangles, in an order of their
    // positions, not of the contour's walk: the face turned over is
    // sampled at the same points (ugflip run twice flips nothing more).
    let key = |i: usize| flat[i].to_array();
    let cmp = |a: &usize, b: &usize| {
        let (x, y) = (key(*a), key(*b));
        x[0].total_cmp(&y[0])
            .then(x[1].total_cmp(&y[1]))
            .then(x[2].total_cmp(&y[2]))
    };
    let mut tris = face_triangles(&pts);
    for t in tris.iter_mut() {
        t.sort_by(cmp);
    }
    tris.sort_by(|a, b| {
        cmp(&a[0], &b[0])
            .then_with(|| cmp(&a[1], &b[1]))
            .then_with(|| cmp(&a[2], &b[2]))
    });
    let best = tris
        .iter()
        .max_by(|a, b| tri_area(&flat, a).total_cmp(&tri_area(&flat, b)))?;
    let p = (flat[best[0]] + flat[best[1]] + flat[best[2]]) / 3.0;
    let areas: Vec<f64> = tris.iter().map(|t| tri_area(&flat, t)).collect();
    let total: f64 = areas.iter().sum();
    let mut spread = Vec::with_capacity(SPREAD);
    if total > 0.0 {
        let mut acc = 0.0;
        let mut k = 0;
        for j in 0..SPREAD {
            let target = (j as f64 + 0.5) / SPREAD as f64 * total;
            while k + 1 < tris.len() && acc + areas[k] < target {
                acc += areas[k];
                k += 1;
            }
            // A point inside triangle k (reflected into it when outside).
            let (mut u, mut v) = (
                (j as f64 + 0.5) / SPREAD as f64,
                (j as u32).reverse_bits() as f64 / 4294967296.0 + 0.5 / SPREAD as f64,
            );
            v = v.fract();
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let t = tris[k];
            spread.push(flat[t[0]] + (flat[t[1]] - flat[t[0]]) * u + (flat[t[2]] - flat[t[0]]) * v);
        }
    } else {
        spread.push(p);
    }
    Some(Sample {
        p,
        spread,
        n,
        area: mesh.face_area(f).abs(),
    })
}

fn tri_area(p: &[DVec3], t: &[usize; 3]) -> f64 {
    (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).length() / 2.0
}

/// Triangles of every live face, tagged with the face id.
fn scene(mesh: &Mesh) -> Bvh {
    let mut tris = Vec::new();
    for f in mesh.faces() {
        let pts = mesh.face_points(f);
        let flat: Vec<DVec3> = pts.iter().flatten().copied().collect();
        for t in face_triangles(&pts) {
            tris.push(Triangle {
                p: [flat[t[0]], flat[t[1]], flat[t[2]]],
                id: f.0,
            });
        }
    }
    Bvh::new(tris)
}

/// Deterministic cosine-weighted directions around +z (Hammersley points).
fn hemisphere(k: usize) -> Vec<DVec3> {
    (0..k)
        .map(|i| {
            let u = (i as f64 + 0.5) / k as f64;
            let v = (i as u32).reverse_bits() as f64 / 4294967296.0;
            let r = u.sqrt();
            let phi = 2.0 * std::f64::consts::PI * v;
            DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u).max(0.0).sqrt())
        })
        .collect()
}

/// Faces joined by manifold edges (two uses by two faces), each with the
/// flip that makes it agree with its component's reference orientation.
struct Components {
    /// Component of each face slot (`usize::MAX` for none).
    comp: Vec<usize>,
    /// Whether the face must turn to agree.
    rel: Vec<bool>,
    /// Each component's faces, from its first.
    comps: Vec<Vec<FaceId>>,
    /// The first face of each component that cannot be oriented
    /// consistently (Möbius-like).
    conflicted: Vec<FaceId>,
}

/// Finds the components of `faces` by a breadth-first walk from each
/// component's first face; the reference orientation is that of the faces
/// with the most `weight` (ties keep the first face's), so the least weight
/// is turned.
fn components(mesh: &Mesh, faces: &[FaceId], weight: impl Fn(FaceId) -> f64) -> Components {
    let nf = mesh.model().faces.len();
    let mut comp = vec![usize::MAX; nf];
    let mut rel = vec![false; nf];
    let mut comps: Vec<Vec<FaceId>> = Vec::new();
    let mut conflicted = Vec::new();
    for &start in faces {
        if comp[start.idx()] != usize::MAX {
            continue;
        }
        let c = comps.len();
        let mut members = vec![start];
        comp[start.idx()] = c;
        let mut conflict = false;
        let mut k = 0;
        while k < members.len() {
            let f = members[k];
            k += 1;
            for e in mesh.face_edges(f) {
                let ed = mesh.edge(e);
                if ed.uses.len() != 2 || ed.uses[0].face == ed.uses[1].face {
                    continue;
                }
                let (mine, other) = if ed.uses[0].face == f {
                    (ed.uses[0], ed.uses[1])
                } else {
                    (ed.uses[1], ed.uses[0])
                };
                let g = other.face;
                // Consistent neighbours walk the shared edge in opposite directions.
                let want = rel[f.idx()] ^ (mine.forward == other.forward);
                if comp[g.idx()] == usize::MAX {
                    comp[g.idx()] = c;
                    rel[g.idx()] = want;
                    members.push(g);
                } else if rel[g.idx()] != want {
                    conflict = true;
                }
            }
        }
        if conflict {
            conflicted.push(start);
        }
        let (mut turned, mut all) = (0.0, 0.0);
        for &f in &members {
            let w = weight(f);
            all += w;
            if rel[f.idx()] {
                turned += w;
            }
        }
        if 2.0 * turned > all {
            for f in &members {
                rel[f.idx()] = !rel[f.idx()];
            }
        }
        comps.push(members);
    }
    Components {
        comp,
        rel,
        comps,
        conflicted,
    }
}

/// Turns parts of a component (`members`, faces joined by manifold edges)
/// until no edge between two parts is inconsistent: a part is a set of
/// faces joined by edges they walk consistently (with the turns in `turn`),
/// so every edge between two parts is inconsistent, and turning a part
/// makes all of its edges to other parts consistent and breaks none. The
/// part of the least area with such an edge turns first (ties: the first
/// face); each turn makes at least one edge consistent, so this ends, with
/// the inconsistent edges that no turn of a part can mend inside parts.
fn turn_parts(mesh: &Mesh, members: &[FaceId], area: &[f64], turn: &mut [bool]) {
    let index: rustc_hash::FxHashMap<FaceId, usize> =
        members.iter().enumerate().map(|(k, &f)| (f, k)).collect();
    // The manifold edges between two members, as pairs of member indices
    // with whether the two walk the edge the same way (as given).
    let mut links: Vec<(usize, usize, bool)> = Vec::new();
    for &f in members {
        for e in mesh.face_edges(f) {
            let u = &mesh.edge(e).uses;
            if u.len() != 2 || u[0].face == u[1].face || u[0].face != f {
                continue;
            }
            if let (Some(&a), Some(&b)) = (index.get(&u[0].face), index.get(&u[1].face)) {
                links.push((a, b, u[0].forward == u[1].forward));
            }
        }
    }
    let n = members.len();
    loop {
        let flipped = |k: usize| turn[members[k].idx()];
        let consistent = |&(a, b, same): &(usize, usize, bool)| same == (flipped(a) != flipped(b));
        let mut parent: Vec<usize> = (0..n).collect();
        for l in links.iter().filter(|l| consistent(l)) {
            crate::join(&mut parent, l.0, l.1);
        }
        let part: Vec<usize> = (0..n).map(|k| crate::root(&mut parent, k)).collect();
        let mut part_area = vec![0.0; n];
        for k in 0..n {
            part_area[part[k]] += area[members[k].idx()];
        }
        let mut open = vec![false; n];
        for l in links.iter().filter(|l| !consistent(l)) {
            if part[l.0] != part[l.1] {
                open[part[l.0]] = true;
                open[part[l.1]] = true;
            }
        }
        // Roots are each part's least member index: ties go to the first.
        let Some(p) = (0..n)
            .filter(|&r| open[r])
            .min_by(|&a, &b| part_area[a].total_cmp(&part_area[b]).then(a.cmp(&b)))
        else {
            return;
        };
        for k in 0..n {
            if part[k] == p {
                let f = members[k].idx();
                turn[f] = !turn[f];
            }
        }
    }
}

/// Makes orientation consistent again across the edges that cutting and
/// cleaning joined, keeping every decision that does not conflict: faces
/// joined by manifold edges form components as in [`orient`]'s first step,
/// and in each the faces of the lesser area turn to agree with the rest
/// (so a component that is consistent already keeps its orientation, and a
/// model without an inconsistently oriented edge is returned unchanged).
/// ugflip oriented the faces before ugisect cut them; a slab's side whose
/// corners an export rounded a centimetre apart from the floor's is a part
/// of its own there, and only after the cuts does it share an edge with the
/// floor. Returns the faces turned, in face order (the model's faces keep
/// their ids).
pub fn agree(mut model: Model) -> (Model, Vec<FaceId>) {
    if !model.is_flat() {
        return (model, Vec::new());
    }
    // The topology of a copy: a flat model's faces keep their ids in it.
    let mesh = Mesh::from_model(model.clone());
    if mesh.edges().all(|e| {
        let u = &mesh.edge(e).uses;
        u.len() != 2 || u[0].face == u[1].face || mesh.consistently_oriented(e)
    }) {
        return (model, Vec::new());
    }
    let faces: Vec<FaceId> = mesh.faces().collect();
    let area: Vec<f64> = (0..mesh.model().faces.len())
        .map(|i| mesh.face_area(FaceId(i as u32)).abs())
        .collect();
    let Components {
        comp,
        mut rel,
        comps,
        conflicted,
    } = components(&mesh, &faces, |f| area[f.idx()]);
    // A component no orientation makes consistent (cuts joined the inside
    // of a solid to its outside): the walk's flips depend on its order, so
    // such a component starts from the faces as they are, and its parts
    // turn one at a time, each only where that makes edges consistent.
    for start in conflicted {
        let members = &comps[comp[start.idx()]];
        for f in members {
            rel[f.idx()] = false;
        }
        turn_parts(&mesh, members, &area, &mut rel);
    }
    let turned: Vec<FaceId> = faces.into_iter().filter(|f| rel[f.idx()]).collect();
    for f in &turned {
        for c in &mut model.faces[f.idx()].contours {
            c[1..].reverse();
        }
    }
    (model, turned)
}

/// Orients the faces of a flat model.
///
/// Adjacency is decided on a welded copy (vertices within `eps` merged,
/// T-vertices inserted), so the result does not depend on whether the
/// grouper ran first; a face that duplicates an earlier one (the same
/// vertices once welded) takes no part and is then oriented by the faces
/// of its material around it, or where they do not decide like its twin
/// (so `ugclean` removes a copy as coincident); a `NAME.back` twin of
/// `NAME` (what `--double-sided` adds) keeps its orientation.
pub fn orient(model: Model, opts: &Options) -> Result<(Model, Report), UnknownFace> {
    let welded = opts.auto.then(|| model.clone());
    let mut mesh = Mesh::from_model(model);
    let mut rep = Report::default();
    let names = labels(&mesh);
    let find = |n: &str| names.iter().find(|(_, l)| l == n).map(|(f, _)| *f);
    let flips: Vec<FaceId> = opts
        .flip
        .iter()
        .map(|n| find(n).ok_or_else(|| UnknownFace(n.clone())))
        .collect::<Result<_, _>>()?;
    let doubles: Vec<FaceId> = opts
        .double_sided
        .iter()
        .map(|n| find(n).ok_or_else(|| UnknownFace(n.clone())))
        .collect::<Result<_, _>>()?;

    let mut ambiguous_faces: Vec<FaceId> = Vec::new();
    if let Some(copy) = welded {
        let mut work = Mesh::from_model(copy);
        winged::weld::merge_vertices(&mut work, opts.eps);
        winged::weld::split_edges(&mut work, opts.eps);
        // Duplicates: the same set of vertices as an earlier face.
        let mut first: rustc_hash::FxHashMap<Vec<ug::VertexId>, FaceId> = Default::default();
        let mut ghosts: Vec<(FaceId, FaceId, Face)> = Vec::new();
        for f in work.faces().collect::<Vec<_>>() {
            let mut key: Vec<ug::VertexId> =
                work.face(f).contours.iter().flatten().copied().collect();
            key.sort_unstable();
            key.dedup();
            match first.get(&key) {
                Some(&o) => {
                    ghosts.push((f, o, work.face(f).clone()));
                    work.remove_face(f);
                }
                None => {
                    first.insert(key, f);
                }
            }
        }
        let (ambiguous, flipped) = automatic(&mut work, opts, &names, &mut rep);
        ambiguous_faces = ambiguous;
        for f in flipped {
            if mesh.is_face_live(f) {
                mesh.flip_face(f);
            }
        }
        for (g, o, welded) in ghosts {
            // The reversed twin that `--double-sided` added (`NAME.back`)
            // stays reversed: ugflip run again keeps its own output.
            let back = |f: FaceId| mesh.face(f).name.clone();
            if let (Some(gn), Some(on)) = (back(g), back(o))
                && gn.strip_suffix(".back") == Some(on.as_str())
            {
                continue;
            }
            let turn = match own_surface(&work, &welded, o) {
                Some(flip) => flip,
                None => matches!(
                    (mesh.face_normal(g), mesh.face_normal(o)),
                    (Some(ng), Some(no)) if ng.dot(no) < 0.0
                ),
            };
            if turn {
                mesh.flip_face(g);
                rep.duplicates += 1;
            }
        }
    }
    if !opts.bombs.is_empty() {
        let bvh = scene(&mesh);
        let faces: Vec<FaceId> = mesh.faces().collect();
        let samples: Vec<Option<Sample>> = faces.iter().map(|&f| sample(&mesh, f)).collect();
        let mut flipped = vec![false; faces.len()];
        for &b in &opts.bombs {
            let visible: Vec<bool> = faces
                .par_iter()
                .zip(&samples)
                .map(|(&f, s)| {
                    let Some(s) = s else { return false };
                    let d = s.p - b;
                    d.length() > opts.eps && !bvh.occluded(b, d, 0.0, 1.0 - 1e-9, |id| id != f.0)
                })
                .collect();
            for (k, &f) in faces.iter().enumerate() {
                let Some(s) = &samples[k] else { continue };
                let front = s.n * if flipped[k] { -1.0 } else { 1.0 };
                if visible[k] && front.dot(b - s.p) < 0.0 {
                    mesh.flip_face(f);
                    flipped[k] = !flipped[k];
                    rep.by_bombs += 1;
                }
            }
        }
    }
    for f in flips {
        mesh.flip_face(f);
        rep.by_name += 1;
    }
    let mut twins: Vec<FaceId> = doubles;
    if opts.double_sided_ambiguous {
        twins.extend(ambiguous_faces);
    }
    twins.sort_unstable();
    twins.dedup();
    for f in twins {
        let face = mesh.face(f).clone();
        let mut contours = face.contours.clone();
        for c in &mut contours {
            c[1..].reverse();
        }
        let name = face.name.as_ref().map(|n| format!("{n}.back"));
        mesh.add_face(
            Some(f),
            Face {
                name,
                contours,
                material: face.material,
            },
        );
        rep.doubled += 1;
    }
    Ok((mesh.into_model(), rep))
}

/// How a duplicate face (`ghost`, its welded contours as given) should
/// face by its own surface: the faces of its material that share its edges
/// (but its twin), as the automatic step oriented them. `Some(true)` when
/// more of them walk its edges the same way it does (it must turn),
/// `Some(false)` when more walk them the other way, `None` when there are
/// none or as many each way. A duplicate is thus oriented like its twin
/// when it is a copy of it (same material, same neighbours: ugclean then
/// removes it), but two surfaces of different materials that meet back to
/// back (ugcopl's pieces where a mullion's side lies on a wall, in Soda
/// Hall) each keep facing their own way.
fn own_surface(work: &Mesh, ghost: &Face, twin: FaceId) -> Option<bool> {
    let (mut same, mut other) = (0usize, 0usize);
    for c in &ghost.contours {
        for (i, &a) in c.iter().enumerate() {
            let b = c[(i + 1) % c.len()];
            let Some(e) = work.edge_between(a, b) else {
                continue;
            };
            let edge = work.edge(e);
            let forward = edge.v[0] == a;
            for u in &edge.uses {
                if u.face == twin || work.face(u.face).material != ghost.material {
                    continue;
                }
                if u.forward == forward {
                    same += 1;
                } else {
                    other += 1;
                }
            }
        }
    }
    match same.cmp(&other) {
        std::cmp::Ordering::Greater => Some(true),
        std::cmp::Ordering::Less => Some(false),
        std::cmp::Ordering::Equal => None,
    }
}

/// Automatic orientation (on `mesh`, in place); returns the faces of
/// ambiguous components and the faces flipped.
fn automatic(
    mesh: &mut Mesh,
    opts: &Options,
    names: &[(FaceId, String)],
    rep: &mut Report,
) -> (Vec<FaceId>, Vec<FaceId>) {
    let faces: Vec<FaceId> = mesh.faces().collect();
    let nf = mesh.model().faces.len();
    let label = |f: FaceId| {
        names
            .iter()
            .find(|(g, _)| *g == f)
            .map(|(_, l)| l.clone())
            .unwrap_or_default()
    };
    // 1. Components over manifold edges, with relative flips (the
    // majority of faces keeps its orientation).
    let Components {
        mut comp,
        mut rel,
        mut comps,
        conflicted,
    } = components(mesh, &faces, |_| 1.0);
    rep.nonorientable.extend(conflicted.into_iter().map(label));
    let closed_union = close_pairs(mesh, &mut comps, &mut comp, &mut rel);
    rep.components = comps.iter().filter(|m| !m.is_empty()).count();
    // Objects: components that share any edge (a wall whose foot face is
    // split off by edges it shares with an overlapping run is still one
    // wall). Enclosure is judged per object, never by a piece of one.
    let mut parent: Vec<usize> = (0..comps.len()).collect();
    for e in mesh.edges() {
        let uses = &mesh.edge(e).uses;
        let first = comp[uses[0].face.idx()];
        for u in &uses[1..] {
            crate::join(&mut parent, first, comp[u.face.idx()]);
        }
    }
    let object_of: Vec<usize> = (0..comps.len())
        .map(|c| crate::root(&mut parent, c))
        .collect();

    // Geometry with the relative flips applied.
    let samples: Vec<Option<Sample>> = (0..nf)
        .map(|i| {
            let f = FaceId(i as u32);
            if !mesh.is_face_live(f) {
                return None;
            }
            sample(mesh, f).map(|mut s| {
                if rel[i] {
                    s.n = -s.n;
                }
                s
            })
        })
        .collect();
    let bvh = scene(mesh);
    let objects = Objects::new(&comps, &object_of, &samples);

    // 2. Decide each component's side: +1 keep, -1 flip, 0 ambiguous.
    // First the closed ones (by their volume), then the open ones by the
    // visibility vote, where a ray that meets the back of a closed one's
    // face (it started inside a solid, behind a face lying on its surface
    // within epsilon) sees nothing.
    let decide_with = |c: usize, solids: Option<&[i8]>| {
        decide(
            mesh,
            &bvh,
            &comp,
            &rel,
            &samples,
            c,
            &comps[c],
            closed_union[c],
            &objects,
            &object_of,
            opts,
            solids,
        )
    };
    let first: Vec<Option<(i32, Reason)>> = (0..comps.len())
        .into_par_iter()
        .map(|c| decide_with(c, None))
        .collect();
    let mut solids = vec![0i8; nf];
    for (c, d) in first.iter().enumerate() {
        if let Some((d, Reason::Outward | Reason::Inward)) = d {
            for f in &comps[c] {
                solids[f.idx()] = if *d < 0 { -1 } else { 1 };
            }
        }
    }
    let decisions: Vec<(i32, Reason)> = first
        .into_par_iter()
        .enumerate()
        .map(|(c, d)| {
            d.or_else(|| decide_with(c, Some(&solids)))
                .unwrap_or((0, Reason::None))
        })
        .collect();
    // 3. An open part lying on a larger one's surface faces like it.
    let decisions = lying_on(&bvh, &comp, &comps, &samples, decisions, opts);
    let mut ambiguous = Vec::new();
    let mut flipped = Vec::new();
    for (c, members) in comps.iter().enumerate() {
        let (d, reason) = decisions[c];
        if d == 0 {
            rep.ambiguous.push(label(members[0]));
            ambiguous.extend(members.iter().copied());
        }
        for &f in members {
            let flip_all = d < 0;
            let flip = rel[f.idx()] ^ flip_all;
            if !flip {
                continue;
            }
            mesh.flip_face(f);
            flipped.push(f);
            if !flip_all {
                rep.consistency += 1;
            } else {
                match reason {
                    Reason::Outward => rep.outward += 1,
                    Reason::Inward => rep.inward += 1,
                    Reason::Scene | Reason::None => rep.toward_scene += 1,
                }
            }
        }
    }
    flipped.sort_unstable();
    (ambiguous, flipped)
}

/// Open parts that lie on another, larger part's surface (most of their
/// area within about 2 epsilon of its faces, on planes within 26°: a rug on
/// a floor, a paper on a desk, a picture on a wall, a cap's copy fanned
/// the other way on the cap) face the way that surface faces, whatever
/// their own vote said: from a sheet on a surface one side sees almost
/// nothing and the other the room, or, when the sheet is a hair behind the
/// surface, the inside of a solid, and a few rays decided. Ambiguous parts
/// (their vote undecided) get the same treatment; closed parts and the
/// surfaces under the parts keep their decision.
fn lying_on(
    bvh: &Bvh,
    comp: &[usize],
    comps: &[Vec<FaceId>],
    samples: &[Option<Sample>],
    decisions: Vec<(i32, Reason)>,
    opts: &Options,
) -> Vec<(i32, Reason)> {
    let area: Vec<f64> = comps
        .iter()
        .map(|m| {
            m.iter()
                .filter_map(|f| samples[f.idx()].as_ref())
                .map(|s| s.area)
                .sum()
        })
        .collect();
    let cos26 = 26f64.to_radians().cos();
    let overrides: Vec<Option<i32>> = comps
        .par_iter()
        .enumerate()
        .map(|(c, members)| {
            if members.is_empty()
                || !matches!(decisions[c].1, Reason::Scene | Reason::None)
                || area[c] <= 0.0
            {
                return None;
            }
            // Area on faces of larger decided parts, and how it agrees.
            let (mut agree, mut against) = (0.0, 0.0);
            for &f in members {
                let Some(s) = &samples[f.idx()] else { continue };
                let n = s.n.normalize_or_zero();
                let delta = opts.eps.max(1e-12 * (1.0 + s.p.length()));
                let w = s.area / s.spread.len() as f64;
                for &q in &s.spread {
                    // The faces of larger decided parts within the reach,
                    // in planes within 26° of this one: the largest part's
                    // (a paper under a monitor lies on the desk's top).
                    let under = bvh
                        .all_hits(q - n * (2.0 * delta), n, 0.0, 4.0 * delta, |id| {
                            comp[id as usize] != c
                        })
                        .into_iter()
                        .filter_map(|h| {
                            let g = h.id as usize;
                            let d = decisions[comp[g]].0;
                            let gs = samples[g].as_ref()?;
                            let ng = gs.n.normalize_or_zero() * f64::from(d);
                            (d != 0 && area[comp[g]] > area[c] && n.dot(ng).abs() >= cos26)
                                .then_some((area[comp[g]], comp[g], ng))
                        })
                        .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
                    let Some((_, _, ng)) = under else { continue };
                    let cos = n.dot(ng);
                    if cos >= cos26 {
                        agree += w;
                    } else if cos <= -cos26 {
                        against += w;
                    }
                }
            }
            if agree > 0.5 * area[c] {
                Some(1)
            } else if against > 0.5 * area[c] {
                Some(-1)
            } else {
                None
            }
        })
        .collect();
    decisions
        .into_iter()
        .zip(overrides)
        .map(|(d, o)| match o {
            Some(o) => (o, Reason::Scene),
            None => d,
        })
        .collect()
}

/// Joins pairs of open components that together form a closed surface:
/// every edge of their faces used exactly twice by them, and the two
/// orientable alike (the second flipped as a whole if need be). A slab's
/// top face, whose edges the walls standing flush on it make non-manifold
/// (top, side, wall foot and wall face meet there), is a component of its
/// own, and the rest of the slab box an open tray, which the visibility
/// vote turned inside out (its sides see only the tray from within).
/// Joined, they are one solid and face outward. Returns per component
/// whether it was closed this way; the second of a pair is left empty.
fn close_pairs(
    mesh: &Mesh,
    comps: &mut [Vec<FaceId>],
    comp: &mut [usize],
    rel: &mut [bool],
) -> Vec<bool> {
    let mut closed_union = vec![false; comps.len()];
    // The edges of component `c` not used exactly twice by it.
    let open_edges = |comps: &[Vec<FaceId>], comp: &[usize], c: usize| -> Vec<winged::EdgeId> {
        let mut out: Vec<winged::EdgeId> = comps[c]
            .iter()
            .flat_map(|&f| mesh.face_edges(f))
            .filter(|&e| {
                let u = &mesh.edge(e).uses;
                u.iter().filter(|x| comp[x.face.idx()] == c).count() != 2
            })
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    };
    for c in 0..comps.len() {
        if comps[c].is_empty() || closed_union[c] {
            continue;
        }
        let open = open_edges(comps, comp, c);
        if open.is_empty() {
            continue;
        }
        // A partner uses every open edge of `c` (once: with `c`'s use, two).
        let mut cand: Option<Vec<usize>> = None;
        for &e in &open {
            let u = &mesh.edge(e).uses;
            if u.iter().filter(|x| comp[x.face.idx()] == c).count() != 1 {
                cand = Some(Vec::new());
                break;
            }
            let mut here: Vec<usize> = u
                .iter()
                .map(|x| comp[x.face.idx()])
                .filter(|&d| d != c && !closed_union[d])
                .collect();
            here.sort_unstable();
            // Exactly one use by the partner.
            let once: Vec<usize> = here
                .chunk_by(|a, b| a == b)
                .filter(|g| g.len() == 1)
                .map(|g| g[0])
                .collect();
            cand = Some(match cand {
                None => once,
                Some(prev) => prev.into_iter().filter(|d| once.contains(d)).collect(),
            });
            if cand.as_ref().is_some_and(|v| v.is_empty()) {
                break;
            }
        }
        for d in cand.unwrap_or_default() {
            // Every open edge of `d` is one of `c`'s.
            let open_d = open_edges(comps, comp, d);
            if open_d != open {
                continue;
            }
            // One relative flip of `d` makes every shared edge consistent.
            let mut flip: Option<bool> = None;
            let mut ok = true;
            for &e in &open {
                let u = &mesh.edge(e).uses;
                let mine = u.iter().find(|x| comp[x.face.idx()] == c);
                let other = u.iter().find(|x| comp[x.face.idx()] == d);
                let (Some(mine), Some(other)) = (mine, other) else {
                    ok = false;
                    break;
                };
                let want = rel[mine.face.idx()] ^ (mine.forward == other.forward);
                let x = want ^ rel[other.face.idx()];
                if *flip.get_or_insert(x) != x {
                    ok = false;
                    break;
                }
            }
            if !ok {
                continue;
            }
            let x = flip.unwrap_or(false);
            let moved = std::mem::take(&mut comps[d]);
            for &f in &moved {
                comp[f.idx()] = c;
                rel[f.idx()] ^= x;
            }
            comps[c].extend(moved);
            closed_union[c] = true;
            break;
        }
    }
    closed_union
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reason {
    None,
    Outward,
    Inward,
    Scene,
}

#[allow(clippy::too_many_arguments)]
fn decide(
    mesh: &Mesh,
    bvh: &Bvh,
    comp: &[usize],
    rel: &[bool],
    samples: &[Option<Sample>],
    c: usize,
    members: &[FaceId],
    closed_union: bool,
    objects: &Objects,
    object_of: &[usize],
    opts: &Options,
    solids: Option<&[i8]>,
) -> Option<(i32, Reason)> {
    let total_area: f64 = members
        .iter()
        .filter_map(|f| samples[f.idx()].as_ref())
        .map(|s| s.area)
        .sum();
    if total_area <= 0.0 {
        return Some((1, Reason::None));
    }
    // Closed: every edge of every member has exactly two uses in this
    // component (or two components that close each other, see
    // `close_pairs`). Uses by other components do not count: a slab with
    // walls standing flush on its edges is still a closed box (its edges
    // have four uses), and judging it by the visibility vote turned the
    // 100k building's ground slab inside out once the vote's rays changed
    // (from inside a thin slab every ray sees its own faces, far away
    // along it).
    let closed = closed_union
        || members.iter().all(|&f| {
            mesh.face_edges(f).iter().all(|&e| {
                let u = &mesh.edge(e).uses;
                u.iter().filter(|x| comp[x.face.idx()] == c).count() == 2
            })
        });
    if closed {
        // The signed volume, from the middle of the component's box: from
        // the origin, the tetrahedra of a table leg on a site half a
        // million metres away are 10¹⁵ times its volume, whose sign their
        // rounding decided (a leg turned inside out).
        let (lo, hi) = bbox_of(mesh, members);
        let o = (lo + hi) * 0.5;
        let mut vol = 0.0;
        for &f in members {
            let pts = mesh.face_points(f);
            let flat: Vec<DVec3> = pts.iter().flatten().map(|&p| p - o).collect();
            for t in face_triangles(&pts) {
                let v = flat[t[0]].dot(flat[t[1]].cross(flat[t[2]])) / 6.0;
                vol += if rel[f.idx()] { -v } else { v };
            }
        }
        let size = (hi - lo).length();
        if vol.abs() > opts.eps * total_area.max(size * size) {
            let encloses = encloses(mesh, members, samples, c, objects, object_of, opts, lo, hi);
            let outward = vol > 0.0;
            return Some(if encloses {
                (if outward { -1 } else { 1 }, Reason::Inward)
            } else {
                (if outward { 1 } else { -1 }, Reason::Outward)
            });
        }
        // Flat closed surfaces (two sides of a zero-thickness wall): nothing to decide.
        return Some((1, Reason::None));
    }
    // Open: the vote, once the closed components are decided.
    let solids = solids?;
    // Open: visibility vote. Each ray that hits scene at distance t sees about
    // t² of surface (per unit solid angle), so the sums estimate how much of the
    // scene each side sees; a face close under a ceiling sees little behind it.
    let dirs = hemisphere(opts.rays.max(1));
    // [front, back] for other components and for the component's own faces.
    // Per face in parallel (a building floor is one component of tens of
    // thousands of faces), summed in member order: the same bytes at any
    // thread count.
    let per_face: Vec<([f64; 2], [f64; 2], [f64; 2])> = members
        .par_iter()
        .map(|&f| {
            let (mut other, mut own, mut backs) = ([0.0f64; 2], [0.0f64; 2], [0.0f64; 2]);
            let Some(s) = &samples[f.idx()] else {
                return (other, own, backs);
            };
            // The frame of the normal's unsigned direction (its largest
            // component positive), the sides by the normal: turned over,
            // the face casts the same rays from each side.
            let a = s.n.abs();
            let lead = if a.x >= a.y && a.x >= a.z {
                s.n.x
            } else if a.y >= a.z {
                s.n.y
            } else {
                s.n.z
            };
            let sgn = if lead < 0.0 { -1.0 } else { 1.0 };
            let frame = Frame::new(s.p, s.n * sgn);
            // Epsilon off the face, and (far from the origin) at least
            // 1e-12 of the distance, a thousand times the rounding of the
            // point there. (1e-9 of it was 4 mm on a site 4·10⁶ m away:
            // the back rays of a picture 2 mm in front of a wall started
            // inside the wall. No placed seed's vote changed either way.)
            let delta = opts.eps.max(1e-12 * (1.0 + s.p.length()));
            let w = s.area / dirs.len() as f64;
            for (k, side) in [1.0, -1.0].into_iter().enumerate() {
                for (i, d) in dirs.iter().enumerate() {
                    let o = s.spread[i % s.spread.len()] + s.n * (side * delta);
                    let dir = (frame.u * d.x + frame.v * d.y + frame.n * d.z) * (side * sgn);
                    if let Some(h) = bvh.intersect(o, dir, 0.0, f64::INFINITY, |id| id != f.0) {
                        let hit = h.id as usize;
                        let seen = h.t * h.t * w;
                        if solids[hit] != 0
                            && let Some(hs) = &samples[hit]
                            && dir.dot(hs.n) * f64::from(solids[hit]) > 0.0
                        {
                            backs[k] += seen;
                            continue;
                        }
                        if comp[hit] == c {
                            own[k] += seen;
                        } else {
                            other[k] += seen;
                        }
                    }
                }
            }
            (other, own, backs)
        })
        .collect();
    let (mut other, mut own, mut backs) = ([0.0f64; 2], [0.0f64; 2], [0.0f64; 2]);
    for (o, w, b) in &per_face {
        for k in 0..2 {
            other[k] += o[k];
            own[k] += w[k];
            backs[k] += b[k];
        }
    }
    let verdict = |s: [f64; 2]| {
        let (sum, diff) = (s[0] + s[1], s[0] - s[1]);
        (sum > 0.0 && diff.abs() > 0.05 * sum).then_some(if diff > 0.0 { 1 } else { -1 })
    };
    // Everything the two sides see counts, the component's own faces too: a
    // whole building floor (one open component: rooms joined by doorways)
    // sees its own walls and ceilings from the inside, and only the odd
    // separate part from the outside. (Letting other components decide
    // first turned the Soda Hall floor inside out.) Own faces alone still
    // decide where nothing else is seen (a box missing a side faces inward).
    // Where what the sides see in front of faces does not decide (a part
    // inside a solid sees only backs from either side), the backs count.
    let all = [other[0] + own[0], other[1] + own[1]];
    let with_backs = [all[0] + backs[0], all[1] + backs[1]];
    Some(match verdict(all).or_else(|| verdict(with_backs)) {
        Some(d) => (d, Reason::Scene),
        None => (0, Reason::None),
    })
}

fn bbox_of(mesh: &Mesh, members: &[FaceId]) -> (DVec3, DVec3) {
    geom::index::bbox(
        members
            .iter()
            .flat_map(|&f| mesh.face_points(f).into_iter().flatten()),
        0.0,
    )
}

/// The objects (components joined by shared edges) with their sampled
/// faces, components in order and members in order, and an index of their
/// sample boxes: a closed component looks only at objects within its box.
struct Objects {
    /// Per object root (component id of the root): its faces with samples.
    members: Vec<Vec<FaceId>>,
    index: geom::index::BoxIndex,
}

impl Objects {
    fn new(comps: &[Vec<FaceId>], object_of: &[usize], samples: &[Option<Sample>]) -> Objects {
        let mut members: Vec<Vec<FaceId>> = vec![Vec::new(); comps.len()];
        for (k, m) in comps.iter().enumerate() {
            members[object_of[k]].extend(m.iter().filter(|f| samples[f.idx()].is_some()));
        }
        let index = geom::index::BoxIndex::new(members.iter().enumerate().filter_map(|(o, m)| {
            if m.is_empty() {
                return None;
            }
            let (lo, hi) = geom::index::bbox(
                m.iter()
                    .filter_map(|f| samples[f.idx()].as_ref())
                    .map(|s| s.p),
                0.0,
            );
            Some((lo, hi, o as u32))
        }));
        Objects { members, index }
    }
}

/// Whether a closed component contains a point of another component (lights
/// included), a camera eye or a light bomb (ray parity against its own faces).
#[allow(clippy::too_many_arguments)]
fn encloses(
    mesh: &Mesh,
    members: &[FaceId],
    samples: &[Option<Sample>],
    c: usize,
    objects: &Objects,
    object_of: &[usize],
    opts: &Options,
    lo: DVec3,
    hi: DVec3,
) -> bool {
    let d = (1e-4 * (hi - lo).length()).max(10.0 * opts.eps);
    let dir = DVec3::new(0.302_775_637, 0.723_606_798, 0.620_349_731).normalize();
    let in_box = |p: DVec3| p.cmpge(lo).all() && p.cmple(hi).all();
    // Parity against the component's own faces: a BVH of just them (the
    // scene's, filtered, walks everything along the ray).
    let own = {
        let mut tris = Vec::new();
        for &f in members {
            let pts = mesh.face_points(f);
            let flat: Vec<DVec3> = pts.iter().flatten().copied().collect();
            for t in face_triangles(&pts) {
                tris.push(Triangle {
                    p: [flat[t[0]], flat[t[1]], flat[t[2]]],
                    id: f.0,
                });
            }
        }
        Bvh::new(tris)
    };
    let inside = |p: DVec3| {
        if !in_box(p) {
            return false;
        }
        let mut ts: Vec<f64> = own
            .all_hits(p, dir, 0.0, f64::INFINITY, |_| true)
            .into_iter()
            .map(|h| h.t)
            .collect();
        ts.sort_by(f64::total_cmp);
        ts.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * (1.0 + b.abs()));
        ts.len() % 2 == 1
    };
    // Every other object within the box: enclosed when more than half of
    // its area is inside (each face judged at the points just in front of
    // and just behind it, so a sheet lying on this component's surface — a
    // rug on a floor — is not inside, and neither is a box sunk a little
    // into a slab, whose bottom alone is).
    for o in objects.index.query(lo, hi) {
        let o = o as usize;
        if o == object_of[c] {
            continue;
        }
        let faces: Vec<&Sample> = objects.members[o]
            .iter()
            .filter_map(|f| samples[f.idx()].as_ref())
            .collect();
        if !faces.iter().all(|s| in_box(s.p)) {
            continue;
        }
        let total: f64 = faces.iter().map(|s| s.area).sum();
        if total <= 0.0 {
            continue;
        }
        // Each face judged at its spread points, each for its share of
        // the area: a window pane that a wall box crosses (a wing's wall
        // starting at the window of the building it joins) has a fifth of
        // its area inside the box, and its one centroid there made the
        // wall a room, turned inside out (property seed 400319 at 4
        // decimals with oblique wings: an overlapping pair after ugcut at
        // the wall's far end). Stops as soon as the majority is decided
        // either way.
        let (mut within, mut without) = (0.0, 0.0);
        'faces: for s in faces.iter() {
            let w = s.area / s.spread.len() as f64;
            for &q in &s.spread {
                if inside(q + s.n * d) && inside(q - s.n * d) {
                    within += w;
                    if within > 0.5 * total {
                        return true;
                    }
                } else {
                    without += w;
                    if without >= 0.5 * total {
                        break 'faces;
                    }
                }
            }
        }
    }
    // Or a viewpoint (camera eye, explicit point) inside it.
    opts.viewpoints
        .iter()
        .chain(opts.bombs.iter())
        .any(|&p| inside(p))
}

/// Eye points of `cam` statements written `cam NAME … -eye X Y Z …`.
pub fn camera_eyes(m: &Model) -> Vec<DVec3> {
    m.items
        .iter()
        .filter_map(|it| match it {
            ug::Item::Camera(r) => {
                let w: Vec<&str> = r.text.split_whitespace().collect();
                let k = w.iter().position(|x| *x == "-eye")?;
                let n: Vec<f64> = w
                    .get(k + 1..k + 4)?
                    .iter()
                    .filter_map(|x| x.parse().ok())
                    .collect();
                (n.len() == 3 && n.iter().all(|v| v.is_finite()))
                    .then(|| DVec3::new(n[0], n[1], n[2]))
            }
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Model {
        ug::parse(text.as_bytes(), "t").unwrap().model
    }

    /// Edges walked the same way by their two faces.
    fn inconsistent(m: &Model) -> usize {
        let mesh = Mesh::from_model(m.clone());
        mesh.edges()
            .filter(|&e| mesh.edge(e).uses.len() == 2 && !mesh.consistently_oriented(e))
            .count()
    }

    /// A unit cube's six faces, each reversed where `reversed` says.
    fn cube(reversed: [bool; 6]) -> Model {
        let mut t = String::new();
        for (k, p) in [
            [0, 0, 0],
            [1, 0, 0],
            [1, 1, 0],
            [0, 1, 0],
            [0, 0, 1],
            [1, 0, 1],
            [1, 1, 1],
            [0, 1, 1],
        ]
        .iter()
        .enumerate()
        {
            t += &format!("v v{k} {} {} {};\n", p[0], p[1], p[2]);
        }
        // Outward, counter-clockwise seen from outside.
        let faces = [
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [1, 2, 6, 5],
            [2, 3, 7, 6],
            [3, 0, 4, 7],
        ];
        for (k, f) in faces.iter().enumerate() {
            let mut f = f.to_vec();
            if reversed[k] {
                f[1..].reverse();
            }
            let names: Vec<String> = f.iter().map(|v| format!("v{v}")).collect();
            t += &format!("f s{k} ({});\n", names.join(" "));
        }
        parse(&t)
    }

    #[test]
    fn a_consistent_model_comes_back_as_it_went_in() {
        let m = cube([false; 6]);
        let (out, turned) = agree(m.clone());
        assert!(turned.is_empty());
        assert_eq!(ug::write_string(&out), ug::write_string(&m));
    }

    #[test]
    fn the_faces_of_the_lesser_area_turn() {
        // Two sides reversed: they turn back, not the other four.
        let (out, turned) = agree(cube([false, true, false, false, true, false]));
        assert_eq!(turned, [FaceId(1), FaceId(4)]);
        assert_eq!(inconsistent(&out), 0);
        assert_eq!(ug::write_string(&out), ug::write_string(&cube([false; 6])));
        // Four reversed: the two others turn.
        let (out, turned) = agree(cube([true, true, false, true, true, true]));
        assert_eq!(turned, [FaceId(2)]);
        assert_eq!(inconsistent(&out), 0);
    }

    /// A Möbius band of `n` quads, quad `k` reversed where `flips` has bit
    /// `k`: no orientation makes it consistent, and the best leaves one
    /// edge walked the same way.
    fn moebius(n: usize, flips: u32) -> Model {
        let mut t = String::new();
        for k in 0..n {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            // The cross-section turns by half a turn around the loop.
            let (s, c) = (a / 2.0).sin_cos();
            for (side, r) in [("a", -0.3), ("b", 0.3)] {
                let (rr, z) = (2.0 + r * c, r * s);
                t += &format!("v {side}{k} {} {} {z};\n", rr * a.cos(), rr * a.sin());
            }
        }
        for k in 0..n {
            let j = (k + 1) % n;
            // The last quad closes the band across the twist.
            let (aj, bj) = if j == 0 {
                ("b0".to_string(), "a0".to_string())
            } else {
                (format!("a{j}"), format!("b{j}"))
            };
            let mut f = [format!("a{k}"), format!("b{k}"), bj, aj];
            if flips >> k & 1 == 1 {
                f[1..].reverse();
            }
            t += &format!("f q{k} ({});\n", f.join(" "));
        }
        parse(&t)
    }

    #[test]
    fn a_band_no_orientation_mends_keeps_one_inconsistent_edge() {
        for flips in [0, 0b1, 0b1010_0110, 0b0101_0101, 0b1111_0000, 0b1_1011] {
            let m = moebius(9, flips);
            let before = inconsistent(&m);
            assert!(before >= 1);
            let (out, turned) = agree(m);
            assert_eq!(inconsistent(&out), 1, "flips {flips:b}");
            // Nothing turns where the faces as given leave one edge only.
            if before == 1 {
                assert!(turned.is_empty(), "flips {flips:b}");
            }
        }
    }
}
