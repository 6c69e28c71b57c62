//! Enclosures of the elementary functions: trigonometric, exponential,
//! hyperbolic, powers; each library result widened by [`LIBM_ULPS`] ulps.

use super::Interval;
use crate::types::rounding::*;
use std::f64::consts::{FRAC_PI_2, PI};
use std::ops::{Div, Mul, Neg, Sub};

/// `f` at the ends of `x`, evaluated once for a point (library functions
/// are the costliest operations of an enclosure, and points are common: the
/// centre of a box, a point of a ray).
#[inline]
pub(super) fn ends(f: fn(f64) -> f64, x: Interval) -> (f64, f64) {
    // By bits: f(−0) and f(+0) may differ in sign.
    if x.lo.to_bits() == x.hi.to_bits() {
        let v = f(x.lo);
        (v, v)
    } else {
        (f(x.lo), f(x.hi))
    }
}

// ---- the interval type ------------------------------------------------------

impl Interval {
    /// Encloses a monotone library function over `[lo, hi]` of its domain:
    /// `f` evaluated at the ends, widened by [`LIBM_ULPS`], clamped to `range`.
    fn monotone(self, f: fn(f64) -> f64, increasing: bool, range: Interval) -> Interval {
        if self.is_empty() {
            return Interval::EMPTY;
        }
        let (a, b) = ends(f, self);
        let (a, b) = if increasing { (a, b) } else { (b, a) };
        let lo = if a.is_nan() {
            range.lo
        } else {
            ulps_down(a, LIBM_ULPS)
        };
        let hi = if b.is_nan() {
            range.hi
        } else {
            ulps_up(b, LIBM_ULPS)
        };
        Interval::new(lo.max(range.lo), hi.min(range.hi))
    }

    /// True when some `phase + k·period` may lie in the interval. Errs
    /// towards yes: including an extremum that is not there only loosens.
    fn may_hold_phase(self, phase: f64, period: f64) -> bool {
        let scale = self.lo.abs().max(self.hi.abs()).max(1.0);
        let tol = ROUNDINGS_127 * scale;
        let k = ((self.lo - tol - phase) / period).ceil();
        let candidate = phase + k * period;
        candidate <= self.hi + tol
    }

    /// Sine, with exact extrema: `sin [0, 10] = [-1, 1]`.
    pub fn sin(self) -> Interval {
        self.periodic(f64::sin, FRAC_PI_2)
    }

    /// Cosine, with exact extrema.
    pub fn cos(self) -> Interval {
        self.periodic(f64::cos, 0.0)
    }

    /// sin or cos, whose maxima lie at `max_phase + 2πk` and minima half a
    /// period further.
    fn periodic(self, f: fn(f64) -> f64, max_phase: f64) -> Interval {
        if self.is_empty() {
            return Interval::EMPTY;
        }
        // Beyond ~1e9 the spacing of f64 values is too coarse to locate
        // extrema; past a full period every value is taken anyway.
        if !self.is_bounded() || self.wid() >= 2.0 * PI || self.mag() > 1e9 {
            return Interval::UNIT;
        }
        let (a, b) = ends(f, self);
        let mut lo = ulps_down(a.min(b), LIBM_ULPS);
        let mut hi = ulps_up(a.max(b), LIBM_ULPS);
        if self.may_hold_phase(max_phase, 2.0 * PI) {
            hi = 1.0;
        }
        if self.may_hold_phase(max_phase + PI, 2.0 * PI) {
            lo = -1.0;
        }
        Interval::new(lo.max(-1.0), hi.min(1.0))
    }

    /// Tangent: the whole line across a pole.
    pub fn tan(self) -> Interval {
        if self.is_empty() {
            return Interval::EMPTY;
        }
        if !self.is_bounded()
            || self.wid() >= PI
            || self.mag() > 1e9
            || self.may_hold_phase(FRAC_PI_2, PI)
        {
            return Interval::ENTIRE;
        }
        self.monotone(f64::tan, true, Interval::ENTIRE)
    }

    /// Arcsine over `[-1, 1]`.
    pub fn asin(self) -> Interval {
        let half_pi = FRAC_PI_2.next_up();
        self.intersection(Interval::UNIT).monotone(
            f64::asin,
            true,
            Interval {
                lo: -half_pi,
                hi: half_pi,
            },
        )
    }

    /// Arccosine over `[-1, 1]`.
    pub fn acos(self) -> Interval {
        self.intersection(Interval::UNIT).monotone(
            f64::acos,
            false,
            Interval {
                lo: 0.0,
                hi: PI.next_up(),
            },
        )
    }

    /// Arctangent.
    pub fn atan(self) -> Interval {
        let half_pi = FRAC_PI_2.next_up();
        self.monotone(
            f64::atan,
            true,
            Interval {
                lo: -half_pi,
                hi: half_pi,
            },
        )
    }

    /// `e^self`.
    pub fn exp(self) -> Interval {
        self.monotone(
            f64::exp,
            true,
            Interval {
                lo: 0.0,
                hi: f64::INFINITY,
            },
        )
    }

    /// Natural logarithm over `(0, ∞]`; `ln [0, 1] = [-∞, 0]`.
    pub fn ln(self) -> Interval {
        let d = self.intersection(Interval::NON_NEGATIVE);
        if d.is_empty() {
            return Interval::EMPTY;
        }
        if d.hi == 0.0 {
            // ln 0 = −∞, as at points: unbounded below, not undefined.
            return Interval::point(f64::NEG_INFINITY);
        }
        d.monotone(f64::ln, true, Interval::ENTIRE)
    }

    /// Hyperbolic sine.
    pub fn sinh(self) -> Interval {
        self.monotone(f64::sinh, true, Interval::ENTIRE)
    }

    /// Hyperbolic cosine, at least 1.
    pub fn cosh(self) -> Interval {
        self.abs().monotone(
            f64::cosh,
            true,
            Interval {
                lo: 1.0,
                hi: f64::INFINITY,
            },
        )
    }

    /// Hyperbolic tangent, within `[-1, 1]`.
    pub fn tanh(self) -> Interval {
        self.monotone(f64::tanh, true, Interval::UNIT)
    }

    /// Hyperbolic secant, within `[0, 1]`.
    pub fn sech(self) -> Interval {
        self.abs().monotone(
            crate::types::real::sech,
            false,
            Interval { lo: 0.0, hi: 1.0 },
        )
    }

    /// `atan2(self, x)`: the angle of the points (x, y) with y in `self`.
    pub fn atan2(self, x: Interval) -> Interval {
        let y = self;
        // atan2(0, 0) is no angle: the origin alone is outside the domain.
        if y.is_empty() || x.is_empty() || (y == Interval::ZERO && x == Interval::ZERO) {
            return Interval::EMPTY;
        }
        let half_pi = Interval {
            lo: FRAC_PI_2,
            hi: FRAC_PI_2.next_up(),
        };
        if x.lo > 0.0 {
            // Right half-plane: atan2 = atan(y/x).
            return y.div(x).atan();
        }
        if y.lo > 0.0 {
            // Upper half-plane: atan2 = π/2 − atan(x/y).
            return half_pi.sub(x.div(y).atan());
        }
        if y.hi < 0.0 {
            return half_pi.neg().sub(x.div(y).atan());
        }
        // The branch cut (x < 0, y = 0) or the origin may be inside.
        Interval {
            lo: -PI.next_up(),
            hi: PI.next_up(),
        }
    }

    /// `self^b` for `self ≥ 0`, as `exp(b·ln(self))`; `0^b` is 1 at `b = 0`.
    pub fn pow(self, b: Interval) -> Interval {
        let a = self.intersection(Interval::NON_NEGATIVE);
        if a.is_empty() || b.is_empty() {
            return Interval::EMPTY;
        }
        let mut r = b.mul(a.ln()).exp();
        // exp(b·ln 0) misses 0^0 = 1 and 0^b = ∞ (b < 0) only through the
        // conventions of ±∞·0; add those values where they occur.
        if a.lo == 0.0 {
            if b.contains(0.0) {
                r = r.hull(Interval::point(1.0));
            }
            if b.lo < 0.0 {
                r = r.hull(Interval {
                    lo: f64::MAX,
                    hi: f64::INFINITY,
                });
            }
            if b.hi > 0.0 {
                r = r.hull(Interval { lo: 0.0, hi: 0.0 });
            }
        }
        r
    }

    /// `floor` over the interval: `[floor(inf), floor(sup)]`, exact (a
    /// monotone step whose f64 values are exact integers).
    pub fn floor(self) -> Interval {
        self.step(f64::floor)
    }

    /// `ceil` over the interval: `[ceil(inf), ceil(sup)]`, exact.
    pub fn ceil(self) -> Interval {
        self.step(f64::ceil)
    }

    /// `round` (halves away from zero) over the interval: `[round(inf),
    /// round(sup)]`, exact.
    pub fn round(self) -> Interval {
        self.step(f64::round)
    }

    /// A monotone step function at both ends (the empty interval stays empty).
    fn step(self, f: fn(f64) -> f64) -> Interval {
        if self.is_empty() {
            return self;
        }
        Interval::new(f(self.lo), f(self.hi))
    }
}
