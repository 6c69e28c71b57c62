//! Decorated interval evaluation that skips the decorations' work where no
//! output read can lose them.

use super::Evaluator;
use crate::expr::tape::Tape;
use crate::types::{DecInterval, Decoration, Interval};

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
                let decorate = decorator(e.tape, inputs);
                let values = e.eval(&inputs.map(|v| v.interval()));
                for (k, (o, &v)) in out.iter_mut().zip(values).enumerate() {
                    *o = decorate(k, v);
                }
                out
            }
        }
    }

    /// The first output at `inputs`, and every output where `rest` asks for
    /// them given it, as [`Evaluator::eval_first_then`].
    pub fn eval_first_then(
        &mut self,
        inputs: &[DecInterval; 6],
        rest: impl FnOnce(&DecInterval) -> bool,
    ) -> (DecInterval, Option<&[DecInterval]>) {
        match self {
            DecoratedEvaluator::Decorated(e) => e.eval_first_then(inputs, rest),
            DecoratedEvaluator::Plain(e, out) => {
                let decorate = decorator(e.tape, inputs);
                let plain = inputs.map(|v| v.interval());
                let (first, all) = e.eval_first_then(&plain, |&v| rest(&decorate(0, v)));
                let first = decorate(0, first);
                let Some(values) = all else {
                    return (first, None);
                };
                for (k, (o, &v)) in out.iter_mut().zip(values).enumerate() {
                    *o = decorate(k, v);
                }
                (first, Some(out))
            }
        }
    }
}

/// Output `k`'s decorated value from its plain one, for the undecorated
/// evaluation of `tape` at `inputs`: each output keeps the weakest
/// decoration of the inputs it reads, and the weakest of all six is that or
/// weaker (the same where, as always here, every input is defined); an
/// output that may lose it is `Trv`.
fn decorator<'a>(
    tape: &'a Tape,
    inputs: &[DecInterval; 6],
) -> impl Fn(usize, Interval) -> DecInterval + 'a {
    let dec = inputs.iter().map(|v| v.decoration()).min();
    let dec = dec.unwrap_or(Decoration::Dac);
    move |k, v| {
        let kept = tape.keeps_decoration.get(k).copied().unwrap_or(false);
        DecInterval::new(v, if kept { dec } else { Decoration::Trv })
    }
}
