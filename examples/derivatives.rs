//! Parse a formula, print its symbolic derivatives, and evaluate them on a
//! batch of points along a ray.
//!
//! cargo run --example derivatives -- "x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8"

use lgc::{BatchEvaluator, Formula, Output};

fn main() {
    let source = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "x^2+y^2+z^2-1".to_string());
    let formula = match Formula::parse(&source) {
        Ok(f) => f,
        Err(e) => {
            eprint!("{}", e.render(&source, "<formula>"));
            std::process::exit(1);
        }
    };
    for (name, output) in [
        ("df/dx", Output::Dfdx),
        ("df/dy", Output::Dfdy),
        ("df/dz", Output::Dfdz),
        ("g", Output::G),
        ("g'", Output::Dg),
    ] {
        println!("{name:6} = {}", formula.print(formula.node(output)));
    }

    // F(t), g(t) and g'(t) along the ray o + t*d, o = (-3, 0.1, 0.2), d = (1, 0, 0).
    let ts: Vec<f64> = (0..=12).map(|i| f64::from(i) * 0.5).collect();
    let xs: Vec<f64> = ts.iter().map(|t| -3.0 + t).collect();
    let n = ts.len();
    let (ys, zs, dx, dy, dz) = (
        vec![0.1; n],
        vec![0.2; n],
        vec![1.0; n],
        vec![0.0; n],
        vec![0.0; n],
    );
    let tape = formula.tape(&[Output::F, Output::G, Output::Dg]);
    let (mut f, mut g, mut dg) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    BatchEvaluator::new(&tape).eval(
        &[&xs, &ys, &zs, &dx, &dy, &dz],
        &mut [&mut f, &mut g, &mut dg],
    );
    println!("\n{:>5} {:>14} {:>14} {:>14}", "t", "F(t)", "g(t)", "g'(t)");
    for i in 0..n {
        println!("{:>5} {:>14.6} {:>14.6} {:>14.6}", ts[i], f[i], g[i], dg[i]);
    }
}
