//! Deeply nested and huge formulas parse, differentiate, compile, print and
//! evaluate without overflowing the stack. Test threads have small (2 MiB)
//! stacks, so any recursion over the depth would crash here.

use lgc::{BatchEvaluator, Evaluator, Formula, Output};

const DEPTH: usize = 100_000;

fn eval_all(f: &Formula, p: [f64; 3]) -> Vec<f64> {
    let tape = f.tape(&Output::ALL);
    Evaluator::<f64>::new(&tape)
        .eval(&[p[0], p[1], p[2], 1.0, 0.0, 0.0])
        .to_vec()
}

#[test]
fn hundred_thousand_nested_parentheses() {
    let src = format!("{}x^2 + y{}", "(".repeat(DEPTH), ")".repeat(DEPTH));
    let f = Formula::parse(&src).unwrap();
    assert_eq!(eval_all(&f, [3.0, 1.0, 0.0])[..2], [10.0, 6.0]);
    assert_eq!(f.print(f.f()), "x^2+y");
}

#[test]
fn hundred_thousand_nested_sums_make_a_deep_graph() {
    // (1+(1+(…(x^2)…))): a chain 100,000 nodes deep in the graph itself.
    let src = format!("{}x^2{}", "(1 + ".repeat(DEPTH), ")".repeat(DEPTH));
    let f = Formula::parse(&src).unwrap();
    let v = eval_all(&f, [2.0, 0.0, 0.0]);
    assert_eq!(v[0], 4.0 + DEPTH as f64);
    assert_eq!(v[1], 4.0);
    let printed = f.print(f.f());
    assert!(printed.starts_with("x^2+1+1"), "{}", &printed[..20]);
    assert!(Formula::parse(&printed).is_ok());
}

#[test]
fn hundred_thousand_nested_functions() {
    let src = format!("{}x{}", "sin(".repeat(DEPTH), ")".repeat(DEPTH));
    let f = Formula::parse(&src).unwrap();
    let v = eval_all(&f, [0.5, 0.0, 0.0]);
    // sin iterated n times shrinks slowly towards 0; the derivative is the
    // product of the cosines along the way, positive and below 1.
    let mut s = 0.5f64;
    let mut d = 1.0;
    for _ in 0..DEPTH {
        d *= s.cos();
        s = s.sin();
    }
    assert!((v[0] - s).abs() < 1e-12);
    assert!(
        (v[1] - d).abs() < 1e-9 * d.abs().max(1e-300),
        "{} vs {d}",
        v[1]
    );
    let printed = f.print(f.gradient()[0]);
    assert!(printed.len() > DEPTH);
}

#[test]
fn hundred_thousand_unary_minuses() {
    let src = format!("{}x", "-".repeat(DEPTH + 1));
    let f = Formula::parse(&src).unwrap();
    assert_eq!(f.print(f.f()), "-x");
}

#[test]
fn a_sum_of_a_million_terms() {
    let terms = ["x", "y^2", "sin(z)", "x*y", "z^3"];
    let mut src = String::with_capacity(16 * 1_000_000);
    for k in 0..1_000_000 {
        if k > 0 {
            src.push_str(" + ");
        }
        src.push_str(&format!("{}*{}", k % 97 + 1, terms[k % terms.len()]));
    }
    let f = Formula::parse(&src).unwrap();
    let tape = f.tape(&[Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz]);
    let p: [f64; 3] = [0.5, -0.25, 0.75];
    // Reference by direct summation in the same order.
    let (mut want_f, mut want_dx) = (0.0, 0.0);
    for k in 0..1_000_000 {
        let c = (k % 97 + 1) as f64;
        let (t, dt) = match k % 5 {
            0 => (p[0], 1.0),
            1 => (p[1] * p[1], 0.0),
            2 => (p[2].sin(), 0.0),
            3 => (p[0] * p[1], p[1]),
            _ => (p[2].powi(3), 0.0),
        };
        want_f += c * t;
        want_dx += c * dt;
    }
    let v = Evaluator::<f64>::new(&tape)
        .eval(&[p[0], p[1], p[2], 0.0, 0.0, 0.0])
        .to_vec();
    assert!(
        (v[0] - want_f).abs() < 1e-9 * want_f.abs(),
        "{} vs {want_f}",
        v[0]
    );
    assert!(
        (v[1] - want_dx).abs() < 1e-9 * want_dx.abs(),
        "{} vs {want_dx}",
        v[1]
    );
    // The batch evaluator runs the same million-term tape.
    let mut out = [0.0; 3];
    let mut dx = [0.0; 3];
    let mut dy = [0.0; 3];
    let mut dz = [0.0; 3];
    BatchEvaluator::new(&tape).eval(
        &[&[p[0]; 3], &[p[1]; 3], &[p[2]; 3]],
        &mut [&mut out, &mut dx, &mut dy, &mut dz],
    );
    assert_eq!(out[2], v[0]);
    let printed = f.print(f.gradient()[1]);
    assert!(Formula::parse(&printed).is_ok());
}
