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
    pub fn new(x: Interval, dec: Decoration) -> DecInterval {
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

    /// `self`, no longer known to be continuous when `jumps` (a function on
    /// the way may be discontinuous on its input).
    #[inline(always)]
    pub fn jumping_if(self, jumps: bool) -> DecInterval {
        DecInterval {
            x: self.x,
            dec: if jumps {
                self.dec.min(Decoration::Def)
            } else {
                self.dec
            },
        }
    }

    /// The interval.
    pub fn interval(self) -> Interval {
        self.x
    }

    /// The decoration.
    pub fn decoration(self) -> Decoration {
        self.dec
    }

    /// `image`, the enclosure of a function's values over `self`, decorated:
    /// it keeps `self`'s decoration only if the whole argument lies in the
    /// function's `domain` (everywhere when `None`) and `image` is not empty,
    /// and is `Trv` otherwise.
    ///
    /// The image is passed in, not a closure computing it: a closure too large
    /// to inline becomes a function of its own, compiled outside the tape
    /// loop's FMA copy, and each product's rounding then calls out for it.
    #[inline(always)]
    pub fn with_image(self, domain: Option<Interval>, image: Interval) -> DecInterval {
        let inside = domain.is_none_or(|d| self.x.is_empty() || d.encloses(self.x));
        // An empty result of a non-empty argument: defined nowhere on it.
        let defined = inside && (self.x.is_empty() || !image.is_empty());
        DecInterval {
            x: image,
            dec: if defined { self.dec } else { Decoration::Trv },
        }
    }

    /// `self`, no longer known to be defined everywhere when `undefined` (a
    /// function on the way may have no value somewhere on its input).
    #[inline(always)]
    pub fn undefined_if(self, undefined: bool) -> DecInterval {
        DecInterval {
            x: self.x,
            dec: if undefined { Decoration::Trv } else { self.dec },
        }
    }

    /// `self` with the weaker of its own and `other`'s decoration: a result
    /// that also depends on `other`.
    #[inline(always)]
    pub fn depending_on(self, other: DecInterval) -> DecInterval {
        DecInterval {
            x: self.x,
            dec: self.dec.min(other.dec),
        }
    }
}
