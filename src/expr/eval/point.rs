//! f64 points evaluated as machine code, or interpreted until a tape has
//! earned its compilation.

use super::Evaluator;
use crate::expr::tape::{Tape, Tier};
use code::Compiled;
use std::sync::Arc;

/// Evaluates a tape at f64 points with its machine code (with the `jit`
/// feature), or the interpreter where there is none: the same
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
    /// The machine code that runs, and its tier.
    compiled: Option<(Arc<Compiled>, Tier)>,
    /// Evaluations still to run before the next tier's code replaces what
    /// runs now (0: the last tier runs, or none can).
    until_next_tier: u32,
}

/// Evaluations a [`PointEvaluator`] interprets before it compiles its tape
/// at [`Tier::Baseline`]. Compiling at that tier costs about as much as a
/// few hundred to a thousand interpreted evaluations, so tapes that only a
/// few rays meet (the shapes of a few leaves) never pay it, and the others
/// pay it back many times over.
pub(super) const EVALUATIONS_BEFORE_COMPILING: u32 = 512;

/// Evaluations a [`PointEvaluator`] runs as [`Tier::Baseline`] code before
/// it compiles its tape again at [`Tier::Optimised`]: about as many as the
/// optimised compile costs in the time it saves. On the bear's f and g
/// (1,161 operations, a 2-core AMD EPYC VM) the optimised compile takes 5.6
/// ms against 1.8, and its code 650 ns an evaluation against 870.
pub(super) const EVALUATIONS_BEFORE_OPTIMISING: u32 = 16_384;

impl<'t> PointEvaluator<'t> {
    /// Prepares the register file; the tape is compiled once this
    /// evaluator has run it a few hundred times, and optimised once it has
    /// run that code some thousands of times (once per tape and tier,
    /// shared by every evaluator and thread).
    pub fn new(tape: &'t Tape) -> Self {
        // Code that another evaluator (or thread) has compiled runs at once:
        // each render worker makes its own evaluators.
        let optimised = code::compiled_already(tape, Tier::Optimised);
        let (compiled, until_next_tier) =
            match (&optimised, code::compiled_already(tape, Tier::Baseline)) {
                (Some(Some(c)), _) => (Some((c.clone(), Tier::Optimised)), 0),
                (_, Some(Some(c))) => {
                    // Optimising may have been tried, and refused, already.
                    let until = if optimised.is_some() {
                        0
                    } else {
                        EVALUATIONS_BEFORE_OPTIMISING
                    };
                    (Some((c, Tier::Baseline)), until)
                }
                // The tape cannot be compiled.
                (_, Some(None)) => (None, 0),
                _ => (None, EVALUATIONS_BEFORE_COMPILING),
            };
        PointEvaluator {
            interpreter: Evaluator::new(tape),
            compiled,
            until_next_tier,
        }
    }

    /// [`PointEvaluator::new`], compiling the tape at once, optimised.
    pub fn compiled(tape: &'t Tape) -> Self {
        PointEvaluator {
            interpreter: Evaluator::new(tape),
            compiled: code::machine_code(tape, Tier::Optimised).map(|c| (c, Tier::Optimised)),
            until_next_tier: 0,
        }
    }

    /// Whether machine code runs (not the interpreter).
    pub fn is_compiled(&self) -> bool {
        self.compiled.is_some()
    }

    /// Whether optimised machine code runs.
    pub fn is_optimised(&self) -> bool {
        matches!(self.compiled, Some((_, Tier::Optimised)))
    }

    /// Counts `n` evaluations of the tape made elsewhere (in a batch) toward
    /// compiling it, as if this evaluator had run them; whether machine code
    /// runs now.
    pub fn count_evaluations(&mut self, n: u32) -> bool {
        if self.until_next_tier > 0 {
            self.until_next_tier = self.until_next_tier.saturating_sub(n);
            if self.until_next_tier == 0 {
                self.next_tier();
            }
        }
        self.compiled.is_some()
    }

    /// Replaces the interpreter by baseline code, or that by optimised code
    /// (where the next tier cannot be compiled, what runs goes on running).
    #[cold]
    fn next_tier(&mut self) {
        let tape = self.interpreter.tape;
        match self.compiled {
            None => {
                if let Some(c) = code::machine_code(tape, Tier::Baseline) {
                    self.compiled = Some((c, Tier::Baseline));
                    self.until_next_tier = EVALUATIONS_BEFORE_OPTIMISING;
                }
            }
            Some((_, Tier::Baseline)) => {
                if let Some(c) = code::machine_code(tape, Tier::Optimised) {
                    self.compiled = Some((c, Tier::Optimised));
                }
            }
            Some((_, Tier::Optimised)) => {}
        }
    }

    /// The first `N` outputs at `inputs` (x, y, z, dx, dy, dz).
    ///
    /// # Panics
    /// When the tape has fewer than `N` outputs.
    #[inline]
    pub fn eval_array<const N: usize>(&mut self, inputs: &[f64; 6]) -> [f64; N] {
        self.count_towards_next_tier();
        let Some((code, _)) = &self.compiled else {
            return self.interpreter.eval_array(inputs);
        };
        // SAFETY: `Evaluator::new` made the register file at least the
        // tape's slot count, with its constants in place.
        self.interpreter
            .eval_array_by(inputs, |_, slots| unsafe { code.run(slots) })
    }

    /// The first output alone at `inputs`, the same value as
    /// [`PointEvaluator::eval_array`]'s: by the machine code where the tape
    /// has it (which computes every output), else by the interpreter up to
    /// the first output's last instruction (f's, in a tape of f and g).
    ///
    /// # Panics
    /// When the tape has no output.
    #[inline]
    pub fn eval_first(&mut self, inputs: &[f64; 6]) -> f64 {
        if self.compiled.is_some() || self.interpreter.tape.outputs.is_empty() {
            let [first] = self.eval_array(inputs);
            return first;
        }
        self.count_towards_next_tier();
        self.interpreter.eval_first_then(inputs, |_| false).0
    }

    /// Counts an evaluation towards the next tier of machine code, and
    /// compiles it once enough were made.
    #[inline(always)]
    fn count_towards_next_tier(&mut self) {
        if self.until_next_tier > 0 {
            self.until_next_tier -= 1;
            if self.until_next_tier == 0 {
                self.next_tier();
            }
        }
    }
}

/// Machine code from the `jit` feature's compiler.
#[cfg(feature = "jit")]
mod code {
    pub(super) use crate::expr::jit::{compiled_already, machine_code, Compiled};
}

/// Without the `jit` feature no tape has machine code: the interpreter runs.
#[cfg(not(feature = "jit"))]
mod code {
    use crate::expr::tape::{Tape, Tier};
    use std::sync::Arc;

    /// Machine code, of which there is none.
    #[derive(Debug)]
    pub(crate) enum Compiled {}

    impl Compiled {
        /// Never called: no value of this type exists.
        pub(crate) unsafe fn run(&self, _slots: &mut [f64]) {
            match *self {}
        }
    }

    pub(super) fn machine_code(_tape: &Tape, _tier: Tier) -> Option<Arc<Compiled>> {
        None
    }

    pub(super) fn compiled_already(_tape: &Tape, _tier: Tier) -> Option<Option<Arc<Compiled>>> {
        Some(None)
    }
}
