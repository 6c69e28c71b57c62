//! Lipschitz slopes of a formula over a box, carried forward through its
//! operations.
//!
//! The interval gradient bounds `|∂f/∂xᵢ|` where every operation's
//! derivative is bounded. At the centre of a circle, `√(u² + v²)` has no
//! derivative and the interval of `u/√(u² + v²)` is the whole line, though f
//! moves by at most `|(Δu, Δv)|` there: `‖·‖` is 1-Lipschitz. A [`Slopes`]
//! value carries, beside an enclosure, how fast the value may change along
//! each axis, and for a value that is at least 0, how fast its square root
//! may: the root of a sum of squares then has slopes however near 0 the sum
//! comes.
//!
//! Each operation's rule is the Lipschitz constant of the operation over its
//! arguments' enclosures (convex, so the constant holds between any two of
//! their values) times the arguments' slopes. A finite result also proves
//! every operation defined over the box (a root of a value at least 0, a
//! quotient by a value without 0, ...), so f is defined and Lipschitz, and
//! thus continuous, there.

use super::op::{BinaryOp, UnaryOp};
use super::tape::value::TapeValue;
use crate::types::{Aabb, Interval};

/// No bound along any axis.
const UNBOUNDED: [f64; 3] = [f64::INFINITY; 3];

/// A value's enclosure over a box, and how fast it may change there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slopes {
    /// Encloses every value over the box.
    pub range: Interval,
    /// `|v(p) − v(q)| ≤ Σᵢ slope[i]·|pᵢ − qᵢ|` for all p, q in the box;
    /// `+∞` where no bound is known, and along every axis where v may be
    /// undefined somewhere in the box.
    pub slope: [f64; 3],
    /// The same for `√v`, where v is at least 0 over the box; `+∞` where
    /// unknown.
    pub root: [f64; 3],
    /// Whether v is defined everywhere in the box (every operation on the
    /// way within its domain).
    pub defined: bool,
}

impl Slopes {
    /// Coordinate `axis` over `range`.
    pub fn axis(range: Interval, axis: usize) -> Slopes {
        let mut slope = [0.0; 3];
        slope[axis] = 1.0;
        Slopes::new(range, slope, UNBOUNDED, true)
    }

    /// A value that does not change over the box (a ray's direction), in
    /// `range`.
    pub fn fixed(range: Interval) -> Slopes {
        Slopes::new(range, [0.0; 3], UNBOUNDED, true)
    }

    /// A tape's six inputs over the box `b`: its coordinates, and a ray's
    /// direction (any in `[-1, 1]³`, which does not change over the box).
    pub fn inputs(b: &Aabb) -> [Slopes; 6] {
        let [x, y, z] = b.intervals();
        let direction = Slopes::fixed(Interval::UNIT);
        [
            Slopes::axis(x, 0),
            Slopes::axis(y, 1),
            Slopes::axis(z, 2),
            direction,
            direction,
            direction,
        ]
    }

    /// A value that may be undefined somewhere in the box: no slopes.
    fn undefined(range: Interval) -> Slopes {
        Slopes {
            range,
            slope: UNBOUNDED,
            root: UNBOUNDED,
            defined: false,
        }
    }

    /// The Euclidean norm of the slopes, rounded up: `|v(p) − v(q)| ≤
    /// L·|p − q|` (Cauchy–Schwarz on the sum of the slopes).
    pub fn lipschitz(&self) -> f64 {
        crate::types::interval::norm_sup(self.slope)
    }

    /// A value in `range` with these slopes, `defined` everywhere in the box
    /// or not: no slope where it is not (or its range is empty), none that
    /// is NaN, none along an axis where the range is a single value (it does
    /// not change), and for a value above 0, root slopes at most those of
    /// the derivative bound `1/(2√v)`.
    fn new(range: Interval, slope: [f64; 3], root: [f64; 3], defined: bool) -> Slopes {
        if range.is_empty() || !defined {
            return Slopes::undefined(range);
        }
        let constant = range.inf() == range.sup();
        let clean = |s: f64| if s.is_nan() { f64::INFINITY } else { s };
        let slope = slope.map(|s| if constant { 0.0 } else { clean(s) });
        let mut root = root.map(clean);
        if range.inf() > 0.0 {
            let k = (Interval::point(0.5) / Interval::point(range.inf()).sqrt()).sup();
            root = std::array::from_fn(|i| root[i].min(times(k, slope[i])));
        } else if constant && range.inf() == 0.0 {
            root = [0.0; 3];
        }
        if range.inf() < 0.0 {
            root = UNBOUNDED;
        }
        Slopes {
            range,
            slope,
            root,
            defined: true,
        }
    }

    /// Slopes `k·s`, the value in `range`: `op(v)` where op is defined and
    /// k-Lipschitz over v's range (or jumps, for `k = ∞`).
    fn through(range: Interval, k: f64, a: &Slopes) -> Slopes {
        Slopes::new(range, a.slope.map(|s| times(k, s)), UNBOUNDED, a.defined)
    }
}

/// `k·s` rounded up, for `k, s ≥ 0`; 0 where `s` is (a value that does not
/// change moves nothing, whatever the factor).
fn times(k: f64, s: f64) -> f64 {
    if s == 0.0 {
        0.0
    } else {
        (k * s).next_up()
    }
}

/// `a + b` rounded up, for `a, b ≥ 0`.
fn plus(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        a + b
    } else {
        (a + b).next_up()
    }
}

/// `√(a² + b²)` rounded up: the slope of `‖(√u, √w)‖` from those of `√u`
/// and `√w` (the triangle inequality of the norm, axis by axis).
fn hypot_up(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        return a + b;
    }
    let (a, b) = (Interval::point(a), Interval::point(b));
    (a.powi(2) + b.powi(2)).sqrt().sup()
}

/// An upper bound of an interval's magnitude (`+∞` for an empty one, where
/// no bound is known).
fn mag(x: Interval) -> f64 {
    if x.is_empty() {
        f64::INFINITY
    } else {
        x.mag()
    }
}

impl TapeValue for Slopes {
    fn constant(v: f64) -> Self {
        Slopes::new(Interval::point(v), [0.0; 3], [0.0; 3], true)
    }

    fn unary(op: UnaryOp, a: Self) -> Self {
        use UnaryOp::*;
        let x = a.range;
        let range = <Interval as TapeValue>::unary(op, x);
        let k = match op {
            Neg => return Slopes::new(range, a.slope, UNBOUNDED, a.defined),
            Abs => {
                // |v| = v where v ≥ 0, so √|v| = √v.
                let root = if x.inf() >= 0.0 { a.root } else { UNBOUNDED };
                return Slopes::new(range, a.slope, root, a.defined);
            }
            // v's root slopes, which `new` made at most v's slopes times the
            // bound 1/(2√v) of √′ where v > 0.
            Sqrt if x.inf() >= 0.0 => return Slopes::new(range, a.root, UNBOUNDED, a.defined),
            Sin | Cos | Atan | Tanh | Sech => 1.0,
            Exp => Interval::point(x.sup()).exp().sup(),
            Ln if x.inf() > 0.0 => (Interval::point(1.0) / Interval::point(x.inf())).sup(),
            Sinh | Cosh => Interval::point(mag(x)).cosh().sup(),
            // tan′ = 1 + tan², bounded where tan is (no pole in the range).
            Tan if range.is_bounded() => (Interval::point(1.0) + range.powi(2)).sup(),
            Asin | Acos if mag(x) < 1.0 => {
                let m = Interval::point(mag(x));
                (Interval::point(1.0) / (Interval::point(1.0) - m.powi(2)).sqrt()).sup()
            }
            Sqrt | Ln | Tan | Asin | Acos => return Slopes::undefined(range),
            // Steps and spikes: constant where their range is one value
            // (`new` sees to it), else they jump.
            Sign | Dirac | Floor | Ceil | Round => f64::INFINITY,
        };
        Slopes::through(range, k, &a)
    }

    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        use BinaryOp::*;
        let (x, y) = (a.range, b.range);
        let range = <Interval as TapeValue>::binary(op, x, y);
        // ka·|Δa| + kb·|Δb|, axis by axis.
        let linear = |ka: f64, kb: f64| -> [f64; 3] {
            std::array::from_fn(|i| plus(times(ka, a.slope[i]), times(kb, b.slope[i])))
        };
        if !(a.defined && b.defined) {
            return Slopes::undefined(range);
        }
        match op {
            Add | Sub => {
                let slope = linear(1.0, 1.0);
                let root = if op == Add {
                    std::array::from_fn(|i| hypot_up(a.root[i], b.root[i]))
                } else {
                    UNBOUNDED
                };
                Slopes::new(range, slope, root, true)
            }
            Mul => {
                // √(ab) = √a·√b, where both are at least 0.
                let (ra, rb) = (x.max(Interval::ZERO).sqrt(), y.max(Interval::ZERO).sqrt());
                let root = std::array::from_fn(|i| {
                    plus(times(mag(rb), a.root[i]), times(mag(ra), b.root[i]))
                });
                Slopes::new(range, linear(mag(y), mag(x)), root, true)
            }
            Div if y.mig() > 0.0 => {
                let m = Interval::point(y.mig());
                let ka = (Interval::point(1.0) / m).sup();
                let kb = (Interval::point(mag(x)) / m.powi(2)).sup();
                Slopes::new(range, linear(ka, kb), UNBOUNDED, true)
            }
            Min | Max => {
                let (low, high) = if x.sup() <= y.inf() { (a, b) } else { (b, a) };
                let decided = x.sup() <= y.inf() || y.sup() <= x.inf();
                if decided {
                    let kept = if op == Min { low } else { high };
                    return Slopes::new(range, kept.slope, kept.root, true);
                }
                // |max(a, b) − max(a′, b′)| ≤ max(|a − a′|, |b − b′|), and √
                // is increasing, so the same holds of the roots.
                let most = |u: [f64; 3], w: [f64; 3]| std::array::from_fn(|i| u[i].max(w[i]));
                Slopes::new(range, most(a.slope, b.slope), most(a.root, b.root), true)
            }
            Atan2 => {
                // |∇atan2(a, b)| = 1/r, over a rectangle of (b, a) that
                // misses the origin and the cut b < 0, a = 0.
                let r = (Interval::point(x.mig()).powi(2) + Interval::point(y.mig()).powi(2))
                    .sqrt()
                    .inf();
                let cut = x.contains(0.0) && y.inf() < 0.0;
                if r > 0.0 && !cut {
                    let k = (Interval::point(1.0) / Interval::point(r)).sup();
                    Slopes::new(range, linear(k, k), UNBOUNDED, true)
                } else {
                    Slopes::undefined(range)
                }
            }
            Pow if x.inf() > 0.0 => {
                // ∂/∂a a^b = b·a^(b−1), ∂/∂b a^b = a^b·ln a.
                let ka = mag(y * x.pow(y - Interval::point(1.0)));
                let kb = mag(x.pow(y) * x.ln());
                Slopes::new(range, linear(ka, kb), UNBOUNDED, true)
            }
            Div | Pow => Slopes::undefined(range),
        }
    }

    fn powi(a: Self, n: i32) -> Self {
        let x = a.range;
        let range = x.powi(n);
        if n < 0 && x.contains(0.0) {
            return Slopes::undefined(range);
        }
        if n == 0 {
            return Slopes::new(range, [0.0; 3], [0.0; 3], a.defined);
        }
        // |d/dt tⁿ| = |n|·|t|ⁿ⁻¹ over the range.
        let k = mag(Interval::point(f64::from(n)) * x.powi(n - 1));
        let slopes = Slopes::through(range, k, &a);
        if n == 2 {
            // √(v²) = |v|: v's own slopes.
            Slopes::new(range, slopes.slope, a.slope, a.defined)
        } else {
            slopes
        }
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        let range = Interval::choose(c.range, p.range, n.range);
        if !c.defined {
            Slopes::undefined(range)
        } else if c.range.sup() < 0.0 {
            p
        } else if c.range.inf() > 0.0 {
            n
        } else {
            // It may jump where c changes sign.
            Slopes::new(range, UNBOUNDED, UNBOUNDED, p.defined && n.defined)
        }
    }
}
