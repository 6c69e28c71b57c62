//! What the steps of an octree build cost, in tape instructions, as the
//! work budget ([`MAX_WORK`](super::options::MAX_WORK)) counts them.

use super::classify::Plan;
use super::shapes::Shape;
use crate::expr::Tape;

/// The tape instructions in `t`, plus one: what one evaluation costs.
pub(super) fn cost(t: &Tape) -> u64 {
    t.body().len() as u64 + 1
}

/// What one box costs to classify by `shape`, at most: f at its corners
/// (points count ¼), over it and at its centre, and f and ∇f over it.
pub(super) fn classify_cost(shape: &Shape) -> u64 {
    4 * cost(&shape.f) + cost(&shape.f_grad)
}

/// What one box of `shape` costs to make a leaf of: f and ∇f, the Hessian
/// and the rounding of f and g where no branch point is open; where some
/// are, the branch points' operands, and f and ∇f with f's rounding (∇f
/// then jumps in nearly every leaf, which needs neither the Hessian nor
/// g's rounding).
pub(super) fn leaf_cost(plan: &Plan, shape: &Shape) -> u64 {
    if shape.open == 0 {
        cost(&shape.f_grad)
            + shape.local.as_ref().map_or(0, cost)
            + cost(&shape.fg)
            + cost(&shape.f) * 9 / 2
    } else {
        cost(&shape.f_grad) + cost(&shape.f) * 9 / 2 + cost(&plan.operands)
    }
}
