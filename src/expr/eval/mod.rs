//! Evaluators of a tape: at one input in any number type, at f64 points
//! as machine code, in decorated intervals, and over batches of points.

mod batch;
mod decorated;
mod point;
mod settling;

pub use batch::{BatchEvaluator, LANES};
pub use decorated::DecoratedEvaluator;
pub use point::PointEvaluator;
pub use settling::SettlingEvaluator;

use crate::expr::op::Var;
use crate::expr::tape::value::{register_file, TapeValue};
use crate::expr::tape::Tape;

/// A number type whose values are those of `W`, bit for bit: a register
/// file of one may be run as one of the other.
///
/// # Safety
/// Implementors have `W`'s size and alignment, and every bit pattern of
/// one is a valid value of the other (a `#[repr(transparent)]` wrapper).
pub(crate) unsafe trait SameLayout<W> {}

// SAFETY: a type has its own layout.
unsafe impl<V> SameLayout<V> for V {}

// SAFETY: `Guarded` is a `#[repr(transparent)]` wrapper of `Interval`.
unsafe impl SameLayout<crate::types::Interval> for crate::expr::tape::value::Guarded {}

/// Evaluates a tape at one input at a time, in any [`TapeValue`] type.
#[derive(Debug, Clone)]
pub struct Evaluator<'t, V> {
    pub(super) tape: &'t Tape,
    pub(super) slots: Vec<V>,
    pub(super) out: Vec<V>,
    /// The body instructions up to the last that writes the first output's
    /// slot (see [`Evaluator::eval_first_then`]), found on its first call
    /// (`usize::MAX` until then): most evaluators never stop early.
    first_end: usize,
}

impl<'t, V: TapeValue> Evaluator<'t, V> {
    /// Prepares the register file and runs the prelude once.
    pub fn new(tape: &'t Tape) -> Self {
        let slots = register_file(tape);
        Self {
            tape,
            slots,
            out: vec![V::constant(0.0); tape.outputs.len()],
            first_end: usize::MAX,
        }
    }

    /// The tape it evaluates.
    pub fn tape(&self) -> &'t Tape {
        self.tape
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

    /// The first output at `inputs`, and then, where `rest` asks for them
    /// given it, every output, as [`Evaluator::eval`] computes them.
    ///
    /// The first output is final once the last instruction writing its slot
    /// has run; the instructions after it run only when `rest` says so. A
    /// tape compiled with f first ([`Tape::new`] lays out each output's
    /// operands before the next output's) then stops after f's own: an
    /// enclosure of f that excludes 0 costs f's instructions, not g's too.
    pub fn eval_first_then(
        &mut self,
        inputs: &[V; 6],
        rest: impl FnOnce(&V) -> bool,
    ) -> (V, Option<&[V]>) {
        self.eval_first_then_rest_in::<V>(inputs, rest)
    }

    /// [`Evaluator::eval_first_then`] with the instructions after the first
    /// output's run in `W`, a type of the same layout as `V` (`unsafe` to
    /// implement: see [`SameLayout`]).
    pub(crate) fn eval_first_then_rest_in<W: TapeValue>(
        &mut self,
        inputs: &[V; 6],
        rest: impl FnOnce(&V) -> bool,
    ) -> (V, Option<&[V]>)
    where
        V: SameLayout<W>,
    {
        if self.first_end == usize::MAX {
            self.first_end = first_output_end(self.tape);
        }
        let body = &self.tape.body;
        self.slots[..Var::ALL.len()].copy_from_slice(inputs);
        V::run_instructions(self.tape, &body[..self.first_end], &mut self.slots);
        let first = self.tape.outputs.first().map(|&s| self.slots[s as usize]);
        let first = first.unwrap_or(V::constant(f64::NAN));
        if !rest(&first) {
            return (first, None);
        }
        // SAFETY: `V: SameLayout<W>` promises the same size, alignment and
        // valid bit patterns, so the register file is one of `W` values.
        let slots = unsafe {
            std::slice::from_raw_parts_mut(self.slots.as_mut_ptr().cast::<W>(), self.slots.len())
        };
        W::run_instructions(self.tape, &body[self.first_end..], slots);
        for (o, &s) in self.out.iter_mut().zip(&self.tape.outputs) {
            *o = self.slots[s as usize];
        }
        (first, Some(&self.out))
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
    pub(super) fn eval_array_by<const N: usize>(
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

/// How many body instructions of `tape` run before its first output is
/// final: up to the last that writes its slot (none after it do).
fn first_output_end(tape: &Tape) -> usize {
    let Some(&slot) = tape.outputs.first() else {
        return 0;
    };
    let last = tape.body.iter().rposition(|i| i.out() == slot);
    last.map_or(0, |i| i + 1)
}

#[cfg(test)]
mod tests {
    use super::point::{EVALUATIONS_BEFORE_COMPILING, EVALUATIONS_BEFORE_OPTIMISING};
    use super::*;
    use crate::expr::op::{BinaryOp, Node, UnaryOp};
    use crate::expr::tape::value::{run_portable, run_with_fma, Guarded};
    use crate::expr::Context;
    use crate::types::{DecInterval, Interval};

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
    fn evaluations_counted_elsewhere_compile_and_optimise_the_tape_as_the_evaluators_own() {
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
        assert!(!e.is_optimised());
        // Baseline code runs, then optimised code, once it has run enough.
        assert_eq!(e.count_evaluations(EVALUATIONS_BEFORE_OPTIMISING - 1), can);
        assert!(!e.is_optimised());
        assert_eq!(e.count_evaluations(1), can);
        assert_eq!(e.is_optimised(), can);
        // An evaluator made now runs the optimised code at once.
        assert_eq!(PointEvaluator::new(&tape).is_optimised(), can);
        let p = [3.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(e.eval_array::<1>(&p), [9.0]);
    }

    /// The inputs over the box `b` (x, y and z's ends), with a fixed
    /// direction, some of it an interval.
    fn box_inputs(b: [f64; 6]) -> [Interval; 6] {
        [
            Interval::new(b[0], b[1]),
            Interval::new(b[2], b[3]),
            Interval::new(b[4], b[5]),
            Interval::new(0.6, 0.61),
            Interval::point(-0.8),
            Interval::new(-0.1, 0.3),
        ]
    }

    /// A tape with every opcode of the one-dispatch form: each arithmetic
    /// operation, `|·|`, `sqrt`, powers 2 to 5, `choose`, and the catch-all
    /// functions of one and two arguments, of x, y, z and the direction.
    fn every_opcode() -> Tape {
        let mut ctx = Context::new();
        let v = Var::ALL.map(|v| ctx.var(v));
        let sum = ctx.add(v[0], v[1]);
        let difference = ctx.sub(sum, v[2]);
        let product = ctx.mul(difference, v[3]);
        let quotient = ctx.div(product, v[1]);
        let least = ctx.binary(BinaryOp::Min, quotient, v[4]);
        let most = ctx.binary(BinaryOp::Max, least, v[5]);
        let negated = ctx.neg(most);
        let size = ctx.unary(UnaryOp::Abs, negated);
        let root = ctx.unary(UnaryOp::Sqrt, size);
        let powers: Vec<Node> = (2..=5).map(|n| ctx.powi(difference, n)).collect();
        let chosen = ctx.choose(v[2], powers[0], powers[1]);
        let sine = ctx.unary(UnaryOp::Sin, chosen);
        let angle = ctx.binary(BinaryOp::Atan2, sine, powers[2]);
        let total = ctx.add(angle, powers[3]);
        let f = ctx.add(total, root);
        Tape::new(&ctx, &[f, root, chosen])
    }

    /// Runs `tape`'s body both ways in `V` over `inputs`: by kind and then
    /// operation, and by one opcode, whole and as two runs; the register
    /// files of each.
    fn both_loops<V: TapeValue>(tape: &Tape, inputs: &[V; 6]) -> [Vec<V>; 3] {
        let mut by_kind = Evaluator::<V>::new(tape);
        let mut by_opcode = by_kind.clone();
        let mut in_two = by_kind.clone();
        for e in [&mut by_kind, &mut by_opcode, &mut in_two] {
            e.slots[..6].copy_from_slice(inputs);
        }
        // SAFETY: the register file fits the tape (`Evaluator::new`).
        unsafe { crate::expr::tape::value::run(&tape.body, &mut by_kind.slots) };
        V::run_body(tape, &mut by_opcode.slots);
        let half = tape.body.len() / 2;
        V::run_instructions(tape, &tape.body[..half], &mut in_two.slots);
        V::run_instructions(tape, &tape.body[half..], &mut in_two.slots);
        [by_kind.slots, by_opcode.slots, in_two.slots]
    }

    /// The one-dispatch loop runs the same operations as the loop over
    /// instructions, so every interval type's enclosures are the same bit
    /// for bit, whole or in runs.
    #[test]
    fn the_one_dispatch_loop_matches_the_loop_over_instructions() {
        let tape = every_opcode();
        let boxes = [
            [-1.0, 1.0, 0.25, 0.5, -0.3, 0.7],
            [0.1, 0.3, 0.2, 0.9, 1.0, 1.0],
            [-3.0, -1e-3, 2.0, 2.5, -0.6, -0.1],
            [0.0, 0.0, -1e300, 1e300, 0.5, 0.5],
        ];
        let bits = |i: Interval| (i.inf().to_bits(), i.sup().to_bits());
        for b in boxes {
            let inputs = box_inputs(b);
            let [a, o, t] = both_loops::<Interval>(&tape, &inputs);
            for (k, s) in [o, t].iter().enumerate() {
                let same = a.iter().zip(s).all(|(x, y)| bits(*x) == bits(*y));
                assert!(same, "run {k} over {b:?}");
            }
            let guarded = inputs.map(Guarded);
            let [a, o, t] = both_loops::<Guarded>(&tape, &guarded);
            for s in [o, t] {
                assert!(a.iter().zip(&s).all(|(x, y)| bits(x.0) == bits(y.0)));
            }
            let decorated = inputs.map(DecInterval::defined);
            let [a, o, t] = both_loops::<DecInterval>(&tape, &decorated);
            for s in [o, t] {
                let same = a.iter().zip(&s).all(|(x, y)| {
                    bits(x.interval()) == bits(y.interval()) && x.decoration() == y.decoration()
                });
                assert!(same, "decorated over {b:?}");
            }
        }
    }

    /// Both compiled copies of the interval loop give the same enclosures,
    /// bit for bit (where the CPU has FMA; elsewhere there is one copy).
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_fma_copy_of_the_loop_matches_the_portable_one() {
        if !crate::types::rounding::has_fma() {
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
            let inputs = box_inputs(b);
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

    /// f and g = d·∇f of a soft union of two balls (exp and ln: decorated)
    /// and of a sharp one (min: plain intervals), as the ray tracer's tapes.
    fn f_and_g_tapes() -> Vec<Tape> {
        let mut out = Vec::new();
        for soft in [true, false] {
            let mut ctx = Context::new();
            let v = Var::ALL.map(|v| ctx.var(v));
            let ball = |ctx: &mut Context, cx: f64| {
                let c = ctx.constant(cx);
                let dx = ctx.sub(v[0], c);
                let [a, b, c] = [dx, v[1], v[2]].map(|t| ctx.powi(t, 2));
                let ab = ctx.add(a, b);
                let r2 = ctx.add(ab, c);
                let one = ctx.constant(1.0);
                ctx.sub(r2, one)
            };
            let (p, q) = (ball(&mut ctx, -0.5), ball(&mut ctx, 0.5));
            let f = if soft {
                let [ep, eq] = [p, q].map(|t| {
                    let n = ctx.neg(t);
                    ctx.unary(UnaryOp::Exp, n)
                });
                let sum = ctx.add(ep, eq);
                let l = ctx.unary(UnaryOp::Ln, sum);
                ctx.neg(l)
            } else {
                ctx.binary(BinaryOp::Min, p, q)
            };
            let grad = [Var::X, Var::Y, Var::Z].map(|a| ctx.partial(f, a));
            let terms: Vec<Node> = (0..3).map(|k| ctx.mul(grad[k], v[3 + k])).collect();
            let gx = ctx.add(terms[0], terms[1]);
            let g = ctx.add(gx, terms[2]);
            out.push(Tape::new(&ctx, &[f, g]));
        }
        out
    }

    /// f's instructions come first in a tape of f and g, so the evaluation
    /// that stops after them skips g's.
    #[test]
    fn the_first_output_of_a_tape_of_f_and_g_is_final_before_g_is_computed() {
        for tape in f_and_g_tapes() {
            let end = super::first_output_end(&tape);
            assert!(
                end > 0 && end < tape.body.len(),
                "{end} of {}",
                tape.body.len()
            );
        }
    }

    /// Stopping after the first output, or going on, gives what `eval`
    /// gives, bit for bit, decorations included.
    #[test]
    fn evaluating_the_first_output_then_the_rest_matches_eval() {
        let boxes = [
            [-2.0, 2.0, -1.0, 1.0, -0.5, 0.5],
            [-0.1, 0.1, 0.0, 0.2, 0.3, 0.4],
            [1.5, 1.75, 1.0, 1.25, 0.0, 0.5],
        ];
        for tape in f_and_g_tapes() {
            for reading in [vec![0], vec![0, 1]] {
                let mut whole = DecoratedEvaluator::reading(&tape, &reading);
                let mut split = whole.clone();
                for b in boxes {
                    let inputs = [
                        Interval::new(b[0], b[1]),
                        Interval::new(b[2], b[3]),
                        Interval::new(b[4], b[5]),
                        Interval::point(0.6),
                        Interval::point(-0.8),
                        Interval::point(0.0),
                    ]
                    .map(crate::types::DecInterval::defined);
                    let all = whole.eval(&inputs).to_vec();
                    let same = |a: &crate::types::DecInterval, b: &crate::types::DecInterval| {
                        a.interval().inf().to_bits() == b.interval().inf().to_bits()
                            && a.interval().sup().to_bits() == b.interval().sup().to_bits()
                            && a.decoration() == b.decoration()
                    };
                    let (first, rest) = split.eval_first_then(&inputs, |_| false);
                    assert!(same(&first, &all[0]) && rest.is_none(), "over {b:?}");
                    let (first, rest) = split.eval_first_then(&inputs, |_| true);
                    let rest = rest.expect("asked for");
                    assert!(same(&first, &all[0]), "over {b:?}");
                    assert!(rest.iter().zip(&all).all(|(a, b)| same(a, b)), "over {b:?}");
                }
            }
        }
    }
    /// A point evaluator's first output alone is `eval_array`'s, bit for
    /// bit, interpreted (stopping after f) and as machine code, and the
    /// same as a tape of f alone gives.
    #[test]
    fn a_point_evaluators_first_output_alone_is_its_first_of_all() {
        use super::point::PointEvaluator;
        let mut rng = 0x5eed_00f1_u64;
        let mut next = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        for tape in f_and_g_tapes() {
            let mut interpreted = PointEvaluator::new(&tape);
            let mut compiled = PointEvaluator::compiled(&tape);
            let mut both = PointEvaluator::new(&tape);
            for _ in 0..200 {
                let p = [next(), next(), next(), next(), next(), next()];
                let [f, _] = both.eval_array(&p);
                for e in [&mut interpreted, &mut compiled] {
                    assert_eq!(e.eval_first(&p).to_bits(), f.to_bits(), "at {p:?}");
                }
            }
        }
    }
}
