//! The extremes of f64: numbers near its ends, large degrees, deep nesting,
//! formulas defined nowhere. Each test is named after what once went wrong.

use glam::DVec3;
use lgc::bounds::Bounder;
use lgc::{Aabb, Formula};

fn unit_box() -> Aabb {
    Aabb::new(DVec3::ZERO, DVec3::ONE).unwrap()
}

#[test]
fn constant_products_that_underflow_do_not_drop_the_variable() {
    // 1e-300·1e-300 rounds to 0 in f64; folding it so made x − 0.5 constant,
    // with L = 0 and a "proved" verdict for any constant.
    let f = Formula::parse("x*1e-300*1e-300*1e300*1e300 - 0.5").unwrap();
    let grad = f.print(f.gradient()[0]);
    assert_ne!(grad, "0", "∂f/∂x folded to 0");
    let b = Bounder::new(&f);
    let [v, dx, _, _] = b.f_and_gradient(&unit_box());
    // The real f ranges over [-0.5, 0.5] and ∂f/∂x is (about) 1.
    assert!(v.inf() <= -0.5 && v.sup() >= 0.4, "f: {v:?}");
    assert!(dx.sup() >= 0.99, "∂f/∂x: {dx:?}");
    assert!(b.lipschitz_bound(&unit_box(), 0).value >= 0.99);
}

#[test]
fn exact_tiny_products_still_fold() {
    // Products into the subnormals that f64 holds exactly keep folding.
    let f = Formula::parse("x*(2^-600*2^-400) + y*(1e-300*1)").unwrap();
    let [dx, dy, _] = f.gradient().map(|n| f.context().const_value(n));
    assert_eq!(dx, Some(2f64.powi(-1000)));
    assert_eq!(dy, Some(1e-300));
}
