//! Lipschitz bounds: L over a box and G over a ray segment, sound and automatic.
//!
//! * **L** bounds `max |∇f|` over an axis-aligned box: the Euclidean norm of
//!   the magnitudes of the interval gradient, rounded up. By the mean value
//!   theorem (with Clarke gradients where f has creases), `|f(p) − f(q)| ≤
//!   L·|p − q|` for all p, q in the box.
//! * **G** bounds `max |g′(t)|` over a segment `{o + t·d : t ∈ [t1, t2]}`,
//!   where `g(t) = d·∇f(o + t·d)`: the magnitude of the interval `g′`.
//!
//! Both may be infinite (`sqrt` at 0, `1/x` across 0, a crease of `abs`
//! crossed by the ray); a [`Bound`] then says which quantity is unbounded
//! instead of returning a finite number that would be wrong. A subdivision
//! depth tightens either bound: the maximum over `8^depth` sub-boxes or
//! `2^depth` sub-segments.
//!
//! Each piece's bound comes from an enclosure [`Method`]: the natural
//! interval extension of ∇f; the centred (mean-value) form
//! `∇f(c) + [H](X)·(X − c)` intersected with it, where the Hessian is
//! bounded and continuous; or, for polynomials, the Bernstein form of
//! `|∇f|²` (and of `g′(t)`, a polynomial in t). Each is sound, so the
//! default, [`Method::Best`], takes the smallest that applies.

use super::poly::{Expansion, Poly};
use crate::expr::tape::instr::Instr;
use crate::expr::{BatchEvaluator, Evaluator, Slopes, Tape};
use crate::expr::{BinaryOp, UnaryOp, Var};
use crate::formula::{Formula, Output};
use crate::types::geom::norm;
pub use crate::types::interval::euclidean_norm;
use crate::types::interval::norm_sup;
use crate::types::{Aabb, Affine, DecInterval, Decoration, Interval, Segment};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// The degree of the Taylor polynomials of [`Method::Taylor`]: on a piece
/// a fifth of a period wide, sin's remainder is below 10⁻⁵.
pub const TAYLOR_ORDER: usize = 6;

/// How a bound over one piece is enclosed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// The natural interval extension of the derivatives.
    Natural,
    /// The centred (mean-value) form of ∇f, intersected with the natural
    /// extension; the natural extension where the Hessian is unbounded or
    /// discontinuous. For G it is the natural extension.
    Centred,
    /// The Bernstein form of `|∇f|²` (for G, of `g′(t)`): polynomial
    /// formulas only.
    Bernstein,
    /// Taylor models: `sin cos exp sinh cosh` expanded to order
    /// [`TAYLOR_ORDER`] about each piece's centre with a Lagrange remainder,
    /// then the Bernstein form; formulas of those functions and `+ − ×`.
    Taylor,
    /// Reduced affine arithmetic ([`Affine`]): ∇f evaluated in affine
    /// forms over the x, y, z of the box (for G, g′ over t), intersected
    /// with the natural extension.
    Affine,
    /// The smallest of those that apply.
    Best,
}

impl Method {
    /// Every method, in the order tables show them.
    pub const ALL: [Method; 6] = [
        Method::Natural,
        Method::Centred,
        Method::Bernstein,
        Method::Taylor,
        Method::Affine,
        Method::Best,
    ];

    /// The method's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Natural => "natural",
            Method::Centred => "centred",
            Method::Bernstein => "bernstein",
            Method::Taylor => "taylor",
            Method::Affine => "affine",
            Method::Best => "best",
        }
    }

    /// The method called `name` on the command line.
    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name.trim())
    }

    /// Every method's name, for messages: "natural, centred, …, affine or best".
    pub fn names() -> String {
        let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
        let (last, rest) = names.split_last().expect("there are methods");
        format!("{} or {last}", rest.join(", "))
    }
}

/// A sound upper bound, or the reason there is none.
#[derive(Debug, Clone, PartialEq)]
pub struct Bound {
    /// The bound; `f64::INFINITY` when the quantity is unbounded.
    pub value: f64,
    /// Why the bound is infinite, or why it is vacuous (f undefined).
    pub note: Option<String>,
}

impl Bound {
    /// True when the bound is a finite number.
    pub fn is_finite(&self) -> bool {
        self.value.is_finite()
    }
}

/// A sampled lower estimate of a maximum, with the point where it occurs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sampled {
    /// The largest value found.
    pub value: f64,
    /// Where it was found.
    pub point: DVec3,
}

fn norm_up(m: [f64; 3]) -> f64 {
    norm_sup(m)
}

fn norm_down(m: [f64; 3]) -> f64 {
    euclidean_norm(m).inf()
}

const AXES: [&str; 3] = ["∂f/∂x", "∂f/∂y", "∂f/∂z"];

/// The most tape instructions a sampled estimate of L evaluates on its
/// grid (a few hundredths of a second; climbs from the best points follow).
const SAMPLE_WORK: f64 = 2e7;

/// Why an enclosure of a derivative is unbounded: where the derivative is
/// continuous on the closed region it is bounded there, and only f64's
/// range overflowed.
fn why_infinite(continuous: bool) -> &'static str {
    if continuous {
        "overflows f64 (it is finite, but its enclosure exceeds 1.8e308)"
    } else {
        "is unbounded"
    }
}

/// Computes L, G and interval values of one formula; holds its compiled tapes.
#[derive(Debug, Clone)]
pub struct Bounder {
    formula: Formula,
    f_and_grad: Tape,
    g_and_dg: Tape,
    hessian: Tape,
    /// `|∇f|²` expanded as a polynomial, when f is one (made on first use).
    grad_square: OnceLock<Option<Poly>>,
    /// Whether [`Method::Best`] uses affine forms (see [`affine_pays`]).
    affine_pays: bool,
}

/// Whether affine forms keep the correlations of a tape: every operation is
/// one they carry (`+ − × ÷`, powers, `sqrt`, `exp`, `ln`) or a selection
/// (`min`, `max`, `abs`, `choose`, `sign`). Through any other function
/// (`sin`, `atan`, …) a form falls back to an interval, and its cost buys
/// nothing: on the gyroid, affine forms in the bracket's best method took
/// 25 % longer for the same pieces. On the blend (`min` and `exp`) they cut
/// its 1 % bracket from 391 pieces to 135.
fn affine_pays(tape: &Tape) -> bool {
    tape.body().iter().all(|instr| match *instr {
        Instr::Unary { op, .. } => matches!(
            op,
            UnaryOp::Neg
                | UnaryOp::Sqrt
                | UnaryOp::Exp
                | UnaryOp::Ln
                | UnaryOp::Abs
                | UnaryOp::Sign
                | UnaryOp::Dirac
        ),
        Instr::Binary { op, .. } => !matches!(op, BinaryOp::Atan2 | BinaryOp::Pow),
        Instr::PowI { .. } | Instr::Choose { .. } => true,
    })
}

impl Bounder {
    /// Compiles the tapes that bounds need.
    pub fn new(formula: &Formula) -> Bounder {
        let f_and_grad = formula.tape(&[Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz]);
        let g_and_dg = formula.tape(&[Output::F, Output::G, Output::Dg]);
        Bounder {
            formula: formula.clone(),
            affine_pays: affine_pays(&f_and_grad) && affine_pays(&g_and_dg),
            f_and_grad,
            g_and_dg,
            hessian: formula.tape(&Output::HESSIAN),
            grad_square: OnceLock::new(),
        }
    }

    /// The two halves of `b` across the axis where |∇f| may vary most: the
    /// smear rule, each side's width times a bound of |∇f|'s sensitivity to
    /// that coordinate, |∂|∇f|/∂xᵢ| ≤ |H·eᵢ| (the Hessian's column, over
    /// the box). A coordinate |∇f| does not depend on has a smear of 0 and
    /// is not split while another has more. Where the Hessian is unbounded
    /// or undefined, or every smear is 0, the longest side is split.
    pub fn split(&self, b: &Aabb) -> [Aabb; 2] {
        b.bisect_along(self.split_axis(b))
    }

    /// The axis [`Bounder::split`] splits `b` across (0, 1, 2 for x, y, z).
    pub fn split_axis(&self, b: &Aabb) -> usize {
        let [x, y, z] = b.intervals();
        let zero = Interval::ZERO;
        let h = Evaluator::<Interval>::new(&self.hessian)
            .eval(&[x, y, z, zero, zero, zero])
            .to_vec();
        let [xx, yy, zz, xy, xz, yz] = [0, 1, 2, 3, 4, 5].map(|k| h[k]);
        let columns = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]];
        let [_, gx, gy, gz] = self.f_and_gradient(b);
        let grad = [gx, gy, gz];
        // |∇f| at least this over the box (0 when ∇f may vanish).
        let least = norm_down(grad.map(|g| if g.is_empty() { 0.0 } else { g.mig() }));
        let size = b.hi - b.lo;
        let mut smear = [0.0; 3];
        for (axis, column) in columns.iter().enumerate() {
            // ∂|∇f|/∂xᵢ = (H·eᵢ)·∇f / |∇f|, or at most |H·eᵢ| where |∇f|
            // may vanish.
            let sensitivity = if least > 0.0 {
                let dot = (0..3).fold(Interval::ZERO, |acc, k| acc + column[k] * grad[k]);
                dot.mag() / least
            } else {
                norm_up(column.map(|v| if v.is_empty() { 0.0 } else { v.mag() }))
            };
            smear[axis] = size[axis] * sensitivity;
        }
        if smear.iter().any(|s| !s.is_finite()) || smear.iter().all(|&s| s == 0.0) {
            smear = size.to_array();
        }
        (1..3).fold(0, |best, k| if smear[k] > smear[best] { k } else { best })
    }

    /// `|∇f|²` as a polynomial in x, y, z, when f is a polynomial small
    /// enough to expand.
    fn grad_square(&self) -> Option<&Poly> {
        self.grad_square
            .get_or_init(|| {
                let grads =
                    Poly::expand(self.formula.context(), &self.formula.gradient(), &xyz, None)?;
                sum_of_squares(&grads)
            })
            .as_ref()
    }

    /// Whether the Bernstein method applies: f is a polynomial (after
    /// constant folding) small enough to expand.
    pub fn is_polynomial(&self) -> bool {
        self.grad_square().is_some()
    }

    /// Intervals of f and its three partials over a box.
    pub fn f_and_gradient(&self, b: &Aabb) -> [Interval; 4] {
        let [x, y, z] = b.intervals();
        let zero = Interval::point(0.0);
        let v = Evaluator::<Interval>::new(&self.f_and_grad)
            .eval(&[x, y, z, zero, zero, zero])
            .to_vec();
        [v[0], v[1], v[2], v[3]]
    }

    /// Intervals of f, g and g′ over a segment.
    pub fn f_g_dg(&self, s: &Segment) -> [Interval; 3] {
        let v = Evaluator::<Interval>::new(&self.g_and_dg)
            .eval(&s.inputs())
            .to_vec();
        [v[0], v[1], v[2]]
    }

    /// L over one box by `method`, without subdivision.
    pub fn lipschitz_piece_by(&self, b: &Aabb, method: Method) -> Bound {
        self.tighten(b, self.lipschitz_piece(b), method)
    }

    /// The smaller of `natural`, L over `b` by the natural extension, and
    /// what `method` gives there.
    pub fn tighten(&self, b: &Aabb, natural: Bound, method: Method) -> Bound {
        self.tighten_with(b, natural, method, true)
    }

    /// [`Bounder::tighten`], where [`Method::Best`] leaves the Taylor models
    /// out unless `taylor`: a piece costs microseconds to split and a Taylor
    /// model milliseconds, so a search that splits is better off without.
    pub(super) fn tighten_with(
        &self,
        b: &Aabb,
        natural: Bound,
        method: Method,
        taylor: bool,
    ) -> Bound {
        if !natural.value.is_finite() || natural.value == 0.0 {
            return natural;
        }
        let other = match method {
            Method::Natural => None,
            Method::Centred => self.centred_lipschitz(b),
            Method::Bernstein => self.bernstein_lipschitz(b),
            Method::Taylor => self.taylor_lipschitz(b),
            Method::Affine => self.affine_lipschitz(b),
            Method::Best => {
                // For a polynomial the Taylor models are its Bernstein form.
                let expanded = if self.is_polynomial() {
                    self.bernstein_lipschitz(b)
                } else if taylor {
                    self.taylor_lipschitz(b)
                } else {
                    None
                };
                let affine = self.affine_pays.then(|| self.affine_lipschitz(b)).flatten();
                [self.centred_lipschitz(b), expanded, affine]
                    .into_iter()
                    .flatten()
                    .reduce(f64::min)
            }
        };
        match other {
            Some(v) if v < natural.value => Bound {
                value: v,
                note: None,
            },
            _ => natural,
        }
    }

    /// L over one box from the centred form of ∇f intersected with the
    /// natural one; `None` where the Hessian is unbounded, undefined or
    /// may jump somewhere in the box (the mean value theorem needs ∇f
    /// continuously differentiable there).
    fn centred_lipschitz(&self, b: &Aabb) -> Option<f64> {
        let [x, y, z] = b.intervals();
        let zero = Interval::ZERO;
        let inputs = [x, y, z, zero, zero, zero].map(DecInterval::defined);
        // The mean value theorem needs ∇f itself continuous on the box, not
        // only a continuous Hessian: a jump of ∇f (a `choose` across its
        // switch, `atan2` across its cut) can leave a Hessian of 0.
        let continuous = |v: &DecInterval| {
            v.decoration() == Decoration::Dac
                && !v.interval().is_empty()
                && v.interval().is_bounded()
        };
        let grad = Evaluator::<DecInterval>::new(&self.f_and_grad)
            .eval(&inputs)
            .to_vec();
        if !grad.iter().all(continuous) {
            return None;
        }
        let h = Evaluator::<DecInterval>::new(&self.hessian)
            .eval(&inputs)
            .to_vec();
        if !h.iter().all(continuous) {
            return None;
        }
        let [xx, yy, zz, xy, xz, yz] = [0, 1, 2, 3, 4, 5].map(|k| h[k].interval());
        let rows = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]];
        let c = b.center();
        let [_, cx, cy, cz] = self.f_and_gradient(&Aabb { lo: c, hi: c });
        let [nx, ny, nz] = [1, 2, 3].map(|k| grad[k].interval());
        let offset = [
            x - Interval::point(c.x),
            y - Interval::point(c.y),
            z - Interval::point(c.z),
        ];
        let mut mags = [0.0; 3];
        for (i, (gc, natural)) in [cx, cy, cz].into_iter().zip([nx, ny, nz]).enumerate() {
            if gc.is_empty() || !gc.is_bounded() {
                return None;
            }
            let centred = (0..3).fold(gc, |acc, j| acc + rows[i][j] * offset[j]);
            let both = centred.intersection(natural);
            if both.is_empty() || !both.is_bounded() {
                return None;
            }
            mags[i] = both.mag();
        }
        Some(norm_up(mags))
    }

    /// L over one box from ∇f in reduced affine forms, each partial
    /// intersected with its natural extension; `None` where one is
    /// unbounded or empty.
    fn affine_lipschitz(&self, b: &Aabb) -> Option<f64> {
        let [x, y, z] = b.intervals();
        let zero = Affine::constant(0.0);
        let inputs = [
            Affine::input(x, 0),
            Affine::input(y, 1),
            Affine::input(z, 2),
            zero,
            zero,
            zero,
        ];
        let forms = Evaluator::<Affine>::new(&self.f_and_grad)
            .eval(&inputs)
            .to_vec();
        let [_, nx, ny, nz] = self.f_and_gradient(b);
        let mut mags = [0.0; 3];
        for (k, natural) in [nx, ny, nz].into_iter().enumerate() {
            let both = forms[1 + k].range().intersection(natural);
            if both.is_empty() || !both.is_bounded() {
                return None;
            }
            mags[k] = both.mag();
        }
        Some(norm_up(mags))
    }

    /// G over one piece of a ray from g′ in reduced affine forms over t
    /// (x = o + t·d, one noise symbol), intersected with the natural
    /// extension; `None` where unbounded or empty.
    fn affine_dg(&self, s: &Segment) -> Option<f64> {
        let t = Affine::input(Interval::new(s.t0, s.t1), 0);
        let (o, d) = (s.origin, s.direction);
        let x = |k: usize| Affine::constant(o[k]) + t * Affine::constant(d[k]);
        let inputs = [
            x(0),
            x(1),
            x(2),
            Affine::constant(d.x),
            Affine::constant(d.y),
            Affine::constant(d.z),
        ];
        let forms = Evaluator::<Affine>::new(&self.g_and_dg)
            .eval(&inputs)
            .to_vec();
        let [_, _, natural] = self.f_g_dg(s);
        let both = forms[2].range().intersection(natural);
        (!both.is_empty() && both.is_bounded()).then(|| both.mag())
    }

    /// L over one box from the Bernstein form of `|∇f|²`; `None` when f is
    /// not a polynomial.
    fn bernstein_lipschitz(&self, b: &Aabb) -> Option<f64> {
        let (lo, w) = frame(b);
        norm_from_square(self.grad_square()?.range_over(lo, w))
    }

    /// Whether the Taylor method applies over `b`: f is built from `+ − ×`,
    /// integer powers, constants and `sin cos exp sinh cosh` (and its
    /// models stay within their limits there).
    pub fn expands(&self, b: &Aabb) -> bool {
        self.taylor_lipschitz(b).is_some()
    }

    /// L over one box from Taylor models of ∇f, squared and summed, bounded
    /// by the Bernstein form; `None` when f holds a function they do not
    /// expand.
    fn taylor_lipschitz(&self, b: &Aabb) -> Option<f64> {
        let (lo, w) = frame(b);
        let e = Expansion {
            lo,
            w,
            order: TAYLOR_ORDER,
        };
        let grads = Poly::expand(
            self.formula.context(),
            &self.formula.gradient(),
            &xyz,
            Some(&e),
        )?;
        norm_from_square(sum_of_squares(&grads)?.range_over(lo, w))
    }

    /// A Lipschitz constant of f over `b` from the slopes carried through
    /// its operations ([`Slopes`]), where they are finite: they bound how
    /// fast f changes where its interval gradient does not (the centre of a
    /// circle, where ∇f is undefined though f is 1-Lipschitz), and so
    /// `|∇f|` wherever ∇f exists.
    fn slopes_lipschitz(&self, b: &Aabb) -> Option<f64> {
        let s = Evaluator::<Slopes>::new(&self.f_and_grad).eval(&Slopes::inputs(b))[0];
        let l = s.lipschitz();
        (s.defined && l.is_finite()).then_some(l)
    }

    /// L over one box, without subdivision.
    fn lipschitz_piece(&self, b: &Aabb) -> Bound {
        let [f, gx, gy, gz] = self.f_and_gradient(b);
        let grad = [gx, gy, gz];
        if f.is_empty() || grad.iter().all(|g| g.is_empty()) {
            // (The bound is still that of the derivatives' formulas, which
            // may be defined where f is not.)
            let mags = grad.map(|g| if g.is_empty() { 0.0 } else { g.mag() });
            return Bound {
                value: norm_up(mags),
                note: Some("f is undefined everywhere on this box".into()),
            };
        }
        for (axis, (g, name)) in grad.iter().zip(AXES).enumerate() {
            if !g.is_empty() && !g.is_bounded() {
                let why = why_infinite(self.partial_is_continuous(b, axis));
                if let Some(value) = self.slopes_lipschitz(b) {
                    return Bound {
                        value,
                        note: Some(format!(
                            "{name} {why} on this box; L bounds f's slopes there"
                        )),
                    };
                }
                return Bound {
                    value: f64::INFINITY,
                    note: Some(format!("{name} {why} on this box")),
                };
            }
        }
        let mags = grad.map(|g| if g.is_empty() { 0.0 } else { g.mag() });
        let value = norm_up(mags);
        Bound {
            value,
            note: value
                .is_infinite()
                .then(|| "|∇f| overflows f64 on this box (each partial is finite)".into()),
        }
    }

    /// Whether the partial along `axis` is defined and continuous on the
    /// whole box: then it is bounded there (a continuous function on a
    /// closed box is), and an unbounded enclosure of it is f64's overflow.
    fn partial_is_continuous(&self, b: &Aabb, axis: usize) -> bool {
        let [x, y, z] = b.intervals();
        let zero = Interval::point(0.0);
        let inputs = [x, y, z, zero, zero, zero].map(DecInterval::defined);
        let v = Evaluator::<DecInterval>::new(&self.f_and_grad).eval(&inputs)[1 + axis];
        v.decoration() == Decoration::Dac
    }

    /// A sound upper bound of `max |∇f|` over the box, as the maximum over
    /// `8^depth` sub-boxes.
    ///
    /// ```
    /// use lgc::{bounds::Bounder, Aabb, Formula};
    /// use glam::DVec3;
    /// let f = Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
    /// let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    /// let l = Bounder::new(&f).lipschitz_bound(&b, 0);
    /// // |∇f| = 2|p| ≤ 2√3 on the box; the interval bound is exactly that.
    /// assert!(l.value >= 2.0 * 3f64.sqrt() && l.value < 2.0 * 3f64.sqrt() + 1e-12);
    /// ```
    pub fn lipschitz_bound(&self, b: &Aabb, depth: u32) -> Bound {
        self.lipschitz_bound_by(b, depth, Method::Best)
    }

    /// [`Bounder::lipschitz_bound`] with each piece enclosed by `method`.
    pub fn lipschitz_bound_by(&self, b: &Aabb, depth: u32, method: Method) -> Bound {
        let pieces = b.split(depth);
        let mut natural: Vec<(Bound, &Aabb)> = pieces
            .iter()
            .map(|piece| (self.lipschitz_piece(piece), piece))
            .collect();
        if method == Method::Natural || natural.iter().any(|(l, _)| !l.is_finite()) {
            return max_bound(natural.into_iter().map(|(l, _)| l));
        }
        // Every method's bound is at most the natural one, so a piece whose
        // natural bound is below the largest tightened bound so far cannot
        // raise the maximum: the costly methods run on the loosest pieces
        // only, and the result is the same as running them everywhere.
        natural.sort_by(|a, b| b.0.value.total_cmp(&a.0.value));
        // Chunks in parallel, loosest first; bounds are non-negative, so
        // their bits order as they do.
        let largest = AtomicU64::new(0f64.to_bits());
        let mut tightened = Vec::with_capacity(natural.len());
        for chunk in natural.chunks(64) {
            let done: Vec<Bound> = chunk
                .par_iter()
                .map(|(l, piece)| {
                    if l.value <= f64::from_bits(largest.load(Ordering::Relaxed)) {
                        return l.clone();
                    }
                    let t = self.tighten(piece, l.clone(), method);
                    largest.fetch_max(t.value.to_bits(), Ordering::Relaxed);
                    t
                })
                .collect();
            tightened.extend(done);
        }
        max_bound(tightened.into_iter())
    }

    /// G over one segment, without subdivision.
    fn grad_lipschitz_piece(&self, s: &Segment) -> Bound {
        let [_, _, dg] = self.f_g_dg(s);
        if dg.is_empty() {
            return Bound {
                value: 0.0,
                note: Some("f is undefined everywhere on this segment".into()),
            };
        }
        if !dg.is_bounded() {
            let inputs = s.inputs().map(DecInterval::defined);
            let continuous = Evaluator::<DecInterval>::new(&self.g_and_dg).eval(&inputs)[2]
                .decoration()
                == Decoration::Dac;
            let why = why_infinite(continuous);
            return Bound {
                value: f64::INFINITY,
                note: Some(format!(
                    "g′ (the rate of change of d·∇f) {why} on this segment"
                )),
            };
        }
        Bound {
            value: dg.mag(),
            note: None,
        }
    }

    /// A sound upper bound of `max |g′(t)|` over the segment, as the maximum
    /// over `2^depth` pieces.
    pub fn grad_lipschitz_bound(&self, s: &Segment, depth: u32) -> Bound {
        self.grad_lipschitz_bound_by(s, depth, Method::Best)
    }

    /// [`Bounder::grad_lipschitz_bound`] with each piece enclosed by
    /// `method` (the centred form is the natural one here).
    pub fn grad_lipschitz_bound_by(&self, s: &Segment, depth: u32, method: Method) -> Bound {
        let exact = self.exact_dg(s, method);
        max_bound(
            s.split(depth)
                .iter()
                .map(|piece| self.grad_piece_by(piece, method, exact.as_ref(), true)),
        )
    }

    /// `g′(t)` of a polynomial f on `s`'s ray, when `method` would use it:
    /// one expansion serves every piece of the ray.
    pub(super) fn exact_dg(&self, s: &Segment, method: Method) -> Option<Poly> {
        let wanted = matches!(method, Method::Bernstein | Method::Best | Method::Taylor);
        (wanted && self.is_polynomial())
            .then(|| self.dg_polynomial(s, None))
            .flatten()
    }

    /// G over one piece of a ray by `method`; `exact` is [`Bounder::exact_dg`]
    /// for the ray.
    /// Under [`Method::Best`], Taylor models are used only if `taylor` (see
    /// [`Bounder::tighten_with`]).
    pub(super) fn grad_piece_by(
        &self,
        piece: &Segment,
        method: Method,
        exact: Option<&Poly>,
        taylor: bool,
    ) -> Bound {
        let natural = self.grad_lipschitz_piece(piece);
        let taylor = !self.is_polynomial()
            && (method == Method::Taylor || (method == Method::Best && taylor));
        let t0 = Interval::point(piece.t0);
        let lo = [t0, Interval::ZERO, Interval::ZERO];
        let w = [
            Interval::point(piece.t1) - t0,
            Interval::ZERO,
            Interval::ZERO,
        ];
        let model = if exact.is_none() && taylor && natural.is_finite() {
            let e = Expansion {
                lo,
                w,
                order: TAYLOR_ORDER,
            };
            self.dg_polynomial(piece, Some(&e))
        } else {
            None
        };
        let expanded = exact.or(model.as_ref()).and_then(|p| {
            let range = p.range_over(lo, w);
            (!range.is_empty() && range.is_bounded()).then(|| range.mag())
        });
        let affine = natural.is_finite()
            && (method == Method::Affine || (method == Method::Best && self.affine_pays));
        let affine = if affine { self.affine_dg(piece) } else { None };
        match [expanded, affine].into_iter().flatten().reduce(f64::min) {
            Some(v) if v < natural.value => Bound {
                value: v,
                note: None,
            },
            _ => natural,
        }
    }

    /// `g′(t)` on the segment's ray as a polynomial in t (x = o + t·d
    /// exactly, d constant): exact for a polynomial f, a Taylor model over
    /// `expansion`'s range of t otherwise.
    fn dg_polynomial(&self, s: &Segment, expansion: Option<&Expansion>) -> Option<Poly> {
        let (o, d) = (s.origin, s.direction);
        let map = |v: Var| {
            let k = v.index();
            match v {
                Var::X | Var::Y | Var::Z => Some(Poly::linear(
                    0,
                    Interval::point(o[k]),
                    Interval::point(d[k]),
                )),
                _ => Some(Poly::constant(Interval::point(d[k - 3]))),
            }
        };
        Poly::expand(
            self.formula.context(),
            &[self.formula.dg()],
            &map,
            expansion,
        )
        .map(|mut v| v.remove(0))
    }

    /// A certified lower bound of `|∇f(p)|` (the true value is at least this).
    pub fn gradient_norm_at_least(&self, p: DVec3) -> f64 {
        let b = Aabb { lo: p, hi: p };
        let [_, gx, gy, gz] = self.f_and_gradient(&b);
        if gx.is_empty() || gy.is_empty() || gz.is_empty() {
            return 0.0;
        }
        norm_down([gx.mig(), gy.mig(), gz.mig()])
    }

    /// A certified lower bound of `|g′(t)|` at one parameter.
    pub fn dg_at_least(&self, s: &Segment, t: f64) -> f64 {
        let [_, _, dg] = self.f_g_dg(&Segment { t0: t, t1: t, ..*s });
        if dg.is_empty() {
            0.0
        } else {
            dg.mig()
        }
    }

    /// A sampled lower estimate of `max |∇f|` over the box: a grid of
    /// `n³` points, then a pattern search from the best few.
    pub fn sample_gradient(&self, b: &Aabb, n: usize) -> Sampled {
        // n³ points of a long tape would take minutes: the grid is made
        // coarser so that it costs at most SAMPLE_WORK instructions.
        let len = self.f_and_grad.body().len().max(1) as f64;
        let affordable = (SAMPLE_WORK / len).cbrt() as usize;
        let n = n.min(affordable).max(2);
        let mut pts = Vec::with_capacity(n * n * n);
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let t = DVec3::new(i as f64, j as f64, k as f64) / (n - 1) as f64;
                    // lo + 1·(hi − lo) can round past hi: keep samples inside.
                    pts.push((b.lo + t * (b.hi - b.lo)).clamp(b.lo, b.hi));
                }
            }
        }
        let norms = self.gradient_norms(&pts);
        let mut order: Vec<usize> = (0..pts.len()).filter(|&i| norms[i].is_finite()).collect();
        order.sort_by(|&a, &c| norms[c].total_cmp(&norms[a]));
        let mut best = Sampled {
            value: 0.0,
            point: b.center(),
        };
        let step = (b.hi - b.lo) / (n - 1) as f64;
        // Climbs go point by point: a batch evaluator would run a whole
        // chunk of lanes for each.
        let mut point = Evaluator::<f64>::new(&self.f_and_grad);
        for &i in order.iter().take(8) {
            let found = self.climb(pts[i], norms[i], step, |p| {
                let q = p.clamp(b.lo, b.hi);
                let v = point.eval(&[q.x, q.y, q.z, 0.0, 0.0, 0.0]);
                (q, norm(DVec3::new(v[1], v[2], v[3])))
            });
            if found.value > best.value {
                best = found;
            }
        }
        best
    }

    /// A sampled lower estimate of `max |g′(t)|` over the segment; the point
    /// reported is `o + t·d` at the best `t`.
    pub fn sample_dg(&self, s: &Segment, n: usize) -> (Sampled, f64) {
        let n = n.max(2);
        let ts: Vec<f64> = (0..n)
            .map(|i| s.t0 + (s.t1 - s.t0) * i as f64 / (n - 1) as f64)
            .collect();
        let vals = self.dg_values(s, &ts);
        let mut best = (
            Sampled {
                value: 0.0,
                point: s.at(s.t0),
            },
            s.t0,
        );
        let mut order: Vec<usize> = (0..n).filter(|&i| vals[i].is_finite()).collect();
        order.sort_by(|&a, &c| vals[c].total_cmp(&vals[a]));
        let step = (s.t1 - s.t0) / (n - 1) as f64;
        for &i in order.iter().take(4) {
            let found = self.climb(
                DVec3::new(ts[i], 0.0, 0.0),
                vals[i],
                DVec3::new(step, 0.0, 0.0),
                |p| {
                    let t = p.x.clamp(s.t0, s.t1);
                    (DVec3::new(t, 0.0, 0.0), self.dg_values(s, &[t])[0])
                },
            );
            if found.value > best.0.value {
                best = (
                    Sampled {
                        value: found.value,
                        point: s.at(found.point.x),
                    },
                    found.point.x,
                );
            }
        }
        best
    }

    /// Pattern search for a larger value of `eval` around `start`.
    fn climb(
        &self,
        start: DVec3,
        value: f64,
        step: DVec3,
        mut eval: impl FnMut(DVec3) -> (DVec3, f64),
    ) -> Sampled {
        let mut p = start;
        let mut v = value;
        let mut h = step;
        for _ in 0..60 {
            let mut moved = false;
            for axis in 0..3 {
                if h[axis] == 0.0 {
                    continue;
                }
                for sign in [1.0, -1.0] {
                    let mut q = p;
                    q[axis] += sign * h[axis];
                    let (q, w) = eval(q);
                    if w.is_finite() && w > v {
                        p = q;
                        v = w;
                        moved = true;
                    }
                }
            }
            if !moved {
                h *= 0.5;
            }
        }
        Sampled { value: v, point: p }
    }

    fn gradient_norms(&self, pts: &[DVec3]) -> Vec<f64> {
        let xs: Vec<f64> = pts.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = pts.iter().map(|p| p.y).collect();
        let zs: Vec<f64> = pts.iter().map(|p| p.z).collect();
        let n = pts.len();
        let mut out = vec![vec![0.0; n]; 4];
        {
            let mut slices: Vec<&mut [f64]> = out.iter_mut().map(|v| v.as_mut_slice()).collect();
            BatchEvaluator::new(&self.f_and_grad).eval(&[&xs, &ys, &zs], &mut slices);
        }
        (0..n)
            .map(|i| norm(DVec3::new(out[1][i], out[2][i], out[3][i])))
            .collect()
    }

    fn dg_values(&self, s: &Segment, ts: &[f64]) -> Vec<f64> {
        let n = ts.len();
        let coord = |i: usize| {
            ts.iter()
                .map(|t| s.origin[i] + t * s.direction[i])
                .collect::<Vec<f64>>()
        };
        let (xs, ys, zs) = (coord(0), coord(1), coord(2));
        let d = |i: usize| vec![s.direction[i]; n];
        let (dx, dy, dz) = (d(0), d(1), d(2));
        let mut out = vec![vec![0.0; n]; 3];
        {
            let mut slices: Vec<&mut [f64]> = out.iter_mut().map(|v| v.as_mut_slice()).collect();
            BatchEvaluator::new(&self.g_and_dg).eval(&[&xs, &ys, &zs, &dx, &dy, &dz], &mut slices);
        }
        out[2].iter().map(|v| v.abs()).collect()
    }
}

/// A box as the polynomial methods take it: its low corner and widths,
/// enclosed.
fn frame(b: &Aabb) -> ([Interval; 3], [Interval; 3]) {
    let lo = [0, 1, 2].map(|a| Interval::point(b.lo[a]));
    let w = [0, 1, 2].map(|a| Interval::point(b.hi[a]) - lo[a]);
    (lo, w)
}

/// `Σ pᵢ²`, within the expansion limits.
fn sum_of_squares(polys: &[Poly]) -> Option<Poly> {
    let mut work = 0;
    let mut sum = Poly::constant(Interval::ZERO);
    for p in polys {
        sum = sum.add(&p.mul(p, &mut work)?)?;
    }
    Some(sum)
}

/// A bound of `|v|` from an enclosure of `|v|²` (`None` if unbounded).
fn norm_from_square(range: Interval) -> Option<f64> {
    if range.is_empty() || !range.is_bounded() {
        return None;
    }
    Some(Interval::new(0.0, range.sup().max(0.0)).sqrt().sup())
}

/// x, y and z as polynomials in themselves.
fn xyz(v: Var) -> Option<Poly> {
    let (zero, one) = (Interval::ZERO, Interval::point(1.0));
    match v {
        Var::X => Some(Poly::linear(0, zero, one)),
        Var::Y => Some(Poly::linear(1, zero, one)),
        Var::Z => Some(Poly::linear(2, zero, one)),
        _ => None,
    }
}

/// The largest of several bounds; the first infinite one carries its reason.
fn max_bound(bounds: impl Iterator<Item = Bound>) -> Bound {
    let mut best = Bound {
        value: 0.0,
        note: None,
    };
    let mut vacuous = None;
    for b in bounds {
        if b.value.is_infinite() {
            return b;
        }
        if b.note.is_some() && b.value == 0.0 {
            vacuous = b.note.clone();
            continue;
        }
        if b.value > best.value {
            best = b;
        }
    }
    if best.value == 0.0 && best.note.is_none() {
        best.note = vacuous;
    }
    best
}
