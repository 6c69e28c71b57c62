//! The pad: how far every box is widened for its proofs and bounds.

use crate::types::rounding::ROUNDINGS_127;
use crate::types::Aabb;
use glam::DVec3;

/// The pad of a bounding box: a millionth of a millionth of its diagonal,
/// and enough to cover the spacing of f64 numbers at its coordinates.
pub fn pad_for(bounds: &Aabb) -> f64 {
    let size = bounds.diagonal();
    let coords = bounds.lo.abs().max(bounds.hi.abs()).max_element();
    1e-12 * size + ROUNDINGS_127 * coords
}

/// `b` widened by `pad` on every side, rounded outward.
pub(crate) fn padded(b: &Aabb, pad: f64) -> Aabb {
    let lo = b.lo - DVec3::splat(pad);
    let hi = b.hi + DVec3::splat(pad);
    Aabb {
        lo: DVec3::new(lo.x.next_down(), lo.y.next_down(), lo.z.next_down()),
        hi: DVec3::new(hi.x.next_up(), hi.y.next_up(), hi.z.next_up()),
    }
}
