//! Compilation of expression graphs to a flat, register-allocated [`Tape`].
//!
//! A tape computes several outputs at once (say f, ∇f, g and g′), sharing
//! every common subexpression. Instructions are in topological order and write
//! to numbered slots that are reused once their value is dead, so the working
//! set stays small. Constant subexpressions (`sqrt(2)`, `pi/3`) form a
//! *prelude* that an evaluator runs once, in its own number type, when it is
//! created; only the *body* runs per evaluation.

use super::context::Context;
use super::jit::Compiled;
use super::op::{choose, powi, BinaryOp, Node, Op, UnaryOp, Var};
use super::point::{self, PointOp};
use crate::types::{DecInterval, Decoration, Interval};
use std::ops::{Add, Div, Mul, Neg, Sub};
use std::sync::{Arc, OnceLock};

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

/// A compiled, flat program computing one or more outputs from the inputs.
#[derive(Debug, Clone)]
pub struct Tape {
    slot_count: usize,
    constants: Vec<(Slot, f64)>,
    inputs: Vec<(Slot, Var)>,
    prelude: Vec<Instr>,
    body: Vec<Instr>,
    /// The body with one opcode per operation, for f64 points.
    point: Vec<PointOp>,
    outputs: Vec<Slot>,
    /// Per output, whether it keeps its inputs' decoration (judged once, by
    /// [`Tape::judge_decorations`]).
    keeps_decoration: Vec<bool>,
    /// The f64 body as machine code, compiled on first use by a point
    /// evaluator that asks for it (`None` inside: not compiled here).
    compiled: OnceLock<Option<Arc<Compiled>>>,
}

impl Tape {
    /// Compiles `outputs` of `ctx` into one tape. Walks with explicit stacks.
    ///
    /// ```
    /// use lgc::{Context, Var, Tape, Evaluator};
    /// let mut ctx = Context::new();
    /// let x = ctx.var(Var::X);
    /// let f = ctx.powi(x, 2);
    /// let df = ctx.partial(f, Var::X);
    /// let tape = Tape::new(&ctx, &[f, df]);
    /// let mut eval = Evaluator::<f64>::new(&tape);
    /// assert_eq!(eval.eval(&[3.0, 0.0, 0.0, 0.0, 0.0, 0.0]), &[9.0, 6.0]);
    /// ```
    pub fn new(ctx: &Context, outputs: &[Node]) -> Tape {
        let order = ctx.topological_order(outputs);
        // Per node of the context, indexed by it (a tape is compiled per
        // specialised shape, tens of times per octree: hashing each node's
        // slot and last use was most of the compile).
        let mut slot_of: Vec<Slot> = vec![Slot::MAX; ctx.len()];
        // Slots 0..6 hold the inputs x, y, z, dx, dy, dz (read or not), so an
        // evaluation starts with one copy of six values.
        let mut next_slot: Slot = Var::ALL.len() as Slot;
        let mut fresh = || {
            let s = next_slot;
            next_slot += 1;
            s
        };
        let mut tape = Tape {
            slot_count: 0,
            constants: Vec::new(),
            inputs: Vec::new(),
            prelude: Vec::new(),
            body: Vec::new(),
            point: Vec::new(),
            outputs: Vec::new(),
            keeps_decoration: Vec::new(),
            compiled: OnceLock::new(),
        };

        // Pass 1: constants, inputs and constant subexpressions get pinned slots.
        let mut is_constant = vec![false; ctx.len()];
        let mut body_nodes = Vec::new();
        for &node in &order {
            let op = ctx.get(node);
            let constant = match op {
                Op::Const(_) => true,
                Op::Var(_) => false,
                _ => op.children().all(|c| is_constant[c.index()]),
            };
            is_constant[node.index()] = constant;
            match *op {
                Op::Const(c) => {
                    let s = fresh();
                    tape.constants.push((s, c.value()));
                    slot_of[node.index()] = s;
                }
                Op::Var(v) => {
                    let s = v.index() as Slot;
                    tape.inputs.push((s, v));
                    slot_of[node.index()] = s;
                }
                _ if constant => {
                    let s = fresh();
                    tape.prelude.push(instruction(op, s, &slot_of));
                    slot_of[node.index()] = s;
                }
                _ => body_nodes.push(node),
            }
        }

        // Pass 2: body values live from their instruction to their last use.
        let mut pinned = vec![false; ctx.len()];
        for &n in outputs {
            pinned[n.index()] = true;
        }
        let mut last_use: Vec<usize> = vec![usize::MAX; ctx.len()];
        for (i, &node) in body_nodes.iter().enumerate() {
            for child in ctx.get(node).children() {
                last_use[child.index()] = i;
            }
        }
        let mut free: Vec<Slot> = Vec::new();
        for (i, &node) in body_nodes.iter().enumerate() {
            let op = ctx.get(node);
            // At most three operands, each once: kept on the stack, not
            // collected.
            let mut dying = [Node(0); 3];
            let mut count = 0;
            for c in op.children() {
                if !dying[..count].contains(&c)
                    && last_use[c.index()] == i
                    && !pinned[c.index()]
                    && !is_constant[c.index()]
                    && !matches!(ctx.get(c), Op::Var(_))
                {
                    dying[count] = c;
                    count += 1;
                }
            }
            let dying = &mut dying[..count];
            dying.sort();
            // The result is allocated before the dying operands are freed, so an
            // instruction never writes a slot it also reads: evaluators may
            // stream operands and result without copies.
            let out = free.pop().unwrap_or_else(&mut fresh);
            tape.body.push(instruction(op, out, &slot_of));
            free.extend(dying.iter().map(|c| slot_of[c.index()]));
            slot_of[node.index()] = out;
        }
        tape.outputs = outputs.iter().map(|n| slot_of[n.index()]).collect();
        tape.slot_count = next_slot as usize;
        tape.point = point::compile(&tape.body);
        tape.keeps_decoration = tape.judge_decorations();
        tape
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
    pub(crate) fn point_program(&self) -> &[PointOp] {
        &self.point
    }

    /// The slot of each output.
    pub(crate) fn output_slots(&self) -> &[Slot] {
        &self.outputs
    }

    /// The f64 body as machine code, compiled once per tape (shared by every
    /// evaluator and thread); `None` where it cannot be.
    fn compiled(&self) -> Option<Arc<Compiled>> {
        self.compiled
            .get_or_init(|| super::jit::compile(self).map(Arc::new))
            .clone()
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

    /// [`Tape::output_keeps_decoration`] for every output, from the
    /// instructions.
    fn judge_decorations(&self) -> Vec<bool> {
        // The prelude's constants (`sqrt(2)`) are decided by their values.
        let constants = Evaluator::<DecInterval>::new(self);
        let mut keeps: Vec<bool> = constants
            .slots
            .iter()
            .map(|v| v.decoration() == Decoration::Dac)
            .collect();
        // Slots are reused, so the flags are followed in execution order:
        // each write sets its slot's flag from what it read.
        for instr in &self.body {
            let (out, ok) = match *instr {
                Instr::Unary { op, out, a } => {
                    let total = op.domain().is_none()
                        && !matches!(op, UnaryOp::Sign | UnaryOp::Dirac | UnaryOp::Tan);
                    (out, total && keeps[a as usize])
                }
                Instr::Binary { op, out, a, b } => {
                    let total = op.domain().is_none()
                        && !matches!(op, BinaryOp::Div | BinaryOp::Atan2 | BinaryOp::Pow);
                    (out, total && keeps[a as usize] && keeps[b as usize])
                }
                Instr::PowI { out, a, n } => (out, n >= 0 && keeps[a as usize]),
                Instr::Choose { out, .. } => (out, false),
            };
            keeps[out as usize] = ok;
        }
        self.outputs.iter().map(|&o| keeps[o as usize]).collect()
    }
}

/// The instruction computing `op` into `out`, its operands read from the
/// slots `slot_of` gives them (by node index; each set before it is read).
fn instruction(op: &Op, out: Slot, slot_of: &[Slot]) -> Instr {
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

/// A number type a tape can be evaluated in: `f64` for points, an interval
/// type for sound bounds.
pub trait TapeValue: Copy {
    /// The value of a constant.
    fn constant(v: f64) -> Self;
    /// A function of one argument.
    fn unary(op: UnaryOp, a: Self) -> Self;
    /// A function of two arguments.
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self;
    /// `a^n`.
    fn powi(a: Self, n: i32) -> Self;
    /// `choose(c, p, n)`.
    fn choose(c: Self, p: Self, n: Self) -> Self;

    /// Runs `tape`'s body over `slots` (f64 runs its one-dispatch form).
    ///
    /// # Panics
    /// When `slots` is shorter than [`Tape::slot_count`].
    #[inline]
    fn run_body(tape: &Tape, slots: &mut [Self]) {
        assert!(slots.len() >= tape.slot_count, "register file too small");
        // SAFETY: every slot a tape names is below its slot count (slots
        // are numbered as `Tape::new` allocates them), checked just above.
        unsafe { run(&tape.body, slots) }
    }
}

impl TapeValue for f64 {
    fn constant(v: f64) -> Self {
        v
    }
    #[inline]
    fn unary(op: UnaryOp, a: Self) -> Self {
        op.eval(a)
    }
    #[inline]
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        op.eval(a, b)
    }
    #[inline]
    fn powi(a: Self, n: i32) -> Self {
        powi(a, n)
    }
    #[inline]
    fn choose(c: Self, p: Self, n: Self) -> Self {
        choose(c, p, n)
    }
    #[inline]
    fn run_body(tape: &Tape, slots: &mut [Self]) {
        assert!(slots.len() >= tape.slot_count, "register file too small");
        // SAFETY: the point program names the body's slots, all below the
        // slot count, checked just above.
        unsafe { point::run(&tape.point, slots) }
    }
}

impl TapeValue for Interval {
    fn constant(v: f64) -> Self {
        Interval::point(v)
    }

    #[inline(always)]
    fn unary(op: UnaryOp, a: Self) -> Self {
        use UnaryOp::*;
        match op {
            Neg => a.neg(),
            Sqrt => a.sqrt(),
            Abs => a.abs(),
            Sign => a.sign(),
            Sin => a.sin(),
            Cos => a.cos(),
            Tan => a.tan(),
            Asin => a.asin(),
            Acos => a.acos(),
            Atan => a.atan(),
            Exp => a.exp(),
            Ln => a.ln(),
            Sinh => a.sinh(),
            Cosh => a.cosh(),
            Tanh => a.tanh(),
            Sech => a.sech(),
            Dirac => a.dirac(),
        }
    }

    #[inline(always)]
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        use BinaryOp::*;
        match op {
            Add => a.add(b),
            Sub => a.sub(b),
            Mul => a.mul(b),
            Div => a.div(b),
            Min => a.min(b),
            Max => a.max(b),
            Atan2 => a.atan2(b),
            Pow => a.pow(b),
        }
    }

    #[inline(always)]
    fn powi(a: Self, n: i32) -> Self {
        a.powi(n)
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        Interval::choose(c, p, n)
    }
}

/// Evaluation with decorations: every result also says whether each function
/// on its way was defined on all of its argument (see [`DecInterval`]).
impl TapeValue for DecInterval {
    fn constant(v: f64) -> Self {
        DecInterval::defined(Interval::point(v))
    }

    #[inline(always)]
    fn unary(op: UnaryOp, a: Self) -> Self {
        a.apply(op.domain(), |x| Interval::unary(op, x))
            .jumping_if(op.may_jump(a.interval()))
    }

    #[inline(always)]
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        a.apply(op.domain(), |x| Interval::binary(op, x, b.interval()))
            .depending_on(b)
            .jumping_if(op.may_jump(a.interval(), b.interval()))
    }

    #[inline(always)]
    fn powi(a: Self, n: i32) -> Self {
        a.apply(None, |x| x.powi(n))
            .jumping_if(n < 0 && a.interval().contains(0.0))
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        let (ci, pi, ni) = (c.interval(), p.interval(), n.interval());
        let straddles = ci.contains(0.0) && !(ci.inf() == 0.0 && ci.sup() == 0.0);
        DecInterval::defined(Interval::choose(ci, pi, ni))
            .depending_on(c)
            .depending_on(p)
            .depending_on(n)
            .jumping_if(straddles && pi != ni)
    }
}

/// The largest slot any instruction reads or writes.
fn max_slot(instrs: &[Instr]) -> Option<Slot> {
    instrs
        .iter()
        .map(|i| match *i {
            Instr::Unary { out, a, .. } | Instr::PowI { out, a, .. } => out.max(a),
            Instr::Binary { out, a, b, .. } => out.max(a).max(b),
            Instr::Choose { out, c, p, n } => out.max(c).max(p).max(n),
        })
        .max()
}

/// Runs `instrs` over `slots`.
///
/// The loop is compiled twice, and the copy for CPUs with a fused
/// multiply-add is chosen at run time: there each directed rounding of an
/// interval product inlines as one FMA instruction, where a portable build
/// must call out for it. One binary still runs on every x86-64.
///
/// # Safety
/// Every slot index in `instrs` must be below `slots.len()`. Evaluators check
/// this once, when they are created, so the per-operand bounds checks (a
/// measurable share of a renderer's time) can be left out here.
#[inline]
unsafe fn run<V: TapeValue>(instrs: &[Instr], slots: &mut [V]) {
    #[cfg(target_arch = "x86_64")]
    if crate::types::interval::has_fma() {
        // SAFETY: the CPU has FMA; the slots are the caller's contract.
        return unsafe { run_with_fma(instrs, slots) };
    }
    // SAFETY: the caller's contract.
    unsafe { run_portable(instrs, slots) }
}

/// [`run`] compiled for CPUs with FMA.
///
/// # Safety
/// The CPU has FMA, and [`run`]'s contract holds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn run_with_fma<V: TapeValue>(instrs: &[Instr], slots: &mut [V]) {
    // SAFETY: the caller's contract.
    unsafe { run_portable(instrs, slots) }
}

/// The loop of [`run`], inlined into each of its compiled copies.
///
/// # Safety
/// [`run`]'s contract.
#[inline(always)]
unsafe fn run_portable<V: TapeValue>(instrs: &[Instr], slots: &mut [V]) {
    let s = slots.as_mut_ptr();
    // SAFETY (all accesses below): indices are < slots.len() by the contract.
    let get = |i: Slot| unsafe { *s.add(i as usize) };
    let set = |i: Slot, v: V| unsafe { *s.add(i as usize) = v };
    for instr in instrs {
        match *instr {
            Instr::Unary { op, out, a } => set(out, V::unary(op, get(a))),
            Instr::Binary { op, out, a, b } => set(out, V::binary(op, get(a), get(b))),
            Instr::PowI { out, a, n } => set(out, V::powi(get(a), n)),
            Instr::Choose { out, c, p, n } => set(out, V::choose(get(c), get(p), get(n))),
        }
    }
}

/// Evaluates a tape at one input at a time, in any [`TapeValue`] type.
#[derive(Debug, Clone)]
pub struct Evaluator<'t, V> {
    tape: &'t Tape,
    slots: Vec<V>,
    out: Vec<V>,
}

impl<'t, V: TapeValue> Evaluator<'t, V> {
    /// Prepares the register file and runs the prelude once.
    pub fn new(tape: &'t Tape) -> Self {
        let mut slots = vec![V::constant(0.0); tape.slot_count];
        for &(s, v) in &tape.constants {
            slots[s as usize] = V::constant(v);
        }
        let highest = max_slot(&tape.prelude)
            .max(max_slot(&tape.body))
            .max(point::max_slot(&tape.point))
            .max(tape.outputs.iter().copied().max());
        assert!(
            highest.is_none_or(|h| (h as usize) < slots.len()) && slots.len() >= Var::ALL.len(),
            "tape reads a slot beyond its register file"
        );
        // SAFETY: checked just above for every instruction list.
        unsafe { run(&tape.prelude, &mut slots) };
        Self {
            tape,
            slots,
            out: vec![V::constant(0.0); tape.outputs.len()],
        }
    }

    /// Evaluates every output at `inputs`, indexed by [`Var::index`]
    /// (x, y, z, dx, dy, dz).
    pub fn eval(&mut self, inputs: &[V; 6]) -> &[V] {
        self.slots[..Var::ALL.len()].copy_from_slice(inputs);
        V::run_body(self.tape, &mut self.slots);
        let slots = &self.slots;
        for (o, &s) in self.out.iter_mut().zip(&self.tape.outputs) {
            // SAFETY: `new` checked every output slot against `slots`, whose
            // length never changes.
            *o = unsafe { *slots.get_unchecked(s as usize) };
        }
        &self.out
    }

    /// The first `N` outputs at `inputs`, as [`Evaluator::eval`] computes
    /// them, returned by value: the hot paths of the intersector read one to
    /// three outputs, and copying them out of the register file directly
    /// skips the output buffer.
    ///
    /// # Panics
    /// When the tape has fewer than `N` outputs.
    #[inline]
    pub fn eval_array<const N: usize>(&mut self, inputs: &[V; 6]) -> [V; N] {
        self.eval_array_by(inputs, V::run_body)
    }

    /// [`Evaluator::eval_array`] with the body run by `run` (the interpreter,
    /// or the tape's machine code), given the register file with the inputs
    /// in place.
    #[inline]
    fn eval_array_by<const N: usize>(
        &mut self,
        inputs: &[V; 6],
        run: impl FnOnce(&Tape, &mut [V]),
    ) -> [V; N] {
        let outputs = &self.tape.outputs[..N];
        self.slots[..Var::ALL.len()].copy_from_slice(inputs);
        run(self.tape, &mut self.slots);
        let slots = &self.slots;
        // SAFETY: `new` checked every output slot against `slots`, whose
        // length never changes.
        std::array::from_fn(|i| unsafe { *slots.get_unchecked(outputs[i] as usize) })
    }
}

/// Evaluates a tape at f64 points with its machine code (see
/// [`crate::expr::jit`]), or the interpreter where there is none: the same
/// values as [`Evaluator<f64>`], bit for bit, for the hot paths of rays.
///
/// ```
/// use lgc::{Context, Evaluator, PointEvaluator, Tape, UnaryOp, Var};
/// let mut ctx = Context::new();
/// let x = ctx.var(Var::X);
/// let f = ctx.unary(UnaryOp::Sin, x);
/// let tape = Tape::new(&ctx, &[f]);
/// let p = [0.5, 0.0, 0.0, 0.0, 0.0, 0.0];
/// let compiled: [f64; 1] = PointEvaluator::compiled(&tape).eval_array(&p);
/// let interpreted: [f64; 1] = Evaluator::<f64>::new(&tape).eval_array(&p);
/// assert_eq!(compiled[0].to_bits(), interpreted[0].to_bits());
/// ```
#[derive(Debug, Clone)]
pub struct PointEvaluator<'t> {
    interpreter: Evaluator<'t, f64>,
    compiled: Option<Arc<Compiled>>,
    /// Evaluations the interpreter still runs before the tape is compiled
    /// (0: compiled, or never to be).
    until_compiled: u32,
}

/// Evaluations a [`PointEvaluator`] interprets before it compiles its tape.
/// Compiling costs about as much as a thousand interpreted evaluations, so
/// tapes that only a few rays meet (the shapes of a few leaves) never pay
/// it, and the others pay it back many times over.
const EVALUATIONS_BEFORE_COMPILING: u32 = 512;

impl<'t> PointEvaluator<'t> {
    /// Prepares the register file; the tape is compiled once this
    /// evaluator has run it a few hundred times (once per tape, shared by
    /// every evaluator and thread).
    pub fn new(tape: &'t Tape) -> Self {
        // A tape that another evaluator (or thread) has compiled runs as
        // machine code at once: each render worker makes its own evaluators.
        let (compiled, until_compiled) = match tape.compiled.get() {
            Some(compiled) => (compiled.clone(), 0),
            None => (None, EVALUATIONS_BEFORE_COMPILING),
        };
        PointEvaluator {
            interpreter: Evaluator::new(tape),
            compiled,
            until_compiled,
        }
    }

    /// [`PointEvaluator::new`], compiling the tape at once.
    pub fn compiled(tape: &'t Tape) -> Self {
        PointEvaluator {
            interpreter: Evaluator::new(tape),
            compiled: tape.compiled(),
            until_compiled: 0,
        }
    }

    /// Whether machine code runs (not the interpreter).
    pub fn is_compiled(&self) -> bool {
        self.compiled.is_some()
    }

    /// Counts `n` evaluations of the tape made elsewhere (in a batch) toward
    /// compiling it, as if this evaluator had run them; whether machine code
    /// runs now.
    pub fn count_evaluations(&mut self, n: u32) -> bool {
        if self.compiled.is_none() && self.until_compiled > 0 {
            self.until_compiled = self.until_compiled.saturating_sub(n);
            if self.until_compiled == 0 {
                self.compiled = self.interpreter.tape.compiled();
            }
        }
        self.compiled.is_some()
    }

    /// The first `N` outputs at `inputs` (x, y, z, dx, dy, dz).
    ///
    /// # Panics
    /// When the tape has fewer than `N` outputs.
    #[inline]
    pub fn eval_array<const N: usize>(&mut self, inputs: &[f64; 6]) -> [f64; N] {
        let Some(code) = &self.compiled else {
            if self.until_compiled > 0 {
                self.until_compiled -= 1;
                if self.until_compiled == 0 {
                    self.compiled = self.interpreter.tape.compiled();
                }
            }
            return self.interpreter.eval_array(inputs);
        };
        // SAFETY: `Evaluator::new` made the register file at least the
        // tape's slot count, with its constants in place.
        self.interpreter
            .eval_array_by(inputs, |_, slots| unsafe { code.run(slots) })
    }
}

/// Evaluates a tape in decorated intervals, skipping the decorations' work
/// where the outputs whose decorations are read cannot lose them (see
/// [`Tape::output_keeps_decoration`]): the same enclosures, and the same
/// decorations for those outputs, as [`Evaluator<DecInterval>`].
#[derive(Debug, Clone)]
pub enum DecoratedEvaluator<'t> {
    /// Some output read may be undefined or jump: decorations are computed.
    Decorated(Evaluator<'t, DecInterval>),
    /// Every output read keeps its inputs' decoration: plain intervals, and
    /// a buffer for the decorated outputs. An output that may lose its
    /// decoration (one the caller does not read) is marked `Trv`, the
    /// weakest, never more than is known.
    Plain(Evaluator<'t, Interval>, Vec<DecInterval>),
}

impl<'t> DecoratedEvaluator<'t> {
    /// Prepares the evaluator, undecorated where every output allows.
    pub fn new(tape: &'t Tape) -> Self {
        let all: Vec<usize> = (0..tape.output_count()).collect();
        Self::reading(tape, &all)
    }

    /// Prepares the evaluator for a caller that reads the decorations of
    /// `outputs` only, undecorated where those allow.
    pub fn reading(tape: &'t Tape, outputs: &[usize]) -> Self {
        if outputs.iter().all(|&k| tape.output_keeps_decoration(k)) {
            let out = vec![DecInterval::defined(Interval::ZERO); tape.output_count()];
            DecoratedEvaluator::Plain(Evaluator::new(tape), out)
        } else {
            DecoratedEvaluator::Decorated(Evaluator::new(tape))
        }
    }

    /// Every output at `inputs`, as [`Evaluator::eval`].
    pub fn eval(&mut self, inputs: &[DecInterval; 6]) -> &[DecInterval] {
        match self {
            DecoratedEvaluator::Decorated(e) => e.eval(inputs),
            DecoratedEvaluator::Plain(e, out) => {
                // Each output keeps the weakest decoration of the inputs it
                // reads; the weakest of all six is that or weaker (the same
                // where, as always here, every input is defined).
                let dec = inputs.iter().map(|v| v.decoration()).min();
                let dec = dec.unwrap_or(Decoration::Dac);
                let tape = e.tape;
                let values = e.eval(&inputs.map(|v| v.interval()));
                let keeps = &tape.keeps_decoration;
                for ((o, &v), &kept) in out.iter_mut().zip(values).zip(keeps) {
                    *o = DecInterval::new(v, if kept { dec } else { Decoration::Trv });
                }
                out
            }
        }
    }
}

/// Points per chunk of the batch evaluator: long enough for the per-instruction
/// dispatch to vanish, short enough that the register file stays in cache.
pub const LANES: usize = 64;

/// Evaluates a tape at many points per call, in f64.
///
/// Each instruction runs over a chunk of [`LANES`] points, so the dispatch
/// cost is paid once per chunk and the inner loops vectorise.
#[derive(Debug, Clone)]
pub struct BatchEvaluator<'t> {
    tape: &'t Tape,
    slots: Vec<f64>,
}

impl<'t> BatchEvaluator<'t> {
    /// Prepares the register file (constants broadcast to every lane).
    pub fn new(tape: &'t Tape) -> Self {
        let mut scalar = Evaluator::<f64>::new(tape);
        let mut slots = vec![0.0; tape.slot_count * LANES];
        for (s, v) in scalar.slots.iter_mut().enumerate() {
            slots[s * LANES..(s + 1) * LANES].fill(*v);
        }
        Self { tape, slots }
    }

    /// Evaluates every output at `n = outputs[0].len()` points.
    ///
    /// `inputs[v]` holds the values of variable `v` (x, y, z, dx, dy, dz); a
    /// variable the tape does not read may be given as an empty slice, and
    /// trailing ones may be omitted.
    ///
    /// # Panics
    /// When an input the tape reads is shorter than the outputs, or the number
    /// of output slices differs from the tape's.
    pub fn eval(&mut self, inputs: &[&[f64]], outputs: &mut [&mut [f64]]) {
        assert_eq!(
            outputs.len(),
            self.tape.outputs.len(),
            "one slice per output"
        );
        let n = outputs.first().map_or(0, |o| o.len());
        for &(_, var) in &self.tape.inputs {
            let len = inputs.get(var.index()).map_or(0, |s| s.len());
            assert!(
                len >= n,
                "input `{}` has {len} values for {n} points",
                var.name()
            );
        }
        let mut start = 0;
        while start < n {
            let m = LANES.min(n - start);
            for &(s, var) in &self.tape.inputs {
                let src = &inputs[var.index()][start..start + m];
                self.slots[s as usize * LANES..s as usize * LANES + m].copy_from_slice(src);
            }
            self.run_chunk();
            for (o, &s) in outputs.iter_mut().zip(&self.tape.outputs) {
                o[start..start + m]
                    .copy_from_slice(&self.slots[s as usize * LANES..s as usize * LANES + m]);
            }
            start += m;
        }
    }

    fn run_chunk(&mut self) {
        let slots = &mut self.slots;
        let lane = |s: Slot| s as usize * LANES;
        for instr in &self.tape.body {
            match *instr {
                Instr::Binary { op, out, a, b } => {
                    let mut va = [0.0; LANES];
                    let mut vb = [0.0; LANES];
                    va.copy_from_slice(&slots[lane(a)..lane(a) + LANES]);
                    vb.copy_from_slice(&slots[lane(b)..lane(b) + LANES]);
                    let dst = &mut slots[lane(out)..lane(out) + LANES];
                    match op {
                        BinaryOp::Add => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = x + y),
                        BinaryOp::Sub => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = x - y),
                        BinaryOp::Mul => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = x * y),
                        BinaryOp::Div => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = x / y),
                        _ => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = op.eval(*x, *y)),
                    }
                }
                Instr::Unary { op, out, a } => {
                    let mut va = [0.0; LANES];
                    va.copy_from_slice(&slots[lane(a)..lane(a) + LANES]);
                    let dst = &mut slots[lane(out)..lane(out) + LANES];
                    match op {
                        UnaryOp::Neg => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = -x),
                        _ => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = op.eval(*x)),
                    }
                }
                Instr::PowI { out, a, n } => {
                    let mut va = [0.0; LANES];
                    va.copy_from_slice(&slots[lane(a)..lane(a) + LANES]);
                    let dst = &mut slots[lane(out)..lane(out) + LANES];
                    // One branch per instruction, not per lane; the shared
                    // powi keeps batch and point results identical.
                    match n {
                        2 => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, 2)),
                        3 => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, 3)),
                        4 => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, 4)),
                        _ => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, n)),
                    }
                }
                Instr::Choose { out, c, p, n } => {
                    for k in 0..LANES {
                        slots[lane(out) + k] =
                            choose(slots[lane(c) + k], slots[lane(p) + k], slots[lane(n) + k]);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_tapes_are_those_without_transcendental_functions() {
        let mut ctx = Context::new();
        let (x, y) = (ctx.var(Var::X), ctx.var(Var::Y));
        let m = ctx.binary(BinaryOp::Max, x, y);
        let a = ctx.unary(UnaryOp::Abs, m);
        let q = ctx.powi(a, 3);
        let r = ctx.div(q, y);
        assert!(Tape::new(&ctx, &[r]).is_arithmetic());
        let s = ctx.unary(UnaryOp::Sin, x);
        let t = ctx.mul(s, r);
        assert!(!Tape::new(&ctx, &[t]).is_arithmetic());
        let p = ctx.binary(BinaryOp::Pow, x, y);
        assert!(!Tape::new(&ctx, &[p]).is_arithmetic());
    }

    #[test]
    fn evaluations_counted_elsewhere_compile_the_tape_as_the_evaluators_own() {
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let f = ctx.mul(x, x);
        let tape = Tape::new(&ctx, &[f]);
        let mut e = PointEvaluator::new(&tape);
        // The host may have no backend: then nothing is ever compiled.
        let can = PointEvaluator::compiled(&Tape::new(&ctx, &[f])).is_compiled();
        assert!(!e.count_evaluations(EVALUATIONS_BEFORE_COMPILING - 1));
        assert!(!e.is_compiled());
        assert_eq!(e.count_evaluations(1), can);
        assert_eq!(e.is_compiled(), can);
        let p = [3.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(e.eval_array::<1>(&p), [9.0]);
    }

    /// Both compiled copies of the interval loop give the same enclosures,
    /// bit for bit (where the CPU has FMA; elsewhere there is one copy).
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_fma_copy_of_the_loop_matches_the_portable_one() {
        if !crate::types::interval::has_fma() {
            return;
        }
        // Products, squares, sums, a quotient, min/max, |·|, sqrt and a
        // transcendental function, of x, y, z and the direction.
        let mut ctx = Context::new();
        let v = Var::ALL.map(|v| ctx.var(v));
        let squares = v.map(|a| ctx.powi(a, 2));
        let r2 = ctx.add(squares[0], squares[1]);
        let r2 = ctx.add(r2, squares[2]);
        let one = ctx.constant(1.0);
        let sphere = ctx.sub(r2, one);
        let xy = ctx.mul(v[0], v[1]);
        let zd = ctx.mul(v[2], v[3]);
        let quotient = ctx.div(xy, r2);
        let a = ctx.unary(UnaryOp::Abs, zd);
        let root = ctx.unary(UnaryOp::Sqrt, a);
        let sine = ctx.unary(UnaryOp::Sin, v[4]);
        let m = ctx.binary(BinaryOp::Max, sphere, quotient);
        let n = ctx.binary(BinaryOp::Min, root, sine);
        let cube = ctx.powi(m, 3);
        let total = ctx.add(cube, n);
        let dy = ctx.mul(v[5], total);
        let tape = Tape::new(&ctx, &[sphere, m, n, total, dy]);
        let boxes = [
            [-1.0, 1.0, 0.25, 0.5, -0.3, 0.7],
            [0.1, 0.3, 0.2, 0.9, 1.0, 1.0],
            [-3.0, -1e-3, 2.0, 2.5, -0.6, -0.1],
        ];
        for b in boxes {
            let inputs: [Interval; 6] = [
                Interval::new(b[0], b[1]),
                Interval::new(b[2], b[3]),
                Interval::new(b[4], b[5]),
                Interval::new(0.6, 0.61),
                Interval::point(-0.8),
                Interval::new(-0.1, 0.3),
            ];
            let mut portable = Evaluator::<Interval>::new(&tape);
            let mut fma = portable.clone();
            portable.slots[..6].copy_from_slice(&inputs);
            fma.slots[..6].copy_from_slice(&inputs);
            // SAFETY: the evaluators' register files fit the tape, and
            // the CPU has FMA (checked above).
            unsafe {
                run_portable(&tape.body, &mut portable.slots);
                run_with_fma(&tape.body, &mut fma.slots);
            }
            for (p, f) in portable.slots.iter().zip(&fma.slots) {
                assert_eq!(p.inf().to_bits(), f.inf().to_bits(), "over {b:?}");
                assert_eq!(p.sup().to_bits(), f.sup().to_bits(), "over {b:?}");
            }
        }
    }
}
