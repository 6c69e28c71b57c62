//! Whitted ray tracing of a scene: several objects, each answered by its own
//! guaranteed intersector; reflection, refraction with Fresnel weights, total
//! internal reflection, and shadows that transparent objects lighten.

use super::bvh::Bvh;
use super::camera::Camera;
use super::film::{render_rows, render_tiles, Integrator, RenderSettings, Rendering};
use super::optics::{fresnel, reflect, refract};
use super::shade::{highlight, srgb_to_linear, SKY};
use super::tile_lists::{TileLists, TileRays};
use crate::formula::Formula;
use crate::ray::octree::{BuildOptions, Octree};
use crate::ray::{Intersector, RayStats, Tracer};
use crate::scene::{LightKind, Material, Scene};
use crate::types::Aabb;
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::sync::Arc;

/// Ambient light (linear).
const AMBIENT: f64 = 0.05;
/// The default least share of a pixel a reflected or refracted ray is
/// followed for (see [`RayTree::min_weight`]). At 1/1024 the example scenes'
/// pixels move by at most one level of 255 against following every ray.
pub const MIN_WEIGHT: f64 = 1.0 / 1024.0;

/// The deepest ray tree [`RayTree::max_depth`] may ask for: each level is a
/// frame of the tracer's recursion on a thread's stack.
pub const MAX_RAY_DEPTH: u32 = 256;

/// The default [`RayTree::max_depth`].
pub const DEFAULT_RAY_DEPTH: u32 = 5;

/// How far the tree of reflected and refracted rays from a camera ray grows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayTree {
    /// Reflections and refractions a ray may follow.
    pub max_depth: u32,
    /// The least share of the pixel a reflected or refracted ray is followed
    /// for (adaptive depth control, as POV-Ray's `adc_bailout`); below it,
    /// the local light stands in for the ray, as at the depth limit. 0
    /// follows every ray to `max_depth`.
    pub min_weight: f64,
}

impl RayTree {
    /// Rays followed to `max_depth`, or until their share falls below
    /// [`MIN_WEIGHT`].
    pub fn to_depth(max_depth: u32) -> RayTree {
        RayTree {
            max_depth,
            min_weight: MIN_WEIGHT,
        }
    }
}
/// At most this many transparent objects are looked through for a shadow.
const MAX_SHADOW_LAYERS: usize = 8;

/// A scene ready to render: one intersector per distinct shape (objects of
/// the same shape share it, each with its own placement).
pub struct Prepared<'s> {
    scene: &'s Scene,
    /// Each distinct shape's formula and box, and the octree depth.
    distinct: Vec<(&'s Formula, Aabb)>,
    depth: u32,
    shapes: Vec<Intersector>,
    /// For each object, the index of its shape.
    shape_of: Vec<usize>,
    /// The objects' boxes, so that a ray queries only those it crosses.
    bvh: Bvh,
    scale: f64,
    /// Each object's colours, linear: converted once, not at every hit.
    pigments: Vec<Pigment>,
    /// Each light's colour, linear.
    light_colors: Vec<DVec3>,
    /// Each object's `1/scale`: rays enter its coordinates by products, not
    /// the six divisions per query of `Placement::to_object`.
    inverse_scales: Vec<f64>,
}

/// A material's diffuse colours in linear light: the colour, and the checker's
/// second colour and cell size.
#[derive(Debug, Clone, Copy)]
struct Pigment {
    color: DVec3,
    checker: Option<(DVec3, f64)>,
}

impl Pigment {
    fn of(m: &Material) -> Pigment {
        Pigment {
            color: linear(m.color),
            checker: m.checker.map(|(other, tile)| (linear(other), tile)),
        }
    }
}

impl<'s> Prepared<'s> {
    /// Builds every distinct shape's octree at `depth`.
    pub fn new(scene: &'s Scene, depth: u32) -> Prepared<'s> {
        let mut index: FxHashMap<(*const Formula, [u64; 6]), usize> = FxHashMap::default();
        let mut distinct: Vec<(&Formula, Aabb)> = Vec::new();
        let shape_of = scene
            .objects
            .iter()
            .map(|o| {
                let b = o.local_bounds;
                let key = (
                    Arc::as_ptr(&o.formula),
                    [b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z].map(f64::to_bits),
                );
                *index.entry(key).or_insert_with(|| {
                    distinct.push((&o.formula, b));
                    distinct.len() - 1
                })
            })
            .collect();
        let shapes: Vec<Intersector> = distinct
            .par_iter()
            .map(|(f, b)| Intersector::new(f, b, depth))
            .collect();
        let scale = scene
            .objects
            .iter()
            .map(|o| o.bounds.diagonal())
            .fold(0.0, f64::max);
        let boxes: Vec<Aabb> = scene.objects.iter().map(|o| o.bounds).collect();
        Prepared {
            scene,
            distinct,
            depth,
            shapes,
            shape_of,
            bvh: Bvh::new(&boxes),
            scale,
            pigments: scene
                .objects
                .iter()
                .map(|o| Pigment::of(&o.material))
                .collect(),
            light_colors: scene.lights.iter().map(|l| linear(l.color)).collect(),
            inverse_scales: scene
                .objects
                .iter()
                .map(|o| 1.0 / o.placement.scale)
                .collect(),
        }
    }

    /// The smallest box around every object's kept boxes at the octree depth,
    /// to frame a default view: from octrees of their own that subdivide every
    /// kept box to that depth (the intersectors' stop early where the surface
    /// is smooth, and their leaves are larger).
    pub fn surface_bounds(&self) -> Option<Aabb> {
        let options = BuildOptions {
            coarse_quadrics: false,
            leaf_bounds: false,
            ..BuildOptions::to_depth(self.depth)
        };
        let framed: Vec<Option<Aabb>> = self
            .distinct
            .par_iter()
            .map(|(f, b)| Octree::build_with(f, b, &options).surface_bounds())
            .collect();
        self.scene
            .objects
            .iter()
            .zip(&self.shape_of)
            .filter_map(|(o, &k)| Some(o.placement.to_scene(&framed[k]?)))
            .reduce(|a, b| a.union(&b))
    }

    /// How many distinct shapes the objects share.
    pub fn shape_count(&self) -> usize {
        self.shapes.len()
    }
}

/// Objects per tile whose leaves its camera rays search from lists; camera
/// rays that query more objects walk those objects' octrees, as other rays
/// do. (Lists are gathered for an object when the tile's first camera ray
/// queries it, so the cap bounds the work and memory of each tile.)
pub const LISTED_OBJECTS: usize = 8;

/// Per-thread state: per shape, a tracer for camera and secondary rays and
/// one for shadow rays, so that each counts its own work.
struct Worker<'p> {
    tracers: Vec<Tracer<'p>>,
    shadow_tracers: Vec<Tracer<'p>>,
    /// Scratch space of the object hierarchy's walk.
    bvh_stack: Vec<(usize, f64)>,
    /// The current tile's camera rays.
    rays: TileRays,
    /// The objects the tile's camera rays have queried, in turn; the lists
    /// of the `k`th are `lists[k]` (kept from tile to tile for their space).
    listed: Vec<usize>,
    lists: Vec<TileLists>,
    /// Reflected and refracted rays the current pixel may still follow.
    secondary_left: u32,
}

/// At most this many reflected and refracted rays are followed per pixel:
/// a tree that splits at every level (nested glass, `--min-weight 0`) would
/// otherwise take 2^depth rays. Past it, the local light stands in for a
/// ray, as at the depth limit.
pub const MAX_SECONDARY_RAYS: u32 = 4096;

/// What a ray query is for, so that the summary counts it where it belongs
/// and rays leaving a surface are answered as such.
#[derive(Clone, Copy)]
enum Query {
    /// Camera ray `k` of the tile.
    Camera(usize),
    /// Reflected and refracted rays.
    Secondary,
    /// Rays towards a light.
    Shadow,
}

/// The nearest hit: object index and t (for a shadow ray, any hit on an
/// opaque object, else the nearest).
fn nearest(
    prepared: &Prepared<'_>,
    w: &mut Worker<'_>,
    query: Query,
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(usize, f64)> {
    let Worker {
        tracers,
        shadow_tracers,
        bvh_stack,
        rays,
        listed,
        lists,
        ..
    } = w;
    // A shadow ray is blocked by any opaque object it meets: the first
    // found ends its search.
    let opaque = |i: usize| {
        matches!(query, Query::Shadow) && prepared.scene.objects[i].material.transparency <= 0.0
    };
    let best = prepared.bvh.nearest_or(
        o,
        d,
        t_min,
        t_max,
        bvh_stack,
        |i, limit| {
            let object = &prepared.scene.objects[i];
            let shape = prepared.shape_of[i];
            let tracer = match query {
                Query::Shadow => &mut shadow_tracers[shape],
                Query::Camera(_) | Query::Secondary => &mut tracers[shape],
            };
            // The same t in the object's own coordinates (each rounded
            // once more than by division: the object's tracer answers the
            // ray it is given, so its certificate is unchanged).
            let placement = &object.placement;
            let inverse = (placement.scale != 1.0).then(|| prepared.inverse_scales[i]);
            let (lo, ld) = match inverse {
                None => (o - placement.offset, d),
                Some(inverse) => ((o - placement.offset) * inverse, d * inverse),
            };
            let hit = match query {
                Query::Camera(k) => {
                    // The object's lists for the tile, gathered when its
                    // first camera ray queries it.
                    // (A formula answered in closed form gains nothing.)
                    let lists_pay = !tracer.closed_form();
                    let at = listed.iter().position(|&j| j == i).or_else(|| {
                        (lists_pay && listed.len() < LISTED_OBJECTS).then(|| {
                            let at = listed.len();
                            if lists.len() == at {
                                lists.push(TileLists::default());
                            }
                            let bounds = prepared.shapes[shape].bounds();
                            let eye = rays.eye();
                            let origin = match inverse {
                                None => eye - placement.offset,
                                Some(inverse) => (eye - placement.offset) * inverse,
                            };
                            lists[at].gather(tracer, &bounds, rays, origin, inverse);
                            listed.push(i);
                            at
                        })
                    });
                    match at {
                        Some(at) => {
                            let lists = &lists[at];
                            let from = lists.clear_until(lo, ld).max(t_min);
                            if from == f64::INFINITY {
                                tracer.count_proved_misses(1);
                                None
                            } else {
                                tracer.first_hit_in_until(lists.list(rays, k), lo, ld, from, limit)
                            }
                        }
                        None => tracer.first_hit(lo, ld, t_min, limit),
                    }
                }
                Query::Secondary | Query::Shadow => {
                    tracer.first_hit_from_surface(lo, ld, t_min, limit)
                }
            };
            hit
        },
        opaque,
    );
    best
}

fn linear(c: DVec3) -> DVec3 {
    DVec3::from(c.to_array().map(srgb_to_linear))
}

/// The diffuse colour at `p` with normal `n`: a checker is laid out in the
/// two axes across the normal, so a plane's own coordinate (noisy at the ulp
/// level on a hit) never decides the cell.
fn albedo(m: &Pigment, p: DVec3, n: DVec3) -> DVec3 {
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
                m.color
            } else {
                other
            }
        }
        None => m.color,
    }
}

fn sky(d: DVec3) -> DVec3 {
    let v = (0.5 * (1.0 - d.z.clamp(-1.0, 1.0))).clamp(0.0, 1.0);
    SKY.0.lerp(SKY.1, v)
}

struct Tracing<'a, 'p> {
    prepared: &'a Prepared<'p>,
    tree: RayTree,
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
            match nearest(self.prepared, w, Query::Shadow, start, l, self.eps, left) {
                None => return through,
                Some((i, t)) => {
                    let m = &self.prepared.scene.objects[i].material;
                    if m.transparency <= 0.0 {
                        return DVec3::ZERO;
                    }
                    let hit = start + t * l;
                    through *= m.transparency
                        * albedo(&self.prepared.pigments[i], hit, l).lerp(DVec3::ONE, 0.5);
                    start = hit;
                    left -= t;
                }
            }
        }
        through
    }

    /// The radiance along a ray whose light reaches the pixel scaled by at
    /// most `weight`.
    /// `query`: a camera ray (at depth 0) or a secondary ray.
    fn trace(
        &self,
        w: &mut Worker<'_>,
        (o, d): (DVec3, DVec3),
        query: Query,
        depth: u32,
        weight: f64,
    ) -> DVec3 {
        let t_min = match query {
            Query::Camera(_) => 0.0,
            Query::Secondary | Query::Shadow => self.eps,
        };
        let Some((i, t)) = nearest(self.prepared, w, query, o, d, t_min, f64::INFINITY) else {
            return sky(d);
        };
        let object = &self.prepared.scene.objects[i];
        let m = &object.material;
        let p = o + t * d;
        let outward = w.tracers[self.prepared.shape_of[i]]
            .normal(object.placement.to_object(p))
            .unwrap_or(-d);
        let entering = d.dot(outward) < 0.0;
        let n = if entering { outward } else { -outward };
        let base = albedo(&self.prepared.pigments[i], p, outward);

        // Local Blinn–Phong light, with shadows.
        let mut local = base * AMBIENT;
        let lights = self.prepared.scene.lights.iter();
        for (light, &light_color) in lights.zip(&self.prepared.light_colors) {
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
            let spec = highlight(n.dot(h), m.shininess) * m.specular;
            local += light_color
                * light.intensity
                * reach
                * (base * m.diffuse * ndl + DVec3::splat(spec));
        }
        let opaque = (1.0 - m.transparency - m.reflect).max(0.0);
        let mut color = local * opaque;
        if depth >= self.tree.max_depth {
            return color + local * (m.transparency + m.reflect);
        }
        // Fresnel's split of a transparent material's share, and where the
        // refracted ray goes (none: total internal reflection).
        let (eta_i, eta_t) = if entering { (1.0, m.ior) } else { (m.ior, 1.0) };
        let (kr, refracted) = if m.transparency > 0.0 {
            (
                fresnel(-d.dot(n), eta_i, eta_t),
                refract(d, n, eta_i, eta_t),
            )
        } else {
            (0.0, None)
        };
        let tint = if entering { DVec3::ONE } else { base };
        // What each secondary ray can add to the pixel. A ray that could add
        // less than `min_weight` is not followed: like a ray at the depth
        // limit, the local light stands in for it.
        let through_share = m.transparency * (1.0 - kr) * tint.max_element();
        let mirror_share = m.reflect
            + m.transparency * kr
            + if refracted.is_none() {
                through_share
            } else {
                0.0
            };
        let follow = |w: &mut Worker<'_>, share: f64| {
            let wanted = share > 0.0 && weight * share >= self.tree.min_weight;
            let allowed = wanted && w.secondary_left > 0;
            w.secondary_left -= u32::from(allowed);
            allowed
        };
        // The mirror ray serves both the material's reflection and the
        // Fresnel reflection of a transparent one: it is traced once.
        let mirrored = if follow(w, mirror_share) {
            self.trace(
                w,
                (p + n * self.eps, reflect(d, n)),
                Query::Secondary,
                depth + 1,
                weight * mirror_share,
            )
        } else {
            local
        };
        if m.reflect > 0.0 {
            color += m.reflect * mirrored;
        }
        if m.transparency > 0.0 {
            let through = match refracted {
                Some(tdir) if follow(w, through_share) => {
                    let ray = (p - n * self.eps, tdir);
                    self.trace(w, ray, Query::Secondary, depth + 1, weight * through_share)
                }
                Some(_) => local,
                None => mirrored, // total internal reflection
            };
            color += m.transparency * (kr * mirrored + (1.0 - kr) * through * tint);
        }
        color
    }
}

struct SceneIntegrator<'a, 'p> {
    tracing: Tracing<'a, 'p>,
    camera: &'a Camera,
    /// Whether each tile's camera rays search leaf lists (off: they walk).
    bundles: bool,
}

impl<'a, 'p> Integrator for SceneIntegrator<'a, 'p> {
    type Worker = Worker<'a>;

    fn worker(&self) -> Worker<'a> {
        let shapes = &self.tracing.prepared.shapes;
        Worker {
            tracers: shapes.iter().map(|s| s.tracer()).collect(),
            shadow_tracers: shapes.iter().map(|s| s.tracer()).collect(),
            bvh_stack: Vec::new(),
            rays: TileRays::default(),
            listed: Vec::new(),
            lists: Vec::new(),
            secondary_left: MAX_SECONDARY_RAYS,
        }
    }

    /// The tile's camera rays leave the eye as a bundle: each object they
    /// query lists the leaves they may cross once for all of them.
    fn begin_tile(&self, worker: &mut Worker<'a>, points: &[(f64, f64)]) {
        worker.rays.set(self.camera.eye(), points, |directions| {
            if self.bundles {
                self.camera.directions_into(points, directions);
            }
        });
        worker.listed.clear();
    }

    fn radiance(&self, worker: &mut Worker<'a>, k: usize, px: f64, py: f64) -> DVec3 {
        // `begin_tile` computed the camera rays already.
        let ray = match worker.rays.direction(k) {
            Some(d) => (worker.rays.eye(), d),
            None => self.camera.ray(px, py),
        };
        worker.secondary_left = MAX_SECONDARY_RAYS;
        self.tracing.trace(worker, ray, Query::Camera(k), 0, 1.0)
    }

    fn ray_stats(&self, worker: &Worker<'a>) -> (RayStats, RayStats) {
        let total = |tracers: &[Tracer<'_>]| {
            tracers.iter().fold(RayStats::default(), |mut sum, t| {
                sum.add(&t.stats);
                sum
            })
        };
        (total(&worker.tracers), total(&worker.shadow_tracers))
    }
}

/// Renders a prepared scene through `camera`. `tree` bounds reflection and
/// refraction; `progress` is called once per finished tile.
pub fn render_scene(
    prepared: &Prepared<'_>,
    camera: &Camera,
    settings: &RenderSettings,
    tree: RayTree,
    progress: &(dyn Fn() + Sync),
) -> Rendering {
    let integrator = SceneIntegrator::new(prepared, camera, settings, tree);
    render_tiles(&integrator, settings, progress)
}

/// [`render_scene`], handing the finished rows to `sink` band by band
/// instead of holding the image; returns the primary and shadow queries.
pub fn render_scene_into(
    prepared: &Prepared<'_>,
    camera: &Camera,
    settings: &RenderSettings,
    tree: RayTree,
    progress: &(dyn Fn() + Sync),
    sink: &mut dyn FnMut(&[u8]) -> std::io::Result<()>,
) -> std::io::Result<(RayStats, RayStats)> {
    let integrator = SceneIntegrator::new(prepared, camera, settings, tree);
    render_rows(&integrator, settings, progress, sink)
}

impl<'a, 'p> SceneIntegrator<'a, 'p> {
    fn new(
        prepared: &'a Prepared<'p>,
        camera: &'a Camera,
        settings: &RenderSettings,
        tree: RayTree,
    ) -> Self {
        SceneIntegrator {
            tracing: Tracing {
                prepared,
                tree,
                eps: 1e-7 * prepared.scale.max(1e-300),
                shadows: settings.shadows,
            },
            camera,
            bundles: settings.bundles,
        }
    }
}
