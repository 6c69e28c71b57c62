//! Interval enclosures, L and G against sampled points, the paper's sphere
//! constants, and infinite bounds reported as such.

use crate::common::{corpus, Rng};
use glam::DVec3;
use lgc::bounds::{Bounder, Method};
use lgc::{verify_grad_lipschitz, verify_lipschitz, Evaluator, Formula, Interval, Output, Verdict};
use lgc::{Aabb, Segment};
use proptest::prelude::*;

/// A random formula over the whole language (domains may be violated: such
/// points have no value and are skipped).
/// A random ray segment from a point of `b`, for t in [−0.5, 0.75].
fn random_segment(rng: &mut Rng, b: &Aabb) -> Segment {
    let o = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
    let d = DVec3::from(rng.direction());
    Segment::new(o, d, -0.5, 0.75).unwrap()
}

fn formula() -> impl Strategy<Value = String> {
    let leaf = prop_oneof![
        Just("x".to_string()),
        Just("y".to_string()),
        Just("z".to_string()),
        (-30i32..30).prop_map(|c| format!("{}", f64::from(c) / 10.0)),
    ];
    leaf.prop_recursive(4, 24, 3, |inner| {
        let unary = [
            "sqrt", "abs", "sin", "cos", "tan", "asin", "acos", "atan", "exp", "ln", "log", "sinh",
            "cosh", "tanh", "sech", "sign", "floor", "ceil", "round",
        ];
        prop_oneof![
            (
                inner.clone(),
                inner.clone(),
                prop::sample::select(vec!["+", "-", "*", "/"])
            )
                .prop_map(|(a, b, op)| format!("({a}){op}({b})")),
            (inner.clone(), -3i32..5).prop_map(|(a, n)| format!("({a})^{n}")),
            (inner.clone(), prop::sample::select(unary.to_vec()))
                .prop_map(|(a, f)| format!("{f}({a})")),
            (
                inner.clone(),
                inner.clone(),
                prop::sample::select(vec!["min", "max", "atan2", "hypot", "pow", "mod"])
            )
                .prop_map(|(a, b, f)| format!("{f}({a}, {b})")),
            (inner.clone(), inner.clone(), inner.clone())
                .prop_map(|(c, a, b)| format!("choose({c}, {a}, {b})")),
            // Sums of exponentials under ln, whose derivatives are weighted means.
            (inner.clone(), inner.clone(), prop::option::of(inner)).prop_map(|(a, b, c)| match c {
                Some(c) => format!("ln(exp({a}) + (exp({b}) + exp({c})))"),
                None => format!("ln(exp({a}) + exp({b}))"),
            }),
        ]
    })
}

/// A random polynomial: the formulas the Bernstein method expands, with
/// constants that are not f64 numbers (`sqrt(2)`) among the coefficients.
fn polynomial() -> impl Strategy<Value = String> {
    let leaf = prop_oneof![
        Just("x".to_string()),
        Just("y".to_string()),
        Just("z".to_string()),
        Just("sqrt(2)".to_string()),
        (-30i32..30).prop_map(|c| format!("{}", f64::from(c) / 10.0)),
    ];
    leaf.prop_recursive(4, 20, 2, |inner| {
        prop_oneof![
            (
                inner.clone(),
                inner.clone(),
                prop::sample::select(vec!["+", "-", "*"])
            )
                .prop_map(|(a, b, op)| format!("({a}){op}({b})")),
            (inner.clone(), 0i32..4).prop_map(|(a, n)| format!("({a})^{n}")),
            inner.prop_map(|a| format!("({a})/3")),
        ]
    })
}

/// A random formula of the functions Taylor models expand.
fn analytic() -> impl Strategy<Value = String> {
    let leaf = prop_oneof![
        Just("x".to_string()),
        Just("y".to_string()),
        Just("z".to_string()),
        (-30i32..30).prop_map(|c| format!("{}", f64::from(c) / 10.0)),
    ];
    leaf.prop_recursive(4, 16, 2, |inner| {
        prop_oneof![
            (
                inner.clone(),
                inner.clone(),
                prop::sample::select(vec!["+", "-", "*"])
            )
                .prop_map(|(a, b, op)| format!("({a}){op}({b})")),
            (inner.clone(), 0i32..3).prop_map(|(a, n)| format!("({a})^{n}")),
            (
                inner,
                prop::sample::select(vec!["sin", "cos", "exp", "sinh", "cosh"])
            )
                .prop_map(|(a, f)| format!("{f}({a})")),
        ]
    })
}

/// A small box, where Taylor models are tight.
fn small_region() -> impl Strategy<Value = Aabb> {
    (
        prop::array::uniform3(-2.0f64..2.0),
        prop::array::uniform3(0.001f64..0.3),
    )
        .prop_map(|(c, h)| {
            let (c, h) = (DVec3::from(c), DVec3::from(h));
            Aabb::new(c - h, c + h).unwrap()
        })
}

fn region() -> impl Strategy<Value = Aabb> {
    (
        prop::array::uniform3(-2.0f64..2.0),
        prop::array::uniform3(0.001f64..1.5),
    )
        .prop_map(|(c, h)| {
            let (c, h) = (DVec3::from(c), DVec3::from(h));
            Aabb::new(c - h, c + h).unwrap()
        })
}

/// The intervals of all six outputs over the box, with a point direction.
fn over_box(tape: &lgc::Tape, b: &Aabb, d: DVec3) -> Vec<Interval> {
    let [x, y, z] = b.intervals();
    let p = Interval::point;
    Evaluator::<Interval>::new(tape)
        .eval(&[x, y, z, p(d.x), p(d.y), p(d.z)])
        .to_vec()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn intervals_enclose_every_sampled_point(src in formula(), b in region(), seed in any::<u64>()) {
        let f = Formula::parse(&src).unwrap();
        let tape = f.tape(&Output::ALL);
        let mut rng = Rng::new(seed);
        let d = DVec3::from(rng.direction());
        let boxed = over_box(&tape, &b, d);
        let mut point_eval = Evaluator::<f64>::new(&tape);
        for _ in 0..16 {
            let p = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
            let at = over_box(&tape, &Aabb { lo: p, hi: p }, d);
            let values = point_eval.eval(&[p.x, p.y, p.z, d.x, d.y, d.z]).to_vec();
            for k in 0..6 {
                // Rigorous: the exact value lies in the point's own enclosure,
                // so that must meet the box's enclosure.
                prop_assert!(at[k].is_empty() || !boxed[k].intersection(at[k]).is_empty(),
                    "{src}: output {k} over {b:?} is {:?}, but at {p} it is {:?}", boxed[k], at[k]);
                // And the f64 value itself, up to its own rounding.
                let v = values[k];
                if v.is_finite() {
                    let tol = 1e-9 * v.abs().max(1.0);
                    prop_assert!(boxed[k].inf() - tol <= v && v <= boxed[k].sup() + tol,
                        "{src}: output {k} = {v} at {p} is outside {:?}", boxed[k]);
                }
            }
        }
    }

    #[test]
    fn lipschitz_bounds_are_never_below_a_sample(src in formula(), b in region(), seed in any::<u64>(), depth in 0u32..2) {
        let f = Formula::parse(&src).unwrap();
        let bounder = Bounder::new(&f);
        let l = bounder.lipschitz_bound(&b, depth);
        let mut rng = Rng::new(seed);
        for _ in 0..16 {
            let p = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
            let at_least = bounder.gradient_norm_at_least(p);
            prop_assert!(l.value >= at_least, "{src}: L = {} < |grad f({p})| >= {at_least}", l.value);
        }
        // The sampled estimate is attained somewhere, so it is below L too.
        let s = bounder.sample_gradient(&b, 6);
        prop_assert!(l.value >= bounder.gradient_norm_at_least(s.point));
    }

    #[test]
    fn every_method_is_sound_and_inside_the_natural_bound(src in formula(), b in region(), seed in any::<u64>(), depth in 0u32..2) {
        let f = Formula::parse(&src).unwrap();
        let bounder = Bounder::new(&f);
        let natural = bounder.lipschitz_bound_by(&b, depth, Method::Natural).value;
        let mut rng = Rng::new(seed);
        let points: Vec<DVec3> = (0..12).map(|_| DVec3::from(rng.point(b.lo.into(), b.hi.into()))).collect();
        for m in Method::ALL {
            let l = bounder.lipschitz_bound_by(&b, depth, m).value;
            prop_assert!(l <= natural, "{src} {}: {l} > natural {natural}", m.name());
            for &p in &points {
                let at_least = bounder.gradient_norm_at_least(p);
                prop_assert!(l >= at_least, "{src} {}: L = {l} < |grad f({p})| >= {at_least}", m.name());
            }
        }
    }

    #[test]
    fn bernstein_bounds_of_polynomials_are_sound(src in polynomial(), b in region(), seed in any::<u64>(), depth in 0u32..2) {
        let f = Formula::parse(&src).unwrap();
        let bounder = Bounder::new(&f);
        prop_assert!(bounder.is_polynomial(), "{src} should expand");
        let natural = bounder.lipschitz_bound_by(&b, depth, Method::Natural).value;
        let l = bounder.lipschitz_bound_by(&b, depth, Method::Bernstein).value;
        prop_assert!(l <= natural);
        let mut rng = Rng::new(seed);
        for _ in 0..24 {
            let p = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
            let at_least = bounder.gradient_norm_at_least(p);
            prop_assert!(l >= at_least, "{src}: L = {l} < |grad f({p})| >= {at_least}");
        }
        let s = random_segment(&mut rng, &b);
        let g = bounder.grad_lipschitz_bound_by(&s, depth, Method::Bernstein).value;
        prop_assert!(g <= bounder.grad_lipschitz_bound_by(&s, depth, Method::Natural).value);
        for i in 0..=24 {
            let t = -0.5 + 1.25 * f64::from(i) / 24.0;
            let at_least = bounder.dg_at_least(&s, t);
            prop_assert!(g >= at_least, "{src}: G = {g} < |g'({t})| >= {at_least}");
        }
    }

    #[test]
    fn taylor_models_are_sound_on_small_boxes(src in analytic(), b in small_region(), seed in any::<u64>()) {
        let f = Formula::parse(&src).unwrap();
        let bounder = Bounder::new(&f);
        let natural = bounder.lipschitz_bound_by(&b, 0, Method::Natural).value;
        let l = bounder.lipschitz_bound_by(&b, 0, Method::Taylor).value;
        prop_assert!(l <= natural);
        let mut rng = Rng::new(seed);
        for _ in 0..24 {
            let p = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
            let at_least = bounder.gradient_norm_at_least(p);
            prop_assert!(l >= at_least, "{src}: L = {l} < |grad f({p})| >= {at_least}");
        }
        let o = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
        let d = DVec3::from(rng.direction());
        let s = Segment::new(o, d, -0.2, 0.2).unwrap();
        let g = bounder.grad_lipschitz_bound_by(&s, 0, Method::Taylor).value;
        prop_assert!(g <= bounder.grad_lipschitz_bound_by(&s, 0, Method::Natural).value);
        for i in 0..=24 {
            let t = -0.2 + 0.4 * f64::from(i) / 24.0;
            let at_least = bounder.dg_at_least(&s, t);
            prop_assert!(g >= at_least, "{src}: G = {g} < |g'({t})| >= {at_least}");
        }
    }

    /// Affine forms along a ray (and Best, which uses them on formulas they
    /// carry) never fall below g′ at sampled t, nor above the natural bound.
    #[test]
    fn affine_g_is_sound_and_inside_the_natural_bound(src in formula(), b in region(), seed in any::<u64>(), depth in 0u32..2) {
        let f = Formula::parse(&src).unwrap();
        let bounder = Bounder::new(&f);
        let mut rng = Rng::new(seed);
        let s = random_segment(&mut rng, &b);
        let natural = bounder.grad_lipschitz_bound_by(&s, depth, Method::Natural).value;
        for m in [Method::Affine, Method::Best] {
            let g = bounder.grad_lipschitz_bound_by(&s, depth, m).value;
            prop_assert!(g <= natural, "{src} {}: {g} > natural {natural}", m.name());
            for i in 0..=24 {
                let t = -0.5 + 1.25 * f64::from(i) / 24.0;
                let at_least = bounder.dg_at_least(&s, t);
                prop_assert!(g >= at_least, "{src} {}: G = {g} < |g'({t})| >= {at_least}", m.name());
            }
        }
    }

    #[test]
    fn grad_lipschitz_bounds_are_never_below_a_sample(src in formula(), b in region(), seed in any::<u64>(), depth in 0u32..3) {
        let f = Formula::parse(&src).unwrap();
        let bounder = Bounder::new(&f);
        let mut rng = Rng::new(seed);
        let s = random_segment(&mut rng, &b);
        let g = bounder.grad_lipschitz_bound(&s, depth);
        for i in 0..=16 {
            let t = -0.5 + 1.25 * f64::from(i) / 16.0;
            let at_least = bounder.dg_at_least(&s, t);
            prop_assert!(g.value >= at_least, "{src}: G = {} < |g'({t})| >= {at_least}", g.value);
        }
    }
}

fn sphere(c: DVec3, r: f64) -> Formula {
    Formula::parse(&format!(
        "(x-({}))^2 + (y-({}))^2 + (z-({}))^2 - {}^2",
        c.x, c.y, c.z, r
    ))
    .unwrap()
}

/// The exponential smooth union of two balls, whose gradient is a weighted
/// mean of theirs: `|∇f| ≤ 1`. Its chain-rule quotient `(e^A·A′ + e^B·B′) /
/// (e^A + e^B)` enclosed over [0.1, 1]³ gave L = 5.8·10¹¹ and, on a ray
/// across both balls, G = 1.6·10¹².
#[test]
fn smooth_union_bounds_are_not_quotients_of_exponentials() {
    let f = Formula::parse(
        "-ln(exp(-16*(sqrt(x^2+y^2+z^2)-0.8)) + exp(-16*(sqrt((x-0.7)^2+y^2+z^2)-0.5)))/16",
    )
    .unwrap();
    let bounder = Bounder::new(&f);
    let b = Aabb::new(DVec3::splat(0.1), DVec3::splat(1.0)).unwrap();
    let l = bounder.lipschitz_bound(&b, 0).value;
    let sampled = bounder.sample_gradient(&b, 8);
    assert!(l >= bounder.gradient_norm_at_least(sampled.point));
    assert!(l < 20.0, "L = {l}");
    // G, on a ray across both balls: finite, and never below a sampled |g′|.
    let s = Segment::new(DVec3::new(-1.0, 0.3, 0.2), DVec3::X, 0.0, 2.0).unwrap();
    let g = bounder.grad_lipschitz_bound(&s, 0).value;
    assert!(g.is_finite() && g < 1000.0, "G = {g}");
    let mut rng = Rng::new(7);
    let tape = f.tape(&[Output::G]);
    let mut eval = Evaluator::<f64>::new(&tape);
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        let t = 2.0 * rng.point([0.0; 3], [1.0; 3])[0];
        let h = 1e-6;
        let at = |e: &mut Evaluator<f64>, t: f64| e.eval(&[t - 1.0, 0.3, 0.2, 1.0, 0.0, 0.0])[0];
        let slope = (at(&mut eval, t + h) - at(&mut eval, t - h)) / (2.0 * h);
        worst = worst.max(slope.abs());
    }
    assert!(g >= 0.99 * worst, "G = {g} below a sampled |g′| of {worst}");
}

#[test]
fn paper_sphere_grad_lipschitz_two_d_squared_is_proved() {
    // g′ = dᵀHd = 2|d|² for every sphere, on every segment.
    let f = sphere(DVec3::new(3.0, -2.0, 5.0), 2.0);
    let bounder = Bounder::new(&f);
    let d = DVec3::new(1.0, 2.0, 2.0); // |d|² = 9, so 2|d|² = 18 exactly
    let s = Segment::new(DVec3::new(-4.0, 1.0, 0.5), d, 0.0, 10.0).unwrap();
    let claim = Interval::point(2.0 * d.length_squared());
    assert!(matches!(
        verify_grad_lipschitz(&bounder, &s, claim, 1000),
        Verdict::Proved { .. }
    ));
    // …and it is tight: any smaller claim is refuted with a real witness.
    match verify_grad_lipschitz(&bounder, &s, Interval::point(17.9), 1000) {
        Verdict::Refuted { value, .. } => assert!(value > 17.9),
        other => panic!("expected refutation, got {other:?}"),
    }
}

#[test]
fn paper_sphere_lipschitz_with_its_centre_is_proved() {
    // L = 2·max over the box of |p − c|, which with the centre is correct.
    let c = DVec3::new(3.0, -2.0, 5.0);
    let f = sphere(c, 2.0);
    let b = Aabb::new(
        c + DVec3::new(-1.0, -2.0, -2.0),
        c + DVec3::new(1.0, 2.0, 2.0),
    )
    .unwrap();
    let farthest = (b.lo - c).abs().max((b.hi - c).abs());
    let l = 2.0 * farthest.length(); // 2·|(1,2,2)| = 6 exactly
    assert_eq!(l, 6.0);
    let verdict = verify_lipschitz(&Bounder::new(&f), &b, Interval::point(l), 100_000);
    assert!(matches!(verdict, Verdict::Proved { .. }), "{verdict:?}");
}

#[test]
fn paper_sphere_lipschitz_with_one_for_the_centre_is_refuted() {
    // The reference paper's code computes the sphere's L with the constant 1
    // where the centre belongs: L = 2·max |p − (1,1,1)|. For a sphere centred
    // far from (1,1,1) that is far too small.
    let c = DVec3::new(1.0, 1.0, 11.0);
    let f = sphere(c, 10.0); // passes through (1, 1, 1)
    let b = Aabb::new(DVec3::splat(0.0), DVec3::splat(2.0)).unwrap();
    let one = DVec3::ONE;
    let paper_l = 2.0 * (b.lo - one).abs().max((b.hi - one).abs()).length();
    let bounder = Bounder::new(&f);
    match verify_lipschitz(&bounder, &b, Interval::point(paper_l), 100_000) {
        Verdict::Refuted { witness, value, .. } => {
            assert!(value > paper_l);
            // The witness is real: the gradient there, 2(p − c), is longer than L.
            let true_norm = 2.0 * (witness - c).length();
            assert!(true_norm > paper_l, "{true_norm} vs {paper_l}");
            assert!(b.lo.cmple(witness).all() && witness.cmple(b.hi).all());
        }
        other => panic!("expected refutation, got {other:?}"),
    }
}

#[test]
fn unbounded_derivatives_are_reported_infinite_with_a_reason() {
    let unit = Aabb::new(DVec3::ZERO, DVec3::ONE).unwrap();
    let centred = Aabb::new(DVec3::splat(-1.0), DVec3::ONE).unwrap();
    for (src, b, axis) in [
        ("sqrt(x) + y", unit, "∂f/∂x"),
        ("1/x + y", centred, "∂f/∂x"),
        ("ln(y) + x", unit, "∂f/∂y"),
        ("sqrt(abs(z))", centred, "∂f/∂z"),
        ("(x^2 + y^2)^0.25", centred, "∂f/∂x"),
    ] {
        let l = Bounder::new(&Formula::parse(src).unwrap()).lipschitz_bound(&b, 2);
        assert_eq!(l.value, f64::INFINITY, "{src}");
        assert_eq!(
            l.note.as_deref(),
            Some(format!("{axis} is unbounded on this box").as_str()),
            "{src}"
        );
    }
    // Away from the singular point the same formulas have finite bounds.
    let away = Aabb::new(DVec3::splat(0.5), DVec3::ONE).unwrap();
    for src in ["sqrt(x) + y", "1/x + y", "ln(y) + x"] {
        let l = Bounder::new(&Formula::parse(src).unwrap()).lipschitz_bound(&away, 0);
        assert!(l.is_finite() && l.note.is_none(), "{src}: {l:?}");
    }
}

#[test]
fn a_ray_across_a_crease_has_infinite_g() {
    let bounder = Bounder::new(&Formula::parse("abs(x) + y^2 - 1").unwrap());
    let across = Segment::new(DVec3::new(-1.0, 0.0, 0.0), DVec3::X, 0.0, 2.0).unwrap();
    let g = bounder.grad_lipschitz_bound(&across, 3);
    assert_eq!(g.value, f64::INFINITY);
    assert!(g.note.unwrap().contains("unbounded"));
    let beside = Segment::new(DVec3::new(0.5, -1.0, 0.0), DVec3::Y, 0.0, 2.0).unwrap();
    assert_eq!(bounder.grad_lipschitz_bound(&beside, 0).value, 2.0);
}

#[test]
fn verify_proves_true_and_refutes_false_constants_on_the_corpus() {
    for s in corpus() {
        let f = Formula::parse(&s.expr).unwrap();
        let bounder = Bounder::new(&f);
        let b = Aabb::new(DVec3::from(s.lo), DVec3::from(s.hi)).unwrap();
        // True: the bound of the 64 sub-boxes is a valid constant; bisection
        // reaches those sub-boxes, so it proves it.
        let l2 = bounder.lipschitz_bound(&b, 2);
        assert!(l2.is_finite(), "{}", s.name);
        let verdict = verify_lipschitz(&bounder, &b, Interval::point(l2.value), 10_000);
        assert!(
            matches!(verdict, Verdict::Proved { .. }),
            "{}: {verdict:?}",
            s.name
        );
        // False: 90% of a sampled maximum is refuted, with a real witness.
        let sampled = bounder.sample_gradient(&b, 8);
        let claim = 0.9 * sampled.value;
        match verify_lipschitz(&bounder, &b, Interval::point(claim), 10_000) {
            Verdict::Refuted { witness, value, .. } => {
                assert!(value > claim);
                let tape = f.tape(&[Output::Dfdx, Output::Dfdy, Output::Dfdz]);
                let g = Evaluator::<f64>::new(&tape)
                    .eval(&[witness.x, witness.y, witness.z, 0.0, 0.0, 0.0])
                    .to_vec();
                let norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                assert!(
                    norm > claim,
                    "{}: witness {witness} has |grad f| = {norm} <= {claim}",
                    s.name
                );
            }
            other => panic!("{}: expected refutation, got {other:?}", s.name),
        }
    }
}

#[test]
fn the_centred_form_is_not_fooled_by_a_jump_of_the_gradient() {
    // Regression: ∇f = (choose(atan2(z, z), 1, 0), 0, 0) jumps across z = 0,
    // but its derivative simplifies to 0, so the Hessian was a continuous 0
    // and the centred form gave ∇f at the centre alone: L = 0 where
    // |∇f| = 1 below the plane.
    let f = Formula::parse("choose(atan2(z, z), x, 0)").unwrap();
    let b = Aabb::new(
        DVec3::new(-0.001, -0.001, -0.3),
        DVec3::new(0.001, 0.001, 0.9),
    )
    .unwrap();
    let bounder = Bounder::new(&f);
    let below = DVec3::new(0.0005, 0.0, -0.26);
    assert!(bounder.gradient_norm_at_least(below) >= 1.0);
    for m in Method::ALL {
        let l = bounder.lipschitz_bound_by(&b, 0, m).value;
        assert!(l >= 1.0, "{}: L = {l}", m.name());
    }
}

#[test]
fn splitting_never_loosens_a_bound() {
    // Inclusion isotonicity: the natural extension over a sub-box is inside
    // the one over the box. Other methods are at most it at every depth
    // (their own roundings may differ by ulps between depths).
    for s in corpus() {
        let bounder = Bounder::new(&Formula::parse(&s.expr).unwrap());
        let b = Aabb::new(DVec3::from(s.lo), DVec3::from(s.hi)).unwrap();
        let by = |m: Method| -> Vec<f64> {
            (0..3)
                .map(|d| bounder.lipschitz_bound_by(&b, d, m).value)
                .collect()
        };
        let natural = by(Method::Natural);
        assert!(
            natural[1] <= natural[0] && natural[2] <= natural[1],
            "{}: {natural:?}",
            s.name
        );
        let sampled = bounder.sample_gradient(&b, 8).value;
        for m in Method::ALL {
            let l = by(m);
            for d in 0..3 {
                assert!(l[d] <= natural[d], "{} {}: {l:?}", s.name, m.name());
                assert!(
                    l[d] >= sampled,
                    "{} {}: {l:?} < {sampled}",
                    s.name,
                    m.name()
                );
            }
        }
    }
}

#[test]
fn sampled_points_stay_inside_the_box() {
    // Regression: the sample grid's far corner lo + 1·(hi − lo) rounded past
    // hi, so the "sampled maximum" of 1/x came from outside the box and
    // exceeded the sound L computed over the box.
    let f = Formula::parse("choose(y, x, (x)^-1)").unwrap();
    let b = Aabb::new(
        DVec3::new(-1.6982711374207895, 0.6775014171004129, -0.001),
        DVec3::new(-0.14119069072972235, 0.6795014171004129, 0.001),
    )
    .unwrap();
    let bounder = Bounder::new(&f);
    let s = bounder.sample_gradient(&b, 24);
    assert!(
        b.lo.cmple(s.point).all() && s.point.cmple(b.hi).all(),
        "{} is outside {b:?}",
        s.point
    );
    assert!(bounder.lipschitz_bound(&b, 0).value >= s.value);
    let seg = Segment::new(
        DVec3::new(0.1, 0.2, 0.3),
        DVec3::new(0.7, -0.3, 0.1),
        -0.1,
        0.7,
    )
    .unwrap();
    let (_, t) = bounder.sample_dg(&seg, 1025);
    assert!((-0.1..=0.7).contains(&t));
}

#[test]
fn division_by_exact_zero_has_no_value_at_points_either() {
    // 1/[0,0] is empty, but at points 1/0 was ∞, and choose(∞, x, y) was y:
    // a finite value the interval claimed did not exist. A quotient by 0
    // is NaN at points now; ln(0) = -∞ stays a value (its limit).
    let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    let p = [0.5, -0.25, 0.0, 0.0, 0.0, 0.0];
    let f = Formula::parse("choose((0)^-1, x, y) + choose(1/(0*x), x, y)").unwrap();
    let tape = f.tape(&[Output::F]);
    assert!(over_box(&tape, &b, DVec3::X)[0].is_empty());
    assert!(Evaluator::<f64>::new(&tape).eval(&p)[0].is_nan());
    let g = Formula::parse("choose(ln(0*x), 2, 3) + y").unwrap();
    let tape = g.tape(&[Output::F]);
    let at = Evaluator::<f64>::new(&tape).eval(&p)[0];
    assert_eq!(at, -0.25 + 2.0);
    assert!(over_box(&tape, &b, DVec3::X)[0].contains(at));
}

#[test]
fn pow_of_an_undefined_operand_is_undefined_at_points() {
    // Regression: powf(1, NaN) = 1 in IEEE arithmetic, so pow(1, pow(x, x))
    // had a value at x < 0 where its interval (rightly) had none.
    let f = Formula::parse("pow(x^0, pow(x, x)) + pow(pow(x, 0.5), 0*y)").unwrap();
    let v = Evaluator::<f64>::new(&f.tape(&[Output::F])).eval(&[-1.5, 0.0, 0.0, 0.0, 0.0, 0.0])[0];
    assert!(v.is_nan());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// The rounding bound of the f64 evaluation holds at every sampled point:
    /// the exact value (inside the point's interval enclosure) is within `err`
    /// of what the f64 evaluator computed.
    #[test]
    fn rounding_bounds_cover_the_f64_error(src in formula(), b in region(), seed in any::<u64>()) {
        use lgc::expr::RoundingBound;
        let f = Formula::parse(&src).unwrap();
        let tape = f.tape(&[Output::F, Output::G]);
        let mut rng = Rng::new(seed);
        let d = DVec3::from(rng.direction());
        let [x, y, z] = b.intervals().map(RoundingBound::exact);
        let unit = RoundingBound::exact(Interval::UNIT);
        let bound = Evaluator::<RoundingBound>::new(&tape).eval(&[x, y, z, unit, unit, unit]).to_vec();
        let mut point_eval = Evaluator::<f64>::new(&tape);
        for _ in 0..16 {
            let p = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
            let exact = over_box(&tape, &Aabb { lo: p, hi: p }, d);
            let computed = point_eval.eval(&[p.x, p.y, p.z, d.x, d.y, d.z]).to_vec();
            for k in 0..2 {
                let (v, e) = (computed[k], bound[k].err);
                if !v.is_finite() || !e.is_finite() || exact[k].is_empty() {
                    continue;
                }
                let reach = Interval::new(v - e - e * 1e-12, v + e + e * 1e-12);
                prop_assert!(!reach.intersection(exact[k]).is_empty(),
                    "{src}: output {k} = {v} at {p}, error bound {e}, exact value in {:?}", exact[k]);
            }
        }
    }
}

/// Where ∇f is undefined inside the box but f is Lipschitz (the axis of a
/// cone, the centre of a ball), L comes from the slopes carried through f's
/// operations: finite, and a true Lipschitz constant of f, checked against
/// pairs of sampled points.
#[test]
fn a_norms_centre_gets_a_finite_lipschitz_bound_from_its_slopes() {
    let centred = Aabb::new(DVec3::splat(-0.5), DVec3::splat(0.5)).unwrap();
    let mut rng = Rng::new(0x0051_09e5);
    for src in [
        "sqrt(x^2+y^2)-1",
        "sqrt(x^2+y^2+z^2)",
        "sqrt((x-0.2)^2+y^2)+0.5*z",
        "abs(sqrt(x^2+z^2)-0.3)",
        "min(sqrt(x^2+y^2), sqrt(y^2+z^2)+0.1)",
    ] {
        let f = Formula::parse(src).unwrap();
        let l = Bounder::new(&f).lipschitz_bound(&centred, 0);
        assert!(l.value.is_finite(), "{src}: {l:?}");
        assert!(
            l.note.as_deref().is_some_and(|n| n.contains("slopes")),
            "{src}: {l:?}"
        );
        let tape = f.tape(&[Output::F]);
        let mut e = Evaluator::<f64>::new(&tape);
        let mut at = |p: [f64; 3]| e.eval(&[p[0], p[1], p[2], 0.0, 0.0, 0.0])[0];
        for k in 0..2_000 {
            let p = rng.point(centred.lo.into(), centred.hi.into());
            // Half the pairs close together, where a slope shows most.
            let q = if k % 2 == 0 {
                rng.point(centred.lo.into(), centred.hi.into())
            } else {
                let r = rng.uniform(0.0, 1e-3);
                let d = rng.direction();
                std::array::from_fn(|i| (p[i] + r * d[i]).clamp(-0.5, 0.5))
            };
            let (fp, fq) = (at(p), at(q));
            let dist = DVec3::from(p).distance(DVec3::from(q));
            assert!(
                (fp - fq).abs() <= l.value * dist * (1.0 + 1e-12) + 1e-15,
                "{src}: |f({p:?}) - f({q:?})| = {} > L·{dist}",
                (fp - fq).abs()
            );
        }
    }
}
