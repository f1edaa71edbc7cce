//! Labels for the false-colour legend: a 5 × 7 pixel font for the characters
//! numbers need (`0-9 . - + e`), and number formatting with three
//! significant digits.

/// Glyph height in pixels (one row of spacing is left below).
pub const GLYPH_H: u32 = 7;
const GLYPH_W: u32 = 5;

/// Rows of 5 bits, most significant bit leftmost.
fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        ' ' => [0; 7],
        _ => return None,
    })
}

/// A value with three significant digits: `0.0123`, `12.3`, `1.23e+05`.
pub fn format_value(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".to_string();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (2 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.2e}");
        // Rust writes 1.23e5 / 1.23e-5: add the sign and two digits.
        match s.split_once('e') {
            Some((m, e)) => {
                let (sign, digits) = match e.strip_prefix('-') {
                    Some(d) => ('-', d),
                    None => ('+', e),
                };
                format!("{m}e{sign}{digits:0>2}")
            }
            None => s,
        }
    }
}

/// Draws `text` in white into an RGB8 picture `w` × `h` at (x, y), top-left.
/// Characters without a glyph are skipped; pixels outside are clipped.
pub fn draw_text(px: &mut [u8], w: u32, h: u32, x: u32, y: u32, text: &str) {
    let mut cx = x;
    for c in text.chars() {
        if let Some(g) = glyph(c) {
            for (row, bits) in g.iter().enumerate() {
                for col in 0..GLYPH_W {
                    if bits & (0x10 >> col) != 0 {
                        let (px_x, px_y) = (cx + col, y + row as u32);
                        if px_x < w && px_y < h {
                            let i = ((px_y * w + px_x) * 3) as usize;
                            px[i..i + 3].copy_from_slice(&[255; 3]);
                        }
                    }
                }
            }
        }
        cx += GLYPH_W + 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_significant_digits() {
        assert_eq!(format_value(0.0), "0");
        assert_eq!(format_value(1.0), "1");
        assert_eq!(format_value(12.345), "12.3");
        assert_eq!(format_value(0.012345), "0.0123");
        assert_eq!(format_value(123.45), "123");
        assert_eq!(format_value(54321.0), "54321");
        assert_eq!(format_value(123456.0), "1.23e+05");
        assert_eq!(format_value(0.000123), "1.23e-04");
        assert_eq!(format_value(-2.5), "-2.5");
        for v in [0.5, 3.0, 1e-7, 9.99e9] {
            assert!(format_value(v).chars().all(|c| glyph(c).is_some()));
        }
    }

    #[test]
    fn text_is_drawn_and_clipped() {
        let mut px = vec![0u8; 20 * 10 * 3];
        draw_text(&mut px, 20, 10, 0, 0, "8");
        // '8': rows of 3, 2, 2, 3, 2, 2, 3 pixels.
        let lit = px.chunks(3).filter(|p| p[0] == 255).count();
        assert_eq!(lit, 17);
        draw_text(&mut px, 20, 10, 18, 8, "888");
        assert_eq!(px.len(), 20 * 10 * 3);
    }
}
