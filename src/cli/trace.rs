//! `lgc trace`: guaranteed first hits for rays read from text.

use super::args::{
    aabb_from, note_if_undefined, num, parse_depth, parse_numbers, warn_if_capped, Outcome,
    SourceArgs, DEFAULT_DEPTH,
};
use anyhow::Context as _;
use clap::Args;
use glam::DVec3;
use lgc::ray::bundle::clear_until;
use lgc::ray::{Answer, Intersector};
use lgc::{Aabb, Formula};
use rayon::prelude::*;
use std::io::{Read, Write};

/// Options of `lgc trace`.
#[derive(Args, Debug)]
pub struct TraceArgs {
    #[command(flatten)]
    source: SourceArgs,
    /// The box X0,Y0,Z0,X1,Y1,Z1 that holds the surface.
    #[arg(long = "box", value_name = "X0,Y0,Z0,X1,Y1,Z1", allow_hyphen_values = true, value_parser = parse_numbers::<6>, default_value = "-2,-2,-2,2,2,2")]
    region: [f64; 6],
    /// Octree depth (pruning resolution): at most N levels (a box where f is
    /// at most quadratic is a leaf at any level, a smooth algebraic one whose
    /// Lipschitz bound is tight from level 2).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_DEPTH, value_parser = parse_depth)]
    depth: u32,
    /// Trace the rays as one bundle, as `render` traces a tile's camera rays:
    /// the space in front of the surface is proved empty for all of them at
    /// once and each ray starts where that proof ends. All rays must share
    /// one origin.
    #[arg(long)]
    bundle: bool,
    /// The rays start at (or just off) the surface, as shadow and reflected
    /// rays do: each is first tested from its start, where F and g with G
    /// can clear a stretch that tests at the middle of a piece cannot.
    #[arg(long, conflicts_with = "bundle")]
    from_surface: bool,
}

/// Rays per parallel task: large enough to amortise a tracer's setup.
const CHUNK: usize = 256;

/// Reads rays from standard input and answers them.
pub fn run(args: &TraceArgs) -> Outcome {
    let b = aabb_from(args.region)?;
    let formula = args.source.formula()?;
    let mut input = String::new();
    std::io::stdin()
        .read_to_string(&mut input)
        .context("cannot read rays from standard input")?;
    let start = if args.bundle {
        Start::Bundle
    } else if args.from_surface {
        Start::Surface
    } else {
        Start::Free
    };
    answer(&formula, &b, args.depth, start, &input)?;
    Ok(0)
}

/// Where the rays start, and so how they are answered.
#[derive(Clone, Copy, PartialEq)]
enum Start {
    /// Anywhere: each ray on its own.
    Free,
    /// At one eye (`--bundle`): as a tile of camera rays.
    Bundle,
    /// At or just off the surface (`--from-surface`).
    Surface,
}

/// Parses the rays in `input`, answers them in parallel and prints one line
/// per ray, in order: the first hit `t` to 17 significant digits, `touch t`,
/// `undecided t`, or `none`. As one bundle (`--bundle`), every ray starts
/// where the bundle's proof of empty space ends.
fn answer(
    formula: &Formula,
    bounds: &Aabb,
    depth: u32,
    how: Start,
    input: &str,
) -> anyhow::Result<()> {
    let mut rays = Vec::new();
    for (i, line) in input.lines().enumerate() {
        // A `#` starts a comment, on a line of its own or after a ray.
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let words: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .collect();
        anyhow::ensure!(
            words.len() == 6,
            "line {}: expected six finite numbers `ox oy oz dx dy dz`, found `{line}`",
            i + 1
        );
        let nums = words
            .iter()
            .map(|w| {
                lgc::lang::read_number(w)
                    .map_err(|why| anyhow::anyhow!("line {}: `{w}` {why}", i + 1))
            })
            .collect::<anyhow::Result<Vec<f64>>>()?;
        let d = DVec3::new(nums[3], nums[4], nums[5]);
        anyhow::ensure!(
            d != DVec3::ZERO,
            "line {}: the direction (0, 0, 0) is not a ray: `{line}`",
            i + 1
        );
        rays.push((DVec3::new(nums[0], nums[1], nums[2]), d));
    }
    let scene = Intersector::new(formula, bounds, depth);
    warn_if_capped(&scene.octree_stats(), depth);
    note_if_undefined(formula, bounds);
    let start = match rays.first() {
        Some(&(eye, _)) if how == Start::Bundle => {
            if let Some(i) = rays.iter().position(|&(o, _)| o != eye) {
                anyhow::bail!(
                    "--bundle: every ray must leave the first ray's origin {eye}, but ray {} leaves {}",
                    i + 1,
                    rays[i].0
                );
            }
            let directions: Vec<DVec3> = rays.iter().map(|&(_, d)| d).collect();
            clear_until(&mut scene.tracer(), bounds, eye, &directions, 0.0)
        }
        _ => 0.0,
    };
    let answers: Vec<Answer> = rays
        .par_chunks(CHUNK)
        .map_init(
            || scene.tracer(),
            |tracer, chunk| {
                chunk
                    .iter()
                    .map(|&(o, d)| match how {
                        Start::Surface => tracer.answer_from_surface(o, d, start, f64::INFINITY),
                        _ => tracer.answer(o, d, start, f64::INFINITY),
                    })
                    .collect::<Vec<_>>()
            },
        )
        .flatten()
        .collect();
    let count = |kind: fn(&Answer) -> bool| answers.iter().filter(|a| kind(a)).count();
    let touches = count(|a| matches!(a, Answer::Touch(_)));
    if touches > 0 {
        eprintln!(
            "note: {touches} touch(es): f's enclosure held 0 within the tolerance {} (1e-10 of the box's diagonal) with no sign change proved; a smaller --box makes the tolerance finer",
            num(scene.tolerance())
        );
    }
    let undecided = count(|a| matches!(a, Answer::Undecided(_)));
    if undecided > 0 {
        eprintln!(
            "note: {undecided} undecided: everything before t is excluded; past it the ray ran out of pieces, or f64 could not narrow f's enclosures (its derivatives underflow at this scale)"
        );
    }
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for answer in answers {
        match answer {
            Answer::Hit(t) => writeln!(out, "{t:.16e}")?,
            Answer::Touch(t) => writeln!(out, "touch {t:.16e}")?,
            Answer::Undecided(t) => writeln!(out, "undecided {t:.16e}")?,
            Answer::Miss => writeln!(out, "none")?,
        }
    }
    out.flush()?;
    Ok(())
}
