//! A deterministic, seeded generator of CAD-like building models, for tests,
//! benchmarks and the `ugbuilding` tool.
//!
//! # The building
//!
//! A grid of `rooms_x` × `rooms_y` rooms, each [`ROOM_W`] × [`ROOM_D`] ×
//! [`ROOM_H`] (4 × 5 × 3, metres; x, y across, z up), drawn the way a CAD
//! model often is — in pieces:
//!
//! * each **floor** is 2 × 2 coplanar quads facing up (`floor`), on a grid
//!   of vertices at half-room spacing, so every floor has a vertex in the
//!   middle of each side and one in its centre;
//! * each **wall segment** (one room side) is a single face shared by the two
//!   rooms it separates (material `wall`): a lower face from the floor to
//!   mid height and an upper quad above it. Inner walls face +x or +y; the
//!   outer walls face into the building. The lower face is a pentagon that
//!   includes the floor's mid-side vertex on its foot, so the clean model has
//!   no T-vertex;
//! * each **ceiling** is one quad facing down (`ceiling`) on the walls' top
//!   corners.
//!
//! A clean building ([`Dirt::default`]) has `9·X·Y + 2·(X + Y)` faces for
//! X × Y rooms ([`face_count`]), and `ugcheck` finds no defect in it: every
//! face is planar, no vertex lies inside another face's edge, neighbours are
//! consistently oriented where an edge has exactly two faces (each room is an
//! inward-facing box). Inner floor and ceiling edges are non-manifold (two
//! rooms and a wall meet there), and the lower wall faces are pentagons with
//! a straight angle: topology facts, not defects.
//!
//! # Dirt
//!
//! [`generate`] adds what real models have, as a [`Dirt`] asks, at random
//! places drawn from the seed:
//!
//! | field | what is added | what `ugcheck` finds |
//! |---|---|---|
//! | `tvertices` | wall segments whose lower face is a quad skipping the floor's mid-side vertex | one T-vertex per such segment |
//! | `coincident` | wall segments whose upper quad uses its own copies of the mid-height corners (`offset` off in y), and ceilings with their own corner copies (0, 1 or 2 × `offset` off in x) | the copies are within epsilon (`ugvlmerge` merges them): more boundary edges, and some inconsistently oriented edges (below) |
//! | `nonplanar` | floor pieces whose corner at the room's centre is moved `lift` down and `lift` towards the piece's centre (a private copy) | exactly one non-planar face per lifted quad (judging it on its best-fit plane, `ugcheck` may also find it crossing a wall standing on it); after `ugplanar`, no defect |
//! | `flipped` | faces written reversed | inconsistently oriented edges between flipped and unflipped neighbours |
//! | `lights` | per room, an emitting quad (`light`, a `defmat` with `emission_rgb`) 1 × 1 hanging 1 cm below the ceiling's centre, facing down | one emitter per room |
//! | `furniture` | per room, that many closed boxes (outward, `furniture`), each standing on the floor inside one quarter of the room | per box: its four sides intersect the floor and its bottom overlaps it (back to back) — furniture standing on an uncut floor |
//!
//! Inner walls are single faces, seen by the two rooms from opposite sides:
//! on an edge where such a wall meets the floor or ceiling of the room it
//! turns its back to, or an outer wall of that room, the orientations
//! disagree. In the clean building those edges are non-manifold (a third
//! face shares them); nearly coincident copies can leave just the two, and
//! `ugcheck` then reports the edge as inconsistently oriented.
//!
//! Each kind of dirt draws from its own random stream, so changing one
//! fraction leaves the places of the others unchanged; the same arguments
//! always give the same model. Fractions are exact: `round(fraction × n)`
//! items are chosen without repetition.
//!
//! Faces are unnamed; vertices are named after their place (`g4_6` floor
//! grid, `m4_6` / `m4_6b` mid height, `t4_6` top, `c1_2_0` ceiling copies,
//! `np7` lifted corners, `L1_2_0` lights, `F1_2_3_0` furniture).
//!
//! [`building`] is the model of the `ugvlmerge` benchmark: every wall segment
//! with a T-vertex and nearly coincident vertices, every ceiling with its own
//! corners.

pub mod cad;

pub use cad::{Cad, cad};

use glam::DVec3;
use ug::{Defmat, Face, Item, Material, MaterialDef, MaterialId, Model, Vertex, VertexId};

/// Room width (x).
pub const ROOM_W: f64 = 4.0;
/// Room depth (y).
pub const ROOM_D: f64 = 5.0;
/// Room height (z).
pub const ROOM_H: f64 = 3.0;
/// How far a ceiling light hangs below the ceiling.
pub const LIGHT_DROP: f64 = 0.01;
/// Side of a ceiling light.
pub const LIGHT_SIZE: f64 = 1.0;
/// Emitted exitance of a ceiling light (per channel).
pub const LIGHT_EMISSION: f64 = 10.0;

/// The defects and extras [`generate`] adds to the clean building.
///
/// Fractions are clamped to [0, 1]; `furniture` to at most 4 boxes a room.
#[derive(Clone, Debug, PartialEq)]
pub struct Dirt {
    /// Fraction of all faces written reversed (back side to the room).
    pub flipped: f64,
    /// Fraction of all faces made non-planar: that many floor pieces (at
    /// most all of them, 4 a room) get their corner at the room's centre
    /// replaced by a private copy moved `lift` down and `lift` towards the
    /// piece's centre — below the floor, so nothing in the room touches it,
    /// and off every edge.
    pub nonplanar: f64,
    /// How far a non-planar quad's corner is moved (model units); a quad's
    /// deviation from its best-fit plane is then about `lift / 4`.
    pub lift: f64,
    /// Fraction of wall segments whose upper quad uses its own copies of the
    /// mid-height corners, and (drawn separately) of ceilings with their own
    /// corner vertices: nearly coincident vertices.
    pub coincident: f64,
    /// Distance of the nearly coincident copies from the originals.
    pub offset: f64,
    /// Fraction of wall segments whose lower face skips the floor's mid-side
    /// vertex: one T-vertex each.
    pub tvertices: f64,
    /// A light in every room: a 1 × 1 emitting quad 1 cm below the ceiling.
    pub lights: bool,
    /// Boxes of furniture per room (0 to 4), standing on the floor.
    pub furniture: usize,
}

impl Default for Dirt {
    /// A clean building: no dirt, no lights, no furniture.
    fn default() -> Self {
        Dirt {
            flipped: 0.0,
            nonplanar: 0.0,
            lift: 0.01,
            coincident: 0.0,
            offset: 1e-10,
            tvertices: 0.0,
            lights: false,
            furniture: 0,
        }
    }
}

impl Dirt {
    /// What the grouper (`ugvlmerge`) removes: every wall segment with a
    /// T-vertex and nearly coincident vertices, every ceiling with its own corners.
    pub fn grouper() -> Self {
        Dirt {
            coincident: 1.0,
            tvertices: 1.0,
            ..Dirt::default()
        }
    }

    /// Everything at once, lit and furnished: 30% flipped faces, 10%
    /// non-planar, half the walls with T-vertices and nearly coincident
    /// vertices, a light and two boxes per room.
    pub fn messy() -> Self {
        Dirt {
            flipped: 0.3,
            nonplanar: 0.1,
            coincident: 0.5,
            tvertices: 0.5,
            lights: true,
            furniture: 2,
            ..Dirt::default()
        }
    }

    fn boxes(&self) -> usize {
        self.furniture.min(4)
    }
}

/// Number of faces [`generate`] makes for these rooms and dirt.
pub fn face_count(rooms_x: usize, rooms_y: usize, dirt: &Dirt) -> usize {
    let rooms = rooms_x * rooms_y;
    let segments = (rooms_x + 1) * rooms_y + (rooms_y + 1) * rooms_x;
    rooms * (5 + usize::from(dirt.lights) + 6 * dirt.boxes()) + 2 * segments
}

/// A nearly square grid of rooms (`(n, n)` or `(n + 1, n)`) whose face count
/// is the nearest to `faces` (at least one room).
pub fn rooms_for_faces(faces: usize, dirt: &Dirt) -> (usize, usize) {
    let mut best = (1, 1);
    let err = |(x, y): (usize, usize)| face_count(x, y, dirt).abs_diff(faces);
    let mut n = 1;
    loop {
        for cand in [(n, n), (n + 1, n)] {
            if err(cand) < err(best) {
                best = cand;
            }
        }
        if face_count(n, n, dirt) > faces {
            return best;
        }
        n += 1;
    }
}

/// The `ugvlmerge` benchmark's model: `n` × `n` rooms with [`Dirt::grouper`]
/// (9·n² + 4·n faces; 9,933 for n = 33).
pub fn building(n: usize) -> Model {
    generate(n, n, &Dirt::grouper(), 0)
}

/// A small, fast generator (SplitMix64): deterministic on every platform.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// The generator for `seed`, on an independent stream `stream`.
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut r = Rng(seed ^ stream.wrapping_mul(0xD1B5_4A32_D192_ED03));
        r.next_u64();
        r
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        // Lemire's multiply-shift: unbiased enough for n far below 2⁶⁴.
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }

    /// `k` distinct indices of 0..n, as a mask (partial Fisher–Yates).
    pub fn choose(&mut self, n: usize, k: usize) -> Vec<bool> {
        let k = k.min(n);
        let mut idx: Vec<usize> = (0..n).collect();
        let mut mask = vec![false; n];
        for i in 0..k {
            let j = i + self.below(n - i);
            idx.swap(i, j);
            mask[idx[i]] = true;
        }
        mask
    }
}

/// Random streams, one per kind of dirt.
mod stream {
    pub const COINCIDENT_WALLS: u64 = 1;
    pub const COINCIDENT_CEILINGS: u64 = 2;
    pub const TVERTICES: u64 = 3;
    pub const NONPLANAR: u64 = 4;
    pub const FLIPPED: u64 = 5;
    pub const FURNITURE: u64 = 6;
}

fn count(fraction: f64, n: usize) -> usize {
    let f = if fraction.is_nan() {
        0.0
    } else {
        fraction.clamp(0.0, 1.0)
    };
    ((f * n as f64).round() as usize).min(n)
}

struct Builder {
    m: Model,
    /// For each floor piece, its corner at the room's centre (the one
    /// `nonplanar` lifts).
    lift_corner: Vec<Option<usize>>,
}

impl Builder {
    fn vertex(&mut self, name: String, pos: DVec3) -> VertexId {
        self.m.add_vertex(Vertex {
            name,
            pos,
            color: None,
        })
    }

    fn face(&mut self, contour: Vec<VertexId>, material: MaterialId, lift: Option<usize>) {
        self.lift_corner.push(lift);
        self.m.add_face(Face {
            name: None,
            contours: vec![contour],
            material: Some(material),
        });
    }

    fn rgb(&mut self, name: &str, c: [f64; 3]) -> MaterialId {
        self.m.add_material(Material {
            name: name.into(),
            def: MaterialDef::Rgb(c),
        })
    }
}

/// A wall segment from grid corner `a` to `b` (half-grid indices, both even).
struct Segment {
    a: (usize, usize),
    b: (usize, usize),
}

/// Generates `rooms_x` × `rooms_y` rooms with `dirt`, drawn from `seed`.
///
/// The model is flat: materials, the grid's vertices, floors, walls,
/// ceilings, then per room its light and furniture; private vertices are
/// written just before the face that uses them. It has
/// [`face_count`]`(rooms_x, rooms_y, dirt)` faces.
pub fn generate(rooms_x: usize, rooms_y: usize, dirt: &Dirt, seed: u64) -> Model {
    let (nx, ny) = (rooms_x, rooms_y);
    let (w, d, h) = (ROOM_W, ROOM_D, ROOM_H);
    let mut b = Builder {
        m: Model::new(),
        lift_corner: Vec::new(),
    };
    let floor = b.rgb("floor", [0.5, 0.4, 0.3]);
    let wall = b.rgb("wall", [0.8, 0.8, 0.8]);
    let ceiling = b.rgb("ceiling", [0.9, 0.9, 0.9]);
    let light = dirt.lights.then(|| {
        b.m.add_material(Material {
            name: "light".into(),
            def: MaterialDef::Defmat(Defmat {
                diffuse: Some([0.8, 0.8, 0.8]),
                emission: Some([LIGHT_EMISSION; 3]),
                other: Vec::new(),
            }),
        })
    });
    let furniture = (dirt.boxes() > 0).then(|| b.rgb("furniture", [0.6, 0.45, 0.3]));

    // Wall segments: along y at each x grid line, then along x at each y grid
    // line. Inner walls face +x or +y; the outer ones face into the building.
    let mut segments = Vec::new();
    for i in 0..=nx {
        for j in 0..ny {
            let (a, c) = ((2 * i, 2 * j), (2 * i, 2 * j + 2));
            segments.push(if i == nx {
                Segment { a: c, b: a }
            } else {
                Segment { a, b: c }
            });
        }
    }
    for j in 0..=ny {
        for i in 0..nx {
            let (a, c) = ((2 * i + 2, 2 * j), (2 * i, 2 * j));
            segments.push(if j == ny {
                Segment { a: c, b: a }
            } else {
                Segment { a, b: c }
            });
        }
    }
    let ns = segments.len();
    let coincident_wall =
        Rng::new(seed, stream::COINCIDENT_WALLS).choose(ns, count(dirt.coincident, ns));
    let coincident_ceiling = Rng::new(seed, stream::COINCIDENT_CEILINGS)
        .choose(nx * ny, count(dirt.coincident, nx * ny));
    let coarse = Rng::new(seed, stream::TVERTICES).choose(ns, count(dirt.tvertices, ns));

    // Corners whose offset mid-height copy is used.
    let (gx, gy) = (2 * nx + 1, 2 * ny + 1);
    let at = |i: usize, j: usize| i * gy + j;
    let mut needs_b = vec![false; gx * gy];
    for (s, seg) in segments.iter().enumerate() {
        if coincident_wall[s] {
            needs_b[at(seg.a.0, seg.a.1)] = true;
            needs_b[at(seg.b.0, seg.b.1)] = true;
        }
    }

    // The grid: floor vertices at half-room spacing; mid-height and top
    // vertices at the room corners.
    const NONE: VertexId = VertexId(u32::MAX);
    let mut g = vec![NONE; gx * gy];
    let mut mid = vec![NONE; gx * gy];
    let mut mid_b = vec![NONE; gx * gy];
    let mut top = vec![NONE; gx * gy];
    for i in 0..gx {
        for j in 0..gy {
            let (x, y) = (i as f64 * w / 2.0, j as f64 * d / 2.0);
            g[at(i, j)] = b.vertex(format!("g{i}_{j}"), DVec3::new(x, y, 0.0));
            if i % 2 == 0 && j % 2 == 0 {
                mid[at(i, j)] = b.vertex(format!("m{i}_{j}"), DVec3::new(x, y, h / 2.0));
                if needs_b[at(i, j)] {
                    mid_b[at(i, j)] = b.vertex(
                        format!("m{i}_{j}b"),
                        DVec3::new(x, y + dirt.offset, h / 2.0),
                    );
                }
                top[at(i, j)] = b.vertex(format!("t{i}_{j}"), DVec3::new(x, y, h));
            }
        }
    }

    // Floors: 2 × 2 quads per room, facing up.
    for ri in 0..nx {
        for rj in 0..ny {
            for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (i, j) = (2 * ri + di, 2 * rj + dj);
                let q = vec![
                    g[at(i, j)],
                    g[at(i + 1, j)],
                    g[at(i + 1, j + 1)],
                    g[at(i, j + 1)],
                ];
                // The room's centre is at (2ri + 1, 2rj + 1).
                let centre = match (1 - di, 1 - dj) {
                    (0, 0) => 0,
                    (1, 0) => 1,
                    (1, 1) => 2,
                    _ => 3,
                };
                b.face(q, floor, Some(centre));
            }
        }
    }

    // Walls: a lower face (with the floor's mid-side vertex unless coarse)
    // and an upper quad (on the offset copies when coincident).
    for (s, seg) in segments.iter().enumerate() {
        let (ka, kb) = (at(seg.a.0, seg.a.1), at(seg.b.0, seg.b.1));
        let km = at((seg.a.0 + seg.b.0) / 2, (seg.a.1 + seg.b.1) / 2);
        let lower = if coarse[s] {
            vec![g[ka], g[kb], mid[kb], mid[ka]]
        } else {
            vec![g[ka], g[km], g[kb], mid[kb], mid[ka]]
        };
        b.face(lower, wall, None);
        let upper = if coincident_wall[s] {
            vec![mid_b[ka], mid_b[kb], top[kb], top[ka]]
        } else {
            vec![mid[ka], mid[kb], top[kb], top[ka]]
        };
        b.face(upper, wall, None);
    }

    // Ceilings, facing down; some with their own corner vertices.
    for ri in 0..nx {
        for rj in 0..ny {
            let corners = [(0, 0), (0, 1), (1, 1), (1, 0)];
            let q: Vec<VertexId> = if coincident_ceiling[ri * ny + rj] {
                let off = dirt.offset * ((ri + rj) % 3) as f64;
                corners
                    .iter()
                    .enumerate()
                    .map(|(k, &(di, dj))| {
                        let (x, y) = ((ri + di) as f64 * w, (rj + dj) as f64 * d);
                        b.vertex(format!("c{ri}_{rj}_{k}"), DVec3::new(x + off, y, h))
                    })
                    .collect()
            } else {
                corners
                    .iter()
                    .map(|&(di, dj)| top[at(2 * (ri + di), 2 * (rj + dj))])
                    .collect()
            };
            b.face(q, ceiling, None);
        }
    }

    // Lights and furniture, room by room.
    let mut rng = Rng::new(seed, stream::FURNITURE);
    for ri in 0..nx {
        for rj in 0..ny {
            let (x0, y0) = (ri as f64 * w, rj as f64 * d);
            if let Some(mat) = light {
                let (cx, cy) = (x0 + w / 2.0, y0 + d / 2.0);
                let r = LIGHT_SIZE / 2.0;
                let z = h - LIGHT_DROP;
                // Clockwise seen from above: facing down.
                let q: Vec<VertexId> = [(-r, -r), (-r, r), (r, r), (r, -r)]
                    .iter()
                    .enumerate()
                    .map(|(k, &(dx, dy))| {
                        b.vertex(format!("L{ri}_{rj}_{k}"), DVec3::new(cx + dx, cy + dy, z))
                    })
                    .collect();
                b.face(q, mat, None);
            }
            if let Some(mat) = furniture {
                let quarters = rng.choose(4, dirt.boxes());
                for (q, _) in quarters.iter().enumerate().filter(|(_, c)| **c) {
                    let qx0 = x0 + (q % 2) as f64 * w / 2.0;
                    let qy0 = y0 + (q / 2) as f64 * d / 2.0;
                    furniture_box(&mut b, &mut rng, mat, (ri, rj, q), qx0, qy0);
                }
            }
        }
    }

    let Builder { mut m, lift_corner } = b;
    lift_quads(&mut m, &lift_corner, dirt, seed);
    let nf = m.faces.len();
    let flip = Rng::new(seed, stream::FLIPPED).choose(nf, count(dirt.flipped, nf));
    for (f, face) in m.faces.iter_mut().enumerate() {
        if flip[f] {
            face.contours[0].reverse();
        }
    }
    m
}

/// A closed box, faces outward, standing on the floor of the room quarter
/// whose lower corner is (qx0, qy0), keeping 25 cm from the quarter's sides.
fn furniture_box(
    b: &mut Builder,
    rng: &mut Rng,
    mat: MaterialId,
    (ri, rj, q): (usize, usize, usize),
    qx0: f64,
    qy0: f64,
) {
    let margin = 0.25;
    let (qw, qd) = (ROOM_W / 2.0, ROOM_D / 2.0);
    let sx = rng.range(0.4, 1.2);
    let sy = rng.range(0.4, 1.5);
    let sz = rng.range(0.4, 1.2);
    let x = qx0 + margin + rng.unit() * (qw - 2.0 * margin - sx);
    let y = qy0 + margin + rng.unit() * (qd - 2.0 * margin - sy);
    // Corner k: bit 0 → +x, bit 1 → +y, bit 2 → +z.
    let v: Vec<VertexId> = (0..8)
        .map(|k| {
            let p = DVec3::new(
                x + if k & 1 != 0 { sx } else { 0.0 },
                y + if k & 2 != 0 { sy } else { 0.0 },
                if k & 4 != 0 { sz } else { 0.0 },
            );
            b.vertex(format!("F{ri}_{rj}_{q}_{k}"), p)
        })
        .collect();
    // Counter-clockwise seen from outside.
    for f in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        b.face(f.iter().map(|&k| v[k]).collect(), mat, None);
    }
}

/// Makes `round(nonplanar × faces)` floor pieces non-planar: the corner at
/// the room's centre of each is moved `lift` down and `lift` towards the
/// piece's centre — a private copy written just before the face, or the
/// vertex itself when no other face uses it any more.
fn lift_quads(m: &mut Model, lift_corner: &[Option<usize>], dirt: &Dirt, seed: u64) {
    let eligible: Vec<(usize, usize)> = lift_corner
        .iter()
        .enumerate()
        .filter_map(|(f, c)| c.map(|c| (f, c)))
        .collect();
    let k = count(dirt.nonplanar, m.faces.len()).min(eligible.len());
    if k == 0 {
        return;
    }
    let chosen = Rng::new(seed, stream::NONPLANAR).choose(eligible.len(), k);
    let mut uses = vec![0usize; m.vertices.len()];
    for f in &m.faces {
        for &v in &f.contours[0] {
            uses[v.idx()] += 1;
        }
    }
    let mut before: Vec<Option<VertexId>> = vec![None; m.faces.len()];
    let mut made = 0;
    for (e, &(f, corner)) in eligible.iter().enumerate() {
        if !chosen[e] {
            continue;
        }
        let c = &m.faces[f].contours[0];
        let pts: Vec<DVec3> = c.iter().map(|&v| m.pos(v)).collect();
        let centre = pts.iter().copied().sum::<DVec3>() / 4.0;
        let p = pts[corner];
        let inward = (centre - p).normalize_or_zero();
        let pos = p - DVec3::Z * dirt.lift + inward * dirt.lift;
        let old = c[corner];
        if uses[old.idx()] == 1 {
            m.vertices[old.idx()].pos = pos;
            continue;
        }
        uses[old.idx()] -= 1;
        made += 1;
        let v = VertexId(m.vertices.len() as u32);
        m.vertices.push(Vertex {
            name: format!("np{made}"),
            pos,
            color: None,
        });
        m.faces[f].contours[0][corner] = v;
        before[f] = Some(v);
    }
    let items = std::mem::take(&mut m.items);
    m.items.reserve(items.len() + made);
    for it in items {
        if let Item::Face(f) = it
            && let Some(v) = before[f.idx()]
        {
            m.items.push(Item::Vertex(v));
        }
        m.items.push(it);
    }
}

#[cfg(test)]
mod tests;
