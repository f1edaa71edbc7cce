//! ugcopl: intersect coplanar faces.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugcopl < in.ug | ugclean > clean.ug      cut overlaps, then drop the hidden copies
  ugvlmerge < in.ug | ugisect | ugcopl | ugclean | ugcut -l 2
  ugcopl -v -e 0.001 model.ug -o cut.ug";

/// Intersect coplanar, overlapping faces (either orientation) in their plane
/// so that every overlap region becomes a face of its own in each face it
/// belongs to; ugclean then drops the hidden copy. Pieces keep their face's
/// material and orientation, are named NAME.c1, NAME.c2, ..., and carry the
/// annotation {ugcopl origin NAME area A} that ugclean reads. Points where
/// cuts meet neighbouring edges are inserted there (no T-vertex). Instances
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
        let (out, st) = clean::copl::copl(&model, eps)?;
        c.verbose(format!(
            "epsilon {eps:e}; {} overlapping pairs; {} faces cut into {} pieces; {} new vertices; {} T-vertices inserted",
            st.pairs, st.faces_cut, st.pieces, st.new_vertices, st.tvertices
        ));
        Ok(out)
    })
}
