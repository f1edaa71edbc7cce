//! ugview: render a UG model to PNG.

use clap::Parser;
use std::io::IsTerminal;

const EXAMPLES: &str = "\
Examples:
  ugview lit.ug -o lit.png                 default view (or the model's first cam), auto exposure
  ugcut -l 2 < room.ug | ugrad | ugview -o room.png
  ugview lit.ug --cam front --exposure 1 -o front.png
                                           a UG camera, one stop brighter than radiance 1 = white
  ugview lit.ug --eye 2,-6,1.6 --look 2,2,1.2 --fov 60 --size 1280x720 -o view.png
  ugview lit.ug --top --cut-z 1.2 --mesh -o plan.png
                                           plan view cut at 1.2 with the element mesh
  ugview lit.ug --false-colour --range 1,1000 -o lum.png
                                           luminance in false colour with a legend
  ugview model.ug --backfaces -o check.png back faces magenta: check orientation before ugflip

Environment: WGPU_BACKEND (vulkan, gl), WGPU_ADAPTER_NAME, WGPU_POWER_PREF.
Without a GPU, Mesa's lavapipe (Debian: mesa-vulkan-drivers) renders on the CPU.";

/// Render a UniGrafix model to a PNG picture.
///
/// Lit models (ugrad output) are Gouraud-shaded with radiance B/π, exposed and
/// tone-mapped to sRGB; unlit models are flat-shaded by material colour. Back
/// faces are culled (one-sided surfaces, as the radiosity solution sees them),
/// so a view from outside a room looks in through its walls. Instances are
/// flattened first. Exit status 1 when no GPU device (or lavapipe) is usable.
#[derive(Parser, Debug)]
#[command(version, after_help = EXAMPLES)]
struct Args {
    #[command(flatten)]
    common: cli::Common,
    /// Picture size in pixels.
    #[arg(long, default_value = "800x600", value_parser = view::parse_size, value_name = "WxH")]
    size: (u32, u32),
    /// Eye position (default: the cam statement's, or a view framing the model).
    #[arg(long, value_parser = view::parse_vec3, value_name = "X,Y,Z", allow_hyphen_values = true)]
    eye: Option<glam::DVec3>,
    /// Point looked at (default with --eye: the model's centre).
    #[arg(long, value_parser = view::parse_vec3, value_name = "X,Y,Z", allow_hyphen_values = true)]
    look: Option<glam::DVec3>,
    /// Up direction (default: the cam statement's, else +z).
    #[arg(long, value_parser = view::parse_vec3, value_name = "X,Y,Z", allow_hyphen_values = true)]
    up: Option<glam::DVec3>,
    /// Vertical field of view in degrees (default 45, or the cam statement's).
    #[arg(long, value_name = "DEG")]
    fov: Option<f64>,
    /// Use the model's `cam NAME …;` statement (-eye, -look, -up, -fov).
    #[arg(long, value_name = "NAME")]
    cam: Option<String>,
    /// Orthographic plan view from above, cut at --cut-z (default: half the model's height).
    #[arg(long, conflicts_with_all = ["eye", "look", "cam", "fov"])]
    top: bool,
    /// Remove everything above this height along the up axis.
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    cut_z: Option<f64>,
    /// Exposure in stops: radiance × 2^STOPS, 1.0 is white. Default: automatic
    /// (log-average luminance of the lit pixels → middle grey: the unlit
    /// exterior of a building seen from outside does not count).
    #[arg(long, value_name = "STOPS", allow_hyphen_values = true)]
    exposure: Option<f64>,
    /// Tone mapping after exposure.
    #[arg(long, value_enum, default_value = "clamp")]
    tonemap: TonemapArg,
    /// Colour by luminance (radiance, model units) with a legend bar.
    #[arg(long, alias = "false-color")]
    false_colour: bool,
    /// False-colour range LO,HI (default: 1st–99th percentile of the picture).
    #[arg(long, value_name = "LO,HI", requires = "false_colour")]
    range: Option<String>,
    /// Overlay the faces' edges (ugrad's elements).
    #[arg(long)]
    mesh: bool,
    /// Draw back faces magenta instead of culling them.
    #[arg(long)]
    backfaces: bool,
    /// Multisample anti-aliasing: 1 (off) or 4 samples per pixel.
    #[arg(long, default_value_t = 4, value_parser = parse_msaa)]
    msaa: u32,
    /// Background colour (linear RGB, 0..1).
    #[arg(long, value_parser = view::parse_vec3, value_name = "R,G,B", default_value = "0,0,0")]
    background: glam::DVec3,
    /// Graphics API.
    #[arg(long, value_enum, default_value = "auto")]
    gpu_backend: BackendArg,
}

fn parse_msaa(s: &str) -> Result<u32, String> {
    match s {
        "1" => Ok(1),
        "4" => Ok(4),
        _ => Err(format!("'{s}' is not 1 or 4")),
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum TonemapArg {
    Clamp,
    Reinhard,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum BackendArg {
    Auto,
    Vulkan,
    Gl,
}

fn main() -> std::process::ExitCode {
    // SAFETY: first thing in main, before any thread exists.
    unsafe { gpu::prepare_env() };
    let args = Args::parse();
    cli::run(|| {
        let c = &args.common;
        if c.output.is_none() && std::io::stdout().is_terminal() {
            return Err(cli::Failure::input(
                "error: a PNG is binary: give -o FILE.png or redirect stdout",
            ));
        }
        let range = match &args.range {
            Some(s) => {
                let parts: Vec<f64> = s.split(',').filter_map(|p| p.trim().parse().ok()).collect();
                match parts[..] {
                    [lo, hi] if lo.is_finite() && hi.is_finite() && hi > lo && lo >= 0.0 => {
                        Some((lo, hi))
                    }
                    _ => {
                        return Err(cli::Failure::input(format!(
                            "error: --range wants LO,HI with 0 <= LO < HI, got '{s}'"
                        )));
                    }
                }
            }
            None => None,
        };
        let t0 = std::time::Instant::now();
        let model = c.load_flat()?;
        let t_load = t0.elapsed();
        let o = view::ViewOptions {
            width: args.size.0,
            height: args.size.1,
            eye: args.eye,
            look: args.look,
            up: args.up,
            fov: args.fov,
            cam: args.cam.clone(),
            top: args.top,
            cut_z: args.cut_z,
            exposure: args.exposure,
            tonemap: match args.tonemap {
                TonemapArg::Clamp => view::ToneMap::Clamp,
                TonemapArg::Reinhard => view::ToneMap::Reinhard,
            },
            false_colour: args.false_colour,
            range,
            mesh: args.mesh,
            backfaces: args.backfaces,
            msaa: args.msaa,
            background: args.background.to_array(),
        };
        // Usage errors (camera names, …) before the GPU is needed.
        let plan =
            view::plan(&model, &o).map_err(|m| cli::Failure::input(format!("error: {m}")))?;
        drop(model);
        let t_plan = t0.elapsed();
        let backend = match args.gpu_backend {
            BackendArg::Auto => gpu::Backend::Auto,
            BackendArg::Vulkan => gpu::Backend::Vulkan,
            BackendArg::Gl => gpu::Backend::Gl,
        };
        let g = gpu::open(&gpu::Request {
            backend,
            ..Default::default()
        })
        .map_err(|e| cli::Failure::runtime(format!("error: {e}")))?;
        c.verbose(format!("device: {}", g.describe()));
        let t_device = t0.elapsed();
        let pic =
            view::draw(&g, plan, &o).map_err(|e| cli::Failure::runtime(format!("error: {e}")))?;
        let t_draw = t0.elapsed();
        for n in &pic.notes {
            if n.starts_with("warning:") && !c.quiet {
                eprintln!("{n}");
            } else {
                c.verbose(n);
            }
        }
        let png = pic
            .png()
            .map_err(|e| cli::Failure::runtime(format!("error: {e}")))?;
        let t_png = t0.elapsed();
        c.verbose(format!(
            "times: read {:.3} s, scene and camera {:.3} s, device {:.3} s, render and tone map {:.3} s, PNG {:.3} s",
            t_load.as_secs_f64(),
            (t_plan - t_load).as_secs_f64(),
            (t_device - t_plan).as_secs_f64(),
            (t_draw - t_device).as_secs_f64(),
            (t_png - t_draw).as_secs_f64()
        ));
        c.write(&png)
    })
}
