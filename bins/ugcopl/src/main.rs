//! ugcopl: intersect coplanar faces.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugcopl < in.ug | ugclean > clean.ug      cut overlaps, then drop the hidden copies
  ugvlmerge < in.ug | ugisect | ugcopl | ugclean | ugcut -l 2
  ugcopl -v -e 0.001 model.ug -o cut.ug
  ugcopl --contact 0 model.ug > cut.ug       no contact cuts (coplanar overlaps only)
  ugcopl --contact 0.1 model.ug > cut.ug     cut behind covers up to a tenth of their size away";

/// Intersect coplanar, overlapping faces (either orientation) in their plane
/// so that every overlap region becomes a face of its own in each face it
/// belongs to; ugclean then drops the hidden copy. Pieces keep their face's
/// material and orientation, are named NAME.c1, NAME.c2, ..., and carry the
/// annotation {ugcopl origin NAME area A} that ugclean reads. Points where
/// cuts meet neighbouring edges are inserted there (no T-vertex); a pair
/// that the cuts make intersect (a piece's corner lies in its own plane, up
/// to 3 epsilon from the vertex it stands for) is cut as ugisect cuts it.
/// Instances are flattened first.
///
/// Contact cuts: a face is also cut along the outline of a parallel face
/// lying a small gap in front of it (a lamp a hair below the ceiling, a
/// rug, a picture, a cupboard against a wall), so that the dark part behind
/// it becomes pieces of its own instead of being interpolated from lit
/// corners. Only the face whose front faces the other is cut, in its own
/// plane; ugclean keeps these pieces.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
    /// Largest gap for contact cuts, as a fraction of the covering face's
    /// size (√area); 0 turns them off.
    #[arg(long = "contact", value_name = "RATIO", default_value_t = clean::copl::DEFAULT_CONTACT, value_parser = cli::parse_epsilon)]
    contact: f64,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let c = &args.common;
    cli::filter(c, args.epsilon, |model, eps| {
        let model = clean::group::settle_warned(model, eps, c.quiet, c.verbose > 0)?;
        let contact = args.contact;
        let (out, st) = clean::copl::copl_contact(&model, eps, contact)?;
        c.verbose(format!(
            "epsilon {eps:e}; contact ratio {contact}; {} overlapping pairs; {} contact pairs; {} faces cut into {} pieces; {} new vertices; {} T-vertices inserted; {} faces bent off their plane by welding, folded into triangles; {} round(s); {} pairs the cuts made intersect, cut",
            st.pairs, st.contacts, st.faces_cut, st.pieces, st.new_vertices, st.tvertices, st.folded, st.rounds, st.recut_pairs
        ));
        Ok(out)
    })
}
