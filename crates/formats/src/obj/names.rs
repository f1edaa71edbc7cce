//! UG identifiers from foreign names, made unique.

use rustc_hash::{FxHashMap, FxHashSet};

/// A foreign name as a UG identifier: letters, digits and `_ : # . -` are
/// kept, every other character (blanks, UG delimiters `;(){}`, quotes,
/// non-ASCII) becomes `_`. An empty name becomes `_`.
pub fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | ':' | '#' | '.' | '-') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() { "_".to_string() } else { s }
}

/// A material name: [`sanitize`]d, and prefixed with `m_` unless it begins
/// with a letter, `_`, `:` or `#`, so that it can never read as a number or
/// a transform flag where UG expects a colour.
pub fn sanitize_material(name: &str) -> String {
    let s = sanitize(name);
    let first = s.chars().next().unwrap_or('_');
    let lower = s.to_ascii_lowercase();
    if !(first.is_ascii_alphabetic() || matches!(first, '_' | ':' | '#'))
        || matches!(lower.as_str(), "inf" | "infinity" | "nan")
    {
        format!("m_{s}")
    } else {
        s
    }
}

/// Hands out unique names: a base name the first time, then `BASE.2`, `BASE.3`, …
/// (skipping names already taken).
#[derive(Default, Debug)]
pub struct Namer {
    used: FxHashSet<String>,
    next: FxHashMap<String, u64>,
}

impl Namer {
    /// Marks a name as taken.
    pub fn reserve(&mut self, name: &str) {
        self.used.insert(name.to_string());
    }

    /// A unique name derived from `base`.
    pub fn unique(&mut self, base: &str) -> String {
        if self.used.insert(base.to_string()) {
            return base.to_string();
        }
        let n = self.next.entry(base.to_string()).or_insert(2);
        loop {
            let cand = format!("{base}.{n}");
            *n += 1;
            if self.used.insert(cand.clone()) {
                return cand;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sanitising() {
        assert_eq!(sanitize("wall 3;(x)"), "wall_3__x_");
        assert_eq!(sanitize("café"), "caf_");
        assert_eq!(sanitize(""), "_");
        assert_eq!(sanitize("a:b#c.d-e"), "a:b#c.d-e");
        assert_eq!(sanitize_material("1"), "m_1");
        assert_eq!(sanitize_material("-red"), "m_-red");
        assert_eq!(sanitize_material("NaN"), "m_NaN");
        assert_eq!(sanitize_material("red"), "red");
    }

    #[test]
    fn unique_names() {
        let mut n = Namer::default();
        n.reserve("a.2");
        assert_eq!(n.unique("a"), "a");
        assert_eq!(n.unique("a"), "a.3");
        assert_eq!(n.unique("a"), "a.4");
        assert_eq!(n.unique("a.3"), "a.3.2");
        assert_eq!(n.unique("b"), "b");
    }
}
