//! ug2obj: write a UniGrafix model as Wavefront OBJ + MTL.

use std::path::{Path, PathBuf};

use clap::Parser;

const EXAMPLES: &str = "\
Examples:
  ug2obj model.ug -o model.obj             also writes model.mtl (and a mtllib line)
  ug2obj lit.ug --exposure 1 -o lit.obj    vertex colours two times brighter
  ug2obj model.ug --mtl model.mtl > model.obj
                                           to stdout, the MTL only with --mtl
  ug2obj --triangles model.ug -o tris.obj  triangles only
  ug2obj --radiosity lit.ug -o lit.obj && obj2ug --vertex-colours lit.obj > back.ug
                                           colours are the radiosity B: a lossless round trip";

/// Write a UniGrafix model as Wavefront OBJ with an MTL material library.
///
/// Instances are flattened first. Face names become 'g' groups, materials
/// 'usemtl' / 'newmtl' with Kd (diffuse) and Ke (emission); faces with holes
/// are triangulated; wires become 'l' lines. Lit models (per-vertex colours
/// from ugrad) get 'v x y z r g b' display colours: sRGB of the radiance
/// B/pi times 2^exposure, clamped (--radiosity: the radiosity B itself,
/// exactly, for obj2ug --vertex-colours). With -o FILE.obj the MTL is
/// written beside it as FILE.mtl; to stdout, only with --mtl.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Write the material library to FILE (default with -o X.obj: X.mtl).
    #[arg(long, value_name = "FILE")]
    mtl: Option<PathBuf>,
    /// Display exposure in stops for vertex colours of lit models.
    #[arg(long, value_name = "STOPS", default_value_t = 0.0, allow_negative_numbers = true, value_parser = finite)]
    exposure: f64,
    /// Triangulate every face (default: only faces with holes).
    #[arg(long)]
    triangles: bool,
    /// Vertex colours of lit models are the radiosity B, written exactly (not display colours).
    #[arg(long, conflicts_with = "exposure")]
    radiosity: bool,
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
        let out_path = c.output.as_deref().filter(|p| *p != Path::new("-"));
        let mtl_path: Option<PathBuf> = match (&args.mtl, out_path) {
            (Some(p), _) => Some(p.clone()),
            (None, Some(o)) => Some(o.with_extension("mtl")),
            (None, None) => None,
        };
        // The mtllib line: the file name when the MTL sits beside the OBJ, else the path as given.
        let mtllib = mtl_path.as_ref().map(|p| {
            let beside = match out_path {
                Some(o) => {
                    o.parent().unwrap_or(Path::new("")) == p.parent().unwrap_or(Path::new(""))
                }
                None => p.parent().is_none_or(|d| d.as_os_str().is_empty()),
            };
            match (beside, p.file_name()) {
                (true, Some(f)) => f.to_string_lossy().into_owned(),
                _ => p.display().to_string(),
            }
        });
        if let (Some(o), Some(mp)) = (out_path, &mtl_path)
            && o == mp.as_path()
        {
            return Err(cli::Failure::input(format!(
                "error: the MTL file would overwrite the OBJ file '{}'",
                o.display()
            )));
        }
        let model = c.load_flat()?;
        let out = formats::obj::write::to_obj(
            &model,
            &formats::obj::write::ObjOptions {
                triangles: args.triangles,
                exposure: args.exposure,
                mtllib,
                radiosity: args.radiosity,
            },
        );
        if !c.quiet {
            out.warnings.iter().for_each(|w| eprintln!("{w}"));
        }
        c.verbose(format!(
            "{} vertices, {} faces, {} materials written",
            out.vertices, out.faces, out.materials
        ));
        if let Some(p) = &mtl_path {
            cli::write_output(Some(p), &out.mtl)?;
        }
        c.write(&out.obj)
    })
}
