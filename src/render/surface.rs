//! The single-surface integrator of `lgc render EXPR`: Blinn–Phong shading
//! with shadow rays, every ray answered by the guaranteed intersector.

use super::camera::Camera;
use super::film::{render_rows, render_tiles, Integrator, RenderSettings, Rendering, TILE};
use super::shade::Shading;
use crate::ray::bundle::{clear_until_between, clear_until_listed, widen, LeafList};
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
    /// Where the current tile's camera rays start: no surface before it.
    clear_until: f64,
    /// The current tile's camera ray directions, by point (empty without
    /// bundles).
    directions: Vec<DVec3>,
    /// The kept leaves the tile's camera rays may cross past `clear_until`.
    tile_leaves: LeafList,
    /// The same for each group of [`GROUP`]×[`GROUP`] pixels, and each
    /// point's group (empty when the tile's list was not kept).
    group_leaves: Vec<LeafList>,
    group_of: Vec<u16>,
}

/// Side, in pixels, of the groups of camera rays that share a list of the
/// leaves they may cross: narrow enough that a ray tests few boxes.
const GROUP: u32 = 8;

impl<'a> Integrator for SurfaceIntegrator<'a> {
    type Worker = Worker<'a>;

    fn worker(&self) -> Self::Worker {
        Worker {
            primary: self.scene.tracer(),
            shadow: self.scene.tracer(),
            clear_until: 0.0,
            directions: Vec::new(),
            tile_leaves: LeafList::default(),
            group_leaves: Vec::new(),
            group_of: Vec::new(),
        }
    }

    /// The tile's camera rays leave the eye as one bundle: the space in front
    /// of the surface is proved empty for all of them at once. (Bundles of
    /// 8×8 pixels took more instructions than whole 16×16 tiles: each proof
    /// costs an interval evaluation, and a narrower bundle gains little.)
    fn begin_tile(&self, worker: &mut Self::Worker, points: &[(f64, f64)]) {
        worker.clear_until = 0.0;
        worker.directions.clear();
        worker.group_of.clear();
        worker.tile_leaves.clear();
        if !self.bundles {
            return;
        }
        let eye = self.camera.eye();
        self.camera.directions_into(points, &mut worker.directions);
        // The rays' least and greatest direction components, as they come.
        let hull = worker
            .directions
            .iter()
            .fold(None, |hull, &d| widen(hull, d));
        let bounds = self.scene.bounds();
        // The leaves any ray may cross, then the sweep with them.
        let tile = &mut worker.tile_leaves;
        if !tile.gather_between(&worker.primary, eye, hull, 0.0) {
            worker.clear_until = clear_until_between(&mut worker.primary, &bounds, eye, hull, 0.0);
            return;
        }
        worker.clear_until = clear_until_listed(&mut worker.primary, &bounds, tile);
        if worker.clear_until == f64::INFINITY {
            tile.clear();
            return;
        }
        tile.advance(worker.clear_until);
        // Groups by pixel, from the tile's top-left pixel.
        let Some(&(x0, y0)) = points.first() else {
            return;
        };
        let (x0, y0) = (x0.floor(), y0.floor());
        let groups_x = points.iter().map(|p| p.0).fold(x0, f64::max) - x0;
        let groups_x = (groups_x as u32) / GROUP + 1;
        let group = |(px, py): (f64, f64)| {
            let (gx, gy) = ((px - x0) as u32 / GROUP, (py - y0) as u32 / GROUP);
            (gy * groups_x + gx) as u16
        };
        worker.group_of.extend(points.iter().map(|&p| group(p)));
        let count = worker.group_of.iter().max().map_or(0, |&g| g as usize + 1);
        let mut hulls =
            [(DVec3::INFINITY, DVec3::NEG_INFINITY); (TILE / GROUP * TILE / GROUP) as usize];
        for (&g, &d) in worker.group_of.iter().zip(&worker.directions) {
            let (lo, hi) = &mut hulls[g as usize];
            (*lo, *hi) = (lo.min(d), hi.max(d));
        }
        worker.group_leaves.resize_with(count, LeafList::default);
        for (list, &(lo, hi)) in worker.group_leaves.iter_mut().zip(&hulls) {
            list.narrow(&worker.primary, &worker.tile_leaves, lo, hi);
        }
    }

    fn radiance(&self, worker: &mut Self::Worker, k: usize, px: f64, py: f64) -> DVec3 {
        let Worker {
            primary,
            shadow,
            clear_until,
            directions,
            tile_leaves,
            group_leaves,
            group_of,
        } = worker;
        // The tile's sweep computed the camera rays already.
        let (o, d) = match directions.get(k) {
            Some(&d) => (self.camera.eye(), d),
            None => self.camera.ray(px, py),
        };
        // Without groups the tile's list is empty and rays walk the octree.
        let list = group_of
            .get(k)
            .map_or(&*tile_leaves, |&g| &group_leaves[g as usize]);
        let Some(t) = primary.first_hit_in(list, o, d, *clear_until) else {
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
        (worker.clear_until == f64::INFINITY).then(|| {
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
            scale: (scene.bounds().hi - scene.bounds().lo).length(),
            bundles: settings.bundles,
        }
    }
}
