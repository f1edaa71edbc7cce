//! mgf2ug: read MGF (Materials and Geometry Format) and write UG.

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  mgf2ug scene.mgf > scene.ug              includes resolved relative to scene.mgf
  mgf2ug --segments 32 room.mgf -o room.ug finer spheres, cylinders, cones, tori
  mgf2ug --two-sided --emission-scale 0.01 scene.mgf | ugplanar | ugcut -l 0.5 | ugrad > lit.ug
  mgf2ug --strict < scene.mgf > scene.ug   unknown entities are errors";

/// Read an MGF model (Greg Ward's Materials and Geometry Format) and write UG.
///
/// Supported: vertices (v, p, n), faces (f, with holes given as seams; fh),
/// sph, cyl, cone, ring, torus and prism (tessellated), materials (m, rd, ed,
/// sides; td, rs, ts, ir are ignored), colours (c, cxy, cspec, cct, cmix),
/// transforms (xf with -t -rx -ry -rz -s -mx -my -mz -i -a, nested), includes
/// (i FILE [xform], relative to the including file) and objects (o, which
/// name the faces). diffuse_rgb is rd times the colour, emission_rgb ed times
/// the colour times --emission-scale (MGF's ed is in lumens per square metre).
/// Unknown entities and ies are ignored with a warning (errors with --strict).
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Divisions around spheres, cylinders, cones, rings and tori.
    #[arg(long, value_name = "N", default_value_t = 16, value_parser = clap::value_parser!(u32).range(3..=4096))]
    segments: u32,
    /// Write faces of two-sided materials twice, the back copy reversed (NAME.back).
    #[arg(long)]
    two_sided: bool,
    /// Multiply MGF emittance (ed, lumens/m^2) by F to get UG emission_rgb.
    #[arg(long, value_name = "F", default_value_t = 1.0, value_parser = positive)]
    emission_scale: f64,
}

fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a finite, non-negative number")),
    }
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        let input = c.read_input()?;
        let out = formats::mgf::convert(
            &input.bytes,
            &input.name,
            &input.dir,
            &formats::mgf::Options {
                strict: c.strict,
                segments: args.segments,
                two_sided: args.two_sided,
                emission_scale: args.emission_scale,
                ..Default::default()
            },
        )?;
        if !c.quiet {
            out.warnings.iter().for_each(|w| eprintln!("{w}"));
        }
        if c.verbose > 0 {
            out.notes.iter().for_each(|w| eprintln!("{w}"));
        }
        c.verbose(format!(
            "{} vertices, {} faces, {} materials",
            out.model.vertices.len(),
            out.model.faces.len(),
            out.model.materials.len()
        ));
        c.write_model(&out.model)
    })
}
