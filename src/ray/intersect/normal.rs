//! Surface normals at hits.

use super::*;
use crate::expr::PointEvaluator;
use glam::DVec3;

impl<'s> Tracer<'s> {
    /// The unit surface normal at `p`, the last hit: the normalised gradient
    /// of the shape that found the hit (f itself around it, and shorter than
    /// the whole formula where a leaf settled its branch points).
    /// Where the gradient is below a millionth of the hit leaf's L (singular
    /// curves such as the heart's rim, where it is only rounding noise), the
    /// direction in which f grows across a small neighbourhood (central
    /// differences at a thousandth of the leaf) stands in; `None` if that
    /// vanishes too.
    pub fn normal(&mut self, p: DVec3) -> Option<DVec3> {
        if let Some(affine) = &self.intersector.octree.affine {
            return affine.normal();
        }
        let at = [p.x, p.y, p.z, 0.0, 0.0, 0.0];
        // A leaf of the whole formula with a short tape: its gradient,
        // f's near the hit, for a fraction of the whole's cost.
        let short = (self.hit_shape == 0)
            .then(|| self.short_gradient(self.hit_index, p))
            .flatten();
        let n = DVec3::from(if let Some(n) = short {
            n.to_array()
        } else if self.hit_shape == 0 {
            self.grad.eval_array(&at)
        } else {
            self.current = self.hit_shape;
            let shape = &self.intersector.octree.shapes[self.current];
            let evals = self.evals();
            evals
                .grad
                .get_or_insert_with(|| PointEvaluator::new(shape.grad()))
                .eval_array(&at)
        });
        let (mut l, mut size) = self.hit_leaf;
        if l.is_nan() {
            // A hit in Bernstein form: the box's bound of |∇f| first, and
            // the leaf's own where that cannot tell.
            let octree = &self.intersector.octree;
            l = octree.whole.lipschitz;
            if n.length() <= 1e-6 * l {
                (l, size) = octree.leaf_bounds_at(p);
            }
        }
        let reliable = n.length() > 1e-6 * l || !l.is_finite() || size == 0.0;
        if let (true, Some(unit)) = (reliable, n.try_normalize()) {
            return Some(unit);
        }
        let h = 1e-3
            * if size > 0.0 {
                size
            } else {
                self.intersector.octree.bounds.diagonal()
            };
        let mut f = |q: DVec3| {
            self.whole_f
                .eval_array::<1>(&[q.x, q.y, q.z, 0.0, 0.0, 0.0])[0]
        };
        let diff = |f: &mut dyn FnMut(DVec3) -> f64, axis: DVec3| f(p + h * axis) - f(p - h * axis);
        let m = DVec3::new(
            diff(&mut f, DVec3::X),
            diff(&mut f, DVec3::Y),
            diff(&mut f, DVec3::Z),
        );
        m.try_normalize().or_else(|| n.try_normalize())
    }
}
