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
//!
//! Each value also carries a relative bound, `|f̂ − f| ≤ rel·|f|`, and each
//! bound tightens the other. An absolute bound grows with the value: through
//! `exp` of arguments up to 400 it reaches 10¹⁶⁰, and the `ln` of a sum of
//! such exponentials (a soft blend) divided it by the sum's least value. A
//! relative one stays near the roundings made through `exp` (`e^(a+ε) =
//! e^a·e^ε`), sums of one sign, products, quotients, integer powers and
//! `sqrt`, where no result may be subnormal; `ln` turns it back into an
//! absolute one (`ln(a·(1+δ)) = ln a + ln(1+δ)`, at most `δ/(1−δ)`).

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
    /// Bounds `|computed − exact| / |exact|` at every f64 point of the
    /// region; `+∞` when no finite bound is known.
    pub rel: f64,
    /// Whether every computed value that is a number is at least 0 (a
    /// square, a sum of squares): its root is then defined wherever its
    /// error is bounded, however near 0 it comes.
    pub nonneg: bool,
    /// Where `nonneg` and the exact values are at least 0 too, bounds
    /// `|√ĉ − √c|` at every f64 point of the region; `+∞` when no finite
    /// bound is known. A sum of squares near 0 has a relative error without
    /// bound and an absolute one whose root is far larger than the root's
    /// actual error; this follows the root itself (`‖·‖` is 1-Lipschitz).
    pub root_err: f64,
}

impl RoundingBound {
    /// An input or an exact constant: its f64 value is exact.
    pub fn exact(range: Interval) -> RoundingBound {
        RoundingBound {
            range,
            err: 0.0,
            rel: 0.0,
            nonneg: range.inf() >= 0.0,
            root_err: 0.0,
        }
    }

    /// `range` with absolute error `err` and relative error `rel`, each
    /// tightened by the other: `|ĉ − c| ≤ rel·|c| ≤ rel·mag(range)`, and
    /// `|ĉ − c| ≤ err ≤ (err / mig(range))·|c|`.
    fn with(range: Interval, err: f64, rel: f64) -> RoundingBound {
        if range.is_empty() {
            return RoundingBound {
                range,
                err: 0.0,
                rel: 0.0,
                nonneg: false,
                root_err: f64::INFINITY,
            };
        }
        let (mag, mig) = (range.mag(), range.mig());
        let from_rel = if rel.is_finite() && mag.is_finite() {
            up_error(rel * mag)
        } else {
            f64::INFINITY
        };
        let from_err = if err.is_finite() && mig > 0.0 {
            up_error(err / mig)
        } else {
            f64::INFINITY
        };
        RoundingBound {
            range,
            err: err.min(from_rel),
            rel: rel.min(from_err),
            nonneg: false,
            root_err: f64::INFINITY,
        }
    }

    /// This bound, its computed values known to be at least 0 where `yes`.
    fn nonneg_if(self, yes: bool) -> RoundingBound {
        RoundingBound {
            nonneg: self.nonneg || yes,
            ..self
        }
    }

    /// This bound of a value at least 0, with `root_err` bounding the error
    /// of its square root (rounded up; NaN is no bound).
    fn with_root(self, root_err: f64) -> RoundingBound {
        RoundingBound {
            nonneg: true,
            root_err: if root_err.is_nan() {
                f64::INFINITY
            } else {
                up_error(root_err)
            },
            ..self
        }
    }

    /// Every value the computed result can take: the exact range widened by
    /// the error.
    fn computed(self) -> Interval {
        if self.err == 0.0 {
            return self.range;
        }
        let mut by_err = self.range + Interval::new(-self.err, self.err);
        if self.nonneg && by_err.sup() >= 0.0 {
            by_err = by_err.intersection(Interval::new(0.0, f64::INFINITY));
        }
        if self.rel < 1.0 {
            // Every c·(1 + δ) with |δ| ≤ rel (the factor's ends rounded out).
            let factor = Interval::new((1.0 - self.rel).next_down(), (1.0 + self.rel).next_up());
            let by_rel = self.range * factor;
            by_err.intersection(by_rel)
        } else {
            by_err
        }
    }

    /// A result of exact range `range`, with `propagated` error from the
    /// operands, its own rounding of `own` relative to the largest result,
    /// and relative error `rel` (`+∞` where none is known).
    fn result(
        range: Interval,
        propagated: f64,
        own: f64,
        widened: Interval,
        rel: f64,
    ) -> RoundingBound {
        let own = if own == 0.0 {
            0.0
        } else {
            own * widened.mag() + TINY
        };
        let err = up_error(propagated + own);
        RoundingBound::with(range, err, rel)
    }
}

/// Values whose relative rounding may not be bounded by `u`: results that
/// may be subnormal or 0 by underflow, or near overflow (the reciprocal of a
/// subnormal power is below the largest f64).
fn outside_normal(x: Interval) -> bool {
    !(x.mig() >= 2f64.powi(-1000) && x.mag() <= 2f64.powi(1000))
}

/// `(1 + a)(1 + b) − 1` rounded up: the relative error of a product of
/// factors with relative errors a and b.
fn compose(a: f64, b: f64) -> f64 {
    let s = a + b + a * b;
    if s.is_nan() {
        f64::INFINITY
    } else {
        up_error(s)
    }
}

/// `ρ/(1 − ρ)` rounded up: bounds `|1/(1+δ) − 1|` and `|ln(1+δ)|` for
/// `|δ| ≤ ρ`; `+∞` from ρ ≥ ½, far past any rounding.
fn inverse_rel(r: f64) -> f64 {
    if r < 0.5 {
        up_error(r / (1.0 - r))
    } else {
        f64::INFINITY
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
            Neg | Abs => RoundingBound::with(range, a.err, a.rel).nonneg_if(op == Abs),
            // Piecewise constant: exact while the argument keeps its sign.
            Sign => {
                let keeps = x.inf() > 0.0 || x.sup() < 0.0 || (x.inf() == 0.0 && x.sup() == 0.0);
                if keeps {
                    RoundingBound::exact(range)
                } else {
                    RoundingBound::with(range, 2.0, f64::INFINITY)
                }
            }
            // 0 at every point (its point value is `a·0`).
            Dirac => RoundingBound::exact(range),
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
                let err = if err.is_nan() { f64::INFINITY } else { err };
                RoundingBound::with(range, err, if err == 0.0 { 0.0 } else { f64::INFINITY })
            }
            // |√(1+δ) − 1| ≤ |δ|.
            Sqrt => {
                let rel = if a.rel < 1.0 {
                    compose(a.rel, U)
                } else {
                    f64::INFINITY
                };
                let mut propagated = propagate(unary_lipschitz(op, x), a.err);
                // |√â − √a| ≤ √|â − a| for â, a ≥ 0: bounded where √′ is not,
                // as at the centre of a circle (the root of a sum of squares
                // near 0).
                if x.inf() >= 0.0 && a.range.inf() >= 0.0 {
                    propagated = propagated.min(Interval::point(a.err).sqrt().sup());
                    if a.nonneg {
                        propagated = propagated.min(a.root_err);
                    }
                }
                RoundingBound::result(range, propagated, U, widened, rel).nonneg_if(true)
            }
            _ => {
                let own = LIBM_ULPS_POINT * f64::EPSILON;
                let mut propagated = propagate(unary_lipschitz(op, x), a.err);
                let mut rel = f64::INFINITY;
                match op {
                    // exp(a + e) = exp(a)·e^e: relative, whatever exp(a) is.
                    Exp if !outside_normal(widened) => {
                        let grown = Interval::point(a.err).exp().sup() - 1.0;
                        rel = compose(up_error(grown), own);
                    }
                    // ln(a·(1+δ)) = ln a + ln(1+δ): absolute, whatever a is.
                    Ln if a.range.inf() > 0.0 => {
                        propagated = propagated.min(inverse_rel(a.rel));
                    }
                    _ => {}
                }
                RoundingBound::result(range, propagated, own, widened, rel).nonneg_if(op == Exp)
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
            Add | Sub => {
                // Terms of one sign: the sum's relative error is at most the
                // larger of theirs (sums never underflow into error).
                let (ra, rb) = (a.range, if op == Add { b.range } else { -b.range });
                let one_sign =
                    (ra.inf() >= 0.0 && rb.inf() >= 0.0) || (ra.sup() <= 0.0 && rb.sup() <= 0.0);
                let rel = if one_sign {
                    compose(a.rel.max(b.rel), U)
                } else {
                    f64::INFINITY
                };
                let sum = RoundingBound::result(range, a.err + b.err, U, widened, rel);
                if op == Add && a.nonneg && b.nonneg {
                    // A rounded sum of numbers at least 0 is at least 0, and
                    // |√(â + b̂) − √(a + b)| ≤ ‖(√â − √a, √b̂ − √b)‖ (the
                    // triangle inequality of the norm of (√a, √b)); the
                    // sum's own rounding moves its root by at most u·√sum.
                    let own = U * Interval::point(widened.mag()).sqrt().sup();
                    sum.with_root(a.root_err + b.root_err + own)
                } else {
                    sum
                }
            }
            Mul => {
                let propagated = y.mag() * a.err + x.mag() * b.err;
                let rel = if outside_normal(widened) {
                    f64::INFINITY
                } else {
                    compose(compose(a.rel, b.rel), U)
                };
                RoundingBound::result(range, propagated, U, widened, rel)
                    .nonneg_if(a.nonneg && b.nonneg)
            }
            Div => {
                let lo = y.mig();
                let propagated = if lo > 0.0 {
                    (a.err + x.mag() * b.err / lo) / lo
                } else {
                    f64::INFINITY
                };
                let rel = if outside_normal(widened) {
                    f64::INFINITY
                } else {
                    compose(compose(a.rel, inverse_rel(b.rel)), U)
                };
                RoundingBound::result(range, propagated, U, widened, rel)
                    .nonneg_if(a.nonneg && b.nonneg)
            }
            // Lipschitz 1 in the largest operand error, no rounding of its own.
            Min | Max => {
                let bound = RoundingBound::with(range, a.err.max(b.err), f64::INFINITY);
                if a.nonneg && b.nonneg {
                    // √ is increasing: the root of the least (largest) is
                    // the least (largest) root.
                    bound.with_root(a.root_err.max(b.root_err))
                } else {
                    bound.nonneg_if(op == Max && (a.nonneg || b.nonneg))
                }
            }
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
                RoundingBound::result(range, propagated, rel, widened, f64::INFINITY)
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
                RoundingBound::result(range, propagated, rel, widened, f64::INFINITY)
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
        let own = (f64::from(n.unsigned_abs().min(1 << 20)) + 2.0) * f64::EPSILON;
        let mut rel = f64::INFINITY;
        if n.unsigned_abs() <= 64 && !outside_normal(widened) {
            let factor = if n > 0 { a.rel } else { inverse_rel(a.rel) };
            rel = (0..n.unsigned_abs()).fold(0.0, |r, _| compose(r, factor));
            rel = compose(rel, own);
        }
        // Products of an even count of factors of one value, or of values at
        // least 0, round to values at least 0.
        let power = RoundingBound::result(range, propagated, own, widened, rel);
        if n == 2 && widened.mag() < f64::MAX {
            // √(v̂²) = |v̂| is within err of |v|, and the product's rounding
            // (relative u, or an underflow below TINY) moves it by at most
            // u·|v̂| (or √TINY) where it does not overflow.
            power.with_root(a.err + U * x.mag() + TINY.sqrt())
        } else {
            power.nonneg_if(n % 2 == 0 || a.nonneg)
        }
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        let w = c.computed();
        let range = Interval::choose(c.range, p.range, n.range);
        if w.sup() < 0.0 {
            RoundingBound {
                nonneg: p.nonneg,
                root_err: p.root_err,
                ..RoundingBound::with(range, p.err, p.rel)
            }
        } else if w.inf() > 0.0 {
            RoundingBound {
                nonneg: n.nonneg,
                root_err: n.root_err,
                ..RoundingBound::with(range, n.err, n.rel)
            }
        } else {
            // The computed branch may differ from the exact one: the error is
            // at most the distance between the branches' computed values.
            let spread = (p.computed() - n.computed()).mag();
            RoundingBound::with(range, up_error(p.err.max(n.err) + spread), f64::INFINITY)
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

    /// Relative errors through `exp`, `×`, `÷`, integer powers, `sqrt`
    /// and sums, and back to absolute ones by `ln`: `Aᵢ = kᵢ·(x + c) − mᵢ`
    /// near 0, whose rounding errors Δᵢ are known exactly at each point
    /// (the error-free transformations of their sum, product and
    /// difference), so the error of each `ln(…)` below is known to a few
    /// ulps: `ln(e₁·e₂)` is off by Δ₁ + Δ₂, `ln(e₁/e₂)` by Δ₁ − Δ₂ (and
    /// each with its operands swapped),
    /// `ln(e₁³)` by 3Δ₁, `ln(√e₁)` by Δ₁/2 and `ln(e₁ + e₂)` by their
    /// weighted mean (eᵢ = exp(Aᵢ)). With kᵢ of 1000 and 4000, the Δs are several
    /// times the roundings allowed for the operations themselves, so a rule
    /// that dropped an operand's relative error fails here.
    #[test]
    fn relative_errors_carry_through_products_powers_and_ln() {
        use crate::types::rounding::{two_prod_err, two_sum_err};
        let (c, km) = (0.1, [(1000.0, 400.0), (4000.0, 1599.7)]);
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let cc = ctx.constant(c);
        let sum = ctx.add(x, cc);
        let [e1, e2] = km.map(|(k, m)| {
            let scaled = ctx.scale(k, sum);
            let mc = ctx.constant(m);
            let a = ctx.sub(scaled, mc);
            ctx.unary(UnaryOp::Exp, a)
        });
        let composites = [
            ctx.mul(e1, e2),
            ctx.mul(e2, e1),
            ctx.div(e1, e2),
            ctx.div(e2, e1),
            ctx.powi(e1, 3),
            ctx.unary(UnaryOp::Sqrt, e1),
            ctx.add(e1, e2),
        ];
        let outputs: Vec<_> = composites.map(|n| ctx.unary(UnaryOp::Ln, n)).to_vec();
        let tape = Tape::new(&ctx, &[&[e1][..], &outputs].concat());
        let zero = RoundingBound::exact(Interval::point(0.0));
        let (lo, hi) = (0.2995, 0.3005);
        let region = RoundingBound::exact(Interval::new(lo, hi));
        let b = Evaluator::<RoundingBound>::new(&tape)
            .eval(&[region, zero, zero, zero, zero, zero])
            .to_vec();
        assert!(b.iter().all(|b| b.err < 1e-12), "{b:?}");
        let half_ulp = f64::EPSILON / 2.0;
        let mut largest = [0.0f64; 7];
        for i in 0..=4000 {
            let xv = lo + (hi - lo) * f64::from(i) / 4000.0;
            let s = xv + c;
            // Aᵢ = kᵢ·(x + c) − mᵢ exactly = aᵢ + Δᵢ.
            let [(a1, d1), (a2, d2)] = km.map(|(k, m)| {
                let p = k * s;
                let a = p - m;
                let d = two_sum_err(p, -m, a) + two_prod_err(k, s, p) + k * two_sum_err(xv, c, s);
                (a, d)
            });
            assert!(b[0].rel >= d1.abs() - half_ulp, "exp at x = {xv}: Δ = {d1}");
            let w1 = 1.0 / (1.0 + (a2 - a1).exp());
            let moved = [
                d1 + d2,
                d1 + d2,
                d1 - d2,
                d2 - d1,
                3.0 * d1,
                0.5 * d1,
                w1 * d1 + (1.0 - w1) * d2,
            ];
            for (j, m) in moved.iter().enumerate() {
                largest[j] = largest[j].max(m.abs());
                assert!(
                    b[j + 1].err >= 0.99 * m.abs() - 12.0 * half_ulp,
                    "output {j} at x = {xv}: moved by {m}, bound {}",
                    b[j + 1].err
                );
            }
        }
        for (j, l) in largest.iter().enumerate() {
            assert!(*l > 40.0 * half_ulp, "output {j}: Δ only {l}");
        }
    }

    /// The root of a sum of squares around the point where it is 0 (the
    /// centre of a circle), whose argument's relative error has no bound:
    /// the bound is finite, near the roundings of the squared terms, and
    /// covers the actual error, measured against the exact terms `k·x + c`
    /// (their error-free transformations) at points a few ulps from the
    /// centre and across the box.
    #[test]
    fn covers_the_error_of_a_root_of_squares_at_its_centre() {
        use crate::types::rounding::{two_prod_err, two_sum_err};
        let (k, c, d) = (3.7, 0.123_456_789, -0.987_654_321);
        let mut ctx = Context::new();
        let term = |ctx: &mut Context, v: Var, shift: f64| {
            let v = ctx.var(v);
            let kv = ctx.scale(k, v);
            let s = ctx.constant(shift);
            let t = ctx.add(kv, s);
            ctx.powi(t, 2)
        };
        let (u2, v2) = (term(&mut ctx, Var::X, c), term(&mut ctx, Var::Y, d));
        let sum = ctx.add(u2, v2);
        let f = ctx.unary(UnaryOp::Sqrt, sum);
        let tape = Tape::new(&ctx, &[f]);
        let (x0, y0, h) = (-c / k, -d / k, 1e-6);
        let zero = RoundingBound::exact(Interval::point(0.0));
        let bound = Evaluator::<RoundingBound>::new(&tape).eval(&[
            RoundingBound::exact(Interval::new(x0 - h, x0 + h)),
            RoundingBound::exact(Interval::new(y0 - h, y0 + h)),
            zero,
            zero,
            zero,
            zero,
        ])[0];
        assert!(bound.err < 1e-15, "{bound:?}");
        let exact_term = |v: f64, shift: f64| {
            let p = k * v;
            let s = p + shift;
            // k·v + shift = s + e exactly (to the roundings of e itself).
            s + (two_prod_err(k, v, p) + two_sum_err(p, shift, s))
        };
        let mut point = Evaluator::<f64>::new(&tape);
        let mut worst = 0.0f64;
        for i in 0..4000i32 {
            let (x, y) = if i < 400 {
                let ulps = |v: f64, n: i64| f64::from_bits((v.to_bits() as i64 + n) as u64);
                (
                    ulps(x0, i64::from(i / 20 - 10)),
                    ulps(y0, i64::from(i % 20 - 10)),
                )
            } else {
                // Low-discrepancy points across the box.
                let (a, b) = (
                    (f64::from(i) * 0.618_034).fract(),
                    (f64::from(i) * 0.754_878).fract(),
                );
                (x0 - h + 2.0 * h * a, y0 - h + 2.0 * h * b)
            };
            let got = point.eval(&[x, y, 0.0, 0.0, 0.0, 0.0])[0];
            let exact = exact_term(x, c).hypot(exact_term(y, d));
            let off = (got - exact).abs() - 4.0 * f64::EPSILON * exact;
            worst = worst.max(off);
            assert!(
                off <= bound.err,
                "at ({x}, {y}): off by {off}, bound {}",
                bound.err
            );
        }
        assert!(worst > 0.0, "the example must round");
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
