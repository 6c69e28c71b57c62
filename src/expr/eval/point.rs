//! f64 points evaluated as machine code, or interpreted until a tape has
//! earned its compilation.

use super::Evaluator;
use crate::expr::tape::Tape;
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
    compiled: Option<Arc<Compiled>>,
    /// Evaluations the interpreter still runs before the tape is compiled
    /// (0: compiled, or never to be).
    until_compiled: u32,
}

/// Evaluations a [`PointEvaluator`] interprets before it compiles its tape.
/// Compiling costs about as much as a thousand interpreted evaluations, so
/// tapes that only a few rays meet (the shapes of a few leaves) never pay
/// it, and the others pay it back many times over.
pub(super) const EVALUATIONS_BEFORE_COMPILING: u32 = 512;

impl<'t> PointEvaluator<'t> {
    /// Prepares the register file; the tape is compiled once this
    /// evaluator has run it a few hundred times (once per tape, shared by
    /// every evaluator and thread).
    pub fn new(tape: &'t Tape) -> Self {
        // A tape that another evaluator (or thread) has compiled runs as
        // machine code at once: each render worker makes its own evaluators.
        let (compiled, until_compiled) = match code::compiled_already(tape) {
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
            compiled: code::machine_code(tape),
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
                self.compiled = code::machine_code(self.interpreter.tape);
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
                    self.compiled = code::machine_code(self.interpreter.tape);
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

/// Machine code from the `jit` feature's compiler.
#[cfg(feature = "jit")]
mod code {
    pub(super) use crate::expr::jit::{compiled_already, machine_code, Compiled};
}

/// Without the `jit` feature no tape has machine code: the interpreter runs.
#[cfg(not(feature = "jit"))]
mod code {
    use crate::expr::tape::Tape;
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

    pub(super) fn machine_code(_tape: &Tape) -> Option<Arc<Compiled>> {
        None
    }

    pub(super) fn compiled_already(_tape: &Tape) -> Option<Option<Arc<Compiled>>> {
        Some(None)
    }
}
