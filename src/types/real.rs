//! Point formulas of functions whose f64 value is not a one-line library call,
//! shared by the point evaluators and the interval endpoints so both agree.

/// The sign: 1, −1, 0 at ±0, NaN at NaN.
pub fn sign(a: f64) -> f64 {
    if a > 0.0 {
        1.0
    } else if a < 0.0 {
        -1.0
    } else {
        a * 0.0 // 0 for ±0, NaN for NaN
    }
}

/// The hyperbolic secant as `2/(e^|a| + e^-|a|)`: it tends to 0 where
/// `1/cosh` would pass through ∞.
pub fn sech(a: f64) -> f64 {
    let e = (-a.abs()).exp();
    2.0 * e / (1.0 + e * e)
}
