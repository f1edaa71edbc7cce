//! Streaming the mesh as UG text: the bytes `ug::write(&mesh.to_model(src))`
//! gives, without building the output model (no `String` per vertex or face,
//! no copy of the whole text in memory).
//!
//! Vertex names are not stored: each is its base vertex's name (an input
//! name, or recursively another vertex's) followed by `.k`, so only `k` is
//! kept per vertex and a name is spelled out when it is written. A derived
//! name `P.k` can only clash with an input name: two derived names `P.k` and
//! `Q.j` are equal only when the names `P` and `Q` (everything before the
//! last dot) and `k`, `j` are, and names are unique by induction. So the
//! uniqueness check needs the input names only, as in [`Mesh::to_model`],
//! which checks against the input names and every earlier derived name.
//! The same holds for face names `NAME.k`, whose counter is kept per base
//! name (patches sharing a name continue where the previous one stopped,
//! which is what skipping the names already taken does).

use std::io::{self, Write};
use std::ops::Range;

use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};
use ug::{Item, MaterialId, Model};

use crate::{Mesh, NONE, PatchId, VertId};

/// Lines formatted by one parallel job of [`write_in_parallel`] (at
/// least one item a job).
const JOB: usize = 8192;
/// Jobs formatted before their text is written (so that at most twice
/// this many jobs' text is held at once: a few megabytes).
const JOBS: usize = 16;

/// Writes to `out` the text that `fmt(range, buf)` appends for the items
/// `0..n`, in order, an item a line: see [`write_in_parallel_by`].
pub fn write_in_parallel(
    out: &mut dyn Write,
    n: usize,
    fmt: impl Fn(Range<usize>, &mut Vec<u8>) + Sync,
) -> io::Result<()> {
    write_in_parallel_by(out, n, |_| 1, fmt)
}

/// Writes to `out` the text that `fmt(range, buf)` appends for the items
/// `0..n`, in order, item `i` taking about `lines(i)` lines: the items are
/// formatted a job of consecutive items at a time on rayon's threads (up
/// to [`JOB`] lines a job), a batch of [`JOBS`] jobs at a time, and each
/// batch is written by the calling thread while the next is formatted.
/// The bytes are those of one `fmt(0..n, buf)` when `fmt` formats each
/// item on its own (as the writers here do: the text of an item depends on
/// the item only), whatever the jobs. (Jobs of a fixed 8,192 items held
/// 10 MB a job where an item is a converged patch with a line per leaf:
/// the writing was ugrad's memory peak, 29 MB above the solve's on the
/// 8.6k building and about 250 MB at 100k.)
pub fn write_in_parallel_by(
    out: &mut dyn Write,
    n: usize,
    lines: impl Fn(usize) -> usize,
    fmt: impl Fn(Range<usize>, &mut Vec<u8>) + Sync,
) -> io::Result<()> {
    // The longest job's text so far: the next jobs' buffers start there.
    let longest = std::sync::atomic::AtomicUsize::new(0);
    let batch = |jobs: &[Range<usize>]| -> Vec<Vec<u8>> {
        jobs.par_iter()
            .map(|r| {
                let mut buf =
                    Vec::with_capacity(longest.load(std::sync::atomic::Ordering::Relaxed));
                fmt(r.clone(), &mut buf);
                longest.fetch_max(buf.len(), std::sync::atomic::Ordering::Relaxed);
                buf
            })
            .collect()
    };
    // The next batch's jobs from item `a`.
    let plan = |mut a: usize| -> Vec<Range<usize>> {
        let mut jobs = Vec::with_capacity(JOBS);
        while a < n && jobs.len() < JOBS {
            let (mut b, mut w) = (a + 1, lines(a));
            while b < n {
                let l = lines(b);
                if w + l > JOB {
                    break;
                }
                w += l;
                b += 1;
            }
            jobs.push(a..b);
            a = b;
        }
        jobs
    };
    let mut pending: Vec<Vec<u8>> = Vec::new();
    let mut start = 0;
    loop {
        let jobs = plan(start);
        let end = jobs.last().map_or(start, |r| r.end);
        let mut next = Vec::new();
        rayon::in_place_scope(|s| {
            if start < n {
                s.spawn(|_| next = batch(&jobs));
            }
            pending.iter().try_for_each(|t| out.write_all(t))
        })?;
        if start >= n {
            return Ok(());
        }
        pending = next;
        start = end;
    }
}

/// What [`Mesh::write_ug_with`] writes besides the mesh: statements just
/// before the first vertex, and a colour on each vertex. (Shared by the
/// threads that format the vertices.)
pub trait VertexColours: Sync {
    /// Writes whole statements (each ending with a newline) that go after the
    /// input's kept statements and before the first vertex.
    fn write_before_vertices(&mut self, out: &mut dyn Write) -> io::Result<()>;

    /// Appends the name of vertex `v`'s colour material to `line` and returns
    /// true, or returns false to keep the input vertex's colour.
    fn colour_name(&self, v: VertId, line: &mut Vec<u8>) -> bool;
}

/// No extra statements; input vertices keep their colours.
struct InputColours;

impl VertexColours for InputColours {
    fn write_before_vertices(&mut self, _: &mut dyn Write) -> io::Result<()> {
        Ok(())
    }
    fn colour_name(&self, _: VertId, _: &mut Vec<u8>) -> bool {
        false
    }
}

/// Output vertex names, computed once (4 bytes per vertex) and spelled on demand.
struct VertexNames<'a> {
    mesh: &'a Mesh,
    src: &'a Model,
    /// The `k` of a derived name `BASE.k`; 0 for a vertex that keeps an input name.
    k: Vec<u32>,
    /// Per input vertex: the mesh vertex that is its first copy (`NONE` if none).
    first_copy: Vec<u32>,
}

/// Appends the decimal digits of `n`.
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

impl<'a> VertexNames<'a> {
    /// Assigns the names as [`Mesh::to_model`] does. `None` when the input
    /// has duplicate vertex names (then the uniqueness argument fails).
    fn new(mesh: &'a Mesh, src: &'a Model) -> Option<VertexNames<'a>> {
        let mut taken: FxHashSet<&str> = FxHashSet::default();
        taken.reserve(src.vertices.len());
        for v in &src.vertices {
            if !taken.insert(v.name.as_str()) {
                return None;
            }
        }
        // Only a name with a dot can equal a derived name.
        let dotted = src.vertices.iter().any(|v| v.name.contains('.'));
        let nv = mesh.pos.len();
        let n_input = mesh
            .vparent
            .iter()
            .filter(|p| p[1] == NONE)
            .map(|p| p[0] as usize + 1)
            .max()
            .unwrap_or(0);
        let mut names = VertexNames {
            mesh,
            src,
            k: vec![0; nv],
            first_copy: vec![NONE; n_input],
        };
        let mut count = vec![0u32; nv];
        let mut line = Vec::new();
        let mut scratch = Vec::new();
        for v in 0..nv {
            let [a, b] = mesh.vparent[v];
            let base = if b == NONE {
                let f = &mut names.first_copy[a as usize];
                if *f == NONE {
                    *f = v as u32;
                    continue;
                }
                *f
            } else {
                a
            };
            let k = loop {
                count[base as usize] += 1;
                let k = count[base as usize];
                if !dotted {
                    break k;
                }
                line.clear();
                names.spell(base, &mut line, &mut scratch);
                line.push(b'.');
                push_u64(&mut line, k as u64);
                let free = std::str::from_utf8(&line).map_or(true, |s| !taken.contains(s));
                if free {
                    break k;
                }
            };
            names.k[v] = k;
        }
        Some(names)
    }

    /// Appends the name of vertex `v` to `out` (`scratch` is working space).
    fn spell(&self, v: u32, out: &mut Vec<u8>, scratch: &mut Vec<u32>) {
        scratch.clear();
        let mut x = v;
        loop {
            let [a, b] = self.mesh.vparent[x as usize];
            if b == NONE {
                let f = self.first_copy[a as usize];
                if f == x {
                    match self.src.vertices.get(a as usize) {
                        Some(iv) => out.extend_from_slice(iv.name.as_bytes()),
                        None => {
                            out.push(b'v');
                            push_u64(out, a as u64);
                        }
                    }
                    break;
                }
                scratch.push(self.k[x as usize]);
                x = f;
            } else {
                scratch.push(self.k[x as usize]);
                x = a;
            }
        }
        for &k in scratch.iter().rev() {
            out.push(b'.');
            push_u64(out, k as u64);
        }
    }
}

impl Mesh {
    /// Writes `ug::write(&self.to_model(src))` to `out` without building the
    /// model: the same bytes, in a fraction of the memory.
    ///
    /// Of `src` (the model the mesh was built from) only the materials, the
    /// statements [`Mesh::to_model`] keeps, the vertices' names and colours
    /// and the faces' and wires' names are read: its geometry (vertex
    /// positions, face contours, wire polylines, the vertex and face items)
    /// may have been dropped after meshing.
    pub fn write_ug(&self, src: &Model, out: &mut dyn Write) -> io::Result<()> {
        self.write_ug_with(src, &mut InputColours, out)
    }

    /// [`Mesh::write_ug`] with extra statements before the first vertex and
    /// vertex colours chosen by `colours`: the bytes of writing the model
    /// [`Mesh::to_model`] gives after inserting those statements before its
    /// first vertex and setting those colours.
    pub fn write_ug_with(
        &self,
        src: &Model,
        colours: &mut dyn VertexColours,
        out: &mut dyn Write,
    ) -> io::Result<()> {
        let mut out = io::BufWriter::with_capacity(1 << 16, out);
        // The input's kept statements, through the canonical writer.
        let head = Model {
            materials: src.materials.clone(),
            items: src
                .items
                .iter()
                .filter(|it| {
                    matches!(
                        it,
                        Item::Material(_)
                            | Item::Comment(_)
                            | Item::Light(_)
                            | Item::Camera(_)
                            | Item::Include(_)
                            | Item::Escape(_)
                            | Item::Unknown(_)
                    )
                })
                .cloned()
                .collect(),
            ..Model::default()
        };
        ug::write(&head, &mut out)?;
        drop(head);

        // Names before colours: the names' working counts are freed before
        // the colours' tables are built.
        let names = VertexNames::new(self, src);
        colours.write_before_vertices(&mut out)?;
        let Some(names) = names else {
            // Duplicate input names: the general (memory-hungry) path.
            let mut m = self.to_model(src);
            let mut line = Vec::new();
            for v in 0..m.vertices.len() {
                line.clear();
                if colours.colour_name(VertId(v as u32), &mut line) {
                    let name = String::from_utf8_lossy(&line).into_owned();
                    let id = MaterialId(m.materials.len() as u32);
                    m.materials.push(ug::Material {
                        name,
                        def: ug::MaterialDef::Rgb([0.0; 3]),
                    });
                    m.vertices[v].color = Some(id);
                }
            }
            m.items
                .retain(|it| matches!(it, Item::Vertex(_) | Item::Face(_)));
            ug::write(&m, &mut out)?;
            return out.flush();
        };
        let mat_name = |m: MaterialId| src.materials[m.idx()].name.as_bytes();
        let colours: &dyn VertexColours = colours;

        // Vertices.
        write_in_parallel(&mut out, self.pos.len(), |range, line| {
            let mut ryu = ryu::Buffer::new();
            let mut scratch = Vec::new();
            for v in range {
                line.extend_from_slice(b"v ");
                names.spell(v as u32, line, &mut scratch);
                for x in self.pos[v].to_array() {
                    line.push(b' ');
                    ug::push_f64(line, x, &mut ryu);
                }
                let mark = line.len();
                line.push(b' ');
                if !colours.colour_name(VertId(v as u32), line) {
                    line.truncate(mark);
                    let [a, b] = self.vparent[v];
                    if b == NONE
                        && let Some(c) = src.vertices.get(a as usize).and_then(|x| x.color)
                    {
                        line.push(b' ');
                        line.extend_from_slice(mat_name(c));
                    }
                }
                line.extend_from_slice(b";\n");
            }
        })?;

        // Faces: a patch's pieces are `NAME.k` (or `NAME` when the patch
        // is one piece), `k` counting on over the patches of one name and
        // skipping the names the input's faces and wires take. The pieces
        // per patch first, then each named patch's first `k` (in patch
        // order), then the lines, formatted in parallel.
        let pieces_of = |p: PatchId, pieces: &mut Vec<VertId>, ends: &mut Vec<usize>| {
            pieces.clear();
            ends.clear();
            self.for_each_patch_leaf(p, |e| {
                self.for_each_anchored(e, |q| {
                    pieces.extend_from_slice(q);
                    ends.push(pieces.len());
                });
            });
        };
        let np = self.patches.len();
        // The input's face and wire names `PREFIX.k` (k as written: no
        // leading zero), as (PREFIX, k): the derived names they take.
        let taken: FxHashSet<(&str, u32)> = src
            .faces
            .iter()
            .filter_map(|f| f.name.as_deref())
            .chain(src.wires.iter().filter_map(|w| w.name.as_deref()))
            .filter_map(|n| {
                let (prefix, digits) = n.rsplit_once('.')?;
                let canonical = !digits.is_empty()
                    && digits.bytes().all(|b| b.is_ascii_digit())
                    && (digits == "0" || !digits.starts_with('0'));
                canonical
                    .then(|| digits.parse::<u32>().ok())
                    .flatten()
                    .map(|k| (prefix, k))
            })
            .collect();
        let next = |n: &str, k: &mut u32| loop {
            *k += 1;
            if !taken.contains(&(n, *k)) {
                break *k;
            }
        };
        let name_of = |p: PatchId| {
            src.faces
                .get(self.patch_face(p).idx())
                .and_then(|f| f.name.as_deref())
        };
        // Per patch, its name's count before its first piece: 0 but where
        // patches share a name (a parsed model's face names are unique, so
        // only a model built in memory), whose pieces are counted first.
        let mut first_k = vec![0u32; np];
        let mut patches_named: FxHashMap<&str, u32> = FxHashMap::default();
        for p in 0..np {
            if let Some(n) = name_of(PatchId(p as u32)) {
                *patches_named.entry(n).or_insert(0) += 1;
            }
        }
        if patches_named.values().any(|&c| c > 1) {
            let mut next_k: FxHashMap<&str, u32> = FxHashMap::default();
            let (mut pieces, mut ends) = (Vec::new(), Vec::new());
            for (p, first) in first_k.iter_mut().enumerate() {
                let patch = PatchId(p as u32);
                let Some(n) = name_of(patch).filter(|n| patches_named[n] > 1) else {
                    continue;
                };
                pieces_of(patch, &mut pieces, &mut ends);
                if ends.len() < 2 {
                    continue;
                }
                let k = next_k.entry(n).or_insert(0);
                *first = *k;
                for _ in 0..ends.len() {
                    next(n, k);
                }
            }
        }
        drop(patches_named);
        // A line a leaf (about: an anchored leaf may write more pieces).
        let leaves: Vec<u32> = (0..np)
            .into_par_iter()
            .map(|p| {
                let mut k = 0u32;
                self.for_each_patch_leaf(PatchId(p as u32), |_| k += 1);
                k
            })
            .collect();
        write_in_parallel_by(
            &mut out,
            np,
            |p| leaves[p] as usize,
            |range, line| {
                let (mut pieces, mut ends) = (Vec::new(), Vec::new());
                let mut scratch = Vec::new();
                for p in range {
                    let patch = PatchId(p as u32);
                    let name = name_of(patch);
                    let material = self.patch_material(patch);
                    pieces_of(patch, &mut pieces, &mut ends);
                    let whole = ends.len() == 1;
                    let mut k = first_k[p];
                    let mut start = 0;
                    for &end in &ends {
                        line.push(b'f');
                        if let Some(n) = name {
                            line.push(b' ');
                            line.extend_from_slice(n.as_bytes());
                            if !whole {
                                line.push(b'.');
                                push_u64(line, next(n, &mut k) as u64);
                            }
                        }
                        line.extend_from_slice(b" (");
                        for (i, v) in pieces[start..end].iter().enumerate() {
                            if i > 0 {
                                line.push(b' ');
                            }
                            names.spell(v.0, line, &mut scratch);
                        }
                        line.push(b')');
                        if let Some(m) = material {
                            line.push(b' ');
                            line.extend_from_slice(mat_name(m));
                        }
                        line.extend_from_slice(b";\n");
                        start = end;
                    }
                }
            },
        )?;
        out.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Several batches of jobs, the last ones short: the same bytes as one
    /// serial pass; and with items of very different lengths, given.
    #[test]
    fn parallel_writing_keeps_the_order() {
        let len = |i: usize| if i % 5000 < 100 { 3000 } else { 1 + i % 7 };
        let uneven = |r: Range<usize>, buf: &mut Vec<u8>| {
            for i in r {
                for _ in 0..len(i) {
                    buf.push(b'a' + (i % 26) as u8);
                    buf.push(b'\n');
                }
            }
        };
        for n in [0, 1, 63, 65, 20_000, 100_000] {
            let mut serial = Vec::new();
            uneven(0..n, &mut serial);
            let mut out = Vec::new();
            write_in_parallel_by(&mut out, n, len, uneven).unwrap();
            assert!(out == serial, "{n} uneven items");
        }
        let fmt = |r: Range<usize>, buf: &mut Vec<u8>| {
            for i in r {
                push_u64(buf, (i as u64).wrapping_mul(2_654_435_761) % 1000);
                buf.push(b'\n');
            }
        };
        for n in [0, 1, JOB - 1, JOB + 1, 2 * JOB * JOBS + 3] {
            let mut serial = Vec::new();
            fmt(0..n, &mut serial);
            let mut out = Vec::new();
            write_in_parallel(&mut out, n, fmt).unwrap();
            assert_eq!(out, serial, "{n} items");
        }
    }
}
