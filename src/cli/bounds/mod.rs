//! `lgc bounds`: the interval of f, L over a box and G over a ray segment,
//! each beside a sampled estimate of the true maximum.

use super::args::{fmt3, json_number, num, parse_count, Outcome, RegionArgs, SourceArgs};
use clap::Args;
mod corpus;
mod plot;

use lgc::bounds::{convergence, Bracket, Field, Method, Refine, MAX_PIECES};
use lgc::{Bound, Bounder};
use std::path::PathBuf;

/// Options of `lgc bounds`.
#[derive(Args, Debug)]
pub struct BoundsArgs {
    #[command(flatten)]
    source: SourceArgs,
    #[command(flatten)]
    region: RegionArgs,
    /// Subdivide N times (8^N sub-boxes, 2^N sub-segments); tighter bounds.
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=6))]
    split: u32,
    /// Refine by branch and bound until the true L (and G) is bracketed to
    /// this relative width: upper / lower <= 1 + R (e.g. 0.01).
    #[arg(long, value_name = "R", allow_hyphen_values = true, value_parser = parse_tolerance, conflicts_with = "split")]
    tolerance: Option<f64>,
    /// With --tolerance: stop after this many pieces, bracket or not.
    #[arg(long, value_name = "N", default_value_t = MAX_PIECES as u64, value_parser = parse_count, requires = "tolerance")]
    max_boxes: u64,
    /// How each piece's bound is enclosed: natural (interval extension),
    /// centred (mean-value form), bernstein (polynomials), taylor (Taylor
    /// models of sin, cos, exp, sinh, cosh), affine (reduced affine
    /// arithmetic), or best (the smallest of those that apply).
    #[arg(long, value_name = "METHOD", default_value = "best", value_parser = parse_method)]
    method: Method,
    /// Write a plot of L / max |grad f| against subdivision depth 0..5, one
    /// line per method (.png or .svg), and print the same table.
    #[arg(long, value_name = "PLOT", conflicts_with_all = ["split", "tolerance"])]
    convergence: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Instead of one formula: every surface of a corpus file (a JSON
    /// object of {"expr": …, "box": [x0, y0, z0, x1, y1, z1]} by name, as
    /// examples/surfaces.json), L over its box split 8^N ways (--split) by
    /// every method that applies, timed, beside a certified bracket of the
    /// true maximum: the tightness table of docs/bounds.md. Repeatable.
    #[arg(long, value_name = "FILE.json", conflicts_with_all = ["expr", "file", "region", "ray", "tolerance", "convergence", "method"])]
    corpus: Vec<PathBuf>,
}

/// An enclosure method by name.
fn parse_method(text: &str) -> Result<Method, String> {
    Method::from_name(text)
        .ok_or_else(|| format!("`{text}` is not a method: use {}", Method::names()))
}

/// A relative tolerance: a positive finite number.
/// The finest relative tolerance a bracket is asked for: a few hundred
/// ulps, which the outward roundings of its two ends leave room for.
const MIN_TOLERANCE: f64 = 1e-13;

fn parse_tolerance(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(r) if r >= MIN_TOLERANCE && r.is_finite() => Ok(r),
        // A bracket's ends are each rounded outward: their ratio cannot
        // come within a few ulps of 1, and pieces would be split for ever.
        Ok(r) if r > 0.0 => Err(format!(
            "`{text}` is finer than f64 can bracket: its bounds are rounded outward by a few ulps each; use {MIN_TOLERANCE:e} or more"
        )),
        _ => Err(format!(
            "`{text}` is not a relative tolerance: give a positive number such as 0.01"
        )),
    }
}

/// Help shown under `lgc bounds --help`.
pub const HELP: &str = "L is a sound upper bound of |grad f| over the box (Euclidean norm), so\n\
|f(p) - f(q)| <= L |p - q| there. G bounds |g'(t)|, g(t) = d . grad f(o + t d), with d as\n\
given (not normalised). Either is reported as infinite, with the reason, where the\n\
derivative is unbounded (sqrt at 0, 1/x across 0, a crease of abs/min/max crossed by\n\
the ray). The sampled estimate is a lower bound found by search; their ratio is the\n\
tightness of the bound. --method picks how each piece is enclosed (default best: the\n\
smallest of the natural interval extension, the centred form and, for polynomials,\n\
the Bernstein form of |grad f|^2, or for formulas of sin, cos, exp, sinh, cosh, Taylor\n\
models of order 6 bounded by it; for G the centred form is the natural one).\n\
With --tolerance R the box (or segment) is split, worst piece\n\
first, until the true constant is bracketed: L_lower <= max |grad f| <= L with\n\
L <= (1 + R) L_lower, L_lower being certified at L_point (the lower end of an\n\
enclosure of |grad f| there). JSON: {\"f\": [lo, hi], \"L\": num, \"L_sampled\": num,\n\
\"L_point\": [x, y, z], ...} plus \"G\", \"G_sampled\", \"G_t\" with --ray, and with\n\
--tolerance \"L_lower\", \"pieces\", \"L_reached\" (and \"G_lower\", \"G_pieces\",\n\
\"G_reached\"); an infinite bound is null, with its reason in \"L_note\" or \"G_note\".";

/// Prints the interval of f, L (and G) beside sampled estimates, or their
/// certified brackets with `--tolerance`.
pub fn run(args: &BoundsArgs) -> Outcome {
    if !args.corpus.is_empty() {
        return corpus::run(&args.corpus, args.split, args.json);
    }
    let b = args
        .region
        .aabb()?
        .ok_or_else(|| anyhow::anyhow!("bounds needs --box X0,Y0,Z0,X1,Y1,Z1"))?;
    let seg = args.region.segment()?;
    let formula = args.source.formula()?;
    let (b, seg, split, json) = (&b, seg.as_ref(), args.split, args.json);
    let max_pieces = usize::try_from(args.max_boxes).unwrap_or(usize::MAX);
    let method = args.method;
    let bounder = Bounder::new(&formula);
    if method == Method::Bernstein && !bounder.is_polynomial() {
        return Err(anyhow::anyhow!(
            "--method bernstein needs a polynomial f (+, -, *, integer powers >= 0, constants) of degree at most 256 in each variable: use --method best"
        )
        .into());
    }
    if method == Method::Taylor && !bounder.expands(b) {
        return Err(anyhow::anyhow!(
            "--method taylor needs f built from +, -, *, integer powers, constants and sin, cos, exp, sinh, cosh, of degree at most 256 in each variable once expanded: use --method best"
        )
        .into());
    }
    if let Some(path) = &args.convergence {
        return run_convergence(&bounder, b, path, &args.source.title(), json);
    }
    let refine = match args.tolerance {
        None => Refine::Split(split),
        Some(tolerance) => Refine::Bracket {
            tolerance,
            max_pieces,
        },
    };
    let report = lgc::bounds::report(&bounder, b, seg, refine, method);
    if json {
        let obj: serde_json::Map<String, serde_json::Value> = report
            .fields()
            .into_iter()
            .map(|(key, value)| (key, json_field(value)))
            .collect();
        println!("{}", serde_json::Value::Object(obj));
        return Ok(0);
    }
    let f = report.f;
    let mut text = vec![if f.is_empty() {
        "f over the box  = empty: f is defined nowhere on the box, which has no surface".into()
    } else {
        format!("f over the box  = [{}, {}]", num(f.inf()), num(f.sup()))
    }];
    let l = &report.l;
    match (&l.bracket, args.tolerance) {
        (Some(br), Some(r)) => {
            bracket_lines(&mut text, "L", br, r);
            text.push(format!("L_lower at      = ({})", point(l.point)));
        }
        _ => text.extend([
            describe_bound("L", &l.bound),
            format!(
                "L sampled       = {} at ({})",
                num(l.sampled),
                point(l.point)
            ),
            format!("L tightness     = {}", ratio(&l.bound, l.sampled)),
        ]),
    }
    if let Some(g) = &report.g {
        let t = g.t.unwrap_or(f64::NAN);
        match (&g.bracket, args.tolerance) {
            (Some(br), Some(r)) => {
                bracket_lines(&mut text, "G", br, r);
                text.push(format!("G_lower at      = t = {}", num(t)));
            }
            _ => text.extend([
                describe_bound("G", &g.bound),
                format!("G sampled       = {} at t = {}", num(g.sampled), num(t)),
                format!("G tightness     = {}", ratio(&g.bound, g.sampled)),
            ]),
        }
    }
    println!("{}", text.join("\n"));
    Ok(0)
}

/// A report field as JSON: a number that is not finite is `null`.
fn json_field(value: Field) -> serde_json::Value {
    match value {
        Field::Number(v) => json_number(v),
        Field::Numbers(v) => v.into_iter().map(json_number).collect(),
        Field::Count(n) => n.into(),
        Field::Flag(b) => b.into(),
        Field::Text(t) => t.into(),
    }
}

/// Deepest level of the convergence table: 8⁵ = 32,768 boxes.
const CONVERGENCE_DEPTH: u32 = 5;

/// The convergence table on stdout (or in JSON) and its plot at `path`.
fn run_convergence(
    bounder: &Bounder,
    b: &lgc::Aabb,
    path: &std::path::Path,
    title: &str,
    json: bool,
) -> Outcome {
    let c = convergence(bounder, b, CONVERGENCE_DEPTH);
    plot::write(path, title, &c)?;
    if json {
        let mut obj = serde_json::Map::new();
        obj.insert("reference".into(), json_number(c.reference));
        obj.insert(
            "reference_point".into(),
            serde_json::json!([c.point.x, c.point.y, c.point.z]),
        );
        obj.insert("depths".into(), serde_json::json!(c.depths));
        for (m, values) in &c.methods {
            let v: Vec<_> = values.iter().map(|&l| json_number(l)).collect();
            obj.insert(m.name().into(), v.into());
        }
        println!("{}", serde_json::Value::Object(obj));
        return Ok(0);
    }
    println!(
        "L / max |grad f| by subdivision depth; max |grad f| >= {} (certified at {})",
        c.reference,
        point(c.point)
    );
    let mut header = format!("{:<6} {:>7}", "depth", "boxes");
    for (m, _) in &c.methods {
        header.push_str(&format!(" {:>10}", m.name()));
    }
    println!("{header}");
    for (k, &d) in c.depths.iter().enumerate() {
        let mut line = format!("{d:<6} {:>7}", 8u64.pow(d));
        for (_, values) in &c.methods {
            line.push_str(&format!(" {:>10.4}", values[k] / c.reference));
        }
        println!("{line}");
    }
    eprintln!("wrote {}", path.display());
    Ok(0)
}

/// `x, y, z` for text output.
fn point(p: glam::DVec3) -> String {
    fmt3(p).replace(',', ", ")
}

/// A bracket's lines: its ends and ratio, or its bound and lower end
/// where it is unbounded.
fn bracket_lines(text: &mut Vec<String>, name: &str, br: &Bracket, tolerance: f64) {
    let bound = Bound {
        value: br.upper,
        note: br.note.clone(),
    };
    if !br.upper.is_finite() {
        text.push(describe_bound(name, &bound));
        text.push(format!(
            "{:<15} = {}",
            format!("{name}_lower"),
            num(br.lower)
        ));
        return;
    }
    // 0.01 as written; 1e-12 rather than its forty decimals.
    let r = if tolerance >= 1e-4 {
        format!("{tolerance}")
    } else {
        format!("{tolerance:e}")
    };
    let width = if br.reached {
        format!("within {r}")
    } else {
        format!("NOT within {r}: the piece budget ran out, raise --max-boxes")
    };
    text.push(format!(
        "{name} bracket       = [{}, {}]  ratio {:.6} ({width}, {} pieces)",
        num(br.lower),
        num(br.upper),
        br.ratio(),
        br.pieces
    ));
}

fn describe_bound(name: &str, b: &Bound) -> String {
    match (&b.note, b.value.is_finite()) {
        (Some(note), false) => format!("{name:<15} = infinite: {note}"),
        (Some(note), true) => format!("{name:<15} = {} ({note})", num(b.value)),
        (None, _) => format!("{name:<15} = {}", num(b.value)),
    }
}

fn ratio(b: &Bound, sampled: f64) -> String {
    if !b.value.is_finite() {
        "unbounded".into()
    } else if sampled > 0.0 {
        match b.value / sampled {
            r if r < 1e6 => format!("{r:.4} (bound / sampled)"),
            r => format!("{r:.4e} (bound / sampled)"),
        }
    } else {
        "n/a (sampled maximum is 0)".into()
    }
}
