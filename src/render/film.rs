//! The film: the one tile loop every integrator shares. Tiles are rendered in
//! parallel, each pixel averaging an integrator's radiance over a
//! low-discrepancy pattern of samples, and converted to 8-bit sRGB.

use super::shade::linear_to_srgb8;
use crate::ray::RayStats;
use glam::DVec3;
use rayon::prelude::*;

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
    /// `width·height·3` bytes.
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

    /// The linear colour seen through the image point `(px, py)` (pixels,
    /// from the top-left corner).
    fn radiance(&self, worker: &mut Self::Worker, px: f64, py: f64) -> DVec3;

    /// The rays `worker` has answered so far: primary and shadow.
    fn ray_stats(&self, worker: &Self::Worker) -> (RayStats, RayStats);
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

/// Renders every tile with `integrator`; `progress` is called once per
/// finished tile (see [`RenderSettings::tile_count`]).
pub fn render_tiles<I: Integrator>(
    integrator: &I,
    settings: &RenderSettings,
    progress: &(dyn Fn() + Sync),
) -> Rendering {
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty)))
        .collect();
    let offsets = sample_offsets(settings.samples);
    let results: Vec<TileResult> = tiles
        .par_iter()
        .map_init(
            || integrator.worker(),
            |worker, &(tx, ty)| {
                let before = integrator.ray_stats(worker);
                let mut rgb = Vec::with_capacity((3 * TILE * TILE) as usize);
                for y in ty * TILE..((ty + 1) * TILE).min(h) {
                    for x in tx * TILE..((tx + 1) * TILE).min(w) {
                        let mut sum = DVec3::ZERO;
                        for &(ox, oy) in &offsets {
                            sum +=
                                integrator.radiance(worker, f64::from(x) + ox, f64::from(y) + oy);
                        }
                        let c = sum / offsets.len() as f64;
                        rgb.extend([c.x, c.y, c.z].map(linear_to_srgb8));
                    }
                }
                progress();
                let after = integrator.ray_stats(worker);
                TileResult {
                    tile: (tx, ty),
                    rgb,
                    primary: after.0.since(&before.0),
                    shadow: after.1.since(&before.1),
                }
            },
        )
        .collect();
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    let mut primary = RayStats::default();
    let mut shadow = RayStats::default();
    for tile in results {
        primary.add(&tile.primary);
        shadow.add(&tile.shadow);
        let (tx, ty) = tile.tile;
        let (x0, x1) = (tx * TILE, ((tx + 1) * TILE).min(w));
        let row = (3 * (x1 - x0)) as usize;
        for (k, y) in (ty * TILE..((ty + 1) * TILE).min(h)).enumerate() {
            let start = ((y * w + x0) * 3) as usize;
            rgb[start..start + row].copy_from_slice(&tile.rgb[k * row..(k + 1) * row]);
        }
    }
    Rendering {
        width: w,
        height: h,
        rgb,
        primary,
        shadow,
    }
}
