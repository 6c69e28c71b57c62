//! The slab test: the range of a ray's parameter inside an axis-aligned box.

use crate::types::rounding::ROUNDINGS_7;
use crate::types::Aabb;
use glam::DVec3;

/// The parameter range in which the ray `o + t·d` is inside the closed box
/// `b` (empty, `near > far`, when it misses).
#[inline]
pub(crate) fn slab(b: &Aabb, o: DVec3, d: DVec3, inv_d: DVec3) -> (f64, f64) {
    slab_from(b, &o, &d, inv_d)
}

/// [`slab`] widened by its rounding error. Each time is three roundings off
/// (the gap, `1/d`, their product), so a point on the box's wall may fall
/// just outside the computed range, and a root there would be lost; the
/// widened range holds it. The points it adds lie within a few ulps of the
/// box, inside the pad that leaves' proofs cover.
#[inline(always)]
pub(crate) fn slab_widened(b: &Aabb, o: &DVec3, d: &DVec3, inv_d: DVec3) -> (f64, f64) {
    let (near, far) = slab_from(b, o, d, inv_d);
    // 8u covers the three roundings (γ₃ < 4u), the rounding of the
    // subtraction or sum that applies the widening, and its own; the
    // absolute term covers a time that underflowed.
    let widen = |t: f64| {
        if t.is_finite() {
            ROUNDINGS_7 * t.abs() + f64::MIN_POSITIVE
        } else {
            0.0
        }
    };
    (near - widen(near), far + widen(far))
}

/// [`slab`], reading the ray's origin and direction where they are: in a
/// loop, a copy of them made for each call was read back across two of its
/// stores, which the processor cannot forward (a stall each time).
#[inline(always)]
pub(crate) fn slab_from(b: &Aabb, o: &DVec3, d: &DVec3, inv_d: DVec3) -> (f64, f64) {
    if inv_d.is_finite() {
        // No time is NaN (a finite difference times a finite 1/dᵢ): plain
        // comparisons give what f64's min and max, which skip NaN at the
        // cost of several instructions each, would.
        let mut near = f64::NEG_INFINITY;
        let mut far = f64::INFINITY;
        for i in 0..3 {
            let (lo, hi) = ((b.lo[i] - o[i]) * inv_d[i], (b.hi[i] - o[i]) * inv_d[i]);
            let (enter, leave) = if lo < hi { (lo, hi) } else { (hi, lo) };
            if enter > near {
                near = enter;
            }
            if leave < far {
                far = leave;
            }
        }
        return (near, far);
    }
    slab_with_zeros(b, *o, *d, inv_d)
}

/// [`slab`] for a ray with a direction component 0 (or so small that its
/// reciprocal overflows).
#[cold]
pub(crate) fn slab_with_zeros(b: &Aabb, o: DVec3, d: DVec3, inv_d: DVec3) -> (f64, f64) {
    let mut near = f64::NEG_INFINITY;
    let mut far = f64::INFINITY;
    for i in 0..3 {
        if d[i] == 0.0 {
            // Parallel to this axis's faces: inside the slab or never. (The
            // product form would give 0·∞ = NaN for a ray in a face's plane.)
            if o[i] < b.lo[i] || o[i] > b.hi[i] {
                return (f64::INFINITY, f64::NEG_INFINITY);
            }
            continue;
        }
        let t0 = crossing(b.lo[i] - o[i], d[i], inv_d[i]);
        let t1 = crossing(b.hi[i] - o[i], d[i], inv_d[i]);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    (near, far)
}

/// The time `gap / d` at which a ray crosses a plane `gap` ahead of its
/// origin along one axis, `d ≠ 0`. Where `1/d` overflows, the product form
/// would give `0·∞ = NaN` for a ray starting in the plane: divide instead.
#[inline]
pub(crate) fn crossing(gap: f64, d: f64, inv_d: f64) -> f64 {
    if inv_d.is_finite() {
        gap * inv_d
    } else {
        gap / d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_slab_test_without_min_and_max_gives_their_times() {
        // Boxes and rays at random, some starting on a face or a corner, some
        // nearly parallel to an axis: the fast slab test's times are those of
        // the careful one (f64's min and max), which axis-parallel rays take.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        let mut compared = 0;
        for k in 0..20_000 {
            let (a, b) = (
                DVec3::new(next(), next(), next()),
                DVec3::new(next(), next(), next()),
            );
            let bounds = Aabb::new(a.min(b), a.max(b)).unwrap();
            let mut o = DVec3::new(next(), next(), next());
            let mut d = DVec3::new(next(), next(), next());
            match k % 4 {
                1 => o.x = bounds.lo.x,
                2 => o = bounds.hi,
                3 => d.y *= 1e-300,
                _ => {}
            }
            let inv_d = d.recip();
            if !inv_d.is_finite() {
                continue;
            }
            let (fast, careful) = (
                slab(&bounds, o, d, inv_d),
                slab_with_zeros(&bounds, o, d, inv_d),
            );
            assert_eq!(fast, careful, "box {bounds:?}, ray {o} + t·{d}");
            compared += 1;
        }
        assert!(compared > 19_000);
    }
}
