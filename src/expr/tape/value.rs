//! The number types a tape runs in, and the loop that runs its instructions.

use super::instr::{max_slot, Instr, Slot};
use super::point;
use super::Tape;
use crate::expr::op::{choose, powi, BinaryOp, UnaryOp, Var};
use crate::types::interval::Decoration;
use crate::types::{Affine, DecInterval, Interval};
use std::ops::{Add, Div, Mul, Neg, Sub};

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

    /// `x · c` for a constant `c > 0`, finite (`c · x` where `first`):
    /// the product, unless the type has a faster way to the same value.
    #[inline(always)]
    fn mul_by_positive(x: Self, c: Self, first: bool) -> Self {
        product(x, c, first)
    }

    /// `x · c` for a constant `c < 0`, finite, as [`TapeValue::mul_by_positive`].
    #[inline(always)]
    fn mul_by_negative(x: Self, c: Self, first: bool) -> Self {
        product(x, c, first)
    }

    /// Runs `tape`'s body over `slots`, in its one-dispatch form.
    ///
    /// # Panics
    /// When `slots` is shorter than [`Tape::slot_count`].
    #[inline]
    fn run_body(tape: &Tape, slots: &mut [Self]) {
        assert!(slots.len() >= tape.slot_count, "register file too small");
        // SAFETY: the point program names the body's slots, all below the
        // slot count (slots are numbered as `Tape::new` allocates them),
        // checked just above.
        unsafe { run_program(&tape.point, slots) }
    }

    /// Runs `instrs`, a run of `tape`'s body, on `slots`, in the
    /// interpreter whatever the type (by the run's one-dispatch form).
    ///
    /// # Panics
    /// When `slots` is shorter than [`Tape::slot_count`], or `instrs` is not
    /// within `tape`'s body.
    #[inline]
    fn run_instructions(tape: &Tape, instrs: &[Instr], slots: &mut [Self]) {
        assert!(slots.len() >= tape.slot_count, "register file too small");
        let range = tape.body.as_ptr_range();
        let within = instrs.is_empty()
            || (range.start <= instrs.as_ptr() && instrs.as_ptr_range().end <= range.end);
        assert!(within, "instructions from another tape");
        // The point program has one operation per body instruction, in
        // the same order.
        let start = if instrs.is_empty() {
            0
        } else {
            // SAFETY: both pointers are into the body (checked above).
            unsafe { instrs.as_ptr().offset_from(range.start) as usize }
        };
        let program = &tape.point[start..start + instrs.len()];
        // SAFETY: every slot the tape's body names is below its slot count,
        // checked just above, and `program` is some of its operations.
        unsafe { run_program(program, slots) }
    }
}

/// `x · c`, or `c · x` where `first`: the product in the formula's order.
#[inline(always)]
fn product<V: TapeValue>(x: V, c: V, first: bool) -> V {
    if first {
        V::binary(BinaryOp::Mul, c, x)
    } else {
        V::binary(BinaryOp::Mul, x, c)
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
            Floor => a.floor(),
            Ceil => a.ceil(),
            Round => a.round(),
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

    #[inline(always)]
    fn mul_by_positive(x: Self, c: Self, _: bool) -> Self {
        x.mul_by_signed(c.inf(), true)
    }

    #[inline(always)]
    fn mul_by_negative(x: Self, c: Self, _: bool) -> Self {
        x.mul_by_signed(c.inf(), false)
    }
}

/// Reduced affine forms: `+ − × /`, integer powers, `sqrt`, `exp` and `ln`
/// keep their first-order dependence on x, y and z; every other operation
/// goes through the interval of its arguments (see [`Affine`]).
impl TapeValue for Affine {
    fn constant(v: f64) -> Self {
        Affine::constant(v)
    }

    fn unary(op: UnaryOp, a: Self) -> Self {
        match op {
            UnaryOp::Neg => a.neg(),
            UnaryOp::Sqrt => a.sqrt(),
            UnaryOp::Exp => a.exp(),
            UnaryOp::Ln => a.ln(),
            op => a.fallback(|x| Interval::unary(op, x)),
        }
    }

    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        match op {
            BinaryOp::Add => a.add(b),
            BinaryOp::Sub => a.sub(b),
            BinaryOp::Mul => a.mul(b),
            BinaryOp::Div => a.div(b),
            op => Affine::from_interval(Interval::binary(op, a.range(), b.range())),
        }
    }

    fn powi(a: Self, n: i32) -> Self {
        a.powi(n)
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        let c = c.range();
        if c.sup() < 0.0 {
            p
        } else if c.inf() > 0.0 {
            n
        } else {
            Affine::from_interval(Interval::choose(c, p.range(), n.range()))
        }
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
        let x = a.interval();
        let image = Interval::unary(op, x);
        DecInterval::new(image, a.decoration().min(unary_leaves(op, x, image)))
    }

    #[inline(always)]
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        let (x, y) = (a.interval(), b.interval());
        let (image, leaves) = binary_leaves(op, x, y);
        let dec = a.decoration().min(b.decoration()).min(leaves);
        DecInterval::new(image, dec)
    }

    #[inline(always)]
    fn powi(a: Self, n: i32) -> Self {
        let x = a.interval();
        let image = x.powi(n);
        DecInterval::new(image, a.decoration().min(powi_leaves(n, x, image)))
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        let (ci, pi, ni) = (c.interval(), p.interval(), n.interval());
        let dec = c.decoration().min(p.decoration()).min(n.decoration());
        DecInterval::new(
            Interval::choose(ci, pi, ni),
            dec.min(choose_leaves(ci, pi, ni)),
        )
    }
}

/// An interval whose evaluation notes, for the whole run, whether any
/// operation on the way may have lost its arguments' decoration (see
/// [`take_lost`]): where none did, every result keeps its inputs'
/// decoration, so a decorated evaluation costs a plain one and a check per
/// operation (the common case; `DecoratedEvaluator` runs the decorated one
/// only where some operation may have lost it).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(transparent)]
pub struct Guarded(pub Interval);

thread_local! {
    /// The least decoration a [`Guarded`] operation on this thread kept of
    /// its arguments' since [`take_lost`] or [`take_least`] last read it
    /// ([`Decoration::Dac`]: none lost). Beside the values rather than in
    /// them: a decoration in each value makes it 24 bytes, not 16, and the
    /// tape loop over such values took 1.6 times as long (the bear model's
    /// tape: 15.6 ns an instruction, against 9.6).
    static LOST: std::cell::Cell<Decoration> = const { std::cell::Cell::new(Decoration::Dac) };
}

/// Whether a [`Guarded`] operation on this thread may have lost its
/// arguments' decoration since the last call, and forgets it.
pub fn take_lost() -> bool {
    take_least() != Decoration::Dac
}

/// The least decoration a [`Guarded`] operation on this thread may have
/// kept of its arguments' since the last call ([`Decoration::Dac`] where
/// none lost any), and forgets it: every result since keeps at least this
/// much of its inputs' decoration.
pub fn take_least() -> Decoration {
    LOST.with(|l| l.replace(Decoration::Dac))
}

/// Notes, for [`take_lost`], that an operation may have lost a decoration
/// where `leaves` is less than [`Decoration::Dac`].
#[inline(always)]
pub(super) fn note(leaves: Decoration) {
    if leaves != Decoration::Dac {
        note_lost(leaves);
    }
}

#[cold]
fn note_lost(leaves: Decoration) {
    LOST.with(|l| l.set(l.get().min(leaves)));
}

impl TapeValue for Guarded {
    fn constant(v: f64) -> Self {
        Guarded(Interval::point(v))
    }

    #[inline(always)]
    fn unary(op: UnaryOp, a: Self) -> Self {
        let image = Interval::unary(op, a.0);
        note(unary_leaves(op, a.0, image));
        Guarded(image)
    }

    #[inline(always)]
    fn binary(op: BinaryOp, a: Self, b: Self) -> Self {
        let (image, leaves) = binary_leaves(op, a.0, b.0);
        note(leaves);
        Guarded(image)
    }

    #[inline(always)]
    fn powi(a: Self, n: i32) -> Self {
        let image = a.0.powi(n);
        note(powi_leaves(n, a.0, image));
        Guarded(image)
    }

    fn choose(c: Self, p: Self, n: Self) -> Self {
        note(choose_leaves(c.0, p.0, n.0));
        Guarded(Interval::choose(c.0, p.0, n.0))
    }

    // The same interval and the same note as `binary`'s (which judges the
    // first factor), the interval by its faster path.
    #[inline(always)]
    fn mul_by_positive(x: Self, c: Self, first: bool) -> Self {
        let image = x.0.mul_by_signed(c.0.inf(), true);
        note(leaves(None, if first { c.0 } else { x.0 }, image, false));
        Guarded(image)
    }

    #[inline(always)]
    fn mul_by_negative(x: Self, c: Self, first: bool) -> Self {
        let image = x.0.mul_by_signed(c.0.inf(), false);
        note(leaves(None, if first { c.0 } else { x.0 }, image, false));
        Guarded(image)
    }
}

/// The most a function's result keeps of its argument's decoration, given
/// the argument `x` and the image: `Trv` where the function may be
/// undefined somewhere on `x` (outside its domain, or an empty image of a
/// non-empty argument), `Def` where it may jump there, `Dac` otherwise.
#[inline(always)]
fn leaves(domain: Option<Interval>, x: Interval, image: Interval, jumps: bool) -> Decoration {
    let inside = domain.is_none_or(|d| x.is_empty() || d.encloses(x));
    if !inside || (!x.is_empty() && image.is_empty()) {
        Decoration::Trv
    } else if jumps {
        Decoration::Def
    } else {
        Decoration::Dac
    }
}

#[inline(always)]
pub(super) fn unary_leaves(op: UnaryOp, x: Interval, image: Interval) -> Decoration {
    leaves(op.domain(), x, image, op.may_jump(x))
}

/// `op(x, y)` and what it keeps of its arguments' decorations (as
/// [`leaves`]; a quotient by 0 or `atan2` at the origin has no value).
#[inline(always)]
pub(super) fn binary_leaves(op: BinaryOp, x: Interval, y: Interval) -> (Interval, Decoration) {
    // The arithmetic that fills long formulas, each arm with its operation
    // known: none asks again for a domain, a jump or a quotient by 0 it
    // cannot have.
    let image = match op {
        BinaryOp::Add => x + y,
        BinaryOp::Sub => x - y,
        BinaryOp::Mul => x * y,
        BinaryOp::Min => x.min(y),
        BinaryOp::Max => x.max(y),
        // Undefined only where the divisor may be 0. An arm of its own: in
        // the shared arm below, whose operation is known only at run time,
        // quotients made one compiled copy of the interval loop (the
        // criterion bench's) take the bear model's enclosures of f and g
        // twice as long as plain intervals.
        BinaryOp::Div => {
            let image = x / y;
            let kept = if y.contains(0.0) {
                Decoration::Trv
            } else {
                leaves(None, x, image, false)
            };
            return (image, kept);
        }
        _ => {
            let image = Interval::binary(op, x, y);
            let kept = if op.may_be_undefined(x, y) {
                Decoration::Trv
            } else {
                leaves(op.domain(), x, image, op.may_jump(x, y))
            };
            return (image, kept);
        }
    };
    (image, leaves(None, x, image, false))
}

/// `x^n` keeps its argument's decoration but where it is empty of a
/// non-empty argument, or a negative power of 0 (a quotient by 0).
#[inline(always)]
pub(super) fn powi_leaves(n: i32, x: Interval, image: Interval) -> Decoration {
    if n < 0 && x.contains(0.0) {
        Decoration::Trv
    } else {
        leaves(None, x, image, false)
    }
}

/// `choose(c, p, n)` jumps where c may change sign strictly and the
/// branches differ.
#[inline(always)]
pub(super) fn choose_leaves(c: Interval, p: Interval, n: Interval) -> Decoration {
    let straddles = c.contains(0.0) && !(c.inf() == 0.0 && c.sup() == 0.0);
    if straddles && p != n {
        Decoration::Def
    } else {
        Decoration::Dac
    }
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
pub(crate) unsafe fn run<V: TapeValue>(instrs: &[Instr], slots: &mut [V]) {
    #[cfg(target_arch = "x86_64")]
    if crate::types::rounding::has_directed() && crate::types::rounding::has_fma() {
        // SAFETY: the CPU has AVX-512F and FMA; the slots are the caller's
        // contract.
        return unsafe { run_with_directed(instrs, slots) };
    }
    #[cfg(target_arch = "x86_64")]
    if crate::types::rounding::has_fma() {
        // SAFETY: the CPU has FMA; the slots are the caller's contract.
        return unsafe { run_with_fma(instrs, slots) };
    }
    // SAFETY: the caller's contract.
    unsafe { run_portable(instrs, slots) }
}

/// [`run`] compiled for CPUs with AVX-512F and FMA: the directed roundings
/// of intervals are then single instructions in place.
///
/// # Safety
/// The CPU has AVX-512F and FMA, and [`run`]'s contract holds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
pub(crate) unsafe fn run_with_directed<V: TapeValue>(instrs: &[Instr], slots: &mut [V]) {
    // SAFETY: the caller's contract.
    unsafe { run_portable(instrs, slots) }
}

/// [`run`] compiled for CPUs with FMA.
///
/// # Safety
/// The CPU has FMA, and [`run`]'s contract holds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
pub(crate) unsafe fn run_with_fma<V: TapeValue>(instrs: &[Instr], slots: &mut [V]) {
    // SAFETY: the caller's contract.
    unsafe { run_portable(instrs, slots) }
}

/// The loop of [`run`], inlined into each of its compiled copies.
///
/// # Safety
/// [`run`]'s contract.
#[inline(always)]
pub(crate) unsafe fn run_portable<V: TapeValue>(instrs: &[Instr], slots: &mut [V]) {
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

/// Runs `program`, a tape body's one-dispatch form (see
/// [`point::PointOp`]), over `slots` in `V`: the same operations as [`run`]
/// on the body, each selected by one jump rather than by its kind and then
/// its operation.
///
/// # Safety
/// Every slot index in `program` must be below `slots.len()`.
#[inline]
unsafe fn run_program<V: TapeValue>(program: &[point::PointOp], slots: &mut [V]) {
    #[cfg(target_arch = "x86_64")]
    if crate::types::rounding::has_directed() && crate::types::rounding::has_fma() {
        // SAFETY: the CPU has AVX-512F and FMA; the slots are the caller's
        // contract.
        return unsafe { run_program_with_directed(program, slots) };
    }
    #[cfg(target_arch = "x86_64")]
    if crate::types::rounding::has_fma() {
        // SAFETY: the CPU has FMA; the slots are the caller's contract.
        return unsafe { run_program_with_fma(program, slots) };
    }
    // SAFETY: the caller's contract.
    unsafe { run_program_portable(program, slots) }
}

/// [`run_program`] compiled for CPUs with AVX-512F and FMA (see
/// [`run_with_directed`]).
///
/// # Safety
/// The CPU has AVX-512F and FMA, and [`run_program`]'s contract holds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
pub(crate) unsafe fn run_program_with_directed<V: TapeValue>(
    program: &[point::PointOp],
    slots: &mut [V],
) {
    // SAFETY: the caller's contract.
    unsafe { run_program_portable(program, slots) }
}

/// [`run_program`] compiled for CPUs with FMA.
///
/// # Safety
/// The CPU has FMA, and [`run_program`]'s contract holds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
pub(crate) unsafe fn run_program_with_fma<V: TapeValue>(
    program: &[point::PointOp],
    slots: &mut [V],
) {
    // SAFETY: the caller's contract.
    unsafe { run_program_portable(program, slots) }
}

/// The loop of [`run_program`], inlined into each of its compiled copies.
///
/// # Safety
/// [`run_program`]'s contract.
#[inline(always)]
pub(crate) unsafe fn run_program_portable<V: TapeValue>(
    program: &[point::PointOp],
    slots: &mut [V],
) {
    use point::PointOp as P;
    let s = slots.as_mut_ptr();
    // SAFETY (all accesses below): indices are < slots.len() by the contract.
    let get = |i: Slot| unsafe { *s.add(i as usize) };
    let set = |i: Slot, v: V| unsafe { *s.add(i as usize) = v };
    for op in program {
        match *op {
            P::Add(o, a, b) => set(o, V::binary(BinaryOp::Add, get(a), get(b))),
            P::Sub(o, a, b) => set(o, V::binary(BinaryOp::Sub, get(a), get(b))),
            P::Mul(o, a, b) => set(o, V::binary(BinaryOp::Mul, get(a), get(b))),
            P::MulPos(o, x, c, first) => set(o, V::mul_by_positive(get(x), get(c), first)),
            P::MulNeg(o, x, c, first) => set(o, V::mul_by_negative(get(x), get(c), first)),
            P::Div(o, a, b) => set(o, V::binary(BinaryOp::Div, get(a), get(b))),
            P::Min(o, a, b) => set(o, V::binary(BinaryOp::Min, get(a), get(b))),
            P::Max(o, a, b) => set(o, V::binary(BinaryOp::Max, get(a), get(b))),
            P::Neg(o, a) => set(o, V::unary(UnaryOp::Neg, get(a))),
            P::Abs(o, a) => set(o, V::unary(UnaryOp::Abs, get(a))),
            P::Sqrt(o, a) => set(o, V::unary(UnaryOp::Sqrt, get(a))),
            P::Square(o, a) => set(o, V::powi(get(a), 2)),
            P::Cube(o, a) => set(o, V::powi(get(a), 3)),
            P::Fourth(o, a) => set(o, V::powi(get(a), 4)),
            P::PowI(o, a, n) => set(o, V::powi(get(a), n)),
            P::Choose(o, c, p, n) => set(o, V::choose(get(c), get(p), get(n))),
            P::Unary(op, o, a) => set(o, V::unary(op, get(a))),
            P::Binary(op, o, a, b) => set(o, V::binary(op, get(a), get(b))),
        }
    }
}

/// The register file of an evaluator of `tape` in `V`: the constants in
/// place and the prelude run once.
///
/// # Panics
/// When an instruction or output names a slot beyond the tape's slot count
/// (the check that lets [`run`] go without bounds checks).
pub(crate) fn register_file<V: TapeValue>(tape: &Tape) -> Vec<V> {
    let mut slots = vec![V::constant(0.0); tape.slot_count];
    for &(s, v) in &tape.constants {
        slots[s as usize] = V::constant(v);
    }
    let fits = *tape.slots_fit.get_or_init(|| {
        let highest = max_slot(&tape.prelude)
            .max(max_slot(&tape.body))
            .max(point::max_slot(&tape.point))
            .max(tape.outputs.iter().copied().max());
        highest.is_none_or(|h| (h as usize) < tape.slot_count)
    });
    assert!(
        fits && slots.len() >= Var::ALL.len(),
        "tape reads a slot beyond its register file"
    );
    // SAFETY: checked just above (once per tape) for every instruction list.
    unsafe { run(&tape.prelude, &mut slots) };
    slots
}
