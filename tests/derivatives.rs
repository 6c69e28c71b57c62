//! Symbolic derivatives against finite differences, for every function of the
//! language, compositions, and every surface of the corpus.

mod common;

use common::{all_outputs, central_difference, close, corpus, values, Rng, FORMULAS};
use lgc::{Evaluator, Formula};

/// Checks ∇f, g and g′ of `expr` against finite differences at `n` points.
fn check_derivatives(expr: &str, lo: [f64; 3], hi: [f64; 3], n: usize, rng: &mut Rng) {
    let formula = Formula::parse(expr).unwrap_or_else(|e| panic!("{expr}: {e}"));
    let tape = all_outputs(&formula);
    let mut eval = Evaluator::<f64>::new(&tape);
    let mut probe = Evaluator::<f64>::new(&tape);
    let mut checked = 0;
    for _ in 0..n {
        let p = rng.point(lo, hi);
        let d = rng.direction();
        let v = values(&mut eval, p, d);
        if !v.f.is_finite() {
            continue;
        }
        let size = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
        let step = 1e-3 * size;
        let scale = v.f.abs();
        for axis in 0..3 {
            let fd = central_difference(
                |s| {
                    let mut q = p;
                    q[axis] += s;
                    values(&mut probe, q, d).f
                },
                step,
            );
            assert!(
                close(v.grad[axis], fd, 1e-5, scale),
                "{expr}: df/d{} at {p:?} is {} but finite differences give {fd}",
                ["x", "y", "z"][axis],
                v.grad[axis]
            );
        }
        let along = |s: f64| [p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]];
        let fd_g = central_difference(|s| values(&mut probe, along(s), d).f, step);
        assert!(
            close(v.g, fd_g, 1e-5, scale),
            "{expr}: g at {p:?} along {d:?} is {} but differences give {fd_g}",
            v.g
        );
        let fd_dg = central_difference(|s| values(&mut probe, along(s), d).g, step);
        assert!(
            close(v.dg, fd_dg, 1e-5, scale.max(v.g.abs())),
            "{expr}: g' at {p:?} along {d:?} is {} but differences give {fd_dg}",
            v.dg
        );
        let dot: f64 = (0..3).map(|i| d[i] * v.grad[i]).sum();
        assert!(close(v.g, dot, 1e-12, scale), "{expr}: g is not d.grad f");
        checked += 1;
    }
    assert!(
        checked >= n / 2,
        "{expr}: only {checked} of {n} sample points were in the domain"
    );
}

#[test]
fn every_listed_formula_matches_finite_differences() {
    let mut rng = Rng::new(0x5eed_0001);
    for &(expr, lo, hi) in FORMULAS {
        check_derivatives(expr, lo, hi, 40, &mut rng);
    }
}

#[test]
fn every_corpus_surface_matches_finite_differences() {
    let mut rng = Rng::new(0x5eed_0002);
    let surfaces = corpus();
    assert!(surfaces.len() >= 15);
    for s in &surfaces {
        check_derivatives(&s.expr, s.lo, s.hi, 40, &mut rng);
    }
}

#[test]
fn at_least_forty_formulas_are_checked() {
    assert!(FORMULAS.len() + corpus().len() >= 40);
}

#[test]
fn every_function_of_the_language_is_differentiated_somewhere() {
    let all: String = FORMULAS.iter().map(|f| f.0).collect::<Vec<_>>().join(" ");
    for f in lgc::functions::FUNCTIONS {
        if f.name == "dirac" {
            continue; // appears only in second derivatives, checked below
        }
        assert!(
            all.contains(&format!("{}(", f.name)),
            "no formula uses `{}`",
            f.name
        );
    }
    assert!(lgc::lower::all_functions_lower());
}

#[test]
fn sphere_derivatives_are_the_textbook_ones() {
    let f = Formula::parse("x^2+y^2+z^2-1").unwrap();
    let printed: Vec<String> = f.gradient().iter().map(|&n| f.print(n)).collect();
    assert_eq!(printed, ["2*x", "2*y", "2*z"]);
    // g′ = dᵀHd = 2|d|² for the sphere, whatever the point.
    let tape = all_outputs(&f);
    let mut eval = Evaluator::<f64>::new(&tape);
    let v = values(&mut eval, [0.3, -0.2, 5.0], [1.0, 2.0, -2.0]);
    assert_eq!(v.dg, 2.0 * 9.0);
}

#[test]
fn kinks_put_dirac_into_second_derivatives_only() {
    let f = Formula::parse("abs(x) + min(y, z)").unwrap();
    let first: String = f.gradient().iter().map(|&n| f.print(n)).collect();
    assert!(!first.contains("dirac"), "{first}");
    assert!(first.contains("sign(x)"), "{first}");
    let second = f.print(f.dg());
    assert!(second.contains("dirac(x)"), "{second}");
    assert!(second.contains("dirac(y-z)"), "{second}");
}
