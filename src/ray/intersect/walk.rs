//! The walk of the octree that hands a ray its leaves, nearest first.

use super::bounds::*;
use super::piece::*;
use super::*;
use crate::ray::answer::Answer;
use crate::ray::octree::NodeId;
use crate::ray::slab::{crossing, slab, slab_widened};
use crate::types::geom::norm;
use crate::types::rounding::ROUNDINGS_15;
use crate::types::rounding::{up_test as up, U};
use glam::DVec3;

/// A ray ready to be traced ([`Tracer::setup`]).
pub(in crate::ray) struct Setup {
    pub(in crate::ray) ray: Ray,
    pub(in crate::ray) inv_d: DVec3,
    /// How far along the given ray the evaluated ray's origin lies.
    pub(in crate::ray) offset: f64,
    pub(in crate::ray) near: f64,
    pub(in crate::ray) far: f64,
}

impl<'s> Tracer<'s> {
    /// Answers one ray by walking the octree from its root, nearest leaf
    /// first (the walk every ray but a listed camera ray takes).
    #[inline(always)]
    pub(in crate::ray) fn trace_ray(
        &mut self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
        leaving: bool,
    ) -> Answer {
        let Some(Setup {
            ray,
            inv_d,
            offset,
            near,
            far,
        }) = self.setup(o, d, t_min, t_max, leaving)
        else {
            return Answer::Miss;
        };
        let mut budget = MAX_PIECES_PER_RAY;
        self.stack.clear();
        self.stack.push((0, near, far));
        while let Some((id, t0, t1)) = self.next_walked(&ray, inv_d) {
            let answer = self.visit(id, &ray, t0, t1, &mut budget);
            if answer != Answer::Miss {
                return answer.moved_by(offset);
            }
        }
        Answer::Miss
    }

    /// The ray as the tracer evaluates it, with `1/d` and its range
    /// `[near, far]` in the box (relative to the moved origin, `offset`
    /// along the ray); `None` when it misses the box.
    #[inline(always)]
    pub(in crate::ray) fn setup(
        &self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
        leaving: bool,
    ) -> Option<Setup> {
        // (t_min = +∞: a bundle's rays that all leave the box before any root.)
        if t_min == f64::INFINITY || d == DVec3::ZERO || !o.is_finite() || !d.is_finite() {
            return None;
        }
        let intersector = self.intersector;
        let inv_d = d.recip();
        let root = &intersector.octree.nodes[0];
        // (Widened: a root on the box's wall is in the box.)
        let (near, far) = slab_widened(&root.bounds, &o, &d, inv_d);
        let (near, far) = (near.max(t_min), far.min(t_max));
        if near > far || near.is_nan() || far.is_nan() {
            return None;
        }
        let speed = up(norm(d));
        let d_scale = {
            let m = d.abs().max_element();
            let mut s = 1.0f64;
            while s < m {
                s *= 2.0;
            }
            s
        };
        // Rounding moves computed crossings and points by about u·(|o| + |t·d|);
        // within the pad, the leaves' proofs and bounds cover it. A far origin
        // is first moved along the ray to the entry, with one rounding (FMA).
        let reach = |o: DVec3, t: f64| ROUNDINGS_15 * (norm(o) + t.abs() * speed);
        let pad = intersector.octree.pad;
        let radius = intersector.radius;
        let moved = |t: f64, shift: f64| up(U * (t * speed + radius) + shift);
        let (ray, offset, near, far) = if reach(o, near.abs().max(far.abs())) <= pad {
            let ray = Ray {
                o,
                d,
                speed,
                d_scale,
                shift: 0.0,
                moved: moved(near.abs().max(far.abs()), 0.0),
                fast: true,
                // The start test applies where the ray starts inside the box.
                start: (leaving && near == t_min).then_some(near),
            };
            (ray, 0.0, near, far)
        } else {
            let start = DVec3::new(
                near.mul_add(d.x, o.x),
                near.mul_add(d.y, o.y),
                near.mul_add(d.z, o.z),
            );
            let shift = up(U * norm(start));
            let span = up(far - near);
            let ray = Ray {
                o: start,
                d,
                speed,
                d_scale,
                shift,
                moved: moved(span, shift),
                fast: reach(start, span) + shift <= pad,
                start: None,
            };
            (ray, near, 0.0, span)
        };
        Some(Setup {
            ray,
            inv_d,
            offset,
            near,
            far,
        })
    }

    /// Searches the leaf of node `id` on `[t0, t1]`, and notes where a hit
    /// was found (for its normal).
    #[inline(always)]
    pub(in crate::ray) fn visit(
        &mut self,
        id: NodeId,
        ray: &Ray,
        t0: f64,
        t1: f64,
        budget: &mut u32,
    ) -> Answer {
        let intersector = self.intersector;
        let node = &intersector.octree.nodes[id as usize];
        let Some(index) = node.leaf_index() else {
            return Answer::Miss;
        };
        let leaf = &intersector.octree.leaves[index];
        self.stats.leaves += 1;
        let answer = self.in_leaf(leaf, index, ray, t0, t1, budget);
        if answer != Answer::Miss {
            self.hit_leaf = (leaf.lipschitz, node.bounds.diagonal());
            self.hit_shape = self.current;
            self.hit_index = index;
        }
        answer
    }

    /// The next leaf the ray crosses (its node and range), from a walk of
    /// the octree: nodes on [`Tracer::stack`] hold the ray's unvisited
    /// ranges, nearest on top; an inner node is replaced by its children.
    #[inline(always)]
    pub(in crate::ray) fn next_walked(
        &mut self,
        ray: &Ray,
        inv_d: DVec3,
    ) -> Option<(NodeId, f64, f64)> {
        let intersector = self.intersector;
        while let Some((id, t0, t1)) = self.stack.pop() {
            let node = &intersector.octree.nodes[id as usize];
            if let Some(index) = node.leaf_index() {
                if !node.is_tight() {
                    return Some((id, t0, t1));
                }
                // Only the leaf's hull holds surface: clipped to its slab
                // test, the ray's range is the list's (`next_listed`).
                let (a, b) = slab(intersector.octree.leaf_hull(index), ray.o, ray.d, inv_d);
                let t0 = if a > t0 { a } else { t0 };
                let t1 = if b < t1 { b } else { t1 };
                if t0 < t1 {
                    return Some((id, t0, t1));
                }
                continue;
            }
            let Some(first) = node.first_child() else {
                continue;
            };
            // A ray leaving the surface inside this node: its bounds, coarser
            // than a leaf's, may prove it leaves across several leaves at once.
            let mut t0 = t0;
            if let (Some(i), true) = (node.start_index(), ray.start == Some(t0)) {
                let bounds = &intersector.octree.start_bounds[i];
                let k = Bounds::new(bounds, ray);
                if k.second_order {
                    self.current = bounds.shape as usize;
                    if let Ok(end) = self.leave_start(ray, &k, t0) {
                        if end >= t1 {
                            continue;
                        }
                        t0 = end;
                    }
                }
            }
            // The children the ray crosses, in order, come from the times at
            // which it crosses the three mid-planes (Revelles et al. 2000):
            // each crossing flips one octant bit. No box tests, no sorting.
            let (o, d) = (ray.o, ray.d);
            let c = node.bounds.center();
            let mut octant = 0usize;
            let mut cross = [(f64::INFINITY, 0usize); 3];
            for axis in 0..3 {
                if d[axis] == 0.0 {
                    if o[axis] >= c[axis] {
                        octant |= 1 << axis;
                    }
                    continue;
                }
                let tm = crossing(c[axis] - o[axis], d[axis], inv_d[axis]);
                // At the entry t0 the ray is on the side it has not yet left.
                let upper = if d[axis] > 0.0 { t0 >= tm } else { t0 < tm };
                if upper {
                    octant |= 1 << axis;
                }
                if tm > t0 && tm < t1 {
                    cross[axis] = (tm, axis);
                }
            }
            // Three compare-and-swaps sort them (no crossing time is NaN: one
            // is kept only when it compares inside (t0, t1)).
            let order = |cross: &mut [(f64, usize); 3], i: usize, j: usize| {
                if cross[j].0 < cross[i].0 {
                    cross.swap(i, j);
                }
            };
            order(&mut cross, 0, 1);
            order(&mut cross, 1, 2);
            order(&mut cross, 0, 1);
            let mut pieces = [(0usize, 0.0f64, 0.0f64); 4];
            let mut n = 0;
            let mut start = t0;
            for &(tm, axis) in cross.iter().filter(|c| c.0.is_finite()) {
                pieces[n] = (octant, start, tm);
                n += 1;
                octant ^= 1 << axis;
                start = tm;
            }
            pieces[n] = (octant, start, t1);
            n += 1;
            // Nearest first: push the farthest first.
            let alive = node.alive_children();
            for &(k, a, b) in pieces[..n].iter().rev() {
                if alive & (1 << k) != 0 {
                    self.stack.push((first + k as NodeId, a, b));
                }
            }
        }
        None
    }
}
