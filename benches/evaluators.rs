//! Throughput of the tape evaluators on corpus surfaces: the point evaluator
//! against the batch evaluator, for f alone (what pruning and marching need)
//! and for f with its gradient (what shading needs).
//!
//! Run with `cargo bench --bench evaluators`; compare the two evaluators'
//! figures from the same run, since absolute times depend on the machine.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use lgc::{BatchEvaluator, Evaluator, Formula, Output};
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

criterion_group!(benches, evaluators, compile);
criterion_main!(benches);
