//! A tape shortened over a region: the branches the region decides, taken.
//!
//! Over a box where `min(a, b)` has `a ≤ b` at every point, the value of
//! `min(a, b)` is `a`'s, exactly: there the tape need not compute `b`, nor
//! anything only `b` reads. fidget and MPR (Keeter 2020) call this tape
//! simplification. [`Tape::settled_over`] finds what a box decides, by one
//! interval evaluation; [`Tape::shortened`] writes the tape without the
//! branches not taken and the code only they read, with its slots allocated
//! afresh.
//!
//! The short tape computes the same real function as the tape at every
//! point of the region, so its enclosures over any part of the region are
//! sound, with the same decorations or better (a jump no longer reachable is
//! gone). Its f64 values may differ from the tape's by rounding (`min` of
//! two rounded values is not always the rounded `a`), so a caller that
//! decides on f64 values with the tape's rounding bounds keeps evaluating
//! the tape for those.

use super::instr::{Instr, Slot};
use super::value::{
    binary_leaves, choose_leaves, note, powi_leaves, register_file, run_portable, take_lost,
    unary_leaves, TapeValue,
};
#[cfg(feature = "jit")]
use super::MachineCode;
use super::{point, Tape};
use crate::expr::op::{BinaryOp, UnaryOp, Var};
use crate::types::{DecInterval, Decoration, Interval};

/// How a region settles one branching instruction of a tape's body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Settled {
    /// Its value is its operand's: `min`/`max` (0: `a`, 1: `b`), `abs`
    /// (0: `a`), `choose` (1: `p`, 2: `n`).
    Operand(u8),
    /// `abs` of an operand that is at most 0: its negation.
    Negated,
    /// `sign` (±1) or `dirac` (0) of an operand away from 0: a constant.
    Constant(i8),
}

/// The branching instructions a region settles, by their index in the body,
/// in order: two regions with equal lists get the same short tape.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct Decisions(Vec<(u32, Settled)>);

impl Decisions {
    /// How many branching instructions are settled.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether the region settles none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// An enclosure a decision may rest on: defined on the whole region (a
/// `min` or `max` is undefined where either operand is, so a branch that
/// is dropped must not take with it where the formula is undefined; a
/// `choose` needs only its condition firm). It may be unbounded: a branch
/// dropped is never evaluated, and one compared is compared as an
/// extended real.
fn firm(v: DecInterval) -> bool {
    v.decoration() != Decoration::Trv && !v.interval().is_empty()
}

/// Whether `instr` is one a region may decide: `min`, `max`, `abs`,
/// `sign`, `dirac` or `choose`.
fn is_branch(instr: &Instr) -> bool {
    match *instr {
        Instr::Binary { op, .. } => matches!(op, BinaryOp::Min | BinaryOp::Max),
        Instr::Unary { op, .. } => matches!(op, UnaryOp::Abs | UnaryOp::Sign | UnaryOp::Dirac),
        Instr::Choose { .. } => true,
        Instr::PowI { .. } => false,
    }
}

/// A `min`/`max` that takes its first operand where `first` holds, its
/// second where `second` does, else is open.
fn either(first: bool, second: bool) -> Option<Settled> {
    match (first, second) {
        (true, _) => Some(Settled::Operand(0)),
        (_, true) => Some(Settled::Operand(1)),
        _ => None,
    }
}

/// How `instr` goes for operands enclosed by `slots`, if it is a branch the
/// enclosures decide.
fn settle(instr: &Instr, slots: &[DecInterval]) -> Option<Settled> {
    let at = |s: Slot| slots[s as usize];
    match *instr {
        Instr::Binary { op, a, b, .. } if matches!(op, BinaryOp::Min | BinaryOp::Max) => {
            let (a, b) = (at(a), at(b));
            if !firm(a) || !firm(b) {
                return None;
            }
            min_max_way(op, a.interval(), b.interval())
        }
        Instr::Unary { op, a, .. } => {
            let a = at(a);
            if !firm(a) {
                return None;
            }
            unary_way(op, a.interval())
        }
        Instr::Choose { c, .. } => {
            // Unlike `min` and `max`, `choose` is `p` wherever `c < 0`,
            // whatever `n` is (and `n` wherever `c > 0`): no evaluator
            // reads the branch not taken, so dropping it changes no value,
            // even where that branch is undefined. That is where it counts:
            // g's `choose(a − b, a′, b′)` for `min(a, b)` must drop `b′`
            // where `b` is a root of squares whose derivative is undefined
            // at its centre, or every `choose` after it in a chain of
            // `min`s stays open.
            let c = at(c);
            if !firm(c) {
                return None;
            }
            choose_way(c.interval())
        }
        _ => None,
    }
}

/// How `min` or `max` (`op`) of operands enclosed by firm `a` and `b` goes,
/// if they decide it.
#[inline(always)]
fn min_max_way(op: BinaryOp, a: Interval, b: Interval) -> Option<Settled> {
    if op == BinaryOp::Min {
        either(a.sup() <= b.inf(), b.sup() <= a.inf())
    } else {
        either(a.inf() >= b.sup(), b.inf() >= a.sup())
    }
}

/// How `abs`, `sign` or `dirac` (`op`) of an operand enclosed by a firm `a`
/// goes, if it decides it (no other function is a branch).
#[inline(always)]
fn unary_way(op: UnaryOp, a: Interval) -> Option<Settled> {
    match op {
        UnaryOp::Abs if a.inf() >= 0.0 => Some(Settled::Operand(0)),
        UnaryOp::Abs if a.sup() <= 0.0 => Some(Settled::Negated),
        UnaryOp::Sign if a.inf() > 0.0 => Some(Settled::Constant(1)),
        UnaryOp::Sign if a.sup() < 0.0 => Some(Settled::Constant(-1)),
        UnaryOp::Dirac if a.inf() > 0.0 || a.sup() < 0.0 => Some(Settled::Constant(0)),
        _ => None,
    }
}

/// How `choose(c, p, n)` goes for a firm enclosure `c` of its condition
/// (and firm ones of its branches), if it decides it.
#[inline(always)]
fn choose_way(c: Interval) -> Option<Settled> {
    if c.sup() < 0.0 {
        Some(Settled::Operand(1))
    } else if c.inf() > 0.0 {
        Some(Settled::Operand(2))
    } else {
        None
    }
}

/// An interval whose evaluation notes the way of each branching operation
/// it meets, in order, for settling a body at the speed of a plain
/// evaluation: where no operation of the run lost its arguments'
/// decoration ([`take_lost`]) and the inputs are defined and continuous,
/// every enclosure is [`firm`], so the ways noted are [`settle`]'s.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Settling(pub(crate) Interval);

thread_local! {
    /// The ways of the branching operations [`Settling`] values met on this
    /// thread, in order (`None` where open), since it was last cleared.
    static WAYS: std::cell::RefCell<Vec<Option<Settled>>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// Forgets the ways noted on this thread.
pub(crate) fn forget_ways() {
    WAYS.with(|w| w.borrow_mut().clear());
}

/// Whether every way noted on this thread since [`forget_ways`] is settled.
pub(crate) fn ways_settled() -> bool {
    WAYS.with(|w| w.borrow().iter().all(Option::is_some))
}

/// Notes the way of the next branching operation.
#[inline(always)]
fn note_way(way: Option<Settled>) {
    WAYS.with(|w| w.borrow_mut().push(way));
}

impl TapeValue for Settling {
    fn constant(v: f64) -> Self {
        Settling(Interval::point(v))
    }

    #[inline(always)]
    fn unary(op: UnaryOp, a: Self) -> Self {
        if matches!(op, UnaryOp::Abs | UnaryOp::Sign | UnaryOp::Dirac) {
            note_way(unary_way(op, a.0));
        }
        let image = Interval::unary(op, a.0);
        note(unary_leaves(op, a.0, image));
        Settling(image)
    }

    #[inline(always)]
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        if matches!(op, BinaryOp::Min | BinaryOp::Max) {
            note_way(min_max_way(op, a.0, b.0));
        }
        let (image, leaves) = binary_leaves(op, a.0, b.0);
        note(leaves);
        Settling(image)
    }

    #[inline(always)]
    fn powi(a: Self, n: i32) -> Self {
        let image = a.0.powi(n);
        note(powi_leaves(n, a.0, image));
        Settling(image)
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        note_way(choose_way(c.0));
        note(choose_leaves(c.0, p.0, n.0));
        Settling(Interval::choose(c.0, p.0, n.0))
    }
}

/// How `instr` goes for the f64 operands in `slots`, if it is a branch
/// they decide (a tie, or a NaN, decides nothing).
fn settle_point(instr: &Instr, slots: &[f64]) -> Option<Settled> {
    let at = |s: Slot| slots[s as usize];
    match *instr {
        Instr::Binary { op, a, b, .. } if matches!(op, BinaryOp::Min | BinaryOp::Max) => {
            let (a, b) = (at(a), at(b));
            if op == BinaryOp::Min {
                either(a < b, b < a)
            } else {
                either(a > b, b > a)
            }
        }
        Instr::Unary { op, a, .. } => {
            let a = at(a);
            match op {
                UnaryOp::Abs if a > 0.0 => Some(Settled::Operand(0)),
                UnaryOp::Abs if a < 0.0 => Some(Settled::Negated),
                UnaryOp::Sign if a > 0.0 => Some(Settled::Constant(1)),
                UnaryOp::Sign if a < 0.0 => Some(Settled::Constant(-1)),
                UnaryOp::Dirac if a != 0.0 && !a.is_nan() => Some(Settled::Constant(0)),
                _ => None,
            }
        }
        Instr::Choose { c, p, n, .. } => {
            let (c, p, n) = (at(c), at(p), at(n));
            if p.is_nan() || n.is_nan() {
                None
            } else if c < 0.0 {
                Some(Settled::Operand(1))
            } else if c > 0.0 {
                Some(Settled::Operand(2))
            } else {
                None
            }
        }
        _ => None,
    }
}

/// A value of the short tape: a slot the tape fills before its body runs
/// (an input, a constant, a constant subexpression), a kept body
/// instruction's result, or a constant a decision made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Value {
    Fixed(Slot),
    Body(u32),
    Constant(i8),
}

/// A kept body instruction, its operands as values.
#[derive(Debug, Clone, Copy)]
struct Kept {
    /// The instruction (its slots are rewritten when it is emitted).
    instr: Instr,
    operands: [Value; 3],
    arity: usize,
}

/// [`Tape::settled_over`]'s loop compiled for CPUs with FMA, as the tape
/// loop is (each directed rounding of a product one instruction).
///
/// # Safety
/// The CPU has FMA, and [`settle_portable`]'s contract holds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn settle_with_fma(
    body: &[Instr],
    slots: &mut [DecInterval],
    stop_at_open: bool,
) -> Option<Decisions> {
    // SAFETY: the caller's contract.
    unsafe { settle_portable(body, slots, stop_at_open) }
}

/// The first output of a tape with none: an enclosure that claims nothing.
const NOTHING_KNOWN: DecInterval = DecInterval::new(Interval::ENTIRE, Decoration::Trv);

/// `body` run on `slots` (the register file of its tape, inputs in place),
/// each branching instruction's way noted; `None` at the first open one if
/// `stop_at_open`.
///
/// # Safety
/// Every slot `body` names is below `slots.len()`.
unsafe fn settle_slots(
    body: &[Instr],
    slots: &mut [DecInterval],
    stop_at_open: bool,
) -> Option<Decisions> {
    #[cfg(target_arch = "x86_64")]
    if crate::types::rounding::has_fma() {
        // SAFETY: the CPU has FMA; the rest is the caller's contract.
        return unsafe { settle_with_fma(body, slots, stop_at_open) };
    }
    // SAFETY: the caller's contract.
    unsafe { settle_portable(body, slots, stop_at_open) }
}

/// The body run on `slots`, each branching instruction's way noted; `None`
/// at the first open one if `stop_at_open`.
///
/// # Safety
/// Every slot `body` names is below `slots.len()`.
#[inline(always)]
unsafe fn settle_portable(
    body: &[Instr],
    slots: &mut [DecInterval],
    stop_at_open: bool,
) -> Option<Decisions> {
    let mut decisions = Vec::new();
    for (i, instr) in body.iter().enumerate() {
        match settle(instr, slots) {
            Some(settled) => decisions.push((i as u32, settled)),
            None if stop_at_open && is_branch(instr) => return None,
            None => {}
        }
        // SAFETY: the caller's contract.
        unsafe { run_portable(std::slice::from_ref(instr), slots) };
    }
    Some(Decisions(decisions))
}

/// `instr` writing `out` and reading `operands`.
fn with_slots(instr: &Instr, out: Slot, operands: [Slot; 3]) -> Instr {
    let [a, b, c] = operands;
    match *instr {
        Instr::Unary { op, .. } => Instr::Unary { op, out, a },
        Instr::PowI { n, .. } => Instr::PowI { out, a, n },
        Instr::Binary { op, .. } => Instr::Binary { op, out, a, b },
        Instr::Choose { .. } => Instr::Choose {
            out,
            c: a,
            p: b,
            n: c,
        },
    }
}

impl Tape {
    /// Whether the body holds an instruction a region may decide (else
    /// [`Tape::settled_over`] is always empty).
    pub fn has_branches(&self) -> bool {
        self.body.iter().any(is_branch)
    }

    /// The branching instructions (`min`, `max`, `abs`, `sign`, `dirac`,
    /// `choose`) whose way the region `inputs` encloses decides, by one
    /// decorated interval evaluation of the body.
    pub fn settled_over(&self, inputs: &[DecInterval; 6]) -> Decisions {
        self.settled_and_first_over(inputs).0
    }

    /// [`Tape::settled_over`], with the first output's decorated enclosure
    /// over the region, which the same run computes.
    pub fn settled_and_first_over(&self, inputs: &[DecInterval; 6]) -> (Decisions, DecInterval) {
        self.settle_body(inputs, false)
            .expect("only a stop at an open branch gives none")
    }

    /// [`Tape::settled_over`] where the region settles every branching
    /// instruction, else `None`, found at the first one left open (the rest
    /// of the body is not evaluated).
    pub fn settled_all_over(&self, inputs: &[DecInterval; 6]) -> Option<Decisions> {
        self.settle_body(inputs, true).map(|(d, _)| d)
    }

    /// The branching instructions the point `inputs` settles, found on f64
    /// values: [`Tape::settled_over`] at a point without intervals, several
    /// times cheaper, and a guide only (a rounded comparison may go the
    /// other way than the exact one; a tie leaves the branch open).
    pub fn settled_at(&self, inputs: &[f64; 6]) -> Decisions {
        let mut slots: Vec<f64> = register_file(self);
        slots[..Var::ALL.len()].copy_from_slice(inputs);
        let mut decisions = Vec::new();
        for (i, instr) in self.body.iter().enumerate() {
            if let Some(settled) = settle_point(instr, &slots) {
                decisions.push((i as u32, settled));
            }
            // SAFETY: `register_file` checked every slot of the body
            // against the register file.
            unsafe { run_portable(std::slice::from_ref(instr), &mut slots) };
        }
        Decisions(decisions)
    }

    /// The body run on `inputs`, each branching instruction's way noted,
    /// and the first output; `None` at the first open one if
    /// `stop_at_open`.
    fn settle_body(
        &self,
        inputs: &[DecInterval; 6],
        stop_at_open: bool,
    ) -> Option<(Decisions, DecInterval)> {
        match self.settle_quickly(inputs, stop_at_open) {
            Some(settled) => settled,
            None => self.settle_decorated(inputs, stop_at_open),
        }
    }

    /// [`Tape::settle_body`] by a decorated run of the body, instruction by
    /// instruction.
    fn settle_decorated(
        &self,
        inputs: &[DecInterval; 6],
        stop_at_open: bool,
    ) -> Option<(Decisions, DecInterval)> {
        let mut slots: Vec<DecInterval> = register_file(self);
        slots[..Var::ALL.len()].copy_from_slice(inputs);
        // SAFETY: `register_file` checked every slot of the body against
        // the register file.
        let decisions = unsafe { settle_slots(&self.body, &mut slots, stop_at_open)? };
        let first = self.outputs.first().map(|&o| slots[o as usize]);
        Some((decisions, first.unwrap_or(NOTHING_KNOWN)))
    }

    /// [`Tape::settle_body`] by one plain run of the body in [`Settling`]
    /// values, where the inputs are defined and continuous: `None` where
    /// some operation may have lost a decoration, and the decorated run
    /// must decide.
    fn settle_quickly(
        &self,
        inputs: &[DecInterval; 6],
        stop_at_open: bool,
    ) -> Option<Option<(Decisions, DecInterval)>> {
        let plain = |v: &DecInterval| v.decoration() == Decoration::Dac && !v.interval().is_empty();
        if !inputs.iter().all(plain) {
            return None;
        }
        take_lost();
        // The prelude's constants may lose a decoration (noted), and may
        // meet branches, which are not the body's (forgotten).
        let mut slots: Vec<Settling> = register_file(self);
        forget_ways();
        for (slot, v) in slots.iter_mut().zip(inputs) {
            *slot = Settling(v.interval());
        }
        Settling::run_body(self, &mut slots);
        if take_lost() {
            return None;
        }
        WAYS.with(|w| {
            let ways = w.borrow();
            if stop_at_open && ways.iter().any(Option::is_none) {
                return Some(None);
            }
            let branches = self.body.iter().enumerate().filter(|(_, i)| is_branch(i));
            debug_assert_eq!(branches.clone().count(), ways.len());
            let decisions = branches
                .zip(ways.iter())
                .filter_map(|((i, _), way)| way.map(|w| (i as u32, w)))
                .collect();
            // Nothing lost from defined, continuous inputs: every value is.
            let first = self.outputs.first().map(|&o| slots[o as usize].0);
            let first = first.map_or(NOTHING_KNOWN, |v| DecInterval::new(v, Decoration::Dac));
            Some(Some((Decisions(decisions), first)))
        })
    }

    /// Whether a branching instruction that `decisions` (from
    /// [`Tape::settled_over`] on this tape) leaves open is still read by an
    /// output once the settled ones are taken: exactly when
    /// [`Tape::shortened`] would keep a branch, found by one backward pass
    /// over the slots without writing the tape.
    pub fn leaves_open(&self, decisions: &Decisions) -> bool {
        self.each_reached(decisions, self.outputs.iter(), |instr, settled| {
            settled.is_none() && is_branch(instr)
        })
    }

    /// The body instructions of [`Tape::shortened`]`(decisions)`, found by
    /// the same backward pass (as [`Tape::leaves_open`]): a few times
    /// cheaper, for a caller that keeps only short enough tapes.
    pub fn shortened_len(&self, decisions: &Decisions) -> usize {
        let mut len = 0;
        self.each_reached(decisions, self.outputs.iter(), |_, settled| {
            // A settled instruction becomes an operand or a constant, but a
            // negation stays an instruction.
            len += usize::from(matches!(settled, None | Some(Settled::Negated)));
            false
        });
        len
    }

    /// Each body instruction one of `outputs` still reads once `decisions` are
    /// taken, last first, with its decision, by one backward pass over the
    /// slots; stops, and says so, where `visit` says to.
    fn each_reached<'a>(
        &self,
        decisions: &Decisions,
        outputs: impl Iterator<Item = &'a Slot>,
        mut visit: impl FnMut(&Instr, Option<Settled>) -> bool,
    ) -> bool {
        let mut live = vec![false; self.slot_count];
        for &o in outputs {
            live[o as usize] = true;
        }
        let mut next = decisions.0.iter().rev().peekable();
        for (i, instr) in self.body.iter().enumerate().rev() {
            let settled = next.next_if(|&&(k, _)| k as usize == i).map(|&(_, s)| s);
            let out = instr.out() as usize;
            if !live[out] {
                continue;
            }
            live[out] = false;
            let (reads, count) = instr.reads();
            match settled {
                None => reads[..count].iter().for_each(|&r| live[r as usize] = true),
                Some(Settled::Operand(k)) => live[reads[k as usize] as usize] = true,
                Some(Settled::Negated) => live[reads[0] as usize] = true,
                Some(Settled::Constant(_)) => {}
            }
            if visit(instr, settled) {
                return true;
            }
        }
        false
    }

    /// The tape with `decisions` (from [`Tape::settled_over`] on this tape)
    /// taken: each settled instruction replaced by the operand, negation or
    /// constant it comes to, and every instruction no output then reads
    /// removed. Equal to this tape, as a real function, over the region the
    /// decisions were found on.
    pub fn shortened(&self, decisions: &Decisions) -> Tape {
        self.shortened_keeping(decisions, &vec![true; self.outputs.len()])
    }

    /// The tape of only the outputs `keep` marks (in order), with the code
    /// only the others read removed: the same operations on the same
    /// values for the outputs kept.
    ///
    /// # Panics
    /// When `keep` does not have one entry per output.
    pub fn keeping(&self, keep: &[bool]) -> Tape {
        self.shortened_keeping(&Decisions::default(), keep)
    }

    /// The body instructions of [`Tape::keeping`]`(keep)`, by one backward
    /// pass that writes nothing.
    ///
    /// # Panics
    /// When `keep` does not have one entry per output.
    pub fn keeping_len(&self, keep: &[bool]) -> usize {
        assert_eq!(keep.len(), self.outputs.len(), "one entry per output");
        let kept = self.outputs.iter().zip(keep).filter(|(_, &k)| k);
        let mut len = 0;
        self.each_reached(&Decisions::default(), kept.map(|(o, _)| o), |_, _| {
            len += 1;
            false
        });
        len
    }

    /// [`Tape::shortened`] with only the outputs `keep` marks (in order):
    /// the code only the others read goes too.
    ///
    /// # Panics
    /// When `keep` does not have one entry per output.
    pub fn shortened_keeping(&self, decisions: &Decisions, keep: &[bool]) -> Tape {
        assert_eq!(keep.len(), self.outputs.len(), "one entry per output");
        // Forward: each body instruction's value, in terms of kept ones.
        let mut current: Vec<Value> = (0..self.slot_count as Slot).map(Value::Fixed).collect();
        let mut kept: Vec<Option<Kept>> = Vec::with_capacity(self.body.len());
        let mut next = decisions.0.iter().peekable();
        for (i, instr) in self.body.iter().enumerate() {
            let settled = next.next_if(|(k, _)| *k as usize == i).map(|&(_, s)| s);
            let (slots, arity) = instr.reads();
            let operands = slots.map(|s| current[s as usize]);
            let (value, keep) = match settled {
                None => (
                    Value::Body(i as u32),
                    Some(Kept {
                        instr: *instr,
                        operands,
                        arity,
                    }),
                ),
                Some(Settled::Operand(k)) => (operands[usize::from(k)], None),
                Some(Settled::Negated) => (
                    Value::Body(i as u32),
                    Some(Kept {
                        instr: Instr::Unary {
                            op: UnaryOp::Neg,
                            out: 0,
                            a: 0,
                        },
                        operands,
                        arity: 1,
                    }),
                ),
                Some(Settled::Constant(c)) => (Value::Constant(c), None),
            };
            kept.push(keep);
            current[instr.out() as usize] = value;
        }
        let outputs: Vec<Value> = self
            .outputs
            .iter()
            .zip(keep)
            .filter(|&(_, &k)| k)
            .map(|(&s, _)| current[s as usize])
            .collect();

        // Backward: the kept instructions some output reads.
        let mut live = vec![false; kept.len()];
        for v in &outputs {
            if let Value::Body(i) = *v {
                live[i as usize] = true;
            }
        }
        for i in (0..kept.len()).rev() {
            if !live[i] {
                continue;
            }
            if let Some(k) = &kept[i] {
                for v in &k.operands[..k.arity] {
                    if let Value::Body(j) = *v {
                        live[j as usize] = true;
                    }
                }
            }
        }

        // Emit: the inputs keep their slots; the constants and prelude values
        // the kept code reads get the next ones, in their order (a long
        // formula's others would ride along in every short tape, and in the
        // register file of every evaluator of one); decided constants and
        // body values get slots past them, body slots reused once dead.
        let mut used = vec![false; self.slot_count];
        let fixed_reads = kept
            .iter()
            .zip(&live)
            .filter_map(|(k, &live)| k.as_ref().filter(|_| live))
            .flat_map(|k| k.operands[..k.arity].iter().copied())
            .chain(outputs.iter().copied());
        for v in fixed_reads {
            if let Value::Fixed(s) = v {
                used[s as usize] = true;
            }
        }
        for instr in self.prelude.iter().rev() {
            if used[instr.out() as usize] {
                let (reads, arity) = instr.reads();
                for &s in &reads[..arity] {
                    used[s as usize] = true;
                }
            }
        }
        let mut fixed_slot = vec![Slot::MAX; self.slot_count];
        for (s, slot) in fixed_slot.iter_mut().enumerate().take(Var::ALL.len()) {
            *slot = s as Slot;
        }
        let mut next_slot = Var::ALL.len() as Slot;
        let mut renumber = |s: Slot, fixed_slot: &mut [Slot]| {
            fixed_slot[s as usize] = next_slot;
            next_slot += 1;
            next_slot - 1
        };
        let mut constants = Vec::new();
        for &(s, v) in &self.constants {
            if used[s as usize] && fixed_slot[s as usize] == Slot::MAX {
                constants.push((renumber(s, &mut fixed_slot), v));
            }
        }
        let mut prelude = Vec::new();
        for instr in &self.prelude {
            if used[instr.out() as usize] {
                let (reads, _) = instr.reads();
                let reads = reads.map(|r| fixed_slot[r as usize]);
                let out = renumber(instr.out(), &mut fixed_slot);
                prelude.push(with_slots(instr, out, reads));
            }
        }
        let mut constant_slots: [Option<Slot>; 3] = [None; 3];
        // The slot of the decided constant c (−1, 0 or 1), made on first use.
        let mut constant_slot = |c: i8| {
            constant_slots[(c + 1) as usize].get_or_insert_with(|| {
                let s = next_slot;
                next_slot += 1;
                constants.push((s, f64::from(c)));
                s
            });
        };
        let mut last_use = vec![usize::MAX; kept.len()];
        for (i, k) in kept.iter().enumerate() {
            let Some(k) = k.as_ref().filter(|_| live[i]) else {
                continue;
            };
            for v in &k.operands[..k.arity] {
                match *v {
                    Value::Body(j) => last_use[j as usize] = i,
                    Value::Constant(c) => constant_slot(c),
                    Value::Fixed(_) => {}
                }
            }
        }
        for v in &outputs {
            if let Value::Constant(c) = *v {
                constant_slot(c);
            }
        }
        let mut pinned = vec![false; kept.len()];
        for v in &outputs {
            if let Value::Body(i) = *v {
                pinned[i as usize] = true;
            }
        }
        let mut slot_of = vec![Slot::MAX; kept.len()];
        let slot = |v: Value, slot_of: &[Slot]| match v {
            Value::Fixed(s) => fixed_slot[s as usize],
            Value::Body(j) => slot_of[j as usize],
            Value::Constant(c) => constant_slots[(c + 1) as usize].expect("constant slot"),
        };
        let mut free: Vec<Slot> = Vec::new();
        let mut body = Vec::new();
        for (i, k) in kept.iter().enumerate() {
            let Some(k) = k.as_ref().filter(|_| live[i]) else {
                continue;
            };
            let operands = k.operands.map(|v| slot(v, &slot_of));
            // The result's slot is taken before the dying operands' are
            // freed, so no instruction writes a slot it reads (as
            // `Tape::new` allocates).
            let out = free.pop().unwrap_or_else(|| {
                let s = next_slot;
                next_slot += 1;
                s
            });
            body.push(with_slots(&k.instr, out, operands));
            slot_of[i] = out;
            let mut dying: [u32; 3] = [u32::MAX; 3];
            for (d, v) in dying.iter_mut().zip(&k.operands[..k.arity]) {
                if let Value::Body(j) = *v {
                    if last_use[j as usize] == i && !pinned[j as usize] {
                        *d = j;
                    }
                }
            }
            dying.sort_unstable();
            for (n, &j) in dying.iter().enumerate() {
                if j != u32::MAX && (n == 0 || dying[n - 1] != j) {
                    free.push(slot_of[j as usize]);
                }
            }
        }
        let point = point::compile(&body, &constants);
        let mut tape = Tape {
            slot_count: next_slot as usize,
            constants,
            inputs: self.inputs.clone(),
            prelude,
            point,
            body,
            outputs: outputs.iter().map(|&v| slot(v, &slot_of)).collect(),
            keeps_decoration: Vec::new(),
            #[cfg(feature = "jit")]
            machine_code: MachineCode::default(),
            slots_fit: std::sync::OnceLock::new(),
        };
        tape.keeps_decoration = tape.judge_decorations();
        tape
    }
}

#[cfg(test)]
pub(crate) mod tests;
