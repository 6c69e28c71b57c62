//! Reduced affine arithmetic, with outward rounding.
//!
//! A form is `c₀ + c₁ε₁ + c₂ε₂ + c₃ε₃ ± e`: each εᵢ ∈ [−1, 1] is one of the
//! box's coordinates (x = mid + rad·ε₁, and so on), and `e ≥ 0` gathers
//! everything else, the non-linear parts and every rounding error. This is
//! the reduced form of Knoll et al. (2009): the noise symbols are the
//! inputs' and no more, so a form is five numbers and never grows, and the
//! correlation it keeps is the first-order dependence on x, y and z, which
//! intervals lose (`x − x` is 0 here, `[−2w, 2w]` there).
//!
//! Every coefficient is computed with the interval type and split into its
//! midpoint and a radius rounded up, which joins `e`: a form always encloses
//! the exact result. `+ − ×`, integer powers, `sqrt`, `exp`, `ln` and `1/x`
//! are affine (the last four by their chord, with the error of the
//! linearisation bounded by a tangent); every other function falls back to
//! the interval of its argument, so the result loses its correlation but
//! stays sound.

use super::interval::Interval;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Noise symbols: x, y, z (t along a ray uses the first).
const SYMBOLS: usize = 3;

/// A reduced affine form; empty where the value is undefined everywhere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine {
    /// The centre, then one coefficient per noise symbol.
    c: [f64; SYMBOLS + 1],
    /// The radius of everything else; `+∞` for an unbounded value.
    e: f64,
    /// No value at all (outside the domain everywhere).
    empty: bool,
}

/// `a + b` for non-negative numbers, rounded up.
fn up_add(a: f64, b: f64) -> f64 {
    let s = a + b;
    if s.is_finite() {
        s.next_up()
    } else {
        s
    }
}

/// `a·b` for non-negative numbers, rounded up.
fn up_mul(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        return 0.0;
    }
    let p = a * b;
    if p.is_finite() {
        p.next_up()
    } else {
        f64::INFINITY
    }
}

/// An interval's midpoint and a radius rounded up that reaches both ends.
fn split(v: Interval) -> (f64, f64) {
    if v.is_empty() || !v.is_bounded() {
        return (0.0, f64::INFINITY);
    }
    let m = v.mid();
    let r = (v.sup() - m).max(m - v.inf());
    (m, if r > 0.0 { r.next_up() } else { 0.0 })
}

impl Affine {
    /// The form with no value.
    pub const EMPTY: Affine = Affine {
        c: [0.0; SYMBOLS + 1],
        e: 0.0,
        empty: true,
    };

    /// A constant.
    pub fn constant(v: f64) -> Affine {
        if !v.is_finite() {
            return Affine::from_interval(Interval::point(v));
        }
        let mut c = [0.0; SYMBOLS + 1];
        c[0] = v;
        Affine {
            c,
            e: 0.0,
            empty: false,
        }
    }

    /// The input whose range is `v`, as noise symbol `symbol` (0, 1, 2):
    /// `mid + rad·ε`, enclosing `v`.
    pub fn input(v: Interval, symbol: usize) -> Affine {
        let (m, r) = split(v);
        if !r.is_finite() {
            return Affine::from_interval(v);
        }
        let mut c = [0.0; SYMBOLS + 1];
        c[0] = m;
        c[1 + symbol] = r;
        Affine {
            c,
            e: 0.0,
            empty: false,
        }
    }

    /// The form of an interval, correlated with nothing.
    pub fn from_interval(v: Interval) -> Affine {
        if v.is_empty() {
            return Affine::EMPTY;
        }
        let (m, r) = split(v);
        let mut c = [0.0; SYMBOLS + 1];
        c[0] = m;
        Affine {
            c,
            e: r,
            empty: false,
        }
    }

    /// The radius of the noise: `Σ|cᵢ| + e`, rounded up.
    fn radius(&self) -> f64 {
        self.c[1..].iter().fold(self.e, |r, c| up_add(r, c.abs()))
    }

    /// The interval the form encloses.
    pub fn range(&self) -> Interval {
        if self.empty {
            return Interval::EMPTY;
        }
        let r = self.radius();
        if !r.is_finite() {
            return Interval::ENTIRE;
        }
        Interval::point(self.c[0]) + Interval::new(-r, r)
    }

    /// Builds a form from exact coefficients given as intervals, their
    /// radii joining `e`.
    fn from_parts(parts: [Interval; SYMBOLS + 1], e: f64) -> Affine {
        let mut c = [0.0; SYMBOLS + 1];
        let mut e = e;
        for (k, p) in parts.iter().enumerate() {
            let (m, r) = split(*p);
            c[k] = m;
            e = up_add(e, r);
        }
        if !e.is_finite() {
            return Affine::from_interval(Interval::ENTIRE);
        }
        Affine { c, e, empty: false }
    }

    /// `a²`: `(a₀ + L)² = a₀² + 2a₀L + L²`, with L² in `[0, r²]` centred.
    fn square(self) -> Affine {
        if self.empty {
            return self;
        }
        let a0 = Interval::point(self.c[0]);
        let r = self.radius();
        let half = up_mul(up_mul(r, r), 0.5);
        let two_a0 = a0 * Interval::point(2.0);
        let parts = std::array::from_fn(|k| {
            if k == 0 {
                a0 * a0 + Interval::point(half)
            } else {
                two_a0 * Interval::point(self.c[k])
            }
        });
        // 2a₀'s part of e, and L²'s spread about its centre.
        let e = up_add(up_mul(up_mul(self.c[0].abs(), 2.0), self.e), half);
        Affine::from_parts(parts, e)
    }

    /// `aⁿ`, by squaring.
    pub fn powi(self, n: i32) -> Affine {
        match n {
            0 => Affine::constant(1.0),
            1 => self,
            2 => self.square(),
            n if n < 0 => self.powi(-n).recip(),
            n => {
                let half = self.powi(n / 2).square();
                if n % 2 == 1 {
                    half.mul(self)
                } else {
                    half
                }
            }
        }
    }

    /// `1/a`: affine where a keeps one sign.
    pub fn recip(self) -> Affine {
        let r = self.range();
        let slope = |v: Interval| -(v * v).recip_of_one();
        if r.inf() > 0.0 {
            let u = |alpha: f64| (-1.0 / alpha).sqrt();
            self.chord(|v| Interval::point(1.0) / v, slope, u, true)
        } else if r.sup() < 0.0 {
            let u = |alpha: f64| -(-1.0 / alpha).sqrt();
            self.chord(|v| Interval::point(1.0) / v, slope, u, false)
        } else {
            self.fallback(|v| Interval::point(1.0) / v)
        }
    }

    /// `√a`.
    pub fn sqrt(self) -> Affine {
        if self.range().inf() > 0.0 {
            let slope = |v: Interval| (v.sqrt() * Interval::point(2.0)).recip_of_one();
            self.chord(Interval::sqrt, slope, |alpha| 0.25 / (alpha * alpha), false)
        } else {
            self.fallback(Interval::sqrt)
        }
    }

    /// `eᵃ`.
    pub fn exp(self) -> Affine {
        self.chord(Interval::exp, Interval::exp, f64::ln, true)
    }

    /// `ln a`.
    pub fn ln(self) -> Affine {
        if self.range().inf() > 0.0 {
            self.chord(
                Interval::ln,
                |v| v.recip_of_one(),
                |alpha| 1.0 / alpha,
                false,
            )
        } else {
            self.fallback(Interval::ln)
        }
    }

    /// `f(a)` for any function, through the interval of a.
    pub fn fallback(self, f: impl Fn(Interval) -> Interval) -> Affine {
        if self.empty {
            return self;
        }
        Affine::from_interval(f(self.range()))
    }

    /// `f(a)` for a convex (`convex`) or concave f over a's range, by its
    /// chord: `f(a) ≈ α·a + ζ ± δ`, α the chord's slope. The error
    /// `g = f − α·x` is bounded at the ends (where g is largest for a convex
    /// f) and, on the other side, by the tangent of g at the point
    /// `u = at_slope(α)` where f′(u) = α: a tangent of a convex g lies below
    /// it everywhere, whichever u is taken, so rounding in α or u costs
    /// tightness, never soundness. `slope` encloses f′.
    fn chord(
        self,
        f: impl Fn(Interval) -> Interval,
        slope: impl Fn(Interval) -> Interval,
        at_slope: impl Fn(f64) -> f64,
        convex: bool,
    ) -> Affine {
        if self.empty {
            return self;
        }
        let range = self.range();
        let (a, b) = (range.inf(), range.sup());
        if !(a.is_finite() && b.is_finite()) || a == b {
            return self.fallback(f);
        }
        let (fa, fb) = (f(Interval::point(a)), f(Interval::point(b)));
        let alpha = ((fb - fa) / (Interval::point(b) - Interval::point(a))).mid();
        if !alpha.is_finite() {
            return self.fallback(f);
        }
        let g = |x: f64| f(Interval::point(x)) - Interval::point(alpha) * Interval::point(x);
        let ends = g(a).hull(g(b));
        // The point where the slope is α, kept inside [a, b].
        let u = at_slope(alpha);
        let u = if u.is_finite() {
            u.clamp(a, b)
        } else {
            a + 0.5 * (b - a)
        };
        let gu = g(u);
        let gslope = slope(Interval::point(u)) - Interval::point(alpha);
        let reach = Interval::new(a, b) - Interval::point(u);
        let tangent = gu + gslope * reach;
        let error = if convex {
            Interval::new(tangent.inf(), ends.sup())
        } else {
            Interval::new(ends.inf(), tangent.sup())
        };
        if error.is_empty() || !error.is_bounded() {
            return self.fallback(f);
        }
        let (zeta, delta) = split(error);
        let scaled = self.mul(Affine::constant(alpha));
        let mut out = scaled.add(Affine::constant(zeta));
        out.e = up_add(out.e, delta);
        // Never wider than the interval of f itself.
        if out.range().wid() > f(range).wid() {
            return self.fallback(f);
        }
        out
    }
}

impl Add for Affine {
    type Output = Affine;

    /// `a + b`.
    fn add(self, b: Affine) -> Affine {
        if self.empty || b.empty {
            return Affine::EMPTY;
        }
        let parts = std::array::from_fn(|k| Interval::point(self.c[k]) + Interval::point(b.c[k]));
        Affine::from_parts(parts, up_add(self.e, b.e))
    }
}

impl Neg for Affine {
    type Output = Affine;

    /// `−a`, exactly.
    fn neg(self) -> Affine {
        Affine {
            c: self.c.map(|v| -v),
            ..self
        }
    }
}

impl Sub for Affine {
    type Output = Affine;

    /// `a − b`.
    fn sub(self, b: Affine) -> Affine {
        self.add(b.neg())
    }
}

impl Mul for Affine {
    type Output = Affine;

    /// `a·b`: the product's linear part, and `|a₀|e_b + |b₀|e_a + r_a·r_b`
    /// for the rest.
    // A product's linear part is a sum of products.
    #[allow(clippy::suspicious_arithmetic_impl)]
    fn mul(self, b: Affine) -> Affine {
        if self.empty || b.empty {
            return Affine::EMPTY;
        }
        let (a0, b0) = (Interval::point(self.c[0]), Interval::point(b.c[0]));
        let parts = std::array::from_fn(|k| {
            if k == 0 {
                a0 * b0
            } else {
                a0 * Interval::point(b.c[k]) + b0 * Interval::point(self.c[k])
            }
        });
        let e = up_add(
            up_add(up_mul(self.c[0].abs(), b.e), up_mul(b.c[0].abs(), self.e)),
            up_mul(self.radius(), b.radius()),
        );
        Affine::from_parts(parts, e)
    }
}

impl Div for Affine {
    type Output = Affine;

    /// `a/b`.
    fn div(self, b: Affine) -> Affine {
        self.mul(b.recip())
    }
}

impl Interval {
    /// `1/v`, for the slopes of the chords above.
    fn recip_of_one(self) -> Interval {
        Interval::point(1.0) / self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn forms() -> [(Interval, Affine); 3] {
        let x = Interval::new(0.5, 1.5);
        let y = Interval::new(-2.0, 1.0);
        let z = Interval::new(3.0, 3.25);
        [
            (x, Affine::input(x, 0)),
            (y, Affine::input(y, 1)),
            (z, Affine::input(z, 2)),
        ]
    }

    /// Every operation encloses its exact value at sampled points of the box.
    #[test]
    fn every_operation_encloses_sampled_values() {
        let [(xi, x), (yi, y), (zi, z)] = forms();
        type Case = (
            &'static str,
            Box<dyn Fn(Affine, Affine, Affine) -> Affine>,
            fn(f64, f64, f64) -> f64,
        );
        let cases: Vec<Case> = vec![
            ("x-x", Box::new(|x, _, _| x.sub(x)), |_, _, _| 0.0),
            ("x*y+z", Box::new(|x, y, z| x.mul(y).add(z)), |x, y, z| {
                x * y + z
            }),
            ("y^2", Box::new(|_, y, _| y.powi(2)), |_, y, _| y * y),
            (
                "x^5*y^3",
                Box::new(|x, y, _| x.powi(5).mul(y.powi(3))),
                |x, y, _| x.powi(5) * y.powi(3),
            ),
            ("1/x", Box::new(|x, _, _| x.recip()), |x, _, _| 1.0 / x),
            ("1/-z", Box::new(|_, _, z| z.neg().recip()), |_, _, z| {
                -1.0 / z
            }),
            ("z/x", Box::new(|x, _, z| z.div(x)), |x, _, z| z / x),
            (
                "sqrt(x*z)",
                Box::new(|x, _, z| x.mul(z).sqrt()),
                |x, _, z| (x * z).sqrt(),
            ),
            ("exp(y-x)", Box::new(|x, y, _| y.sub(x).exp()), |x, y, _| {
                (y - x).exp()
            }),
            ("ln(z-x)", Box::new(|x, _, z| z.sub(x).ln()), |x, _, z| {
                (z - x).ln()
            }),
            ("x^-2", Box::new(|x, _, _| x.powi(-2)), |x, _, _| x.powi(-2)),
            (
                "sin fallback",
                Box::new(|x, y, _| x.mul(y).fallback(Interval::sin)),
                |x, y, _| (x * y).sin(),
            ),
        ];
        for (name, form, exact) in &cases {
            let r = form(x, y, z).range();
            for i in 0..=8 {
                for j in 0..=8 {
                    for k in 0..=4 {
                        let at = |v: Interval, s: usize, n: usize| {
                            v.inf() + (v.sup() - v.inf()) * s as f64 / n as f64
                        };
                        let v = exact(at(xi, i, 8), at(yi, j, 8), at(zi, k, 4));
                        assert!(r.contains(v), "{name}: {v} outside {r:?}");
                    }
                }
            }
        }
    }

    /// Affine forms keep the dependence intervals lose.
    #[test]
    fn correlation_is_kept() {
        let [(xi, x), (yi, y), _] = forms();
        assert!(x.sub(x).range().wid() < 1e-15);
        // xy − xy: the linear parts cancel; each product's quadratic part
        // (±r_x·r_y = ±0.75) is its own, and stays.
        let affine = x.mul(y).sub(x.mul(y)).range();
        let interval = xi * yi - xi * yi;
        assert!(
            affine.wid() <= 3.0 + 1e-12 && interval.wid() >= 9.0,
            "{affine:?} {interval:?}"
        );
        // (x + y)² − x² − 2xy − y² is 0: affine gets within the square's
        // spread, intervals are off by far more.
        let s = x
            .add(y)
            .powi(2)
            .sub(x.powi(2))
            .sub(x.mul(y).mul(Affine::constant(2.0)))
            .sub(y.powi(2));
        let i = (xi + yi).powi(2) - xi.powi(2) - Interval::point(2.0) * xi * yi - yi.powi(2);
        assert!(s.range().contains(0.0) && s.range().wid() < i.wid() / 2.0);
    }

    #[test]
    fn empty_and_unbounded_propagate() {
        let [(_, x), ..] = forms();
        assert!(x.neg().fallback(Interval::sqrt).range().is_empty());
        assert!(x.add(Affine::EMPTY).range().is_empty());
        let wide = Affine::from_interval(Interval::ENTIRE);
        assert!(!x.mul(wide).range().is_bounded());
    }
}
