//! Prints the tightness table of `docs/bounds.md`: for every corpus surface (and a
//! Chmutov sextic), L over its box split into 8³ = 512 sub-boxes by each
//! enclosure method, against the certified lower end of a 0.01 % bracket of
//! the true maximum (a bound can never be below it), with the time the
//! natural and the default method took.
//!
//! cargo run --release --example tightness

use glam::DVec3;
use lgc::bounds::{bracket_lipschitz, Bounder, Method};
use lgc::Aabb;
use lgc::Formula;
use std::time::Instant;

/// Chmutov's sextic, `T6(x) + T6(y) + T6(z)` with the Chebyshev polynomial
/// `T6(u) = 32u⁶ − 48u⁴ + 18u² − 1`: not in the corpus, and a
/// hard case for the natural extension.
const CHMUTOV: &str = "32*x^6-48*x^4+18*x^2+32*y^6-48*y^4+18*y^2+32*z^6-48*z^4+18*z^2-3";

fn main() {
    let text = include_str!("surfaces.json");
    let corpus: serde_json::Value = serde_json::from_str(text).expect("valid JSON");
    let mut cases: Vec<(String, String, Vec<f64>)> = corpus
        .as_object()
        .expect("an object of surfaces")
        .iter()
        .map(|(name, s)| {
            let b = s["box"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            (name.clone(), s["expr"].as_str().unwrap().to_string(), b)
        })
        .collect();
    cases.push((
        "chmutov (extra)".into(),
        CHMUTOV.into(),
        vec![-1.1, -1.1, -1.1, 1.1, 1.1, 1.1],
    ));
    let methods = Method::ALL;
    print!("| surface | box | max \\|∇f\\| ≥ |");
    for m in methods {
        print!(" {} |", m.name());
    }
    println!(" time (natural / best) |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for (name, expr, b) in &cases {
        let region = Aabb::new(DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5])).unwrap();
        let formula = Formula::parse(expr).unwrap();
        let bounder = Bounder::new(&formula);
        let lower = bracket_lipschitz(&bounder, &region, 1e-4, 1_000_000).lower;
        let mut times = Vec::new();
        let cells: Vec<String> = methods
            .iter()
            .map(|&m| {
                // Taylor models of a polynomial are its Bernstein form.
                let applies = match m {
                    Method::Bernstein => bounder.is_polynomial(),
                    Method::Taylor => !bounder.is_polynomial() && bounder.expands(&region),
                    _ => true,
                };
                if !applies {
                    return "—".into();
                }
                let start = Instant::now();
                let l = bounder.lipschitz_bound_by(&region, 3, m).value;
                times.push((m, start.elapsed().as_secs_f64()));
                format!("{} ({:.3}×)", sig(l), l / lower)
            })
            .collect();
        let time = |m| {
            times
                .iter()
                .find(|t| t.0 == m)
                .map_or(0.0, |t| t.1 * 1000.0)
        };
        let extent = if b[0] == b[1] && b[1] == b[2] && b[3] == b[4] && b[4] == b[5] {
            format!("[{}, {}]³", b[0], b[3])
        } else {
            format!(
                "[{}, {}]×[{}, {}]×[{}, {}]",
                b[0], b[3], b[1], b[4], b[2], b[5]
            )
        };
        println!(
            "| {name} | {extent} | {} | {} | {:.0} / {:.0} ms |",
            sig(lower),
            cells.join(" | "),
            time(Method::Natural),
            time(Method::Best)
        );
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
