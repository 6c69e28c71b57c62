//! Rays of formulas answered in closed form: planes and polynomials.

use super::*;
use crate::ray::answer::{half_placement, Answer};
use crate::ray::slab::slab_widened;
use crate::types::geom::norm;
use crate::types::rounding::up_test as up;
use crate::types::rounding::ROUNDINGS_15;
use glam::DVec3;

impl<'s> Tracer<'s> {
    /// The ray's answer in closed form, on its range in the box, for a
    /// formula affine over it ([`Affine`](super::affine::Affine): a plane)
    /// or a polynomial ([`Polynomial`](super::polynomial::Polynomial), in
    /// Bernstein form); `None` where the general search answers: another
    /// formula, a ray the form declines (an end where F's enclosure holds 0,
    /// a tangency, a root in the noise), or, for a plane, a ray whose
    /// rounding could move its points out of the padded box (where f is
    /// known to be affine). (Out of line and marked cold: inlined, or laid
    /// out in the search's path, it slows the search for every other
    /// formula by 1–2 %.)
    #[inline(never)]
    #[cold]
    pub(super) fn answer_in_closed_form(
        &mut self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<Answer> {
        let intersector = self.intersector;
        let octree = &intersector.octree;
        let affine = octree.affine.as_ref().filter(|_| self.closed_form_planes);
        let polynomial = octree.polynomial.as_ref();
        if affine.is_none() && polynomial.is_none() {
            return None;
        }
        if t_min == f64::INFINITY || d == DVec3::ZERO || !o.is_finite() || !d.is_finite() {
            return None;
        }
        let root = &octree.nodes[0];
        let (near, far) = slab_widened(&root.bounds, &o, &d, d.recip());
        let (near, far) = (near.max(t_min), far.min(t_max));
        if near > far || near.is_nan() || far.is_nan() {
            return Some(Answer::Miss);
        }
        let speed = up(norm(d));
        let tol = intersector.tolerance / speed;
        let place = half_placement(tol);
        let (answer, evals) = match (affine, polynomial) {
            (Some(affine), _) => {
                // (Sums of magnitudes bound the lengths, without roots.)
                let (o_size, d_size) = (o.abs().element_sum(), d.abs().element_sum());
                let reach = up(ROUNDINGS_15 * (o_size + near.abs().max(far.abs()) * d_size));
                if reach > octree.pad {
                    return None;
                }
                affine.answer(o, d, near, far, place)?
            }
            (None, Some(form)) => {
                let scratch = self.polynomial.as_mut()?;
                form.answer(scratch, (o, d), (near, far), place, tol)?
            }
            (None, None) => return None,
        };
        self.stats.f_evals += evals;
        self.stats.leaves += 1;
        self.stats.closed_form += 1;
        if answer != Answer::Miss {
            // A plane's normal is its gradient, and a polynomial's hit leaf
            // is found only if the normal needs its bounds.
            self.hit_leaf = (f64::NAN, 0.0);
            self.hit_shape = 0;
            self.hit_index = usize::MAX;
        }
        Some(answer)
    }
}
