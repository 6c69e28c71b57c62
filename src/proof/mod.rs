//! Proof files: a claim about L (over a box) or G (along a ray segment),
//! with a certificate anyone can re-check, and the checker that re-checks it.
//!
//! A proof of `max |∇f| ≤ C` over a box is a tree of binary splits, each an
//! axis and a split point, whose leaves tile the box; each leaf records a
//! bound of |∇f| over it that follows from the natural interval extension
//! of f's derivatives alone. A proof of `max |g′| ≤ C` on a segment splits
//! t. A refutation records a witness point and a certified lower bound of
//! the quantity there, above C. `docs/bounds.md` specifies the format and
//! the rules, so that other checkers can be written from it.
//!
//! This module uses the parser and the interval type, and nothing else of
//! lgc: [`terms`] differentiates and evaluates on its own, so a mistake in
//! lgc's simplifier, tapes or bound methods cannot make a wrong proof check.

pub mod check;
pub mod format;
pub mod terms;

pub use check::{check, Checked, Quantity, Rejection};
pub use format::{Claim, Entry, Outcome, Proof, ProofFileError};
