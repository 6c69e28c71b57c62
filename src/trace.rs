//! `lgc trace`: guaranteed first hits for rays read from text.

use anyhow::Context as _;
use glam::DVec3;
use lgc::bounds::Aabb;
use lgc::intersect::Intersector;
use lgc::Formula;
use rayon::prelude::*;
use std::io::Write;

/// Rays per parallel task: large enough to amortise a tracer's setup.
const CHUNK: usize = 256;

/// Parses the rays in `input`, answers them in parallel and prints one line
/// per ray, in order: the first hit `t` to 17 significant digits, or `none`.
pub fn run(formula: &Formula, bounds: &Aabb, depth: u32, input: &str) -> anyhow::Result<()> {
    let mut rays = Vec::new();
    for (i, line) in input.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let nums: Vec<f64> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>())
            .collect::<Result<_, _>>()
            .ok()
            .filter(|v: &Vec<f64>| v.len() == 6 && v.iter().all(|x| x.is_finite()))
            .with_context(|| {
                format!(
                    "line {}: expected six finite numbers `ox oy oz dx dy dz`, found `{line}`",
                    i + 1
                )
            })?;
        rays.push((
            DVec3::new(nums[0], nums[1], nums[2]),
            DVec3::new(nums[3], nums[4], nums[5]),
        ));
    }
    let scene = Intersector::new(formula, bounds, depth);
    let answers: Vec<Option<f64>> = rays
        .par_chunks(CHUNK)
        .map_init(
            || scene.tracer(),
            |tracer, chunk| {
                chunk
                    .iter()
                    .map(|&(o, d)| tracer.first_hit(o, d, 0.0, f64::INFINITY))
                    .collect::<Vec<_>>()
            },
        )
        .flatten()
        .collect();
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for answer in answers {
        match answer {
            Some(t) => writeln!(out, "{t:.16e}")?,
            None => writeln!(out, "none")?,
        }
    }
    out.flush()?;
    Ok(())
}
