//! Polynomial formulas along rays: the jets' coefficients enclose F, and
//! rays answered in Bernstein form agree with the octree search, each hit an
//! enclosed sign change.

use crate::common::{agree, corpus, rays, Rng};
use glam::DVec3;
use lgc::expr::along::AlongLine;
use lgc::ray::octree::BuildOptions;
use lgc::ray::{Answer, Intersector};
use lgc::{Aabb, Evaluator, Formula, Interval, Output};

fn compiled(src: &str) -> Option<AlongLine> {
    AlongLine::compile(&Formula::parse(src).unwrap().tape(&[Output::F]))
}

#[test]
fn only_polynomials_of_bounded_degree_compile() {
    for (src, degree) in [
        ("x^2 + y^2 + z^2 - 1", 2),
        ("(x^2 + y^2 + z^2 + 0.7975)^2 - 4*(x^2 + y^2)", 4),
        ("x*y*z/3 - sqrt(2)", 3),
        ("(x - y)^7 + z", 7),
        ("(x + y)^6 - z^3", 6),
        ("z + 0.5", 1),
    ] {
        let p = compiled(src).unwrap_or_else(|| panic!("{src}"));
        assert_eq!(p.degree(), degree, "{src}");
    }
    for src in [
        "x^9 - 1",
        "(x^2 + y^2)^5",
        "sqrt(x^2 + y^2) - 1",
        "max(x, y)",
        "x/y",
        "x/sqrt(2)",
        "sin(x) + y",
        "abs(x) - 1",
        "x^-2 - 1",
    ] {
        assert!(compiled(src).is_none(), "{src}");
    }
}

/// F's enclosure at `t` on the ray, from intervals around the point: the
/// reference, independent of the jets and of both searches.
fn enclosure(f: &Formula, o: DVec3, d: DVec3, t: f64) -> Interval {
    let tape = f.tape(&[Output::F]);
    let mut eval = Evaluator::<Interval>::new(&tape);
    let p = |i: usize| Interval::point(o[i]) + Interval::point(t) * Interval::point(d[i]);
    let zero = Interval::point(0.0);
    eval.eval(&[p(0), p(1), p(2), zero, zero, zero])[0]
}

const POLYNOMIALS: [&str; 5] = [
    "(x^2 + y^2 + z^2 + 0.7975)^2 - 4*(x^2 + y^2)",
    "(x + y - z)^6 - 0.3*(x - y)^5 + z^3",
    "x*y*z/3 - sqrt(2)*x^3 + 1e-3",
    "(x - 2*y)^5 + (z + 0.1)^3 - y/7",
    "16*x^4 - 16*x^2 + 2 + 16*y^4 - 16*y^2 + 16*z^4 - 16*z^2",
];

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(500))]
    #[test]
    fn the_coefficients_enclose_the_formula_along_rays(
        which in 0usize..POLYNOMIALS.len(),
        o in proptest::array::uniform3(-3.0f64..3.0),
        d in proptest::array::uniform3(-1.0f64..1.0),
        t0 in -2.0f64..2.0,
        dt in -1.5f64..1.5,
    ) {
        let (o, d) = (DVec3::from(o), DVec3::from(d));
        let t = t0 + dt;
        // s = t − t0 recovered exactly, so the jets' F(t0 + s) is F(t).
        let s = t - t0;
        proptest::prop_assume!(t0 + s == t);
        let src = POLYNOMIALS[which];
        let poly = compiled(src).unwrap();
        let mut regs = poly.registers();
        let c = poly.coefficients(&mut regs, (o, d), t0, s.abs());
        let (mut v, mut size) = (0.0f64, 0.0f64);
        for k in (0..=poly.degree()).rev() {
            v = v * s + c.c[k];
            size = size * s.abs() + c.c[k].abs();
        }
        // Horner's roundings, generously.
        let err = c.error + 1e-15 * (poly.degree() as f64 + 1.0) * size;
        let e = enclosure(&Formula::parse(src).unwrap(), o, d, t);
        // The real F(t) is in both: they meet.
        proptest::prop_assert!(
            v - err <= e.sup() && v + err >= e.inf(),
            "{}: F({}) in [{}, {}], jets {} ± {}", src, t, e.inf(), e.sup(), v, err
        );
        // And the jets' bound is tight enough to use: some thousands of
        // roundings of the coefficients' size, or of 1.
        proptest::prop_assert!(
            c.error < 1e-12 * (1.0 + c.size),
            "{}: bound {} of {}", src, c.error, c.size
        );
    }
}

/// F's certified sign at `t` on the ray (0 where the enclosure holds 0).
fn enclosed_sign(f: &Formula, o: DVec3, d: DVec3, t: f64) -> i8 {
    let v = enclosure(f, o, d, t);
    if v.inf() > 0.0 {
        1
    } else if v.sup() < 0.0 {
        -1
    } else {
        0
    }
}

#[test]
fn rays_answered_in_bernstein_form_agree_with_the_search_and_enclose_their_roots() {
    // Every corpus surface that is a polynomial of degree 3 to 8, with rays
    // at random, rays through surface points pushed off by 1e-6 to 1e-12
    // (nearly tangent ones among them), and rays leaving the surface (as
    // shadow and reflected rays do).
    let mut rng = Rng::new(0xbe75);
    let mut surfaces = 0;
    for s in corpus() {
        let f = Formula::parse(&s.expr).unwrap();
        let degree = compiled(&s.expr).map(|p| p.degree());
        if !degree.is_some_and(|n| (3..=8).contains(&n)) {
            continue;
        }
        surfaces += 1;
        let b = Aabb::new(DVec3::from(s.lo), DVec3::from(s.hi)).unwrap();
        let closed = Intersector::new(&f, &b, 5);
        let searched = BuildOptions {
            polynomial_form: false,
            ..BuildOptions::to_depth(5)
        };
        let searched = Intersector::with_options(&f, &b, &searched);
        let (mut c, mut w) = (closed.tracer(), searched.tracer());
        assert!(c.closed_form() && !w.closed_form(), "{}", s.name);
        let tol = 1e-10 * (b.hi - b.lo).length();
        let mut hits = 0;
        let mut cases = rays(&mut rng, &f)
            .into_iter()
            .map(|(o, d)| (o, d, 0.0))
            .collect::<Vec<_>>();
        // From the hits of some, leaving the surface in random directions.
        for k in 0..200 {
            let (o, d, _) = cases[k];
            if let Answer::Hit(t) = w.answer(o, d, 0.0, f64::INFINITY) {
                cases.push((o + t * d, DVec3::from(rng.direction()), 1e-7));
            }
        }
        for &(o, d, t_min) in &cases {
            let (a, b) = (
                c.answer(o, d, t_min, f64::INFINITY),
                w.answer(o, d, t_min, f64::INFINITY),
            );
            let tol_t = tol / d.length();
            assert!(
                agree(a, b, tol_t),
                "{}: ray {o} + t·{d} from {t_min}: Bernstein {a:?}, search {b:?}",
                s.name
            );
            if let Answer::Hit(t) = a {
                let (s0, s1) = (
                    enclosed_sign(&f, o, d, t - tol_t),
                    enclosed_sign(&f, o, d, t + tol_t),
                );
                assert!(
                    s0 * s1 == -1,
                    "{}: {o} + t·{d} hit at {t}: signs {s0} and {s1} a tolerance either side",
                    s.name
                );
                hits += 1;
            }
        }
        // Not vacuous: many hits, and most rays answered in the form (half
        // of them pass within 1e-6 of the surface; sextics' singular points
        // and larger roundings leave more to the search).
        assert!(hits > 100, "{}: {hits} hits", s.name);
        let answered = c.stats.closed_form as f64 / c.stats.rays as f64;
        let least = if degree <= Some(4) { 0.8 } else { 0.5 };
        assert!(
            answered > least,
            "{}: {:.3} of rays in Bernstein form",
            s.name,
            answered
        );
    }
    assert!(surfaces >= 8, "{surfaces} polynomial surfaces");
}

#[test]
fn bernstein_roots_do_not_crawl_once_an_iterate_is_the_f64_zero() {
    // The root search once fell back to halving whenever its step landed on
    // the bracket's end, which happens as soon as an iterate is F's f64 zero:
    // 14 % of a torus scene's hits took 15 to 30 halvings. A hit now takes
    // the jets, a few steps and the certificate's two values: about 7.5.
    let f = Formula::parse("(x^2 + y^2 + z^2 + 0.7975)^2 - 4*(x^2 + y^2)").unwrap();
    let b = Aabb::new(DVec3::new(-1.5, -1.5, -0.5), DVec3::new(1.5, 1.5, 0.5)).unwrap();
    let closed = Intersector::new(&f, &b, 5);
    let mut tracer = closed.tracer();
    let mut rng = Rng::new(0x7043);
    let eye = DVec3::new(3.2, -4.2, 2.8);
    let (mut hits, mut most, mut total) = (0, 0, 0);
    for _ in 0..4000 {
        let target = DVec3::from(rng.point([-1.5, -1.5, -0.5], [1.5, 1.5, 0.5]));
        let (evals, answered) = (tracer.stats.f_evals, tracer.stats.closed_form);
        let answer = tracer.answer(eye, target - eye, 0.0, f64::INFINITY);
        if matches!(answer, Answer::Hit(_)) && tracer.stats.closed_form > answered {
            let taken = tracer.stats.f_evals - evals;
            most = most.max(taken);
            total += taken;
            hits += 1;
        }
    }
    assert!(hits > 1000, "{hits} hits in Bernstein form");
    let mean = total as f64 / hits as f64;
    assert!(mean <= 9.0, "{mean:.2} evaluations a hit");
    assert!(most <= 24, "a hit took {most} evaluations");
}
