//! Points files: one point a line, `x y z nx ny nz` (the position and the
//! normal of the side it is seen from), separated by spaces or tabs; `#`
//! starts a comment to the end of the line; blank lines are allowed.

use glam::DVec3;

/// A point read from a points file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Line number (from 1).
    pub line: usize,
    pub position: DVec3,
    /// As written (not normalised; never zero).
    pub normal: DVec3,
}

/// Parses a points file; `name` is used in messages, which read
/// `NAME:LINE:COL: error: …`. An error when a line is not six finite
/// numbers, a normal is zero, or there is no point at all.
pub fn parse(bytes: &[u8], name: &str) -> Result<Vec<Point>, String> {
    let mut out = Vec::new();
    for (k, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = k + 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let body = match raw.iter().position(|&b| b == b'#') {
            Some(i) => &raw[..i],
            None => raw,
        };
        let text = std::str::from_utf8(body).map_err(|e| {
            format!(
                "{name}:{line}:{}: error: not UTF-8 text",
                e.valid_up_to() + 1
            )
        })?;
        let mut words = Vec::new();
        let mut start = None;
        for (i, ch) in text.char_indices() {
            if ch == ' ' || ch == '\t' {
                if let Some(s) = start.take() {
                    words.push((s, &text[s..i]));
                }
            } else if start.is_none() {
                start = Some(i);
            }
        }
        if let Some(s) = start {
            words.push((s, &text[s..]));
        }
        if words.is_empty() {
            continue;
        }
        let mut v = [0.0; 6];
        for (j, &(col, w)) in words.iter().enumerate() {
            if j == 6 {
                return Err(format!(
                    "{name}:{line}:{}: error: expected 6 numbers (x y z nx ny nz), found more",
                    col + 1
                ));
            }
            match w.parse::<f64>() {
                Ok(x) if x.is_finite() => v[j] = x,
                _ => {
                    return Err(format!(
                        "{name}:{line}:{}: error: '{w}' is not a finite number",
                        col + 1
                    ));
                }
            }
        }
        if words.len() < 6 {
            return Err(format!(
                "{name}:{line}:{}: error: expected 6 numbers (x y z nx ny nz), found {}",
                text.trim_end_matches([' ', '\t']).len() + 1,
                words.len()
            ));
        }
        let normal = DVec3::new(v[3], v[4], v[5]);
        if normal.length_squared() == 0.0 || !normal.length_squared().is_finite() {
            return Err(format!(
                "{name}:{line}:{}: error: the normal ({} {} {}) has no direction",
                words[3].0 + 1,
                words[3].1,
                words[4].1,
                words[5].1
            ));
        }
        out.push(Point {
            line,
            position: DVec3::new(v[0], v[1], v[2]),
            normal,
        });
    }
    if out.is_empty() {
        return Err(format!(
            "{name}: error: no points (lines of x y z nx ny nz)"
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_comments_and_blank_lines() {
        let p = parse(
            b"# x y z nx ny nz\n\n1 2 3 0 0 1\r\n\t4 5 6\t0 1 0 # wall\n",
            "p.txt",
        )
        .unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].line, 3);
        assert_eq!(p[1].position, DVec3::new(4.0, 5.0, 6.0));
        assert_eq!(p[1].normal, DVec3::Y);
    }

    #[test]
    fn bad_lines_name_the_place() {
        let e = |s: &str| parse(s.as_bytes(), "p.txt").unwrap_err();
        assert_eq!(
            e("1 2 3 0 0 1\n1 2 x 0 0 1\n"),
            "p.txt:2:5: error: 'x' is not a finite number"
        );
        assert_eq!(
            e("1 2 3 0 0\n"),
            "p.txt:1:10: error: expected 6 numbers (x y z nx ny nz), found 5"
        );
        assert_eq!(
            e("1 2 3 0 0 1 7\n"),
            "p.txt:1:13: error: expected 6 numbers (x y z nx ny nz), found more"
        );
        assert_eq!(
            e("1 2 3 0 0 0\n"),
            "p.txt:1:7: error: the normal (0 0 0) has no direction"
        );
        assert_eq!(
            e("1 2 3 nan 0 1"),
            "p.txt:1:7: error: 'nan' is not a finite number"
        );
        assert_eq!(
            e("# nothing\n"),
            "p.txt: error: no points (lines of x y z nx ny nz)"
        );
    }
}
