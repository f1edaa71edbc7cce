//! ugrad: progressive radiosity.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use clap::{Parser, ValueEnum};

const EXAMPLES: &str = "\
Examples:
  ugcut -l 0.5 clean.ug | ugrad > lit.ug             solve to 1e-3 unshot energy
  ugrad --converge 1e-4 -v patches.ug -o lit.ug      tighter, with statistics (-vv: a line per shot)
  ugrad --max-shots 50 --ambient patches.ug          a quick preview with an ambient term
  ugrad --gradient 0.05 --min-edge 0.02 patches.ug   finer adaptive subdivision
  ugrad --output irradiance patches.ug               write H instead of B
  ugrad --tail 0 patches.ug                          shoot patch by patch to the end (no tail)
  ugvlmerge < in.ug | ugrad > lit.ug                 faces that are not patches are meshed (one warning)
  ugrad --allow-dark unlit.ug                        no light: write the black model instead of failing";

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
    /// The GPU hemi-cube (wgpu), questionable vertices ray cast.
    Hemicube,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum MethodArg {
    Depth,
    Points,
    Decal,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum BackendArg {
    Auto,
    Vulkan,
    Gl,
}

/// Progressive radiosity on a patch-meshed UniGrafix model (Smith 1991).
///
/// The input should be patches: triangles and convex quadrilaterals (run
/// ugcut first to choose their size). Any other planar polygon is meshed
/// into patches as ugcut would (at --patch-length, ugcut's default), with one
/// warning. A model with nothing that emits light is an error unless
/// --allow-dark. Patches shoot their unshot energy to element vertices with the
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
    /// Scale the default --gradient by this factor (0.5: finer penumbrae and shadows; the Cornell
    /// box at `ugcut -l 3%`: max error 3.2% -> 2.3% against ugprobe, 1.4x the time).
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0, value_parser = cli::parse_epsilon)]
    gradient_scale: f64,
    /// … and by more than this fraction of the larger value (0: the absolute threshold alone).
    #[arg(long, value_name = "FRACTION", default_value_t = 0.0, value_parser = cli::parse_epsilon)]
    gradient_relative: f64,
    /// … unless their longest edge is below this length (default: an eighth of the mean patch edge).
    #[arg(long, value_parser = cli::parse_epsilon)]
    min_edge: Option<f64>,
    /// Quantity written as the vertex colours.
    #[arg(long = "output", value_enum, default_value = "radiosity")]
    quantity: OutputKind,
    /// Add a display ambient term for the energy not yet shot.
    #[arg(long)]
    ambient: bool,
    /// Once every emitter has shot and no patch carries more than this
    /// fraction of the unshot energy, move the rest patch to patch corner in
    /// one linear solve (the indirect tail: reflected light at patch
    /// resolution, every patch shooting at once). 0: shoot one patch at a
    /// time to the end.
    #[arg(long, default_value_t = 5e-3, value_name = "FRACTION", value_parser = fraction)]
    tail: f64,
    /// Rays from each patch centre that find the patches it sees in the
    /// tail (corners and split vertices then try what the centres around
    /// them see); 0 tries every patch everywhere (default: 0 up to 2,048
    /// patches or where the rays would find most patches anyway, else 512).
    #[arg(long, value_name = "N")]
    tail_rays: Option<usize>,
    /// After the tail, gather it exactly at split vertices where their
    /// parents' mean is in doubt (level by level), then split elements where
    /// its reflected light is steep (the gradient rule) and gather it at the
    /// new vertices, the steepest first: each at most this many times as
    /// many vertices as the patch corners that gathered it (0: never).
    #[arg(long, default_value_t = 1.0, value_name = "FRACTION", value_parser = cli::parse_epsilon)]
    tail_refine: f64,
    /// In the indirect tail, a cluster of one surface's patches shoots as
    /// one (the exact form factor of its outline, visibility from up to
    /// four of its patches) at receivers at least 1/R of its radius away;
    /// rows then grow with the log of the patches a point sees, not their
    /// number (0: every patch shoots alone).
    #[arg(long, default_value_t = radiosity::solver::TAIL_FAR, value_name = "R", value_parser = cli::parse_epsilon)]
    tail_far: f64,
    /// How visibility is decided. auto: the hemi-cube on a hardware GPU,
    /// else ray casting (on a software rasteriser such as lavapipe the CPU
    /// ray caster is faster).
    #[arg(long, value_enum, default_value = "auto")]
    visibility: VisibilityKind,
    /// With ray visibility, a shot at many vertices first rules out those
    /// hidden behind one big convex occluder (a wall, a floor, a patch of
    /// them) with a conservative occlusion cube of N × N cells a face around
    /// the shooter: the answers are the rays', only rays are saved (0: off).
    #[arg(long, default_value_t = 128, value_name = "N")]
    cull_res: usize,
    /// Hemi-cube resolution: pixels across its top face (a multiple of 64).
    #[arg(long, default_value_t = 512, value_name = "N", value_parser = hemicube_res)]
    hemicube_res: u32,
    /// How the hemi-cube finds visible vertices: depth (depth image and a
    /// compute test), points (vertex points with early depth test; needs
    /// SHADER_EARLY_DEPTH_TEST) or decal (the report's algorithm, §4.3–4.4).
    #[arg(long, value_enum, default_value = "depth")]
    hemicube_method: MethodArg,
    /// Graphics API for the hemi-cube.
    #[arg(long, value_enum, default_value = "auto")]
    gpu_backend: BackendArg,
    /// Patch length for faces that are not patches (meshed as ugcut -l
    /// would): model units or a percentage of the bounding-box diagonal.
    #[arg(long, value_name = "LEN", default_value = "2%")]
    patch_length: String,
    /// Write a black model when nothing emits light, instead of failing.
    #[arg(long)]
    allow_dark: bool,
    /// Give each vertex made by refinement the mean of its parents' light
    /// from earlier shots (§6's rule), instead of re-shooting those shots
    /// at it (the default: exact where earlier light is not linear along the
    /// split edge — a closed furnace is uniform to 1e-4 with it, ±8% without;
    /// a lamp's penumbra 5–7% too dark without it; only the shots whose
    /// light reached the edge are re-shot, by rays).
    #[arg(long)]
    no_regather: bool,
    /// (The default; kept for old scripts.)
    #[arg(long, hide = true)]
    regather: bool,
    /// A receiver in a shot's penumbra (it sees some of the shooter's pieces
    /// and not others, is a corner of an element that spans the shadow's
    /// edge, or lies near such a receiver: --penumbra-reach) finds its light
    /// from each piece by cutting the piece in four where the cell's corners
    /// disagree, down to 1/N of the piece (rounded up to a power of two; 1:
    /// off).
    #[arg(long, value_name = "N", default_value_t = 16)]
    penumbra_split: usize,
    /// Receivers within FACTOR × the shot's largest piece of one found in
    /// its penumbra are sampled as in the penumbra too: their piece centres
    /// agree while a shadow's edge crosses a piece (0: off; the penumbra of
    /// a finely meshed floor was 5.7% rms off without it, 0.4% with it).
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0, value_parser = cli::parse_epsilon)]
    penumbra_reach: f64,
    /// Take each shooter's light as uniform over it (the report's rule).
    /// By default it is shared over the shooter as its unshot radiosity
    /// lies, for receivers within two patch sizes of it and in the tail's
    /// first bounce: at a wall's foot the adjacent floor's light is then its
    /// light at the junction, not its patch's mean (junction vertices were
    /// +11 to +40% on the Cornell box and a nine-room building; see
    /// docs/decisions.md, "Shaped shooters").
    #[arg(long)]
    uniform_shooters: bool,
}

/// `--patch-length`: model units, or a percentage of the diagonal.
fn patch_length(arg: &str, model: &ug::Model, eps: f64) -> Result<f64, cli::Failure> {
    let diag = model.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length());
    let len = match arg.strip_suffix('%') {
        Some(p) => p.trim().parse::<f64>().ok().map(|p| p / 100.0 * diag),
        None => arg.trim().parse::<f64>().ok(),
    };
    match len {
        Some(l) if l.is_finite() && l > 10.0 * eps => Ok(l),
        _ => Err(cli::Failure::input(format!(
            "error: --patch-length '{arg}' is not a length or percentage above 10 × epsilon ({eps:e})"
        ))),
    }
}

fn hemicube_res(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(v) if (64..=8192).contains(&v) && v.is_multiple_of(64) => Ok(v),
        _ => Err(format!("'{s}' is not a multiple of 64 in 64..8192")),
    }
}

fn fraction(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a number between 0 and 1")),
    }
}

/// Large allocations (the per-vertex and per-element arrays) from `mmap`
/// instead of the heap: glibc otherwise raises its mmap threshold to the size
/// of the largest block freed so far (the input text), after which growing
/// arrays are copied within the heap and the space they leave stays resident
/// (with this, the peak resident memory of a solve is about a quarter lower).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn tune_allocator() {
    unsafe extern "C" {
        fn mallopt(param: i32, value: i32) -> i32;
    }
    const M_MMAP_THRESHOLD: i32 = -3;
    // SAFETY: mallopt only sets a glibc allocation parameter; it is called
    // first thing in main, before any other thread exists.
    unsafe {
        mallopt(M_MMAP_THRESHOLD, 128 * 1024);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn tune_allocator() {}

fn main() -> std::process::ExitCode {
    // SAFETY: first thing in main, before any thread exists.
    unsafe { gpu::prepare_env() };
    tune_allocator();
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        let t_start = Instant::now();
        let mut model = c.load_flat()?;
        let t_read = t_start.elapsed();
        let rss_input = memory_kb("VmRSS");
        let eps = cli::epsilon(args.epsilon, &model);
        let others = libmesh::not_patches(&model, eps);
        if !others.is_empty() {
            let len = patch_length(&args.patch_length, &model, eps)?;
            if !c.quiet {
                let (face, why) = &others[0];
                eprintln!(
                    "warning: {} face{} not patches (triangles or convex quadrilaterals; the first, {face}: {why}); meshed as `ugcut -l {len:.4}` would (run ugcut first to choose the patch size)",
                    others.len(),
                    if others.len() == 1 { " is" } else { "s are" },
                );
            }
            let opts = libmesh::patch::Options {
                len,
                eps,
                angle: 25.0,
                quads: true,
            };
            let (cut, _) = libmesh::patch::cut(&model, opts)
                .map_err(|e| cli::Failure::runtime(format!("error: {e}")))?;
            model = cut;
        }
        // Coincident faces (duplicates, a face written twice, front and
        // back copies) would each receive the light the other receives:
        // the energy grows with every bounce (a box whose walls were
        // written four times reached 700 times its emitted energy in 40
        // shots, and the tail's iteration overflowed). One of each pair
        // is left out, as ugclean's coincident step does.
        let (kept, st) = clean::coincident::clean(&model, eps);
        if !st.removed.is_empty() {
            if !c.quiet {
                let (gone, other, _) = &st.removed[0];
                eprintln!(
                    "warning: {} coincident face{} left out (the first, {gone}, coincides with {other}; run ugclean first to choose)",
                    st.removed.len(),
                    if st.removed.len() == 1 { "" } else { "s" },
                );
            }
            model = kept;
        }
        let mesh = libmesh::Mesh::from_model(&model, eps)
            .map_err(|e| cli::Failure::input(format!("error: {e}")))?;
        if !c.quiet {
            let d = mesh.degenerate_faces();
            for (face, reason) in d.iter().take(5) {
                eprintln!("warning: face {face}: {reason}; left out (it has no area to light)");
            }
            if d.len() > 5 {
                eprintln!("warning: {} more degenerate faces left out", d.len() - 5);
            }
        }
        let backend = match args.gpu_backend {
            BackendArg::Auto => gpu::Backend::Auto,
            BackendArg::Vulkan => gpu::Backend::Vulkan,
            BackendArg::Gl => gpu::Backend::Gl,
        };
        let hc_opts = hemicube::Options {
            res: args.hemicube_res,
            method: match args.hemicube_method {
                MethodArg::Depth => hemicube::Method::Depth,
                MethodArg::Points => hemicube::Method::Points,
                MethodArg::Decal => hemicube::Method::Decal,
            },
            ..Default::default()
        };
        let request = gpu::Request {
            backend,
            optional: hemicube::POINTS_FEATURE,
            ..Default::default()
        };
        let choice = match args.visibility {
            VisibilityKind::Auto => hemicube::Choice::Auto,
            VisibilityKind::Ray => hemicube::Choice::Ray,
            VisibilityKind::Hemicube => hemicube::Choice::Hemicube,
        };
        let chosen = hemicube::choose(choice, &mesh, &request, hc_opts)
            .map_err(|e| cli::Failure::runtime(format!("error: {e}")))?;
        if let Some(d) = chosen.detail {
            c.verbose(d);
        }
        if let (Some(n), false) = (chosen.note, c.quiet) {
            eprintln!("{n}");
        }
        let hc = chosen.hemicube;
        let ray;
        let vis: &dyn radiosity::Visibility = match &hc {
            Some(h) => h,
            None => {
                ray = radiosity::RayVisibility::new(&mesh);
                &ray
            }
        };
        let opts = radiosity::Options {
            converge: args.converge,
            max_shots: args.max_shots,
            time_limit: args.time_limit.map(Duration::from_secs_f64),
            batch: args.batch,
            penumbra_energy: args.penumbra_energy,
            penumbra_size: args.penumbra_size,
            gradient: args.gradient,
            gradient_scale: args.gradient_scale,
            gradient_relative: args.gradient_relative,
            min_edge: args.min_edge,
            output: match args.quantity {
                OutputKind::Radiosity => radiosity::Output::Radiosity,
                OutputKind::Irradiance => radiosity::Output::Irradiance,
            },
            ambient: args.ambient,
            tail: args.tail,
            tail_rays: args.tail_rays,
            tail_refine: args.tail_refine,
            tail_far: args.tail_far,
            regather: !args.no_regather,
            shape: !args.uniform_shooters,
            cull_res: args.cull_res,
            penumbra_split: args.penumbra_split.max(1),
            penumbra_reach: args.penumbra_reach,
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
        let mut solver = radiosity::Solver::new(mesh, &model.materials, vis, opts);
        if solver.emitted() <= 0.0 && !args.allow_dark {
            return Err(cli::Failure::runtime(
                "error: nothing in the model emits light: no face has a material with an emission. \
                 Give the lights a material that emits, for example\n  \
                 defmat lamp; diffuse_rgb 0.8 0.8 0.8; emission_rgb 10 10 10; end;\n\
                 and name it on their faces; or pass --allow-dark to write the black model",
            ));
        }
        // The output needs only the input's names, colours, materials and
        // non-geometry statements: drop its geometry.
        model.items.retain(|it| {
            !matches!(
                it,
                ug::Item::Vertex(_) | ug::Item::Face(_) | ug::Item::Wire(_)
            )
        });
        model.items.shrink_to_fit();
        for f in &mut model.faces {
            f.contours = Vec::new();
        }
        for w in &mut model.wires {
            w.polylines = Vec::new();
        }
        let (g, m, p) = solver.thresholds();
        c.verbose(format!(
            "{} patches on {} surfaces, {} vertices; emitted {:.6e}; gradient {g:.4e}, min edge {m:.4e}, penumbra size {p:.4e}; epsilon {eps:e}",
            solver.mesh.num_patches(),
            solver.mesh.num_surfaces(),
            solver.mesh.num_vertices(),
            solver.emitted()
        ));
        let bar = c.progress(1000, "unshot energy");
        // One line per shot only with -vv (-v: the set-up and the end).
        let verbose = c.verbose > 1;
        let t_solve = Instant::now();
        let t_setup = t_start.elapsed() - t_read;
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
        if stop == radiosity::Stop::Diverged {
            return Err(cli::Failure::runtime(format!(
                "error: the light grows without end (after {} shots the unshot energy is over {} times the emitted): faces lie on one another, each receiving the light of the other; run ugcopl and ugclean first (or the whole cleaning chain)",
                solver.shots.len(),
                radiosity::DIVERGED,
            )));
        }
        let t_solve = t_solve.elapsed();
        if !c.quiet {
            match stop {
                radiosity::Stop::Dark => {
                    eprintln!(
                        "warning: nothing in the model emits light; every vertex is dark (--allow-dark)"
                    )
                }
                radiosity::Stop::Interrupted => {
                    eprintln!("note: interrupted; writing the solution so far")
                }
                _ => {}
            }
        }
        if let Some(t) = &solver.tail {
            c.verbose(format!(
                "indirect tail after shot {}: {} patch centres ({} pairs stored, {:.1} MB with the geometry; {}), {} iterations; unshot {:.3e} -> {:.3e}; {} corners gathered; {:.2} s to build, {:.3} s to iterate, {:.2} s for the corners; {} split vertices checked, {:.2} s; {} elements refined after it, {} vertices gathered, {:.2} s",
                t.after_shots,
                solver.mesh.num_patches(),
                t.pairs,
                t.bytes as f64 / 1e6,
                match (t.rays, t.clusters) {
                    (0, 0) => "every patch tried".to_string(),
                    (0, k) => format!("every patch tried, {k} far-field clusters"),
                    (r, 0) => format!("{r} rays per point"),
                    (r, k) => format!("{r} rays per point, {k} far-field clusters"),
                },
                t.iterations,
                t.unshot_before,
                t.unshot_after,
                t.receivers,
                t.build_seconds,
                t.iterate_seconds,
                t.corner_seconds,
                t.checked,
                t.check_seconds,
                t.refined,
                t.regathered,
                t.refine_seconds
            ));
        }
        c.verbose(format!(
            "stopped ({stop:?}) after {} shots; {} leaf elements, {} vertices; unshot {:.3e} of the emitted energy",
            solver.shots.len(),
            solver.mesh.num_leaves(),
            solver.mesh.num_vertices(),
            solver.unshot_fraction()
        ));
        if let Some(h) = &hc {
            let st = h.stats();
            c.verbose(format!(
                "hemi-cube: {} visibility calls, {} vertices tested, {} questionable and ray cast ({:.2}%), {} calls fell back to rays",
                st.shots,
                st.candidates,
                st.questionable,
                100.0 * st.questionable as f64 / st.candidates.max(1) as f64,
                st.fallbacks
            ));
            if let Some(e) = h.last_error() {
                eprintln!(
                    "warning: the GPU failed during the solve; those shots used ray casting: {e}"
                );
            }
        }
        // Streamed: the output model and its text are never held in memory.
        solver.release_scratch();
        let t_write = Instant::now();
        cli::write_streamed(c.output.as_deref(), |w| solver.write_ug(&model, w))?;
        // Timings (wall clock): for benches/pipeline.sh and docs/performance.md.
        c.verbose(format!(
            "time: read {:.3} s, mesh and set-up {:.3} s, solve {:.3} s ({} shots, {:.2} ms per shot), write {:.3} s",
            t_read.as_secs_f64(),
            t_setup.as_secs_f64(),
            t_solve.as_secs_f64(),
            solver.shots.len(),
            1e3 * t_solve.as_secs_f64() / solver.shots.len().max(1) as f64,
            t_write.elapsed().as_secs_f64()
        ));
        if let (Some(input), Some(peak)) = (rss_input, memory_kb("VmHWM")) {
            let leaves = solver.mesh.num_leaves().max(1) as f64;
            c.verbose(format!(
                "memory: peak RSS {:.1} MB, {:.1} MB after reading the input; {} leaf elements, {} vertices: {:.0} bytes per leaf element over the input ({:.0} in all)",
                peak as f64 / 1024.0,
                input as f64 / 1024.0,
                solver.mesh.num_leaves(),
                solver.mesh.num_vertices(),
                peak.saturating_sub(input) as f64 * 1024.0 / leaves,
                peak as f64 * 1024.0 / leaves,
            ));
        }
        Ok(())
    })
}

/// A field of /proc/self/status in kB (`VmRSS`: resident now, `VmHWM`: peak
/// resident); `None` where there is no such file.
fn memory_kb(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line[field.len() + 1..]
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()
}
