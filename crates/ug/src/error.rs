//! Diagnostics with source positions: `file:line:col: error: message`.

use std::fmt;

/// A position in a source file (1-based line and column; columns count characters).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Pos {
    pub file: String,
    pub line: u32,
    pub col: u32,
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.col)
    }
}

/// Severity of a diagnostic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    Error,
    Warning,
}

/// A diagnostic: a parse error, a warning, or an error found while flattening.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    pub level: Level,
    /// Where it happened; `None` for errors that have no single position.
    pub pos: Option<Pos>,
    pub message: String,
}

impl Diagnostic {
    pub fn error(pos: Pos, message: impl Into<String>) -> Self {
        Diagnostic {
            level: Level::Error,
            pos: Some(pos),
            message: message.into(),
        }
    }
    pub fn warning(pos: Pos, message: impl Into<String>) -> Self {
        Diagnostic {
            level: Level::Warning,
            pos: Some(pos),
            message: message.into(),
        }
    }
    /// An error without a source position (e.g. an unreadable file).
    pub fn plain(message: impl Into<String>) -> Self {
        Diagnostic {
            level: Level::Error,
            pos: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let level = match self.level {
            Level::Error => "error",
            Level::Warning => "warning",
        };
        match &self.pos {
            Some(p) => write!(f, "{p}: {level}: {}", self.message),
            None => write!(f, "{level}: {}", self.message),
        }
    }
}

impl std::error::Error for Diagnostic {}

/// Shortens a piece of offending source text for quoting in a message.
pub(crate) fn quote(text: &[u8]) -> String {
    const MAX: usize = 40;
    let s = String::from_utf8_lossy(text);
    let mut out: String = s.chars().take(MAX).collect();
    if s.chars().count() > MAX {
        out.push('…');
    }
    // Control characters and the like are escaped (`\u{feff}`); quotes are not.
    let mut shown = String::with_capacity(out.len() + 2);
    shown.push('\'');
    for c in out.chars() {
        if matches!(c, '"' | '\'') {
            shown.push(c);
        } else {
            shown.extend(c.escape_debug());
        }
    }
    shown.push('\'');
    shown
}
