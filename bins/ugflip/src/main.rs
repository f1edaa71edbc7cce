//! ugflip: orient faces.

use clap::Parser;
use geom::DVec3;

const EXAMPLES: &str = "\
Examples:
  ugflip < in.ug > oriented.ug                  automatic orientation
  ugflip -v --double-sided-ambiguous in.ug      also make undecidable parts two-sided
  ugflip --bomb 2.5,1.2,1.5 room.ug             light bomb: faces seen from the point turn toward it
  ugflip --no-auto --flip wall3 --flip door in.ug
                                                flip just these faces
  ugflip --no-auto --double-sided glass in.ug   add the reversed twin glass.back";

/// Orient the faces of a UniGrafix model (front = counter-clockwise outer contour).
///
/// Automatic mode (the default) makes orientation consistent across shared
/// edges, then turns closed solids outward, closed rooms and shells (that
/// contain other geometry, a camera eye or a light bomb) inward, and open
/// parts toward the side from which more of the scene is seen. What stays
/// ambiguous is reported on stderr. Light bombs, --flip and --double-sided
/// apply after it (use --no-auto to apply only them). Instances are flattened.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
    /// A light bomb at X,Y,Z: faces visible from it whose front faces away are flipped (repeatable, in order).
    #[arg(long = "bomb", value_name = "X,Y,Z", value_parser = parse_point)]
    bombs: Vec<DVec3>,
    /// Flip the face with this name (repeatable; unnamed faces are #k).
    #[arg(long = "flip", value_name = "NAME")]
    flip: Vec<String>,
    /// Add the reversed twin NAME.back of this face (repeatable).
    #[arg(long = "double-sided", value_name = "NAME")]
    double_sided: Vec<String>,
    /// Make the faces of components whose outside is ambiguous double-sided.
    #[arg(long)]
    double_sided_ambiguous: bool,
    /// Skip automatic orientation (only bombs, --flip and --double-sided apply).
    #[arg(long)]
    no_auto: bool,
    /// Rays per face side for the automatic visibility vote.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=4096))]
    rays: u32,
}

fn parse_point(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("'{s}': {e}"))?;
    if v.len() != 3 || !v.iter().all(|x| x.is_finite()) {
        return Err(format!("'{s}' is not three finite numbers X,Y,Z"));
    }
    Ok(DVec3::new(v[0], v[1], v[2]))
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let c = &args.common;
    cli::filter(c, args.epsilon, |model, eps| {
        let model = clean::group::settle_warned(model, eps, c.quiet, c.verbose > 0)?;
        let opts = clean::orient::Options {
            auto: !args.no_auto,
            bombs: args.bombs.clone(),
            flip: args.flip.clone(),
            double_sided: args.double_sided.clone(),
            double_sided_ambiguous: args.double_sided_ambiguous,
            rays: args.rays as usize,
            eps,
            viewpoints: clean::orient::camera_eyes(&model),
        };
        let (out, r) = clean::orient::orient(model, &opts).map_err(|u| {
            cli::Failure::input(format!(
                "error: no face named '{}' (unnamed faces are #1, #2, …)",
                u.0
            ))
        })?;
        if !c.quiet {
            // One line per part up to a limit (all of them with -v): a big
            // messy building can have thousands.
            let limit = if c.verbose > 0 { usize::MAX } else { 20 };
            for a in r.ambiguous.iter().take(limit) {
                eprintln!(
                    "warning: the outside of the part containing face {a} is ambiguous; left as it is{}",
                    if args.double_sided_ambiguous {
                        " and made double-sided"
                    } else {
                        " (--double-sided-ambiguous makes it two-sided)"
                    }
                );
            }
            if r.ambiguous.len() > limit {
                eprintln!(
                    "warning: {} more parts are ambiguous (-v lists them all)",
                    r.ambiguous.len() - limit
                );
            }
            for a in &r.nonorientable {
                eprintln!(
                    "warning: the part containing face {a} cannot be oriented consistently (non-orientable)"
                );
            }
        }
        c.verbose(format!(
            "epsilon {eps:e}; {} components; flipped {} faces: {} for consistency, {} outward (solids), {} inward (rooms), {} toward the scene (open parts), {} by light bombs, {} by name; {} double-sided twins added; {} duplicates turned like their own surface or their twin; {} ambiguous",
            r.components, r.flipped(), r.consistency, r.outward, r.inward, r.toward_scene, r.by_bombs, r.by_name, r.doubled, r.duplicates, r.ambiguous.len()
        ));
        Ok(out)
    })
}
