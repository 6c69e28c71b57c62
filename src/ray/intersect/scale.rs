//! Rays of any direction's size, traced at unit size.
//!
//! The tracer's tolerances, pads and rounding bounds are made for directions
//! of about unit size. A direction of 1e-170 or 1e170 puts the roots at t of
//! 1e170 or 1e-170, where they fail. Scaling the direction by a power of two
//! changes no point of the ray and is exact; only t is scaled back.

use crate::ray::answer::Answer;
use crate::types::rounding::{binade, div_down};
use glam::DVec3;

/// The power of two `s` with `max |dᵢ| / s` in `[1, 2)`, when `d / s` is
/// exact (no component underflows) and `d` is far from unit size (beyond
/// 2^±30; nearer, rays are traced as given, so that a bundle's listed
/// rays, which are never scaled, answer as walked ones to the bit);
/// `None` otherwise.
pub(super) fn unit_scale(d: DVec3) -> Option<f64> {
    let m = d.abs().max_element();
    if m == 0.0 || !m.is_finite() || (NEAR_UNIT..=1.0 / NEAR_UNIT).contains(&m) {
        return None;
    }
    let s = binade(m);
    let unit = d / s;
    (unit * s == d && unit.is_finite()).then_some(s)
}

/// Directions no smaller than this, and no larger than its inverse, are
/// traced as given.
const NEAR_UNIT: f64 = 1.0 / (1u64 << 30) as f64;

/// The answer for the ray with direction `d` from that for `d / s`: every
/// t divided by `s` (exact but where it leaves the normal range). A t past f64's range leaves the ray undecided after
/// `f64::MAX`, before which it was excluded.
pub(super) fn scaled_back(answer: Answer, s: f64) -> Answer {
    let back = |t: f64| t / s;
    match answer {
        Answer::Miss => Answer::Miss,
        Answer::Hit(t) | Answer::Touch(t) | Answer::Undecided(t) if !back(t).is_finite() => {
            Answer::Undecided(f64::MAX)
        }
        Answer::Hit(t) => Answer::Hit(back(t)),
        Answer::Touch(t) => Answer::Touch(back(t)),
        // Everything before t was excluded: rounded down where t / s is
        // inexact (in the subnormals), it still was.
        Answer::Undecided(t) => Answer::Undecided(div_down(t, s)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_of_any_size_scale_exactly_to_unit_size() {
        assert_eq!(
            unit_scale(DVec3::new(0.3, 1000.0, 0.0)),
            None,
            "near unit size"
        );
        for m in [5e-324, 1e-320, 1e-170, 1e-10, 1e10, 1e170, f64::MAX] {
            let d = DVec3::new(m, -m / 3.0, 0.0);
            let s = unit_scale(d).unwrap();
            let unit = d / s;
            assert!(
                (1.0..2.0).contains(&unit.abs().max_element()),
                "{m}: {unit}"
            );
            assert_eq!(unit * s, d);
        }
        // A component that would underflow at unit size keeps the ray as given.
        assert_eq!(unit_scale(DVec3::new(1e300, 1e-300, 0.0)), None);
        assert_eq!(unit_scale(DVec3::ZERO), None);
    }

    #[test]
    fn answers_past_the_range_of_f64_are_undecided() {
        let s = 2f64.powi(-1000);
        assert_eq!(scaled_back(Answer::Hit(0.5), s), Answer::Hit(0.5 / s));
        assert_eq!(
            scaled_back(Answer::Hit(2e8), s),
            Answer::Undecided(f64::MAX)
        );
        assert_eq!(scaled_back(Answer::Miss, s), Answer::Miss);
    }
}
