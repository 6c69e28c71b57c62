//! `lgc bounds`: the interval of f, L over a box and G over a ray segment,
//! each beside a sampled estimate of the true maximum.

use super::args::{fmt3, json_number, Outcome, RegionArgs, SourceArgs};
use clap::Args;
use lgc::{Bound, Bounder};

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
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

/// Help shown under `lgc bounds --help`.
pub const HELP: &str = "L is a sound upper bound of |grad f| over the box (Euclidean norm), so\n\
|f(p) - f(q)| <= L |p - q| there. G bounds |g'(t)|, g(t) = d . grad f(o + t d), with d as\n\
given (not normalised). Either is reported as infinite, with the reason, where the\n\
derivative is unbounded (sqrt at 0, 1/x across 0, a crease of abs/min/max crossed by\n\
the ray). The sampled estimate is a lower bound found by search; their ratio is the\n\
tightness of the bound. JSON: {\"f\": [lo, hi], \"L\": num, \"L_sampled\": num,\n\
\"L_point\": [x, y, z], ...} plus \"G\", \"G_sampled\" with --ray; an infinite bound\n\
is null, with its reason in \"L_note\" or \"G_note\".";

/// Prints the interval of f, L (and G) beside sampled estimates.
pub fn run(args: &BoundsArgs) -> Outcome {
    let b = args
        .region
        .aabb()?
        .ok_or_else(|| anyhow::anyhow!("bounds needs --box X0,Y0,Z0,X1,Y1,Z1"))?;
    let seg = args.region.segment()?;
    let formula = args.source.formula()?;
    let (b, seg, split, json) = (&b, seg.as_ref(), args.split, args.json);
    let bounder = Bounder::new(&formula);
    let f = bounder.f_and_gradient(b)[0];
    let l = bounder.lipschitz_bound(b, split);
    let ls = bounder.sample_gradient(b, 24);
    let mut obj = serde_json::Map::new();
    obj.insert(
        "f".into(),
        serde_json::json!([json_number(f.inf()), json_number(f.sup())]),
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
        obj.insert("G_t".into(), json_number(t));
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
    Ok(0)
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
    obj.insert(name.into(), json_number(b.value));
    obj.insert(format!("{name}_sampled"), json_number(sampled));
    if b.value.is_finite() && sampled > 0.0 {
        obj.insert(format!("{name}_ratio"), json_number(b.value / sampled));
    }
    if let Some(note) = &b.note {
        obj.insert(format!("{name}_note"), note.clone().into());
    }
}
