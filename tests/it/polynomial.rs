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
fn enclosure(f: &Formula, o: DVec3, d: DVec3, t: Interval) -> Interval {
    let tape = f.tape(&[Output::F]);
    let mut eval = Evaluator::<Interval>::new(&tape);
    let p = |i: usize| Interval::point(o[i]) + t * Interval::point(d[i]);
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

/// Whether the jets of `src` on the ray `o + t·d` about `t0`, over `h`,
/// enclose F at `t0 + h·u` (`|u| ≤ 1`), with a bound some thousands of
/// roundings of the coefficients' size, or of the smallest normal f64.
fn jets_enclose(
    src: &str,
    (o, d): (DVec3, DVec3),
    (t0, h, u): (f64, f64, f64),
) -> Result<(), String> {
    let poly = compiled(src).unwrap();
    let mut regs = poly.registers();
    let c = poly.coefficients(&mut regs, (o, d), t0, h);
    let (mut v, mut size) = (0.0f64, 0.0f64);
    for k in (0..=poly.degree()).rev() {
        v = v * u + c.c[k];
        size = size * u.abs() + c.c[k].abs();
    }
    // Horner's roundings, generously.
    let err = c.error + 1e-15 * (poly.degree() as f64 + 1.0) * size + f64::MIN_POSITIVE;
    let t = Interval::point(t0) + Interval::point(h) * Interval::point(u);
    let e = enclosure(&Formula::parse(src).unwrap(), o, d, t);
    // The real F(t0 + h·u) is in both: they meet.
    let meet = v - err <= e.sup() && v + err >= e.inf();
    if !meet {
        return Err(format!(
            "{src}: F({t0} + {h}·{u}) in [{}, {}], jets {v} ± {err}",
            e.inf(),
            e.sup()
        ));
    }
    let tight = c.error < 1e-12 * c.size + 1e-290;
    if !tight {
        return Err(format!("{src}: bound {} of {}", c.error, c.size));
    }
    Ok(())
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(500))]
    #[test]
    fn the_coefficients_enclose_the_formula_along_rays(
        which in 0usize..POLYNOMIALS.len(),
        o in proptest::array::uniform3(-3.0f64..3.0),
        d in proptest::array::uniform3(-1.0f64..1.0),
        t0 in -2.0f64..2.0,
        h in 0.0f64..1.5,
        u in -1.0f64..1.0,
    ) {
        let ray = (DVec3::from(o), DVec3::from(d));
        let checked = jets_enclose(POLYNOMIALS[which], ray, (t0, h, u));
        proptest::prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
    }

    #[test]
    fn jets_keep_coefficients_that_underflow_in_the_ray_parameter(
        which in 0usize..POLYNOMIALS.len(),
        o in proptest::array::uniform3(-3.0f64..3.0),
        d in proptest::array::uniform3(-1.0f64..1.0),
        t0 in -2.0f64..2.0,
        h in 0.0f64..1.5,
        u in -1.0f64..1.0,
        k in 40i32..150,
    ) {
        // F = 10⁻²⁰⁰·P(10⁻¹⁰⁰·p) on a ray 10ᵏ times longer in t than the
        // same ray of P: F's coefficients in t (10⁻²⁰⁰⁻ᵏⁱ) underflow, its
        // coefficients in the range's unit parameter (10⁻²⁰⁰) do not.
        let stretch = 10f64.powi(k);
        let ray = (DVec3::from(o) * 1e100, DVec3::from(d) * 1e100 / stretch);
        let scaled = POLYNOMIALS[which]
            .replace('x', "(x*1e-100)")
            .replace('y', "(y*1e-100)")
            .replace('z', "(z*1e-100)");
        let src = format!("1e-200*({scaled})");
        let checked = jets_enclose(&src, ray, (t0 * stretch, h * stretch, u));
        proptest::prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
    }
}

/// F's certified sign at `t` on the ray (0 where the enclosure holds 0).
fn enclosed_sign(f: &Formula, o: DVec3, d: DVec3, t: f64) -> i8 {
    let v = enclosure(f, o, d, Interval::point(t));
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
