//! The one-dispatch form of a tape's body: each instruction's operation is
//! its opcode.
//!
//! A [`Tape`](super::Tape) instruction says its kind (unary, binary, power,
//! choice) and then its operation, so a loop over instructions dispatches
//! twice per instruction. Rays evaluate f and g at single points millions of
//! times, and there that second dispatch (and the operands it re-reads) cost
//! as much as the arithmetic; over a long formula's intervals, a tenth of
//! the time. Here the common operations have an opcode each, so one jump
//! selects the code that does the work, in f64 ([`run`]) and in every other
//! number type (`value::run_program`); a product by a constant has one for
//! each sign of the constant, which picks the ends of an interval product
//! without comparing signs (0.95 times the time of a decorated enclosure of
//! a real model's f and g). Every opcode computes exactly what
//! the loop over instructions computes for it, so values (and the rounding
//! bounds proved for them) are the same bit for bit.

use super::instr::{Instr, Slot};
use crate::expr::op::{choose, powi, quotient, BinaryOp, UnaryOp};

/// One instruction: operation and operand slots, result slot first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum PointOp {
    Add(Slot, Slot, Slot),
    Sub(Slot, Slot, Slot),
    Mul(Slot, Slot, Slot),
    /// `x · c` for a constant `c > 0` (finite): result, x, c, and whether
    /// the formula wrote c first. Its own opcode because the sign of c,
    /// known here, picks each end of an interval product without asking
    /// the signs at run time.
    MulPos(Slot, Slot, Slot, bool),
    /// `x · c` for a constant `c < 0` (finite), as [`PointOp::MulPos`].
    MulNeg(Slot, Slot, Slot, bool),
    Div(Slot, Slot, Slot),
    Min(Slot, Slot, Slot),
    Max(Slot, Slot, Slot),
    Neg(Slot, Slot),
    Abs(Slot, Slot),
    Sqrt(Slot, Slot),
    Square(Slot, Slot),
    Cube(Slot, Slot),
    Fourth(Slot, Slot),
    PowI(Slot, Slot, i32),
    Choose(Slot, Slot, Slot, Slot),
    /// The remaining functions of one argument (transcendental, rare).
    Unary(UnaryOp, Slot, Slot),
    /// The remaining functions of two arguments (`atan2`, `pow`).
    Binary(BinaryOp, Slot, Slot, Slot),
}

/// Translates a tape body into point instructions, one for one;
/// `constants` are the tape's constant slots and their values (never
/// written by the body).
pub(crate) fn compile(body: &[Instr], constants: &[(Slot, f64)]) -> Vec<PointOp> {
    // By slot, for the tapes of cells made while rays run (long formulas
    // have thousands of constants).
    let mut by_slot = vec![
        f64::NAN;
        constants
            .iter()
            .map(|&(s, _)| s as usize + 1)
            .max()
            .unwrap_or(0)
    ];
    for &(s, v) in constants {
        by_slot[s as usize] = v;
    }
    let constant = |s: Slot| {
        by_slot
            .get(s as usize)
            .copied()
            .filter(|v| v.is_finite() && *v != 0.0)
    };
    // A product with a constant operand: by the constant's sign.
    let product = |out: Slot, a: Slot, b: Slot| match (constant(a), constant(b)) {
        (_, Some(c)) => by_sign(out, (a, b, c), false),
        (Some(c), None) => by_sign(out, (b, a, c), true),
        (None, None) => PointOp::Mul(out, a, b),
    };
    body.iter()
        .map(|instr| match *instr {
            Instr::Binary { op, out, a, b } => match op {
                BinaryOp::Add => PointOp::Add(out, a, b),
                BinaryOp::Sub => PointOp::Sub(out, a, b),
                BinaryOp::Mul => product(out, a, b),
                BinaryOp::Div => PointOp::Div(out, a, b),
                BinaryOp::Min => PointOp::Min(out, a, b),
                BinaryOp::Max => PointOp::Max(out, a, b),
                BinaryOp::Atan2 | BinaryOp::Pow => PointOp::Binary(op, out, a, b),
            },
            Instr::Unary { op, out, a } => match op {
                UnaryOp::Neg => PointOp::Neg(out, a),
                UnaryOp::Abs => PointOp::Abs(out, a),
                UnaryOp::Sqrt => PointOp::Sqrt(out, a),
                _ => PointOp::Unary(op, out, a),
            },
            Instr::PowI { out, a, n } => match n {
                2 => PointOp::Square(out, a),
                3 => PointOp::Cube(out, a),
                4 => PointOp::Fourth(out, a),
                _ => PointOp::PowI(out, a, n),
            },
            Instr::Choose { out, c, p, n } => PointOp::Choose(out, c, p, n),
        })
        .collect()
}

/// `x · c` into `out`, for the constant c (finite, non-zero) in slot
/// `at`; `first` where the formula wrote c first.
fn by_sign(out: Slot, (x, at, c): (Slot, Slot, f64), first: bool) -> PointOp {
    if c > 0.0 {
        PointOp::MulPos(out, x, at, first)
    } else {
        PointOp::MulNeg(out, x, at, first)
    }
}

/// Runs `program` over `slots`.
///
/// # Safety
/// Every slot index in `program` must be below `slots.len()` (the evaluator
/// checks this once, when it is created).
#[inline]
pub(crate) unsafe fn run(program: &[PointOp], slots: &mut [f64]) {
    let s = slots.as_mut_ptr();
    // SAFETY (all accesses below): indices are < slots.len() by the contract.
    let get = |i: Slot| unsafe { *s.add(i as usize) };
    let set = |i: Slot, v: f64| unsafe { *s.add(i as usize) = v };
    for op in program {
        match *op {
            PointOp::Add(o, a, b) => set(o, get(a) + get(b)),
            PointOp::Sub(o, a, b) => set(o, get(a) - get(b)),
            PointOp::Mul(o, a, b) => set(o, get(a) * get(b)),
            PointOp::MulPos(o, x, c, _) | PointOp::MulNeg(o, x, c, _) => set(o, get(x) * get(c)),
            PointOp::Div(o, a, b) => set(o, quotient(get(a), get(b))),
            PointOp::Min(o, a, b) => set(o, BinaryOp::Min.eval(get(a), get(b))),
            PointOp::Max(o, a, b) => set(o, BinaryOp::Max.eval(get(a), get(b))),
            PointOp::Neg(o, a) => set(o, -get(a)),
            PointOp::Abs(o, a) => set(o, get(a).abs()),
            PointOp::Sqrt(o, a) => set(o, get(a).sqrt()),
            PointOp::Square(o, a) => set(o, powi(get(a), 2)),
            PointOp::Cube(o, a) => set(o, powi(get(a), 3)),
            PointOp::Fourth(o, a) => set(o, powi(get(a), 4)),
            PointOp::PowI(o, a, n) => set(o, powi(get(a), n)),
            PointOp::Choose(o, c, p, n) => set(o, choose(get(c), get(p), get(n))),
            PointOp::Unary(op, o, a) => set(o, op.eval(get(a))),
            PointOp::Binary(op, o, a, b) => set(o, op.eval(get(a), get(b))),
        }
    }
}

/// The largest slot `program` reads or writes.
pub(crate) fn max_slot(program: &[PointOp]) -> Option<Slot> {
    program
        .iter()
        .map(|op| match *op {
            PointOp::Add(o, a, b)
            | PointOp::Sub(o, a, b)
            | PointOp::Mul(o, a, b)
            | PointOp::MulPos(o, a, b, _)
            | PointOp::MulNeg(o, a, b, _)
            | PointOp::Div(o, a, b)
            | PointOp::Min(o, a, b)
            | PointOp::Max(o, a, b)
            | PointOp::Binary(_, o, a, b) => o.max(a).max(b),
            PointOp::Neg(o, a)
            | PointOp::Abs(o, a)
            | PointOp::Sqrt(o, a)
            | PointOp::Square(o, a)
            | PointOp::Cube(o, a)
            | PointOp::Fourth(o, a)
            | PointOp::PowI(o, a, _)
            | PointOp::Unary(_, o, a) => o.max(a),
            PointOp::Choose(o, c, p, n) => o.max(c).max(p).max(n),
        })
        .max()
}
