//! Coplanar face intersection (Smith 1991, §2.5).
//!
//! Faces that are coplanar (within epsilon, either orientation) and partly
//! overlap are cut in their plane so that every overlap region becomes a
//! face of its own in each face it belongs to: a face overlapped by faces
//! G₁…Gₖ is split by each in turn into its parts inside and outside
//! (polygon booleans of the `geo` crate, holes and islands respected), so the
//! pieces lying in the same set of faces are the same region in every face,
//! and `ugclean` can then drop one of each coincident pair.
//!
//! Piece corners within epsilon of an existing vertex reuse it; new corners
//! are shared between all faces that need them. Each piece keeps its face's
//! material and orientation, is named `NAME.c1`, `NAME.c2`, …, and is
//! preceded by the origin annotation `{ugcopl origin NAME area A}` (A is the
//! area of the original face's connected coplanar surface of its material),
//! which `ugclean` reads to remove the piece of the larger surface. Finally
//! the points where the cuts meet neighbouring faces' edges are inserted into
//! those edges (the grouper's T-vertex step), so no T-vertex is left.

use geom::intersect::FaceGeom;
use geom::overlap::split_by;
use geom::{DVec2, DVec3};
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Face, FaceId, Item, Model, Vertex, VertexId};
use ugcheck::PairKind;

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub pairs: usize,
    pub faces_cut: usize,
    pub pieces: usize,
    pub new_vertices: usize,
    pub tvertices: usize,
}

/// Vertices found by position (within eps) or created.
struct Points {
    eps: f64,
    cell: f64,
    grid: FxHashMap<(i64, i64, i64), Vec<VertexId>>,
}

impl Points {
    fn key(&self, p: DVec3) -> (i64, i64, i64) {
        let k = (p / self.cell).floor();
        (k.x as i64, k.y as i64, k.z as i64)
    }
    fn add(&mut self, p: DVec3, v: VertexId) {
        let k = self.key(p);
        self.grid.entry(k).or_default().push(v);
    }
    fn find(&self, vertices: &[Vertex], p: DVec3) -> Option<VertexId> {
        let (x, y, z) = self.key(p);
        let mut best: Option<(f64, VertexId)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &v in self
                        .grid
                        .get(&(x + dx, y + dy, z + dz))
                        .into_iter()
                        .flatten()
                    {
                        let d = (vertices[v.idx()].pos - p).length();
                        if d <= self.eps && best.is_none_or(|(b, w)| d < b || (d == b && v < w)) {
                            best = Some((d, v));
                        }
                    }
                }
            }
        }
        best.map(|b| b.1)
    }
}

/// Cuts the coplanar overlapping faces of a flat model.
pub fn copl(m: &Model, eps: f64) -> Result<(Model, Stats), ug::Diagnostic> {
    let faces: Vec<FaceId> = m.top_faces().collect();
    let points3 = |f: FaceId| -> Vec<Vec<DVec3>> {
        m.faces[f.idx()]
            .contours
            .iter()
            .map(|c| c.iter().map(|&v| m.pos(v)).collect())
            .collect()
    };
    let geoms: Vec<Option<FaceGeom>> = faces.iter().map(|&f| FaceGeom::new(points3(f))).collect();
    let pairs: Vec<(usize, usize)> = ugcheck::classify_pairs(&geoms, eps)
        .into_iter()
        .filter(|p| matches!(p.2, PairKind::Overlap(_)))
        .map(|(i, j, _)| (i, j))
        .collect();
    let mut stats = Stats {
        pairs: pairs.len(),
        ..Stats::default()
    };
    if pairs.is_empty() {
        return Ok((m.clone(), stats));
    }
    let mut others: Vec<Vec<usize>> = vec![Vec::new(); faces.len()];
    for &(i, j) in &pairs {
        others[i].push(j);
        others[j].push(i);
    }
    let mesh = winged::Mesh::from_model(m.clone());
    let mut out = m.clone();
    out.items.clear();
    out.faces.clear();
    let mut pts = Points {
        eps,
        cell: (2.0 * eps).max(f64::MIN_POSITIVE),
        grid: FxHashMap::default(),
    };
    for (k, v) in m.vertices.iter().enumerate() {
        pts.add(v.pos, VertexId(k as u32));
    }
    let mut names: FxHashSet<String> = m.faces.iter().filter_map(|f| f.name.clone()).collect();
    let mut vnames: FxHashSet<String> = m.vertices.iter().map(|v| v.name.clone()).collect();
    let mut emitted = m.vertices.len();
    let mut order = vec![usize::MAX; m.faces.len()];
    for (k, &f) in faces.iter().enumerate() {
        order[f.idx()] = k;
    }
    for it in &m.items {
        let Item::Face(f) = it else {
            out.items.push(it.clone());
            continue;
        };
        let k = order[f.idx()];
        let face = &m.faces[f.idx()];
        let push = |out: &mut Model, face: Face| {
            let id = FaceId(out.faces.len() as u32);
            out.faces.push(face);
            out.items.push(Item::Face(id));
        };
        let (Some(g), false) = (geoms[k].as_ref(), others[k].is_empty()) else {
            push(&mut out, face.clone());
            continue;
        };
        let cutters: Vec<Vec<Vec<DVec2>>> = others[k]
            .iter()
            .filter_map(|&j| geoms[j].as_ref())
            .map(|o| {
                o.contours
                    .iter()
                    .map(|c| c.iter().map(|&p| g.frame.to_2d(p)).collect())
                    .collect()
            })
            .collect();
        let perim: f64 = g
            .contours_2d
            .iter()
            .map(|c| {
                (0..c.len())
                    .map(|i| (c[(i + 1) % c.len()] - c[i]).length())
                    .sum::<f64>()
            })
            .sum();
        let pieces = split_by(&g.contours_2d, &cutters, eps * perim);
        // Exact f64 positions for the points the booleans rounded: on the
        // face's edges and the other faces' edges.
        let features: Vec<(DVec2, DVec2)> = g
            .contours_2d
            .iter()
            .chain(cutters.iter().flatten())
            .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
            .collect();
        let (blo, bhi) =
            geom::index::bbox(g.contours_2d.iter().flatten().map(|p| p.extend(0.0)), 0.0);
        let tol = 1e-7 * (bhi - blo).length().max(eps);
        if pieces.len() <= 1 {
            push(&mut out, face.clone());
            continue;
        }
        stats.faces_cut += 1;
        let base = face.name.clone().unwrap_or_else(|| format!("f{}", k + 1));
        let origin_area = ugclean::surface_area(&mesh, *f, eps);
        let mut nv = 0usize;
        let mut piece_no = 0usize;
        for piece in pieces {
            let mut contours: Vec<Vec<VertexId>> = Vec::new();
            for ring in piece {
                let mut c: Vec<VertexId> = Vec::with_capacity(ring.len());
                for p2 in ring {
                    let p = g
                        .frame
                        .to_3d(geom::overlap::refine_point(p2, &features, tol));
                    let v = match pts.find(&out.vertices, p) {
                        Some(v) => v,
                        None => {
                            nv += 1;
                            let mut name = format!("{base}.x{nv}");
                            while vnames.contains(&name) {
                                nv += 1;
                                name = format!("{base}.x{nv}");
                            }
                            vnames.insert(name.clone());
                            let id = VertexId(out.vertices.len() as u32);
                            out.vertices.push(Vertex {
                                name,
                                pos: p,
                                color: None,
                            });
                            pts.add(p, id);
                            stats.new_vertices += 1;
                            id
                        }
                    };
                    if c.last() != Some(&v) {
                        c.push(v);
                    }
                }
                while c.len() > 1 && c.first() == c.last() {
                    c.pop();
                }
                if c.len() >= 3 {
                    contours.push(c);
                }
            }
            if contours.is_empty() {
                continue;
            }
            for v in emitted..out.vertices.len() {
                out.items.push(Item::Vertex(VertexId(v as u32)));
            }
            emitted = out.vertices.len();
            let name = face.name.as_ref().map(|_| {
                loop {
                    piece_no += 1;
                    let cand = format!("{base}.c{piece_no}");
                    if names.insert(cand.clone()) {
                        break cand;
                    }
                }
            });
            out.items.push(Item::Comment(format!(
                "ugcopl origin {base} area {origin_area}"
            )));
            push(
                &mut out,
                Face {
                    name,
                    contours,
                    material: face.material,
                },
            );
            stats.pieces += 1;
        }
    }
    // Where the cuts meet neighbouring edges: insert the points (no T-vertex).
    let opts = ugvlmerge::Options {
        merge_faces: false,
        ..ugvlmerge::Options::new(eps)
    };
    let (out, vst) = ugvlmerge::vlmerge(out, &opts)?;
    stats.tvertices = vst.tvertices;
    Ok((out, stats))
}
