//! Rounding-error bounds of the f64 tape evaluation over a region.
//!
//! The point evaluators compute in f64, so a value they return is not the
//! value of the formula at that point. Evaluating a tape in [`RoundingBound`]
//! over a box gives, for every output, a bound `err` such that at *any* f64
//! point of the box `|f̂(p) − f(p)| ≤ err`, where f̂ is what
//! [`Evaluator<f64>`](super::Evaluator) computes there. A ray tracer computes
//! the bound once per octree leaf and then decides on f64 values with that
//! margin: a decision its rounding could flip is never taken.
//!
//! Each operation adds two terms (standard forward error analysis): the
//! propagated error, `Lip(φ) · err_in`, with the Lipschitz constant of φ over
//! its input range widened by the input error; and the operation's own
//! rounding, a relative error of `u = 2⁻⁵³` for `+ − × ÷ √` (correctly
//! rounded) and of [`LIBM_ULPS_POINT`] ulps for library functions, times the
//! largest result magnitude, plus a subnormal allowance. Where a constant is
//! unbounded (a pole, `sqrt` at 0, `sign` across 0) the bound is `+∞`: the
//! caller then decides by intervals.

use super::op::{BinaryOp, UnaryOp};
use super::tape::value::TapeValue;
use crate::types::rounding::{up_error, U};
use crate::types::Interval;

/// Relative error of a library function or a composite point formula (sech,
/// powi through repeated products), in ulps of the result: glibc documents at
/// most 1–2 for the functions used; the composites add a few roundings.
pub const LIBM_ULPS_POINT: f64 = 16.0;

/// An absolute allowance for results that underflow to subnormals.
const TINY: f64 = 1e-300;

/// The range of a value's exact results over a region, and a bound of the
/// rounding error of its f64 computation anywhere in that region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundingBound {
    /// Encloses every exact value over the region.
    pub range: Interval,
    /// Bounds `|computed − exact|` at every f64 point of the region; `+∞`
    /// when no finite bound is known.
    pub err: f64,
}

impl RoundingBound {
    /// An input or an exact constant: its f64 value is exact.
    pub fn exact(range: Interval) -> RoundingBound {
        RoundingBound { range, err: 0.0 }
    }

    /// Every value the computed result can take: the exact range widened by
    /// the error.
    fn computed(self) -> Interval {
        if self.err == 0.0 {
            self.range
        } else {
            self.range + Interval::new(-self.err, self.err)
        }
    }

    /// A result of exact range `range`, with `propagated` error from the
    /// operands and its own rounding of `rel` relative to the largest result.
    fn result(range: Interval, propagated: f64, rel: f64, widened: Interval) -> RoundingBound {
        let own = if rel == 0.0 {
            0.0
        } else {
            rel * widened.mag() + TINY
        };
        let err = up_error(propagated + own);
        RoundingBound {
            range,
            err: if range.is_empty() { 0.0 } else { err },
        }
    }
}

/// `lip · err`, where an exact operand (`err = 0`) propagates nothing even
/// through an unbounded derivative.
#[inline]
fn propagate(lip: f64, err: f64) -> f64 {
    if err == 0.0 {
        0.0
    } else {
        lip * err
    }
}

/// The largest `|φ′|` over `x` for the functions of one argument, `+∞` where
/// unbounded or unknown.
fn unary_lipschitz(op: UnaryOp, x: Interval) -> f64 {
    use UnaryOp::*;
    let m = x.mag();
    let lip = match op {
        Neg | Abs | Sin | Cos | Atan | Tanh | Sech => 1.0,
        Sqrt => {
            let lo = x.inf();
            if lo > 0.0 {
                0.5 / Interval::point(lo).sqrt().inf()
            } else {
                f64::INFINITY
            }
        }
        Ln => {
            let lo = x.inf();
            if lo > 0.0 {
                (Interval::point(1.0) / Interval::point(lo)).sup()
            } else {
                f64::INFINITY
            }
        }
        Exp => Interval::point(x.sup()).exp().sup(),
        Sinh | Cosh => Interval::point(m).cosh().sup(),
        Tan => {
            let t = x.tan();
            (Interval::point(1.0) + t.powi(2)).sup()
        }
        Asin | Acos => {
            if m < 1.0 {
                (Interval::point(1.0) / (Interval::point(1.0) - Interval::point(m).powi(2)).sqrt())
                    .sup()
            } else {
                f64::INFINITY
            }
        }
        Sign | Dirac | Floor | Ceil | Round => 0.0,
    };
    if lip.is_nan() {
        f64::INFINITY
    } else {
        lip
    }
}

impl TapeValue for RoundingBound {
    fn constant(v: f64) -> Self {
        RoundingBound::exact(Interval::point(v))
    }

    #[inline(always)]
    fn unary(op: UnaryOp, a: Self) -> Self {
        use UnaryOp::*;
        let x = a.computed();
        let range = <Interval as TapeValue>::unary(op, a.range);
        let widened = <Interval as TapeValue>::unary(op, x);
        match op {
            Neg | Abs => RoundingBound { range, err: a.err },
            // Piecewise constant: exact while the argument keeps its sign.
            Sign => {
                let keeps = x.inf() > 0.0 || x.sup() < 0.0 || (x.inf() == 0.0 && x.sup() == 0.0);
                RoundingBound {
                    range,
                    err: if keeps { 0.0 } else { 2.0 },
                }
            }
            // 0 at every point (its point value is `a·0`).
            Dirac => RoundingBound { range, err: 0.0 },
            // Steps: exact while every value the argument may take (computed
            // or exact) gives the same step, else off by at most the steps
            // between the ends (exact integers, so the difference is exact).
            Floor | Ceil | Round => {
                let (lo, hi) = (op.eval(x.inf()), op.eval(x.sup()));
                let err = if x.is_empty() || lo == hi {
                    0.0
                } else {
                    hi - lo
                };
                RoundingBound {
                    range,
                    err: if err.is_nan() { f64::INFINITY } else { err },
                }
            }
            Sqrt => {
                RoundingBound::result(range, propagate(unary_lipschitz(op, x), a.err), U, widened)
            }
            _ => {
                let rel = LIBM_ULPS_POINT * f64::EPSILON;
                RoundingBound::result(
                    range,
                    propagate(unary_lipschitz(op, x), a.err),
                    rel,
                    widened,
                )
            }
        }
    }

    #[inline(always)]
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        use BinaryOp::*;
        let (x, y) = (a.computed(), b.computed());
        let range = <Interval as TapeValue>::binary(op, a.range, b.range);
        let widened = <Interval as TapeValue>::binary(op, x, y);
        match op {
            Add | Sub => RoundingBound::result(range, a.err + b.err, U, widened),
            Mul => {
                let propagated = y.mag() * a.err + x.mag() * b.err;
                RoundingBound::result(range, propagated, U, widened)
            }
            Div => {
                let lo = y.mig();
                let propagated = if lo > 0.0 {
                    (a.err + x.mag() * b.err / lo) / lo
                } else {
                    f64::INFINITY
                };
                RoundingBound::result(range, propagated, U, widened)
            }
            // Lipschitz 1 in the largest operand error, no rounding of its own.
            Min | Max => RoundingBound {
                range,
                err: a.err.max(b.err),
            },
            Atan2 => {
                // |∇atan2| = 1/r; it jumps across the cut y = 0, x < 0.
                let r = (x.powi(2) + y.powi(2)).sqrt().inf();
                let cut = x.contains(0.0) && y.inf() < 0.0;
                let propagated = if r > 0.0 && !cut {
                    (a.err + b.err) / r
                } else {
                    f64::INFINITY
                };
                let rel = LIBM_ULPS_POINT * f64::EPSILON;
                RoundingBound::result(range, propagated, rel, widened)
            }
            Pow => {
                // d/da a^b = b·a^(b−1), d/db a^b = a^b·ln a.
                let propagated = if x.inf() > 0.0 {
                    let da = (y * x.pow(y - Interval::point(1.0))).mag();
                    let db = (x.pow(y) * x.ln()).mag();
                    da * a.err + db * b.err
                } else if a.err == 0.0 && b.err == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                };
                let rel = LIBM_ULPS_POINT * f64::EPSILON;
                RoundingBound::result(range, propagated, rel, widened)
            }
        }
    }

    #[inline(always)]
    fn powi(a: Self, n: i32) -> Self {
        let x = a.computed();
        let range = a.range.powi(n);
        let widened = x.powi(n);
        if n == 0 {
            return RoundingBound::exact(range);
        }
        let lip = (Interval::point(f64::from(n)) * x.powi(n - 1)).mag();
        let propagated = propagate(lip, a.err);
        // Repeated products (or 1/products): at most |n| + 1 roundings.
        let rel = (f64::from(n.unsigned_abs().min(1 << 20)) + 2.0) * f64::EPSILON;
        RoundingBound::result(range, propagated, rel, widened)
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        let w = c.computed();
        let range = Interval::choose(c.range, p.range, n.range);
        if w.sup() < 0.0 {
            RoundingBound { range, err: p.err }
        } else if w.inf() > 0.0 {
            RoundingBound { range, err: n.err }
        } else {
            // The computed branch may differ from the exact one: the error is
            // at most the distance between the branches' computed values.
            let spread = (p.computed() - n.computed()).mag();
            RoundingBound {
                range,
                err: up_error(p.err.max(n.err) + spread),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::{Context, Evaluator, Tape, Var};

    /// The bound covers the actual error at many points, measured against an
    /// exact rational evaluation of a polynomial with cancellation.
    #[test]
    fn covers_the_error_of_a_cancelling_polynomial() {
        // (z + 1e5)^2 - z^2 - 2e5*z - 1e10 is exactly 0 but not in f64.
        let mut ctx = Context::new();
        let z = ctx.var(Var::Z);
        let big = ctx.constant(1e5);
        let s = ctx.add(z, big);
        let sq = ctx.powi(s, 2);
        let z2 = ctx.powi(z, 2);
        let a = ctx.sub(sq, z2);
        let k = ctx.constant(2e5);
        let kz = ctx.mul(k, z);
        let b = ctx.sub(a, kz);
        let c = ctx.constant(1e10);
        let f = ctx.sub(b, c);
        let tape = Tape::new(&ctx, &[f]);
        let region = Interval::new(-2.0, 2.0);
        let zero = RoundingBound::exact(Interval::point(0.0));
        let bound = Evaluator::<RoundingBound>::new(&tape).eval(&[
            zero,
            zero,
            RoundingBound::exact(region),
            zero,
            zero,
            zero,
        ])[0];
        assert!(bound.range.contains(0.0));
        assert!(bound.err.is_finite() && bound.err < 1e-4, "{bound:?}");
        let mut point = Evaluator::<f64>::new(&tape);
        let mut worst = 0.0f64;
        for i in 0..=4000 {
            let zv = -2.0 + 4.0 * f64::from(i) / 4000.0;
            let got = point.eval(&[0.0, 0.0, zv, 0.0, 0.0, 0.0])[0];
            worst = worst.max(got.abs()); // the exact value is 0
        }
        assert!(worst > 0.0, "the example must actually cancel");
        assert!(worst <= bound.err, "{worst} > {}", bound.err);
    }

    #[test]
    fn unbounded_where_a_derivative_is() {
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let one = ctx.constant(0.1);
        let shifted = ctx.add(x, one);
        let f = ctx.unary(UnaryOp::Sqrt, shifted);
        let tape = Tape::new(&ctx, &[f]);
        let zero = RoundingBound::exact(Interval::point(0.0));
        let mut eval = Evaluator::<RoundingBound>::new(&tape);
        let at = |e: &mut Evaluator<RoundingBound>, lo, hi| {
            e.eval(&[
                RoundingBound::exact(Interval::new(lo, hi)),
                zero,
                zero,
                zero,
                zero,
                zero,
            ])[0]
        };
        assert!(at(&mut eval, 0.0, 1.0).err.is_finite());
        assert!(at(&mut eval, -1.0, 1.0).err.is_infinite(), "sqrt near 0");
    }
}
