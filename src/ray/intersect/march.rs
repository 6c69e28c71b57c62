//! The march along a creased leaf's first piece: steps F's Lipschitz bound
//! proves clear, spent on values of f in machine code to spare enclosures.

use super::bounds::*;
use super::piece::*;
use super::*;

/// Most steps a march along a creased leaf's first piece takes
/// ([`Tracer::march`]).
const MARCH_STEPS: u32 = 16;

/// A march stops where its clear radius falls to this fraction of the
/// piece: near the surface, where halving and enclosures isolate the root.
const MARCH_SHORTEST: f64 = 1.0 / 32.0;

/// Each step of a march lands this many clear radii ahead; the radius there
/// must reach back to what is already clear, or the march steps back. On the
/// bear model, 1.6 took the fewest evaluations (1.0: 6.4 point evaluations a
/// ray against 5.2; 2.0: 7.8).
const MARCH_OVERSTEP: f64 = 1.6;

impl<'s> Tracer<'s> {
    /// Marches along `piece` from its start by steps F's Lipschitz bound
    /// proves clear (as sphere tracing does, each with a certified radius):
    /// `Some(true)` where it cleared the whole piece, `Some(false)` where it
    /// moved the piece's start, `None` where it did not run or move.
    ///
    /// Only in creased leaves with no cells, where f runs as machine code
    /// (the `jit` feature): there an enclosure of f and g costs about as
    /// much as fifteen values of f, and the march spends a few values to
    /// spare the enclosures of the ray's approach to the surface. Where f is
    /// interpreted or looked up by cell (the prospero slab), values cost too
    /// much for it to pay.
    pub(super) fn march(&mut self, k: &Bounds, ray: &Ray, piece: &mut Piece) -> Option<bool> {
        if !(k.first_order && k.lt > 0.0 && k.lt.is_finite() && k.f_err.is_finite()) {
            return None;
        }
        // Whether it runs depends on the build and the leaf alone, never on
        // whether this thread's code is compiled yet: a ray's answer is the
        // same whichever thread traces it.
        if !cfg!(feature = "jit")
            || self
                .intersector
                .octree
                .short
                .has_cells(self.leaf, self.current)
        {
            return None;
        }
        let (a0, b) = (piece.a, piece.b);
        let shortest = (b - a0) * MARCH_SHORTEST;
        // No root on [a0, covered]; the next value is taken at t.
        let (mut covered, mut t) = (a0, a0);
        // F at `covered`, where the march stopped there.
        let mut stopped_at = None;
        for _ in 0..MARCH_STEPS {
            let f = self.f_at(ray, t);
            // |F(t)| ≥ |f| − f_err > 0, and F moves at most lt·|t' − t|:
            // no root within the radius of t. It is rounded down by a
            // relative margin for the subtraction's and quotient's
            // roundings and an absolute one for those of t ± r (as in
            // `clear_around_middle`); no bound or F near 0 leave 0.
            let radius = (f.abs() - k.f_err) / k.lt;
            let r = if radius.is_finite() && radius > 0.0 {
                (radius * (1.0 - 1e-12) - 4.0 * f64::EPSILON * (t.abs() + radius)).max(0.0)
            } else {
                0.0
            };
            if t - r > covered {
                // A step too long: F's radius at t does not reach back.
                t = covered;
                continue;
            }
            if r > 0.0 && t + r >= b {
                return Some(true);
            }
            if r <= shortest {
                if t == covered {
                    stopped_at = Some(f);
                }
                break;
            }
            covered = t + r;
            t += MARCH_OVERSTEP * r;
            if t >= b {
                t = covered;
            }
        }
        if covered <= a0 {
            return None;
        }
        piece.a = covered;
        (piece.fa, piece.sa) = match stopped_at {
            Some(f) => (f, certified_sign(f, k.f_err)),
            None => (f64::NAN, 0),
        };
        Some(false)
    }
}
