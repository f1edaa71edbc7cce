//! ugbuilding: a generated building model, for benchmarks and experiments.

use clap::{CommandFactory, FromArgMatches, Parser};

const EXAMPLES: &str = "\
Examples:
  ugbuilding --rooms 10 > clean.ug                      a clean 10 × 10 grid of rooms (940 faces)
  ugbuilding --faces 10000 --messy --seed 7 -o m.ug     about 10,000 faces with every kind of dirt
  ugbuilding --faces 1000 --nonplanar 0.2 | ugplanar -v   20% of the faces non-planar
  ugbuilding --rooms 3 --lights --furniture 2 | ugcheck   lit, furnished rooms; furniture stands on the floors
  ugbuilding --faces 10000 --messy | ugplanar | ugflip | ugvlmerge | ugcut -l 1 | ugrad --max-shots 100
  ugbuilding --cad --faces 8600 --storeys 2 -o house.ug   drawn as CAD exports it (slabs, wall runs, openings, ...)
  ugbuilding --cad --rooms 2 --storeys 3 --seed 5         a small three-storey one
  ugbuilding --cad --faces 2000 --triangles                exported as triangles (STL-like)
  ugbuilding --cad --rooms 3 --wing --pitched --seed 4    an oblique wing and a pitched roof
  ugbuilding --cad --rooms 2 --stairs                     stairs and ramps in some rooms
  ugbuilding --cad --rooms 2 --curved                     round columns, globe lamps, pipes";

/// Generate a CAD-like building as UniGrafix: a grid of 4 × 5 × 3 rooms
/// (metres) with floors of 2 × 2 quads, walls of a lower and an upper face,
/// and one ceiling quad per room.
///
/// The clean building has no defect. Dirt is added at random places drawn
/// from the seed (the same arguments always give the same model): flipped
/// faces, non-planar floor quads, nearly coincident vertices, T-vertices;
/// and ceiling lights (emitters) and furniture boxes standing on the floors.
/// Fractions are exact: round(fraction × n) items are chosen.
///
/// --cad draws a different building, the way CAD programs export one:
/// slabs, walls as box slabs in overlapping runs that interpenetrate at the
/// junctions, doors and windows of piers, sills, lintels and glass, tiled
/// floors, desks, cabinets pushed into walls and rotated boxes, rugs, papers
/// and pictures lying on other faces, columns and vaults with non-planar
/// faces, flush ceiling panels and hanging light boxes, several storeys;
/// then random flips, duplicate faces and vertex jitter (1e-7 of the size).
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Rooms along x and y (N × N).
    #[arg(long, value_name = "N", conflicts_with_all = ["faces", "rooms_x"], value_parser = clap::value_parser!(u32).range(1..=2000))]
    rooms: Option<u32>,
    /// Rooms along x (with --rooms-y).
    #[arg(long, value_name = "X", requires = "rooms_y", conflicts_with = "faces", value_parser = clap::value_parser!(u32).range(1..=2000))]
    rooms_x: Option<u32>,
    /// Rooms along y (with --rooms-x).
    #[arg(long, value_name = "Y", requires = "rooms_x", value_parser = clap::value_parser!(u32).range(1..=2000))]
    rooms_y: Option<u32>,
    /// About this many faces: the nearly square grid of rooms that comes nearest.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=50_000_000))]
    faces: Option<u64>,
    /// Draw the CAD-like building (see above); --rooms, --rooms-x/-y or
    /// --faces size each storey's grid; --flipped and --furniture apply.
    #[arg(long, conflicts_with_all = ["messy", "grouper"])]
    cad: bool,
    /// Storeys of the --cad building.
    #[arg(long, default_value_t = 2, requires = "cad", value_parser = clap::value_parser!(u32).range(1..=50))]
    storeys: u32,
    /// Export the --cad building as triangles, each on vertex records of its
    /// own (as an STL or a triangulated OBJ export does): every convex face
    /// fanned from its first vertex.
    #[arg(long, requires = "cad")]
    triangles: bool,
    /// Add a one-storey wing to the --cad building's +x facade, its plan
    /// sheared by an arbitrary angle (2–50°), so that its walls and slabs
    /// meet the facade and each other obliquely.
    #[arg(long, requires = "cad")]
    wing: bool,
    /// Put a pitched roof on the --cad building: sloped box slabs meeting
    /// past the ridge, overhanging eaves crossing the top slab's edge, and
    /// gable walls running into the roof.
    #[arg(long, requires = "cad")]
    pitched: bool,
    /// Put a flight of steps or a ramp in about half the --cad building's
    /// rooms: steps as boxes sunk into the floor, each overlapping the
    /// next; ramps as wedges whose slope meets the floor at 2.9–7.1°.
    #[arg(long, requires = "cad")]
    stairs: bool,
    /// Put curved things, tessellated, in about half the --cad building's
    /// rooms: a round column through the floor into the ceiling slab, a
    /// globe lamp whose pole touches or pokes into the ceiling, and a pipe
    /// running obliquely across the room into the walls.
    #[arg(long, requires = "cad")]
    curved: bool,
    /// Seed of the random choices.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Start from every kind of dirt: 30% flipped, 10% non-planar, half the
    /// walls with T-vertices and nearly coincident vertices, a light and two
    /// boxes a room (the flags below override).
    #[arg(long)]
    messy: bool,
    /// The grouper's dirt (every wall with a T-vertex and nearly coincident vertices).
    #[arg(long, conflicts_with = "messy")]
    grouper: bool,
    /// Fraction of all faces written reversed.
    #[arg(long, value_name = "F", value_parser = fraction)]
    flipped: Option<f64>,
    /// Fraction of all faces made non-planar (floor quads, at most 4 a room).
    #[arg(long, value_name = "F", value_parser = fraction)]
    nonplanar: Option<f64>,
    /// How far a non-planar quad's corner moves (model units).
    #[arg(long, value_name = "LEN", value_parser = cli::parse_epsilon)]
    lift: Option<f64>,
    /// Fraction of walls and of ceilings with nearly coincident vertex copies.
    #[arg(long, value_name = "F", value_parser = fraction)]
    coincident: Option<f64>,
    /// Distance of the nearly coincident copies.
    #[arg(long, value_name = "LEN", value_parser = cli::parse_epsilon)]
    offset: Option<f64>,
    /// Fraction of walls with a T-vertex at their foot.
    #[arg(long, value_name = "F", value_parser = fraction)]
    tvertices: Option<f64>,
    /// A 1 × 1 ceiling light (emitter) in every room, 1 cm below the ceiling.
    #[arg(long)]
    lights: bool,
    /// No lights (with --messy).
    #[arg(long, conflicts_with = "lights")]
    no_lights: bool,
    /// Furniture boxes per room, 0 to 4.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(0..=4))]
    furniture: Option<u8>,
}

fn fraction(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a number between 0 and 1")),
    }
}

fn main() -> std::process::ExitCode {
    // The input file and --strict of the common flags mean nothing here.
    let cmd = Args::command()
        .mut_arg("input", |a| a.hide(true))
        .mut_arg("strict", |a| a.hide(true));
    let args = match Args::from_arg_matches(&cmd.get_matches()) {
        Ok(a) => a,
        Err(e) => e.exit(),
    };
    cli::run(|| {
        let c = &args.common;
        if c.input.is_some() {
            return Err(cli::Failure::input(
                "error: ugbuilding reads no input (did you mean -o FILE?)",
            ));
        }
        if args.cad {
            let storeys = args.storeys as usize;
            let mut cfg = match (args.rooms, args.rooms_x.zip(args.rooms_y), args.faces) {
                (Some(n), _, _) => building::Cad {
                    rooms_x: n as usize,
                    rooms_y: n as usize,
                    storeys,
                    ..building::Cad::default()
                },
                (_, Some((x, y)), _) => building::Cad {
                    rooms_x: x as usize,
                    rooms_y: y as usize,
                    storeys,
                    ..building::Cad::default()
                },
                (_, _, Some(f)) => building::Cad::for_faces(f as usize, storeys, args.seed),
                _ => building::Cad {
                    storeys,
                    ..building::Cad::default()
                },
            };
            if let Some(v) = args.flipped {
                cfg.flipped = v;
            }
            if let Some(v) = args.furniture {
                cfg.furniture = v as usize;
            }
            cfg.triangles = args.triangles;
            cfg.wing = args.wing;
            cfg.pitched = args.pitched;
            cfg.stairs = args.stairs;
            cfg.curved = args.curved;
            let model = building::cad(&cfg, args.seed);
            c.verbose(format!(
                "{} storeys of {} × {} rooms, {} faces, {} vertices; seed {}",
                cfg.storeys,
                cfg.rooms_x,
                cfg.rooms_y,
                model.faces.len(),
                model.vertices.len(),
                args.seed
            ));
            return c.write_model(&model);
        }
        let mut dirt = if args.messy {
            building::Dirt::messy()
        } else if args.grouper {
            building::Dirt::grouper()
        } else {
            building::Dirt::default()
        };
        if let Some(v) = args.flipped {
            dirt.flipped = v;
        }
        if let Some(v) = args.nonplanar {
            dirt.nonplanar = v;
        }
        if let Some(v) = args.lift {
            dirt.lift = v;
        }
        if let Some(v) = args.coincident {
            dirt.coincident = v;
        }
        if let Some(v) = args.offset {
            dirt.offset = v;
        }
        if let Some(v) = args.tvertices {
            dirt.tvertices = v;
        }
        if args.lights {
            dirt.lights = true;
        }
        if args.no_lights {
            dirt.lights = false;
        }
        if let Some(v) = args.furniture {
            dirt.furniture = v as usize;
        }
        let (x, y) = match (args.rooms, args.rooms_x.zip(args.rooms_y), args.faces) {
            (Some(n), _, _) => (n as usize, n as usize),
            (_, Some((x, y)), _) => (x as usize, y as usize),
            (_, _, Some(f)) => building::rooms_for_faces(f as usize, &dirt),
            _ => {
                return Err(cli::Failure::input(
                    "error: say how big: --rooms N, --rooms-x X --rooms-y Y or --faces N",
                ));
            }
        };
        let model = building::generate(x, y, &dirt, args.seed);
        c.verbose(format!(
            "{x} × {y} rooms, {} faces, {} vertices; seed {}; {dirt:?}",
            model.faces.len(),
            model.vertices.len(),
            args.seed
        ));
        c.write_model(&model)
    })
}
