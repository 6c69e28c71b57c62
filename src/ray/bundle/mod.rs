//! Bundles of rays from one origin: the empty space in front of the surface,
//! proved once for all of them.
//!
//! The camera rays of an image tile leave one eye in nearly the same
//! direction, and each one crosses the same empty leaves before it reaches
//! the surface: each would spend an evaluation of f (and a walk of the octree)
//! per leaf to exclude them. Here the bundle is swept once: for `t` in a range
//! `[t₀, t₁]`, every point `o + t·d` of every ray lies in the box
//! `o + [t₀, t₁]·D` (D the hull of the rays' directions, computed with outward
//! rounding), clipped to the bounding box; if that box meets no kept leaf of
//! the octree (every point of the surface lies in one), or the enclosure of f
//! over it excludes 0, no ray has a root there. Ranges are proved one after
//! another from the bundle's first entry into the box, each twice as long as
//! the last while they succeed and half as long when one fails, until a range
//! of the smallest length fails or an evaluation budget is spent. Every ray
//! then starts where the proved ranges end: the same certificate as a ray
//! whose leaves were excluded one by one (an interval test, as the
//! intersector's own fallback), so answers stay proven.

mod leaf_list;
mod listed;

use super::intersect::Tracer;
use crate::types::geom::norm;
use crate::types::{Aabb, Interval};
use glam::DVec3;
use leaf_list::hull_of;
pub use leaf_list::widen;
pub use leaf_list::{LeafList, Listed, MAX_LISTED_LEAVES};

/// Ranges one bundle may try to prove (each an octree query, and an
/// interval evaluation of f where that does not decide).
pub const MAX_BUNDLE_RANGES: u32 = 24;

/// The first range a sweep tries, as a fraction of the bundle's extent in
/// the box; no range is shorter than [`MIN_RANGE`] of it.
const FIRST_RANGE: f64 = 1.0 / 16.0;

const MIN_RANGE: f64 = 1.0 / 512.0;

/// A `t` from `t_min` up to which no ray `o + t·d`, `d` in `directions`, meets
/// the surface inside `bounds`, the tracer's bounding box (proved by
/// intervals; `t_min` itself when nothing could be proved; `+∞` when that
/// range reaches past every ray's exit from the box). `o` and every
/// direction must be finite.
pub fn clear_until(
    tracer: &mut Tracer<'_>,
    bounds: &Aabb,
    o: DVec3,
    directions: &[DVec3],
    t_min: f64,
) -> f64 {
    clear_until_between(tracer, bounds, o, hull_of(directions), t_min)
}

/// [`clear_until`] for directions whose componentwise least and greatest are
/// `hull` (see [`LeafList::gather_between`]).
pub fn clear_until_between(
    tracer: &mut Tracer<'_>,
    bounds: &Aabb,
    o: DVec3,
    hull: Option<(DVec3, DVec3)>,
    t_min: f64,
) -> f64 {
    match hull {
        Some(hull) => sweep(tracer, bounds, o, hull, t_min, None),
        None => t_min,
    }
}

/// [`clear_until`] for the bundle `list` was gathered for (its origin, its
/// directions, from its start), with the list for the octree: no ray meets
/// a kept leaf before the list's first entry, so the sweep starts there,
/// and a range whose box meets no listed leaf is clear without a walk.
/// `+∞` at once when no ray crosses a kept leaf.
pub fn clear_until_listed(tracer: &mut Tracer<'_>, bounds: &Aabb, list: &LeafList) -> f64 {
    match list.hull {
        Some(hull) => sweep(
            tracer,
            bounds,
            list.origin,
            (hull.lo, hull.hi),
            list.from,
            Some(list),
        ),
        None => list.from,
    }
}

/// The sweep of [`clear_until`] for directions between `lo` and `hi`.
fn sweep(
    tracer: &mut Tracer<'_>,
    bounds: &Aabb,
    o: DVec3,
    (lo, hi): (DVec3, DVec3),
    t_min: f64,
    list: Option<&LeafList>,
) -> f64 {
    // Every root of every ray lies in a listed leaf, entered no earlier
    // than the list says.
    let t_min = match list.map(|l| l.leaves.first()) {
        Some(None) => return f64::INFINITY,
        Some(Some(first)) => t_min.max(first.enter),
        None => t_min,
    };
    if !o.is_finite() || !t_min.is_finite() {
        return t_min;
    }
    let hull = [0, 1, 2].map(|i| Interval::new(lo[i], hi[i]));
    let boxed = bounds.intervals();
    // Every point of every ray with t in [a, b], inside the box.
    let region = |a: f64, b: f64| -> [Interval; 3] {
        let t = Interval::new(a, b);
        std::array::from_fn(|i| (Interval::point(o[i]) + t * hull[i]).intersection(boxed[i]))
    };
    let empty = |r: &[Interval; 3]| r.iter().any(|x| x.is_empty());
    // Where the rays are in the box, roughly (from distances to the box and
    // the rays' speeds): these only pace the sweep, which proves each range.
    let (slow, fast) = (
        norm(DVec3::from(hull.map(|x| x.mig()))),
        norm(DVec3::from(hull.map(|x| x.mag()))),
    );
    let nearest = norm(o.clamp(bounds.lo, bounds.hi) - o);
    let farthest = (o - bounds.center()).abs() + 0.5 * (bounds.hi - bounds.lo);
    let (near, far) = (nearest / fast, norm(farthest) / slow);
    if slow.is_nan() || slow <= 0.0 || !far.is_finite() || !near.is_finite() {
        return t_min;
    }
    // Before the box, the region is empty: no evaluation proves it.
    let start = if near > t_min && empty(&region(t_min, near)) {
        near
    } else {
        t_min
    };
    if start >= far {
        return t_min;
    }
    let extent = far - start;
    let (mut step, min_step) = (extent * FIRST_RANGE, extent * MIN_RANGE);
    let mut t = start;
    let mut budget = MAX_BUNDLE_RANGES;
    while t < far && budget > 0 {
        let next = t + step;
        if next.is_nan() || next <= t {
            break;
        }
        let r = region(t, next);
        let clear = empty(&r) || {
            budget -= 1;
            match list {
                Some(list) => list.clear_in(tracer, &r, t, next),
                None => tracer.region_is_clear(r),
            }
        };
        if clear {
            t = next;
            step *= 2.0;
        } else if step > min_step {
            step *= 0.5;
        } else {
            break;
        }
    }
    // Past `far` every ray has left the box (farther than any of its points
    // at its least speed); a millionth of a millionth more covers the
    // roundings of that bound. Nothing is left for the rays to search.
    if t >= far * (1.0 + 1e-12) {
        return f64::INFINITY;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::leaf_list::DirectionHull;
    use super::*;
    use crate::formula::Formula;
    use crate::ray::octree::NodeId;
    use crate::ray::slab::slab;
    use crate::ray::test_rng::Rng;
    use crate::ray::Intersector;

    /// Directions around `centre`, `spread` apart at most, and one more at
    /// random inside the hull of the others (componentwise).
    fn bundle(rng: &mut Rng, centre: DVec3, spread: f64) -> Vec<DVec3> {
        let mut directions: Vec<DVec3> = (0..8).map(|_| centre + spread * rng.vec()).collect();
        let (lo, hi) = hull_of(&directions).unwrap();
        let t = DVec3::new(rng.next(), rng.next(), rng.next());
        directions.push((lo + t * (hi - lo)).clamp(lo, hi));
        directions
    }

    #[test]
    fn a_bundles_times_bound_every_rays_slab_times() {
        // Each ray's entry into a box is at least the bundle's bound, and its
        // exit at most the other: the lists rest on this.
        let mut rng = Rng(0x5eed_1e57);
        let (mut checked, mut tight) = (0, 0);
        for k in 0..20_000 {
            let (a, b) = (2.0 * rng.vec(), 2.0 * rng.vec());
            let bounds = Aabb::new(a.min(b), a.max(b)).unwrap();
            let mut o = 4.0 * rng.vec();
            if k % 5 == 1 {
                o.y = bounds.lo.y; // on a face's plane
            }
            let centre = rng.vec();
            let spread = [1e-3, 0.05, 0.5][k % 3];
            let mut directions = bundle(&mut rng, centre, spread);
            if k % 7 == 3 {
                directions[0].z = 0.0; // a component of either sign
            }
            let Some(hull) =
                hull_of(&directions).and_then(|(lo, hi)| DirectionHull::between(lo, hi))
            else {
                continue;
            };
            let (enter, leave) = hull.times(&bounds, o);
            for &d in &directions {
                let (t0, t1) = slab(&bounds, o, d, d.recip());
                assert!(
                    enter <= t0 && t1 <= leave,
                    "{bounds:?} from {o} along {d}: [{t0}, {t1}] outside [{enter}, {leave}]"
                );
                checked += 1;
                tight += usize::from(enter == t0 && enter.is_finite());
            }
        }
        // Not vacuous: the bounds are some ray's own times, often.
        assert!(
            checked > 100_000 && tight > 10_000,
            "{checked} checked, {tight} tight"
        );
    }

    #[test]
    fn a_listed_sweep_clears_no_rays_first_hit() {
        // A union of eight balls: each leaf's shape holds one or two, far
        // shorter than the whole formula, so the sweep encloses each met
        // leaf's part of a range by its own shape. No ray of a bundle may
        // hit the surface before the time the sweep proves clear.
        let balls: Vec<String> = (0..8)
            .map(|k| {
                let c = |bit: usize| if k >> bit & 1 == 0 { -0.5 } else { 0.5 };
                format!("(x-{})^2+(y-{})^2+(z-{})^2-0.09", c(0), c(1), c(2))
            })
            .collect();
        let f = Formula::parse(&format!("min({})", balls.join(","))).unwrap();
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let scene = Intersector::new(&f, &b, 5);
        let mut tracer = scene.tracer();
        let octree = tracer.octree();
        assert!(octree.shapes.len() > 8, "{} shapes", octree.shapes.len());
        let mut rng = Rng(0xc1ea_5eed);
        let (mut swept, mut hits, mut list) = (0, 0, LeafList::default());
        for k in 0..200 {
            let eye = 4.0 * rng.vec().normalize_or(DVec3::X);
            let centre = (0.8 * rng.vec() - eye).normalize();
            let directions = bundle(&mut rng, centre, [0.002, 0.02, 0.1][k % 3]);
            if !list.gather(&tracer, eye, &directions, 0.0) {
                continue;
            }
            let clear = clear_until_listed(&mut tracer, &b, &list);
            swept += usize::from(clear > 0.0);
            for &d in &directions {
                if let Some(t) = tracer.first_hit(eye, d, 0.0, f64::INFINITY) {
                    hits += 1;
                    assert!(clear <= t, "{eye} + t·{d}: hit at {t}, cleared to {clear}");
                }
            }
        }
        assert!(swept > 100 && hits > 300, "{swept} swept, {hits} hits");
    }

    #[test]
    fn a_list_holds_every_leaf_a_ray_of_its_bundle_crosses() {
        // Against every kept leaf: a ray whose slab test of a leaf's hull
        // gives a range past the list's start finds that leaf listed,
        // entered no earlier than the list says. So do the rays of a
        // narrowed list.
        let f = Formula::parse("max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))").unwrap();
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let scene = Intersector::new(&f, &b, 5);
        let tracer = scene.tracer();
        let octree = tracer.octree();
        let leaves: Vec<(NodeId, usize)> = (0..octree.nodes.len() as NodeId)
            .filter_map(|id| Some((id, octree.nodes[id as usize].leaf_index()?)))
            .collect();
        let mut rng = Rng(0x11_57ed);
        let (mut lists, mut crossings) = (0, 0);
        let (mut list, mut narrow) = (LeafList::default(), LeafList::default());
        for k in 0..60 {
            let eye = 4.0 * rng.vec().normalize_or(DVec3::X);
            let centre = (0.9 * rng.vec() - eye).normalize();
            let directions = bundle(&mut rng, centre, [0.002, 0.02][k % 2]);
            let from = [0.0, 2.5, 3.5][k % 3];
            if !list.gather(&tracer, eye, &directions, from) {
                continue;
            }
            lists += 1;
            let half = &directions[..4];
            let (lo, hi) = hull_of(half).unwrap();
            narrow.narrow(&tracer, &list, lo, hi);
            for (list, rays) in [(&list, &directions[..]), (&narrow, half)] {
                for &d in rays {
                    let listed = list
                        .for_ray(eye, d, from)
                        .expect("the list covers its rays");
                    for &(id, leaf) in &leaves {
                        let (t0, t1) = slab(octree.leaf_hull(leaf), eye, d, d.recip());
                        if t0.max(from) >= t1 {
                            continue;
                        }
                        crossings += 1;
                        let found = listed.iter().find(|l| l.node == id);
                        assert!(
                            found.is_some_and(|l| l.enter <= t0.max(from)),
                            "leaf {id}, crossed by {eye} + t·{d} on [{t0}, {t1}], listed as {found:?}"
                        );
                    }
                }
            }
        }
        assert!(
            lists > 30 && crossings > 500,
            "{lists} lists, {crossings} crossings"
        );
    }
}
