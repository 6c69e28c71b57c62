//! Writing proof files: a verdict of [`super::verify`] turned into a
//! certificate that [`crate::proof::check()`] re-checks.
//!
//! lgc's own search may use any bound method; a proof's leaves must follow
//! from the natural interval extension alone. So a proved claim is proved
//! again, by splitting until the checker's own bound (the natural extension
//! of its own derivatives) is at most the constant on every leaf. A
//! refutation keeps lgc's witness, with the checker's certified value there.

// Every test is written so that a NaN fails it (`!(a <= b)` rejects a NaN,
// `a > b` would let it through): a proof is accepted only on numbers.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::lipschitz::Bounder;
use super::verify::Verdict;
use crate::formula::Formula;
use crate::proof::check::{midpoint, push_halves};
use crate::proof::format::MAX_ENTRIES;
use crate::proof::terms::{TermError, Terms};
use crate::proof::{Claim, Entry, Outcome, Proof, Quantity};
use crate::types::Aabb;
use crate::types::Interval;
use glam::DVec3;

/// Why no proof could be written.
#[derive(Debug, thiserror::Error)]
pub enum ProveError {
    /// The formula or the constant is outside the language proofs are
    /// checked in, or too large.
    #[error("{0}")]
    Unreadable(#[from] TermError),
    /// The constant is not a finite constant.
    #[error("the constant `{0}` is not a finite number")]
    Constant(String),
    /// The natural interval extension needs more leaves than allowed.
    #[error("the natural interval extension alone did not prove every piece within {0} pieces; a larger --max-boxes, or a constant with more room, may")]
    TooManyPieces(usize),
    /// A piece too narrow for f64 to split still has too large a bound.
    #[error("a piece too narrow to split, {0:?}, still has the bound {1:?} by the natural interval extension")]
    Unsplittable(Vec<(f64, f64)>, f64),
    /// The claim was neither proved nor refuted.
    #[error("the claim is undecided: neither proved nor refuted within the piece budget")]
    Undecided,
    /// The witness's value is not certified by the natural extension.
    #[error(
        "the natural interval extension at the witness does not certify a value above the constant"
    )]
    Witness,
}

/// The proof of a claim lgc proved: a tree whose every leaf's natural
/// extension bound is at most the constant's lower end, with at most
/// `max_pieces` entries, each box split at its midpoint across the side
/// [`Bounder::split_axis`] picks.
pub fn prove(formula: &str, claim: Claim, max_pieces: usize) -> Result<Proof, ProveError> {
    let constant = enclosure(&claim)?.inf();
    let quantity = Quantity::new(formula, &claim)?;
    // No more than a checker reads.
    let max_pieces = max_pieces.min(MAX_ENTRIES);
    // A box is split where |∇f| varies most (the smear rule, as lgc's own
    // searches split); a segment has one side.
    let bounder = match claim {
        Claim::Lipschitz { .. } => {
            let parsed = Formula::parse(formula).map_err(TermError::Formula)?;
            Some(Bounder::new(&parsed))
        }
        Claim::GradLipschitz { .. } => None,
    };
    let mut entries = Vec::new();
    let mut stack = vec![Quantity::region_of(&claim)];
    while let Some(region) = stack.pop() {
        let bound = quantity.upper(&region);
        if bound <= constant {
            entries.push(Entry::Leaf(bound));
            continue;
        }
        if entries.len() + stack.len() + 2 > max_pieces {
            return Err(ProveError::TooManyPieces(max_pieces));
        }
        let axis = match &bounder {
            Some(bounder) => {
                let r = |k: usize| region[k];
                let b = Aabb {
                    lo: DVec3::new(r(0).0, r(1).0, r(2).0),
                    hi: DVec3::new(r(0).1, r(1).1, r(2).1),
                };
                bounder.split_axis(&b)
            }
            None => 0,
        };
        let (lo, hi) = region[axis];
        let at = midpoint((lo, hi));
        if !(lo < at && at < hi) {
            return Err(ProveError::Unsplittable(region, bound));
        }
        entries.push(Entry::Split {
            axis: axis as u8,
            at,
        });
        push_halves(&mut stack, region, axis, at);
    }
    Ok(Proof {
        formula: formula.to_string(),
        claim,
        outcome: Outcome::Proved(entries),
    })
}

/// The proof of a claim lgc refuted at `point` (and `t` on a ray): the
/// checker's certified value there must exceed the constant.
pub fn refute(
    formula: &str,
    claim: Claim,
    point: [f64; 3],
    t: Option<f64>,
) -> Result<Proof, ProveError> {
    // A refutation must clear all of the constant's enclosure.
    let constant = enclosure(&claim)?.sup();
    let quantity = Quantity::new(formula, &claim)?;
    let at: Vec<f64> = match t {
        Some(t) => vec![t],
        None => point.to_vec(),
    };
    let at_least = quantity.lower_at(&at);
    if !(at_least > constant) {
        return Err(ProveError::Witness);
    }
    Ok(Proof {
        formula: formula.to_string(),
        claim,
        outcome: Outcome::Refuted { point, t, at_least },
    })
}

/// The proof file of a verdict: a proved claim's tree, a refuted one's
/// witness; an undecided claim has none.
pub fn certificate<R>(
    formula: &str,
    claim: Claim,
    verdict: &Verdict<R>,
    max_pieces: usize,
) -> Result<Proof, ProveError> {
    match verdict {
        Verdict::Proved { .. } => prove(formula, claim, max_pieces),
        Verdict::Refuted { witness, t, .. } => refute(formula, claim, witness.to_array(), *t),
        Verdict::Undecided { .. } => Err(ProveError::Undecided),
    }
}

/// The claim's constant as the checker encloses it.
fn enclosure(claim: &Claim) -> Result<Interval, ProveError> {
    match Terms::constant_of(claim.constant())? {
        Some(c) if c.inf().is_finite() && c.sup().is_finite() => Ok(c),
        _ => Err(ProveError::Constant(claim.constant().to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proof::check;

    #[test]
    fn a_proof_of_the_spheres_constant_checks_and_a_lower_one_is_refused() {
        let claim = |c: &str| Claim::Lipschitz {
            constant: c.into(),
            region: [-1.0, -1.0, -1.0, 1.0, 1.0, 1.0],
        };
        let proof = prove("x^2+y^2+z^2-1", claim("2*sqrt(3)*1.01"), 100_000).unwrap();
        let checked = check(&proof).unwrap();
        assert!(checked.proved && checked.largest <= checked.constant.inf());
        // 2√3 is the true maximum, at the corners: the natural extension
        // never gets below it there, however small the piece.
        assert!(matches!(
            prove("x^2+y^2+z^2-1", claim("3.4"), 10_000),
            Err(ProveError::TooManyPieces(_) | ProveError::Unsplittable(..))
        ));
    }
}
