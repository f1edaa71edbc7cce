//! MGF colours to RGB.
//!
//! MGF colours carry chromaticity only (the intensity comes from `rd`, `ed`,
//! …). Every colour form is reduced to CIE 1931 (x, y): `cxy` directly;
//! `cspec` and `cct` (a black body) through the colour matching functions,
//! here the multi-lobe Gaussian fit of Wyman, Sloan and Shirley (2013,
//! "Simple Analytic Approximations to the CIE XYZ Color Matching
//! Functions"), integrated in 1 nm steps over 360–830 nm; `cmix` mixes the
//! named colours' XYZ (each normalised to Y = 1) with the given weights.
//!
//! RGB: as Radiance's `mgf2rgb` does, XYZ with luminance Y = 1 goes to
//! linear RGB with the primaries R (0.640, 0.330), G (0.290, 0.600),
//! B (0.150, 0.060) and the equal-energy white (1/3, 1/3), so that MGF's
//! neutral colour is exactly (1, 1, 1); negative components (colours
//! outside the gamut) are clamped to 0.

use glam::{DMat3, DVec3};

/// A chromaticity; `neutral` marks MGF's default (equal-energy) colour exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chroma {
    pub x: f64,
    pub y: f64,
    pub neutral: bool,
}

impl Default for Chroma {
    fn default() -> Self {
        Chroma {
            x: 1.0 / 3.0,
            y: 1.0 / 3.0,
            neutral: true,
        }
    }
}

impl Chroma {
    pub fn xy(x: f64, y: f64) -> Chroma {
        Chroma {
            x,
            y,
            neutral: false,
        }
    }

    /// From XYZ (any scale); `None` when the sum is not positive and finite.
    pub fn from_xyz(c: DVec3) -> Option<Chroma> {
        let s = c.x + c.y + c.z;
        if !(s.is_finite() && s > 0.0 && c.y > 0.0) {
            return None;
        }
        Some(Chroma::xy(c.x / s, c.y / s))
    }

    /// XYZ with Y = 1.
    pub fn xyz(&self) -> DVec3 {
        DVec3::new(self.x / self.y, 1.0, (1.0 - self.x - self.y) / self.y)
    }

    /// Linear RGB with luminance 1 (negative components clamped to 0).
    pub fn rgb(&self) -> [f64; 3] {
        if self.neutral {
            return [1.0; 3];
        }
        let c = xyz_to_rgb() * self.xyz();
        [c.x.max(0.0), c.y.max(0.0), c.z.max(0.0)]
    }
}

/// The XYZ → RGB matrix for the primaries above and the equal-energy white.
fn xyz_to_rgb() -> DMat3 {
    let prim = |x: f64, y: f64| DVec3::new(x / y, 1.0, (1.0 - x - y) / y);
    let p = DMat3::from_cols(prim(0.640, 0.330), prim(0.290, 0.600), prim(0.150, 0.060));
    let s = p.inverse() * DVec3::ONE; // white E: XYZ (1, 1, 1)
    let rgb_to_xyz = DMat3::from_cols(p.x_axis * s.x, p.y_axis * s.y, p.z_axis * s.z);
    rgb_to_xyz.inverse()
}

fn lobe(l: f64, mu: f64, s1: f64, s2: f64) -> f64 {
    let t = (l - mu) / if l < mu { s1 } else { s2 };
    (-0.5 * t * t).exp()
}

/// The CIE 1931 2° colour matching functions at wavelength `l` (nm), fitted.
pub fn cmf(l: f64) -> DVec3 {
    DVec3::new(
        1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7)
            - 0.065 * lobe(l, 501.1, 20.4, 26.2),
        0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
        1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8),
    )
}

/// XYZ of a spectral distribution given as a function of wavelength (nm).
pub fn spectrum_xyz(s: impl Fn(f64) -> f64) -> DVec3 {
    let mut sum = DVec3::ZERO;
    let mut l = 360.0;
    while l <= 830.0 {
        sum += cmf(l) * s(l);
        l += 1.0;
    }
    sum
}

/// XYZ of `cspec lmin lmax v1 v2 …`: values evenly spaced from lmin to lmax,
/// linearly interpolated, zero outside.
pub fn cspec_xyz(lmin: f64, lmax: f64, v: &[f64]) -> DVec3 {
    let n = v.len();
    spectrum_xyz(|l| {
        if n < 2 || l < lmin || l > lmax {
            return 0.0;
        }
        let t = (l - lmin) / (lmax - lmin) * (n - 1) as f64;
        let i = (t.floor() as usize).min(n - 2);
        let f = t - i as f64;
        v[i] * (1.0 - f) + v[i + 1] * f
    })
}

/// XYZ of a black body at temperature `t` kelvin.
pub fn blackbody_xyz(t: f64) -> DVec3 {
    const C2: f64 = 1.438_776_877e-2; // m·K
    spectrum_xyz(|l| {
        let m = l * 1e-9;
        let e = (C2 / (m * t)).exp_m1();
        // Scaled by 1e-30 against overflow of m^5 at these wavelengths.
        if e.is_finite() && e > 0.0 {
            1.0 / ((m * 1e6).powi(5) * e)
        } else {
            0.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neutral_and_primaries() {
        assert_eq!(Chroma::default().rgb(), [1.0, 1.0, 1.0]);
        let e = Chroma::xy(1.0 / 3.0, 1.0 / 3.0).rgb();
        for c in e {
            assert!((c - 1.0).abs() < 1e-12, "{e:?}");
        }
        let r = Chroma::xy(0.64, 0.33).rgb();
        assert!(
            r[0] > 1.0 && r[1].abs() < 1e-12 && r[2].abs() < 1e-12,
            "{r:?}"
        );
        // Luminance of the result is 1: 0.2651 R + 0.6701 G + 0.0648 B (Radiance's weights).
        let c = Chroma::xy(0.4, 0.4).rgb();
        let y = 0.2651 * c[0] + 0.6701 * c[1] + 0.0648 * c[2];
        assert!((y - 1.0).abs() < 2e-3, "{y}");
    }

    #[test]
    fn flat_spectrum_is_near_white_and_blackbodies_follow_the_locus() {
        let c = Chroma::from_xyz(cspec_xyz(380.0, 780.0, &[1.0, 1.0])).unwrap();
        assert!(
            (c.x - 1.0 / 3.0).abs() < 0.01 && (c.y - 1.0 / 3.0).abs() < 0.01,
            "{c:?}"
        );
        // Planckian locus: 6500 K ≈ (0.3135, 0.3236), 2856 K (illuminant A) ≈ (0.4476, 0.4074).
        let d = Chroma::from_xyz(blackbody_xyz(6500.0)).unwrap();
        assert!(
            (d.x - 0.3135).abs() < 0.006 && (d.y - 0.3236).abs() < 0.006,
            "{d:?}"
        );
        let a = Chroma::from_xyz(blackbody_xyz(2856.0)).unwrap();
        assert!(
            (a.x - 0.4476).abs() < 0.006 && (a.y - 0.4074).abs() < 0.006,
            "{a:?}"
        );
        assert!(Chroma::from_xyz(blackbody_xyz(1e-3)).is_none());
    }
}
