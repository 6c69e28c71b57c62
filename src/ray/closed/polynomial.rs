//! Rays against a formula that is a polynomial over its whole box (a torus,
//! a quartic, a sextic with no `max` or `abs`): F along a ray is a
//! polynomial in t, whose roots are isolated in Bernstein form with no
//! octree walk.
//!
//! The coefficients of F about the ray's entry, in the unit parameter of
//! the ray's range, come from jets ([`AlongLine`]), with a bound E of their
//! error in the norm `Σ |c_k|`. On the range, F's Bernstein coefficients enclose it
//! (their hull holds its graph), and splitting at the middle (de Casteljau)
//! gives those of each half; the error's own Bernstein coefficients are
//! weighted means of its scaled power coefficients, so each is within E
//! too, on every piece. A piece whose coefficients all share a certified sign
//! holds no root; one whose coefficients change sign exactly once (each
//! sign certified) holds exactly one, a simple root (Descartes' rule in
//! Bernstein form), found by Halley's method kept inside the piece. Pieces
//! are taken nearest first, so the first piece with a root holds the first
//! root.
//!
//! The certificate is the general search's: a hit is a sign change of F
//! enclosed within a small fraction of the tolerance, everything before it
//! excluded by a sound test; a miss is every piece excluded. Where the
//! pieces reach the tolerance undecided (a tangency, a double root, noise),
//! or a value cannot certify a sign, `Polynomial::answer` declines and the
//! general search answers.

use crate::expr::along::{AlongLine, Jet, MAX_DEGREE};

use crate::ray::answer::Answer;
use crate::types::rounding::{up_sum, U};
use glam::DVec3;

/// Coefficients a polynomial of the highest degree has.
const TERMS: usize = MAX_DEGREE + 1;

/// Splits one ray may take before it declines.
const MAX_SPLITS: u32 = 48;

/// Steps (Halley's or Newton's) a root may take before the ray declines.
const MAX_NEWTON: u32 = 40;

/// The sign of a value within `r` of `m` when it is certified (±1), else 0.
#[inline(always)]
fn sign(m: f64, r: f64) -> i8 {
    if m > r {
        1
    } else if m < -r {
        -1
    } else {
        0
    }
}

/// F on a piece `[lo, hi]` of the unit parameter: its Bernstein
/// coefficients, each real one within `radius` of the f64 one.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Piece {
    lo: f64,
    hi: f64,
    b: [f64; TERMS],
    radius: f64,
}

/// A tracer's scratch space for polynomial rays.
#[derive(Debug, Clone)]
pub(crate) struct Scratch {
    registers: Vec<Jet>,
    pieces: Vec<Piece>,
}

/// The formula as a polynomial along rays.
#[derive(Debug, Clone)]
pub struct Polynomial {
    along: AlongLine,
    /// `C(j, k) / C(n, k)`: the Bernstein coefficient `j` of degree n takes
    /// that share of the scaled power coefficient `k ≤ j`.
    weights: [[f64; TERMS]; TERMS],
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64)
}

impl Polynomial {
    /// The form for a formula whose f tape `along` compiles, of degree at
    /// least 3 (the search answers quadrics' rays from their exact second
    /// derivative in fewer evaluations, and planes have their own closed
    /// form).
    pub(crate) fn new(along: AlongLine) -> Option<Polynomial> {
        let n = along.degree();
        if n < 3 {
            return None;
        }
        let mut weights = [[0.0; TERMS]; TERMS];
        for (j, row) in weights.iter_mut().enumerate().take(n + 1) {
            for (k, w) in row.iter_mut().enumerate().take(j + 1) {
                // Exact integers divided once: within u of the real ratio.
                *w = binomial(j, k) / binomial(n, k);
            }
        }
        Some(Polynomial { along, weights })
    }

    /// The scratch space a tracer keeps for [`Polynomial::answer`].
    pub(crate) fn scratch(&self) -> Scratch {
        Scratch {
            registers: self.along.registers(),
            pieces: Vec::with_capacity(MAX_SPLITS as usize + 1),
        }
    }

    /// The certified answer for the ray `o + t·d` on `[t0, t1]` (its range
    /// in the box), placing a hit within `place` of the root and giving up
    /// on pieces of F no longer than `tol`, with the number of evaluations
    /// taken (the jets count as one); `None` where the general search
    /// answers.
    pub(crate) fn answer(
        &self,
        scratch: &mut Scratch,
        ray: (DVec3, DVec3),
        (t0, t1): (f64, f64),
        place: f64,
        tol: f64,
    ) -> Option<(Answer, u64)> {
        // One copy per degree: its loops unroll.
        let args = (scratch, ray, (t0, t1), place, tol);
        match self.along.degree() {
            3 => self.answer_of::<3>(args),
            4 => self.answer_of::<4>(args),
            5 => self.answer_of::<5>(args),
            6 => self.answer_of::<6>(args),
            7 => self.answer_of::<7>(args),
            8 => self.answer_of::<8>(args),
            _ => None,
        }
    }

    /// [`Polynomial::answer`] for a polynomial of degree `N`.
    #[inline(always)]
    fn answer_of<const N: usize>(
        &self,
        (scratch, ray, (t0, t1), place, tol): (&mut Scratch, (DVec3, DVec3), (f64, f64), f64, f64),
    ) -> Option<(Answer, u64)> {
        let n = N;
        // The range in s = t − t0, widened to an f64 length.
        let h = (t1 - t0).next_up();
        if !(h > 0.0 && h.is_finite()) {
            return None;
        }
        let c = self.along.coefficients(&mut scratch.registers, ray, t0, h);
        let (error, size) = (c.error, c.size);
        if !(error.is_finite() && size.is_finite()) {
            return None;
        }
        let mut evals = 1;
        // F(t0 + h·u) in powers of u, then in Bernstein form on [0, 1]
        // (weights within u, sums of at most n + 1 terms): every coefficient
        // within E and these roundings.
        let mut piece = Piece {
            lo: 0.0,
            hi: 1.0,
            b: [0.0; TERMS],
            radius: up_sum(error + (4 * n + 8) as f64 * U * size),
        };
        for j in 0..n + 1 {
            let mut m = 0.0f64;
            for (w, a) in self.weights[j][..j + 1].iter().zip(&c.c) {
                m += w * a;
            }
            piece.b[j] = m;
        }
        // F's value at a point of the range is within this of Horner's.
        let point_error = up_sum(error + (4 * n + 4) as f64 * U * size);
        let pieces = &mut scratch.pieces;
        pieces.clear();
        let mut splits = 0;
        loop {
            // The coefficients' certified signs: all one (no root), or one
            // change (one simple root), or neither.
            let r = piece.radius;
            // (Without branches first: most pieces are all of one sign.)
            let b = &piece.b[..n + 1];
            let above = b.iter().fold(true, |all, &bj| all & (bj > r));
            let below = b.iter().fold(true, |all, &bj| all & (bj < -r));
            if above | below {
                match pieces.pop() {
                    Some(next) => {
                        piece = next;
                        continue;
                    }
                    None => return Some((Answer::Miss, evals)),
                }
            }
            let sign0 = sign(piece.b[0], r);
            let (mut certified, mut changes) = (sign0 != 0, 0);
            let mut last = sign0;
            for &bj in &b[1..] {
                let sj = sign(bj, r);
                certified &= sj != 0;
                changes += usize::from(sj != last);
                last = sj;
            }
            if certified && changes == 1 {
                let u = root_in(c, n, &piece, (place / h, tol / h), point_error, &mut evals)?;
                let t = t0 + u * h;
                return (t >= t0 && t <= t1).then_some((Answer::Hit(t), evals));
            }
            if (piece.hi - piece.lo) * h <= tol || splits == MAX_SPLITS {
                return None;
            }
            splits += 1;
            let (left, right) = halves(&piece, n);
            pieces.push(right);
            piece = left;
        }
    }
}

/// The one root of F in `piece` (whose ends have certified opposite signs,
/// its coefficients one sign change), as `u`: Halley's method on the power
/// form `c`, kept in a bracket, to within `place`; certified by F's signs
/// either side of it, within half the tolerance `tol` (`None` where
/// rounding hides them), both in units of `u`. F is within `point_error` of
/// Horner's value anywhere on the range.
#[inline(always)]
fn root_in(
    c: &Jet,
    n: usize,
    piece: &Piece,
    (place, tol): (f64, f64),
    point_error: f64,
    evals: &mut u64,
) -> Option<f64> {
    let before = sign(piece.b[0], piece.radius);
    // The bracket is kept strictly inside the piece.
    let (lo, hi) = (piece.lo.next_up(), piece.hi.next_down());
    if lo >= hi {
        return None;
    }
    let (mut a, mut b) = (lo, hi);
    // Start where the chord of the end values crosses 0.
    let (fa, fb) = (piece.b[0], piece.b[n]);
    let mut x = a + (b - a) * (fa / (fa - fb)).clamp(0.0, 1.0);
    let mut last_slope = 0.0f64;
    for _ in 0..MAX_NEWTON {
        let (v, slope, half_curvature) = value_and_derivatives(c, n, x);
        *evals += 1;
        // The bracket follows the f64 sign: it only steers the search.
        if (v > 0.0) == (before > 0) {
            a = x;
        } else {
            b = x;
        }
        // Halley's step (cubic convergence: a step or two fewer than
        // Newton's), Newton's where its denominator does not keep the sign.
        let denominator = slope * slope - v * half_curvature;
        let newton = if denominator > 0.5 * slope * slope {
            x - v * slope / denominator
        } else {
            x - v / slope
        };
        // A Newton step may land on an end: one already evaluated, where F
        // is a rounding from 0 (it had the far side's sign, or was 0).
        let next = if newton >= a && newton <= b {
            newton
        } else {
            0.5 * (a + b)
        };
        last_slope = slope;
        let done = (next - x).abs() <= 0.25 * place || b - a <= 0.5 * place;
        x = next;
        if done {
            break;
        }
    }
    // Certified: F has the sign of the piece's start just before x and the
    // other just after, both within the piece (the root is its only one, so
    // F's sign says which side of it a point is on), as near as F's bound
    // allows: `place` at least, half the tolerance at most. (The slope is
    // the last step's, a step or less away: it only says where to test.)
    let near = (4.0 * point_error / last_slope.abs())
        .max(place)
        .min(0.5 * tol);
    let (p, q) = ((x - near).max(lo), (x + near).min(hi));
    *evals += 2;
    let at = |s: f64| sign(value(c, n, s), point_error);
    let certified = p < q && at(p) == before && at(q) == -before;
    certified.then_some(x)
}

/// F, F′ and F″/2 at `u` from the power form (f64).
#[inline(always)]
fn value_and_derivatives(c: &Jet, n: usize, u: f64) -> (f64, f64, f64) {
    let (mut v, mut slope, mut half_curvature) = (0.0f64, 0.0f64, 0.0f64);
    for k in (0..n + 1).rev() {
        half_curvature = half_curvature * u + slope;
        slope = slope * u + v;
        v = v * u + c.c[k];
    }
    (v, slope, half_curvature)
}

/// F at `u` from the power form (f64, Horner's rule: the certificate's
/// values need no slope).
#[inline(always)]
fn value(c: &Jet, n: usize, u: f64) -> f64 {
    c.c[..n + 1].iter().rev().fold(0.0, |v, &ck| v * u + ck)
}

/// The pieces either side of the middle of `piece` (de Casteljau at ½:
/// each new coefficient the rounded mean of two, n levels deep, each
/// rounding within u of the largest coefficient).
#[inline(always)]
fn halves(piece: &Piece, n: usize) -> (Piece, Piece) {
    let middle = 0.5 * (piece.lo + piece.hi);
    let largest = piece.b[..n + 1].iter().fold(0.0f64, |m, b| m.max(b.abs()));
    let radius = up_sum(piece.radius + (n + 1) as f64 * U * largest);
    let mut left = Piece {
        lo: piece.lo,
        hi: middle,
        b: piece.b,
        radius,
    };
    let mut right = Piece {
        lo: middle,
        hi: piece.hi,
        b: piece.b,
        radius,
    };
    let mut m = piece.b;
    for level in 1..n + 1 {
        for i in 0..n - level + 1 {
            m[i] = 0.5 * (m[i] + m[i + 1]);
        }
        left.b[level] = m[0];
        right.b[n - level] = m[n - level];
    }
    (left, right)
}
