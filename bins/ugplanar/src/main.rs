//! ugplanar: tessellate non-planar faces.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugplanar < in.ug > planar.ug             tessellate with the model-relative epsilon
  ugplanar -e 0.5 -v model.ug -o out.ug     faces off their plane by > 0.5 units; print counts
  ugplanar in.ug | ugflip | ugvlmerge       first stage of the cleaning pipeline";

/// Tessellate the non-planar faces of a UniGrafix model into triangles.
///
/// A face is non-planar when a vertex lies farther than epsilon from its
/// best-fit plane. Quads split along the diagonal that folds least; larger
/// faces (holes included) get a constrained Delaunay triangulation on their
/// best-fit plane. Triangles keep the face's material and orientation and are
/// named NAME.1, NAME.2, ... Planar faces pass through unchanged. Instances
/// are flattened first.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Planarity tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let c = &args.common;
    cli::filter(c, args.epsilon, |model, eps| {
        c.verbose(format!("epsilon {eps:e}"));
        let (out, st) = clean::planar::planarize(&model, eps);
        if !c.quiet {
            for f in &st.repaired {
                eprintln!(
                    "warning: face {f} is not planar and its projection crosses or touches itself; repaired on its best-fit plane (even-odd region) and triangulated"
                );
            }
            for f in &st.failed {
                eprintln!("warning: face {f} is not planar and encloses no area; left out");
            }
        }
        c.verbose(format!(
            "{} faces, {} non-planar, {} triangles written",
            st.faces, st.nonplanar, st.triangles
        ));
        // Planar now: every face made sound (`clean::group::settle`).
        Ok(clean::group::settle_warned(
            out,
            eps,
            c.quiet,
            c.verbose > 0,
        )?)
    })
}
