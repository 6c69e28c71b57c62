//! Whitted ray tracing of a scene: several objects, each answered by its own
//! guaranteed intersector; reflection, refraction with Fresnel weights, total
//! internal reflection, and shadows that transparent objects lighten.

use crate::camera::Camera;
use crate::intersect::{Intersector, RayStats, Tracer};
use crate::optics::{fresnel, reflect, refract};
use crate::render::{sample_offsets, RenderSettings, Rendering};
use crate::scene::{LightKind, Material, Scene};
use crate::shade::{linear_to_srgb8, srgb_to_linear};
use glam::DVec3;
use rayon::prelude::*;

/// Ambient light (linear).
const AMBIENT: f64 = 0.05;
/// At most this many transparent objects are looked through for a shadow.
const MAX_SHADOW_LAYERS: usize = 8;

/// A scene ready to render: one intersector per object.
pub struct Prepared<'s> {
    scene: &'s Scene,
    objects: Vec<Intersector>,
    scale: f64,
}

impl<'s> Prepared<'s> {
    /// Builds every object's octree at `depth`.
    pub fn new(scene: &'s Scene, depth: u32) -> Prepared<'s> {
        let objects: Vec<Intersector> = scene
            .objects
            .par_iter()
            .map(|o| Intersector::new(&o.formula, &o.bounds, depth))
            .collect();
        let scale = scene
            .objects
            .iter()
            .map(|o| (o.bounds.hi - o.bounds.lo).length())
            .fold(0.0, f64::max);
        Prepared {
            scene,
            objects,
            scale,
        }
    }

    /// The smallest box around every object's kept leaves.
    pub fn surface_bounds(&self) -> Option<crate::bounds::Aabb> {
        self.objects
            .iter()
            .filter_map(|o| o.surface_bounds())
            .reduce(|a, b| crate::bounds::Aabb {
                lo: a.lo.min(b.lo),
                hi: a.hi.max(b.hi),
            })
    }
}

/// Per-thread state: one tracer per object.
struct Worker<'p> {
    tracers: Vec<Tracer<'p>>,
}

/// The nearest hit: object index and t.
fn nearest(w: &mut Worker<'_>, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (i, tracer) in w.tracers.iter_mut().enumerate() {
        let limit = best.map_or(t_max, |b| b.1);
        if let Some(t) = tracer.first_hit(o, d, t_min, limit) {
            if best.is_none_or(|b| t < b.1) {
                best = Some((i, t));
            }
        }
    }
    best
}

fn linear(c: DVec3) -> DVec3 {
    DVec3::from(c.to_array().map(srgb_to_linear))
}

/// The material's diffuse colour at `p` with normal `n`: a checker is laid
/// out in the two axes across the normal, so a plane's own coordinate (noisy
/// at the ulp level on a hit) never decides the cell.
fn albedo(m: &Material, p: DVec3, n: DVec3) -> DVec3 {
    match m.checker {
        Some((other, tile)) => {
            let k = (p / tile).floor();
            let a = n.abs();
            let sum = if a.z >= a.x && a.z >= a.y {
                k.x + k.y
            } else if a.y >= a.x {
                k.x + k.z
            } else {
                k.y + k.z
            };
            if sum.rem_euclid(2.0) < 1.0 {
                linear(m.color)
            } else {
                linear(other)
            }
        }
        None => linear(m.color),
    }
}

fn sky(d: DVec3) -> DVec3 {
    let v = (0.5 * (1.0 - d.z.clamp(-1.0, 1.0))).clamp(0.0, 1.0);
    crate::shade::SKY.0.lerp(crate::shade::SKY.1, v)
}

struct Tracing<'a, 'p> {
    prepared: &'a Prepared<'p>,
    max_depth: u32,
    eps: f64,
    shadows: bool,
}

impl Tracing<'_, '_> {
    /// How much of a light reaches `p` along `l` (up to `dist`): 1, 0, or the
    /// product of the transparencies of the objects in the way.
    fn transmission(&self, w: &mut Worker<'_>, p: DVec3, l: DVec3, dist: f64) -> DVec3 {
        let mut through = DVec3::ONE;
        let mut start = p;
        let mut left = dist;
        for _ in 0..MAX_SHADOW_LAYERS {
            match nearest(w, start, l, self.eps, left) {
                None => return through,
                Some((i, t)) => {
                    let m = &self.prepared.scene.objects[i].material;
                    if m.transparency <= 0.0 {
                        return DVec3::ZERO;
                    }
                    let hit = start + t * l;
                    through *= m.transparency * albedo(m, hit, l).lerp(DVec3::ONE, 0.5);
                    start = hit;
                    left -= t;
                }
            }
        }
        through
    }

    fn trace(&self, w: &mut Worker<'_>, o: DVec3, d: DVec3, depth: u32) -> DVec3 {
        let Some((i, t)) = nearest(
            w,
            o,
            d,
            if depth == 0 { 0.0 } else { self.eps },
            f64::INFINITY,
        ) else {
            return sky(d);
        };
        let object = &self.prepared.scene.objects[i];
        let m = &object.material;
        let p = o + t * d;
        let outward = w.tracers[i].normal(p).unwrap_or(-d);
        let entering = d.dot(outward) < 0.0;
        let n = if entering { outward } else { -outward };
        let base = albedo(m, p, outward);

        // Local Blinn–Phong light, with shadows.
        let mut local = base * AMBIENT;
        for light in &self.prepared.scene.lights {
            let (l, dist) = match light.kind {
                LightKind::Directional(dir) => (dir, f64::INFINITY),
                LightKind::Point(pos) => {
                    let v = pos - p;
                    (v.normalize(), v.length())
                }
            };
            let ndl = n.dot(l);
            if ndl <= 0.0 {
                continue;
            }
            let reach = if self.shadows {
                self.transmission(w, p + n * self.eps, l, dist)
            } else {
                DVec3::ONE
            };
            if reach == DVec3::ZERO {
                continue;
            }
            let h = (l - d).normalize();
            let spec = n.dot(h).max(0.0).powf(m.shininess) * m.specular;
            local += light.color * reach * (base * m.diffuse * ndl + DVec3::splat(spec));
        }
        let opaque = (1.0 - m.transparency - m.reflect).max(0.0);
        let mut color = local * opaque;
        if depth >= self.max_depth {
            return color + local * (m.transparency + m.reflect);
        }
        if m.reflect > 0.0 {
            let r = reflect(d, n);
            color += m.reflect * self.trace(w, p + n * self.eps, r, depth + 1);
        }
        if m.transparency > 0.0 {
            let (eta_i, eta_t) = if entering { (1.0, m.ior) } else { (m.ior, 1.0) };
            let cos_i = -d.dot(n);
            let kr = fresnel(cos_i, eta_i, eta_t);
            let mirrored = self.trace(w, p + n * self.eps, reflect(d, n), depth + 1);
            let through = match refract(d, n, eta_i, eta_t) {
                Some(tdir) => self.trace(w, p - n * self.eps, tdir, depth + 1),
                None => mirrored, // total internal reflection
            };
            let tint = if entering { DVec3::ONE } else { base };
            color += m.transparency * (kr * mirrored + (1.0 - kr) * through * tint);
        }
        color
    }
}

/// Renders a prepared scene through `camera`. `max_depth` bounds reflection
/// and refraction; `progress` is called once per finished row.
pub fn render_scene(
    prepared: &Prepared<'_>,
    camera: &Camera,
    settings: &RenderSettings,
    max_depth: u32,
    progress: &(dyn Fn() + Sync),
) -> Rendering {
    let (w, h) = (settings.width, settings.height);
    let offsets = sample_offsets(settings.samples);
    let tracing = Tracing {
        prepared,
        max_depth,
        eps: 1e-7 * prepared.scale.max(1e-300),
        shadows: settings.shadows,
    };
    let rows: Vec<(Vec<u8>, RayStats)> = (0..h)
        .into_par_iter()
        .map_init(
            || Worker {
                tracers: prepared.objects.iter().map(|o| o.tracer()).collect(),
            },
            |worker, y| {
                let before: Vec<RayStats> = worker.tracers.iter().map(|t| t.stats).collect();
                let mut row = Vec::with_capacity(3 * w as usize);
                for x in 0..w {
                    let mut sum = DVec3::ZERO;
                    for &(ox, oy) in &offsets {
                        let (o, d) = camera.ray(f64::from(x) + ox, f64::from(y) + oy);
                        sum += tracing.trace(worker, o, d, 0);
                    }
                    let c = sum / offsets.len() as f64;
                    row.extend([
                        linear_to_srgb8(c.x),
                        linear_to_srgb8(c.y),
                        linear_to_srgb8(c.z),
                    ]);
                }
                progress();
                let mut stats = RayStats::default();
                for (t, b) in worker.tracers.iter().zip(&before) {
                    stats.add(&t.stats.since(b));
                }
                (row, stats)
            },
        )
        .collect();
    let mut rgb = Vec::with_capacity((3 * w * h) as usize);
    let mut primary = RayStats::default();
    for (row, stats) in rows {
        rgb.extend(row);
        primary.add(&stats);
    }
    Rendering {
        width: w,
        height: h,
        rgb,
        primary,
        shadow: RayStats::default(),
    }
}
