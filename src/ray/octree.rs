//! Octree space pruning (Kalra–Barr §6.1).
//!
//! From the bounding box, boxes are subdivided to a fixed depth. A box whose
//! corners straddle the surface is kept (and subdivided further); otherwise it
//! is discarded when `|f(x₀)| > L·d`, with x₀ its centre, d its half-diagonal
//! and L its own automatic Lipschitz bound, or when the interval of f over it
//! excludes 0; anything else is subdivided. Both discard reasons are counted.
//! Each kept leaf stores what the intersector needs so that rays pay no
//! interval evaluation: its L and the interval Hessian, from which any ray's G
//! inside the leaf is `|dᵀ[H]d|`.

use crate::expr::{Evaluator, RoundingBound, Tape};
use crate::formula::{Formula, Output};
use crate::types::{Aabb, DecInterval, Decoration, Interval};
use glam::DVec3;

/// Index of a node in [`Octree::nodes`].
pub type NodeId = u32;

/// What the intersector knows about a kept leaf. Every bound holds over the
/// leaf's box widened by the octree's [`Octree::pad`], so that rays whose
/// computed points stray from the exact ray by rounding stay covered.
#[derive(Debug, Clone, Copy)]
pub struct Leaf {
    /// Sound bound of `|∇f|` over the leaf (may be `+∞`).
    pub lipschitz: f64,
    /// Interval Hessian over the leaf: xx, yy, zz, xy, xz, yz.
    pub hessian: [Interval; 6],
    /// Bound of the Hessian's Frobenius norm over the leaf (`‖H‖₂ ≤` this).
    pub hessian_norm: f64,
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
}

impl Leaf {
    /// A sound bound of `|g′(t)|` for a ray with direction `d` inside the leaf:
    /// `|dᵀ[H]d|`. With a point direction this needs no interval products:
    /// each term is an interval end times a number. The sums are rounded to
    /// nearest, so the result is raised by a rounding allowance (twelve
    /// operations, each off by at most ε relative, bounded by 1e-12 of the sum
    /// of magnitudes).
    #[inline]
    pub fn grad_lipschitz(&self, d: DVec3) -> f64 {
        let w = [
            d.x * d.x,
            d.y * d.y,
            d.z * d.z,
            2.0 * d.x * d.y,
            2.0 * d.x * d.z,
            2.0 * d.y * d.z,
        ];
        let (mut lo, mut hi, mut size) = (0.0f64, 0.0f64, 0.0f64);
        for (h, &wk) in self.hessian.iter().zip(&w) {
            if wk == 0.0 {
                continue;
            }
            if h.is_empty() {
                return f64::INFINITY;
            }
            let (a, b) = (h.inf() * wk, h.sup() * wk);
            lo += a.min(b);
            hi += a.max(b);
            size += a.abs().max(b.abs());
        }
        let bound = lo.abs().max(hi.abs()) + 1e-12 * size;
        if bound.is_nan() {
            f64::INFINITY
        } else {
            bound
        }
    }
}

/// One node: an inner node with eight children, a kept leaf, or a pruned box.
#[derive(Debug, Clone)]
pub struct OctreeNode {
    /// The node's box.
    pub bounds: Aabb,
    /// The first of eight consecutive children, in octant order (bit 0: upper
    /// half in x, bit 1: in y, bit 2: in z); `None` for leaves and pruned boxes.
    pub first_child: Option<NodeId>,
    /// Leaf data (kept leaves only).
    pub leaf: Option<Leaf>,
    /// Whether the node holds a kept leaf somewhere below it.
    pub alive: bool,
}

/// Counts describing one octree build.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct OctreeStats {
    /// Leaves kept.
    pub leaves: usize,
    /// Boxes discarded because `|f(x₀)| > L·d`.
    pub pruned_by_lipschitz: usize,
    /// Boxes discarded because the interval of f excludes 0.
    pub pruned_by_interval: usize,
    /// Kept leaves where f changes sign on a face of the bounding box: the
    /// surface runs into the box's wall and is clipped there.
    pub leaves_on_faces: usize,
    /// The level at which subdivision stopped because the next one would
    /// exceed [`MAX_NODES`] (a formula that pruning cannot thin out) or
    /// [`MAX_WORK`] (a formula so long that each box costs a great deal).
    pub capped_at_depth: Option<u32>,
    /// Tape instructions evaluated while building (interval ones count 1,
    /// point ones ¼), at most about [`MAX_WORK`].
    pub work: u64,
}

/// The most nodes an octree may hold (about 0.5 GB), whatever the formula and
/// the requested depth.
pub const MAX_NODES: usize = 1 << 21;

/// The most work an octree build may do, in tape instructions (interval
/// ones count 1, point ones ¼): under 10 s on one core of this project's
/// machine, whatever the formula's length. The tangle cube uses half of it
/// at depth 8; a formula of 10⁵ instructions stops after a few levels.
pub const MAX_WORK: u64 = 1 << 28;

/// A pruned octree over a bounding box.
#[derive(Debug, Clone)]
pub struct Octree {
    /// All nodes; `nodes[0]` is the root.
    pub nodes: Vec<OctreeNode>,
    /// The bounding box.
    pub bounds: Aabb,
    /// Build statistics.
    pub stats: OctreeStats,
    /// How far every box was widened for its proofs (pruning) and bounds
    /// (leaves): a ray whose rounding moves its points by less than this is
    /// covered by them.
    pub pad: f64,
}

/// The pad of a bounding box: a millionth of a millionth of its diagonal,
/// and enough to cover the spacing of f64 numbers at its coordinates.
pub fn pad_for(bounds: &Aabb) -> f64 {
    let size = (bounds.hi - bounds.lo).length();
    let coords = bounds.lo.abs().max(bounds.hi.abs()).max_element();
    1e-12 * size + 64.0 * f64::EPSILON * coords
}

/// `b` widened by `pad` on every side, rounded outward.
fn padded(b: &Aabb, pad: f64) -> Aabb {
    let lo = b.lo - DVec3::splat(pad);
    let hi = b.hi + DVec3::splat(pad);
    Aabb {
        lo: DVec3::new(lo.x.next_down(), lo.y.next_down(), lo.z.next_down()),
        hi: DVec3::new(hi.x.next_up(), hi.y.next_up(), hi.z.next_up()),
    }
}

impl Octree {
    /// Builds the octree of `formula` over `bounds` to `depth` levels.
    ///
    /// ```
    /// use glam::DVec3;
    /// use lgc::{Aabb, Formula, ray::Octree};
    /// let f = Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
    /// let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    /// let tree = Octree::build(&f, &b, 4);
    /// // Only boxes near the unit sphere survive: far fewer than 16³.
    /// assert!(tree.stats.leaves > 0 && tree.stats.leaves < 16 * 16 * 16 / 4);
    /// ```
    pub fn build(formula: &Formula, bounds: &Aabb, depth: u32) -> Octree {
        Self::build_within(formula, bounds, depth, MAX_WORK)
    }

    /// [`Octree::build`] with a work budget of `max_work` instead of
    /// [`MAX_WORK`]: subdivision stops before a level that would exceed it.
    pub fn build_within(formula: &Formula, bounds: &Aabb, depth: u32, max_work: u64) -> Octree {
        let f_grad = formula.tape(&[Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz]);
        let f_only = formula.tape(&[Output::F]);
        let hessian = formula.tape(&Output::HESSIAN);
        let fg = formula.tape(&FG);
        let pad = pad_for(bounds);
        // What one box costs to classify (eight corners, f and ∇f over it
        // and at its centre) and to make a leaf (∇f, Hessian, rounding).
        let len = |t: &Tape| t.body().len() as u64 + 1;
        let classify_cost = 2 * len(&f_only) + 2 * len(&f_grad);
        let leaf_cost = len(&f_grad) + len(&hessian) + len(&fg) + len(&f_only) * 9 / 2;
        let mut builder = Builder {
            f_grad: Evaluator::new(&f_grad),
            f_point: Evaluator::new(&f_only),
            hessian: Evaluator::new(&hessian),
            rounding: Evaluator::new(&fg),
            pad,
            bounds: *bounds,
            stats: OctreeStats::default(),
            nodes: Vec::new(),
        };
        let root = builder.node(bounds);
        builder.nodes.push(root);
        // Level by level: nodes still to classify, each with the rounding
        // bounds of f and g over its parent's box when it is a leaf-to-be
        // (those hold for it too: one evaluation per eight leaves).
        let mut level_nodes: Vec<(NodeId, Option<(f64, f64)>)> = vec![(0, None)];
        let mut level = 0u32;
        while !level_nodes.is_empty() {
            let mut possible = Vec::new();
            builder.stats.work += classify_cost * level_nodes.len() as u64;
            for &(id, rounding) in &level_nodes {
                let b = builder.nodes[id as usize].bounds;
                if let Class::Possible = builder.classify(&b) {
                    possible.push((id, rounding));
                }
            }
            // Subdividing must keep the tree within its memory budget; where
            // it would not, this level's boxes become the leaves (rays are then
            // slower, never less certain).
            let children = 8 * possible.len() as u64;
            let next_work = children * (classify_cost + leaf_cost);
            let fits = builder.nodes.len() + 8 * possible.len() <= MAX_NODES
                && builder.stats.work + next_work <= max_work;
            if level >= depth || !fits {
                builder.stats.work += leaf_cost * possible.len() as u64;
                if level < depth {
                    builder.stats.capped_at_depth = Some(level);
                }
                for (id, rounding) in possible {
                    let b = builder.nodes[id as usize].bounds;
                    let leaf = builder.leaf(&b, rounding);
                    builder.nodes[id as usize].leaf = Some(leaf);
                }
                break;
            }
            let mut next = Vec::with_capacity(8 * possible.len());
            for (id, _) in possible {
                let b = builder.nodes[id as usize].bounds;
                let first = builder.nodes.len() as NodeId;
                builder.nodes[id as usize].first_child = Some(first);
                let inherited = (level + 1 >= depth).then(|| builder.rounding(&b));
                for (k, child) in b.octants().iter().enumerate() {
                    let node = builder.node(child);
                    builder.nodes.push(node);
                    next.push((first + k as NodeId, inherited));
                }
            }
            level_nodes = next;
            level += 1;
        }
        let mut nodes = builder.nodes;
        mark_alive(&mut nodes);
        Octree {
            nodes,
            bounds: *bounds,
            stats: builder.stats,
            pad,
        }
    }

    /// The smallest box holding every kept leaf (the part of the bounding box
    /// where the surface may be); `None` when nothing was kept.
    pub fn surface_bounds(&self) -> Option<Aabb> {
        let mut leaves = self
            .nodes
            .iter()
            .filter(|n| n.leaf.is_some())
            .map(|n| n.bounds);
        let first = leaves.next()?;
        Some(leaves.fold(first, |acc, b| Aabb {
            lo: acc.lo.min(b.lo),
            hi: acc.hi.max(b.hi),
        }))
    }

    /// True when nothing of the surface was kept.
    pub fn is_empty(&self) -> bool {
        self.stats.leaves == 0
    }
}

/// Marks the nodes that hold a kept leaf, so traversal skips the rest.
/// Children always come after their parent, so one backward pass settles it.
fn mark_alive(nodes: &mut [OctreeNode]) {
    for i in (0..nodes.len()).rev() {
        nodes[i].alive = nodes[i].leaf.is_some()
            || nodes[i]
                .first_child
                .is_some_and(|c| (c..c + 8).any(|k| nodes[k as usize].alive));
    }
}

enum Class {
    /// Certainly free of the surface.
    Empty,
    /// May hold the surface.
    Possible,
}

/// The outputs the intersector evaluates in f64 (its `fg` tape): their
/// rounding is bounded per leaf over this same tape.
pub const FG: [Output; 2] = [Output::F, Output::G];

struct Builder<'t> {
    f_grad: Evaluator<'t, DecInterval>,
    f_point: Evaluator<'t, f64>,
    hessian: Evaluator<'t, DecInterval>,
    rounding: Evaluator<'t, RoundingBound>,
    pad: f64,
    bounds: Aabb,
    stats: OctreeStats,
    nodes: Vec<OctreeNode>,
}

impl Builder<'_> {
    fn node(&self, b: &Aabb) -> OctreeNode {
        OctreeNode {
            bounds: *b,
            first_child: None,
            leaf: None,
            alive: false,
        }
    }

    fn f_at(&mut self, p: DVec3) -> f64 {
        self.f_point.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0]
    }

    /// Whether f changes sign on a face this leaf shares with the bounding
    /// box, sampled on a 3×3 grid: the surface then runs into the box's wall.
    fn surface_crosses_outer_face(&mut self, b: &Aabb) -> bool {
        for axis in 0..3 {
            for (side, outer) in [
                (b.lo[axis], self.bounds.lo[axis]),
                (b.hi[axis], self.bounds.hi[axis]),
            ] {
                if side != outer {
                    continue;
                }
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let (mut neg, mut pos) = (false, false);
                for i in 0..3 {
                    for j in 0..3 {
                        let mut p = DVec3::ZERO;
                        p[axis] = side;
                        p[u] = b.lo[u] + (b.hi[u] - b.lo[u]) * f64::from(i) / 2.0;
                        p[v] = b.lo[v] + (b.hi[v] - b.lo[v]) * f64::from(j) / 2.0;
                        let f = self.f_at(p);
                        neg |= f <= 0.0;
                        pos |= f >= 0.0;
                    }
                }
                if neg && pos {
                    return true;
                }
            }
        }
        false
    }

    /// f and ∇f over the box, and whether paths through it support a
    /// Lipschitz argument: f defined and continuous on all of it, and its
    /// (Clarke) gradient defined there.
    fn intervals(&mut self, b: &Aabb) -> ([Interval; 4], bool) {
        let [x, y, z] = b.intervals().map(DecInterval::defined);
        let zero = DecInterval::defined(Interval::point(0.0));
        let v = self.f_grad.eval(&[x, y, z, zero, zero, zero]);
        let lipschitz_ok = v[0].decoration() == Decoration::Dac && !partly_undefined(&v[1..4]);
        (
            [v[0], v[1], v[2], v[3]].map(DecInterval::interval),
            lipschitz_ok,
        )
    }

    fn classify(&mut self, b: &Aabb) -> Class {
        // Corners that straddle the surface: it is certainly inside.
        let (mut neg, mut pos) = (false, false);
        for k in 0..8 {
            let c = DVec3::new(
                if k & 1 == 0 { b.lo.x } else { b.hi.x },
                if k & 2 == 0 { b.lo.y } else { b.hi.y },
                if k & 4 == 0 { b.lo.z } else { b.hi.z },
            );
            let v = self.f_at(c);
            neg |= v <= 0.0;
            pos |= v >= 0.0;
        }
        if neg && pos {
            return Class::Possible;
        }
        // Proofs of emptiness cover the padded box, so that rays whose
        // rounded crossings stray into it skip nothing.
        let b = &padded(b, self.pad);
        let ([f, gx, gy, gz], lipschitz_ok) = self.intervals(b);
        // The L-test argues along the segment from x₀ to any root, so f must be
        // defined and continuous on the whole box; where it is not, only the
        // interval decides.
        if lipschitz_ok && [gx, gy, gz].iter().all(|g| g.is_bounded()) {
            let l = lipschitz([gx, gy, gz].map(|g| g.mag()));
            let f0 = self.centre_enclosure(b.center());
            let ld = (Interval::point(l) * half_diagonal(b)).sup();
            if !f0.is_empty() && f0.mig() > ld {
                self.stats.pruned_by_lipschitz += 1;
                return Class::Empty;
            }
        }
        if f.is_empty() || !f.contains(0.0) {
            self.stats.pruned_by_interval += 1;
            return Class::Empty;
        }
        Class::Possible
    }

    fn centre_enclosure(&mut self, p: DVec3) -> Interval {
        let pt = |v: f64| DecInterval::defined(Interval::point(v));
        let zero = pt(0.0);
        self.f_grad
            .eval(&[pt(p.x), pt(p.y), pt(p.z), zero, zero, zero])[0]
            .interval()
    }

    /// Bounds of the rounding error of the f64 values of f and g (for
    /// directions in [-1, 1]³) anywhere in the padded box.
    fn rounding(&mut self, b: &Aabb) -> (f64, f64) {
        let [x, y, z] = padded(b, self.pad).intervals().map(RoundingBound::exact);
        let unit = RoundingBound::exact(Interval::UNIT);
        let e = self.rounding.eval(&[x, y, z, unit, unit, unit]);
        (e[0].err, e[1].err)
    }

    /// The leaf's data; `inherited` are the rounding bounds of its parent's
    /// box, used when they are small against the leaf's own scale.
    fn leaf(&mut self, b: &Aabb, inherited: Option<(f64, f64)>) -> Leaf {
        let unpadded = *b;
        self.stats.leaves += 1;
        if self.surface_crosses_outer_face(b) {
            self.stats.leaves_on_faces += 1;
        }
        let b = &padded(b, self.pad);
        let ([f, gx, gy, gz], lipschitz_ok) = self.intervals(b);
        let grad = [gx, gy, gz];
        let lipschitz_bound = if grad.iter().any(|g| !g.is_empty() && !g.is_bounded()) {
            f64::INFINITY
        } else {
            lipschitz(grad.map(|g| if g.is_empty() { 0.0 } else { g.mag() }))
        };
        let [x, y, z] = b.intervals().map(DecInterval::defined);
        let zero = DecInterval::defined(Interval::point(0.0));
        let h = self.hessian.eval(&[x, y, z, zero, zero, zero]);
        let hessian_undefined = partly_undefined(h);
        let hessian = [h[0], h[1], h[2], h[3], h[4], h[5]].map(DecInterval::interval);
        let unbounded = !lipschitz_bound.is_finite() || hessian.iter().any(|e| !e.is_bounded());
        let hessian_norm = frobenius(&hessian);
        // A parent's bounds cover the leaf, but where they are coarse (a crease
        // the parent's box straddles and the leaf's does not) the leaf's own
        // are worth the evaluation.
        let size = (b.hi - b.lo).length();
        let (f_error, g_error) = match inherited {
            Some((fe, ge))
                if fe <= 1e-9 * lipschitz_bound * size
                    && ge <= 1e-9 * (lipschitz_bound + hessian_norm * size) =>
            {
                (fe, ge)
            }
            _ => self.rounding(&unpadded),
        };
        Leaf {
            lipschitz: lipschitz_bound,
            hessian,
            hessian_norm,
            f_error,
            g_error,
            needs_intervals: unbounded || !lipschitz_ok || hessian_undefined || f.is_empty(),
            continuous: lipschitz_ok && !f.is_empty(),
        }
    }
}

/// `sqrt(Σ mag(Hᵢⱼ)²)` over the full symmetric matrix, rounded up: a bound
/// of the spectral norm of every Hessian in the leaf.
fn frobenius(h: &[Interval; 6]) -> f64 {
    if h.iter().any(|e| e.is_empty()) {
        return f64::INFINITY;
    }
    let m = h.map(|e| Interval::point(e.mag()));
    let two = Interval::point(2.0);
    let sum = m[0].powi(2)
        + m[1].powi(2)
        + m[2].powi(2)
        + two * (m[3].powi(2) + m[4].powi(2) + m[5].powi(2));
    sum.sqrt().sup()
}

/// Whether some function on the way to these results was undefined on part of
/// its argument.
fn partly_undefined(values: &[DecInterval]) -> bool {
    values.iter().any(|v| v.decoration() < Decoration::Def)
}

/// Half the box's diagonal, enclosed (the f64 value may round low).
fn half_diagonal(b: &Aabb) -> Interval {
    let [x, y, z] = [0, 1, 2].map(|i| Interval::point(b.hi[i]) - Interval::point(b.lo[i]));
    (x.powi(2) + y.powi(2) + z.powi(2)).sqrt() * Interval::point(0.5)
}

/// `sqrt(a² + b² + c²)` rounded up.
fn lipschitz(m: [f64; 3]) -> f64 {
    crate::bounds::euclidean_norm(m).sup()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_node_budget_is_about_half_a_gigabyte() {
        let bytes = MAX_NODES * std::mem::size_of::<OctreeNode>();
        assert!(
            bytes < 600 << 20,
            "{} bytes per node",
            std::mem::size_of::<OctreeNode>()
        );
    }
}
