//! What the intersector knows about a kept leaf, and a creased leaf's two sides.

use crate::types::rounding::LOOSE_SUM;
use crate::types::{DecInterval, Decoration, Interval};
use glam::DVec3;

/// What the intersector knows about a kept leaf. Every bound holds over the
/// leaf's box widened by the octree's [`Octree::pad`](super::Octree::pad), so that rays whose
/// computed points stray from the exact ray by rounding stay covered.
#[derive(Debug, Clone, Copy)]
pub struct Leaf {
    /// Sound bound of `|∇f|` over the leaf (may be `+∞`).
    pub lipschitz: f64,
    /// Sound bounds of `|∂f/∂x|`, `|∂f/∂y|` and `|∂f/∂z|` over the leaf (each
    /// may be `+∞`): `lipschitz` bounds their norm.
    pub slopes: [f64; 3],
    /// Interval Hessian over the leaf: xx, yy, zz, xy, xz, yz.
    pub hessian: [Interval; 6],
    /// Bound of the Hessian's Frobenius norm over the leaf (`‖H‖₂ ≤` this).
    pub hessian_norm: f64,
    /// Whether each entry of the Hessian is enclosed by one number (f is at
    /// most quadratic over the leaf: a plane, a sphere, a quadric) and is
    /// finite, so that [`Leaf::curvature`] needs one product per entry.
    pub point_hessian: bool,
    /// Bound of the rounding error of the f64 value of f anywhere in the leaf.
    pub f_error: f64,
    /// Bound of the rounding error of the f64 value of g = d·∇f anywhere in
    /// the leaf, for directions with every component in [-1, 1] (g is linear
    /// in d, so it scales with a power-of-two bound of d).
    pub g_error: f64,
    /// True when f may be undefined somewhere in the leaf, or L or the Hessian
    /// is unbounded: the intersector then decides by intervals of f alone.
    pub needs_intervals: bool,
    /// True when f is defined and continuous on the whole leaf, with a
    /// defined gradient (its interval evaluation kept the `Dac` decoration),
    /// so Lipschitz arguments along paths through it hold.
    pub continuous: bool,
    /// The index in [`Octree::shapes`](super::Octree::shapes) of the formula as the leaf sees it:
    /// f, or a formula with f's sign everywhere in the (padded) leaf.
    pub shape: u32,
}

/// A creased leaf whose formula is the larger (or the smaller) of two smooth
/// formulas, its sides (see [`crate::expr::specialise::root_split`]): where
/// their difference keeps one sign along a piece of a ray, F is one side
/// there, and Kalra–Barr's tests run with that side's bounds.
#[derive(Debug, Clone, Copy)]
pub struct SplitLeaf {
    /// Whether the leaf's formula is the larger side (else the smaller).
    pub larger: bool,
    /// Each side's bounds over the leaf (their `shape` names the formula).
    pub sides: [Leaf; 2],
    /// `2⁻ᵏ` for a leaf k levels above the requested depth (both sides
    /// quadratic: a leaf early, like a quadric's), else 1: pieces of a ray no
    /// side holds on are halved down to the length they would have in a
    /// leaf at that depth.
    pub scale: f64,
}

impl Leaf {
    /// A leaf of shape `shape` with no bounds known: rays decide everything
    /// in it by intervals.
    pub(super) fn unknown(shape: u32) -> Leaf {
        Leaf {
            lipschitz: f64::INFINITY,
            slopes: [f64::INFINITY; 3],
            hessian: [Interval::ENTIRE; 6],
            hessian_norm: f64::INFINITY,
            point_hessian: false,
            f_error: f64::INFINITY,
            g_error: f64::INFINITY,
            needs_intervals: true,
            continuous: false,
            shape,
        }
    }

    /// A sound bound of `|g′(t)|` for a ray with direction `d` inside the leaf:
    /// `|dᵀ[H]d|`, the larger magnitude of [`Leaf::curvature`]'s ends.
    #[inline]
    pub fn grad_lipschitz(&self, d: DVec3) -> f64 {
        let (lo, hi) = self.curvature(d);
        lo.abs().max(hi.abs())
    }

    /// Sound bounds `(lo, hi)` of `g′(t) = dᵀH d` for a ray with direction `d`
    /// inside the leaf (`(−∞, +∞)` where the Hessian is unknown). With a
    /// point direction this needs no interval products: each term is an
    /// interval end times a number. The sums are rounded to nearest, so each
    /// end is moved out by a rounding allowance (twelve operations, each off
    /// by at most ε relative, bounded by 1e-12 of the sum of magnitudes).
    #[inline]
    pub fn curvature(&self, d: DVec3) -> (f64, f64) {
        let w = [
            d.x * d.x,
            d.y * d.y,
            d.z * d.z,
            2.0 * d.x * d.y,
            2.0 * d.x * d.z,
            2.0 * d.y * d.z,
        ];
        // Straight-line code (this runs for every leaf a ray enters): an
        // empty entry's NaN ends propagate to the result, and a zero weight
        // contributes nothing (0·∞ would be NaN).
        let (mut lo, mut hi, mut size) = (0.0f64, 0.0f64, 0.0f64);
        if self.point_hessian {
            // Both ends' products are one number a: the same sums as below
            // (a finite entry times a zero weight is a zero of either sign,
            // which adds nothing to a sum that starts at +0).
            for (h, &wk) in self.hessian.iter().zip(&w) {
                let a = h.inf() * wk;
                lo += a;
                size += a.abs();
            }
            hi = lo;
        } else {
            for (h, &wk) in self.hessian.iter().zip(&w) {
                let (a, b) = if wk == 0.0 {
                    (0.0, 0.0)
                } else {
                    (h.inf() * wk, h.sup() * wk)
                };
                let (l, u) = if a <= b { (a, b) } else { (b, a) };
                lo += l;
                hi += u;
                size += if a.abs() >= b.abs() { a.abs() } else { b.abs() };
            }
        }
        // Products that underflow are off by up to half the least subnormal,
        // absolutely, and so is a weight d_i·d_j of non-zero components that
        // rounded to 0 (times its entry): at the ends of f64 (a Hessian of
        // 5e-324 times weights below 1) every product can round to 0, and
        // g′ would seem exactly 0.
        let least = f64::from_bits(1);
        let nonzero = [d.x != 0.0, d.y != 0.0, d.z != 0.0];
        let weighs = [
            nonzero[0],
            nonzero[1],
            nonzero[2],
            nonzero[0] && nonzero[1],
            nonzero[0] && nonzero[2],
            nonzero[1] && nonzero[2],
        ];
        let mut entries = 0.0f64;
        for (h, &w) in self.hessian.iter().zip(&weighs) {
            if w {
                entries += h.mag();
            }
        }
        let underflow = (entries * least).next_up() + 8.0 * least;
        let slack = LOOSE_SUM * size + underflow;
        let (lo, hi) = (lo - slack, hi + slack);
        if lo.is_nan() || hi.is_nan() {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (lo, hi)
        }
    }
}

/// An enclosure of one number up to the rounding of its computation.
pub(super) fn constant(h: Interval) -> bool {
    !h.is_empty() && h.is_bounded() && h.wid() <= 1e-9 * (1.0 + h.mag())
}

/// Whether a leaf of a quadratic shape is fine enough: its interval Hessian
/// has no width, so smaller boxes could not tighten G, the bound that decides
/// rays crossing it, and rays would only cross more leaves.
pub fn quadric_leaf(leaf: &Leaf) -> bool {
    !leaf.needs_intervals && leaf.lipschitz.is_finite() && leaf.hessian.iter().all(|&h| constant(h))
}

/// The sides of leaf `index` as [`record_split`] recorded them, if any.
#[inline]
pub(super) fn split_at<'a>(
    splits: &'a [SplitLeaf],
    split_of: &[u32],
    index: usize,
) -> Option<&'a SplitLeaf> {
    match split_of.get(index) {
        Some(&k) if k > 0 => splits.get(k as usize - 1),
        _ => None,
    }
}

/// Records `two` as the sides of the leaf about to be pushed as
/// `leaves[leaf]` (see [`Octree::split`]).
pub(super) fn record_split(
    splits: &mut Vec<SplitLeaf>,
    split_of: &mut Vec<u32>,
    leaf: usize,
    two: SplitLeaf,
) {
    splits.push(two);
    split_of.resize(leaf, 0);
    split_of.push(splits.len() as u32);
}

/// Whether some function on the way to these results was undefined on part of
/// its argument.
pub(super) fn partly_undefined(values: &[DecInterval]) -> bool {
    values.iter().any(|v| v.decoration() < Decoration::Def)
}
