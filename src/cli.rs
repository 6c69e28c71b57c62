//! Command-line interface: argument definitions and the subcommands.

use anyhow::Context as _;
use clap::{Args, Parser, Subcommand};
use glam::DVec3;
use lgc::bounds::{Aabb, Bound, Bounder, Segment};
use lgc::{Evaluator, Formula, FormulaError, Interval, Output, Verdict};
use std::fmt;
use std::io::Read;

/// Compile an implicit surface f(x,y,z) = 0 into exact derivatives, sound
/// Lipschitz bounds and guaranteed ray intersections; render formulas and scenes.
#[derive(Parser, Debug)]
#[command(name = "lgc", version, after_long_help = lgc::functions::language_reference())]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the simplified partial derivatives of f (and with --directional, g and g').
    #[command(after_long_help = lgc::functions::language_reference())]
    Grad {
        #[command(flatten)]
        source: SourceArgs,
        /// Also print g = dx*df/dx + dy*df/dy + dz*df/dz and g' = d^T H d.
        #[arg(long)]
        directional: bool,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Evaluate f and its gradient (and g, g' with --dir) at a point.
    #[command(after_long_help = lgc::functions::language_reference())]
    Eval {
        #[command(flatten)]
        source: SourceArgs,
        /// The point X,Y,Z (negative values are fine: --at -1,-2,-3).
        #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_numbers::<3>)]
        at: [f64; 3],
        /// A ray direction DX,DY,DZ: also print g and g' along it.
        #[arg(long, value_name = "DX,DY,DZ", allow_hyphen_values = true, value_parser = parse_numbers::<3>)]
        dir: Option<[f64; 3]>,
        /// Print one JSON object: {"f", "grad"} plus {"g", "dg"} with --dir.
        #[arg(long)]
        json: bool,
    },
    /// Sound bounds over a box: the interval of f and L >= max |grad f| (with
    /// --ray, G >= max |g'| on a segment), each beside a sampled estimate.
    #[command(after_long_help = BOUNDS_HELP)]
    Bounds {
        #[command(flatten)]
        source: SourceArgs,
        #[command(flatten)]
        region: RegionArgs,
        /// Subdivide N times (8^N sub-boxes, 2^N sub-segments); tighter bounds.
        #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=6))]
        split: u32,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Render the surface to an image (PNG or PPM, by extension), with no
    /// missed surface: every ray is answered by the guaranteed intersector.
    #[command(after_long_help = SCENE_HELP)]
    Render {
        #[command(flatten)]
        source: SourceArgs,
        #[command(flatten)]
        options: crate::render_cmd::RenderArgs,
    },
    /// Benchmark: render corpus surfaces (no files written) and report time,
    /// rays per second, and f and interval evaluations per ray.
    Bench {
        /// Corpus surfaces to render, by name.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "sphere,torus,tangle_cube"
        )]
        surfaces: Vec<String>,
        /// Image side in pixels.
        #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=16384))]
        size: u32,
        /// Runs per surface; the median is reported.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
        repeat: u32,
        /// Worker threads (default: one per core).
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        threads: Option<u64>,
        /// Octree depth.
        #[arg(long, default_value_t = DEFAULT_DEPTH, value_parser = clap::value_parser!(u32).range(0..=10))]
        depth: u32,
    },
    /// Guaranteed first hits: reads rays "ox oy oz dx dy dz" from standard input,
    /// one per line, and prints the first hit t (o + t*d, t >= 0, inside the box)
    /// or "none" for each.
    Trace {
        #[command(flatten)]
        source: SourceArgs,
        /// The box X0,Y0,Z0,X1,Y1,Z1 that holds the surface.
        #[arg(long = "box", value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true, value_parser = parse_numbers::<6>, default_value = "-2,-2,-2,2,2,2")]
        region: [f64; 6],
        /// Octree depth (pruning resolution).
        #[arg(long, value_name = "N", default_value_t = DEFAULT_DEPTH, value_parser = clap::value_parser!(u32).range(0..=10))]
        depth: u32,
    },
    /// Prove or refute a hand-derived constant: max |grad f| <= C on the box, or
    /// max |g'| <= C on a ray segment. Exit 0 proved, 3 refuted, 4 undecided.
    Verify {
        #[command(flatten)]
        source: SourceArgs,
        #[command(flatten)]
        region: RegionArgs,
        /// The claimed L: a number or a constant expression such as "2*sqrt(3)".
        #[arg(
            long,
            value_name = "C",
            allow_hyphen_values = true,
            conflicts_with = "grad_lipschitz",
            required_unless_present = "grad_lipschitz"
        )]
        lipschitz: Option<String>,
        /// The claimed G (needs --ray and --t).
        #[arg(long, value_name = "C", allow_hyphen_values = true, requires = "ray")]
        grad_lipschitz: Option<String>,
        /// Give up after examining this many pieces.
        #[arg(long, value_name = "N", default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..))]
        max_boxes: u64,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
}

/// Octree depth used when --depth is not given.
pub const DEFAULT_DEPTH: u32 = 5;

const SCENE_HELP: &str = "SCENE FILES (lgc render scene.lgc)\n  \
let and fn bindings, then blocks:\n  \
camera { eye = (x, y, z); look_at = (x, y, z); up = (0, 0, 1); fov = 30; }\n  \
light { position = (x, y, z); color = (1, 1, 1); intensity = 1; }   (or direction = ...)\n  \
material NAME { color = (r, g, b); diffuse; specular; shininess; reflect; transparency; ior; checker; tile; }\n  \
object { surface = FORMULA; box = (x0, y0, z0, x1, y1, z1); material = NAME; }\n  \
sphere { center; radius; }  plane { normal; offset; extent; }  box { min; max; }\n  \
torus { center; major; minor; }  cylinder { center; radius; height; }\n  \
CSG in formulas: union intersect subtract blend translate rotate scale.\n  \
Command-line options override the file. See README.md for the full reference.";

const BOUNDS_HELP: &str =
    "L is a sound upper bound of |grad f| over the box (Euclidean norm), so\n\
|f(p) - f(q)| <= L |p - q| there. G bounds |g'(t)|, g(t) = d . grad f(o + t d), with d as\n\
given (not normalised). Either is reported as infinite, with the reason, where the\n\
derivative is unbounded (sqrt at 0, 1/x across 0, a crease of abs/min/max crossed by\n\
the ray). The sampled estimate is a lower bound found by search; their ratio is the\n\
tightness of the bound. JSON: {\"f\": [lo, hi], \"L\": num, \"L_sampled\": num,\n\
\"L_point\": [x, y, z], ...} plus \"G\", \"G_sampled\" with --ray; an infinite bound\n\
is null, with its reason in \"L_note\" or \"G_note\".";

/// A box, and optionally a ray segment.
#[derive(Args, Debug)]
struct RegionArgs {
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

/// The box of six numbers, or a one-line error when it is inverted.
pub fn aabb_from(b: [f64; 6]) -> anyhow::Result<Aabb> {
    let (lo, hi) = (DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]));
    match Aabb::new(lo, hi) {
        Some(a) => Ok(a),
        None => anyhow::bail!(
            "--box {lo},{hi} is inverted: each of X0,Y0,Z0 must not exceed X1,Y1,Z1",
            lo = fmt3(lo),
            hi = fmt3(hi)
        ),
    }
}

impl RegionArgs {
    fn aabb(&self) -> anyhow::Result<Option<Aabb>> {
        self.region.map(aabb_from).transpose()
    }

    fn segment(&self) -> anyhow::Result<Option<Segment>> {
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

pub fn fmt3(v: DVec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
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
        *o = p
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("`{p}` is not a finite number"))?;
    }
    Ok(out)
}

/// Where the formula comes from: the command line or a file.
#[derive(Args, Debug)]
struct SourceArgs {
    /// The formula, such as "x^2+y^2+z^2-1" (for render: or a .lgc file).
    #[arg(
        value_name = "EXPR",
        required_unless_present = "file",
        allow_hyphen_values = true
    )]
    expr: Option<String>,
    /// Read the formula from FILE ("-" reads standard input).
    #[arg(
        short = 'f',
        long = "file",
        value_name = "FILE",
        conflicts_with = "expr"
    )]
    file: Option<String>,
}

/// Why a command failed, already worded for the user.
pub enum Failure {
    /// A mistake in the formula, rendered with its source line and caret.
    Formula(String),
    /// Anything else: one line.
    Other(anyhow::Error),
    /// Not an error: the command's answer is carried by this exit code.
    Exit(u8),
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::Formula(rendered) => f.write_str(rendered),
            Failure::Other(e) => writeln!(f, "error: {e:#}"),
            Failure::Exit(_) => Ok(()),
        }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Other(e)
    }
}

/// The formula text and the name to show in diagnostics.
pub struct Source {
    /// The text.
    pub text: String,
    /// The name diagnostics show for it.
    pub origin: String,
}

impl SourceArgs {
    fn read(&self) -> anyhow::Result<Source> {
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
            // A scene or formula file named directly: `lgc render scene.lgc`.
            (Some(expr), None)
                if expr.ends_with(".lgc") && !expr.contains(['(', '^', '*', '+']) =>
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

    fn formula(&self) -> Result<Formula, Failure> {
        let source = self.read()?;
        Formula::parse(&source.text)
            .map_err(|e: FormulaError| Failure::Formula(e.render(&source.text, &source.origin)))
    }
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Grad {
            source,
            directional,
            json,
        } => grad(&source.formula()?, directional, json),
        Command::Eval {
            source,
            at,
            dir,
            json,
        } => eval(&source.formula()?, at, dir, json),
        Command::Bench {
            surfaces,
            size,
            repeat,
            threads,
            depth,
        } => {
            let threads = threads.map(|t| usize::try_from(t).unwrap_or(usize::MAX));
            crate::bench::run(&surfaces, size, repeat, threads, depth).map_err(Failure::Other)
        }
        Command::Render { source, options } => crate::render_cmd::run(&source.read()?, &options),
        Command::Trace {
            source,
            region,
            depth,
        } => {
            let b = aabb_from(region)?;
            let formula = source.formula()?;
            let mut input = String::new();
            std::io::stdin()
                .read_to_string(&mut input)
                .context("cannot read rays from standard input")?;
            crate::trace::run(&formula, &b, depth, &input).map_err(Failure::Other)
        }
        Command::Bounds {
            source,
            region,
            split,
            json,
        } => {
            let b = region
                .aabb()?
                .ok_or_else(|| anyhow::anyhow!("bounds needs --box X0,Y0,Z0,X1,Y1,Z1"))?;
            let seg = region.segment()?;
            bounds(&source.formula()?, &b, seg.as_ref(), split, json)
        }
        Command::Verify {
            source,
            region,
            lipschitz,
            grad_lipschitz,
            max_boxes,
            json,
        } => {
            let formula = source.formula()?;
            let max = usize::try_from(max_boxes).unwrap_or(usize::MAX);
            let code = if let Some(c) = lipschitz {
                let b = region.aabb()?.ok_or_else(|| {
                    anyhow::anyhow!("verify --lipschitz needs --box X0,Y0,Z0,X1,Y1,Z1")
                })?;
                let claim = constant(&c, "--lipschitz")?;
                let verdict = lgc::verify_lipschitz(&Bounder::new(&formula), &b, claim, max);
                report_verdict(verdict, "|grad f|", &c, json, |b: &Aabb| {
                    vec![b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z]
                })
            } else {
                let c = grad_lipschitz.unwrap_or_default();
                let seg = region.segment()?.ok_or_else(|| {
                    anyhow::anyhow!("verify --grad-lipschitz needs --ray and --t")
                })?;
                let claim = constant(&c, "--grad-lipschitz")?;
                let verdict = lgc::verify_grad_lipschitz(&Bounder::new(&formula), &seg, claim, max);
                report_verdict(verdict, "|g'|", &c, json, |s: &Segment| vec![s.t0, s.t1])
            };
            match code {
                0 => Ok(()),
                code => Err(Failure::Exit(code)),
            }
        }
    }
}

fn grad(formula: &Formula, directional: bool, json: bool) -> Result<(), Failure> {
    let mut rows = vec![
        ("df/dx", formula.print(formula.node(Output::Dfdx))),
        ("df/dy", formula.print(formula.node(Output::Dfdy))),
        ("df/dz", formula.print(formula.node(Output::Dfdz))),
    ];
    if directional {
        rows.push(("g", formula.print(formula.g())));
        rows.push(("dg", formula.print(formula.dg())));
    }
    if json {
        let mut obj = serde_json::Map::new();
        obj.insert(
            "grad".into(),
            serde_json::json!([rows[0].1, rows[1].1, rows[2].1]),
        );
        if directional {
            obj.insert("g".into(), rows[3].1.clone().into());
            obj.insert("dg".into(), rows[4].1.clone().into());
        }
        println!("{}", serde_json::Value::Object(obj));
    } else {
        for (name, text) in rows {
            println!("{name} = {text}");
        }
    }
    Ok(())
}

fn eval(formula: &Formula, at: [f64; 3], dir: Option<[f64; 3]>, json: bool) -> Result<(), Failure> {
    let mut outputs = vec![Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz];
    if dir.is_some() {
        outputs.extend([Output::G, Output::Dg]);
    }
    let tape = formula.tape(&outputs);
    let d = dir.unwrap_or([0.0; 3]);
    let values = Evaluator::<f64>::new(&tape)
        .eval(&[at[0], at[1], at[2], d[0], d[1], d[2]])
        .to_vec();
    if json {
        let mut obj = serde_json::Map::new();
        obj.insert("f".into(), number(values[0]));
        obj.insert(
            "grad".into(),
            serde_json::Value::Array(values[1..4].iter().map(|&v| number(v)).collect()),
        );
        if dir.is_some() {
            obj.insert("g".into(), number(values[4]));
            obj.insert("dg".into(), number(values[5]));
        }
        println!("{}", serde_json::Value::Object(obj));
    } else {
        let names = ["f", "df/dx", "df/dy", "df/dz", "g", "dg"];
        for (name, v) in names.iter().zip(&values) {
            println!("{name:<6} = {v}");
        }
    }
    Ok(())
}

/// A JSON number; NaN (a point outside the formula's domain) becomes null.
fn number(v: f64) -> serde_json::Value {
    serde_json::Number::from_f64(v).map_or(serde_json::Value::Null, serde_json::Value::Number)
}

/// Encloses a claimed constant given as a number or a constant expression.
fn constant(text: &str, flag: &str) -> Result<Interval, Failure> {
    let ast = lgc::parse(text).map_err(|e| Failure::Formula(e.render(text, flag)))?;
    let mut ctx = lgc::Context::new();
    let node =
        lgc::lower::lower(&mut ctx, &ast).map_err(|e| Failure::Formula(e.render(text, flag)))?;
    if !ctx.vars_used(node).is_empty() {
        return Err(anyhow::anyhow!(
            "{flag} {text}: the claimed constant may not depend on x, y or z"
        )
        .into());
    }
    let tape = lgc::Tape::new(&ctx, &[node]);
    let v = Evaluator::<Interval>::new(&tape).eval(&[Interval::point(0.0); 6])[0];
    if !v.is_bounded() {
        return Err(anyhow::anyhow!("{flag} {text} is not a finite number").into());
    }
    Ok(v)
}

/// Prints a verdict; returns the exit code (0 proved, 3 refuted, 4 undecided).
fn report_verdict<R>(
    verdict: Verdict<R>,
    what: &str,
    claim: &str,
    json: bool,
    region: impl Fn(&R) -> Vec<f64>,
) -> u8 {
    match verdict {
        Verdict::Proved { pieces } => {
            if json {
                let obj =
                    serde_json::json!({"verdict": "proved", "claim": claim, "pieces": pieces});
                println!("{obj}");
            } else {
                println!("proved: max {what} <= {claim} ({pieces} pieces checked)");
            }
            0
        }
        Verdict::Refuted {
            witness,
            t,
            value,
            pieces,
        } => {
            if json {
                let mut obj = serde_json::json!({
                    "verdict": "refuted", "claim": claim,
                    "witness": [witness.x, witness.y, witness.z],
                    "value": value, "pieces": pieces
                });
                if let Some(t) = t {
                    obj["t"] = number(t);
                }
                println!("{obj}");
            } else {
                let at_t = t.map(|t| format!(" (t = {t})")).unwrap_or_default();
                let p = fmt3(witness).replace(',', ", ");
                println!("refuted: {what} >= {value} > {claim} at ({p}){at_t}");
            }
            3
        }
        Verdict::Undecided {
            worst,
            bound,
            pieces,
        } => {
            let r = region(&worst);
            if json {
                let obj = serde_json::json!({
                    "verdict": "undecided", "claim": claim, "worst": r,
                    "bound": number(bound), "pieces": pieces
                });
                println!("{obj}");
            } else {
                println!(
                    "undecided after {pieces} pieces: the worst piece {r:?} still has bound {bound} > {claim}"
                );
            }
            4
        }
    }
}

fn bounds(
    formula: &Formula,
    b: &Aabb,
    seg: Option<&Segment>,
    split: u32,
    json: bool,
) -> Result<(), Failure> {
    let bounder = Bounder::new(formula);
    let f = bounder.f_and_gradient(b)[0];
    let l = bounder.lipschitz_bound(b, split);
    let ls = bounder.sample_gradient(b, 24);
    let mut obj = serde_json::Map::new();
    obj.insert(
        "f".into(),
        serde_json::json!([number(f.inf()), number(f.sup())]),
    );
    put_bound(&mut obj, "L", &l, ls.value);
    obj.insert(
        "L_point".into(),
        serde_json::json!([ls.point.x, ls.point.y, ls.point.z]),
    );
    let mut text = vec![
        format!("f over the box  = [{}, {}]", f.inf(), f.sup()),
        describe_bound("L", &l),
        format!(
            "L sampled       = {} at ({})",
            ls.value,
            fmt3(ls.point).replace(',', ", ")
        ),
        format!("L tightness     = {}", ratio(&l, ls.value)),
    ];
    if let Some(s) = seg {
        let g = bounder.grad_lipschitz_bound(s, split);
        let (gs, t) = bounder.sample_dg(s, 1025);
        put_bound(&mut obj, "G", &g, gs.value);
        obj.insert("G_t".into(), number(t));
        obj.insert(
            "G_point".into(),
            serde_json::json!([gs.point.x, gs.point.y, gs.point.z]),
        );
        text.push(describe_bound("G", &g));
        text.push(format!("G sampled       = {} at t = {t}", gs.value));
        text.push(format!("G tightness     = {}", ratio(&g, gs.value)));
    }
    if json {
        println!("{}", serde_json::Value::Object(obj));
    } else {
        println!("{}", text.join("\n"));
    }
    Ok(())
}

fn describe_bound(name: &str, b: &Bound) -> String {
    match (&b.note, b.value.is_finite()) {
        (Some(note), false) => format!("{name:<15} = infinite: {note}"),
        (Some(note), true) => format!("{name:<15} = {} ({note})", b.value),
        (None, _) => format!("{name:<15} = {}", b.value),
    }
}

fn ratio(b: &Bound, sampled: f64) -> String {
    if !b.value.is_finite() {
        "unbounded".into()
    } else if sampled > 0.0 {
        format!("{:.4} (bound / sampled)", b.value / sampled)
    } else {
        "n/a (sampled maximum is 0)".into()
    }
}

fn put_bound(
    obj: &mut serde_json::Map<String, serde_json::Value>,
    name: &str,
    b: &Bound,
    sampled: f64,
) {
    obj.insert(name.into(), number(b.value));
    obj.insert(format!("{name}_sampled"), number(sampled));
    if b.value.is_finite() && sampled > 0.0 {
        obj.insert(format!("{name}_ratio"), number(b.value / sampled));
    }
    if let Some(note) = &b.note {
        obj.insert(format!("{name}_note"), note.clone().into());
    }
}
