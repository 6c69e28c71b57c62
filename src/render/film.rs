//! The film: the one tile loop every integrator shares. Tiles are rendered in
//! parallel, each pixel averaging an integrator's radiance over a
//! low-discrepancy pattern of samples, and converted to 8-bit sRGB.

use super::shade::linear_to_srgb8_rgb;
use crate::ray::RayStats;
use glam::DVec3;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
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
    /// once, and then search the leaves the bundle may cross rather than
    /// walk the octree ([`crate::ray::bundle`], [`super::tile_lists`]; in a
    /// scene, per object); answers are the same either way.
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

/// Bands whose tiles may be rendered before the first of them reaches the
/// sink: one being encoded, and the next ones to keep every thread busy.
pub const BANDS_IN_FLIGHT: usize = 3;

/// Renders the image band by band (see [`band_rows`]) and hands `sink` the
/// finished rows in order from the top, as 8-bit sRGB, while later bands
/// render: memory stays at [`BANDS_IN_FLIGHT`] bands of tiles and the one
/// being sunk, whatever the image's size. Returns the primary and shadow
/// rays answered, or the sink's first error; a panic in a tile, on any
/// thread, is passed on.
///
/// Every thread takes the next tile of the whole image until none is left,
/// so no thread waits at a band's end for the others (measured on a
/// two-core VM, a wait per band left a thread idle for 0.1 to 1.2 ms, a
/// woken core's latency, sixteen times an image); the calling thread also
/// assembles and sinks each band once its tiles are in.
pub fn render_rows<I: Integrator>(
    integrator: &I,
    settings: &RenderSettings,
    progress: &(dyn Fn() + Sync),
    sink: &mut dyn FnMut(&[u8]) -> std::io::Result<()>,
) -> std::io::Result<(RayStats, RayStats)> {
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE) as usize;
    let tiles_y = h.div_ceil(TILE) as usize;
    let band = band_rows(w);
    let band_tile_rows = (band / TILE) as usize;
    let bands = h.div_ceil(band) as usize;
    let total = tiles_x * tiles_y;
    let band_of = |tile: usize| tile / tiles_x / band_tile_rows;
    let tiles_in =
        |b: usize| tiles_x * ((b + 1) * band_tile_rows).min(tiles_y) - tiles_x * b * band_tile_rows;
    let offsets = sample_offsets(settings.samples);
    let shared = Shared {
        next: AtomicUsize::new(0),
        sunk: AtomicUsize::new(0),
        stop: AtomicBool::new(false),
        slots: (0..BANDS_IN_FLIGHT)
            .map(|_| Mutex::new(Vec::new()))
            .collect(),
    };
    // Takes the next tile and renders it into its band's slot, once the
    // band is in flight; `None` when no tile is left (or the sink failed).
    // The worker is made on the thread that uses it, on its first tile:
    // made on one thread, or side by side in one vector, the scratch space
    // and ray counts one thread writes would share cache lines with what
    // the other reads (measured: a scene took 1.1–1.2x the time on two
    // threads).
    let render_next = |worker: &mut Option<I::Worker>, wait: &mut dyn FnMut()| -> Option<()> {
        if shared.stop.load(Ordering::Relaxed) {
            return None;
        }
        let tile = shared.next.fetch_add(1, Ordering::Relaxed);
        if tile >= total {
            return None;
        }
        let b = band_of(tile);
        let mut backoff = Backoff::default();
        while b >= shared.sunk.load(Ordering::Acquire) + BANDS_IN_FLIGHT {
            if shared.stop.load(Ordering::Relaxed) {
                return None;
            }
            wait();
            backoff.wait();
        }
        let worker = worker.get_or_insert_with(|| integrator.worker());
        let at = ((tile % tiles_x) as u32, (tile / tiles_x) as u32);
        let result = render_tile(integrator, worker, at, (w, h), &offsets);
        lock(&shared.slots[b % BANDS_IN_FLIGHT]).push(result);
        progress();
        Some(())
    };
    let mut bands_out = Bands {
        next: 0,
        count: bands,
        rows: Vec::new(),
        primary: RayStats::default(),
        shadow: RayStats::default(),
    };
    let mut failed: std::io::Result<()> = Ok(());
    rayon::in_place_scope(|scope| {
        for _ in 1..rayon::current_num_threads() {
            scope.spawn(|_| {
                let _stop = StopOnPanic(&shared.stop);
                let mut worker = None;
                while render_next(&mut worker, &mut || {}).is_some() {}
            });
        }
        // This thread hands each band to the sink once its tiles are in,
        // between tiles of its own (and then while the others finish).
        let mut sink_ready = || {
            let sunk = bands_out.sink_ready(&shared, (w, h, band), &tiles_in, sink);
            if sunk.is_err() {
                shared.stop.store(true, Ordering::Relaxed);
            }
            sunk
        };
        let _stop = StopOnPanic(&shared.stop);
        let mut worker = None;
        failed = (|| loop {
            let mut waited = Ok(false);
            let rendered = render_next(&mut worker, &mut || {
                if waited.is_ok() {
                    waited = sink_ready();
                }
            });
            let mut all = waited.and_then(|_| sink_ready())?;
            if rendered.is_none() {
                // No tile is left to take: the others' last ones (none
                // come from a thread that panicked: the scope then passes
                // its panic on).
                let mut backoff = Backoff::default();
                while !all && !shared.stop.load(Ordering::Relaxed) {
                    backoff.wait();
                    all = sink_ready()?;
                }
                return Ok(());
            }
        })();
    });
    failed?;
    Ok((bands_out.primary, bands_out.shadow))
}

/// The calling thread's side of [`render_rows`]: bands assembled from their
/// tiles and handed to the sink in order, and the rays their tiles took.
struct Bands {
    /// The next band to sink.
    next: usize,
    /// Bands in the image.
    count: usize,
    /// The band being assembled.
    rows: Vec<u8>,
    primary: RayStats,
    shadow: RayStats,
}

impl Bands {
    /// Hands `sink` every band from the next on whose tiles are all in;
    /// whether every band has gone.
    fn sink_ready(
        &mut self,
        shared: &Shared,
        (w, h, band): (u32, u32, u32),
        tiles_in: &dyn Fn(usize) -> usize,
        sink: &mut dyn FnMut(&[u8]) -> std::io::Result<()>,
    ) -> std::io::Result<bool> {
        while self.next < self.count {
            let results = {
                let mut slot = lock(&shared.slots[self.next % BANDS_IN_FLIGHT]);
                if slot.len() < tiles_in(self.next) {
                    return Ok(false);
                }
                std::mem::take(&mut *slot)
            };
            let y0 = self.next as u32 * band;
            let y1 = (y0 + band).min(h);
            self.rows.clear();
            self.rows.resize(((y1 - y0) * w * 3) as usize, 0);
            for tile in results {
                self.primary.add(&tile.primary);
                self.shadow.add(&tile.shadow);
                let (tx, ty) = tile.tile;
                let (x0, x1) = (tx * TILE, ((tx + 1) * TILE).min(w));
                let row = (3 * (x1 - x0)) as usize;
                for (k, y) in (ty * TILE..((ty + 1) * TILE).min(h)).enumerate() {
                    let start = (((y - y0) * w + x0) * 3) as usize;
                    self.rows[start..start + row]
                        .copy_from_slice(&tile.rgb[k * row..(k + 1) * row]);
                }
            }
            // The slot is free for the band after the next ones in flight.
            self.next += 1;
            shared.sunk.store(self.next, Ordering::Release);
            sink(&self.rows)?;
        }
        Ok(true)
    }
}

/// A wait for another thread of [`render_rows`]: spinning at first, then
/// yielding the core to any other program, then napping, so that a slow
/// sink (a file on a slow disk) costs no CPU. The usual wait is for a tile
/// or a band's encoding, a millisecond or less, and a thread that sleeps
/// lets its core halt (on the two-core VM, a halted core took up to a
/// millisecond to wake). Counted in rounds, not timed: reading the clock
/// for every tile taken cost 1.02-1.04x the wall time of a 1024² render.
#[derive(Default)]
struct Backoff {
    rounds: u32,
}

impl Backoff {
    /// Rounds a wait spins (a pause instruction each, about a millisecond
    /// in all), and then yields, before it naps.
    const SPINS: u32 = 1 << 14;
    const YIELDS: u32 = Self::SPINS + (1 << 12);
    const NAP: std::time::Duration = std::time::Duration::from_micros(200);

    fn wait(&mut self) {
        self.rounds = self.rounds.saturating_add(1);
        if self.rounds < Self::SPINS {
            std::hint::spin_loop();
        } else if self.rounds < Self::YIELDS {
            std::thread::yield_now();
        } else {
            std::thread::sleep(Self::NAP);
        }
    }
}

/// Stops [`render_rows`]' other threads when the one holding it panics, so
/// that none waits for its tiles (or its sink) forever.
struct StopOnPanic<'a>(&'a AtomicBool);

impl Drop for StopOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::Relaxed);
        }
    }
}

/// What the threads of [`render_rows`] share.
struct Shared {
    /// The next tile to take, in rows of tiles from the top.
    next: AtomicUsize,
    /// Bands handed to the sink.
    sunk: AtomicUsize,
    /// Set when the sink failed: no more tiles are taken.
    stop: AtomicBool,
    /// The finished tiles of the bands in flight, band `b` in slot
    /// `b % BANDS_IN_FLIGHT`.
    slots: Vec<Mutex<Vec<TileResult>>>,
}

/// The value behind `m`, whether or not a thread panicked holding it.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::shade::linear_to_srgb8;

    /// A `width`×`height` image of `samples` rays a pixel, no shadows.
    fn settings(width: u32, height: u32, samples: u32) -> RenderSettings {
        RenderSettings {
            width,
            height,
            samples,
            shadows: false,
            bundles: true,
        }
    }

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
            let settings = settings(w, h, 1);
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
    /// afresh. Now one per thread serves the whole image (a thread that
    /// joins after the last tile is taken makes none).
    #[test]
    fn one_worker_per_thread_renders_every_band() {
        let settings = settings(1024, 300, 1);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let counting = Counting(AtomicUsize::new(0));
        let image = pool.install(|| render_tiles(&counting, &settings, &|| {}));
        assert!(settings.height > 4 * band_rows(settings.width));
        assert!((1..=3).contains(&counting.0.load(Ordering::Relaxed)));
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
            let settings = settings(w, h, samples);
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
        // 640 rows of 1024 pixels: ten bands of 64 rows, 256 tiles each.
        let settings = settings(1024, 640, 1);
        assert_eq!(band_rows(1024), 64);
        for threads in [1, 2, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut calls = 0;
            let tiles = AtomicUsize::new(0);
            let result = pool.install(|| {
                render_rows(
                    &Gradient,
                    &settings,
                    &|| {
                        tiles.fetch_add(1, Ordering::Relaxed);
                    },
                    &mut |_| {
                        calls += 1;
                        Err(std::io::Error::other("disk full"))
                    },
                )
            });
            assert!(result.is_err());
            assert_eq!(calls, 1);
            // No tile past the bands in flight, and those in hand, is taken.
            let taken = tiles.into_inner();
            assert!(
                taken <= 256 * (1 + BANDS_IN_FLIGHT) + threads,
                "{taken} tiles on {threads} threads"
            );
        }
    }

    /// Panics at the first pixel it is asked for on the pool thread `caller`
    /// (`on_caller`) or on any other; each tile takes a while, so that
    /// every thread of the pool gets some.
    struct Faulty {
        caller: Option<usize>,
        on_caller: bool,
    }

    impl Integrator for Faulty {
        type Worker = u64;
        fn worker(&self) -> u64 {
            0
        }
        fn begin_tile(&self, _: &mut u64, _: &[(f64, f64)]) {
            std::thread::sleep(std::time::Duration::from_micros(50));
        }
        fn radiance(&self, rays: &mut u64, k: usize, px: f64, py: f64) -> DVec3 {
            let here = rayon::current_thread_index() == self.caller;
            assert!(here != self.on_caller, "faulty pixel");
            Gradient.radiance(rays, k, px, py)
        }
        fn ray_stats(&self, rays: &u64) -> (RayStats, RayStats) {
            Gradient.ray_stats(rays)
        }
    }

    /// A panic while rendering a tile reaches the caller, on whichever
    /// thread it happens, rather than leaving the others waiting for that
    /// tile's band.
    #[test]
    fn a_panic_in_a_tile_reaches_the_caller() {
        let settings = settings(1024, 200, 1);
        for (threads, on_caller) in [(1, true), (2, true), (2, false), (3, false)] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                pool.install(|| {
                    let faulty = Faulty {
                        caller: rayon::current_thread_index(),
                        on_caller,
                    };
                    render_rows(&faulty, &settings, &|| {}, &mut |_| Ok(()))
                })
            }));
            let message = outcome.err().and_then(|p| {
                let text = p.downcast_ref::<&str>().map(|s| s.to_string());
                text.or_else(|| p.downcast_ref::<String>().cloned())
            });
            assert!(
                message.is_some_and(|m| m.contains("faulty pixel")),
                "{threads} threads, on the caller: {on_caller}"
            );
        }
    }

    /// Rows arrive in order and whole on pools of any size, and no thread
    /// runs more than the bands in flight ahead of the sink, however slow
    /// the sink is.
    #[test]
    fn a_slow_sink_holds_the_bands_in_flight() {
        // Sixteen bands of 64 rows, 256 tiles each (the last of 40 rows).
        let (w, h) = (1024, 1000);
        assert_eq!(band_rows(w), 64);
        let settings = settings(w, h, 1);
        let plain = render_tiles(&Gradient, &settings, &|| {});
        for threads in [1, 2, 3, 5] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let tiles = AtomicUsize::new(0);
            let mut rows = Vec::new();
            let mut most_ahead = 0;
            let (primary, _) = pool
                .install(|| {
                    render_rows(
                        &Gradient,
                        &settings,
                        &|| {
                            tiles.fetch_add(1, Ordering::Relaxed);
                        },
                        &mut |band| {
                            let sunk = rows.len() / (3 * 64 * w as usize);
                            // Tiles done beyond this band (the last is short).
                            let done = tiles.load(Ordering::Relaxed);
                            most_ahead = most_ahead.max(done.saturating_sub(256 * (sunk + 1)));
                            rows.extend_from_slice(band);
                            std::thread::sleep(std::time::Duration::from_millis(2));
                            Ok(())
                        },
                    )
                })
                .unwrap();
            assert_eq!(primary.rays, u64::from(w * h));
            assert_eq!(rows, plain.rgb, "{threads} threads");
            assert!(
                most_ahead <= 256 * BANDS_IN_FLIGHT,
                "{most_ahead} tiles ahead on {threads} threads"
            );
            // Not vacuous: with helpers, the others did run ahead.
            assert!(threads == 1 || most_ahead > 0, "{threads} threads");
        }
    }
}
