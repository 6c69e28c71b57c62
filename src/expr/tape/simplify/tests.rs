//! Tests of tape shortening: the ways settled, the tapes written, their lengths.

use super::*;
use crate::expr::{Context, Evaluator, Node};
use crate::types::Interval;

fn boxed(lo: [f64; 3], hi: [f64; 3]) -> [DecInterval; 6] {
    let mut v = [DecInterval::defined(Interval::ENTIRE); 6];
    for k in 0..3 {
        v[k] = DecInterval::defined(Interval::new(lo[k], hi[k]));
    }
    v
}

/// max(min(x, y), |z| − 1) + sign(x − 5): over x, y in [1, 2], z in [4, 5]
/// the `max` takes `|z| − 1`, `|z|` is `z`, `sign` is −1, and `min`
/// (read only by the `max`) is gone.
#[test]
fn a_decided_box_keeps_only_the_branches_it_takes() {
    let mut ctx = Context::new();
    let [x, y, z] = [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v));
    let m = ctx.binary(BinaryOp::Min, x, y);
    let a = ctx.unary(UnaryOp::Abs, z);
    let one = ctx.constant(1.0);
    let five = ctx.constant(5.0);
    let a1 = ctx.sub(a, one);
    let top = ctx.binary(BinaryOp::Max, m, a1);
    let x5 = ctx.sub(x, five);
    let s = ctx.unary(UnaryOp::Sign, x5);
    let f = ctx.add(top, s);
    let tape = Tape::new(&ctx, &[f]);
    let region = boxed([1.0, 1.0, 4.0], [2.0, 2.0, 5.0]);
    let decisions = tape.settled_over(&region);
    assert_eq!(decisions.len(), 3, "{decisions:?}");
    let short = tape.shortened(&decisions);
    assert!(short.body().len() < tape.body().len());
    assert!(short.body().iter().all(|i| !matches!(
        i,
        Instr::Binary {
            op: BinaryOp::Min | BinaryOp::Max,
            ..
        } | Instr::Unary {
            op: UnaryOp::Abs | UnaryOp::Sign,
            ..
        }
    )));
    let mut long = Evaluator::<f64>::new(&tape);
    let mut shorter = Evaluator::<f64>::new(&short);
    for p in [[1.0, 1.5, 4.0], [2.0, 1.0, 5.0], [1.25, 1.75, 4.5]] {
        let input = [p[0], p[1], p[2], 0.0, 0.0, 0.0];
        assert_eq!(long.eval(&input)[0], shorter.eval(&input)[0]);
        assert_eq!(shorter.eval(&input)[0], p[2] - 2.0);
    }
    assert!(!tape.leaves_open(&decisions));
    // The min is open there, so not every branch is settled.
    assert!(tape.settled_all_over(&region).is_none());
    let min_settled = boxed([1.0, 3.0, 4.0], [2.0, 4.0, 5.0]);
    assert_eq!(
        tape.settled_all_over(&min_settled),
        Some(tape.settled_over(&min_settled))
    );
    // Nothing is decided where the box straddles every branch.
    let open = boxed([-1.0, -1.0, -1.0], [6.0, 6.0, 1.0]);
    assert!(tape.settled_over(&open).is_empty());
    assert!(tape.leaves_open(&tape.settled_over(&open)));
    // Where the max takes |z| − 1 but sign(x − 5) is open, the open
    // min is dead and the sign is not.
    let half = boxed([4.0, 1.0, 4.0], [6.0, 2.0, 5.0]);
    let d = tape.settled_over(&half);
    assert!(tape.leaves_open(&d));
    assert_eq!(tape.leaves_open(&d), tape.shortened(&d).has_branches());
    // And on boxes of every kind around the branches' creases.
    let edges = [-2.0, 0.5, 1.5, 3.0, 4.5, 5.5, 7.0];
    for (i, j, k) in (0..6).flat_map(|i| (0..6).flat_map(move |j| (0..6).map(move |k| (i, j, k)))) {
        let region = boxed(
            [edges[i], edges[j], edges[k] - 3.0],
            [edges[i + 1], edges[j + 1], edges[k + 1] - 3.0],
        );
        let d = tape.settled_over(&region);
        assert_eq!(
            tape.leaves_open(&d),
            tape.shortened(&d).has_branches(),
            "{region:?}"
        );
    }
}

/// The length the backward pass predicts is the shortened tape's, over
/// boxes that settle some branches, all or none.
#[test]
fn the_shortened_length_is_the_shortened_tapes() {
    let edges = [-1.0, -0.6, -0.1, 0.2, 0.45, 0.8, 1.0, 1.3];
    let mut shorter = 0;
    for tape in &creased_tapes() {
        for (i, j, k) in
            (0..7).flat_map(|i| (0..7).flat_map(move |j| (0..7).map(move |k| (i, j, k))))
        {
            let region = boxed(
                [edges[i], edges[j], edges[k]],
                [edges[i + 1], edges[j + 1], edges[k + 1]],
            );
            let d = tape.settled_over(&region);
            let len = tape.shortened(&d).body().len();
            assert_eq!(tape.shortened_len(&d), len, "{region:?}");
            shorter += usize::from(len < tape.body().len());
        }
    }
    assert!(shorter > 100, "{shorter}");
}

/// The tape of some of a formula's outputs cut from the tape of all of them
/// has the length its backward pass predicts, and that of the tape compiled
/// for those outputs alone, for every choice of f, g and ∇f's partials.
#[test]
fn a_tape_kept_to_some_outputs_is_as_long_as_one_compiled_for_them() {
    // max(min(x, y² − z), |z − 0.3| − 0.5) + √(x² + y²)·eᶻ
    let mut ctx = Context::new();
    let top = crease(&mut ctx);
    let [x, y, z] = [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v));
    let x2 = ctx.powi(x, 2);
    let y2 = ctx.powi(y, 2);
    let r2 = ctx.add(x2, y2);
    let r = ctx.unary(UnaryOp::Sqrt, r2);
    let e = ctx.unary(UnaryOp::Exp, z);
    let re = ctx.mul(r, e);
    let f = ctx.add(top, re);
    let g = ctx.directional(f);
    let grad = [Var::X, Var::Y, Var::Z].map(|v| ctx.partial(f, v));
    let outputs = [f, g, grad[0], grad[1], grad[2]];
    let all = Tape::new(&ctx, &outputs);
    for mask in 1u32..32 {
        let keep: Vec<bool> = (0..5).map(|k| mask & (1 << k) != 0).collect();
        let chosen = outputs.iter().zip(&keep).filter(|(_, &k)| k);
        let chosen: Vec<_> = chosen.map(|(&o, _)| o).collect();
        let alone = Tape::new(&ctx, &chosen).body().len();
        assert_eq!(all.keeping_len(&keep), alone, "{keep:?}");
        assert_eq!(all.keeping(&keep).body().len(), alone, "{keep:?}");
    }
}

/// The first output's enclosure that settling finds is the decorated
/// evaluator's, interval and decoration, over boxes around every crease
/// (where some are not defined or continuous).
#[test]
fn settling_encloses_the_first_output_as_the_decorated_evaluator() {
    let edges = [-1.0, -0.6, -0.1, 0.2, 0.45, 0.8, 1.0, 1.3];
    let mut weaker = 0;
    for tape in &creased_tapes() {
        let mut e = crate::expr::DecoratedEvaluator::new(tape);
        for (i, j, k) in
            (0..7).flat_map(|i| (0..7).flat_map(move |j| (0..7).map(move |k| (i, j, k))))
        {
            let region = boxed(
                [edges[i], edges[j], edges[k]],
                [edges[i + 1], edges[j + 1], edges[k + 1]],
            );
            let (_, first) = tape.settled_and_first_over(&region);
            let expected = e.eval(&region)[0];
            let (a, b) = (first.interval(), expected.interval());
            assert!(a == b || (a.is_empty() && b.is_empty()), "{region:?}");
            assert_eq!(first.decoration(), expected.decoration(), "{region:?}");
            weaker += usize::from(first.decoration() < Decoration::Dac);
        }
    }
    // Both kinds of box were met.
    assert!(weaker > 10 && weaker < 600, "{weaker}");
}

/// Settling in plain intervals, where no decoration is lost, finds the
/// ways (and the first output's enclosure) the decorated run finds, on f's tape and on ∇f's (which holds
/// `choose` and `dirac`), over boxes around every crease, where some
/// square roots are undefined and some quotients' divisors hold 0.
#[test]
fn settling_in_plain_intervals_finds_the_decorated_ways() {
    let tapes = creased_tapes();
    let edges = [-1.0, -0.6, -0.1, 0.2, 0.45, 0.8, 1.0, 1.3];
    let (mut quick, mut decorated) = (0, 0);
    for tape in &tapes {
        for (i, j, k) in
            (0..7).flat_map(|i| (0..7).flat_map(move |j| (0..7).map(move |k| (i, j, k))))
        {
            let region = boxed(
                [edges[i], edges[j], edges[k]],
                [edges[i + 1], edges[j + 1], edges[k + 1]],
            );
            for stop_at_open in [false, true] {
                match tape.settle_quickly(&region, stop_at_open) {
                    Some(ways) => {
                        quick += 1;
                        let expected = tape.settle_decorated(&region, stop_at_open);
                        assert_eq!(ways, expected, "{region:?}");
                    }
                    None => decorated += 1,
                }
            }
        }
    }
    // Both runs were met, many times each.
    assert!(decorated > 100 && quick > 100, "{quick}, {decorated}");
}

/// max(min(x, y² − z), |z − 0.3| − 0.5), built in `ctx`: a `min`, a `max`
/// and an `abs`, each deciding somewhere in [-1, 1.3]³.
fn crease(ctx: &mut Context) -> Node {
    let [x, y, z] = [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v));
    let y2 = ctx.powi(y, 2);
    let y2z = ctx.sub(y2, z);
    let m = ctx.binary(BinaryOp::Min, x, y2z);
    let c3 = ctx.constant(0.3);
    let z3 = ctx.sub(z, c3);
    let a = ctx.unary(UnaryOp::Abs, z3);
    let half = ctx.constant(0.5);
    let a5 = ctx.sub(a, half);
    ctx.binary(BinaryOp::Max, m, a5)
}

/// The tape of f = max(min(x, y² − z), |z − 0.3| − 0.5) + 0.1·sign(x − y)
/// plus 0.01·√(x + 0.5) + 0.01/(y − 0.9), and that of f and ∇f (which
/// holds `choose` and `dirac`).
pub(crate) fn creased_tapes() -> [Tape; 2] {
    let mut ctx = Context::new();
    let top = crease(&mut ctx);
    let [x, y] = [Var::X, Var::Y].map(|v| ctx.var(v));
    let half = ctx.constant(0.5);
    let xy = ctx.sub(x, y);
    let sign = ctx.unary(UnaryOp::Sign, xy);
    let sign = ctx.scale(0.1, sign);
    let x5 = ctx.add(x, half);
    let root = ctx.unary(UnaryOp::Sqrt, x5);
    let root = ctx.scale(0.01, root);
    let c9 = ctx.constant(0.9);
    let y9 = ctx.sub(y, c9);
    let hundredth = ctx.constant(0.01);
    let pole = ctx.div(hundredth, y9);
    let f = [top, sign, root, pole]
        .into_iter()
        .reduce(|s, t| ctx.add(s, t))
        .unwrap();
    let [dx, dy, dz] = [Var::X, Var::Y, Var::Z].map(|v| ctx.partial(f, v));
    [Tape::new(&ctx, &[f]), Tape::new(&ctx, &[f, dx, dy, dz])]
}

/// A branch that may be undefined somewhere in the region is never
/// dropped: the short tape must stay undefined where the tape is.
#[test]
fn an_undefined_branch_is_never_dropped() {
    let mut ctx = Context::new();
    let [x, y] = [Var::X, Var::Y].map(|v| ctx.var(v));
    let r = ctx.unary(UnaryOp::Sqrt, y);
    let ten = ctx.constant(10.0);
    let big = ctx.add(r, ten);
    let f = ctx.binary(BinaryOp::Min, x, big);
    let tape = Tape::new(&ctx, &[f]);
    // y < 0 on part of the box: sqrt(y) is undefined there.
    let region = boxed([0.0, -1.0, 0.0], [1.0, 1.0, 1.0]);
    assert!(tape.settled_over(&region).is_empty());
    let region = boxed([0.0, 0.5, 0.0], [1.0, 1.0, 1.0]);
    assert_eq!(tape.settled_over(&region).len(), 1);
}

/// g of a chain of `min`s past a circle's centre stays short: the `choose`
/// that g writes for `min(a, b)` drops `a′` where `b` is taken, even where
/// `a′` is undefined (`a` a root of squares, at its centre), as `choose`
/// never reads the branch it does not take. Were it dropped only where `a′`
/// is defined, every later `choose` of the chain would stay in the short
/// tape, with the derivative of every term it reads (the prospero slab's
/// top face: 4,913 instructions of f and g instead of 284).
#[test]
fn a_chain_of_mins_past_a_circles_centre_keeps_g_short() {
    let mut ctx = Context::new();
    let [x, y, z] = [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v));
    // f = min(min(…min(√(x² + y²) + 10, x)…, √((x − k)² + y²) + 10 + k), z)
    let x2 = ctx.powi(x, 2);
    let y2 = ctx.powi(y, 2);
    let r2 = ctx.add(x2, y2);
    let r = ctx.unary(UnaryOp::Sqrt, r2);
    let ten = ctx.constant(10.0);
    let far = ctx.add(r, ten);
    let mut f = ctx.binary(BinaryOp::Min, far, x);
    for k in 1..=8 {
        let c = ctx.constant(k as f64);
        let xc = ctx.sub(x, c);
        let xc2 = ctx.powi(xc, 2);
        let d2 = ctx.add(xc2, y2);
        let d = ctx.unary(UnaryOp::Sqrt, d2);
        let off = ctx.constant(10.0 + k as f64);
        let term = ctx.add(d, off);
        f = ctx.binary(BinaryOp::Min, f, term);
    }
    f = ctx.binary(BinaryOp::Min, f, z);
    let g = ctx.directional(f);
    let tape = Tape::new(&ctx, &[f, g]);
    // The first circle's centre is inside; f takes x or z there.
    let mut region = boxed([-0.25, -0.25, -0.25], [0.25, 0.25, 0.25]);
    for (k, d) in [0.6, -0.48, 0.64].into_iter().enumerate() {
        region[3 + k] = DecInterval::defined(Interval::point(d));
    }
    let short = tape.shortened(&tape.settled_over(&region));
    let roots = |t: &Tape| {
        let is_root = |i: &Instr| {
            matches!(
                i,
                Instr::Unary {
                    op: UnaryOp::Sqrt,
                    ..
                }
            )
        };
        t.body().iter().filter(|i| is_root(i)).count()
    };
    assert_eq!(
        roots(&short),
        0,
        "{} of {} instructions",
        short.body().len(),
        tape.body().len()
    );
    // The same values, at the centre too, where a′ is not a number.
    let mut long = Evaluator::<f64>::new(&tape);
    let mut brief = Evaluator::<f64>::new(&short);
    for p in [
        [0.0, 0.0, 0.1],
        [0.2, -0.1, -0.2],
        [-0.25, 0.25, 0.0],
        [0.1, 0.0, 0.25],
    ] {
        let input = [p[0], p[1], p[2], 0.6, -0.48, 0.64];
        let (a, b) = (long.eval(&input), brief.eval(&input));
        assert!(a[1].is_finite(), "at {p:?}");
        assert_eq!((a[0], a[1]), (b[0], b[1]), "at {p:?}");
    }
}

/// A short tape keeps only the constants its kept code reads, in a
/// register file of its own size, and computes the same values: a long
/// formula's constants would otherwise fill every short tape.
#[test]
fn a_short_tape_keeps_only_the_constants_it_reads() {
    let mut ctx = Context::new();
    let [x, y] = [Var::X, Var::Y].map(|v| ctx.var(v));
    // min(x + 0.5, y·(1.25 + 2.75·y) + 3.5·y − 4.5)
    let [a, b, c, d, e] = [0.5, 1.25, 2.75, 3.5, 4.5].map(|v| ctx.constant(v));
    let left = ctx.add(x, a);
    let cy = ctx.mul(c, y);
    let inner = ctx.add(b, cy);
    let yi = ctx.mul(y, inner);
    let dy = ctx.mul(d, y);
    let sum = ctx.add(yi, dy);
    let right = ctx.sub(sum, e);
    let f = ctx.binary(BinaryOp::Min, left, right);
    let tape = Tape::new(&ctx, &[f]);
    // x + 0.5 ≤ 1 and the right side ≥ 3.3 there: the min takes the left.
    let region = boxed([0.0, 1.0, 0.0], [0.5, 1.5, 1.0]);
    let short = tape.shortened(&tape.settled_over(&region));
    let values = |t: &Tape| t.constants.iter().map(|&(_, v)| v).collect::<Vec<_>>();
    assert_eq!(values(&short), [0.5], "of {:?}", values(&tape));
    assert!(short.slot_count < tape.slot_count);
    let mut long = Evaluator::<f64>::new(&tape);
    let mut brief = Evaluator::<f64>::new(&short);
    for p in [[0.0, 1.0], [0.25, 1.2], [0.5, 1.5]] {
        let input = [p[0], p[1], 0.5, 0.0, 0.0, 0.0];
        assert_eq!(long.eval(&input)[0], brief.eval(&input)[0], "at {p:?}");
    }
}

/// A tape shortened with some outputs dropped computes the kept ones as the
/// whole tape does, over every part of the region, with no more code than
/// the tape shortened keeping them all.
#[test]
fn outputs_not_kept_take_their_code_with_them() {
    let [_, f_grad] = creased_tapes();
    let region = boxed([-0.4, -0.3, 0.5], [0.2, 0.4, 1.0]);
    let decisions = f_grad.settled_over(&region);
    let keep = [true, false, false, true];
    let short = f_grad.shortened_keeping(&decisions, &keep);
    let all = f_grad.shortened(&decisions);
    assert_eq!(short.output_count(), 2);
    assert!(short.body().len() < all.body().len());
    let (mut whole, mut kept) = (
        Evaluator::<DecInterval>::new(&f_grad),
        Evaluator::new(&short),
    );
    for part in [
        boxed([-0.4, -0.3, 0.5], [-0.1, 0.0, 0.7]),
        boxed([0.0, 0.1, 0.8], [0.2, 0.4, 1.0]),
        boxed([-0.2, -0.2, 0.6], [-0.2, -0.2, 0.6]),
    ] {
        let expected = whole.eval(&part).to_vec();
        let got = kept.eval(&part);
        assert_eq!(got[0].interval(), expected[0].interval());
        assert_eq!(got[1].interval(), expected[3].interval());
    }
}
