//! From the HDR picture to display pixels: exposure (manual or from the
//! log-average luminance), tone mapping, sRGB encoding, false colour and its
//! legend.

use crate::legend;

/// How radiance becomes display values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ToneMap {
    /// Linear, clipped at 1 (photometrically faithful below white).
    #[default]
    Clamp,
    /// x / (1 + x): keeps detail in bright areas.
    Reinhard,
}

/// An HDR picture: linear RGB per pixel, and whether a surface covers it.
#[derive(Clone, Debug)]
pub struct Hdr {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance (model units), row-major, top row first.
    pub rgb: Vec<[f32; 3]>,
    /// Coverage by a surface in 0..1 (anti-aliased edges are fractional).
    pub coverage: Vec<f32>,
    /// Overlay (mesh lines, back-face marking): linear RGB premultiplied by
    /// alpha, drawn over the tone-mapped picture unchanged by exposure.
    pub overlay: Vec<[f32; 4]>,
}

/// Middle grey that the log-average luminance is mapped to (Reinhard's key).
pub const KEY: f64 = 0.18;

/// Pixels darker than this fraction of the brightest are not lit: left out
/// of the automatic exposure. Tiny on purpose: a lamp in view is hundreds
/// of times brighter than a dim corner, which is still lit; what is left
/// out is the black of surfaces no light reaches (their radiosity is 0).
pub const LIT: f64 = 1e-6;

/// The exposure (a multiplier) that maps the log-average luminance of the
/// lit pixels (covered, and brighter than [`LIT`] × the brightest) to
/// [`KEY`]; 1 when nothing is covered or all is black. Only the lit pixels
/// count: a lit building seen from outside is mostly unlit exterior, whose
/// black would otherwise drag the average down and turn the visible
/// interior white.
pub fn auto_exposure(h: &Hdr) -> f64 {
    let mut sum = 0.0;
    let mut n = 0.0;
    // δ keeps black pixels from sending the log average to zero.
    // Never below zero, never NaN: a negative or non-finite pixel would
    // make the log average NaN and the whole picture black.
    let lum: Vec<f64> = h
        .rgb
        .iter()
        .map(|c| crate::scene::luminance(c.map(f64::from)))
        .map(|l| if l.is_finite() { l.max(0.0) } else { 0.0 })
        .collect();
    let counted = |i: usize| h.coverage[i] > 0.5 && h.overlay[i][3] < 0.5;
    let peak = (0..lum.len())
        .filter(|&i| counted(i))
        .map(|i| lum[i])
        .fold(0.0, f64::max);
    if peak <= 0.0 {
        return 1.0;
    }
    let delta = peak * 1e-4;
    for (i, &l) in lum.iter().enumerate() {
        if counted(i) && l > LIT * peak {
            sum += (delta + l).ln();
            n += 1.0;
        }
    }
    if n == 0.0 {
        return 1.0;
    }
    KEY / (sum / n).exp()
}

/// The sRGB transfer function (IEC 61966-2-1), for x in 0..1.
pub fn srgb_encode(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

fn to_u8(x: f64) -> u8 {
    (x * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Display pixels (RGB8, sRGB) from an HDR picture.
pub fn tonemap(h: &Hdr, exposure: f64, map: ToneMap, background: [f64; 3]) -> Vec<u8> {
    let mut out = Vec::with_capacity(h.rgb.len() * 3);
    for (i, c) in h.rgb.iter().enumerate() {
        let a = f64::from(h.coverage[i]).clamp(0.0, 1.0);
        let o = h.overlay[i];
        let oa = f64::from(o[3]).clamp(0.0, 1.0);
        for k in 0..3 {
            // Resolved MSAA pixels hold coverage-weighted colour.
            let x = f64::from(c[k]) * exposure;
            let x = match map {
                ToneMap::Clamp => x,
                ToneMap::Reinhard => x / (1.0 + x),
            };
            let v = x.clamp(0.0, 1.0) + background[k] * (1.0 - a);
            // The overlay is premultiplied by its coverage.
            let v = v * (1.0 - oa) + f64::from(o[k]);
            out.push(to_u8(srgb_encode(v)));
        }
    }
    out
}

/// The false-colour scale: luminance `lo..hi` (model units of radiance),
/// logarithmic when `log`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

impl Scale {
    /// A scale from the covered pixels: 1st to 99th percentile of luminance;
    /// logarithmic when that spans more than a factor of 10.
    pub fn auto(h: &Hdr) -> Scale {
        let mut l: Vec<f64> = h
            .rgb
            .iter()
            .zip(&h.coverage)
            .zip(&h.overlay)
            .filter(|((_, a), o)| **a > 0.5 && o[3] < 0.5)
            .map(|((c, _), _)| crate::scene::luminance(c.map(f64::from)))
            .filter(|x| x.is_finite())
            .collect();
        if l.is_empty() {
            return Scale {
                lo: 0.0,
                hi: 1.0,
                log: false,
            };
        }
        l.sort_by(f64::total_cmp);
        let at = |q: f64| l[((l.len() - 1) as f64 * q).round() as usize];
        let (lo, hi) = (at(0.01), at(0.99));
        let hi = if hi > lo {
            hi
        } else {
            lo + lo.abs().max(1e-12)
        };
        if lo > 0.0 && hi / lo > 10.0 {
            Scale { lo, hi, log: true }
        } else {
            Scale {
                lo: 0.0,
                hi,
                log: false,
            }
        }
    }

    /// Position of a luminance on the scale, 0..1 (clamped).
    pub fn t(&self, l: f64) -> f64 {
        let t = if self.log {
            (l.max(self.lo * 1e-12).ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (l - self.lo) / (self.hi - self.lo)
        };
        if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The luminance at position t (inverse of [`Scale::t`]).
    pub fn value(&self, t: f64) -> f64 {
        if self.log {
            (self.lo.ln() + t * (self.hi.ln() - self.lo.ln())).exp()
        } else {
            self.lo + t * (self.hi - self.lo)
        }
    }
}

/// The colour ramp: dark blue → blue → cyan → green → yellow → red (sRGB 0..1).
pub fn ramp(t: f64) -> [f64; 3] {
    const STOPS: [[f64; 3]; 6] = [
        [0.0, 0.0, 0.35],
        [0.0, 0.2, 1.0],
        [0.0, 0.85, 0.9],
        [0.1, 0.8, 0.1],
        [1.0, 0.9, 0.0],
        [0.9, 0.0, 0.0],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    [0, 1, 2].map(|k| STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f)
}

/// Width in pixels of the legend strip added at the right.
pub const LEGEND_WIDTH: u32 = 96;

/// False-colour pixels (RGB8) with a legend strip at the right: the ramp
/// from lo (bottom) to hi (top) with labelled ticks.
pub fn false_colour(h: &Hdr, scale: Scale, background: [f64; 3]) -> (u32, Vec<u8>) {
    let w = h.width + LEGEND_WIDTH;
    let mut out = vec![0u8; (w * h.height * 3) as usize];
    let put = |out: &mut Vec<u8>, x: u32, y: u32, c: [f64; 3]| {
        let i = ((y * w + x) * 3) as usize;
        for k in 0..3 {
            out[i + k] = to_u8(c[k]);
        }
    };
    let bg_srgb = background.map(srgb_encode);
    for y in 0..h.height {
        for x in 0..h.width {
            let i = (y * h.width + x) as usize;
            let a = f64::from(h.coverage[i]).clamp(0.0, 1.0);
            let c = h.rgb[i].map(f64::from);
            // Un-weight anti-aliased edge pixels before measuring.
            let l = if a > 0.0 {
                crate::scene::luminance(c) / a
            } else {
                0.0
            };
            let rc = ramp(scale.t(l));
            let o = h.overlay[i];
            let oa = f64::from(o[3]).clamp(0.0, 1.0);
            let px = [0, 1, 2].map(|k| {
                let v = rc[k] * a + bg_srgb[k] * (1.0 - a);
                let ov = if oa > 0.0 { f64::from(o[k]) / oa } else { 0.0 };
                v * (1.0 - oa) + srgb_encode(ov) * oa
            });
            put(&mut out, x, y, px);
        }
    }
    // The legend: a bar 16 px wide, labels to its right.
    let (x0, bar_w) = (h.width + 6, 16);
    let (top, bottom) = (10u32, h.height.saturating_sub(10));
    for y in 0..h.height {
        for x in h.width..w {
            put(&mut out, x, y, [0.12; 3]);
        }
    }
    if bottom > top + 1 {
        for y in top..bottom {
            let t = 1.0 - f64::from(y - top) / f64::from(bottom - top - 1);
            for x in x0..x0 + bar_w {
                put(&mut out, x, y, ramp(t));
            }
        }
        let ticks = 5;
        for k in 0..=ticks {
            let t = f64::from(k) / f64::from(ticks);
            let y = bottom - 1 - ((t * f64::from(bottom - top - 1)).round() as u32);
            for x in x0 + bar_w..x0 + bar_w + 4 {
                put(&mut out, x, y, [1.0; 3]);
            }
            let label = legend::format_value(scale.value(t));
            let ly = y
                .saturating_sub(legend::GLYPH_H / 2)
                .min(h.height.saturating_sub(legend::GLYPH_H));
            legend::draw_text(&mut out, w, h.height, x0 + bar_w + 9, ly, &label);
        }
    }
    (w, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(w: u32, h: u32, c: f32) -> Hdr {
        let n = (w * h) as usize;
        Hdr {
            width: w,
            height: h,
            rgb: vec![[c; 3]; n],
            coverage: vec![1.0; n],
            overlay: vec![[0.0; 4]; n],
        }
    }

    #[test]
    fn srgb_curve_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-12);
        assert!((srgb_encode(0.5) * 255.0 - 187.5).abs() < 0.6);
        assert!((srgb_encode(0.18) * 255.0 - 117.9).abs() < 0.5);
        assert!((srgb_encode(0.002) - 0.02584).abs() < 1e-9);
    }

    #[test]
    fn auto_exposure_maps_the_log_average_to_middle_grey() {
        let h = flat(4, 4, 7.0);
        let e = auto_exposure(&h);
        let px = tonemap(&h, e, ToneMap::Clamp, [0.0; 3]);
        // 0.18 linear = 118 in sRGB, whatever the absolute level was.
        assert!(px.iter().all(|&v| v == 118), "{px:?}");
        // Uncovered pixels do not count.
        let mut h2 = flat(2, 1, 1.0);
        h2.rgb[1] = [1000.0; 3];
        h2.coverage[1] = 0.0;
        assert!((auto_exposure(&h2) - 0.18).abs() < 1e-4); // δ = 1e-4 of the peak
    }

    /// A lit interior seen through a dark exterior: the unlit pixels do not
    /// count, so the lit ones are exposed as if alone.
    #[test]
    fn auto_exposure_ignores_unlit_pixels() {
        let alone = auto_exposure(&flat(4, 4, 7.0));
        let mut h = flat(4, 4, 7.0);
        for i in 0..12 {
            h.rgb[i] = [0.0; 3];
        }
        let e = auto_exposure(&h);
        assert!((e - alone).abs() <= 1e-12 * alone, "{e} vs {alone}");
        // Dim but lit pixels still count.
        h.rgb[0] = [0.07; 3];
        assert!(auto_exposure(&h) > alone);
    }

    /// A slightly negative or NaN pixel (MSAA extrapolating a colour past a
    /// sliver's edge) once made the exposure NaN and the picture black.
    #[test]
    fn negative_or_nan_pixels_do_not_spoil_the_exposure() {
        let mut h = flat(4, 4, 7.0);
        let want = auto_exposure(&h);
        h.rgb[3] = [-1.0; 3];
        h.rgb[5] = [f32::NAN; 3];
        // They count as unlit: left out, as black pixels are.
        let e = auto_exposure(&h);
        assert!((e - want).abs() <= 1e-12 * want, "{e} vs {want}");
    }

    #[test]
    fn clamp_and_reinhard() {
        let h = flat(1, 1, 0.5);
        assert_eq!(tonemap(&h, 1.0, ToneMap::Clamp, [0.0; 3]), vec![188; 3]);
        assert_eq!(tonemap(&h, 4.0, ToneMap::Clamp, [0.0; 3]), vec![255; 3]);
        // 2/(1+2) = 2/3 → sRGB 213.
        assert_eq!(tonemap(&h, 4.0, ToneMap::Reinhard, [0.0; 3]), vec![213; 3]);
    }

    #[test]
    fn overlay_wins_over_exposure() {
        let mut h = flat(1, 1, 0.5);
        h.overlay[0] = [1.0, 0.0, 1.0, 1.0];
        assert_eq!(
            tonemap(&h, 100.0, ToneMap::Clamp, [0.0; 3]),
            vec![255, 0, 255]
        );
    }

    #[test]
    fn scale_and_ramp() {
        let s = Scale {
            lo: 1.0,
            hi: 1000.0,
            log: true,
        };
        assert!((s.t(31.6227766) - 0.5).abs() < 1e-6);
        assert!((s.value(s.t(123.0)) - 123.0).abs() < 1e-9);
        assert_eq!(s.t(0.0), 0.0);
        assert_eq!(s.t(1e9), 1.0);
        let lin = Scale {
            lo: 0.0,
            hi: 2.0,
            log: false,
        };
        assert_eq!(lin.t(1.0), 0.5);
        // The ramp runs from dark blue to red.
        assert!(ramp(0.0)[2] > ramp(0.0)[0]);
        assert!(ramp(1.0)[0] > ramp(1.0)[2]);
        let mut h = flat(10, 10, 1.0);
        for (i, c) in h.rgb.iter_mut().enumerate() {
            *c = [(i + 1) as f32; 3];
        }
        let a = Scale::auto(&h);
        assert!(
            a.log && (a.lo - 2.0).abs() < 1e-3 && (a.hi - 99.0).abs() < 1e-3,
            "{a:?}"
        );
    }

    #[test]
    fn false_colour_adds_a_legend() {
        let h = flat(40, 120, 1.0);
        let (w, px) = false_colour(
            &h,
            Scale {
                lo: 0.0,
                hi: 2.0,
                log: false,
            },
            [0.0; 3],
        );
        assert_eq!(w, 40 + LEGEND_WIDTH);
        assert_eq!(px.len(), (w * 120 * 3) as usize);
        // The picture shows the middle of the ramp.
        let mid = ramp(0.5).map(|v| (v * 255.0).round() as u8);
        assert_eq!(&px[0..3], &mid);
        // The bar's top is red, its bottom dark blue.
        let at = |x: u32, y: u32| {
            let i = ((y * w + x) * 3) as usize;
            [px[i], px[i + 1], px[i + 2]]
        };
        let bx = 40 + 6 + 8;
        assert!(at(bx, 11)[0] > 200 && at(bx, 11)[2] < 40);
        assert!(at(bx, 108)[2] > 60 && at(bx, 108)[0] < 20);
        // Labels were drawn: some white text pixels right of the bar.
        let text = (40 + 28..w)
            .flat_map(|x| (0..120).map(move |y| (x, y)))
            .filter(|&(x, y)| at(x, y) == [255; 3])
            .count();
        assert!(text > 30, "{text}");
    }
}
