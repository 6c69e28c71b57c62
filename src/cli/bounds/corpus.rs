//! `lgc bounds --corpus`: the tightness table, every surface of a corpus
//! file by every method, timed, beside a certified bracket of the maximum.

use super::super::args::{json_number, Failure, Outcome};
use anyhow::Context as _;
use glam::DVec3;
use lgc::bounds::{tightness, Method};
use lgc::{Aabb, Bounder, Formula};
use std::path::PathBuf;

/// One surface of a corpus file.
struct Surface {
    name: String,
    expr: String,
    region: [f64; 6],
}

/// Reads a corpus file: a JSON object of `{"expr", "box"}` by name.
fn read(path: &PathBuf) -> anyhow::Result<Vec<Surface>> {
    let name = path.display();
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read corpus `{name}`"))?;
    let json: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("corpus `{name}` is not JSON"))?;
    let entries = json.as_object().with_context(|| {
        format!("corpus `{name}`: expected an object of surfaces by name, each {{\"expr\": ..., \"box\": [...]}}")
    })?;
    entries
        .iter()
        .map(|(surface, s)| {
            let expr = s["expr"].as_str().with_context(|| {
                format!("corpus `{name}`, surface `{surface}`: \"expr\" must be a formula string")
            })?;
            let region: Vec<f64> = s["box"]
                .as_array()
                .map(|b| b.iter().filter_map(|v| v.as_f64()).collect())
                .unwrap_or_default();
            let region: [f64; 6] = region.try_into().ok().with_context(|| {
                format!("corpus `{name}`, surface `{surface}`: \"box\" must be six numbers, x0, y0, z0, x1, y1, z1")
            })?;
            Ok(Surface {
                name: surface.clone(),
                expr: expr.to_string(),
                region,
            })
        })
        .collect()
}

/// Prints the tightness of every surface of the corpus files.
pub fn run(files: &[PathBuf], split: u32, json: bool) -> Outcome {
    let mut surfaces = Vec::new();
    for file in files {
        surfaces.extend(read(file)?);
    }
    // Every surface is read and checked before any is bounded.
    let mut prepared = Vec::new();
    for s in &surfaces {
        let formula = Formula::parse(&s.expr)
            .map_err(|e| Failure::Formula(e.render(&s.expr, &format!("surface `{}`", s.name))))?;
        let b = s.region;
        let region = Aabb::new(DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]))
            .filter(|a| a.hi.cmpgt(a.lo).all())
            .with_context(|| {
                format!(
                    "surface `{}`: the box {b:?} must be finite, each side of positive length",
                    s.name
                )
            })?;
        prepared.push((s, Bounder::new(&formula), region));
    }
    let mut rows = Vec::new();
    if !json {
        print!("| surface | box | max \\|∇f\\| ≥ |");
        for m in Method::ALL {
            print!(" {} |", m.name());
        }
        println!(" time (natural / best) |");
        println!("|---|---|---:|{}---:|", "---:|".repeat(Method::ALL.len()));
    }
    // One thread, so that the times compare methods rather than cores.
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .context("cannot start a thread")?;
    for (s, bounder, region) in &prepared {
        let t = one.install(|| tightness(bounder, region, split));
        let lower = t.maximum.lower;
        if json {
            let methods: serde_json::Map<String, serde_json::Value> = t
                .methods
                .iter()
                .map(|m| {
                    let value = serde_json::json!({
                        "L": json_number(m.bound),
                        "ratio": json_number(m.bound / lower),
                        "seconds": m.seconds,
                    });
                    (m.method.name().to_string(), value)
                })
                .collect();
            let p = t.maximum.point;
            rows.push(serde_json::json!({
                "name": s.name, "expr": s.expr, "box": s.region,
                "max_lower": json_number(lower), "max_upper": json_number(t.maximum.upper),
                "max_point": [p.x, p.y, p.z], "methods": methods,
            }));
            continue;
        }
        let cells: Vec<String> = Method::ALL
            .iter()
            .map(|&m| match t.methods.iter().find(|b| b.method == m) {
                Some(b) => format!("{} ({:.3}×)", sig(b.bound), b.bound / lower),
                None => "—".into(),
            })
            .collect();
        let ms = |m: Method| {
            t.methods
                .iter()
                .find(|b| b.method == m)
                .map_or(0.0, |b| b.seconds * 1000.0)
        };
        println!(
            "| {} | {} | {} | {} | {:.0} / {:.0} ms |",
            s.name,
            extent(&s.region),
            sig(lower),
            cells.join(" | "),
            ms(Method::Natural),
            ms(Method::Best)
        );
    }
    if json {
        println!("{}", serde_json::json!({"split": split, "surfaces": rows}));
    }
    Ok(0)
}

/// A box as `[a, b]³`, or `[a, b]×[c, d]×[e, f]`.
fn extent(b: &[f64; 6]) -> String {
    if b[0] == b[1] && b[1] == b[2] && b[3] == b[4] && b[4] == b[5] {
        format!("[{}, {}]³", b[0], b[3])
    } else {
        format!(
            "[{}, {}]×[{}, {}]×[{}, {}]",
            b[0], b[3], b[1], b[4], b[2], b[5]
        )
    }
}

/// Four significant digits.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}
