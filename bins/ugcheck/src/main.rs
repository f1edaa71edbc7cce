//! ugcheck: report a UG model's defects.

use clap::Parser;

const EXAMPLES: &str = "\
Categories for --deny (comma-separated; 'defects' = the first seven, 'all' = every one):
  nonplanar, tvertex, intersect, overlap, coincident, degenerate, orientation,
  boundary, nonmanifold, nonpatch

Examples:
  ugcheck model.ug                        human-readable report
  ugcheck --json model.ug > report.json   machine-readable report
  ugvlmerge < in.ug | ugcheck --deny tvertex,degenerate
                                          exit 1 if the grouper left either defect
  ugcut -l 2 < clean.ug | ugcheck --deny defects,nonpatch -q
                                          CI gate before ugrad";

/// Report a UniGrafix model's defects: counts, non-planar faces, T-vertices,
/// intersecting, overlapping and coincident faces, degenerate faces,
/// inconsistent orientation, boundary and non-manifold edges, faces that are
/// not triangles or convex quads, and area per material.
///
/// Instances are flattened first. Distances use one tolerance: -e in model
/// units, or 1e-6 of the bounding-box diagonal. The exit status is 0, or 1
/// when a category named by --deny is present, or 2 for bad input.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Distance tolerance in model units (default: 1e-6 of the bounding-box diagonal).
    #[arg(short = 'e', long = "epsilon", value_parser = cli::parse_epsilon)]
    epsilon: Option<f64>,
    /// Write the report as JSON.
    #[arg(long)]
    json: bool,
    /// List every finding (the text report lists at most 50 per category).
    #[arg(long)]
    all: bool,
    /// Exit with status 1 when any of these categories is present.
    #[arg(long, value_delimiter = ',', value_name = "LIST", value_parser = parse_category)]
    deny: Vec<String>,
}

fn parse_category(s: &str) -> Result<String, String> {
    if s == "all" || s == "defects" || check::CATEGORIES.contains(&s) {
        Ok(s.to_string())
    } else {
        Err(format!(
            "unknown category '{s}' (one of: {}, defects, all)",
            check::CATEGORIES.join(", ")
        ))
    }
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let mut denied = false;
    let code = cli::run(|| {
        let c = &args.common;
        let model = c.load_flat()?;
        let chosen = cli::choose_epsilon(args.epsilon, &model);
        let eps = chosen.value;
        c.verbose(format!(
            "epsilon {eps:e}{}",
            match chosen.source {
                cli::Source::Explicit => "",
                cli::Source::Relative => " (model-relative)",
                cli::Source::Precision => " (from the precision the coordinates are written with)",
                cli::Source::Carried => " (carried from an earlier tool: {ugkit epsilon})",
            }
        ));
        let t = std::time::Instant::now();
        let report = check::check(&model, eps);
        c.verbose(format!("checked in {:.3} s", t.elapsed().as_secs_f64()));
        let text = if args.json {
            let mut s = serde_json::to_string_pretty(&report)
                .map_err(|e| cli::Failure::runtime(e.to_string()))?;
            s.push('\n');
            s
        } else {
            report.text(args.all)
        };
        let cats: Vec<&str> = args
            .deny
            .iter()
            .flat_map(|d| match d.as_str() {
                "all" => check::CATEGORIES.to_vec(),
                "defects" => check::DEFECTS.to_vec(),
                other => vec![other],
            })
            .collect();
        let present: Vec<&str> = cats
            .iter()
            .copied()
            .filter(|cat| report.count(cat) > 0)
            .collect();
        c.write(text.as_bytes())?;
        if !present.is_empty() {
            denied = true;
            if !c.quiet {
                eprintln!("ugcheck: denied categories present: {}", present.join(", "));
            }
        }
        Ok(())
    });
    if denied {
        std::process::ExitCode::from(1)
    } else {
        code
    }
}
