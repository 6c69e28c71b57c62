//! Enclosures of F and g that a bundle's rays share: one evaluation over
//! the region the bundle crosses in a leaf serves every ray's pieces there.
//!
//! The camera rays of a group of pixels leave one eye in nearly one
//! direction, and each one that reaches a leaf near the surface encloses F
//! and g over its piece of the ray there: on long models, most of a
//! render's time. Every such piece lies in one box: the points
//! `o + t·d` of the leaf's hull, `d` in the bundle's directions, with the
//! directions themselves as g's inputs. Enclosures over that box enclose F
//! and g over each piece in it, so where they decide (F's excludes 0, or F
//! is continuous and g's excludes 0: F is monotone on every piece), each
//! ray takes them instead of its own; elsewhere each evaluates its own, as
//! without a bundle. Whether a piece lies in the box is checked, not
//! assumed: a ray outside the bundle, or moved, evaluates its own.
//!
//! Answers stay certified: a ray's tests read the shared enclosures as they
//! read its own, which are inside them. Its hit may lie elsewhere within
//! the tolerance than the one it finds alone.
//!
//! A leaf cut into cells ([`Cells`](crate::ray::octree::Cells)) shares
//! nothing: its cells' short tapes and clear cells already cost less.

use super::eval::FG_CUTS;
use super::*;
use crate::ray::octree::padded;

/// Leaves (and shapes) of one bundle whose enclosures are kept: past them,
/// rays evaluate their own.
const MAX_SHARED: usize = 64;

/// Bundles whose enclosures are kept at once: the rays of a tile come
/// row by row, so consecutive rays belong to neighbouring bundles.
const MAX_BUNDLES: usize = 8;

/// The shared enclosures of the last few bundles, and the current one.
#[derive(Clone, Debug, Default)]
pub(crate) struct SharedEnclosures {
    bundles: Vec<Bundle>,
    /// The bundle of the rays to come (`None`: every ray evaluates its own).
    current: Option<usize>,
    /// The slot the next new bundle takes once all are used.
    next: usize,
}

/// A bundle: its origin and the componentwise least and greatest of its
/// directions, and its enclosures.
#[derive(Clone, Debug)]
struct Bundle {
    key: (DVec3, DVec3, DVec3),
    entries: Vec<Shared>,
}

/// The enclosures of one shape over the bundle's region of one leaf's hull
/// (`inputs`), where they decide.
#[derive(Clone, Debug)]
struct Shared {
    leaf: usize,
    shape: usize,
    inputs: [Interval; 6],
    /// F's and g's enclosures and whether F is continuous there; `None`
    /// where they decide nothing.
    found: Option<(Interval, Interval, bool)>,
}

impl SharedEnclosures {
    /// The rays to come leave `o` with directions between `lo` and `hi`
    /// (componentwise).
    pub(crate) fn set_bundle(&mut self, o: DVec3, lo: DVec3, hi: DVec3) {
        let key = (o, lo, hi);
        // Most rays are of the last ray's bundle.
        if self.current.is_some_and(|at| self.bundles[at].key == key) {
            return;
        }
        if let Some(at) = self.bundles.iter().position(|b| b.key == key) {
            self.current = Some(at);
            return;
        }
        let fresh = Bundle {
            key,
            entries: Vec::new(),
        };
        if self.bundles.len() < MAX_BUNDLES {
            self.bundles.push(fresh);
            self.current = Some(self.bundles.len() - 1);
        } else {
            let at = self.next;
            self.next = (self.next + 1) % MAX_BUNDLES;
            self.bundles[at].key = key;
            self.bundles[at].entries.clear();
            self.current = Some(at);
        }
    }
}

impl<'s> Tracer<'s> {
    /// The bundle the rays to come belong to (see [`SharedEnclosures`]).
    pub(crate) fn set_bundle(&mut self, o: DVec3, lo: DVec3, hi: DVec3) {
        self.shared.set_bundle(o, lo, hi);
    }

    /// [`Tracer::fg_over`] on a piece longer than a point, taken from the
    /// current bundle's enclosures over the leaf where they hold the piece
    /// and decide.
    pub(super) fn fg_over_shared(
        &mut self,
        ray: &Ray,
        a: f64,
        b: f64,
    ) -> (Interval, Interval, bool) {
        if let Some(found) = self.kept_part(a, b) {
            return found;
        }
        let piece = Self::piece_inputs(ray, a, b);
        match self.shared_over(&piece, a, b) {
            Some(found) => found,
            None => self.fg_over_inputs(ray, a, b, &piece, (FG_CUTS, true)),
        }
    }

    /// The current bundle's decisive enclosures that hold `piece` (the
    /// inputs of `[a, b]`), made for its leaf where they are not yet.
    fn shared_over(
        &mut self,
        piece: &[Interval; 6],
        a: f64,
        b: f64,
    ) -> Option<(Interval, Interval, bool)> {
        let which = self.shared.current?;
        let (o, lo, hi) = self.shared.bundles[which].key;
        // (A point's own enclosure is far tighter, and NaN ends have none.)
        if a.partial_cmp(&b) != Some(std::cmp::Ordering::Less) || self.leaf == usize::MAX {
            return None;
        }
        let (leaf, shape) = (self.leaf, self.current);
        // A leaf cut into cells encloses pieces by its cells' tapes, or
        // with no evaluation in a clear cell: cheaper than sharing.
        if self.intersector.octree.short.has_cells(leaf, shape) {
            return None;
        }
        let at = match self.shared.bundles[which]
            .entries
            .iter()
            .position(|e| e.leaf == leaf && e.shape == shape)
        {
            Some(at) => at,
            None if self.shared.bundles[which].entries.len() < MAX_SHARED => {
                let octree = &self.intersector.octree;
                let (hull, pad) = (octree.leaf_hull(leaf), octree.pad);
                let within = padded(&octree.bounds, pad);
                let inputs = region(o, (lo, hi), hull, pad, &within)?;
                let (f, g, continuous) = self.fg_over_one(&inputs, true);
                let decides = f.is_empty()
                    || !f.contains(0.0)
                    || (continuous && !g.is_empty() && !g.contains(0.0));
                self.stats.shared_evals += 1;
                let entries = &mut self.shared.bundles[which].entries;
                entries.push(Shared {
                    leaf,
                    shape,
                    inputs,
                    found: decides.then_some((f, g, continuous)),
                });
                entries.len() - 1
            }
            None => return None,
        };
        let shared = &self.shared.bundles[which].entries[at];
        let found = shared.found?;
        let inside = piece
            .iter()
            .zip(&shared.inputs)
            .all(|(p, s)| s.inf() <= p.inf() && p.sup() <= s.sup());
        if inside {
            self.stats.shared_pieces += 1;
        }
        inside.then_some(found)
    }
}

/// The inputs (points and directions) of every point `o + t·d` of `hull`
/// widened by `pad / 2`, `d` between `lo` and `hi`, inside the box `within`:
/// `None` where no such point is known or the box is not finite.
///
/// A piece's own inputs lie in the leaf's hull but for their roundings,
/// which move its points by less than the pad; a leaf's shape and its
/// tapes hold in its box widened by the pad, and a hull's face on the
/// bounding box's face lies on the padded bounding box (`within`).
fn region(
    o: DVec3,
    (lo, hi): (DVec3, DVec3),
    hull: &Aabb,
    pad: f64,
    within: &Aabb,
) -> Option<[Interval; 6]> {
    let d = [0, 1, 2].map(|i| Interval::new(lo[i], hi[i]));
    let w = 0.5 * pad;
    let h = [0, 1, 2].map(|i| {
        let (a, b) = ((hull.lo[i] - w).next_down(), (hull.hi[i] + w).next_up());
        Interval::new(a.max(within.lo[i]), b.min(within.hi[i]))
    });
    // The times at which a ray of the bundle is inside the box, from each
    // axis along which every direction moves one way.
    let mut t = Interval::ENTIRE;
    for i in 0..3 {
        if d[i].inf() > 0.0 || d[i].sup() < 0.0 {
            t = t.intersection((h[i] - Interval::point(o[i])) / d[i]);
        }
    }
    if t.is_empty() {
        return None;
    }
    let x = [0, 1, 2].map(|i| (Interval::point(o[i]) + t * d[i]).intersection(h[i]));
    let inputs = [x[0], x[1], x[2], d[0], d[1], d[2]];
    inputs
        .iter()
        .all(|v| !v.is_empty() && v.inf().is_finite() && v.sup().is_finite())
        .then_some(inputs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::octree::pad_for;
    use crate::ray::slab::slab;
    use crate::ray::test_rng::Rng;
    use crate::types::Segment;

    /// Directions around `centre`, `spread` apart at most, with their
    /// componentwise least and greatest.
    fn bundle(rng: &mut Rng, centre: DVec3, spread: f64) -> (Vec<DVec3>, (DVec3, DVec3)) {
        let directions: Vec<DVec3> = (0..16).map(|_| centre + spread * rng.vec()).collect();
        let lo = directions.iter().fold(DVec3::INFINITY, |a, &d| a.min(d));
        let hi = directions
            .iter()
            .fold(DVec3::NEG_INFINITY, |a, &d| a.max(d));
        (directions, (lo, hi))
    }

    #[test]
    fn a_bundles_region_holds_every_piece_of_its_rays_in_the_hull() {
        // Each ray's pieces inside a hull (its slab range, and parts of it)
        // have inputs inside the region, which is no wider than the hull
        // and the pad.
        let mut rng = Rng(0x5_4a7ed);
        let root = Aabb::new(DVec3::splat(-1.5), DVec3::splat(1.5)).unwrap();
        let pad = pad_for(&root);
        let within = padded(&root, pad);
        let (mut pieces, mut regions) = (0, 0);
        for k in 0..4_000 {
            let (a, b) = (1.5 * rng.vec(), 1.5 * rng.vec());
            let mut hull = Aabb::new(a.min(b), a.max(b)).unwrap();
            if k % 4 == 0 {
                hull.hi.x = 1.5 + pad; // a face on the padded bounding box
            }
            let o = 5.0 * rng.vec();
            let centre = (0.5 * rng.vec() - o).normalize();
            let (directions, hull_of) = bundle(&mut rng, centre, [1e-3, 0.02, 0.3][k % 3]);
            let Some(inputs) = region(o, hull_of, &hull, pad, &within) else {
                continue;
            };
            regions += 1;
            for (i, x) in inputs[..3].iter().enumerate() {
                assert!(x.inf() >= hull.lo[i] - pad && x.sup() <= hull.hi[i] + pad);
                assert!(x.inf() >= within.lo[i] && x.sup() <= within.hi[i]);
            }
            for d in directions {
                let (t0, t1) = slab(&hull, o, d, d.recip());
                if t0.partial_cmp(&t1) != Some(std::cmp::Ordering::Less) {
                    continue;
                }
                let m = t0 + rng.next() * (t1 - t0);
                for (a, b) in [(t0, t1), (t0, m), (m, t1)] {
                    let piece = Segment::new(o, d, a, b).unwrap().inputs();
                    let inside = piece
                        .iter()
                        .zip(&inputs)
                        .all(|(p, s)| s.inf() <= p.inf() && p.sup() <= s.sup());
                    // (Inputs rounded past the padded bounding box are the
                    // piece's own to evaluate.)
                    let past = (0..3)
                        .any(|i| piece[i].inf() < within.lo[i] || piece[i].sup() > within.hi[i]);
                    assert!(
                        inside || past,
                        "{piece:?} of {o} + t·{d} outside {inputs:?}"
                    );
                    pieces += 1;
                }
            }
        }
        assert!(
            regions > 1_000 && pieces > 20_000,
            "{regions} regions, {pieces} pieces"
        );
    }

    #[test]
    fn rays_sharing_their_bundles_enclosures_keep_their_answers() {
        // A soft union of a ball and an octahedron, creased along the
        // octahedron's edges, so pieces there are enclosed. Each ray of a
        // bundle, answered with the bundle's shared enclosures, gets the
        // answer it gets alone (a hit within the tolerance of it); so does
        // a ray outside the bundle, which shares nothing.
        let f =
            Formula::parse("-ln(exp(-8*(x^2+y^2+z^2-1)) + exp(-8*(abs(x)+abs(y)+abs(z)-1.2)))/8")
                .unwrap();
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let scene = Intersector::new(&f, &b, 5);
        let (mut alone, mut shared) = (scene.tracer(), scene.tracer());
        let tol = scene.tolerance();
        let mut rng = Rng(0x5_4a2ed);
        let (mut hits, mut rays) = (0, 0);
        for k in 0..300 {
            let eye = 4.0 * rng.vec().normalize_or(DVec3::Z);
            let target = DVec3::new(0.0, 0.0, 0.6) + 0.5 * rng.vec();
            let (directions, (lo, hi)) =
                bundle(&mut rng, (target - eye).normalize(), [1e-3, 4e-3][k % 2]);
            // Rays beside the bundle cross the same leaves elsewhere.
            let beside: Vec<DVec3> = (0..8)
                .map(|_| (target + 0.1 * rng.vec() - eye).normalize())
                .collect();
            for d in directions.into_iter().chain(beside) {
                shared.set_bundle(eye, lo, hi);
                let (one, two) = (
                    alone.answer(eye, d, 0.0, f64::INFINITY),
                    shared.answer(eye, d, 0.0, f64::INFINITY),
                );
                rays += 1;
                match (one, two) {
                    (Answer::Hit(s), Answer::Hit(t)) => {
                        assert!(
                            (s - t).abs() * d.length() <= 2.0 * tol,
                            "{eye} + t·{d}: {s} alone, {t} shared"
                        );
                        hits += 1;
                    }
                    (one, two) => assert_eq!(one, two, "{eye} + t·{d}"),
                }
            }
        }
        let used = shared.stats.shared_pieces;
        assert!(
            hits > rays / 2 && used > 200,
            "{hits} hits of {rays} rays, {used} pieces shared"
        );
        assert_eq!(alone.stats.shared_pieces, 0);
    }
}
