//! Prints the tightness table of the README: for every corpus surface, the
//! automatic L over its box and over its 8 and 64 sub-boxes, against the
//! largest |∇f| a search of the box finds (a lower bound of the true maximum).
//!
//! cargo run --release --example tightness

use glam::DVec3;
use lgc::bounds::Bounder;
use lgc::Aabb;
use lgc::Formula;

fn main() {
    let text = include_str!("surfaces.json");
    let corpus: serde_json::Value = serde_json::from_str(text).expect("valid JSON");
    println!("| surface | box | sampled max \\|∇f\\| | L (1 box) | L (8 boxes) | L (64 boxes) |");
    println!("|---|---|---:|---:|---:|---:|");
    for (name, s) in corpus.as_object().expect("an object of surfaces") {
        let b: Vec<f64> = s["box"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let region = Aabb::new(DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5])).unwrap();
        let formula = Formula::parse(s["expr"].as_str().unwrap()).unwrap();
        let bounder = Bounder::new(&formula);
        let sampled = bounder.sample_gradient(&region, 32).value;
        let cell = |depth| {
            let l = bounder.lipschitz_bound(&region, depth).value;
            format!("{} ({:.2}×)", sig(l), l / sampled)
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
            "| {name} | {extent} | {} | {} | {} | {} |",
            sig(sampled),
            cell(0),
            cell(1),
            cell(2)
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
