//! Settling a piece at the tolerance and placing a bracketed root.

use super::bounds::*;
use super::piece::*;
use super::*;
use crate::ray::answer::{placement, Answer};
use crate::types::rounding::up_test as up;

/// The most enclosures [`Tracer::finer`] spends on one piece at the
/// tolerance: enough to split it some 60 times along one path (a curvature
/// bound loosened by an underflowing product needs a thousandth of the
/// tolerance), and few beside a tangency, where it ends as a touch.
const FINER_EVALUATIONS: u32 = 128;

impl<'s> Tracer<'s> {
    /// A root on the leaf's far face `b`, F's sign at `c` (just before it,
    /// nothing in between) being `sc`: certified when the whole formula has
    /// the opposite sign half a tolerance past `b`, continuous across. The
    /// point past `b` lies outside the leaf, where only the whole formula and
    /// intervals are sound; the current shape is kept when this fails.
    pub(super) fn across_face(
        &mut self,
        ray: &Ray,
        c: f64,
        b: f64,
        sc: i8,
        tol: f64,
    ) -> Option<Answer> {
        let beyond = b + 0.5 * tol;
        if beyond <= b || beyond.is_nan() {
            return None;
        }
        // The whole formula's f64 value and its error bound over the whole
        // (padded) box decide first, where the point lies in the box; the
        // exact point is within twice `moved` of it (beyond may pass the
        // ray's far end by half a tolerance), well inside the pad.
        // Intervals decide where these cannot.
        let whole = self.intersector.octree.whole;
        let p = ray.o + beyond * ray.d;
        let bounds = &self.intersector.octree.bounds;
        let in_box = p.cmpge(bounds.lo).all() && p.cmple(bounds.hi).all();
        let shape = self.current;
        self.current = 0;
        let mut sign = 0;
        if ray.fast && in_box {
            self.stats.f_evals += 1;
            let [f] = self.whole_f.eval_array(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
            sign = certified_sign(f, up(whole.f_error + whole.lipschitz * 2.0 * ray.moved));
        }
        if sign == 0 {
            sign = interval_sign(self.fg_over(ray, beyond, beyond).0);
        }
        // Both ends in the (convex) box: the whole segment is.
        if sign == -sc && ((in_box && whole.continuous) || self.fg_over(ray, c, beyond).2) {
            return Some(Answer::Hit(b));
        }
        self.current = shape;
        None
    }

    /// A piece at the tolerance that no test excluded: a miss if the interval
    /// of F over it excludes 0, a hit if F's sign changes across it
    /// (certified), a touch otherwise.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn settle(
        &mut self,
        ray: &Ray,
        k: &Bounds,
        mut piece: Piece,
        m: f64,
        fm: f64,
        mut sm: i8,
        tol: f64,
    ) -> Answer {
        let (span, _, continuous) = self.fg_over(ray, piece.a, piece.b);
        if span.is_empty() || !span.contains(0.0) {
            return Answer::Miss;
        }
        self.evaluate_ends(ray, k, &mut piece);
        // A sign change proves a root only where F is continuous: across a
        // jump or a pole the piece can only be a touch.
        let continuous = continuous || k.first_order;
        if piece.sa == 0 {
            piece.sa = self.sign_at(ray, piece.a, piece.fa, k.f_err);
        }
        if piece.sb == 0 {
            piece.sb = self.sign_at(ray, piece.b, piece.fb, k.f_err);
        }
        if sm == 0 {
            sm = self.sign_at(ray, m, fm, k.f_err);
        }
        let crossing = |x: i8, y: i8| continuous && x != 0 && y != 0 && x != y;
        if crossing(piece.sa, sm) {
            let left = Piece {
                b: m,
                fb: fm,
                sb: sm,
                ..piece
            };
            return self.refine(ray, k, left, 0.0, tol);
        }
        if crossing(sm, piece.sb) {
            let right = Piece {
                a: m,
                fa: fm,
                sa: sm,
                ..piece
            };
            return self.refine(ray, k, right, 0.0, tol);
        }
        if crossing(piece.sa, piece.sb) {
            return self.refine(ray, k, piece, 0.0, tol);
        }
        // Certified one sign at both ends and the middle: the enclosure may
        // hold 0 only by its overestimate, which halves with the width. Where
        // the leaf's bounds are loose (a curvature or error bound that f64
        // can only round up to a subnormal, at extreme scales), the piece is
        // split further below the tolerance, on certified tests alone,
        // before it may become a touch.
        if continuous && piece.sa != 0 && piece.sa == sm && sm == piece.sb {
            if let Some(answer) = self.finer(ray, k, &piece, m, sm, tol) {
                return answer;
            }
        }
        // F exactly 0 at a point (its enclosure is {0}): a root there.
        for t in [piece.a, m, piece.b] {
            let (at, _, _) = self.fg_over(ray, t, t);
            if at.inf() == 0.0 && at.sup() == 0.0 {
                return Answer::Hit(t);
            }
        }
        // A root within rounding noise of an end: certify the crossing with a
        // point one piece further, F continuous across both pieces. That
        // point may lie outside the leaf, where its specialised shape need
        // not be f: from here on the whole formula decides, by intervals
        // (the leaf's bounds are its shape's). Every path below ends the ray.
        let unknown;
        let k = if self.current == 0 {
            k
        } else {
            self.current = 0;
            unknown = Bounds::UNKNOWN;
            &unknown
        };
        let w = piece.b - piece.a;
        let (outer_a, outer_b) = (piece.a - w, piece.b + w);
        let (_, _, wide_continuous) = self.fg_over(ray, outer_a, outer_b);
        if wide_continuous || k.first_order {
            let inner = if piece.sa != 0 { piece.sa } else { sm };
            if piece.sb == 0 && inner != 0 {
                let beyond = interval_sign(self.fg_over(ray, outer_b, outer_b).0);
                if beyond == -inner {
                    let bracket = Piece {
                        a: if piece.sa != 0 { piece.a } else { m },
                        b: outer_b,
                        fa: if piece.sa != 0 { piece.fa } else { fm },
                        fb: f64::NAN,
                        sa: inner,
                        sb: beyond,
                        side: 0,
                        lip: f64::INFINITY,
                    };
                    return self.refine(ray, k, bracket, 0.0, tol);
                }
            }
            let inner = if piece.sb != 0 { piece.sb } else { sm };
            if piece.sa == 0 && inner != 0 {
                let before = interval_sign(self.fg_over(ray, outer_a, outer_a).0);
                if before == -inner {
                    let bracket = Piece {
                        a: outer_a,
                        b: if piece.sb != 0 { piece.b } else { m },
                        fa: f64::NAN,
                        fb: if piece.sb != 0 { piece.fb } else { fm },
                        sa: before,
                        sb: inner,
                        side: 0,
                        lip: f64::INFINITY,
                    };
                    return self.refine(ray, k, bracket, 0.0, tol);
                }
            }
        }
        Answer::Touch(m)
    }

    /// The halves of `piece`, of certified sign `s` at both ends and at its
    /// middle `m`, split again while their enclosures hold 0, at most
    /// [`FINER_EVALUATIONS`] enclosures in all: `Miss` when every part is
    /// excluded, the refined root where a certified sign change turns up
    /// (F continuous), `Undecided` at the first part not excluded when the
    /// evaluations run out first, `None` where F's sign at a middle is lost
    /// in its rounding (a tangency, which ends as a touch).
    fn finer(
        &mut self,
        ray: &Ray,
        k: &Bounds,
        piece: &Piece,
        m: f64,
        s: i8,
        tol: f64,
    ) -> Option<Answer> {
        let mut left = FINER_EVALUATIONS;
        // Later parts first on the stack: the first root is found first.
        let mut stack = vec![(m, piece.b), (piece.a, m)];
        while let Some((a, b)) = stack.pop() {
            if left == 0 {
                // Not a tangency found but a budget spent: everything
                // before `a` is excluded, nothing is known past it.
                return Some(Answer::Undecided(a));
            }
            left -= 1;
            let (span, g, continuous) = self.fg_over(ray, a, b);
            if span.is_empty() || !span.contains(0.0) {
                continue;
            }
            let mid = a + 0.5 * (b - a);
            if mid <= a || mid >= b {
                return None;
            }
            // The mean value form F(mid) + g·(t − mid) (F continuous, g
            // bounded: F is Lipschitz on the piece): its excess shrinks with
            // the square of the width, the natural enclosure's only with the
            // width, which may take more splits than the budget holds where
            // the leaf's curvature bound is too loose to exclude the piece.
            if continuous && g.is_bounded() {
                let at = self.fg_over(ray, mid, mid).0;
                let offsets = Interval::new(a, b) - Interval::point(mid);
                let centred = at + g * offsets;
                if !at.is_empty() && !centred.contains(0.0) {
                    continue;
                }
            }
            let sm = self.sign_at_t(ray, k, mid);
            if sm == -s {
                let bracket = Piece {
                    a,
                    b: mid,
                    fa: f64::NAN,
                    fb: f64::NAN,
                    sa: s,
                    sb: sm,
                    side: piece.side,
                    lip: f64::INFINITY,
                };
                return Some(self.refine(ray, k, bracket, 0.0, tol));
            }
            if sm == 0 {
                return None;
            }
            stack.push((mid, b));
            stack.push((a, mid));
        }
        Some(Answer::Miss)
    }

    /// The root in `[a, b]`, whose ends have certified opposite signs (F
    /// monotone with `|g| ≥ slope_min` there when that is positive), by
    /// Newton's method kept inside the bracket (bisection whenever a step
    /// would leave it). The bracket shrinks only on certified signs, until
    /// the steps stall or it is within the tolerance: a hit. If F's sign at
    /// an iterate is lost in its rounding noise first, the root cannot be
    /// placed to the tolerance: a touch at the last point of certified sign
    /// (a wide bracket is monotone, so nothing lies before it).
    pub(super) fn refine(
        &mut self,
        ray: &Ray,
        k: &Bounds,
        piece: Piece,
        slope_min: f64,
        tol: f64,
    ) -> Answer {
        self.refine_from(ray, k, piece, slope_min, tol, f64::NAN)
    }

    /// [`Tracer::refine`] with a first iterate `start` (used when inside the
    /// bracket; otherwise the secant or the middle).
    pub(super) fn refine_from(
        &mut self,
        ray: &Ray,
        k: &Bounds,
        piece: Piece,
        slope_min: f64,
        tol: f64,
        start: f64,
    ) -> Answer {
        let Piece {
            mut a,
            mut b,
            fa,
            fb,
            sa,
            ..
        } = piece;
        let mut x = if start > a && start < b {
            start
        } else if fa.is_finite() && fb.is_finite() && fa != fb {
            a - fa * (b - a) / (fb - fa)
        } else {
            0.5 * (a + b)
        };
        if !(x > a && x < b) {
            x = 0.5 * (a + b);
        }
        // How close to the root an answer is placed when that costs little.
        let place = placement(tol);
        // Brackets from the tolerance (up to three pieces wide) count as placed.
        let within = |a: f64, b: f64| b - a <= 8.0 * tol;
        for _ in 0..200 {
            let (fx, gx) = self.fg_at(ray, x);
            let err = k.f_err;
            // Monotone with |g| ≥ slope_min between ends of opposite sign:
            // the one root r has |F(x)| = |F(x) − F(r)| ≥ slope_min·|x − r|,
            // so |x − r| ≤ (|f(x)| + err)/slope_min. Within a thousandth of
            // the tolerance, x places it, however far F(x) is from rounding
            // noise: Newton's next step would gain nothing a user could see,
            // and answers stay the same to far below the tolerance whatever
            // the octree (a thousandth off covers the roundings of the test).
            if up(fx.abs() + err) <= 0.999 * slope_min * place {
                return Answer::Hit(x);
            }
            let mut sx = certified_sign(fx, err);
            if sx == 0 {
                // Monotone with |g| ≥ slope_min: the root is within
                // 2·err/slope_min of x (|F(x)| ≤ 2·err).
                if within(a, b) || 2.0 * err <= slope_min * tol {
                    return Answer::Hit(x);
                }
                // x is within rounding noise of a root: a tolerance-wide
                // bracket around it, certified at both ends, places it.
                let (lo, hi) = ((x - tol).max(a), (x + tol).min(b));
                let s_lo = if lo == a {
                    sa
                } else {
                    self.sign_at_t(ray, k, lo)
                };
                let s_hi = if hi == b {
                    -sa
                } else {
                    self.sign_at_t(ray, k, hi)
                };
                if s_lo == sa && s_hi == -sa {
                    return Answer::Hit(x);
                }
                // The f64 value cannot tell; an enclosure at x may.
                sx = self.sign_at(ray, x, fx, f64::INFINITY);
                if sx == 0 {
                    // The root cannot be placed to the tolerance: F is
                    // monotone here, so nothing lies before a; move a up to
                    // the noise (bisecting on certified signs) and touch there.
                    let mut noisy = x;
                    for _ in 0..64 {
                        let mid = 0.5 * (a + noisy);
                        if mid <= a || mid >= noisy {
                            break;
                        }
                        if self.sign_at_t(ray, k, mid) == sa {
                            a = mid;
                        } else {
                            noisy = mid;
                        }
                    }
                    return Answer::Touch(a);
                }
            }
            if sx == sa {
                a = x;
            } else {
                b = x;
            }
            let newton = x - fx / gx;
            if newton > a && newton < b && newton_lands(k, x, fx, gx, slope_min) <= place {
                return Answer::Hit(newton);
            }
            let next = if newton > a && newton < b {
                newton
            } else {
                0.5 * (a + b)
            };
            if (next - x).abs() <= 2.0 * f64::EPSILON * x.abs().max(f64::MIN_POSITIVE)
                || b - a <= (4.0 * f64::EPSILON * a.abs().max(b.abs())).max(1e-6 * tol)
            {
                return Answer::Hit(next);
            }
            x = next;
        }
        if within(a, b) {
            Answer::Hit(x)
        } else {
            Answer::Touch(a)
        }
    }
}
