//! mgf2ug: MGF (Greg Ward's Materials and Geometry Format, 2.0) as a
//! UniGrafix model. The choices made where UG and MGF differ are listed in
//! docs/format.md ("Bridges"); in short:
//!
//! * **Geometry.** `f` (holes given as MGF seams, an edge walked once each
//!   way, are turned back into UG holes), `fh` (contours separated by `-`),
//!   and `sph`, `cyl`, `cone`, `ring`, `torus`, `prism` tessellated with
//!   `segments` divisions around (spheres: half as many from pole to pole).
//!   Vertices are looked up when a surface uses them and transformed by the
//!   transform in effect then (MGF's rule); each (vertex, transformed
//!   position) becomes one UG vertex named after the MGF vertex.
//! * **Transforms.** `xf` contexts (nested), `-t -rx -ry -rz -s -mx -my -mz
//!   -i N -a N` (multi-dimensional arrays, each copy in an object named
//!   `aK` or `aK.L`, as MGF's parser names them), also on `i FILE`.
//!   A mirroring transform reverses the faces.
//! * **Materials.** `m` contexts with `rd` (diffuse reflectance) and `ed`
//!   (diffuse emittance), each taking the colour current when it is given:
//!   `diffuse_rgb` = rd × RGB(colour), `emission_rgb` = ed × RGB(colour) ×
//!   emission scale; `sides 2` is kept as a `defmat` property. `td`, `rs`,
//!   `ts`, `ir` are read and ignored (UG materials are diffuse). Each
//!   distinct material state used by a face becomes one `defmat`.
//! * **Names.** Faces are named by the object path (`o` contexts joined by
//!   `.`), made unique (`desk.top`, `desk.top.2`, …); faces outside any
//!   object are unnamed.
//! * Unknown entities (and `ies`) are ignored with one warning per keyword,
//!   or are errors with `--strict`.

pub mod color;

use std::path::{Path, PathBuf};
use std::rc::Rc;

use crate::obj::{Namer, Tok, Warnings, quote, sanitize, sanitize_material, tokenize};
use glam::{DAffine3, DMat3, DVec3};
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{
    Defmat, Diagnostic, Face, Material, MaterialDef, MaterialId, Model, Pos, Vertex, VertexId,
};

use color::Chroma;

/// Options of the conversion.
#[derive(Clone, Debug)]
pub struct Options {
    /// Unknown entities are errors.
    pub strict: bool,
    /// Divisions around curved primitives (at least 3).
    pub segments: u32,
    /// Faces of two-sided materials are written twice (the back one reversed).
    pub two_sided: bool,
    /// Factor from `ed` (lumens/m²) to UG emission.
    pub emission_scale: f64,
    /// At most this many faces (an error beyond).
    pub max_faces: usize,
    /// At most this many statements executed (array expansion included).
    pub max_steps: u64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            strict: false,
            segments: 16,
            two_sided: false,
            emission_scale: 1.0,
            max_faces: 50_000_000,
            max_steps: 200_000_000,
        }
    }
}

/// The converted model, warnings (for stderr) and notes (for `-v`).
#[derive(Debug)]
pub struct Converted {
    pub model: Model,
    pub warnings: Vec<String>,
    pub notes: Vec<String>,
}

/// Include files nest at most this deep.
pub const MAX_INCLUDE_DEPTH: usize = 32;
/// Transform contexts nest at most this deep.
pub const MAX_XF_DEPTH: usize = 256;

/// A word of a source file, owned.
#[derive(Clone, Debug)]
struct OTok {
    text: Vec<u8>,
    line: u32,
    col: u32,
}

impl OTok {
    fn s(&self) -> String {
        String::from_utf8_lossy(&self.text).into_owned()
    }
}

/// A read source file: its statements and, for each `xf` that opens a
/// context, the index of the `xf` that closes it.
struct SrcFile {
    name: String,
    dir: PathBuf,
    lines: Vec<Vec<OTok>>,
    xf_end: Vec<Option<usize>>,
}

fn error(file: &str, t: &OTok, msg: impl Into<String>) -> Diagnostic {
    Diagnostic::error(
        Pos {
            file: file.to_string(),
            line: t.line,
            col: t.col,
        },
        msg,
    )
}

fn warning(file: &str, t: &OTok, msg: impl Into<String>) -> String {
    Diagnostic::warning(
        Pos {
            file: file.to_string(),
            line: t.line,
            col: t.col,
        },
        msg,
    )
    .to_string()
}

impl SrcFile {
    fn parse(bytes: &[u8], name: String, dir: PathBuf) -> Result<SrcFile, Diagnostic> {
        let lines: Vec<Vec<OTok>> = tokenize(bytes)
            .into_iter()
            .map(|l| {
                l.iter()
                    .map(|t: &Tok| OTok {
                        text: t.text.to_vec(),
                        line: t.line,
                        col: t.col,
                    })
                    .collect()
            })
            .collect();
        let mut xf_end = vec![None; lines.len()];
        let mut open: Vec<usize> = Vec::new();
        for (i, l) in lines.iter().enumerate() {
            if l[0].text == b"xf" {
                if l.len() > 1 {
                    open.push(i);
                } else if let Some(b) = open.pop() {
                    xf_end[b] = Some(i);
                } else {
                    return Err(error(
                        &name,
                        &l[0],
                        "'xf' ends a transform context that was not begun in this file",
                    ));
                }
            }
        }
        if let Some(&b) = open.last() {
            return Err(error(
                &name,
                &lines[b][0],
                "transform context not ended in this file (missing 'xf')",
            ));
        }
        Ok(SrcFile {
            name,
            dir,
            lines,
            xf_end,
        })
    }

    fn err(&self, t: &OTok, msg: impl Into<String>) -> Diagnostic {
        error(&self.name, t, msg)
    }

    /// The position just after the last word of a statement (for missing arguments).
    fn after(&self, toks: &[OTok]) -> OTok {
        let last = &toks[toks.len() - 1];
        OTok {
            text: Vec::new(),
            line: last.line,
            col: last
                .col
                .saturating_add(String::from_utf8_lossy(&last.text).chars().count() as u32),
        }
    }

    fn num(&self, t: &OTok, what: &str) -> Result<f64, Diagnostic> {
        let s = std::str::from_utf8(&t.text).ok();
        match s.and_then(|s| s.parse::<f64>().ok()) {
            Some(v) if v.is_finite() => Ok(v),
            Some(_) => Err(self.err(
                t,
                format!("non-finite number {} (expected {what})", quote(&t.text)),
            )),
            None => Err(self.err(
                t,
                format!("bad number {} (expected {what})", quote(&t.text)),
            )),
        }
    }

    fn int(&self, t: &OTok, what: &str, lo: i64, hi: i64) -> Result<i64, Diagnostic> {
        match std::str::from_utf8(&t.text)
            .ok()
            .and_then(|s| s.parse::<i64>().ok())
        {
            Some(v) if (lo..=hi).contains(&v) => Ok(v),
            _ => Err(self.err(
                t,
                format!(
                    "bad {what} {} (expected a whole number from {lo} to {hi})",
                    quote(&t.text)
                ),
            )),
        }
    }

    /// Checks that a statement has exactly `n` arguments.
    fn arity(&self, toks: &[OTok], n: usize, usage: &str) -> Result<(), Diagnostic> {
        if toks.len() - 1 < n {
            return Err(self.err(
                &self.after(toks),
                format!("missing arguments: usage '{usage}'"),
            ));
        }
        if toks.len() - 1 > n {
            return Err(self.err(&toks[n + 1], format!("too many arguments: usage '{usage}'")));
        }
        Ok(())
    }
}

/// One step of an `xf` argument list.
#[derive(Clone, Debug)]
enum XfPart {
    /// Transforms applied once.
    Once(DAffine3),
    /// `-i N`: the following transforms applied N times.
    Repeat(DAffine3, u64),
    /// `-a N`: array dimension (index into the counts), transforms applied k times.
    Array(DAffine3, usize),
}

struct XfSpec {
    parts: Vec<XfPart>,
    counts: Vec<u64>,
}

impl XfSpec {
    fn local(&self, idx: &[u64]) -> DAffine3 {
        let mut m = DAffine3::IDENTITY;
        for p in &self.parts {
            let step = match p {
                XfPart::Once(a) => *a,
                XfPart::Repeat(a, n) => pow(*a, *n),
                XfPart::Array(a, d) => pow(*a, idx[*d]),
            };
            m = step * m;
        }
        m
    }
}

/// `a` applied `n` times.
fn pow(a: DAffine3, mut n: u64) -> DAffine3 {
    let (mut result, mut base) = (DAffine3::IDENTITY, a);
    while n > 0 {
        if n & 1 == 1 {
            result = base * result;
        }
        base = base * base;
        n >>= 1;
    }
    result
}

/// sin and cos of an angle in degrees, exact for multiples of 90°.
fn sin_cos_deg(deg: f64) -> (f64, f64) {
    let r = deg.rem_euclid(360.0);
    if r == 0.0 {
        (0.0, 1.0)
    } else if r == 90.0 {
        (1.0, 0.0)
    } else if r == 180.0 {
        (0.0, -1.0)
    } else if r == 270.0 {
        (-1.0, 0.0)
    } else {
        deg.to_radians().sin_cos()
    }
}

fn parse_xf(f: &SrcFile, args: &[OTok]) -> Result<XfSpec, Diagnostic> {
    let mut parts = Vec::new();
    let mut counts = Vec::new();
    let mut cur = DAffine3::IDENTITY;
    // What the transforms being gathered are: once, repeated or an array dimension.
    let mut kind: Option<(bool, u64)> = None; // (is_array, count or dimension)
    let mut i = 0;
    let close = |parts: &mut Vec<XfPart>, kind: Option<(bool, u64)>, cur: DAffine3| match kind {
        None => parts.push(XfPart::Once(cur)),
        Some((false, n)) => parts.push(XfPart::Repeat(cur, n)),
        Some((true, d)) => parts.push(XfPart::Array(cur, d as usize)),
    };
    while i < args.len() {
        let t = &args[i];
        let need = |n: usize| -> Result<Vec<f64>, Diagnostic> {
            let mut v = Vec::with_capacity(n);
            for k in 0..n {
                match args.get(i + 1 + k) {
                    Some(a) => v.push(f.num(a, &format!("a number after '{}'", t.s()))?),
                    None => {
                        return Err(f.err(t, format!("transform '{}' needs {n} number(s)", t.s())));
                    }
                }
            }
            Ok(v)
        };
        let op = match t.text.as_slice() {
            b"-t" => {
                let v = need(3)?;
                i += 3;
                DAffine3::from_translation(DVec3::new(v[0], v[1], v[2]))
            }
            b"-rx" | b"-ry" | b"-rz" => {
                let v = need(1)?;
                i += 1;
                let (s, c) = sin_cos_deg(v[0]);
                let m = match t.text[2] {
                    b'x' => {
                        DMat3::from_cols(DVec3::X, DVec3::new(0.0, c, s), DVec3::new(0.0, -s, c))
                    }
                    b'y' => {
                        DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c))
                    }
                    _ => DMat3::from_cols(DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0), DVec3::Z),
                };
                DAffine3::from_mat3(m)
            }
            b"-s" => {
                let v = need(1)?;
                if v[0] == 0.0 {
                    return Err(f.err(&args[i + 1], "scale factor 0"));
                }
                i += 1;
                DAffine3::from_scale(DVec3::splat(v[0]))
            }
            b"-mx" => DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0)),
            b"-my" => DAffine3::from_scale(DVec3::new(1.0, -1.0, 1.0)),
            b"-mz" => DAffine3::from_scale(DVec3::new(1.0, 1.0, -1.0)),
            b"-i" | b"-a" => {
                let Some(a) = args.get(i + 1) else {
                    return Err(f.err(t, format!("'{}' needs a count", t.s())));
                };
                close(&mut parts, kind, cur);
                cur = DAffine3::IDENTITY;
                if t.text == b"-i" {
                    kind = Some((false, f.int(a, "repeat count", 0, 1_000_000_000)? as u64));
                } else {
                    if counts.len() >= 8 {
                        return Err(f.err(t, "more than 8 array dimensions"));
                    }
                    counts.push(f.int(a, "array count", 1, 1_000_000_000)? as u64);
                    kind = Some((true, (counts.len() - 1) as u64));
                }
                i += 2;
                continue;
            }
            _ => {
                return Err(f.err(t, format!("unknown transform {}", quote(&t.text))));
            }
        };
        cur = op * cur;
        i += 1;
    }
    close(&mut parts, kind, cur);
    Ok(XfSpec { parts, counts })
}

/// A material as MGF describes it.
#[derive(Clone, Debug, PartialEq)]
struct MgfMaterial {
    two_sided: bool,
    rd: f64,
    rd_c: Chroma,
    ed: f64,
    ed_c: Chroma,
}

impl Default for MgfMaterial {
    fn default() -> Self {
        // The unnamed material is a two-sided perfect absorber.
        MgfMaterial {
            two_sided: true,
            rd: 0.0,
            rd_c: Chroma::default(),
            ed: 0.0,
            ed_c: Chroma::default(),
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct MgfVertex {
    p: DVec3,
    n: DVec3,
}

/// A transform context: the total transform and whether it mirrors.
#[derive(Clone, Copy)]
struct Frame {
    m: DAffine3,
    mirror: bool,
}

/// A named context (colour, material or vertex): the table and the current one.
struct Contexts<T: Clone + Default> {
    table: FxHashMap<Vec<u8>, T>,
    current: T,
    name: Option<Vec<u8>>,
}

impl<T: Clone + Default> Default for Contexts<T> {
    fn default() -> Self {
        Contexts {
            table: FxHashMap::default(),
            current: T::default(),
            name: None,
        }
    }
}

impl<T: Clone + Default> Contexts<T> {
    /// `KW`, `KW id`, `KW id =`, `KW id = template`.
    fn select(&mut self, f: &SrcFile, toks: &[OTok], what: &str) -> Result<(), Diagnostic> {
        match toks.len() {
            1 => {
                self.current = T::default();
                self.name = None;
            }
            2 => {
                let Some(v) = self.table.get(&toks[1].text) else {
                    return Err(f.err(
                        &toks[1],
                        format!("undefined {what} {}", quote(&toks[1].text)),
                    ));
                };
                self.current = v.clone();
                self.name = Some(toks[1].text.clone());
            }
            3 | 4 if toks[2].text == b"=" => {
                let v =
                    match toks.get(3) {
                        None => T::default(),
                        Some(t) => self.table.get(&t.text).cloned().ok_or_else(|| {
                            f.err(t, format!("undefined {what} {}", quote(&t.text)))
                        })?,
                    };
                self.table.insert(toks[1].text.clone(), v.clone());
                self.current = v;
                self.name = Some(toks[1].text.clone());
            }
            _ => {
                let at = if toks.len() > 2 && toks[2].text != b"=" {
                    &toks[2]
                } else {
                    &toks[toks.len() - 1]
                };
                return Err(f.err(
                    at,
                    format!(
                        "usage '{} [id [= [template]]]'",
                        String::from_utf8_lossy(&toks[0].text)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Changes the current context (and its table entry when named).
    fn modify(&mut self, change: impl FnOnce(&mut T)) {
        change(&mut self.current);
        if let Some(n) = &self.name {
            self.table.insert(n.clone(), self.current.clone());
        }
    }
}

/// A corner of a surface before it is transformed: the name UG derives
/// its vertex name from, and the position in the surface's coordinates.
#[derive(Clone, Debug)]
struct Corner {
    name: Vec<u8>,
    p: DVec3,
}

/// The interpreter.
struct Conv<'a> {
    opts: &'a Options,
    read: &'a mut dyn FnMut(&Path) -> std::io::Result<Vec<u8>>,
    files: FxHashMap<PathBuf, Rc<SrcFile>>,
    includes: Vec<PathBuf>,
    colors: Contexts<Chroma>,
    mats: Contexts<MgfMaterial>,
    verts: Contexts<MgfVertex>,
    frames: Vec<Frame>,
    objects: Vec<String>,
    steps: u64,
    warn: Warnings,
    warned: FxHashSet<Vec<u8>>,
    notes: Vec<String>,
    // Output.
    out_mats: Vec<Material>,
    mat_index: FxHashMap<(Option<Vec<u8>>, [u64; 7]), MaterialId>,
    mat_names: Namer,
    out_verts: Vec<Vertex>,
    vert_index: FxHashMap<(Vec<u8>, [u64; 3]), VertexId>,
    vert_names: Namer,
    out_faces: Vec<Face>,
    face_names: Namer,
}

impl Conv<'_> {
    fn frame(&self) -> Frame {
        self.frames.last().copied().unwrap_or(Frame {
            m: DAffine3::IDENTITY,
            mirror: false,
        })
    }

    fn load(
        &mut self,
        path: &Path,
        name: String,
        at: Option<(&SrcFile, &OTok)>,
    ) -> Result<Rc<SrcFile>, Diagnostic> {
        if let Some(f) = self.files.get(path) {
            return Ok(f.clone());
        }
        let bytes = (self.read)(path).map_err(|e| match at {
            Some((f, t)) => f.err(t, format!("cannot read {}: {e}", quote(name.as_bytes()))),
            None => Diagnostic::plain(format!("{name}: cannot read: {e}")),
        })?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let f = Rc::new(SrcFile::parse(&bytes, name, dir)?);
        self.files.insert(path.to_path_buf(), f.clone());
        Ok(f)
    }

    /// Runs statements `range` of a file.
    fn exec(&mut self, f: &Rc<SrcFile>, range: std::ops::Range<usize>) -> Result<(), Diagnostic> {
        let mut i = range.start;
        while i < range.end {
            let toks = &f.lines[i];
            self.step(f, &toks[0])?;
            if toks[0].text == b"xf" {
                // Every `xf` with arguments has its end (checked when the file was read).
                let end = f.xf_end[i].unwrap_or(range.end);
                let spec = parse_xf(f, &toks[1..])?;
                let f2 = f.clone();
                self.with_xf(f, &toks[0], &spec, &mut |c| c.exec(&f2, i + 1..end))?;
                i = end + 1;
                continue;
            }
            self.statement(f, toks)?;
            i += 1;
        }
        Ok(())
    }

    /// Counts one unit of work (a statement, an array copy) against the limit.
    fn step(&mut self, f: &SrcFile, at: &OTok) -> Result<(), Diagnostic> {
        self.steps += 1;
        if self.steps > self.opts.max_steps {
            return Err(f.err(
                at,
                format!(
                    "more than {} statements to run (arrays expanding without end?)",
                    self.opts.max_steps
                ),
            ));
        }
        Ok(())
    }

    /// Runs `body` once per array copy of a transform context.
    fn with_xf(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        spec: &XfSpec,
        body: &mut dyn FnMut(&mut Self) -> Result<(), Diagnostic>,
    ) -> Result<(), Diagnostic> {
        if self.frames.len() >= MAX_XF_DEPTH {
            return Err(f.err(
                at,
                format!("transform contexts nested deeper than {MAX_XF_DEPTH}"),
            ));
        }
        let mut idx = vec![0u64; spec.counts.len()];
        loop {
            self.step(f, at)?;
            let local = spec.local(&idx);
            let outer = self.frame();
            let m = outer.m * local;
            if !m.matrix3.is_finite() || !m.translation.is_finite() {
                return Err(f.err(at, "the transform overflows"));
            }
            self.frames.push(Frame {
                m,
                mirror: outer.mirror ^ (local.matrix3.determinant() < 0.0),
            });
            let depth = self.objects.len();
            if !idx.is_empty() {
                let name: Vec<String> = idx.iter().map(u64::to_string).collect();
                self.objects.push(format!("a{}", name.join(".")));
            }
            let r = body(self);
            if !idx.is_empty() {
                self.objects.truncate(depth);
            }
            self.frames.pop();
            r?;
            // Next index, last dimension fastest.
            let mut d = idx.len();
            loop {
                if d == 0 {
                    return Ok(());
                }
                d -= 1;
                idx[d] += 1;
                if idx[d] < spec.counts[d] {
                    break;
                }
                idx[d] = 0;
            }
        }
    }

    fn unknown(&mut self, f: &SrcFile, t: &OTok, why: &str) -> Result<(), Diagnostic> {
        if self.opts.strict {
            return Err(f.err(t, format!("{why} {}", quote(&t.text))));
        }
        if self.warned.insert(t.text.clone()) {
            self.warn.push(
                "entity",
                warning(&f.name, t, format!("{why} {} ignored", quote(&t.text))),
            );
        }
        Ok(())
    }

    fn note_once(&mut self, key: &[u8], msg: String) {
        if self.warned.insert(key.to_vec()) {
            self.notes.push(msg);
        }
    }

    fn vertex(&self, f: &SrcFile, t: &OTok) -> Result<MgfVertex, Diagnostic> {
        self.verts
            .table
            .get(&t.text)
            .copied()
            .ok_or_else(|| f.err(t, format!("undefined vertex {}", quote(&t.text))))
    }

    fn statement(&mut self, f: &Rc<SrcFile>, toks: &[OTok]) -> Result<(), Diagnostic> {
        let kw = toks[0].text.as_slice();
        match kw {
            b"o" => match toks.len() {
                1 => {
                    if self.objects.pop().is_none() {
                        return Err(f.err(&toks[0], "'o' ends an object context, but none is open"));
                    }
                }
                2 => self.objects.push(toks[1].s()),
                _ => return Err(f.err(&toks[2], "too many arguments: usage 'o [name]'")),
            },
            b"i" => {
                if toks.len() < 2 {
                    return Err(f.err(&f.after(toks), "missing file name: usage 'i file [xform]'"));
                }
                let name = toks[1].s();
                if name.starts_with('!') {
                    return self.unknown(f, &toks[1], "command include (not run)");
                }
                if self.includes.len() >= MAX_INCLUDE_DEPTH {
                    return Err(f.err(
                        &toks[1],
                        format!("includes nested deeper than {MAX_INCLUDE_DEPTH}"),
                    ));
                }
                let path = f.dir.join(&name);
                if self.includes.contains(&path) {
                    return Err(f.err(
                        &toks[1],
                        format!(
                            "include cycle: {} is already being read",
                            quote(name.as_bytes())
                        ),
                    ));
                }
                let shown = path.display().to_string();
                let inc = self.load(&path, shown, Some((f.as_ref(), &toks[1])))?;
                let spec = parse_xf(f, &toks[2..])?;
                self.includes.push(path);
                let n = inc.lines.len();
                let depth = self.objects.len();
                let r = if toks.len() > 2 {
                    self.with_xf(f, &toks[0], &spec, &mut |c| c.exec(&inc, 0..n))
                } else {
                    self.exec(&inc, 0..n)
                };
                self.includes.pop();
                r?;
                if self.objects.len() > depth {
                    self.warn.push(
                        "object",
                        warning(
                            &f.name,
                            &toks[1],
                            "object context(s) left open by the included file were closed",
                        ),
                    );
                    self.objects.truncate(depth);
                }
            }
            b"c" => self.colors.select(f, toks, "colour")?,
            b"cxy" => {
                f.arity(toks, 2, "cxy x y")?;
                let x = f.num(&toks[1], "x chromaticity")?;
                let y = f.num(&toks[2], "y chromaticity")?;
                if !(x >= 0.0 && y > 0.0 && x + y <= 1.0) {
                    return Err(f.err(
                        &toks[1],
                        "chromaticity outside the CIE diagram (need x ≥ 0, y > 0, x + y ≤ 1)",
                    ));
                }
                self.colors.modify(|c| *c = Chroma::xy(x, y));
            }
            b"cspec" => {
                if toks.len() < 5 {
                    return Err(f.err(
                        &f.after(toks),
                        "missing arguments: usage 'cspec l_min l_max v1 v2 ...'",
                    ));
                }
                let lmin = f.num(&toks[1], "minimum wavelength")?;
                let lmax = f.num(&toks[2], "maximum wavelength")?;
                if !(lmin > 0.0 && lmax > lmin) {
                    return Err(f.err(&toks[1], "wavelengths must be positive and increasing"));
                }
                let mut v = Vec::with_capacity(toks.len() - 3);
                let mut lowest: Option<(f64, &OTok)> = None;
                for t in &toks[3..] {
                    let x = f.num(t, "spectral value")?;
                    if x < 0.0 {
                        // Measured tables dip below zero by noise: clamp.
                        if lowest.is_none_or(|(l, _)| x < l) {
                            lowest = Some((x, t));
                        }
                        v.push(0.0);
                    } else {
                        v.push(x);
                    }
                }
                if let Some((x, t)) = lowest {
                    // One warning per material (or colour, outside one).
                    let (what, name) = match (&self.mats.name, &self.colors.name) {
                        (Some(m), _) => ("material", m.clone()),
                        (None, Some(c)) => ("colour", c.clone()),
                        (None, None) => ("colour", Vec::new()),
                    };
                    let mut key = b"cspec<0 ".to_vec();
                    key.extend_from_slice(what.as_bytes());
                    key.push(b' ');
                    key.extend_from_slice(&name);
                    if self.warned.insert(key) {
                        let who = if name.is_empty() {
                            "the current colour".to_string()
                        } else {
                            format!("{what} {}", quote(&name))
                        };
                        self.warn.push(
                            "spectrum",
                            warning(
                                &f.name,
                                t,
                                format!(
                                    "negative spectral samples (down to {x}) in {who} clamped to 0"
                                ),
                            ),
                        );
                    }
                }
                let c = Chroma::from_xyz(color::cspec_xyz(lmin, lmax, &v))
                    .ok_or_else(|| f.err(&toks[0], "the spectrum has no visible energy"))?;
                self.colors.modify(|x| *x = c);
            }
            b"cct" => {
                f.arity(toks, 1, "cct temperature")?;
                let t = f.num(&toks[1], "temperature")?;
                let c = (t > 0.0)
                    .then(|| Chroma::from_xyz(color::blackbody_xyz(t)))
                    .flatten()
                    .ok_or_else(|| f.err(&toks[1], "colour temperature out of range"))?;
                self.colors.modify(|x| *x = c);
            }
            b"cmix" => {
                if toks.len() < 3 || toks.len() & 1 == 0 {
                    return Err(f.err(&f.after(toks), "usage 'cmix w1 c1 w2 c2 ...'"));
                }
                let mut sum = DVec3::ZERO;
                for pair in toks[1..].chunks(2) {
                    let w = f.num(&pair[0], "weight")?;
                    if w < 0.0 {
                        return Err(f.err(&pair[0], "negative weight"));
                    }
                    let c = self
                        .colors
                        .table
                        .get(&pair[1].text)
                        .copied()
                        .ok_or_else(|| {
                            f.err(
                                &pair[1],
                                format!("undefined colour {}", quote(&pair[1].text)),
                            )
                        })?;
                    sum += c.xyz() * w;
                }
                let c = Chroma::from_xyz(sum)
                    .ok_or_else(|| f.err(&toks[0], "the mixture has no weight"))?;
                self.colors.modify(|x| *x = c);
            }
            b"m" => self.mats.select(f, toks, "material")?,
            b"sides" => {
                f.arity(toks, 1, "sides {1|2}")?;
                let n = f.int(&toks[1], "number of sides", 1, 2)?;
                self.mats.modify(|m| m.two_sided = n == 2);
            }
            b"rd" | b"ed" => {
                f.arity(
                    toks,
                    1,
                    if kw == b"rd" {
                        "rd rho_d"
                    } else {
                        "ed epsilon_d"
                    },
                )?;
                let v = f.num(
                    &toks[1],
                    if kw == b"rd" {
                        "reflectance"
                    } else {
                        "emittance"
                    },
                )?;
                if v < 0.0 {
                    return Err(f.err(&toks[1], "negative value"));
                }
                let c = self.colors.current;
                if kw == b"rd" {
                    self.mats.modify(|m| {
                        m.rd = v;
                        m.rd_c = c;
                    });
                } else {
                    self.mats.modify(|m| {
                        m.ed = v;
                        m.ed_c = c;
                    });
                }
            }
            b"td" | b"rs" | b"ts" | b"ir" => {
                let n = if kw == b"td" { 1 } else { 2 };
                f.arity(toks, n, &format!("{} …", String::from_utf8_lossy(kw)))?;
                for t in &toks[1..] {
                    f.num(t, "a number")?;
                }
                let msg = warning(
                    &f.name,
                    &toks[0],
                    format!(
                        "note: '{}' ignored (UG materials are diffuse)",
                        String::from_utf8_lossy(kw)
                    ),
                )
                .replacen("warning: note:", "note:", 1);
                self.note_once(kw, msg);
            }
            b"v" => self.verts.select(f, toks, "vertex")?,
            b"p" | b"n" => {
                f.arity(toks, 3, if kw == b"p" { "p x y z" } else { "n dx dy dz" })?;
                let mut c = [0.0; 3];
                for k in 0..3 {
                    c[k] = f.num(&toks[k + 1], ["x", "y", "z"][k])?;
                }
                let v = DVec3::from_array(c);
                if kw == b"p" {
                    self.verts.modify(|x| x.p = v);
                } else {
                    self.verts.modify(|x| x.n = v);
                }
            }
            b"f" => self.face(f, toks)?,
            b"fh" => self.face_holes(f, toks)?,
            b"sph" => {
                f.arity(toks, 2, "sph vc radius")?;
                let c = self.vertex(f, &toks[1])?;
                let r = f.num(&toks[2], "radius")?;
                if r == 0.0 {
                    return Err(f.err(&toks[2], "zero radius"));
                }
                self.sphere(f, &toks[0], &toks[1].text, c.p, r)?;
            }
            b"cyl" | b"cone" => {
                let (a, r1, b, r2) = if kw == b"cyl" {
                    f.arity(toks, 3, "cyl v1 radius v2")?;
                    let r = f.num(&toks[2], "radius")?;
                    (&toks[1], r, &toks[3], r)
                } else {
                    f.arity(toks, 4, "cone v1 rad1 v2 rad2")?;
                    let r1 = f.num(&toks[2], "radius")?;
                    let r2 = f.num(&toks[4], "radius")?;
                    (&toks[1], r1, &toks[3], r2)
                };
                if r1 == 0.0 && r2 == 0.0 {
                    return Err(f.err(&toks[2], "zero radius"));
                }
                if r1 * r2 < 0.0 {
                    return Err(f.err(&toks[2], "radii of opposite signs"));
                }
                let (pa, pb) = (self.vertex(f, a)?.p, self.vertex(f, b)?.p);
                if pa == pb {
                    return Err(f.err(b, "the axis has zero length"));
                }
                self.cone(f, &toks[0], (&a.text, pa, r1), (&b.text, pb, r2))?;
            }
            b"ring" | b"torus" => {
                let usage = if kw == b"ring" {
                    "ring vc rmin rmax"
                } else {
                    "torus vc rmin rmax"
                };
                f.arity(toks, 3, usage)?;
                let c = self.vertex(f, &toks[1])?;
                let r0 = f.num(&toks[2], "inner radius")?;
                let r1 = f.num(&toks[3], "outer radius")?;
                if c.n.length_squared() == 0.0 || !c.n.is_finite() {
                    return Err(f.err(
                        &toks[1],
                        format!(
                            "{} needs a vertex with a normal",
                            String::from_utf8_lossy(kw)
                        ),
                    ));
                }
                let inward = kw == b"torus" && r1 < 0.0 && r0 <= 0.0;
                let (r0, r1) = if inward { (-r0, -r1) } else { (r0, r1) };
                if !(r0 >= 0.0 && r0 < r1) {
                    return Err(f.err(&toks[2], "need 0 ≤ inner radius < outer radius"));
                }
                if kw == b"ring" {
                    self.ring(f, &toks[0], &toks[1].text, c, r0, r1)?;
                } else {
                    self.torus(f, &toks[0], &toks[1].text, c, r0, r1, inward)?;
                }
            }
            b"prism" => {
                if toks.len() < 5 {
                    return Err(f.err(
                        &f.after(toks),
                        "missing arguments: usage 'prism v1 v2 v3 ... length'",
                    ));
                }
                let len = f.num(&toks[toks.len() - 1], "length")?;
                if len == 0.0 {
                    return Err(f.err(&toks[toks.len() - 1], "zero length"));
                }
                let mut base = Vec::new();
                for t in &toks[1..toks.len() - 1] {
                    base.push(Corner {
                        name: t.text.clone(),
                        p: self.vertex(f, t)?.p,
                    });
                }
                self.prism(f, &toks[0], base, len)?;
            }
            b"ies" => self.unknown(f, &toks[0], "unsupported entity")?,
            b"xf" => {
                return Err(f.err(&toks[0], "'xf' ends a transform context that was not begun"));
            }
            _ => self.unknown(f, &toks[0], "unknown entity")?,
        }
        Ok(())
    }

    /// `f v1 v2 …`, with holes written as seams.
    fn face(&mut self, f: &SrcFile, toks: &[OTok]) -> Result<(), Diagnostic> {
        if toks.len() < 4 {
            return Err(f.err(&f.after(toks), "a face needs at least 3 vertices"));
        }
        // Small ids for the names, in order.
        let mut ids: FxHashMap<&[u8], usize> = FxHashMap::default();
        let mut corners: Vec<Corner> = Vec::new();
        let mut seq = Vec::with_capacity(toks.len() - 1);
        for t in &toks[1..] {
            let v = self.vertex(f, t)?;
            let n = ids.len();
            let id = *ids.entry(&t.text).or_insert(n);
            if id == corners.len() {
                corners.push(Corner {
                    name: t.text.clone(),
                    p: v.p,
                });
            }
            seq.push(id);
        }
        // Consecutive repeats (cyclically) are dropped.
        seq.dedup();
        while seq.len() > 1 && seq.first() == seq.last() {
            seq.pop();
        }
        // Seams first (an edge walked both ways), then pinches (a loop that
        // passes a vertex twice: a hole hung on one vertex, or two loops
        // meeting at a corner).
        let mut loops: Vec<Vec<usize>> = Vec::new();
        let mut pinched: Vec<Vec<usize>> = Vec::new();
        for l in split_seams(seq) {
            let pieces = split_pinches(l);
            if pieces.len() > 1 {
                pinched.extend(pieces.into_iter().filter(|p| p.len() >= 3));
            } else {
                loops.extend(pieces.into_iter().filter(|p| p.len() >= 3));
            }
        }
        if !pinched.is_empty() {
            // The largest loop is the outline; a pinched piece inside it is a
            // hole, one outside it is a face of its own.
            let pts = |l: &[usize]| l.iter().map(|&i| corners[i].p).collect::<Vec<_>>();
            let area = |l: &[usize]| geom::newell_normal(&pts(l)).length();
            let all: Vec<Vec<usize>> = loops.iter().chain(&pinched).cloned().collect();
            let outer = (0..all.len())
                .max_by(|&a, &b| area(&all[a]).total_cmp(&area(&all[b])).then(b.cmp(&a)))
                .unwrap_or(0);
            let outline = pts(&all[outer]);
            let mut separate = Vec::new();
            for p in pinched {
                if p == all[outer] || inside_loop(&outline, &pts(&p)) {
                    loops.push(p);
                } else {
                    separate.push(p);
                }
            }
            for p in separate {
                let contour: Vec<Corner> = p.iter().map(|&i| corners[i].clone()).collect();
                self.polygon_with_holes(f, &toks[0], vec![contour])?;
            }
        }
        if loops.is_empty() {
            self.warn.push(
                "degenerate",
                warning(
                    &f.name,
                    &toks[0],
                    "face with fewer than 3 distinct vertices dropped",
                ),
            );
            return Ok(());
        }
        let contours: Vec<Vec<Corner>> = loops
            .iter()
            .map(|l| l.iter().map(|&i| corners[i].clone()).collect())
            .collect();
        self.polygon_with_holes(f, &toks[0], contours)
    }

    /// `fh v1 v2 v3 … - v4 v5 v6 … - …`
    fn face_holes(&mut self, f: &SrcFile, toks: &[OTok]) -> Result<(), Diagnostic> {
        let mut contours: Vec<Vec<Corner>> = vec![Vec::new()];
        let mut starts = vec![&toks[0]];
        for t in &toks[1..] {
            if t.text == b"-" {
                contours.push(Vec::new());
                starts.push(t);
                continue;
            }
            let v = self.vertex(f, t)?;
            if let Some(c) = contours.last_mut() {
                c.push(Corner {
                    name: t.text.clone(),
                    p: v.p,
                });
            }
        }
        let mut seen = FxHashSet::default();
        for (c, at) in contours.iter().zip(&starts) {
            if c.len() < 3 {
                return Err(f.err(at, "a contour needs at least 3 vertices"));
            }
            if !c.iter().all(|x| seen.insert(x.name.clone())) {
                return Err(f.err(at, "a vertex is repeated in the face"));
            }
        }
        self.polygon_with_holes(f, &toks[0], contours)
    }

    /// The outer contour is the largest; holes are made to wind against it.
    fn polygon_with_holes(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        mut contours: Vec<Vec<Corner>>,
    ) -> Result<(), Diagnostic> {
        let normals: Vec<DVec3> = contours
            .iter()
            .map(|c| geom::newell_normal(&c.iter().map(|x| x.p).collect::<Vec<_>>()))
            .collect();
        let outer = (0..contours.len())
            .max_by(|&a, &b| {
                normals[a]
                    .length()
                    .total_cmp(&normals[b].length())
                    .then(b.cmp(&a))
            })
            .unwrap_or(0);
        let n0 = normals[outer];
        let first = contours.remove(outer);
        let mut out = vec![first];
        for (k, mut c) in contours.into_iter().enumerate() {
            let n = normals[if k >= outer { k + 1 } else { k }];
            if n.dot(n0) > 0.0 {
                c[1..].reverse();
            }
            out.push(c);
        }
        self.emit(f, at, out)
    }

    /// Adds a surface (contours of corners in surface coordinates) under the
    /// current transform, material and object.
    fn emit(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        contours: Vec<Vec<Corner>>,
    ) -> Result<(), Diagnostic> {
        if self.out_faces.len() >= self.opts.max_faces {
            return Err(f.err(at, format!("more than {} faces", self.opts.max_faces)));
        }
        let fr = self.frame();
        let mut vs: Vec<Vec<VertexId>> = Vec::with_capacity(contours.len());
        for c in contours {
            let mut ids = Vec::with_capacity(c.len());
            for corner in c {
                let p = fr.m.transform_point3(corner.p);
                if !p.is_finite() {
                    return Err(f.err(at, "a transformed coordinate overflows"));
                }
                let key = (corner.name, p.to_array().map(|x| (x + 0.0).to_bits()));
                let id = match self.vert_index.get(&key) {
                    Some(&id) => id,
                    None => {
                        let id = VertexId(self.out_verts.len() as u32);
                        let name = self
                            .vert_names
                            .unique(&sanitize(&String::from_utf8_lossy(&key.0)));
                        self.out_verts.push(Vertex {
                            name,
                            pos: p,
                            color: None,
                        });
                        self.vert_index.insert(key, id);
                        id
                    }
                };
                ids.push(id);
            }
            if fr.mirror && ids.len() > 1 {
                ids[1..].reverse();
            }
            vs.push(ids);
        }
        let material = self.material(f, at)?;
        let base = (!self.objects.is_empty()).then(|| sanitize(&self.objects.join(".")));
        let two = self.opts.two_sided && self.mats.current.two_sided;
        let back = two.then(|| {
            vs.iter()
                .map(|c| {
                    let mut r = c.clone();
                    r[1..].reverse();
                    r
                })
                .collect::<Vec<_>>()
        });
        let name = base.as_deref().map(|b| self.face_names.unique(b));
        self.out_faces.push(Face {
            name,
            contours: vs,
            material: Some(material),
        });
        if let Some(back) = back {
            let name = base
                .as_deref()
                .map(|b| self.face_names.unique(&format!("{b}.back")));
            self.out_faces.push(Face {
                name,
                contours: back,
                material: Some(material),
            });
        }
        Ok(())
    }

    /// The UG material of the current MGF material state.
    fn material(&mut self, f: &SrcFile, at: &OTok) -> Result<MaterialId, Diagnostic> {
        let m = &self.mats.current;
        let diffuse = m.rd_c.rgb().map(|c| c * m.rd);
        let emission = m.ed_c.rgb().map(|c| c * m.ed * self.opts.emission_scale);
        if !diffuse.iter().chain(&emission).all(|v| v.is_finite()) {
            return Err(f.err(at, "the material's colour overflows"));
        }
        let bits = |v: f64| (v + 0.0).to_bits();
        let key = (
            self.mats.name.clone(),
            [
                bits(diffuse[0]),
                bits(diffuse[1]),
                bits(diffuse[2]),
                bits(emission[0]),
                bits(emission[1]),
                bits(emission[2]),
                m.two_sided as u64,
            ],
        );
        if let Some(&id) = self.mat_index.get(&key) {
            return Ok(id);
        }
        let base = match &self.mats.name {
            Some(n) => sanitize_material(&String::from_utf8_lossy(n)),
            None => "default".to_string(),
        };
        let name = self.mat_names.unique(&base);
        if let Some(k) = (0..3).find(|&k| diffuse[k] > 1.0) {
            let ch = ["red", "green", "blue"][k];
            self.warn.push(
                "reflectance",
                warning(
                    &f.name,
                    at,
                    format!(
                        "material '{name}' reflects more than it receives in {ch} ({}): a saturated colour with a high 'rd'",
                        diffuse[k]
                    ),
                ),
            );
        }
        let id = MaterialId(self.out_mats.len() as u32);
        self.out_mats.push(Material {
            name,
            def: MaterialDef::Defmat(Defmat {
                diffuse: Some(diffuse),
                emission: emission.iter().any(|&e| e > 0.0).then_some(emission),
                other: if m.two_sided {
                    vec![("sides".to_string(), vec!["2".to_string()])]
                } else {
                    Vec::new()
                },
            }),
        });
        self.mat_index.insert(key, id);
        Ok(id)
    }

    fn segments(&self) -> usize {
        self.opts.segments.max(3) as usize
    }

    /// Emits quads (or triangles where two corners coincide) of a grid of
    /// generated corners; `quads` lists corner indices counter-clockwise
    /// seen from outside.
    fn emit_cells(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        corners: &[Corner],
        cells: Vec<Vec<usize>>,
        inward: bool,
    ) -> Result<(), Diagnostic> {
        for mut cell in cells {
            cell.dedup();
            while cell.len() > 1 && cell.first() == cell.last() {
                cell.pop();
            }
            if cell.len() < 3 {
                continue;
            }
            if inward {
                cell[1..].reverse();
            }
            let c: Vec<Corner> = cell.iter().map(|&i| corners[i].clone()).collect();
            self.emit(f, at, vec![c])?;
        }
        Ok(())
    }

    fn sphere(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        base: &[u8],
        c: DVec3,
        r: f64,
    ) -> Result<(), Diagnostic> {
        let n = self.segments();
        let stacks = (n / 2).max(2);
        let rr = r.abs();
        let mut corners = Vec::new();
        let name = |k: usize| {
            let mut s = base.to_vec();
            s.extend_from_slice(format!(".{k}").as_bytes());
            s
        };
        corners.push(Corner {
            name: name(0),
            p: c + DVec3::Z * rr,
        });
        for i in 1..stacks {
            let (sp, cp) = (std::f64::consts::PI * i as f64 / stacks as f64).sin_cos();
            for j in 0..n {
                let (sl, cl) = (std::f64::consts::TAU * j as f64 / n as f64).sin_cos();
                corners.push(Corner {
                    name: name(corners.len()),
                    p: c + DVec3::new(sp * cl, sp * sl, cp) * rr,
                });
            }
        }
        let south = corners.len();
        corners.push(Corner {
            name: name(south),
            p: c - DVec3::Z * rr,
        });
        let at_ij = |i: usize, j: usize| -> usize {
            if i == 0 {
                0
            } else if i == stacks {
                south
            } else {
                1 + (i - 1) * n + j % n
            }
        };
        let mut cells = Vec::new();
        for i in 0..stacks {
            for j in 0..n {
                cells.push(vec![
                    at_ij(i, j),
                    at_ij(i + 1, j),
                    at_ij(i + 1, j + 1),
                    at_ij(i, j + 1),
                ]);
            }
        }
        self.emit_cells(f, at, &corners, cells, r < 0.0)
    }

    /// Cylinders and cones (open-ended), outward for positive radii.
    fn cone(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        a: (&[u8], DVec3, f64),
        b: (&[u8], DVec3, f64),
    ) -> Result<(), Diagnostic> {
        let n = self.segments();
        let axis = (b.1 - a.1).normalize();
        let (u, w) = perpendiculars(axis);
        let mut corners = Vec::new();
        let mut rings = Vec::new();
        for (base, p, r) in [a, b] {
            let start = corners.len();
            if r == 0.0 {
                corners.push(Corner {
                    name: base.to_vec(),
                    p,
                });
                rings.push(vec![start; n]);
                continue;
            }
            let mut ring = Vec::new();
            for k in 0..n {
                let (s, c) = (std::f64::consts::TAU * k as f64 / n as f64).sin_cos();
                let mut name = base.to_vec();
                name.extend_from_slice(format!(".{k}").as_bytes());
                ring.push(corners.len());
                corners.push(Corner {
                    name,
                    p: p + (u * c + w * s) * r.abs(),
                });
            }
            rings.push(ring);
        }
        let cells = (0..n)
            .map(|k| {
                let k1 = (k + 1) % n;
                vec![rings[0][k], rings[0][k1], rings[1][k1], rings[1][k]]
            })
            .collect();
        self.emit_cells(f, at, &corners, cells, a.2 < 0.0 || b.2 < 0.0)
    }

    fn ring(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        base: &[u8],
        c: MgfVertex,
        r0: f64,
        r1: f64,
    ) -> Result<(), Diagnostic> {
        let n = self.segments();
        let axis = c.n.normalize();
        let (u, w) = perpendiculars(axis);
        let mut corners = Vec::new();
        let circle = |corners: &mut Vec<Corner>, r: f64, tag: &str| -> Vec<usize> {
            if r == 0.0 {
                corners.push(Corner {
                    name: base.to_vec(),
                    p: c.p,
                });
                return vec![corners.len() - 1; n];
            }
            (0..n)
                .map(|k| {
                    let (s, co) = (std::f64::consts::TAU * k as f64 / n as f64).sin_cos();
                    let mut name = base.to_vec();
                    name.extend_from_slice(format!(".{tag}{k}").as_bytes());
                    corners.push(Corner {
                        name,
                        p: c.p + (u * co + w * s) * r,
                    });
                    corners.len() - 1
                })
                .collect()
        };
        let inner = circle(&mut corners, r0, "i");
        let outer = circle(&mut corners, r1, "o");
        let cells = (0..n)
            .map(|k| {
                let k1 = (k + 1) % n;
                vec![inner[k], outer[k], outer[k1], inner[k1]]
            })
            .collect();
        self.emit_cells(f, at, &corners, cells, false)
    }

    #[allow(clippy::too_many_arguments)]
    fn torus(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        base: &[u8],
        c: MgfVertex,
        r0: f64,
        r1: f64,
        inward: bool,
    ) -> Result<(), Diagnostic> {
        let n = self.segments();
        let axis = c.n.normalize();
        let (u, w) = perpendiculars(axis);
        let (major, minor) = ((r0 + r1) / 2.0, (r1 - r0) / 2.0);
        let mut corners = Vec::new();
        for j in 0..n {
            let (su, cu) = (std::f64::consts::TAU * j as f64 / n as f64).sin_cos();
            for k in 0..n {
                let (sv, cv) = (std::f64::consts::TAU * k as f64 / n as f64).sin_cos();
                let mut name = base.to_vec();
                name.extend_from_slice(format!(".{}", corners.len()).as_bytes());
                let radial = u * cu + w * su;
                corners.push(Corner {
                    name,
                    p: c.p + radial * (major + minor * cv) + axis * (minor * sv),
                });
            }
        }
        let at_jk = |j: usize, k: usize| (j % n) * n + k % n;
        let mut cells = Vec::new();
        for j in 0..n {
            for k in 0..n {
                cells.push(vec![
                    at_jk(j, k),
                    at_jk(j + 1, k),
                    at_jk(j + 1, k + 1),
                    at_jk(j, k + 1),
                ]);
            }
        }
        self.emit_cells(f, at, &corners, cells, inward)
    }

    /// A closed prism: the given end face points outward (inward for a
    /// negative length), extruded against its normal by `len`.
    fn prism(
        &mut self,
        f: &SrcFile,
        at: &OTok,
        base: Vec<Corner>,
        len: f64,
    ) -> Result<(), Diagnostic> {
        let pts: Vec<DVec3> = base.iter().map(|c| c.p).collect();
        let n = geom::newell_normal(&pts);
        if n.length_squared() == 0.0 || !n.is_finite() {
            return Err(f.err(at, "the prism's end face has no area"));
        }
        let d = -n.normalize() * len;
        let top: Vec<Corner> = base
            .iter()
            .map(|c| {
                let mut name = c.name.clone();
                name.extend_from_slice(b".e");
                Corner { name, p: c.p + d }
            })
            .collect();
        self.emit(f, at, vec![base.clone()])?;
        let mut other = top.clone();
        other.reverse();
        self.emit(f, at, vec![other])?;
        let k = base.len();
        for i in 0..k {
            let j = (i + 1) % k;
            self.emit(
                f,
                at,
                vec![vec![
                    base[i].clone(),
                    top[i].clone(),
                    top[j].clone(),
                    base[j].clone(),
                ]],
            )?;
        }
        Ok(())
    }
}

/// Two unit vectors u, w with u × w = axis (axis a unit vector).
fn perpendiculars(axis: DVec3) -> (DVec3, DVec3) {
    let helper = if axis.x.abs() < 0.9 {
        DVec3::X
    } else {
        DVec3::Y
    };
    let u = helper.cross(axis).normalize();
    let w = axis.cross(u);
    (u, w)
}

/// Splits a cyclic vertex sequence at its seams: an edge (a, b) that is also
/// walked as (b, a) is removed, leaving two loops. Repeats until no seam is
/// left. Loops are returned in a deterministic order.
pub fn split_seams(seq: Vec<usize>) -> Vec<Vec<usize>> {
    let mut work = vec![seq];
    let mut done = Vec::new();
    while let Some(s) = work.pop() {
        let n = s.len();
        let mut edges: FxHashMap<(usize, usize), usize> = FxHashMap::default();
        for i in 0..n {
            edges.entry((s[i], s[(i + 1) % n])).or_insert(i);
        }
        let mut found = None;
        for j in 0..n {
            if let Some(&i) = edges.get(&(s[(j + 1) % n], s[j]))
                && i != j
            {
                found = Some((i.min(j), i.max(j)));
                break;
            }
        }
        match found {
            Some((i, j)) => {
                let inner: Vec<usize> = s[i + 1..j].to_vec();
                let mut outer: Vec<usize> = s[j + 1..].to_vec();
                outer.extend_from_slice(&s[..i]);
                // Walk the outer loop first (it keeps the start of the face).
                work.push(inner);
                work.push(outer);
            }
            None => done.push(s),
        }
    }
    done
}

/// Splits a cyclic vertex sequence wherever it passes a vertex twice (a
/// pinch: `a b c d e c f` is the loops `c d e` and `c f a b`), until no loop
/// repeats a vertex. One loop without repeats is returned as it is.
pub fn split_pinches(seq: Vec<usize>) -> Vec<Vec<usize>> {
    let mut work = vec![seq];
    let mut done = Vec::new();
    while let Some(s) = work.pop() {
        let mut first: FxHashMap<usize, usize> = FxHashMap::default();
        let mut found = None;
        for (j, &v) in s.iter().enumerate() {
            if let Some(&i) = first.get(&v) {
                found = Some((i, j));
                break;
            }
            first.insert(v, j);
        }
        match found {
            Some((i, j)) => {
                let inner: Vec<usize> = s[i..j].to_vec();
                let mut outer: Vec<usize> = s[j..].to_vec();
                outer.extend_from_slice(&s[..i]);
                work.push(inner);
                work.push(outer);
            }
            None => done.push(s),
        }
    }
    done
}

/// Whether the loop `inner` lies inside the polygon `outer` (both in one
/// plane): judged at the midpoints of `inner`'s edges, by majority, so that
/// corners it shares with `outer` do not decide.
fn inside_loop(outer: &[DVec3], inner: &[DVec3]) -> bool {
    let n = geom::newell_normal(outer);
    let axis = if n.x.abs() >= n.y.abs() && n.x.abs() >= n.z.abs() {
        0
    } else if n.y.abs() >= n.z.abs() {
        1
    } else {
        2
    };
    let flat = |p: DVec3| match axis {
        0 => geom::DVec2::new(p.y, p.z),
        1 => geom::DVec2::new(p.z, p.x),
        _ => geom::DVec2::new(p.x, p.y),
    };
    let poly = [outer.iter().map(|&p| flat(p)).collect::<Vec<_>>()];
    let contains = |q| geom::locate_2d(q, &poly) == geom::Location::Inside;
    let k = inner.len();
    let votes = (0..k)
        .filter(|&i| contains(flat((inner[i] + inner[(i + 1) % k]) / 2.0)))
        .count();
    2 * votes > k
}

/// Converts MGF source, reading includes with `read` (relative to `dir`).
pub fn convert_with(
    src: &[u8],
    file: &str,
    dir: &Path,
    opts: &Options,
    read: &mut dyn FnMut(&Path) -> std::io::Result<Vec<u8>>,
) -> Result<Converted, Diagnostic> {
    let main = Rc::new(SrcFile::parse(src, file.to_string(), dir.to_path_buf())?);
    let mut conv = Conv {
        opts,
        read,
        files: FxHashMap::default(),
        includes: Vec::new(),
        colors: Contexts::default(),
        mats: Contexts::default(),
        verts: Contexts::default(),
        frames: Vec::new(),
        objects: Vec::new(),
        steps: 0,
        warn: Warnings::default(),
        warned: FxHashSet::default(),
        notes: Vec::new(),
        out_mats: Vec::new(),
        mat_index: FxHashMap::default(),
        mat_names: Namer::default(),
        out_verts: Vec::new(),
        vert_index: FxHashMap::default(),
        vert_names: Namer::default(),
        out_faces: Vec::new(),
        face_names: Namer::default(),
    };
    let n = main.lines.len();
    conv.exec(&main, 0..n)?;
    let mut model = Model::new();
    for m in conv.out_mats {
        model.add_material(m);
    }
    for v in conv.out_verts {
        model.add_vertex(v);
    }
    for f in conv.out_faces {
        model.add_face(f);
    }
    Ok(Converted {
        model,
        warnings: conv.warn.finish(),
        notes: conv.notes,
    })
}

/// Converts MGF source, reading includes from the file system.
pub fn convert(
    src: &[u8],
    file: &str,
    dir: &Path,
    opts: &Options,
) -> Result<Converted, Diagnostic> {
    convert_with(src, file, dir, opts, &mut |p| std::fs::read(p))
}

#[cfg(test)]
mod tests;
