//! The UniGrafix parser: a hand-written recursive descent over [`Lexer`] tokens.
//!
//! It stops at the first error and reports it with file, line and column.
//! Nothing in it panics on any input (fuzzed: `fuzz/fuzz_targets/parse.rs`).

use std::hash::BuildHasher;
use std::path::{Path, PathBuf};

use glam::DVec3;
use hashbrown::HashTable;
use rustc_hash::FxBuildHasher;

use crate::error::{Diagnostic, Pos, quote};
use crate::lexer::{Kind, Lexer, Token};
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
}

/// A parsed model and the warnings met on the way.
#[derive(Debug)]
pub struct Parsed {
    pub model: Model,
    pub warnings: Vec<Diagnostic>,
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
    let mut p = Parser {
        model: Model::default(),
        opts,
        warnings: Vec::new(),
        materials: NameTable::default(),
        defs: NameTable::default(),
        pending_materials: Vec::new(),
        include_stack: Vec::new(),
        dir: dir.map(Path::to_path_buf).unwrap_or_default(),
    };
    let mut scope = Scope::default();
    let mut items = Vec::new();
    let mut toks = Toks::new(Lexer::new(src, file));
    p.statements(&mut toks, &mut scope, &mut items, None)?;
    p.finish_scope(scope, &items)?;
    p.resolve_materials()?;
    p.model.items = items;
    Ok(Parsed {
        model: p.model,
        warnings: p.warnings,
    })
}

/// Reads and parses a file; its includes resolve relative to its directory.
pub fn parse_file(path: &Path, opts: &ParseOptions) -> Result<Parsed, Diagnostic> {
    let src = std::fs::read(path)
        .map_err(|e| Diagnostic::plain(format!("cannot read '{}': {e}", path.display())))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_with(&src, &path.display().to_string(), Some(&dir), opts)
}

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

/// A name → id table that stores only ids; names are read back from the model.
#[derive(Default)]
struct NameTable {
    table: HashTable<u32>,
}

impl NameTable {
    fn hash(name: &[u8]) -> u64 {
        FxBuildHasher.hash_one(name)
    }
    fn find<'m>(&self, name: &[u8], names: impl Fn(u32) -> &'m str) -> Option<u32> {
        self.table
            .find(Self::hash(name), |&id| names(id).as_bytes() == name)
            .copied()
    }
    /// Inserts; returns false when the name is taken.
    fn insert<'m>(&mut self, name: &[u8], id: u32, names: impl Fn(u32) -> &'m str) -> bool {
        let h = Self::hash(name);
        match self.table.entry(
            h,
            |&k| names(k).as_bytes() == name,
            |&k| Self::hash(names(k).as_bytes()),
        ) {
            hashbrown::hash_table::Entry::Occupied(_) => false,
            hashbrown::hash_table::Entry::Vacant(v) => {
                v.insert(id);
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
    /// The one handed out before `prev`.
    before: Option<Token<'a>>,
}

impl<'a> Toks<'a> {
    fn new(lx: Lexer<'a>) -> Self {
        Toks {
            lx,
            peeked: None,
            prev: None,
            before: None,
        }
    }
    /// Next token, comments included.
    fn next_raw(&mut self) -> Result<Token<'a>, Diagnostic> {
        match self.peeked.take() {
            Some(t) => Ok(t),
            None => self.lx.next_token(),
        }
    }
    /// Next token that is not a comment (comments inside statements are dropped).
    fn next(&mut self) -> Result<Token<'a>, Diagnostic> {
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
    fn note(&mut self, t: Token<'a>) {
        self.before = self.prev;
        self.prev = Some(t);
    }
    fn peek(&mut self) -> Result<Token<'a>, Diagnostic> {
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
    fn err(&self, t: &Token<'_>, msg: impl Into<String>) -> Diagnostic {
        Diagnostic::error(self.pos(t), msg)
    }
    /// Error for a token that should have been `;`: placed right after the previous token.
    fn missing_semi(&self, found: &Token<'_>, stmt: &str) -> Diagnostic {
        let pos = match &self.prev {
            Some(p) if p.start < found.start => self.lx.pos_after(p),
            _ => self.pos(found),
        };
        Diagnostic::error(
            pos,
            format!(
                "expected ';' to end the {stmt} statement, found {}",
                Lexer::describe(found)
            ),
        )
    }
    fn expect_semi(&mut self, stmt: &str) -> Result<(), Diagnostic> {
        let t = self.peek()?;
        if t.kind == Kind::Semi {
            self.next()?;
            Ok(())
        } else {
            Err(self.missing_semi(&t, stmt))
        }
    }
    fn number(&mut self, what: &str) -> Result<f64, Diagnostic> {
        let t = self.next()?;
        if t.kind != Kind::Word {
            return Err(self.err(
                &t,
                format!("expected {what}, found {}", Lexer::describe(&t)),
            ));
        }
        parse_number(&t).map_err(|m| self.err(&t, format!("{m} (expected {what})")))
    }
    fn name(&mut self, what: &str) -> Result<Token<'a>, Diagnostic> {
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

fn parse_number(t: &Token<'_>) -> Result<f64, String> {
    let s = std::str::from_utf8(t.text).map_err(|_| format!("bad number {}", quote(t.text)))?;
    // Rust accepts "inf", "NaN" and "infinity"; UniGrafix numbers are finite decimals.
    let first = s.as_bytes().first().copied().unwrap_or(b' ');
    let looks_numeric = first.is_ascii_digit() || matches!(first, b'-' | b'+' | b'.');
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && looks_numeric => Ok(v),
        Ok(_) => Err(format!("non-finite number {}", quote(t.text))),
        Err(_) => Err(format!("bad number {}", quote(t.text))),
    }
}

fn lossy(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

struct Parser<'o> {
    model: Model,
    opts: &'o ParseOptions,
    warnings: Vec<Diagnostic>,
    materials: NameTable,
    defs: NameTable,
    pending_materials: Vec<PendingMaterial>,
    include_stack: Vec<PathBuf>,
    dir: PathBuf,
}

impl Parser<'_> {
    /// Parses statements until end of file, or until `end;` when inside a def.
    fn statements(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
        def: Option<(&str, &Pos)>,
    ) -> Result<(), Diagnostic> {
        loop {
            let tok = t.next_raw()?;
            match tok.kind {
                Kind::Eof => {
                    return match def {
                        Some((name, pos)) => Err(t.err(
                            &tok,
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
                    if t.peek()?.kind == Kind::Semi {
                        t.next()?;
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
                        b"v" => self.vertex(t, scope, items)?,
                        b"f" => self.face_or_wire(t, scope, items, false)?,
                        b"w" => self.face_or_wire(t, scope, items, true)?,
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
    fn raw(&mut self, t: &mut Toks<'_>, keyword: &str) -> Result<Raw, Diagnostic> {
        let mut text = String::new();
        let mut depth = 0usize;
        let mut opens: Vec<Token<'_>> = Vec::new();
        loop {
            let tok = t.next()?;
            match tok.kind {
                Kind::Semi if depth == 0 => break,
                Kind::Eof => {
                    return Err(match opens.last() {
                        Some(o) => t.err(o, "unbalanced '(': never closed"),
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
                        "unbalanced '(': not closed before ';'",
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
    ) -> Result<(), Diagnostic> {
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

    fn rgb(t: &mut Toks<'_>, what: &str) -> Result<[f64; 3], Diagnostic> {
        Ok([
            t.number(&format!("{what} red"))?,
            t.number(&format!("{what} green"))?,
            t.number(&format!("{what} blue"))?,
        ])
    }

    fn c_rgb(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> Result<(), Diagnostic> {
        let name = t.name("material name")?;
        let rgb = Self::rgb(t, "c_rgb")?;
        t.expect_semi("c_rgb")?;
        self.new_material(t, &name, MaterialDef::Rgb(rgb), items)
    }

    fn c_lhs(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> Result<(), Diagnostic> {
        let name = t.name("colour name")?;
        let mut vals = vec![t.number("lightness")?];
        while t.peek()?.kind == Kind::Word && vals.len() < 4 {
            let what = ["hue", "saturation", "translucency"][vals.len() - 1];
            vals.push(t.number(what)?);
        }
        t.expect_semi("c")?;
        self.new_material(t, &name, MaterialDef::Lhs(vals), items)
    }

    fn defmat(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> Result<(), Diagnostic> {
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
                    let rgb = Self::rgb(t, &what)?;
                    if what == "diffuse_rgb" {
                        d.diffuse = Some(rgb);
                    } else {
                        if rgb.iter().any(|&c| c < 0.0) {
                            return Err(t.err(&key, "emission_rgb must not be negative"));
                        }
                        d.emission = Some(rgb);
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
                        let w = t.next()?;
                        match w.kind {
                            Kind::Semi => break,
                            Kind::Word => words.push(lossy(w.text)),
                            _ => return Err(t.missing_semi(&w, "material property")),
                        }
                    }
                    d.other.push((lossy(key.text), words));
                }
                Kind::Semi => {}
                Kind::Eof => {
                    return Err(t.err(
                        &key,
                        format!(
                            "end of file inside 'defmat {}': missing 'end;'",
                            lossy(name.text)
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
    fn trailing_color(
        &mut self,
        t: &mut Toks<'_>,
        stmt: &str,
    ) -> Result<Option<(String, Pos)>, Diagnostic> {
        let tok = t.peek()?;
        match tok.kind {
            Kind::Semi => {
                t.next()?;
                Ok(None)
            }
            Kind::Word => {
                t.next()?;
                // `v a 1 2 3` + newline + `v b …`: the keyword is the next statement.
                if KEYWORDS.contains(&tok.text) && t.peek()?.kind != Kind::Semi {
                    return Err(Diagnostic::error(
                        t.lx.pos_after(&t.prev_before(&tok)),
                        format!(
                            "expected ';' to end the {stmt} statement, found {}",
                            quote(tok.text)
                        ),
                    ));
                }
                if parse_number(&tok).is_ok() {
                    return Err(t.err(
                        &tok,
                        format!("unexpected number {} in {stmt} statement", quote(tok.text)),
                    ));
                }
                if !valid_name(tok.text) {
                    return Err(t.err(&tok, format!("invalid material name {}", quote(tok.text))));
                }
                let pos = t.pos(&tok);
                t.expect_semi(stmt)?;
                Ok(Some((lossy(tok.text), pos)))
            }
            _ => Err(t.missing_semi(&tok, stmt)),
        }
    }

    fn vertex(
        &mut self,
        t: &mut Toks<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
    ) -> Result<(), Diagnostic> {
        let name = t.name("vertex name")?;
        let x = t.number("x coordinate")?;
        let y = t.number("y coordinate")?;
        let z = t.number("z coordinate")?;
        let color = self.trailing_color(t, "vertex")?;
        let id = self.model.vertices.len() as u32;
        let verts = &self.model.vertices;
        if !scope
            .vertices
            .insert(name.text, id, |k| verts[k as usize].name.as_str())
        {
            return Err(t.err(&name, format!("duplicate vertex name {}", quote(name.text))));
        }
        self.model.vertices.push(Vertex {
            name: lossy(name.text),
            pos: DVec3::new(x, y, z),
            color: None,
        });
        if let Some((c, pos)) = color {
            self.material_ref(MatSite::Vertex(VertexId(id)), c, pos);
        }
        items.push(Item::Vertex(VertexId(id)));
        Ok(())
    }

    fn material_ref(&mut self, site: MatSite, name: String, pos: Pos) {
        let mats = &self.model.materials;
        match self
            .materials
            .find(name.as_bytes(), |k| mats[k as usize].name.as_str())
        {
            Some(id) => self.set_material(site, MaterialId(id)),
            None => self
                .pending_materials
                .push(PendingMaterial { site, name, pos }),
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
    ) -> Result<(), Diagnostic> {
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
        let mut pending = Vec::new();
        let mut open = tok;
        loop {
            // Inside a contour.
            let mut c = Vec::new();
            loop {
                let v = t.next()?;
                match v.kind {
                    Kind::RParen => break,
                    Kind::Word => {
                        if !valid_name(v.text) {
                            return Err(t.err(&v, format!("invalid vertex name {}", quote(v.text))));
                        }
                        let verts = &self.model.vertices;
                        match scope.vertices.find(v.text, |k| verts[k as usize].name.as_str()) {
                            Some(id) => c.push(VertexId(id)),
                            None => {
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
                        return Err(t.err(&open, format!("unbalanced '(': contour not closed before {}", Lexer::describe(&v))));
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
            if scope.geoms.find(n.text, names).is_some() {
                return Err(t.err(n, format!("duplicate {stmt} name {}", quote(n.text))));
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
        if let Some((c, pos)) = color {
            self.material_ref(site, c, pos);
        }
        Ok(())
    }

    fn def(&mut self, t: &mut Toks<'_>, items: &mut Vec<Item>) -> Result<(), Diagnostic> {
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
        let mut scope = Scope::default();
        let mut body = Vec::new();
        self.statements(t, &mut scope, &mut body, Some((&name_s, &pos)))?;
        self.finish_scope(scope, &body)?;
        // Registered only now: a def cannot instantiate itself.
        let defs = &self.model.defs;
        if self
            .defs
            .find(name.text, |k| defs[k as usize].name.as_str())
            .is_some()
        {
            return Err(Diagnostic::error(
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

    fn transforms(&mut self, t: &mut Toks<'_>, until: Kind) -> Result<Vec<Transform>, Diagnostic> {
        let mut out = Vec::new();
        loop {
            let tok = t.peek()?;
            if tok.kind == until {
                return Ok(out);
            }
            let tok = t.next()?;
            if tok.kind != Kind::Word {
                let want = if until == Kind::Semi { "';'" } else { "')'" };
                return Err(t.err(
                    &tok,
                    format!(
                        "expected a transform flag or {want}, found {}",
                        Lexer::describe(&tok)
                    ),
                ));
            }
            let Some(op) = TransformOp::from_flag(tok.text) else {
                return Err(t.err(&tok, format!("unknown transform flag {}", quote(tok.text))));
            };
            let mut args = Vec::with_capacity(op.arity());
            for k in 0..op.arity() {
                args.push(t.number(&format!("argument {} of {}", k + 1, op.flag()))?);
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
    ) -> Result<(), Diagnostic> {
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
            color = Some((lossy(c.text), t.pos(&c)));
        }
        let transforms = self.transforms(t, Kind::RParen).map_err(|e| {
            if e.message.starts_with("expected a transform flag") {
                Diagnostic::error(
                    t.pos(&open),
                    format!("unbalanced '(': {stmt} not closed ({})", e.message),
                )
            } else {
                e
            }
        })?;
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
            let step = self.transforms(t, Kind::Semi)?;
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
        if let Some((c, pos)) = color {
            self.material_ref(MatSite::Instance(InstanceId(id)), c, pos);
        }
        items.push(Item::Instance(InstanceId(id)));
        Ok(())
    }

    fn include(
        &mut self,
        t: &mut Toks<'_>,
        kw: &Token<'_>,
        scope: &mut Scope,
        items: &mut Vec<Item>,
    ) -> Result<(), Diagnostic> {
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
        t.expect_semi("include")?;
        if self.opts.includes == IncludeMode::Keep {
            items.push(Item::Include(name));
            return Ok(());
        }
        let path = self.dir.join(&name);
        let canon = path.canonicalize().unwrap_or_else(|_| path.clone());
        if self.include_stack.contains(&canon) {
            return Err(t.err(
                kw,
                format!("include cycle: '{}' includes itself", path.display()),
            ));
        }
        if self.include_stack.len() >= 32 {
            return Err(t.err(kw, "includes nested more than 32 deep"));
        }
        let src = std::fs::read(&path).map_err(|e| {
            t.err(
                &f,
                format!("cannot read include file '{}': {e}", path.display()),
            )
        })?;
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
    fn finish_scope(&mut self, scope: Scope, _items: &[Item]) -> Result<(), Diagnostic> {
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
                return Err(Diagnostic::error(
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

    fn resolve_materials(&mut self) -> Result<(), Diagnostic> {
        let pending = std::mem::take(&mut self.pending_materials);
        for p in pending {
            let mats = &self.model.materials;
            let Some(id) = self
                .materials
                .find(p.name.as_bytes(), |k| mats[k as usize].name.as_str())
            else {
                return Err(Diagnostic::error(
                    p.pos,
                    format!("undefined material '{}'", p.name.escape_debug()),
                ));
            };
            self.set_material(p.site, MaterialId(id));
        }
        Ok(())
    }
}

impl<'a> Toks<'a> {
    /// The significant token before `tok` (the one handed out before it), or `tok` itself.
    fn prev_before(&self, tok: &Token<'a>) -> Token<'a> {
        self.before.filter(|b| b.start < tok.start).unwrap_or(*tok)
    }
}
