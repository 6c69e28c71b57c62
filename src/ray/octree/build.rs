//! The level-by-level build of an octree.

use super::classify::*;
use super::cost::*;
use super::frame::*;
use super::hull::*;
use super::leaf::*;
use super::node::*;
use super::options::*;
use super::pad::*;
use super::shapes::*;
use super::{Octree, OctreeStats, WholeBounds};
use crate::expr::along::AlongLine;
use crate::expr::specialise::{Branch, PointIndex};
use crate::expr::Tape;
use crate::formula::Formula;
use crate::ray::closed::affine::Affine;
use crate::ray::closed::polynomial::Polynomial;
use crate::types::interval::Decoration;
use crate::types::Aabb;
use crate::types::DecInterval;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::num::NonZeroU32;
use std::sync::Arc;

mod leaves;
use leaves::Waiting;

/// What a subdivided box hands its children: rounding bounds (near the
/// requested depth) and whether each child's corners straddle the surface.
pub(super) type Inherited = (Option<(f64, f64)>, [bool; 8], Option<Leaf>);

/// A box to classify.
#[derive(Clone, Copy)]
pub(super) struct Task {
    pub(super) id: NodeId,
    /// The box this one was split from.
    pub(super) parent: Option<NodeId>,
    /// Rounding bounds of f and g over the parent's box, for leaves-to-be.
    pub(super) rounding: Option<(f64, f64)>,
    /// Whether f's f64 values at the box's corners take both signs, when the
    /// parent's grid already says.
    pub(super) straddles: Option<bool>,
    /// The shape its parent saw: the branches settled there hold here too.
    pub(super) shape: u32,
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
        Self::build_with(formula, bounds, &BuildOptions::to_depth(depth))
    }

    /// [`Octree::build`] with every limit chosen.
    pub fn build_with(formula: &Formula, bounds: &Aabb, options: &BuildOptions) -> Octree {
        crate::ray::awake::with_workers_awake(|| Self::build_in_pool(formula, bounds, options))
    }

    /// [`Octree::build_with`], with the pool's workers awake.
    fn build_in_pool(formula: &Formula, bounds: &Aabb, options: &BuildOptions) -> Octree {
        let whole = Shape::new(formula);
        let plan = Plan::new(formula, &whole, bounds, options.specialise);
        let padded_root = padded(bounds, plan.pad);
        // One enclosure of the whole formula over the padded box for both.
        let over = local_over(&whole, &padded_root);
        let affine = over
            .as_deref()
            .and_then(|over| affine_form(&whole, over, &padded_root));
        let shapes = Shapes {
            quadratic: vec![over.as_deref().is_some_and(quadratic_over)],
            bounds: padded_root,
            list: vec![whole.clone()],
            patterns: vec![vec![Branch::Open; plan.points.len()]],
            ids: FxHashMap::default(),
            remembered: FxHashMap::default(),
            splits: FxHashMap::default(),
            instructions: 0,
            closed: false,
            unworthy: Default::default(),
            normalised: FxHashMap::default(),
        };
        let mut builder = Builder::new(&plan, options, shapes);
        builder.subdivide();
        builder.finish(affine)
    }
}

impl<'t> Plan<'t> {
    /// What every box of a build of `formula` over `bounds` reads: its
    /// branch points (none unless `specialise`) and their operands.
    fn new(formula: &'t Formula, whole: &'t Shape, bounds: &Aabb, specialise: bool) -> Plan<'t> {
        let points = if specialise {
            formula.branch_points()
        } else {
            Vec::new()
        };
        let operand_nodes: Vec<_> = points.iter().flat_map(|p| p.operands().to_vec()).collect();
        Plan {
            formula,
            whole,
            operands: Tape::new(formula.context(), &operand_nodes),
            index: PointIndex::new(&points),
            starts: points
                .iter()
                .scan(0, |at, p| {
                    let start = *at;
                    *at += p.operands().len();
                    Some(start)
                })
                .collect(),
            points,
            pad: pad_for(bounds),
            bounds: *bounds,
        }
    }
}

/// A kept box to subdivide: its id, shape, open branch points, the
/// rounding bounds it hands its children, and its parent (for when the
/// budget makes it a leaf after all).
type ToSubdivide = (NodeId, u32, usize, Option<(f64, f64)>, Option<NodeId>);

/// A kept box to make a leaf of: its id, inherited rounding bounds, shape,
/// open branch points and parent.
type ToLeaf = (NodeId, Option<(f64, f64)>, u32, usize, Option<NodeId>);

/// One octree build under way: what every level reads, and what the levels
/// so far have made.
struct Builder<'a> {
    plan: &'a Plan<'a>,
    options: BuildOptions,
    shapes: Shapes,
    /// The frame being found on the way (see [`BuildOptions::frame_depth`]).
    frame: Option<Frame>,
    splits: Vec<SplitLeaf>,
    split_of: Vec<u32>,
    stats: OctreeStats,
    nodes: Vec<OctreeNode>,
    leaves: Vec<Leaf>,
    start_bounds: Vec<Leaf>,
    /// This level's boxes whose classification evaluated f and ∇f, with
    /// the shape they were of and the enclosures.
    known: FxHashMap<NodeId, (u32, [DecInterval; 4])>,
    /// The open operands each box of the last level was settled by (see
    /// [`OpenOperands`]): its children's are that tape shortened again.
    settled_with: FxHashMap<NodeId, Arc<OpenOperands>>,
    /// Creased leaves of the whole formula, bounded once the tree is done.
    waiting: Vec<Waiting>,
}

impl<'a> Builder<'a> {
    fn new(plan: &'a Plan<'a>, options: &BuildOptions, shapes: Shapes) -> Builder<'a> {
        let (classify_cost, leaf_cost) = (classify_cost(plan.whole), leaf_cost(plan, plan.whole));
        // The frame: a framing tree classifies every box this one does down
        // to its depth, the same way (a box's shape comes from its parent's
        // settled branches in both), and the children of boxes this one
        // keeps early as leaves. It is found here unless a budget could
        // stop either tree before that depth (then it is left to a build of
        // its own): this one's, seen on the way; the framing tree's, known
        // from the start where all its boxes at the whole formula's cost
        // fit, or else where this tree keeps no leaf early (see
        // [`Frame::budget_known`]).
        let BuildOptions {
            depth,
            max_work,
            frame_depth,
            ..
        } = *options;
        let framing_boxes = frame_depth.map_or(0, |fd| (0..=fd).map(|l| 8u64.pow(l)).sum());
        let frame = frame_depth
            .filter(|&fd| fd < depth && framing_boxes <= MAX_NODES as u64)
            .map(|fd| Frame {
                depth: fd,
                hull: None,
                below_leaves: Vec::new(),
                budget_known: (classify_cost + leaf_cost).saturating_mul(framing_boxes) <= max_work,
            });
        Builder {
            plan,
            options: *options,
            shapes,
            frame,
            splits: Vec::new(),
            split_of: Vec::new(),
            stats: OctreeStats::default(),
            nodes: vec![OctreeNode::new(plan.bounds)],
            leaves: Vec::new(),
            start_bounds: Vec::new(),
            known: FxHashMap::default(),
            settled_with: FxHashMap::default(),
            waiting: Vec::new(),
        }
    }

    /// Level by level, each level's boxes in parallel: classifies the boxes
    /// of a level, makes leaves of those that stop there, and subdivides the
    /// others, until no box is left or a budget would be exceeded.
    fn subdivide(&mut self) {
        // Nodes still to classify, each with the rounding bounds of f and g
        // over its parent's box when it is a leaf-to-be (those hold for it
        // too: one evaluation per eight leaves).
        let mut level_nodes: Vec<Task> = vec![Task {
            id: 0,
            parent: None,
            rounding: None,
            straddles: None,
            shape: 0,
        }];
        let mut level = 0u32;
        while !level_nodes.is_empty() {
            let possible = self.classify_level(&level_nodes, level);
            let (mut finals, mut further) = self.settle_shapes(&possible, level);
            let mut tight = self.take_tight(&mut further, level);
            self.take_quadric_leaves(&mut further, level);
            let fits = self.next_level_fits(&further, level);
            if self.frame.as_ref().is_some_and(|f| level < f.depth) && (!fits || !finals.is_empty())
            {
                self.frame = None;
            }
            finals.append(&mut tight);
            if !fits {
                // Everything left becomes a leaf, with the shape it sees.
                for (id, shape, open, rounding, parent) in further.drain(..) {
                    finals.push((id, rounding, shape, open, parent));
                }
            }
            self.make_leaves(&finals);
            if !fits {
                break;
            }
            level_nodes = self.children(&further, level);
            level += 1;
        }
        // No level settles more boxes.
        self.settled_with = FxHashMap::default();
    }

    /// The boxes of one level that may hold the surface; each is classified
    /// by the formula as its parent saw it (the parent's settled branches
    /// hold on it too).
    fn classify_level(&mut self, level_nodes: &[Task], level: u32) -> Vec<Task> {
        self.known.clear();
        let list = &self.shapes.list;
        self.stats.work += level_nodes
            .iter()
            .map(|t| classify_cost(&list[t.shape as usize]))
            .sum::<u64>();
        let (plan, nodes) = (self.plan, &self.nodes);
        let pool = Workspaces::new(plan, &self.shapes.list);
        let classes: Vec<Class> = level_nodes
            .par_iter()
            .map_init(
                || pool.lend(),
                |ws, task| {
                    ws.current = task.shape;
                    ws.classify(plan, &nodes[task.id as usize].bounds, task.straddles)
                },
            )
            .collect();
        let mut possible = Vec::new();
        for (task, class) in level_nodes.iter().zip(classes) {
            match class {
                Class::Possible(v) => {
                    if let Some(v) = v {
                        self.known.insert(task.id, (task.shape, v));
                    }
                    if let Some(frame) = self.frame.as_mut().filter(|f| f.depth == level) {
                        frame.keep(&self.nodes[task.id as usize].bounds);
                    }
                    possible.push(*task);
                }
                Class::PrunedByLipschitz => self.stats.pruned_by_lipschitz += 1,
                Class::PrunedByInterval => self.stats.pruned_by_interval += 1,
            }
        }
        possible
    }

    /// The shape each kept box and its children see (the branches it
    /// settles, with its parent's), and whether it stops here: the boxes to
    /// make leaves of and those to subdivide. Past the requested depth, boxes
    /// a crease may still cross go on for a few levels: most of them then
    /// settle their branches.
    fn settle_shapes(&mut self, possible: &[Task], level: u32) -> (Vec<ToLeaf>, Vec<ToSubdivide>) {
        let formula = self.plan.formula;
        let poles = self.poles(possible, level);
        let (plan, nodes, shapes) = (self.plan, &self.nodes, &self.shapes);
        let settling = possible
            .iter()
            .filter(|t| shapes.list[t.shape as usize].open > 0)
            .count() as u64;
        self.stats.work += cost(&plan.operands) * settling;
        // The operands each parent left open, over its box, once a parent,
        // from those it was settled by.
        let mut parents: Vec<(NodeId, u32)> = possible
            .iter()
            .filter(|t| shapes.list[t.shape as usize].open > 0)
            .filter_map(|t| Some((t.parent?, t.shape)))
            .collect();
        parents.sort_unstable();
        parents.dedup();
        let mut parent_shapes: Vec<u32> = parents.iter().map(|&(_, shape)| shape).collect();
        parent_shapes.sort_unstable();
        parent_shapes.dedup();
        let live: FxHashMap<u32, Vec<bool>> = parent_shapes
            .par_iter()
            .map(|&shape| (shape, live_points(plan, &shapes.patterns[shape as usize])))
            .collect();
        let settled_with = std::mem::take(&mut self.settled_with);
        let open_operands: FxHashMap<NodeId, Arc<OpenOperands>> = parents
            .par_iter()
            .filter_map(|&(parent, shape)| {
                let source = settled_with.get(&parent).map(|o| &**o);
                let b = &nodes[parent as usize].bounds;
                let open = OpenOperands::of(plan, source, &live[&shape], b)?;
                Some((parent, Arc::new(open)))
            })
            .collect();
        drop(settled_with);
        self.settled_with = possible
            .iter()
            .filter_map(|t| Some((t.id, open_operands.get(&t.parent?)?.clone())))
            .collect();
        // Patterns seen before are looked up here, in parallel; only new
        // ones are kept for [`Shapes::id`].
        let pool = Workspaces::new(plan, &[]);
        let settled: Vec<Settled> = possible
            .par_iter()
            .map_init(
                || (pool.lend(), Vec::new(), FxHashMap::default()),
                |(ws, pattern, evaluators), task| {
                    if shapes.list[task.shape as usize].open == 0 {
                        return Settled::Inherited;
                    }
                    let inherited = &shapes.patterns[task.shape as usize];
                    let b = &nodes[task.id as usize].bounds;
                    let open = task.parent.and_then(|parent| {
                        let o = open_operands.get(&parent)?;
                        let evaluator = evaluators.entry(parent).or_insert_with(|| o.evaluator());
                        Some((&**o, evaluator))
                    });
                    ws.branches(plan, b, inherited, open, pattern);
                    match shapes.known(pattern) {
                        Some((shape, open)) => Settled::Known(shape, open),
                        None => Settled::New(pattern.clone()),
                    }
                },
            )
            .collect();
        let new: Vec<&[Branch]> = settled
            .iter()
            .filter_map(|s| match s {
                Settled::New(pattern) => Some(pattern.as_slice()),
                _ => None,
            })
            .collect();
        self.shapes
            .compile(formula, (&plan.points, &plan.index), &new);
        let BuildOptions {
            depth,
            crease_levels,
            ..
        } = self.options;
        let mut finals = Vec::new();
        let mut further = Vec::new();
        for ((task, pattern), pole) in possible.iter().zip(settled).zip(poles) {
            let (shape, open) = match pattern {
                Settled::New(pattern) => {
                    self.shapes
                        .id(formula, (&plan.points, &plan.index), &pattern)
                }
                Settled::Known(shape, open) => (shape, open),
                Settled::Inherited => (task.shape, self.shapes.list[task.shape as usize].open),
            };
            let (id, rounding, parent) = (task.id, task.rounding, task.parent);
            if level < depth || (open > 0 && (level < depth + crease_levels || pole)) {
                further.push((id, shape, open, rounding, parent));
            } else {
                finals.push((id, rounding, shape, open, parent));
            }
        }
        (finals, further)
    }

    /// Whether each box of `possible` at `level` goes on as a pole box (see
    /// [`POLE_LEVELS`]): past the crease levels, within the pole levels, a
    /// creased box where f may be undefined.
    fn poles(&mut self, possible: &[Task], level: u32) -> Vec<bool> {
        let o = &self.options;
        let (plan, nodes, list) = (self.plan, &self.nodes, &self.shapes.list);
        let past = o.depth + o.crease_levels;
        let levels = if o.leaf_bounds { o.pole_levels } else { 0 };
        if !(level >= past && level < past + levels) {
            return vec![false; possible.len()];
        }
        self.stats.work += possible
            .iter()
            .filter(|t| list[t.shape as usize].open > 0)
            .map(|t| cost(&list[t.shape as usize].f))
            .sum::<u64>();
        let pool = Workspaces::new(plan, list);
        possible
            .par_iter()
            .map_init(
                || pool.lend(),
                |ws, task| {
                    if list[task.shape as usize].open == 0 {
                        return false;
                    }
                    ws.current = task.shape;
                    let b = padded(&nodes[task.id as usize].bounds, plan.pad);
                    let f = ws.classifiers().f_interval.eval(&inputs_over(&b))[0];
                    f.decoration() != Decoration::Dac
                },
            )
            .collect()
    }

    /// Takes out of `further` the smooth boxes whose Lipschitz bound is
    /// already tight (see [`TIGHT_RATIO`]): leaves here. Like quadrics'
    /// boxes, they settle no more branches, so a frame sees their children
    /// as their shape.
    fn take_tight(&mut self, further: &mut Vec<ToSubdivide>, level: u32) -> Vec<ToLeaf> {
        let mut tight_finals = Vec::new();
        let o = &self.options;
        if !(o.tight_leaves && o.leaf_bounds && level >= TIGHT_LEVEL && level < o.depth) {
            return tight_finals;
        }
        let (plan, nodes) = (self.plan, &self.nodes);
        let (quadratic, list) = (&self.shapes.quadratic, &self.shapes.list);
        self.stats.work += further
            .iter()
            .map(|f| 2 * cost(&list[f.1 as usize].f_grad))
            .sum::<u64>();
        let pool = Workspaces::new(plan, list);
        let tight: Vec<bool> = further
            .par_iter()
            .map_init(
                || pool.lend(),
                |ws, &(id, shape, open, _, _)| {
                    open == 0
                        && !quadratic[shape as usize]
                        && list[shape as usize].algebraic
                        && ws.is_tight(plan, &nodes[id as usize].bounds, shape)
                },
            )
            .collect();
        let mut kept = Vec::with_capacity(further.len());
        for (f, tight) in further.drain(..).zip(tight) {
            if !tight {
                kept.push(f);
                continue;
            }
            if let Some(frame) = self.frame.as_mut().filter(|f| level < f.depth) {
                let b = self.nodes[f.0 as usize].bounds;
                frame.below_leaves.push((b, f.1, level));
            }
            self.stats.tight += 1;
            tight_finals.push((f.0, f.3, f.1, f.2, None));
        }
        *further = kept;
        tight_finals
    }

    /// Makes leaves at once of the boxes in `further` where f is at most
    /// quadratic, and of the creased boxes near the requested depth whose
    /// two sides are.
    ///
    /// Boxes where f is at most quadratic are leaves already, from the root
    /// down: smaller boxes would not tighten the tests that decide rays
    /// there, only make rays cross more leaves. (Along a ray F is then a
    /// quadratic whose |F″| is G itself, and the second-order test halves a
    /// leaf as well as the octree would; measured, a sphere took 0.82x the
    /// instructions of stopping at level 3.) So are creased boxes one level
    /// above the requested depth, or at it, whose formula is the larger or
    /// smaller of two such sides (a CSG of quadrics along its seam): each
    /// piece of a ray runs the tests of the side it is proved to be on.
    /// (Instructions at 384², with the second-order side test, against
    /// leaves at the depth without it: one level early, 0.91–0.94x on the
    /// CSG shapes; at any level, the ball cut by a plane 0.85x but the cube
    /// minus a ball 1.02x, whose rays then cross the hole's rim for long
    /// stretches on which neither side holds.) At the depth itself such a
    /// box would otherwise go on to the crease levels, eight smaller split
    /// leaves for one: stopping there, the cube minus a ball took 0.85x the
    /// instructions at 384² and 0.98x at 1024², its build 0.69x.
    fn take_quadric_leaves(&mut self, further: &mut Vec<ToSubdivide>, level: u32) {
        let BuildOptions {
            depth,
            specialise,
            coarse_quadrics,
            ..
        } = self.options;
        if !(coarse_quadrics && level <= depth) {
            return;
        }
        let formula = self.plan.formula;
        let points = (self.plan.points.as_slice(), &self.plan.index);
        let quadric_splits: Vec<Option<Split>> = further
            .iter()
            .map(|&(_, shape, open, _, _)| {
                let split = (specialise && open == 1 && level + SPLIT_LEVELS_EARLY >= depth)
                    .then(|| self.shapes.split(formula, points, shape))
                    .flatten()?;
                let quadratic = |side: &u32| self.shapes.quadratic[*side as usize];
                split.sides.iter().all(quadratic).then_some(split)
            })
            .collect();
        let candidates = further
            .iter()
            .zip(&quadric_splits)
            .map(|(f, split)| {
                let shape_cost = leaf_cost(self.plan, &self.shapes.list[f.1 as usize]);
                match split {
                    Some(_) => 3 * shape_cost,
                    None if f.2 == 0 && self.shapes.quadratic[f.1 as usize] => shape_cost,
                    None => 0,
                }
            })
            .sum::<u64>();
        self.stats.work += candidates;
        let scale = 0.5f64.powi((depth - level) as i32);
        let (plan, nodes, shapes) = (self.plan, &self.nodes, &self.shapes);
        // The leaves are read in place where `checked` holds them: copying
        // them, a few hundred bytes each, cost a fresh page every dozen.
        let pool = Workspaces::new(plan, &shapes.list);
        let mut checked: Vec<Option<(Leaf, bool, Option<SplitLeaf>)>> = further
            .par_iter()
            .zip(&quadric_splits)
            .map_init(
                || pool.lend(),
                |ws, (&(id, shape, open, _, _), split)| {
                    let b = &nodes[id as usize].bounds;
                    if let Some(split) = split {
                        let sides = split
                            .sides
                            .map(|side| ws.leaf(plan, b, (None, None), (side, 0), None).0);
                        if !sides.iter().all(quadric_leaf) {
                            return None;
                        }
                        let (leaf, on_face) = ws.leaf(plan, b, (None, None), (shape, open), None);
                        let larger = split.larger;
                        let two = SplitLeaf {
                            larger,
                            sides,
                            scale,
                        };
                        return Some((leaf, on_face, Some(two)));
                    }
                    if open > 0 || !shapes.quadratic[shape as usize] {
                        return None;
                    }
                    let (leaf, on_face) = ws.leaf(plan, b, (None, None), (shape, 0), None);
                    quadric_leaf(&leaf).then_some((leaf, on_face, None))
                },
            )
            .collect();
        // Boxes made leaves here: their ids, open branch points and where
        // `checked` holds their leaves.
        let mut early: Vec<(NodeId, usize, usize)> = Vec::new();
        let mut kept = Vec::with_capacity(further.len());
        for (i, (f, c)) in further.drain(..).zip(&checked).enumerate() {
            match c {
                Some(_) => early.push((f.0, f.2, i)),
                None => kept.push(f),
            }
        }
        *further = kept;
        for (id, open, i) in early {
            let Some((leaf, on_face, two)) = checked[i].take() else {
                continue;
            };
            if self.frame.as_ref().is_some_and(|f| level < f.depth) {
                // A leaf whose formula is at most quadratic settles no more
                // branches: its children see its shape. (A split leaf's
                // would settle more: its frame is left to a build of its
                // own.)
                match (&mut self.frame, two.is_none()) {
                    (Some(f), true) => {
                        f.below_leaves
                            .push((self.nodes[id as usize].bounds, leaf.shape, level))
                    }
                    _ => self.frame = None,
                }
            }
            self.push_leaf(id, leaf, on_face, open, two);
        }
    }

    /// Whether subdividing the boxes of `further` keeps the tree within its
    /// budgets; where it would not, this level's boxes become the leaves
    /// (rays are then slower, never less certain).
    fn next_level_fits(&mut self, further: &[ToSubdivide], level: u32) -> bool {
        // Children are classified by their parent's shape, and most become
        // leaves of one no longer.
        let list = &self.shapes.list;
        let next_work = further
            .iter()
            .map(|f| {
                let shape = &list[f.1 as usize];
                8 * (classify_cost(shape) + leaf_cost(self.plan, shape))
            })
            .sum::<u64>();
        let fits = self.nodes.len() + 8 * further.len() <= MAX_NODES
            && self.stats.work + next_work <= self.options.max_work;
        if !fits && level < self.options.depth {
            self.stats.capped_at_depth = Some(level);
        }
        fits
    }

    /// Subdivides each box of `further` into its eight children, the tasks
    /// of the next level: each child inherits its parent's rounding bounds
    /// (near the requested depth) and whether its corners straddle the
    /// surface, from one 3×3×3 grid of f per parent.
    fn children(&mut self, further: &[ToSubdivide], level: u32) -> Vec<Task> {
        let BuildOptions {
            depth, leaf_bounds, ..
        } = self.options;
        let rounding_level = leaf_bounds && level + ROUNDING_LEVELS >= depth;
        // Three levels above the leaves, a node's own bounds serve rays that
        // start inside it (see `Octree::start_bounds`). Measured at 384²
        // with shadows: one level above cost more than it saved (the leaf's
        // test repeats where the node's fails), two saved 2 %, three 4 %
        // (torus, tangle cube), four 2–3 %.
        let start_level = leaf_bounds && level >= 1 && level + 3 == depth;
        let (plan, nodes) = (self.plan, &self.nodes);
        let pool = Workspaces::new(plan, &self.shapes.list);
        let inherited: Vec<Inherited> = further
            .par_iter()
            .map_init(
                || pool.lend(),
                |ws, &(id, shape, open, rounding, _)| {
                    let b = &nodes[id as usize].bounds;
                    // Only leaves that see the whole formula read them (a
                    // specialised shape's bounds are its own); a node's own
                    // are computed where its parent has none.
                    let rounding = (rounding_level && shape == 0)
                        .then(|| rounding.unwrap_or_else(|| ws.rounding(plan, b)));
                    let start = start_level
                        .then(|| ws.leaf(plan, b, (None, None), (shape, open), None).0)
                        .filter(|l| !l.needs_intervals && l.continuous);
                    ws.current = shape;
                    (rounding, ws.children_straddling(b), start)
                },
            )
            .collect();
        let mut next = Vec::with_capacity(8 * further.len());
        self.nodes.reserve(8 * further.len());
        for (&(id, shape, ..), (rounding, straddles, start)) in further.iter().zip(inherited) {
            if let Some(start) = start {
                self.start_bounds.push(start);
                self.nodes[id as usize].start = NonZeroU32::new(self.start_bounds.len() as u32);
            }
            let b = self.nodes[id as usize].bounds;
            let first = self.nodes.len() as NodeId;
            self.nodes[id as usize].first_child = NonZeroU32::new(first);
            for (k, child) in b.octants().iter().enumerate() {
                self.nodes.push(OctreeNode::new(*child));
                next.push(Task {
                    id: first + k as NodeId,
                    parent: Some(id),
                    rounding,
                    straddles: Some(straddles[k]),
                    shape,
                });
            }
        }
        next
    }

    /// Each kept leaf's hull, where the budget allows (at most
    /// 8 + 8² + … sub-boxes per leaf, each an evaluation of f, or of both
    /// sides of a split leaf); the leaf's box where no hull is found.
    fn hulls(&mut self) -> Vec<Aabb> {
        let BuildOptions {
            depth,
            max_work,
            leaf_bounds,
            hull_levels,
            ..
        } = self.options;
        let bounds = self.plan.bounds;
        let sub_boxes: u64 = (1..=hull_levels).map(|l| 8u64.saturating_pow(l)).sum();
        let hull_work =
            (2 * cost(&self.plan.whole.fg) * sub_boxes).saturating_mul(self.leaves.len() as u64);
        let leaf_nodes: Vec<(NodeId, usize)> = (0..self.nodes.len() as NodeId)
            .filter_map(|id| Some((id, self.nodes[id as usize].leaf_index()?)))
            .collect();
        let mut hulls = vec![bounds; self.leaves.len()];
        for &(id, i) in &leaf_nodes {
            hulls[i] = self.nodes[id as usize].bounds;
        }
        let leaf_width = (bounds.hi.x - bounds.lo.x) * 0.5f64.powi(depth as i32);
        if leaf_bounds && hull_levels > 0 && self.stats.work + hull_work <= max_work {
            self.stats.work += hull_work;
            let (plan, nodes, shapes) = (self.plan, &self.nodes, &self.shapes);
            let (splits, split_of, leaves) = (&self.splits, &self.split_of, &self.leaves);
            let found: Vec<Aabb> = leaf_nodes
                .par_iter()
                .map_init(
                    || HullFinder::new(&shapes.list, &shapes.quadratic),
                    |finder, &(id, i)| {
                        let split = split_at(splits, split_of, i);
                        let b = &nodes[id as usize].bounds;
                        // Leaves above the depth (tight ones) are large:
                        // more of them is empty.
                        let early = b.hi.x - b.lo.x > 1.5 * leaf_width;
                        finder.hull(plan, b, &leaves[i], split, hull_levels, early)
                    },
                )
                .collect();
            for (&(id, i), hull) in leaf_nodes.iter().zip(found) {
                let node = &mut self.nodes[id as usize];
                node.tight = hull != node.bounds;
                hulls[i] = hull;
            }
        }
        // A ray's range in the box is widened by its rounding, so that a
        // root on the box's wall stays in it; a hull face on the box's face
        // moves out to the padded box, or clipping to the hull would cut
        // that root off again. (Leaves' proofs hold on their padded boxes.)
        let outer = padded(&bounds, self.plan.pad);
        for hull in &mut hulls {
            for axis in 0..3 {
                if hull.lo[axis] <= bounds.lo[axis] {
                    hull.lo[axis] = outer.lo[axis];
                }
                if hull.hi[axis] >= bounds.hi[axis] {
                    hull.hi[axis] = outer.hi[axis];
                }
            }
        }
        hulls
    }

    /// Bounds of the whole formula over the whole padded box.
    fn whole_bounds(&self) -> WholeBounds {
        let (plan, bounds) = (self.plan, &self.plan.bounds);
        let mut ws = Workspace::new(plan, &[]);
        let padded_box = padded(bounds, plan.pad);
        let ([f, gx, gy, gz], continuous) = ws.intervals(&padded_box);
        let grad = [gx, gy, gz];
        WholeBounds {
            f_error: ws.rounding(plan, bounds).0,
            lipschitz: if grad.iter().all(|g| g.is_bounded()) {
                lipschitz(grad.map(|g| g.mag()))
            } else {
                f64::INFINITY
            },
            continuous: continuous && !f.is_empty(),
        }
    }

    /// The octree: nodes marked alive, the frame completed, hulls found, and
    /// a closed form for the whole formula where it has one.
    fn finish(mut self, affine: Option<Affine>) -> Octree {
        mark_alive(&mut self.nodes);
        let plan = self.plan;
        let frame = match self
            .frame
            .take()
            .filter(|f| f.budget_known || f.below_leaves.is_empty())
            .map(|f| f.complete(plan, &self.shapes.list))
        {
            None => ViewFrame::NotFound,
            Some(None) => ViewFrame::Empty,
            Some(Some(b)) => ViewFrame::Found(b),
        };
        let short = self.bound_whole_leaves();
        let hulls = self.hulls();
        let whole = self.whole_bounds();
        let polynomial = match (&affine, self.shapes.list[0].open) {
            (None, 0) if self.options.polynomial_form => {
                AlongLine::compile(&self.shapes.list[0].f).and_then(Polynomial::new)
            }
            _ => None,
        };
        let shape_instructions = self.shapes.instructions;
        let shapes = self.shapes.list;
        let mut stats = self.stats;
        stats.shapes = shapes.len();
        stats.shape_instructions = shape_instructions;
        stats.short_tapes = short.tapes.len();
        stats.short_instructions = short.instructions;
        Octree {
            nodes: self.nodes,
            leaves: self.leaves,
            hulls,
            start_bounds: self.start_bounds,
            bounds: plan.bounds,
            stats,
            pad: plan.pad,
            shapes,
            short,
            depth: self.options.depth,
            whole,
            splits: self.splits,
            split_of: self.split_of,
            frame,
            affine,
            polynomial,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::specialise::normalise;
    use glam::DVec3;

    /// Boxes settled by the operands their parent leaves open (the whole
    /// operands tape shortened over the parent's box, and that tape
    /// shortened again over the next box down) take the shapes the whole
    /// operands tape gives them, three levels down.
    #[test]
    fn boxes_settled_by_their_parents_open_operands_get_the_same_shapes() {
        // Twelve balls in a ring, their union cut by a slab: 13 branch
        // points, most settled in small boxes.
        let ring = (0..12).map(|i| {
            let a = f64::from(i) * std::f64::consts::PI / 6.0;
            let (c, s) = (0.7 * a.cos(), 0.7 * a.sin());
            format!("(x-({c}))^2+(y-({s}))^2+z^2-0.04")
        });
        let union = ring.reduce(|u, b| format!("min({u}, {b})")).unwrap();
        let f = Formula::parse(&format!("max({union}, abs(z)-0.1)")).unwrap();
        let bounds = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        let whole = Shape::new(&f);
        let plan = Plan::new(&f, &whole, &bounds, true);
        let mut ws = Workspace::new(&plan, &[]);
        let mut counts = [0usize; 2];
        check(
            &plan,
            &mut ws,
            &bounds,
            &vec![Branch::Open; plan.points.len()],
            None,
            0,
            &mut counts,
        );
        // Boxes settled both ways, and shapes that left most points dead.
        assert!(counts[0] > 100 && counts[1] > 100, "{counts:?}");
    }

    /// Settles the children of `b` both ways and compares their shapes;
    /// counts the children settled by open operands, and those settled to
    /// a shape with a point open but dead.
    fn check(
        plan: &Plan,
        ws: &mut Workspace,
        b: &Aabb,
        inherited: &[Branch],
        source: Option<&OpenOperands>,
        level: u32,
        counts: &mut [usize; 2],
    ) {
        let (ctx, root) = (plan.formula.context(), plan.formula.f());
        let normal = |p: &[Branch]| normalise(ctx, root, &plan.points, &plan.index, p);
        let live = live_points(plan, inherited);
        let open = OpenOperands::of(plan, source, &live, b);
        let mut evaluator = open.as_ref().map(OpenOperands::evaluator);
        let (mut by_whole, mut by_open) = (Vec::new(), Vec::new());
        for child in b.octants() {
            ws.branches(plan, &child, inherited, None, &mut by_whole);
            let shape = normal(&by_whole);
            if let (Some(o), Some(e)) = (&open, &mut evaluator) {
                ws.branches(plan, &child, inherited, Some((o, e)), &mut by_open);
                assert_eq!(normal(&by_open), shape, "{child:?}");
                counts[0] += 1;
            }
            let dead = shape
                .iter()
                .zip(live_points(plan, &shape))
                .any(|(b, l)| *b == Branch::Open && !l);
            counts[1] += usize::from(dead);
            if level < 3 {
                check(plan, ws, &child, &shape, open.as_ref(), level + 1, counts);
            }
        }
    }
}
