//! Rendering: one or more rays per pixel through the guaranteed intersector,
//! shaded, in parallel over tiles.

use crate::camera::Camera;
use crate::intersect::{Intersector, RayStats};
use crate::shade::{linear_to_srgb8, Shading};
use glam::DVec3;
use rayon::prelude::*;

/// Side of the square tiles that threads take one at a time.
const TILE: u32 = 16;

/// What to render and how.
#[derive(Debug, Clone)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Rays per pixel (anti-aliasing).
    pub samples: u32,
    /// Whether the key light casts shadows.
    pub shadows: bool,
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
    /// Primary (camera) rays.
    pub primary: RayStats,
    /// Shadow rays.
    pub shadow: RayStats,
}

/// One finished tile: its linear colours and the rays it took.
struct TileResult {
    tile: (u32, u32),
    pixels: Vec<DVec3>,
    primary: RayStats,
    shadow: RayStats,
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

/// Renders the surface. `progress` is called once per finished tile.
pub fn render(
    scene: &Intersector,
    camera: &Camera,
    shading: &Shading,
    settings: &RenderSettings,
    progress: &(dyn Fn() + Sync),
) -> Rendering {
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty)))
        .collect();
    let offsets = sample_offsets(settings.samples);
    let scale = (scene.bounds().hi - scene.bounds().lo).length();
    let results: Vec<TileResult> = tiles
        .par_iter()
        .map_init(
            || (scene.tracer(), scene.tracer()),
            |(primary, shadow), &(tx, ty)| {
                let before = (primary.stats, shadow.stats);
                let mut pixels = Vec::with_capacity((TILE * TILE) as usize);
                for y in ty * TILE..((ty + 1) * TILE).min(h) {
                    for x in tx * TILE..((tx + 1) * TILE).min(w) {
                        let mut sum = DVec3::ZERO;
                        for &(ox, oy) in &offsets {
                            let (px, py) = (f64::from(x) + ox, f64::from(y) + oy);
                            let (o, d) = camera.ray(px, py);
                            sum += match primary.first_hit(o, d, 0.0, f64::INFINITY) {
                                None => shading.background(py / f64::from(h)),
                                Some(t) => {
                                    let p = o + t * d;
                                    let mut n = primary.normal(p).unwrap_or(-d);
                                    if n.dot(d) > 0.0 {
                                        n = -n; // two-sided: face the viewer
                                    }
                                    shading.surface(n, d, |i| {
                                        if !settings.shadows {
                                            return true;
                                        }
                                        let l = shading.lights[i].direction;
                                        // Leave the surface before looking for blockers.
                                        let start = p + n * (1e-7 * scale);
                                        shadow
                                            .first_hit(start, l, 1e-6 * scale, f64::INFINITY)
                                            .is_none()
                                    })
                                }
                            };
                        }
                        pixels.push(sum / offsets.len() as f64);
                    }
                }
                progress();
                let p = primary.stats.since(&before.0);
                let s = shadow.stats.since(&before.1);
                TileResult {
                    tile: (tx, ty),
                    pixels,
                    primary: p,
                    shadow: s,
                }
            },
        )
        .collect();
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    let mut primary = RayStats::default();
    let mut shadow = RayStats::default();
    for TileResult {
        tile: (tx, ty),
        pixels,
        primary: p,
        shadow: s,
    } in results
    {
        primary.add(&p);
        shadow.add(&s);
        let mut k = 0;
        for y in ty * TILE..((ty + 1) * TILE).min(h) {
            for x in tx * TILE..((tx + 1) * TILE).min(w) {
                let i = ((y * w + x) * 3) as usize;
                let c = pixels[k];
                rgb[i] = linear_to_srgb8(c.x);
                rgb[i + 1] = linear_to_srgb8(c.y);
                rgb[i + 2] = linear_to_srgb8(c.z);
                k += 1;
            }
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
