//! The film: the one tile loop every integrator shares. Tiles are rendered in
//! parallel, each pixel averaging an integrator's radiance over a
//! low-discrepancy pattern of samples, and converted to 8-bit sRGB.

use super::shade::linear_to_srgb8_rgb;
use crate::ray::RayStats;
use glam::DVec3;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

/// Side of the square tiles that threads take one at a time.
pub const TILE: u32 = 16;

/// What to render and how.
#[derive(Debug, Clone)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Rays per pixel (anti-aliasing).
    pub samples: u32,
    /// Whether lights cast shadows.
    pub shadows: bool,
    /// Whether each tile's camera rays are first swept as a bundle, which
    /// proves the space in front of the surface empty for all of them at
    /// once ([`crate::ray::bundle`]; single surfaces, not scene files);
    /// answers are the same either way.
    pub bundles: bool,
}

impl RenderSettings {
    /// How many tiles the image has: the progress callback's total.
    pub fn tile_count(&self) -> u64 {
        u64::from(self.width.div_ceil(TILE)) * u64::from(self.height.div_ceil(TILE))
    }
}

/// A rendered image: 8-bit sRGB, row-major, and the work it took.
#[derive(Debug, Clone)]
pub struct Rendering {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width·height·3` bytes; empty where the rows went to a sink as they
    /// were rendered ([`render_rows`]).
    pub rgb: Vec<u8>,
    /// Camera rays and the rays they spawn (reflected, refracted).
    pub primary: RayStats,
    /// Shadow rays.
    pub shadow: RayStats,
}

/// What the film asks of a way of computing light along camera rays.
pub trait Integrator: Sync {
    /// Per-thread state (tracers, scratch space, ray counts).
    type Worker: Send;

    /// A fresh per-thread state.
    fn worker(&self) -> Self::Worker;

    /// Called before a tile's pixels with every image point the tile will
    /// then ask [`Integrator::radiance`] about, so that work its rays share
    /// can be done once. Nothing by default.
    fn begin_tile(&self, worker: &mut Self::Worker, points: &[(f64, f64)]) {
        let _ = (worker, points);
    }

    /// The linear colour seen through the image point `(px, py)` (pixels,
    /// from the top-left corner): point `k` of the last
    /// [`Integrator::begin_tile`], so that what it found for that point can
    /// be looked up.
    fn radiance(&self, worker: &mut Self::Worker, k: usize, px: f64, py: f64) -> DVec3;

    /// The rays `worker` has answered so far: primary and shadow.
    fn ray_stats(&self, worker: &Self::Worker) -> (RayStats, RayStats);

    /// Where the last [`Integrator::begin_tile`] proved that each of its
    /// `rays` sees the background (each then counted as answered): the
    /// background by image row, the radiance each of those rays would have.
    /// `None` (the default): ask [`Integrator::radiance`] point by point.
    fn tile_background(
        &self,
        worker: &mut Self::Worker,
        rays: usize,
    ) -> Option<impl Fn(f64) -> DVec3> {
        let _ = (worker, rays);
        None::<fn(f64) -> DVec3>
    }
}

/// Offsets of `n` samples inside a pixel: the R2 low-discrepancy sequence,
/// which spreads any number of samples evenly.
pub fn sample_offsets(n: u32) -> Vec<(f64, f64)> {
    if n <= 1 {
        return vec![(0.5, 0.5)];
    }
    const A1: f64 = 0.754_877_666_246_692_8;
    const A2: f64 = 0.569_840_290_998_053_2;
    (0..n)
        .map(|k| {
            (
                (0.5 + A1 * f64::from(k)).fract(),
                (0.5 + A2 * f64::from(k)).fract(),
            )
        })
        .collect()
}

/// One finished tile: its 8-bit colours and the rays it took.
struct TileResult {
    tile: (u32, u32),
    rgb: Vec<u8>,
    primary: RayStats,
    shadow: RayStats,
}

/// Tiles a band of rows should hold so that threads stay busy to its end.
const TILES_PER_BAND: u32 = 256;

/// Rows per band: whole tiles, enough of them per band to keep every
/// thread busy, and no more, so that a band of a 16384-pixel-wide image is
/// 16 rows (under a megabyte).
pub fn band_rows(width: u32) -> u32 {
    let tiles_x = width.div_ceil(TILE).max(1);
    TILE * TILES_PER_BAND.div_ceil(tiles_x).max(1)
}

/// Renders every tile with `integrator`; `progress` is called once per
/// finished tile (see [`RenderSettings::tile_count`]).
pub fn render_tiles<I: Integrator>(
    integrator: &I,
    settings: &RenderSettings,
    progress: &(dyn Fn() + Sync),
) -> Rendering {
    let (w, h) = (settings.width, settings.height);
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    let (primary, shadow) = render_rows(integrator, settings, progress, &mut |rows| {
        rgb.extend_from_slice(rows);
        Ok(())
    })
    .expect("collecting rows in memory cannot fail");
    Rendering {
        width: w,
        height: h,
        rgb,
        primary,
        shadow,
    }
}

/// Renders one tile with `worker`: its 8-bit colours and the rays it took.
fn render_tile<I: Integrator>(
    integrator: &I,
    worker: &mut I::Worker,
    (tx, ty): (u32, u32),
    (w, h): (u32, u32),
    offsets: &[(f64, f64)],
) -> TileResult {
    let before = integrator.ray_stats(worker);
    let (xs, ys) = (
        tx * TILE..((tx + 1) * TILE).min(w),
        ty * TILE..((ty + 1) * TILE).min(h),
    );
    let mut points = Vec::with_capacity(xs.len() * ys.len() * offsets.len());
    for y in ys {
        for x in xs.clone() {
            for &(ox, oy) in offsets {
                points.push((f64::from(x) + ox, f64::from(y) + oy));
            }
        }
    }
    integrator.begin_tile(worker, &points);
    let mut rgb = Vec::with_capacity((3 * TILE * TILE) as usize);
    // A tile of background alone: each sample's radiance is its row's
    // background, taken once per row; with one sample a pixel, a row's
    // pixels are one colour.
    let background = match integrator.tile_background(worker, points.len()) {
        Some(background) if offsets.len() == 1 => {
            for row in points.chunk_by(|p, q| p.1 == q.1) {
                let bytes = linear_to_srgb8_rgb(background(row[0].1));
                for _ in row {
                    rgb.extend(bytes);
                }
            }
            true
        }
        Some(background) => {
            let mut row = (f64::NAN, DVec3::ZERO);
            colour_pixels(&points, offsets.len(), &mut rgb, |_, _, py| {
                if py != row.0 {
                    row = (py, background(py));
                }
                row.1
            });
            true
        }
        None => false,
    };
    if !background {
        colour_pixels(&points, offsets.len(), &mut rgb, |k, px, py| {
            integrator.radiance(worker, k, px, py)
        });
    }
    let after = integrator.ray_stats(worker);
    TileResult {
        tile: (tx, ty),
        rgb,
        primary: after.0.since(&before.0),
        shadow: after.1.since(&before.1),
    }
}

/// Appends the 8-bit colours of the pixels whose `n` samples each are
/// `points`, from `radiance(k, px, py)` of sample k.
fn colour_pixels(
    points: &[(f64, f64)],
    n: usize,
    rgb: &mut Vec<u8>,
    mut radiance: impl FnMut(usize, f64, f64) -> DVec3,
) {
    // Background pixels of a row share one colour: it is converted once.
    let mut last = (DVec3::NAN, [0u8; 3]);
    for (first, pixel) in points.chunks(n).enumerate() {
        let c = if let [(px, py)] = *pixel {
            // One sample is the pixel's colour (the sum from 0 and the
            // division by 1 could change only the sign of a zero, whose byte
            // is the same).
            radiance(first, px, py)
        } else {
            let mut sum = DVec3::ZERO;
            for (j, &(px, py)) in pixel.iter().enumerate() {
                sum += radiance(first * n + j, px, py);
            }
            sum / n as f64
        };
        if c != last.0 {
            last = (c, linear_to_srgb8_rgb(c));
        }
        rgb.extend(last.1);
    }
}

/// Renders the image band by band (see [`band_rows`]), each band's tiles in
/// parallel, and hands `sink` the finished rows in order from the top, as
/// 8-bit sRGB, while the next band renders: memory stays at two bands
/// whatever the image's size. Returns the primary and shadow rays answered,
/// or the sink's first error.
pub fn render_rows<I: Integrator>(
    integrator: &I,
    settings: &RenderSettings,
    progress: &(dyn Fn() + Sync),
    sink: &mut dyn FnMut(&[u8]) -> std::io::Result<()>,
) -> std::io::Result<(RayStats, RayStats)> {
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE);
    let band = band_rows(w);
    let offsets = sample_offsets(settings.samples);
    let mut primary = RayStats::default();
    let mut shadow = RayStats::default();
    // One worker per thread for the whole image: its evaluators and scratch
    // space stay warm from tile to tile and band to band. Each is made on its
    // own thread, and moved to that thread's stack while it works: made on
    // one thread, or side by side in one vector, the scratch space and ray
    // counts one thread writes would share cache lines with what the other
    // reads (measured: a scene took 1.1–1.2x the time on two threads).
    let workers: Vec<Mutex<Option<I::Worker>>> = (0..rayon::current_num_threads())
        .map(|_| Mutex::new(None))
        .collect();
    // The last band's finished rows, not yet handed to the sink.
    let mut finished: Option<Vec<u8>> = None;
    for y0 in (0..h).step_by(band as usize) {
        let y1 = (y0 + band).min(h);
        let tiles: Vec<(u32, u32)> = (y0 / TILE..y1.div_ceil(TILE))
            .flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty)))
            .collect();
        // Each thread takes the next tile until none is left, so a band
        // ends at most one tile after its last thread falls idle. The last
        // band's rows go to the sink meanwhile (encoding them is serial);
        // the sink's thread then joins in.
        let next = AtomicUsize::new(0);
        let mut results: Vec<Vec<TileResult>> = Vec::new();
        let mut sunk = Ok(());
        rayon::in_place_scope(|scope| {
            scope.spawn(|_| {
                results = rayon::broadcast(|ctx| {
                    let mut slot = workers[ctx.index()]
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner);
                    let mut worker = slot.take().unwrap_or_else(|| integrator.worker());
                    let mut done = Vec::new();
                    while let Some(&tile) = tiles.get(next.fetch_add(1, Ordering::Relaxed)) {
                        done.push(render_tile(integrator, &mut worker, tile, (w, h), &offsets));
                        progress();
                    }
                    *slot = Some(worker);
                    done
                });
            });
            if let Some(rows) = &finished {
                sunk = sink(rows);
            }
        });
        sunk?;
        let mut rows = finished.take().unwrap_or_default();
        rows.clear();
        rows.resize(((y1 - y0) * w * 3) as usize, 0);
        for tile in results.into_iter().flatten() {
            primary.add(&tile.primary);
            shadow.add(&tile.shadow);
            let (tx, ty) = tile.tile;
            let (x0, x1) = (tx * TILE, ((tx + 1) * TILE).min(w));
            let row = (3 * (x1 - x0)) as usize;
            for (k, y) in (ty * TILE..((ty + 1) * TILE).min(h)).enumerate() {
                let start = (((y - y0) * w + x0) * 3) as usize;
                rows[start..start + row].copy_from_slice(&tile.rgb[k * row..(k + 1) * row]);
            }
        }
        finished = Some(rows);
    }
    if let Some(rows) = &finished {
        sink(rows)?;
    }
    Ok((primary, shadow))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::shade::linear_to_srgb8;

    /// Colours each pixel by its own coordinates.
    struct Gradient;

    impl Integrator for Gradient {
        type Worker = u64;
        fn worker(&self) -> u64 {
            0
        }
        fn radiance(&self, rays: &mut u64, _: usize, px: f64, py: f64) -> DVec3 {
            *rays += 1;
            DVec3::new(px / 1000.0, py / 1000.0, (px * py) % 1.0)
        }
        fn ray_stats(&self, rays: &u64) -> (RayStats, RayStats) {
            let stats = RayStats {
                rays: *rays,
                ..RayStats::default()
            };
            (stats, RayStats::default())
        }
    }

    #[test]
    fn streamed_rows_arrive_in_order_and_whole() {
        // Sizes that are no multiple of the tile or of the band, the last
        // in four bands.
        for (w, h) in [(1, 1), (37, 5), (300, 141), (17, 700), (1000, 300)] {
            let settings = RenderSettings {
                width: w,
                height: h,
                samples: 1,
                shadows: false,
                bundles: true,
            };
            let mut rows = Vec::new();
            let mut calls = 0;
            let (primary, _) = render_rows(&Gradient, &settings, &|| {}, &mut |band| {
                assert_eq!(band.len() % (3 * w as usize), 0);
                assert!(band.len() <= 3 * (w * band_rows(w)) as usize);
                rows.extend_from_slice(band);
                calls += 1;
                Ok(())
            })
            .unwrap();
            assert_eq!(primary.rays, u64::from(w * h));
            assert_eq!(calls, h.div_ceil(band_rows(w)));
            assert!(w < 1000 || calls == 4);
            assert_eq!(rows.len(), (3 * w * h) as usize);
            for y in 0..h {
                for x in 0..w {
                    let c = Gradient.radiance(&mut 0, 0, f64::from(x) + 0.5, f64::from(y) + 0.5);
                    let at = (3 * (y * w + x)) as usize;
                    assert_eq!(
                        &rows[at..at + 3],
                        &[c.x, c.y, c.z].map(linear_to_srgb8),
                        "pixel ({x}, {y}) of {w}x{h}"
                    );
                }
            }
        }
    }

    /// Counts the workers it makes.
    struct Counting(std::sync::atomic::AtomicUsize);

    impl Integrator for Counting {
        type Worker = u64;
        fn worker(&self) -> u64 {
            self.0.fetch_add(1, Ordering::Relaxed);
            0
        }
        fn radiance(&self, rays: &mut u64, k: usize, px: f64, py: f64) -> DVec3 {
            Gradient.radiance(rays, k, px, py)
        }
        fn ray_stats(&self, rays: &u64) -> (RayStats, RayStats) {
            Gradient.ray_stats(rays)
        }
    }

    /// Regression: workers were made per split of each band's tiles, a few
    /// hundred for a 1024² image on two threads, each meeting every shape
    /// afresh. Now one per thread serves the whole image.
    #[test]
    fn one_worker_per_thread_renders_every_band() {
        let settings = RenderSettings {
            width: 1024,
            height: 300,
            samples: 1,
            shadows: false,
            bundles: true,
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let counting = Counting(AtomicUsize::new(0));
        let image = pool.install(|| render_tiles(&counting, &settings, &|| {}));
        assert!(settings.height > 4 * band_rows(settings.width));
        assert_eq!(counting.0.load(Ordering::Relaxed), 3);
        assert_eq!(image.primary.rays, 1024 * 300);
        let plain = render_tiles(&Gradient, &settings, &|| {});
        assert_eq!(image.rgb, plain.rgb);
    }

    /// A sky by rows; where `proved`, every other column of tiles is
    /// declared background (`filled` counts them).
    struct Sky {
        proved: bool,
        filled: AtomicUsize,
    }

    fn sky(py: f64) -> DVec3 {
        DVec3::new(py / 97.0, 0.3, 1.0 - py / 211.0)
    }

    impl Integrator for Sky {
        /// Rays answered, and whether the current tile is background.
        type Worker = (u64, bool);
        fn worker(&self) -> (u64, bool) {
            (0, false)
        }
        fn begin_tile(&self, worker: &mut (u64, bool), points: &[(f64, f64)]) {
            worker.1 = self.proved && (points[0].0 as u32 / TILE).is_multiple_of(2);
        }
        fn radiance(&self, worker: &mut (u64, bool), _: usize, _: f64, py: f64) -> DVec3 {
            worker.0 += 1;
            sky(py)
        }
        fn ray_stats(&self, worker: &(u64, bool)) -> (RayStats, RayStats) {
            Gradient.ray_stats(&worker.0)
        }
        fn tile_background(
            &self,
            worker: &mut (u64, bool),
            rays: usize,
        ) -> Option<impl Fn(f64) -> DVec3> {
            worker.1.then(|| {
                self.filled.fetch_add(1, Ordering::Relaxed);
                worker.0 += rays as u64;
                sky
            })
        }
    }

    /// Tiles of background alone are filled by rows: the bytes and ray
    /// counts of asking each pixel, with one sample a pixel or several.
    #[test]
    fn background_tiles_are_the_pixels_radiance() {
        for (w, h, samples) in [(100, 70, 1), (33, 17, 1), (40, 20, 3)] {
            let settings = RenderSettings {
                width: w,
                height: h,
                samples,
                shadows: false,
                bundles: true,
            };
            let image = |proved| {
                let sky = Sky {
                    proved,
                    filled: AtomicUsize::new(0),
                };
                let image = render_tiles(&sky, &settings, &|| {});
                (image, sky.filled.into_inner())
            };
            let ((filled, tiles), (asked, none)) = (image(true), image(false));
            assert_eq!(filled.rgb, asked.rgb, "{w}x{h}");
            assert_eq!(filled.primary.rays, u64::from(w * h * samples));
            assert_eq!(asked.primary.rays, filled.primary.rays);
            assert_eq!(none, 0);
            assert!(tiles > 0);
        }
    }

    #[test]
    fn a_sink_error_stops_the_render() {
        let settings = RenderSettings {
            width: 64,
            height: 640,
            samples: 1,
            shadows: false,
            bundles: true,
        };
        let mut calls = 0;
        let result = render_rows(&Gradient, &settings, &|| {}, &mut |_| {
            calls += 1;
            Err(std::io::Error::other("disk full"))
        });
        assert!(result.is_err());
        assert_eq!(calls, 1);
    }
}
