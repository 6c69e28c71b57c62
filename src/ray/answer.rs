//! The certified answers a ray can get.

/// A ray's certified answer on `[t_min, t_max]` inside the box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer {
    /// No surface: every piece of the ray was excluded by a sound test.
    Miss,
    /// The first root: F changes sign (certified) within the tolerance of t,
    /// or t is the unique root of a piece where F is monotone.
    Hit(f64),
    /// No sign change, but the enclosure of F over a piece within the
    /// tolerance of t contains 0: a tangency, or |F| below its rounding
    /// noise. Everything before it was excluded.
    Touch(f64),
    /// Everything before t was excluded, but the ray needed more pieces than
    /// [`MAX_PIECES_PER_RAY`](crate::ray::intersect::MAX_PIECES_PER_RAY) to settle what follows.
    Undecided(f64),
}

impl Answer {
    /// The t a renderer shades: hits and touches (and undecided rays, which
    /// are shown rather than hidden).
    pub fn t(self) -> Option<f64> {
        match self {
            Answer::Miss => None,
            Answer::Hit(t) | Answer::Touch(t) | Answer::Undecided(t) => Some(t),
        }
    }

    /// The same answer at `t + offset`.
    pub(crate) fn moved_by(self, offset: f64) -> Answer {
        match self {
            Answer::Miss => Answer::Miss,
            Answer::Hit(t) => Answer::Hit(t + offset),
            Answer::Touch(t) => Answer::Touch(t + offset),
            Answer::Undecided(t) => Answer::Undecided(t + offset),
        }
    }
}

/// How close to its root a hit is placed where placing it costs little: a
/// thousandth of the tolerance `tol` (2⁻¹⁰, so that the division is exact).
/// Answers then agree to far below the tolerance whatever the octree.
#[inline]
pub fn placement(tol: f64) -> f64 {
    tol / 1024.0
}

/// Half of [`placement`]: how far either side of an estimate the closed
/// forms reach, so that their brackets are a placement wide.
#[inline]
pub fn half_placement(tol: f64) -> f64 {
    tol / 2048.0
}
