//! ugprobe: an independent estimate of radiosity at points of a model, and
//! its comparison with a lit model.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use clap::{Parser, ValueEnum};
use cli::Failure;
use glam::DVec3;
use probe::{Estimate, Options, Receiver, Scene};

const EXAMPLES: &str = "\
Examples:
  ugprobe model.ug --points pts.txt                 B at the points (x y z nx ny nz per line)
  ugprobe model.ug --points pts.txt --target-se 0.005 --format tsv
                                                    sample until 0.5% standard error; tab-separated
  ugprobe model.ug --random 100 --seed 7            B at 100 random points on faces that do not emit
  ugcut -l 5% model.ug | ugrad -q > lit.ug && ugprobe --compare lit.ug model.ug --random 200
                                                    how far ugrad's solution is from the estimate";

#[derive(Clone, Copy, Debug, ValueEnum)]
enum Format {
    /// Columns separated by single spaces.
    Text,
    /// Columns separated by tabs.
    Tsv,
}

/// An independent check of a radiosity solution: Monte Carlo path tracing
/// with next-event estimation at points of a UniGrafix model.
///
/// The model is read as ugrad reads it: one-sided Lambertian faces, the
/// front the side from which the outer contour runs counter-clockwise,
/// emission_rgb E the exitance of the front, diffuse_rgb or c_rgb the
/// reflectance ρ; light reaching the back of a face is absorbed. At each
/// point B = E + ρH, with H the irradiance on the side the point's normal
/// names and E, ρ those of the face the point lies on (within --tolerance,
/// facing that side). H is estimated from paths that sample the emitters at
/// every bounce (next-event estimation), continue in cosine-distributed
/// directions (emitters they meet weighed against the emitter samples by
/// multiple importance sampling) and end by Russian roulette; nothing of
/// ugrad's meshing, form
/// factors or visibility is used. Every point has its own random stream
/// (from --seed and its position in the list): the output is the same at
/// any thread count.
///
/// Output: a header line starting with '#', then one line per point:
/// x y z nx ny nz B_r B_g B_b se_r se_g se_b (se: standard errors).
///
/// With --compare LIT, the radiosity of the lit model LIT (ugrad's output:
/// a colour on every vertex) is interpolated at the points (linearly on the
/// triangles of its faces; quadrilaterals split along the diagonal from
/// their first vertex) and compared in luminance Y = 0.2126 r + 0.7152 g +
/// 0.0722 b: the error of a point is (Y_lit − Y_ref) / max(Y_ref, 0.05 ×
/// mean Y_ref). The worst points are listed, then a last line
/// `rms X% max Y% n N se Z%`: the rms and largest |error|, the number of
/// points compared and the rms of the estimates' own relative standard
/// errors (rms² ≈ true rms² + se²). Points on no face of LIT are reported
/// on stderr and left out.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// The points: a file of `x y z nx ny nz` lines ('#' comments, blank
    /// lines allowed; '-' for stdin).
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with = "random",
        required_unless_present = "random"
    )]
    points: Option<PathBuf>,
    /// N random points on the faces that do not emit light, by area, each
    /// at least --margin of its face's size (√area) from its edges.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
    random: Option<u64>,
    /// Compare with the lit model LIT (ugrad's output) at the points.
    #[arg(long, value_name = "LIT")]
    compare: Option<PathBuf>,
    /// Paths per point; with --target-se, paths per batch.
    #[arg(long, value_name = "N", default_value_t = 4096, value_parser = clap::value_parser!(u64).range(2..))]
    samples: u64,
    /// Add batches of --samples paths until the standard error of the
    /// luminance of B is at most this fraction of it (or --max-samples).
    #[arg(long, value_name = "F", value_parser = positive)]
    target_se: Option<f64>,
    /// The most paths per point with --target-se.
    #[arg(long, value_name = "N", default_value_t = 1 << 20, value_parser = clap::value_parser!(u64).range(2..))]
    max_samples: u64,
    /// Seed of the random streams (and of --random's points).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// How far a point may be from the plane of its face (and, with
    /// --compare, from the lit model's faces): model units, or a percentage
    /// of the model's bounding-box diagonal.
    #[arg(long, value_name = "LEN", default_value = "0.5%")]
    tolerance: String,
    /// --random: the clearance from a face's edges, as a fraction of its size.
    #[arg(long, value_name = "F", default_value_t = 0.01, value_parser = fraction)]
    margin: f64,
    /// --compare: how many of the worst points to list.
    #[arg(long, value_name = "N", default_value_t = 10)]
    worst: usize,
    /// --compare: also compare points that no light reaches (enclosed
    /// pieces: reference exactly 0); left out by default.
    #[arg(long)]
    keep_unreached: bool,
    /// Column separator of the output.
    #[arg(long, value_enum, default_value = "text")]
    format: Format,
}

fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a positive number")),
    }
}

fn fraction(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..0.5).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a number in [0, 0.5)")),
    }
}

/// `--tolerance`: model units, or a percentage of the diagonal.
fn tolerance(arg: &str, diag: f64) -> Result<f64, Failure> {
    let v = match arg.strip_suffix('%') {
        Some(p) => p.trim().parse::<f64>().ok().map(|p| p / 100.0 * diag),
        None => arg.trim().parse::<f64>().ok(),
    };
    match v {
        Some(t) if t.is_finite() && t >= 0.0 => Ok(t),
        _ => Err(Failure::input(format!(
            "error: --tolerance '{arg}' is not a length or a percentage"
        ))),
    }
}

/// A point to estimate: where it came from and what it is.
struct Query {
    /// As given (or drawn).
    position: DVec3,
    normal: DVec3,
    receiver: Receiver,
}

fn name_of(p: Option<&std::path::Path>) -> String {
    match p {
        Some(p) if p != std::path::Path::new("-") => p.display().to_string(),
        _ => "<stdin>".to_string(),
    }
}

fn is_stdin(p: Option<&std::path::Path>) -> bool {
    p.is_none_or(|p| p == std::path::Path::new("-"))
}

/// Shortest round-trip form.
fn exact(v: f64) -> String {
    let mut b = ryu::Buffer::new();
    if v.is_finite() {
        ug::fmt_f64(v, &mut b).to_string()
    } else {
        v.to_string()
    }
}

/// Six significant digits, shortest form.
fn sig(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let r: f64 = format!("{v:.5e}").parse().unwrap_or(v);
    exact(r)
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    cli::run(|| run(&args))
}

fn run(args: &Args) -> Result<(), Failure> {
    let c = &args.common;
    let t0 = Instant::now();
    if args.points.is_some() && is_stdin(args.points.as_deref()) && is_stdin(c.input.as_deref()) {
        return Err(Failure::input(
            "error: the model and --points cannot both be read from stdin",
        ));
    }
    let model = c.load_flat()?;
    let model_name = name_of(c.input.as_deref());
    let scene =
        Scene::new(&model).map_err(|e| Failure::input(format!("{model_name}: error: {e}")))?;
    if !c.quiet {
        let s = scene.skipped();
        for (face, why) in s.iter().take(5) {
            eprintln!("warning: face {face}: {why}; left out");
        }
        if s.len() > 5 {
            eprintln!("warning: {} more faces left out", s.len() - 5);
        }
        if !scene.has_emitters() && args.compare.is_none() {
            eprintln!("warning: nothing in the model emits light: every B is 0");
        }
    }
    let tol = tolerance(&args.tolerance, scene.diagonal())?;
    let queries = match &args.points {
        Some(path) => {
            let pc = cli::Common {
                input: Some(path.clone()),
                ..Default::default()
            };
            let input = pc.read_input()?;
            let pts = probe::points::parse(&input.bytes, &input.name).map_err(Failure::input)?;
            let mut q = Vec::with_capacity(pts.len());
            for p in pts {
                let Some(at) = scene.locate(p.position, p.normal, tol) else {
                    return Err(Failure::input(format!(
                        "{}:{}:1: error: the point ({} {} {}) lies on no face whose front faces ({} {} {}) within --tolerance {}",
                        input.name,
                        p.line,
                        exact(p.position.x),
                        exact(p.position.y),
                        exact(p.position.z),
                        exact(p.normal.x),
                        exact(p.normal.y),
                        exact(p.normal.z),
                        sig(tol)
                    )));
                };
                q.push(Query {
                    position: p.position,
                    normal: p.normal,
                    receiver: scene.receiver(&at),
                });
            }
            q
        }
        None => {
            let n = args.random.unwrap_or(0) as usize;
            scene
                .sample_points(n, args.seed, args.margin)
                .map_err(|e| Failure::input(format!("{model_name}: error: {e}")))?
                .into_iter()
                .map(|s| {
                    let f = &scene.faces()[s.face];
                    Query {
                        position: s.point,
                        normal: s.normal,
                        receiver: Receiver {
                            point: s.point,
                            normal: s.normal,
                            rho: f.rho,
                            emission: f.emission,
                        },
                    }
                })
                .collect()
        }
    };
    // Read the lit model before the long part, so that its errors come at once.
    let lit = match &args.compare {
        Some(path) => {
            let lc = cli::Common {
                input: Some(path.clone()),
                quiet: c.quiet,
                strict: c.strict,
                ..Default::default()
            };
            let m = lc.load_flat()?;
            let name = name_of(Some(path));
            Some((
                probe::lit::Lit::new(&m)
                    .map_err(|e| Failure::input(format!("{name}: error: {e}")))?,
                name,
            ))
        }
        None => None,
    };
    let opts = Options {
        samples: args.samples,
        target_se: args.target_se,
        max_samples: args.max_samples.max(args.samples),
        seed: args.seed,
        ..Options::default()
    };
    let receivers: Vec<Receiver> = queries.iter().map(|q| q.receiver).collect();
    let bar = c.progress(receivers.len() as u64, "points");
    let t1 = Instant::now();
    let est = scene.estimate_all(&receivers, &opts, &|| bar.inc(1));
    bar.finish_and_clear();
    let paths: u64 = est.iter().map(|e| e.samples).sum();
    c.verbose(format!(
        "{} faces ({} triangles), {} points, {paths} paths in {:.3} s ({:.3} s in all); tolerance {}",
        scene.faces().len(),
        scene.triangles().len(),
        est.len(),
        t1.elapsed().as_secs_f64(),
        t0.elapsed().as_secs_f64(),
        sig(tol)
    ));
    let sep = match args.format {
        Format::Text => " ",
        Format::Tsv => "\t",
    };
    let out = match &lit {
        None => table(&queries, &est, sep),
        Some((lit, lit_name)) => report(args, &queries, &est, lit, lit_name, tol, sep)?,
    };
    c.write(out.as_bytes())
}

/// The per-point table.
fn table(queries: &[Query], est: &[Estimate], sep: &str) -> String {
    let mut s = String::with_capacity(128 * (queries.len() + 1));
    s.push_str("# ");
    s.push_str(
        &[
            "x", "y", "z", "nx", "ny", "nz", "B_r", "B_g", "B_b", "se_r", "se_g", "se_b",
        ]
        .join(sep),
    );
    s.push('\n');
    for (q, e) in queries.iter().zip(est) {
        let mut cols: Vec<String> = [q.position, q.normal]
            .iter()
            .flat_map(|v| v.to_array())
            .map(exact)
            .collect();
        cols.extend(e.b.iter().chain(&e.se).map(|&v| sig(v)));
        s.push_str(&cols.join(sep));
        s.push('\n');
    }
    s
}

/// The comparison with a lit model: the worst points, then the summary line.
fn report(
    args: &Args,
    queries: &[Query],
    est: &[Estimate],
    lit: &probe::lit::Lit,
    lit_name: &str,
    tol: f64,
    sep: &str,
) -> Result<String, Failure> {
    let c = &args.common;
    let looked: Vec<Option<probe::Rgb>> = queries
        .iter()
        .map(|q| lit.lookup(q.receiver.point, q.receiver.normal, tol))
        .collect();
    let missing: Vec<usize> = (0..queries.len())
        .filter(|&i| looked[i].is_none())
        .collect();
    if !c.quiet {
        for &i in missing.iter().take(10) {
            let q = &queries[i];
            eprintln!(
                "warning: point {} ({} {} {}) is on no face of {lit_name} facing ({} {} {}) within {}; not compared",
                i + 1,
                sig(q.position.x),
                sig(q.position.y),
                sig(q.position.z),
                sig(q.normal.x),
                sig(q.normal.y),
                sig(q.normal.z),
                sig(tol)
            );
        }
        if missing.len() > 10 {
            eprintln!("warning: {} more points not compared", missing.len() - 10);
        }
    }
    if missing.len() == queries.len() {
        return Err(Failure::input(format!(
            "{lit_name}: error: none of the {} points lies on a face of the lit model (within --tolerance {}): is it a solution of the model?",
            queries.len(),
            sig(tol)
        )));
    }
    // Points no path connected to a light (reference exactly 0, no
    // variance) are enclosed: a floor piece under a block, a ceiling
    // behind a flush lamp. No viewer sees them, and a vertex solution
    // interpolates its lit neighbours into them; they are left out unless
    // --keep-unreached.
    let mut looked = looked;
    let unreached: Vec<usize> = (0..queries.len())
        .filter(|&i| looked[i].is_some() && est[i].y == 0.0 && est[i].se_y == 0.0)
        .collect();
    if !args.keep_unreached && unreached.len() < queries.len() {
        for &i in &unreached {
            looked[i] = None;
        }
        if !c.quiet && !unreached.is_empty() {
            eprintln!(
                "note: {} points that no light reaches (enclosed) left out (--keep-unreached)",
                unreached.len()
            );
        }
    }
    let (errors, summary) = probe::lit::compare(est, &looked).map_err(|e| {
        Failure::runtime(format!(
            "error: {e}; is anything in the model emitting light?"
        ))
    })?;
    let mut worst = errors.clone();
    worst.sort_by(|a, b| {
        b.error
            .abs()
            .total_cmp(&a.error.abs())
            .then(a.index.cmp(&b.index))
    });
    worst.truncate(args.worst);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# the {} worst of {} points compared: error = (Y_lit - Y_ref) / max(Y_ref, {})",
        worst.len(),
        summary.n,
        sig(summary.floor)
    );
    s.push_str("# ");
    s.push_str(
        &[
            "x", "y", "z", "nx", "ny", "nz", "ref_r", "ref_g", "ref_b", "lit_r", "lit_g", "lit_b",
            "error",
        ]
        .join(sep),
    );
    s.push('\n');
    for p in &worst {
        let q = &queries[p.index];
        let mut cols: Vec<String> = [q.position, q.normal]
            .iter()
            .flat_map(|v| v.to_array())
            .map(sig)
            .collect();
        cols.extend(p.reference.iter().chain(&p.lit).map(|&v| sig(v)));
        cols.push(format!("{:+.2}%", 100.0 * p.error));
        s.push_str(&cols.join(sep));
        s.push('\n');
    }
    // Robust figures too: one point behind a lamp can dominate the rms.
    let mut abs: Vec<f64> = errors.iter().map(|p| p.error.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let quantile = |q: f64| abs[((q * (abs.len() - 1) as f64).round() as usize).min(abs.len() - 1)];
    let _ = writeln!(
        s,
        "# |error|: median {:.2}%, 90th percentile {:.2}%, 99th percentile {:.2}%",
        100.0 * quantile(0.5),
        100.0 * quantile(0.9),
        100.0 * quantile(0.99)
    );
    let _ = writeln!(
        s,
        "rms {:.2}% max {:.2}% n {} se {:.2}%",
        100.0 * summary.rms,
        100.0 * summary.max,
        summary.n,
        100.0 * summary.se
    );
    Ok(s)
}
