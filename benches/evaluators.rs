//! Throughput of the tape evaluators on corpus surfaces: the point evaluator
//! against the batch evaluator, for f alone (what pruning and marching need)
//! and for f with its gradient (what shading needs); and the decorated
//! interval evaluation of f and g over small boxes on a real model, what a
//! ray's enclosure tests in a creased leaf spend most of their time on.
//!
//! Run with `cargo bench --bench evaluators`; compare the two evaluators'
//! figures from the same run, since absolute times depend on the machine.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use lgc::expr::DecoratedEvaluator;
use lgc::types::DecInterval;
use lgc::{BatchEvaluator, Evaluator, Formula, Interval, Output};
use std::hint::black_box;

/// Corpus surfaces measured, by name.
const SURFACES: &[&str] = &["sphere", "torus", "tangle_cube", "gyroid", "barth_sextic"];

/// The repository's one corpus file (`lgc bench` and the tests read it too).
const CORPUS: &str = include_str!("../examples/surfaces.json");

/// `(name, formula)` of each measured surface.
fn surfaces() -> Vec<(&'static str, String)> {
    let corpus: serde_json::Value = serde_json::from_str(CORPUS).expect("valid JSON");
    SURFACES
        .iter()
        .map(|&name| {
            let expr = corpus[name]["expr"].as_str().expect("a corpus surface");
            (name, expr.to_string())
        })
        .collect()
}

const POINTS: usize = 4096;

fn grid() -> [Vec<f64>; 3] {
    let mut xs = Vec::with_capacity(POINTS);
    let mut ys = Vec::with_capacity(POINTS);
    let mut zs = Vec::with_capacity(POINTS);
    for i in 0..POINTS {
        let t = i as f64 / POINTS as f64;
        xs.push(-2.0 + 4.0 * t);
        ys.push((7.0 * t).sin() * 2.0);
        zs.push((13.0 * t).cos() * 2.0);
    }
    [xs, ys, zs]
}

fn evaluators(c: &mut Criterion) {
    let [xs, ys, zs] = grid();
    for (outputs, label) in [
        (vec![Output::F], "f"),
        (
            vec![Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz],
            "f+grad",
        ),
    ] {
        let mut group = c.benchmark_group(format!("eval {label}"));
        group.throughput(Throughput::Elements(POINTS as u64));
        for (name, expr) in surfaces() {
            let formula = Formula::parse(&expr).unwrap();
            let tape = formula.tape(&outputs);
            group.bench_with_input(BenchmarkId::new("point", name), &tape, |b, tape| {
                let mut eval = Evaluator::<f64>::new(tape);
                b.iter(|| {
                    let mut acc = 0.0;
                    for i in 0..POINTS {
                        acc += eval.eval(&[xs[i], ys[i], zs[i], 0.0, 0.0, 0.0])[0];
                    }
                    black_box(acc)
                })
            });
            group.bench_with_input(BenchmarkId::new("batch", name), &tape, |b, tape| {
                let mut eval = BatchEvaluator::new(tape);
                let mut out = vec![vec![0.0; POINTS]; outputs.len()];
                b.iter(|| {
                    let mut slices: Vec<&mut [f64]> =
                        out.iter_mut().map(|v| v.as_mut_slice()).collect();
                    eval.eval(&[&xs, &ys, &zs], &mut slices);
                    black_box(out[0][POINTS - 1])
                })
            });
        }
        group.finish();
    }
}

/// Boxes a fiftieth wide along a curve through the bear model's bounds,
/// each with a point direction: the inputs of a ray's pieces.
fn pieces() -> Vec<[DecInterval; 6]> {
    let [xs, ys, zs] = grid();
    (0..POINTS)
        .step_by(4)
        .map(|i| {
            let at = |v: f64| DecInterval::defined(Interval::new(0.5 * v, 0.5 * v + 0.02));
            let d = |v: f64| DecInterval::defined(Interval::point(v));
            let n = (xs[i] * xs[i] + ys[i] * ys[i] + zs[i] * zs[i])
                .sqrt()
                .max(1e-3);
            [
                at(xs[i]),
                at(ys[i]),
                at(zs[i]),
                d(xs[i] / n),
                d(ys[i] / n),
                d(zs[i] / n),
            ]
        })
        .collect()
}

fn intervals(c: &mut Criterion) {
    let bear = Formula::parse_vm(include_str!("../examples/models/bear.vm")).unwrap();
    let tape = bear.tape(&[Output::F, Output::G]);
    let pieces = pieces();
    let mut group = c.benchmark_group("enclose f then g");
    group.throughput(Throughput::Elements(pieces.len() as u64));
    group.bench_function("bear", |b| {
        // As the tracer reads them: f first, g only where f's enclosure
        // holds 0, and only f's decoration.
        let mut eval = DecoratedEvaluator::reading(&tape, &[0]);
        b.iter(|| {
            let mut acc = 0.0;
            for piece in &pieces {
                let (f, rest) = eval.eval_first_then(piece, |f| f.interval().contains(0.0));
                acc += f.interval().sup() + rest.map_or(0.0, |v| v[1].interval().inf());
            }
            black_box(acc)
        })
    });
    group.finish();
}

fn compile(c: &mut Criterion) {
    let mut group = c.benchmark_group("compile");
    for (name, expr) in surfaces() {
        group.bench_function(name, |b| {
            b.iter(|| {
                let formula = Formula::parse(black_box(&expr)).unwrap();
                black_box(formula.tape(&Output::ALL))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, evaluators, intervals, compile);
criterion_main!(benches);
