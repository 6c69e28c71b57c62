//! Root-free ranges and certified sign changes from Taylor's bound of F
//! along a ray.
//!
//! At a point m of a ray, F's value and slope are known within error bounds
//! (`|F(m) − f| ≤ e_f`, `|F′(m) − g| ≤ e_g`) and F″ lies in `[c_lo, c_hi]` on
//! the whole leaf. Where F(m)'s sign σ is certified, `φ(s) = σ·F(m ± s)` lies
//! between two parabolas for every `s ≥ 0` in the leaf:
//!
//! `A₋ + B₋·s + ½φ″₋·s² ≤ φ(s) ≤ A₊ + B₊·s + ½φ″₊·s²`,
//!
//! with `A± = |f| ± e_f`, `B± = ±σg ± e_g` (the sign of the step first), and
//! φ″± the ends of σF″. Up to the lower parabola's first root, F keeps σ: a
//! range with no root ([`Expansion::clear`]). Past the upper parabola's first
//! root, F has −σ: a sign change, certified without evaluating F there
//! ([`Expansion::crossing`]). Where F is quadratic along the ray (a quadric,
//! a plane) the two parabolas nearly meet, so a root is bracketed to within
//! the error bounds from one evaluation on each side of it.
//!
//! Every number here is rounded so that a clear range can only shrink, and
//! a crossing is checked with a bound of its own rounding.

use crate::types::rounding::{up_bound, ROUNDINGS_1, ROUNDINGS_127, ROUNDINGS_15, ROUNDINGS_7};

/// The Taylor bounds of F around one point, oriented by F's certified sign
/// there.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Expansion {
    /// σ, the sign of F at the point: ±1.
    pub sign: f64,
    /// |f|, and lower and upper bounds of |F| at the point.
    a: f64,
    a_lo: f64,
    a_hi: f64,
    /// σ·g and g's error.
    slope: f64,
    slope_err: f64,
    /// Bounds of σF″ on the leaf.
    c_lo: f64,
    c_hi: f64,
}

impl Expansion {
    /// The bounds at a point where F's value is `f` within `f_err`, its
    /// slope `g` within `g_err`, and F″ in `curvature` on the leaf; `None`
    /// where F's sign is not certified there or a bound is not finite.
    #[inline(always)]
    pub fn new(f: f64, f_err: f64, g: f64, g_err: f64, curvature: (f64, f64)) -> Option<Expansion> {
        let (c_lo, c_hi) = curvature;
        let finite = [f, f_err, g, g_err, c_lo, c_hi]
            .iter()
            .all(|v| v.is_finite());
        // |f| − e_f is one rounding of a positive result: it is at least
        // (1 − ε/2) of the exact difference, less the least normal where it
        // underflows.
        let a_lo = (f.abs() - f_err) * (1.0 - ROUNDINGS_1) - f64::MIN_POSITIVE;
        // (With finite inputs, a_lo is a number.)
        if !finite || a_lo <= 0.0 {
            return None;
        }
        let sign = f.signum();
        let (c_lo, c_hi) = if sign > 0.0 {
            (c_lo, c_hi)
        } else {
            (-c_hi, -c_lo)
        };
        Some(Expansion {
            sign,
            a: f.abs(),
            a_lo,
            a_hi: (f.abs() + f_err) * (1.0 + ROUNDINGS_1),
            slope: sign * g,
            slope_err: g_err,
            c_lo,
            c_hi,
        })
    }

    /// A distance r such that F keeps its sign on `[m, m + dir·r)` (`dir`
    /// ±1): a lower bound of the lower parabola's first positive root, `+∞`
    /// where it has none.
    #[inline(always)]
    pub fn clear(&self, dir: f64) -> f64 {
        // (A difference that underflows is exact; halving a subnormal is
        // not, and its error is absolute: the least normal covers it, and
        // changes nothing at ordinary scales.)
        let b = dir * self.slope - self.slope_err;
        let b = b - ROUNDINGS_1 * b.abs();
        let c = 0.5 * self.c_lo;
        let underflow = if self.c_lo == 0.0 {
            0.0
        } else {
            f64::MIN_POSITIVE
        };
        let c = c - ROUNDINGS_1 * c.abs() - underflow;
        first_root_below(self.a_lo, b, c)
    }

    /// The range of t around m on which F keeps its sign (from
    /// [`Expansion::clear`] both ways), each end moved inward by a few ulps
    /// of t for the roundings of `m ± r`. An end where the range is
    /// unbounded is NaN (infinite r: `∞ − ∞` on the way in), and compares as
    /// reaching past any piece.
    #[inline(always)]
    pub fn clear_range(&self, m: f64) -> (f64, f64) {
        let lo = m - self.clear(-1.0);
        let hi = m + self.clear(1.0);
        (lo + ROUNDINGS_7 * lo.abs(), hi - ROUNDINGS_7 * hi.abs())
    }

    /// The first root ahead (`dir` ±1) of the parabola through the values
    /// themselves, with F″ the middle of its bounds: where a crossing
    /// brackets the root closely, the best place for it.
    pub fn estimate(&self, m: f64, dir: f64) -> Option<f64> {
        let c = 0.25 * (self.c_lo + self.c_hi);
        first_root_estimate(self.a, dir * self.slope, c).map(|s| m + dir * s)
    }

    /// A point `t` past m in direction `dir` (±1) at which F certainly has
    /// the opposite sign (the upper parabola is below 0 there), and no
    /// farther than `limit` from m; `None` where no such point is found.
    /// `m` is the point itself, so that `t − m` is enclosed exactly.
    pub fn crossing(&self, m: f64, dir: f64, limit: f64) -> Option<f64> {
        let b = dir * self.slope + self.slope_err;
        let c = 0.5 * self.c_hi;
        // The upper parabola's first positive root, roughly; a little past
        // it the parabola is below 0 unless it only touches 0 there (then
        // the check below fails).
        let root = first_root_estimate(self.a_hi, b, c)?;
        // Past the root by many times the parabola's rounding noise over its
        // slope there, and the ulps of t.
        let falling = -(b + 2.0 * c * root);
        let noise = self.a_hi + b.abs() * root + c.abs() * root * root;
        if falling <= 0.0 || falling.is_nan() {
            return None;
        }
        let s = root + ROUNDINGS_127 * (noise / falling + m.abs() + root);
        if s > limit || s.is_nan() {
            return None;
        }
        let t = m + dir * s;
        // The step actually taken, `t − m` (within half an ulp of its f64
        // value), and the upper parabola there: its f64 value within a
        // bound of its roundings, and of how far the step may move it.
        let step = (t - m) * dir;
        let (a, bs, cs) = (self.a_hi, b * step, c * step * step);
        let value = a + bs + cs;
        let rounding = ROUNDINGS_7 * (a + bs.abs() + cs.abs());
        let moved = ROUNDINGS_1 * step * (b.abs() + 2.0 * c.abs() * step);
        let certain = value + up_bound(rounding + moved) < 0.0;
        (step > 0.0 && certain).then_some(t)
    }
}

/// A lower bound of the first `r > 0` at which `a + b·r + c·r²` (`a > 0`)
/// reaches 0, for the exact coefficients given; `+∞` where it never does.
fn first_root_below(a: f64, b: f64, c: f64) -> f64 {
    if b >= 0.0 && c >= 0.0 {
        return f64::INFINITY;
    }
    // The discriminant and a bound of its rounding error. Where b² or a·c
    // underflows, its error is absolute, not relative: the least normal
    // covers it. (Far from f64's ends this changes nothing; near them, with
    // F of 1e-200 and F″ of 1e-300, both products round to 0, and without
    // it the clear range would pass the root.)
    let d = b * b - 4.0 * a * c;
    let d_err = ROUNDINGS_7 * (b * b + 4.0 * (a * c).abs()) + f64::MIN_POSITIVE;
    let root = if c == 0.0 {
        a / -b
    } else if c > 0.0 {
        // Convex (so b < 0): no root where d is certainly negative; else the
        // smaller root, whose form 2a/(−b + √d) is smaller for a larger d.
        if d + d_err < 0.0 {
            return f64::INFINITY;
        }
        2.0 * a / (-b + (d.max(0.0) + d_err).sqrt())
    } else if b <= 0.0 {
        // Concave: one positive root, 2a/(−b + √d), smaller for a larger d.
        2.0 * a / (-b + (d + d_err).sqrt())
    } else {
        // Concave and rising: the same root as (b + √d)/(−2c), with no
        // cancellation; smaller for a smaller d.
        (b + (d - d_err).max(0.0).sqrt()) / (-2.0 * c)
    };
    // A few roundings of the root's own arithmetic, each ε/2 relative.
    let root = root * (1.0 - ROUNDINGS_15);
    if root.is_nan() {
        0.0
    } else {
        root.max(0.0)
    }
}

/// The first `r > 0` at which `a + b·r + c·r²` (`a > 0`) reaches 0, to
/// rounding, where it does.
fn first_root_estimate(a: f64, b: f64, c: f64) -> Option<f64> {
    if b >= 0.0 && c >= 0.0 {
        return None;
    }
    let d = b * b - 4.0 * a * c;
    let root = if c == 0.0 {
        a / -b
    } else if d < 0.0 {
        return None;
    } else if b <= 0.0 {
        2.0 * a / (-b + d.sqrt())
    } else {
        (b + d.sqrt()) / (-2.0 * c)
    };
    (root.is_finite() && root >= 0.0).then_some(root)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::test_rng::Rng;

    /// `a + b·r + c·r²` in exact rational arithmetic would do; f64 with the
    /// terms' error bound suffices to tell a clear sign.
    fn parabola(a: f64, b: f64, c: f64, r: f64) -> (f64, f64) {
        let v = a + b * r + c * r * r;
        (
            v,
            ROUNDINGS_15 * (a.abs() + (b * r).abs() + (c * r * r).abs()),
        )
    }

    #[test]
    fn a_clear_range_never_reaches_the_lower_parabolas_root() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut tight = 0;
        for i in 0..20_000 {
            let a = rng.between(1e-6, 2.0);
            let b = rng.between(-3.0, 3.0);
            // Convex, concave and flat, and some nearly tangent.
            let c = match i % 4 {
                0 => rng.between(-2.0, 2.0),
                1 => 0.0,
                2 => b * b / (4.0 * a) * rng.between(0.999_999, 1.000_001),
                _ => rng.between(-2.0, 2.0) * 1e-8,
            };
            let r = first_root_below(a, b, c);
            assert!(r >= 0.0, "{a} {b} {c}: {r}");
            if r.is_finite() {
                // Positive all the way to r: at many points, and at r itself
                // to within rounding.
                for k in 0..=64 {
                    let (v, err) = parabola(a, b, c, r * f64::from(k) / 64.0);
                    assert!(v > -err, "{a} {b} {c}: clear to {r}, {v} at {k}/64");
                }
                // Just past r (a millionth), the parabola is at or below 0
                // where the root is simple: r is tight.
                let (v, err) = parabola(a, b, c, r * (1.0 + 1e-6));
                tight += usize::from(v < err);
            } else {
                // No root: positive far out (on a convex or rising line).
                let (v, err) = parabola(a, b, c, 1e6);
                assert!(v > -err, "{a} {b} {c}: clear for ever, {v} at 1e6");
            }
        }
        assert!(tight > 5_000, "{tight} tight roots");
    }

    #[test]
    fn a_crossing_is_below_zero_on_the_upper_parabola() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let mut found = 0;
        for _ in 0..20_000 {
            let f = rng.between(-2.0, 2.0);
            let g = rng.between(-3.0, 3.0);
            let c = rng.between(-2.0, 2.0);
            let err = rng.between(0.0, 1e-9);
            let m = rng.between(-10.0, 10.0);
            let Some(e) = Expansion::new(f, err, g, err, (c - 1e-3, c + 1e-3)) else {
                assert!(f.abs() <= err * (1.0 + ROUNDINGS_7));
                continue;
            };
            for dir in [1.0, -1.0] {
                let clear = e.clear(dir);
                let Some(t) = e.crossing(m, dir, 10.0) else {
                    continue;
                };
                found += 1;
                let s = (t - m) * dir;
                assert!(s > 0.0 && s <= 10.0 + 1e-9);
                // σF(m + dir·s) ≤ |f| + err + (dir·σg + err)s + ½(σc)⁺s² < 0.
                let sigma = f.signum();
                let c_hi = if sigma > 0.0 { c + 1e-3 } else { -(c - 1e-3) };
                let (v, v_err) = parabola(f.abs() + err, dir * sigma * g + err, 0.5 * c_hi, s);
                assert!(v < v_err, "{f} {g} {c}: crossing at {s}, {v}");
                // The crossing lies past the clear range.
                assert!(clear <= s, "{f} {g} {c}: clear to {clear}, crossing at {s}");
            }
        }
        assert!(found > 5_000, "{found} crossings");
    }

    #[test]
    fn one_evaluation_brackets_a_planes_root_to_its_error_bounds() {
        // F(t) = 2t − 1 from m = 0: the root is 0.5.
        let e = Expansion::new(-1.0, 1e-15, 2.0, 1e-15, (0.0, 0.0)).unwrap();
        let clear = e.clear(1.0);
        let t = e.crossing(0.0, 1.0, 1.0).unwrap();
        assert!(clear < 0.5 && 0.5 < t, "{clear} {t}");
        assert!(t - clear < 1e-8, "{clear} {t}");
        // Backward, F only falls: clear for ever, no crossing.
        assert_eq!(e.clear(-1.0), f64::INFINITY);
        assert_eq!(e.crossing(0.0, -1.0, 1.0), None);
    }
}
