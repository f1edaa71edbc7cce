//! ugrad: progressive radiosity.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use clap::{Parser, ValueEnum};

const EXAMPLES: &str = "\
Examples:
  ugcut -l 0.5 clean.ug | ugrad > lit.ug             solve to 1e-3 unshot energy
  ugrad --converge 1e-4 -v patches.ug -o lit.ug      tighter, with per-shot statistics
  ugrad --max-shots 50 --ambient patches.ug          a quick preview with an ambient term
  ugrad --gradient 0.05 --min-edge 0.02 patches.ug   finer adaptive subdivision
  ugrad --output irradiance patches.ug               write H instead of B";

#[derive(Clone, Copy, Debug, ValueEnum)]
enum OutputKind {
    Radiosity,
    Irradiance,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum VisibilityKind {
    /// Hemi-cube on the GPU when an adapter exists, else ray casting.
    Auto,
    /// CPU ray casting against a BVH (the reference).
    Ray,
    /// The GPU hemi-cube (not in this build yet).
    Hemicube,
}

/// Progressive radiosity on a patch-meshed UniGrafix model (Smith 1991).
///
/// The input must be patches: triangles and convex quadrilaterals (run ugcut
/// first). Patches shoot their unshot energy to element vertices with the
/// exact point-to-polygon form factor; bright shooters are subdivided for
/// penumbrae; elements whose radiosity changes steeply across an edge are
/// refined. The output is UG with a colour on every vertex: radiosity B
/// (exitance; radiance for display is B/π) or irradiance H. The current
/// solution is written at convergence, at --max-shots, at --time-limit and on
/// Ctrl-C.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
    /// Stop when the unshot energy falls below this fraction of the emitted energy.
    #[arg(long, default_value_t = 1e-3, value_parser = fraction)]
    converge: f64,
    /// Stop after this many shots.
    #[arg(long)]
    max_shots: Option<usize>,
    /// Stop after this many seconds.
    #[arg(long, value_name = "SECONDS", value_parser = cli::parse_epsilon)]
    time_limit: Option<f64>,
    /// Patches taken per batch of brightest shooters (§5.2).
    #[arg(long, default_value_t = 20)]
    batch: usize,
    /// Subdivide a shooter while a piece carries more than this fraction of the emitted energy (§5.3).
    #[arg(long, default_value_t = 0.02, value_parser = fraction)]
    penumbra_energy: f64,
    /// … and its longest edge exceeds this length (default: half the mean patch edge).
    #[arg(long, value_parser = cli::parse_epsilon)]
    penumbra_size: Option<f64>,
    /// Split elements whose radiosity differs across an edge by more than this (default: 0.1 × mean emitted power per area).
    #[arg(long, value_parser = cli::parse_epsilon)]
    gradient: Option<f64>,
    /// … unless their longest edge is below this length (default: an eighth of the mean patch edge).
    #[arg(long, value_parser = cli::parse_epsilon)]
    min_edge: Option<f64>,
    /// Quantity written as the vertex colours.
    #[arg(long = "output", value_enum, default_value = "radiosity")]
    quantity: OutputKind,
    /// Add a display ambient term for the energy not yet shot.
    #[arg(long)]
    ambient: bool,
    /// How visibility is decided.
    #[arg(long, value_enum, default_value = "auto")]
    visibility: VisibilityKind,
}

fn fraction(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a number between 0 and 1")),
    }
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        let model = c.load_flat()?;
        let eps = cli::epsilon(args.epsilon, &model);
        let mesh = libmesh::Mesh::from_model(&model, eps)
            .map_err(|e| cli::Failure::input(format!("error: {e}")))?;
        match args.visibility {
            VisibilityKind::Hemicube => {
                return Err(cli::Failure::runtime(
                    "error: the GPU hemi-cube is not part of this build yet; use --visibility ray",
                ));
            }
            VisibilityKind::Auto => c.verbose("note: visibility by CPU ray casting (the GPU hemi-cube is not part of this build yet)"),
            VisibilityKind::Ray => {}
        }
        let vis = radiosity::RayVisibility::new(&mesh);
        let opts = radiosity::Options {
            converge: args.converge,
            max_shots: args.max_shots,
            time_limit: args.time_limit.map(Duration::from_secs_f64),
            batch: args.batch,
            penumbra_energy: args.penumbra_energy,
            penumbra_size: args.penumbra_size,
            gradient: args.gradient,
            min_edge: args.min_edge,
            output: match args.quantity {
                OutputKind::Radiosity => radiosity::Output::Radiosity,
                OutputKind::Irradiance => radiosity::Output::Irradiance,
            },
            ambient: args.ambient,
            ..radiosity::Options::default()
        };
        let interrupt = Arc::new(AtomicBool::new(false));
        {
            let flag = interrupt.clone();
            // A second Ctrl-C, or a failure to install the handler, falls back to the default.
            let _ = ctrlc::set_handler(move || {
                if flag.swap(true, Ordering::SeqCst) {
                    std::process::exit(130);
                }
            });
        }
        let mut solver = radiosity::Solver::new(mesh, &model.materials, &vis, opts);
        let (g, m, p) = solver.thresholds();
        c.verbose(format!(
            "{} patches on {} surfaces, {} vertices; emitted {:.6e}; gradient {g:.4e}, min edge {m:.4e}, penumbra size {p:.4e}; epsilon {eps:e}",
            solver.mesh.num_patches(),
            solver.mesh.num_surfaces(),
            solver.mesh.num_vertices(),
            solver.emitted()
        ));
        let bar = c.progress(1000, "unshot energy");
        let verbose = c.verbose > 0;
        let stop = solver.solve(Some(interrupt), |s| {
            if verbose {
                bar.suspend(|| {
                    eprintln!(
                        "shot {:>5}: patch {:>6}  energy {:.4e}  received {:.4e}  shooters {:>3}  vertices {:>7}  subdivided {:>5}  {:.3} s  unshot {:.3e}",
                        s.shot, s.patch, s.energy, s.received, s.shooters, s.vertices_reached, s.subdivided, s.seconds, s.unshot
                    )
                });
            }
            let done = (1.0 - s.unshot.clamp(0.0, 1.0)) * 1000.0;
            bar.set_position(done as u64);
        });
        bar.finish_and_clear();
        let out = solver.to_model(&model);
        if !c.quiet {
            match stop {
                radiosity::Stop::Dark => {
                    eprintln!("warning: nothing in the model emits light; every vertex is dark")
                }
                radiosity::Stop::Interrupted => {
                    eprintln!("note: interrupted; writing the solution so far")
                }
                _ => {}
            }
        }
        c.verbose(format!(
            "stopped ({stop:?}) after {} shots; {} leaf elements, {} vertices; unshot {:.3e} of the emitted energy",
            solver.shots.len(),
            solver.mesh.num_leaves(),
            solver.mesh.num_vertices(),
            solver.shots.last().map_or(1.0, |s| s.unshot)
        ));
        c.write_model(&out)
    })
}
