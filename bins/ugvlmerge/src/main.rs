//! ugvlmerge: the grouper.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugvlmerge < in.ug > grouped.ug              all three steps, model-relative epsilon
  ugvlmerge -e 0.001 -v model.ug -o out.ug    1 mm tolerance; print counts per step
  ugvlmerge --no-merge-faces in.ug            only connect: merge vertices, split edges";

/// The grouper: merge nearly coincident vertices, remove T-vertices, and join
/// coplanar faces of the same material into complex faces (with holes).
///
/// 1. Vertices within epsilon of an earlier vertex are replaced by it (the
///    first name in statement order is kept); faces left without area are
///    dropped with a warning.
///
/// 2. Vertices lying within epsilon of an edge are inserted into that edge
///    in every face that uses it, so no T-vertex remains.
///
/// 3. Faces of the same material sharing an edge, facing the same way
///    (normals within --angle degrees) and lying within epsilon of each
///    other's plane are joined; the first face in statement order keeps its
///    name and place. The result may have holes (outer contour
///    counter-clockwise, holes clockwise, seen from the front). Edges used by
///    three or more faces are never joined across, and no vertex another face
///    uses is left inside a joined face. Boundary vertices between collinear
///    edges of a joined face, used by nothing else, are dropped.
///
/// Vertices no face uses any more are removed; other statements pass
/// through. Instances are flattened first.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
    /// Largest angle between the normals of faces that are joined, in degrees.
    #[arg(long, value_name = "DEGREES", default_value_t = clean::group::DEFAULT_ANGLE, value_parser = parse_angle)]
    angle: f64,
    /// Skip step 1 (merging nearly coincident vertices).
    #[arg(long)]
    no_merge_vertices: bool,
    /// Skip step 2 (inserting T-vertices into edges).
    #[arg(long)]
    no_split_edges: bool,
    /// Skip step 3 (joining coplanar faces).
    #[arg(long)]
    no_merge_faces: bool,
    /// Do not repair faces whose contours cross or touch themselves, or are
    /// narrower than epsilon somewhere (after step 2).
    #[arg(long)]
    no_repair: bool,
}

fn parse_angle(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=90.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not an angle between 0 and 90 degrees")),
    }
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let c = &args.common;
    cli::filter(c, args.epsilon, |model, eps| {
        c.verbose(format!("epsilon {eps:e}, angle {}°", args.angle));
        let opts = clean::group::Options {
            eps,
            angle: args.angle,
            merge_vertices: !args.no_merge_vertices,
            split_edges: !args.no_split_edges,
            merge_faces: !args.no_merge_faces,
            repair: !args.no_repair,
        };
        let (out, st) = clean::group::vlmerge(model, &opts)?;
        if !c.quiet {
            for w in clean::group::warnings(&st, c.verbose > 0) {
                eprintln!("{w}");
            }
        }
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        c.verbose(format!(
            "{} faces, {} vertices in",
            st.faces_in, st.vertices_in
        ));
        if opts.merge_vertices {
            c.verbose(format!(
                "merge vertices: {} merged into an earlier one, {} faces dropped ({:.1} ms)",
                st.vertices_merged,
                st.dropped.len(),
                ms(st.times[0])
            ));
            if st.retriangulated > 0 {
                c.verbose(format!(
                    "{} triangles of twisted quads triangulated twice given the other copy's diagonal",
                    st.retriangulated
                ));
            }
        }
        if opts.split_edges {
            c.verbose(format!(
                "split edges: {} T-vertices inserted into {} edges ({:.1} ms)",
                st.tvertices,
                st.edges_split,
                ms(st.times[1])
            ));
        }
        if opts.merge_faces {
            c.verbose(format!(
                "merge faces: {} faces joined into {} ({} holes), {} collinear vertices dropped ({:.1} ms)",
                st.faces_joined + st.groups,
                st.groups,
                st.holes,
                st.collinear,
                ms(st.times[2])
            ));
        }
        c.verbose(format!(
            "{} faces, {} vertices out ({} unused vertices removed)",
            st.faces_out, st.vertices_out, st.unused_removed
        ));
        Ok(out)
    })
}
