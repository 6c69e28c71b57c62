//! Printed formulas and derivatives parse back to the same values.

use crate::common::{all_formulas, close, Rng};
use lgc::{Context, Formula, Node, Output};

/// Parses text that may use the ray direction (dx, dy, dz) into `ctx`.
fn reparse(ctx: &mut Context, text: &str) -> Node {
    let ast = lgc::lang::parse(text)
        .unwrap_or_else(|e| panic!("printed text does not parse: {e}\n{text}"));
    lgc::lang::lower(ctx, &ast)
        .unwrap_or_else(|e| panic!("printed text does not lower: {e}\n{text}"))
}

#[test]
fn printed_outputs_reparse_to_the_same_values() {
    let mut rng = Rng::new(0x5eed_0003);
    for (expr, lo, hi) in all_formulas() {
        let formula = Formula::parse(&expr).unwrap();
        for output in Output::ALL {
            let node = formula.node(output);
            let text = formula.print(node);
            let mut ctx = Context::new();
            let again = reparse(&mut ctx, &text);
            // Printing is a fixed point: the reparsed graph prints the same text.
            assert_eq!(lgc::to_source(&ctx, again), text, "{expr}: {output:?}");
            for _ in 0..10 {
                let p = rng.point(lo, hi);
                let d = rng.direction();
                let inputs = [p[0], p[1], p[2], d[0], d[1], d[2]];
                let want = formula.context().eval(node, &inputs);
                let got = ctx.eval(again, &inputs);
                assert!(
                    (want.is_nan() && got.is_nan()) || close(want, got, 1e-12, 0.0),
                    "{expr}: {output:?} printed as `{text}` gives {got}, not {want}, at {inputs:?}"
                );
            }
        }
    }
}

#[test]
fn constants_print_so_they_parse_back_exactly() {
    let mut rng = Rng::new(7);
    for _ in 0..2000 {
        let bits = rng.next_u64();
        let v = f64::from_bits(bits);
        if !v.is_finite() {
            continue;
        }
        let text = lgc::expr::print::format_number(v.abs());
        let mut ctx = Context::new();
        let node = reparse(&mut ctx, &text);
        assert_eq!(ctx.const_value(node), Some(v.abs()), "{text}");
    }
    assert_eq!(lgc::expr::print::format_number(std::f64::consts::PI), "pi");
    assert_eq!(lgc::expr::print::format_number(1e-7), "1e-7");
    assert_eq!(lgc::expr::print::format_number(2.0), "2");
}

#[test]
fn precedence_survives_printing() {
    for (src, printed) in [
        ("-x^2", "-x^2"),
        ("(-x)^3", "-x^3"),
        ("2^3^2*x", "512*x"),
        ("x^y^z", "x^y^z"),
        ("(x^y)^z", "(x^y)^z"),
        ("x - (y - z)", "x-(y-z)"),
        ("x/(y*z)", "x/(y*z)"),
        ("(x + 1)*(y - 2)", "(x+1)*(y-2)"),
        ("x^-2", "x^-2"),
        ("2^-x", "2^-x"),
        ("(x - 1)^2 - 3", "(x-1)^2-3"),
    ] {
        let f = Formula::parse(src).unwrap();
        assert_eq!(f.print(f.f()), printed, "{src}");
    }
}

#[test]
fn shared_subexpressions_print_once_as_let() {
    // Each derivative of a deep composition reuses the inner functions: without
    // `let` the text would grow quadratically.
    let mut src = String::from("x");
    for _ in 0..200 {
        src = format!("sin({src}+y)");
    }
    let f = Formula::parse(&src).unwrap();
    let text = f.print(f.gradient()[0]);
    assert!(
        text.contains("let s1 = "),
        "{}",
        &text[..200.min(text.len())]
    );
    assert!(
        text.len() < 40 * src.len(),
        "{} bytes for a {} byte formula",
        text.len(),
        src.len()
    );
}
