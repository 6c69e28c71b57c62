//! One conformance suite, run against every f64 evaluator: the graph walk
//! (`Context::eval`), the point [`Evaluator`], the compiled
//! [`PointEvaluator`] and the [`BatchEvaluator`] must agree bit for bit on
//! every output, and a tape computing many outputs must give what
//! single-output tapes give.

use crate::common::{all_formulas, Rng};
use lgc::types::{DecInterval, Decoration, Interval};
use lgc::{BatchEvaluator, DecoratedEvaluator, Evaluator, Formula, Output, PointEvaluator};

/// Evaluators of `tape` running its machine code at each tier, baseline
/// then optimised (asserted to be machine code where Cranelift has a
/// backend, so the interpreter cannot stand in unnoticed).
fn tiers(tape: &lgc::Tape) -> [PointEvaluator<'_>; 2] {
    // The baseline code first: once the tape holds optimised code, new
    // evaluators run that.
    let mut baseline = PointEvaluator::new(tape);
    baseline.count_evaluations(u32::MAX);
    let optimised = PointEvaluator::compiled(tape);
    if cfg!(any(target_arch = "x86_64", target_arch = "aarch64")) {
        assert!(
            baseline.is_compiled() && !baseline.is_optimised(),
            "no baseline machine code on a host Cranelift supports"
        );
        assert!(
            optimised.is_optimised(),
            "no optimised machine code on a host Cranelift supports"
        );
    }
    [baseline, optimised]
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

#[test]
fn all_evaluators_agree_bit_for_bit() {
    let mut rng = Rng::new(0x5eed_0004);
    for (expr, lo, hi) in all_formulas() {
        let formula = Formula::parse(&expr).unwrap();
        let tape = formula.tape(&Output::ALL);
        // 150 points: more than two batch chunks, with a ragged tail.
        let n = 150;
        let inputs: Vec<[f64; 6]> = (0..n)
            .map(|_| {
                let p = rng.point(lo, hi);
                let d = rng.direction();
                [p[0], p[1], p[2], d[0], d[1], d[2]]
            })
            .collect();
        let columns: Vec<Vec<f64>> = (0..6)
            .map(|k| inputs.iter().map(|i| i[k]).collect())
            .collect();
        let column_refs: Vec<&[f64]> = columns.iter().map(|c| c.as_slice()).collect();
        let mut batch_out = vec![vec![0.0; n]; Output::ALL.len()];
        {
            let mut outs: Vec<&mut [f64]> =
                batch_out.iter_mut().map(|v| v.as_mut_slice()).collect();
            BatchEvaluator::new(&tape).eval(&column_refs, &mut outs);
        }
        let mut point = Evaluator::<f64>::new(&tape);
        let mut code = tiers(&tape);
        let singles: Vec<_> = Output::ALL.iter().map(|&o| formula.tape(&[o])).collect();
        for (i, input) in inputs.iter().enumerate() {
            let all = point.eval(input).to_vec();
            let machine: [[f64; Output::ALL.len()]; 2] =
                code.each_mut().map(|c| c.eval_array(input));
            for (k, &output) in Output::ALL.iter().enumerate() {
                let walked = formula.context().eval(formula.node(output), input);
                let single = Evaluator::<f64>::new(&singles[k]).eval(input)[0];
                assert!(
                    same(all[k], walked),
                    "{expr} {output:?} at {input:?}: tape {} vs graph {walked}",
                    all[k]
                );
                assert!(
                    same(all[k], single),
                    "{expr} {output:?}: shared tape {} vs own tape {single}",
                    all[k]
                );
                assert!(
                    same(all[k], batch_out[k][i]),
                    "{expr} {output:?}: point {} vs batch {}",
                    all[k],
                    batch_out[k][i]
                );
                for (tier, machine) in ["baseline", "optimised"].iter().zip(&machine) {
                    assert!(
                        same(all[k], machine[k]),
                        "{expr} {output:?} at {input:?}: interpreted {} vs {tier} {}",
                        all[k],
                        machine[k]
                    );
                }
            }
        }
    }
}

/// Signed zeros, the edges of the f64 range, subnormals and points outside
/// the domains: the compiled code keeps the interpreter's every bit there
/// too (where `min` and `max` of ±0, say, are a compiler's choice).
#[test]
fn compiled_code_agrees_at_special_values() {
    let specials = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        -2.5,
        1e300,
        -1e300,
        4.9e-324,
        -2.2e-308,
        f64::MAX,
        f64::INFINITY,
    ];
    let mut extra: Vec<String> = [
        "min(x, y) + max(y, x) * min(-x, z)",
        "max(abs(x), abs(y), abs(z)) - 1",
        "choose(x, y, z) + sign(x) * dirac(y)",
        "x^5 + y^-3 + z^-2 + x^7",
        "atan2(y, x) + pow(abs(x), y) + exp(z) - ln(y)",
        "sqrt(x) * sin(y) / cos(z) + tan(x) + asin(y) + acos(z) + atan(x)",
        "sinh(x) + cosh(y) + tanh(z) + sech(x)",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    extra.extend(all_formulas().into_iter().map(|(expr, _, _)| expr));
    for expr in extra {
        let formula = Formula::parse(&expr).unwrap();
        let tape = formula.tape(&Output::ALL);
        let mut point = Evaluator::<f64>::new(&tape);
        let mut code = tiers(&tape);
        for (i, &a) in specials.iter().enumerate() {
            for &b in &specials[i % 3..] {
                let input = [a, b, -a, b, a, 0.5];
                let all = point.eval(&input).to_vec();
                for (tier, code) in ["baseline", "optimised"].iter().zip(&mut code) {
                    let machine: [f64; Output::ALL.len()] = code.eval_array(&input);
                    for k in 0..all.len() {
                        assert!(
                            same(all[k], machine[k]),
                            "{expr} {:?} at {input:?}: interpreted {} vs {tier} {}",
                            Output::ALL[k],
                            all[k],
                            machine[k]
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn slots_are_reused() {
    let f = Formula::parse(
        &crate::common::corpus()
            .iter()
            .find(|s| s.name == "barth_decic")
            .unwrap()
            .expr,
    )
    .unwrap();
    let tape = f.tape(&Output::ALL);
    assert!(
        tape.slot_count() * 2 < tape.body().len() + tape.prelude().len(),
        "{} slots for {} instructions",
        tape.slot_count(),
        tape.body().len()
    );
}

#[test]
fn constant_subexpressions_run_once_in_the_prelude() {
    let f = Formula::parse("sqrt(2)*x + sin(1)").unwrap();
    let tape = f.tape(&[Output::F]);
    assert_eq!(tape.prelude().len(), 2, "sqrt(2) and sin(1)");
    assert_eq!(tape.body().len(), 2, "one product, one sum");
    let v = Evaluator::<f64>::new(&tape).eval(&[3.0, 0.0, 0.0, 0.0, 0.0, 0.0])[0];
    assert_eq!(v, 2f64.sqrt() * 3.0 + 1f64.sin());
}

#[test]
fn language_semantics_match_independent_values() {
    // Values worked out by hand, independently of lgc: the conventions a
    // computer-algebra system would be checked against.
    let cases: &[(&str, [f64; 3], f64)] = &[
        ("-x^2", [3.0, 0.0, 0.0], -9.0),
        ("2^3^2", [0.0; 3], 512.0),
        ("x - y - z", [10.0, 3.0, 2.0], 5.0),
        ("x / y / z", [12.0, 3.0, 2.0], 2.0),
        ("log(x)", [1000.0, 0.0, 0.0], 3.0),
        ("ln(e)", [0.0; 3], 1.0),
        ("atan2(y, x)", [0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2),
        ("atan2(y, x)", [-1.0, 0.0, 0.0], std::f64::consts::PI),
        ("min(x, y, z) + max(x, y, z)", [3.0, -1.0, 2.0], 2.0),
        ("hypot(x, y)", [3.0, 4.0, 0.0], 5.0),
        ("pow(x, 0.5)", [16.0, 0.0, 0.0], 4.0),
        ("x^-1", [4.0, 0.0, 0.0], 0.25),
        ("let a = x + 1; let b = a*a; b - a", [2.0, 0.0, 0.0], 6.0),
        ("sign(x) + sign(y) + sign(z)", [-2.0, 0.0, 5.0], 0.0),
        ("abs(x)", [-2.5, 0.0, 0.0], 2.5),
        ("sech(x)*cosh(x)", [3.0, 0.0, 0.0], 1.0),
        (".5e1 + 2.5E+4 + 1e-3", [0.0; 3], 25005.001),
    ];
    for &(src, p, want) in cases {
        let f = Formula::parse(src).unwrap();
        let got = Evaluator::<f64>::new(&f.tape(&[Output::F]))
            .eval(&[p[0], p[1], p[2], 0.0, 0.0, 0.0])[0];
        assert!(
            (got - want).abs() <= 1e-12 * want.abs().max(1.0),
            "{src} at {p:?} = {got}, want {want}"
        );
    }
}

#[test]
fn undefined_operands_stay_undefined_in_every_evaluator() {
    // IEEE min/max return the other operand when one is NaN, and powf(1, NaN)
    // is 1; a value of f where part of the formula is undefined would be
    // invented, and a ray could exclude or certify on it.
    let cases = [
        "min(sqrt(x), 1)",
        "max(y, ln(x))",
        "min(max(sqrt(x), y), z)",
        "abs(sqrt(x)) + 1",
        "pow(1, sqrt(x))",
        "(sqrt(x))^2 - 1",
        "(sqrt(x))^3 + (sqrt(x))^4 + (sqrt(x))^5",
        "choose(sqrt(x), y, z)",
    ];
    let at = [-1.0, 2.0, 3.0, 0.0, 0.0, 0.0];
    for src in cases {
        let f = Formula::parse(src).unwrap();
        let tape = f.tape(&[Output::F]);
        let point = Evaluator::<f64>::new(&tape).eval(&at)[0];
        let [machine] = PointEvaluator::compiled(&tape).eval_array(&at);
        assert!(machine.is_nan(), "{src}: compiled code gives {machine}");
        let mut batch = [0.0];
        let columns: Vec<[f64; 1]> = at.iter().map(|&v| [v]).collect();
        let refs: Vec<&[f64]> = columns.iter().map(|c| c.as_slice()).collect();
        BatchEvaluator::new(&tape).eval(&refs, &mut [&mut batch]);
        let walked = f.context().eval(f.node(Output::F), &at);
        assert!(point.is_nan(), "{src}: point evaluator gives {point}");
        assert!(
            batch[0].is_nan(),
            "{src}: batch evaluator gives {}",
            batch[0]
        );
        assert!(walked.is_nan(), "{src}: graph walk gives {walked}");
    }
}

#[test]
fn folds_do_not_define_f_where_a_dropped_operand_is_undefined() {
    // `0*u = 0`, `u - u = 0`, `u^0 = 1` and `choose(c, p, p) = p` hold only
    // where u (or c) is defined: folding them for `sqrt(x)` gave f a value,
    // and a surface, at x < 0. Each case is undefined at x = -1 in every
    // evaluator and over intervals, and takes the folded value where defined.
    let cases = [
        ("sqrt(x)*0", 0.0),
        ("0*ln(x) + y", 2.0),
        ("sqrt(x) - sqrt(x)", 0.0),
        ("0/sqrt(x)", 0.0),
        ("sqrt(x)^0", 1.0),
        ("pow(sqrt(x), 0)", 1.0),
        ("choose(sqrt(x) - 1, y, y)", 2.0),
        ("asin(x - 1)*0 + acos(x - 1)*0 + y", 2.0),
    ];
    let undefined = [-1.0, 2.0, 3.0, 0.0, 0.0, 0.0];
    let defined = [0.25, 2.0, 3.0, 0.0, 0.0, 0.0];
    for (src, value) in cases {
        let f = Formula::parse(src).unwrap();
        let tape = f.tape(&[Output::F]);
        let mut point = Evaluator::<f64>::new(&tape);
        let columns: Vec<[f64; 1]> = undefined.iter().map(|&v| [v]).collect();
        let refs: Vec<&[f64]> = columns.iter().map(|c| c.as_slice()).collect();
        let mut batch = [0.0];
        BatchEvaluator::new(&tape).eval(&refs, &mut [&mut batch]);
        assert!(
            point.eval(&undefined)[0].is_nan(),
            "{src}: point value at x = -1"
        );
        assert!(
            batch[0].is_nan(),
            "{src}: batch value {} at x = -1",
            batch[0]
        );
        let walked = f.context().eval(f.node(Output::F), &undefined);
        assert!(
            walked.is_nan(),
            "{src}: graph walk gives {walked} at x = -1"
        );
        let boxed = [
            Interval::new(-2.0, 1.0),
            Interval::new(1.0, 3.0),
            Interval::new(2.0, 4.0),
            Interval::ZERO,
            Interval::ZERO,
            Interval::ZERO,
        ]
        .map(DecInterval::defined);
        let over = Evaluator::<DecInterval>::new(&tape).eval(&boxed)[0];
        assert!(
            over.decoration() < Decoration::Def,
            "{src}: decorated {:?} over a box reaching x < 0",
            over.decoration()
        );
        let v = point.eval(&defined)[0];
        assert!(
            (v - value).abs() < 1e-12,
            "{src}: {v} at x = 0.25, not {value}"
        );
    }
    // Derivatives still fold them: f is defined wherever they are read.
    let f = Formula::parse("sqrt(x)*0 + y").unwrap();
    assert_eq!(f.print(f.node(Output::Dfdx)), "0");
    assert_eq!(f.print(f.node(Output::Dfdy)), "1");
}

#[test]
fn the_undecorated_path_gives_the_decorated_enclosures_and_decorations() {
    // `DecoratedEvaluator` skips the decorations' work for tapes whose every
    // output keeps its inputs' decoration; a wrong static judgement (an
    // operation that may be undefined or jump, taken for total) would call
    // a crease-free formula continuous where it jumps. Over boxes of every
    // size, including ones straddling poles and domain edges, both paths
    // must agree exactly.
    let mut rng = Rng::new(0x5eed_0006);
    let extra = [
        ("max(abs(x), y) - z^2 + sin(x)*cos(y)", [-2.0; 3], [2.0; 3]),
        ("1/x + y", [-1.0; 3], [1.0; 3]),
        ("sqrt(x) + y", [-1.0; 3], [1.0; 3]),
        ("x^-2 + y", [-1.0; 3], [1.0; 3]),
        ("sign(x) + y", [-1.0; 3], [1.0; 3]),
        ("x*sqrt(2) + y", [-1.0; 3], [1.0; 3]),
        // f total, its derivatives not: g jumps where f is creased.
        ("max(x, y) - z", [-1.0; 3], [1.0; 3]),
        ("abs(x) - 0.5 + y^2", [-1.0; 3], [1.0; 3]),
        ("1/(x^2 + 0.25) - y", [-1.0; 3], [1.0; 3]),
    ];
    let cases = all_formulas()
        .into_iter()
        .chain(extra.iter().map(|&(e, lo, hi)| (e.to_string(), lo, hi)));
    let (mut plain, mut decorated) = (0, 0);
    for (expr, lo, hi) in cases {
        let formula = Formula::parse(&expr).unwrap();
        let gradient = [Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz];
        let fg = [Output::F, Output::G];
        for outputs in [&[Output::F][..], &fg[..], &gradient[..], &Output::ALL[..]] {
            let tape = formula.tape(outputs);
            let mut reference = Evaluator::<DecInterval>::new(&tape);
            let mut fast = DecoratedEvaluator::new(&tape);
            match fast {
                DecoratedEvaluator::Plain(..) => plain += 1,
                DecoratedEvaluator::Guarded { .. } => decorated += 1,
            }
            for _ in 0..40 {
                let (a, b) = (rng.point(lo, hi), rng.point(lo, hi));
                let width = 10f64.powf(rng.uniform(-6.0, 0.0));
                let d = rng.direction();
                let inputs: [DecInterval; 6] = std::array::from_fn(|k| {
                    let v = if k < 3 {
                        let (l, h) = (a[k].min(b[k]), a[k].max(b[k]));
                        Interval::new(l, l + (h - l) * width)
                    } else {
                        Interval::point(d[k - 3])
                    };
                    DecInterval::defined(v)
                });
                let want = reference.eval(&inputs).to_vec();
                // Output by output, as the intersector reads f alone.
                for (k, w) in want.iter().enumerate() {
                    if tape.output_keeps_decoration(k) {
                        assert_eq!(w.decoration(), Decoration::Dac, "{expr}, output {k}");
                    }
                }
                let got = fast.eval(&inputs);
                for (k, (w, g)) in want.iter().zip(got).enumerate() {
                    let (wi, gi) = (w.interval(), g.interval());
                    let same_set = wi == gi || (wi.is_empty() && gi.is_empty());
                    assert!(
                        same_set && w.decoration() == g.decoration(),
                        "{expr}, output {k} over {inputs:?}: decorated {w:?}, fast {g:?}"
                    );
                }
                // A caller reading f's decoration alone (the intersector over
                // ray pieces): the same enclosures, the same f decoration, and
                // no other output claimed better than it is.
                let got = DecoratedEvaluator::reading(&tape, &[0])
                    .eval(&inputs)
                    .to_vec();
                for (k, (w, g)) in want.iter().zip(&got).enumerate() {
                    let (wi, gi) = (w.interval(), g.interval());
                    let same_set = wi == gi || (wi.is_empty() && gi.is_empty());
                    let decoration_ok = if k == 0 {
                        w.decoration() == g.decoration()
                    } else {
                        g.decoration() <= w.decoration()
                    };
                    assert!(
                        same_set && decoration_ok,
                        "{expr}, output {k} of f-reading over {inputs:?}: {w:?} vs {g:?}"
                    );
                }
                // f first, the rest only where asked (the intersector's
                // call), for a caller of every output and one of f's alone:
                // a decoration lost in the rest must not reach f's, nor be
                // missed in an output read.
                for reads_all in [true, false] {
                    let mut fast = if reads_all {
                        DecoratedEvaluator::new(&tape)
                    } else {
                        DecoratedEvaluator::reading(&tape, &[0])
                    };
                    for ask in [false, true] {
                        let (first, all) = fast.eval_first_then(&inputs, |_| ask);
                        let same = |w: &DecInterval, g: &DecInterval| {
                            w.interval() == g.interval()
                                || (w.interval().is_empty() && g.interval().is_empty())
                        };
                        assert!(
                            same(&want[0], &first) && want[0].decoration() == first.decoration(),
                            "{expr}: f first over {inputs:?}: {:?} vs {first:?}",
                            want[0]
                        );
                        assert_eq!(all.is_some(), ask, "{expr}");
                        for (k, (w, g)) in want.iter().zip(all.unwrap_or(&[])).enumerate() {
                            let decoration_ok = if reads_all || k == 0 {
                                w.decoration() == g.decoration()
                            } else {
                                g.decoration() <= w.decoration()
                            };
                            assert!(
                                same(w, g) && decoration_ok,
                                "{expr}, output {k} after f over {inputs:?}: {w:?} vs {g:?}"
                            );
                        }
                    }
                }
            }
        }
    }
    assert!(
        plain > 0 && decorated > 0,
        "{plain} plain, {decorated} decorated"
    );
}

/// Compiling grows faster than the tape (register allocation): a tape of
/// tens of thousands of operations runs in the interpreter, with the same
/// values, rather than spending seconds and memory in the compiler.
#[test]
fn a_tape_too_long_to_compile_runs_in_the_interpreter() {
    let text = (1..=8000)
        .map(|k| format!("sin({k}*x)"))
        .collect::<Vec<_>>()
        .join("+");
    let formula = Formula::parse(&text).unwrap();
    let tape = formula.tape(&[Output::F, Output::G]);
    let mut long = PointEvaluator::compiled(&tape);
    assert!(!long.is_compiled());
    let at = [0.3, 0.1, 0.2, 1.0, 0.0, 0.0];
    let [f, g] = long.eval_array(&at);
    let interpreted = Evaluator::<f64>::new(&tape).eval(&at).to_vec();
    assert!(same(f, interpreted[0]) && same(g, interpreted[1]));
    // A short tape of the same kind is compiled.
    let short = Formula::parse("sin(x)+sin(2*x)").unwrap();
    let tape = short.tape(&[Output::F]);
    if cfg!(any(target_arch = "x86_64", target_arch = "aarch64")) {
        assert!(PointEvaluator::compiled(&tape).is_compiled());
    }
}

/// Regression: every render worker makes its own evaluators, and each used
/// to interpret a few hundred evaluations of a tape before taking the
/// machine code another worker had already compiled.
#[test]
fn an_evaluator_of_a_compiled_tape_runs_the_machine_code_at_once() {
    if !cfg!(any(target_arch = "x86_64", target_arch = "aarch64")) {
        return;
    }
    let formula = Formula::parse("x^2+y^2+z^2-1").unwrap();
    let tape = formula.tape(&[Output::F, Output::G]);
    assert!(!PointEvaluator::new(&tape).is_compiled());
    assert!(PointEvaluator::compiled(&tape).is_compiled());
    let mut fresh = PointEvaluator::new(&tape);
    assert!(fresh.is_compiled());
    let at = [0.3, 0.1, 0.2, 1.0, 0.5, 0.0];
    let [f, g] = fresh.eval_array(&at);
    let interpreted = Evaluator::<f64>::new(&tape).eval(&at).to_vec();
    assert!(same(f, interpreted[0]) && same(g, interpreted[1]));
}
