//! Proving or refuting a hand-derived Lipschitz constant by branch and bound.
//!
//! The region is split until every piece's sound bound is at most the claimed
//! constant C (**proved**), or a point is found where the quantity certainly
//! exceeds C, its interval at that point lying wholly above C (**refuted**,
//! with that point as witness), or the budget of pieces runs out
//! (**undecided**, with the worst piece left). Pieces are taken worst first,
//! so the proof needs no more pieces than the bound's looseness requires.

use super::lipschitz::Bounder;
use super::queue::{box_witness, halves, segment_witness, Queued};
use crate::types::Interval;
use crate::types::{Aabb, Segment};
use glam::DVec3;
use std::collections::BinaryHeap;

/// The outcome of a verification.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict<R> {
    /// Every piece's sound bound is at most C.
    Proved {
        /// Pieces examined.
        pieces: usize,
    },
    /// At `witness` the quantity is certainly at least `value`, which exceeds C.
    Refuted {
        /// Where.
        witness: DVec3,
        /// For a segment, the parameter of the witness.
        t: Option<f64>,
        /// A certified lower bound of the quantity at the witness.
        value: f64,
        /// Pieces examined.
        pieces: usize,
    },
    /// The budget ran out first.
    Undecided {
        /// The piece with the largest bound left.
        worst: R,
        /// Its bound.
        bound: f64,
        /// Pieces examined.
        pieces: usize,
    },
}

/// The shared search: `bound` gives a piece's sound bound, `witness` a
/// certified lower bound at a point of it (and the point), `split` its halves.
fn branch_and_bound<R: Clone>(
    start: R,
    claim: Interval,
    max_pieces: usize,
    bound: impl Fn(&R) -> f64,
    witness: impl Fn(&R) -> (f64, DVec3, Option<f64>),
    split: impl Fn(&R) -> [R; 2],
) -> Verdict<R> {
    let mut queue = BinaryHeap::new();
    queue.push(Queued {
        bound: bound(&start),
        region: start,
    });
    let mut pieces = 1;
    while let Some(Queued { bound: b, region }) = queue.pop() {
        // NaN never occurs (bounds are numbers or +∞), but would sort first
        // and fail this test, which keeps it undecided rather than proved.
        if b <= claim.inf() {
            return Verdict::Proved { pieces };
        }
        let (value, point, t) = witness(&region);
        if value > claim.sup() {
            return Verdict::Refuted {
                witness: point,
                t,
                value,
                pieces,
            };
        }
        if pieces >= max_pieces {
            return Verdict::Undecided {
                worst: region,
                bound: b,
                pieces,
            };
        }
        for half in split(&region) {
            pieces += 1;
            queue.push(Queued {
                bound: bound(&half),
                region: half,
            });
        }
    }
    Verdict::Proved { pieces }
}

/// Proves or refutes `max |∇f| ≤ claim` over the box.
///
/// `claim` is an interval so that a constant like `2*sqrt(3)` keeps its
/// rounding: proof needs every bound ≤ its lower end, refutation a witness
/// above its upper end.
pub fn verify_lipschitz(
    bounder: &Bounder,
    region: &Aabb,
    claim: Interval,
    max_pieces: usize,
) -> Verdict<Aabb> {
    // A good sampled point refutes a false claim at once, before any split.
    let sampled = bounder.sample_gradient(region, 12);
    let at = bounder.gradient_norm_at_least(sampled.point);
    if at > claim.sup() {
        return Verdict::Refuted {
            witness: sampled.point,
            t: None,
            value: at,
            pieces: 0,
        };
    }
    branch_and_bound(
        *region,
        claim,
        max_pieces,
        |b| bounder.lipschitz_bound(b, 0).value,
        |b| box_witness(bounder, b),
        |b| bounder.split(b),
    )
}

/// Proves or refutes `max |g′(t)| ≤ claim` over the segment.
pub fn verify_grad_lipschitz(
    bounder: &Bounder,
    segment: &Segment,
    claim: Interval,
    max_pieces: usize,
) -> Verdict<Segment> {
    let (sampled, t) = bounder.sample_dg(segment, 257);
    let at = bounder.dg_at_least(segment, t);
    if at > claim.sup() {
        return Verdict::Refuted {
            witness: sampled.point,
            t: Some(t),
            value: at,
            pieces: 0,
        };
    }
    branch_and_bound(
        *segment,
        claim,
        max_pieces,
        |s| bounder.grad_lipschitz_bound(s, 0).value,
        |s| segment_witness(bounder, s),
        halves,
    )
}
