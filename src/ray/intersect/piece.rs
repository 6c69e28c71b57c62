//! A piece of a ray, the ray as the tracer evaluates it, and certified signs.

use crate::types::Interval;
use glam::DVec3;

/// A piece of a ray inside one leaf, with F at its ends and their certified
/// signs (0: not certified yet).
#[derive(Clone, Copy)]
pub(super) struct Piece {
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) fa: f64,
    pub(super) fb: f64,
    pub(super) sa: i8,
    pub(super) sb: i8,
    /// Which formula F is on the piece: 0 for the leaf's own, `k + 1` for
    /// the k-th side of a split leaf ([`SplitLeaf`]), proved to hold there.
    pub(super) side: u8,
    /// A bound of |F′| on the piece, from an enclosure of g over it or over
    /// a piece that holds it (F continuous there); `+∞` where none is known.
    pub(super) lip: f64,
}

/// The ray being answered, as the tracer evaluates it.
#[derive(Clone, Copy)]
pub(in crate::ray) struct Ray {
    /// Origin: the given one, or a point on the ray near the box when the
    /// given one is so far away that rounding would blur the leaves.
    pub(in crate::ray) o: DVec3,
    pub(in crate::ray) d: DVec3,
    /// `|d|`, rounded up.
    pub(in crate::ray) speed: f64,
    /// A power of two at least every `|dᵢ|`: the scale of g's rounding bound.
    pub(in crate::ray) d_scale: f64,
    /// How far the evaluated ray may lie from the given one (the shift of the
    /// origin).
    pub(in crate::ray) shift: f64,
    /// How far any computed point `o + t·d` of the ray inside the box may lie
    /// from the exact point of the given ray: two roundings per coordinate,
    /// of t·dᵢ and of the sum, plus the shift.
    pub(in crate::ray) moved: f64,
    /// Whether the leaves' f64 bounds cover this ray (its rounding stays
    /// within the octree's pad); if not, intervals decide everything.
    pub(in crate::ray) fast: bool,
    /// For a ray that leaves a surface, its first t inside the box, where
    /// F and g are tested first (see [`Tracer::answer_from_surface`]).
    pub(in crate::ray) start: Option<f64>,
}

/// The sign of a value known to within `err`: ±1, or 0 when the error could
/// flip it (or the value is undefined).
#[inline]
pub(super) fn certified_sign(v: f64, err: f64) -> i8 {
    if v > err {
        1
    } else if v < -err {
        -1
    } else {
        0
    }
}

/// The sign an interval certifies: ±1, or 0 when it holds 0 or is empty.
pub(super) fn interval_sign(i: Interval) -> i8 {
    if i.is_empty() {
        0
    } else if i.inf() > 0.0 {
        1
    } else if i.sup() < 0.0 {
        -1
    } else {
        0
    }
}

/// The f64 values of F and g at a point.
pub(super) type Values = (f64, f64);
