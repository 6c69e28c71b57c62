//! Sound Lipschitz bounds: L over a box, G over a ray segment, and branch and
//! bound that proves or refutes a hand-derived constant.

pub mod lipschitz;
pub mod verify;

pub use lipschitz::{euclidean_norm, Bound, Bounder, Sampled};
pub use verify::{verify_grad_lipschitz, verify_lipschitz, Verdict};
