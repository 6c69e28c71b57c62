//! A leaf's bounds as one ray sees them, and the tests and brackets built on them.

use super::piece::*;
use crate::ray::answer::half_placement;
use crate::ray::octree::{Leaf, SplitLeaf};
use crate::ray::seam::{self, Parabola, Seam};
use crate::ray::taylor::Expansion;
use crate::types::rounding::up_test as up;
use crate::types::rounding::{ROUNDINGS_3, ROUNDINGS_7};

/// The bounds of one leaf as a ray sees them.
#[derive(Clone, Copy)]
pub(super) struct Bounds {
    /// `L·|d|`, the Lipschitz constant of F in t; `+∞` if unknown.
    pub(super) lt: f64,
    /// `G`, a bound of |g′| on the leaf's part of the ray.
    pub(super) g: f64,
    /// Bounds of g′ itself (signed) on the leaf's part of the ray.
    pub(super) curvature: (f64, f64),
    /// Error bounds of the computed f and g at any computed point of the ray
    /// in the leaf: their rounding, and how far the point may have moved;
    /// `+∞` where the f64 tests may not run.
    pub(super) f_err: f64,
    pub(super) g_err: f64,
    /// Whether the first-order (L) test may run: f defined on the whole leaf,
    /// L and f's error finite. Creases of min/max/abs allow it.
    pub(super) first_order: bool,
    /// Whether the second-order and G-tests may run too: G and g's error
    /// finite as well.
    pub(super) second_order: bool,
}

impl Bounds {
    /// No bound known: every decision by intervals.
    pub(super) const UNKNOWN: Bounds = Bounds {
        lt: f64::INFINITY,
        g: f64::INFINITY,
        curvature: (f64::NEG_INFINITY, f64::INFINITY),
        f_err: f64::INFINITY,
        g_err: f64::INFINITY,
        first_order: false,
        second_order: false,
    };

    #[inline(always)]
    pub(super) fn new(leaf: &Leaf, ray: &Ray) -> Bounds {
        Self::first_order_of(leaf, ray).with_second_order(leaf, ray)
    }

    /// The bounds without G and g's error (as if unknown): all the L-test
    /// reads, which excludes most leaves a ray crosses.
    #[inline]
    pub(super) fn first_order_of(leaf: &Leaf, ray: &Ray) -> Bounds {
        let lt = up(leaf.lipschitz * ray.speed);
        // |f(p̂) − f(p)| ≤ L·|p̂ − p|.
        let f_err = up(leaf.f_error + leaf.lipschitz * ray.moved);
        let first_order = ray.fast && leaf.continuous && lt.is_finite() && f_err.is_finite();
        Bounds {
            lt,
            f_err: if first_order { f_err } else { f64::INFINITY },
            first_order,
            ..Bounds::UNKNOWN
        }
    }

    /// `self` (from [`Bounds::first_order_of`] for the same leaf and ray)
    /// with G and g's error.
    #[inline(always)]
    pub(super) fn with_second_order(self, leaf: &Leaf, ray: &Ray) -> Bounds {
        // G is never read where intervals decide (creased leaves among them).
        if !self.first_order || leaf.needs_intervals {
            return self;
        }
        // A Hessian enclosed by zeros (a plane's): g is constant, G is 0
        // (exactly: a tiny G would make the tests' products subnormal).
        let (curvature, g) = if leaf.hessian_norm == 0.0 {
            ((0.0, 0.0), 0.0)
        } else {
            let (lo, hi) = leaf.curvature(ray.d);
            ((lo, hi), up(lo.abs().max(hi.abs())))
        };
        // |g(p̂) − g(p)| ≤ |d|·‖H‖·|p̂ − p|.
        let g_err = up(leaf.g_error * ray.d_scale + leaf.hessian_norm * ray.speed * ray.moved);
        let second_order = g.is_finite() && g_err.is_finite();
        Bounds {
            g,
            curvature,
            g_err: if second_order { g_err } else { f64::INFINITY },
            second_order,
            ..self
        }
    }
}

impl Bounds {
    /// Whether F is quadratic along the ray, to a millionth: the bounds of
    /// F″ meet (a quadric's or a plane's), so Taylor's parabolas nearly do.
    #[inline(always)]
    pub(super) fn quadratic(&self) -> bool {
        let (lo, hi) = self.curvature;
        hi - lo <= 1e-6 * self.g
    }

    /// Whether F, with value `f` and slope `g` at the middle of a piece
    /// whose every t is within `hh` of it, has no root on the piece: the
    /// L-test, or the second-order test where G is known.
    #[inline]
    pub(super) fn excludes(&self, (f, g): Values, hh: f64) -> bool {
        if !self.first_order || f.is_nan() {
            return false;
        }
        let f_low = f.abs() - self.f_err;
        f_low > up(self.lt * hh)
            || (self.second_order
                && !g.is_nan()
                && f_low > up((g.abs() + self.g_err) * hh + 0.5 * self.g * hh * hh))
    }
}

/// What [`Tracer::side_of`] proves of a piece of a ray in a split leaf.
pub(super) enum Side {
    /// F is side `k` (1 or 2) on the whole piece; its values at the middle.
    On(u8, Values),
    /// A side alone proves F has no root on the piece.
    Clear,
    /// Neither: both sides' values at the middle, where they have
    /// first-order bounds.
    Undecided(Option<[Values; 2]>),
}

/// Where a split leaf's sides' difference C keeps its sign around the middle
/// m of `piece` (Taylor's bounds of C from both sides' values at m, their
/// error bounds and their bounds of F″), the piece cut in three: before that
/// range (if any), the range itself with the side F is there, and after it
/// (if any). `None` where C's sign at m is not certified, a side has no
/// second-order bounds, or the range is under a quarter of the piece.
#[inline(always)]
pub(super) fn crease_free(
    split: &SplitLeaf,
    values: [Values; 2],
    bounds: [Bounds; 2],
    piece: &Piece,
    m: f64,
) -> Option<(Option<Piece>, Piece, Option<Piece>)> {
    let [(f1, g1), (f2, g2)] = values;
    let [b1, b2] = bounds;
    if !(b1.second_order && b2.second_order) {
        return None;
    }
    const E: f64 = ROUNDINGS_7;
    let (c, slope) = (f1 - f2, g1 - g2);
    // The subtractions' roundings on top of both sides' error bounds.
    let c_err = up(b1.f_err + b2.f_err) + E * c.abs();
    let slope_err = up(b1.g_err + b2.g_err) + E * slope.abs();
    let ((lo1, hi1), (lo2, hi2)) = (b1.curvature, b2.curvature);
    let bend = (
        (lo1 - hi2) - E * (lo1.abs() + hi2.abs()),
        (hi1 - lo2) + E * (hi1.abs() + lo2.abs()),
    );
    let e = Expansion::new(c, c_err, slope, slope_err, bend)?;
    let Piece { a, b, .. } = *piece;
    let (lo, hi) = e.clear_range(m);
    let (lo, hi) = (lo.max(a), hi.min(b));
    if hi - lo < 0.25 * (b - a) || (hi - lo).is_nan() {
        return None;
    }
    // C > 0 where the first side is the larger.
    let side = if (e.sign > 0.0) == split.larger { 1 } else { 2 };
    let undecided = |a: f64, b: f64| Piece {
        a,
        b,
        fa: f64::NAN,
        fb: f64::NAN,
        sa: 0,
        sb: 0,
        side: 0,
        lip: f64::INFINITY,
    };
    let near = (lo > a).then(|| Piece {
        fa: piece.fa,
        sa: piece.sa,
        ..undecided(a, lo)
    });
    let far = (hi < b).then(|| Piece {
        fb: piece.fb,
        sb: piece.sb,
        ..undecided(hi, b)
    });
    // Certified signs at the piece's ends hold for F whatever formula
    // computes it; other values were the leaf's own.
    let middle = Piece {
        side,
        fa: if lo == a && piece.sa != 0 {
            piece.fa
        } else {
            f64::NAN
        },
        sa: if lo == a { piece.sa } else { 0 },
        fb: if hi == b && piece.sb != 0 {
            piece.fb
        } else {
            f64::NAN
        },
        sb: if hi == b { piece.sb } else { 0 },
        ..undecided(lo, hi)
    };
    Some((near, middle, far))
}

/// The closed-form answer on `piece` of a split leaf ([`seam::first_root`])
/// from both sides' values at its middle m, where both sides are quadratic
/// along the ray (F″ known to a millionth, as for Taylor's parabolas) and
/// have second-order bounds; `None` where they are not or the proof fails.
/// A hit's bracket is a thousandth of the tolerance `tol` wide.
#[inline(always)]
pub(super) fn closed_form(
    split: &SplitLeaf,
    values: [Values; 2],
    bounds: [Bounds; 2],
    piece: &Piece,
    m: f64,
    tol: f64,
) -> Option<Seam> {
    let side = |(v, w): Values, k: &Bounds| {
        let (lo, hi) = k.curvature;
        let quadratic = k.second_order && k.quadratic();
        let p = Parabola {
            v,
            e: k.f_err,
            w,
            u: k.g_err,
            lo,
            hi,
        };
        // The smaller of two sides is the negated larger of their negations,
        // with the same roots.
        quadratic.then_some(if split.larger { p } else { p.negated() })
    };
    let sides = [side(values[0], &bounds[0])?, side(values[1], &bounds[1])?];
    // The piece's ends as steps from m, moved out past the roundings of the
    // subtractions (the leaves' bounds hold on their padded boxes).
    let out = |s: f64| s * (1.0 + ROUNDINGS_3) + f64::MIN_POSITIVE.copysign(s);
    let (s_a, s_b) = (out(piece.a - m), out(piece.b - m));
    seam::first_root(&sides, m, s_a, s_b, half_placement(tol))
}

/// Where F is monotone on `piece` with `|g| ≥ slope_min` and sign
/// `slope_sign`, and its value at the middle `m` is `fm` (certified sign):
/// the root, if any, lies on the side where F falls toward 0, within
/// `δ = (|f(m)| + err)/slope_min` of m (|F(m)| ≥ slope_min·|m − r|). When that
/// side's end of `[m − δ, m]` or `[m, m + δ]` lies inside the piece, F has
/// the opposite sign there without an evaluation: a bracket of the one root
/// on the piece (none lies before it: F is monotone), with Newton's step from
/// m to start. `None` when the bracket would reach past the piece.
#[allow(clippy::too_many_arguments)]
pub(super) fn slope_bracket(
    k: &Bounds,
    piece: &Piece,
    m: f64,
    fm: f64,
    gm: f64,
    slope_min: f64,
    slope_sign: f64,
) -> Option<(Piece, f64)> {
    let sm = certified_sign(fm, k.f_err);
    if sm == 0 || slope_sign == 0.0 || slope_sign.is_nan() {
        return None;
    }
    // A millionth more covers the roundings of δ; four ulps of m, those of
    // m ± δ.
    let delta = (fm.abs() + k.f_err) / slope_min * (1.0 + 1e-6) + ROUNDINGS_7 * m.abs();
    if !delta.is_finite() {
        return None;
    }
    let newton = m - fm / gm;
    // F falls toward 0 to the left of m when F(m) and g have one sign.
    if (f64::from(sm) > 0.0) == (slope_sign > 0.0) {
        let lo = m - delta;
        (lo > piece.a).then_some((
            Piece {
                a: lo,
                b: m,
                fa: f64::NAN,
                fb: fm,
                sa: -sm,
                sb: sm,
                side: piece.side,
                lip: f64::INFINITY,
            },
            newton,
        ))
    } else {
        let hi = m + delta;
        (hi < piece.b).then_some((
            Piece {
                a: m,
                b: hi,
                fa: fm,
                fb: f64::NAN,
                sa: sm,
                sb: -sm,
                side: piece.side,
                lip: f64::INFINITY,
            },
            newton,
        ))
    }
}

/// A bound of the distance from Newton's step `x − f/g` (values at x, with
/// the leaf's error bounds) to the root r of a bracket on which F is
/// monotone with `|g| ≥ slope_min` and `|g′| ≤ G`; `+∞` when the leaf has no
/// finite G. From `0 = F(r) = F(x) + g(x)(r − x) + ½g′(ξ)(r − x)²`:
/// `|r − step| ≤ |F(x)/g(x) − f/g| + ½G(r − x)²/|g(x)|`, where
/// `|r − x| ≤ (|f| + err)/slope_min` and
/// `|F(x)/g(x) − f/g| ≤ (err + |f|·g_err/|g|)/slope_min`; doubled to cover
/// the roundings of the bound, plus ulps of x and of f/g for those of the
/// step `x − f/g` itself.
pub(super) fn newton_lands(k: &Bounds, x: f64, f: f64, g: f64, slope_min: f64) -> f64 {
    if !k.second_order || slope_min <= 0.0 || g == 0.0 || g.is_nan() || f.is_nan() {
        return f64::INFINITY;
    }
    let to_root = (f.abs() + k.f_err) / slope_min;
    // A plane's g error is the smallest normal (g is exact there): times
    // |f|, a subnormal, which costs a hundred cycles an operation. A larger
    // error bound is as sound, and keeps the products normal.
    let g_err = k.g_err.max(1e-150);
    let values = (k.f_err + f.abs() * g_err / g.abs()) / slope_min;
    let curvature = 0.5 * k.g * to_root * to_root / slope_min;
    let bound = 2.0 * (values + curvature) + ROUNDINGS_7 * (x.abs() + (f / g).abs());
    if bound.is_nan() {
        f64::INFINITY
    } else {
        bound
    }
}
