//! A second generator: buildings drawn the way CAD programs export them
//! (issue #13), with the dirt the `generate` grid does not have.
//!
//! Everything is a solid or a sheet lying on one, as a draftsman models it,
//! not a clean boundary:
//!
//! * **storeys** of rooms on a grid of random column widths and row depths
//!   (3–5.5 m), 3 m apart; each storey stands on a **slab** (a closed box,
//!   0.2 m thick; its top is the floor, its underside the ceiling of the
//!   storey below; the last one is the roof);
//! * **walls are box slabs** (0.15 m inside, 0.25 m outside) from just
//!   below the floor (sunk 0–3 cm into the slab, or standing exactly on it)
//!   to just above the ceiling, one per room side, **split into 1–3 short
//!   runs that overlap collinearly** (2–30 cm), every run reaching past the
//!   junction so that walls **interpenetrate at every junction**;
//! * **openings**: a door (0.9 × 2.1 m) in some inner walls, a window
//!   (1.2 m wide, sill 0.9, lintel 2.1) in some outer walls; there the wall
//!   is several convex boxes — piers, a lintel, a sill — whose faces are the
//!   reveals, and a window has a **glass** quad in the wall's mid-plane whose
//!   edges lie on the reveals;
//! * **floors of running-bond tiles** in some rooms: rows of 1.2 × 0.6 m
//!   tiles offset by half a tile (a T-vertex at every joint), clipped to the
//!   room, lying on the slab;
//! * **furniture**: desks (a top and four legs that pierce it and sink into
//!   the floor), cabinets **pushed into a wall**, and boxes **rotated by an
//!   arbitrary angle**; **papers** on desks, **rugs** on floors (on the
//!   tiles too: three coplanar layers), **pictures** on walls — small faces
//!   lying on larger ones of another material;
//! * **columns** (0.3 m square, floor to ceiling) with one top corner
//!   displaced 2 cm, so two sides are not planar;
//! * **vaulted ceilings** in some rooms: a barrel of twisted (non-planar)
//!   quads under the slab, springing from the side walls;
//! * **stairs and ramps** (with [`Cad::stairs`]): steps as boxes from the
//!   floor, each overlapping the next, up to a landing; ramps as wedges whose
//!   slope meets the floor at 2.9–7.1°;
//! * **lights**: a panel flush with the ceiling (coplanar with it, facing
//!   down) or a **hanging light box** (its underside emits);
//! * and over everything: faces **flipped** at random, **duplicate faces**
//!   (sharing the vertex records, or on fresh copies of them), and **vertex
//!   jitter** of about `jitter` × the model's size, so that coincident
//!   vertices are only nearly so.
//!
//! Faces are named after their object (`s0w3r1.4`: storey 0, wall 3, run 1,
//! box face 4); vertices likewise. The same arguments always give the same
//! model.

use glam::{DVec2, DVec3};
use ug::{Defmat, Face, Item, Material, MaterialDef, MaterialId, Model, Vertex, VertexId};

use crate::Rng;

/// Storey height (floor to floor).
pub const STOREY: f64 = 3.0;
/// Slab thickness.
pub const SLAB: f64 = 0.2;
/// Inner and outer wall thickness.
pub const WALL_IN: f64 = 0.15;
pub const WALL_OUT: f64 = 0.25;
/// Emitted exitance of panels and light boxes (per channel, before the tint).
pub const EMISSION: f64 = 10.0;

/// What [`cad`] draws and how much dirt it adds.
#[derive(Clone, Debug, PartialEq)]
pub struct Cad {
    pub storeys: usize,
    pub rooms_x: usize,
    pub rooms_y: usize,
    /// Fraction of faces written reversed.
    pub flipped: f64,
    /// Fraction of faces written twice (half on the same vertex records,
    /// half on fresh copies).
    pub duplicates: f64,
    /// Vertex jitter, relative to the model's size (each coordinate moved
    /// by up to this much).
    pub jitter: f64,
    /// Fraction of rooms with running-bond tile floors.
    pub tiles: f64,
    /// Fraction of outer wall segments with a window.
    pub windows: f64,
    /// Fraction of inner wall segments with a door.
    pub doors: f64,
    /// Fraction of rooms with a vaulted ceiling.
    pub vaults: f64,
    /// Fraction of rooms with a column.
    pub columns: f64,
    /// Pieces of furniture per room (0 to 4).
    pub furniture: usize,
    /// Rugs, papers and pictures.
    pub extras: bool,
    /// Fraction of rooms lit by a flush ceiling panel (the others by a
    /// hanging light box).
    pub panels: f64,
    /// Export every face as triangles fanned from its first vertex, each
    /// triangle on vertex records of its own (an STL export, or an OBJ
    /// export of triangles): the grouper has to weld and join them again,
    /// and a flipped duplicate of a twisted quad comes triangulated along
    /// the other diagonal. A face that is not convex in its plane keeps
    /// its contour (on fresh vertex records too).
    pub triangles: bool,
    /// A one-storey wing on the +x facade, its plan sheared by an
    /// arbitrary angle: side walls, slabs and contents meet the facade and
    /// each other obliquely, the wing's walls and slabs run into the
    /// facade wall and the main slabs.
    pub wing: bool,
    /// A pitched roof on the top slab: two sloped box slabs meeting past
    /// the ridge, eaves overhanging the walls and crossing the top slab's
    /// edge, and gable walls whose slanted edges run into the roof.
    pub pitched: bool,
    /// Stairs and ramps in about half the rooms, along the room's −x wall
    /// and pushed into it: a flight of steps, each a box from the floor
    /// (sunk into it) overlapping the next, up to a landing box; or a ramp,
    /// a wedge rising at 1:20 to 1:8 (2.9–7.1°), so its slope meets the
    /// floor at a shallow angle, up to a landing.
    pub stairs: bool,
    /// Curved things tessellated as CAD programs export them, in about
    /// half the rooms: a round column (a 12- to 48-gon prism) through the
    /// floor and into the ceiling slab, a globe lamp (a UV sphere of
    /// triangles and quads) hanging under the ceiling, its pole touching
    /// or pushed into it, and a pipe (a 12- to 16-gon prism) running
    /// obliquely across the room with its ends pushed into the walls.
    pub curved: bool,
}

impl Default for Cad {
    /// Two storeys of 2 × 2 rooms with every kind of dirt.
    fn default() -> Self {
        Cad {
            storeys: 2,
            rooms_x: 2,
            rooms_y: 2,
            flipped: 0.3,
            duplicates: 0.03,
            jitter: 1e-7,
            tiles: 0.3,
            windows: 0.6,
            doors: 0.5,
            vaults: 0.25,
            columns: 0.3,
            furniture: 2,
            extras: true,
            panels: 0.5,
            triangles: false,
            wing: false,
            pitched: false,
            stairs: false,
            curved: false,
        }
    }
}

impl Cad {
    /// The default dirt with the room grid chosen so that the model has
    /// about `faces` faces (`storeys` storeys; rooms as square as possible).
    pub fn for_faces(faces: usize, storeys: usize, seed: u64) -> Cad {
        let storeys = storeys.max(1);
        let mut c = Cad {
            storeys,
            rooms_x: 1,
            rooms_y: 1,
            ..Cad::default()
        };
        // Faces grow with rooms; measure a small model and scale.
        let probe = Cad {
            rooms_x: 4,
            rooms_y: 4,
            ..c.clone()
        };
        let per_room = cad(&probe, seed).faces.len() as f64 / (16 * storeys) as f64;
        let rooms = (faces as f64 / per_room / storeys as f64).max(1.0);
        let x = rooms.sqrt().round().max(1.0) as usize;
        let y = (rooms / x as f64).round().max(1.0) as usize;
        c.rooms_x = x;
        c.rooms_y = y;
        c
    }
}

/// Random streams, one per kind of thing, so that changing one fraction
/// leaves the others' places unchanged.
mod stream {
    pub const GRID: u64 = 101;
    pub const WALLS: u64 = 102;
    pub const ROOMS: u64 = 103;
    pub const FURNITURE: u64 = 104;
    pub const DUPLICATES: u64 = 105;
    pub const FLIPPED: u64 = 106;
    pub const JITTER: u64 = 107;
    pub const WING: u64 = 108;
    pub const ROOF: u64 = 109;
    pub const STAIRS: u64 = 110;
    pub const CURVED: u64 = 111;
}

struct B {
    m: Model,
    mats: Mats,
}

struct Mats {
    floor: MaterialId,
    ceiling: MaterialId,
    roof: MaterialId,
    slab: MaterialId,
    wall: MaterialId,
    facade: MaterialId,
    glass: MaterialId,
    tile: MaterialId,
    wood: MaterialId,
    metal: MaterialId,
    rug: MaterialId,
    paper: MaterialId,
    picture: MaterialId,
    column: MaterialId,
    vault: MaterialId,
    panel: MaterialId,
    light: MaterialId,
    lamp: MaterialId,
    attic: MaterialId,
}

impl B {
    fn v(&mut self, name: String, p: DVec3) -> VertexId {
        self.m.add_vertex(Vertex {
            name,
            pos: p,
            color: None,
        })
    }

    fn f(&mut self, name: String, c: Vec<VertexId>, mat: MaterialId) {
        self.m.add_face(Face {
            name: Some(name),
            contours: vec![c],
            material: Some(mat),
        });
    }

    /// A quad on four points (counter-clockwise seen from its front).
    fn quad(&mut self, name: &str, p: [DVec3; 4], mat: MaterialId) {
        let ids: Vec<VertexId> = (0..4)
            .map(|k| self.v(format!("{name}.{k}"), p[k]))
            .collect();
        self.f(name.to_string(), ids, mat);
    }

    /// A closed box facing outward on eight corners (bit 0: +x side, bit 1:
    /// +y, bit 2: +z, in the box's own frame), with a material per face:
    /// bottom, top, and the four sides (−y, +x, +y, −x).
    fn solid(&mut self, name: &str, c: [DVec3; 8], mats: [MaterialId; 6]) {
        let ids: Vec<VertexId> = (0..8)
            .map(|k| self.v(format!("{name}.v{k}"), c[k]))
            .collect();
        // Corner index from (x, y, z) bits.
        let q = |x: usize, y: usize, z: usize| ids[x | (y << 1) | (z << 2)];
        let faces = [
            [q(0, 0, 0), q(0, 1, 0), q(1, 1, 0), q(1, 0, 0)], // bottom, −z
            [q(0, 0, 1), q(1, 0, 1), q(1, 1, 1), q(0, 1, 1)], // top, +z
            [q(0, 0, 0), q(1, 0, 0), q(1, 0, 1), q(0, 0, 1)], // −y
            [q(1, 0, 0), q(1, 1, 0), q(1, 1, 1), q(1, 0, 1)], // +x
            [q(1, 1, 0), q(0, 1, 0), q(0, 1, 1), q(1, 1, 1)], // +y
            [q(0, 1, 0), q(0, 0, 0), q(0, 0, 1), q(0, 1, 1)], // −x
        ];
        for (k, f) in faces.iter().enumerate() {
            self.f(format!("{name}.{k}"), f.to_vec(), mats[k]);
        }
    }

    /// An axis-aligned box.
    fn aabb(&mut self, name: &str, lo: DVec3, hi: DVec3, mats: [MaterialId; 6]) {
        let c = std::array::from_fn(|k| {
            DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        self.solid(name, c, mats);
    }

    /// A box of footprint `size` centred at `centre` (x, y), rotated by
    /// `angle` about z, from `z0` to `z1`.
    #[allow(clippy::too_many_arguments)]
    fn rotated(
        &mut self,
        name: &str,
        centre: DVec2,
        size: DVec2,
        angle: f64,
        z0: f64,
        z1: f64,
        mats: [MaterialId; 6],
    ) {
        let (s, c) = angle.sin_cos();
        let corner = |k: usize| {
            let lx = if k & 1 == 0 { -0.5 } else { 0.5 } * size.x;
            let ly = if k & 2 == 0 { -0.5 } else { 0.5 } * size.y;
            let p = centre + DVec2::new(c * lx - s * ly, s * lx + c * ly);
            DVec3::new(p.x, p.y, if k & 4 == 0 { z0 } else { z1 })
        };
        self.solid(name, std::array::from_fn(corner), mats);
    }

    /// A prism facing outward: the planar polygon `base` swept by `off`
    /// (not in its plane); the base and the top take `ends`, the sides
    /// `sides`.
    fn prism(
        &mut self,
        name: &str,
        base: &[DVec3],
        off: DVec3,
        ends: MaterialId,
        sides: MaterialId,
    ) {
        let mut p = base.to_vec();
        if geom::newell_normal(&p).dot(off) > 0.0 {
            p.reverse();
        }
        let n = p.len();
        let lo: Vec<VertexId> = (0..n)
            .map(|k| self.v(format!("{name}.v{k}"), p[k]))
            .collect();
        let hi: Vec<VertexId> = (0..n)
            .map(|k| self.v(format!("{name}.w{k}"), p[k] + off))
            .collect();
        self.f(format!("{name}.0"), lo.clone(), ends);
        self.f(
            format!("{name}.1"),
            hi.iter().rev().copied().collect(),
            ends,
        );
        for i in 0..n {
            let j = (i + 1) % n;
            self.f(
                format!("{name}.{}", i + 2),
                vec![lo[j], lo[i], hi[i], hi[j]],
                sides,
            );
        }
    }
}

fn rgb(m: &mut Model, name: &str, c: [f64; 3]) -> MaterialId {
    m.add_material(Material {
        name: name.into(),
        def: MaterialDef::Rgb(c),
    })
}

fn emitter(m: &mut Model, name: &str, e: [f64; 3]) -> MaterialId {
    m.add_material(Material {
        name: name.into(),
        def: MaterialDef::Defmat(Defmat {
            diffuse: Some([0.8, 0.8, 0.8]),
            emission: Some(e),
            other: Vec::new(),
        }),
    })
}

fn pick(r: &mut Rng, fraction: f64) -> bool {
    r.unit() < fraction.clamp(0.0, 1.0)
}

/// One room: its storey, grid place and clear rectangle.
#[derive(Clone, Copy)]
struct Room {
    s: usize,
    i: usize,
    j: usize,
    /// Inner faces of the surrounding walls (the room's clear rectangle).
    ilo: DVec2,
    ihi: DVec2,
}

/// Generates a CAD-like building (see the module documentation).
pub fn cad(cfg: &Cad, seed: u64) -> Model {
    let (nx, ny, ns) = (cfg.rooms_x.max(1), cfg.rooms_y.max(1), cfg.storeys.max(1));
    let mut m = Model::new();
    let mats = Mats {
        floor: rgb(&mut m, "floor", [0.55, 0.5, 0.45]),
        ceiling: rgb(&mut m, "ceiling", [0.85, 0.85, 0.85]),
        roof: rgb(&mut m, "roof", [0.3, 0.3, 0.3]),
        slab: rgb(&mut m, "slab", [0.5, 0.5, 0.5]),
        wall: rgb(&mut m, "wall", [0.8, 0.78, 0.75]),
        facade: rgb(&mut m, "facade", [0.6, 0.55, 0.5]),
        glass: rgb(&mut m, "glass", [0.08, 0.1, 0.1]),
        tile: rgb(&mut m, "tile", [0.7, 0.68, 0.6]),
        wood: rgb(&mut m, "wood", [0.5, 0.35, 0.2]),
        metal: rgb(&mut m, "metal", [0.4, 0.4, 0.42]),
        rug: rgb(&mut m, "rug", [0.6, 0.15, 0.1]),
        paper: rgb(&mut m, "paper", [0.9, 0.9, 0.88]),
        picture: rgb(&mut m, "picture", [0.3, 0.4, 0.6]),
        column: rgb(&mut m, "column", [0.7, 0.7, 0.7]),
        vault: rgb(&mut m, "vault", [0.88, 0.86, 0.82]),
        panel: emitter(&mut m, "panel", [EMISSION, EMISSION, 0.9 * EMISSION]),
        light: emitter(&mut m, "light", [EMISSION, 0.9 * EMISSION, 0.7 * EMISSION]),
        lamp: rgb(&mut m, "lamp", [0.6, 0.6, 0.6]),
        attic: rgb(&mut m, "attic", [0.55, 0.45, 0.35]),
    };
    let mut b = B { m, mats };

    // The grid of wall axes, shared by every storey.
    let mut rg = Rng::new(seed, stream::GRID);
    let mut xs = vec![0.0];
    for _ in 0..nx {
        let last = *xs.last().unwrap_or(&0.0);
        xs.push(last + rg.range(3.0, 5.5));
    }
    let mut ys = vec![0.0];
    for _ in 0..ny {
        let last = *ys.last().unwrap_or(&0.0);
        ys.push(last + rg.range(3.0, 5.5));
    }
    let half_out = WALL_OUT / 2.0;
    let thick = |outer: bool| if outer { WALL_OUT } else { WALL_IN };

    // Slabs: storey s stands on slab s; slab ns is the roof.
    let (x0, x1) = (xs[0] - half_out, xs[nx] + half_out);
    let (y0, y1) = (ys[0] - half_out, ys[ny] + half_out);
    for s in 0..=ns {
        let top = s as f64 * STOREY;
        let mt = b.mats.slab;
        let up = if s == ns { b.mats.roof } else { b.mats.floor };
        let down = if s == 0 { mt } else { b.mats.ceiling };
        b.aabb(
            &format!("slab{s}"),
            DVec3::new(x0, y0, top - SLAB),
            DVec3::new(x1, y1, top),
            [down, up, mt, mt, mt, mt],
        );
    }

    // Walls, storey by storey: along y at every x axis, then along x.
    let mut rw = Rng::new(seed, stream::WALLS);
    let mut wall_no = 0usize;
    for s in 0..ns {
        let zf = s as f64 * STOREY;
        let zc = (s + 1) as f64 * STOREY - SLAB;
        // (axis position, from, to, along x?, the outside's side: -1, +1 or 0 inside)
        let mut segs: Vec<(f64, f64, f64, bool, i32)> = Vec::new();
        let side = |k: usize, n: usize| {
            if k == 0 {
                -1
            } else if k == n {
                1
            } else {
                0
            }
        };
        for (i, &x) in xs.iter().enumerate() {
            for j in 0..ny {
                segs.push((x, ys[j], ys[j + 1], false, side(i, nx)));
            }
        }
        for (j, &y) in ys.iter().enumerate() {
            for i in 0..nx {
                segs.push((y, xs[i], xs[i + 1], true, side(j, ny)));
            }
        }
        for &(c, a, e, along_x, out_side) in &segs {
            let outer = out_side != 0;
            let t = thick(outer);
            let name = format!("s{s}w{wall_no}");
            wall_no += 1;
            let sink = if pick(&mut rw, 0.3) {
                0.0
            } else {
                rw.range(0.005, 0.03)
            };
            let pen = rw.range(0.0, 0.03);
            let (z0, z1) = (zf - sink, zc + pen);
            // Past the junctions: half the crossing wall and a little more.
            let a0 = a - t / 2.0 - rw.range(0.0, 0.05);
            let e1 = e + t / 2.0 + rw.range(0.0, 0.05);
            let face_mat = if outer { b.mats.facade } else { b.mats.wall };
            let inner_mat = b.mats.wall;
            // Box from along-axis [p, q] and height [za, zb], in world coordinates.
            let wall_box = |b: &mut B, n: &str, p: f64, q: f64, za: f64, zb: f64| {
                let (lo, hi) = if along_x {
                    (
                        DVec3::new(p, c - t / 2.0, za),
                        DVec3::new(q, c + t / 2.0, zb),
                    )
                } else {
                    (
                        DVec3::new(c - t / 2.0, p, za),
                        DVec3::new(c + t / 2.0, q, zb),
                    )
                };
                // Sides facing −y/+y (along x) or −x/+x (along y); the
                // outside of an outer wall is the facade.
                let (sm, sp) = match out_side {
                    -1 => (face_mat, inner_mat),
                    1 => (inner_mat, face_mat),
                    _ => (inner_mat, inner_mat),
                };
                let m = if along_x {
                    [inner_mat, inner_mat, sm, inner_mat, sp, inner_mat]
                } else {
                    [inner_mat, inner_mat, inner_mat, sp, inner_mat, sm]
                };
                b.aabb(n, lo, hi, m);
            };
            let len = e - a;
            let opening = if outer {
                pick(&mut rw, cfg.windows)
            } else {
                pick(&mut rw, cfg.doors)
            };
            if opening && len >= 2.2 {
                let (w, sill, head) = if outer {
                    (1.2, Some(0.9), 2.1)
                } else {
                    (0.9, None, 2.1)
                };
                let o0 = a + rw.range(0.5, len - w - 0.5);
                let o1 = o0 + w;
                wall_box(&mut b, &format!("{name}p0"), a0, o0, z0, z1);
                wall_box(&mut b, &format!("{name}p1"), o1, e1, z0, z1);
                wall_box(&mut b, &format!("{name}l"), o0, o1, zf + head, z1);
                if let Some(h) = sill {
                    wall_box(&mut b, &format!("{name}s"), o0, o1, z0, zf + h);
                    // Glass in the mid-plane, its edges on the reveals.
                    let (za, zb) = (zf + h, zf + head);
                    let p = |u: f64, z: f64| {
                        if along_x {
                            DVec3::new(u, c, z)
                        } else {
                            DVec3::new(c, u, z)
                        }
                    };
                    let g = [p(o0, za), p(o1, za), p(o1, zb), p(o0, zb)];
                    let g = if along_x { g } else { [g[1], g[0], g[3], g[2]] };
                    b.quad(&format!("{name}g"), g, b.mats.glass);
                }
            } else {
                // 1–3 runs overlapping collinearly.
                let runs = 1 + rw.below(3);
                let mut cuts = vec![a0];
                for k in 1..runs {
                    cuts.push(a + len * (k as f64 / runs as f64) + rw.range(-0.2, 0.2) * len / 3.0);
                }
                cuts.push(e1);
                for k in 0..runs {
                    let p = cuts[k] - if k > 0 { rw.range(0.02, 0.3) } else { 0.0 };
                    let q = cuts[k + 1];
                    wall_box(&mut b, &format!("{name}r{k}"), p, q, z0, z1);
                }
            }
        }
    }

    // Rooms.
    let mut rooms = Vec::new();
    for s in 0..ns {
        for i in 0..nx {
            for j in 0..ny {
                let tl = |k: usize, n: usize| thick(k == 0 || k == n) / 2.0;
                rooms.push(Room {
                    s,
                    i,
                    j,
                    ilo: DVec2::new(xs[i] + tl(i, nx), ys[j] + tl(j, ny)),
                    ihi: DVec2::new(xs[i + 1] - tl(i + 1, nx), ys[j + 1] - tl(j + 1, ny)),
                });
            }
        }
    }
    let mut rr = Rng::new(seed, stream::ROOMS);
    let mut rf = Rng::new(seed, stream::FURNITURE);
    for room in &rooms {
        room_contents(&mut b, cfg, room, &mut rr, &mut rf);
    }
    if cfg.stairs {
        let mut rs = Rng::new(seed, stream::STAIRS);
        for room in &rooms {
            stairs(&mut b, room, &mut rs);
        }
    }
    if cfg.curved {
        let mut rc = Rng::new(seed, stream::CURVED);
        for room in &rooms {
            curved(&mut b, room, &mut rc);
        }
    }
    if cfg.wing {
        let mut rw = Rng::new(seed, stream::WING);
        wing(&mut b, cfg, (nx, ny), (x1, y0, y1), &mut rw, seed);
    }
    if cfg.pitched {
        let mut rp = Rng::new(seed, stream::ROOF);
        pitched_roof(
            &mut b,
            DVec2::new(x0, y0),
            DVec2::new(x1, y1),
            ns as f64 * STOREY,
            &mut rp,
        );
    }

    // Duplicates, flips, jitter.
    let faces = b.m.faces.len();
    let mut rd = Rng::new(seed, stream::DUPLICATES);
    let mut copies = 0usize;
    for f in 0..faces {
        if !pick(&mut rd, cfg.duplicates) {
            continue;
        }
        let face = b.m.faces[f].clone();
        let fresh = rd.unit() < 0.5;
        let contours = if fresh {
            face.contours
                .iter()
                .map(|c| {
                    c.iter()
                        .map(|&v| {
                            let old = b.m.vertices[v.idx()].clone();
                            copies += 1;
                            b.v(format!("{}.d{copies}", old.name), old.pos)
                        })
                        .collect()
                })
                .collect()
        } else {
            face.contours.clone()
        };
        b.m.add_face(Face {
            name: face.name.as_ref().map(|n| format!("{n}.dup")),
            contours,
            material: face.material,
        });
    }
    let mut rfl = Rng::new(seed, stream::FLIPPED);
    for face in &mut b.m.faces {
        if pick(&mut rfl, cfg.flipped) {
            for c in &mut face.contours {
                c.reverse();
            }
        }
    }
    if cfg.triangles {
        b.m = triangles(&b.m);
    }
    let size = b.m.bounds().map_or(1.0, |(lo, hi)| (hi - lo).length());
    let j = cfg.jitter * size;
    if j > 0.0 {
        let mut rj = Rng::new(seed, stream::JITTER);
        for v in &mut b.m.vertices {
            v.pos += DVec3::new(rj.range(-j, j), rj.range(-j, j), rj.range(-j, j));
        }
    }
    b.m
}

/// The model exported as triangles (see [`Cad::triangles`]): every face
/// fanned from its first vertex where its outer contour is convex in its
/// plane (one without holes), each triangle written after its own three
/// vertex records (`FACE.tK.0` …); other statements stay in place.
fn triangles(m: &Model) -> Model {
    let mut out = Model {
        materials: m.materials.clone(),
        ..Model::default()
    };
    for it in &m.items {
        match *it {
            Item::Vertex(_) => {}
            Item::Face(f) => {
                let face = &m.faces[f.idx()];
                let name = face.name.clone().unwrap_or_else(|| format!("f{}", f.0 + 1));
                let c = &face.contours[0];
                let p: Vec<DVec3> = c.iter().map(|&v| m.pos(v)).collect();
                let n = geom::newell_normal(&p);
                let convex = face.contours.len() == 1
                    && (0..p.len()).all(|i| {
                        let (a, b, d) = (p[i], p[(i + 1) % p.len()], p[(i + 2) % p.len()]);
                        (b - a).cross(d - b).dot(n) > 0.0
                    });
                let pieces: Vec<Vec<Vec<VertexId>>> = if convex && c.len() > 3 {
                    (1..c.len() - 1)
                        .map(|k| vec![vec![c[0], c[k], c[k + 1]]])
                        .collect()
                } else {
                    vec![face.contours.clone()]
                };
                let many = pieces.len() > 1;
                for (k, contours) in pieces.into_iter().enumerate() {
                    let fname = if many {
                        format!("{name}.t{}", k + 1)
                    } else {
                        name.clone()
                    };
                    let mut i = 0;
                    let contours = contours
                        .iter()
                        .map(|cc| {
                            cc.iter()
                                .map(|&v| {
                                    i += 1;
                                    out.add_vertex(Vertex {
                                        name: format!("{fname}.{}", i - 1),
                                        pos: m.pos(v),
                                        color: None,
                                    })
                                })
                                .collect()
                        })
                        .collect();
                    out.add_face(Face {
                        name: Some(fname),
                        contours,
                        material: face.material,
                    });
                }
            }
            ref other => out.items.push(other.clone()),
        }
    }
    out
}

/// The wing (see [`Cad::wing`]): drawn as a one-room storey in its own
/// frame (`u` out of the facade at `x = x1`, `v` along it, `z`), then
/// sheared by the wing's angle: `(x, y) = (x1 + u, yb + v + u·tan θ)`.
/// A shear keeps planes planar, so every face stays as flat as drawn.
fn wing(
    b: &mut B,
    cfg: &Cad,
    grid: (usize, usize),
    facade: (f64, f64, f64),
    r: &mut Rng,
    seed: u64,
) {
    let (x1, y0, y1) = facade;
    let first = b.m.vertices.len();
    let t = WALL_OUT;
    let len = r.range(3.5, 6.0);
    let width = r.range(3.0, 5.0).min(y1 - y0 - 0.8).max(1.5);
    let yb = r.range(y0 + 0.4, (y1 - 0.4 - width).max(y0 + 0.4));
    // Now and then nearly square to the facade (slivers along the
    // junctions), else well off it; either way.
    let deg = if r.unit() < 0.25 {
        r.range(2.0, 8.0)
    } else {
        r.range(15.0, 50.0)
    };
    let k = (if r.unit() < 0.5 { -deg } else { deg }).to_radians().tan();
    let zc = STOREY - SLAB;
    let (wall, facade_mat, slab) = (b.mats.wall, b.mats.facade, b.mats.slab);
    let side = |b: &mut B, n: &str, lo: DVec3, hi: DVec3, out_minus: bool, across: bool| {
        // A wall box; the facade material outside.
        let (m_lo, m_hi) = if out_minus {
            (facade_mat, wall)
        } else {
            (wall, facade_mat)
        };
        let m = if across {
            [wall, wall, wall, m_hi, wall, m_lo]
        } else {
            [wall, wall, m_lo, wall, m_hi, wall]
        };
        b.aabb(n, lo, hi, m);
    };
    // Side walls run into the facade wall (0.25 thick behind u = 0).
    let (sink, top) = (r.range(0.0, 0.03), zc + r.range(0.0, 0.03));
    for (j, v) in [0.0, width].into_iter().enumerate() {
        let pen = r.range(0.05, 0.2);
        side(
            b,
            &format!("wing{j}"),
            DVec3::new(-pen, v - t / 2.0, -sink),
            DVec3::new(len + t / 2.0 + r.range(0.0, 0.05), v + t / 2.0, top),
            j == 0,
            false,
        );
    }
    let over = r.range(0.0, 0.05);
    side(
        b,
        "wing2",
        DVec3::new(len - t / 2.0, -t / 2.0 - over, -sink),
        DVec3::new(len + t / 2.0, width + t / 2.0 + over, top),
        false,
        true,
    );
    // The floor and roof slabs, overlapping the main slabs' edges.
    let back = r.range(0.0, 0.3);
    let (lo, hi) = (
        DVec2::new(-back, -t / 2.0),
        DVec2::new(len + t / 2.0, width + t / 2.0),
    );
    b.aabb(
        "wingslab0",
        DVec3::new(lo.x, lo.y, -SLAB),
        DVec3::new(hi.x, hi.y, 0.0),
        [slab, b.mats.floor, slab, slab, slab, slab],
    );
    b.aabb(
        "wingslab1",
        DVec3::new(lo.x, lo.y, zc),
        DVec3::new(hi.x, hi.y, STOREY),
        [b.mats.ceiling, b.mats.roof, slab, slab, slab, slab],
    );
    // Its room, furnished and lit as the others.
    let room = Room {
        s: 0,
        i: grid.0,
        j: grid.1,
        ilo: DVec2::new(0.0, t / 2.0),
        ihi: DVec2::new(len - t / 2.0, width - t / 2.0),
    };
    let mut rr = Rng::new(seed, stream::WING + 100);
    let mut rf = Rng::new(seed, stream::WING + 200);
    room_contents(b, cfg, &room, &mut rr, &mut rf);
    for v in &mut b.m.vertices[first..] {
        let p = v.pos;
        v.pos = DVec3::new(x1 + p.x, yb + p.y + p.x * k, p.z);
    }
}

/// The pitched roof (see [`Cad::pitched`]) on a top slab of footprint
/// `lo`–`hi` whose top is at `ztop`; the ridge runs along the longer side.
fn pitched_roof(b: &mut B, lo: DVec2, hi: DVec2, ztop: f64, r: &mut Rng) {
    let along_y = hi.y - lo.y >= hi.x - lo.x;
    // (a across the ridge, b along it) → world; a rotation either way.
    let (a0, a1, b0, b1) = if along_y {
        (lo.x, hi.x, lo.y, hi.y)
    } else {
        (lo.y, hi.y, lo.x, hi.x)
    };
    let w = |a: f64, bb: f64, z: f64| {
        if along_y {
            DVec3::new(a, bb, z)
        } else {
            DVec3::new(bb, lo.y + hi.y - a, z)
        }
    };
    let pitch = r.range(20.0, 40.0).to_radians();
    let slope = pitch.tan();
    let thick = 0.2 / pitch.cos();
    let (eave, gable) = (r.range(0.3, 0.6), r.range(0.2, 0.4));
    let sink = r.range(0.03, 0.08);
    let am = 0.5 * (a0 + a1);
    let past = r.range(0.1, 0.25);
    // The underside meets the wall line `sink` below the top slab's top.
    let zb = ztop - sink - eave * slope;
    let (roof, attic, slab) = (b.mats.roof, b.mats.attic, b.mats.slab);
    let under_l = |a: f64| zb + (a - (a0 - eave)) * slope;
    let under_r = |a: f64| zb + (a1 + eave - a) * slope;
    for (n, (aa, ab), under) in [
        (
            "roofl",
            (a0 - eave, am + past),
            &under_l as &dyn Fn(f64) -> f64,
        ),
        ("roofr", (am - past, a1 + eave), &under_r),
    ] {
        let c: [DVec3; 8] = std::array::from_fn(|k| {
            let a = if k & 1 == 0 { aa } else { ab };
            let bb = if k & 2 == 0 { b0 - gable } else { b1 + gable };
            w(a, bb, under(a) + if k & 4 == 0 { 0.0 } else { thick })
        });
        b.solid(n, c, [attic, roof, slab, slab, slab, slab]);
    }
    // Gables on the outer walls, sunk 2 cm into the top slab, their
    // slanted edges 1–8 cm into the roof.
    let apex = under_l(am) + 0.05;
    for (n, bb) in [("gable0", b0), ("gable1", b1 - WALL_OUT)] {
        let base = [
            w(a0, bb, ztop - 0.02),
            w(a1, bb, ztop - 0.02),
            w(am, bb, apex),
        ];
        let off = w(a0, bb + WALL_OUT, 0.0) - w(a0, bb, 0.0);
        b.prism(n, &base, off, b.mats.facade, slab);
    }
}

/// A round column, a globe lamp and a pipe in about half the rooms (see
/// [`Cad::curved`]); clear of the −x wall, where stairs may stand.
fn curved(b: &mut B, room: &Room, r: &mut Rng) {
    use std::f64::consts::PI;
    if !pick(r, 0.5) {
        return;
    }
    let zf = room.s as f64 * STOREY;
    let zc = (room.s + 1) as f64 * STOREY - SLAB;
    let name = format!("s{}r{}_{}", room.s, room.i, room.j);
    let (ilo, ihi) = (room.ilo, room.ihi);
    if ihi.x - ilo.x < 2.5 || ihi.y - ilo.y < 2.0 {
        return;
    }
    // The column: from under the floor's top into the ceiling slab.
    let n = 12 + 4 * (r.unit() * 10.0) as usize;
    let rad = r.range(0.1, 0.25);
    let c = DVec2::new(
        r.range(ilo.x + 1.4, ihi.x - 0.5),
        r.range(ilo.y + 0.5, ihi.y - 0.5),
    );
    let turn = r.range(0.0, PI);
    let z0 = zf - r.range(0.0, 0.05);
    let base: Vec<DVec3> = (0..n)
        .map(|k| {
            let t = turn + 2.0 * PI * k as f64 / n as f64;
            DVec3::new(c.x + rad * t.cos(), c.y + rad * t.sin(), z0)
        })
        .collect();
    let up = zc + r.range(0.0, 0.1) - z0;
    b.prism(
        &format!("{name}rc"),
        &base,
        DVec3::new(0.0, 0.0, up),
        b.mats.column,
        b.mats.column,
    );
    // The globe: its pole on the ceiling or pushed a little into it.
    let (nu, nv) = (
        8 + 4 * (r.unit() * 4.0) as usize,
        4 + 2 * (r.unit() * 3.0) as usize,
    );
    let gr = r.range(0.1, 0.25);
    let poke = if pick(r, 0.5) {
        0.0
    } else {
        r.range(0.001, 0.05)
    };
    let g = DVec3::new(
        r.range(ilo.x + 1.4, ihi.x - 0.4),
        r.range(ilo.y + 0.4, ihi.y - 0.4),
        zc + poke - gr,
    );
    let ring = |a: usize, k: usize| {
        let (ph, th) = (PI * a as f64 / nv as f64, 2.0 * PI * k as f64 / nu as f64);
        g + gr * DVec3::new(ph.sin() * th.cos(), ph.sin() * th.sin(), ph.cos())
    };
    let top = b.v(format!("{name}gl.n"), g + DVec3::new(0.0, 0.0, gr));
    let bottom = b.v(format!("{name}gl.s"), g - DVec3::new(0.0, 0.0, gr));
    let rows: Vec<Vec<VertexId>> = (1..nv)
        .map(|a| {
            (0..nu)
                .map(|k| b.v(format!("{name}gl.v{a}_{k}"), ring(a, k)))
                .collect()
        })
        .collect();
    for k in 0..nu {
        let k2 = (k + 1) % nu;
        b.f(
            format!("{name}gl.n{k}"),
            vec![top, rows[0][k], rows[0][k2]],
            b.mats.light,
        );
        b.f(
            format!("{name}gl.s{k}"),
            vec![bottom, rows[nv - 2][k2], rows[nv - 2][k]],
            b.mats.light,
        );
        for a in 0..nv - 2 {
            b.f(
                format!("{name}gl.q{a}_{k}"),
                vec![rows[a][k], rows[a + 1][k], rows[a + 1][k2], rows[a][k2]],
                b.mats.light,
            );
        }
    }
    // The pipe: across the room in y, rising a little, its ends 2–10 cm
    // into the walls.
    let m = 12 + 4 * (r.unit() * 2.0) as usize;
    let pr = r.range(0.03, 0.08);
    let x = r.range(ilo.x + 1.4, ihi.x - 0.3);
    let z = r.range(zc - 0.6, zc - 0.3);
    let (y0, y1) = (ilo.y - r.range(0.02, 0.1), ihi.y + r.range(0.02, 0.1));
    let dx = r.range(-0.2, 0.2);
    let rise = r.range(0.0, 0.1);
    let section: Vec<DVec3> = (0..m)
        .map(|k| {
            let t = 2.0 * PI * k as f64 / m as f64;
            DVec3::new(x + pr * t.cos(), y0, z + pr * t.sin())
        })
        .collect();
    b.prism(
        &format!("{name}pp"),
        &section,
        DVec3::new(dx, y1 - y0, rise),
        b.mats.metal,
        b.mats.metal,
    );
}

/// A flight of steps or a ramp along the room's −x wall, in about half the
/// rooms (see [`Cad::stairs`]).
fn stairs(b: &mut B, room: &Room, r: &mut Rng) {
    if !pick(r, 0.5) {
        return;
    }
    let zf = room.s as f64 * STOREY;
    let name = format!("s{}r{}_{}", room.s, room.i, room.j);
    let (ilo, ihi) = (room.ilo, room.ihi);
    // Pushed into the wall, sunk into the floor (or standing on it).
    let x0 = ilo.x - r.range(0.0, 0.03);
    let x1 = ilo.x + r.range(0.9, 1.2);
    let sink = if pick(r, 0.3) {
        0.0
    } else {
        r.range(0.003, 0.02)
    };
    let z0 = zf - sink;
    let mat = [b.mats.wood; 6];
    // Rising towards +y or −y; `at(d)` is the y a distance d along it.
    let up = pick(r, 0.5);
    let (ya, yb) = (ilo.y + 0.1, ihi.y - 0.1);
    let at = |d: f64| if up { ya + d } else { yb - d };
    let span = |d0: f64, d1: f64| (at(d0).min(at(d1)), at(d0).max(at(d1)));
    let landing = 1.0;
    if pick(r, 0.5) {
        let (rise, going) = (r.range(0.15, 0.19), r.range(0.25, 0.3));
        let room_for = ((yb - ya - landing) / going).floor().max(0.0) as usize;
        let n = room_for.min(7);
        if n < 2 {
            return;
        }
        for k in 0..n {
            // Each step reaches a little under the next (or exactly to it).
            let over = if pick(r, 0.3) {
                0.0
            } else {
                r.range(0.01, 0.05)
            };
            let (lo, hi) = span(k as f64 * going, (k + 1) as f64 * going + over);
            b.aabb(
                &format!("{name}st{k}"),
                DVec3::new(x0, lo, z0),
                DVec3::new(x1, hi, zf + (k + 1) as f64 * rise),
                mat,
            );
        }
        let d = n as f64 * going;
        let (lo, hi) = span(d - r.range(0.0, 0.05), d + landing);
        b.aabb(
            &format!("{name}sl"),
            DVec3::new(x0, lo, z0),
            DVec3::new(x1, hi, zf + n as f64 * rise),
            mat,
        );
    } else {
        let slope = r.range(1.0 / 20.0, 1.0 / 8.0);
        let run = (yb - ya - landing).min(1.2 / slope);
        if run < 1.0 {
            return;
        }
        // The top, from the wedge's (possibly sunk) foot.
        let h = z0 + run * slope - zf;
        // A wedge with a flat bottom: sunk, its slope crosses the floor a
        // little way up (sink / slope); standing on it, its foot rests on
        // the floor along an edge.
        let p = |d: f64, z: f64| DVec3::new(x0, at(d), z);
        let base = [p(0.0, z0), p(run, zf + h), p(run, z0)];
        b.prism(
            &format!("{name}ramp"),
            &base,
            DVec3::new(x1 - x0, 0.0, 0.0),
            b.mats.wood,
            b.mats.wood,
        );
        // The landing's top a hair above or below the ramp's end.
        let (lo, hi) = span(run - r.range(0.0, 0.05), run + landing);
        b.aabb(
            &format!("{name}rl"),
            DVec3::new(x0, lo, z0),
            DVec3::new(x1, hi, zf + h + r.range(-0.003, 0.003)),
            mat,
        );
    }
}

fn room_contents(b: &mut B, cfg: &Cad, room: &Room, rr: &mut Rng, rf: &mut Rng) {
    let s = room.s;
    let zf = s as f64 * STOREY;
    let zc = (s + 1) as f64 * STOREY - SLAB;
    let name = format!("s{s}r{}_{}", room.i, room.j);
    let (ilo, ihi) = (room.ilo, room.ihi);
    let size = ihi - ilo;

    // Running-bond tiles on the slab.
    if pick(rr, cfg.tiles) {
        let (tw, td) = (1.2, 0.6);
        let rows = (size.y / td).ceil() as usize;
        let mut k = 0;
        for r in 0..rows {
            let ya = ilo.y + r as f64 * td;
            let yb = (ya + td).min(ihi.y);
            let shift = if r % 2 == 1 { tw / 2.0 } else { 0.0 };
            let mut x = ilo.x - shift;
            while x < ihi.x - 1e-9 {
                let xa = x.max(ilo.x);
                let xb = (x + tw).min(ihi.x);
                if xb - xa > 0.05 && yb - ya > 0.05 {
                    b.quad(
                        &format!("{name}t{k}"),
                        [
                            DVec3::new(xa, ya, zf),
                            DVec3::new(xb, ya, zf),
                            DVec3::new(xb, yb, zf),
                            DVec3::new(xa, yb, zf),
                        ],
                        b.mats.tile,
                    );
                    k += 1;
                }
                x += tw;
            }
        }
    }

    // A column with one top corner displaced.
    let mut column: Option<DVec2> = None;
    if pick(rr, cfg.columns) && size.x > 2.0 && size.y > 2.0 {
        let c = DVec2::new(
            rr.range(ilo.x + 0.8, ihi.x - 0.8),
            rr.range(ilo.y + 0.8, ihi.y - 0.8),
        );
        column = Some(c);
        let h = 0.15;
        let (z0, z1) = (zf - rr.range(0.0, 0.02), zc + rr.range(0.0, 0.02));
        let mut corners: [DVec3; 8] = std::array::from_fn(|k| {
            DVec3::new(
                c.x + if k & 1 == 0 { -h } else { h },
                c.y + if k & 2 == 0 { -h } else { h },
                if k & 4 == 0 { z0 } else { z1 },
            )
        });
        corners[7] += DVec3::new(0.02, 0.01, 0.0);
        b.solid(&format!("{name}c"), corners, [b.mats.column; 6]);
    }

    // Vault or flat ceiling; the light.
    let vault = pick(rr, cfg.vaults) && size.x > 1.5 && size.y > 1.5;
    let mut light_top = zc;
    if vault {
        let (spring, crown) = (zc - 0.8, zc - 0.05);
        let nu = 6usize;
        let nv = ((size.y / 1.2).round() as usize).max(2);
        let mut ids = vec![VertexId(0); (nu + 1) * (nv + 1)];
        for u in 0..=nu {
            for v in 0..=nv {
                let a = u as f64 / nu as f64;
                let t = v as f64 / nv as f64;
                let mut p = DVec3::new(
                    ilo.x + size.x * a,
                    ilo.y + size.y * t,
                    spring + (crown - spring) * (std::f64::consts::PI * a).sin(),
                );
                // A twist: inner vertices move along the barrel, so the
                // quads are not planar.
                if u > 0 && u < nu && v > 0 && v < nv {
                    p.y += 0.03 * (a - 0.5) * if v % 2 == 0 { 1.0 } else { -1.0 };
                    p.z += 0.02 * ((u + v) % 2) as f64;
                }
                ids[u * (nv + 1) + v] = b.v(format!("{name}vv{u}_{v}"), p);
            }
        }
        let mut k = 0;
        for u in 0..nu {
            for v in 0..nv {
                let q = |du: usize, dv: usize| ids[(u + du) * (nv + 1) + v + dv];
                // Facing down into the room.
                b.f(
                    format!("{name}v{k}"),
                    vec![q(0, 0), q(0, 1), q(1, 1), q(1, 0)],
                    b.mats.vault,
                );
                k += 1;
            }
        }
        light_top = crown - 0.3;
    }
    let centre = (ilo + ihi) / 2.0;
    let lc = match column {
        // Keep the light off the column.
        Some(c) if (c - centre).length() < 1.0 => centre + (centre - c).normalize_or_zero() * 1.0,
        _ => centre,
    };
    if !vault && pick(rr, cfg.panels) {
        // Flush with the ceiling, facing down.
        let (hx, hy) = (0.6, 0.3);
        b.quad(
            &format!("{name}panel"),
            [
                DVec3::new(lc.x - hx, lc.y - hy, zc),
                DVec3::new(lc.x - hx, lc.y + hy, zc),
                DVec3::new(lc.x + hx, lc.y + hy, zc),
                DVec3::new(lc.x + hx, lc.y - hy, zc),
            ],
            b.mats.panel,
        );
    } else {
        let lamp = b.mats.lamp;
        let drop = rr.range(0.3, 0.6);
        b.aabb(
            &format!("{name}lamp"),
            DVec3::new(lc.x - 0.3, lc.y - 0.3, light_top - drop - 0.1),
            DVec3::new(lc.x + 0.3, lc.y + 0.3, light_top - drop),
            [b.mats.light, lamp, lamp, lamp, lamp, lamp],
        );
    }

    // Rug (sometimes on the tiles), picture.
    if cfg.extras {
        if size.x > 2.0 && size.y > 2.0 && rr.unit() < 0.5 {
            let c = DVec2::new(
                rr.range(ilo.x + 1.0, ihi.x - 1.0),
                rr.range(ilo.y + 1.0, ihi.y - 1.0),
            );
            let (hx, hy) = (0.8, 0.5);
            b.quad(
                &format!("{name}rug"),
                [
                    DVec3::new(c.x - hx, c.y - hy, zf),
                    DVec3::new(c.x + hx, c.y - hy, zf),
                    DVec3::new(c.x + hx, c.y + hy, zf),
                    DVec3::new(c.x - hx, c.y + hy, zf),
                ],
                b.mats.rug,
            );
        }
        if size.x > 1.5 && rr.unit() < 0.5 {
            // On the inner face of the room's −y wall, facing +y.
            let x = rr.range(ilo.x + 0.2, ihi.x - 0.8);
            let y = ilo.y;
            b.quad(
                &format!("{name}pic"),
                [
                    DVec3::new(x, y, zf + 1.3),
                    DVec3::new(x, y, zf + 1.7),
                    DVec3::new(x + 0.6, y, zf + 1.7),
                    DVec3::new(x + 0.6, y, zf + 1.3),
                ],
                b.mats.picture,
            );
        }
    }

    // Furniture.
    let wood = b.mats.wood;
    let metal = b.mats.metal;
    for k in 0..cfg.furniture.min(4) {
        let fname = format!("{name}f{k}");
        if size.x < 1.8 || size.y < 1.8 {
            break;
        }
        match rf.below(3) {
            0 => {
                // A desk: top and four legs piercing it, sunk into the floor.
                let c = DVec2::new(
                    rf.range(ilo.x + 0.9, ihi.x - 0.9),
                    rf.range(ilo.y + 0.6, ihi.y - 0.6),
                );
                let (hx, hy) = (0.7, 0.35);
                let top = zf + 0.76;
                b.aabb(
                    &format!("{fname}top"),
                    DVec3::new(c.x - hx, c.y - hy, top - 0.04),
                    DVec3::new(c.x + hx, c.y + hy, top),
                    [wood; 6],
                );
                let sink = rf.range(0.0, 0.02);
                for (l, (sx, sy)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                    .into_iter()
                    .enumerate()
                {
                    let p = c + DVec2::new(sx * (hx - 0.06), sy * (hy - 0.06));
                    b.aabb(
                        &format!("{fname}leg{l}"),
                        DVec3::new(p.x - 0.025, p.y - 0.025, zf - sink),
                        DVec3::new(p.x + 0.025, p.y + 0.025, top - 0.02),
                        [metal; 6],
                    );
                }
                if cfg.extras {
                    // A sheet of paper on the top, at an angle.
                    let a = rf.range(0.0, std::f64::consts::PI);
                    let (s_, c_) = a.sin_cos();
                    let (w, h) = (0.105, 0.1485);
                    let q = |x: f64, y: f64| {
                        DVec3::new(c.x + c_ * x - s_ * y, c.y + s_ * x + c_ * y, top)
                    };
                    b.quad(
                        &format!("{fname}paper"),
                        [q(-w, -h), q(w, -h), q(w, h), q(-w, h)],
                        b.mats.paper,
                    );
                }
            }
            1 => {
                // A cabinet pushed 2 cm into the −x wall.
                let y = rf.range(ilo.y + 0.5, ihi.y - 0.5);
                let x0 = ilo.x - 0.02;
                b.aabb(
                    &fname,
                    DVec3::new(x0, y - 0.45, zf - rf.range(0.0, 0.01)),
                    DVec3::new(x0 + 0.5, y + 0.45, zf + 1.8),
                    [wood; 6],
                );
            }
            _ => {
                // A box at an arbitrary angle, sunk a little.
                let c = DVec2::new(
                    rf.range(ilo.x + 0.8, ihi.x - 0.8),
                    rf.range(ilo.y + 0.8, ihi.y - 0.8),
                );
                let a = rf.range(0.0, std::f64::consts::TAU);
                b.rotated(
                    &fname,
                    c,
                    DVec2::new(rf.range(0.6, 1.4), rf.range(0.4, 0.8)),
                    a,
                    zf - rf.range(0.0, 0.015),
                    zf + rf.range(0.4, 0.9),
                    [wood; 6],
                );
            }
        }
    }
}
