use super::*;
use std::f64::consts::FRAC_PI_2;

fn iv(lo: f64, hi: f64) -> Interval {
    Interval::new(lo, hi)
}

/// Values over the whole f64 range, with the awkward ones often.
fn any_value() -> impl proptest::strategy::Strategy<Value = f64> {
    use proptest::prelude::*;
    prop_oneof![
        Just(0.0),
        Just(-0.0),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(f64::MAX),
        Just(f64::MIN_POSITIVE),
        -4.0..4.0f64,
        (-1.0..1.0f64, -1074..1024i32).prop_map(|(m, e)| m * 2f64.powi(e)),
        proptest::num::f64::NORMAL | proptest::num::f64::SUBNORMAL,
    ]
}

/// The sign of `a/b − q`, exactly, from the residual `q·b − a` scaled by
/// 2¹⁰⁰⁰ so that it cannot underflow (for the numerators below 2⁻¹⁰⁰ and
/// divisors below 1 used here, nothing overflows).
fn quotient_error_sign(a: f64, b: f64, q: f64) -> f64 {
    let scale = 2f64.powi(1000);
    let r = (q * scale).mul_add(b, -(a * scale));
    -r.signum() * b.signum() * f64::from(r != 0.0)
}

/// A quotient whose numerator is so small that the residual `q·b − a`
/// underflows lost the sign of its error, and with it the step outward:
/// 2.2250738585072014e-308 / −1.522777869042796e-18 rounded "down" to a
/// value above the exact quotient.
#[test]
fn quotient_of_a_tiny_numerator_rounds_outward() {
    let cases = [
        (2.225_073_858_507_201_4e-308, -1.522_777_869_042_796e-18),
        (3.0e-300, 7.0e-15),
        (-5.0e-305, 3.3e-17),
        (f64::MIN_POSITIVE, 1e-20),
    ];
    for (a, b) in cases {
        let q = a / b;
        assert!(q.abs() >= TINY, "{a:e} / {b:e} is meant to be above TINY");
        let down = div_down_stepped(a, b);
        let up = div_up_stepped(a, b);
        // down ≤ a/b ≤ up: each end's error from the exact quotient has
        // the right sign (or is 0).
        assert!(
            quotient_error_sign(a, b, down) >= 0.0,
            "{a:e}/{b:e} down {down:e}"
        );
        assert!(
            quotient_error_sign(a, b, up) <= 0.0,
            "{a:e}/{b:e} up {up:e}"
        );
        assert!(down <= q && q <= up);
    }
}

/// The product by its definition: the hull of the four directed
/// products of the ends, each rounded with an FMA residual.
fn four_products(a: Interval, b: Interval) -> Interval {
    let down = |x: f64, y: f64| {
        if x == 0.0 || y == 0.0 {
            return 0.0;
        }
        let p = x * y;
        if !p.is_finite() {
            return overflow_down(p, x.is_finite() && y.is_finite());
        }
        if p.abs() < TINY {
            return p.next_down();
        }
        lower(p, x.mul_add(y, -p))
    };
    let up = |x: f64, y: f64| -down(-x, y);
    let ends = [(a.lo, b.lo), (a.lo, b.hi), (a.hi, b.lo), (a.hi, b.hi)];
    Interval {
        lo: ends
            .iter()
            .map(|&(x, y)| down(x, y))
            .fold(f64::INFINITY, f64::min),
        hi: ends
            .iter()
            .map(|&(x, y)| up(x, y))
            .fold(f64::NEG_INFINITY, f64::max),
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]

    /// Dekker's split product has the FMA's exact residual wherever it
    /// is used (and the FMA's own elsewhere), and so has the residual by
    /// the CPU's FMA where it is taken.
    #[test]
    fn dekker_residual_is_the_fma_residual(a in any_value(), b in any_value()) {
        let p = a * b;
        if p.is_finite() && p.abs() >= TINY {
            let exact = a.mul_add(b, -p).to_bits();
            let r = two_prod_err_by_halves(a, b, p);
            proptest::prop_assert_eq!(r.to_bits(), exact, "{} * {}", a, b);
            let r = two_prod_err(a, b, p);
            proptest::prop_assert_eq!(r.to_bits(), exact, "{} * {} (dispatched)", a, b);
            proptest::prop_assert_eq!(fused(a, b, -p).to_bits(), exact);
        }
    }

    /// Where the CPU rounds in a chosen direction, each directed operation
    /// it rounds is the one stepped from the nearest result, bit for bit,
    /// wherever the dispatch takes it (a plain result), and the dispatched
    /// operation is the stepped one everywhere: the interval code's
    /// results do not depend on the CPU.
    #[test]
    fn directed_roundings_by_the_cpu_are_the_stepped_ones(a in any_value(), b in any_value()) {
        use crate::types::rounding as r;
        type Binary = (fn(f64, f64) -> f64, fn(f64, f64) -> f64, &'static str);
        let binary: [Binary; 6] = [
            (r::add_down, r::add_down_stepped, "add_down"),
            (r::add_up, r::add_up_stepped, "add_up"),
            (r::mul_down, r::mul_down_stepped, "mul_down"),
            (r::mul_up, r::mul_up_stepped, "mul_up"),
            (r::div_down, r::div_down_stepped, "div_down"),
            (r::div_up, r::div_up_stepped, "div_up"),
        ];
        for (dispatched, stepped, name) in binary {
            let (d, s) = (dispatched(a, b), stepped(a, b));
            proptest::prop_assert!(
                d.to_bits() == s.to_bits() || (d.is_nan() && s.is_nan()),
                "{}({:e}, {:e}): {:e} against {:e}", name, a, b, d, s
            );
        }
        type Unary = (fn(f64) -> f64, fn(f64) -> f64, &'static str);
        let unary: [Unary; 2] = [
            (r::sqrt_down, r::sqrt_down_stepped, "sqrt_down"),
            (r::sqrt_up, r::sqrt_up_stepped, "sqrt_up"),
        ];
        for (dispatched, stepped, name) in unary {
            let (d, s) = (dispatched(a), stepped(a));
            proptest::prop_assert!(
                d.to_bits() == s.to_bits() || (d.is_nan() && s.is_nan()),
                "{}({:e}): {:e} against {:e}", name, a, d, s
            );
        }
        #[cfg(target_arch = "x86_64")]
        if r::has_directed() {
            // The CPU's own results, before the dispatch's filter: equal
            // to the stepped ones wherever they are plain.
            for (cpu, stepped, name) in r::cpu_binary() {
                let (c, s) = (cpu(a, b), stepped(a, b));
                if r::plain(c) && !(name.starts_with("div") && a.abs() < TINY) {
                    proptest::prop_assert_eq!(c.to_bits(), s.to_bits(), "{}({:e}, {:e})", name, a, b);
                }
            }
        }
    }

    /// A product by a signed number is the product by its point
    /// interval, bit for bit, in either order, for every interval
    /// (unbounded, zero, empty or straddling 0).
    #[test]
    fn a_product_by_a_signed_number_is_the_product_by_its_point(
        a in any_value(), b in any_value(), c in any_value(), empty in 0u8..8
    ) {
        // Only finite non-zero numbers are asked for (zeros and ±∞ as
        // the other factor's ends).
        let c = if c.is_finite() && c != 0.0 { c } else { -f64::MIN_POSITIVE };
        let x = if empty == 0 { Interval::EMPTY } else { iv(a.min(b), a.max(b)) };
        let fast = x.mul_by_signed(c, c > 0.0);
        let bits = |v: Interval| (v.lo.to_bits(), v.hi.to_bits());
        let same = |v: Interval| bits(v) == bits(fast) || (v.is_empty() && fast.is_empty());
        proptest::prop_assert!(same(x * Interval::point(c)), "{x:?} · {c}: {fast:?}");
        proptest::prop_assert!(same(Interval::point(c) * x), "{c} · {x:?}: {fast:?}");
    }

    /// The widened product holds the exact one and is at most an ulp
    /// looser at each end.
    #[test]
    fn ulps_steps_taken_at_once_are_the_steps_one_by_one(v in any_value(), n in 0u32..6) {
        let (mut down, mut up) = (v, v);
        for _ in 0..n {
            down = down.next_down();
            up = up.next_up();
        }
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        proptest::prop_assert!(same(ulps_down(v, n), down), "{v} down {n}");
        proptest::prop_assert!(same(ulps_up(v, n), up), "{v} up {n}");
    }

    #[test]
    fn norm_bounds_are_the_interval_sums(a in any_value(), b in any_value(), c in any_value()) {
        let m = [a, b, c];
        let (fast, slow) = (norm_sup(m), euclidean_norm(m).sup());
        proptest::prop_assert!(
            fast.to_bits() == slow.to_bits() || (fast.is_nan() && slow.is_nan()),
            "{m:?}: {fast} vs {slow}"
        );
    }

    #[test]
    fn widened_products_hold_the_exact_ones(
        a in -1e6..1e6f64, b in -1e6..1e6f64, c in -1e6..1e6f64, d in -1e6..1e6f64
    ) {
        let x = Interval::new(a.min(b), a.max(b));
        let y = Interval::new(c.min(d), c.max(d));
        let (w, e) = (x.mul_widened(y), x.mul(y));
        proptest::prop_assert!(w.lo <= e.lo && e.hi <= w.hi, "{:?} {:?}", w, e);
        proptest::prop_assert!(w.lo >= e.lo.next_down() && w.hi <= e.hi.next_up(), "{:?} {:?}", w, e);
    }

    /// Choosing ends by sign gives the hull of all four directed
    /// products, infinite and zero ends included.
    #[test]
    fn sign_cases_give_the_four_product_hull(
        a in any_value(), b in any_value(), c in any_value(), d in any_value()
    ) {
        let x = Interval::new(a.min(b), a.max(b));
        let y = Interval::new(c.min(d), c.max(d));
        if x.is_empty() || y.is_empty() {
            proptest::prop_assert!(x.mul(y).is_empty());
            return Ok(());
        }
        let (fast, slow) = (x.mul(y), four_products(x, y));
        // Equal, except that a product underflowing near 0 which the
        // signs show to be no end is not widened across 0.
        let same = |f: f64, s: f64| f == s || (f.abs() < TINY && s.abs() < TINY);
        proptest::prop_assert!(
            slow.lo <= fast.lo && fast.hi <= slow.hi
                && same(fast.lo, slow.lo) && same(fast.hi, slow.hi),
            "{:?} * {:?}: {:?} vs {:?}", x, y, fast, slow
        );
    }
}

#[test]
fn exact_results_stay_exact() {
    assert_eq!(iv(2.0, 2.0).mul(iv(3.0, 3.0)), iv(6.0, 6.0));
    assert_eq!(iv(1.0, 2.0).add(iv(0.5, 0.25 + 0.5)), iv(1.5, 2.75));
    assert_eq!(iv(9.0, 16.0).sqrt(), iv(3.0, 4.0));
    assert_eq!(iv(1.0, 1.0).div(iv(4.0, 4.0)), iv(0.25, 0.25));
}

#[test]
fn inexact_results_enclose_the_real_value() {
    // 0.1 + 0.2 is not 0.30000000000000004 exactly.
    let s = Interval::point(0.1).add(Interval::point(0.2));
    assert!(s.inf() < s.sup());
    assert!(s.inf() <= 0.3 && 0.30000000000000004 <= s.sup());
    let third = Interval::point(1.0).div(Interval::point(3.0));
    assert_eq!(third.sup(), third.inf().next_up());
    let r2 = Interval::point(2.0).sqrt();
    assert!(r2.inf() * r2.inf() < 2.0 || r2.inf().mul_add(r2.inf(), -2.0) < 0.0);
    assert!(r2.sup().mul_add(r2.sup(), -2.0) > 0.0);
}

#[test]
fn even_powers_across_zero() {
    assert_eq!(iv(-1.0, 2.0).powi(2), iv(0.0, 4.0));
    assert_eq!(iv(-3.0, -2.0).powi(2), iv(4.0, 9.0));
    assert_eq!(iv(-1.0, 2.0).powi(3), iv(-1.0, 8.0));
    assert_eq!(iv(-2.0, 1.0).powi(4), iv(0.0, 16.0));
    // x·x loses the dependency: the even power is tighter.
    assert_eq!(iv(-1.0, 2.0).mul(iv(-1.0, 2.0)), iv(-2.0, 4.0));
}

#[test]
fn negative_powers_across_zero_are_unbounded() {
    assert_eq!(iv(-1.0, 1.0).powi(-2), iv(1.0, f64::INFINITY));
    assert_eq!(iv(-1.0, 1.0).powi(-1), Interval::ENTIRE);
    assert_eq!(iv(2.0, 4.0).powi(-1), iv(0.25, 0.5));
}

#[test]
fn division_by_intervals_holding_zero() {
    assert_eq!(Interval::point(1.0).div(iv(-1.0, 1.0)), Interval::ENTIRE);
    assert_eq!(
        Interval::point(1.0).div(iv(0.0, 2.0)),
        iv(0.5, f64::INFINITY)
    );
    assert_eq!(
        iv(-3.0, -1.0).div(iv(0.0, 2.0)),
        iv(f64::NEG_INFINITY, -0.5)
    );
    assert_eq!(iv(1.0, 2.0).div(iv(-2.0, 0.0)), iv(f64::NEG_INFINITY, -0.5));
    // x/0 is NaN at every point: nothing to enclose.
    assert!(Interval::point(-0.0).div(Interval::point(0.0)).is_empty());
    assert!(Interval::point(1.0).div(Interval::point(0.0)).is_empty());
    assert!(iv(-1.0, 1.0).div(Interval::point(-0.0)).is_empty());
    assert!(iv(0.0, 0.0).powi(-3).is_empty());
    assert!(!Interval::point(1.0).div(iv(-1.0, 1.0)).inf().is_nan());
}

/// The quotient's ends picked by sign enclose every sampled quotient
/// and are never looser than the four corners' outward-rounded
/// quotients, for every sign pattern of the dividend and either sign of
/// the divisor.
#[test]
fn quotients_by_intervals_without_zero_enclose_samples_within_the_corners() {
    let ends = [-7.5, -3.0, -1e-3, -0.0, 0.0, 1e-300, 0.1, 2.0, 9.0, 1e300];
    let divisors = [
        (0.5, 3.0),
        (1e-300, 2.0),
        (2.0, 2.0),
        (-3.0, -0.5),
        (-1e300, -1e-3),
    ];
    for (i, &lo) in ends.iter().enumerate() {
        for &hi in &ends[i..] {
            for &(c, d) in &divisors {
                let corners = [(lo, c), (lo, d), (hi, c), (hi, d)];
                let least = corners.map(|(x, y)| div_down(x, y));
                let most = corners.map(|(x, y)| div_up(x, y));
                let least = least.into_iter().fold(f64::INFINITY, f64::min);
                let most = most.into_iter().fold(f64::NEG_INFINITY, f64::max);
                let q = iv(lo, hi).div(iv(c, d));
                let at = format!("[{lo:e}, {hi:e}] / [{c:e}, {d:e}] = {q:?}");
                assert!(q.inf() >= least && q.sup() <= most, "{at}");
                for s in 0..=8 {
                    for t in 0..=8 {
                        let x = lo + (hi - lo) * (s as f64 / 8.0);
                        let y = c + (d - c) * (t as f64 / 8.0);
                        let (x, y) = (x.clamp(lo, hi), y.clamp(c, d));
                        assert!(q.inf() <= x / y && x / y <= q.sup(), "{x:e}/{y:e}: {at}");
                    }
                }
            }
        }
    }
}

#[test]
fn sine_has_exact_extrema() {
    assert_eq!(iv(0.0, 10.0).sin(), Interval::UNIT);
    let s = iv(1.5, 1.6).sin();
    assert_eq!(s.sup(), 1.0, "π/2 is inside");
    assert!(s.inf() <= 1.5f64.sin() && s.inf() > 0.99);
    let t = iv(1.5, 1.57).sin();
    assert!(
        t.sup() < 1.0 && t.sup() >= 1.57f64.sin(),
        "π/2 = 1.5707963… is outside: {t:?}"
    );
    let c = iv(3.0, 3.3).cos();
    assert_eq!(c.inf(), -1.0, "π is inside");
    assert_eq!(iv(-0.1, 0.1).cos().sup(), 1.0);
    let big = iv(1e6, 1e6 + 1.0).sin();
    assert!(
        big.encloses(Interval::point(1e6f64.sin()))
            && big.encloses(Interval::point((1e6f64 + 1.0).sin()))
    );
}

#[test]
fn tangent_across_a_pole_is_the_whole_line() {
    assert_eq!(iv(1.5, 1.6).tan(), Interval::ENTIRE);
    let t = iv(1.5, 1.57).tan();
    assert!(t.is_bounded() && t.sup() >= 1.57f64.tan() && t.inf() <= 1.5f64.tan());
    assert_eq!(iv(-2.0, 2.0).tan(), Interval::ENTIRE);
}

#[test]
fn domain_edges() {
    assert_eq!(iv(-1.0, 4.0).sqrt(), iv(0.0, 2.0));
    assert!(iv(-2.0, -1.0).sqrt().is_empty());
    let l = iv(0.0, 1.0).ln();
    assert_eq!(l.inf(), f64::NEG_INFINITY);
    assert!(l.sup() >= 0.0 && l.sup() < 1e-300);
    assert_eq!(iv(-1.0, 0.0).ln().sup(), f64::MIN, "ln 0 = -inf");
    assert!(iv(-2.0, -1.0).ln().is_empty());
    let a = iv(0.0, 2.0).asin();
    assert!(a.sup() >= FRAC_PI_2 && a.inf() <= 0.0);
    assert!(iv(2.0, 3.0).acos().is_empty());
}

#[test]
fn empty_propagates() {
    let e = Interval::EMPTY;
    assert!(e.add(iv(1.0, 2.0)).is_empty());
    assert!(iv(1.0, 2.0).mul(e).is_empty());
    assert!(e.sin().is_empty());
    assert!(e.min(iv(0.0, 1.0)).is_empty());
}

#[test]
fn sign_and_choose_cover_both_branches_at_a_kink() {
    assert_eq!(iv(-1.0, 1.0).sign(), Interval::UNIT);
    assert_eq!(iv(0.5, 1.0).sign(), Interval::point(1.0));
    assert_eq!(iv(-1.0, 0.0).sign(), iv(-1.0, 0.0));
    let h = Interval::choose(iv(-1.0, 1.0), iv(2.0, 3.0), iv(-5.0, -4.0));
    assert_eq!(h, iv(-5.0, 3.0));
    assert_eq!(iv(-1.0, 1.0).dirac(), iv(0.0, f64::INFINITY));
    assert_eq!(iv(1.0, 2.0).dirac(), iv(0.0, 0.0));
}

#[test]
fn overflow_keeps_a_finite_side() {
    let big = Interval::point(f64::MAX);
    let p = big.mul(Interval::point(2.0));
    assert_eq!(p.inf(), f64::MAX);
    assert_eq!(p.sup(), f64::INFINITY);
}

#[test]
fn pow_at_zero() {
    assert!(iv(0.0, 1.0).pow(iv(0.0, 0.0)).contains(1.0));
    assert!(iv(0.0, 4.0)
        .pow(Interval::point(0.5))
        .encloses(iv(0.0, 2.0)));
    assert_eq!(iv(0.0, 1.0).pow(Interval::point(-1.0)).sup(), f64::INFINITY);
}
