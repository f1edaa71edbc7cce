//! The checks behind `ugcheck`: a model's counts, defects and topology.
//!
//! Defects (what the cleaning tools remove): non-planar faces, T-vertices,
//! intersecting pairs, partially overlapping coplanar pairs, coincident faces,
//! degenerate faces, and neighbours with inconsistent orientation.
//! Topology facts (normal in open architectural models, deny-able): boundary
//! edges, non-manifold edges, and faces that are not triangles or convex quads.
//!
//! Faces are named by their UG name or, when unnamed, `#k` (the k-th face of
//! the file, from 1). Every list is in file order; the report is deterministic.

use std::fmt::Write as _;

use geom::intersect::{FaceGeom, Relation, relate};
use geom::overlap::coverage_near;
use geom::{BoxIndex, DVec2, DVec3, Plane, orient2d, point_segment_distance};
use rayon::prelude::*;
use serde::Serialize;
use ug::{FaceId, Model, VertexId};

/// The categories `--deny` accepts.
pub const CATEGORIES: [&str; 10] = [
    "nonplanar",
    "tvertex",
    "intersect",
    "overlap",
    "coincident",
    "degenerate",
    "orientation",
    "boundary",
    "nonmanifold",
    "nonpatch",
];

/// The categories that are defects (the rest are topology facts).
pub const DEFECTS: [&str; 7] = [
    "nonplanar",
    "tvertex",
    "intersect",
    "overlap",
    "coincident",
    "degenerate",
    "orientation",
];

#[derive(Serialize, Debug, Default, Clone, PartialEq)]
pub struct Counts {
    pub vertices: usize,
    pub faces: usize,
    pub contours: usize,
    pub edges: usize,
    pub materials: usize,
    /// Faces whose material emits light.
    pub emitters: usize,
    pub wires: usize,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct NonPlanar {
    pub face: String,
    /// Largest distance of a vertex from the face's best-fit plane (model units).
    pub deviation: f64,
    /// `deviation` divided by the face's size (its bounding-box diagonal).
    pub relative: f64,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct TVertex {
    pub vertex: String,
    /// The edge whose interior the vertex lies on.
    pub edge: [String; 2],
    /// Faces that use that edge without the vertex.
    pub faces: Vec<String>,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Pair {
    pub a: String,
    pub b: String,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Overlap {
    pub a: String,
    pub b: String,
    /// Area of the common region.
    pub area: f64,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Degenerate {
    pub face: String,
    pub reason: String,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct EdgeReport {
    pub edge: [String; 2],
    pub faces: Vec<String>,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct NonPatch {
    pub face: String,
    pub reason: String,
}

#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct MaterialArea {
    pub material: String,
    pub area: f64,
}

/// Everything `ugcheck` reports.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Report {
    pub epsilon: f64,
    pub counts: Counts,
    pub nonplanar: Vec<NonPlanar>,
    pub tvertices: Vec<TVertex>,
    pub intersecting: Vec<Pair>,
    pub overlapping: Vec<Overlap>,
    pub coincident: Vec<Pair>,
    pub degenerate: Vec<Degenerate>,
    pub inconsistent: Vec<EdgeReport>,
    pub boundary_edges: Vec<EdgeReport>,
    pub nonmanifold_edges: Vec<EdgeReport>,
    pub nonpatch: Vec<NonPatch>,
    pub area_by_material: Vec<MaterialArea>,
}

impl Report {
    /// Number of findings in a category (one of [`CATEGORIES`]).
    pub fn count(&self, category: &str) -> usize {
        match category {
            "nonplanar" => self.nonplanar.len(),
            "tvertex" => self.tvertices.len(),
            "intersect" => self.intersecting.len(),
            "overlap" => self.overlapping.len(),
            "coincident" => self.coincident.len(),
            "degenerate" => self.degenerate.len(),
            "orientation" => self.inconsistent.len(),
            "boundary" => self.boundary_edges.len(),
            "nonmanifold" => self.nonmanifold_edges.len(),
            "nonpatch" => self.nonpatch.len(),
            _ => 0,
        }
    }

    /// Total number of defects (not counting topology facts).
    pub fn defects(&self) -> usize {
        DEFECTS.iter().map(|c| self.count(c)).sum()
    }
}

/// Formats a number compactly and deterministically for the text report.
fn num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e7).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.6e}")
    }
}

const LIST_LIMIT: usize = 50;

impl Report {
    /// The human-readable report (at most 50 items listed per category unless `all`).
    pub fn text(&self, all: bool) -> String {
        let mut s = String::new();
        let c = &self.counts;
        let _ = writeln!(s, "epsilon: {}", num(self.epsilon));
        let _ = writeln!(
            s,
            "counts: {} vertices, {} faces, {} contours, {} edges, {} materials, {} emitters, {} wires",
            c.vertices, c.faces, c.contours, c.edges, c.materials, c.emitters, c.wires
        );
        let _ = writeln!(s, "defects: {}", self.defects());
        let rows: [(&str, &str); 10] = [
            ("nonplanar", "non-planar faces"),
            ("tvertex", "T-vertices"),
            ("intersect", "intersecting pairs"),
            ("overlap", "overlapping coplanar pairs"),
            ("coincident", "coincident pairs"),
            ("degenerate", "degenerate faces"),
            ("orientation", "inconsistently oriented edges"),
            ("boundary", "boundary edges"),
            ("nonmanifold", "non-manifold edges"),
            ("nonpatch", "faces not triangles or convex quads"),
        ];
        for (k, (cat, label)) in rows.iter().enumerate() {
            if k == 7 {
                let _ = writeln!(s, "topology:");
            }
            let _ = writeln!(s, "  {label}: {}", self.count(cat));
        }
        let _ = writeln!(s, "area per material:");
        for m in &self.area_by_material {
            let _ = writeln!(s, "  {}: {}", m.material, num(m.area));
        }
        let limit = if all { usize::MAX } else { LIST_LIMIT };
        let mut section = |title: &str, lines: Vec<String>| {
            if lines.is_empty() {
                return;
            }
            let _ = writeln!(s, "{title}:");
            for l in lines.iter().take(limit) {
                let _ = writeln!(s, "  {l}");
            }
            if lines.len() > limit {
                let _ = writeln!(
                    s,
                    "  … {} more (--all lists everything)",
                    lines.len() - limit
                );
            }
        };
        section(
            "non-planar faces",
            self.nonplanar
                .iter()
                .map(|n| {
                    format!(
                        "{}: deviation {} ({} of its size)",
                        n.face,
                        num(n.deviation),
                        num(n.relative)
                    )
                })
                .collect(),
        );
        section(
            "T-vertices",
            self.tvertices
                .iter()
                .map(|t| {
                    format!(
                        "{} on edge {}-{} of {}",
                        t.vertex,
                        t.edge[0],
                        t.edge[1],
                        t.faces.join(" ")
                    )
                })
                .collect(),
        );
        section(
            "intersecting pairs",
            self.intersecting
                .iter()
                .map(|p| format!("{} {}", p.a, p.b))
                .collect(),
        );
        section(
            "overlapping coplanar pairs",
            self.overlapping
                .iter()
                .map(|p| format!("{} {}: common area {}", p.a, p.b, num(p.area)))
                .collect(),
        );
        section(
            "coincident pairs",
            self.coincident
                .iter()
                .map(|p| format!("{} {}", p.a, p.b))
                .collect(),
        );
        section(
            "degenerate faces",
            self.degenerate
                .iter()
                .map(|d| format!("{}: {}", d.face, d.reason))
                .collect(),
        );
        let edges = |v: &[EdgeReport]| -> Vec<String> {
            v.iter()
                .map(|e| format!("{}-{}: {}", e.edge[0], e.edge[1], e.faces.join(" ")))
                .collect()
        };
        section("inconsistently oriented edges", edges(&self.inconsistent));
        section("non-manifold edges", edges(&self.nonmanifold_edges));
        section("boundary edges", edges(&self.boundary_edges));
        section(
            "faces not triangles or convex quads",
            self.nonpatch
                .iter()
                .map(|n| format!("{}: {}", n.face, n.reason))
                .collect(),
        );
        s
    }
}

struct Ctx<'m> {
    m: &'m Model,
    eps: f64,
    faces: Vec<FaceId>,
    labels: Vec<String>,
    /// Position of each face id in `faces` (usize::MAX for faces not at the top level).
    order: Vec<usize>,
}

impl Ctx<'_> {
    fn label(&self, f: FaceId) -> &str {
        &self.labels[self.order[f.idx()]]
    }
    fn vname(&self, v: VertexId) -> String {
        self.m.vertices[v.idx()].name.clone()
    }
    fn points(&self, f: FaceId) -> Vec<Vec<DVec3>> {
        self.m.faces[f.idx()]
            .contours
            .iter()
            .map(|c| c.iter().map(|&v| self.m.pos(v)).collect())
            .collect()
    }
}

/// Checks a flat model (call `Model::flatten` first) with distance tolerance `eps`.
pub fn check(m: &Model, eps: f64) -> Report {
    let faces: Vec<FaceId> = m.top_faces().collect();
    let mut order = vec![usize::MAX; m.faces.len()];
    let labels: Vec<String> = faces
        .iter()
        .enumerate()
        .map(|(k, &f)| {
            order[f.idx()] = k;
            m.faces[f.idx()]
                .name
                .clone()
                .unwrap_or_else(|| format!("#{}", k + 1))
        })
        .collect();
    let cx = Ctx {
        m,
        eps,
        faces,
        labels,
        order,
    };

    let mesh = winged::Mesh::from_model(m.clone());
    let edge_faces = |e: winged::EdgeId| -> Vec<String> {
        let mut v: Vec<String> = mesh
            .edge(e)
            .uses
            .iter()
            .map(|u| cx.label(u.face).to_string())
            .collect();
        v.dedup();
        v
    };
    let edge_report = |e: winged::EdgeId| {
        let ed = mesh.edge(e);
        EdgeReport {
            edge: [cx.vname(ed.v[0]), cx.vname(ed.v[1])],
            faces: edge_faces(e),
        }
    };

    // Counts.
    let emitters = cx
        .faces
        .iter()
        .filter(|&&f| {
            m.faces[f.idx()]
                .material
                .is_some_and(|mm| m.material(mm).is_emitter())
        })
        .count();
    let counts = Counts {
        vertices: m.top_vertices().count(),
        faces: cx.faces.len(),
        contours: cx
            .faces
            .iter()
            .map(|&f| m.faces[f.idx()].contours.len())
            .sum(),
        edges: mesh.edges().count(),
        materials: m.materials.len(),
        emitters,
        wires: m
            .items
            .iter()
            .filter(|i| matches!(i, ug::Item::Wire(_)))
            .count(),
    };

    // Per-face checks.
    let per_face: Vec<FaceFindings> = cx.faces.par_iter().map(|&f| face_checks(&cx, f)).collect();
    let mut degenerate = Vec::new();
    let mut nonplanar = Vec::new();
    let mut nonpatch = Vec::new();
    let mut geoms = Vec::with_capacity(per_face.len());
    let mut is_nonplanar = Vec::with_capacity(per_face.len());
    for (d, n, p, g) in per_face {
        is_nonplanar.push(n.is_some());
        degenerate.extend(d);
        nonplanar.extend(n);
        nonpatch.extend(p);
        geoms.push(g);
    }

    // Edge topology.
    let mut inconsistent = Vec::new();
    let mut boundary_edges = Vec::new();
    let mut nonmanifold_edges = Vec::new();
    for e in mesh.edges() {
        let uses = mesh.edge(e).uses.len();
        if uses == 1 {
            boundary_edges.push(edge_report(e));
        } else if uses > 2 {
            nonmanifold_edges.push(edge_report(e));
        } else if !mesh.consistently_oriented(e) {
            inconsistent.push(edge_report(e));
        }
    }

    let tvertices = t_vertices(&cx, &mesh, &geoms);

    let (intersecting, overlapping, coincident) = pairs(&cx, &geoms);

    // Area per material, in material order, then faces without one.
    let mut areas = vec![0.0; m.materials.len() + 1];
    let mut used = vec![false; m.materials.len() + 1];
    for (k, &f) in cx.faces.iter().enumerate() {
        let slot = m.faces[f.idx()]
            .material
            .map_or(m.materials.len(), |mm| mm.idx());
        used[slot] = true;
        if geoms[k].is_some() {
            areas[slot] += surface_area(&cx.points(f), is_nonplanar[k]);
        }
    }
    let area_by_material = (0..=m.materials.len())
        .filter(|&k| used[k])
        .map(|k| MaterialArea {
            material: m
                .materials
                .get(k)
                .map_or_else(|| "(none)".to_string(), |mm| mm.name.clone()),
            area: areas[k],
        })
        .collect();

    Report {
        epsilon: eps,
        counts,
        nonplanar,
        tvertices,
        intersecting,
        overlapping,
        coincident,
        degenerate,
        inconsistent,
        boundary_edges,
        nonmanifold_edges,
        nonpatch,
        area_by_material,
    }
}

/// What the per-face checks find: degeneracy, non-planarity, patch shape,
/// and the geometry for the pair tests (`None` for a degenerate face).
type FaceFindings = (
    Option<Degenerate>,
    Option<NonPlanar>,
    Option<NonPatch>,
    Option<FaceGeom>,
);

fn face_checks(cx: &Ctx<'_>, f: FaceId) -> FaceFindings {
    let face = &cx.m.faces[f.idx()];
    let label = cx.label(f).to_string();
    let pts = cx.points(f);
    let eps = cx.eps;
    // Degeneracy.
    let mut reason = None;
    for (ci, c) in face.contours.iter().enumerate() {
        let n = c.len();
        let mut distinct: Vec<VertexId> = c.clone();
        distinct.sort_unstable();
        distinct.dedup();
        if distinct.len() < 3 {
            reason = Some(format!(
                "contour {} has fewer than 3 distinct vertices",
                ci + 1
            ));
            break;
        }
        if let Some(i) = (0..n).find(|&i| c[i] == c[(i + 1) % n]) {
            reason = Some(format!(
                "contour {} repeats vertex {} consecutively",
                ci + 1,
                cx.vname(c[i])
            ));
            break;
        }
        if let Some(i) = (0..n).find(|&i| (pts[ci][i] - pts[ci][(i + 1) % n]).length() <= eps) {
            reason = Some(format!(
                "contour {} has a zero-length edge {}-{}",
                ci + 1,
                cx.vname(c[i]),
                cx.vname(c[(i + 1) % n])
            ));
            break;
        }
        // A tent: a vertex within epsilon of the short chord between its
        // neighbours (no mesher covers it without a degenerate triangle;
        // in a triangle the whole face is measured below).
        if n >= 4
            && let Some(i) = (0..n).find(|&i| {
                let (u, v, w) = (pts[ci][(i + n - 1) % n], pts[ci][i], pts[ci][(i + 1) % n]);
                winged::weld::is_tent(u, v, w, eps)
            })
        {
            reason = Some(format!(
                "contour {} has a tent at {} (its neighbours {} and {} are {} apart)",
                ci + 1,
                cx.vname(c[i]),
                cx.vname(c[(i + n - 1) % n]),
                cx.vname(c[(i + 1) % n]),
                num(pts[ci][(i + n - 1) % n].distance(pts[ci][(i + 1) % n]))
            ));
            break;
        }
    }
    let (lo, hi) = geom::index::bbox(pts.iter().flatten().copied(), 0.0);
    let size = (hi - lo).length();
    let outer_area = geom::newell_normal(&pts[0]).length() / 2.0;
    if reason.is_none() && outer_area <= eps * eps {
        reason = Some(if geom::spread_normal(&pts[0]).length() / 2.0 > eps * eps {
            // Lobes of opposite winding and equal area (a bow-tie).
            "contour 1 crosses itself (its lobes' areas cancel)".to_string()
        } else {
            "zero area (its vertices are collinear)".to_string()
        });
    }
    if reason.is_none() {
        reason = shape_defect(cx, face, &pts, eps);
    }
    if let Some(r) = reason {
        return (
            Some(Degenerate {
                face: label,
                reason: r,
            }),
            None,
            None,
            None,
        );
    }
    // Planarity against the face's best-fit plane (the tools' measure).
    let np = Plane::face_deviation(&pts)
        .filter(|&(dev, _)| dev > eps)
        .map(|(dev, _)| NonPlanar {
            face: label.clone(),
            deviation: dev,
            relative: dev / size,
        });
    // Patch shape.
    let outer = &face.contours[0];
    let patch = if face.contours.len() > 1 {
        Some(format!(
            "{} contours (holes or islands)",
            face.contours.len()
        ))
    } else if outer.len() > 4 {
        Some(format!("{} vertices", outer.len()))
    } else if outer.len() == 4 {
        let g = FaceGeom::new(pts.clone());
        let convex = g.is_some_and(|g| {
            let c = &g.contours_2d[0];
            (0..4).all(|i| orient2d(c[i], c[(i + 1) % 4], c[(i + 2) % 4]) > 0)
        });
        (!convex).then(|| "quadrilateral is not convex".to_string())
    } else {
        None
    };
    let patch = patch.map(|reason| NonPatch {
        face: label,
        reason,
    });
    (None, np, patch, FaceGeom::new(pts))
}

/// What is wrong with the shape of a face whose contours each have three
/// distinct vertices and no zero-length edge: a contour that visits a vertex
/// twice (a spike `(a b a c)` or a pinch), two edges that cross (a contour
/// crossing itself or another), or a vertex within `eps` of an edge it is
/// not an end of (the face is narrower than epsilon there: a sliver, a
/// neck, a contour touching itself or another). Decided in the face's
/// best-fit plane, crossings exactly. Contours that share a vertex (a hole
/// hung on the outer contour at one vertex) are fine.
fn shape_defect(cx: &Ctx<'_>, face: &ug::Face, pts: &[Vec<DVec3>], eps: f64) -> Option<String> {
    for (ci, c) in face.contours.iter().enumerate() {
        let mut seen: Vec<VertexId> = c.clone();
        seen.sort_unstable();
        if let Some(w) = seen.windows(2).find(|w| w[0] == w[1]) {
            return Some(format!(
                "contour {} visits vertex {} twice",
                ci + 1,
                cx.vname(w[0])
            ));
        }
    }
    // An edge walked twice: a hole lying along the outer contour (or two
    // holes along each other). The face's boundary touches itself there.
    if let Some((a, b)) = winged::pieces::edge_walked_twice(&face.contours) {
        return Some(format!(
            "its contours walk edge {}-{} twice",
            cx.vname(a),
            cx.vname(b)
        ));
    }
    let g = FaceGeom::new(pts.to_vec())?;
    // Edges as (vertex ids, 2-D ends).
    let mut edges: Vec<([VertexId; 2], DVec2, DVec2)> = Vec::new();
    for (ci, c) in face.contours.iter().enumerate() {
        let n = c.len();
        for i in 0..n {
            let j = (i + 1) % n;
            edges.push(([c[i], c[j]], g.contours_2d[ci][i], g.contours_2d[ci][j]));
        }
    }
    let mut verts: Vec<(VertexId, DVec2)> = face
        .contours
        .iter()
        .zip(&g.contours_2d)
        .flat_map(|(c, c2)| c.iter().copied().zip(c2.iter().copied()))
        .collect();
    verts.sort_by_key(|v| v.0);
    verts.dedup_by_key(|v| v.0);
    let index = (edges.len() > 24).then(|| {
        BoxIndex::new(edges.iter().enumerate().map(|(k, &(_, a, b))| {
            (
                (a.min(b) - DVec2::splat(eps)).extend(0.0),
                (a.max(b) + DVec2::splat(eps)).extend(0.0),
                k as u32,
            )
        }))
    });
    let near = |lo: DVec2, hi: DVec2| -> Vec<usize> {
        match &index {
            Some(ix) => ix
                .query(lo.extend(0.0), hi.extend(0.0))
                .into_iter()
                .map(|k| k as usize)
                .collect(),
            None => (0..edges.len()).collect(),
        }
    };
    if let Some((i, j)) = geom::first_proper_crossing(&edges, &near) {
        let (ev, fv) = (edges[i].0, edges[j].0);
        return Some(format!(
            "edges {}-{} and {}-{} cross",
            cx.vname(ev[0]),
            cx.vname(ev[1]),
            cx.vname(fv[0]),
            cx.vname(fv[1])
        ));
    }
    for &(v, p) in &verts {
        for k in near(p - DVec2::splat(eps), p + DVec2::splat(eps)) {
            let (ev, _, _) = edges[k];
            if ev.contains(&v) {
                continue;
            }
            // In space, as the weld and the T-vertex test measure (the
            // plane's frame can bring a pair kept apart a hair closer).
            let pos = |v: VertexId| cx.m.pos(v);
            let d = point_segment_distance(pos(v), pos(ev[0]), pos(ev[1])).0;
            if d <= eps {
                return Some(format!(
                    "narrower than epsilon: vertex {} lies {} from edge {}-{}",
                    cx.vname(v),
                    num(d),
                    cx.vname(ev[0]),
                    cx.vname(ev[1])
                ));
            }
        }
    }
    None
}

/// T-vertices among the non-degenerate faces (`geoms[k]` is `None` for a
/// degenerate face: its own collinear vertices are not T-vertices).
fn t_vertices(cx: &Ctx<'_>, mesh: &winged::Mesh, geoms: &[Option<FaceGeom>]) -> Vec<TVertex> {
    let m = cx.m;
    let eps = cx.eps;
    let sound = |f: FaceId| geoms[cx.order[f.idx()]].is_some();
    let mut used: Vec<VertexId> = cx
        .faces
        .iter()
        .filter(|&&f| sound(f))
        .flat_map(|&f| m.faces[f.idx()].contours.iter().flatten().copied())
        .collect();
    used.sort_unstable();
    used.dedup();
    let index = BoxIndex::new(used.iter().map(|&v| {
        let p = m.pos(v);
        (p - DVec3::splat(eps), p + DVec3::splat(eps), v.0)
    }));
    let edges: Vec<winged::EdgeId> = mesh
        .edges()
        .filter(|&e| mesh.edge(e).uses.iter().any(|u| sound(u.face)))
        .collect();
    let found: Vec<Vec<TVertex>> = edges
        .par_iter()
        .map(|&e| {
            let ed = mesh.edge(e);
            let (a, b) = (m.pos(ed.v[0]), m.pos(ed.v[1]));
            let (lo, hi) = (a.min(b) - DVec3::splat(eps), a.max(b) + DVec3::splat(eps));
            let mut out = Vec::new();
            for id in index.query(lo, hi) {
                let v = VertexId(id);
                if v == ed.v[0] || v == ed.v[1] {
                    continue;
                }
                if geom::on_edge_interior(m.pos(v), a, b, eps).is_some() {
                    let mut faces: Vec<String> = ed
                        .uses
                        .iter()
                        .map(|u| cx.label(u.face).to_string())
                        .collect();
                    faces.dedup();
                    out.push(TVertex {
                        vertex: cx.vname(v),
                        edge: [cx.vname(ed.v[0]), cx.vname(ed.v[1])],
                        faces,
                    });
                }
            }
            out
        })
        .collect();
    found.into_iter().flatten().collect()
}

type PairLists = (Vec<Pair>, Vec<Overlap>, Vec<Pair>);

/// The top-level faces of a model and their geometry for the pair tests
/// (`None` for a face without area).
pub fn face_geoms(m: &Model) -> (Vec<FaceId>, Vec<Option<FaceGeom>>) {
    let faces: Vec<FaceId> = m.top_faces().collect();
    let geoms = faces.iter().map(|&f| face_geom(m, f, None)).collect();
    (faces, geoms)
}

/// Face `f`'s geometry for the pair tests, with vertex `moved.0` (where
/// given) at `moved.1`: how the tools that move a vertex judge the move
/// ([`meeting`] before and after). `None` for a face without area.
pub fn face_geom(m: &Model, f: FaceId, moved: Option<(VertexId, DVec3)>) -> Option<FaceGeom> {
    FaceGeom::new(
        m.faces[f.idx()]
            .contours
            .iter()
            .map(|c| {
                c.iter()
                    .map(|&u| match moved {
                        Some((v, p)) if u == v => p,
                        _ => m.pos(u),
                    })
                    .collect()
            })
            .collect(),
    )
}

/// How two faces of a pair meet (see [`classify_pairs`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairKind {
    /// A common point lies inside one of them.
    Intersect,
    /// Coplanar and partly overlapping, with this common area.
    Overlap(f64),
    /// Coplanar, covering the same region, facing the same way.
    Coincident,
    /// Coplanar, covering the same region, facing opposite ways (a
    /// zero-thickness wall's two sides): not a defect.
    BackToBack,
}

/// Every pair (i < j) of faces that intersect or overlap, found with an
/// R*-tree broad phase over the faces' boxes; `geoms[k]` is `None` for a
/// degenerate face, which takes part in no pair. In order of (i, j), the same
/// at any thread count.
pub fn classify_pairs(geoms: &[Option<FaceGeom>], eps: f64) -> Vec<(usize, usize, PairKind)> {
    classify(
        geoms,
        eps,
        Want::All,
        None,
        geom::intersect::COPLANAR_EPSILONS,
    )
}

/// The coplanar pairs only (overlapping, coincident, back to back: what
/// `ugcopl` and `ugclean` act on), faces up to `epsilons` × `eps` apart
/// taken as coplanar (the tools that resolve them look further than the
/// check: [`geom::intersect::CLEAN_COPLANAR_EPSILONS`]); other pairs are
/// not looked at.
pub fn coplanar_pairs(
    geoms: &[Option<FaceGeom>],
    eps: f64,
    epsilons: f64,
) -> Vec<(usize, usize, PairKind)> {
    classify(geoms, eps, Want::Coplanar, None, epsilons)
}

/// [`coplanar_pairs`], and with `among` (per face) only the pairs with at
/// least one face marked: the neighbourhood of a few faces in a large
/// model. The same pairs, in the same order, as [`coplanar_pairs`] filtered.
pub fn coplanar_pairs_with(
    geoms: &[Option<FaceGeom>],
    eps: f64,
    among: Option<&[bool]>,
    epsilons: f64,
) -> Vec<(usize, usize, PairKind)> {
    classify(geoms, eps, Want::Coplanar, among, epsilons)
}

/// How two faces meet, as the check judges: 2 where they cross, 1 where
/// they are coplanar and `shared` (if given) takes the kind of what they
/// share ([`coplanar_kind`]), 0 otherwise. The cleaning tools' and the
/// mesher's checks of a move compare it before and after.
pub fn meeting(a: &FaceGeom, b: &FaceGeom, eps: f64, shared: Option<fn(PairKind) -> bool>) -> u8 {
    match relate(a, b, eps) {
        Relation::Intersect => 2,
        Relation::Coplanar => {
            u8::from(shared.is_some_and(|counts| coplanar_kind(a, b, eps).is_some_and(counts)))
        }
        Relation::Disjoint | Relation::Touch => 0,
    }
}

/// How two faces already found coplanar share their plane: `Coincident`
/// (the same region, facing the same way), `BackToBack` (the same region,
/// facing opposite ways), `Overlap` (a common area over epsilon² that is
/// not all of both), or `None` (nothing in common but slivers narrower
/// than `eps`). What [`classify_pairs`] reports for a coplanar pair; the
/// tools that move vertices use it to see whether a move makes a pair
/// overlap.
pub fn coplanar_kind(ga: &FaceGeom, gb: &FaceGeom, eps: f64) -> Option<PairKind> {
    // Both are measured in the plane of the one with the larger area, so
    // that the answer does not depend on which is named first: a sliver's
    // plane is ill-defined (a slab's end piece 1.2 epsilon wide, its
    // normal 18° off the facade it lies on, overlapped the facade by 1,800
    // epsilon² in the facade's plane and not at all in its own; property
    // seed 71131 with curved things and stairs, once the pieces were
    // written in the other order).
    let area = |g: &FaceGeom| -> f64 {
        g.contours_2d
            .iter()
            .map(|c| geom::signed_area_2d(c))
            .sum::<f64>()
            .abs()
    };
    let (ga, gb) = if area(gb) > area(ga) {
        (gb, ga)
    } else {
        (ga, gb)
    };
    // Only contours reaching the common box matter (one outside it cannot
    // surround any of it): a storey's floor with hundreds of holes against
    // a rug is the rug's neighbourhood.
    let ((alo, ahi), (blo, bhi)) = (ga.bounds(), gb.bounds());
    let pad = DVec3::splat(4.0 * eps);
    let (wlo, whi) = (alo.max(blo) - pad, ahi.min(bhi) + pad);
    let near = |b: &(DVec3, DVec3)| b.0.cmple(whi).all() && b.1.cmpge(wlo).all();
    // The contours of `g` that reach the common box, in `ga`'s frame.
    let reaching = |g: &FaceGeom| -> Vec<Vec<DVec2>> {
        g.contours
            .iter()
            .zip(&g.contour_boxes)
            .filter(|(_, b)| near(b))
            .map(|(c, _)| c.iter().map(|&p| ga.frame.to_2d(p)).collect())
            .collect()
    };
    let (a2, b2) = (reaching(ga), reaching(gb));
    let dropped = a2.len() < ga.contours.len() || b2.len() < gb.contours.len();
    // Snap rounding at epsilon drops every sliver narrower than epsilon:
    // what is left is a real overlap, however small.
    let (cov, clipped) = coverage_near(&a2, &b2, eps);
    let clipped = clipped || dropped;
    let ov = cov.common;
    let tol = eps * eps;
    if ov > tol {
        let same_region = !clipped && cov.only_a <= tol && cov.only_b <= tol;
        let same_side = ga.plane.n.dot(gb.plane.n) > 0.0;
        Some(match (same_region, same_side) {
            (true, true) => PairKind::Coincident,
            (true, false) => PairKind::BackToBack,
            (false, _) => PairKind::Overlap(ov),
        })
    } else {
        None
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Want {
    All,
    Intersecting,
    Coplanar,
}

/// The intersecting pairs only (what `ugisect` cuts): coplanar pairs are
/// not measured.
pub fn intersecting_pairs(geoms: &[Option<FaceGeom>], eps: f64) -> Vec<(usize, usize)> {
    intersecting_pairs_with(geoms, eps, None)
}

/// [`intersecting_pairs`], and with `among` (per face) only the pairs with
/// at least one face marked. The same pairs, in the same order, as
/// [`intersecting_pairs`] filtered.
pub fn intersecting_pairs_with(
    geoms: &[Option<FaceGeom>],
    eps: f64,
    among: Option<&[bool]>,
) -> Vec<(usize, usize)> {
    classify(
        geoms,
        eps,
        Want::Intersecting,
        among,
        geom::intersect::COPLANAR_EPSILONS,
    )
    .into_iter()
    .filter(|p| p.2 == PairKind::Intersect)
    .map(|(i, j, _)| (i, j))
    .collect()
}

/// The pairs `want`s, coplanar meaning within `epsilons` × `eps`.
fn classify(
    geoms: &[Option<FaceGeom>],
    eps: f64,
    want: Want,
    among: Option<&[bool]>,
    epsilons: f64,
) -> Vec<(usize, usize, PairKind)> {
    // Boxes grown by half the coplanar distance meet for every pair within it.
    let pad = eps.max(0.5 * epsilons * eps);
    let marked = |k: u32| among.is_none_or(|a| a.get(k as usize).copied().unwrap_or(false));
    let boxes: Vec<(DVec3, DVec3, u32)> = geoms
        .iter()
        .enumerate()
        .filter_map(|(k, g)| {
            g.as_ref().map(|g| {
                let (lo, hi) = geom::index::bbox(g.contours.iter().flatten().copied(), pad);
                (lo, hi, k as u32)
            })
        })
        .collect();
    let index = BoxIndex::new(boxes.iter().copied());
    // With `among`, each pair is found from a marked face (the lower one
    // when both are marked).
    let from: Vec<(DVec3, DVec3, u32)> = boxes.iter().copied().filter(|b| marked(b.2)).collect();
    let per: Vec<Vec<(usize, usize, PairKind)>> = from
        .par_iter()
        .map(|&(lo, hi, me)| {
            let mut out = Vec::new();
            for other in index.query(lo, hi) {
                let (i, j) = if other > me {
                    (me, other)
                } else if other < me && !marked(other) {
                    (other, me)
                } else {
                    continue;
                };
                let ga = geoms[i as usize]
                    .as_ref()
                    .expect("indexed faces have geometry");
                let gb = geoms[j as usize]
                    .as_ref()
                    .expect("indexed faces have geometry");
                let rel = if want == Want::Coplanar {
                    if geom::intersect::coplanar_within(ga, gb, epsilons * eps) {
                        Relation::Coplanar
                    } else {
                        Relation::Disjoint
                    }
                } else {
                    relate(ga, gb, eps)
                };
                let kind = match rel {
                    Relation::Intersect => Some(PairKind::Intersect),
                    Relation::Coplanar if want == Want::Intersecting => None,
                    Relation::Coplanar => coplanar_kind(ga, gb, eps),
                    Relation::Disjoint | Relation::Touch => None,
                };
                if let Some(k) = kind {
                    out.push((i as usize, j as usize, k));
                }
            }
            out
        })
        .collect();
    let mut all: Vec<(usize, usize, PairKind)> = per.into_iter().flatten().collect();
    if among.is_some() {
        all.sort_by_key(|p| (p.0, p.1));
    }
    all
}

fn pairs(cx: &Ctx<'_>, geoms: &[Option<FaceGeom>]) -> PairLists {
    let mut out: PairLists = Default::default();
    for (i, j, kind) in classify_pairs(geoms, cx.eps) {
        let (a, b) = (cx.labels[i].clone(), cx.labels[j].clone());
        match kind {
            PairKind::Intersect => out.0.push(Pair { a, b }),
            PairKind::Overlap(area) => out.1.push(Overlap { a, b, area }),
            PairKind::Coincident => out.2.push(Pair { a, b }),
            PairKind::BackToBack => {}
        }
    }
    out
}

/// The area of a face: for a planar face its polygon area (holes subtract,
/// islands add); for a non-planar one the area of the triangles `ugplanar`
/// would replace it with, so that tessellation keeps area per material exactly.
pub fn surface_area(pts: &[Vec<DVec3>], nonplanar: bool) -> f64 {
    if nonplanar && let Some(t) = geom::triangulate::fold_triangles(pts) {
        let flat: Vec<DVec3> = pts.iter().flatten().copied().collect();
        return geom::triangulate::triangles_area(&flat, &t);
    }
    geom::face_area(pts).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A slab's end piece 1.2 epsilon wide lying on a facade face, the two
    /// sharing three records (property seed 71131 after ugclean, before
    /// the fix): they overlap, whichever is named first.
    #[test]
    fn a_coplanar_pair_is_judged_the_same_in_either_order() {
        let eps = 1.4516520713073137e-5;
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let iv382 = p(8.440535156989538, 5.426429645946041, 2.8119230403363593);
        let iv409 = p(8.440534967234381, 5.426387073243252, 2.799999915256978);
        let cv7 = p(8.440513991096031, 5.426405345428492, 2.8119232482884997);
        let v1 = p(8.440535078822357, 5.426426204448327, 2.7999998344779895);
        let v5 = p(8.440534970487347, 5.4263870722987875, 2.8119232533537843);
        let facade = FaceGeom::new(vec![vec![iv382, v5, iv409, v1]]).unwrap();
        let piece = FaceGeom::new(vec![vec![v1, iv382, cv7, iv409]]).unwrap();
        let kind = |a: &FaceGeom, b: &FaceGeom| match geom::intersect::relate(a, b, eps) {
            Relation::Coplanar => coplanar_kind(a, b, eps),
            _ => None,
        };
        let (ab, ba) = (kind(&facade, &piece), kind(&piece, &facade));
        assert!(matches!(ab, Some(PairKind::Overlap(_))), "{ab:?}");
        assert_eq!(ab, ba);
    }
}
