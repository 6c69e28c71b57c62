//! Decorated interval evaluation that skips the decorations' work where no
//! output read can lose them.

use super::Evaluator;
use crate::expr::tape::value::{take_least, take_lost, Guarded};
use crate::expr::tape::Tape;
use crate::types::{DecInterval, Decoration, Interval};

/// Evaluates a tape in decorated intervals, skipping the decorations' work
/// where the outputs whose decorations are read cannot lose them (see
/// [`Tape::output_keeps_decoration`]), and elsewhere wherever no operation
/// of one evaluation may lose them: the same enclosures, and the same
/// decorations for the outputs read, as [`Evaluator<DecInterval>`].
#[derive(Debug, Clone)]
pub enum DecoratedEvaluator<'t> {
    /// Some output read may be undefined or jump: plain intervals that note
    /// whether any operation may have lost a decoration ([`Guarded`]), and
    /// the decorated evaluation run again only where one may have (kept
    /// once made): decorated values take 1.6 times as long to run.
    Guarded {
        /// The evaluation in guarded intervals.
        guarded: Evaluator<'t, Guarded>,
        /// The decorated evaluation, made when first needed.
        full: Option<Box<Evaluator<'t, DecInterval>>>,
        /// The decorated outputs.
        out: Vec<DecInterval>,
        /// Whether the caller reads no decoration past the first output's
        /// but those that cannot be lost: a loss after the first output's
        /// instructions then needs no decorated run.
        first_only: bool,
    },
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
            let out = vec![DecInterval::defined(Interval::ZERO); tape.output_count()];
            let first_only = outputs
                .iter()
                .all(|&k| k == 0 || tape.output_keeps_decoration(k));
            DecoratedEvaluator::Guarded {
                guarded: Evaluator::new(tape),
                full: None,
                out,
                first_only,
            }
        }
    }

    /// Every output at `inputs`, as [`Evaluator::eval`].
    pub fn eval(&mut self, inputs: &[DecInterval; 6]) -> &[DecInterval] {
        match self {
            DecoratedEvaluator::Guarded {
                guarded: e,
                full,
                out,
                ..
            } => {
                take_lost();
                let values = e.eval(&inputs.map(|v| Guarded(v.interval())));
                if take_lost() {
                    return decorated(e.tape, full).eval(inputs);
                }
                let dec = least_decoration(inputs);
                for (o, v) in out.iter_mut().zip(values) {
                    *o = DecInterval::new(v.0, dec);
                }
                out
            }
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

    /// Every output at `inputs` with [`DecoratedEvaluator::eval`]'s
    /// enclosures, the first with its decoration too, and every other with
    /// one no stronger than its own: the least any of them may have, where
    /// the operations past the first output's lost continuity at most (they
    /// may jump, but are defined). That saves a decorated run there: ∇f of
    /// a `max` left open over the box jumps, and a caller that asks whether
    /// f is continuous and ∇f defined (and some part of it jumps) reads no
    /// more.
    pub fn eval_first_exactly(&mut self, inputs: &[DecInterval; 6]) -> &[DecInterval] {
        match self {
            DecoratedEvaluator::Guarded {
                guarded: e,
                full,
                out,
                ..
            } => {
                let tape = e.tape;
                take_lost();
                let mut lost_in_f = false;
                let (_, all) = e.eval_first_then(&inputs.map(|v| Guarded(v.interval())), |_| {
                    lost_in_f = take_lost();
                    !lost_in_f
                });
                let rest = take_least();
                let Some(values) = all.filter(|_| rest != Decoration::Trv) else {
                    return decorated(tape, full).eval(inputs);
                };
                let dec = least_decoration(inputs);
                for (k, (o, v)) in out.iter_mut().zip(values).enumerate() {
                    let kept = k == 0 || tape.output_keeps_decoration(k);
                    *o = DecInterval::new(v.0, if kept { dec } else { dec.min(rest) });
                }
                out
            }
            DecoratedEvaluator::Plain(..) => self.eval(inputs),
        }
    }

    /// Every output at `inputs` where each is defined and continuous there
    /// (decorated [`Decoration::Dac`], as [`DecoratedEvaluator::eval`] would
    /// have it), else `None`, found without a decorated run: an operation
    /// that lost its arguments' decoration passes the loss to every output
    /// that reads it, and every operation of a tape is read by one.
    pub fn eval_continuous(&mut self, inputs: &[DecInterval; 6]) -> Option<&[DecInterval]> {
        if least_decoration(inputs) != Decoration::Dac {
            return None;
        }
        match self {
            DecoratedEvaluator::Guarded {
                guarded: e, out, ..
            } => {
                take_lost();
                let values = e.eval(&inputs.map(|v| Guarded(v.interval())));
                if take_lost() {
                    return None;
                }
                for (o, v) in out.iter_mut().zip(values) {
                    *o = DecInterval::new(v.0, Decoration::Dac);
                }
                Some(out)
            }
            DecoratedEvaluator::Plain(..) => {
                let out = self.eval(inputs);
                out.iter()
                    .all(|v| v.decoration() == Decoration::Dac)
                    .then_some(out)
            }
        }
    }

    /// The first output at `inputs`, as [`DecoratedEvaluator::eval`] has
    /// it, except where an operation may have lost a decoration and
    /// `decided` accepts the enclosure: there the decorated run is skipped
    /// and the output is marked `Trv`, which claims nothing. For a caller
    /// whom such an enclosure tells enough. On a tape whose one output is
    /// this one, every operation feeds it, so a loss means it is not `Dac`.
    pub fn eval_first_unless(
        &mut self,
        inputs: &[DecInterval; 6],
        decided: impl FnOnce(Interval) -> bool,
    ) -> DecInterval {
        match self {
            DecoratedEvaluator::Guarded {
                guarded: e, full, ..
            } => {
                take_lost();
                let x = e
                    .eval_first_then(&inputs.map(|v| Guarded(v.interval())), |_| false)
                    .0
                     .0;
                if !take_lost() {
                    DecInterval::new(x, least_decoration(inputs))
                } else if decided(x) {
                    DecInterval::new(x, Decoration::Trv)
                } else {
                    decorated(e.tape, full).eval(inputs)[0]
                }
            }
            DecoratedEvaluator::Plain(..) => self.eval(inputs)[0],
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
            DecoratedEvaluator::Guarded {
                guarded: e,
                full,
                out,
                first_only,
            } => {
                let tape = e.tape;
                take_lost();
                let dec = least_decoration(inputs);
                let guarded = inputs.map(|v| Guarded(v.interval()));
                // `rest` is asked only if f's instructions lost nothing;
                // otherwise it goes to the decorated run.
                let mut rest = Some(rest);
                let mut lost_in_f = false;
                let ask = |f: &Guarded| {
                    lost_in_f = take_lost();
                    !lost_in_f && rest.take().is_some_and(|r| r(&DecInterval::new(f.0, dec)))
                };
                // Where only f's decoration is read, the rest runs in plain
                // intervals, noting nothing: its outputs are taken to have
                // lost theirs (below), as no caller reads them.
                let (first, all) = if *first_only {
                    e.eval_first_then_rest_in::<Interval>(&guarded, ask)
                } else {
                    e.eval_first_then(&guarded, ask)
                };
                if let Some(rest) = rest.filter(|_| lost_in_f) {
                    return decorated(e.tape, full).eval_first_then(inputs, rest);
                }
                let first = DecInterval::new(first.0, dec);
                let Some(values) = all else {
                    return (first, None);
                };
                let lost = *first_only || take_lost();
                if lost && !*first_only {
                    // The rest lost a decoration: f's value is the same, its
                    // decoration (as the decorated run has it) no weaker.
                    let all = decorated(e.tape, full).eval(inputs);
                    return (all[0], Some(all));
                }
                // Where the rest lost one, the outputs that may have lost it
                // are unread: `Trv`, never more than is known.
                for (k, (o, v)) in out.iter_mut().zip(values).enumerate() {
                    let kept = !lost || k == 0 || tape.output_keeps_decoration(k);
                    *o = DecInterval::new(v.0, if kept { dec } else { Decoration::Trv });
                }
                (first, Some(out))
            }
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

/// The decorated evaluator of `tape`, made on first use.
fn decorated<'a, 't>(
    tape: &'t Tape,
    full: &'a mut Option<Box<Evaluator<'t, DecInterval>>>,
) -> &'a mut Evaluator<'t, DecInterval> {
    full.get_or_insert_with(|| Box::new(Evaluator::new(tape)))
}

/// The weakest decoration of `inputs`: each output of an evaluation that
/// lost none keeps the weakest of the inputs it reads, this or stronger
/// (the same where, as always here, every input is defined).
fn least_decoration(inputs: &[DecInterval; 6]) -> Decoration {
    let dec = inputs.iter().map(|v| v.decoration()).min();
    dec.unwrap_or(Decoration::Dac)
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
    let dec = least_decoration(inputs);
    move |k, v| {
        let kept = tape.keeps_decoration.get(k).copied().unwrap_or(false);
        DecInterval::new(v, if kept { dec } else { Decoration::Trv })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::tape::point::PointOp;
    use crate::expr::{BinaryOp, Context, Node, UnaryOp, Var};

    /// √(x + 0.3) + ln(y + 0.6) + 1/(z − 0.2); max(x, y) + |z − 0.1|·⌊x + 0.5⌋;
    /// x² + y² + z² − 0.5: each with ∇f and ∂²f/∂x∂y.
    fn tapes() -> Vec<Tape> {
        let mut ctx = Context::new();
        let [x, y, z] = [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v));
        let shift = |ctx: &mut Context, v: Node, c: f64| {
            let c = ctx.constant(c);
            ctx.add(v, c)
        };
        let (x3, y6, z2) = (
            shift(&mut ctx, x, 0.3),
            shift(&mut ctx, y, 0.6),
            shift(&mut ctx, z, -0.2),
        );
        let (root, log) = (ctx.unary(UnaryOp::Sqrt, x3), ctx.unary(UnaryOp::Ln, y6));
        let one = ctx.constant(1.0);
        let pole = ctx.div(one, z2);
        let sum = ctx.add(root, log);
        let first = ctx.add(sum, pole);
        let m = ctx.binary(BinaryOp::Max, x, y);
        let z1 = shift(&mut ctx, z, -0.1);
        let a = ctx.unary(UnaryOp::Abs, z1);
        let x5 = shift(&mut ctx, x, 0.5);
        let fl = ctx.unary(UnaryOp::Floor, x5);
        let af = ctx.mul(a, fl);
        let second = ctx.add(m, af);
        let [x2, y2, z2] = [x, y, z].map(|v| ctx.powi(v, 2));
        let s = ctx.add(x2, y2);
        let s = ctx.add(s, z2);
        let third = shift(&mut ctx, s, -0.5);
        [first, second, third]
            .map(|f| {
                let [dx, dy, dz] = [Var::X, Var::Y, Var::Z].map(|v| ctx.partial(f, v));
                let hxy = ctx.partial(dx, Var::Y);
                Tape::new(&ctx, &[f, dx, dy, dz, hxy])
            })
            .into()
    }

    /// [`tapes`], each with what it holds.
    fn named_tapes() -> impl Iterator<Item = (&'static str, Tape)> {
        ["sqrt, ln and a pole", "a crease and a floor", "a sphere"]
            .into_iter()
            .zip(tapes())
    }

    /// Whether two enclosures are the same (both empty counts).
    fn same(a: Interval, b: Interval) -> bool {
        a == b || a.is_empty() && b.is_empty()
    }

    /// The inputs of 216 boxes around the tapes' edges, poles and jumps.
    fn boxes() -> Vec<[DecInterval; 6]> {
        let edges = [-1.0, -0.65, -0.25, 0.15, 0.35, 0.7, 1.0];
        let zero = DecInterval::defined(Interval::ZERO);
        (0..216)
            .map(|n: usize| {
                let b = [n % 6, n / 6 % 6, n / 36]
                    .map(|a| DecInterval::defined(Interval::new(edges[a], edges[a + 1])));
                [b[0], b[1], b[2], zero, zero, zero]
            })
            .collect()
    }

    /// Products by constants of either sign, written either way round, run
    /// by their own opcodes in intervals; the decorated values, which take
    /// the products' general path, have the same enclosures bit for bit
    /// (and the same decorations, where ours are read).
    #[test]
    fn products_by_constants_are_the_general_products() {
        let mut ctx = Context::new();
        let [x, y, z] = [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v));
        let c = |ctx: &mut Context, v: f64| ctx.constant(v);
        let (k1, k2, k3, k4) = (
            c(&mut ctx, -2.5),
            c(&mut ctx, 3.0),
            c(&mut ctx, 0.1),
            c(&mut ctx, -1e300),
        );
        let x3 = ctx.add(x, k3);
        let root = ctx.unary(UnaryOp::Sqrt, x3);
        let a = ctx.mul(k1, root);
        let log = ctx.unary(UnaryOp::Ln, y);
        let b = ctx.mul(log, k2);
        let zx = ctx.mul(z, x);
        let d = ctx.mul(zx, k4);
        let m = ctx.binary(BinaryOp::Max, x, y);
        let e = ctx.mul(k3, m);
        let sum = [b, d, e].into_iter().fold(a, |s, t| ctx.add(s, t));
        let [dx, dy] = [Var::X, Var::Y].map(|v| ctx.partial(sum, v));
        let tape = Tape::new(&ctx, &[sum, dx, dy]);
        let ops = |pick: fn(&PointOp) -> bool| tape.point.iter().filter(|op| pick(op)).count();
        assert!(ops(|op| matches!(op, PointOp::MulPos(..))) >= 2);
        assert!(ops(|op| matches!(op, PointOp::MulNeg(..))) >= 2);
        let mut plain = Evaluator::<Interval>::new(&tape);
        let mut ours = DecoratedEvaluator::new(&tape);
        let mut full = Evaluator::<DecInterval>::new(&tape);
        let edges = [-1e300, -1.0, -0.25, 0.0, 0.15, 1.0, 1e300];
        let bits = |v: Interval| (v.inf().to_bits(), v.sup().to_bits());
        for (i, j, k) in
            (0..6).flat_map(|i| (0..6).flat_map(move |j| (0..6).map(move |k| (i, j, k))))
        {
            let b = [i, j, k].map(|a| Interval::new(edges[a], edges[a + 1]));
            let zero = Interval::ZERO;
            let inputs = [b[0], b[1], b[2], zero, zero, zero];
            let expected = full.eval(&inputs.map(DecInterval::defined)).to_vec();
            let got = ours.eval(&inputs.map(DecInterval::defined)).to_vec();
            let fast = plain.eval(&inputs).to_vec();
            for ((e, g), p) in expected.iter().zip(&got).zip(&fast) {
                assert_eq!(bits(e.interval()), bits(g.interval()), "{inputs:?}");
                assert_eq!(bits(e.interval()), bits(*p), "{inputs:?}");
                assert_eq!(e.decoration(), g.decoration(), "{inputs:?}");
            }
        }
    }

    /// Over boxes around square roots' and logarithms' edges, poles and
    /// jumps, `eval_continuous` answers exactly where every output of the
    /// decorated run is `Dac`, with the same enclosures.
    #[test]
    fn continuous_outputs_are_those_the_decorated_run_calls_continuous() {
        let (mut some, mut none) = (0, 0);
        for (source, tape) in named_tapes() {
            let mut ours = DecoratedEvaluator::new(&tape);
            let mut full = Evaluator::<DecInterval>::new(&tape);
            for inputs in boxes() {
                let expected = full.eval(&inputs).to_vec();
                let dac = expected.iter().all(|v| v.decoration() == Decoration::Dac);
                match ours.eval_continuous(&inputs) {
                    Some(out) => {
                        assert!(dac, "{source} over {inputs:?}");
                        for (o, e) in out.iter().zip(&expected) {
                            assert_eq!(o.interval(), e.interval());
                            assert_eq!(o.decoration(), Decoration::Dac);
                        }
                        some += 1;
                    }
                    None => {
                        assert!(!dac, "{source} over {inputs:?}");
                        none += 1;
                    }
                }
            }
        }
        assert!(some > 100 && none > 100, "{some} {none}");
    }

    /// `eval_first_unless` gives the decorated run's first output, or the
    /// same enclosure marked `Trv` where that run would not be `Dac` and
    /// the enclosure is accepted.
    #[test]
    fn the_first_output_is_marked_trv_only_where_it_is_not_continuous() {
        let (mut skipped, mut run) = (0, 0);
        let mut ctx = Context::new();
        let [x, y] = [Var::X, Var::Y].map(|v| ctx.var(v));
        let root = ctx.unary(UnaryOp::Sqrt, x);
        let fl = ctx.unary(UnaryOp::Floor, y);
        let f = ctx.add(root, fl);
        // One output, and f with its derivatives.
        for (tape, one_output) in [
            (Tape::new(&ctx, &[f]), true),
            (tapes().remove(1), false),
            (tapes().remove(0), false),
        ] {
            let mut ours = DecoratedEvaluator::new(&tape);
            let mut full = Evaluator::<DecInterval>::new(&tape);
            for inputs in boxes() {
                let expected = full.eval(&inputs)[0];
                let got = ours.eval_first_unless(&inputs, |x| x.contains(0.0));
                assert!(same(got.interval(), expected.interval()), "{inputs:?}");
                if got.decoration() == expected.decoration() {
                    run += 1;
                } else {
                    assert_eq!(got.decoration(), Decoration::Trv);
                    assert!(!one_output || expected.decoration() < Decoration::Dac);
                    assert!(got.interval().contains(0.0));
                    skipped += 1;
                }
            }
        }
        assert!(skipped > 20 && run > 100, "{skipped} {run}");
    }

    /// `eval_first_exactly` gives the decorated run's enclosures and first
    /// decoration, and no other decoration stronger than the run's; where
    /// past f the run is defined but jumps (the crease's ∇f), every other
    /// output is `Def` or better without a decorated run, so whether ∇f
    /// jumps, and whether it is defined, read the same as from the run.
    #[test]
    fn the_first_output_is_exact_and_the_rest_no_stronger() {
        let (mut jumps, mut exact) = (0, 0);
        for (source, tape) in named_tapes() {
            let mut ours = DecoratedEvaluator::new(&tape);
            let mut full = Evaluator::<DecInterval>::new(&tape);
            for inputs in boxes() {
                let expected = full.eval(&inputs).to_vec();
                let got = ours.eval_first_exactly(&inputs).to_vec();
                for (g, e) in got.iter().zip(&expected) {
                    assert!(same(g.interval(), e.interval()), "{source} over {inputs:?}");
                    assert!(g.decoration() <= e.decoration(), "{source} over {inputs:?}");
                }
                assert_eq!(got[0].decoration(), expected[0].decoration(), "{source}");
                let least = |v: &[DecInterval]| v[1..].iter().map(|v| v.decoration()).min();
                assert_eq!(least(&got), least(&expected), "{source} over {inputs:?}");
                if got == expected {
                    exact += 1;
                } else {
                    jumps += 1;
                }
            }
        }
        assert!(jumps > 20 && exact > 100, "{jumps} {exact}");
    }

    /// An evaluator reading f's decoration alone (the tracer's), whose
    /// instructions past f run in plain intervals: f as the decorated run
    /// has it, every other output's enclosure the run's, and no decoration
    /// stronger.
    #[test]
    fn reading_f_alone_gives_the_decorated_runs_f_and_enclosures() {
        let (mut all, mut first) = (0, 0);
        for (source, tape) in named_tapes() {
            let mut ours = DecoratedEvaluator::reading(&tape, &[0]);
            let mut full = Evaluator::<DecInterval>::new(&tape);
            for inputs in boxes() {
                let expected = full.eval(&inputs).to_vec();
                let wants = |f: &DecInterval| f.interval().contains(0.0);
                let (f, rest) = ours.eval_first_then(&inputs, wants);
                assert!(same(f.interval(), expected[0].interval()), "{source}");
                assert_eq!(
                    f.decoration(),
                    expected[0].decoration(),
                    "{source} over {inputs:?}"
                );
                let Some(rest) = rest else {
                    assert!(!wants(&expected[0]), "{source} over {inputs:?}");
                    first += 1;
                    continue;
                };
                for (g, e) in rest.iter().zip(&expected) {
                    assert!(same(g.interval(), e.interval()), "{source} over {inputs:?}");
                    assert!(g.decoration() <= e.decoration(), "{source} over {inputs:?}");
                }
                all += 1;
            }
        }
        assert!(all > 100 && first > 100, "{all} {first}");
    }
}
