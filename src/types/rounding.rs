//! The one home of f64 rounding: the unit roundoff, γₙ, directed rounding
//! of single operations, and every slack by which lgc raises a bound to
//! cover the roundings of its own computation.
//!
//! # Why a slack covers what it claims
//!
//! Each operation of IEEE 754 arithmetic, rounded to nearest, returns the
//! exact result times `(1 + δ)` with `|δ| ≤ u` ([`U`], half the machine
//! epsilon), unless it underflows, where the absolute error is at most half
//! the least subnormal. A value computed by `n` such operations on
//! non-negative numbers (sums and products of magnitudes, as every error
//! bound here is) lies within a factor `1 ± γₙ` of the exact one, with
//! `γₙ = n·u / (1 − n·u)` ([`gamma`]; Higham, *Accuracy and Stability of
//! Numerical Algorithms*, §3.1). So multiplying by `1 + k·u` covers any
//! `n < k` operations: `γₙ < (n + 1)·u` while `n·u < 1/(n + 1)`, far beyond
//! every `n` here. Adding the least normal f64 covers the absolute errors of
//! up to 2⁵² underflowing operations. The products `x·(1 + k·u)` and the
//! sum are themselves rounded: one unit of `k` pays for them.
//!
//! Each `up_*` function below is one such slack, named for the computation
//! it covers.

/// The unit roundoff of f64: every rounded operation is off by at most this
/// much relative to its exact result (outside underflow).
pub const U: f64 = f64::EPSILON / 2.0;

/// `γₙ = n·u / (1 − n·u)`, the relative error bound of `n` rounded
/// operations on non-negative numbers (see the module's notes); `+∞` where
/// `n·u ≥ 1`.
pub const fn gamma(n: u32) -> f64 {
    let nu = n as f64 * U;
    if nu >= 1.0 {
        f64::INFINITY
    } else {
        nu / (1.0 - nu)
    }
}

/// `x ≥ 0` raised past the rounding of the few operations (at most seven,
/// `γ₇ < 8u`) that computed it, and past any underflow: a plane's closed-form
/// error bounds, a line's value and slope.
#[inline(always)]
pub fn up_few(x: f64) -> f64 {
    x * (1.0 + 8.0 * U) + f64::MIN_POSITIVE
}

/// `x ≥ 0` raised past the rounding of an error formula of rounding bounds
/// (at most fifteen operations on non-negative numbers, `γ₁₅ < 16u`); NaN
/// becomes `+∞`, and one step up covers the product's own rounding.
#[inline]
pub fn up_error(x: f64) -> f64 {
    if x.is_nan() {
        f64::INFINITY
    } else {
        (x * (1.0 + 16.0 * U)).next_up()
    }
}

/// `x ≥ 0` raised past the roundings of a Taylor bound's own arithmetic (at
/// most thirty-one operations, `γ₃₁ < 32u`), and past any underflow.
#[inline]
pub fn up_bound(x: f64) -> f64 {
    x * (1.0 + 32.0 * U) + f64::MIN_POSITIVE
}

/// `x ≥ 0` raised past the roundings of a ray test's bound (at most
/// sixty-three operations, `γ₆₃ < 64u`: a leaf's bound times a length, plus
/// an error bound), and past any underflow.
#[inline]
pub fn up_test(x: f64) -> f64 {
    x * (1.0 + 64.0 * U) + f64::MIN_POSITIVE
}

/// `x ≥ 0` raised past the roundings of the few dozen operations (at most
/// 127, `γ₁₂₇ < 128u`) that summed a series' error bound, and past any
/// underflow: jets along a ray, Bernstein coefficients.
#[inline(always)]
pub fn up_sum(x: f64) -> f64 {
    x * (1.0 + 128.0 * U) + f64::MIN_POSITIVE
}

/// How many ulps library-function results are widened by. glibc documents at
/// most 1–2 ulps for the functions used here; 4 leaves a margin.
pub const LIBM_ULPS: u32 = 4;

/// Below this magnitude an FMA residual may underflow and stop being exact, so
/// results there are widened both ways instead.
pub(crate) const TINY: f64 = 1e-290;

// ---- directed rounding of single operations -------------------------------

/// The exact error `(a + b) - s` of `s = fl(a + b)` (Knuth's TwoSum).
#[inline]
pub(crate) fn two_sum_err(a: f64, b: f64, s: f64) -> f64 {
    let bb = s - a;
    (a - (s - bb)) + (b - bb)
}

/// `a·b + c` rounded once: the CPU's fused multiply-add where it has one
/// (detected at run time, so one binary runs everywhere), else the software
/// routine behind `f64::mul_add`. Both are the same correctly rounded value.
#[inline]
pub(crate) fn fused(a: f64, b: f64, c: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if has_fma() {
        // SAFETY: the CPU has FMA.
        return unsafe { fused_by_cpu(a, b, c) };
    }
    a.mul_add(b, c)
}

/// Whether the CPU has a fused multiply-add (the answer is cached by std).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn has_fma() -> bool {
    std::arch::is_x86_feature_detected!("fma")
}

/// [`fused`] compiled for CPUs with FMA: one instruction.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
pub(crate) unsafe fn fused_by_cpu(a: f64, b: f64, c: f64) -> f64 {
    a.mul_add(b, c)
}

/// The exact error `a·b − p` of `p = fl(a·b)` (finite, `|p| ≥ TINY`).
///
/// One fused multiply-add where the CPU has it. Elsewhere Dekker's product
/// by halves where its splitting can neither overflow nor underflow (the
/// lowest partial product is exact when `|p| ≥ 2⁻⁸⁸⁰`): a few exact f64
/// operations that inline, where `mul_add` without FMA is a call into a
/// software routine; that routine decides the rest.
#[inline]
pub(crate) fn two_prod_err(a: f64, b: f64, p: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if has_fma() {
        // SAFETY: the CPU has FMA.
        return unsafe { fused_by_cpu(a, b, -p) };
    }
    two_prod_err_by_halves(a, b, p)
}

/// [`two_prod_err`] without FMA instructions.
#[inline]
pub(crate) fn two_prod_err_by_halves(a: f64, b: f64, p: f64) -> f64 {
    // 2⁹⁹⁰ (splitting multiplies by 2²⁷ + 1), 2⁻⁸⁸⁰ and 2⁻⁹⁶⁰ (factors
    // and their halves stay normal).
    const BIG: f64 = 1.046_395_124_205_339_2e298;
    const SMALL: f64 = 1.240_520_129_162_012e-265;
    const SMALL_FACTOR: f64 = 1.026_134_200_324_594_1e-289;
    let (ma, mb, mp) = (a.abs(), b.abs(), p.abs());
    if ma.max(mb).max(mp) < BIG && mp >= SMALL && ma.min(mb) >= SMALL_FACTOR {
        let (ah, al) = split(a);
        let (bh, bl) = split(b);
        ((ah * bh - p) + ah * bl + al * bh) + al * bl
    } else {
        a.mul_add(b, -p)
    }
}

/// Veltkamp's split of `a` into a high part of 26 bits and the exact rest.
#[inline]
pub(crate) fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a; // 2²⁷ + 1
    let hi = c - (c - a);
    (hi, a - hi)
}

/// The largest f64 not above the value that rounded to `r`, given the sign of
/// `exact − r` (positive: the exact value is above `r`).
#[inline]
pub(crate) fn lower(r: f64, exact_minus_r: f64) -> f64 {
    if exact_minus_r < 0.0 {
        r.next_down()
    } else {
        r
    }
}

#[inline]
pub(crate) fn upper(r: f64, exact_minus_r: f64) -> f64 {
    if exact_minus_r > 0.0 {
        r.next_up()
    } else {
        r
    }
}

/// A finite result that overflowed to ±∞ is still bounded by ±MAX on the
/// other side.
#[inline]
pub(crate) fn overflow_down(r: f64, finite_inputs: bool) -> f64 {
    if r == f64::INFINITY && finite_inputs {
        f64::MAX
    } else {
        r
    }
}

#[inline]
pub(crate) fn overflow_up(r: f64, finite_inputs: bool) -> f64 {
    if r == f64::NEG_INFINITY && finite_inputs {
        f64::MIN
    } else {
        r
    }
}

#[inline(always)]
pub(crate) fn add_down(a: f64, b: f64) -> f64 {
    let s = a + b;
    if s.is_finite() {
        lower(s, two_sum_err(a, b, s))
    } else {
        overflow_down(s, a.is_finite() && b.is_finite())
    }
}

#[inline(always)]
pub(crate) fn add_up(a: f64, b: f64) -> f64 {
    let s = a + b;
    if s.is_finite() {
        upper(s, two_sum_err(a, b, s))
    } else {
        overflow_up(s, a.is_finite() && b.is_finite())
    }
}

/// `a·b` rounded down; `0·∞` is 0, as the product of a zero interval end with
/// an unbounded one contributes no real value.
#[inline(always)]
pub(crate) fn mul_down(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        return 0.0;
    }
    let p = a * b;
    if !p.is_finite() {
        return overflow_down(p, a.is_finite() && b.is_finite());
    }
    if p.abs() < TINY {
        return p.next_down();
    }
    lower(p, two_prod_err(a, b, p))
}

#[inline(always)]
pub(crate) fn mul_up(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        return 0.0;
    }
    let p = a * b;
    if !p.is_finite() {
        return overflow_up(p, a.is_finite() && b.is_finite());
    }
    if p.abs() < TINY {
        return p.next_up();
    }
    upper(p, two_prod_err(a, b, p))
}

/// Sign of `a/b − q` for `q = fl(a/b)`: from the exact residual `q·b − a`.
pub(crate) fn div_error_sign(a: f64, b: f64, q: f64) -> f64 {
    let r = fused(q, b, -a); // exact: q·b − a
                             // a/b − q = −r/b
    if r == 0.0 {
        0.0
    } else if (r > 0.0) == (b > 0.0) {
        -1.0
    } else {
        1.0
    }
}

pub(crate) fn div_down(a: f64, b: f64) -> f64 {
    if a == 0.0 {
        return 0.0;
    }
    let q = a / b;
    if !q.is_finite() {
        return overflow_down(q, a.is_finite() && b.is_finite());
    }
    if a.is_infinite() || b.is_infinite() {
        return q; // ∞/x and x/∞ are exact limits
    }
    if q.abs() < TINY {
        return q.next_down();
    }
    lower(q, div_error_sign(a, b, q))
}

pub(crate) fn div_up(a: f64, b: f64) -> f64 {
    if a == 0.0 {
        return 0.0;
    }
    let q = a / b;
    if !q.is_finite() {
        return overflow_up(q, a.is_finite() && b.is_finite());
    }
    if a.is_infinite() || b.is_infinite() {
        return q;
    }
    if q.abs() < TINY {
        return q.next_up();
    }
    upper(q, div_error_sign(a, b, q))
}

pub(crate) fn sqrt_down(a: f64) -> f64 {
    let s = a.sqrt();
    if !s.is_finite() || s == 0.0 || a < TINY {
        return if s > 0.0 && s.is_finite() {
            s.next_down()
        } else {
            s
        };
    }
    // sqrt(a) − s has the sign of a − s².
    lower(s, -fused(s, s, -a))
}

pub(crate) fn sqrt_up(a: f64) -> f64 {
    let s = a.sqrt();
    if !s.is_finite() || s == 0.0 || a < TINY {
        return if s.is_finite() && a > 0.0 {
            s.next_up()
        } else {
            s
        };
    }
    upper(s, -fused(s, s, -a))
}

/// `v` moved down by `n` ulps, as `n` steps of `next_down` (−∞ stays put),
/// taken at once on the bits where no step crosses zero or reaches an
/// infinity (consecutive f64s of one sign have consecutive bits).
#[inline]
pub(crate) fn ulps_down(v: f64, n: u32) -> f64 {
    let bits = v.to_bits();
    let magnitude = bits & !(1 << 63);
    let n64 = u64::from(n);
    if v > 0.0 && magnitude > n64 {
        return f64::from_bits(bits - n64); // towards zero
    }
    if v < 0.0 && magnitude + n64 < f64::INFINITY.to_bits() {
        return f64::from_bits(bits + n64); // away from zero
    }
    (0..n).fold(v, |v, _| v.next_down())
}

/// `v` moved up by `n` ulps (+∞ stays put); see [`ulps_down`].
#[inline]
pub(crate) fn ulps_up(v: f64, n: u32) -> f64 {
    -ulps_down(-v, n)
}
