//! The canonical writer: one statement per line, single spaces, shortest
//! round-trip numbers. The same model always gives the same bytes.

use std::io::{self, Write};

use crate::model::*;

/// Formats a finite f64 in the shortest form that reads back to the same value
/// (`1` rather than `1.0`).
pub fn fmt_f64(v: f64, buf: &mut ryu::Buffer) -> &str {
    let v = if v == 0.0 { 0.0 } else { v }; // no "-0"
    let s = buf.format(v);
    s.strip_suffix(".0").unwrap_or(s)
}

/// Appends `v` to `out` exactly as [`fmt_f64`] formats it, faster for the
/// common short decimals: when `v` is a whole number of millionths `n` (that is,
/// `n / 10⁶` reads back as `v`; `n` is then unique, and the fewest decimals
/// are those of `n` less its trailing zeros), the digits are those of `n`.
/// Everything else goes through ryu.
pub fn push_f64(out: &mut Vec<u8>, v: f64, buf: &mut ryu::Buffer) {
    const SCALE: f64 = 1e6;
    let a = v.abs();
    if v == 0.0 {
        out.push(b'0');
        return;
    }
    // Within these bounds ryu writes plain decimals (no exponent), and
    // a·10⁶ < 2⁵⁰, so rounding the product finds the one candidate.
    if (1e-4..1e9).contains(&a) {
        let n = (a * SCALE).round();
        if n / SCALE == a {
            let n = n as u64;
            if v < 0.0 {
                out.push(b'-');
            }
            push_u64(out, n / 1_000_000);
            let mut frac = n % 1_000_000;
            if frac != 0 {
                let mut width = 6;
                while frac.is_multiple_of(10) {
                    frac /= 10;
                    width -= 1;
                }
                out.push(b'.');
                let mut digits = [b'0'; 6];
                for d in digits[..width].iter_mut().rev() {
                    *d = b'0' + (frac % 10) as u8;
                    frac /= 10;
                }
                out.extend_from_slice(&digits[..width]);
            }
            return;
        }
    }
    out.extend_from_slice(fmt_f64(v, buf).as_bytes());
}

fn push_u64(out: &mut Vec<u8>, mut n: u64) {
    let mut digits = [0u8; 20];
    let mut k = digits.len();
    loop {
        k -= 1;
        digits[k] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[k..]);
}

/// Output is handed to the writer in pieces of about this size.
const CHUNK: usize = 1 << 16;

/// Writes a model as UG text.
pub fn write<W: Write>(m: &Model, out: &mut W) -> io::Result<()> {
    let mut w = Writer {
        m,
        buf: ryu::Buffer::new(),
        out: Vec::with_capacity(CHUNK + 4096),
        sink: out,
        error: None,
    };
    w.items(&m.items, 0);
    w.flush();
    match w.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// The model as a UG string.
pub fn write_string(m: &Model) -> String {
    let mut v = Vec::new();
    write(m, &mut v).expect("writing to a Vec cannot fail");
    String::from_utf8(v).expect("the writer emits UTF-8")
}

struct Writer<'m, 'w> {
    m: &'m Model,
    buf: ryu::Buffer,
    /// Pending output, handed to `sink` every [`CHUNK`] bytes.
    out: Vec<u8>,
    sink: &'w mut dyn Write,
    /// The first write error; nothing more is written after it.
    error: Option<io::Error>,
}

impl Writer<'_, '_> {
    fn flush(&mut self) {
        if self.error.is_none()
            && let Err(e) = self.sink.write_all(&self.out)
        {
            self.error = Some(e);
        }
        self.out.clear();
    }
    fn s(&mut self, s: &str) {
        self.out.extend_from_slice(s.as_bytes());
    }
    #[inline]
    fn num(&mut self, v: f64) {
        push_f64(&mut self.out, v, &mut self.buf);
    }
    fn nums(&mut self, vs: &[f64]) {
        for &v in vs {
            self.out.push(b' ');
            self.num(v);
        }
    }
    fn indent(&mut self, depth: usize) {
        for _ in 0..depth {
            self.out.extend_from_slice(b"  ");
        }
    }
    fn mat_suffix(&mut self, m: Option<MaterialId>) {
        if let Some(m) = m {
            self.out.push(b' ');
            let name = &self.m.materials[m.idx()].name;
            self.out.extend_from_slice(name.as_bytes());
        }
    }
    fn contours(&mut self, cs: &[Vec<VertexId>]) {
        for c in cs {
            self.s(" (");
            for (k, v) in c.iter().enumerate() {
                if k > 0 {
                    self.out.push(b' ');
                }
                let name = &self.m.vertices[v.idx()].name;
                self.out.extend_from_slice(name.as_bytes());
            }
            self.out.push(b')');
        }
    }
    fn transforms(&mut self, ts: &[Transform]) {
        for t in ts {
            self.out.push(b' ');
            self.s(t.op.flag());
            self.nums(&t.args);
        }
    }

    /// Writes a statement list. Every vertex is written before the first
    /// face or wire that names it, so that one-pass readers can stream the
    /// output: a vertex statement that comes later in the list is moved up
    /// to just before that face (and not written again in its own place).
    fn items(&mut self, items: &[Item], depth: usize) {
        const NOWHERE: u32 = u32::MAX;
        // Position of each vertex's statement in this list.
        let mut at: Vec<u32> = Vec::new();
        for (k, it) in items.iter().enumerate() {
            if let Item::Vertex(v) = it {
                if at.is_empty() {
                    at = vec![NOWHERE; self.m.vertices.len()];
                }
                if let Some(slot) = at.get_mut(v.idx())
                    && *slot == NOWHERE
                {
                    *slot = k as u32;
                }
            }
        }
        let mut early: Vec<bool> = Vec::new();
        for (k, it) in items.iter().enumerate() {
            // Comments just before a face stay next to it (annotations such
            // as ugcopl's origin notes): its vertices go before them.
            if matches!(it, Item::Comment(_))
                && (k == 0 || !matches!(items[k - 1], Item::Comment(_)))
                && let Some(j) = (k..items.len()).find(|&j| !matches!(items[j], Item::Comment(_)))
            {
                let names: &[Vec<VertexId>] = match &items[j] {
                    Item::Face(f) => &self.m.faces[f.idx()].contours,
                    Item::Wire(w) => &self.m.wires[w.idx()].polylines,
                    _ => &[],
                };
                for &v in names.iter().flatten() {
                    if at
                        .get(v.idx())
                        .is_some_and(|&p| p != NOWHERE && p as usize > k)
                        && !early.get(v.idx()).copied().unwrap_or(false)
                    {
                        if early.is_empty() {
                            early = vec![false; self.m.vertices.len()];
                        }
                        early[v.idx()] = true;
                        self.indent(depth);
                        self.item(&Item::Vertex(v), depth);
                        self.out.push(b'\n');
                    }
                }
            }
            let names: &[Vec<VertexId>] = match it {
                Item::Face(f) => &self.m.faces[f.idx()].contours,
                Item::Wire(w) => &self.m.wires[w.idx()].polylines,
                Item::Vertex(v) => {
                    if early.get(v.idx()).copied().unwrap_or(false) {
                        continue;
                    }
                    &[]
                }
                _ => &[],
            };
            for &v in names.iter().flatten() {
                if at
                    .get(v.idx())
                    .is_some_and(|&p| p != NOWHERE && p as usize > k)
                    && !early.get(v.idx()).copied().unwrap_or(false)
                {
                    if early.is_empty() {
                        early = vec![false; self.m.vertices.len()];
                    }
                    early[v.idx()] = true;
                    self.indent(depth);
                    self.item(&Item::Vertex(v), depth);
                    self.out.push(b'\n');
                }
            }
            self.indent(depth);
            self.item(it, depth);
            self.out.push(b'\n');
            if self.out.len() >= CHUNK {
                self.flush();
            }
        }
    }

    fn item(&mut self, it: &Item, depth: usize) {
        let m = self.m;
        match it {
            Item::Comment(c) => {
                self.out.push(b'{');
                self.s(c);
                self.out.push(b'}');
            }
            Item::Material(id) => {
                let mat = &m.materials[id.idx()];
                match &mat.def {
                    MaterialDef::Rgb(c) => {
                        self.s("c_rgb ");
                        self.s(&mat.name);
                        self.nums(c);
                        self.out.push(b';');
                    }
                    MaterialDef::Lhs(v) => {
                        self.s("c ");
                        self.s(&mat.name);
                        self.nums(v);
                        self.out.push(b';');
                    }
                    MaterialDef::Defmat(d) => {
                        self.s("defmat ");
                        self.s(&mat.name);
                        self.s(";\n");
                        if let Some(c) = d.diffuse {
                            self.indent(depth + 1);
                            self.s("diffuse_rgb");
                            self.nums(&c);
                            self.s(";\n");
                        }
                        if let Some(c) = d.emission {
                            self.indent(depth + 1);
                            self.s("emission_rgb");
                            self.nums(&c);
                            self.s(";\n");
                        }
                        for (k, words) in &d.other {
                            self.indent(depth + 1);
                            self.s(k);
                            for w in words {
                                self.out.push(b' ');
                                self.s(w);
                            }
                            self.s(";\n");
                        }
                        self.indent(depth);
                        self.s("end;");
                    }
                }
            }
            Item::Vertex(id) => {
                let v = &m.vertices[id.idx()];
                self.s("v ");
                self.s(&v.name);
                self.nums(&v.pos.to_array());
                self.mat_suffix(v.color);
                self.out.push(b';');
            }
            Item::Face(id) => {
                let f = &m.faces[id.idx()];
                self.out.push(b'f');
                if let Some(n) = &f.name {
                    self.out.push(b' ');
                    self.s(n);
                }
                self.contours(&f.contours);
                self.mat_suffix(f.material);
                self.out.push(b';');
            }
            Item::Wire(id) => {
                let w = &m.wires[id.idx()];
                self.out.push(b'w');
                if let Some(n) = &w.name {
                    self.out.push(b' ');
                    self.s(n);
                }
                self.contours(&w.polylines);
                self.mat_suffix(w.material);
                self.out.push(b';');
            }
            Item::Def(id) => {
                let d = &m.defs[id.idx()];
                self.s("def ");
                self.s(&d.name);
                self.s(";\n");
                self.items(&d.items, depth + 1);
                self.indent(depth);
                self.s("end;");
            }
            Item::Instance(id) => {
                let inst = &m.instances[id.idx()];
                self.s(if inst.array.is_some() { "a" } else { "i" });
                if let Some(n) = &inst.name {
                    self.out.push(b' ');
                    self.s(n);
                }
                self.s(" (");
                self.s(&m.defs[inst.def.idx()].name);
                self.mat_suffix(inst.color);
                self.transforms(&inst.transforms);
                self.out.push(b')');
                if let Some(a) = &inst.array {
                    self.out.push(b' ');
                    self.s(&a.count.to_string());
                    self.transforms(&a.step);
                }
                self.out.push(b';');
            }
            Item::Light(r) | Item::Camera(r) | Item::Unknown(r) => {
                self.s(&r.keyword);
                if !r.text.is_empty() {
                    self.out.push(b' ');
                    self.s(&r.text);
                }
                self.out.push(b';');
            }
            Item::Include(p) => {
                self.s("include ");
                // The reader removes one pair of quotes around the name: a name
                // that is itself quoted is written inside the other kind.
                let quoted = |q: char| p.len() >= 2 && p.starts_with(q) && p.ends_with(q);
                if quoted('"') {
                    self.out.push(b'\'');
                    self.s(p);
                    self.out.push(b'\'');
                } else if quoted('\'') {
                    self.out.push(b'"');
                    self.s(p);
                    self.out.push(b'"');
                } else {
                    self.s(p);
                }
                self.out.push(b';');
            }
            Item::Escape(e) => {
                self.out.push(b'(');
                self.s(e);
                self.out.push(b')');
            }
        }
    }
}
