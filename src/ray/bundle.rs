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

use super::intersect::Tracer;
use crate::types::{Aabb, Interval};
use glam::DVec3;

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
    let Some(first) = directions.first() else {
        return t_min;
    };
    if !o.is_finite() || !t_min.is_finite() {
        return t_min;
    }
    // The hull of the directions (exact: min and max round nothing).
    let (mut lo, mut hi) = (*first, *first);
    for &d in directions {
        lo = lo.min(d);
        hi = hi.max(d);
    }
    if !lo.is_finite() || !hi.is_finite() {
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
        DVec3::from(hull.map(|x| x.mig())).length(),
        DVec3::from(hull.map(|x| x.mag())).length(),
    );
    let nearest = (o.clamp(bounds.lo, bounds.hi) - o).length();
    let farthest = (o - bounds.center()).abs() + 0.5 * (bounds.hi - bounds.lo);
    let (near, far) = (nearest / fast, farthest.length() / slow);
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
            tracer.region_is_clear(r)
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
