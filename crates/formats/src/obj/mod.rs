//! obj2ug: Wavefront OBJ (with MTL material libraries) as a UniGrafix model.
//!
//! What is read (see docs/format.md, "Bridges"):
//!
//! * `v x y z [w | r g b]` (x, y, z; with [`Options::vertex_colours`] the
//!   colours `r g b` become per-vertex UG colours, one `c_rgb _radN` per
//!   distinct value as `ugrad` writes them), `f`/`fo` with `v`, `v/vt`,
//!   `v//vn`, `v/vt/vn` references, negative (relative) indices and n-gons,
//!   `l` polylines (as UG wires), `o`/`g` names (face names, sanitised to UG
//!   identifiers and made unique: `wall`, `wall.2`, …), `usemtl`, `mtllib`.
//! * MTL: `newmtl`, `Kd` (→ `diffuse_rgb`), `Ke` (→ `emission_rgb` when not zero).
//! * `vt`, `vn`, `vp`, `s` and other display attributes are ignored silently;
//!   free-form geometry (curves, surfaces) and unknown statements are ignored
//!   with one warning per keyword (errors with `--strict`).
//! * Faces: a vertex repeated consecutively is removed (warning); a face with
//!   fewer than 3 distinct vertices, or a vertex repeated elsewhere, is
//!   dropped with a warning.
//!
//! Output: materials (in order of first use, each a `defmat`), vertices in
//! order of first use named `v1`, `v2`, …, faces in file order, then wires.

use std::path::{Path, PathBuf};

use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Defmat, Diagnostic, Face, Item, Material, MaterialDef, Model, Pos, Vertex, VertexId};

pub mod names;
pub mod write;

pub use names::{Namer, sanitize, sanitize_material};

/// The diffuse reflectance of a material without `Kd` (or not found in any library).
pub const DEFAULT_KD: [f64; 3] = [0.8, 0.8, 0.8];

/// At most this many warnings of one kind are listed; the rest are counted.
pub const WARN_LIMIT: usize = 10;

/// Options of the conversion.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Unsupported and unknown statements are errors.
    pub strict: bool,
    /// Materials to mark as emitters: (OBJ or UG material name, emission).
    pub emit: Vec<(String, [f64; 3])>,
    /// `v x y z r g b` colours become per-vertex colours (radiosity, as
    /// `ug2obj --radiosity` writes them) instead of being ignored.
    pub vertex_colours: bool,
}

/// The converted model and the warnings for stderr.
#[derive(Debug)]
pub struct Converted {
    pub model: Model,
    pub warnings: Vec<String>,
    /// Faces dropped as degenerate.
    pub dropped: usize,
    /// Vertices with `r g b` colours that were ignored (without [`Options::vertex_colours`]).
    pub colours_ignored: usize,
}

/// Warnings, at most [`WARN_LIMIT`] per kind, the rest counted.
#[derive(Default, Debug)]
pub struct Warnings {
    list: Vec<String>,
    counts: FxHashMap<&'static str, usize>,
    order: Vec<&'static str>,
}

impl Warnings {
    /// Adds a warning of a kind (a short key).
    pub fn push(&mut self, kind: &'static str, msg: String) {
        let n = self.counts.entry(kind).or_insert(0);
        if *n == 0 {
            self.order.push(kind);
        }
        *n += 1;
        if *n <= WARN_LIMIT {
            self.list.push(msg);
        }
    }

    /// The messages, with a summary line for each kind that went over the limit.
    pub fn finish(self) -> Vec<String> {
        let mut out = self.list;
        for k in self.order {
            let n = self.counts[k];
            if n > WARN_LIMIT {
                out.push(format!(
                    "warning: {} more warnings like this ({k}) not shown",
                    n - WARN_LIMIT
                ));
            }
        }
        out
    }
}

/// A word of the input with its position (1-based line and column).
#[derive(Clone, Copy, Debug)]
pub struct Tok<'a> {
    pub text: &'a [u8],
    pub line: u32,
    pub col: u32,
}

impl Tok<'_> {
    pub fn str(&self) -> String {
        String::from_utf8_lossy(self.text).into_owned()
    }
}

/// Splits a source into logical lines of words: blanks separate words, a
/// backslash at the end of a line continues it, and a word beginning with
/// `#` starts a comment to the end of the line. A UTF-8 byte order mark is
/// skipped. Lines without words are left out.
pub fn tokenize(src: &[u8]) -> Vec<Vec<Tok<'_>>> {
    let src = src.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(src);
    let mut lines = Vec::new();
    let mut cur: Vec<Tok> = Vec::new();
    let (mut line, mut col) = (1u32, 1u32);
    let mut i = 0;
    let mut in_comment = false;
    let is_blank = |c: u8| matches!(c, b' ' | b'\t' | b'\r' | 0x0b | 0x0c);
    while i < src.len() {
        let c = src[i];
        // A carriage return not followed by a line feed ends a line too
        // (classic Mac OS line endings: read as blanks, a whole file was
        // one `v` statement whose extra words were ignored, and the model
        // came out empty).
        let lone_cr = c == b'\r' && src.get(i + 1) != Some(&b'\n');
        if c == b'\n' || lone_cr {
            // A backslash right before the newline (blanks allowed) continues the line.
            let continued = !in_comment
                && cur
                    .last()
                    .is_some_and(|t| t.text == b"\\" && t.line == line);
            if continued {
                cur.pop();
            } else {
                if !cur.is_empty() {
                    lines.push(std::mem::take(&mut cur));
                }
                in_comment = false;
            }
            line = line.saturating_add(1);
            col = 1;
            i += 1;
            continue;
        }
        if is_blank(c) || in_comment {
            i += 1;
            if c & 0xC0 != 0x80 {
                col = col.saturating_add(1);
            }
            continue;
        }
        if c == b'#' {
            in_comment = true;
            continue;
        }
        let start = i;
        let start_col = col;
        while i < src.len() && !is_blank(src[i]) && src[i] != b'\n' {
            if src[i] & 0xC0 != 0x80 {
                col = col.saturating_add(1);
            }
            i += 1;
        }
        let mut text = &src[start..i];
        // `word\` followed by the newline: the backslash is a continuation.
        if text.len() > 1
            && text.ends_with(b"\\")
            && src.get(i).is_none_or(|&c| c == b'\n' || c == b'\r')
        {
            text = &text[..text.len() - 1];
            cur.push(Tok {
                text,
                line,
                col: start_col,
            });
            cur.push(Tok {
                text: b"\\",
                line,
                col: col - 1,
            });
            continue;
        }
        cur.push(Tok {
            text,
            line,
            col: start_col,
        });
    }
    if cur.last().is_some_and(|t| t.text == b"\\") {
        cur.pop();
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// An error at a word.
pub fn err_at(file: &str, t: &Tok, msg: impl Into<String>) -> Diagnostic {
    Diagnostic::error(
        Pos {
            file: file.to_string(),
            line: t.line,
            col: t.col,
        },
        msg,
    )
}

/// A warning at a word, formatted.
pub fn warn_at(file: &str, t: &Tok, msg: impl Into<String>) -> String {
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

/// Quotes a word for a message (shortened, control characters escaped).
pub fn quote(t: &[u8]) -> String {
    let s = String::from_utf8_lossy(t);
    let mut out: String = s.chars().take(40).flat_map(char::escape_debug).collect();
    if s.chars().count() > 40 {
        out.push('…');
    }
    format!("'{out}'")
}

/// Reads a finite decimal number.
pub fn number(file: &str, t: &Tok, what: &str) -> Result<f64, Diagnostic> {
    let s = std::str::from_utf8(t.text).ok();
    match s.and_then(|s| s.parse::<f64>().ok()) {
        Some(v) if v.is_finite() => Ok(v),
        Some(_) => Err(err_at(
            file,
            t,
            format!("non-finite number {} (expected {what})", quote(t.text)),
        )),
        None => Err(err_at(
            file,
            t,
            format!("bad number {} (expected {what})", quote(t.text)),
        )),
    }
}

/// Reads one number per name in `what` after the keyword at `toks[0]`.
fn numbers(file: &str, toks: &[Tok], what: &[&str]) -> Result<Vec<f64>, Diagnostic> {
    let mut out = Vec::with_capacity(what.len());
    for (k, w) in what.iter().enumerate() {
        match toks.get(k + 1) {
            Some(t) => out.push(number(file, t, w)?),
            None => {
                let last = toks.last().unwrap_or(&toks[0]);
                let at = Tok {
                    text: b"",
                    line: last.line,
                    col: last.col.saturating_add(last.text.len() as u32),
                };
                return Err(err_at(
                    file,
                    &at,
                    format!(
                        "missing {} in '{}' statement",
                        w,
                        String::from_utf8_lossy(toks[0].text)
                    ),
                ));
            }
        }
    }
    Ok(out)
}

/// Statements of display and rendering attributes that are ignored silently.
const IGNORED: &[&str] = &[
    "vt",
    "vn",
    "vp",
    "s",
    "mg",
    "lod",
    "usemap",
    "maplib",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "bevel",
    "c_interp",
    "d_interp",
];

/// Free-form geometry and other statements that are not supported.
const UNSUPPORTED: &[&str] = &[
    "p", "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv",
    "sp", "end", "con", "call", "csh",
];

/// A material from an MTL file.
#[derive(Clone, Debug, Default)]
struct MtlMaterial {
    kd: Option<[f64; 3]>,
    ke: Option<[f64; 3]>,
}

/// A face or polyline as read: OBJ vertex indices (0-based), name, material.
struct RawItem<'a> {
    verts: Vec<usize>,
    name: Option<String>,
    material: Option<String>,
    at: Tok<'a>,
}

/// Parses an MTL library into `mats` (a later definition of a name replaces an earlier one).
fn parse_mtl(
    src: &[u8],
    file: &str,
    mats: &mut FxHashMap<String, MtlMaterial>,
    warn: &mut Warnings,
) -> Result<(), Diagnostic> {
    let mut current: Option<String> = None;
    for toks in tokenize(src) {
        let kw = toks[0].text;
        match kw {
            b"newmtl" => {
                let name = rest_name(&toks[1..]);
                let Some(name) = name else {
                    return Err(err_at(file, &toks[0], "'newmtl' without a name"));
                };
                mats.insert(name.clone(), MtlMaterial::default());
                current = Some(name);
            }
            b"Kd" | b"Ke" => {
                let what = if kw == b"Kd" { "Kd" } else { "Ke" };
                let Some(cur) = current.as_ref() else {
                    warn.push(
                        "mtl-no-material",
                        warn_at(
                            file,
                            &toks[0],
                            format!("'{what}' before any 'newmtl' ignored"),
                        ),
                    );
                    continue;
                };
                if toks
                    .get(1)
                    .is_some_and(|t| t.text == b"spectral" || t.text == b"xyz")
                {
                    warn.push(
                        "mtl-colour-form",
                        warn_at(
                            file,
                            &toks[1],
                            format!("'{what} {}' is not supported; ignored", toks[1].str()),
                        ),
                    );
                    continue;
                }
                let names = ["red component", "green component", "blue component"];
                let rgb = if toks.len() == 2 {
                    let v = number(file, &toks[1], names[0])?;
                    [v, v, v]
                } else {
                    let v = numbers(file, &toks, &names)?;
                    [v[0], v[1], v[2]]
                };
                let m = mats.entry(cur.clone()).or_default();
                if what == "Kd" {
                    m.kd = Some(rgb);
                } else {
                    if let Some(k) = rgb.iter().position(|&c| c < 0.0) {
                        return Err(err_at(
                            file,
                            &toks[1 + k.min(toks.len() - 2)],
                            "negative emission (Ke) component",
                        ));
                    }
                    m.ke = Some(rgb);
                }
            }
            _ => {} // Ka, Ks, Ns, d, illum, maps, …: not used
        }
    }
    Ok(())
}

/// The words after a keyword joined by single spaces (`None` when there are none).
fn rest_name(toks: &[Tok]) -> Option<String> {
    if toks.is_empty() {
        return None;
    }
    let words: Vec<String> = toks.iter().map(Tok::str).collect();
    Some(words.join(" "))
}

/// Reads one vertex reference of `f` or `l` (`v`, `v/vt`, `v//vn`, `v/vt/vn`),
/// resolving negative indices against the `n` vertices read so far.
fn vertex_ref(file: &str, t: &Tok, n: usize) -> Result<usize, Diagnostic> {
    let s = std::str::from_utf8(t.text).unwrap_or("");
    let mut parts = s.split('/');
    let vpart = parts.next().unwrap_or("");
    let parse = |p: &str| -> Result<i64, Diagnostic> {
        p.parse::<i64>()
            .map_err(|_| err_at(file, t, format!("bad vertex reference {}", quote(t.text))))
    };
    let i = parse(vpart)?;
    let mut count = 0;
    for p in parts {
        count += 1;
        if count > 2 || (!p.is_empty() && parse(p)? == 0) || (p.is_empty() && count == 2) {
            return Err(err_at(
                file,
                t,
                format!("bad vertex reference {}", quote(t.text)),
            ));
        }
    }
    let idx = if i > 0 {
        (i - 1) as u64
    } else if i < 0 {
        let back = i.unsigned_abs();
        if back > n as u64 {
            return Err(err_at(
                file,
                t,
                format!("vertex index {i} is out of range ({n} vertices defined so far)"),
            ));
        }
        n as u64 - back
    } else {
        return Err(err_at(file, t, "vertex index 0 (indices count from 1)"));
    };
    if idx >= n as u64 {
        return Err(err_at(
            file,
            t,
            format!("vertex index {i} is out of range ({n} vertices defined so far)"),
        ));
    }
    Ok(idx as usize)
}

/// Converts OBJ source to a UG model, reading MTL libraries with `read`
/// (paths relative to `dir`).
pub fn convert_with(
    src: &[u8],
    file: &str,
    dir: &Path,
    opts: &Options,
    read: &mut dyn FnMut(&Path) -> std::io::Result<Vec<u8>>,
) -> Result<Converted, Diagnostic> {
    let mut warn = Warnings::default();
    let mut warned_kw: FxHashSet<String> = FxHashSet::default();
    let mut positions: Vec<glam::DVec3> = Vec::new();
    let mut colours: Vec<Option<[f64; 3]>> = Vec::new();
    let mut colours_ignored = 0usize;
    let mut faces: Vec<RawItem> = Vec::new();
    let mut wires: Vec<RawItem> = Vec::new();
    let mut mtl: FxHashMap<String, MtlMaterial> = FxHashMap::default();
    let mut object: Option<String> = None;
    let mut group: Option<String> = None;
    let mut material: Option<String> = None;
    let mut dropped = 0usize;
    let lines = tokenize(src);
    for toks in &lines {
        let kw = toks[0].text;
        match kw {
            b"v" => {
                let c = numbers(
                    file,
                    toks,
                    &["x coordinate", "y coordinate", "z coordinate"],
                )?;
                positions.push(glam::DVec3::new(c[0], c[1], c[2]));
                // `v x y z r g b`: exactly six numbers.
                let rgb = if toks.len() == 7 && opts.vertex_colours {
                    let names = ["red component", "green component", "blue component"];
                    let mut rgb = [0.0; 3];
                    for (k, w) in names.iter().enumerate() {
                        rgb[k] = number(file, &toks[4 + k], w)?;
                    }
                    Some(rgb)
                } else {
                    colours_ignored += usize::from(toks.len() == 7);
                    None
                };
                colours.push(rgb);
                // Whatever else follows (a weight, a colour) must be
                // numbers: a word that is not is an error, not ignored.
                for t in toks.iter().skip(4) {
                    number(file, t, "a number (a weight or colour component)")?;
                }
            }
            b"f" | b"fo" | b"l" => {
                let mut verts = Vec::with_capacity(toks.len() - 1);
                for t in &toks[1..] {
                    verts.push(vertex_ref(file, t, positions.len())?);
                }
                let is_face = kw != b"l";
                let min = if is_face { 3 } else { 2 };
                let what = if is_face { "face" } else { "line" };
                // Consecutive repeats (cyclically for faces) are removed.
                let before = verts.len();
                verts.dedup();
                if is_face {
                    while verts.len() > 1 && verts.first() == verts.last() {
                        verts.pop();
                    }
                }
                if verts.len() < min {
                    warn.push(
                        "degenerate",
                        warn_at(
                            file,
                            &toks[0],
                            format!("{what} with fewer than {min} distinct vertices dropped"),
                        ),
                    );
                    dropped += 1;
                    continue;
                }
                if is_face {
                    let mut seen = FxHashSet::default();
                    if !verts.iter().all(|v| seen.insert(*v)) {
                        warn.push(
                            "degenerate",
                            warn_at(file, &toks[0], "face with a repeated vertex dropped"),
                        );
                        dropped += 1;
                        continue;
                    }
                }
                if verts.len() != before {
                    warn.push(
                        "repeated",
                        warn_at(
                            file,
                            &toks[0],
                            format!("{what}: consecutive repeated vertex removed"),
                        ),
                    );
                }
                let item = RawItem {
                    verts,
                    name: group.clone().or_else(|| object.clone()),
                    material: material.clone(),
                    at: toks[0],
                };
                if is_face {
                    faces.push(item);
                } else {
                    wires.push(item);
                }
            }
            b"o" => {
                object = rest_name(&toks[1..]);
                group = None;
            }
            b"g" => group = rest_name(&toks[1..]),
            b"usemtl" => material = rest_name(&toks[1..]),
            b"mtllib" => {
                // File names are separated by blanks; a name with blanks is
                // accepted when the whole rest of the line names a file.
                let whole = rest_name(&toks[1..]).unwrap_or_default();
                let single: Vec<(String, &Tok)> = if toks.len() > 2 && dir.join(&whole).is_file() {
                    vec![(whole, &toks[1])]
                } else {
                    toks[1..].iter().map(|t| (t.str(), t)).collect()
                };
                for (name, t) in single {
                    let path: PathBuf = dir.join(&name);
                    // A library left behind by the exporter is common: its
                    // materials then get the default grey, with a warning
                    // (an error with --strict).
                    let bytes = match read(&path) {
                        Ok(b) => b,
                        Err(e) => {
                            let msg = format!(
                                "cannot read material library {}: {e}",
                                quote(name.as_bytes())
                            );
                            if opts.strict {
                                return Err(err_at(file, t, msg));
                            }
                            warn.push(
                                "mtllib",
                                warn_at(file, t, format!("{msg}; its materials get diffuse 0.8")),
                            );
                            continue;
                        }
                    };
                    parse_mtl(&bytes, &path.display().to_string(), &mut mtl, &mut warn)?;
                }
            }
            _ => {
                let k = String::from_utf8_lossy(kw).into_owned();
                if IGNORED.contains(&k.as_str()) {
                    continue;
                }
                let supported = UNSUPPORTED.contains(&k.as_str());
                let msg = if supported {
                    format!("unsupported statement {} ignored", quote(kw))
                } else {
                    format!("unknown statement {} ignored", quote(kw))
                };
                if opts.strict {
                    return Err(err_at(file, &toks[0], msg.replace(" ignored", "")));
                }
                if warned_kw.insert(k) {
                    warn.push("statement", warn_at(file, &toks[0], msg));
                }
            }
        }
    }

    // Materials in order of first use.
    let mut model = Model::new();
    let mut mat_ids: FxHashMap<Option<String>, Option<ug::MaterialId>> = FxHashMap::default();
    let mut mat_names = Namer::default();
    let mut emit_used = vec![false; opts.emit.len()];
    mat_ids.insert(None, None);
    for item in faces.iter().chain(wires.iter()) {
        let Some(raw) = &item.material else { continue };
        if mat_ids.contains_key(&item.material) {
            continue;
        }
        let name = mat_names.unique(&sanitize_material(raw));
        let found = mtl.get(raw);
        if found.is_none() {
            warn.push(
                "material",
                warn_at(
                    file,
                    &item.at,
                    format!(
                        "material {} is not defined in any material library; using diffuse 0.8",
                        quote(raw.as_bytes())
                    ),
                ),
            );
        }
        let mut emission = found
            .and_then(|m| m.ke)
            .filter(|e| e.iter().any(|&c| c > 0.0));
        for (k, (n, e)) in opts.emit.iter().enumerate() {
            if n == raw || *n == name {
                emission = Some(*e);
                emit_used[k] = true;
            }
        }
        let def = Defmat {
            diffuse: Some(found.and_then(|m| m.kd).unwrap_or(DEFAULT_KD)),
            emission,
            other: Vec::new(),
        };
        let id = model.add_material(Material {
            name,
            def: MaterialDef::Defmat(def),
        });
        mat_ids.insert(item.material.clone(), Some(id));
    }
    for (k, (n, _)) in opts.emit.iter().enumerate() {
        if !emit_used[k] {
            warn.push(
                "emit",
                format!("warning: --emit: no face uses a material named '{n}'"),
            );
        }
    }
    // Vertices in order of first use.
    let mut order: Vec<usize> = Vec::new();
    let mut used = vec![false; positions.len()];
    for item in faces.iter().chain(wires.iter()) {
        for &v in &item.verts {
            if !used[v] {
                used[v] = true;
                order.push(v);
            }
        }
    }
    // Vertex colours: one `c_rgb _radN` per distinct value, in vertex order,
    // before the first vertex (as ugrad writes them; names taken skipped).
    let mut colour_ids: FxHashMap<[u64; 3], ug::MaterialId> = FxHashMap::default();
    let mut vcolour: Vec<Option<ug::MaterialId>> = vec![None; positions.len()];
    if opts.vertex_colours {
        let taken: FxHashSet<String> = model.materials.iter().map(|m| m.name.clone()).collect();
        let mut counter = 0usize;
        for &v in &order {
            let Some(rgb) = colours[v] else { continue };
            let key = rgb.map(|x| (x + 0.0).to_bits());
            let id = *colour_ids.entry(key).or_insert_with(|| {
                let name = loop {
                    let cand = format!("_rad{counter}");
                    counter += 1;
                    if !taken.contains(&cand) {
                        break cand;
                    }
                };
                model.add_material(Material {
                    name,
                    def: MaterialDef::Rgb(rgb.map(|x| x + 0.0)),
                })
            });
            vcolour[v] = Some(id);
        }
        if colour_ids.is_empty() {
            warn.push(
                "colours",
                "warning: --vertex-colours: no vertex has colours ('v x y z r g b')".to_string(),
            );
        }
    }
    let mut vid: Vec<Option<VertexId>> = vec![None; positions.len()];
    for &v in &order {
        let n = model.vertices.len() + 1;
        vid[v] = Some(model.add_vertex(Vertex {
            name: format!("v{n}"),
            pos: positions[v],
            color: vcolour[v],
        }));
    }
    let ids =
        |item: &RawItem| -> Vec<VertexId> { item.verts.iter().filter_map(|&v| vid[v]).collect() };
    let mut names = Namer::default();
    for item in &faces {
        let contour = ids(item);
        let name = item.name.as_deref().map(|n| names.unique(&sanitize(n)));
        model.add_face(Face {
            name,
            contours: vec![contour],
            material: mat_ids.get(&item.material).copied().flatten(),
        });
    }
    for item in &wires {
        let polyline = ids(item);
        let name = item.name.as_deref().map(|n| names.unique(&sanitize(n)));
        let id = ug::WireId(model.wires.len() as u32);
        model.wires.push(ug::Wire {
            name,
            polylines: vec![polyline],
            material: mat_ids.get(&item.material).copied().flatten(),
        });
        model.items.push(Item::Wire(id));
    }
    Ok(Converted {
        model,
        warnings: warn.finish(),
        dropped,
        colours_ignored,
    })
}

/// Converts OBJ source, reading MTL libraries from the file system.
pub fn convert(
    src: &[u8],
    file: &str,
    dir: &Path,
    opts: &Options,
) -> Result<Converted, Diagnostic> {
    convert_with(src, file, dir, opts, &mut |p| std::fs::read(p))
}

/// Parses an `--emit NAME=r,g,b` value.
pub fn parse_emit(s: &str) -> Result<(String, [f64; 3]), String> {
    let (name, rgb) = s
        .rsplit_once('=')
        .ok_or_else(|| format!("'{s}' is not NAME=r,g,b"))?;
    if name.is_empty() {
        return Err(format!("'{s}': empty material name"));
    }
    let v: Vec<f64> = rgb
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{rgb}' is not r,g,b"))?;
    let rgb = match v.as_slice() {
        [x] => [*x; 3],
        [r, g, b] => [*r, *g, *b],
        _ => return Err(format!("'{rgb}' is not r,g,b")),
    };
    if rgb.iter().any(|c| !c.is_finite() || *c < 0.0) {
        return Err(format!("'{s}': emission must be finite and non-negative"));
    }
    Ok((name.to_string(), rgb))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn conv(src: &str) -> Result<Converted, Diagnostic> {
        conv_with(src, &[], &Options::default())
    }

    fn conv_with(
        src: &str,
        files: &[(&str, &str)],
        opts: &Options,
    ) -> Result<Converted, Diagnostic> {
        let files: Vec<(PathBuf, Vec<u8>)> = files
            .iter()
            .map(|(n, t)| (Path::new("d").join(n), t.as_bytes().to_vec()))
            .collect();
        convert_with(src.as_bytes(), "t.obj", Path::new("d"), opts, &mut |p| {
            files
                .iter()
                .find(|(n, _)| n == p)
                .map(|(_, t)| t.clone())
                .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "not found"))
        })
    }

    fn ug_text(c: &Converted) -> String {
        ug::write_string(&c.model)
    }

    #[test]
    fn square_with_all_reference_forms() {
        let c = conv(
            "# a square\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
             f 1 2/1 3//1 4/1/1\n",
        )
        .unwrap();
        assert_eq!(
            ug_text(&c),
            "v v1 0 0 0;\nv v2 1 0 0;\nv v3 1 1 0;\nv v4 0 1 0;\nf (v1 v2 v3 v4);\n"
        );
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    }

    #[test]
    fn negative_indices_and_ngons() {
        let c = conv("v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf -5 -4 -3 -2 -1\n").unwrap();
        let f = &c.model.faces[0];
        assert_eq!(f.contours[0].len(), 5);
        assert_eq!(c.model.vertex(f.contours[0][0]).pos.x, 0.0);
        assert_eq!(c.model.vertex(f.contours[0][4]).pos.x, -1.0);
    }

    #[test]
    fn groups_objects_and_unique_names() {
        let c = conv(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\no box\nf 1 2 3\ng wall side\nf 1 2 3\nf 1 2 3\n\
             g wall_side\nf 1 2 3\no\nf 1 2 3\ng bad(name);x\nf 1 2 3\n",
        )
        .unwrap();
        let names: Vec<Option<&str>> = c.model.faces.iter().map(|f| f.name.as_deref()).collect();
        assert_eq!(
            names,
            [
                Some("box"),
                Some("wall_side"),
                Some("wall_side.2"),
                Some("wall_side.3"),
                None,
                Some("bad_name__x")
            ]
        );
    }

    #[test]
    fn materials_from_mtl_and_emit() {
        let mtl = "newmtl white\nKd 0.8 0.7 0.6\nKe 0 0 0\nnewmtl light\nKd 0.5\nKe 10 10 10\n\
                   newmtl 1st mat\nKd 0.1 0.2 0.3\n";
        let src = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl light\nf 1 2 3\n\
                   usemtl white\nf 1 3 2\nusemtl 1st mat\nf 1 2 3\nusemtl\nf 3 2 1\n";
        let c = conv_with(src, &[("m.mtl", mtl)], &Options::default()).unwrap();
        let t = ug_text(&c);
        assert!(
            t.starts_with(
                "defmat light;\n  diffuse_rgb 0.5 0.5 0.5;\n  emission_rgb 10 10 10;\nend;\n\
                 defmat white;\n  diffuse_rgb 0.8 0.7 0.6;\nend;\n\
                 defmat m_1st_mat;\n  diffuse_rgb 0.1 0.2 0.3;\nend;\n"
            ),
            "{t}"
        );
        assert!(
            t.ends_with("f (v1 v3 v2) white;\nf (v1 v2 v3) m_1st_mat;\nf (v3 v2 v1);\n"),
            "{t}"
        );
        let opts = Options {
            emit: vec![
                ("white".into(), [1.0, 2.0, 3.0]),
                ("nothing".into(), [1.0; 3]),
            ],
            ..Default::default()
        };
        let c = conv_with(src, &[("m.mtl", mtl)], &opts).unwrap();
        assert!(
            ug_text(&c)
                .contains("defmat white;\n  diffuse_rgb 0.8 0.7 0.6;\n  emission_rgb 1 2 3;\nend;")
        );
        assert!(
            c.warnings.iter().any(|w| w.contains("'nothing'")),
            "{:?}",
            c.warnings
        );
    }

    #[test]
    fn missing_material_warns_and_uses_default() {
        let c = conv("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl ghost\nf 1 2 3\n").unwrap();
        assert!(ug_text(&c).contains("diffuse_rgb 0.8 0.8 0.8"));
        assert!(
            c.warnings[0].starts_with("t.obj:5:1: warning: material 'ghost'"),
            "{:?}",
            c.warnings
        );
    }

    #[test]
    fn degenerate_faces_are_dropped() {
        let c = conv(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 2\nf 1 2 3 1\nf 1 2 1 3\nf 1 2 2 3\nf 1\nl 1 1\n",
        )
        .unwrap();
        // `f 1 2 3 1` and `f 1 2 2 3` are triangles after removing the repeat.
        assert_eq!(c.model.faces.len(), 2);
        assert_eq!(c.dropped, 4);
        assert_eq!(c.model.wires.len(), 0);
        assert!(
            c.warnings
                .iter()
                .any(|w| w.contains("t.obj:5:1: warning: face with fewer than 3"))
        );
        assert!(
            c.warnings
                .iter()
                .any(|w| w.contains("t.obj:7:1: warning: face with a repeated vertex dropped"))
        );
    }

    /// Classic Mac OS line endings (a lone CR) end lines as LF and CRLF
    /// do: read as blanks, the whole file was one `v` statement whose
    /// other words were ignored, an empty model.
    #[test]
    fn lone_carriage_returns_end_lines() {
        let c = conv("v 0 0 0\rv 1 0 0\r\nv 0 1 0\rf 1 2 3\r").unwrap();
        assert_eq!(c.model.vertices.len(), 3);
        assert_eq!(c.model.faces.len(), 1);
        let e = conv("v 0 0 0\rv 1 0 x\r").unwrap_err().to_string();
        assert_eq!(
            e,
            "t.obj:2:7: error: bad number 'x' (expected z coordinate)"
        );
    }

    /// A word after a vertex's coordinates that is not a number is an
    /// error, not ignored (weights and colours are numbers).
    #[test]
    fn words_after_coordinates_are_numbers() {
        assert!(conv("v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\n").is_ok());
        let e = conv("v 0 0 0 garbage\n").unwrap_err().to_string();
        assert!(
            e.starts_with("t.obj:1:9: error: bad number 'garbage'"),
            "{e}"
        );
    }

    #[test]
    fn errors_have_positions() {
        let e = |s: &str| conv(s).unwrap_err().to_string();
        assert_eq!(
            e("v 0 0 0\nf 1 2 3\n"),
            "t.obj:2:5: error: vertex index 2 is out of range (1 vertices defined so far)"
        );
        assert_eq!(
            e("v 0 0\n"),
            "t.obj:1:6: error: missing z coordinate in 'v' statement"
        );
        assert_eq!(
            e("v 0 x 0\n"),
            "t.obj:1:5: error: bad number 'x' (expected y coordinate)"
        );
        assert_eq!(
            e("v 0 nan 0\n"),
            "t.obj:1:5: error: non-finite number 'nan' (expected y coordinate)"
        );
        assert_eq!(
            e("v 0 0 0\nf 0 1 1\n"),
            "t.obj:2:3: error: vertex index 0 (indices count from 1)"
        );
        assert_eq!(
            e("v 0 0 0\nf -2 1 1\n"),
            "t.obj:2:3: error: vertex index -2 is out of range (1 vertices defined so far)"
        );
        assert_eq!(
            e("v 0 0 0\nf 1/x 1 1\n"),
            "t.obj:2:3: error: bad vertex reference '1/x'"
        );
        // A missing library: a warning, its materials grey; an error with --strict.
        let c = conv("mtllib  nope.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n").unwrap();
        assert_eq!(
            c.warnings[0],
            "t.obj:1:9: warning: cannot read material library 'nope.mtl': not found; its materials get diffuse 0.8"
        );
        assert!(
            ug_text(&c).contains("diffuse_rgb 0.8 0.8 0.8;"),
            "{}",
            ug_text(&c)
        );
        let strict = Options {
            strict: true,
            ..Default::default()
        };
        assert_eq!(
            conv_with("mtllib  nope.mtl\n", &[], &strict)
                .unwrap_err()
                .to_string(),
            "t.obj:1:9: error: cannot read material library 'nope.mtl': not found"
        );
        let c = conv_with(
            "mtllib m.mtl\n",
            &[("m.mtl", "newmtl a\nKd 1 x 1\n")],
            &Options::default(),
        );
        assert_eq!(
            c.unwrap_err().to_string(),
            "d/m.mtl:2:6: error: bad number 'x' (expected green component)"
        );
    }

    #[test]
    fn unsupported_statements_warn_once_or_fail_strictly() {
        let src = "v 0 0 0\ncstype bspline\ncurv 0 1 1 1\ncurv 0 1 1 1\nfrob 1\ns 1\n";
        let c = conv(src).unwrap();
        assert_eq!(c.warnings.len(), 3, "{:?}", c.warnings);
        let strict = Options {
            strict: true,
            ..Default::default()
        };
        let e = conv_with(src, &[], &strict).unwrap_err().to_string();
        assert_eq!(e, "t.obj:2:1: error: unsupported statement 'cstype'");
    }

    #[test]
    fn continuation_lines_and_comments() {
        let c = conv("v 0 0 0 # origin\nv 1 \\\n 0 0\nv 0 1 0\nf 1 2 \\\n3\n").unwrap();
        assert_eq!(c.model.faces.len(), 1);
        assert_eq!(c.model.vertices[1].pos.x, 1.0);
    }

    #[test]
    fn vertex_colours_on_request() {
        let src = "mtllib m.mtl\nv 0 0 0 0.5 0.25 0.125\nv 1 0 0 3.141592653589793 0 0\n\
                   v 0 1 0 0.5 0.25 0.125\nv 1 1 1\nusemtl _rad0\nf 1 2 3\nf 2 4 3\n";
        let files = [("m.mtl", "newmtl _rad0\nKd 0.5 0.5 0.5\n")];
        let plain = conv_with(src, &files, &Options::default()).unwrap();
        assert_eq!(plain.colours_ignored, 3);
        assert!(plain.model.vertices.iter().all(|v| v.color.is_none()));
        let opts = Options {
            vertex_colours: true,
            ..Default::default()
        };
        let c = conv_with(src, &files, &opts).unwrap();
        assert_eq!(c.colours_ignored, 0);
        assert_eq!(
            ug_text(&c),
            "defmat _rad0;\n  diffuse_rgb 0.5 0.5 0.5;\nend;\n\
             c_rgb _rad1 0.5 0.25 0.125;\nc_rgb _rad2 3.141592653589793 0 0;\n\
             v v1 0 0 0 _rad1;\nv v2 1 0 0 _rad2;\nv v3 0 1 0 _rad1;\nv v4 1 1 1;\n\
             f (v1 v2 v3) _rad0;\nf (v2 v4 v3) _rad0;\n"
        );
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        let e = conv_with("v 0 0 0 1 x 1\n", &[], &opts).unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.obj:1:11: error: bad number 'x' (expected green component)"
        );
        let none = conv_with("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", &[], &opts).unwrap();
        assert_eq!(none.warnings.len(), 1, "{:?}", none.warnings);
    }

    #[test]
    fn emit_values() {
        assert_eq!(
            parse_emit("lamp=1,2,3"),
            Ok(("lamp".into(), [1.0, 2.0, 3.0]))
        );
        assert_eq!(parse_emit("a=b=5"), Ok(("a=b".into(), [5.0; 3])));
        assert!(parse_emit("lamp").is_err());
        assert!(parse_emit("lamp=1,2").is_err());
        assert!(parse_emit("lamp=-1,2,3").is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = convert_with(&bytes, "r.obj", Path::new("."), &Options::default(), &mut |_| Err(std::io::Error::other("no")));
        }

        #[test]
        fn random_statements_never_panic(lines in proptest::collection::vec(
            prop_oneof![
                Just("v 0 0 0".to_string()),
                Just("v 1 0 0".to_string()),
                Just("v 1 1 1".to_string()),
                (-4i32..6, -4i32..6, -4i32..6).prop_map(|(a, b, c)| format!("f {a} {b}/1 {c}//2")),
                (-4i32..6, -4i32..6).prop_map(|(a, b)| format!("l {a} {b}")),
                Just("g a".to_string()),
                Just("o".to_string()),
                Just("usemtl x".to_string()),
                Just("curv 1".to_string()),
                Just("\\".to_string()),
            ], 0..30)) {
            let src = lines.join("\n");
            if let Ok(c) = convert_with(src.as_bytes(), "r.obj", Path::new("."), &Options::default(), &mut |_| Err(std::io::Error::other("no"))) {
                // The output is valid UG.
                let text = ug::write_string(&c.model);
                prop_assert!(ug::parse(text.as_bytes(), "<out>").is_ok(), "{}", text);
            }
        }
    }
}
