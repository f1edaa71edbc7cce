//! A lit model (ugrad's output) as a field of radiosity to look up at
//! points, and the comparison of estimates with it.
//!
//! In a lit model every vertex has a colour (`c_rgb _radN r g b`), the
//! radiosity B there. The value at a point of a face is interpolated
//! linearly on triangles: a convex face of one contour (ugrad's triangles
//! and quadrilaterals) is split into a fan from its first vertex, as ugview
//! draws it (a quadrilateral along the diagonal from its first vertex), any
//! other face as [`crate::triangulate`] splits it.

use geom::bvh::{Bvh, Triangle};
use glam::DVec3;
use ug::Model;

use crate::{Estimate, Rgb, diagonal, face_label, luminance, nearest_triangle};

struct LitTri {
    p: [DVec3; 3],
    normal: DVec3,
    colour: [Rgb; 3],
}

/// The radiosity field of a lit model.
pub struct Lit {
    tris: Vec<LitTri>,
    bvh: Bvh,
    diagonal: f64,
}

impl Lit {
    /// Reads a lit model (flattened first when it has instances). An error
    /// when a vertex of a face has no colour (the model is not ugrad's
    /// output) or no face has area.
    pub fn new(model: &Model) -> Result<Lit, String> {
        let flat;
        let m = if model.is_flat() {
            model
        } else {
            flat = model.flatten().map_err(|d| d.to_string())?;
            &flat
        };
        let mut tris = Vec::new();
        for (k, f) in m.top_faces().enumerate() {
            let face = m.face(f);
            if face.contours.first().is_none_or(|c| c.len() < 3) {
                continue;
            }
            let mut colours = Vec::new();
            for &v in face.contours.iter().flatten() {
                let vx = m.vertex(v);
                let c = vx
                    .color
                    .and_then(|id| m.materials.get(id.idx()))
                    .map(|mat| mat.diffuse());
                match c {
                    Some(c) => colours.push(c),
                    None => {
                        return Err(format!(
                            "face {}: vertex {} has no colour (a lit model, ugrad's output, has one on every vertex)",
                            face_label(m, f, k),
                            vx.name
                        ));
                    }
                }
            }
            let pts: Vec<Vec<DVec3>> = face
                .contours
                .iter()
                .map(|c| c.iter().map(|&v| m.pos(v)).collect())
                .collect();
            let Some(normal) = geom::polygon::face_normal(&pts) else {
                continue;
            };
            let ix: Vec<[usize; 3]> = if pts.len() == 1 && is_convex(&pts[0], normal) {
                (1..pts[0].len() - 1).map(|i| [0, i, i + 1]).collect()
            } else {
                crate::triangulate(&pts)
            };
            let all: Vec<DVec3> = pts.iter().flatten().copied().collect();
            for t in ix {
                let mut t = t;
                let c = (all[t[1]] - all[t[0]]).cross(all[t[2]] - all[t[0]]);
                let len = c.length();
                if !(len > 0.0 && len.is_finite()) {
                    continue;
                }
                let mut n = c / len;
                if n.dot(normal) < 0.0 {
                    t.swap(1, 2);
                    n = -n;
                }
                tris.push(LitTri {
                    p: t.map(|i| all[i]),
                    normal: n,
                    colour: t.map(|i| colours[i]),
                });
            }
        }
        if tris.is_empty() {
            return Err("the lit model has no face with area".to_string());
        }
        let bvh = Bvh::new(
            tris.iter()
                .enumerate()
                .map(|(i, t)| Triangle {
                    p: t.p,
                    id: i as u32,
                })
                .collect(),
        );
        Ok(Lit {
            tris,
            bvh,
            diagonal: diagonal(m),
        })
    }

    /// The lit model's bounding-box diagonal.
    pub fn diagonal(&self) -> f64 {
        self.diagonal
    }

    /// The interpolated radiosity at `p` on a face whose front faces `n`
    /// (within about 25°), its plane within `tol` of `p` (the nearest such
    /// plane); `None` when no face of the lit model holds the point.
    pub fn lookup(&self, p: DVec3, n: DVec3, tol: f64) -> Option<Rgb> {
        let f = nearest_triangle(
            &self.bvh,
            self.tris.len(),
            |i| (self.tris[i].p, self.tris[i].normal),
            p,
            n,
            tol,
        )?;
        let c = &self.tris[f.index].colour;
        Some([0, 1, 2].map(|k| f.bary[0] * c[0][k] + f.bary[1] * c[1][k] + f.bary[2] * c[2][k]))
    }
}

/// Whether a polygon is convex (no turn against `n`; collinear runs allowed).
fn is_convex(pts: &[DVec3], n: DVec3) -> bool {
    let k = pts.len();
    (0..k).all(|i| {
        let (a, b, c) = (pts[i], pts[(i + 1) % k], pts[(i + 2) % k]);
        (b - a).cross(c - b).dot(n) >= 0.0
    })
}

/// One compared point.
#[derive(Clone, Copy, Debug)]
pub struct PointError {
    /// Index into the points compared.
    pub index: usize,
    /// The estimate's B.
    pub reference: Rgb,
    /// The lit model's B.
    pub lit: Rgb,
    /// (Y_lit − Y_ref) / max(Y_ref, floor).
    pub error: f64,
    /// The estimate's standard error of Y over the same denominator.
    pub rel_se: f64,
}

/// What a comparison found.
#[derive(Clone, Copy, Debug)]
pub struct Summary {
    /// √(mean error²).
    pub rms: f64,
    /// max |error|.
    pub max: f64,
    /// Points compared.
    pub n: usize,
    /// √(mean rel_se²): the part of `rms` that is the estimate's own noise
    /// (rms² ≈ true rms² + se²).
    pub se: f64,
    /// The smallest denominator: 0.05 × the mean reference luminance.
    pub floor: f64,
}

/// The fraction of the mean reference luminance below which a point's
/// error is relative to that fraction instead of its own luminance.
pub const DARK: f64 = 0.05;

/// Compares estimates with lit values (`None`: not found, left out). The
/// error of a point is relative, in luminance Y: (Y_lit − Y_ref) /
/// max(Y_ref, [`DARK`] × mean Y_ref), the mean over the points compared, so
/// that points in deep shadow do not divide by almost nothing. Returns
/// every point's error (in input order) and the summary; an error when no
/// point was found or the mean reference luminance is not positive.
pub fn compare(
    estimates: &[Estimate],
    lit: &[Option<Rgb>],
) -> Result<(Vec<PointError>, Summary), String> {
    let pairs: Vec<(usize, &Estimate, Rgb)> = estimates
        .iter()
        .zip(lit)
        .enumerate()
        .filter_map(|(i, (e, l))| l.map(|l| (i, e, l)))
        .collect();
    if pairs.is_empty() {
        return Err("no point was found on a face of the lit model".to_string());
    }
    let mean = pairs.iter().map(|(_, e, _)| e.y).sum::<f64>() / pairs.len() as f64;
    if !(mean > 0.0 && mean.is_finite()) {
        return Err(format!(
            "the mean reference luminance is {mean}: nothing lights the points compared"
        ));
    }
    let floor = DARK * mean;
    let errors: Vec<PointError> = pairs
        .iter()
        .map(|&(index, e, l)| {
            let den = e.y.max(floor);
            PointError {
                index,
                reference: e.b,
                lit: l,
                error: (luminance(l) - e.y) / den,
                rel_se: e.se_y / den,
            }
        })
        .collect();
    let k = errors.len() as f64;
    let summary = Summary {
        rms: (errors.iter().map(|p| p.error * p.error).sum::<f64>() / k).sqrt(),
        max: errors.iter().map(|p| p.error.abs()).fold(0.0, f64::max),
        n: errors.len(),
        se: (errors.iter().map(|p| p.rel_se * p.rel_se).sum::<f64>() / k).sqrt(),
        floor,
    };
    Ok((errors, summary))
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIT: &str = "\
c_rgb white 0.5 0.5 0.5;
c_rgb _rad0 0 0 0;
c_rgb _rad1 1 2 3;
c_rgb _rad2 2 2 2;
v a 0 0 0 _rad0;
v b 1 0 0 _rad1;
v c 1 1 0 _rad2;
v d 0 1 0 _rad1;
f q (a b c d) white;
";

    #[test]
    fn lookup_interpolates_on_the_fan_of_a_quad_and_respects_the_side() {
        let m = ug::parse(LIT.as_bytes(), "lit.ug").unwrap().model;
        let lit = Lit::new(&m).unwrap();
        // On the diagonal a–c: half of c's colour.
        let c = lit
            .lookup(DVec3::new(0.5, 0.5, 0.0), DVec3::Z, 1e-6)
            .unwrap();
        assert!(c.iter().all(|&x| (x - 1.0).abs() < 1e-12), "{c:?}");
        // Triangle a b c at (0.75, 0.25): a 0.25, b 0.5, c 0.25.
        let c = lit
            .lookup(DVec3::new(0.75, 0.25, 1e-7), DVec3::Z, 1e-6)
            .unwrap();
        let want = [0.5 + 0.5, 1.0 + 0.5, 1.5 + 0.5];
        assert!(
            c.iter().zip(want).all(|(x, w)| (x - w).abs() < 1e-9),
            "{c:?}"
        );
        // From behind, off the plane, or outside: nothing.
        assert!(
            lit.lookup(DVec3::new(0.5, 0.5, 0.0), -DVec3::Z, 1e-6)
                .is_none()
        );
        assert!(
            lit.lookup(DVec3::new(0.5, 0.5, 0.1), DVec3::Z, 1e-6)
                .is_none()
        );
        assert!(
            lit.lookup(DVec3::new(1.5, 0.5, 0.0), DVec3::Z, 1e-6)
                .is_none()
        );
        // A vertex (on the edge between the fan's triangles).
        let c = lit
            .lookup(DVec3::new(1.0, 1.0, 0.0), DVec3::Z, 1e-6)
            .unwrap();
        assert!(c.iter().all(|&x| (x - 2.0).abs() < 1e-12), "{c:?}");
    }

    #[test]
    fn a_model_without_colours_is_not_lit() {
        let src = LIT.replace(" _rad1;", ";");
        let m = ug::parse(src.as_bytes(), "lit.ug").unwrap().model;
        let e = Lit::new(&m).err().unwrap();
        assert!(e.contains("vertex b has no colour"), "{e}");
    }

    #[test]
    fn errors_are_relative_with_a_floor_for_dark_points() {
        let est = |y: f64| Estimate {
            b: [y; 3],
            se: [0.01; 3],
            y,
            se_y: 0.01,
            samples: 100,
        };
        let estimates = [est(1.0), est(1.0), est(0.0), est(2.0)];
        let lit = [Some([1.1; 3]), Some([0.9; 3]), Some([0.05; 3]), None];
        let (errors, s) = compare(&estimates, &lit).unwrap();
        assert_eq!(s.n, 3);
        // Mean Y_ref of the compared points: 2/3; floor 1/30.
        assert!((s.floor - 0.05 * 2.0 / 3.0).abs() < 1e-12);
        assert!((errors[0].error - 0.1).abs() < 1e-9);
        assert!((errors[1].error + 0.1).abs() < 1e-9);
        assert!((errors[2].error - 0.05 / s.floor).abs() < 1e-9);
        assert!((s.max - 1.5).abs() < 1e-9);
        let rms = ((0.01 + 0.01 + 2.25) / 3.0f64).sqrt();
        assert!((s.rms - rms).abs() < 1e-9);
        assert!(compare(&estimates, &[None, None, None, None]).is_err());
    }
}
