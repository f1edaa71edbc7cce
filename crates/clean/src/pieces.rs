//! Rebuilding a model in which some faces are replaced by pieces computed in
//! 2-D (shared by `ugcopl` and `ugisect`): piece corners are moved back onto
//! the exact intersection of the features they lie on, snapped to existing
//! vertices within epsilon (or to corners other pieces created), and written
//! just before the first piece that uses them.

use geom::overlap::refine_point;
use geom::{DVec2, DVec3, Frame};
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Face, FaceId, Item, Model, Vertex, VertexId};

pub use check::face_geoms;

/// Total length of a face's contours in 2-D.
pub fn perimeter(contours: &[Vec<DVec2>]) -> f64 {
    contours
        .iter()
        .map(|c| {
            (0..c.len())
                .map(|i| (c[(i + 1) % c.len()] - c[i]).length())
                .sum::<f64>()
        })
        .sum()
}

/// The contour segments of polygons, for [`refine_point`].
pub fn segments<'a>(polys: impl IntoIterator<Item = &'a Vec<DVec2>>) -> Vec<(DVec2, DVec2)> {
    polys
        .into_iter()
        .flat_map(|c| (0..c.len()).map(move |i| (c[i], c[(i + 1) % c.len()])))
        .collect()
}

/// The output model under construction.
pub struct Rebuild {
    pub out: Model,
    eps: f64,
    cell: f64,
    grid: FxHashMap<(i64, i64, i64), Vec<VertexId>>,
    fnames: FxHashSet<String>,
    vnames: FxHashSet<String>,
    emitted: usize,
    /// Vertices created so far.
    pub new_vertices: usize,
}

impl Rebuild {
    /// Starts from `m`'s arenas with no statements.
    pub fn new(m: &Model, eps: f64) -> Rebuild {
        let mut out = m.clone();
        out.items.clear();
        out.faces.clear();
        let mut r = Rebuild {
            out,
            eps,
            cell: (2.0 * eps).max(f64::MIN_POSITIVE),
            grid: FxHashMap::default(),
            fnames: m.faces.iter().filter_map(|f| f.name.clone()).collect(),
            vnames: m.vertices.iter().map(|v| v.name.clone()).collect(),
            emitted: m.vertices.len(),
            new_vertices: 0,
        };
        for (k, v) in m.vertices.iter().enumerate() {
            let key = r.key(v.pos);
            r.grid.entry(key).or_default().push(VertexId(k as u32));
        }
        r
    }

    fn key(&self, p: DVec3) -> (i64, i64, i64) {
        let k = (p / self.cell).floor();
        (k.x as i64, k.y as i64, k.z as i64)
    }

    /// The nearest vertex within epsilon (lowest id on ties).
    fn find(&self, p: DVec3) -> Option<VertexId> {
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
                        let d = (self.out.vertices[v.idx()].pos - p).length();
                        if d <= self.eps && best.is_none_or(|(b, w)| d < b || (d == b && v < w)) {
                            best = Some((d, v));
                        }
                    }
                }
            }
        }
        best.map(|b| b.1)
    }

    /// Passes a statement through.
    pub fn pass(&mut self, it: &Item) {
        self.out.items.push(it.clone());
    }

    /// Writes a face.
    pub fn face(&mut self, face: Face) {
        let id = FaceId(self.out.faces.len() as u32);
        self.out.faces.push(face);
        self.out.items.push(Item::Face(id));
    }

    /// Writes the pieces of `face` (2-D polygons in `frame`) as faces named
    /// `BASE.TAGk`, each preceded by `annotation` when given. Points are moved
    /// onto the exact intersection of the nearest `features` (within `tol`).
    /// Returns how many pieces were written.
    #[allow(clippy::too_many_arguments)]
    pub fn pieces(
        &mut self,
        face: &Face,
        base: &str,
        tag: &str,
        pieces: Vec<Vec<Vec<DVec2>>>,
        frame: &Frame,
        features: &[(DVec2, DVec2)],
        tol: f64,
        annotation: Option<&str>,
    ) -> usize {
        let mut nv = 0usize;
        let mut piece_no = 0usize;
        let mut written = 0;
        for piece in pieces {
            let mut contours: Vec<Vec<VertexId>> = Vec::new();
            for ring in piece {
                let mut c: Vec<VertexId> = Vec::with_capacity(ring.len());
                for p2 in ring {
                    let p = frame.to_3d(refine_point(p2, features, tol));
                    let v = match self.find(p) {
                        Some(v) => v,
                        None => {
                            let name = loop {
                                nv += 1;
                                let cand = format!("{base}.{tag}v{nv}");
                                if self.vnames.insert(cand.clone()) {
                                    break cand;
                                }
                            };
                            let id = VertexId(self.out.vertices.len() as u32);
                            self.out.vertices.push(Vertex {
                                name,
                                pos: p,
                                color: None,
                            });
                            let key = self.key(p);
                            self.grid.entry(key).or_default().push(id);
                            self.new_vertices += 1;
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
            for v in self.emitted..self.out.vertices.len() {
                self.out.items.push(Item::Vertex(VertexId(v as u32)));
            }
            self.emitted = self.out.vertices.len();
            let name = face.name.as_ref().map(|_| {
                loop {
                    piece_no += 1;
                    let cand = format!("{base}.{tag}{piece_no}");
                    if self.fnames.insert(cand.clone()) {
                        break cand;
                    }
                }
            });
            if let Some(a) = annotation {
                self.out.items.push(Item::Comment(a.to_string()));
            }
            self.face(Face {
                name,
                contours,
                material: face.material,
            });
            written += 1;
        }
        written
    }
}
