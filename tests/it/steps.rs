//! Step functions (`floor`, `ceil`, `round`, `mod`): enclosures that hold
//! every value, decorations that mark exactly their jumps, derivatives that
//! are 0 between jumps and unbounded across them, and rays that never take a
//! jump for a root.

use crate::common::Rng;
use glam::DVec3;
use lgc::bounds::Bounder;
use lgc::ray::{Answer, Intersector};
use lgc::types::{DecInterval, Decoration, Interval};
use lgc::{Aabb, Evaluator, Formula, Output, Segment};

/// f and its decoration over the box `x ∈ [lo, hi]` (y and z at 0).
fn over(formula: &Formula, lo: f64, hi: f64) -> DecInterval {
    let tape = formula.tape(&[Output::F]);
    let mut eval = Evaluator::<DecInterval>::new(&tape);
    let x = DecInterval::defined(Interval::new(lo, hi));
    let zero = DecInterval::defined(Interval::point(0.0));
    eval.eval(&[x, zero, zero, zero, zero, zero])[0]
}

/// A step function: its formula, its f64 value, and where its jumps are
/// (integers plus this offset).
type StepFunction = (&'static str, fn(f64) -> f64, f64);

#[test]
fn step_enclosures_hold_every_value_and_mark_exactly_their_jumps() {
    let mut rng = Rng::new(0x57e9);
    let steps: [StepFunction; 3] = [
        ("floor(x)", f64::floor, 0.0),
        ("ceil(x)", f64::ceil, 0.0),
        ("round(x)", f64::round, 0.5),
    ];
    let (mut jumps, mut smooth) = (0, 0);
    for (src, step, offset) in steps {
        let f = Formula::parse(src).unwrap();
        for k in 0..2000 {
            // Ends at random, on a jump, or just beside one.
            let mut lo = rng.uniform(-4.0, 4.0);
            let mut hi = lo + rng.uniform(0.0, 1.5);
            match k % 4 {
                1 => lo = lo.round() + offset,
                2 => hi = hi.round() + offset,
                3 => hi = (lo.floor() + offset + 1.0).next_down(),
                _ => {}
            }
            if hi < lo {
                continue;
            }
            let v = over(&f, lo, hi);
            for i in 0..=16 {
                let p = lo + (hi - lo) * f64::from(i) / 16.0;
                let p = p.clamp(lo, hi);
                assert!(
                    v.interval().contains(step(p)),
                    "{src} over [{lo}, {hi}] at {p}"
                );
            }
            // Continuous on [lo, hi] exactly where both ends take one step.
            let jump = step(lo) != step(hi);
            let dac = v.decoration() == Decoration::Dac;
            assert_eq!(dac, !jump, "{src} over [{lo}, {hi}]: {:?}", v.decoration());
            if jump {
                jumps += 1;
            } else {
                smooth += 1;
            }
        }
    }
    assert!(
        jumps > 1000 && smooth > 1000,
        "{jumps} with a jump, {smooth} without"
    );
}

#[test]
fn modulo_takes_the_sign_of_its_divisor() {
    let f = Formula::parse("mod(x, y)").unwrap();
    let tape = f.tape(&[Output::F]);
    let mut eval = Evaluator::<f64>::new(&tape);
    let mut rng = Rng::new(3);
    for _ in 0..2000 {
        let (a, b) = (rng.uniform(-50.0, 50.0), rng.uniform(-3.0, 3.0));
        let [m] = eval.eval_array(&[a, b, 0.0, 0.0, 0.0, 0.0]);
        assert!(m == 0.0 || m.signum() == b.signum(), "mod({a}, {b}) = {m}");
        assert!(m.abs() <= b.abs() * (1.0 + 1e-12), "mod({a}, {b}) = {m}");
        let k = (a - m) / b;
        assert!((k - k.round()).abs() < 1e-9, "mod({a}, {b}) = {m}");
    }
}

#[test]
fn g_is_unbounded_across_a_jump_and_finite_between_jumps() {
    let f = Formula::parse("floor(2*x) + y^2 + z").unwrap();
    let bounder = Bounder::new(&f);
    let along_x = |t0: f64, t1: f64| {
        let ray = Segment::new(DVec3::new(0.0, 0.3, 0.0), DVec3::X, t0, t1).unwrap();
        bounder.grad_lipschitz_bound(&ray, 0).value
    };
    assert!(
        along_x(0.55, 0.95).is_finite(),
        "no jump between 0.55 and 0.95"
    );
    assert_eq!(along_x(0.8, 1.2), f64::INFINITY, "a jump at x = 1");
    // Between jumps the gradient is the smooth part's: ∂f/∂x = 0.
    let tape = f.tape(&[Output::Dfdx, Output::Dfdy]);
    let [fx, fy] = Evaluator::<f64>::new(&tape).eval_array(&[0.7, 0.3, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!((fx, fy), (0.0, 0.6));
}

#[test]
fn a_jump_across_zero_is_never_a_hit() {
    // mod(x, 1) − ½ falls from ½ to −½ at every integer (a jump, no root)
    // and rises through 0 at every half (a root).
    let f = Formula::parse("mod(x, 1) - 0.5 + 0*y*z").unwrap();
    let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    for depth in [3, 5] {
        let scene = Intersector::new(&f, &b, depth);
        let mut tracer = scene.tracer();
        let mut rng = Rng::new(11);
        for _ in 0..200 {
            let x0 = rng.uniform(-1.9, 1.4);
            let o = DVec3::new(x0, rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            let answer = tracer.answer(o, DVec3::X, 0.0, f64::INFINITY);
            let next_half = (x0 - 0.5).ceil() + 0.5;
            let next_jump = x0.floor() + 1.0;
            match answer {
                Answer::Hit(t) => {
                    assert!(
                        (o.x + t - next_half).abs() < 1e-9,
                        "from {x0}: hit at {}",
                        o.x + t
                    );
                    assert!(next_half < next_jump || (x0 - x0.floor() - 0.5).abs() < 1e-12);
                }
                // A piece straddling the jump may only touch, at the jump.
                Answer::Touch(t) => {
                    assert!(next_jump < next_half, "from {x0}: touch at {}", o.x + t);
                    assert!(
                        (o.x + t - next_jump).abs() < 1e-6,
                        "from {x0}: touch at {}",
                        o.x + t
                    );
                }
                other => panic!("from {x0}: {other:?}"),
            }
        }
    }
}
