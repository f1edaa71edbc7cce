//! ug2ply: write a UniGrafix model as PLY.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ug2ply lit.ug -o lit.ply                 ASCII PLY with radiosity and display colours
  ug2ply --binary --exposure 2 lit.ug > lit.ply
                                           binary, two stops brighter
  ugrad patches.ug | ug2ply > lit.ply      straight from the solver
  ug2ply --triangles model.ug -o tris.ply  triangles only";

/// Write a UniGrafix model as PLY (ASCII, or binary little-endian).
///
/// Instances are flattened first. Faces without holes are written as
/// polygons, faces with holes as triangles. Lit models (per-vertex colours
/// from ugrad, holding radiosity B) get float radiosity_r/g/b properties with
/// the raw values and uchar red/green/blue display colours, the sRGB of the
/// radiance B/pi times 2^exposure, clamped. Unlit models get the face
/// material's diffuse colour (a vertex shared by faces of different
/// materials is written once per material). Coordinates are doubles.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Write binary_little_endian instead of ASCII.
    #[arg(long)]
    binary: bool,
    /// Display exposure in stops: colours show B/pi times 2^STOPS (lit models).
    #[arg(long, value_name = "STOPS", default_value_t = 0.0, allow_negative_numbers = true, value_parser = finite)]
    exposure: f64,
    /// Triangulate every face (default: only faces with holes).
    #[arg(long)]
    triangles: bool,
}

fn finite(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a finite number")),
    }
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        let model = c.load_flat()?;
        let out = formats::ply::write::to_ply(
            &model,
            &formats::ply::write::PlyOptions {
                binary: args.binary,
                triangles: args.triangles,
                exposure: args.exposure,
            },
        );
        if !c.quiet {
            out.warnings.iter().for_each(|w| eprintln!("{w}"));
        }
        c.verbose(format!(
            "{} vertices, {} faces written ({})",
            out.vertices,
            out.faces,
            if out.lit {
                "lit: radiosity per vertex"
            } else {
                "unlit: material colours"
            }
        ));
        c.write(&out.bytes)
    })
}
