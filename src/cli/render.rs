//! `lgc render`: options, validation (one line per mistake), the summary line.

use super::args::parse_ray_depth;
use super::args::{aabb_from, fmt3, parse_numbers, progress_bar, thread_pool, Failure, Outcome};
use super::args::{
    f_over, num, parse_depth, specialisation, warn_if_capped, Source, SourceArgs, DEFAULT_DEPTH,
};
use anyhow::{bail, Context as _};
use clap::Args;
use glam::DVec3;
use lgc::ray::RayStats;
use lgc::render::camera::CameraError;
use lgc::render::view::{blame_scene_camera, MAX_SAMPLES, MAX_SIDE};
use lgc::render::{
    framed_intersector, place_camera, render_into, render_scene_into, scene_frame, Camera,
    PendingImage, Prepared, RayTree, RenderSettings, Rendering, Shading, DEFAULT_RAY_DEPTH,
    MIN_WEIGHT,
};
use lgc::scene::{CameraSpec, Scene};
use lgc::{Aabb, Formula};
use std::path::PathBuf;
use std::time::Instant;

/// Options of `lgc render`. They are parsed from text here, not by clap, so
/// that each mistake gets exactly one line and exit code 1, like the other
/// mistakes a render can find.
#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    source: SourceArgs,
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
    /// Octree depth (pruning resolution): at most N levels (a box where f is
    /// at most quadratic is a leaf at any level, a smooth algebraic one whose
    /// Lipschitz bound is tight from level 2).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_DEPTH, value_parser = parse_depth)]
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
    #[arg(long, value_name = "N", default_value_t = DEFAULT_RAY_DEPTH, value_parser = parse_ray_depth)]
    max_depth: u32,
    /// Scene files: the least share of a pixel a reflected or refracted ray
    /// is followed for (0 follows every ray to --max-depth)
    #[arg(long, value_name = "W", default_value_t = MIN_WEIGHT)]
    min_weight: f64,
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

/// The options every rendering shares, checked.
struct Checked {
    settings: RenderSettings,
    /// The camera the command line asks for; unset parts come from the scene
    /// file, then from the default framing.
    camera: CameraSpec,
    pool: rayon::ThreadPool,
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

fn opt_vector(flag: &str, text: &Option<String>) -> anyhow::Result<Option<DVec3>> {
    text.as_deref().map(|t| vector(flag, t)).transpose()
}

impl RenderArgs {
    fn check(&self) -> anyhow::Result<Checked> {
        let (width, height) = size(&self.size)?;
        if self.samples == 0 || self.samples > MAX_SAMPLES {
            bail!(
                "--samples {}: use 1 to {MAX_SAMPLES} rays per pixel",
                self.samples
            );
        }
        if !(0.0..=1.0).contains(&self.min_weight) {
            bail!("--min-weight {}: use a share from 0 to 1", self.min_weight);
        }
        let camera = CameraSpec {
            eye: opt_vector("--eye", &self.eye)?,
            look_at: opt_vector("--look-at", &self.look_at)?,
            up: opt_vector("--up", &self.up)?,
            fov: self.fov,
            spans: Default::default(),
        };
        if camera.up == Some(DVec3::ZERO) {
            bail!("--up 0,0,0: the up vector cannot be (0, 0, 0)");
        }
        Ok(Checked {
            settings: RenderSettings {
                width,
                height,
                samples: self.samples,
                shadows: !self.no_shadows,
                bundles: true,
            },
            camera,
            pool: thread_pool(self.threads)?,
        })
    }

    /// The box and the surface colour of a formula rendering.
    fn box_and_color(&self) -> anyhow::Result<(Aabb, DVec3)> {
        let b = parse_numbers::<6>(&self.region)
            .map_err(|e| anyhow::anyhow!("--box {}: {e}", self.region))?;
        let bounds = aabb_from(b)?;
        if bounds.hi.cmple(bounds.lo).any() {
            bail!(
                "--box {}: the box is flat; every side must have positive length",
                self.region
            );
        }
        let color = vector("--color", &self.color)?;
        if !color.cmpge(DVec3::ZERO).all() || !color.cmple(DVec3::ONE).all() {
            bail!(
                "--color {}: each component must be between 0 and 1",
                self.color
            );
        }
        Ok((bounds, color))
    }
}

/// The camera, or a one-line error saying why it cannot be placed.
fn place_camera_or_fail(
    frame: &Aabb,
    cli: &CameraSpec,
    file: &CameraSpec,
    s: &RenderSettings,
) -> anyhow::Result<Camera> {
    let camera = place_camera(frame, cli, file, s);
    camera.context("cannot place the camera")
}

/// The work per ray and the answers that were not plain hits or misses:
/// "2.8 f evaluations per ray (and 0.01 interval), 3 touches", with the
/// pieces of rays excluded by their leaf's clear cells, and those that took
/// their bundle's shared enclosures, where there are any.
fn work(image: &Rendering, per: &str, tolerance: Option<f64>) -> String {
    let mut all = image.primary;
    all.add(&image.shadow);
    let n = all.rays.max(1) as f64;
    // Pieces excluded by the leaf's cell they lie in cost no evaluation.
    let pieces = match all.clear_cells {
        0 => String::new(),
        c => format!(", {:.2} pieces in clear cells", c as f64 / n),
    };
    // Pieces that took their bundle's enclosures over their leaf, where
    // there are enough to show.
    let pieces = match all.shared_pieces {
        c if (c as f64) < 0.005 * n => pieces,
        c => format!(
            "{pieces}, {:.2} pieces sharing {:.3} bundle evaluations",
            c as f64 / n,
            all.shared_evals as f64 / n
        ),
    };
    let mut text = format!(
        "{:.1} f evaluations per {per} (and {:.2} interval{pieces}), {} touches",
        all.f_evals as f64 / n,
        all.interval_evals as f64 / n,
        all.touches
    );
    if let (Some(tol), true) = (tolerance, all.touches > 0) {
        // A touch is an enclosure holding 0 within the tolerance, which
        // follows the box: say how wide, so that a touch in a large box can
        // be read.
        text += &format!(
            " (within the tolerance {}, 1e-10 of the box's diagonal)",
            num(tol)
        );
    }
    if all.undecided > 0 {
        text += &format!(", {} undecided", all.undecided);
    }
    text
}

/// Why a picture shows no surface, with the range of f over the box and a
/// hint; `None` when some camera ray met the surface.
fn nothing_to_see(
    formula: &Formula,
    bounds: &Aabb,
    leaves: usize,
    image: &Rendering,
) -> Option<String> {
    if image.primary.hits + image.primary.touches > 0 {
        return None;
    }
    let f = f_over(formula, bounds);
    let range = if f.is_empty() {
        "f is defined nowhere in the box".to_string()
    } else {
        format!("f over the box is [{}, {}]", num(f.inf()), num(f.sup()))
    };
    let (what, hint) = if leaves == 0 {
        (
            "nothing to see: f is never 0",
            "a --box that holds the surface shows it",
        )
    } else {
        (
            "nothing to see: no camera ray meets the surface",
            "try another --eye, --look-at or --fov",
        )
    };
    Some(format!(
        "{what} in the box {}..{} ({range}); {hint}",
        fmt3(bounds.lo),
        fmt3(bounds.hi)
    ))
}

/// A camera that cannot be placed: where the scene file's own camera is to
/// blame, the error points at it with a caret; otherwise one line.
fn camera_failure(e: CameraError, cli: &CameraSpec, file: &CameraSpec, source: &Source) -> Failure {
    match blame_scene_camera(&e, cli, file) {
        Some(located) => source.located(located),
        None => Failure::Other(anyhow::Error::new(e).context("cannot place the camera")),
    }
}

/// Runs `render` on the worker pool with a progress bar of tiles, then
/// writes the image into place.
/// Rows go to the encoder band by band as they are rendered, so memory
/// stays at a few bands (one encoded while the next ones render) whatever
/// the image's size; the file appears only once complete. The returned
/// rendering holds the ray counts, not the pixels.
fn develop(
    c: &Checked,
    pending: PendingImage,
    render: impl FnOnce(
            &(dyn Fn() + Sync),
            &mut dyn FnMut(&[u8]) -> std::io::Result<()>,
        ) -> std::io::Result<(RayStats, RayStats)>
        + Send,
) -> anyhow::Result<Rendering> {
    let (width, height) = (c.settings.width, c.settings.height);
    let bar = progress_bar(c.settings.tile_count(), "tiles");
    let mut stream = pending.stream(width, height)?;
    let written = c
        .pool
        .install(|| render(&|| bar.inc(1), &mut |rows| stream.write_rows(rows)));
    bar.finish_and_clear();
    let (primary, shadow) = written.context("cannot write the image")?;
    stream.finish()?;
    Ok(Rendering {
        width,
        height,
        rgb: Vec::new(),
        primary,
        shadow,
    })
}

/// Renders a formula or, when the source has `{ … }` blocks, a scene file.
pub fn run(args: &RenderArgs) -> Outcome {
    let source: Source = args.source.read()?;
    if !source.is_vm() && lgc::scene::is_scene(&source.text) {
        let scene = lgc::scene::parse_scene(&source.text).map_err(|e| source.located(e))?;
        run_scene(&scene, args, &source)?;
    } else {
        let formula = source.formula()?;
        run_formula(&formula, args)?;
    }
    Ok(0)
}

/// Renders a scene file: the file's camera, overridden by the command line.
fn run_scene(scene: &Scene, args: &RenderArgs, source: &Source) -> Result<(), Failure> {
    let c = args.check()?;
    let pending = PendingImage::create(&args.output).map_err(anyhow::Error::from)?;
    let start = Instant::now();
    let prepared = c.pool.install(|| Prepared::new(scene, args.depth));
    let frame = scene_frame(scene, &prepared, &c.camera);
    let camera = place_camera(&frame, &c.camera, &scene.camera, &c.settings)
        .map_err(|e| camera_failure(e, &c.camera, &scene.camera, source))?;
    let image = develop(&c, pending, |progress, sink| {
        render_scene_into(
            &prepared,
            &camera,
            &c.settings,
            RayTree {
                max_depth: args.max_depth,
                min_weight: args.min_weight,
            },
            progress,
            sink,
        )
    })?;
    let elapsed = start.elapsed().as_secs_f64();
    eprintln!(
        "rendered {} ({}x{}) in {elapsed:.2} s: {} objects, {} primary + {} shadow ray queries, {}",
        args.output.display(),
        image.width,
        image.height,
        scene.objects.len(),
        image.primary.rays,
        image.shadow.rays,
        work(&image, "query", None)
    );
    exit_soon(prepared);
    Ok(())
}

/// Validates the options, renders a formula, writes the image and prints the summary.
fn run_formula(formula: &Formula, args: &RenderArgs) -> Result<(), Failure> {
    let c = args.check()?;
    let (bounds, color) = args.box_and_color()?;
    // Reserve the output first: an unwritable path fails before any work.
    let pending = PendingImage::create(&args.output).map_err(anyhow::Error::from)?;

    let start = Instant::now();
    let (scene, frame) = c
        .pool
        .install(|| framed_intersector(formula, &bounds, args.depth));
    let stats = scene.octree_stats();
    warn_if_capped(&stats, args.depth);
    if stats.leaves_on_faces > 0 {
        eprintln!(
            "warning: the surface reaches the faces of the box {}..{} and may be clipped there; a larger --box shows all of it",
            fmt3(bounds.lo),
            fmt3(bounds.hi)
        );
    }
    let camera = place_camera_or_fail(&frame, &c.camera, &CameraSpec::default(), &c.settings)?;
    let shading = Shading::studio(camera.basis(), color);
    let image = develop(&c, pending, |progress, sink| {
        render_into(&scene, &camera, &shading, &c.settings, progress, sink)
    })?;
    let elapsed = start.elapsed().as_secs_f64();
    if let Some(why) = nothing_to_see(formula, &bounds, stats.leaves, &image) {
        eprintln!("warning: {why}");
    }

    eprintln!(
        "rendered {} ({}x{}) in {elapsed:.2} s: {} primary + {} shadow rays, {}, {} octree leaves kept ({} of them tight before the depth; {} boxes pruned by |f(x0)| > L*d, {} by interval){}",
        args.output.display(),
        image.width,
        image.height,
        image.primary.rays,
        image.shadow.rays,
        work(&image, "ray", Some(scene.tolerance())),
        stats.leaves,
        stats.tight,
        stats.pruned_by_lipschitz,
        stats.pruned_by_interval,
        specialisation(&stats)
    );
    exit_soon(scene);
    Ok(())
}

/// Leaves `prepared` (an octree, its tapes and their machine code) to the
/// process's exit, which returns its memory at once, rather than freeing it
/// piece by piece first: a command exits right after its summary. Measured
/// on the cube minus a ball at 1024², two threads: 0.98x the wall time, in
/// three runs of 41 to 81 alternating processes.
fn exit_soon<T>(prepared: T) {
    std::mem::forget(prepared);
}
