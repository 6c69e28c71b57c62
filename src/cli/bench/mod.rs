//! `lgc bench`: renders corpus surfaces and reports time, rays per second and
//! evaluations per ray. Times are medians of repeated runs on this machine;
//! compare figures from one run with each other, not across machines.

mod figure;
mod models;

use super::args::{parse_count, parse_depth, parse_numbers, thread_pool, Outcome, DEFAULT_DEPTH};
use clap::Args;
use glam::DVec3;
use lgc::ray::octree::BuildOptions;
use lgc::ray::{Intersector, Octree};
use lgc::render::{render, Camera, RenderSettings, Shading};
use lgc::{Aabb, Formula};
use std::path::PathBuf;
use std::time::Instant;

/// The surface corpus shipped with the repository (tests and benches read it too).
const CORPUS: &str = include_str!("../../../examples/surfaces.json");
/// CSG shapes: min/max creases, and the smooth parts to compare them with.
const CSG: &str = include_str!("../../../examples/csg.json");

/// Options of `lgc bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Surfaces to render, by name: the corpus (examples/surfaces.json) and
    /// CSG shapes (examples/csg.json: gyroid_ball, ball_cut, cube_minus_ball,
    /// three_balls, and gyroid_unit and cube_unit to compare with).
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
    #[arg(long, value_parser = parse_count)]
    threads: Option<u64>,
    /// Octree depth: at most N levels (a box where f is at most quadratic is a leaf at any level,
    /// a smooth algebraic one whose Lipschitz bound is tight from level 2).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_DEPTH, value_parser = parse_depth)]
    depth: u32,
    /// Time these model files instead (fidget's .vm, or .lgc formulas), each
    /// as whole `lgc render` runs: PNG written, no shadows.
    #[arg(long, value_delimiter = ',', value_name = "FILES")]
    models: Vec<PathBuf>,
    /// The box the models are rendered in.
    #[arg(
        long = "box",
        value_name = "X0,Y0,Z0,X1,Y1,Z1",
        default_value = "-1.2,-1.2,-1.2,1.2,1.2,1.2",
        requires = "models"
    )]
    bounds: String,
    /// fidget's peer binary (fidget-peer-bench), to time beside lgc on each
    /// model: the better of its JIT and VM.
    #[arg(long, value_name = "PATH", requires = "models")]
    peer: Option<PathBuf>,
    /// Draw the models' render time against their operation count into FILE
    /// (.svg or .png).
    #[arg(long, value_name = "FILE", requires = "models")]
    plot: Option<PathBuf>,
}

/// Runs the benchmark and prints one row per surface.
pub fn run(args: &BenchArgs) -> Outcome {
    let threads = args
        .threads
        .map(|t| usize::try_from(t).unwrap_or(usize::MAX));
    if !args.models.is_empty() {
        parse_numbers::<6>(&args.bounds).map_err(|e| anyhow::anyhow!("--box: {e}"))?;
        let cores = std::thread::available_parallelism().map_or(1, usize::from);
        models::run(&models::ModelRuns {
            models: &args.models,
            bounds: &args.bounds,
            size: args.size,
            repeat: args.repeat,
            threads: threads.unwrap_or(cores),
            peer: args.peer.as_deref(),
            plot: args.plot.as_deref(),
        })?;
        return Ok(0);
    }
    measure(&args.surfaces, args.size, args.repeat, threads, args.depth)?;
    Ok(0)
}

fn measure(
    names: &[String],
    size: u32,
    repeat: u32,
    threads: Option<usize>,
    depth: u32,
) -> anyhow::Result<()> {
    let mut corpus: serde_json::Value = serde_json::from_str(CORPUS)?;
    if let (Some(all), serde_json::Value::Object(csg)) =
        (corpus.as_object_mut(), serde_json::from_str(CSG)?)
    {
        all.extend(csg);
    }
    let pool = thread_pool(threads)?;
    println!(
        "{} thread(s), {size}x{size}, octree depth {depth}, median of {repeat} run(s)",
        pool.current_num_threads()
    );
    println!(
        "{:<16} {:>9} {:>12} {:>12} {:>14} {:>11} {:>9} {:>7} {:>12} {:>9} {:>7}",
        "surface",
        "time",
        "rays/s",
        "f evals/ray",
        "interval/ray",
        "leaves/ray",
        "leaves",
        "tight",
        "specialised",
        "creased",
        "split"
    );
    for name in names {
        let entry = corpus.get(name).ok_or_else(|| {
            anyhow::anyhow!(
                "unknown surface `{name}`; the corpus has: {}",
                keys(&corpus)
            )
        })?;
        let expr = entry["expr"].as_str().unwrap_or_default();
        let b: Vec<f64> = entry["box"]
            .as_array()
            .map(|a| a.iter().filter_map(|v| v.as_f64()).collect())
            .unwrap_or_default();
        anyhow::ensure!(b.len() == 6, "corpus entry `{name}` has no box");
        let bounds = Aabb::new(DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]))
            .ok_or_else(|| anyhow::anyhow!("corpus entry `{name}` has an inverted box"))?;
        let formula = Formula::parse(expr).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        // The view frames the kept boxes at the full depth (the renderer's
        // octree stops early where the surface is smooth); not timed.
        let framing = BuildOptions {
            coarse_quadrics: false,
            leaf_bounds: false,
            ..BuildOptions::to_depth(depth)
        };
        let frame = pool
            .install(|| Octree::build_with(&formula, &bounds, &framing))
            .surface_bounds()
            .unwrap_or(bounds);
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..repeat.max(1) {
            let start = Instant::now();
            let scene = pool.install(|| Intersector::new(&formula, &bounds, depth));
            let camera = Camera::framing(&frame, 30.0, size, size)?;
            let shading = Shading::studio(camera.basis(), DVec3::new(0.85, 0.45, 0.25));
            let settings = RenderSettings {
                width: size,
                height: size,
                samples: 1,
                shadows: true,
                bundles: true,
            };
            let image = pool.install(|| render(&scene, &camera, &shading, &settings, &|| {}));
            times.push(start.elapsed().as_secs_f64());
            last = Some((image, scene.octree_stats()));
        }
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        if let Some((image, stats)) = last {
            let rays = image.primary.rays + image.shadow.rays;
            let f = image.primary.f_evals + image.shadow.f_evals;
            let iv = image.primary.interval_evals + image.shadow.interval_evals;
            let visits = image.primary.leaves + image.shadow.leaves;
            println!(
                "{name:<16} {:>7.3} s {:>10.2} M {:>12.2} {:>14.3} {:>11.2} {:>9} {:>7} {:>12} {:>9} {:>7}",
                median,
                rays as f64 / median / 1e6,
                f as f64 / rays as f64,
                iv as f64 / rays as f64,
                visits as f64 / rays as f64,
                stats.leaves,
                stats.tight,
                stats.specialised,
                stats.creased,
                stats.split
            );
        }
    }
    Ok(())
}

fn keys(corpus: &serde_json::Value) -> String {
    corpus
        .as_object()
        .map(|o| o.keys().cloned().collect::<Vec<_>>().join(", "))
        .unwrap_or_default()
}
