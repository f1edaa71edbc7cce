//! ugcut: surfaces into patches.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugcut -l 2 < clean.ug > patches.ug       patches of about 2 units
  ugcut -l 2% building.ug -o patches.ug    2% of the model's bounding-box diagonal
  ugvlmerge < in.ug | ugisect | ugcut -l 0.5 | ugrad > lit.ug";

/// Cut every surface of a UniGrafix model into triangle and convex-quad
/// patches of about a given edge length, without T-vertices.
///
/// Boundary edges are divided into the whole number of equal segments nearest
/// to LEN (identically for faces that share the edge); a grid of rectangles
/// aligned with the face's longest edge fills what it can (a rectangle gives
/// only rectangles); the rest is a refined constrained Delaunay triangulation
/// with pairs of triangles joined into convex quads. Run ugvlmerge first so
/// that each surface is one face. Instances are flattened.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Desired patch edge length: model units, or a percentage of the bounding-box diagonal ("2%").
    #[arg(short = 'l', long = "length", value_name = "LEN", default_value = "2%")]
    len: String,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
    /// Smallest triangle angle the refinement aims for, degrees (at most 33).
    #[arg(long, default_value_t = 25.0, value_parser = parse_angle)]
    angle: f64,
    /// Keep triangles (do not join pairs into quads).
    #[arg(long)]
    triangles: bool,
    /// Refuse a length that would make more patches than this (estimated
    /// from the faces' area): `-l 2` on a model in millimetres asks for
    /// billions, and would run until killed.
    #[arg(long, value_name = "N", default_value_t = 50_000_000)]
    max_patches: u64,
}

fn parse_angle(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=33.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not an angle between 0 and 33 degrees")),
    }
}

/// Warnings for what the preparation changed: at most five of a kind (all
/// with -v), then a count.
fn report(st: &libmesh::patch::Stats, all: bool) {
    let limit = if all { usize::MAX } else { 5 };
    let list = |items: Vec<String>, more: &str| {
        for i in items.iter().take(limit) {
            eprintln!("warning: {i}");
        }
        if items.len() > limit {
            eprintln!(
                "warning: {} more {more} (-v lists them)",
                items.len() - limit
            );
        }
    };
    list(
        st.repaired
            .iter()
            .map(|(f, _)| format!("face {f}: its contours cross or touch themselves, or it is narrower than epsilon somewhere; repaired"))
            .collect(),
        "faces repaired",
    );
    list(
        st.tessellated
            .iter()
            .map(|f| format!("face {f} is not planar; folded into triangles (run ugplanar first)"))
            .collect(),
        "non-planar faces folded",
    );
    list(
        st.dropped
            .iter()
            .map(|(f, why)| format!("face {f}: {why}; left out"))
            .collect(),
        "faces left out",
    );
    list(
        st.plain
            .iter()
            .map(|f| format!("face {f}: meshed by a plain triangulation (the grid did not fit)"))
            .collect(),
        "faces meshed plainly",
    );
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let c = &args.common;
    cli::filter(c, args.epsilon, |model, eps| {
        let diag = model.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length());
        // A model without extent (no faces, or all at one point) has
        // nothing to mesh: any length does, and the percentage of its size
        // would be none (an empty model goes through, as through the
        // other filters).
        let flat = diag == 0.0;
        let len = match args.len.strip_suffix('%') {
            Some(p) => p
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|p| *p > 0.0)
                .map(|p| if flat { 1.0 } else { p / 100.0 * diag }),
            None => args.len.trim().parse::<f64>().ok(),
        };
        let len = len.filter(|l| l.is_finite() && *l > 0.0).ok_or_else(|| {
            cli::Failure::input(format!(
                "error: -l '{}' is not a positive length or percentage",
                args.len
            ))
        })?;
        if len <= 10.0 * eps && !flat {
            return Err(cli::Failure::input(format!(
                "error: -l {len} is not larger than 10 × epsilon ({eps:e})"
            )));
        }
        // About two patches per square of the length (triangles are half
        // a square; quads a whole one).
        let area: f64 = model
            .top_faces()
            .map(|f| {
                let pts: Vec<Vec<geom::DVec3>> = model.faces[f.idx()]
                    .contours
                    .iter()
                    .map(|c| c.iter().map(|&v| model.pos(v)).collect())
                    .collect();
                geom::face_area(&pts).abs()
            })
            .sum();
        let estimate = 2.0 * area / (len * len);
        if estimate > args.max_patches as f64 {
            return Err(cli::Failure::input(format!(
                "error: -l {len} would cut the faces' area of {area:e} into about {estimate:.1e} patches, more than --max-patches {} (give a longer -l, or a percentage of the model's size: the default is 2%)",
                args.max_patches
            )));
        }
        let opts = libmesh::patch::Options {
            len,
            eps,
            angle: args.angle,
            quads: !args.triangles,
        };
        let (out, st) = libmesh::patch::cut(&model, opts)
            .map_err(|e| cli::Failure::runtime(format!("error: {e}")))?;
        if !c.quiet {
            report(&st, c.verbose > 0);
        }
        c.verbose(format!(
            "welded {} vertices, joined the ends of {} short edges (faces meshed again: {}, replayed: {}), inserted {} T-vertices, took {} vertices resting inside faces as patch corners; at shallow contacts took out {} points inside faces, moved {} and flipped {} diagonals; repaired {} faces, folded {} non-planar, left out {}",
            st.welded,
            st.joined,
            st.remeshed,
            st.replayed,
            st.tvertices,
            st.resting,
            st.shallow_points,
            st.shallow_moved,
            st.shallow_flips,
            st.repaired.len(),
            st.tessellated.len(),
            st.dropped.len()
        ));
        c.verbose(format!(
            "length {len}, epsilon {eps:e}: {} faces → {} patches ({} quads of which {} grid cells, {} triangles); edges min {:.4} mean {:.4} max {:.4}; worst triangle angle {:.1}°",
            st.faces, st.patches, st.quads, st.grid_cells, st.triangles, st.min_edge, st.mean_edge, st.max_edge, st.worst_angle
        ));
        Ok(out)
    })
}
