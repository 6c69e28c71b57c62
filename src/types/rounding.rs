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
//! Numerical Algorithms*, §3.1), and `γₙ < (n + 1)·u` while `n·u < 1/(n + 1)`,
//! far beyond every `n` here. Adding the least normal f64 covers the absolute
//! errors of up to 2⁵² underflowing operations.
//!
//! Raising a computed `x̂ ≥ 0` to `fl(x̂·(1 + k·u)) + MIN_POSITIVE` rounds
//! once more (the sum only rounds up from `fl(x̂·(1 + k·u))`, which is at
//! least `x̂·(1 + k·u)·(1 − u)`), so it bounds the exact `x` wherever
//! `(1 − γₙ)(1 + k·u)(1 − u) ≥ 1`: for `n ≤ k − 2` roundings. With `u = 2⁻⁵³`
//! that is `(k − n − 1)·2⁵³ ≥ 2nk + k − 2n` after clearing denominators,
//! which the tests check for each function's `n`.
//!
//! Each `up_*` function below is one such slack, named for the computation
//! it covers.

/// The unit roundoff of f64: every rounded operation is off by at most this
/// much relative to its exact result (outside underflow).
pub const U: f64 = f64::EPSILON / 2.0;

/// The unit roundoff of f32: rounding a number to the nearest f32 moves it
/// by at most this much relative (outside underflow).
pub const U_F32: f64 = f32::EPSILON as f64 / 2.0;

/// How far rounding a point of space whose coordinates are at most `most`
/// in magnitude to the nearest f32 moves it, at most: half an ulp of each
/// coordinate, and an underflow's error (2⁻¹⁵⁰).
pub fn f32_move(most: f64) -> f64 {
    up_bound(3f64.sqrt() * (most * U_F32 + f64::powi(2.0, -150)))
}

/// `γₙ = n·u / (1 − n·u)`, the relative error bound of `n` rounded
/// operations on non-negative numbers (see the module's notes; `n < 2³²`
/// keeps `n·u` far below 1).
pub const fn gamma(n: u32) -> f64 {
    let nu = n as f64 * U;
    nu / (1.0 - nu)
}

/// A relative slack that covers one rounding: `ε = 2u > γ₁`. Each of these
/// slacks bounds the relative error of the roundings it names; applying it
/// (a product, a sum) rounds too, which the caller's own margin covers, as
/// its comment says.
pub const ROUNDINGS_1: f64 = 2.0 * U;

/// A relative slack that covers up to three roundings: `4u > γ₃`.
pub const ROUNDINGS_3: f64 = 4.0 * U;

/// A relative slack that covers up to seven roundings: `8u > γ₇`.
pub const ROUNDINGS_7: f64 = 8.0 * U;

/// A relative slack that covers up to fifteen roundings: `16u > γ₁₅`.
pub const ROUNDINGS_15: f64 = 16.0 * U;

/// A relative slack that covers up to thirty-one roundings: `32u > γ₃₁`.
pub const ROUNDINGS_31: f64 = 32.0 * U;

/// A relative slack that covers up to 127 roundings: `128u > γ₁₂₇`.
pub const ROUNDINGS_127: f64 = 128.0 * U;

/// A generous relative slack for a sum of a few dozen products (a
/// quadratic form's twelve terms): `γ₃₀₀ < 3.4·10⁻¹⁴`, thirty times below
/// it, so it covers them with room for the sum's own rounding.
pub const LOOSE_SUM: f64 = 1e-12;

/// `x·(1 + k·u)` plus the least normal f64: the raise the module's notes
/// describe, which covers `k − 2` roundings and any underflow.
#[inline(always)]
fn raise(x: f64, k: f64) -> f64 {
    x * (1.0 + k * U) + f64::MIN_POSITIVE
}

/// `x ≥ 0` raised past the rounding of the few operations (at most six,
/// `k = 8`) that computed it, and past any underflow: a plane's closed-form
/// error bounds, a line's value and slope.
#[inline(always)]
pub fn up_few(x: f64) -> f64 {
    raise(x, 8.0)
}

/// `x ≥ 0` raised past the rounding of an error formula of rounding bounds
/// (at most fifteen operations on non-negative numbers: one step up covers
/// the product's own rounding, so `(1 − γ₁₅)(1 + 16u) ≥ 1` suffices); NaN
/// becomes `+∞`.
#[inline]
pub fn up_error(x: f64) -> f64 {
    if x.is_nan() {
        f64::INFINITY
    } else {
        (x * (1.0 + 16.0 * U)).next_up()
    }
}

/// `x ≥ 0` raised past the roundings of a Taylor bound's own arithmetic (at
/// most thirty operations, `k = 32`), and past any underflow.
#[inline]
pub fn up_bound(x: f64) -> f64 {
    raise(x, 32.0)
}

/// `x ≥ 0` raised past the roundings of a ray test's bound (at most
/// sixty-two operations, `k = 64`: a leaf's bound times a length, plus an
/// error bound), and past any underflow.
#[inline]
pub fn up_test(x: f64) -> f64 {
    raise(x, 64.0)
}

/// `x ≥ 0` raised past the roundings of the few dozen operations (at most
/// 126, `k = 128`) that summed a series' error bound, and past any
/// underflow: jets along a ray, Bernstein coefficients.
#[inline(always)]
pub fn up_sum(x: f64) -> f64 {
    raise(x, 128.0)
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
///
/// Marked to inline: the tape loop's FMA copy (see `expr::tape::run`) then
/// makes it one instruction in place, not a call around which the loop's
/// live values are spilled (the bear model's tape in plain intervals ran 8 %
/// faster).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
#[inline]
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
/// `exact − r` (positive: the exact value is above `r`); `r` is finite.
///
/// Without a branch: the sign of a rounding error is a coin toss, and a
/// branch on it mispredicted every other interval operation.
#[inline(always)]
pub(crate) fn lower(r: f64, exact_minus_r: f64) -> f64 {
    debug_assert!(r.is_finite());
    let down = exact_minus_r < 0.0;
    // From either zero the step down lands on −tiny: step from −0.
    let bits = r.to_bits() | (u64::from(down && r == 0.0) << 63);
    // Below a negative value is a larger magnitude (+1), below a positive
    // one a smaller (−1): 2·sign − 1.
    let step = ((bits >> 63) << 1).wrapping_sub(1);
    f64::from_bits(bits.wrapping_add(step & u64::from(down).wrapping_neg()))
}

/// The smallest f64 not below the value that rounded to `r`, given the sign
/// of `exact − r`; `r` is finite. Without a branch, as [`lower`].
#[inline(always)]
pub(crate) fn upper(r: f64, exact_minus_r: f64) -> f64 {
    debug_assert!(r.is_finite());
    let up = exact_minus_r > 0.0;
    // From either zero the step up lands on +tiny: step from +0.
    let bits = r.to_bits() & !(u64::from(up && r == 0.0) << 63);
    // Above a positive value is a larger magnitude (+1), above a negative
    // one a smaller (−1): 1 − 2·sign.
    let step = 1u64.wrapping_sub((bits >> 63) << 1);
    f64::from_bits(bits.wrapping_add(step & u64::from(up).wrapping_neg()))
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

/// Whether the CPU rounds single operations in a direction of its own
/// choosing (AVX-512's embedded rounding; the answer is cached by std). Where
/// it does, each directed operation below is one instruction rather than a
/// rounded-to-nearest one, its exact error and a step.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn has_directed() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
}

/// Single operations rounded by the CPU towards −∞ or +∞: the exact result
/// rounded once in that direction, as IEEE 754 defines it. Each is the
/// value the portable path computes (the nearest result stepped by the sign
/// of its exact error), wherever that path does not widen (results below
/// [`TINY`], quotients of numerators below it) or special-case (zeros,
/// infinities, overflow): the callers take them only there, so that every
/// CPU gives the same intervals, bit for bit.
#[cfg(target_arch = "x86_64")]
mod directed {
    use std::arch::x86_64::*;

    const DOWN: i32 = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
    const UP: i32 = _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC;

    macro_rules! binary {
        ($name:ident, $intrinsic:ident, $mode:ident) => {
            #[target_feature(enable = "avx512f")]
            #[inline]
            pub(crate) fn $name(a: f64, b: f64) -> f64 {
                _mm_cvtsd_f64($intrinsic::<$mode>(_mm_set_sd(a), _mm_set_sd(b)))
            }
        };
    }
    binary!(add_down, _mm_add_round_sd, DOWN);
    binary!(add_up, _mm_add_round_sd, UP);
    binary!(mul_down, _mm_mul_round_sd, DOWN);
    binary!(mul_up, _mm_mul_round_sd, UP);
    binary!(div_down, _mm_div_round_sd, DOWN);
    binary!(div_up, _mm_div_round_sd, UP);

    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(crate) fn sqrt_down(a: f64) -> f64 {
        let v = _mm_set_sd(a);
        _mm_cvtsd_f64(_mm_sqrt_round_sd::<DOWN>(v, v))
    }

    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(crate) fn sqrt_up(a: f64) -> f64 {
        let v = _mm_set_sd(a);
        _mm_cvtsd_f64(_mm_sqrt_round_sd::<UP>(v, v))
    }
}

/// Whether a result the CPU rounded is one the portable path would return
/// unchanged: finite, and not below [`TINY`] (where that path widens, and
/// where a sum's exact zero takes its sign from the rounding direction).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn plain(r: f64) -> bool {
    r.abs() >= TINY && r.is_finite()
}

/// The CPU's directed binary operations beside the stepped ones, named, for
/// tests (only where [`has_directed`]).
#[cfg(all(test, target_arch = "x86_64"))]
#[allow(clippy::type_complexity)]
pub(crate) fn cpu_binary() -> [(fn(f64, f64) -> f64, fn(f64, f64) -> f64, &'static str); 6] {
    assert!(has_directed());
    // SAFETY (each): the CPU has AVX-512F, asserted above.
    [
        (
            |a, b| unsafe { directed::add_down(a, b) },
            add_down_stepped,
            "add_down",
        ),
        (
            |a, b| unsafe { directed::add_up(a, b) },
            add_up_stepped,
            "add_up",
        ),
        (
            |a, b| unsafe { directed::mul_down(a, b) },
            mul_down_stepped,
            "mul_down",
        ),
        (
            |a, b| unsafe { directed::mul_up(a, b) },
            mul_up_stepped,
            "mul_up",
        ),
        (
            |a, b| unsafe { directed::div_down(a, b) },
            div_down_stepped,
            "div_down",
        ),
        (
            |a, b| unsafe { directed::div_up(a, b) },
            div_up_stepped,
            "div_up",
        ),
    ]
}

/// The CPU's directed result of `$op`, returned where it is [`plain`].
macro_rules! by_cpu {
    ($op:ident, $cond:expr, $($arg:expr),+) => {
        #[cfg(target_arch = "x86_64")]
        if $cond && has_directed() {
            // SAFETY: the CPU has AVX-512F.
            let r = unsafe { directed::$op($($arg),+) };
            if plain(r) {
                return r;
            }
        }
    };
}

#[inline(always)]
pub(crate) fn add_down(a: f64, b: f64) -> f64 {
    by_cpu!(add_down, true, a, b);
    add_down_stepped(a, b)
}

/// [`add_down`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn add_down_stepped(a: f64, b: f64) -> f64 {
    let s = a + b;
    if s.is_finite() {
        lower(s, two_sum_err(a, b, s))
    } else {
        overflow_down(s, a.is_finite() && b.is_finite())
    }
}

#[inline(always)]
pub(crate) fn add_up(a: f64, b: f64) -> f64 {
    by_cpu!(add_up, true, a, b);
    add_up_stepped(a, b)
}

/// [`add_up`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn add_up_stepped(a: f64, b: f64) -> f64 {
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
    by_cpu!(mul_down, true, a, b);
    mul_down_stepped(a, b)
}

/// [`mul_down`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn mul_down_stepped(a: f64, b: f64) -> f64 {
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
    by_cpu!(mul_up, true, a, b);
    mul_up_stepped(a, b)
}

/// [`mul_up`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn mul_up_stepped(a: f64, b: f64) -> f64 {
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

/// Sign of `a/b − q` for `q = fl(a/b)`: from the residual `q·b − a`, exact
/// where `|q|` and `|a|` are at least [`TINY`].
#[inline(always)]
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

#[inline(always)]
pub(crate) fn div_down(a: f64, b: f64) -> f64 {
    // A numerator below TINY is one the stepped path widens.
    by_cpu!(div_down, plain(a) && b.is_finite(), a, b);
    div_down_stepped(a, b)
}

/// [`div_down`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn div_down_stepped(a: f64, b: f64) -> f64 {
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
    // The residual `q·b − a` is exact only where it cannot underflow: a
    // numerator below TINY (its quotient may be far above) widens too.
    if q.abs() < TINY || a.abs() < TINY {
        return q.next_down();
    }
    lower(q, div_error_sign(a, b, q))
}

#[inline(always)]
pub(crate) fn div_up(a: f64, b: f64) -> f64 {
    // A numerator below TINY is one the stepped path widens.
    by_cpu!(div_up, plain(a) && b.is_finite(), a, b);
    div_up_stepped(a, b)
}

/// [`div_up`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn div_up_stepped(a: f64, b: f64) -> f64 {
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
    if q.abs() < TINY || a.abs() < TINY {
        return q.next_up();
    }
    upper(q, div_error_sign(a, b, q))
}

#[inline(always)]
pub(crate) fn sqrt_down(a: f64) -> f64 {
    by_cpu!(sqrt_down, a >= TINY, a);
    sqrt_down_stepped(a)
}

/// [`sqrt_down`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn sqrt_down_stepped(a: f64) -> f64 {
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

#[inline(always)]
pub(crate) fn sqrt_up(a: f64) -> f64 {
    by_cpu!(sqrt_up, a >= TINY, a);
    sqrt_up_stepped(a)
}

/// [`sqrt_up`] from the result rounded to nearest, stepped by its exact
/// error's sign: every CPU.
#[inline(always)]
pub(crate) fn sqrt_up_stepped(a: f64) -> f64 {
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

/// The power of two `2^⌊log₂ m⌋` for a finite `m > 0`, subnormals included:
/// dividing by it scales `m` into `[1, 2)`, exactly where nothing underflows.
pub(crate) fn binade(m: f64) -> f64 {
    let bits = m.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    if biased == 0 {
        // Subnormal: m = mantissa · 2^-1074.
        let mantissa = bits & ((1u64 << 52) - 1);
        f64::from_bits(1u64 << (63 - mantissa.leading_zeros()))
    } else {
        f64::from_bits((biased as u64) << 52)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether raising by `1 + k·u` and then one more rounding covers `n`
    /// roundings: `(1 − γₙ)(1 + k·u)(1 − u) ≥ 1`, with denominators cleared
    /// (`u = 2⁻⁵³`; the term `2nk·u` left out only strengthens it).
    fn raise_covers(k: i128, n: i128) -> bool {
        (k - n - 1) * (1i128 << 53) >= 2 * n * k + k - 2 * n
    }

    /// The branch-free steps are std's `next_down` and `next_up`, bit for bit,
    /// wherever the error's sign asks for one, and `r` itself elsewhere.
    #[test]
    fn lower_and_upper_step_as_next_down_and_next_up() {
        let mut values = vec![
            0.0,
            -0.0,
            f64::from_bits(1),
            -f64::from_bits(1),
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            1.0,
            -1.0,
            0.1,
            -3.5e-310,
        ];
        // Bit patterns spread over every exponent, both signs.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        while values.len() < 20_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let v = f64::from_bits(state);
            if v.is_finite() {
                values.push(v);
            }
        }
        for r in values {
            for e in [-1.0, -0.0, 0.0, 1.0, f64::NAN] {
                let down = if e < 0.0 { r.next_down() } else { r };
                let up = if e > 0.0 { r.next_up() } else { r };
                assert_eq!(lower(r, e).to_bits(), down.to_bits(), "lower({r:e}, {e})");
                assert_eq!(upper(r, e).to_bits(), up.to_bits(), "upper({r:e}, {e})");
            }
        }
    }

    /// Each slack covers the γₙ its name claims, and each `up_*` the
    /// roundings its documentation claims, and no more.
    #[test]
    fn every_slack_covers_the_roundings_it_names() {
        for (slack, n) in [
            (ROUNDINGS_1, 1),
            (ROUNDINGS_3, 3),
            (ROUNDINGS_7, 7),
            (ROUNDINGS_15, 15),
            (ROUNDINGS_31, 31),
            (ROUNDINGS_127, 127),
            (LOOSE_SUM, 300),
        ] {
            assert!(slack > gamma(n), "{n} roundings: {slack} <= {}", gamma(n));
        }
        // up_few, up_bound, up_test, up_sum: k = 8, 32, 64, 128.
        for (k, n) in [(8, 6), (32, 30), (64, 62), (128, 126)] {
            assert!(raise_covers(k, n), "k = {k} covers {n}");
            assert!(
                !raise_covers(k, n + 1),
                "k = {k} is not claimed for {}",
                n + 1
            );
        }
        // up_error: one step up instead of the last rounding, so
        // (1 − γₙ)(1 + k·u) ≥ 1, that is (k − n)·2⁵³ ≥ 2nk.
        let step_covers = |k: i128, n: i128| (k - n) * (1i128 << 53) >= 2 * n * k;
        assert!(step_covers(16, 15) && !step_covers(16, 16));
        // The functions apply exactly these factors.
        for x in [1e-300, 1e-10, 0.5, 1.0, 3.0, 1e10, 1e300] {
            assert_eq!(up_few(x), x * (1.0 + 8.0 * U) + f64::MIN_POSITIVE);
            assert_eq!(up_bound(x), x * (1.0 + 32.0 * U) + f64::MIN_POSITIVE);
            assert_eq!(up_test(x), x * (1.0 + 64.0 * U) + f64::MIN_POSITIVE);
            assert_eq!(up_sum(x), x * (1.0 + 128.0 * U) + f64::MIN_POSITIVE);
            assert_eq!(up_error(x), (x * (1.0 + 16.0 * U)).next_up());
            assert!(up_few(x) > x && up_error(x) > x);
        }
        assert_eq!(up_error(f64::NAN), f64::INFINITY);
        assert!(gamma(1) > U && gamma(1) < 1.000_001 * U);
    }
}
