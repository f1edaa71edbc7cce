//! ugview: render a UniGrafix model to a PNG picture.
//!
//! Lit models (ugrad output: per-vertex radiosity B) are Gouraud-shaded with
//! radiance B/π, exposed (manually in stops, or automatically from the
//! log-average luminance) and tone-mapped to sRGB; unlit models are
//! flat-shaded by material colour with a headlight. The camera comes from
//! the options, a UG `cam` statement, or a default view that frames the
//! model; `--top` draws an orthographic plan view with everything above a
//! cut height removed. Rasterisation runs on wgpu (lavapipe on machines
//! without a GPU); everything after it (exposure, tone mapping, false colour,
//! PNG encoding) runs on the CPU and is deterministic.

pub mod camera;
pub mod legend;
pub mod render;
pub mod scene;
pub mod tone;

use camera::{Bounds, Camera};
use glam::DVec3;
pub use render::RenderOptions;
pub use scene::Scene;
pub use tone::{Hdr, Scale, ToneMap};
use ug::{Item, Model};

/// Everything that decides the picture.
#[derive(Clone, Debug, Default)]
pub struct ViewOptions {
    pub width: u32,
    pub height: u32,
    pub eye: Option<DVec3>,
    pub look: Option<DVec3>,
    pub up: Option<DVec3>,
    pub fov: Option<f64>,
    /// Use the `cam` statement with this name.
    pub cam: Option<String>,
    pub top: bool,
    /// Remove everything above this height (along the up axis).
    pub cut_z: Option<f64>,
    /// Exposure in stops (radiance × 2^stops); automatic when None.
    pub exposure: Option<f64>,
    pub tonemap: ToneMap,
    pub false_colour: bool,
    /// False-colour range (luminance of radiance, model units).
    pub range: Option<(f64, f64)>,
    pub mesh: bool,
    pub backfaces: bool,
    pub msaa: u32,
    pub background: [f64; 3],
}

/// A finished picture.
#[derive(Clone, Debug)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    /// RGB8, sRGB, rows top first.
    pub rgb: Vec<u8>,
    /// What was decided on the way (for `-v`).
    pub notes: Vec<String>,
}

impl Picture {
    /// The picture as PNG bytes.
    pub fn png(&self) -> Result<Vec<u8>, String> {
        let img = image::RgbImage::from_raw(self.width, self.height, self.rgb.clone())
            .ok_or("picture buffer has the wrong size")?;
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png)
            .map_err(|e| format!("cannot encode PNG: {e}"))?;
        Ok(out.into_inner())
    }
}

/// The `cam` statements of a model: (name, words after the name).
pub fn cameras(m: &Model) -> Vec<(String, Vec<String>)> {
    m.items
        .iter()
        .filter_map(|it| match it {
            Item::Camera(raw) => {
                let mut w = raw.text.split_whitespace().map(String::from);
                let name = w.next()?;
                Some((name, w.collect()))
            }
            _ => None,
        })
        .collect()
}

/// Chooses the camera (see `--help`): `--top`; else a named or the first
/// `cam` statement, else the default framing view; then `--eye`, `--look`,
/// `--up`, `--fov` override parts of it. Errors are usage errors.
pub fn choose_camera(
    m: &Model,
    b: &Bounds,
    o: &ViewOptions,
    notes: &mut Vec<String>,
) -> Result<Camera, String> {
    let aspect = f64::from(o.width) / f64::from(o.height);
    let cams = cameras(m);
    let from_statement = match &o.cam {
        Some(name) => {
            let (_, words) = cams.iter().find(|(n, _)| n == name).ok_or_else(|| {
                let names: Vec<&str> = cams.iter().map(|(n, _)| n.as_str()).collect();
                if names.is_empty() {
                    format!("no camera named '{name}': the model has no cam statements")
                } else {
                    format!(
                        "no camera named '{name}'; the model has: {}",
                        names.join(", ")
                    )
                }
            })?;
            Some(camera::parse_cam_words(words).map_err(|e| format!("camera '{name}': {e}"))?)
        }
        None if o.top => None,
        None => match cams.first() {
            Some((name, words)) => match camera::parse_cam_words(words) {
                Ok(c) => {
                    notes.push(format!("camera: cam statement '{name}'"));
                    Some(c)
                }
                Err(e) => {
                    notes.push(format!("warning: camera '{name}' ignored: {e}"));
                    None
                }
            },
            None => None,
        },
    };
    let up =
        o.up.or(from_statement.as_ref().map(|c| c.up))
            .unwrap_or(DVec3::Z);
    if !up.is_finite() || up.length() <= 0.0 {
        return Err("--up must not be the zero vector".into());
    }
    if o.top {
        notes.push("camera: orthographic plan view".into());
        return Ok(Camera::top(b, up, aspect));
    }
    let mut cam = match from_statement {
        Some(c) => c,
        None => {
            notes.push("camera: default view framing the model".into());
            Camera::framing(b, up, o.fov.unwrap_or(45.0), aspect)
        }
    };
    if let Some(e) = o.eye {
        cam.eye = e;
    }
    if let Some(l) = o.look {
        cam.look = l;
    } else if o.eye.is_some() && o.cam.is_none() {
        cam.look = b.centre();
    }
    if let Some(u) = o.up {
        cam.up = u;
    }
    if let Some(f) = o.fov {
        cam.fov_deg = f;
    }
    cam.validate()?;
    Ok(cam)
}

/// The scene, camera and cut chosen for a model: everything decided before
/// the GPU is needed (so that usage errors do not depend on having one).
#[derive(Clone, Debug)]
pub struct Plan {
    pub scene: Scene,
    pub camera: Camera,
    pub render: RenderOptions,
    pub notes: Vec<String>,
}

/// Builds the scene and chooses the camera; errors are usage errors.
pub fn plan(m: &Model, o: &ViewOptions) -> Result<Plan, String> {
    let scene = Scene::from_model(m);
    let mut notes = vec![format!(
        "{} faces → {} triangles ({}), {} skipped",
        m.faces.len(),
        scene.triangles.len() / 3,
        if scene.lit {
            "lit: per-vertex radiosity"
        } else {
            "unlit: material colours"
        },
        scene.skipped
    )];
    if scene.unlit_in_lit > 0 {
        notes.push(format!(
            "warning: {} face(s) have no vertex colours; drawn with their emission only",
            scene.unlit_in_lit
        ));
    }
    let b = scene.bounds.unwrap_or(Bounds {
        min: DVec3::splat(-1.0),
        max: DVec3::splat(1.0),
    });
    let cam = choose_camera(m, &b, o, &mut notes)?;
    let up =
        o.up.unwrap_or(if o.top { cam_up_axis(&cam) } else { cam.up })
            .normalize();
    let cut = match (o.cut_z, o.top) {
        (Some(z), _) => Some(z),
        (None, true) => {
            // Halfway up the model: a plan cut (walls cut, ceilings and roofs gone).
            let (lo, hi) = b
                .corners()
                .iter()
                .map(|p| p.dot(up))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, c), x| {
                    (a.min(x), c.max(x))
                });
            Some(lo + 0.5 * (hi - lo))
        }
        (None, false) => None,
    };
    if let Some(z) = cut {
        notes.push(format!(
            "cut: everything above {z} along the up axis removed"
        ));
    }
    let render = RenderOptions {
        width: o.width,
        height: o.height,
        msaa: o.msaa,
        backfaces: o.backfaces,
        mesh: o.mesh,
        cut: cut.map(|z| (up, z)),
        ..Default::default()
    };
    Ok(Plan {
        scene,
        camera: cam,
        render,
        notes,
    })
}

/// Renders a planned picture and turns it into display pixels.
pub fn draw(g: &gpu::Gpu, plan: Plan, o: &ViewOptions) -> Result<Picture, gpu::GpuError> {
    let Plan {
        scene,
        camera,
        render,
        mut notes,
    } = plan;
    let hdr = render::render(g, &scene, &camera, &render)?;
    let (width, rgb) = if o.false_colour {
        let scale = match o.range {
            Some((lo, hi)) => Scale {
                lo,
                hi,
                log: lo > 0.0 && hi / lo > 10.0,
            },
            None => Scale::auto(&hdr),
        };
        notes.push(format!(
            "false colour: luminance {} to {} ({})",
            scale.lo,
            scale.hi,
            if scale.log { "log scale" } else { "linear" }
        ));
        tone::false_colour(&hdr, scale, o.background)
    } else {
        let exposure = match o.exposure {
            Some(stops) => 2f64.powf(stops),
            None if scene.lit => {
                let e = tone::auto_exposure(&hdr);
                notes.push(format!("auto exposure: {:+.2} stops", e.log2()));
                e
            }
            None => 1.0,
        };
        (
            o.width,
            tone::tonemap(&hdr, exposure, o.tonemap, o.background),
        )
    };
    Ok(Picture {
        width,
        height: o.height,
        rgb,
        notes,
    })
}

/// For the plan view the camera's `up` is the picture's north; the model's
/// up axis is the view direction reversed.
fn cam_up_axis(c: &Camera) -> DVec3 {
    (c.eye - c.look).normalize()
}

/// Parses `x,y,z`.
pub fn parse_vec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{p}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(x, y, z)),
        _ => Err(format!("expected x,y,z, got '{s}'")),
    }
}

/// Parses `WxH`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got '{s}'"))?;
    let p = |t: &str| {
        t.trim()
            .parse::<u32>()
            .ok()
            .filter(|&v| (1..=16384).contains(&v))
            .ok_or_else(|| format!("'{t}' is not a size in 1..16384"))
    };
    Ok((p(w)?, p(h)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_parsing() {
        assert_eq!(parse_vec3("1, 2,3.5").unwrap(), DVec3::new(1.0, 2.0, 3.5));
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,2,nan").is_err());
        assert_eq!(parse_size("640x480").unwrap(), (640, 480));
        assert!(parse_size("0x480").is_err());
        assert!(parse_size("640").is_err());
    }

    fn model(s: &str) -> Model {
        ug::parse(s.as_bytes(), "t.ug").unwrap().model
    }

    #[test]
    fn camera_choice() {
        let m = model(
            "v a 0 0 0; v b 1 0 0; v c 1 1 0; f q (a b c);
             cam side -eye 5 0 0 -look 0 0 0 -up 0 0 1 -fov 30;
             cam bad -eye 1 2;",
        );
        let b = Bounds {
            min: DVec3::ZERO,
            max: DVec3::ONE,
        };
        let mut o = ViewOptions {
            width: 100,
            height: 100,
            ..Default::default()
        };
        let mut notes = vec![];
        let c = choose_camera(&m, &b, &o, &mut notes).unwrap();
        assert_eq!(c.eye, DVec3::new(5.0, 0.0, 0.0));
        assert_eq!(c.fov_deg, 30.0);
        o.fov = Some(60.0);
        o.eye = Some(DVec3::new(0.0, 9.0, 0.0));
        let c = choose_camera(&m, &b, &o, &mut notes).unwrap();
        assert_eq!(
            (c.fov_deg, c.eye, c.look),
            (60.0, DVec3::new(0.0, 9.0, 0.0), b.centre())
        );
        o.cam = Some("bad".into());
        assert!(
            choose_camera(&m, &b, &o, &mut notes)
                .unwrap_err()
                .contains("camera 'bad'")
        );
        o.cam = Some("nope".into());
        let e = choose_camera(&m, &b, &o, &mut notes).unwrap_err();
        assert!(e.contains("side, bad"), "{e}");
        o.cam = None;
        o.top = true;
        let c = choose_camera(&m, &b, &o, &mut notes).unwrap();
        assert!(c.ortho_half_height.is_some());
    }
}
