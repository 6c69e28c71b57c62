//! Property tests of the intersector's certificates: random polynomial
//! surfaces, rays built tangent to the surface at a point and pushed off by
//! ±δ. A miss must never have a sign change along the ray that interval
//! arithmetic certifies; a hit must sit on a certified sign change (or a
//! point where F's enclosure is {0}) within the tolerance, with none before
//! it; a touch must have an enclosure of F holding 0 within the tolerance.

use glam::DVec3;
use lgc::ray::{Answer, Intersector};
use lgc::{Aabb, Evaluator, Formula, Interval, Output, Segment};
use proptest::prelude::*;

/// A random polynomial of degree at most 4 with small integer coefficients.
fn polynomial() -> impl Strategy<Value = String> {
    let monomial = (-3i32..=3, 0u32..=2, 0u32..=2, 0u32..=2)
        .prop_map(|(c, i, j, k)| format!("{c}*x^{i}*y^{j}*z^{k}"));
    prop::collection::vec(monomial, 2..6).prop_map(|terms| terms.join(" + "))
}

/// The sign interval arithmetic certifies for F at t: ±1, or 0.
fn sign(eval: &mut Evaluator<Interval>, o: DVec3, d: DVec3, t: f64) -> i8 {
    let s = Segment::new(o, d, t, t).unwrap();
    let v = eval.eval(&s.inputs())[0];
    if v.inf() > 0.0 {
        1
    } else if v.sup() < 0.0 {
        -1
    } else {
        0
    }
}

/// The first t of `ts` after which a certified sign change occurs between
/// consecutive samples.
fn first_certified_change(
    eval: &mut Evaluator<Interval>,
    o: DVec3,
    d: DVec3,
    ts: &[f64],
) -> Option<f64> {
    let mut last = 0i8;
    for &t in ts {
        let s = sign(eval, o, d, t);
        if s != 0 {
            if last != 0 && s != last {
                return Some(t);
            }
            last = s;
        }
    }
    None
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 150, ..ProptestConfig::default() })]

    #[test]
    fn every_answer_has_its_certificate(
        poly in polynomial(),
        p0 in prop::array::uniform3(-0.8f64..0.8),
        tangent in prop::array::uniform3(-1.0f64..1.0),
        exponent in 3i32..=12,
        side in prop::bool::ANY,
    ) {
        // The surface P(x) = P(p0) passes through p0.
        let p = Formula::parse(&poly).unwrap();
        let p0 = DVec3::from(p0);
        let level = Evaluator::<f64>::new(&p.tape(&[Output::F])).eval(&[p0.x, p0.y, p0.z, 0.0, 0.0, 0.0])[0];
        let src = format!("{poly} - ({level:e})");
        let f = Formula::parse(&src).unwrap();
        let grad = Evaluator::<f64>::new(&f.tape(&[Output::Dfdx, Output::Dfdy, Output::Dfdz]))
            .eval(&[p0.x, p0.y, p0.z, 0.0, 0.0, 0.0])
            .to_vec();
        let n = DVec3::new(grad[0], grad[1], grad[2]);
        prop_assume!(n.length() > 1e-3);
        let n = n.normalize();
        let t = DVec3::from(tangent);
        let t = t - t.dot(n) * n;
        prop_assume!(t.length() > 1e-3);
        let delta = 10f64.powi(-exponent) * if side { 1.0 } else { -1.0 };
        let d = t.normalize();
        let o = p0 + delta * n - 1.5 * d;

        let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        let scene = Intersector::new(&f, &b, 4);
        let answer = scene.tracer().answer(o, d, 0.0, f64::INFINITY);
        let f_tape = f.tape(&[Output::F]);
        let mut eval = Evaluator::<Interval>::new(&f_tape);
        let tol = 1e-10 * (b.hi - b.lo).length() / d.length();
        // Samples along the ray inside the box.
        let ts: Vec<f64> = (0..=4000).map(|k| 0.0 + 4.0 * f64::from(k) / 4000.0)
            .filter(|&t| { let q = o + t * d; q.cmpge(b.lo).all() && q.cmple(b.hi).all() })
            .collect();
        match answer {
            Answer::Miss => {
                let change = first_certified_change(&mut eval, o, d, &ts);
                prop_assert!(change.is_none(), "{src}: a miss, but F changes sign by {change:?} on {o} + t {d}");
            }
            Answer::Hit(th) | Answer::Touch(th) => {
                let before: Vec<f64> = ts.iter().copied().filter(|&t| t < th - 4.0 * tol).collect();
                let change = first_certified_change(&mut eval, o, d, &before);
                prop_assert!(change.is_none(), "{src}: {answer:?}, but F changed sign earlier, by {change:?}");
                if let Answer::Hit(_) = answer {
                    let (lo, hi) = (th - 4.0 * tol, th + 4.0 * tol);
                    let crossing = sign(&mut eval, o, d, lo) * sign(&mut eval, o, d, hi) < 0;
                    let exact_zero = {
                        let s = Segment::new(o, d, th, th).unwrap();
                        let v = eval.eval(&s.inputs())[0];
                        v.inf() == 0.0 && v.sup() == 0.0
                    };
                    prop_assert!(crossing || exact_zero, "{src}: hit at {th} without a certified sign change around it");
                } else {
                    let s = Segment::new(o, d, th - 8.0 * tol, th + 8.0 * tol).unwrap();
                    let v = eval.eval(&s.inputs())[0];
                    prop_assert!(v.contains(0.0), "{src}: touch at {th}, but F over ±tol is {v:?}");
                }
            }
            Answer::Undecided(t) => prop_assert!(false, "{src}: undecided at {t}"),
        }
    }
}
