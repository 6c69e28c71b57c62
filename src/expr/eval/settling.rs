//! Interval evaluation of a tape's first output that also says whether the
//! box settles every branch: one run for both, where a mesh's cells would
//! otherwise be enclosed once to be found and again to be settled.

use super::Evaluator;
use crate::expr::tape::simplify::{forget_ways, ways_settled, Settling};
use crate::expr::tape::value::take_lost;
use crate::expr::tape::Tape;
use crate::types::Interval;

/// Evaluates a tape's first output in plain intervals over boxes where f is
/// known to be defined and continuous, noting whether each box settles
/// every branching instruction, as [`Tape::settled_all_over`] would.
#[derive(Debug, Clone)]
pub struct SettlingEvaluator<'t> {
    eval: Evaluator<'t, Settling>,
    /// Whether the tape's constants lost a decoration when computed.
    prelude_lost: bool,
}

impl<'t> SettlingEvaluator<'t> {
    /// Prepares the evaluator.
    pub fn new(tape: &'t Tape) -> Self {
        take_lost();
        let eval = Evaluator::new(tape);
        SettlingEvaluator {
            eval,
            prelude_lost: take_lost(),
        }
    }

    /// The first output's enclosure over `inputs`, and whether the box
    /// settles every branching instruction: `Some(settled)` where no
    /// operation lost its arguments' decoration, `None` where one may have
    /// (then only [`Tape::settled_all_over`] can say).
    pub fn eval(&mut self, inputs: &[Interval; 6]) -> (Interval, Option<bool>) {
        forget_ways();
        take_lost();
        let out = self.eval.eval(&inputs.map(Settling))[0].0;
        let lost = take_lost() || self.prelude_lost;
        (out, (!lost).then(ways_settled))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::DecInterval;

    /// Over boxes around creases, a pole and a square root's edge, the
    /// enclosure is the plain one and the answer, where given, is
    /// [`Tape::settled_all_over`]'s; it is given wherever nothing jumps.
    #[test]
    fn one_run_encloses_f_and_says_what_settling_says() {
        let [tape, _] = crate::expr::tape::simplify::tests::creased_tapes();
        let mut settling = SettlingEvaluator::new(&tape);
        let mut plain = Evaluator::<Interval>::new(&tape);
        let edges = [-1.0, -0.6, -0.1, 0.2, 0.45, 0.8, 1.0, 1.3];
        let (mut settled, mut open, mut unknown) = (0, 0, 0);
        for i in 0..7 {
            for j in 0..7 {
                for k in 0..7 {
                    let [x, y, z] = [i, j, k].map(|a| Interval::new(edges[a], edges[a + 1]));
                    let zero = Interval::ZERO;
                    let inputs = [x, y, z, zero, zero, zero];
                    let (value, answer) = settling.eval(&inputs);
                    let expected = plain.eval(&inputs)[0];
                    let empty = value.is_empty() && expected.is_empty();
                    assert!(empty || value == expected, "{value:?} {expected:?}");
                    let all = tape.settled_all_over(&inputs.map(DecInterval::defined));
                    let jumps = x.inf() < -0.5
                        || (y.inf() <= 0.9 && 0.9 <= y.sup())
                        || (x.inf() <= y.sup() && y.inf() <= x.sup());
                    match answer {
                        Some(s) => {
                            assert_eq!(s, all.is_some(), "{inputs:?}");
                            if s {
                                settled += 1
                            } else {
                                open += 1
                            }
                        }
                        None => {
                            assert!(jumps, "{inputs:?}");
                            unknown += 1
                        }
                    }
                }
            }
        }
        assert!(
            settled > 20 && open > 20 && unknown > 20,
            "{settled} {open} {unknown}"
        );
    }
}
