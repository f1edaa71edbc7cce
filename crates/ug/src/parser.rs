//! The UniGrafix parser: a hand-written recursive descent over [`Lexer`] tokens.
//!
//! It stops at the first error and reports it with file, line and column.
//! Nothing in it panics on any input (fuzzed: `fuzz/fuzz_targets/parse.rs`).
//!
//! Speed: plain one-line `v`, `f` and `w` statements (the bulk of any model)
//! are read by fast paths straight from the bytes; anything unusual in them
//! (comments, line breaks, errors) makes the fast path give up without
//! consuming anything, and the general parser reads the statement, so results
//! and error positions are the same either way (`tests/fast_paths.rs` and the
//! fuzz target compare the two). Numbers have a fast path too (exact for short
//! decimals, `str::parse` otherwise), and errors are boxed so that the
//! token-by-token `Result`s stay small.

use std::hash::BuildHasher;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use glam::DVec3;
use hashbrown::HashTable;
use rustc_hash::FxBuildHasher;

use crate::error::{Diagnostic, Pos, quote};
use crate::lexer::{Kind, Lexer, MAX_SOURCE, PResult, Token, is_delim, word_len};
use crate::model::*;

/// What to do with `include FILE;`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum IncludeMode {
    /// Read the file (relative to the including file) and splice its statements in.
    #[default]
    Resolve,
    /// Keep the statement as `Item::Include` (the file is not read).
    Keep,
}

#[derive(Clone, Debug, Default)]
pub struct ParseOptions {
    /// Unknown keywords are errors instead of warnings.
    pub strict: bool,
    pub includes: IncludeMode,
    /// The geometry tools' limits: a vertex coordinate beyond
    /// [`MAX_COORDINATE`] is an error at its word, and a model whose vertices
    /// span less than [`MIN_EXTENT`] (but more than a point) one naming the
    /// file. Off, any finite number is a coordinate (the format itself).
    pub limits: bool,
}

/// A parsed model and the warnings met on the way.
#[derive(Debug)]
pub struct Parsed {
    pub model: Model,
    pub warnings: Vec<Diagnostic>,
}

/// Whether the fast paths for plain `v`, `f` and `w` statements are used.
static FAST_PATHS: AtomicBool = AtomicBool::new(true);

/// Turns the parser's fast paths for plain vertex, face and wire statements
/// on (the default) or off, for differential tests: results, errors included,
/// are the same either way.
#[doc(hidden)]
pub fn set_fast_paths(on: bool) {
    FAST_PATHS.store(on, Ordering::Relaxed);
}

/// Parses UG text with default options; includes resolve relative to the current directory.
pub fn parse(src: &[u8], file: &str) -> Result<Parsed, Diagnostic> {
    parse_with(src, file, None, &ParseOptions::default())
}

/// Parses UG text. `dir` is the directory includes are relative to (default: current directory).
pub fn parse_with(
    src: &[u8],
    file: &str,
    dir: Option<&Path>,
    opts: &ParseOptions,
) -> Result<Parsed, Diagnostic> {
    if src.len() > MAX_SOURCE {
        return Err(Diagnostic::plain(format!(
            "{file}: the file is larger than {MAX_SOURCE} bytes"
        )));
    }
    let mut p = Parser {
        model: Model::default(),
        opts,
        warnings: Vec::new(),
        materials: NameTable::default(),
        defs: NameTable::default(),
        pending_materials: Vec::new(),
        include_stack: Vec::new(),
        // The file itself (when `file` names a readable path), so that including it is a cycle.
        root: Path::new(file).canonicalize().ok(),
        open_defs: Vec::new(),
        dir: dir.map(Path::to_path_buf).unwrap_or_default(),
        fast: FAST_PATHS.load(Ordering::Relaxed),
        scratch: Vec::new(),
    };
    let mut scope = Scope::default();
    let mut items = Vec::new();
    // Room for the statements, estimated cheaply (each ends with ';'; a vertex
    // takes at least 10 bytes, a face 9), so that the arenas rarely grow. Only
    // address space is reserved; a failed reservation costs only speed.
    let semis: usize = src
        .chunks(255)
        .map(|c| usize::from(c.iter().fold(0u8, |n, &b| n + u8::from(b == b';'))))
        .sum();
    let _ = p.model.vertices.try_reserve(semis.min(src.len() / 10));
    let _ = p.model.faces.try_reserve(semis.min(src.len() / 9));
    let _ = items.try_reserve(semis.min(src.len() / 2));
    let mut toks = Toks::new(Lexer::new(src, file));
    p.statements(&mut toks, &mut scope, &mut items, None)
        .and_then(|()| p.finish_scope(scope, &items))
        .and_then(|()| p.resolve_materials())
        .map_err(|e| *e)?;
    if opts.limits {
        check_extent(&p.model, file)?;
    }
    items.shrink_to_fit();
    p.model.vertices.shrink_to_fit();
    p.model.faces.shrink_to_fit();
    p.model.items = items;
    Ok(Parsed {
        model: p.model,
        warnings: p.warnings,
    })
}

/// The largest coordinate a vertex may have for the geometry tools
/// ([`ParseOptions::limits`]). The geometric tests multiply
/// up to six lengths (a point against a plane through three others, the
/// polygon-to-point form factor's squared areas): beyond about 1e50 they
/// overflow, a face is found to have no area and is dropped, and `ugrad`
/// emitted NaN and never converged. 1e40 leaves room.
pub const MAX_COORDINATE: f64 = 1e40;

/// The smallest extent (bounding-box diagonal) a model with any extent may
/// have for the geometry tools ([`ParseOptions::limits`]): below about 1e-40 the same products underflow, and faces were
/// dropped or could not be triangulated. 1e-30 leaves room.
pub const MIN_EXTENT: f64 = 1e-30;

/// A model whose vertices span less than [`MIN_EXTENT`] (but more than a
/// point) is refused: the tools cannot measure it.
fn check_extent(m: &Model, file: &str) -> Result<(), Diagnostic> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for v in &m.vertices {
        lo = lo.min(v.pos);
        hi = hi.max(v.pos);
    }
    let d = (hi - lo).length();
    if d > 0.0 && d < MIN_EXTENT {
        return Err(Diagnostic::plain(format!(
            "{file}: the model's vertices span only {d:e}, less than {MIN_EXTENT:e}: too small to measure in double precision (scale the model up, for example with a def and an instance scaled by 1e6)"
        )));
    }
    Ok(())
}

/// Reads and parses a file; its includes resolve relative to its directory.
pub fn parse_file(path: &Path, opts: &ParseOptions) -> Result<Parsed, Diagnostic> {
    let src = std::fs::read(path)
        .map_err(|e| Diagnostic::plain(format!("cannot read '{}': {e}", path.display())))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_with(&src, &path.display().to_string(), Some(&dir), opts)
}

/// How deep `def`s may nest inside one another.
pub const MAX_DEF_DEPTH: usize = 100;

/// How deep includes may nest.
pub const MAX_INCLUDE_DEPTH: usize = 32;

/// Keywords that start a statement (used to spot a missing `;`).
const KEYWORDS: [&[u8]; 14] = [
    b"c_rgb",
    b"c",
    b"defmat",
    b"v",
    b"f",
    b"w",
    b"def",
    b"end",
    b"i",
    b"a",
    b"l",
    b"cam",
    b"include",
    b"diffuse_rgb",
];

/// Names are words of printable ASCII other than the delimiters `;(){}`.
fn valid_name(w: &[u8]) -> bool {
    !w.is_empty() && w.iter().all(|&b| (0x21..=0x7e).contains(&b))
}

/// A name → id table that stores ids (with their names' hashes, so that
/// growing the table needs no names); names are read back from the model.
#[derive(Default)]
struct NameTable {
    table: HashTable<(u64, u32)>,
}

impl NameTable {
    #[inline]
    fn hash(name: &[u8]) -> u64 {
        FxBuildHasher.hash_one(name)
    }
    #[inline]
    fn find<'m>(&self, name: &[u8], names: impl Fn(u32) -> &'m str) -> Option<u32> {
        let h = Self::hash(name);
        self.table
            .find(h, |&(kh, id)| kh == h && names(id).as_bytes() == name)
            .map(|&(_, id)| id)
    }
    /// Inserts; returns false when the name is taken.
    #[inline]
    fn insert<'m>(&mut self, name: &[u8], id: u32, names: impl Fn(u32) -> &'m str) -> bool {
        let h = Self::hash(name);
        match self.table.entry(
            h,
            |&(kh, k)| kh == h && names(k).as_bytes() == name,
            |&(kh, _)| kh,
        ) {
            hashbrown::hash_table::Entry::Occupied(_) => false,
            hashbrown::hash_table::Entry::Vacant(v) => {
                v.insert((h, id));
                true
            }
        }
    }
}

/// Faces and wires share one namespace; wires are tagged with the top bit.
const WIRE_BIT: u32 = 1 << 31;

/// The names visible inside one `def` (or the top level).
#[derive(Default)]
struct Scope {
    vertices: NameTable,
    geoms: NameTable,
    instances: NameTable,
    pending: Vec<PendingVertex>,
}

/// A vertex named before its definition; resolved when the scope ends.
struct PendingVertex {
    /// Face id, or wire id with `WIRE_BIT`.
    owner: u32,
    contour: u32,
    index: u32,
    name: String,
    pos: Pos,
}

#[derive(Clone, Copy)]
enum MatSite {
    Vertex(VertexId),
    Face(FaceId),
    Wire(WireId),
    Instance(InstanceId),
}

struct PendingMaterial {
    site: MatSite,
    name: String,
    pos: Pos,
}

/// A token stream with one token of look-ahead.
struct Toks<'a> {
    lx: Lexer<'a>,
    peeked: Option<Token<'a>>,
    /// The last significant token handed out (for "expected ';' after …").
    prev: Option<Token<'a>>,
}

impl<'a> Toks<'a> {
    fn new(lx: Lexer<'a>) -> Self {
        Toks {
            lx,
            peeked: None,
            prev: None,
        }
    }
    /// Next token, comments included.
    fn next_raw(&mut self) -> PResult<Token<'a>> {
        match self.peeked.take() {
            Some(t) => Ok(t),
            None => self.lx.next_token(),
        }
    }
    /// Next token that is not a comment (comments inside statements are dropped).
    fn next(&mut self) -> PResult<Token<'a>> {
        loop {
            let t = self.next_raw()?;
            if t.kind != Kind::Comment {
                if t.kind != Kind::Eof {
                    self.note(t);
                }
                return Ok(t);
            }
        }
    }
    #[inline]
    fn note(&mut self, t: Token<'a>) {
        self.prev = Some(t);
    }
    fn peek(&mut self) -> PResult<Token<'a>> {
        loop {
            let t = match self.peeked {
                Some(t) => t,
                None => {
                    let t = self.lx.next_token()?;
                    self.peeked = Some(t);
                    t
                }
            };
            if t.kind == Kind::Comment {
                self.peeked = None;
                continue;
            }
            return Ok(t);
        }
    }
    fn pos(&self, t: &Token<'_>) -> Pos {
        self.lx.pos(t)
    }
    #[cold]
    fn err(&self, t: &Token<'_>, msg: impl Into<String>) -> Box<Diagnostic> {
        Box::new(Diagnostic::error(self.pos(t), msg))
    }
    /// Error for a token that should have been `;`: placed right after the previous token.
    #[cold]
    fn missing_semi(&self, found: &Token<'_>, stmt: &str) -> Box<Diagnostic> {
        if found.kind == Kind::RParen {
            return self.err(found, "unbalanced ')': no '(' is open");
        }
        let what = if stmt == "end" {
            "after 'end'".to_string()
        } else {
            format!("to end the {stmt} statement")
        };
        Box::new(Diagnostic::error(
            self.pos_after_prev(found),
            format!("expected ';' {what}, found {}", Lexer::describe(found)),
        ))
    }
    /// Just after the last significant token before `found` (where something is missing).
    fn pos_after_prev(&self, found: &Token<'_>) -> Pos {
        match &self.prev {
            Some(p) if p.start < found.start => self.lx.pos_after(p),
            _ => self.pos(found),
        }
    }
    fn expect_semi(&mut self, stmt: &str) -> PResult<()> {
        let t = self.peek()?;
        if t.kind == Kind::Semi {
            self.next()?;
            Ok(())
        } else {
            Err(self.missing_semi(&t, stmt))
        }
    }
    fn number(&mut self, what: &str) -> PResult<f64> {
        self.number_of(|| what.to_string())
    }
    /// A vertex coordinate: a number no larger than `limit` in magnitude.
    fn coordinate(&mut self, what: &str, limit: f64) -> PResult<f64> {
        let t = self.next()?;
        if t.kind == Kind::Word
            && let Some(v) = number_value(t.text)
        {
            if v.abs() > limit {
                return Err(self.err(
                    &t,
                    format!(
                        "{what} {} is beyond ±{limit:e}: too large to compute with in double precision (scale the model down)",
                        quote(t.text)
                    ),
                ));
            }
            return Ok(v);
        }
        Err(self.not_a_number(&t, what))
    }
    /// A number; `what` describes it for an error message (built only on error).
    #[inline]
    fn number_of(&mut self, what: impl Fn() -> String) -> PResult<f64> {
        let t = self.next()?;
        if t.kind == Kind::Word
            && let Some(v) = number_value(t.text)
        {
            return Ok(v);
        }
        Err(self.not_a_number(&t, &what()))
    }
    #[cold]
    fn not_a_number(&self, t: &Token<'_>, what: &str) -> Box<Diagnostic> {
        if t.kind != Kind::Word {
            return self.err(t, format!("expected {what}, found {}", Lexer::describe(t)));
        }
        match parse_number(t) {
            Err(m) => self.err(t, format!("{m} (expected {what})")),
            Ok(_) => self.err(t, format!("bad number {} (expected {what})", quote(t.text))),
        }
    }
    fn name(&mut self, what: &str) -> PResult<Token<'a>> {
        let t = self.next()?;
        if t.kind != Kind::Word {
            return Err(self.err(
                &t,
                format!("expected {what}, found {}", Lexer::describe(&t)),
            ));
        }
        if !valid_name(t.text) {
            return Err(self.err(
                &t,
                format!(
                    "invalid {what} {}: names are printable ASCII",
                    quote(t.text)
                ),
            ));
        }
        Ok(t)
    }
}

/// Powers of ten that are exact in f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The common case of a number, fast: `[+-]digits[.digits]` of at most 19
/// bytes after the sign, an integer mantissa up to 2^53 and at most 22 decimals. Both the
/// mantissa and the power of ten are exact, so one division rounds correctly
/// (Clinger's fast path) and the result equals `str::parse`'s.
#[inline]
fn fast_decimal(text: &[u8]) -> Option<f64> {
    let (neg, digits) = match text.first()? {
        b'-' => (true, &text[1..]),
        b'+' => (false, &text[1..]),
        _ => (false, text),
    };
    // At most 19 digits: the mantissa fits in a u64.
    if digits.len() > 19 {
        return None;
    }
    let mut mant: u64 = 0;
    let mut k = 0;
    while let Some(&b) = digits.get(k) {
        if !b.is_ascii_digit() {
            break;
        }
        mant = mant * 10 + u64::from(b - b'0');
        k += 1;
    }
    let mut decimals = 0;
    if k < digits.len() {
        if digits[k] != b'.' {
            return None;
        }
        for &b in &digits[k + 1..] {
            if !b.is_ascii_digit() {
                return None;
            }
            mant = mant * 10 + u64::from(b - b'0');
        }
        decimals = digits.len() - k - 1;
    }
    // At least one digit; the mantissa and the power of ten exact.
    if digits.len() == usize::from(k < digits.len()) || mant > 1 << 53 || decimals >= POW10.len() {
        return None;
    }
    let v = mant as f64 / POW10[decimals];
    Some(if neg { -v } else { v })
}

/// The value of a word that is a number: a finite decimal (Rust's float syntax
/// less "inf", "NaN" and "infinity"), or `None`.
#[inline]
fn number_value(text: &[u8]) -> Option<f64> {
    if let Some(v) = fast_decimal(text) {
        return Some(v);
    }
    let first = *text.first()?;
    if !(first.is_ascii_digit() || matches!(first, b'-' | b'+' | b'.')) {
        return None;
    }
    let v: f64 = std::str::from_utf8(text).ok()?.parse().ok()?;
    v.is_finite().then_some(v)
}

/// A number, or the reason the word is not one.
fn parse_number(t: &Token<'_>) -> Result<f64, String> {
    if let Some(v) = number_value(t.text) {
        return Ok(v);
    }
    match std::str::from_utf8(t.text).map(str::parse::<f64>) {
        Ok(Ok(_)) => Err(format!("non-finite number {}", quote(t.text))),
        _ => Err(format!("bad number {}", quote(t.text))),
    }
}

/// A cursor over the bytes of one line, for the parser's fast paths.
struct Cursor<'a> {
    src: &'a [u8],
    i: usize,
    line: u32,
    line_start: u32,
}

impl<'a> Cursor<'a> {
    #[inline]
    fn peek(&self) -> Option<u8> {
        self.src.get(self.i).copied()
    }
    /// Skips spaces, tabs and carriage returns (not newlines).
    #[inline]
    fn blanks(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\r')) {
            self.i += 1;
        }
    }
    /// The word at the cursor (which must be at a word byte).
    #[inline]
    fn word(&mut self) -> Token<'a> {
        let start = self.i;
        let rest = &self.src[start..];
        let len = word_len(rest);
        self.i = start + len;
        Token {
            text: &rest[..len],
            start: start as u32,
            line: self.line,
            line_start: self.line_start,
            kind: Kind::Word,
        }
    }
    /// The next word after blanks (at least one blank when `need_blank`).
    #[inline]
    fn word_after_blanks(&mut self, need_blank: bool) -> Option<Token<'a>> {
        let before = self.i;
        self.blanks();
        if need_blank && self.i == before {
            return None;
        }
        match self.peek() {
            Some(b) if !is_delim(b) => Some(self.word()),
            _ => None,
        }
    }
    /// An optional colour name and the `;` that ends the statement (the same
    /// line), when the colour is one that [`Parser::trailing_color`] accepts.
    #[inline]
    fn trailing_color(&mut self) -> Option<(Option<Token<'a>>, Token<'a>)> {
        self.blanks();
        let mut color = None;
        if matches!(self.peek(), Some(b) if !is_delim(b)) {
            let c = self.word();
            if number_value(c.text).is_some() || !valid_name(c.text) {
                return None;
            }
            color = Some(c);
            self.blanks();
        }
        if self.peek() != Some(b';') {
            return None;
        }
        let semi = Token {
            text: &self.src[self.i..self.i + 1],
            start: self.i as u32,
            line: self.line,
            line_start: self.line_start,
            kind: Kind::Semi,
        };
        self.i += 1;
        Some((color, semi))
    }
}

/// A boxed error at `pos`.
#[cold]
fn error_at(pos: Pos, msg: impl Into<String>) -> Box<Diagnostic> {
    Box::new(Diagnostic::error(pos, msg))
}

/// The text of a word as a String (invalid UTF-8 replaced).
#[inline]
fn lossy(b: &[u8]) -> String {
    match std::str::from_utf8(b) {
        Ok(s) => s.to_owned(),
        Err(_) => String::from_utf8_lossy(b).into_owned(),
    }
}

struct Parser<'o> {
    model: Model,
    opts: &'o ParseOptions,
    warnings: Vec<Diagnostic>,
    materials: NameTable,
    defs: NameTable,
    pending_materials: Vec<PendingMaterial>,
    /// Canonical paths of the include files being read, outermost first.
    include_stack: Vec<PathBuf>,
    /// Canonical path of the file being parsed, when known.
    root: Option<PathBuf>,
    /// Names of the defs being read (a def cannot instantiate itself).
    open_defs: Vec<String>,
    dir: PathBuf,
    /// Use the fast paths for plain statements.
    fast: bool,
    /// Scratch contour for the face fast path.
    scratch: Vec<VertexId>,
}

impl Parser<'_> {
    /// Parses statements until end of file, or until `end;` when inside a def.
    fn statements(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
        def: Option<(&str, &Pos)>,
    ) -> PResult<()> {
        loop {
            let tok = t.next_raw()?;
            match tok.kind {
                Kind::Eof => {
                    return match def {
                        Some((name, pos)) => Err(error_at(
                            t.pos_after_prev(&tok),
                            format!(
                                "end of file inside 'def {name}' (opened at {pos}): missing 'end;'"
                            ),
                        )),
                        None => Ok(()),
                    };
                }
                Kind::Comment => items.push(Item::Comment(lossy(tok.text))),
                Kind::Semi => {}
                Kind::RParen => return Err(t.err(&tok, "unbalanced ')': no '(' is open")),
                Kind::LParen => {
                    t.peeked = None;
                    let text = t.lx.raw_parens(&tok)?;
                    items.push(Item::Escape(lossy(text)));
                    // An optional ';' follows; a comment right after the escape
                    // lies between statements and is kept.
                    let nx = t.next_raw()?;
                    if nx.kind != Kind::Semi {
                        t.peeked = Some(nx);
                    }
                }
                Kind::Word => {
                    t.note(tok);
                    match tok.text {
                        b"end" => {
                            if def.is_some() {
                                return t.expect_semi("end");
                            }
                            return Err(t.err(&tok, "'end' without an open 'def'"));
                        }
                        b"c_rgb" => self.c_rgb(t, items)?,
                        b"c" => self.c_lhs(t, items)?,
                        b"defmat" => self.defmat(t, items)?,
                        b"v" => {
                            if !(self.fast && self.vertex_fast(t, scope, items)?) {
                                self.vertex(t, scope, items)?;
                            }
                        }
                        b"f" | b"w" => {
                            let wire = tok.text == b"w";
                            if !(self.fast && self.face_fast(t, scope, items, wire)?) {
                                self.face_or_wire(t, scope, items, wire)?;
                            }
                        }
                        b"def" => self.def(t, items)?,
                        b"i" => self.instance(t, scope, items, false)?,
                        b"a" => self.instance(t, scope, items, true)?,
                        b"l" => {
                            let raw = self.raw(t, "l")?;
                            items.push(Item::Light(raw));
                        }
                        b"cam" => {
                            let raw = self.raw(t, "cam")?;
                            items.push(Item::Camera(raw));
                        }
                        b"include" => self.include(t, &tok, scope, items)?,
                        kw => {
                            if !valid_name(kw) {
                                return Err(t.err(
                                    &tok,
                                    format!(
                                        "invalid statement keyword {}: names are printable ASCII",
                                        quote(kw)
                                    ),
                                ));
                            }
                            let msg = format!("unknown statement {} passed through", quote(kw));
                            if self.opts.strict {
                                return Err(t.err(
                                    &tok,
                                    format!("unknown statement {} (--strict)", quote(kw)),
                                ));
                            }
                            self.warnings.push(Diagnostic::warning(t.pos(&tok), msg));
                            let kw = lossy(kw);
                            let raw = self.raw(t, &kw)?;
                            items.push(Item::Unknown(raw));
                        }
                    }
                }
            }
        }
    }

    /// Words up to `;`, parentheses balanced, joined by single spaces.
    fn raw(&mut self, t: &mut Toks<'_>, keyword: &str) -> PResult<Raw> {
        let mut text = String::new();
        let mut depth = 0usize;
        let mut opens: Vec<Token<'_>> = Vec::new();
        loop {
            let tok = t.next()?;
            match tok.kind {
                Kind::Semi if depth == 0 => break,
                Kind::Eof => {
                    return Err(match opens.last() {
                        Some(o) => t.err(o, format!("unbalanced '(': the {keyword} statement is not closed before end of file")),
                        None => t.missing_semi(&tok, keyword),
                    });
                }
                Kind::LParen => {
                    depth += 1;
                    opens.push(tok);
                }
                Kind::RParen => {
                    if depth == 0 {
                        return Err(t.err(&tok, "unbalanced ')': no '(' is open"));
                    }
                    depth -= 1;
                    opens.pop();
                }
                Kind::Semi => {
                    return Err(t.err(
                        opens.last().unwrap_or(&tok),
                        format!("unbalanced '(': the {keyword} statement is not closed before ';'"),
                    ));
                }
                _ => {}
            }
            if !text.is_empty() {
                text.push(' ');
            }
            text.push_str(&String::from_utf8_lossy(tok.text));
        }
        Ok(Raw {
            keyword: keyword.to_string(),
            text,
        })
    }

    fn new_material(
        &mut self,
        t: &Toks<'_>,
        name: &Token<'_>,
        def: MaterialDef,
        items: &mut Vec<Item>,
    ) -> PResult<()> {
        let id = self.model.materials.len() as u32;
        let mats = &self.model.materials;
        let taken = self
            .materials
            .find(name.text, |k| mats[k as usize].name.as_str())
            .is_some();
        if taken {
            return Err(t.err(
                name,
                format!("duplicate material name {}", quote(name.text)),
            ));
        }
        self.model.materials.push(Material {
            name: lossy(name.text),
            def,
        });
        let mats = &self.model.materials;
        self.materials
            .insert(name.text, id, |k| mats[k as usize].name.as_str());
        items.push(Item::Material(MaterialId(id)));
        Ok(())
    }

    /// Three numbers (red, green, blue); with `non_negative`, a negative one is an error.
    fn rgb(t: &mut Toks<'_>, what: &str, non_negative: bool) -> PResult<[f64; 3]> {
        let mut rgb = [0.0; 3];
        for (k, channel) in ["red", "green", "blue"].into_iter().enumerate() {
            rgb[k] = t.number_of(|| format!("{what} {channel}"))?;
            if non_negative
                && rgb[k] < 0.0
                && let Some(tok) = t.prev
            {
                return Err(t.err(
                    &tok,
                    format!(
                        "negative {what} {channel} {}: {what} must not be negative",
                        quote(tok.text)
                    ),
                ));
            }
        }
        Ok(rgb)
    }

    fn c_rgb(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> PResult<()> {
        let name = t.name("material name")?;
        let rgb = Self::rgb(t, "c_rgb", false)?;
        t.expect_semi("c_rgb")?;
        self.new_material(t, &name, MaterialDef::Rgb(rgb), items)
    }

    fn c_lhs(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> PResult<()> {
        let name = t.name("colour name")?;
        let mut vals = vec![t.number("lightness")?];
        while t.peek()?.kind == Kind::Word && vals.len() < 4 {
            let what = ["hue", "saturation", "translucency"][vals.len() - 1];
            vals.push(t.number(what)?);
        }
        t.expect_semi("c")?;
        self.new_material(t, &name, MaterialDef::Lhs(vals), items)
    }

    fn defmat(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> PResult<()> {
        let name = t.name("material name")?;
        t.expect_semi("defmat")?;
        let mut d = Defmat::default();
        loop {
            let key = t.next()?;
            match key.kind {
                Kind::Word if key.text == b"end" => {
                    t.expect_semi("end")?;
                    break;
                }
                Kind::Word if key.text == b"diffuse_rgb" || key.text == b"emission_rgb" => {
                    let what = lossy(key.text);
                    let emission = what == "emission_rgb";
                    let rgb = Self::rgb(t, &what, emission)?;
                    if emission {
                        d.emission = Some(rgb);
                    } else {
                        d.diffuse = Some(rgb);
                    }
                    t.expect_semi(&what)?;
                }
                Kind::Word => {
                    if !valid_name(key.text) {
                        return Err(t.err(
                            &key,
                            format!("invalid material property {}", quote(key.text)),
                        ));
                    }
                    let mut words = Vec::new();
                    loop {
                        let w = t.peek()?;
                        match w.kind {
                            Kind::Semi => {
                                t.next()?;
                                break;
                            }
                            Kind::Word => {
                                t.next()?;
                                words.push(lossy(w.text));
                            }
                            _ => return Err(t.missing_semi(&w, "material property")),
                        }
                    }
                    d.other.push((lossy(key.text), words));
                }
                Kind::Semi => {}
                Kind::Eof => {
                    return Err(error_at(
                        t.pos_after_prev(&key),
                        format!(
                            "end of file inside 'defmat {}' (opened at {}): missing 'end;'",
                            lossy(name.text),
                            t.pos(&name)
                        ),
                    ));
                }
                _ => {
                    return Err(t.err(
                        &key,
                        format!(
                            "expected a material property or 'end', found {}",
                            Lexer::describe(&key)
                        ),
                    ));
                }
            }
        }
        self.new_material(t, &name, MaterialDef::Defmat(d), items)
    }

    /// An optional trailing colour name before `;`.
    fn trailing_color<'a>(&mut self, t: &mut Toks<'a>, stmt: &str) -> PResult<Option<Token<'a>>> {
        let tok = t.peek()?;
        match tok.kind {
            Kind::Semi => {
                t.next()?;
                Ok(None)
            }
            Kind::Word => {
                let before = t.prev.filter(|b| b.start < tok.start).unwrap_or(tok);
                t.next()?;
                // `v a 1 2 3` + newline + `v b …`: the keyword is the next statement.
                if KEYWORDS.contains(&tok.text) && t.peek()?.kind != Kind::Semi {
                    return Err(Box::new(Diagnostic::error(
                        t.lx.pos_after(&before),
                        format!(
                            "expected ';' to end the {stmt} statement, found {}",
                            quote(tok.text)
                        ),
                    )));
                }
                if number_value(tok.text).is_some() {
                    return Err(t.err(
                        &tok,
                        format!("unexpected number {} in {stmt} statement", quote(tok.text)),
                    ));
                }
                if !valid_name(tok.text) {
                    return Err(t.err(&tok, format!("invalid material name {}", quote(tok.text))));
                }
                t.expect_semi(stmt)?;
                Ok(Some(tok))
            }
            _ => Err(t.missing_semi(&tok, stmt)),
        }
    }

    fn vertex(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
    ) -> PResult<()> {
        let name = t.name("vertex name")?;
        let limit = if self.opts.limits {
            MAX_COORDINATE
        } else {
            f64::INFINITY
        };
        let x = t.coordinate("x coordinate", limit)?;
        let y = t.coordinate("y coordinate", limit)?;
        let z = t.coordinate("z coordinate", limit)?;
        let color = self.trailing_color(t, "vertex")?;
        self.commit_vertex(t, scope, items, &name, DVec3::new(x, y, z), color)
    }

    /// Stores a parsed vertex statement (the duplicate name check is here).
    #[inline]
    fn commit_vertex(
        &mut self,
        t: &Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
        name: &Token<'_>,
        pos: DVec3,
        color: Option<Token<'_>>,
    ) -> PResult<()> {
        let id = self.model.vertices.len() as u32;
        let verts = &self.model.vertices;
        if !scope
            .vertices
            .insert(name.text, id, |k| verts[k as usize].name.as_str())
        {
            return Err(t.err(name, format!("duplicate vertex name {}", quote(name.text))));
        }
        self.model.vertices.push(Vertex {
            name: lossy(name.text),
            pos,
            color: None,
        });
        if let Some(c) = color {
            self.material_ref(t, MatSite::Vertex(VertexId(id)), &c);
        }
        items.push(Item::Vertex(VertexId(id)));
        Ok(())
    }

    /// The fast path for a plain vertex statement on one line,
    /// `v NAME X Y Z [COLOUR];` with blanks between the words and no comment:
    /// read directly from the bytes. Anything else (and every error but a
    /// duplicate name, which is found in the shared [`Self::commit_vertex`])
    /// returns `Ok(false)` having consumed nothing, and the general parser
    /// reads the statement instead.
    fn vertex_fast(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
    ) -> PResult<bool> {
        if t.peeked.is_some() {
            return Ok(false);
        }
        let src = t.lx.src();
        let (line, line_start) = t.lx.line_info();
        let mut cur = Cursor {
            src,
            i: t.lx.cursor(),
            line,
            line_start,
        };
        let Some(name) = cur.word_after_blanks(true) else {
            return Ok(false);
        };
        if !valid_name(name.text) {
            return Ok(false);
        }
        let mut xyz = [0.0; 3];
        for c in &mut xyz {
            match cur
                .word_after_blanks(true)
                .and_then(|w| number_value(w.text))
            {
                Some(v) if !self.opts.limits || v.abs() <= MAX_COORDINATE => *c = v,
                _ => return Ok(false),
            }
        }
        let Some((color, semi)) = cur.trailing_color() else {
            return Ok(false);
        };
        t.lx.set_cursor(cur.i);
        t.prev = Some(semi);
        self.commit_vertex(t, scope, items, &name, DVec3::from_array(xyz), color)?;
        Ok(true)
    }

    /// Sets the material named by `name` at `site`, now or (for a material
    /// not defined yet) when the whole file has been read.
    fn material_ref(&mut self, t: &Toks<'_>, site: MatSite, name: &Token<'_>) {
        let mats = &self.model.materials;
        match self
            .materials
            .find(name.text, |k| mats[k as usize].name.as_str())
        {
            Some(id) => self.set_material(site, MaterialId(id)),
            None => self.pending_materials.push(PendingMaterial {
                site,
                name: lossy(name.text),
                pos: t.pos(name),
            }),
        }
    }

    fn set_material(&mut self, site: MatSite, m: MaterialId) {
        match site {
            MatSite::Vertex(v) => self.model.vertices[v.idx()].color = Some(m),
            MatSite::Face(f) => self.model.faces[f.idx()].material = Some(m),
            MatSite::Wire(w) => self.model.wires[w.idx()].material = Some(m),
            MatSite::Instance(i) => self.model.instances[i.idx()].color = Some(m),
        }
    }

    fn face_or_wire(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
        wire: bool,
    ) -> PResult<()> {
        let stmt = if wire { "wire" } else { "face" };
        let min = if wire { 2 } else { 3 };
        let mut name = None;
        let mut tok = t.next()?;
        if tok.kind == Kind::Word {
            if !valid_name(tok.text) {
                return Err(t.err(&tok, format!("invalid {stmt} name {}", quote(tok.text))));
            }
            name = Some(tok);
            tok = t.next()?;
        }
        if tok.kind != Kind::LParen {
            return Err(t.err(
                &tok,
                format!(
                    "expected '(' to start a contour of the {stmt}, found {}",
                    Lexer::describe(&tok)
                ),
            ));
        }
        let owner = if wire {
            self.model.wires.len() as u32 | WIRE_BIT
        } else {
            self.model.faces.len() as u32
        };
        let mut contours: Vec<Vec<VertexId>> = Vec::new();
        let mut pending: Vec<PendingVertex> = Vec::new();
        let mut open = tok;
        loop {
            // Inside a contour.
            let mut c = Vec::new();
            loop {
                let v = t.next()?;
                match v.kind {
                    Kind::RParen => break,
                    Kind::Word => {
                        let verts = &self.model.vertices;
                        match scope.vertices.find(v.text, |k| verts[k as usize].name.as_str()) {
                            Some(id) => c.push(VertexId(id)),
                            None => {
                                // Names found are valid; one not found may not be.
                                if !valid_name(v.text) {
                                    return Err(t.err(
                                        &v,
                                        format!(
                                            "invalid vertex name {}: names are printable ASCII",
                                            quote(v.text)
                                        ),
                                    ));
                                }
                                pending.push(PendingVertex {
                                    owner,
                                    contour: contours.len() as u32,
                                    index: c.len() as u32,
                                    name: lossy(v.text),
                                    pos: t.pos(&v),
                                });
                                c.push(VertexId(u32::MAX));
                            }
                        }
                    }
                    Kind::LParen => return Err(t.err(&v, format!("unbalanced '(': a contour cannot contain '(' (the contour opened at {} is not closed)", t.pos(&open)))),
                    _ => {
                        return Err(t.err(&open, format!("unbalanced '(': the {stmt} contour is not closed before {}", Lexer::describe(&v))));
                    }
                }
            }
            if c.len() < min {
                return Err(t.err(
                    &open,
                    format!(
                        "a {stmt} contour needs at least {min} vertices, this one has {}",
                        c.len()
                    ),
                ));
            }
            contours.push(c);
            let nx = t.peek()?;
            if nx.kind == Kind::LParen {
                open = t.next()?;
                continue;
            }
            break;
        }
        let color = self.trailing_color(t, stmt)?;
        self.commit_geom(t, scope, items, wire, name, contours, pending, color)
    }

    /// Stores a parsed face or wire statement (the duplicate name check is here).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn commit_geom(
        &mut self,
        t: &Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
        wire: bool,
        name: Option<Token<'_>>,
        contours: Vec<Vec<VertexId>>,
        pending: Vec<PendingVertex>,
        color: Option<Token<'_>>,
    ) -> PResult<()> {
        let stmt = if wire { "wire" } else { "face" };
        let owner = if wire {
            self.model.wires.len() as u32 | WIRE_BIT
        } else {
            self.model.faces.len() as u32
        };
        // Register the name.
        if let Some(n) = &name {
            let (faces, wires) = (&self.model.faces, &self.model.wires);
            let names = |k: u32| -> &str {
                if k & WIRE_BIT != 0 {
                    wires[(k & !WIRE_BIT) as usize]
                        .name
                        .as_deref()
                        .unwrap_or("")
                } else {
                    faces[k as usize].name.as_deref().unwrap_or("")
                }
            };
            if let Some(k) = scope.geoms.find(n.text, names) {
                let other = if k & WIRE_BIT != 0 { "wire" } else { "face" };
                let msg = if other == stmt {
                    format!("duplicate {stmt} name {}", quote(n.text))
                } else {
                    format!(
                        "duplicate {stmt} name {}: a {other} has it (faces and wires share names)",
                        quote(n.text)
                    )
                };
                return Err(t.err(n, msg));
            }
        }
        let name_s = name.as_ref().map(|n| lossy(n.text));
        let site = if wire {
            let id = WireId(self.model.wires.len() as u32);
            self.model.wires.push(Wire {
                name: name_s,
                polylines: contours,
                material: None,
            });
            items.push(Item::Wire(id));
            MatSite::Wire(id)
        } else {
            let id = FaceId(self.model.faces.len() as u32);
            self.model.faces.push(Face {
                name: name_s,
                contours,
                material: None,
            });
            items.push(Item::Face(id));
            MatSite::Face(id)
        };
        if let Some(n) = &name {
            let (faces, wires) = (&self.model.faces, &self.model.wires);
            let names = |k: u32| -> &str {
                if k & WIRE_BIT != 0 {
                    wires[(k & !WIRE_BIT) as usize]
                        .name
                        .as_deref()
                        .unwrap_or("")
                } else {
                    faces[k as usize].name.as_deref().unwrap_or("")
                }
            };
            scope.geoms.insert(n.text, owner, names);
        }
        scope.pending.extend(pending);
        if let Some(c) = color {
            self.material_ref(t, site, &c);
        }
        Ok(())
    }

    /// The fast path for a plain face or wire statement on one line,
    /// `f [NAME] (A B C …) [(…) …] [COLOUR];` with no comment: read directly
    /// from the bytes. Anything unusual (and every error but a duplicate name,
    /// which is found in the shared [`Self::commit_geom`]) returns `Ok(false)`
    /// having consumed nothing, and the general parser reads the statement.
    fn face_fast(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
        wire: bool,
    ) -> PResult<bool> {
        if t.peeked.is_some() {
            return Ok(false);
        }
        let min = if wire { 2 } else { 3 };
        let owner = if wire {
            self.model.wires.len() as u32 | WIRE_BIT
        } else {
            self.model.faces.len() as u32
        };
        let src = t.lx.src();
        let (line, line_start) = t.lx.line_info();
        let mut cur = Cursor {
            src,
            i: t.lx.cursor(),
            line,
            line_start,
        };
        cur.blanks();
        let mut name = None;
        if cur.peek() != Some(b'(') {
            match cur.word_after_blanks(false) {
                Some(w) if valid_name(w.text) => name = Some(w),
                _ => return Ok(false),
            }
            cur.blanks();
        }
        let mut contours: Vec<Vec<VertexId>> = Vec::new();
        let mut pending: Vec<PendingVertex> = Vec::new();
        let mut c = std::mem::take(&mut self.scratch);
        let ok = loop {
            // At '(' of a contour.
            if cur.peek() != Some(b'(') {
                break false;
            }
            cur.i += 1;
            c.clear();
            let closed = loop {
                cur.blanks();
                match cur.peek() {
                    Some(b')') => {
                        cur.i += 1;
                        break true;
                    }
                    Some(b) if !is_delim(b) => {
                        let v = cur.word();
                        let verts = &self.model.vertices;
                        match scope
                            .vertices
                            .find(v.text, |k| verts[k as usize].name.as_str())
                        {
                            Some(id) => c.push(VertexId(id)),
                            None if valid_name(v.text) => {
                                pending.push(PendingVertex {
                                    owner,
                                    contour: contours.len() as u32,
                                    index: c.len() as u32,
                                    name: lossy(v.text),
                                    pos: t.lx.pos(&v),
                                });
                                c.push(VertexId(u32::MAX));
                            }
                            None => break false,
                        }
                    }
                    _ => break false,
                }
            };
            if !closed || c.len() < min {
                break false;
            }
            contours.push(c.clone());
            cur.blanks();
            if cur.peek() != Some(b'(') {
                break true;
            }
        };
        self.scratch = c;
        if !ok {
            return Ok(false);
        }
        let Some((color, semi)) = cur.trailing_color() else {
            return Ok(false);
        };
        t.lx.set_cursor(cur.i);
        t.prev = Some(semi);
        self.commit_geom(t, scope, items, wire, name, contours, pending, color)?;
        Ok(true)
    }

    fn def(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> PResult<()> {
        let name = t.name("def name")?;
        let defs = &self.model.defs;
        if self
            .defs
            .find(name.text, |k| defs[k as usize].name.as_str())
            .is_some()
        {
            return Err(t.err(&name, format!("duplicate def name {}", quote(name.text))));
        }
        t.expect_semi("def")?;
        let name_s = lossy(name.text);
        let pos = t.pos(&name);
        if self.open_defs.len() >= MAX_DEF_DEPTH {
            return Err(error_at(
                pos,
                format!("defs nested more than {MAX_DEF_DEPTH} deep"),
            ));
        }
        let mut scope = Scope::default();
        let mut body = Vec::new();
        self.open_defs.push(name_s.clone());
        self.statements(t, &mut scope, &mut body, Some((&name_s, &pos)))?;
        self.open_defs.pop();
        self.finish_scope(scope, &body)?;
        // Registered only now: a def cannot instantiate itself.
        let defs = &self.model.defs;
        if self
            .defs
            .find(name.text, |k| defs[k as usize].name.as_str())
            .is_some()
        {
            return Err(error_at(
                pos,
                format!("duplicate def name {}", quote(name.text)),
            ));
        }
        let id = self.model.defs.len() as u32;
        self.model.defs.push(Def {
            name: name_s,
            items: body,
        });
        let defs = &self.model.defs;
        self.defs
            .insert(name.text, id, |k| defs[k as usize].name.as_str());
        items.push(Item::Def(DefId(id)));
        Ok(())
    }

    /// Transform flags with their numbers, up to `)` (when `open` is the
    /// instance's `(`) or up to `;` (an array's step); the end is not consumed.
    fn transforms(
        &mut self,
        t: &mut Toks<'_>,
        stmt: &str,
        open: Option<&Token<'_>>,
    ) -> PResult<Vec<Transform>> {
        let until = if open.is_some() {
            Kind::RParen
        } else {
            Kind::Semi
        };
        let mut out: Vec<Transform> = Vec::new();
        loop {
            let tok = t.peek()?;
            if tok.kind == until {
                return Ok(out);
            }
            if tok.kind != Kind::Word {
                return Err(match open {
                    Some(o) => t.err(
                        o,
                        format!(
                            "unbalanced '(': the {stmt} is not closed before {}",
                            Lexer::describe(&tok)
                        ),
                    ),
                    None => t.missing_semi(&tok, stmt),
                });
            }
            let Some(op) = TransformOp::from_flag(tok.text) else {
                if open.is_none() && KEYWORDS.contains(&tok.text) {
                    // `a … -tx 1` + newline + `v …`: the keyword starts the next statement.
                    return Err(t.missing_semi(&tok, stmt));
                }
                t.next()?;
                if number_value(tok.text).is_some() {
                    let why = match out.last() {
                        Some(last) => format!(
                            "{} takes {} number{}",
                            last.op.flag(),
                            last.op.arity(),
                            if last.op.arity() == 1 { "" } else { "s" }
                        ),
                        None => "expected a transform flag".to_string(),
                    };
                    return Err(t.err(
                        &tok,
                        format!("unexpected number {} in the {stmt}: {why}", quote(tok.text)),
                    ));
                }
                return Err(t.err(&tok, format!("unknown transform flag {}", quote(tok.text))));
            };
            t.next()?;
            let mut args = Vec::with_capacity(op.arity());
            for k in 0..op.arity() {
                args.push(t.number_of(|| format!("argument {} of {}", k + 1, op.flag()))?);
            }
            if op == TransformOp::M4
                && (args[12] != 0.0 || args[13] != 0.0 || args[14] != 0.0 || args[15] == 0.0)
            {
                return Err(t.err(
                    &tok,
                    "-M4 must be affine: its last row must be 0 0 0 w with w non-zero",
                ));
            }
            out.push(Transform { op, args });
        }
    }

    fn instance(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
        array: bool,
    ) -> PResult<()> {
        let stmt = if array { "array" } else { "instance" };
        let mut name = None;
        let mut tok = t.next()?;
        if tok.kind == Kind::Word {
            if !valid_name(tok.text) {
                return Err(t.err(&tok, format!("invalid {stmt} name {}", quote(tok.text))));
            }
            name = Some(tok);
            tok = t.next()?;
        }
        if tok.kind != Kind::LParen {
            return Err(t.err(
                &tok,
                format!(
                    "expected '(' after the {stmt} name, found {}",
                    Lexer::describe(&tok)
                ),
            ));
        }
        let open = tok;
        let dn = t.name("def name")?;
        let defs = &self.model.defs;
        let Some(def) = self.defs.find(dn.text, |k| defs[k as usize].name.as_str()) else {
            if self.open_defs.iter().any(|d| d.as_bytes() == dn.text) {
                return Err(t.err(
                    &dn,
                    format!(
                        "def {} cannot instantiate itself (it is still being defined)",
                        quote(dn.text)
                    ),
                ));
            }
            return Err(t.err(
                &dn,
                format!(
                    "undefined def {} (a def must precede its instances)",
                    quote(dn.text)
                ),
            ));
        };
        let mut color = None;
        let nx = t.peek()?;
        if nx.kind == Kind::Word && !nx.text.starts_with(b"-") {
            let c = t.name("colour name")?;
            if number_value(c.text).is_some() {
                return Err(t.err(
                    &c,
                    format!(
                        "unexpected number {} in the {stmt}: expected a colour name or a transform flag",
                        quote(c.text)
                    ),
                ));
            }
            color = Some(c);
        }
        let transforms = self.transforms(t, stmt, Some(&open))?;
        t.next()?; // ')'
        let array_spec = if array {
            let n = t.next()?;
            let count = std::str::from_utf8(n.text)
                .ok()
                .and_then(|s| s.parse::<u32>().ok());
            let Some(count) = count.filter(|_| n.kind == Kind::Word) else {
                return Err(t.err(
                    &n,
                    format!(
                        "expected the array size (a whole number), found {}",
                        Lexer::describe(&n)
                    ),
                ));
            };
            let step = self.transforms(t, stmt, None)?;
            Some(ArraySpec { count, step })
        } else {
            None
        };
        t.expect_semi(stmt)?;
        let id = self.model.instances.len() as u32;
        if let Some(n) = &name {
            let insts = &self.model.instances;
            let names = |k: u32| insts[k as usize].name.as_deref().unwrap_or("");
            if scope.instances.find(n.text, names).is_some() {
                return Err(t.err(n, format!("duplicate {stmt} name {}", quote(n.text))));
            }
        }
        self.model.instances.push(Instance {
            name: name.as_ref().map(|n| lossy(n.text)),
            def: DefId(def),
            color: None,
            transforms,
            array: array_spec,
        });
        if let Some(n) = &name {
            let insts = &self.model.instances;
            scope.instances.insert(n.text, id, |k| {
                insts[k as usize].name.as_deref().unwrap_or("")
            });
        }
        if let Some(c) = color {
            self.material_ref(t, MatSite::Instance(InstanceId(id)), &c);
        }
        items.push(Item::Instance(InstanceId(id)));
        Ok(())
    }

    fn include(
        &mut self,
        t: &mut Toks<'_>,
        _kw: &Token<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
    ) -> PResult<()> {
        let f = t.next()?;
        if f.kind != Kind::Word {
            return Err(t.err(
                &f,
                format!(
                    "expected a file name after 'include', found {}",
                    Lexer::describe(&f)
                ),
            ));
        }
        let mut name = lossy(f.text);
        if name.len() >= 2
            && (name.starts_with('"') && name.ends_with('"')
                || name.starts_with('\'') && name.ends_with('\''))
        {
            name = name[1..name.len() - 1].to_string();
        }
        if name.is_empty() {
            return Err(t.err(&f, format!("empty include file name {}", quote(f.text))));
        }
        t.expect_semi("include")?;
        if self.opts.includes == IncludeMode::Keep {
            items.push(Item::Include(name));
            return Ok(());
        }
        let path = self.dir.join(&name);
        let canon = path.canonicalize().unwrap_or_else(|_| path.clone());
        if self.include_stack.contains(&canon) || self.root.as_ref() == Some(&canon) {
            return Err(t.err(
                &f,
                format!("include cycle: '{}' is already being read", path.display()),
            ));
        }
        if self.include_stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(t.err(
                &f,
                format!(
                    "include of '{}' nested more than {MAX_INCLUDE_DEPTH} deep",
                    path.display()
                ),
            ));
        }
        let src = std::fs::read(&path).map_err(|e| {
            t.err(
                &f,
                format!("cannot read include file '{}': {e}", path.display()),
            )
        })?;
        if src.len() > MAX_SOURCE {
            return Err(t.err(
                &f,
                format!(
                    "include file '{}' is larger than {MAX_SOURCE} bytes",
                    path.display()
                ),
            ));
        }
        let file = path.display().to_string();
        let saved_dir = std::mem::replace(
            &mut self.dir,
            path.parent().map(Path::to_path_buf).unwrap_or_default(),
        );
        self.include_stack.push(canon);
        let mut inner = Toks::new(Lexer::new(&src, &file));
        let r = self.statements(&mut inner, scope, items, None);
        self.include_stack.pop();
        self.dir = saved_dir;
        r
    }

    /// Resolves forward vertex references of a finished scope.
    fn finish_scope(&mut self, scope: Scope, _items: &[Item]) -> PResult<()> {
        for p in scope.pending {
            let verts = &self.model.vertices;
            let Some(id) = scope
                .vertices
                .find(p.name.as_bytes(), |k| verts[k as usize].name.as_str())
            else {
                let what = if p.owner & WIRE_BIT != 0 {
                    "wire"
                } else {
                    "face"
                };
                return Err(error_at(
                    p.pos,
                    format!("{what} names undefined vertex '{}'", p.name.escape_debug()),
                ));
            };
            let slot = if p.owner & WIRE_BIT != 0 {
                &mut self.model.wires[(p.owner & !WIRE_BIT) as usize].polylines[p.contour as usize]
                    [p.index as usize]
            } else {
                &mut self.model.faces[p.owner as usize].contours[p.contour as usize]
                    [p.index as usize]
            };
            *slot = VertexId(id);
        }
        Ok(())
    }

    fn resolve_materials(&mut self) -> PResult<()> {
        let pending = std::mem::take(&mut self.pending_materials);
        for p in pending {
            let mats = &self.model.materials;
            let Some(id) = self
                .materials
                .find(p.name.as_bytes(), |k| mats[k as usize].name.as_str())
            else {
                return Err(error_at(
                    p.pos,
                    format!("undefined material '{}'", p.name.escape_debug()),
                ));
            };
            self.set_material(p.site, MaterialId(id));
        }
        Ok(())
    }
}
