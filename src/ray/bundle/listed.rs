//! Camera rays answered over their bundle's leaf list instead of a walk of
//! the octree: the walk's answers, to the bit.

use super::leaf_list::{LeafList, Listed};
use crate::ray::answer::Answer;
use crate::ray::intersect::piece::Ray;
use crate::ray::intersect::walk::Setup;
use crate::ray::intersect::{Tracer, MAX_PIECES_PER_RAY};
use crate::ray::octree::NodeId;
use crate::ray::slab::slab_from;
use glam::DVec3;

impl<'s> Tracer<'s> {
    /// [`Tracer::first_hit`] for a camera ray of a bundle, with `t_max` = +∞:
    /// the ray searches the leaves `list` gives for it rather than walking the
    /// octree (and walks when the list does not cover it: another origin, a
    /// direction outside the bundle, an earlier `t_min`, or an origin so far
    /// away that it is moved to the box). The answer is the walk's, to the
    /// bit.
    #[inline]
    pub fn first_hit_in(&mut self, list: &LeafList, o: DVec3, d: DVec3, t_min: f64) -> Option<f64> {
        self.first_hit_in_until(list, o, d, t_min, f64::INFINITY)
    }

    /// [`Tracer::first_hit_in`] up to `t_max`: the answer of
    /// [`Tracer::first_hit`] on `[t_min, t_max]`, to the bit (the list's
    /// ranges are the walk's, clipped to the same range).
    #[inline]
    pub fn first_hit_in_until(
        &mut self,
        list: &LeafList,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<f64> {
        if self.closed_form() {
            return self.first_hit(o, d, t_min, t_max);
        }
        let listed = list.for_ray(o, d, t_min);
        match listed.and_then(|listed| self.trace_listed(listed, o, d, t_min, t_max)) {
            Some(answer) => {
                self.stats.rays += 1;
                self.stats.listed += 1;
                self.count(answer);
                answer.t()
            }
            None => self.first_hit(o, d, t_min, t_max),
        }
    }

    /// [`Tracer::trace_ray`] for a camera ray of a bundle, over the leaves
    /// its list gives (no start test); `None` for a ray whose origin would
    /// be moved (far from the box), which walks instead.
    #[inline(never)]
    fn trace_listed(
        &mut self,
        listed: &[Listed],
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<Answer> {
        let Some(Setup {
            ray,
            inv_d,
            offset,
            near,
            far,
        }) = self.setup(o, d, t_min, t_max, false)
        else {
            return Some(Answer::Miss);
        };
        if offset != 0.0 {
            return None;
        }
        let mut budget = MAX_PIECES_PER_RAY;
        let mut next = 0;
        self.taken.clear();
        while let Some((id, t0, t1)) = self.next_listed(listed, &mut next, &ray, inv_d, near, far) {
            let answer = self.visit(id, &ray, t0, t1, &mut budget);
            if answer != Answer::Miss {
                return Some(answer.moved_by(offset));
            }
        }
        Some(Answer::Miss)
    }

    /// The next leaf the ray crosses (its node and range) from a bundle's
    /// [`LeafList`], `listed[..*next]` already taken. A leaf is taken once
    /// no leaf yet to be taken can be entered before it (the list says when
    /// each can be entered first), so a ray that finds its hit early tests
    /// few boxes. Each range is the ray's slab test of the leaf's hull,
    /// clipped to `[near, far]`: the walk clips the times it computes for
    /// the leaf's box (the box's faces are its ancestors' mid-planes: the
    /// same floating-point times) to that test, which lies within them, so
    /// these are the walk's ranges, in the same order, and the answers are
    /// the walk's.
    #[inline(always)]
    fn next_listed(
        &mut self,
        listed: &[Listed],
        next: &mut usize,
        ray: &Ray,
        inv_d: DVec3,
        near: f64,
        far: f64,
    ) -> Option<(NodeId, f64, f64)> {
        let octree = &self.intersector.octree;
        // Taken leaves not yet searched, farthest first: (t0, t1, node).
        let taken = &mut self.taken;
        while let Some(l) = listed.get(*next) {
            if taken.last().is_some_and(|&(t0, _, _)| l.enter > t0) {
                break;
            }
            *next += 1;
            let (t0, t1) = slab_from(octree.leaf_hull(l.leaf as usize), &ray.o, &ray.d, inv_d);
            // (No time is NaN: plain comparisons clip.)
            let t0 = if t0 < near { near } else { t0 };
            let t1 = if t1 > far { far } else { t1 };
            if t0 < t1 {
                // Kept sorted by insertion (they are few); of equal t0, the
                // shorter goes first.
                taken.push((t0, t1, l.node));
                let mut at = taken.len() - 1;
                while at > 0 && (taken[at - 1].0, taken[at - 1].1) < (t0, t1) {
                    taken.swap(at - 1, at);
                    at -= 1;
                }
            }
        }
        taken.pop().map(|(t0, t1, id)| (id, t0, t1))
    }
}
