//! Certified brackets of the true constants: `L_lower ≤ max |∇f| ≤ L` over a
//! box (and the same for `max |g′|` on a ray segment), refined by branch and
//! bound until the two ends are within a relative tolerance.
//!
//! The upper end is the largest sound bound over the pieces not yet excluded
//! (and over the pieces excluded because their bound fell below the lower
//! end); the lower end is the lower end of an enclosure of the quantity at
//! the best point found, so the true maximum lies between them. The worst
//! piece is split first: it is the one holding the upper end down, and its
//! centre is where a larger lower end is most likely.
//!
//! Pieces are queued with their natural interval bound; a costlier method
//! (centred, Bernstein) runs on a piece only when it comes to the top of the
//! queue, so it is paid for on the pieces that decide the upper end.

use super::lipschitz::{Bound, Bounder, Method};
use super::queue::{box_witness, halves, segment_witness, Queued};
use crate::types::{Aabb, Segment};
use glam::DVec3;
use std::collections::BinaryHeap;

/// Pieces a bracket examines by default before it stops short of its
/// tolerance (about 60 MB of queue at most).
pub const MAX_PIECES: usize = 1_000_000;

/// A certified bracket of a maximum: the true maximum lies in
/// `[lower, upper]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Bracket {
    /// Certified: the quantity at [`Bracket::point`] is at least this.
    pub lower: f64,
    /// Sound: the quantity is at most this everywhere in the region; `+∞`
    /// where a piece's bound is unbounded (see [`Bracket::note`]).
    pub upper: f64,
    /// Where the lower end holds.
    pub point: DVec3,
    /// For a segment, the parameter of [`Bracket::point`].
    pub t: Option<f64>,
    /// Pieces whose bound was computed.
    pub pieces: usize,
    /// Whether `upper ≤ lower·(1 + tolerance)` was reached (not, when the
    /// piece budget ran out first or the bound is unbounded).
    pub reached: bool,
    /// Why the upper end is infinite, when it is.
    pub note: Option<String>,
}

impl Bracket {
    /// `upper / lower`, the bracket's relative width plus one (`+∞` when the
    /// lower end is 0 or the upper one unbounded).
    pub fn ratio(&self) -> f64 {
        if self.lower > 0.0 {
            self.upper / self.lower
        } else if self.upper == 0.0 {
            1.0
        } else {
            f64::INFINITY
        }
    }
}

/// The fraction of the region's size below which a piece whose bound is
/// still unbounded makes the bracket unbounded: 2⁻⁴⁰, some 40 halvings
/// of a segment, 120 of a box.
pub const UNBOUNDED_SHRINK: f64 = 1.0 / (1u64 << 40) as f64;

/// The best point known: a certified lower end, where, and at which t.
type Witness = (f64, DVec3, Option<f64>);

/// The shared search. `bound` gives a piece's sound bound, `tighten` a
/// smaller one from it (run when the piece reaches the top), `witness` a
/// certified lower end at a point of it, `split` its halves, `size` its
/// diameter; `start_witness` comes from sampling the whole region.
///
/// A piece whose bound is unbounded is split like any other (first, as it
/// tops the queue): its interval may only be too wide to see that the
/// kink or pole it suspects lies outside. The bracket is unbounded when
/// such a piece is [`UNBOUNDED_SHRINK`] of the region's size and still
/// unbounded (a true kink or pole stays so however small the piece), or
/// when the budget runs out first.
#[allow(clippy::too_many_arguments)]
fn refine<R>(
    start: R,
    start_witness: Witness,
    tolerance: f64,
    max_pieces: usize,
    bound: impl Fn(&R) -> Bound,
    tighten: impl Fn(&R, Bound) -> Bound,
    witness: impl Fn(&R) -> Witness,
    split: impl Fn(&R) -> [R; 2],
    size: impl Fn(&R) -> f64,
) -> Bracket {
    let (mut lower, mut point, mut t) = start_witness;
    // Where a piece's bound is unbounded, so is the bracket, with its reason.
    let unbounded = |(lower, point, t): Witness, pieces, note| Bracket {
        lower,
        upper: f64::INFINITY,
        point,
        t,
        pieces,
        reached: false,
        note,
    };
    let smallest = size(&start) * UNBOUNDED_SHRINK;
    let first = bound(&start);
    let mut pieces = 1;
    // Why the last unbounded piece was.
    let mut why = first.note.clone();
    // Each piece with whether the method has tightened its bound yet.
    let mut queue = BinaryHeap::new();
    queue.push(Queued {
        bound: first.value,
        region: (start, !first.value.is_finite()),
    });
    // The largest bound of the pieces dropped because it fell to the lower
    // end: the maximum may still be there, so the upper end covers them.
    let mut dropped = 0.0f64;
    loop {
        let top = queue.peek().map_or(0.0, |q| q.bound);
        let upper = top.max(dropped);
        let reached = upper <= lower * (1.0 + tolerance);
        if !upper.is_finite() && pieces >= max_pieces {
            return unbounded((lower, point, t), pieces, why);
        }
        if reached || pieces >= max_pieces || queue.is_empty() {
            return Bracket {
                lower,
                upper,
                point,
                t,
                pieces,
                reached: reached || queue.is_empty(),
                note: None,
            };
        }
        let Some(Queued {
            region: (region, tight),
            bound: b,
        }) = queue.pop()
        else {
            unreachable!("the queue was not empty");
        };
        if !tight {
            let t = tighten(
                &region,
                Bound {
                    value: b,
                    note: None,
                },
            );
            if t.value <= lower {
                dropped = dropped.max(t.value);
            } else {
                queue.push(Queued {
                    bound: t.value,
                    region: (region, true),
                });
            }
            continue;
        }
        if !b.is_finite() && size(&region) <= smallest {
            return unbounded((lower, point, t), pieces, why);
        }
        let (value, p, at) = witness(&region);
        if value > lower {
            (lower, point, t) = (value, p, at);
        }
        for half in split(&region) {
            pieces += 1;
            let b = bound(&half);
            if !b.value.is_finite() {
                why = b.note;
                // Tightening cannot bound it: split it when it comes up.
                queue.push(Queued {
                    bound: b.value,
                    region: (half, true),
                });
            } else if b.value <= lower {
                dropped = dropped.max(b.value);
            } else {
                queue.push(Queued {
                    bound: b.value,
                    region: (half, false),
                });
            }
        }
    }
}

/// Brackets `max |∇f|` over the box to a relative `tolerance` (e.g. 0.01),
/// examining at most `max_pieces` pieces, each bounded by [`Method::Best`].
///
/// ```
/// use lgc::{bounds::{bracket_lipschitz, Bounder}, Aabb, Formula};
/// use glam::DVec3;
/// let f = Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
/// let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
/// let br = bracket_lipschitz(&Bounder::new(&f), &b, 0.01, 100_000);
/// let truth = 2.0 * 3f64.sqrt(); // |∇f| = 2|p| is largest at a corner
/// assert!(br.reached && br.lower <= truth && truth <= br.upper);
/// assert!(br.upper <= 1.01 * br.lower);
/// ```
pub fn bracket_lipschitz(
    bounder: &Bounder,
    region: &Aabb,
    tolerance: f64,
    max_pieces: usize,
) -> Bracket {
    bracket_lipschitz_by(bounder, region, tolerance, max_pieces, Method::Best)
}

/// [`bracket_lipschitz`] with each piece bounded by `method`. Here
/// [`Method::Best`] leaves the Taylor models out: a piece costs microseconds
/// to split and a Taylor model milliseconds, so splitting wins (the gyroid
/// to 1 %: 0.4 s without them, 3.7 s with). [`Method::Taylor`] uses them.
pub fn bracket_lipschitz_by(
    bounder: &Bounder,
    region: &Aabb,
    tolerance: f64,
    max_pieces: usize,
    method: Method,
) -> Bracket {
    let sampled = bounder.sample_gradient(region, 12);
    let start = (
        bounder.gradient_norm_at_least(sampled.point),
        sampled.point,
        None,
    );
    refine(
        *region,
        start,
        tolerance,
        max_pieces,
        |b| bounder.lipschitz_piece_by(b, Method::Natural),
        |b, natural| bounder.tighten_with(b, natural, method, false),
        |b| box_witness(bounder, b),
        |b| bounder.split(b),
        |b| b.diagonal(),
    )
}

/// Brackets `max |g′(t)|` over the segment to a relative `tolerance`.
pub fn bracket_grad_lipschitz(
    bounder: &Bounder,
    segment: &Segment,
    tolerance: f64,
    max_pieces: usize,
) -> Bracket {
    bracket_grad_lipschitz_by(bounder, segment, tolerance, max_pieces, Method::Best)
}

/// [`bracket_grad_lipschitz`] with each piece bounded by `method` (as in
/// [`bracket_lipschitz_by`], `Best` without Taylor models).
pub fn bracket_grad_lipschitz_by(
    bounder: &Bounder,
    segment: &Segment,
    tolerance: f64,
    max_pieces: usize,
    method: Method,
) -> Bracket {
    let (sampled, t) = bounder.sample_dg(segment, 257);
    let start = (bounder.dg_at_least(segment, t), sampled.point, Some(t));
    // Every piece lies on the same ray: a polynomial g′(t) is expanded once.
    let exact = bounder.exact_dg(segment, method);
    refine(
        *segment,
        start,
        tolerance,
        max_pieces,
        |s| bounder.grad_piece_by(s, method, exact.as_ref(), false),
        |_, bound| bound,
        |s| segment_witness(bounder, s),
        halves,
        |s| s.t1 - s.t0,
    )
}
