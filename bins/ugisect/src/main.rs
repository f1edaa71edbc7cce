//! ugisect: cut intersecting faces.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugvlmerge < in.ug | ugisect > cut.ug
  ugisect -v model.ug -o cut.ug            print pair and piece counts
  ugvlmerge < in.ug | ugisect | ugcopl | ugclean | ugcheck --deny intersect";

/// Cut every pair of intersecting faces along the line where their planes
/// meet (crossing faces, and contacts such as a wall standing on a floor, so
/// that light on either side of the wall is independent). Each face is split
/// across its whole extent; where a cut meets the other face's boundary, the
/// point is inserted into the edge it lies on, so the intersection becomes
/// shared edges and no T-vertex remains. Pieces are named NAME.i1, NAME.i2, ...
/// Coplanar pairs are left to ugcopl. Instances are flattened first.
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
        let model = clean::group::settle_warned(model, eps, c.quiet, c.verbose > 0)?;
        let (out, st) = clean::isect::isect(&model, eps)?;
        if st.tessellated > 0 && !c.quiet {
            eprintln!(
                "warning: {} faces are not planar; folded into triangles first (run ugplanar before ugisect)",
                st.tessellated
            );
        }
        if !st.left.is_empty() && !c.quiet {
            let shown = if c.verbose > 0 { st.left.len() } else { 5 };
            let names: Vec<String> = st
                .left
                .iter()
                .take(shown)
                .map(|(a, b, angle)| format!("{a} and {b} ({angle:.1}°)"))
                .collect();
            let more = if st.left.len() > shown {
                format!(" and {} more (-v lists them)", st.left.len() - shown)
            } else {
                String::new()
            };
            let n = st.left.len();
            eprintln!(
                "warning: {n} {} of faces still {} after {} rounds of cutting: {}{more}; cutting within epsilon did not separate them (near the cut their pieces stay within epsilon of each other: faces crossing at a shallow angle); ugcheck lists them",
                if n == 1 { "pair" } else { "pairs" },
                if n == 1 { "crosses" } else { "cross" },
                st.rounds,
                names.join(", ")
            );
        }
        c.verbose(format!(
            "epsilon {eps:e}; {} intersecting pairs, {} cut segments; {} faces cut into {} pieces ({} cuts extended); {} new vertices; {} T-vertices inserted; {} round(s); {} faces bent off their plane by welding, folded into triangles",
            st.pairs, st.segments, st.faces_cut, st.pieces, st.extensions, st.new_vertices, st.tvertices, st.rounds, st.folded
        ));
        Ok(out)
    })
}
