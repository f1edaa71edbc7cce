//! Plumbing shared by every UG tool (DESIGN.md §3):
//!
//! * input from a file argument or stdin (`-` or nothing), named `<stdin>` in messages;
//! * output written only when the whole job succeeded: stdout in one buffered
//!   write, `-o FILE` through a temporary file renamed into place;
//! * a closed pipe (`| head`) ends quietly with status 0;
//! * exit status 0 success, 1 runtime failure, 2 bad input or usage;
//! * `-q` / `-v`, the model-relative epsilon, progress bars on a terminal only.

use std::io::{self, IsTerminal, Read, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;

pub use ug;

/// Exit status for bad input or usage.
pub const EXIT_INPUT: u8 = 2;
/// Exit status for a runtime failure (e.g. a requested device is missing).
pub const EXIT_RUNTIME: u8 = 1;

/// An error that ends a tool: its message (already formatted) and exit status.
#[derive(Debug)]
pub struct Failure {
    pub code: u8,
    pub message: String,
}

impl Failure {
    pub fn input(message: impl Into<String>) -> Self {
        Failure {
            code: EXIT_INPUT,
            message: message.into(),
        }
    }
    pub fn runtime(message: impl Into<String>) -> Self {
        Failure {
            code: EXIT_RUNTIME,
            message: message.into(),
        }
    }
}

impl From<ug::Diagnostic> for Failure {
    fn from(d: ug::Diagnostic) -> Self {
        Failure::input(d.to_string())
    }
}

/// Flags every UG filter takes.
#[derive(Args, Debug, Clone, Default)]
pub struct Common {
    /// Input UG file; stdin when absent or '-'.
    #[arg(value_name = "FILE")]
    pub input: Option<PathBuf>,
    /// Write the result to FILE (atomically) instead of stdout.
    #[arg(short = 'o', long = "out", value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// No progress or warnings on stderr.
    #[arg(short = 'q', long, conflicts_with = "verbose")]
    pub quiet: bool,
    /// More detail on stderr (statistics, timings, the epsilon used).
    #[arg(short = 'v', long, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Unknown UG statements are errors instead of warnings.
    #[arg(long)]
    pub strict: bool,
}

/// The bytes of the input and the name used in messages.
pub struct Input {
    pub bytes: Vec<u8>,
    pub name: String,
    /// Directory includes are resolved against.
    pub dir: PathBuf,
}

impl Common {
    /// Reads the input file or stdin.
    pub fn read_input(&self) -> Result<Input, Failure> {
        match self.input.as_deref() {
            None => read_stdin(),
            Some(p) if p == Path::new("-") => read_stdin(),
            Some(p) => {
                let bytes = std::fs::read(p).map_err(|e| {
                    Failure::input(format!("{}: error: cannot read: {e}", p.display()))
                })?;
                Ok(Input {
                    bytes,
                    name: p.display().to_string(),
                    dir: p.parent().map(Path::to_path_buf).unwrap_or_default(),
                })
            }
        }
    }

    /// Reads and parses the input; warnings go to stderr unless `-q`.
    pub fn load(&self) -> Result<ug::Model, Failure> {
        let input = self.read_input()?;
        let opts = ug::ParseOptions {
            strict: self.strict,
            limits: true,
            ..Default::default()
        };
        let parsed = ug::parse_with(&input.bytes, &input.name, Some(&input.dir), &opts)?;
        if !self.quiet {
            for w in &parsed.warnings {
                eprintln!("{w}");
            }
        }
        Ok(parsed.model)
    }

    /// Reads, parses and flattens the input (geometry tools work on flat models).
    pub fn load_flat(&self) -> Result<ug::Model, Failure> {
        let m = self.load()?;
        if !m.is_flat() && self.verbose > 0 {
            eprintln!(
                "note: flattening {} instance(s) of {} def(s)",
                m.instances.len(),
                m.defs.len()
            );
        }
        let flat = m.flatten()?;
        // Instances may scale vertices beyond the limit the parser keeps.
        if let Some(v) = flat
            .vertices
            .iter()
            .find(|v| v.pos.abs().max_element() > ug::MAX_COORDINATE)
        {
            return Err(Failure::input(format!(
                "{}: error: flattening moves vertex '{}' beyond ±{:e}: too large to compute with in double precision (scale the model down)",
                self.input_name(),
                v.name,
                ug::MAX_COORDINATE
            )));
        }
        Ok(flat)
    }

    /// The input's name in messages.
    fn input_name(&self) -> String {
        match self.input.as_deref() {
            None => "<stdin>".to_string(),
            Some(p) if p == Path::new("-") => "<stdin>".to_string(),
            Some(p) => p.display().to_string(),
        }
    }

    /// Writes the finished output (see [`write_output`]).
    pub fn write(&self, bytes: &[u8]) -> Result<(), Failure> {
        write_output(self.output.as_deref(), bytes)
    }

    /// Writes a model as UG.
    pub fn write_model(&self, m: &ug::Model) -> Result<(), Failure> {
        let mut buf = Vec::new();
        ug::write(m, &mut buf).map_err(|e| Failure::runtime(format!("error: {e}")))?;
        self.write(&buf)
    }

    /// The note that the epsilon was taken from the input's precision
    /// ([`precision_epsilon`]): once, by the first tool of a pipeline (the
    /// next ones read it from the `{ugkit epsilon E}` comment); not with
    /// `-q`.
    pub fn note_precision(&self, e: f64) {
        if !self.quiet {
            eprintln!(
                "note: epsilon {e:e}, {PRECISION_FACTOR} times the precision the coordinates are written with: faces turned off the axes are bent or moved by that rounding (the default would be 1e-6 of the model's size; -e sets it)"
            );
        }
    }

    /// Prints a note on stderr when `-v` was given.
    pub fn verbose(&self, msg: impl AsRef<str>) {
        if self.verbose > 0 {
            eprintln!("{}", msg.as_ref());
        }
    }

    /// A progress bar on stderr, hidden with `-q` or when stderr is not a terminal.
    pub fn progress(&self, len: u64, what: &str) -> indicatif::ProgressBar {
        if self.quiet || !io::stderr().is_terminal() {
            return indicatif::ProgressBar::hidden();
        }
        let pb = indicatif::ProgressBar::new(len);
        if let Ok(style) =
            indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}")
        {
            pb.set_style(style.progress_chars("=> "));
        }
        pb.set_message(what.to_string());
        pb
    }
}

fn read_stdin() -> Result<Input, Failure> {
    let mut bytes = Vec::new();
    io::stdin()
        .lock()
        .read_to_end(&mut bytes)
        .map_err(|e| Failure::input(format!("<stdin>: error: cannot read: {e}")))?;
    Ok(Input {
        bytes,
        name: "<stdin>".to_string(),
        dir: PathBuf::new(),
    })
}

/// Writes all of `bytes` to `path` (atomically: temporary file, then rename;
/// a device or pipe in place) or to stdout. A closed stdout pipe is not an error.
pub fn write_output(path: Option<&Path>, bytes: &[u8]) -> Result<(), Failure> {
    write_streamed(path, |w| w.write_all(bytes))
}

/// Writes the output through `body` as it is produced: `-o FILE` atomically
/// (a temporary file in the same directory, renamed into place once
/// complete), otherwise stdout, where a closed pipe is not an error. `-o`
/// naming a device or a pipe (`-o /dev/null`) is written in place: renaming
/// a regular file over it would replace the device (as root, /dev/null
/// became a regular file that way, and later readers of /dev/null read our
/// output).
pub fn write_streamed(
    path: Option<&Path>,
    body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), Failure> {
    match path {
        Some(p) if std::fs::metadata(p).is_ok_and(|m| !m.is_file() && !m.is_dir()) => {
            // A device or pipe (`-o /dev/null`): written in place, never replaced.
            let fail = |e: &dyn std::fmt::Display| {
                Failure::runtime(format!("{}: error: cannot write: {e}", p.display()))
            };
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(p)
                .map_err(|e| fail(&e))?;
            let mut w = io::BufWriter::with_capacity(1 << 16, file);
            body(&mut w).and_then(|_| w.flush()).map_err(|e| fail(&e))
        }
        Some(p) if p != Path::new("-") => {
            let fail = |e: &dyn std::fmt::Display| {
                Failure::runtime(format!("{}: error: cannot write: {e}", p.display()))
            };
            let dir = match p.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => std::path::PathBuf::from("."),
            };
            let file_name = p
                .file_name()
                .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
            let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
            let mut opts = std::fs::OpenOptions::new();
            // Created with the default mode (0666 less the umask), like any
            // file a shell redirection makes; a file being replaced keeps
            // its permissions.
            opts.write(true).create_new(true);
            let file = opts.open(&tmp).map_err(|e| fail(&e))?;
            if let Ok(old) = std::fs::metadata(p) {
                let _ = file.set_permissions(old.permissions());
            }
            let result = (|| {
                let mut w = io::BufWriter::with_capacity(1 << 16, file);
                body(&mut w)?;
                let file = w.into_inner().map_err(|e| e.into_error())?;
                file.sync_all()?;
                std::fs::rename(&tmp, p)
            })();
            if let Err(e) = result {
                let _ = std::fs::remove_file(&tmp);
                return Err(fail(&e));
            }
            Ok(())
        }
        _ => {
            let mut out = io::stdout().lock();
            match body(&mut out).and_then(|_| out.flush()) {
                Ok(()) => Ok(()),
                Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(()),
                Err(e) => Err(Failure::runtime(format!(
                    "<stdout>: error: cannot write: {e}"
                ))),
            }
        }
    }
}

/// Runs a tool's body and turns its result into an exit status; errors go to stderr.
pub fn run(body: impl FnOnce() -> Result<(), Failure>) -> ExitCode {
    match body() {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            let _ = writeln!(io::stderr(), "{}", f.message);
            ExitCode::from(f.code)
        }
    }
}

/// The skeleton every UG filter shares: read and flatten the input, settle
/// the distance tolerance (`-e`, or [`RELATIVE_EPSILON`] of the model's
/// size), run `body` (one library call and its report on stderr), write the
/// model it returns, and turn the result into an exit status. Nothing is
/// written unless `body` succeeded.
///
/// ```no_run
/// # let common = cli::Common::default();
/// std::process::exit(match cli::filter(&common, None, |model, eps| {
///     common.verbose(format!("epsilon {eps:e}"));
///     Ok(model)
/// }) { _ => 0 });
/// ```
pub fn filter(
    common: &Common,
    explicit_epsilon: Option<f64>,
    body: impl FnOnce(ug::Model, f64) -> Result<ug::Model, Failure>,
) -> ExitCode {
    run(|| {
        let model = common.load_flat()?;
        let eps = choose_epsilon(explicit_epsilon, &model);
        if eps.source == Source::Precision {
            common.note_precision(eps.value);
        }
        let mut out = body(model, eps.value)?;
        // An epsilon chosen from the input's precision goes on down the
        // pipeline: the next tool's coordinates (cuts, welds) are no
        // longer rounded.
        if matches!(eps.source, Source::Precision | Source::Carried) {
            carry_epsilon(&mut out, eps.value);
        }
        common.write_model(&out)
    })
}

/// The model-relative default epsilon: this fraction of the bounding-box diagonal.
pub const RELATIVE_EPSILON: f64 = 1e-6;

/// The epsilon a tool uses: `-e` when given (absolute units), else the one
/// an earlier tool of the pipeline chose from the input's precision (a
/// `{ugkit epsilon E}` comment, see [`Epsilon`]), else that precision
/// where it explains the faces' bends ([`precision_epsilon`]), else
/// [`RELATIVE_EPSILON`] times the model's bounding-box diagonal (1e-9 for
/// an empty or point model).
pub fn epsilon(explicit: Option<f64>, m: &ug::Model) -> f64 {
    choose_epsilon(explicit, m).value
}

/// The comment that carries an epsilon chosen from the input's precision
/// down a pipeline: `{ugkit epsilon E}`. The tools that meet it without
/// `-e` use E, and write it on.
pub const EPSILON_COMMENT: &str = "ugkit epsilon";

/// Where a tool's epsilon came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Source {
    /// `-e`.
    Explicit,
    /// A `{ugkit epsilon E}` comment in the input.
    Carried,
    /// The precision the input's coordinates were written with
    /// ([`precision_epsilon`]).
    Precision,
    /// [`RELATIVE_EPSILON`] of the model's size.
    Relative,
}

/// A tool's epsilon and where it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epsilon {
    pub value: f64,
    pub source: Source,
}

/// [`epsilon`], with its source.
pub fn choose_epsilon(explicit: Option<f64>, m: &ug::Model) -> Epsilon {
    if let Some(e) = explicit {
        return Epsilon {
            value: e,
            source: Source::Explicit,
        };
    }
    if let Some(e) = carried_epsilon(m) {
        return Epsilon {
            value: e,
            source: Source::Carried,
        };
    }
    let relative = relative_epsilon(m);
    match precision_epsilon(m, relative) {
        Some(q) => Epsilon {
            value: q,
            source: Source::Precision,
        },
        None => Epsilon {
            value: relative,
            source: Source::Relative,
        },
    }
}

/// [`RELATIVE_EPSILON`] times the model's bounding-box diagonal (1e-9 for
/// an empty or point model).
pub fn relative_epsilon(m: &ug::Model) -> f64 {
    match m.bounds() {
        Some((lo, hi)) if (hi - lo).length() > 0.0 => RELATIVE_EPSILON * (hi - lo).length(),
        _ => 1e-9,
    }
}

/// The epsilon of a `{ugkit epsilon E}` comment, if the model has one.
pub fn carried_epsilon(m: &ug::Model) -> Option<f64> {
    m.items.iter().find_map(|it| match it {
        ug::Item::Comment(c) => c
            .trim()
            .strip_prefix(EPSILON_COMMENT)
            .and_then(|r| r.trim().parse::<f64>().ok())
            .filter(|e| e.is_finite() && *e > 0.0),
        _ => None,
    })
}

/// Puts a `{ugkit epsilon E}` comment first in `m` (replacing any other).
pub fn carry_epsilon(m: &mut ug::Model, e: f64) {
    m.items
        .retain(|it| !matches!(it, ug::Item::Comment(c) if c.trim().starts_with(EPSILON_COMMENT)));
    m.items
        .insert(0, ug::Item::Comment(format!("{EPSILON_COMMENT} {e:e}")));
}

/// The epsilon taken from a precision q is this many times q: a rounded
/// point lies up to 0.87 q from where it was meant, a rounded edge's ends
/// as much, so a point meant to lie on an edge may lie 1.7 q from it (at
/// q itself, tilted buildings rounded to 4 decimals kept T-vertices on 12
/// of 60 seeds; docs/decisions.md). Not a whole number: between rounded
/// points the distances along an axis are whole multiples of q, and at an
/// epsilon of exactly 2q two faces 2q apart were within epsilon for one
/// test and beyond it for the next, by the last bit (a pier's bottom and
/// a wall's 0.2 mm apart at 4 decimals: an inconsistent edge). No sum of
/// three squared whole numbers is 2.1², so no distance between rounded
/// points is ever exactly 2.1 q.
pub const PRECISION_FACTOR: f64 = 2.1;

/// At most this many times the relative epsilon is taken from the input's
/// precision ([`precision_epsilon`]): an epsilon of at most 2e-3 of the
/// model's size. Exports in whole millimetres (or metres to 3 decimals)
/// of a building from 1 m across are covered (a 7.5 m building's q is 133
/// times its relative epsilon); a hand-written model in whole units needs
/// to be 1,000 units across before its unit could be taken, and then only
/// if a face is bent by at most 2 units (docs/decisions.md).
pub const PRECISION_LIMIT: f64 = 1000.0;

/// At most this many times the relative epsilon is taken from the input's
/// precision where no face is bent but some face is oblique (its normal
/// along no axis): metres to 4 decimals on a building from 1 m across,
/// whole millimetres from 10 m across (docs/decisions.md).
pub const OBLIQUE_LIMIT: f64 = 100.0;

/// 2.1 times the precision the model's coordinates were written with, as
/// an epsilon ([`PRECISION_FACTOR`]), where the rounding matters: the
/// coarsest power of ten q that every coordinate is a whole multiple of,
/// when 2.1 q is more than `relative` (and q at most [`PRECISION_LIMIT`]
/// times it) and some face is bent out of its plane by more than `relative` and
/// at most 2q, or two faces on one edge are (a face of one lies that far
/// from the other's plane: a polygon exported as triangles), or (q at
/// most [`OBLIQUE_LIMIT`] times `relative`) some face is oblique. An export
/// rounded to 4 decimals (0.1 mm, as Revit writes metres) whose
/// walls are turned off the axes has faces bent by up to that rounding,
/// a few times the relative epsilon of a 20 m building; at the relative
/// epsilon the chain cut such faces into hundreds of pieces and still
/// left defects (a helper's exports, 2026-12-06: 4 faces → 1,118), at q
/// it leaves a few clean pieces. A model whose faces are flat and along
/// the axes (or bent by more than the rounding explains) keeps the
/// relative epsilon.
pub fn precision_epsilon(m: &ug::Model, relative: f64) -> Option<f64> {
    if relative.is_nan() || relative <= 0.0 {
        return None;
    }
    m.top_vertices().nth(2)?;
    // Powers of ten q with PRECISION_FACTOR·q above `relative`, up to
    // PRECISION_LIMIT times it, coarsest first. (A q a little under the
    // relative epsilon moves points by most of it: 5 decimals on a
    // building of 11.5 m diagonal, q = 0.87 relative, failed 3 of 200
    // property seeds by orientation.)
    let lo = (relative / PRECISION_FACTOR).log10().floor() as i32 + 1;
    let hi = (relative * PRECISION_LIMIT).log10().floor() as i32;
    let whole = |k: i32| {
        let scale = 10f64.powi(-k);
        m.top_vertices().flat_map(|v| m.pos(v).to_array()).all(|x| {
            let y = x * scale;
            (y - y.round()).abs() <= 1e-3
        })
    };
    // Coordinates on a grid coarser than the limit (whole centimetres on a
    // building of 5 m): a finer power of ten they are multiples of too is
    // not their precision (a point lies up to half the grid off, more than
    // 2.1 times the finer q), so the relative epsilon stays (property
    // seeds 500300..500400 rounded to centimetres, with 2.1 mm: 57 of 100
    // failed in the default chain; with the relative epsilon, 51).
    if whole(hi + 1) {
        return None;
    }
    let q = (lo..=hi).rev().find(|&k| whole(k)).map(|k| 10f64.powi(k))?;
    let explained = |d: f64| d > relative && d <= 2.0 * q;
    let faces: Vec<Vec<Vec<geom::DVec3>>> = m
        .top_faces()
        .map(|f| {
            m.faces[f.idx()]
                .contours
                .iter()
                .map(|c| c.iter().map(|&v| m.pos(v)).collect())
                .collect()
        })
        .collect();
    let fits: Vec<Option<(f64, geom::Plane)>> = faces
        .iter()
        .map(|f| geom::Plane::face_deviation(f))
        .collect();
    if fits.iter().flatten().any(|&(d, _)| explained(d)) {
        return Some(PRECISION_FACTOR * q);
    }
    // Or flat faces of which some are oblique: walls turned about the
    // vertical only stay flat when rounded (a wall's top and bottom
    // corners round alike), but their corners move in the plan, and where
    // other things meet them (a vault's edge meant to lie on the wall, a
    // wall's end on the next) they miss by up to q, several times the
    // relative epsilon (property seeds at 4 decimals with oblique wings:
    // 6 of 200 kept defects, 1 now). Faces along the axes round exactly.
    let oblique = |n: geom::DVec3| n.to_array().iter().filter(|c| c.abs() > 1e-6).count() > 1;
    if q <= OBLIQUE_LIMIT * relative && fits.iter().flatten().any(|&(_, pl)| oblique(pl.n)) {
        return Some(PRECISION_FACTOR * q);
    }
    // Or two faces on one edge (by position: an export may give each face
    // its own copies) lying in one plane but for the rounding: a polygon
    // written as triangles, each flat, the pair bent.
    type Key = ([u64; 3], [u64; 3]);
    let bits = |p: geom::DVec3| p.to_array().map(f64::to_bits);
    let mut by_edge: std::collections::HashMap<Key, Vec<usize>> = Default::default();
    for (k, f) in faces.iter().enumerate() {
        for c in f {
            for i in 0..c.len() {
                let (a, b) = (bits(c[i]), bits(c[(i + 1) % c.len()]));
                let key = if a < b { (a, b) } else { (b, a) };
                let on = by_edge.entry(key).or_default();
                if on.len() < 4 && !on.contains(&k) {
                    on.push(k);
                }
            }
        }
    }
    let off = |f: usize, g: usize| {
        fits[f].map(|(_, plane)| {
            faces[g]
                .iter()
                .flatten()
                .map(|&p| plane.dist(p).abs())
                .fold(0.0, f64::max)
        })
    };
    let bent_pair = by_edge.values().any(|on| {
        on.iter().enumerate().any(|(i, &f)| {
            on[i + 1..]
                .iter()
                .any(|&g| off(f, g).is_some_and(explained) || off(g, f).is_some_and(explained))
        })
    });
    bent_pair.then_some(PRECISION_FACTOR * q)
}

/// Parses an `-e` value: a finite, non-negative number.
pub fn parse_epsilon(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a finite, non-negative number")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(src: &str) -> ug::Model {
        ug::parse(src.as_bytes(), "t").unwrap().model
    }

    /// A quad turned off the axes, its corners rounded to 4 decimals:
    /// bent by the rounding, more than 1e-6 of its size.
    const ROUNDED: &str = "v a 1.2346 2.3457 0.4568; v b 4.12 2.6162 -0.3184; \
        v c 4.0002 4.5975 -0.073; v d 1.1147 4.3269 0.7021; f q (a b c d);";

    #[test]
    fn the_precision_of_rounded_turned_faces_is_the_epsilon() {
        let m = model(ROUNDED);
        let e = choose_epsilon(None, &m);
        // Bent by more than the relative epsilon, so the rounding's.
        let (bend, _) = geom::Plane::face_deviation(&[m_face(&m, 0)]).unwrap();
        assert!(bend > relative_epsilon(&m) && bend < 2e-4, "{bend}");
        assert_eq!(e.source, Source::Precision);
        assert_eq!(e.value, PRECISION_FACTOR * 1e-4);
        // `-e` wins; a carried comment is used as it is.
        assert_eq!(epsilon(Some(0.5), &m), 0.5);
        let mut c = m.clone();
        carry_epsilon(&mut c, 3e-4);
        assert_eq!(choose_epsilon(None, &c).value, 3e-4);
        assert_eq!(choose_epsilon(None, &c).source, Source::Carried);
        // The same quad as two triangles on their own vertex copies (as a
        // triangle-soup export writes it): each flat, the pair bent.
        let soup = model(
            "v a 1.2346 2.3457 0.4568; v b 4.12 2.6162 -0.3184; \
             v c 4.0002 4.5975 -0.073; v d 1.1147 4.3269 0.7021; \
             v a2 1.2346 2.3457 0.4568; v c2 4.0002 4.5975 -0.073; \
             f t1 (a b c); f t2 (a2 c2 d);",
        );
        assert_eq!(choose_epsilon(None, &soup).source, Source::Precision);
        assert_eq!(choose_epsilon(None, &soup).value, PRECISION_FACTOR * 1e-4);
        // Rounded to 1 mm (whole millimetres, written in metres) on a 7.8 m
        // model: q is 129 times the relative epsilon, within the limit.
        let mm = model(
            "v a 0.123 0.457 0.411; v b 4.432 1.801 0.077; \
             v c 3.301 5.977 -0.201; v d -1.009 4.633 0.133; f q (a b c d);",
        );
        let (bend, _) = geom::Plane::face_deviation(&[m_face(&mm, 0)]).unwrap();
        assert!(bend > relative_epsilon(&mm) && bend < 2e-3, "{bend}");
        assert_eq!(choose_epsilon(None, &mm).source, Source::Precision);
        assert_eq!(choose_epsilon(None, &mm).value, PRECISION_FACTOR * 1e-3);
    }

    /// Walls turned about the vertical only, rounded to 4 decimals: every
    /// face flat, but oblique, so the rounding moved their corners in the
    /// plan; q is taken. Along the axes, or with q beyond
    /// [`OBLIQUE_LIMIT`] times the relative epsilon, it is not.
    #[test]
    fn the_precision_of_flat_oblique_faces_is_the_epsilon() {
        let turned = model(
            "v a 0 0 0; v b 3.4641 2 0; v c 3.4641 2 2.8; v d 0 0 2.8; f w (a b c d); \
             v e 4.4641 0.2679 0; v f 4.4641 0.2679 2.8; f x (b e f c);",
        );
        let (bend, _) = geom::Plane::face_deviation(&[m_face(&turned, 0)]).unwrap();
        assert!(bend < 1e-15, "{bend}");
        let e = choose_epsilon(None, &turned);
        assert_eq!(e.source, Source::Precision);
        assert_eq!(e.value, PRECISION_FACTOR * 1e-4);
        // The same walls along the axes: rounding moved nothing.
        let square = model(
            "v a 0 0 0; v b 4 0 0; v c 4 0 2.8; v d 0 0 2.8; f w (a b c d); \
             v e 4 1.7321 0; v f 4 1.7321 2.8; f x (b e f c);",
        );
        assert_eq!(choose_epsilon(None, &square).source, Source::Relative);
        // In whole millimetres but 2 m across: q is 200 times the relative
        // epsilon; only a bend could explain it.
        let small = model("v a 0 0 0; v b 1.732 1 0; v c 1.732 1 0.5; v d 0 0 0.5; f w (a b c d);");
        assert!(1e-3 > OBLIQUE_LIMIT * relative_epsilon(&small));
        assert_eq!(choose_epsilon(None, &small).source, Source::Relative);
        // 5 decimals on a 12 m model: q is under the relative epsilon
        // (1.2e-5) but moves points by most of it; 2.1 q is above it.
        let fine = model(
            "v a 0 0 0; v b 10.39231 6.00001 0; v c 10.39231 6.00001 2.8; v d 0 0 2.8; \
             f w (a b c d);",
        );
        let relative = relative_epsilon(&fine);
        assert!(
            1e-5 < relative && PRECISION_FACTOR * 1e-5 > relative,
            "{relative}"
        );
        assert_eq!(choose_epsilon(None, &fine).value, PRECISION_FACTOR * 1e-5);
        // 6 decimals there: 2.1 q is under it, the relative epsilon stays.
        let finer = model(
            "v a 0 0 0; v b 10.392305 6.000001 0; v c 10.392305 6.000001 2.8; v d 0 0 2.8; \
             f w (a b c d);",
        );
        assert_eq!(choose_epsilon(None, &finer).source, Source::Relative);
    }

    fn m_face(m: &ug::Model, k: usize) -> Vec<geom::DVec3> {
        m.faces[k].contours[0].iter().map(|&v| m.pos(v)).collect()
    }

    #[test]
    fn flat_faces_and_coarse_or_full_precision_keep_the_relative_epsilon() {
        // Axis-aligned with short decimals: flat, nothing to explain.
        let flat = model("v a 0 0 0; v b 2.5 0 0; v c 2.5 1.25 0; v d 0 1.25 0; f q (a b c d);");
        assert_eq!(choose_epsilon(None, &flat).source, Source::Relative);
        // Bent far beyond what the rounding explains (a twisted quad).
        let twisted = model("v a 0 0 0; v b 1 0 0; v c 1 1 0.3; v d 0 1 0; f q (a b c d);");
        assert_eq!(choose_epsilon(None, &twisted).source, Source::Relative);
        // Full precision: no power of ten to round to.
        let full = model(
            "v a 0 0 0; v b 3.14159265358979 1.4142135623731 0.577350269189626; \
             v c 2.44948974278318 3.60555127546399 2.71828182845905; \
             v d -0.692102 2.191398 2.1409312; f q (a b c d);",
        );
        assert_eq!(choose_epsilon(None, &full).source, Source::Relative);
        // A hand-written model in whole units, 30 units across, with a face
        // bent by a unit: its unit is 30,000 times the relative epsilon.
        let units =
            model("v a 0 0 0; v b 20 0 0; v c 20 20 1; v d 0 20 0; f q (a b c d); v e 10 10 10;");
        assert_eq!(choose_epsilon(None, &units).source, Source::Relative);
        // Whole centimetres on a 5.6 m model, with a face bent by the
        // rounding: the centimetre is past the limit (1,700 times the
        // relative epsilon), and the millimetre, which every coordinate is
        // a multiple of too, is not its precision (a rounded point lies up
        // to 5 mm off): the relative epsilon, not 2.1 mm.
        let cm = model("v a 0 0 0; v b 4.33 2.5 0; v c 4.34 2.5 2.8; v d 0 0 2.8; f w (a b c d);");
        let relative = relative_epsilon(&cm);
        assert!(1e-2 > PRECISION_LIMIT * relative && 1e-3 < PRECISION_LIMIT * relative);
        let (bend, _) = geom::Plane::face_deviation(&[m_face(&cm, 0)]).unwrap();
        assert!(bend > relative && bend < 2e-3, "{bend}");
        assert_eq!(choose_epsilon(None, &cm).source, Source::Relative);
        // One coordinate off the centimetres: whole millimetres, taken.
        let mm = model("v a 0 0 0; v b 4.331 2.5 0; v c 4.34 2.5 2.8; v d 0 0 2.8; f w (a b c d);");
        assert_eq!(choose_epsilon(None, &mm).value, PRECISION_FACTOR * 1e-3);
    }

    #[test]
    fn files_are_replaced_atomically_and_devices_written_in_place() {
        let dir = std::env::temp_dir().join(format!("cli-write-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("out.ug");
        std::fs::write(&f, "old").unwrap();
        write_output(Some(&f), b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "new");
        // No temporary file is left behind.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        #[cfg(unix)]
        {
            // A replaced file keeps its permissions.
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o640)).unwrap();
            write_output(Some(&f), b"newer").unwrap();
            let mode = std::fs::metadata(&f).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o640);
        }
        std::fs::remove_dir_all(&dir).unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            let null = Path::new("/dev/null");
            if std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
                write_output(Some(null), b"discarded").unwrap();
                let m = std::fs::metadata(null).unwrap();
                assert!(
                    m.file_type().is_char_device(),
                    "/dev/null must stay a device"
                );
            }
        }
    }
}

/// Checks every tool's integration tests share: the command line contract
/// (`--help` with examples, `--version` naming the tool, exit 2 on a bad
/// option) and running the built binary with bytes on stdin.
pub mod testkit {
    use std::io::Write;
    use std::process::{Command, Output, Stdio};

    /// Runs `exe` with `args` and `stdin` piped in (closed afterwards).
    pub fn run_with_stdin(exe: &str, args: &[&str], stdin: &[u8]) -> Output {
        let mut child = Command::new(exe)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {exe}: {e}"));
        let mut si = child.stdin.take().expect("stdin");
        // The tool may exit before reading everything (an early error).
        let _ = si.write_all(stdin);
        drop(si);
        child.wait_with_output().expect("wait for the tool")
    }

    /// `--help` succeeds with a usage line and examples; `--version` prints
    /// `NAME VERSION`.
    pub fn assert_help_and_version(exe: &str, name: &str, version: &str) {
        let help = run_with_stdin(exe, &["--help"], b"");
        assert!(help.status.success());
        let text = String::from_utf8(help.stdout).expect("UTF-8 help");
        assert!(text.contains("Examples:"), "{text}");
        assert!(text.contains(&format!("Usage: {name}")), "{text}");
        let v = run_with_stdin(exe, &["--version"], b"");
        assert!(v.status.success());
        assert_eq!(
            String::from_utf8(v.stdout).expect("UTF-8"),
            format!("{name} {version}\n")
        );
    }

    /// An unknown option is a usage error: exit status 2, nothing on stdout.
    pub fn assert_unknown_option_is_usage_error(exe: &str) {
        let out = run_with_stdin(exe, &["--no-such-option"], b"");
        assert_eq!(out.status.code(), Some(2));
        assert!(out.stdout.is_empty());
    }
}
