//! Each thread's evaluators over boxes, and the classification of a box as
//! pruned or possibly holding the surface.

use super::leaf::*;
use super::node::NodeId;
use super::options::*;
use super::pad::*;
use super::shapes::*;
use crate::expr::specialise::{live_open, Branch, BranchPoint, PointIndex, RootSplit};
use crate::expr::{
    BatchEvaluator, DecoratedEvaluator, Evaluator, PointEvaluator, RoundingBound, Slopes, Tape,
};
use crate::formula::Formula;
use crate::types::{Aabb, DecInterval, Decoration, Interval};
use glam::DVec3;
use rustc_hash::FxHashMap;

/// What the work on every box reads.
pub(super) struct Plan<'t> {
    pub(super) formula: &'t Formula,
    pub(super) whole: &'t Shape,
    /// The operands of every branch point, in order.
    pub(super) operands: Tape,
    pub(super) points: Vec<BranchPoint>,
    pub(super) index: PointIndex,
    /// Where each point's operands start among the operands.
    pub(super) starts: Vec<usize>,
    pub(super) pad: f64,
    pub(super) bounds: Aabb,
}

pub(super) enum Class {
    /// Discarded because `|f(x₀)| > L·d`.
    PrunedByLipschitz,
    /// Discarded because the interval of f over it excludes 0.
    PrunedByInterval,
    /// May hold the surface; with f and ∇f over the padded box where they
    /// were evaluated (a leaf of the same shape needs them again).
    Possible(Option<[DecInterval; 4]>),
}

/// A shape's rounding bounds of f and g over a parent box: the parent's id,
/// the shape, the bounds.
pub(super) type ShapeRounding = (NodeId, u32, (f64, f64));

/// The evaluators of one shape over boxes: those that classify a box, and
/// those that make a leaf of it.
pub(super) struct BoxEvaluators<'t> {
    pub(super) f_grad: DecoratedEvaluator<'t>,
    pub(super) f_point: PointEvaluator<'t>,
    /// f alone, for enclosures at points.
    pub(super) f_interval: DecoratedEvaluator<'t>,
    /// f, ∇f and the Hessian, for leaves, where the shape holds them.
    pub(super) local: Option<DecoratedEvaluator<'t>>,
    pub(super) rounding: Evaluator<'t, RoundingBound>,
    /// The rounding of f alone (the same operations as f in `rounding`), for
    /// creased leaves, where g's is never read.
    pub(super) rounding_f: Evaluator<'t, RoundingBound>,
    /// f's Lipschitz slopes, for leaves whose interval gradient has no
    /// bound; made on first use.
    pub(super) slopes: Option<Evaluator<'t, Slopes>>,
    /// f at many points at once, made on first use where its register file
    /// is small (see [`Workspace::f_at_grid`]).
    pub(super) f_batch: Option<BatchEvaluator<'t>>,
    pub(super) f: &'t Tape,
}

impl<'t> BoxEvaluators<'t> {
    pub(super) fn new(shape: &'t Shape) -> BoxEvaluators<'t> {
        BoxEvaluators {
            f_grad: DecoratedEvaluator::new(&shape.f_grad),
            f_point: PointEvaluator::new(&shape.f),
            f_interval: DecoratedEvaluator::new(&shape.f),
            local: shape.local.as_ref().map(DecoratedEvaluator::new),
            rounding: Evaluator::new(&shape.fg),
            rounding_f: Evaluator::new(&shape.f),
            slopes: None,
            f_batch: None,
            f: &shape.f,
        }
    }
}

/// The most slots a tape may have for [`Workspace::f_at_grid`] to evaluate
/// it in a batch: its register file is `LANES` values a slot (256 KB here).
pub(super) const MAX_BATCH_SLOTS: usize = 512;

/// The most batch slots one workspace holds over all its shapes (8 MB of
/// register files), so that a formula with hundreds of large shapes cannot
/// make each thread's evaluators grow past it; shapes after that evaluate
/// point by point.
pub(super) const MAX_WORKSPACE_BATCH_SLOTS: usize = 16 * 1024;

/// The workspaces of one parallel stage of the build, lent to its jobs and
/// given back as each job ends.
///
/// rayon's `map_init` makes its state once per job it splits off, and a
/// stage of a few thousand boxes splits into hundreds: each a fresh set of
/// evaluators of the whole formula and of every shape it meets. Lent from
/// here, a stage makes about one workspace per thread.
pub(super) struct Workspaces<'t> {
    plan: &'t Plan<'t>,
    shapes: &'t [Shape],
    free: std::sync::Mutex<Vec<Workspace<'t>>>,
}

impl<'t> Workspaces<'t> {
    /// A pool of workspaces over `shapes`, empty until lent from.
    pub(super) fn new(plan: &'t Plan<'t>, shapes: &'t [Shape]) -> Self {
        Workspaces {
            plan,
            shapes,
            free: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// A workspace no job holds (a new one where all are held), given back
    /// when the loan is dropped.
    pub(super) fn lend(&self) -> Lent<'_, 't> {
        // A job that panicked while holding the lock left only whole
        // workspaces in it (they are pushed and popped whole).
        let mut free = self.free.lock().unwrap_or_else(|e| e.into_inner());
        let ws = free.pop();
        drop(free);
        Lent {
            ws: Some(ws.unwrap_or_else(|| Workspace::new(self.plan, self.shapes))),
            home: &self.free,
        }
    }
}

/// A workspace lent by [`Workspaces::lend`].
pub(super) struct Lent<'p, 't> {
    ws: Option<Workspace<'t>>,
    home: &'p std::sync::Mutex<Vec<Workspace<'t>>>,
}

impl<'t> std::ops::Deref for Lent<'_, 't> {
    type Target = Workspace<'t>;
    fn deref(&self) -> &Workspace<'t> {
        self.ws
            .as_ref()
            .expect("a lent workspace is held until dropped")
    }
}

impl<'t> std::ops::DerefMut for Lent<'_, 't> {
    fn deref_mut(&mut self) -> &mut Workspace<'t> {
        self.ws
            .as_mut()
            .expect("a lent workspace is held until dropped")
    }
}

impl Drop for Lent<'_, '_> {
    fn drop(&mut self) {
        if let Some(ws) = self.ws.take() {
            self.home.lock().unwrap_or_else(|e| e.into_inner()).push(ws);
        }
    }
}

/// One thread's evaluators of the whole formula, and of the shapes it
/// classifies boxes by.
pub(super) struct Workspace<'t> {
    /// The rounding bounds of the last few specialised shapes over a parent
    /// box: siblings with the same shape share them (a split leaf's two
    /// sides alternate, so one would not do).
    pub(super) shape_rounding: [Option<ShapeRounding>; 4],
    /// The rounding bounds of f alone of the last few shapes over a parent
    /// box, for creased leaves (as `shape_rounding`).
    pub(super) f_rounding: [Option<(NodeId, u32, f64)>; 4],
    pub(super) whole: BoxEvaluators<'t>,
    /// Shapes that boxes are classified by ([`Workspace::current`]).
    pub(super) shapes: &'t [Shape],
    /// Their evaluators, made on first use.
    pub(super) shaped: FxHashMap<u32, BoxEvaluators<'t>>,
    /// The shape that `classify` and `children_straddling` evaluate: the
    /// formula as the box's parent saw it (0: the whole formula).
    pub(super) current: u32,
    pub(super) operands: DecoratedEvaluator<'t>,
    /// Batch slots still allowed ([`MAX_WORKSPACE_BATCH_SLOTS`]).
    pub(super) batch_slots_left: usize,
}

impl<'t> Workspace<'t> {
    pub(super) fn new(plan: &'t Plan, shapes: &'t [Shape]) -> Workspace<'t> {
        Workspace {
            shape_rounding: [None; 4],
            f_rounding: [None; 4],
            whole: BoxEvaluators::new(plan.whole),
            shapes,
            shaped: FxHashMap::default(),
            current: 0,
            operands: DecoratedEvaluator::new(&plan.operands),
            batch_slots_left: MAX_WORKSPACE_BATCH_SLOTS,
        }
    }

    /// The evaluators of shape `id` (0: the whole formula).
    pub(super) fn evaluators(&mut self, id: u32) -> &mut BoxEvaluators<'t> {
        if id == 0 {
            return &mut self.whole;
        }
        let shape = &self.shapes[id as usize];
        self.shaped
            .entry(id)
            .or_insert_with(|| BoxEvaluators::new(shape))
    }

    /// The evaluators of the current shape.
    pub(super) fn classifiers(&mut self) -> &mut BoxEvaluators<'t> {
        self.evaluators(self.current)
    }

    /// [`Workspace::f_at`] at each of `points`, bit for bit (the batch
    /// evaluator agrees with the point evaluators), in one batch where the
    /// current shape is arithmetic, interpreted and its register file small:
    /// one dispatch per instruction for all of them rather than one per
    /// point.
    pub(super) fn f_at_grid<const N: usize>(&mut self, points: [DVec3; N]) -> [f64; N] {
        let left = self.batch_slots_left.min(MAX_BATCH_SLOTS);
        let e = self.classifiers();
        // A batch runs all `LANES` lanes: for a few points, a transcendental
        // function's work there outweighs the dispatch it saves, and machine
        // code has no dispatch to save. A batch's points count a third each
        // toward compiling the tape (they cost the interpreter a fraction of
        // its own): measured against points alone, a 1×1 render of the cube
        // minus a ball 0.966x the instructions, of the torus 0.990x; counted
        // whole, the torus's f compiled as before but the cube minus a ball's
        // shapes too (1.000x at 1024²); in batches whatever the tape, the
        // gyroid in a ball 1.018x.
        let slots = e.f.slot_count();
        let room = e.f_batch.is_some() || slots <= left;
        let batched = room && e.f.is_arithmetic();
        if !batched || e.f_point.count_evaluations((N as u32).div_ceil(3)) {
            return points.map(|p| self.f_at(p));
        }
        if e.f_batch.is_none() {
            self.batch_slots_left -= slots;
        }
        let e = self.classifiers();
        let f = e.f;
        let batch = e.f_batch.get_or_insert_with(|| BatchEvaluator::new(f));
        let [xs, ys, zs] = [0, 1, 2].map(|i| points.map(|p| p[i]));
        let mut out = [0.0; N];
        batch.eval(&[&xs, &ys, &zs], &mut [&mut out]);
        out
    }

    pub(super) fn f_at(&mut self, p: DVec3) -> f64 {
        self.classifiers()
            .f_point
            .eval_array::<1>(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0]
    }

    /// Whether f changes sign on a face this leaf shares with the bounding
    /// box, sampled on a 3×3 grid: the surface then runs into the box's wall.
    pub(super) fn surface_crosses_outer_face(&mut self, plan: &Plan, b: &Aabb) -> bool {
        for axis in 0..3 {
            for (side, outer) in [
                (b.lo[axis], plan.bounds.lo[axis]),
                (b.hi[axis], plan.bounds.hi[axis]),
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

    /// The current shape's f and ∇f over the box `b`, decorated.
    pub(super) fn f_and_gradient(&mut self, b: &Aabb) -> [DecInterval; 4] {
        let v = self.classifiers().f_grad.eval(&inputs_over(b));
        [v[0], v[1], v[2], v[3]]
    }

    /// f and ∇f over the box, and whether paths through it support a
    /// Lipschitz argument: f defined and continuous on all of it, and its
    /// (Clarke) gradient defined there.
    pub(super) fn intervals(&mut self, b: &Aabb) -> ([Interval; 4], bool) {
        let v = self.f_and_gradient(b);
        let lipschitz_ok = v[0].decoration() == Decoration::Dac && !partly_undefined(&v[1..4]);
        (
            [v[0], v[1], v[2], v[3]].map(DecInterval::interval),
            lipschitz_ok,
        )
    }

    /// Whether f's f64 values at the corners of each octant of `b` take both
    /// signs (a zero counts as both), from f on the 3×3×3 grid of their
    /// corners: 27 evaluations where the octants one by one take 64.
    pub(super) fn children_straddling(&mut self, b: &Aabb) -> [bool; 8] {
        let c = b.center();
        let coords = [b.lo, c, b.hi];
        let grid: [f64; 27] = self.f_at_grid(std::array::from_fn(|n| {
            DVec3::new(coords[n % 3].x, coords[n / 3 % 3].y, coords[n / 9].z)
        }));
        std::array::from_fn(|k| {
            let (mut neg, mut pos) = (false, false);
            for corner in 0..8 {
                let i = (k & 1) + (corner & 1);
                let j = (k >> 1 & 1) + (corner >> 1 & 1);
                let l = (k >> 2 & 1) + (corner >> 2 & 1);
                let v = grid[i + 3 * j + 9 * l];
                neg |= v <= 0.0;
                pos |= v >= 0.0;
            }
            neg && pos
        })
    }

    /// `straddles`: whether the corners' values take both signs, if known.
    pub(super) fn classify(&mut self, plan: &Plan, b: &Aabb, straddles: Option<bool>) -> Class {
        // Corners that straddle the surface: it is certainly inside.
        let straddles = straddles.unwrap_or_else(|| {
            let corners: [f64; 8] = self.f_at_grid(std::array::from_fn(|k| {
                DVec3::new(
                    if k & 1 == 0 { b.lo.x } else { b.hi.x },
                    if k & 2 == 0 { b.lo.y } else { b.hi.y },
                    if k & 4 == 0 { b.lo.z } else { b.hi.z },
                )
            }));
            corners.iter().any(|&v| v <= 0.0) && corners.iter().any(|&v| v >= 0.0)
        });
        if straddles {
            return Class::Possible(None);
        }
        // Proofs of emptiness cover the padded box, so that rays whose
        // rounded crossings stray into it skip nothing.
        let b = &padded(b, plan.pad);
        // f's enclosure alone first: the boxes it prunes (most of those
        // pruned) never need ∇f, whose tape is two to four times f's. The
        // same boxes are pruned in either order.
        let f = self.classifiers().f_interval.eval(&inputs_over(b))[0].interval();
        if f.is_empty() || !f.contains(0.0) {
            return Class::PrunedByInterval;
        }
        // Where the box's shape leaves a branch point open, ∇f's enclosure
        // is the hull of its branches' gradients, and the L-test it feeds
        // pruned nothing on the models and CSG shapes measured (fidget's bear
        // and prospero slab, the corpus's CSG), while ∇f cost a fifth of the
        // bear's build: such boxes go on with f's enclosure alone (sound
        // either way: the L-test only prunes).
        if self
            .shapes
            .get(self.current as usize)
            .is_some_and(|s| s.open > 0)
        {
            return Class::Possible(None);
        }
        let v = self.f_and_gradient(b);
        let lipschitz_ok = v[0].decoration() == Decoration::Dac && !partly_undefined(&v[1..4]);
        let [_, gx, gy, gz] = v.map(DecInterval::interval);
        // The L-test argues along the segment from x₀ to any root, so f must be
        // defined and continuous on the whole box; where it is not, only the
        // interval decides.
        if lipschitz_ok && [gx, gy, gz].iter().all(|g| g.is_bounded()) {
            let l = lipschitz([gx, gy, gz].map(|g| g.mag()));
            let f0 = self.centre_enclosure(b.center());
            let ld = (Interval::point(l) * half_diagonal(b)).sup();
            if !f0.is_empty() && f0.mig() > ld {
                return Class::PrunedByLipschitz;
            }
        }
        Class::Possible(Some(v))
    }

    /// Whether shape `shape`'s Lipschitz bound L over `b` (padded) is tight
    /// ([`TIGHT_RATIO`], [`FLAT_RATIO`]).
    pub(super) fn is_tight(&mut self, plan: &Plan, b: &Aabb, shape: u32) -> bool {
        self.current = shape;
        let ([_, gx, gy, gz], ok) = self.intervals(&padded(b, plan.pad));
        let g = [gx, gy, gz];
        if !ok || !g.iter().all(|g| g.is_bounded()) {
            return false;
        }
        let l = lipschitz(g.map(|g| g.mag()));
        // ∇f that swings across the box (an oscillation, a fold) is not
        // tight, whatever its value at the centre.
        if lipschitz(g.map(|g| g.wid())) > FLAT_RATIO * l {
            return false;
        }
        let v = self.classifiers().f_grad.eval(&point_inputs(b.center()));
        let least = DVec3::new(
            v[1].interval().mig(),
            v[2].interval().mig(),
            v[3].interval().mig(),
        );
        l <= TIGHT_RATIO * least.length()
    }

    pub(super) fn centre_enclosure(&mut self, p: DVec3) -> Interval {
        self.classifiers().f_interval.eval(&point_inputs(p))[0].interval()
    }

    /// The branch each branch point takes over the padded box `b`, with those
    /// its parent took (`inherited`), into `out` (all open for a formula with
    /// none). A branch is taken where it is the formula's value on the whole
    /// box, or, at a `max` (`min`) at the root, where the other side is below
    /// (above) 0 on the whole box: the formula there is not f but has f's
    /// sign everywhere in the box, so it has the same surface, and rays find
    /// the same first root in it. (Leaves see shapes; only their signs are
    /// certified, and their bounds are the shape's own.)
    ///
    /// With `open`, the tape of the operands the parent left open and live
    /// (and its evaluator), from which the enclosures come: points it does
    /// not hold, cut off from the root already, stay open, as [`normalise`]
    /// would leave them.
    ///
    /// [`normalise`]: crate::expr::specialise::normalise
    pub(super) fn branches(
        &mut self,
        plan: &Plan,
        b: &Aabb,
        inherited: &[Branch],
        open: Option<(&OpenOperands, &mut DecoratedEvaluator)>,
        out: &mut Vec<Branch>,
    ) {
        out.clear();
        if plan.points.is_empty() {
            return;
        }
        let inputs = inputs_over(&padded(b, plan.pad));
        let (values, starts) = match open {
            Some((open, evaluator)) => (evaluator.eval(&inputs), open.starts.as_slice()),
            None => (self.operands.eval(&inputs), plan.starts.as_slice()),
        };
        // Each point's operands' enclosures, where all are defined: dropping
        // a branch must not drop where f is undefined.
        let enclosures = |k: usize| {
            let p = &plan.points[k];
            let start = starts[k];
            if start == usize::MAX {
                return None;
            }
            let ops = &values[start..start + p.operands().len()];
            let mut enclosures = [Interval::EMPTY; 3];
            for (e, v) in enclosures.iter_mut().zip(ops) {
                *e = v.interval();
            }
            let defined = ops.iter().all(|v| v.decoration() >= Decoration::Def);
            defined.then_some(enclosures)
        };
        out.extend(
            plan.points
                .iter()
                .zip(inherited)
                .enumerate()
                .map(|(k, (p, &parent))| match parent {
                    Branch::Open => {
                        enclosures(k).map_or(Branch::Open, |e| p.decide(&e[..p.operands().len()]))
                    }
                    parent => parent,
                }),
        );
        // Each decision at the root may bring another max or min to it: one
        // the parent left open and live (the walk to it passes decided
        // points only), so the open operands hold its operands.
        let (ctx, points, index) = (plan.formula.context(), &plan.points, &plan.index);
        let mut split = RootSplit::of(ctx, plan.formula.f(), points, index, out);
        while let Some(s) = split {
            let branch = enclosures(s.point).map_or(Branch::Open, |e| s.sign_branch(e[0], e[1]));
            if branch == Branch::Open {
                break;
            }
            out[s.point] = branch;
            split = s.then(ctx, points, index, out);
        }
    }
}

/// Which branch points the pattern `branches` leaves open and reachable
/// from f's root: those a box of that shape can still decide.
pub(super) fn live_points(plan: &Plan, branches: &[Branch]) -> Vec<bool> {
    let (ctx, root) = (plan.formula.context(), plan.formula.f());
    live_open(ctx, root, &plan.points, &plan.index, branches)
}

/// The operands of the branch points a box's parent left open, with the
/// code that the parent's box settles taken out: what settling each of
/// its children needs, where the whole operands tape computes every
/// point's operands (the prospero slab's 2,880 points, 6,347
/// instructions; 295 on average for the boxes of its last level). The
/// same enclosures of those operands over any part of the parent's box:
/// a `min`, `max`, `abs` or `choose`
/// that a box settles has its taken operand's enclosure over the box and
/// over any part of it, as an extended interval, not merely a value that
/// holds it. The decorations are no weaker (a settled `choose` drops the
/// decoration of the branch it never reads), so only a `choose` that hides
/// an undefined branch may settle a point the whole tape leaves open.
pub(super) struct OpenOperands {
    tape: Tape,
    /// Where each open point's operands start among the tape's outputs
    /// (`usize::MAX` for the others).
    starts: Vec<usize>,
}

impl OpenOperands {
    /// The open operands of the children of the box `parent`, whose shape
    /// leaves the points `live` open and reachable ([`live_points`]), from
    /// those `parent` was settled by (`source`; `None`: the whole operands
    /// tape); `None` where the whole tape is to be used, as more than half
    /// the points are live.
    pub(super) fn of(
        plan: &Plan,
        source: Option<&OpenOperands>,
        live: &[bool],
        parent: &Aabb,
    ) -> Option<OpenOperands> {
        let (base, base_starts) = match source {
            Some(s) => (&s.tape, s.starts.as_slice()),
            None => (&plan.operands, plan.starts.as_slice()),
        };
        // A point live here is live in every box above (each settles no
        // less than its parent): its operands are among the source's.
        if live
            .iter()
            .zip(base_starts)
            .any(|(&live, &start)| live && start == usize::MAX)
        {
            debug_assert!(false, "a live point missing from its parent's tape");
            return Self::of(plan, None, live, parent);
        }
        if source.is_none() && 2 * live.iter().filter(|&&l| l).count() > live.len() {
            return None;
        }
        let mut keep = vec![false; base.output_count()];
        let mut at = 0;
        let starts = plan
            .points
            .iter()
            .zip(live.iter().zip(base_starts))
            .map(|(p, (&live, &start))| {
                let n = p.operands().len();
                if !live {
                    return usize::MAX;
                }
                keep[start..start + n].iter_mut().for_each(|k| *k = true);
                at += n;
                at - n
            })
            .collect();
        let settled = base.settled_over(&inputs_over(&padded(parent, plan.pad)));
        let tape = base.shortened_keeping(&settled, &keep);
        Some(OpenOperands { tape, starts })
    }

    /// A decorated evaluator of the tape.
    pub(super) fn evaluator(&self) -> DecoratedEvaluator<'_> {
        DecoratedEvaluator::new(&self.tape)
    }
}

pub(super) fn half_diagonal(b: &Aabb) -> Interval {
    let [x, y, z] = [0, 1, 2].map(|i| Interval::point(b.hi[i]) - Interval::point(b.lo[i]));
    (x.powi(2) + y.powi(2) + z.powi(2)).sqrt() * Interval::point(0.5)
}

/// `sqrt(a² + b² + c²)` rounded up.
pub(super) fn lipschitz(m: [f64; 3]) -> f64 {
    crate::types::interval::norm_sup(m)
}
