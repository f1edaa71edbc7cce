//! obj2ug: read Wavefront OBJ (+ MTL) and write UG.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  obj2ug model.obj > model.ug              materials from the OBJ's mtllib files
  obj2ug room.obj --emit lamp=10,10,8 -o room.ug
                                           make material 'lamp' an emitter
  obj2ug model.obj | ugplanar | ugcut -l 0.5 | ugrad > lit.ug
  obj2ug --strict < model.obj > model.ug   unsupported statements are errors
  ug2obj --radiosity lit.ug -o lit.obj && obj2ug --vertex-colours lit.obj > back.ug
                                           'v x y z r g b' colours back as radiosity";

/// Read a Wavefront OBJ model (with its MTL material libraries) and write UG.
///
/// Faces (v, v/vt, v//vn, v/vt/vn, negative indices, n-gons) become UG faces,
/// 'l' polylines wires; 'o'/'g' names become face names (sanitised to UG
/// identifiers and made unique); 'usemtl' materials become defmat blocks with
/// diffuse_rgb from Kd (0.8 grey when missing) and emission_rgb from a
/// non-zero Ke. MTL files are resolved relative to the OBJ file (one that
/// cannot be read is a warning, an error with --strict). Degenerate
/// faces are dropped with a warning; curves, surfaces and unknown statements
/// are ignored with a warning (errors with --strict). Vertices are named
/// v1, v2, ... in order of first use. Vertex colours ('v x y z r g b') are
/// ignored unless --vertex-colours is given: then they become per-vertex UG
/// colours holding radiosity, one 'c_rgb _radN' per distinct value, as ugrad
/// writes them (ug2obj --radiosity writes such files).
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Make material NAME (OBJ or UG name) an emitter with exitance r,g,b (repeatable).
    #[arg(long, value_name = "NAME=R,G,B", value_parser = formats::obj::parse_emit)]
    emit: Vec<(String, [f64; 3])>,
    /// Read 'v x y z r g b' colours as per-vertex colours (radiosity B, as
    /// written by ug2obj --radiosity).
    #[arg(long)]
    vertex_colours: bool,
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        let input = c.read_input()?;
        let out = formats::obj::convert(
            &input.bytes,
            &input.name,
            &input.dir,
            &formats::obj::Options {
                strict: c.strict,
                emit: args.emit.clone(),
                vertex_colours: args.vertex_colours,
            },
        )?;
        if !c.quiet {
            out.warnings.iter().for_each(|w| eprintln!("{w}"));
        }
        c.verbose(format!(
            "{} vertices, {} faces, {} wires, {} materials; {} degenerate dropped",
            out.model.vertices.len(),
            out.model.faces.len(),
            out.model.wires.len(),
            out.model.materials.len(),
            out.dropped
        ));
        if out.colours_ignored > 0 {
            c.verbose(format!(
                "note: {} vertex colours ignored ('v x y z r g b'; --vertex-colours reads them)",
                out.colours_ignored
            ));
        }
        c.write_model(&out.model)
    })
}
