//! Sound interval arithmetic on f64 endpoints.
//!
//! Every operation returns an interval that encloses the exact real result for
//! every real input in its operands. Basic operations (`+ - * /`, `sqrt`,
//! integer powers) round each endpoint outward by exactly the amount needed:
//! an error-free transformation (TwoSum, or an FMA residual) tells whether the
//! rounded result lies above or below the exact one, so an exact result stays
//! exact (`[2,2]·[3,3] = [6,6]`) and an inexact one moves by one ulp.
//! Library functions (`sin`, `exp`, …) are widened by [`LIBM_ULPS`] ulps,
//! which covers the documented error of the platform libm, then clamped to
//! their true ranges.
//!
//! # Domains
//!
//! A function is enclosed over the part of its argument inside its domain:
//! `sqrt([-1, 4]) = [0, 2]`, `ln([0, 1]) = [-∞, 0]`, `asin([0, 2]) =
//! [0, π/2]`. Points outside the domain have no value (they are NaN at points)
//! and so nothing to enclose; an argument wholly outside gives the empty
//! interval, which then propagates. Division by an interval holding 0 gives the
//! whole line, or a half-line when the signs allow it, never NaN. A
//! [`DecInterval`] carries with its value whether every function on the way
//! was defined on all of its argument, as IEEE 1788's decorations do, so a
//! caller never reads that from a global.
//!
//! Names follow the `inari` crate: `inf sup mid wid mag mig contains hull`.

mod decoration;
mod elementary;

use crate::types::rounding::*;
pub use decoration::{DecInterval, Decoration};
use std::fmt;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A closed interval `[inf, sup]` of reals; may be unbounded or empty.
#[derive(Clone, Copy, PartialEq)]
pub struct Interval {
    pub(super) lo: f64,
    hi: f64,
}

impl fmt::Debug for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            f.write_str("[empty]")
        } else {
            write!(f, "[{:?}, {:?}]", self.lo, self.hi)
        }
    }
}

impl fmt::Display for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self, f)
    }
}

// ---- the interval type ------------------------------------------------------

impl Interval {
    /// The empty interval.
    pub const EMPTY: Interval = Interval {
        lo: f64::NAN,
        hi: f64::NAN,
    };

    /// The whole real line.
    pub const ENTIRE: Interval = Interval {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// `[0, 0]`.
    pub const ZERO: Interval = Interval { lo: 0.0, hi: 0.0 };

    /// `[-1, 1]`: the domain of `asin` and `acos`.
    pub const UNIT: Interval = Interval { lo: -1.0, hi: 1.0 };

    /// `[0, ∞]`: the domain of `sqrt`, `ln` and of a non-integer power's base.
    pub const NON_NEGATIVE: Interval = Interval {
        lo: 0.0,
        hi: f64::INFINITY,
    };

    /// `[lo, hi]`; empty when `lo > hi` or either is NaN.
    pub fn new(lo: f64, hi: f64) -> Interval {
        if lo <= hi && lo != f64::INFINITY && hi != f64::NEG_INFINITY {
            Interval { lo, hi }
        } else {
            Interval::EMPTY
        }
    }

    /// The single point `v` (empty for NaN, unbounded for ±∞).
    pub fn point(v: f64) -> Interval {
        if v.is_nan() {
            Interval::EMPTY
        } else if v == f64::INFINITY {
            Interval {
                lo: f64::MAX,
                hi: f64::INFINITY,
            }
        } else if v == f64::NEG_INFINITY {
            Interval {
                lo: f64::NEG_INFINITY,
                hi: f64::MIN,
            }
        } else {
            Interval { lo: v, hi: v }
        }
    }

    /// The smallest interval holding the real number `v` rounded from a
    /// decimal or known to lie within one ulp of `v` (π, e, …).
    pub fn around(v: f64) -> Interval {
        Interval {
            lo: v.next_down(),
            hi: v.next_up(),
        }
    }

    /// Lower end.
    pub fn inf(self) -> f64 {
        self.lo
    }

    /// Upper end.
    pub fn sup(self) -> f64 {
        self.hi
    }

    /// True for the empty interval.
    pub fn is_empty(self) -> bool {
        self.lo.is_nan()
    }

    /// True when both ends are finite.
    pub fn is_bounded(self) -> bool {
        !self.is_empty() && self.lo.is_finite() && self.hi.is_finite()
    }

    /// Midpoint (0 for the whole line, a finite end for a half-line).
    pub fn mid(self) -> f64 {
        match (self.lo.is_finite(), self.hi.is_finite()) {
            (true, true) => {
                let m = 0.5 * self.lo + 0.5 * self.hi;
                m.clamp(self.lo, self.hi)
            }
            (false, false) => 0.0,
            (true, false) => self.lo,
            (false, true) => self.hi,
        }
    }

    /// Width, rounded up.
    pub fn wid(self) -> f64 {
        add_up(self.hi, -self.lo)
    }

    /// Magnitude: the largest `|v|` in the interval.
    pub fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }

    /// Mignitude: the smallest `|v|` in the interval.
    pub fn mig(self) -> f64 {
        if self.contains(0.0) {
            0.0
        } else {
            self.lo.abs().min(self.hi.abs())
        }
    }

    /// True when `v` lies in the interval.
    pub fn contains(self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }

    /// True when every member of `other` is a member of `self`.
    pub fn encloses(self, other: Interval) -> bool {
        other.is_empty() || (self.lo <= other.lo && other.hi <= self.hi)
    }

    /// The smallest interval holding both.
    pub fn hull(self, other: Interval) -> Interval {
        if self.is_empty() {
            return other;
        }
        if other.is_empty() {
            return self;
        }
        Interval {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    /// The common part of both.
    pub fn intersection(self, other: Interval) -> Interval {
        if self.is_empty() || other.is_empty() {
            return Interval::EMPTY;
        }
        Interval::new(self.lo.max(other.lo), self.hi.min(other.hi))
    }

    /// `self^n` for an integer `n`, tight for even powers (`[-1,2]^2 = [0,4]`).
    #[inline(always)]
    pub fn powi(self, n: i32) -> Interval {
        if self.is_empty() {
            return Interval::EMPTY;
        }
        if n == 0 {
            return Interval::point(1.0);
        }
        if n < 0 {
            return self.powi_negative(n);
        }
        if n == 2 {
            // The commonest power: what `pow_nonneg` computes for it, directly.
            let (m, g) = (self.mig(), self.mag());
            return Interval {
                lo: mul_down(m, m),
                hi: mul_up(g, g),
            };
        }
        self.powi_above_two(n as u32)
    }

    /// `self^n` for `n < 0`.
    fn powi_negative(self, n: i32) -> Interval {
        let p = self.powi(n.unsigned_abs().min(i32::MAX as u32) as i32);
        Interval::point(1.0).div(p)
    }

    /// `self^k` for `k > 2`.
    fn powi_above_two(self, k: u32) -> Interval {
        let (lo, hi) = (self.lo, self.hi);
        if k.is_multiple_of(2) {
            let (m, g) = (self.mig(), self.mag());
            Interval {
                lo: pow_nonneg(m, k, false),
                hi: pow_nonneg(g, k, true),
            }
        } else {
            // Odd powers are increasing: x^k = sign(x)·|x|^k.
            let odd = |x: f64, up: bool| {
                if x >= 0.0 {
                    pow_nonneg(x, k, up)
                } else {
                    -pow_nonneg(-x, k, !up)
                }
            };
            Interval {
                lo: odd(lo, false),
                hi: odd(hi, true),
            }
        }
    }

    /// Square root over the part of the interval where it is defined.
    #[inline(always)]
    pub fn sqrt(self) -> Interval {
        let d = self.intersection(Interval::NON_NEGATIVE);
        if d.is_empty() {
            return Interval::EMPTY;
        }
        Interval {
            lo: sqrt_down(d.lo),
            hi: sqrt_up(d.hi),
        }
    }

    /// `|self|`.
    #[inline(always)]
    pub fn abs(self) -> Interval {
        if self.is_empty() {
            return Interval::EMPTY;
        }
        Interval {
            lo: self.mig(),
            hi: self.mag(),
        }
    }

    /// The sign: `[-1, 1]` over an interval holding 0 on both sides.
    pub fn sign(self) -> Interval {
        if self.is_empty() {
            return Interval::EMPTY;
        }
        let s = super::real::sign;
        Interval {
            lo: s(self.lo),
            hi: s(self.hi),
        }
    }

    /// The step derivative: `[0, ∞]` over an interval holding 0, else 0.
    pub fn dirac(self) -> Interval {
        if self.is_empty() {
            return Interval::EMPTY;
        }
        if self.contains(0.0) {
            Interval {
                lo: 0.0,
                hi: f64::INFINITY,
            }
        } else {
            Interval { lo: 0.0, hi: 0.0 }
        }
    }

    /// `min(self, other)`.
    #[inline(always)]
    pub fn min(self, other: Interval) -> Interval {
        if self.is_empty() || other.is_empty() {
            return Interval::EMPTY;
        }
        Interval {
            lo: self.lo.min(other.lo),
            hi: self.hi.min(other.hi),
        }
    }

    /// `max(self, other)`.
    #[inline(always)]
    pub fn max(self, other: Interval) -> Interval {
        if self.is_empty() || other.is_empty() {
            return Interval::EMPTY;
        }
        Interval {
            lo: self.lo.max(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    /// `choose(c, p, n)`: `p` where `c < 0`, `n` where `c > 0`, the hull
    /// where `c` may be 0.
    pub fn choose(c: Interval, p: Interval, n: Interval) -> Interval {
        if c.is_empty() {
            return Interval::EMPTY;
        }
        if c.hi < 0.0 {
            p
        } else if c.lo > 0.0 {
            n
        } else if c.lo == 0.0 && c.hi == 0.0 {
            p.add(n).mul(Interval::point(0.5))
        } else {
            p.hull(n)
        }
    }
}

/// `-self`.
impl Neg for Interval {
    type Output = Interval;

    #[inline(always)]
    fn neg(self) -> Interval {
        Interval {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
}

/// `self + other`.
impl Add for Interval {
    type Output = Interval;

    #[inline(always)]
    fn add(self, other: Interval) -> Interval {
        if self.is_empty() || other.is_empty() {
            return Interval::EMPTY;
        }
        Interval {
            lo: add_down(self.lo, other.lo),
            hi: add_up(self.hi, other.hi),
        }
    }
}

/// `self - other`.
impl Sub for Interval {
    type Output = Interval;

    #[inline(always)]
    fn sub(self, other: Interval) -> Interval {
        self.add(other.neg())
    }
}

/// `self · other`.
impl Mul for Interval {
    type Output = Interval;

    #[inline(always)]
    fn mul(self, other: Interval) -> Interval {
        if self.is_empty() || other.is_empty() {
            return Interval::EMPTY;
        }
        let (a, b) = (self, other);
        if (a.lo == 0.0 && a.hi == 0.0) || (b.lo == 0.0 && b.hi == 0.0) {
            return Interval { lo: 0.0, hi: 0.0 };
        }
        // Closures marked to inline, not the functions themselves: a function
        // item passed by value stays a call, which keeps the FMA copy of the
        // tape loop (see `expr::tape::run`) from inlining the roundings.
        #[allow(clippy::redundant_closure)]
        product_by_signs(
            a,
            b,
            #[inline(always)]
            |x, y| mul_down(x, y),
            #[inline(always)]
            |x, y| mul_up(x, y),
        )
    }
}

impl Interval {
    /// `self · c` for a number `c > 0` (`positive`) or `c < 0`, finite:
    /// what `self * Interval::point(c)` gives, bit for bit, without asking
    /// the signs at run time (whatever `self`'s signs, a positive factor
    /// keeps its ends in order and a negative one swaps them).
    #[inline(always)]
    pub fn mul_by_signed(self, c: f64, positive: bool) -> Interval {
        debug_assert!(c.is_finite() && c != 0.0 && (c > 0.0) == positive);
        if self.is_empty() {
            return Interval::EMPTY;
        }
        if self.lo == 0.0 && self.hi == 0.0 {
            return Interval { lo: 0.0, hi: 0.0 };
        }
        let (lo, hi) = if positive {
            (mul_down(self.lo, c), mul_up(self.hi, c))
        } else {
            (mul_down(self.hi, c), mul_up(self.lo, c))
        };
        Interval { lo, hi }
    }

    /// `self · other`, each end rounded to nearest and then moved one ulp
    /// outward: sound (rounding to nearest errs by half an ulp), at most an
    /// ulp looser than `*`, and cheaper, for long chains of products where
    /// that ulp does not matter (Bernstein coefficients). Unbounded factors
    /// take the exact path.
    #[inline]
    pub fn mul_widened(self, other: Interval) -> Interval {
        let (a, b) = (self, other);
        if !(a.lo.is_finite() && a.hi.is_finite() && b.lo.is_finite() && b.hi.is_finite()) {
            return a * b;
        }
        // A product with a zero factor is exact; any other moves an ulp out
        // (an underflow to 0 included).
        let down = |x: f64, y: f64| {
            if x == 0.0 || y == 0.0 {
                0.0
            } else {
                (x * y).next_down()
            }
        };
        let up = |x: f64, y: f64| {
            if x == 0.0 || y == 0.0 {
                0.0
            } else {
                (x * y).next_up()
            }
        };
        product_by_signs(a, b, down, up)
    }
}

/// The product of two non-empty intervals from the ends its signs pick
/// (zero ends count as either sign: their products are 0): two directed
/// products, four only when both factors straddle 0. `down` and `up` round
/// one product of ends each way.
#[inline(always)]
fn product_by_signs(
    a: Interval,
    b: Interval,
    down: impl Fn(f64, f64) -> f64,
    up: impl Fn(f64, f64) -> f64,
) -> Interval {
    let (lo, hi) = match (sign_class(a), sign_class(b)) {
        (Sign::Pos, Sign::Pos) => (down(a.lo, b.lo), up(a.hi, b.hi)),
        (Sign::Pos, Sign::Neg) => (down(a.hi, b.lo), up(a.lo, b.hi)),
        (Sign::Pos, Sign::Both) => (down(a.hi, b.lo), up(a.hi, b.hi)),
        (Sign::Neg, Sign::Pos) => (down(a.lo, b.hi), up(a.hi, b.lo)),
        (Sign::Neg, Sign::Neg) => (down(a.hi, b.hi), up(a.lo, b.lo)),
        (Sign::Neg, Sign::Both) => (down(a.lo, b.hi), up(a.lo, b.lo)),
        (Sign::Both, Sign::Pos) => (down(a.lo, b.hi), up(a.hi, b.hi)),
        (Sign::Both, Sign::Neg) => (down(a.hi, b.lo), up(a.lo, b.lo)),
        (Sign::Both, Sign::Both) => (
            down(a.lo, b.hi).min(down(a.hi, b.lo)),
            up(a.lo, b.lo).max(up(a.hi, b.hi)),
        ),
    };
    Interval { lo, hi }
}

/// Where an interval lies relative to 0.
#[derive(Clone, Copy)]
enum Sign {
    /// Every element `≥ 0`.
    Pos,
    /// Every element `≤ 0` (and some `< 0`).
    Neg,
    /// Elements on both sides of 0.
    Both,
}

#[inline]
fn sign_class(x: Interval) -> Sign {
    if x.lo >= 0.0 {
        Sign::Pos
    } else if x.hi <= 0.0 {
        Sign::Neg
    } else {
        Sign::Both
    }
}

/// `self / other`, over the quotients that exist: `x/0` has no value (it
/// is NaN at points, as in IEEE 1788), so a divisor holding 0 gives a
/// half-line when the signs allow, else the whole line, and dividing by
/// exactly 0 gives the empty set.
impl Div for Interval {
    type Output = Interval;

    /// The common case, both finite and the divisor of one sign, inline in
    /// the tape loop (and so in its FMA copy); the rest in `Interval::div_rest`.
    #[inline(always)]
    fn div(self, other: Interval) -> Interval {
        let (a, b) = (self, other);
        let finite = a.lo.is_finite() && a.hi.is_finite() && b.lo.is_finite() && b.hi.is_finite();
        // The empty interval's ends are NaN, not finite.
        if finite && (b.lo > 0.0 || b.hi < 0.0) {
            return a.div_one_signed(b);
        }
        a.div_rest(b)
    }
}

impl Interval {
    /// `self / b` for finite intervals and a divisor of one sign: x/y is
    /// monotone in each of x and y on the box, so each end is one of the four
    /// corners, picked by the signs: two divisions instead of eight.
    #[inline(always)]
    fn div_one_signed(self, b: Interval) -> Interval {
        let a = self;
        let (lo, hi) = if b.lo > 0.0 {
            (
                div_down(a.lo, if a.lo >= 0.0 { b.hi } else { b.lo }),
                div_up(a.hi, if a.hi >= 0.0 { b.lo } else { b.hi }),
            )
        } else {
            (
                div_down(a.hi, if a.hi >= 0.0 { b.hi } else { b.lo }),
                div_up(a.lo, if a.lo >= 0.0 { b.lo } else { b.hi }),
            )
        };
        Interval { lo, hi }
    }

    /// [`Div`] where an end is infinite, an interval empty or the divisor
    /// holds 0.
    #[inline(never)]
    fn div_rest(self, other: Interval) -> Interval {
        if self.is_empty() || other.is_empty() {
            return Interval::EMPTY;
        }
        let (a, b) = (self, other);
        if b.lo == 0.0 && b.hi == 0.0 {
            // No quotient exists: nothing to enclose. (f64 would give ±∞ by
            // the sign of the zero, which an interval does not record: at
            // an end of [-1, 0], 1/+0 = +∞ would lie outside [-∞, -1].)
            return Interval::EMPTY;
        }
        if a.lo == 0.0 && a.hi == 0.0 {
            return Interval { lo: 0.0, hi: 0.0 };
        }
        if b.lo > 0.0 || b.hi < 0.0 {
            if a.lo.is_finite() && a.hi.is_finite() && b.lo.is_finite() && b.hi.is_finite() {
                return a.div_one_signed(b);
            }
            let lo = div_down(a.lo, b.lo)
                .min(div_down(a.lo, b.hi))
                .min(div_down(a.hi, b.lo))
                .min(div_down(a.hi, b.hi));
            let hi = div_up(a.lo, b.lo)
                .max(div_up(a.lo, b.hi))
                .max(div_up(a.hi, b.lo))
                .max(div_up(a.hi, b.hi));
            return Interval { lo, hi };
        }
        // 0 ∈ b. With b = [0, s] (s > 0) the quotient takes a's sign and is
        // unbounded away from 0; symmetrically for b = [−s, 0].
        if b.lo == 0.0 {
            if a.lo >= 0.0 {
                return Interval {
                    lo: div_down(a.lo, b.hi),
                    hi: f64::INFINITY,
                };
            }
            if a.hi <= 0.0 {
                return Interval {
                    lo: f64::NEG_INFINITY,
                    hi: div_up(a.hi, b.hi),
                };
            }
        } else if b.hi == 0.0 {
            if a.lo >= 0.0 {
                return Interval {
                    lo: f64::NEG_INFINITY,
                    hi: div_up(a.lo, b.lo),
                };
            }
            if a.hi <= 0.0 {
                return Interval {
                    lo: div_down(a.hi, b.lo),
                    hi: f64::INFINITY,
                };
            }
        }
        Interval::ENTIRE
    }
}

/// An enclosure of `sqrt(a² + b² + c²)`: its upper end bounds a norm from
/// magnitudes (L), its lower end certifies one from mignitudes (witnesses).
pub fn euclidean_norm(m: [f64; 3]) -> Interval {
    let largest = m.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    // Where the squares would overflow (or underflow), the norm is that of
    // m/s for a power of two s near the largest, times s.
    let scale = (largest.is_finite() && (largest > 1e150 || (largest < 1e-150 && largest > 0.0)))
        .then(|| Interval::point(binade(largest)));
    let q = m.map(|v| match scale {
        Some(s) => Interval::point(v) / s,
        None => Interval::point(v),
    });
    let n = q
        .iter()
        .fold(Interval::ZERO, |acc, v| acc + v.powi(2))
        .sqrt();
    match scale {
        Some(s) => n * s,
        None => n,
    }
}

/// `euclidean_norm(m).sup()` computed from the upper ends alone, the same
/// bits for half the work: the Lipschitz bound of every box an octree keeps.
#[inline]
pub fn norm_sup(m: [f64; 3]) -> f64 {
    let largest = m[0].abs().max(m[1].abs()).max(m[2].abs());
    // (Beyond these, squares overflow or underflow: the scaled path.)
    if (1e-150..=1e150).contains(&largest) || largest == 0.0 {
        let square = |v: f64| mul_up(v.abs(), v.abs());
        let s = add_up(add_up(square(m[0]), square(m[1])), square(m[2]));
        return sqrt_up(s);
    }
    euclidean_norm(m).sup()
}

/// `x^n` for `x ≥ 0` and `n ≥ 1`, rounded down (`up = false`) or up.
/// Square-and-multiply with every step rounded the same way stays a bound
/// because all factors are nonnegative.
pub(super) fn pow_nonneg(x: f64, n: u32, up: bool) -> f64 {
    let mul = |a: f64, b: f64| if up { mul_up(a, b) } else { mul_down(a, b) };
    // The first factor is taken as it is, not multiplied by 1.
    let mut result: Option<f64> = None;
    let mut base = x;
    let mut k = n;
    while k > 0 {
        if k & 1 == 1 {
            result = Some(result.map_or(base, |r| mul(r, base)));
        }
        k >>= 1;
        if k > 0 {
            base = mul(base, base);
        }
    }
    result.unwrap_or(1.0)
}

#[cfg(test)]
mod tests;
