//! Polynomials with interval coefficients, and their range over a box by the
//! Bernstein form (Garloff's method).
//!
//! A formula built from `+ − ×`, non-negative integer powers and constants is
//! expanded exactly into monomials; constants that are not f64 numbers
//! (`sqrt(2)`, `pi/3`) become intervals enclosing them, and every product
//! and sum of coefficients rounds outward, so the expanded polynomial's
//! coefficients enclose the exact ones. Over a box, the polynomial is
//! rewritten in the box's unit coordinates and converted to the tensor
//! Bernstein basis: the range of the polynomial over the box lies between
//! the smallest and the largest Bernstein coefficient (the range enclosing
//! property), which for a box small against the polynomial's features is
//! close to the true range, where the natural interval extension may be far
//! off.

use crate::expr::TapeValue;
use crate::expr::{BinaryOp, UnaryOp};
use crate::expr::{Context, Node, Op, Var};
use crate::types::Interval;

/// The most coefficients any polynomial of an expansion may have.
pub const MAX_COEFFICIENTS: usize = 1 << 15;

/// The highest degree in any one variable: the Bernstein form's change of
/// basis takes (degree + 1)² binomial ratios, 16 GB at the coefficient cap
/// in one variable (`sinh(x)^1000`), 2 MB here.
pub const MAX_DEGREE: usize = 256;

/// The most coefficient operations an expansion may take (about a tenth of
/// a second): beyond it the formula counts as not polynomial.
pub const MAX_WORK: u64 = 50_000_000;

/// The most coefficients an expansion may hold at once, over all its nodes
/// (64 MB), whatever the formula's length.
pub const MAX_HELD: usize = 1 << 22;

/// Where the functions of a formula are expanded (Taylor models): the box
/// `lo + w·[0, 1]³` of the polynomial's variables and the order.
#[derive(Debug, Clone, Copy)]
pub struct Expansion {
    /// The box's low corner.
    pub lo: [Interval; 3],
    /// Its widths.
    pub w: [Interval; 3],
    /// The highest degree of each function's Taylor polynomial (lower
    /// where the remainder is already negligible).
    pub order: usize,
}

/// A polynomial in up to three variables with interval coefficients, stored
/// densely: the coefficient of `u^i v^j w^k` at `i + s0·(j + s1·k)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Poly {
    /// The degree in each variable.
    deg: [usize; 3],
    coeffs: Vec<Interval>,
}

const ZERO: Interval = Interval::ZERO;

impl Poly {
    /// The constant polynomial `c`.
    pub fn constant(c: Interval) -> Poly {
        Poly {
            deg: [0; 3],
            coeffs: vec![c],
        }
    }

    /// `a + b·(variable axis)`.
    pub fn linear(axis: usize, a: Interval, b: Interval) -> Poly {
        let mut deg = [0; 3];
        deg[axis] = 1;
        Poly {
            deg,
            coeffs: vec![a, b],
        }
    }

    /// The degree in each variable.
    pub fn degree(&self) -> [usize; 3] {
        self.deg
    }

    fn sizes(deg: [usize; 3]) -> [usize; 3] {
        deg.map(|d| d + 1)
    }

    fn len_of(deg: [usize; 3]) -> Option<usize> {
        let [a, b, c] = Self::sizes(deg);
        a.checked_mul(b)?.checked_mul(c)
    }

    fn zeros(deg: [usize; 3]) -> Option<Poly> {
        if deg.iter().any(|&d| d > MAX_DEGREE) {
            return None;
        }
        let n = Self::len_of(deg).filter(|&n| n <= MAX_COEFFICIENTS)?;
        Some(Poly {
            deg,
            coeffs: vec![ZERO; n],
        })
    }

    #[inline]
    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        let [s0, s1, _] = Self::sizes(self.deg);
        i + s0 * (j + s1 * k)
    }

    /// `self` with room for degree `deg` (at least its own).
    fn widened(&self, deg: [usize; 3]) -> Option<Poly> {
        let mut out = Self::zeros(deg)?;
        let [a, b, c] = Self::sizes(self.deg);
        for k in 0..c {
            for j in 0..b {
                for i in 0..a {
                    let at = out.index(i, j, k);
                    out.coeffs[at] = self.coeffs[self.index(i, j, k)];
                }
            }
        }
        Some(out)
    }

    fn zip(&self, other: &Poly, op: impl Fn(Interval, Interval) -> Interval) -> Option<Poly> {
        let deg = [0, 1, 2].map(|a| self.deg[a].max(other.deg[a]));
        let mut out = self.widened(deg)?;
        let [a, b, c] = Self::sizes(other.deg);
        for k in 0..c {
            for j in 0..b {
                for i in 0..a {
                    let at = out.index(i, j, k);
                    out.coeffs[at] = op(out.coeffs[at], other.coeffs[other.index(i, j, k)]);
                }
            }
        }
        Some(out)
    }

    /// `self + other`.
    pub fn add(&self, other: &Poly) -> Option<Poly> {
        self.zip(other, |a, b| a + b)
    }

    /// `self − other`.
    pub fn sub(&self, other: &Poly) -> Option<Poly> {
        self.zip(other, |a, b| a - b)
    }

    /// `−self`.
    pub fn neg(&self) -> Poly {
        Poly {
            deg: self.deg,
            coeffs: self.coeffs.iter().map(|c| -*c).collect(),
        }
    }

    /// `c·self`.
    pub fn scale(&self, c: Interval) -> Poly {
        Poly {
            deg: self.deg,
            coeffs: self.coeffs.iter().map(|&a| a * c).collect(),
        }
    }

    /// `self·other`, counting coefficient products into `work`.
    pub fn mul(&self, other: &Poly, work: &mut u64) -> Option<Poly> {
        let deg = [0, 1, 2].map(|a| self.deg[a] + other.deg[a]);
        let mut out = Self::zeros(deg)?;
        let nonzero = |p: &Poly| -> Vec<(usize, usize, usize, Interval)> {
            let [a, b, c] = Self::sizes(p.deg);
            let mut v = Vec::new();
            for k in 0..c {
                for j in 0..b {
                    for i in 0..a {
                        let x = p.coeffs[p.index(i, j, k)];
                        if x != ZERO {
                            v.push((i, j, k, x));
                        }
                    }
                }
            }
            v
        };
        let (left, right) = (nonzero(self), nonzero(other));
        *work += (left.len() * right.len()) as u64;
        if *work > MAX_WORK {
            return None;
        }
        for &(i, j, k, x) in &left {
            for &(p, q, r, y) in &right {
                let at = out.index(i + p, j + q, k + r);
                out.coeffs[at] = out.coeffs[at] + x.mul_widened(y);
            }
        }
        Some(out)
    }

    /// `self^n`, `n ≥ 0`, by repeated squaring.
    pub fn powi(&self, n: u32, work: &mut u64) -> Option<Poly> {
        let mut result = Poly::constant(Interval::point(1.0));
        let mut base = self.clone();
        let mut n = n;
        while n > 0 {
            if n & 1 == 1 {
                result = result.mul(&base, work)?;
            }
            n >>= 1;
            if n > 0 {
                base = base.mul(&base, work)?;
            }
        }
        Some(result)
    }

    /// The polynomial of `root`, each variable replaced by `var(v)`; `None`
    /// when `root` is not a polynomial in them (a function other than
    /// `+ − ×`, a division by a non-constant, a negative power), a constant
    /// is undefined or unbounded, or the expansion exceeds its limits.
    pub fn from_graph(
        ctx: &Context,
        root: Node,
        var: &dyn Fn(Var) -> Option<Poly>,
    ) -> Option<Poly> {
        Self::expand(ctx, &[root], var, None).map(|mut v| v.remove(0))
    }

    /// The polynomials of `roots`, each variable replaced by `var(v)`. With
    /// an [`Expansion`], `sin cos exp sinh cosh` of a polynomial are expanded
    /// too, as Taylor models over its box: the Taylor polynomial about the
    /// argument's value at the box centre, with the Lagrange remainder over
    /// the box added to the constant coefficient. The result then holds
    /// pointwise: at each point of the box, the formula's value is the value
    /// of some polynomial with coefficients in the intervals, so the
    /// Bernstein range over the box encloses the formula's range there.
    pub fn expand(
        ctx: &Context,
        roots: &[Node],
        var: &dyn Fn(Var) -> Option<Poly>,
        expansion: Option<&Expansion>,
    ) -> Option<Vec<Poly>> {
        let order = ctx.topological_order(roots);
        let mut held = 0usize;
        // Per node: a constant's enclosure, or a polynomial.
        let mut consts: Vec<Option<Interval>> = vec![None; ctx.len()];
        let mut polys: Vec<Option<Poly>> = vec![None; ctx.len()];
        let mut work = 0u64;
        for &node in &order {
            let c = |n: Node| consts[n.index()];
            let constant = match *ctx.get(node) {
                Op::Const(k) => Some(Interval::point(k.value())),
                Op::Var(_) => None,
                Op::Unary(op, a) => c(a).map(|a| Interval::unary(op, a)),
                Op::Binary(op, a, b) => c(a).zip(c(b)).map(|(a, b)| Interval::binary(op, a, b)),
                Op::PowI(a, n) => c(a).map(|a| a.powi(n)),
                Op::Choose(p, a, b) => c(p)
                    .zip(c(a))
                    .zip(c(b))
                    .map(|((p, a), b)| Interval::choose(p, a, b)),
                Op::Remap(..) => return None,
            };
            if let Some(k) = constant {
                if k.is_empty() || !k.is_bounded() {
                    return None;
                }
                consts[node.index()] = Some(k);
                continue;
            }
            let p = |n: Node| -> Option<Poly> {
                match consts[n.index()] {
                    Some(k) => Some(Poly::constant(k)),
                    None => polys[n.index()].clone(),
                }
            };
            let poly = match *ctx.get(node) {
                Op::Var(v) => var(v)?,
                Op::Unary(UnaryOp::Neg, a) => p(a)?.neg(),
                Op::Binary(BinaryOp::Add, a, b) => p(a)?.add(&p(b)?)?,
                Op::Binary(BinaryOp::Sub, a, b) => p(a)?.sub(&p(b)?)?,
                Op::Binary(BinaryOp::Mul, a, b) => match (c(a), c(b)) {
                    (Some(k), _) => p(b)?.scale(k),
                    (_, Some(k)) => p(a)?.scale(k),
                    _ => p(a)?.mul(&p(b)?, &mut work)?,
                },
                Op::Binary(BinaryOp::Div, a, b) => {
                    let k = Interval::point(1.0) / c(b)?;
                    if k.is_empty() || !k.is_bounded() {
                        return None;
                    }
                    p(a)?.scale(k)
                }
                Op::PowI(a, n) if n >= 0 => p(a)?.powi(n as u32, &mut work)?,
                Op::Unary(op, a) => taylor(op, &p(a)?, expansion?, &mut work)?,
                _ => return None,
            };
            work += poly.coeffs.len() as u64;
            held += poly.coeffs.len();
            if work > MAX_WORK || held > MAX_HELD {
                return None;
            }
            polys[node.index()] = Some(poly);
        }
        Some(
            roots
                .iter()
                .map(|r| match consts[r.index()] {
                    Some(k) => Poly::constant(k),
                    None => polys[r.index()]
                        .clone()
                        .unwrap_or_else(|| Poly::constant(ZERO)),
                })
                .collect(),
        )
    }

    /// An enclosure of the value at a point (Horner's scheme, by axis).
    pub fn eval(&self, at: [Interval; 3]) -> Interval {
        let [a, b, c] = Self::sizes(self.deg);
        let mut total = ZERO;
        for k in (0..c).rev() {
            let mut plane = ZERO;
            for j in (0..b).rev() {
                let mut line = ZERO;
                for i in (0..a).rev() {
                    line = line * at[0] + self.coeffs[self.index(i, j, k)];
                }
                plane = plane * at[1] + line;
            }
            total = total * at[2] + plane;
        }
        total
    }

    /// An enclosure of the polynomial's range over the box `lo + w·[0, 1]³`
    /// (intervals, so that an inexact width still encloses the exact box):
    /// the hull of its Bernstein coefficients there.
    pub fn range_over(&self, lo: [Interval; 3], w: [Interval; 3]) -> Interval {
        let mut p = self.coeffs.clone();
        let sizes = Self::sizes(self.deg);
        for axis in 0..3 {
            let n = self.deg[axis];
            if n == 0 {
                continue;
            }
            let ratios = binomial_ratios(n);
            let stride = match axis {
                0 => 1,
                1 => sizes[0],
                _ => sizes[0] * sizes[1],
            };
            let mut line = vec![ZERO; n + 1];
            for start in 0..p.len() {
                // Each line along `axis` starts where that axis's index is 0.
                if (start / stride) % sizes[axis] != 0 {
                    continue;
                }
                for (i, v) in line.iter_mut().enumerate() {
                    *v = p[start + i * stride];
                }
                to_unit_bernstein(&mut line, lo[axis], w[axis], &ratios);
                for (i, v) in line.iter().enumerate() {
                    p[start + i * stride] = *v;
                }
            }
        }
        p.iter().fold(Interval::EMPTY, |acc, c| acc.hull(*c))
    }
}

/// `op(u)` as a Taylor model over the expansion's box (see
/// [`Poly::expand`]); `None` for functions it does not expand.
fn taylor(op: UnaryOp, u: &Poly, e: &Expansion, work: &mut u64) -> Option<Poly> {
    use UnaryOp::*;
    if !matches!(op, Sin | Cos | Exp | Sinh | Cosh) {
        return None;
    }
    let half = Interval::point(0.5);
    let centre = [0, 1, 2].map(|i| e.lo[i] + e.w[i] * half);
    let a = u.eval(centre).mid();
    if !a.is_finite() {
        return None;
    }
    let a = Interval::point(a);
    let d = u.sub(&Poly::constant(a))?;
    let spread = d.range_over(e.lo, e.w);
    if spread.is_empty() || !spread.is_bounded() {
        return None;
    }
    // The lowest order up to the expansion's whose remainder factor
    // |d|^(k+1)/(k+1)! is below 10⁻⁸: small pieces need few terms.
    let m = spread.mag();
    let mut k = 1;
    let mut factor = m * m / 2.0;
    while k < e.order.max(1) && factor > 1e-8 {
        k += 1;
        factor *= m / (k + 1) as f64;
    }
    // The j-th derivative of op over an interval x.
    let derivative = |j: usize, x: Interval| -> Interval {
        match op {
            Sin => [x.sin(), x.cos(), -x.sin(), -x.cos()][j % 4],
            Cos => [x.cos(), -x.sin(), -x.cos(), x.sin()][j % 4],
            Exp => x.exp(),
            Sinh => [x.sinh(), x.cosh()][j % 2],
            _ => [x.cosh(), x.sinh()][j % 2],
        }
    };
    // Horner in d: Σ op⁽ʲ⁾(a)/j! dʲ.
    let mut factorial = Interval::point(1.0);
    let mut coefficients = Vec::with_capacity(k + 1);
    for j in 0..=k {
        if j > 0 {
            factorial = factorial * Interval::point(j as f64);
        }
        coefficients.push(derivative(j, a) / factorial);
    }
    let mut t = Poly::constant(coefficients[k]);
    for &c in coefficients[..k].iter().rev() {
        t = t.mul(&d, work)?.add(&Poly::constant(c))?;
    }
    // Lagrange: op⁽ᵏ⁺¹⁾(ξ)/(k+1)! d^(k+1), ξ between a and u(x).
    let factorial = factorial * Interval::point((k + 1) as f64);
    let remainder = derivative(k + 1, a + spread) * spread.powi(k as i32 + 1) / factorial;
    if remainder.is_empty() || !remainder.is_bounded() {
        return None;
    }
    t.coeffs[0] = t.coeffs[0] + remainder;
    Some(t)
}

/// `C(k, j) / C(n, j)` for `0 ≤ j ≤ k ≤ n`, enclosed: row k at `k·(n+1)`.
fn binomial_ratios(n: usize) -> Vec<Interval> {
    // Binomials as intervals: exact while below 2⁵³ (n ≤ 50 is far below).
    let mut c = vec![vec![Interval::ZERO; n + 1]; n + 1];
    for k in 0..=n {
        c[k][0] = Interval::point(1.0);
        for j in 1..=k {
            c[k][j] = c[k - 1][j - 1] + if j < k { c[k - 1][j] } else { ZERO };
        }
    }
    let mut out = vec![ZERO; (n + 1) * (n + 1)];
    for k in 0..=n {
        for j in 0..=k {
            out[k * (n + 1) + j] = c[k][j] / c[n][j];
        }
    }
    out
}

/// Rewrites `Σ aᵢ xⁱ` (in `a`) as `Σ bᵢ Bᵢ,ₙ(u)` with `x = lo + w·u`: a Taylor
/// shift by `lo`, a scaling by `wⁱ`, then the change to the Bernstein basis
/// `bₖ = Σⱼ≤ₖ C(k,j)/C(n,j) aⱼ`.
fn to_unit_bernstein(a: &mut [Interval], lo: Interval, w: Interval, ratios: &[Interval]) {
    let n = a.len() - 1;
    // Taylor shift: coefficients of p(lo + s), by repeated synthetic division.
    for i in 0..n {
        for j in (i..n).rev() {
            a[j] = a[j] + lo.mul_widened(a[j + 1]);
        }
    }
    let mut wk = Interval::point(1.0);
    for v in a.iter_mut().skip(1) {
        wk = wk.mul_widened(w);
        *v = v.mul_widened(wk);
    }
    let power = a.to_vec();
    for k in 0..=n {
        let mut b = ZERO;
        for (j, &p) in power.iter().enumerate().take(k + 1) {
            b = b + ratios[k * (n + 1) + j].mul_widened(p);
        }
        a[k] = b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::Formula;

    fn xyz(v: Var) -> Option<Poly> {
        let one = Interval::point(1.0);
        match v {
            Var::X => Some(Poly::linear(0, ZERO, one)),
            Var::Y => Some(Poly::linear(1, ZERO, one)),
            Var::Z => Some(Poly::linear(2, ZERO, one)),
            _ => None,
        }
    }

    fn expand(text: &str) -> Option<Poly> {
        let f = Formula::parse(text).unwrap();
        Poly::from_graph(f.context(), f.f(), &xyz)
    }

    #[test]
    fn polynomials_expand_and_others_do_not() {
        let p = expand("(x + 2*y)^2 - z/4").unwrap();
        assert_eq!(p.degree(), [2, 2, 1]);
        assert!(expand("sin(x) + y").is_none());
        assert!(expand("x / y").is_none());
        assert!(expand("x^-2").is_none());
        // sqrt(2) is not an f64: its coefficient is an interval around it.
        let q = expand("sqrt(2)*x").unwrap();
        assert!(q.coeffs[1].inf() < q.coeffs[1].sup());
        assert!(q.coeffs[1].contains(std::f64::consts::SQRT_2));
    }

    #[test]
    fn the_bernstein_range_of_a_square_is_exact_on_a_side_of_its_minimum() {
        // x² on [1, 3]: Bernstein coefficients 1, 3, 9: the range [1, 9],
        // to the few ulps its products are widened by.
        let p = expand("x^2").unwrap();
        let one = Interval::point(1.0);
        let r = p.range_over([one, ZERO, ZERO], [Interval::point(2.0), one, one]);
        assert!(r.inf() <= 1.0 && r.sup() >= 9.0, "{r:?}");
        assert!(r.inf() > 1.0 - 1e-14 && r.sup() < 9.0 + 1e-13, "{r:?}");
    }

    #[test]
    fn the_bernstein_range_encloses_sampled_values() {
        let text = "(x^2+y^2+z^2-1.69)^2-3.1*(1-z-sqrt(2)*x)*(1-z+sqrt(2)*x)*(1+z+sqrt(2)*y)";
        let f = Formula::parse(text).unwrap();
        let p = Poly::from_graph(f.context(), f.f(), &xyz).unwrap();
        let lo = [-1.0, 0.5, -2.0];
        let w = [0.75, 1.5, 0.5];
        let r = p.range_over(lo.map(Interval::point), w.map(Interval::point));
        for k in 0..1000 {
            let t = [k % 10, k / 10 % 10, k / 100].map(|v| v as f64 / 9.0);
            let x = [0, 1, 2].map(|a| lo[a] + w[a] * t[a]);
            let v = f.context().eval(f.f(), &[x[0], x[1], x[2], 0.0, 0.0, 0.0]);
            assert!(
                r.inf() - 1e-9 <= v && v <= r.sup() + 1e-9,
                "{v} outside {r:?}"
            );
        }
    }
}
