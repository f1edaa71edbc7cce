//! ugcat: parse UG and write it back in canonical form.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ugcat model.ug > canonical.ug        canonical spacing and numbers
  ugcat --flatten building.ug -o flat.ug
                                       expand def/i/a instances into plain geometry
  ugcat --strict < in.ug > /dev/null   validate: unknown statements are errors
  ugcat --keep-includes top.ug         write include statements instead of resolving them";

/// Parse a UniGrafix model and write it in canonical form.
///
/// The output has one statement per line and the shortest numbers that read
/// back to the same values; comments, lights, cameras and unknown statements
/// pass through. Errors are reported as file:line:col (exit status 2).
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Expand def instances and arrays into plain geometry.
    #[arg(long)]
    flatten: bool,
    /// Keep 'include FILE;' statements instead of reading the files.
    #[arg(long, conflicts_with = "flatten")]
    keep_includes: bool,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        let model = if args.keep_includes {
            let input = c.read_input()?;
            let opts = cli::ug::ParseOptions {
                strict: c.strict,
                includes: cli::ug::IncludeMode::Keep,
                limits: true,
            };
            let parsed = cli::ug::parse_with(&input.bytes, &input.name, Some(&input.dir), &opts)?;
            if !c.quiet {
                parsed.warnings.iter().for_each(|w| eprintln!("{w}"));
            }
            parsed.model
        } else if args.flatten {
            c.load_flat()?
        } else {
            c.load()?
        };
        c.verbose(format!(
            "{} vertices, {} faces, {} materials",
            model.vertices.len(),
            model.faces.len(),
            model.materials.len()
        ));
        c.write_model(&model)
    })
}
