//! Expression graphs: the hash-consed [`Context`], symbolic derivatives, CSG
//! builders, printing, and the compiled [`Tape`] with its evaluators.

pub mod along;
pub mod context;
pub mod csg;
mod deriv;
mod jit;
pub mod op;
mod point;
pub mod print;
pub mod rounding;
pub mod specialize;
pub mod tape;

pub use context::Context;
pub use op::{BinaryOp, Node, Op, UnaryOp, Var};
pub use print::to_source;
pub use rounding::RoundingBound;
pub use tape::{BatchEvaluator, DecoratedEvaluator, Evaluator, PointEvaluator, Tape, TapeValue};
