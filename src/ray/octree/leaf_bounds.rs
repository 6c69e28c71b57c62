//! The bounds a kept leaf holds for rays: L, the Hessian, rounding errors.

use super::classify::*;
use super::leaf::*;
use super::node::NodeId;
use super::pad::*;
use super::shapes::inputs_over;
use super::short::{F_ALONE, F_AND_GRADIENT};
use crate::expr::{DecoratedEvaluator, Evaluator, RoundingBound, Slopes, Tape};
use crate::types::rounding::binade;
use crate::types::{Aabb, DecInterval, Decoration, Interval};

/// A leaf's parent: its id and box.
pub(super) type ParentBox = (NodeId, Aabb);

impl<'t> Workspace<'t> {
    /// Bounds of the rounding error of the whole formula's f64 values of f
    /// and g (for directions in [-1, 1]³) anywhere in the padded box.
    pub(super) fn rounding(&mut self, plan: &Plan, b: &Aabb) -> (f64, f64) {
        rounding_over(&mut self.whole.rounding, b, plan.pad)
    }

    /// The data of the leaf with box `unpadded`, from the workspace's shape
    /// `shape_id`, and whether the surface crosses an outer face there.
    /// `inherited` are the rounding bounds of the whole formula over its
    /// parent's box and that parent (id and box): bounds over the parent hold
    /// for the leaf, and are used when they are small against its scale.
    /// `known` is the shape's f and ∇f over the padded box, where the
    /// box's classification evaluated them.
    pub(super) fn leaf(
        &mut self,
        plan: &Plan,
        unpadded: &Aabb,
        inherited: (Option<(f64, f64)>, Option<ParentBox>),
        (shape_id, open): (u32, usize),
        known: Option<&[DecInterval; 4]>,
    ) -> (Leaf, bool) {
        let (inherited, parent) = inherited;
        let on_face = self.surface_crosses_outer_face(plan, unpadded);
        let b = &padded(unpadded, plan.pad);
        let inputs = inputs_over(b);
        let size = b.diagonal();
        // A branch point the leaf leaves open may make ∇f jump inside it.
        // Where it does, g = d·∇f has no finite rate of change (the Hessian
        // holds a Dirac term), so rays here are decided by L and intervals
        // alone, and neither the Hessian nor g's rounding is worth
        // computing. A shape with a branch point open holds no Hessian:
        // where ∇f does not jump, its leaves are made alike (L and
        // intervals are sound wherever f is continuous).
        let over_parents = (inherited, parent);
        let mut first = known.copied();
        if open > 0 {
            let v = *first.get_or_insert_with(|| self.f_and_grad(shape_id, &inputs));
            if v[1..].iter().any(|g| g.decoration() < Decoration::Dac) {
                return (
                    self.creased(plan, unpadded, over_parents, (shape_id, None), &v),
                    on_face,
                );
            }
        }
        let local = match self.evaluators(shape_id).local.as_mut() {
            Some(local) => local.eval(&inputs),
            None => {
                let v = first.unwrap_or_else(|| self.f_and_grad(shape_id, &inputs));
                return (
                    self.creased(plan, unpadded, over_parents, (shape_id, None), &v),
                    on_face,
                );
            }
        };
        let v: [DecInterval; 4] = std::array::from_fn(|i| local[i]);
        let h: [DecInterval; 6] = std::array::from_fn(|i| local[4 + i]);
        let (f, slopes, lipschitz_bound, lipschitz_ok) =
            self.first_order_or_slopes((shape_id, None), &v, b);
        let hessian_undefined = partly_undefined(&h);
        let hessian = h.map(DecInterval::interval);
        let unbounded = !lipschitz_bound.is_finite() || hessian.iter().any(|e| !e.is_bounded());
        let hessian_norm = frobenius(&hessian);
        // A parent's bounds cover the leaf, but where they are coarse (a crease
        // the parent's box straddles and the leaf's does not) the leaf's own
        // are worth the evaluation.
        let fine = |(fe, ge): (f64, f64)| {
            fe <= 1e-9 * lipschitz_bound * size
                && ge <= 1e-9 * (lipschitz_bound + hessian_norm * size)
        };
        // A specialised shape's bounds over the parent box, shared with the
        // siblings that see the same shape (they come one after another).
        let over_parent = match (shape_id, parent) {
            (0, _) => inherited,
            (_, Some((id, parent_box))) => {
                let mut known = self.shape_rounding.iter().flatten();
                match known.find(|&&(p, s, _)| p == id && s == shape_id) {
                    Some(&(_, _, r)) => Some(r),
                    None => {
                        let e = &mut self.evaluators(shape_id).rounding;
                        let r = rounding_over(e, &parent_box, plan.pad);
                        self.shape_rounding.rotate_right(1);
                        self.shape_rounding[0] = Some((id, shape_id, r));
                        Some(r)
                    }
                }
            }
            _ => None,
        };
        let (f_error, g_error) = match over_parent {
            Some(r) if fine(r) => r,
            _ => rounding_over(&mut self.evaluators(shape_id).rounding, unpadded, plan.pad),
        };
        let leaf = Leaf {
            lipschitz: lipschitz_bound,
            slopes,
            hessian,
            hessian_norm,
            point_hessian: hessian
                .iter()
                .all(|h| h.inf() == h.sup() && h.inf().is_finite()),
            f_error,
            g_error,
            needs_intervals: unbounded || !lipschitz_ok || hessian_undefined || f.is_empty(),
            continuous: lipschitz_ok && !f.is_empty(),
            shape: shape_id,
        };
        (leaf, on_face)
    }

    /// Shape `shape_id`'s f and ∇f over the box `inputs`: f's decoration
    /// exact, ∇f's partials each with the least of theirs (all a leaf
    /// reads: whether ∇f may jump, or be undefined, somewhere in the box).
    fn f_and_grad(&mut self, shape_id: u32, inputs: &[DecInterval; 6]) -> [DecInterval; 4] {
        let v = self.evaluators(shape_id).f_grad.eval_first_exactly(inputs);
        std::array::from_fn(|i| v[i])
    }

    /// A creased leaf of the whole formula from `short`, the whole
    /// formula's f, g and ∇f (`short::whole_tape`) shortened over a box
    /// holding the leaf's padded box: f and ∇f enclosed, and f's slopes
    /// found, on it (the same real function there, with the same domain and
    /// decorations no worse), far shorter than the whole formula. Where the
    /// leaf's rays evaluate `short`'s f and g (`rays_evaluate`: it keeps
    /// them as its short tape), f's rounding bound is `short`'s own over the
    /// leaf's box, else the whole formula's. `None` where ∇f does not jump
    /// in the box by these enclosures: such a leaf is made as any other
    /// ([`Workspace::leaf`]).
    pub(super) fn whole_leaf_from_short(
        &mut self,
        plan: &Plan,
        unpadded: &Aabb,
        over_parents: (Option<(f64, f64)>, Option<ParentBox>),
        (short, rays_evaluate): (&Tape, bool),
    ) -> Option<Leaf> {
        let f_grad = short.keeping(&F_AND_GRADIENT);
        let inputs = inputs_over(&padded(unpadded, plan.pad));
        let mut e = DecoratedEvaluator::new(&f_grad);
        let v = e.eval_first_exactly(&inputs);
        let v: [DecInterval; 4] = std::array::from_fn(|i| v[i]);
        if v[1..].iter().all(|g| g.decoration() == Decoration::Dac) {
            return None;
        }
        let f = short.keeping(&F_ALONE);
        let short = Some((&f, rays_evaluate));
        Some(self.creased(plan, unpadded, over_parents, (0, short), &v))
    }

    /// A creased leaf of shape `shape_id` (∇f may jump in it), from f and
    /// ∇f over its padded box `v`: L, or slopes where ∇f has no bound, and
    /// f's rounding bound (the whole formula's over its parent, `inherited`,
    /// or the shape's over `parent`, where small against its scale).
    fn creased(
        &mut self,
        plan: &Plan,
        unpadded: &Aabb,
        (inherited, parent): (Option<(f64, f64)>, Option<ParentBox>),
        (shape_id, short): (u32, Option<(&Tape, bool)>),
        v: &[DecInterval; 4],
    ) -> Leaf {
        let b = &padded(unpadded, plan.pad);
        let size = b.diagonal();
        let f_tape = short.map(|(f, _)| f);
        let (f, slopes, lipschitz_bound, lipschitz_ok) =
            self.first_order_or_slopes((shape_id, f_tape), v, b);
        let fine = |fe: f64| fe <= 1e-9 * lipschitz_bound * size;
        let f_error = match (inherited, short) {
            // The leaf's rays evaluate its short tape's f (or shorter ones
            // cut from it, whose bounds are no larger): its own bound, over
            // the leaf's box, a pass over a short tape.
            (_, Some((f, true))) => rounding_of_f(&mut Evaluator::new(f), unpadded, plan.pad),
            (Some((fe, _)), _) if shape_id == 0 && fine(fe) => fe,
            _ => match self.f_rounding_over_parent(plan, shape_id, parent) {
                Some(fe) if fine(fe) => fe,
                _ => {
                    let e = &mut self.evaluators(shape_id).rounding_f;
                    rounding_of_f(e, unpadded, plan.pad)
                }
            },
        };
        Leaf {
            lipschitz: lipschitz_bound,
            slopes,
            hessian: [Interval::ENTIRE; 6],
            hessian_norm: f64::INFINITY,
            point_hessian: false,
            f_error,
            g_error: f64::INFINITY,
            needs_intervals: true,
            continuous: lipschitz_ok && !f.is_empty(),
            shape: shape_id,
        }
    }

    /// The rounding bound of shape `shape_id`'s f over the padded box of
    /// the leaf's parent, which holds for the leaf too: found once for the
    /// siblings that see the same shape (they come one after another), so
    /// a creased leaf rarely evaluates f's rounding over its own box.
    fn f_rounding_over_parent(
        &mut self,
        plan: &Plan,
        shape_id: u32,
        parent: Option<ParentBox>,
    ) -> Option<f64> {
        let (id, parent_box) = parent?;
        let mut known = self.f_rounding.iter().flatten();
        if let Some(&(_, _, fe)) = known.find(|&&(p, s, _)| p == id && s == shape_id) {
            return Some(fe);
        }
        let e = &mut self.evaluators(shape_id).rounding_f;
        let fe = rounding_of_f(e, &parent_box, plan.pad);
        self.f_rounding.rotate_right(1);
        self.f_rounding[0] = Some((id, shape_id, fe));
        Some(fe)
    }

    /// [`first_order`], from the slopes carried through f's operations
    /// where the interval gradient gives no bound (the centre of a circle,
    /// where ∇f is undefined though f is 1-Lipschitz): f's enclosure, its
    /// slopes, L from them, and whether the Lipschitz argument holds.
    fn first_order_or_slopes(
        &mut self,
        (shape_id, f_tape): (u32, Option<&Tape>),
        v: &[DecInterval; 4],
        padded: &Aabb,
    ) -> (Interval, [f64; 3], f64, bool) {
        let from_gradient = first_order(v);
        if from_gradient.3 && from_gradient.2.is_finite() {
            return from_gradient;
        }
        let inputs = Slopes::inputs(padded);
        let s = match f_tape {
            Some(tape) => Evaluator::new(tape).eval(&inputs)[0],
            None => {
                let evaluators = self.evaluators(shape_id);
                let tape = evaluators.f;
                let e = evaluators
                    .slopes
                    .get_or_insert_with(|| Evaluator::new(tape));
                e.eval(&inputs)[0]
            }
        };
        let lipschitz_bound = s.lipschitz();
        if s.defined && lipschitz_bound.is_finite() {
            // Defined and Lipschitz over the box: continuous there.
            (from_gradient.0, s.slope, lipschitz_bound, true)
        } else {
            from_gradient
        }
    }
}

/// f's enclosure, the bounds of ∂f/∂x, ∂f/∂y and ∂f/∂z in magnitude, the
/// Lipschitz bound from them, and whether a Lipschitz argument holds (f
/// defined and continuous, its Clarke gradient defined), from f and ∇f over
/// a leaf.
pub(super) fn first_order(v: &[DecInterval; 4]) -> (Interval, [f64; 3], f64, bool) {
    let lipschitz_ok = v[0].decoration() == Decoration::Dac && !partly_undefined(&v[1..4]);
    let [f, gx, gy, gz] = v.map(DecInterval::interval);
    let slopes = [gx, gy, gz].map(|g| match g {
        g if g.is_empty() => 0.0,
        g if !g.is_bounded() => f64::INFINITY,
        g => g.mag(),
    });
    let lipschitz_bound = if slopes.iter().any(|s| s.is_infinite()) {
        f64::INFINITY
    } else {
        lipschitz(slopes)
    };
    (f, slopes, lipschitz_bound, lipschitz_ok)
}

/// Bounds of the rounding error of the f64 value of f, as the `f` tape (and
/// the same operations in `fg`) computes it, anywhere in `b` padded.
pub(super) fn rounding_of_f(f: &mut Evaluator<RoundingBound>, b: &Aabb, pad: f64) -> f64 {
    let [x, y, z] = padded(b, pad).intervals().map(RoundingBound::exact);
    let unit = RoundingBound::exact(Interval::UNIT);
    f.eval(&[x, y, z, unit, unit, unit])[0].err
}

/// Bounds of the rounding error of the f64 values of f and g (for
/// directions in [-1, 1]³), as `fg` computes them, anywhere in `b` padded.
pub(super) fn rounding_over(fg: &mut Evaluator<RoundingBound>, b: &Aabb, pad: f64) -> (f64, f64) {
    let [x, y, z] = padded(b, pad).intervals().map(RoundingBound::exact);
    let unit = RoundingBound::exact(Interval::UNIT);
    let e = fg.eval(&[x, y, z, unit, unit, unit]);
    (e[0].err, e[1].err)
}

/// `sqrt(Σ mag(Hᵢⱼ)²)` over the full symmetric matrix, rounded up: a bound
/// of the spectral norm of every Hessian in the leaf.
pub(super) fn frobenius(h: &[Interval; 6]) -> f64 {
    if h.iter().any(|e| e.is_empty()) {
        return f64::INFINITY;
    }
    let top = h.iter().fold(0.0, |m: f64, e| m.max(e.mag()));
    if top == 0.0 || !top.is_finite() {
        return top;
    }
    // The squares are taken at a scale of [1, 2): squared as they are, a
    // Hessian of 2e-180 (coordinates scaled by 1e90) rounds up to the least
    // subnormal, whose root is 4e-162, and one of 1e160 overflows.
    let scale = Interval::point(binade(top));
    let m = h.map(|e| Interval::point(e.mag()) / scale);
    let two = Interval::point(2.0);
    let sum = m[0].powi(2)
        + m[1].powi(2)
        + m[2].powi(2)
        + two * (m[3].powi(2) + m[4].powi(2) + m[5].powi(2));
    (sum.sqrt() * scale).sup()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::Formula;
    use crate::ray::octree::{BuildOptions, Octree};
    use glam::DVec3;

    #[test]
    fn a_creased_leafs_rounding_bound_covers_its_own_box() {
        // Creased leaves take f's rounding bound over their parent's box,
        // found once for the siblings of one shape: it must be their own
        // shape's, over a box holding theirs.
        let src = "max(min(sqrt((x-0.31)^2+(y-0.12)^2+z^2)-0.5, \
                   sqrt((x+0.4)^2+y^2+(z-0.1)^2)-0.45, exp(x*y)-1.4), abs(z)-0.3)";
        let f = Formula::parse(src).unwrap();
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let octree = Octree::build_with(&f, &b, &BuildOptions::to_depth(4));
        let (mut creased, mut wider) = (0, 0);
        for node in &octree.nodes {
            let Some(leaf) = octree.leaf(node) else {
                continue;
            };
            if !leaf.needs_intervals || leaf.g_error.is_finite() {
                continue;
            }
            creased += 1;
            let shape = &octree.shapes[leaf.shape as usize];
            let own = rounding_of_f(&mut Evaluator::new(&shape.f), &node.bounds, octree.pad);
            assert!(
                leaf.f_error >= own,
                "{:?}: {} < {own}",
                node.bounds,
                leaf.f_error
            );
            wider += usize::from(leaf.f_error > own);
        }
        assert!(
            creased > 100 && wider > 0,
            "{creased} creased, {wider} wider"
        );
    }

    /// Creased leaves of the whole formula take L and f's enclosure from
    /// their short tapes, and f's rounding bound from it where their rays
    /// evaluate it: L bounds |∇f| sampled in the leaf, and f's rounding
    /// bound covers the tape the leaf's rays evaluate (its short tape, or
    /// the whole formula where it keeps none). In the second formula the
    /// `min` takes the sphere's shell near the surface, too long a part of
    /// the whole to be kept as a short tape, and far smaller in its
    /// rounding than the side it drops (which sums 10⁹).
    #[test]
    fn creased_leaves_bounded_by_their_short_tapes_cover_what_rays_evaluate() {
        use crate::expr::PointEvaluator;
        use crate::ray::octree::NO_SHORT;
        let sources = [
            "min(max(sqrt((x-0.31)^2+(y-0.12)^2+z^2)-0.5, abs(z)-0.2), \
             max(sqrt((x+0.4)^2+y^2+(z-0.1)^2)-0.45, x*y-0.1), \
             exp(x*y)-1.4+sqrt(x^2+(y-0.9)^2))",
            "min(abs(x^2+y^2+z^2-1)-0.05+0.01*sin(x*y)+0.01*cos(y*z)+0.01*sin(x*z), \
             (1e9+x^2)-1e9+2)",
        ];
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let options = BuildOptions {
            specialise: false,
            ..BuildOptions::to_depth(4)
        };
        let mut rng = crate::ray::test_rng::Rng(5);
        let (mut by_short, mut tighter, mut by_whole) = (0, 0, 0);
        for src in sources {
            let f = Formula::parse(src).unwrap();
            let octree = Octree::build_with(&f, &b, &options);
            let whole = &octree.shapes[0];
            let mut grad = PointEvaluator::new(whole.grad());
            for node in &octree.nodes {
                let (Some(i), Some(leaf)) = (node.leaf_index(), octree.leaf(node)) else {
                    continue;
                };
                if !leaf.needs_intervals || leaf.g_error.is_finite() {
                    continue;
                }
                let whole_bound =
                    rounding_of_f(&mut Evaluator::new(&whole.f), &node.bounds, octree.pad);
                let evaluated = match octree.short.of_leaf[i].tape {
                    NO_SHORT => {
                        by_whole += 1;
                        whole_bound
                    }
                    k => {
                        by_short += 1;
                        let short = &octree.short.tapes[k as usize];
                        rounding_of_f(&mut Evaluator::new(short), &node.bounds, octree.pad)
                    }
                };
                assert!(leaf.f_error >= evaluated, "{src}: {:?}", node.bounds);
                tighter += usize::from(leaf.f_error < whole_bound);
                for _ in 0..20 {
                    let half = 0.5 * (node.bounds.hi - node.bounds.lo);
                    let p = node.bounds.center() + half * rng.vec();
                    let g = grad.eval_array::<3>(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
                    let norm = DVec3::from(g).length();
                    // Undefined at the centre of a root of squares.
                    assert!(
                        norm.is_nan() || norm <= leaf.lipschitz * (1.0 + 1e-9),
                        "{src}: {p}: {norm} > L"
                    );
                }
            }
        }
        assert!(
            by_short > 100 && tighter > 100 && by_whole > 20,
            "{by_short} by short tapes, {tighter} tighter, {by_whole} by the whole"
        );
    }

    #[test]
    fn the_hessian_norm_is_tight_at_either_end_of_f64() {
        // Squared as they were, entries of 2e-180 rounded up to the least
        // subnormal (a norm of 4e-162) and entries of 1e160 overflowed.
        let z = Interval::point(0.0);
        for h in [2e-180, 2e-300, 1e160, 1.0] {
            let e = Interval::point(h);
            let norm = frobenius(&[e, e, e, z, z, z]);
            let exact = h * 3f64.sqrt();
            assert!(
                norm >= exact && norm <= exact * (1.0 + 1e-12),
                "{h:e}: {norm:e}"
            );
        }
        let off = frobenius(&[z, z, z, Interval::point(-1e-200), z, z]);
        assert!(off >= 1e-200 * 2f64.sqrt() && off <= 1.5e-200, "{off:e}");
        assert_eq!(frobenius(&[z; 6]), 0.0);
    }
}
