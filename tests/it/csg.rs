//! CSG and rigid transforms of the formula language: point membership and
//! where transforms move points (moved from a unit test of `expr::csg`, which
//! may not depend on the formula stage above it).

use lgc::Formula;

fn f_at(src: &str, p: [f64; 3]) -> f64 {
    let f = Formula::parse(src).unwrap();
    f.context().eval(f.f(), &[p[0], p[1], p[2], 0.0, 0.0, 0.0])
}

const SPHERE: &str = "x^2+y^2+z^2-1";
const CUBE: &str = "max(abs(x), abs(y), abs(z)) - 0.8";

#[test]
fn csg_point_membership() {
    let inside = |src: &str, p: [f64; 3]| f_at(src, p) < 0.0;
    let u = format!("union({SPHERE}, translate({SPHERE}, 1.5, 0, 0))");
    assert!(
        inside(&u, [0.0, 0.0, 0.0]) && inside(&u, [1.5, 0.0, 0.0]) && !inside(&u, [0.75, 0.9, 0.0])
    );
    let i = format!("intersect({SPHERE}, {CUBE})");
    assert!(
        inside(&i, [0.0, 0.0, 0.0]) && !inside(&i, [0.9, 0.0, 0.0]) && !inside(&i, [0.7, 0.7, 0.7])
    );
    // The CSG part: a cube minus a sphere.
    let d = format!("subtract({CUBE}, scale({SPHERE}, 0.95))");
    assert!(!inside(&d, [0.0, 0.0, 0.0]), "the centre is carved out");
    assert!(inside(&d, [0.78, 0.78, 0.78]), "the corners remain");
    assert!(!inside(&d, [0.9, 0.0, 0.0]), "outside the cube");
}

#[test]
fn transforms_move_points_as_documented() {
    let t = format!("translate({SPHERE}, 2, -1, 0.5)");
    assert!(f_at(&t, [2.0, -1.0, 0.5]) == -1.0);
    let s = format!("scale({SPHERE}, 2)");
    assert!((f_at(&s, [2.0, 0.0, 0.0])).abs() < 1e-12, "radius 2");
    // A box long in x, turned 90° about z, is long in y.
    let slab = "max(abs(x) - 2, abs(y) - 0.5, abs(z) - 0.5)";
    let r = format!("rotate({slab}, 0, 0, 90)");
    assert!(f_at(&r, [0.0, 1.5, 0.0]) < 0.0 && f_at(&r, [1.5, 0.0, 0.0]) > 0.0);
    let r = format!("rotate({slab}, 0, 90, 0)");
    assert!(f_at(&r, [0.0, 0.0, 1.5]) < 0.0 && f_at(&r, [1.5, 0.0, 0.0]) > 0.0);
}

#[test]
fn blend_is_min_far_from_the_seam_and_below_it_near() {
    let a = "x^2+y^2+z^2-1";
    let b = "(x-1.5)^2+y^2+z^2-1";
    let src = format!("blend({a}, {b}, 0.5)");
    let far = [-0.5, 0.0, 0.0];
    assert_eq!(f_at(&src, far), f_at(&format!("min({a}, {b})"), far));
    let seam = [0.75, 0.0, 0.0];
    assert!(f_at(&src, seam) < f_at(&format!("min({a}, {b})"), seam));
}
