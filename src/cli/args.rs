//! What every subcommand shares: where the formula comes from, boxes and ray
//! segments, number lists, the octree depth, and how failures are worded.

use anyhow::Context as _;
use clap::Args;
use glam::DVec3;
use lgc::render::whitted::MAX_RAY_DEPTH;
use lgc::{Aabb, Evaluator, Formula, FormulaError, Interval, Output, Segment};
use std::fmt;
use std::io::{IsTerminal, Read};

/// Octree depth used when --depth is not given.
pub const DEFAULT_DEPTH: u32 = 5;

/// The deepest octree any command accepts (8^10 boxes at most; the octree's
/// node budget stops subdivision earlier where pruning cannot thin it out).
pub const MAX_DEPTH: u32 = 10;

/// Parses `--depth`, the same way for every command.
pub fn parse_depth(text: &str) -> Result<u32, String> {
    match text.trim().parse::<u32>() {
        Ok(d) if d <= MAX_DEPTH => Ok(d),
        _ => Err(format!(
            "use a whole number from 0 to {MAX_DEPTH} (8^{MAX_DEPTH} boxes at most)"
        )),
    }
}

/// Parses a count of at least 1 (a budget of pieces or repeats).
pub fn parse_count(text: &str) -> Result<u64, String> {
    match text.trim().parse::<u64>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("use a whole number of at least 1, not `{text}`")),
    }
}

/// Parses `--max-depth`: reflections and refractions a ray may follow.
pub fn parse_ray_depth(text: &str) -> Result<u32, String> {
    match text.trim().parse::<u32>() {
        Ok(d) if d <= MAX_RAY_DEPTH => Ok(d),
        _ => Err(format!(
            "use a whole number from 0 to {MAX_RAY_DEPTH}, not `{text}`"
        )),
    }
}

/// Why a command failed, already worded for the user.
pub enum Failure {
    /// A mistake in the formula, rendered with its source line and caret.
    Formula(String),
    /// Anything else: one line.
    Other(anyhow::Error),
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::Formula(rendered) => f.write_str(rendered),
            Failure::Other(e) => writeln!(f, "error: {e:#}"),
        }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Other(e)
    }
}

impl From<std::io::Error> for Failure {
    fn from(e: std::io::Error) -> Self {
        Failure::Other(e.into())
    }
}

/// What a finished command answers: its exit code (0, or 3 and 4 for
/// `verify`'s refuted and undecided).
pub type Outcome = Result<u8, Failure>;

/// Where the formula comes from: the command line or a file.
#[derive(Args, Debug)]
pub struct SourceArgs {
    /// The formula, such as "x^2+y^2+z^2-1", or a file: a .lgc formula (or,
    /// for render and mesh, scene) or a .vm model in fidget's format.
    #[arg(
        value_name = "EXPR",
        required_unless_present = "file",
        allow_hyphen_values = true
    )]
    expr: Option<String>,
    /// Read the formula from FILE ("-" reads standard input); a FILE ending
    /// in .vm is a model in fidget's format.
    #[arg(
        short = 'f',
        long = "file",
        value_name = "FILE",
        conflicts_with = "expr"
    )]
    file: Option<String>,
}

/// The formula text and the name to show in diagnostics.
pub struct Source {
    /// The text.
    pub text: String,
    /// The name diagnostics show for it.
    pub origin: String,
}

/// Whether `path` names a model in fidget's `.vm` format (by its extension).
fn is_vm(path: &str) -> bool {
    path.ends_with(".vm")
}

impl Source {
    /// Whether the text is a model in fidget's `.vm` format: it came from a
    /// file whose name ends in `.vm`.
    pub fn is_vm(&self) -> bool {
        is_vm(&self.origin)
    }

    /// Parses the formula, from the formula language or, for a `.vm` file,
    /// fidget's format.
    pub fn formula(&self) -> Result<Formula, Failure> {
        let parsed = if self.is_vm() {
            Formula::parse_vm(&self.text)
        } else {
            Formula::parse(&self.text)
        };
        parsed.map_err(|e| self.located(e))
    }

    /// A mistake in this source, rendered with its line and caret.
    pub fn located(&self, e: FormulaError) -> Failure {
        Failure::Formula(e.render(&self.text, &self.origin))
    }
}

impl SourceArgs {
    /// A short name for the formula in titles: its text as given, or the
    /// file it comes from.
    pub fn title(&self) -> String {
        let full = match (&self.expr, &self.file) {
            (_, Some(path)) if path == "-" => "formula from standard input".to_string(),
            (_, Some(path)) => path.clone(),
            (Some(expr), None) => expr.clone(),
            (None, None) => String::new(),
        };
        let short: String = full.chars().take(70).collect();
        if short.len() < full.len() {
            format!("{short}…")
        } else {
            short
        }
    }

    /// Reads the formula or scene text.
    pub fn read(&self) -> anyhow::Result<Source> {
        match (&self.expr, &self.file) {
            (_, Some(path)) if path == "-" => {
                let mut text = String::new();
                std::io::stdin()
                    .read_to_string(&mut text)
                    .context("cannot read the formula from standard input")?;
                Ok(Source {
                    text,
                    origin: "<stdin>".into(),
                })
            }
            (_, Some(path)) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read formula file `{path}`"))?;
                Ok(Source {
                    text,
                    origin: path.clone(),
                })
            }
            // A scene, formula or model file named directly: `lgc render
            // scene.lgc`, `lgc trace bear.vm`.
            (Some(expr), None)
                if (expr.ends_with(".lgc") || is_vm(expr))
                    && !expr.contains(['(', '^', '*', '+']) =>
            {
                let text = std::fs::read_to_string(expr)
                    .with_context(|| format!("cannot read `{expr}`"))?;
                Ok(Source {
                    text,
                    origin: expr.clone(),
                })
            }
            (Some(expr), None) => Ok(Source {
                text: expr.clone(),
                origin: "<formula>".into(),
            }),
            (None, None) => anyhow::bail!("give a formula or --file"),
        }
    }

    /// Reads and parses the formula.
    pub fn formula(&self) -> Result<Formula, Failure> {
        self.read()?.formula()
    }
}

/// A box, and optionally a ray segment.
#[derive(Args, Debug)]
pub struct RegionArgs {
    /// The box X0,Y0,Z0,X1,Y1,Z1.
    #[arg(long = "box", value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true, value_parser = parse_numbers::<6>)]
    region: Option<[f64; 6]>,
    /// A ray OX,OY,OZ,DX,DY,DZ (its segment is given by --t).
    #[arg(long, value_name = "OX,OY,OZ,DX,DY,DZ", allow_hyphen_values = true, value_parser = parse_numbers::<6>, requires = "t")]
    ray: Option<[f64; 6]>,
    /// The segment T1,T2 of the ray.
    #[arg(long, value_name = "T1,T2", allow_hyphen_values = true, value_parser = parse_numbers::<2>, requires = "ray")]
    t: Option<[f64; 2]>,
}

impl RegionArgs {
    /// The box, if given.
    pub fn aabb(&self) -> anyhow::Result<Option<Aabb>> {
        self.region.map(aabb_from).transpose()
    }

    /// The ray segment, if given.
    pub fn segment(&self) -> anyhow::Result<Option<Segment>> {
        let (Some(r), Some([t0, t1])) = (self.ray, self.t) else {
            return Ok(None);
        };
        let (o, d) = (DVec3::new(r[0], r[1], r[2]), DVec3::new(r[3], r[4], r[5]));
        match Segment::new(o, d, t0, t1) {
            Some(s) => Ok(Some(s)),
            None => anyhow::bail!("--t {t0},{t1} is inverted: T1 must not exceed T2"),
        }
    }
}

/// The box of six numbers, or a one-line error when it is inverted.
pub fn aabb_from(b: [f64; 6]) -> anyhow::Result<Aabb> {
    let (lo, hi) = (DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]));
    match Aabb::new(lo, hi) {
        // Tolerances and pads are fractions of the diagonal: it must be a
        // number, with room for the pad beyond the box.
        Some(a) if !(a.diagonal() * 2.0).is_finite() || !(a.lo.abs().max(a.hi.abs()) * 2.0).is_finite() => anyhow::bail!(
            "--box {lo},{hi} is too large: its diagonal and coordinates must stay below about 8e307 for lengths and pads to be f64 numbers",
            lo = fmt3(lo),
            hi = fmt3(hi)
        ),
        Some(a) => Ok(a),
        None => anyhow::bail!(
            "--box {lo},{hi} is inverted: each of X0,Y0,Z0 must not exceed X1,Y1,Z1",
            lo = fmt3(lo),
            hi = fmt3(hi)
        ),
    }
}

/// A number as text: in exponent form when very large or small, so that
/// 1e200 is not printed as 201 digits. Every digit needed to read it back.
pub fn num(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-6..1e16).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// A point or vector as `x,y,z`, very large or small numbers in exponent form.
pub fn fmt3(v: DVec3) -> String {
    format!("{},{},{}", num(v.x), num(v.y), num(v.z))
}

/// Parses `N` comma-separated finite numbers.
pub fn parse_numbers<const N: usize>(text: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!(
            "expected {N} comma-separated numbers, found {}",
            parts.len()
        ));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = lgc::lang::read_number(p).map_err(|why| format!("`{p}` {why}"))?;
    }
    Ok(out)
}

/// A worker pool of `threads` threads (one per core when `None`).
pub fn thread_pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    if threads == Some(0) {
        anyhow::bail!("--threads 0: use at least one thread");
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .start_handler(|_| reserve_worker_heap())
        .build()
        .context("cannot start worker threads")
}

/// Bytes of heap each worker thread's allocator is first grown by.
const WORKER_HEAP: usize = 8 << 20;

/// Grows the calling thread's heap once by [`WORKER_HEAP`], and hands it
/// back to the allocator, which keeps it (see `keep_freed_memory` in
/// `main.rs`). glibc's malloc grows a thread's heap by the pages each
/// allocation lacks, one `mprotect` call at a time, each taking the
/// process's memory map lock from under the other thread: a 1024² render
/// on two threads made 223 `mprotect` calls, 45 with this. The reserved
/// pages stay untouched, so resident memory does not grow.
fn reserve_worker_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    drop(std::hint::black_box(Vec::<u8>::with_capacity(WORKER_HEAP)));
}

/// A progress bar of `total` steps on a terminal's stderr; hidden elsewhere.
pub fn progress_bar(total: u64, unit: &str) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(total);
    let template = format!("{{elapsed_precise}} [{{bar:40}}] {{percent}}% of {unit}");
    bar.set_style(
        indicatif::ProgressStyle::with_template(&template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// A JSON number; NaN (a point outside the formula's domain) becomes null.
pub fn json_number(v: f64) -> serde_json::Value {
    serde_json::Number::from_f64(v).map_or(serde_json::Value::Null, serde_json::Value::Number)
}

/// What specialisation did, for summaries: `; S leaves specialised (K
/// shapes), C still creased (P with two smooth sides), T short tapes (I
/// instructions on average)`, or nothing for a formula with no branch
/// point.
pub fn specialisation(stats: &lgc::ray::OctreeStats) -> String {
    if stats.specialised == 0 && stats.creased == 0 {
        return String::new();
    }
    let mut text = format!(
        "; {} leaves specialised ({} shapes), {} still creased ({} with two smooth sides)",
        stats.specialised,
        stats.shapes.saturating_sub(1),
        stats.creased,
        stats.split
    );
    if stats.short_tapes > 0 {
        text += &format!(
            ", {} short tapes ({:.0} instructions on average)",
            stats.short_tapes,
            stats.short_instructions as f64 / stats.short_tapes as f64
        );
    }
    text
}

/// Warns on stderr when the octree stopped short of `depth`.
pub fn warn_if_capped(stats: &lgc::ray::OctreeStats, depth: u32) {
    if let Some(level) = stats.capped_at_depth {
        eprintln!(
            "warning: the octree stopped at depth {level} of {depth}: deeper would exceed its budget of {} nodes or {} instructions (pruning cannot thin this formula out, or it is very long); answers are as certain, rays slower",
            lgc::ray::octree::MAX_NODES,
            lgc::ray::octree::MAX_WORK
        );
    }
}

/// The enclosure of f over the box `b`.
pub fn f_over(formula: &Formula, b: &Aabb) -> Interval {
    let tape = formula.tape(&[Output::F]);
    let [x, y, z] = b.intervals();
    let zero = Interval::point(0.0);
    Evaluator::<Interval>::new(&tape).eval(&[x, y, z, zero, zero, zero])[0]
}

/// Says once, on stderr, that f is defined nowhere in the box `b`, where
/// that is so: every ray then misses, and this is why.
pub fn note_if_undefined(formula: &Formula, b: &Aabb) {
    if f_over(formula, b).is_empty() {
        eprintln!(
            "note: f is defined nowhere in the box {}..{}, so it has no surface there: every ray answers none",
            fmt3(b.lo),
            fmt3(b.hi)
        );
    }
}
