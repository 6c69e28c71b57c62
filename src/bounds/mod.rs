//! Sound Lipschitz bounds: L over a box, G over a ray segment, branch and
//! bound that proves or refutes a hand-derived constant, and certified
//! brackets of the true constants.

pub mod bracket;
pub mod convergence;
pub mod lipschitz;
pub mod poly;
pub mod prove;
mod queue;
pub mod report;
pub mod tightness;
pub mod verify;

pub use bracket::{
    bracket_grad_lipschitz, bracket_grad_lipschitz_by, bracket_lipschitz, bracket_lipschitz_by,
    Bracket, MAX_PIECES,
};
pub use convergence::{applies, convergence, Convergence};
pub use lipschitz::{euclidean_norm, Bound, Bounder, Method, Sampled};
pub use prove::{certificate, prove, refute, ProveError};
pub use report::{report, Estimate, Field, Refine, Report};
pub use tightness::{tightness, MethodBound, Tightness};
pub use verify::{verify_grad_lipschitz, verify_lipschitz, Verdict};
