//! The kept octree leaves a tile's camera rays may cross, gathered once per
//! tile (and per group of pixels in it) so that each camera ray searches a
//! short list instead of walking the octree from its root.
//!
//! Every camera ray of a tile leaves the eye, so the tile is a bundle
//! ([`crate::ray::bundle`]): the tile's list holds every leaf one of its rays
//! may cross, and each [`GROUP`]×[`GROUP`] group of pixels narrows it to its
//! own rays. A listed ray's answer is the walk's, to the bit.

use super::film::TILE;
use crate::ray::bundle::{clear_until_between, clear_until_listed, widen, LeafList};
use crate::ray::Tracer;
use crate::types::Aabb;
use glam::DVec3;

/// Side, in pixels, of the groups of camera rays that share a list of the
/// leaves they may cross: narrow enough that a ray tests few boxes.
pub const GROUP: u32 = 8;

/// Groups a tile has at most.
const GROUPS: usize = (TILE / GROUP * TILE / GROUP) as usize;

/// A tile's camera rays: their directions, by point, and each point's group
/// with the least and greatest direction components of each group.
#[derive(Debug, Default)]
pub struct TileRays {
    eye: DVec3,
    directions: Vec<DVec3>,
    /// The image points, until the groups are made from them.
    points: Vec<(f64, f64)>,
    /// Whether `group_of` and `group_hulls` are the tile's (made when a
    /// list is first kept: most of a quadric's tiles never need them).
    grouped: bool,
    group_of: Vec<u16>,
    /// Each group's least and greatest direction components.
    group_hulls: Vec<(DVec3, DVec3)>,
    /// The whole tile's.
    hull: Option<(DVec3, DVec3)>,
    /// Each point's bundle and each bundle's least and greatest direction
    /// components (see [`BUNDLE`]).
    bundle_of: Vec<u16>,
    bundle_hulls: Vec<(DVec3, DVec3)>,
}

/// Side, in pixels, of the bundles of camera rays that share enclosures of
/// F and g over each leaf they cross.
pub const BUNDLE: u32 = 4;

/// Bundles a tile has at most.
const BUNDLES: usize = (TILE / BUNDLE * TILE / BUNDLE) as usize;

impl TileRays {
    /// The rays from `eye` through the image `points` (the tile's, as the
    /// film gives them), whose directions `directions` appends to the
    /// vector it is given (`directions[k]` through `points[k]`; none: the
    /// tile has no bundle).
    pub fn set(
        &mut self,
        eye: DVec3,
        points: &[(f64, f64)],
        directions: impl FnOnce(&mut Vec<DVec3>),
    ) {
        self.eye = eye;
        self.directions.clear();
        directions(&mut self.directions);
        self.points.clear();
        self.points.extend_from_slice(points);
        self.grouped = false;
        // The rays' least and greatest direction components, as they come.
        self.hull = self.directions.iter().fold(None, |hull, &d| widen(hull, d));
    }

    /// Makes each point's group and each group's hull, once per tile.
    fn group(&mut self) {
        if self.grouped {
            return;
        }
        self.grouped = true;
        self.group_of.clear();
        self.group_hulls.clear();
        let points = &self.points;
        // Groups by pixel, from the tile's top-left pixel.
        let Some(&(x0, y0)) = points.first() else {
            return;
        };
        let (x0, y0) = (x0.floor(), y0.floor());
        let groups_x = points.iter().map(|p| p.0).fold(x0, f64::max) - x0;
        let groups_x = (groups_x as u32) / GROUP + 1;
        let group = |(px, py): (f64, f64)| {
            let (gx, gy) = ((px - x0) as u32 / GROUP, (py - y0) as u32 / GROUP);
            // (A point outside the tile's groups has none: it uses the
            // tile's list.)
            u16::try_from(gy * groups_x + gx).unwrap_or(u16::MAX)
        };
        self.group_of.extend(points.iter().map(|&p| group(p)));
        // Bundles by pixel, as groups are.
        let bundles_x = (groups_x * GROUP).div_ceil(BUNDLE);
        let bundle = |(px, py): (f64, f64)| {
            let (bx, by) = ((px - x0) as u32 / BUNDLE, (py - y0) as u32 / BUNDLE);
            u16::try_from(by * bundles_x + bx).unwrap_or(u16::MAX)
        };
        self.bundle_of.clear();
        self.bundle_of.extend(points.iter().map(|&p| bundle(p)));
        self.bundle_hulls.clear();
        self.bundle_hulls
            .resize(BUNDLES, (DVec3::INFINITY, DVec3::NEG_INFINITY));
        for (&b, &d) in self.bundle_of.iter().zip(&self.directions) {
            if let Some((lo, hi)) = self.bundle_hulls.get_mut(usize::from(b)) {
                (*lo, *hi) = (lo.min(d), hi.max(d));
            }
        }
        let count = self
            .group_of
            .iter()
            .filter(|&&g| usize::from(g) < GROUPS)
            .max()
            .map_or(0, |&g| usize::from(g) + 1);
        self.group_hulls
            .resize(count, (DVec3::INFINITY, DVec3::NEG_INFINITY));
        for (&g, &d) in self.group_of.iter().zip(&self.directions) {
            if let Some((lo, hi)) = self.group_hulls.get_mut(usize::from(g)) {
                (*lo, *hi) = (lo.min(d), hi.max(d));
            }
        }
    }

    /// The eye the rays leave.
    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    /// The least and greatest direction components of the bundle of
    /// camera ray `k` (see [`BUNDLE`]), once the tile's groups are made.
    pub fn bundle_hull(&self, k: usize) -> Option<(DVec3, DVec3)> {
        if !self.grouped {
            return None;
        }
        let b = *self.bundle_of.get(k)?;
        self.bundle_hulls.get(usize::from(b)).copied()
    }

    /// Direction `k`, if the tile has one.
    pub fn direction(&self, k: usize) -> Option<DVec3> {
        self.directions.get(k).copied()
    }
}

/// The leaves one shape's octree holds that a tile's camera rays may cross,
/// and where, for all of them, no surface lies before.
#[derive(Debug, Default)]
pub struct TileLists {
    /// No camera ray of the tile meets the surface before it (+∞: none
    /// meets it at all).
    clear_until: f64,
    /// Every kept leaf a ray may cross past `clear_until` (empty when they
    /// were too many: rays then walk).
    tile: LeafList,
    /// The same for each group (empty when the tile's list was not kept).
    groups: Vec<LeafList>,
    /// Whether `groups` holds the tile's groups.
    grouped: bool,
    /// The bundle `clear_until` was proved for: its origin and the least
    /// and greatest components of its directions.
    bundle: Option<(DVec3, DVec3, DVec3)>,
}

impl TileLists {
    /// Gathers the lists of `tracer`'s octree for `rays`, as seen in the
    /// shape's own coordinates: `origin` is the eye there, and each direction
    /// there is the scene's times `inverse_scale` (`None`: the same). The
    /// tile's sweep first proves empty as much of the space in front of the
    /// surface as it can ([`clear_until_listed`]): rays search from there.
    pub fn gather(
        &mut self,
        tracer: &mut Tracer<'_>,
        bounds: &Aabb,
        rays: &mut TileRays,
        origin: DVec3,
        inverse_scale: Option<f64>,
    ) {
        self.clear_until = 0.0;
        self.grouped = false;
        self.bundle = None;
        self.tile.clear();
        // Rounding is monotone, and a positive factor keeps order: the
        // hull of the scaled directions is the scaled hull, to the bit.
        let scaled = |(lo, hi): (DVec3, DVec3)| match inverse_scale {
            None => Some((lo, hi)),
            Some(s) if s > 0.0 && s.is_finite() => Some((lo * s, hi * s)),
            Some(_) => None,
        };
        let Some(hull) = rays.hull.and_then(scaled) else {
            return;
        };
        self.bundle = Some((origin, hull.0, hull.1));
        // The leaves any ray may cross, then the sweep with them.
        if !self.tile.gather_between(tracer, origin, Some(hull), 0.0) {
            self.clear_until = clear_until_between(tracer, bounds, origin, Some(hull), 0.0);
            return;
        }
        self.clear_until = clear_until_listed(tracer, bounds, &self.tile);
        if self.clear_until == f64::INFINITY {
            self.tile.clear();
            return;
        }
        self.tile.advance(self.clear_until);
        rays.group();
        self.groups
            .resize_with(rays.group_hulls.len(), LeafList::default);
        for (list, &hull) in self.groups.iter_mut().zip(&rays.group_hulls) {
            match scaled(hull) {
                Some((lo, hi)) => list.narrow(tracer, &self.tile, lo, hi),
                None => list.clear(),
            }
        }
        self.grouped = true;
    }

    /// Where the ray `o + t·d` is clear of the surface up to: the tile's
    /// proof where the ray is one of its bundle (its origin, a direction
    /// within its hull), else 0.
    pub fn clear_until(&self, o: DVec3, d: DVec3) -> f64 {
        match self.bundle {
            Some((origin, lo, hi)) if o == origin && d.cmpge(lo).all() && d.cmple(hi).all() => {
                self.clear_until
            }
            _ => 0.0,
        }
    }

    /// Whether the tile's sweep proved that none of its camera rays meets
    /// the surface.
    pub fn clears_tile(&self) -> bool {
        self.bundle.is_some() && self.clear_until == f64::INFINITY
    }

    /// The list camera ray `k` of the tile searches.
    pub fn list(&self, rays: &TileRays, k: usize) -> &LeafList {
        if !self.grouped {
            return &self.tile;
        }
        rays.group_of
            .get(k)
            .and_then(|&g| self.groups.get(usize::from(g)))
            .unwrap_or(&self.tile)
    }
}
