//! Lipschitz slopes carried through a formula's operations: a true bound of
//! how far f moves between any two points of a box, finite at the centre of
//! a circle (where ∇f is undefined), and none where f may be undefined.

use crate::common::Rng;
use glam::DVec3;
use lgc::expr::Slopes;
use lgc::ray::Intersector;
use lgc::{Aabb, Evaluator, Formula, Output};

fn cube(h: f64) -> Aabb {
    Aabb::new(DVec3::splat(-h), DVec3::splat(h)).unwrap()
}

/// f's slopes over the box centred at `c` with half-width `h`.
fn slopes_over(f: &Formula, c: [f64; 3], h: f64) -> Slopes {
    let tape = f.tape(&[Output::F]);
    let c = DVec3::from(c);
    let b = Aabb::new(c - h, c + h).unwrap();
    Evaluator::<Slopes>::new(&tape).eval(&Slopes::inputs(&b))[0]
}

/// Formulas and boxes (centre, half-width) where f is defined and
/// Lipschitz: centres of circles and spheres, where ∇f is not defined, among
/// them.
const LIPSCHITZ: &[(&str, [f64; 3], f64)] = &[
    ("sqrt(x^2+y^2)-0.5", [0.0, 0.0, 0.0], 0.1),
    (
        "sqrt((3*x+0.2)^2+(y-0.1)^2+z^2)",
        [-0.2 / 3.0, 0.1, 0.0],
        0.05,
    ),
    // √(x² + x²) = √2·|x|: the roots' slopes along one axis add as a norm.
    ("sqrt((x-0.1)^2+(0.5*x+y)^2)", [0.1, -0.05, 0.0], 0.2),
    ("sqrt(x^2*y^2+z^2)", [0.0, 0.0, 0.0], 0.7),
    (
        "sqrt(max(x^2, y^2)) + sqrt(min(x^2+z^2, 4*y^2))",
        [0.0, 0.0, 0.0],
        0.5,
    ),
    (
        "max(sqrt((x-0.3)^2+y^2)-0.1, abs(z)-0.1)",
        [0.3, 0.0, 0.0],
        0.2,
    ),
    ("x*y*z + exp(x) - ln(y+2)", [0.0, 0.0, 0.0], 1.0),
    (
        "atan2(y, x+2) + 1/(x^2+1) + sin(3*x)*cos(y) + tanh(z)",
        [0.0, 0.0, 0.0],
        1.0,
    ),
    (
        "min(x^2+y, max(z, x-y)) + x^3 - 2*x*y^2",
        [0.1, 0.2, 0.3],
        0.8,
    ),
    ("abs(x) + sqrt(abs(y)+1) + sign(z)", [0.0, 0.0, 0.75], 0.25),
];

/// For every pair of points sampled in the box, `|f(p) − f(q)|` is at
/// most `Σ slopeᵢ·|pᵢ − qᵢ|` (beside the f64 evaluation's own rounding), and
/// the slopes are finite: the centre of a circle no longer stops them.
#[test]
fn slopes_bound_the_change_of_f_between_any_two_points() {
    let mut rng = Rng::new(2026);
    for &(src, c, h) in LIPSCHITZ {
        let f = Formula::parse(src).unwrap();
        let s = slopes_over(&f, c, h);
        assert!(s.defined, "{src}: {s:?}");
        assert!(s.slope.iter().all(|s| s.is_finite()), "{src}: {s:?}");
        let tape = f.tape(&[Output::F]);
        let mut eval = Evaluator::<f64>::new(&tape);
        let mut at = |p: DVec3| eval.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0];
        let centre = DVec3::from(c);
        let mut tightest = f64::INFINITY;
        for k in 0..4000 {
            let p = centre + h * DVec3::from(rng.point([-1.0; 3], [1.0; 3]));
            // Half of the pairs close together, a few around the centre.
            let q = match k % 3 {
                0 => centre + h * DVec3::from(rng.point([-1.0; 3], [1.0; 3])),
                1 => (p + 1e-3 * h * DVec3::from(rng.point([-1.0; 3], [1.0; 3])))
                    .clamp(centre - h, centre + h),
                _ => centre + 1e-6 * h * DVec3::from(rng.point([-1.0; 3], [1.0; 3])),
            };
            let (fp, fq) = (at(p), at(q));
            let moved = (fp - fq).abs();
            let allowed = DVec3::from(s.slope).dot((p - q).abs());
            let rounding = 1e-13 * (1.0 + fp.abs() + fq.abs());
            assert!(
                moved <= allowed + rounding,
                "{src}: f moved {moved} between {p} and {q}, slopes {:?} allow {allowed}",
                s.slope
            );
            if moved > 1e-9 {
                tightest = tightest.min(allowed / moved);
            }
        }
        // Not vacuous: some pair moves within a few times what the slopes allow.
        assert!(tightest < 20.0, "{src}: slopes {:?}, {tightest}", s.slope);
    }
}

/// Where f may be undefined somewhere in the box, or jumps, there are no
/// slopes, even when its enclosure is one value.
#[test]
fn no_slopes_where_f_may_be_undefined_or_jump() {
    for (src, c, h, defined) in [
        ("sqrt(x)", [0.0; 3], 1.0, false),
        ("1/x", [0.0; 3], 1.0, false),
        ("ln(x+0.5)", [0.0; 3], 1.0, false),
        ("min(sqrt(x), 0) + y", [0.0; 3], 1.0, false),
        ("sign(x)", [0.0; 3], 1.0, true),
        ("floor(4*x)", [0.0; 3], 1.0, true),
        ("sqrt(x)", [0.5, 0.0, 0.0], 0.5, true),
    ] {
        let s = slopes_over(&Formula::parse(src).unwrap(), c, h);
        assert_eq!(s.defined, defined, "{src}: {s:?}");
        assert!(s.slope.iter().any(|s| s.is_infinite()), "{src}: {s:?}");
    }
    // sign is constant where its argument keeps one sign.
    let s = slopes_over(&Formula::parse("sign(x)").unwrap(), [0.75, 0.0, 0.0], 0.25);
    assert_eq!(s.slope, [0.0; 3]);
}

/// The leaves of lettering drawn with round strokes, each holding the
/// centre of a circle: the leaves' L was infinite there (∇f is undefined at
/// the centre), and rays in them were decided by intervals only. Now every
/// kept leaf has a finite L and rounding bound, and rays answer as they do
/// with the octree's leaves at full depth.
#[test]
fn leaves_holding_a_circles_centre_have_a_lipschitz_bound() {
    let src = "max(min(sqrt((x-0.31)^2+(y-0.12)^2)-0.03, sqrt((x+0.4)^2+y^2)-0.05, \
               max(abs(x)-0.6, abs(y-0.5)-0.02)), abs(z)-0.1)";
    let f = Formula::parse(src).unwrap();
    let bounds: Aabb = cube(1.0);
    let intersector = Intersector::new(&f, &bounds, 4);
    let octree = intersector.octree();
    let centres = [DVec3::new(0.31, 0.12, 0.05), DVec3::new(-0.4, 0.0, -0.05)];
    let mut holding = 0;
    let leaves = octree
        .nodes
        .iter()
        .filter_map(|n| octree.leaf(n).map(|l| (l, n.bounds)));
    for (leaf, b) in leaves {
        assert!(
            leaf.lipschitz.is_finite() && leaf.continuous,
            "{b:?}: {leaf:?}"
        );
        assert!(
            leaf.f_error.is_finite() && leaf.f_error < 1e-14,
            "{b:?}: {leaf:?}"
        );
        holding += centres.iter().filter(|&&c| b.contains(c)).count();
    }
    assert!(holding >= 2, "the centres lie in kept leaves");
}
