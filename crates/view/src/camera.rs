//! Cameras: UG `cam` statements, explicit eye/look/up, the default framing
//! view and the overhead plan view.

use glam::dcamera::rh::proj::directx as proj;
use glam::dcamera::rh::view;
use glam::{DMat4, DVec3};

/// A pinhole (perspective) or orthographic camera in model coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub look: DVec3,
    pub up: DVec3,
    /// Vertical field of view in degrees (perspective).
    pub fov_deg: f64,
    /// Half of the visible height in model units (orthographic), or None.
    pub ortho_half_height: Option<f64>,
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl Bounds {
    pub fn of(points: impl IntoIterator<Item = DVec3>) -> Option<Bounds> {
        let mut it = points.into_iter();
        let first = it.next()?;
        let mut b = Bounds {
            min: first,
            max: first,
        };
        for p in it {
            b.min = b.min.min(p);
            b.max = b.max.max(p);
        }
        Some(b)
    }
    pub fn centre(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }
    pub fn radius(&self) -> f64 {
        ((self.max - self.min).length() * 0.5).max(1e-9)
    }
    pub fn corners(&self) -> [DVec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            DVec3::new(a.x, a.y, a.z),
            DVec3::new(b.x, a.y, a.z),
            DVec3::new(a.x, b.y, a.z),
            DVec3::new(b.x, b.y, a.z),
            DVec3::new(a.x, a.y, b.z),
            DVec3::new(b.x, a.y, b.z),
            DVec3::new(a.x, b.y, b.z),
            DVec3::new(b.x, b.y, b.z),
        ]
    }
}

/// Reads `-eye X Y Z -look X Y Z -up X Y Z -fov DEG` from a `cam`
/// statement's words (`-pos` is taken as `-eye`, `-at` as `-look`; other
/// words are ignored). `-up` defaults to +z and `-fov` to 45°; a camera
/// without `-eye` or `-look` is an error naming what is missing.
pub fn parse_cam_words(words: &[String]) -> Result<Camera, String> {
    let mut eye = None;
    let mut look = None;
    let mut up = None;
    let mut fov = None;
    let num = |i: usize| -> Result<f64, String> {
        let w = words.get(i).ok_or("a number is missing")?;
        w.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("'{w}' is not a number"))
    };
    let vec3 =
        |i: usize| -> Result<DVec3, String> { Ok(DVec3::new(num(i)?, num(i + 1)?, num(i + 2)?)) };
    let mut i = 0;
    while i < words.len() {
        match words[i].as_str() {
            "-eye" | "-pos" => {
                eye = Some(vec3(i + 1)?);
                i += 4;
            }
            "-look" | "-at" => {
                look = Some(vec3(i + 1)?);
                i += 4;
            }
            "-up" => {
                up = Some(vec3(i + 1)?);
                i += 4;
            }
            "-fov" => {
                fov = Some(num(i + 1)?);
                i += 2;
            }
            _ => i += 1,
        }
    }
    let eye = eye.ok_or("the camera has no -eye X Y Z")?;
    let look = look.ok_or("the camera has no -look X Y Z")?;
    let cam = Camera {
        eye,
        look,
        up: up.unwrap_or(DVec3::Z),
        fov_deg: fov.unwrap_or(45.0),
        ortho_half_height: None,
    };
    cam.validate()?;
    Ok(cam)
}

impl Camera {
    /// Checks that the camera defines a view.
    pub fn validate(&self) -> Result<(), String> {
        let d = self.look - self.eye;
        if d.length().is_nan() || d.length() <= 0.0 {
            return Err("eye and look are the same point".into());
        }
        if d.normalize().cross(self.up).length() < 1e-9 {
            return Err("the up vector is parallel to the view direction".into());
        }
        if self.ortho_half_height.is_none() && !(self.fov_deg > 0.0 && self.fov_deg < 179.0) {
            return Err(format!(
                "field of view {} is not in (0, 179) degrees",
                self.fov_deg
            ));
        }
        Ok(())
    }

    /// The default view: from above-front-left of the model, looking at its
    /// centre, far enough that the bounding sphere fits the narrower field of
    /// view (so the whole model is in the picture).
    pub fn framing(b: &Bounds, up: DVec3, fov_deg: f64, aspect: f64) -> Camera {
        let up = up.normalize();
        // A horizontal direction: the world axis least aligned with up.
        let side = if up.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let right = (side - up * side.dot(up)).normalize();
        let fwd = up.cross(right);
        let dir = (-right * 0.55 - fwd * 1.0 + up * 0.75).normalize();
        let half_v = (fov_deg.to_radians() * 0.5).tan();
        let half = half_v.min(half_v * aspect).atan();
        let dist = b.radius() / half.sin() * 1.02;
        Camera {
            eye: b.centre() + dir * dist,
            look: b.centre(),
            up,
            fov_deg,
            ortho_half_height: None,
        }
    }

    /// An overhead orthographic plan view along -up, framing the box.
    pub fn top(b: &Bounds, up: DVec3, aspect: f64) -> Camera {
        let up = up.normalize();
        // Image "north": +y when z is up, else the axis least aligned with up.
        let north0 = if up.y.abs() < 0.9 {
            DVec3::Y
        } else {
            DVec3::NEG_Z
        };
        let north = (north0 - up * north0.dot(up)).normalize();
        let east = north.cross(up);
        let c = b.centre();
        let (mut w, mut h) = (0.0f64, 0.0f64);
        for p in b.corners() {
            w = w.max((p - c).dot(east).abs());
            h = h.max((p - c).dot(north).abs());
        }
        let half_h = h.max(w / aspect).max(1e-9) * 1.04;
        let height = b.radius() * 4.0;
        Camera {
            eye: c + up * height,
            look: c,
            up: north,
            fov_deg: 0.0,
            ortho_half_height: Some(half_h),
        }
    }

    /// Near and far distances that enclose the box.
    fn clip_range(&self, b: &Bounds) -> (f64, f64) {
        let d = (self.look - self.eye).normalize();
        let mut near = f64::INFINITY;
        let mut far = f64::NEG_INFINITY;
        for p in b.corners() {
            let z = (p - self.eye).dot(d);
            near = near.min(z);
            far = far.max(z);
        }
        let r = b.radius();
        let far = far.max(r * 1e-3) + r * 0.01;
        let near = if self.ortho_half_height.is_some() {
            near - r * 0.01
        } else {
            (near * 0.99).max(far * 1e-4)
        };
        (near, far)
    }

    /// World → clip transform (wgpu's depth range 0..1), for a picture of the
    /// given aspect (width / height). Coordinates are taken relative to
    /// `origin` (so that f32 keeps precision far from the model's origin).
    pub fn view_proj(&self, b: &Bounds, aspect: f64, origin: DVec3) -> DMat4 {
        let view = view::look_at_mat4(self.eye - origin, self.look - origin, self.up);
        let (near, far) = self.clip_range(b);
        let proj = match self.ortho_half_height {
            Some(hh) => proj::orthographic(-hh * aspect, hh * aspect, -hh, hh, near, far),
            None => proj::perspective(self.fov_deg.to_radians(), aspect, near, far),
        };
        proj * view
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn cornell_camera_words() {
        let c = parse_cam_words(&words(
            "-eye 278 273 -800 -look 278 273 0 -up 0 1 0 -fov 39.31",
        ))
        .unwrap();
        assert_eq!(c.eye, DVec3::new(278.0, 273.0, -800.0));
        assert_eq!(c.look, DVec3::new(278.0, 273.0, 0.0));
        assert_eq!(c.up, DVec3::Y);
        assert_eq!(c.fov_deg, 39.31);
        assert!(
            parse_cam_words(&words("-pos 0 0 10"))
                .unwrap_err()
                .contains("-look")
        );
        assert!(
            parse_cam_words(&words("-eye 0 0 x -look 0 0 0"))
                .unwrap_err()
                .contains("'x'")
        );
        assert!(parse_cam_words(&words("-eye 0 0 1 -look 0 0 0 -up 0 0 1")).is_err());
    }

    fn all_inside(c: &Camera, b: &Bounds, aspect: f64) -> bool {
        let m = c.view_proj(b, aspect, b.centre());
        b.corners().iter().all(|p| {
            let q = m * (*p - b.centre()).extend(1.0);
            let n = q.truncate() / q.w;
            q.w > 0.0 && n.x.abs() <= 1.0 && n.y.abs() <= 1.0 && n.z >= 0.0 && n.z <= 1.0
        })
    }

    #[test]
    fn default_and_top_views_frame_the_whole_box() {
        for (min, max) in [
            (DVec3::ZERO, DVec3::new(4.0, 5.0, 3.0)),
            (DVec3::new(-100.0, 0.0, 7.0), DVec3::new(900.0, 20.0, 8.0)),
            (
                DVec3::new(1e6, 1e6, 0.0),
                DVec3::new(1e6 + 1.0, 1e6 + 1.0, 0.001),
            ),
        ] {
            let b = Bounds { min, max };
            for aspect in [0.5, 1.0, 4.0 / 3.0, 3.0] {
                for up in [DVec3::Z, DVec3::Y] {
                    let c = Camera::framing(&b, up, 40.0, aspect);
                    c.validate().unwrap();
                    assert!(all_inside(&c, &b, aspect), "{b:?} {aspect} {up}");
                    let t = Camera::top(&b, up, aspect);
                    t.validate().unwrap();
                    assert!(all_inside(&t, &b, aspect), "top {b:?} {aspect}");
                }
            }
        }
    }
}
