//! Symbolic derivatives against finite differences, for every function of the
//! language, compositions, and every surface of the corpus.

use crate::common::{all_outputs, central_difference, close, corpus, values, Rng, FORMULAS};
use lgc::{Evaluator, Formula};

/// Checks ∇f, g and g′ of `expr` against finite differences at `n` points.
fn check_derivatives(expr: &str, lo: [f64; 3], hi: [f64; 3], n: usize, rng: &mut Rng) {
    let formula = Formula::parse(expr).unwrap_or_else(|e| panic!("{expr}: {e}"));
    let tape = all_outputs(&formula);
    let mut eval = Evaluator::<f64>::new(&tape);
    let mut probe = Evaluator::<f64>::new(&tape);
    let mut checked = 0;
    let mut straddled = 0;
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
        // Each check differentiates numerically at two step sizes. Where a
        // stencil straddles a crease of abs/min/max the two disagree with each
        // other; such samples say nothing about the symbolic derivative and
        // are skipped (and counted). Elsewhere both agree, and lgc must too.
        let mut check = |what: &str, symbolic: f64, h: &mut dyn FnMut(f64) -> f64, scale: f64| {
            let coarse = central_difference(&mut *h, step);
            let fine = central_difference(&mut *h, step / 8.0);
            if !close(coarse, fine, 1e-6, scale) {
                straddled += 1;
                return;
            }
            assert!(
                close(symbolic, fine, 1e-5, scale),
                "{expr}: {what} at {p:?} along {d:?} is {symbolic} but finite differences give {fine}"
            );
        };
        for axis in 0..3 {
            let name = ["df/dx", "df/dy", "df/dz"][axis];
            check(
                name,
                v.grad[axis],
                &mut |s| {
                    let mut q = p;
                    q[axis] += s;
                    values(&mut probe, q, d).f
                },
                scale,
            );
        }
        let along = |s: f64| [p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]];
        check("g", v.g, &mut |s| values(&mut probe, along(s), d).f, scale);
        check(
            "g'",
            v.dg,
            &mut |s| values(&mut probe, along(s), d).g,
            scale.max(v.g.abs()),
        );
        let dot: f64 = (0..3).map(|i| d[i] * v.grad[i]).sum();
        assert!(close(v.g, dot, 1e-12, scale), "{expr}: g is not d.grad f");
        checked += 1;
    }
    assert!(
        checked >= n / 2,
        "{expr}: only {checked} of {n} sample points were in the domain"
    );
    assert!(
        straddled * 20 <= 5 * n,
        "{expr}: {straddled} of {} checks straddled a crease; is the function smooth where it should be?",
        5 * n
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
    for f in lgc::lang::functions::FUNCTIONS {
        if f.name == "dirac" {
            continue; // appears only in second derivatives, checked below
        }
        assert!(
            all.contains(&format!("{}(", f.name)),
            "no formula uses `{}`",
            f.name
        );
    }
    // The arity table and the lowering agree on every function.
    for f in lgc::lang::functions::FUNCTIONS {
        let (lgc::lang::functions::Arity::Exactly(n) | lgc::lang::functions::Arity::AtLeast(n)) =
            f.arity;
        let src = format!("{}({})", f.name, vec!["x"; n].join(","));
        assert!(Formula::parse(&src).is_ok(), "`{src}` does not lower");
    }
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

#[test]
fn second_derivative_of_tanh_stays_finite_where_cosh_overflows() {
    // Regression: tanh′ was 1/cosh², whose derivative is sinh/cosh³ = ∞/∞ = NaN
    // for |u| > 710, although the true value is 0.
    let f = Formula::parse("asin(0.9*tanh(x^3))").unwrap();
    let tape = all_outputs(&f);
    let mut eval = Evaluator::<f64>::new(&tape);
    let v = values(&mut eval, [10.0, 0.0, 0.0], [1.0, 0.5, 0.0]);
    assert_eq!((v.grad[0], v.g, v.dg), (0.0, 0.0, 0.0));
}
