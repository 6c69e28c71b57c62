//! Tape instructions: an operation, the slots it reads and the slot it writes.

use crate::expr::op::{BinaryOp, Node, Op, UnaryOp};

/// Index of a value slot in an evaluator's register file.
pub type Slot = u32;

/// One tape instruction.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(missing_docs)] // fields: `out` is written, the others are read
pub enum Instr {
    /// `out = op(a)`.
    Unary { op: UnaryOp, out: Slot, a: Slot },
    /// `out = op(a, b)`.
    Binary {
        op: BinaryOp,
        out: Slot,
        a: Slot,
        b: Slot,
    },
    /// `out = a^n`.
    PowI { out: Slot, a: Slot, n: i32 },
    /// `out = choose(c, p, n)`.
    Choose {
        out: Slot,
        c: Slot,
        p: Slot,
        n: Slot,
    },
}

impl Instr {
    /// The slot it writes.
    pub fn out(&self) -> Slot {
        match *self {
            Instr::Unary { out, .. }
            | Instr::Binary { out, .. }
            | Instr::PowI { out, .. }
            | Instr::Choose { out, .. } => out,
        }
    }

    /// The slots it reads, in order, and how many there are (the rest of
    /// the array repeats the last).
    pub fn reads(&self) -> ([Slot; 3], usize) {
        match *self {
            Instr::Unary { a, .. } | Instr::PowI { a, .. } => ([a; 3], 1),
            Instr::Binary { a, b, .. } => ([a, b, b], 2),
            Instr::Choose { c, p, n, .. } => ([c, p, n], 3),
        }
    }
}

/// The instruction computing `op` into `out`, its operands read from the
/// slots `slot_of` gives them (by node index; each set before it is read).
pub(crate) fn instruction(op: &Op, out: Slot, slot_of: &[Slot]) -> Instr {
    let s = |n: &Node| {
        let slot = slot_of[n.index()];
        debug_assert_ne!(slot, Slot::MAX, "an operand before its slot");
        slot
    };
    match op {
        Op::Unary(op, a) => Instr::Unary {
            op: *op,
            out,
            a: s(a),
        },
        Op::Binary(op, a, b) => Instr::Binary {
            op: *op,
            out,
            a: s(a),
            b: s(b),
        },
        Op::PowI(a, n) => Instr::PowI {
            out,
            a: s(a),
            n: *n,
        },
        Op::Choose(c, p, n) => Instr::Choose {
            out,
            c: s(c),
            p: s(p),
            n: s(n),
        },
        Op::Remap(..) => unreachable!("{}", crate::expr::context::UNEXPANDED),
        Op::Const(_) | Op::Var(_) => unreachable!("leaves have no instruction"),
    }
}

/// The largest slot any instruction reads or writes.
pub(crate) fn max_slot(instrs: &[Instr]) -> Option<Slot> {
    instrs
        .iter()
        .map(|i| match *i {
            Instr::Unary { out, a, .. } | Instr::PowI { out, a, .. } => out.max(a),
            Instr::Binary { out, a, b, .. } => out.max(a).max(b),
            Instr::Choose { out, c, p, n } => out.max(c).max(p).max(n),
        })
        .max()
}
