//! The single-surface integrator of `lgc render EXPR`: Blinn–Phong shading
//! with shadow rays, every ray answered by the guaranteed intersector.

use super::camera::Camera;
use super::film::{render_rows, render_tiles, Integrator, RenderSettings, Rendering};
use super::shade::Shading;
use super::tile_lists::{TileLists, TileRays};
use crate::ray::{Intersector, RayStats, Tracer};
use glam::DVec3;

/// One surface seen through a camera, under a [`Shading`].
struct SurfaceIntegrator<'a> {
    scene: &'a Intersector,
    camera: &'a Camera,
    shading: &'a Shading,
    height: f64,
    shadows: bool,
    /// The box's diagonal: the unit of the offsets that leave the surface.
    scale: f64,
    /// Whether each tile's camera rays are swept as a bundle first.
    bundles: bool,
}

/// One thread's state: a tracer for camera rays and one for shadow rays, so
/// each counts its own.
struct Worker<'a> {
    primary: Tracer<'a>,
    shadow: Tracer<'a>,
    /// The current tile's camera rays (none without bundles).
    rays: TileRays,
    /// The kept leaves they may cross.
    lists: TileLists,
}

impl<'a> Integrator for SurfaceIntegrator<'a> {
    type Worker = Worker<'a>;

    fn worker(&self) -> Self::Worker {
        Worker {
            primary: self.scene.tracer(),
            shadow: self.scene.tracer(),
            rays: TileRays::default(),
            lists: TileLists::default(),
        }
    }

    /// The tile's camera rays leave the eye as one bundle: the space in front
    /// of the surface is proved empty for all of them at once. (Bundles of
    /// 8×8 pixels took more instructions than whole 16×16 tiles: each proof
    /// costs an interval evaluation, and a narrower bundle gains little.)
    fn begin_tile(&self, worker: &mut Self::Worker, points: &[(f64, f64)]) {
        let eye = self.camera.eye();
        worker.rays.set(eye, points, |directions| {
            if self.bundles {
                self.camera.directions_into(points, directions);
            }
        });
        let bounds = self.scene.bounds();
        worker
            .lists
            .gather(&mut worker.primary, &bounds, &mut worker.rays, eye, None);
    }

    fn radiance(&self, worker: &mut Self::Worker, k: usize, px: f64, py: f64) -> DVec3 {
        let Worker {
            primary,
            shadow,
            rays,
            lists,
            ..
        } = worker;
        // The tile's sweep computed the camera rays already.
        let (o, d) = match rays.direction(k) {
            Some(d) => (rays.eye(), d),
            None => self.camera.ray(px, py),
        };
        // Without a list that covers the ray, it walks the octree.
        let list = lists.list(rays, k);
        if let Some((lo, hi)) = rays.bundle_hull(k) {
            primary.set_bundle(o, lo, hi);
        }
        let Some(t) = primary.first_hit_in(list, o, d, lists.clear_until(o, d)) else {
            return self.shading.background(py / self.height);
        };
        let p = o + t * d;
        let mut n = primary.normal(p).unwrap_or(-d);
        if n.dot(d) > 0.0 {
            n = -n; // two-sided: face the viewer
        }
        self.shading.surface(n, d, |i| {
            if !self.shadows {
                return true;
            }
            let l = self.shading.lights[i].direction;
            // Leave the surface before looking for blockers.
            let start = p + n * (1e-7 * self.scale);
            shadow
                .first_hit_from_surface(start, l, 1e-6 * self.scale, f64::INFINITY)
                .is_none()
        })
    }

    fn ray_stats(&self, worker: &Self::Worker) -> (RayStats, RayStats) {
        (worker.primary.stats, worker.shadow.stats)
    }

    /// The tile's sweep proved every camera ray of it a miss.
    fn tile_background(
        &self,
        worker: &mut Self::Worker,
        rays: usize,
    ) -> Option<impl Fn(f64) -> DVec3> {
        worker.lists.clears_tile().then(|| {
            worker.primary.count_proved_misses(rays as u64);
            |py: f64| self.shading.background(py / self.height)
        })
    }
}

/// Renders the surface. `progress` is called once per finished tile.
pub fn render(
    scene: &Intersector,
    camera: &Camera,
    shading: &Shading,
    settings: &RenderSettings,
    progress: &(dyn Fn() + Sync),
) -> Rendering {
    render_tiles(
        &SurfaceIntegrator::new(scene, camera, shading, settings),
        settings,
        progress,
    )
}

/// [`render`], handing the finished rows to `sink` band by band instead of
/// holding the image (see [`render_rows`]); returns the primary and shadow
/// rays answered.
pub fn render_into(
    scene: &Intersector,
    camera: &Camera,
    shading: &Shading,
    settings: &RenderSettings,
    progress: &(dyn Fn() + Sync),
    sink: &mut dyn FnMut(&[u8]) -> std::io::Result<()>,
) -> std::io::Result<(RayStats, RayStats)> {
    render_rows(
        &SurfaceIntegrator::new(scene, camera, shading, settings),
        settings,
        progress,
        sink,
    )
}

impl<'a> SurfaceIntegrator<'a> {
    fn new(
        scene: &'a Intersector,
        camera: &'a Camera,
        shading: &'a Shading,
        settings: &RenderSettings,
    ) -> Self {
        SurfaceIntegrator {
            scene,
            camera,
            shading,
            height: f64::from(settings.height),
            shadows: settings.shadows,
            scale: scene.bounds().diagonal(),
            bundles: settings.bundles,
        }
    }
}
