//! Closed-form answers on a piece of a ray in a split leaf whose two sides
//! are quadratic along it.
//!
//! A split leaf's formula F is the larger (or the smaller) of two sides F₁,
//! F₂ (see [`SplitLeaf`](super::octree::SplitLeaf)). Where each side's F″ is
//! known to a rounding on the leaf (a quadric, a plane), each side is a
//! parabola in t known at the piece's middle m within its error bounds: with
//! `v`, `w` its computed value and slope at m, `e`, `u` their error bounds
//! and `[lo, hi]` the bounds of F″ on the leaf, for every s with m + s in the
//! leaf,
//!
//! `v − e + w·s − u·|s| + ½·lo·s² ≤ Fₖ(m + s) ≤ v + e + w·s + u·|s| + ½·hi·s²`.
//!
//! The roots of each side's middle parabola `v + w·s + ½·c·s²` estimate
//! where that side changes sign, and so where F first does. The estimate is
//! then proved from the bounds alone, with no evaluation of F: F keeps its
//! sign from the piece's start to just before the estimate (under a max,
//! each stretch above 0 is shown by one side's lower bound, each stretch
//! below by both sides' upper bounds), and has the opposite sign just after
//! it. Where any step of the proof fails (a tangency, a root lost in the
//! error bounds, sides that are not quadratic), nothing is claimed and the
//! piece is searched by the general tests.
//!
//! Every bound is computed in f64 and moved by a bound of its own rounding,
//! so a proof can only fail, never pass wrongly.

use crate::types::rounding::{up_bound, ROUNDINGS_15, ROUNDINGS_7};

/// One side of a split leaf along a ray, oriented so that F is the larger of
/// the two sides: its value and slope at the piece's middle within their
/// error bounds, and bounds of its second derivative on the leaf.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Parabola {
    /// The computed value at m, and a bound of its error.
    pub v: f64,
    pub e: f64,
    /// The computed slope at m, and a bound of its error.
    pub w: f64,
    pub u: f64,
    /// Bounds of F″ on the leaf's part of the ray.
    pub lo: f64,
    pub hi: f64,
}

/// What [`first_root`] proves of a piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Seam {
    /// F has no root on the piece.
    Clear,
    /// F keeps one sign from the piece's start to `lo` and has the other at
    /// `hi` (each the f64 nearest the point proved): the first root lies in
    /// between; `t` is the estimate, in `[lo, hi]`.
    Hit { t: f64, lo: f64, hi: f64 },
}

impl Parabola {
    /// The side negated: the larger of two negated sides is the negated
    /// smaller of the two.
    #[inline(always)]
    pub fn negated(self) -> Parabola {
        Parabola {
            v: -self.v,
            w: -self.w,
            lo: -self.hi,
            hi: -self.lo,
            ..self
        }
    }

    /// Whether every number is finite (else no bound is claimed).
    #[inline(always)]
    fn is_finite(&self) -> bool {
        (self.v + self.e + self.w + self.u + self.lo + self.hi).is_finite()
    }

    /// The middle parabola's value at s: where the estimate puts the side's
    /// sign.
    #[inline(always)]
    fn estimate(&self, s: f64) -> f64 {
        self.v + s * (self.w + 0.25 * (self.lo + self.hi) * s)
    }

    /// The roots of the middle parabola, roughly (no proof rests on them);
    /// NaN where fewer.
    #[inline(always)]
    fn roots(&self) -> [f64; 2] {
        let a = 0.25 * (self.lo + self.hi);
        let (b, c) = (self.w, self.v);
        if a == 0.0 {
            return [if b != 0.0 { -c / b } else { f64::NAN }, f64::NAN];
        }
        let d = b * b - 4.0 * a * c;
        // (NaN compares false: no roots claimed.)
        if d.is_nan() || d < 0.0 {
            return [f64::NAN; 2];
        }
        // The stable pair: q/a and c/q, with no cancellation in q.
        let q = -0.5 * (b + d.sqrt().copysign(b));
        if q == 0.0 {
            return [0.0, f64::NAN];
        }
        [q / a, c / q]
    }

    /// Whether the side is certainly above 0 (`below` false) or below 0
    /// (`below` true) at every `m + s`, `s` in `[s1, s2]` (both on the side
    /// `dir` of m, where `|s| = dir·s`): its lower bound, or its negated
    /// upper bound, `a + b·s + c·s²` there, clears the rounding of its own
    /// evaluation.
    // Not inlined: the compiler would compute every call's vertex, a
    // division, before knowing which calls run.
    #[inline(never)]
    fn clears(&self, below: bool, dir: f64, s1: f64, s2: f64) -> bool {
        let (a, b, c) = if below {
            (-(self.v + self.e), -(self.w + dir * self.u), -0.5 * self.hi)
        } else {
            (self.v - self.e, self.w - dir * self.u, 0.5 * self.lo)
        };
        let far = s1.abs().max(s2.abs());
        // Each value below takes at most eight roundings, with those of the
        // coefficients, each within ε/2 of the magnitudes it adds: 8ε of
        // their sum covers them.
        let size = self.v.abs() + self.e + (self.w.abs() + self.u) * far + c.abs() * far * far;
        let noise = up_bound(ROUNDINGS_15 * size);
        let at = |s: f64| a + s * (b + c * s);
        if !(at(s1) > noise && at(s2) > noise) {
            return false;
        }
        // Convex with its vertex possibly inside: the lowest value anywhere,
        // a − b²/4c, must clear it too (concave, the ends are the lowest).
        if c > 0.0 {
            let vertex = -b / (2.0 * c);
            let slack = ROUNDINGS_7 * vertex.abs();
            if vertex >= s1 - slack && vertex <= s2 + slack {
                // b²/4c as −vertex·b/2: b² itself may underflow to 0 where
                // the drop does not (b of 1e-250, c of 1e-300).
                let drop = -0.5 * vertex * b;
                return a - drop > noise + up_bound(ROUNDINGS_15 * drop);
            }
        }
        true
    }

    /// [`Parabola::clears`] on `[s1, s2]`, which may hold m.
    #[inline(always)]
    fn keeps(&self, below: bool, s1: f64, s2: f64) -> bool {
        if s2 <= 0.0 {
            self.clears(below, -1.0, s1, s2)
        } else if s1 >= 0.0 {
            self.clears(below, 1.0, s1, s2)
        } else {
            self.clears(below, -1.0, s1, 0.0) && self.clears(below, 1.0, 0.0, s2)
        }
    }
}

/// Whether the larger of two sides has the sign `sign` (±1) on all of
/// `[m + s1, m + s2]`: above 0 where one side is; below where both are.
#[inline(always)]
fn keeps_sign_once(sides: &[Parabola; 2], sign: f64, s1: f64, s2: f64) -> bool {
    if sign > 0.0 {
        sides[0].keeps(false, s1, s2) || sides[1].keeps(false, s1, s2)
    } else {
        sides[0].keeps(true, s1, s2) && sides[1].keeps(true, s1, s2)
    }
}

/// [`keeps_sign_once`], halving stretches no single side proves, a few
/// times at most.
#[inline(always)]
fn keeps_sign(sides: &[Parabola; 2], sign: f64, s1: f64, s2: f64) -> bool {
    keeps_sign_once(sides, sign, s1, s2) || keeps_sign_halved(sides, sign, s1, s2, HALVINGS)
}

/// [`keeps_sign`] on the two halves of `[s1, s2]`, `halvings` times more at
/// most.
#[inline(never)]
fn keeps_sign_halved(sides: &[Parabola; 2], sign: f64, s1: f64, s2: f64, halvings: u32) -> bool {
    let mid = 0.5 * (s1 + s2);
    let half = |s1: f64, s2: f64| {
        keeps_sign_once(sides, sign, s1, s2)
            || (halvings > 1 && keeps_sign_halved(sides, sign, s1, s2, halvings - 1))
    };
    halvings > 0 && mid > s1 && mid < s2 && half(s1, mid) && half(mid, s2)
}

/// Halvings [`keeps_sign`] may take of each stretch between estimated roots.
const HALVINGS: u32 = 3;

/// The first root of the larger of `sides` on the piece `[m + s_a, m + s_b]`
/// of a ray (`s_a ≤ 0 ≤ s_b`, both within the leaf), proved within `2·width`:
/// [`Seam::Clear`] where F has no root there, [`Seam::Hit`] with the root's
/// bracket; `None` where the proof fails.
pub(crate) fn first_root(
    sides: &[Parabola; 2],
    m: f64,
    s_a: f64,
    s_b: f64,
    width: f64,
) -> Option<Seam> {
    if !(sides[0].is_finite() && sides[1].is_finite() && s_a <= s_b && width > 0.0) {
        return None;
    }
    // Where either side may change sign, in order: between two of them, F's
    // estimated sign is fixed.
    let mut cuts = [f64::NAN; 4];
    let mut n = 0;
    for side in sides {
        for r in side.roots() {
            if r > s_a && r < s_b {
                cuts[n] = r;
                n += 1;
            }
        }
    }
    let cuts = &mut cuts[..n];
    cuts.sort_unstable_by(f64::total_cmp);
    let sign_between = |x: f64, y: f64| {
        let s = 0.5 * (x + y);
        if sides[0].estimate(s) > 0.0 || sides[1].estimate(s) > 0.0 {
            1.0
        } else {
            -1.0
        }
    };
    let mut start = s_a;
    let first = sign_between(s_a, cuts.first().copied().unwrap_or(s_b));
    // F's sign is proved stretch by stretch up to the first cut where the
    // estimate changes it.
    for i in 0..cuts.len() {
        let cut = cuts[i];
        let next = cuts.get(i + 1).copied().unwrap_or(s_b);
        if sign_between(cut, next) == first {
            if !keeps_sign(sides, first, start, cut) {
                return None;
            }
            start = cut;
            continue;
        }
        // F changes sign at `cut`: it keeps `first` up to just before, and
        // has the other sign just after, still within the piece.
        let (before, after) = (cut - width, cut + width);
        if !(before > start && after < s_b && keeps_sign(sides, first, start, before)) {
            return None;
        }
        let other = keeps_sign_once(sides, -first, after, after);
        return other.then_some(Seam::Hit {
            t: m + cut,
            lo: m + before,
            hi: m + after,
        });
    }
    keeps_sign(sides, first, start, s_b).then_some(Seam::Clear)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::test_rng::Rng;

    /// A side that is exactly `v + w·s + ½·c·s²`, with error bounds.
    fn exact(v: f64, w: f64, c: f64, err: f64) -> Parabola {
        Parabola {
            v,
            e: err,
            w,
            u: err,
            lo: c - err,
            hi: c + err,
        }
    }

    /// The exact larger of the two sides at s, in double-double-free form:
    /// f64 with the terms' error bound suffices for clear signs.
    fn larger(sides: &[(f64, f64, f64); 2], s: f64) -> (f64, f64) {
        let value = |&(v, w, c): &(f64, f64, f64)| {
            (
                v + w * s + 0.5 * c * s * s,
                ROUNDINGS_15 * (v.abs() + (w * s).abs() + (c * s * s).abs()),
            )
        };
        let (a, ea) = value(&sides[0]);
        let (b, eb) = value(&sides[1]);
        if a > b {
            (a, ea.max(eb))
        } else {
            (b, ea.max(eb))
        }
    }

    #[test]
    fn a_proved_answer_is_the_larger_sides_first_sign_change() {
        let mut rng = Rng(0x51ed_2701_a4c3_9b17);
        let (mut hits, mut clears) = (0, 0);
        for i in 0..40_000 {
            // The true sides, and what the proof is given: values off by up
            // to their error bounds, curvature bounds around the true one.
            // Large errors make the estimate wrong often, which the proof
            // must catch.
            let err = [0.0, 1e-12, 1e-4, 3e-2][i % 4];
            let mut side = || {
                let c = match i % 3 {
                    0 => 0.0,
                    _ => rng.between(-4.0, 4.0),
                };
                let truth = (rng.between(-1.0, 1.0), rng.between(-3.0, 3.0), c);
                let given = Parabola {
                    v: truth.0 + err * rng.between(-1.0, 1.0),
                    e: err,
                    w: truth.1 + err * rng.between(-1.0, 1.0),
                    u: err,
                    lo: c - err * rng.between(0.0, 1.0),
                    hi: c + err * rng.between(0.0, 1.0),
                };
                (truth, given)
            };
            let (one, two) = (side(), side());
            let raw = [one.0, two.0];
            let sides = [one.1, two.1];
            let (s_a, s_b) = (-rng.between(0.0, 1.0), rng.between(0.0, 1.0));
            let width = 1e-9;
            let Some(answer) = first_root(&sides, 0.0, s_a, s_b, width) else {
                continue;
            };
            // Sampled densely, the larger side keeps one sign up to the
            // bracket, and has the other past it.
            let (f_a, _) = larger(&raw, s_a);
            let limit = match answer {
                Seam::Clear => s_b,
                Seam::Hit { lo, .. } => lo,
            };
            for k in 0..=256 {
                let s = s_a + (limit - s_a) * f64::from(k) / 256.0;
                let (f, err) = larger(&raw, s);
                assert!(
                    f.abs() <= err || (f > 0.0) == (f_a > 0.0),
                    "{raw:?} {sides:?} on [{s_a}, {s_b}]: {answer:?}, but F is {f} at {s}"
                );
            }
            match answer {
                Seam::Clear => clears += 1,
                Seam::Hit { t, lo, hi } => {
                    hits += 1;
                    // Two widths, to the roundings of the bracket's ends.
                    let wide = hi - lo - 2.0 * width;
                    assert!(
                        lo <= t && t <= hi && wide <= ROUNDINGS_7 * t.abs(),
                        "{answer:?}"
                    );
                    let (f_hi, err) = larger(&raw, hi);
                    assert!(
                        f_hi.abs() > err && (f_hi > 0.0) != (f_a > 0.0),
                        "{raw:?} {sides:?}: {answer:?}, F is {f_hi} at {hi}"
                    );
                }
            }
        }
        assert!(
            hits > 4_000 && clears > 4_000,
            "{hits} hits, {clears} clears"
        );
    }

    #[test]
    fn a_tangency_is_not_claimed() {
        // F = max(s², −1): touches 0 at s = 0 without changing sign.
        let sides = [exact(0.0, 0.0, 2.0, 1e-16), exact(-1.0, 0.0, 0.0, 1e-16)];
        assert_eq!(first_root(&sides, 0.5, -0.5, 0.5, 1e-12), None);
        // Lifted by a millionth, it is clear; lowered, it is hit twice, the
        // first root near −0.001.
        let lifted = [exact(1e-6, 0.0, 2.0, 1e-16), sides[1]];
        assert_eq!(
            first_root(&lifted, 0.5, -0.5, 0.5, 1e-12),
            Some(Seam::Clear)
        );
        let lowered = [exact(-1e-6, 0.0, 2.0, 1e-16), sides[1]];
        match first_root(&lowered, 0.0, -0.5, 0.5, 1e-12) {
            Some(Seam::Hit { t, lo, hi }) => {
                assert!(lo < -1e-3 && -1e-3 < hi, "{lo} {t} {hi}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_dip_the_estimate_misses_is_not_cleared() {
        // The side (s − 0.3)² − 10⁻⁴ dips below 0 around 0.3, but its value
        // at m is given 2·10⁻⁴ high (within its error bound): the estimate
        // has no root, and both ends of [0, 0.5] are above 0.
        let (v, w) = (0.09 - 1e-4, -0.6);
        let side = Parabola {
            v: v + 2e-4,
            e: 2e-4,
            w,
            u: 1e-12,
            lo: 2.0,
            hi: 2.0,
        };
        let sides = [side, exact(-1.0, 0.0, 0.0, 0.0)];
        assert!(side.roots().iter().all(|r| r.is_nan()));
        assert_ne!(first_root(&sides, 0.0, 0.0, 0.5, 1e-9), Some(Seam::Clear));
    }

    #[test]
    fn a_root_lost_in_the_error_bounds_is_not_claimed() {
        // The plane s − 0.25 known only to within a millionth: no bracket of
        // a billionth can be proved.
        let sides = [exact(-0.25, 1.0, 0.0, 1e-6), exact(-1.0, 0.0, 0.0, 0.0)];
        assert_eq!(first_root(&sides, 0.0, -0.5, 0.5, 1e-9), None);
        // Known to rounding, it is.
        let sides = [exact(-0.25, 1.0, 0.0, 1e-16), sides[1]];
        assert!(matches!(
            first_root(&sides, 0.0, -0.5, 0.5, 1e-9),
            Some(Seam::Hit { .. })
        ));
    }
}
