//! Decorations: whether every function on the way to an enclosure was
//! defined, and continuous, on all of its argument (IEEE 1788).

use super::Interval;

// ---- domains and decorations ---------------------------------------------

/// What is known of a function over the whole input region, carried with the
/// value as in IEEE 1788's decorated intervals (three of its levels).
///
/// A Lipschitz argument runs along paths through a region, and a sign change
/// proves a root only where F is continuous, so such callers evaluate in
/// [`DecInterval`] and read the decoration of the result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Decoration {
    /// Some function on the way may have been undefined on part of its input
    /// (IEEE 1788's `trv`): the value encloses f only where f is defined.
    Trv,
    /// Defined everywhere on the input, but possibly not continuous (`def`):
    /// a jump of `sign`, `choose`, the cut of `atan2`, a pole.
    Def,
    /// Defined and continuous everywhere on the input (`dac`).
    Dac,
}

/// An [`Interval`] with its [`Decoration`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecInterval {
    x: Interval,
    dec: Decoration,
}

impl DecInterval {
    /// An interval with a decoration.
    #[inline(always)]
    pub const fn new(x: Interval, dec: Decoration) -> DecInterval {
        DecInterval { x, dec }
    }

    /// An input or constant: defined and continuous everywhere.
    #[inline(always)]
    pub fn defined(x: Interval) -> DecInterval {
        DecInterval {
            x,
            dec: Decoration::Dac,
        }
    }

    /// The interval.
    #[inline(always)]
    pub fn interval(self) -> Interval {
        self.x
    }

    /// The decoration.
    #[inline(always)]
    pub fn decoration(self) -> Decoration {
        self.dec
    }
}
