//! ply2ug: read PLY (ASCII or binary) and write UG.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ply2ug lit.ply > lit.ug                  radiosity_r/g/b back as ugrad's vertex colours
  ug2ply --binary lit.ug | ply2ug | ugview - -o lit.png
                                           round trip through binary PLY
  ply2ug scan.ply | ugplanar | ugcut -l 0.5 | ugrad > lit.ug
  ply2ug --ignore-colours mesh.ply -o mesh.ug
                                           geometry only, no display-colour materials";

/// Read a PLY mesh (ASCII, binary little- or big-endian) and write UG.
///
/// Vertices need x, y, z (any numeric type); faces a vertex_indices (or
/// vertex_index) list. Other elements and properties are skipped. Vertices
/// with radiosity_r/g/b (as ug2ply writes lit models) become lit UG: each
/// vertex names a 'c_rgb _radN' colour holding its radiosity B, one per
/// distinct value, as ugrad writes them (their display red/green/blue are
/// ignored). Otherwise display colours (red/green/blue on faces, or shared
/// by all vertices of a face) become 'c_rgb rgb_RRGGBB' face materials with
/// the sRGB-decoded colour as reflectance (--ignore-colours: none). Binary
/// floats are read as their shortest decimal. Degenerate faces are dropped
/// with a warning; vertices are named v1, v2, ... in order of first use.
/// Errors are file:line:col in the header and ASCII data, file:byte N in
/// binary data.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Leave display colours (red/green/blue) out: no face materials.
    #[arg(long)]
    ignore_colours: bool,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        let input = c.read_input()?;
        let out = formats::ply::convert(
            &input.bytes,
            &input.name,
            &formats::ply::Options {
                ignore_colours: args.ignore_colours,
            },
        )
        .map_err(|e| cli::Failure::input(e.to_string()))?;
        if !c.quiet {
            out.warnings.iter().for_each(|w| eprintln!("{w}"));
        }
        c.verbose(format!(
            "{} vertices, {} faces, {} materials ({}); {} degenerate faces dropped, {} unused vertices left out",
            out.model.vertices.len(),
            out.model.faces.len(),
            out.model.materials.len(),
            if out.lit {
                "lit: radiosity per vertex"
            } else {
                "unlit"
            },
            out.dropped,
            out.unused
        ));
        c.write_model(&out.model)
    })
}
