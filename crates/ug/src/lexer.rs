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
#[derive(Clone, Copy, Debug)]
pub struct Token<'a> {
    pub kind: Kind,
    pub text: &'a [u8],
    /// Byte offset of the token's first byte.
    pub start: usize,
    /// Byte offset just past the token.
    pub end: usize,
    /// 1-based line of `start`.
    pub line: u32,
    /// Byte offset where that line starts.
    pub line_start: usize,
}

pub struct Lexer<'a> {
    src: &'a [u8],
    file: &'a str,
    i: usize,
    line: u32,
    line_start: usize,
}

#[inline]
fn is_delim(b: u8) -> bool {
    matches!(
        b,
        b' ' | b'\t' | b'\n' | b'\r' | b'\x0b' | b'\x0c' | b';' | b'(' | b')' | b'{' | b'}'
    )
}

impl<'a> Lexer<'a> {
    pub fn new(src: &'a [u8], file: &'a str) -> Self {
        // A UTF-8 byte order mark is skipped.
        let i = if src.starts_with(&[0xEF, 0xBB, 0xBF]) {
            3
        } else {
            0
        };
        Lexer {
            src,
            file,
            i,
            line: 1,
            line_start: i,
        }
    }

    pub fn src(&self) -> &'a [u8] {
        self.src
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
        self.pos_of(t.line, t.line_start, t.start)
    }

    /// Position just after a token (where a missing `;` belongs).
    pub fn pos_after(&self, t: &Token<'_>) -> Pos {
        // Comments can span lines; words and punctuation cannot.
        if t.kind == Kind::Comment {
            let (line, ls) = self.line_of(t.end);
            return self.pos_of(line, ls, t.end);
        }
        self.pos_of(t.line, t.line_start, t.end)
    }

    fn line_of(&self, offset: usize) -> (u32, usize) {
        let mut line = 1u32;
        let mut ls = 0usize;
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
            match b {
                b'\n' => {
                    self.i += 1;
                    self.line += 1;
                    self.line_start = self.i;
                }
                b' ' | b'\t' | b'\r' | b'\x0b' | b'\x0c' => self.i += 1,
                _ => break,
            }
        }
    }

    /// The next token, or an error for an unbalanced comment brace.
    pub fn next_token(&mut self) -> Result<Token<'a>, Diagnostic> {
        self.skip_ws();
        let start = self.i;
        let line = self.line;
        let line_start = self.line_start;
        let mk = |kind, text, end| Token {
            kind,
            text,
            start,
            end,
            line,
            line_start,
        };
        let Some(&b) = self.src.get(start) else {
            return Ok(mk(Kind::Eof, &self.src[start..start], start));
        };
        match b {
            b';' => {
                self.i += 1;
                Ok(mk(Kind::Semi, &self.src[start..start + 1], start + 1))
            }
            b'(' => {
                self.i += 1;
                Ok(mk(Kind::LParen, &self.src[start..start + 1], start + 1))
            }
            b')' => {
                self.i += 1;
                Ok(mk(Kind::RParen, &self.src[start..start + 1], start + 1))
            }
            b'}' => Err(Diagnostic::error(
                self.pos_of(line, line_start, start),
                "unbalanced '}': no comment is open",
            )),
            b'{' => {
                let mut depth = 0usize;
                let mut k = start;
                while k < self.src.len() {
                    match self.src[k] {
                        b'{' => depth += 1,
                        b'}' => {
                            depth -= 1;
                            if depth == 0 {
                                self.i = k + 1;
                                return Ok(mk(Kind::Comment, &self.src[start + 1..k], k + 1));
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
                Err(Diagnostic::error(
                    self.pos_of(line, line_start, start),
                    "unterminated comment: this '{' is never closed",
                ))
            }
            _ => {
                let mut k = start;
                while k < self.src.len() && !is_delim(self.src[k]) {
                    k += 1;
                }
                self.i = k;
                Ok(mk(Kind::Word, &self.src[start..k], k))
            }
        }
    }

    /// Reads the raw text of a `( … )` escape whose `(` token is `open`,
    /// up to the matching `)`, which is consumed. Returns the inner text.
    pub fn raw_parens(&mut self, open: &Token<'a>) -> Result<&'a [u8], Diagnostic> {
        let mut depth = 1usize;
        let mut k = open.end;
        while k < self.src.len() {
            match self.src[k] {
                b'(' => depth += 1,
                b')' => {
                    depth -= 1;
                    if depth == 0 {
                        self.i = k + 1;
                        return Ok(&self.src[open.end..k]);
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
        Err(Diagnostic::error(
            self.pos(open),
            "unbalanced '(': this escape is never closed",
        ))
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
