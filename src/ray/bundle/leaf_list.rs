//! The leaves a bundle of camera rays may cross, listed by one walk of the
//! octree for all of them.

use crate::ray::intersect::Tracer;
use crate::ray::octree::NodeId;
use crate::types::{Aabb, Interval};
use glam::DVec3;

/// Kept leaves past which a [`LeafList`] is not kept: a bundle that crosses
/// more walks the octree ray by ray instead.
pub const MAX_LISTED_LEAVES: usize = 256;

/// The directions of a bundle: per axis, the reciprocals of the least and
/// greatest component where every component has one strict sign and both
/// reciprocals are finite (`None`: that axis bounds nothing).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct DirectionHull {
    pub(super) lo: DVec3,
    pub(super) hi: DVec3,
    pub(super) inv: [Option<(f64, f64)>; 3],
}

impl DirectionHull {
    pub(super) fn between(lo: DVec3, hi: DVec3) -> Option<DirectionHull> {
        if !lo.is_finite() || !hi.is_finite() || lo.cmpgt(hi).any() {
            return None;
        }
        let inv = std::array::from_fn(|i| {
            // The same reciprocals a ray computes (`DVec3::recip`).
            let (p, q) = (1.0 / lo[i], 1.0 / hi[i]);
            let one_sign = (lo[i] > 0.0 || hi[i] < 0.0) && p.is_finite() && q.is_finite();
            one_sign.then_some((p, q))
        });
        Some(DirectionHull { lo, hi, inv })
    }

    pub(super) fn contains(&self, d: DVec3) -> bool {
        d.cmpge(self.lo).all() && d.cmple(self.hi).all()
    }

    /// Bounds of the times at which the bundle's rays from `o` enter and
    /// leave the box `b`, as each ray's slab test computes them: every ray's
    /// entry is at least the first, every exit at most the second. Exact,
    /// not padded: for fixed operands a rounded quotient or product is
    /// monotone in the other, so each ray's times lie between those of the
    /// hull's extreme components, per axis.
    pub(super) fn times(&self, b: &Aabb, o: DVec3) -> (f64, f64) {
        let (mut enter, mut leave) = (f64::NEG_INFINITY, f64::INFINITY);
        for i in 0..3 {
            let Some((p, q)) = self.inv[i] else {
                continue;
            };
            let (lo, hi) = (b.lo[i] - o[i], b.hi[i] - o[i]);
            let (front, back) = if p > 0.0 { (lo, hi) } else { (hi, lo) };
            // No time is NaN (finite differences times finite reciprocals):
            // plain comparisons give what f64's min and max, which skip NaN
            // at the cost of several instructions each, would.
            let (a, b) = (front * p, front * q);
            let first = if a < b { a } else { b };
            if first > enter {
                enter = first;
            }
            let (a, b) = (back * p, back * q);
            let last = if a > b { a } else { b };
            if last < leave {
                leave = last;
            }
        }
        (enter, leave)
    }
}

/// A kept leaf some ray of a bundle may cross: its node and leaf index, and
/// a time no ray of the bundle enters its hull before.
#[derive(Clone, Copy, Debug)]
pub struct Listed {
    pub(crate) enter: f64,
    /// A time by which every ray has left its hull.
    pub(super) leave: f64,
    pub(crate) node: NodeId,
    pub(crate) leaf: u32,
}

/// The kept leaves that rays leaving one origin in a bundle of directions
/// may cross from a time on, by the least time any of them enters: each ray
/// searches these (in its own order) instead of walking the octree from its
/// root. The list holds every leaf whose slab test any of the rays would
/// pass, so a ray's answer is the walk's; rays outside the bundle walk.
#[derive(Clone, Debug, Default)]
pub struct LeafList {
    pub(super) origin: DVec3,
    pub(super) from: f64,
    pub(super) hull: Option<DirectionHull>,
    pub(super) leaves: Vec<Listed>,
    pub(super) stack: Vec<NodeId>,
}

impl LeafList {
    /// Lists the kept leaves of `tracer`'s octree that rays from `o` in
    /// `directions` may cross at `t ≥ from`; `false` (and an empty list)
    /// when they are more than [`MAX_LISTED_LEAVES`] or nothing is known of
    /// the directions.
    pub fn gather(
        &mut self,
        tracer: &Tracer<'_>,
        o: DVec3,
        directions: &[DVec3],
        from: f64,
    ) -> bool {
        self.gather_between(tracer, o, hull_of(directions), from)
    }

    /// [`LeafList::gather`] for directions whose componentwise least and
    /// greatest are `hull`, as a fold of `min` and `max` over them in order
    /// gives them (`None`: nothing is known of them).
    pub fn gather_between(
        &mut self,
        tracer: &Tracer<'_>,
        o: DVec3,
        hull: Option<(DVec3, DVec3)>,
        from: f64,
    ) -> bool {
        self.clear();
        let octree = tracer.octree();
        let nodes = &octree.nodes;
        // A tree of one leaf has no walk to save.
        if nodes[0].leaf_index().is_some() || !o.is_finite() || !from.is_finite() {
            return false;
        }
        let Some(hull) = hull.and_then(|(lo, hi)| DirectionHull::between(lo, hi)) else {
            return false;
        };
        (self.origin, self.from, self.hull) = (o, from, Some(hull));
        self.stack.clear();
        self.stack.push(0);
        while let Some(id) = self.stack.pop() {
            let node = &nodes[id as usize];
            if !node.is_alive() {
                continue;
            }
            // A child's computed times lie within its parent's: a box no
            // ray crosses holds no box a ray crosses. Of a leaf, only its
            // hull holds surface.
            let leaf = node.leaf_index();
            let b = leaf.map_or(&node.bounds, |i| octree.leaf_hull(i));
            let (enter, leave) = hull.times(b, o);
            if enter > leave || leave < from {
                continue;
            }
            if let Some(leaf) = leaf {
                if self.leaves.len() == MAX_LISTED_LEAVES {
                    self.clear();
                    return false;
                }
                self.leaves.push(Listed {
                    enter: enter.max(from),
                    leave,
                    node: id,
                    leaf: leaf as u32,
                });
            } else if let Some(first) = node.first_child() {
                // The alive children, lowest first: one per set bit.
                let mut alive = node.alive_children();
                while alive != 0 {
                    self.stack.push(first + alive.trailing_zeros());
                    alive &= alive - 1;
                }
            }
        }
        self.leaves
            .sort_unstable_by(|a, b| a.enter.total_cmp(&b.enter));
        true
    }

    /// The part of `wider` that rays with directions between `lo` and `hi`
    /// (componentwise; inside `wider`'s bundle) may cross: a narrower bundle
    /// from the same origin.
    pub fn narrow(&mut self, tracer: &Tracer<'_>, wider: &LeafList, lo: DVec3, hi: DVec3) {
        self.leaves.clear();
        self.origin = wider.origin;
        self.from = wider.from;
        self.hull = wider.hull.and(DirectionHull::between(lo, hi));
        let Some(hull) = self.hull else {
            return;
        };
        if !wider
            .hull
            .is_some_and(|w| w.contains(hull.lo) && w.contains(hull.hi))
        {
            self.hull = None;
            return;
        }
        let octree = tracer.octree();
        for listed in &wider.leaves {
            let (enter, leave) = hull.times(octree.leaf_hull(listed.leaf as usize), self.origin);
            if enter <= leave && leave >= self.from {
                self.leaves.push(Listed {
                    enter: enter.max(self.from),
                    leave,
                    ..*listed
                });
            }
        }
        self.leaves
            .sort_unstable_by(|a, b| a.enter.total_cmp(&b.enter));
    }

    /// The list from `from` on (no earlier than its start): leaves every
    /// ray has left before it are dropped.
    pub fn advance(&mut self, from: f64) {
        if from.is_nan() || from <= self.from {
            return;
        }
        self.from = from;
        self.leaves.retain(|l| l.leave >= from);
        for l in &mut self.leaves {
            l.enter = l.enter.max(from);
        }
    }

    /// Whether no ray of the bundle meets the surface in `region`, which
    /// holds its points for t in `[a, b]`: the region meets no listed
    /// leaf's hull, or f's enclosure excludes 0 there. Every root of a ray
    /// lies in the hull of a listed leaf the ray crosses, so where the
    /// shapes of the leaves whose hulls the region meets hold at most half
    /// the whole formula's instructions in all, each is enclosed over its
    /// part of the region (a smaller box, by a shorter tape); otherwise the
    /// whole formula is, over the whole region. (A leaf's shape has f's
    /// sign in its padded box, which holds its hull.)
    pub(super) fn clear_in(
        &self,
        tracer: &mut Tracer<'_>,
        region: &[Interval; 3],
        a: f64,
        b: f64,
    ) -> bool {
        let octree = tracer.octree();
        let met = || {
            self.leaves
                .iter()
                .take_while(move |l| l.enter <= b)
                .filter(move |l| l.leave >= a && octree.leaf_hull(l.leaf as usize).meets(region))
        };
        let shape = |l: &Listed| octree.leaves[l.leaf as usize].shape as usize;
        let (mut count, mut len) = (0, 0);
        for l in met() {
            count += 1;
            len += octree.shapes[shape(l)].f.body().len();
        }
        if count == 0 {
            return true;
        }
        if 2 * len > octree.shapes[0].f.body().len() {
            return tracer.f_excludes(*region);
        }
        met().all(|l| {
            let hull = octree.leaf_hull(l.leaf as usize).intervals();
            let part = std::array::from_fn(|i| region[i].intersection(hull[i]));
            tracer.shape_f_excludes(shape(l), part)
        })
    }

    /// Empties the list: every ray walks the octree.
    pub fn clear(&mut self) {
        self.leaves.clear();
        self.hull = None;
    }

    /// How many leaves are listed.
    pub fn len(&self) -> usize {
        self.leaves.len()
    }

    /// Whether no leaf is listed.
    pub fn is_empty(&self) -> bool {
        self.leaves.is_empty()
    }

    /// The listed leaves, for the ray `o + t·d` with `t ≥ t_min`, when the
    /// list covers it: the same origin, a direction in the bundle's hull,
    /// and a start no earlier than the list's.
    pub(crate) fn for_ray(&self, o: DVec3, d: DVec3, t_min: f64) -> Option<&[Listed]> {
        let hull = self.hull?;
        (o == self.origin && t_min >= self.from && hull.contains(d)).then_some(&self.leaves[..])
    }
}

/// The componentwise least and greatest of `directions` (exact: min and
/// max round nothing); `None` when there are none or one is not finite.
pub(super) fn hull_of(directions: &[DVec3]) -> Option<(DVec3, DVec3)> {
    let (lo, hi) = directions.iter().fold(None, |hull, &d| widen(hull, d))?;
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

/// The componentwise least and greatest of directions so far, `hull`, with
/// `d` added (exact: min and max round nothing). Folded over directions in
/// order from `None`, it gives the hull [`LeafList::gather_between`] and
/// [`clear_until_between`](super::clear_until_between) take.
pub fn widen(hull: Option<(DVec3, DVec3)>, d: DVec3) -> Option<(DVec3, DVec3)> {
    Some(hull.map_or((d, d), |(lo, hi)| (lo.min(d), hi.max(d))))
}
