//! ply2ug: a PLY mesh (ASCII, binary little- or big-endian) as a UniGrafix model.
//!
//! What is read (see docs/format.md, "Bridges"):
//!
//! * The header: `ply`, `format ascii|binary_little_endian|binary_big_endian
//!   1.0`, `comment`/`obj_info` lines, `element NAME COUNT`, `property TYPE
//!   NAME` and `property list COUNT_TYPE ITEM_TYPE NAME` with the types
//!   `char uchar short ushort int uint float double` (and `int8` … `float64`).
//! * `vertex`: `x`, `y`, `z` (any numeric type), optional `radiosity_r/g/b`
//!   (all three) and `red/green/blue` (all three).
//! * `face`: a `vertex_indices` (or `vertex_index`) list of integers; optional
//!   `red/green/blue` face colours. Other elements and properties are skipped.
//!
//! Colours:
//!
//! * **Lit** files (vertices with `radiosity_r/g/b`, as `ug2ply` writes lit
//!   models) become lit UG: each vertex names a `c_rgb _radN r g b` holding
//!   its radiosity B, one per distinct value in vertex order, as `ugrad`
//!   writes them. Their display `red/green/blue` (derived from B) are ignored.
//! * **Unlit** files with display colours: a face whose colour is known (its
//!   own `red/green/blue`, else one colour shared by all its vertices) gets a
//!   `c_rgb rgb_RRGGBB` material whose reflectance is the sRGB-decoded colour
//!   (`ug2ply` writes unlit models with the material's diffuse colour, so
//!   this gives it back to 8 bits). Faces whose vertices differ get no
//!   material (one warning). `--ignore-colours` leaves display colours out.
//!
//! Numbers: ASCII values are read as written (as doubles, whatever the
//! declared type); binary `float` values are taken as the shortest decimal
//! that reads back to the same float (so the `float` 0.8 gives 0.8), `double`
//! values exactly. Integer colours are scaled by their type's maximum (255
//! for `uchar`).
//!
//! Output: materials, vertices in order of first use by faces (named `v1`,
//! `v2`, …; vertices no face uses are left out), faces in file order.
//! Errors are `file:line:col: error: …` in the header and in ASCII data, and
//! `file:byte N: error: …` in binary data.

pub mod write;

use std::fmt;

use crate::obj::{Namer, Warnings};
use glam::DVec3;
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Face, Material, MaterialDef, MaterialId, Model, Vertex, VertexId};

/// Where an error or warning is: a line and column (header, ASCII data) or a
/// byte offset from the start of the file (binary data).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum At {
    Text { line: u32, col: u32 },
    Byte(u64),
}

fn locate(file: &str, at: At) -> String {
    match at {
        At::Text { line, col } => format!("{file}:{line}:{col}"),
        At::Byte(n) => format!("{file}:byte {n}"),
    }
}

/// An error in a PLY file.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyError {
    pub file: String,
    pub at: At,
    pub message: String,
}

impl fmt::Display for PlyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: error: {}",
            locate(&self.file, self.at),
            self.message
        )
    }
}

impl std::error::Error for PlyError {}

fn warning(file: &str, at: At, msg: impl fmt::Display) -> String {
    format!("{}: warning: {msg}", locate(file, at))
}

/// A scalar type of the PLY header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(s: &[u8]) -> Option<Scalar> {
        Some(match s {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_int(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The values an integer type holds.
    fn range(self) -> (i64, i64) {
        match self {
            Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
            Scalar::U8 => (0, u8::MAX.into()),
            Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
            Scalar::U16 => (0, u16::MAX.into()),
            Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
            Scalar::U32 => (0, u32::MAX.into()),
            Scalar::F32 | Scalar::F64 => (i64::MIN, i64::MAX),
        }
    }

    /// The value a colour of this type has at full intensity.
    fn full(self) -> f64 {
        match self {
            Scalar::I8 => i8::MAX as f64,
            Scalar::U8 => u8::MAX as f64,
            Scalar::I16 => i16::MAX as f64,
            Scalar::U16 => u16::MAX as f64,
            Scalar::I32 => i32::MAX as f64,
            Scalar::U32 => u32::MAX as f64,
            Scalar::F32 | Scalar::F64 => 1.0,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    at: At,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    Little,
    Big,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the data.
    body: usize,
    /// Line number of the first data line.
    body_line: u32,
    /// The `end_header` line.
    end_at: At,
}

/// A word of a text line with its 1-based column (characters).
struct Word<'a> {
    text: &'a [u8],
    col: u32,
}

fn is_blank(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// Splits a line into words (blank-separated); columns count characters.
fn words(line: &[u8]) -> Vec<Word<'_>> {
    let mut out = Vec::new();
    let mut col = 1u32;
    let mut i = 0;
    while i < line.len() {
        if is_blank(line[i]) {
            col = col.saturating_add(1);
            i += 1;
            continue;
        }
        let start = i;
        let start_col = col;
        while i < line.len() && !is_blank(line[i]) {
            if line[i] & 0xC0 != 0x80 {
                col = col.saturating_add(1);
            }
            i += 1;
        }
        out.push(Word {
            text: &line[start..i],
            col: start_col,
        });
    }
    out
}

/// The column just after the last word of a line (for "missing …" errors).
fn end_col(ws: &[Word]) -> u32 {
    ws.last().map_or(1, |w| {
        w.col
            .saturating_add(String::from_utf8_lossy(w.text).chars().count() as u32)
    })
}

/// Quotes a word for a message (shortened, control characters escaped).
fn quote(t: &[u8]) -> String {
    crate::obj::quote(t)
}

/// Lines of `src` from byte `from`: (line bytes without the newline, start offset).
fn next_line(src: &[u8], from: usize) -> Option<(&[u8], usize)> {
    if from >= src.len() {
        return None;
    }
    let end = src[from..]
        .iter()
        .position(|&c| c == b'\n')
        .map_or(src.len(), |k| from + k);
    Some((&src[from..end], end + 1))
}

fn parse_header(src: &[u8], file: &str) -> Result<Header, PlyError> {
    let err = |line: u32, col: u32, msg: String| PlyError {
        file: file.to_string(),
        at: At::Text { line, col },
        message: msg,
    };
    let mut pos = 0usize;
    let mut line_no = 0u32;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some((line, next)) = next_line(src, pos) else {
            let (l, c) = if line_no == 0 {
                (1, 1)
            } else {
                (line_no + 1, 1)
            };
            let msg = if line_no == 0 {
                "empty file (expected a PLY header)".to_string()
            } else {
                "the header has no 'end_header' line".to_string()
            };
            return Err(err(l, c, msg));
        };
        line_no = line_no.saturating_add(1);
        pos = next;
        let ws = words(line);
        if line_no == 1 {
            if ws.len() != 1 || ws[0].text != b"ply" {
                return Err(err(
                    1,
                    1,
                    "not a PLY file (the first line must be 'ply')".into(),
                ));
            }
            continue;
        }
        let Some(kw) = ws.first() else {
            continue; // blank header lines are tolerated
        };
        match kw.text {
            b"comment" | b"obj_info" => {}
            b"format" => {
                if format.is_some() {
                    return Err(err(line_no, kw.col, "a second 'format' line".into()));
                }
                let Some(f) = ws.get(1) else {
                    return Err(err(
                        line_no,
                        end_col(&ws),
                        "missing format (ascii, binary_little_endian or binary_big_endian)".into(),
                    ));
                };
                format = Some(match f.text {
                    b"ascii" => Format::Ascii,
                    b"binary_little_endian" => Format::Little,
                    b"binary_big_endian" => Format::Big,
                    _ => {
                        return Err(err(
                            line_no,
                            f.col,
                            format!(
                                "unknown format {} (expected ascii, binary_little_endian or binary_big_endian)",
                                quote(f.text)
                            ),
                        ));
                    }
                });
                match ws.get(2) {
                    Some(v) if v.text.starts_with(b"1") => {}
                    Some(v) => {
                        return Err(err(
                            line_no,
                            v.col,
                            format!("unsupported PLY version {} (expected 1.0)", quote(v.text)),
                        ));
                    }
                    None => {
                        return Err(err(line_no, end_col(&ws), "missing version (1.0)".into()));
                    }
                }
                if let Some(w) = ws.get(3) {
                    return Err(err(line_no, w.col, format!("unexpected {}", quote(w.text))));
                }
            }
            b"element" => {
                if format.is_none() {
                    return Err(err(
                        line_no,
                        kw.col,
                        "'element' before the 'format' line".into(),
                    ));
                }
                let (Some(name), Some(count)) = (ws.get(1), ws.get(2)) else {
                    return Err(err(
                        line_no,
                        end_col(&ws),
                        "expected 'element NAME COUNT'".into(),
                    ));
                };
                let n = std::str::from_utf8(count.text)
                    .ok()
                    .and_then(|s| s.parse::<u64>().ok())
                    .ok_or_else(|| {
                        err(
                            line_no,
                            count.col,
                            format!("bad element count {}", quote(count.text)),
                        )
                    })?;
                if let Some(w) = ws.get(3) {
                    return Err(err(line_no, w.col, format!("unexpected {}", quote(w.text))));
                }
                let name = String::from_utf8_lossy(name.text).into_owned();
                if (name == "vertex" || name == "face") && elements.iter().any(|e| e.name == name) {
                    return Err(err(
                        line_no,
                        ws[1].col,
                        format!("a second '{name}' element"),
                    ));
                }
                elements.push(Element {
                    name,
                    count: n,
                    props: Vec::new(),
                    at: At::Text {
                        line: line_no,
                        col: kw.col,
                    },
                });
            }
            b"property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(err(
                        line_no,
                        kw.col,
                        "'property' before any 'element'".into(),
                    ));
                };
                let ty = |w: Option<&Word>, what: &str| -> Result<Scalar, PlyError> {
                    match w {
                        Some(w) => Scalar::from_name(w.text).ok_or_else(|| {
                            err(
                                line_no,
                                w.col,
                                format!("unknown {what} type {}", quote(w.text)),
                            )
                        }),
                        None => Err(err(line_no, end_col(&ws), format!("missing {what} type"))),
                    }
                };
                let (kind, name_at) = if ws.get(1).is_some_and(|w| w.text == b"list") {
                    let count = ty(ws.get(2), "list count")?;
                    if !count.is_int() {
                        return Err(err(
                            line_no,
                            ws[2].col,
                            format!(
                                "a list count must be an integer type, not '{}'",
                                count.name()
                            ),
                        ));
                    }
                    let item = ty(ws.get(3), "list item")?;
                    (Kind::List { count, item }, 4)
                } else {
                    (Kind::Scalar(ty(ws.get(1), "property")?), 2)
                };
                let Some(name) = ws.get(name_at) else {
                    return Err(err(line_no, end_col(&ws), "missing property name".into()));
                };
                if let Some(w) = ws.get(name_at + 1) {
                    return Err(err(line_no, w.col, format!("unexpected {}", quote(w.text))));
                }
                let name = String::from_utf8_lossy(name.text).into_owned();
                if el.props.iter().any(|p| p.name == name) {
                    return Err(err(
                        line_no,
                        ws[name_at].col,
                        format!("a second property '{name}' in element '{}'", el.name),
                    ));
                }
                el.props.push(Property { name, kind });
            }
            b"end_header" => {
                if let Some(w) = ws.get(1) {
                    return Err(err(line_no, w.col, format!("unexpected {}", quote(w.text))));
                }
                let Some(format) = format else {
                    return Err(err(
                        line_no,
                        kw.col,
                        "the header has no 'format' line".into(),
                    ));
                };
                return Ok(Header {
                    format,
                    elements,
                    body: pos.min(src.len()),
                    body_line: line_no.saturating_add(1),
                    end_at: At::Text {
                        line: line_no,
                        col: kw.col,
                    },
                });
            }
            _ => {
                return Err(err(
                    line_no,
                    kw.col,
                    format!("unknown header keyword {}", quote(kw.text)),
                ));
            }
        }
    }
}

/// A value read from the data.
#[derive(Clone, Copy, Debug)]
enum Val {
    Int(i64),
    Float(f64),
}

impl Val {
    fn f64(self) -> f64 {
        match self {
            Val::Int(i) => i as f64,
            Val::Float(x) => x,
        }
    }
}

/// The data of the elements, ASCII or binary.
trait Data {
    /// Starts instance `k` (0-based) of an element.
    fn begin(&mut self, el: &Element, k: u64) -> Result<(), PlyError>;
    /// Reads one value of type `t` for property `prop`; returns it and where it was.
    fn value(&mut self, t: Scalar, el: &Element, prop: &str) -> Result<(Val, At), PlyError>;
    /// Checks that `n` values of type `t` can still be read (binary: enough bytes).
    fn need(&mut self, n: u64, t: Scalar, el: &Element, prop: &str) -> Result<(), PlyError>;
    /// Ends an instance (ASCII: nothing may follow on the line).
    fn end(&mut self, el: &Element) -> Result<(), PlyError>;
    /// Where unread data begins, if any is left.
    fn rest(&mut self) -> Option<At>;
}

struct Ascii<'a> {
    src: &'a [u8],
    file: &'a str,
    pos: usize,
    line_no: u32,
    words: Vec<Word<'a>>,
    next: usize,
    /// The current line's number.
    cur_line: u32,
}

impl<'a> Ascii<'a> {
    fn err(&self, col: u32, msg: String) -> PlyError {
        PlyError {
            file: self.file.to_string(),
            at: At::Text {
                line: self.cur_line,
                col,
            },
            message: msg,
        }
    }

    /// The next line with words, or `None` at the end.
    fn next_words(&mut self) -> Option<(Vec<Word<'a>>, u32)> {
        while let Some((line, next)) = next_line(self.src, self.pos) {
            self.pos = next;
            let n = self.line_no;
            self.line_no = self.line_no.saturating_add(1);
            let ws = words(line);
            if !ws.is_empty() {
                return Some((ws, n));
            }
        }
        None
    }
}

impl Data for Ascii<'_> {
    fn begin(&mut self, el: &Element, k: u64) -> Result<(), PlyError> {
        match self.next_words() {
            Some((ws, n)) => {
                self.words = ws;
                self.next = 0;
                self.cur_line = n;
                Ok(())
            }
            None => {
                self.cur_line = self.line_no;
                Err(self.err(
                    1,
                    format!(
                        "the data ends in element '{}' ({k} of {} read)",
                        el.name, el.count
                    ),
                ))
            }
        }
    }

    fn value(&mut self, t: Scalar, el: &Element, prop: &str) -> Result<(Val, At), PlyError> {
        let Some(w) = self.words.get(self.next) else {
            return Err(self.err(
                end_col(&self.words),
                format!(
                    "missing value for property '{prop}' of element '{}'",
                    el.name
                ),
            ));
        };
        self.next += 1;
        let s = std::str::from_utf8(w.text).unwrap_or("");
        let at = At::Text {
            line: self.cur_line,
            col: w.col,
        };
        let v = if t.is_int() {
            match s.parse::<i64>() {
                Ok(i) if (t.range().0..=t.range().1).contains(&i) => Val::Int(i),
                Ok(_) => {
                    let (lo, hi) = t.range();
                    return Err(self.err(
                        w.col,
                        format!(
                            "{} {} out of range {lo}..={hi} (property '{prop}' of element '{}')",
                            t.name(),
                            quote(w.text),
                            el.name
                        ),
                    ));
                }
                Err(_) => {
                    return Err(self.err(
                        w.col,
                        format!(
                            "bad {} {} (property '{prop}' of element '{}')",
                            t.name(),
                            quote(w.text),
                            el.name
                        ),
                    ));
                }
            }
        } else {
            match s.parse::<f64>() {
                Ok(x) => Val::Float(x),
                Err(_) => {
                    return Err(self.err(
                        w.col,
                        format!(
                            "bad number {} (property '{prop}' of element '{}')",
                            quote(w.text),
                            el.name
                        ),
                    ));
                }
            }
        };
        Ok((v, at))
    }

    fn need(&mut self, _: u64, _: Scalar, _: &Element, _: &str) -> Result<(), PlyError> {
        Ok(())
    }

    fn end(&mut self, el: &Element) -> Result<(), PlyError> {
        match self.words.get(self.next) {
            Some(w) => Err(self.err(
                w.col,
                format!(
                    "unexpected {} after the values of element '{}' (one per line)",
                    quote(w.text),
                    el.name
                ),
            )),
            None => Ok(()),
        }
    }

    fn rest(&mut self) -> Option<At> {
        self.next_words().map(|(ws, n)| At::Text {
            line: n,
            col: ws[0].col,
        })
    }
}

struct Binary<'a> {
    data: &'a [u8],
    /// Offset of `data` in the file.
    base: u64,
    pos: usize,
    big: bool,
    file: &'a str,
    /// The instance being read (for messages).
    k: u64,
}

impl Binary<'_> {
    fn truncated(&self, el: &Element, prop: &str) -> PlyError {
        PlyError {
            file: self.file.to_string(),
            at: At::Byte(self.base + self.pos as u64),
            message: format!(
                "truncated data: it ends in property '{prop}' of element '{}' {} of {}",
                el.name,
                self.k + 1,
                el.count
            ),
        }
    }
}

impl Data for Binary<'_> {
    fn begin(&mut self, _: &Element, k: u64) -> Result<(), PlyError> {
        self.k = k;
        Ok(())
    }

    fn value(&mut self, t: Scalar, el: &Element, prop: &str) -> Result<(Val, At), PlyError> {
        let n = t.size();
        let at = At::Byte(self.base + self.pos as u64);
        let Some(b) = self.data.get(self.pos..self.pos + n) else {
            return Err(self.truncated(el, prop));
        };
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.big {
            a[..n].reverse();
        }
        let v = match t {
            Scalar::I8 => Val::Int(a[0] as i8 as i64),
            Scalar::U8 => Val::Int(a[0] as i64),
            Scalar::I16 => Val::Int(i16::from_le_bytes([a[0], a[1]]) as i64),
            Scalar::U16 => Val::Int(u16::from_le_bytes([a[0], a[1]]) as i64),
            Scalar::I32 => Val::Int(i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as i64),
            Scalar::U32 => Val::Int(u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as i64),
            Scalar::F32 => Val::Float(f32_value(f32::from_le_bytes([a[0], a[1], a[2], a[3]]))),
            Scalar::F64 => Val::Float(f64::from_le_bytes(a)),
        };
        Ok((v, at))
    }

    fn need(&mut self, n: u64, t: Scalar, el: &Element, prop: &str) -> Result<(), PlyError> {
        let left = (self.data.len() - self.pos) as u128;
        if n as u128 * t.size() as u128 > left {
            return Err(self.truncated(el, prop));
        }
        Ok(())
    }

    fn end(&mut self, _: &Element) -> Result<(), PlyError> {
        Ok(())
    }

    fn rest(&mut self) -> Option<At> {
        (self.pos < self.data.len()).then_some(At::Byte(self.base + self.pos as u64))
    }
}

/// A binary `float` as the double of its shortest decimal (0.8f32 → 0.8).
pub fn f32_value(x: f32) -> f64 {
    if !x.is_finite() {
        return x as f64;
    }
    let mut b = ryu::Buffer::new();
    b.format_finite(x).parse::<f64>().unwrap_or(x as f64)
}

/// The linear value of an sRGB-encoded component (clamped to [0, 1]; NaN is 0).
pub fn srgb_decode(c: f64) -> f64 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Options of the conversion.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Leave display colours (`red/green/blue`) out instead of making face materials.
    pub ignore_colours: bool,
}

/// The converted model, warnings for stderr and counts.
#[derive(Debug)]
pub struct Converted {
    pub model: Model,
    pub warnings: Vec<String>,
    /// The file had `radiosity_r/g/b` (the model is lit).
    pub lit: bool,
    /// Faces dropped as degenerate.
    pub dropped: usize,
    /// Vertices no face uses (left out).
    pub unused: usize,
}

/// Indices of the properties an element role needs.
fn prop_index(el: &Element, name: &str) -> Option<usize> {
    el.props.iter().position(|p| p.name == name)
}

/// Indices of three scalar properties (all or none).
fn triple(el: &Element, names: [&str; 3], file: &str) -> Result<Option<[usize; 3]>, PlyError> {
    let ks = names.map(|n| prop_index(el, n));
    if ks.iter().all(Option::is_none) {
        return Ok(None);
    }
    let err = |msg: String| PlyError {
        file: file.to_string(),
        at: el.at,
        message: msg,
    };
    let mut out = [0; 3];
    for (i, k) in ks.iter().enumerate() {
        let Some(k) = *k else {
            return Err(err(format!(
                "element '{}' has some of {}/{}/{} but no '{}'",
                el.name, names[0], names[1], names[2], names[i]
            )));
        };
        if !matches!(el.props[k].kind, Kind::Scalar(_)) {
            return Err(err(format!(
                "property '{}' of element '{}' is a list (expected a number)",
                names[i], el.name
            )));
        }
        out[i] = k;
    }
    Ok(Some(out))
}

fn scalar_type(el: &Element, k: usize) -> Scalar {
    match el.props[k].kind {
        Kind::Scalar(t) => t,
        Kind::List { item, .. } => item,
    }
}

/// A display colour from three values of the given types, in [0, 1] (encoded).
fn display(vals: &[Val], ks: [usize; 3], el: &Element) -> [f64; 3] {
    ks.map(|k| {
        let x = vals[k].f64() / scalar_type(el, k).full();
        if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) }
    })
}

/// A face as read: indices into the PLY vertices, its colour, where it was.
struct RawFace {
    verts: Vec<u32>,
    colour: Option<[f64; 3]>,
}

/// Converts PLY bytes to a UG model.
pub fn convert(src: &[u8], file: &str, opts: &Options) -> Result<Converted, PlyError> {
    let header = parse_header(src, file)?;
    let mut warn = Warnings::default();
    let Some(vi) = header.elements.iter().position(|e| e.name == "vertex") else {
        return Err(PlyError {
            file: file.to_string(),
            at: header.end_at,
            message: "the header has no 'vertex' element".into(),
        });
    };
    let vel = &header.elements[vi];
    let mut xyz = [0usize; 3];
    for (i, n) in ["x", "y", "z"].into_iter().enumerate() {
        let k = prop_index(vel, n).ok_or_else(|| PlyError {
            file: file.to_string(),
            at: vel.at,
            message: format!("element 'vertex' has no property '{n}'"),
        })?;
        if !matches!(vel.props[k].kind, Kind::Scalar(_)) {
            return Err(PlyError {
                file: file.to_string(),
                at: vel.at,
                message: format!(
                    "property '{n}' of element 'vertex' is a list (expected a number)"
                ),
            });
        }
        xyz[i] = k;
    }
    let rad = triple(vel, ["radiosity_r", "radiosity_g", "radiosity_b"], file)?;
    let lit = rad.is_some();
    let vrgb = if lit || opts.ignore_colours {
        None
    } else {
        triple(vel, ["red", "green", "blue"], file)?
    };
    let nverts = vel.count;
    let fi = header.elements.iter().position(|e| e.name == "face");
    let (flist, frgb) = match fi {
        Some(fi) => {
            let fel = &header.elements[fi];
            let k = prop_index(fel, "vertex_indices")
                .or_else(|| prop_index(fel, "vertex_index"))
                .ok_or_else(|| PlyError {
                    file: file.to_string(),
                    at: fel.at,
                    message: "element 'face' has no property 'vertex_indices'".into(),
                })?;
            match fel.props[k].kind {
                Kind::List { item, .. } if item.is_int() => {}
                _ => {
                    return Err(PlyError {
                        file: file.to_string(),
                        at: fel.at,
                        message: format!(
                            "property '{}' of element 'face' must be a list of integers",
                            fel.props[k].name
                        ),
                    });
                }
            }
            let frgb = if lit || opts.ignore_colours {
                None
            } else {
                triple(fel, ["red", "green", "blue"], file)?
            };
            (Some(k), frgb)
        }
        None => (None, None),
    };

    let mut data: Box<dyn Data> = match header.format {
        Format::Ascii => Box::new(Ascii {
            src: &src[header.body..],
            file,
            pos: 0,
            line_no: header.body_line,
            words: Vec::new(),
            next: 0,
            cur_line: header.body_line,
        }),
        f => Box::new(Binary {
            data: &src[header.body..],
            base: header.body as u64,
            pos: 0,
            big: f == Format::Big,
            file,
            k: 0,
        }),
    };

    let cap = |n: u64| n.min(1 << 16) as usize;
    let mut pos: Vec<DVec3> = Vec::with_capacity(cap(nverts));
    let mut radiosity: Vec<[f64; 3]> = Vec::new();
    let mut vcolour: Vec<[f64; 3]> = Vec::new();
    let mut faces: Vec<RawFace> = Vec::new();
    let mut dropped = 0usize;
    let mut vals: Vec<Val> = Vec::new();
    let mut ats: Vec<At> = Vec::new();
    let mut list: Vec<(i64, At)> = Vec::new();
    let non_finite = |what: &str, at: At, el: &str| PlyError {
        file: file.to_string(),
        at,
        message: format!("non-finite {what} in element '{el}'"),
    };
    for (ei, el) in header.elements.iter().enumerate() {
        if el.props.is_empty() {
            continue;
        }
        let is_vertex = ei == vi;
        let is_face = Some(ei) == fi;
        for k in 0..el.count {
            data.begin(el, k)?;
            vals.clear();
            ats.clear();
            let mut face_at = None;
            for (pi, p) in el.props.iter().enumerate() {
                match p.kind {
                    Kind::Scalar(t) => {
                        let (v, at) = data.value(t, el, &p.name)?;
                        vals.push(v);
                        ats.push(at);
                    }
                    Kind::List { count, item } => {
                        let (n, at) = data.value(count, el, &p.name)?;
                        let n = match n {
                            Val::Int(n) if n >= 0 => n as u64,
                            _ => {
                                return Err(PlyError {
                                    file: file.to_string(),
                                    at,
                                    message: format!(
                                        "negative list count {} (property '{}' of element '{}')",
                                        n.f64(),
                                        p.name,
                                        el.name
                                    ),
                                });
                            }
                        };
                        data.need(n, item, el, &p.name)?;
                        vals.push(Val::Int(n as i64));
                        ats.push(at);
                        let keep = is_face && Some(pi) == flist;
                        if keep {
                            list.clear();
                            face_at = Some(at);
                        }
                        for _ in 0..n {
                            let (v, at) = data.value(item, el, &p.name)?;
                            if keep {
                                let Val::Int(i) = v else {
                                    unreachable!("integer item type")
                                };
                                if i < 0 || i as u64 >= nverts {
                                    return Err(PlyError {
                                        file: file.to_string(),
                                        at,
                                        message: format!(
                                            "vertex index {i} is out of range ({nverts} vertices)"
                                        ),
                                    });
                                }
                                list.push((i, at));
                            }
                        }
                    }
                }
            }
            data.end(el)?;
            if is_vertex {
                let p = xyz.map(|k| vals[k].f64());
                if p.iter().any(|c| !c.is_finite()) {
                    let k = xyz[p.iter().position(|c| !c.is_finite()).unwrap_or(0)];
                    return Err(non_finite("coordinate", ats[k], &el.name));
                }
                pos.push(DVec3::from_array(p));
                if let Some(ks) = rad {
                    let b = ks.map(|k| vals[k].f64());
                    if let Some(i) = b.iter().position(|c| !c.is_finite()) {
                        return Err(non_finite("radiosity", ats[ks[i]], &el.name));
                    }
                    radiosity.push(b);
                }
                if let Some(ks) = vrgb {
                    vcolour.push(display(&vals, ks, el));
                }
            } else if is_face {
                let at = face_at.unwrap_or(el.at);
                let mut verts: Vec<u32> = list.iter().map(|&(i, _)| i as u32).collect();
                let before = verts.len();
                verts.dedup();
                while verts.len() > 1 && verts.first() == verts.last() {
                    verts.pop();
                }
                if verts.len() < 3 {
                    warn.push(
                        "degenerate",
                        warning(file, at, "face with fewer than 3 distinct vertices dropped"),
                    );
                    dropped += 1;
                    continue;
                }
                let mut seen = FxHashSet::default();
                if !verts.iter().all(|v| seen.insert(*v)) {
                    warn.push(
                        "degenerate",
                        warning(file, at, "face with a repeated vertex dropped"),
                    );
                    dropped += 1;
                    continue;
                }
                if verts.len() != before {
                    warn.push(
                        "repeated",
                        warning(file, at, "face: consecutive repeated vertex removed"),
                    );
                }
                faces.push(RawFace {
                    verts,
                    colour: frgb.map(|ks| display(&vals, ks, el)),
                });
            }
        }
    }
    if let Some(at) = data.rest() {
        warn.push(
            "trailing",
            warning(file, at, "data after the last element ignored"),
        );
    }

    // Vertices in order of first use.
    const NONE: u32 = u32::MAX;
    let mut vid = vec![NONE; pos.len()];
    let mut order: Vec<u32> = Vec::new();
    for f in &faces {
        for &v in &f.verts {
            if vid[v as usize] == NONE {
                vid[v as usize] = order.len() as u32;
                order.push(v);
            }
        }
    }
    let mut model = Model::new();
    let mut vcol: Vec<Option<MaterialId>> = vec![None; order.len()];
    let mut fmat: Vec<Option<MaterialId>> = vec![None; faces.len()];
    if lit {
        // One `c_rgb _radN` per distinct radiosity, in vertex order (as ugrad).
        let mut by_value: FxHashMap<[u64; 3], MaterialId> = FxHashMap::default();
        for (i, &v) in order.iter().enumerate() {
            let b = radiosity[v as usize];
            let key = b.map(|x| (x + 0.0).to_bits());
            let id = *by_value.entry(key).or_insert_with(|| {
                let name = format!("_rad{}", model.materials.len());
                model.add_material(Material {
                    name,
                    def: MaterialDef::Rgb(b.map(|x| x + 0.0)),
                })
            });
            vcol[i] = Some(id);
        }
    } else if frgb.is_some() || vrgb.is_some() {
        let mut by_value: FxHashMap<[u64; 3], MaterialId> = FxHashMap::default();
        let mut names = Namer::default();
        let mut mixed = 0usize;
        for (k, f) in faces.iter().enumerate() {
            let c = f.colour.or_else(|| {
                let first = vcolour[f.verts[0] as usize];
                let same = f.verts.iter().all(|&v| vcolour[v as usize] == first);
                if !same {
                    mixed += 1;
                }
                same.then_some(first)
            });
            let Some(c) = c else { continue };
            let key = c.map(|x| (x + 0.0).to_bits());
            let id = *by_value.entry(key).or_insert_with(|| {
                let hex = c.map(|x| (x * 255.0).round() as u8);
                let name = names.unique(&format!("rgb_{:02x}{:02x}{:02x}", hex[0], hex[1], hex[2]));
                model.add_material(Material {
                    name,
                    def: MaterialDef::Rgb(c.map(srgb_decode)),
                })
            });
            fmat[k] = Some(id);
        }
        if mixed > 0 {
            warn.push(
                "mixed",
                format!(
                    "warning: {mixed} faces have vertices of different colours; written without a material"
                ),
            );
        }
    }
    for (i, &v) in order.iter().enumerate() {
        model.add_vertex(Vertex {
            name: format!("v{}", i + 1),
            pos: pos[v as usize],
            color: vcol[i],
        });
    }
    for (k, f) in faces.iter().enumerate() {
        model.add_face(Face {
            name: None,
            contours: vec![f.verts.iter().map(|&v| VertexId(vid[v as usize])).collect()],
            material: fmat[k],
        });
    }
    Ok(Converted {
        model,
        warnings: warn.finish(),
        lit,
        dropped,
        unused: pos.len() - order.len(),
    })
}

#[cfg(test)]
mod tests;
