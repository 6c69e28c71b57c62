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
//!
//! ```
//! use lgc::proof::{check, Claim, Proof};
//! let claim = Claim::Lipschitz {
//!     constant: "140".into(),
//!     region: [-3.0, -3.0, -3.0, 3.0, 3.0, 3.0],
//! };
//! let tangle = "x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8";
//! let proof = lgc::bounds::prove(tangle, claim, 100_000).unwrap();
//! let text = proof.to_json();
//! let checked = check(&Proof::from_json(&text).unwrap()).unwrap();
//! assert!(checked.proved && checked.largest <= 140.0);
//! ```

pub mod check;
pub mod format;
pub mod terms;

pub use check::{check, Checked, Quantity, Rejection};
pub use format::{Claim, Entry, Outcome, Proof, ProofFileError};
