//! Tokens of the UniGrafix language.
//!
//! Delimiters are white space, `;`, `(`, `)` and the comment braces `{ … }`
//! (which nest). Everything else is a *word*: a name, a keyword, a number or a
//! transform flag, told apart by the parser from its position in a statement.

use crate::error::{Diagnostic, Pos, quote};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Word,
    Semi,
    LParen,
    RParen,
    /// A comment; the token's text is what lies between the outer braces.
    Comment,
    Eof,
}

/// A token: its kind, its text (a slice of the source) and where it starts.
/// Kept small (offsets are `u32`: sources are limited to [`MAX_SOURCE`] bytes)
/// because the parser passes tokens around by value.
#[derive(Clone, Copy, Debug)]
pub struct Token<'a> {
    pub text: &'a [u8],
    /// Byte offset of the token's first byte.
    pub start: u32,
    /// 1-based line of `start`.
    pub line: u32,
    /// Byte offset where that line starts.
    pub line_start: u32,
    pub kind: Kind,
}

impl Token<'_> {
    /// Byte offset just past the token.
    #[inline]
    pub fn end(&self) -> usize {
        // A comment's text excludes its outer braces.
        let braces = if self.kind == Kind::Comment { 2 } else { 0 };
        self.start as usize + self.text.len() + braces
    }
}

/// The largest source the lexer accepts (offsets are 32-bit).
pub const MAX_SOURCE: usize = u32::MAX as usize;

/// A diagnostic in a box: errors are rare, and a small `Result` keeps the
/// token-by-token hot path cheap.
pub type PResult<T> = Result<T, Box<Diagnostic>>;

pub struct Lexer<'a> {
    src: &'a [u8],
    file: &'a str,
    i: usize,
    line: u32,
    line_start: usize,
    /// Where line 1 starts (after a byte order mark).
    first_line_start: usize,
}

/// Byte classes: 1 white space, 2 other delimiters (`;(){}`), 0 word bytes.
static CLASS: [u8; 256] = {
    let mut t = [0u8; 256];
    t[b' ' as usize] = 1;
    t[b'\t' as usize] = 1;
    t[b'\n' as usize] = 1;
    t[b'\r' as usize] = 1;
    t[0x0b] = 1;
    t[0x0c] = 1;
    t[b';' as usize] = 2;
    t[b'(' as usize] = 2;
    t[b')' as usize] = 2;
    t[b'{' as usize] = 2;
    t[b'}' as usize] = 2;
    t
};

#[inline]
pub(crate) fn is_delim(b: u8) -> bool {
    CLASS[b as usize] != 0
}

/// The length of the word at the start of `s`: the number of bytes before the
/// first delimiter (or `s.len()`). (Eight-bytes-at-a-time scanning was tried:
/// words are too short for it to pay.)
#[inline]
pub fn word_len(s: &[u8]) -> usize {
    s.iter().position(|&c| is_delim(c)).unwrap_or(s.len())
}

impl<'a> Lexer<'a> {
    pub fn new(src: &'a [u8], file: &'a str) -> Self {
        // A UTF-8 byte order mark is skipped.
        let i = if src.starts_with(&[0xEF, 0xBB, 0xBF]) {
            3
        } else {
            0
        };
        // Offsets are 32-bit; callers refuse larger sources (see `MAX_SOURCE`).
        let src = &src[..src.len().min(MAX_SOURCE)];
        Lexer {
            src,
            file,
            i,
            line: 1,
            line_start: i,
            first_line_start: i,
        }
    }

    pub fn src(&self) -> &'a [u8] {
        self.src
    }

    /// Byte offset of the next unread byte.
    #[inline]
    pub(crate) fn cursor(&self) -> usize {
        self.i
    }

    /// The current line and the offset where it starts.
    #[inline]
    pub(crate) fn line_info(&self) -> (u32, u32) {
        (self.line, self.line_start as u32)
    }

    /// Moves the cursor forward on the current line (the parser's fast paths
    /// read plain statements directly; they never cross a newline).
    #[inline]
    pub(crate) fn set_cursor(&mut self, i: usize) {
        debug_assert!(i >= self.i && !self.src[self.i..i].contains(&b'\n'));
        self.i = i;
    }

    pub fn file(&self) -> &'a str {
        self.file
    }

    /// Position (line, character column) of a byte offset on a line that starts at `line_start`.
    pub fn pos_of(&self, line: u32, line_start: usize, offset: usize) -> Pos {
        let prefix = &self.src[line_start.min(offset)..offset.min(self.src.len())];
        let col = String::from_utf8_lossy(prefix).chars().count() as u32 + 1;
        Pos {
            file: self.file.to_string(),
            line,
            col,
        }
    }

    pub fn pos(&self, t: &Token<'_>) -> Pos {
        self.pos_of(t.line, t.line_start as usize, t.start as usize)
    }

    /// Position just after a token (where a missing `;` belongs).
    pub fn pos_after(&self, t: &Token<'_>) -> Pos {
        // Comments can span lines; words and punctuation cannot.
        if t.kind == Kind::Comment {
            let (line, ls) = self.line_of(t.end());
            return self.pos_of(line, ls, t.end());
        }
        self.pos_of(t.line, t.line_start as usize, t.end())
    }

    fn line_of(&self, offset: usize) -> (u32, usize) {
        let mut line = 1u32;
        let mut ls = self.first_line_start;
        for (k, &b) in self.src[..offset.min(self.src.len())].iter().enumerate() {
            if b == b'\n' {
                line += 1;
                ls = k + 1;
            }
        }
        (line, ls)
    }

    #[inline]
    fn skip_ws(&mut self) {
        while let Some(&b) = self.src.get(self.i) {
            if CLASS[b as usize] != 1 {
                break;
            }
            self.i += 1;
            if b == b'\n' {
                self.line += 1;
                self.line_start = self.i;
            }
        }
    }

    /// The next token, or an error for an unbalanced comment brace.
    #[inline]
    pub fn next_token(&mut self) -> PResult<Token<'a>> {
        self.skip_ws();
        let start = self.i;
        let mk = |kind, text| Token {
            kind,
            text,
            start: start as u32,
            line: self.line,
            line_start: self.line_start as u32,
        };
        let Some(&b) = self.src.get(start) else {
            return Ok(mk(Kind::Eof, &self.src[start..start]));
        };
        let kind = match b {
            b';' => Kind::Semi,
            b'(' => Kind::LParen,
            b')' => Kind::RParen,
            b'{' | b'}' => return self.comment(),
            _ => {
                let k = start + 1 + word_len(&self.src[start + 1..]);
                self.i = k;
                return Ok(mk(Kind::Word, &self.src[start..k]));
            }
        };
        self.i += 1;
        Ok(mk(kind, &self.src[start..start + 1]))
    }

    /// A comment (or an unbalanced brace) at the current position.
    #[cold]
    fn comment(&mut self) -> PResult<Token<'a>> {
        let start = self.i;
        let line = self.line;
        let line_start = self.line_start;
        let mk = |kind, text| Token {
            kind,
            text,
            start: start as u32,
            line,
            line_start: line_start as u32,
        };
        match self.src[start] {
            b'}' => Err(Box::new(Diagnostic::error(
                self.pos_of(line, line_start, start),
                "unbalanced '}': no comment is open",
            ))),
            _ => {
                let mut depth = 0usize;
                let mut k = start;
                while k < self.src.len() {
                    match self.src[k] {
                        b'{' => depth += 1,
                        b'}' => {
                            depth -= 1;
                            if depth == 0 {
                                self.i = k + 1;
                                return Ok(mk(Kind::Comment, &self.src[start + 1..k]));
                            }
                        }
                        b'\n' => {
                            self.line += 1;
                            self.line_start = k + 1;
                        }
                        _ => {}
                    }
                    k += 1;
                }
                Err(Box::new(Diagnostic::error(
                    self.pos_of(line, line_start, start),
                    "unterminated comment: this '{' is never closed",
                )))
            }
        }
    }

    /// Reads the raw text of a `( … )` escape whose `(` token is `open`,
    /// up to the matching `)`, which is consumed. Returns the inner text.
    pub fn raw_parens(&mut self, open: &Token<'a>) -> PResult<&'a [u8]> {
        let mut depth = 1usize;
        let inner = open.end();
        let mut k = inner;
        while k < self.src.len() {
            match self.src[k] {
                b'(' => depth += 1,
                b')' => {
                    depth -= 1;
                    if depth == 0 {
                        self.i = k + 1;
                        return Ok(&self.src[inner..k]);
                    }
                }
                b'\n' => {
                    self.line += 1;
                    self.line_start = k + 1;
                }
                _ => {}
            }
            k += 1;
        }
        Err(Box::new(Diagnostic::error(
            self.pos(open),
            "unbalanced '(': this escape is never closed",
        )))
    }

    /// Describes a token for an error message.
    pub fn describe(t: &Token<'_>) -> String {
        match t.kind {
            Kind::Eof => "end of file".to_string(),
            Kind::Comment => "a comment".to_string(),
            _ => quote(t.text),
        }
    }
}
