//! Compilation of expression graphs to a flat, register-allocated [`Tape`].
//!
//! A tape computes several outputs at once (say f, ∇f, g and g′), sharing
//! every common subexpression. Instructions are in topological order and write
//! to numbered slots that are reused once their value is dead, so the working
//! set stays small. Constant subexpressions (`sqrt(2)`, `pi/3`) form a
//! *prelude* that an evaluator runs once, in its own number type, when it is
//! created; only the *body* runs per evaluation.
//!
//! [`instr`] holds the instructions, `point` their one-dispatch form,
//! [`value`] the number types a tape runs in; the evaluators are in
//! [`crate::expr::eval`], the machine-code compiler in `crate::expr::jit`.

mod compile;
pub mod instr;
pub(crate) mod point;
pub mod simplify;
pub mod value;

use super::op::{BinaryOp, UnaryOp, Var};
use instr::{Instr, Slot};
use point::PointOp;
#[cfg(feature = "jit")]
use std::any::Any;
#[cfg(feature = "jit")]
use std::sync::{Arc, OnceLock};

/// A compiled, flat program computing one or more outputs from the inputs.
#[derive(Debug, Clone)]
pub struct Tape {
    pub(crate) slot_count: usize,
    pub(crate) constants: Vec<(Slot, f64)>,
    pub(crate) inputs: Vec<(Slot, Var)>,
    pub(crate) prelude: Vec<Instr>,
    pub(crate) body: Vec<Instr>,
    /// The body with one opcode per operation, which every evaluator runs.
    pub(crate) point: Vec<PointOp>,
    pub(crate) outputs: Vec<Slot>,
    /// Per output, whether it keeps its inputs' decoration (judged once, by
    /// [`Tape::judge_decorations`]).
    pub(crate) keeps_decoration: Vec<bool>,
    /// The f64 body as machine code, compiled on first use by a point
    /// evaluator that asks for it (see [`MachineCode`]).
    #[cfg(feature = "jit")]
    pub(crate) machine_code: MachineCode,
    /// Whether every slot the instruction lists and outputs name is below
    /// `slot_count`: checked on a tape's first register file (the lists
    /// never change once it is built), not on every evaluator made.
    pub(crate) slots_fit: std::sync::OnceLock<bool>,
}

/// How hard the compiler works on a tape's machine code: tapes are compiled
/// quickly first, and again with optimisations once they have been run
/// often enough to repay them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Tier {
    /// Quick to compile (no optimisations, a single-pass register
    /// allocator), slower to run.
    Baseline,
    /// Optimised, with a backtracking register allocator: three times the
    /// compiling, a quarter less running.
    Optimised,
}

/// A tape's machine code at each [`Tier`], compiled once and shared by every
/// evaluator and thread. The tape only keeps it: what compiles and runs it
/// (the `jit` feature's compiler) is the point evaluator's business, so the
/// type is opaque here (`None` inside: not compiled for this tape).
#[cfg(feature = "jit")]
#[derive(Clone, Default)]
pub(crate) struct MachineCode([OnceLock<Option<Arc<dyn Any + Send + Sync>>>; 2]);

#[cfg(feature = "jit")]
impl MachineCode {
    /// The code at `tier`, once some evaluator has tried to compile it.
    pub(crate) fn at(&self, tier: Tier) -> &OnceLock<Option<Arc<dyn Any + Send + Sync>>> {
        &self.0[tier as usize]
    }
}

#[cfg(feature = "jit")]
impl std::fmt::Debug for MachineCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let state = |tier| match self.at(tier).get() {
            None => "not yet",
            Some(None) => "no",
            Some(Some(_)) => "yes",
        };
        f.debug_struct("MachineCode")
            .field("baseline", &state(Tier::Baseline))
            .field("optimised", &state(Tier::Optimised))
            .finish()
    }
}

impl Tape {
    /// Whether `other` is the same program: the same constants, inputs,
    /// instructions and outputs, slot for slot (so the same function).
    pub fn same_program(&self, other: &Tape) -> bool {
        let bits = |c: &[(Slot, f64)]| c.iter().map(|&(s, v)| (s, v.to_bits())).collect::<Vec<_>>();
        self.slot_count == other.slot_count
            && self.outputs == other.outputs
            && self.inputs == other.inputs
            && self.body == other.body
            && self.prelude == other.prelude
            && bits(&self.constants) == bits(&other.constants)
    }

    /// Number of value slots an evaluator needs.
    pub fn slot_count(&self) -> usize {
        self.slot_count
    }

    /// Number of outputs.
    pub fn output_count(&self) -> usize {
        self.outputs.len()
    }

    /// The constants the register file starts with (slot and exact value).
    pub(crate) fn constants(&self) -> &[(Slot, f64)] {
        &self.constants
    }

    /// The body in f64 opcodes.
    #[cfg(feature = "jit")]
    pub(crate) fn point_program(&self) -> &[PointOp] {
        &self.point
    }

    /// The slot of each output.
    pub(crate) fn output_slots(&self) -> &[Slot] {
        &self.outputs
    }

    /// Instructions run per evaluation.
    pub fn body(&self) -> &[Instr] {
        &self.body
    }

    /// Instructions run once per evaluator (constant subexpressions).
    pub fn prelude(&self) -> &[Instr] {
        &self.prelude
    }

    /// Whether every instruction is arithmetic (`+ − × ÷`, `min`, `max`,
    /// `abs`, `sqrt`, powers, choices): no transcendental function, so each
    /// costs a few instructions a value, far less than the interpreter's
    /// dispatch of it.
    pub fn is_arithmetic(&self) -> bool {
        self.body.iter().all(|instr| match *instr {
            Instr::Unary { op, .. } => matches!(
                op,
                UnaryOp::Neg | UnaryOp::Sqrt | UnaryOp::Abs | UnaryOp::Sign | UnaryOp::Dirac
            ),
            Instr::Binary { op, .. } => !matches!(op, BinaryOp::Atan2 | BinaryOp::Pow),
            Instr::PowI { .. } | Instr::Choose { .. } => true,
        })
    }

    /// Whether the tape reads input `var`.
    pub fn uses(&self, var: Var) -> bool {
        self.inputs.iter().any(|&(_, v)| v == var)
    }

    /// Whether output `k` is defined and continuous wherever its inputs are:
    /// no operation it depends on has a restricted domain or may jump (a
    /// division, a negative power, `sqrt`, `ln`, `sign`, `choose`, ...). Its
    /// decorated evaluation then always keeps the inputs' decoration, so an
    /// undecorated one says as much for less work.
    ///
    /// ```
    /// use lgc::{BinaryOp, Context, Var, Tape};
    /// let mut ctx = Context::new();
    /// let (x, y) = (ctx.var(Var::X), ctx.var(Var::Y));
    /// let m = ctx.binary(BinaryOp::Max, x, y);
    /// let q = ctx.div(x, y);
    /// let tape = Tape::new(&ctx, &[m, q]);
    /// assert!(tape.output_keeps_decoration(0) && !tape.output_keeps_decoration(1));
    /// ```
    pub fn output_keeps_decoration(&self, k: usize) -> bool {
        self.keeps_decoration[k]
    }
}
