//! `lgc render`: options, validation (one line per mistake), the summary line.

use crate::cli::{fmt3, parse_numbers, Failure, Source, DEFAULT_DEPTH};
use anyhow::{bail, Context as _};
use clap::Args;
use glam::DVec3;
use lgc::camera::Camera;
use lgc::intersect::Intersector;
use lgc::output::PendingImage;
use lgc::render::{render, RenderSettings};
use lgc::shade::Shading;
use lgc::Formula;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

/// Octree depth of the default camera's framing.
const FRAMING_DEPTH: u32 = 4;

/// The largest image side accepted.
const MAX_SIDE: u32 = 16384;

/// Options of `lgc render`, parsed from text here so that each mistake gets
/// exactly one line.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Output image; the extension picks the format (.png or .ppm).
    #[arg(short = 'o', long, value_name = "FILE", default_value = "render.png")]
    output: PathBuf,
    /// Image size WIDTHxHEIGHT (each 1 to 16384).
    #[arg(long, value_name = "WxH", default_value = "1024x768")]
    size: String,
    /// The box X0,Y0,Z0,X1,Y1,Z1 that holds the surface.
    #[arg(
        long = "box",
        value_name = "X0,Y0,Z0,X1,Y1,Z1",
        allow_hyphen_values = true,
        default_value = "-2,-2,-2,2,2,2"
    )]
    region: String,
    /// Octree depth (pruning resolution).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_DEPTH)]
    depth: u32,
    /// Surface colour R,G,B (sRGB, each 0 to 1).
    #[arg(long, value_name = "R,G,B", default_value = "0.85,0.45,0.25")]
    color: String,
    /// Camera position X,Y,Z (default: a three-quarter view that frames the box).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    eye: Option<String>,
    /// The point the camera looks at (default: the box centre).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    look_at: Option<String>,
    /// The camera's up direction (default 0,0,1).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    up: Option<String>,
    /// Vertical field of view in degrees (default 30).
    #[arg(long, value_name = "DEGREES")]
    fov: Option<f64>,
    /// Scene files: how many reflections and refractions a ray may follow.
    #[arg(long, value_name = "N", default_value_t = 5)]
    max_depth: u32,
    /// Rays per pixel (anti-aliasing).
    #[arg(long, value_name = "N", default_value_t = 1)]
    samples: u32,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Turn off the key light's shadows.
    #[arg(long)]
    no_shadows: bool,
}

fn size(text: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .with_context(|| format!("--size {text}: expected WIDTHxHEIGHT, such as 1024x768"))?;
    let side = |s: &str| -> anyhow::Result<u32> {
        let v: u32 = s
            .trim()
            .parse()
            .with_context(|| format!("--size {text}: `{s}` is not a whole number"))?;
        if v == 0 || v > MAX_SIDE {
            bail!("--size {text}: each side must be between 1 and {MAX_SIDE} pixels");
        }
        Ok(v)
    };
    Ok((side(w)?, side(h)?))
}

fn vector(flag: &str, text: &str) -> anyhow::Result<DVec3> {
    let v = parse_numbers::<3>(text).map_err(|e| anyhow::anyhow!("{flag} {text}: {e}"))?;
    Ok(DVec3::from(v))
}

/// Renders a formula or, when the source has `{ … }` blocks, a scene file.
pub fn run(source: &Source, args: &RenderArgs) -> Result<(), Failure> {
    let located = |e: lgc::FormulaError| Failure::Formula(e.render(&source.text, &source.origin));
    if lgc::scene::is_scene(&source.text) {
        let scene = lgc::scene::parse_scene(&source.text).map_err(located)?;
        return run_scene(&scene, args).map_err(Failure::Other);
    }
    let formula = Formula::parse(&source.text).map_err(located)?;
    run_formula(&formula, args).map_err(Failure::Other)
}

/// The options every rendering shares, checked.
struct Common {
    width: u32,
    height: u32,
    up: DVec3,
    fov: f64,
    pool: rayon::ThreadPool,
}

fn common(args: &RenderArgs) -> anyhow::Result<Common> {
    let (width, height) = size(&args.size)?;
    if args.depth > 10 {
        bail!("--depth {}: use at most 10 (8^10 boxes)", args.depth);
    }
    if args.samples == 0 || args.samples > 1024 {
        bail!("--samples {}: use 1 to 1024 rays per pixel", args.samples);
    }
    if args.threads == Some(0) {
        bail!("--threads 0: use at least one thread");
    }
    let up = args
        .up
        .as_deref()
        .map(|u| vector("--up", u))
        .transpose()?
        .unwrap_or(DVec3::Z);
    let fov = args.fov.unwrap_or(30.0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    Ok(Common {
        width,
        height,
        up,
        fov,
        pool,
    })
}

fn progress_bar(rows_or_tiles: u64) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(rows_or_tiles);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent}%")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Renders a scene file: the file's camera, overridden by the command line.
fn run_scene(scene: &lgc::scene::Scene, args: &RenderArgs) -> anyhow::Result<()> {
    let c = common(args)?;
    let pending = PendingImage::create(&args.output)?;
    let start = Instant::now();
    let prepared = c
        .pool
        .install(|| lgc::whitted::Prepared::new(scene, args.depth));
    let frame = prepared.surface_bounds().unwrap_or(scene.objects[0].bounds);
    let spec = &scene.camera;
    let fov = args.fov.or(spec.fov).unwrap_or(30.0);
    let up = match &args.up {
        Some(_) => c.up,
        None => spec.up.unwrap_or(DVec3::Z),
    };
    let look_at = match &args.look_at {
        Some(t) => Some(vector("--look-at", t)?),
        None => spec.look_at,
    };
    let eye = match &args.eye {
        Some(e) => Some(vector("--eye", e)?),
        None => spec.eye,
    };
    let camera = match (eye, look_at) {
        (None, None) => Camera::framing(&frame, fov, c.width, c.height),
        (eye, look_at) => {
            let target = look_at.unwrap_or(frame.center());
            let eye = match eye {
                Some(e) => e,
                None => Camera::framing(&frame, fov, c.width, c.height)?.eye(),
            };
            Camera::new(eye, target, up, fov, c.width, c.height)
        }
    }
    .context("cannot place the camera")?;
    let settings = RenderSettings {
        width: c.width,
        height: c.height,
        samples: args.samples,
        shadows: !args.no_shadows,
    };
    let bar = progress_bar(u64::from(c.height));
    let image = c.pool.install(|| {
        lgc::whitted::render_scene(&prepared, &camera, &settings, args.max_depth, &|| {
            bar.inc(1)
        })
    });
    bar.finish_and_clear();
    let elapsed = start.elapsed().as_secs_f64();
    pending.finish(image.width, image.height, &image.rgb)?;
    eprintln!(
        "rendered {} ({}x{}) in {elapsed:.2} s: {} objects, {} ray queries, {:.1} f evaluations per query",
        args.output.display(),
        c.width,
        c.height,
        scene.objects.len(),
        image.primary.rays,
        image.primary.f_evals as f64 / image.primary.rays.max(1) as f64
    );
    Ok(())
}

/// Validates the options, renders a formula, writes the image and prints the summary.
fn run_formula(formula: &Formula, args: &RenderArgs) -> anyhow::Result<()> {
    let Common {
        width,
        height,
        up,
        fov,
        pool,
    } = common(args)?;
    let b = parse_numbers::<6>(&args.region)
        .map_err(|e| anyhow::anyhow!("--box {}: {e}", args.region))?;
    let bounds = crate::cli::aabb_from(b)?;
    if bounds.hi.cmple(bounds.lo).any() {
        bail!(
            "--box {}: the box is flat; every side must have positive length",
            args.region
        );
    }
    let color = vector("--color", &args.color)?;
    if !color.cmpge(DVec3::ZERO).all() || !color.cmple(DVec3::ONE).all() {
        bail!(
            "--color {}: each component must be between 0 and 1",
            args.color
        );
    }
    // Reserve the output first: an unwritable path fails before any work.
    let pending = PendingImage::create(&args.output)?;

    let start = Instant::now();
    let scene = Intersector::new(formula, &bounds, args.depth);
    let stats = scene.octree_stats();
    if stats.leaves_on_faces > 0 {
        eprintln!(
            "warning: the surface reaches the faces of the box {}..{} and may be clipped there; a larger --box shows all of it",
            fmt3(bounds.lo),
            fmt3(bounds.hi)
        );
    }
    // The default view frames the part of the box that holds the surface.
    // It comes from a coarse octree of its own, so --depth never moves it.
    let frame = lgc::octree::Octree::build(formula, &bounds, FRAMING_DEPTH)
        .surface_bounds()
        .unwrap_or(bounds);
    let camera = match (&args.eye, &args.look_at) {
        (None, None) => Camera::framing(&frame, fov, width, height),
        (eye, look_at) => {
            let target = look_at
                .as_deref()
                .map(|t| vector("--look-at", t))
                .transpose()?
                .unwrap_or(frame.center());
            let default_eye = Camera::framing(&frame, fov, width, height)?.eye();
            let eye = eye
                .as_deref()
                .map(|e| vector("--eye", e))
                .transpose()?
                .unwrap_or(default_eye);
            Camera::new(eye, target, up, fov, width, height)
        }
    }
    .context("cannot place the camera")?;
    let shading = Shading::studio(camera.basis(), color);
    let settings = RenderSettings {
        width,
        height,
        samples: args.samples,
        shadows: !args.no_shadows,
    };
    let tiles = u64::from(width.div_ceil(16)) * u64::from(height.div_ceil(16));
    let bar = if std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new(tiles);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {percent}% of tiles",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    let image = pool.install(|| render(&scene, &camera, &shading, &settings, &|| bar.inc(1)));
    bar.finish_and_clear();
    let elapsed = start.elapsed().as_secs_f64();
    pending.finish(image.width, image.height, &image.rgb)?;

    let rays = image.primary.rays + image.shadow.rays;
    let evals = image.primary.f_evals + image.shadow.f_evals;
    eprintln!(
        "rendered {} ({width}x{height}) in {elapsed:.2} s: {} primary + {} shadow rays, {:.1} f evaluations per ray, {} octree leaves kept ({} boxes pruned by |f(x0)| > L*d, {} by interval)",
        args.output.display(),
        image.primary.rays,
        image.shadow.rays,
        evals as f64 / rays.max(1) as f64,
        stats.leaves,
        stats.pruned_by_lipschitz,
        stats.pruned_by_interval
    );
    Ok(())
}
