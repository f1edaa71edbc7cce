//! ugclean: remove coincident faces.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugclean < in.ug > clean.ug
  ugvlmerge < in.ug | ugisect | ugcopl | ugclean -v | ugcut -l 2
  ugclean -e 0.001 model.ug -o clean.ug";

/// Remove one face of every coincident pair (coplanar, same region, facing
/// the same way): with the same material the later face goes; with different
/// materials the piece from the larger original surface goes (the floor under
/// the rug), read from ugcopl's `{ugcopl origin NAME area A}` annotations or
/// measured as the connected coplanar surface of the face's material.
/// Faces back to back (a zero-thickness wall's two sides) stay. Instances
/// are flattened first.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let c = &args.common;
    cli::filter(c, args.epsilon, |model, eps| {
        let (out, st) = clean::coincident::clean(&model, eps);
        if c.verbose > 0 {
            eprintln!(
                "epsilon {eps:e}; {} coincident pairs; removed {} faces, area {}",
                st.pairs,
                st.removed.len(),
                st.area_removed
            );
            for (r, k, why) in &st.removed {
                eprintln!("  removed {r} (kept {k}): {why}");
            }
        }
        Ok(out)
    })
}
