//! Expression graphs: the hash-consed [`Context`], symbolic derivatives, CSG
//! builders, printing, and the compiled [`Tape`] with its evaluators.

pub mod along;
pub mod context;
pub mod csg;
mod deriv;
pub mod eval;
#[cfg(feature = "jit")]
mod jit;
pub mod op;
pub mod print;
mod remap;
pub mod rounding;
pub mod slopes;
pub mod specialise;
pub mod tape;

pub use context::{Context, GraphTooLarge, MAX_NODES};
pub use eval::{BatchEvaluator, DecoratedEvaluator, Evaluator, PointEvaluator, SettlingEvaluator};
pub use op::{BinaryOp, Node, Op, UnaryOp, Var};
pub use print::to_source;
pub use rounding::RoundingBound;
pub use slopes::Slopes;
pub use tape::value::TapeValue;
pub use tape::Tape;
