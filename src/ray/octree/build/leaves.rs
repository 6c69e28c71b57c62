//! The leaves a level makes, and their bounds: each as it is made, or,
//! for a creased leaf of the whole formula, from its short tape once the
//! tree is built.

use super::{Builder, ToLeaf};
use crate::expr::Tape;
use crate::ray::octree::classify::*;
use crate::ray::octree::cost::leaf_cost;
use crate::ray::octree::leaf::*;
use crate::ray::octree::node::NodeId;
use crate::ray::octree::options::BuildOptions;
use crate::ray::octree::shapes::Split;
use crate::ray::octree::short::ShortTapes;
use crate::types::DecInterval;
use rayon::prelude::*;
use std::num::NonZeroU32;

/// A creased leaf of the whole formula whose bounds wait for its short tape
/// (see [`Builder::bound_whole_leaves`]): its index, and what it was to be
/// made from (its [`ToLeaf`], and f and ∇f where its classification
/// enclosed them).
pub(super) type Waiting = (usize, ToLeaf, Option<[DecInterval; 4]>);

impl Builder<'_> {
    /// Records `leaf` as node `id`'s, with its two sides where it has them.
    pub(super) fn push_leaf(
        &mut self,
        id: NodeId,
        leaf: Leaf,
        on_face: bool,
        open: usize,
        two: Option<SplitLeaf>,
    ) {
        self.stats.leaves += 1;
        self.stats.leaves_on_faces += usize::from(on_face);
        self.stats.specialised += usize::from(leaf.shape != 0);
        self.stats.creased += usize::from(open > 0);
        if let Some(two) = two {
            record_split(&mut self.splits, &mut self.split_of, self.leaves.len(), two);
            self.stats.split += 1;
        }
        self.leaves.push(leaf);
        self.nodes[id as usize].leaf = NonZeroU32::new(self.leaves.len() as u32);
    }

    /// Makes leaves of the boxes in `finals`, with their bounds; creased
    /// leaves that are the larger or smaller of two smooth sides also get
    /// each side's bounds (their shapes compiled first).
    pub(super) fn make_leaves(&mut self, finals: &[ToLeaf]) {
        let BuildOptions {
            leaf_bounds,
            specialise,
            ..
        } = self.options;
        let list = &self.shapes.list;
        self.stats.work += finals
            .iter()
            .map(|f| leaf_cost(self.plan, &list[f.2 as usize]))
            .sum::<u64>();
        let (plan, nodes, known) = (self.plan, &self.nodes, &self.known);
        // A creased leaf of the whole formula (one past the shapes) waits
        // for the tree: its bounds come from its short tape, whose walk
        // follows the live code, not from the whole formula over its box.
        // Not one that may split into two smooth sides. (Without shapes,
        // branch points are not counted: every leaf of the whole waits.)
        let waits = |shape: u32, open: usize| {
            self.options.short_tapes && shape == 0 && (!specialise || open > 1)
        };
        let pool = Workspaces::new(plan, &self.shapes.list);
        let leaves: Vec<(Leaf, bool)> = finals
            .par_iter()
            .map_init(
                || pool.lend(),
                |ws, &(id, rounding, shape, open, parent)| {
                    if !leaf_bounds {
                        return (Leaf::unknown(shape), false);
                    }
                    let b = &nodes[id as usize].bounds;
                    if waits(shape, open) {
                        return (Leaf::unknown(shape), ws.surface_crosses_outer_face(plan, b));
                    }
                    let parent = parent.map(|p| (p, nodes[p as usize].bounds));
                    let known = known.get(&id).filter(|k| k.0 == shape).map(|k| &k.1);
                    ws.leaf(plan, b, (rounding, parent), (shape, open), known)
                },
            )
            .collect();
        if leaf_bounds {
            let first = self.leaves.len();
            let waiting = finals.iter().enumerate().filter(|(_, f)| waits(f.2, f.3));
            self.waiting.extend(waiting.map(|(i, &to_leaf)| {
                let known = self.known.get(&to_leaf.0).filter(|k| k.0 == 0).map(|k| k.1);
                (first + i, to_leaf, known)
            }));
        }
        let formula = plan.formula;
        let split: Vec<(usize, Split)> = finals
            .iter()
            .enumerate()
            .filter(|&(_, &(_, _, _, open, _))| leaf_bounds && specialise && open == 1)
            .filter_map(|(i, &(_, _, shape, _, _))| {
                Some((
                    i,
                    self.shapes
                        .split(formula, (&plan.points, &plan.index), shape)?,
                ))
            })
            .collect();
        let list = &self.shapes.list;
        self.stats.work += split
            .iter()
            .flat_map(|(_, s)| s.sides)
            .map(|side| leaf_cost(self.plan, &list[side as usize]))
            .sum::<u64>();
        let nodes = &self.nodes;
        let pool = Workspaces::new(plan, &self.shapes.list);
        let sides: Vec<SplitLeaf> = split
            .par_iter()
            .map_init(
                || pool.lend(),
                |ws, &(i, split)| {
                    let (id, rounding, _, _, parent) = finals[i];
                    let parent = parent.map(|p| (p, nodes[p as usize].bounds));
                    let b = &nodes[id as usize].bounds;
                    SplitLeaf {
                        larger: split.larger,
                        sides: split
                            .sides
                            .map(|side| ws.leaf(plan, b, (rounding, parent), (side, 0), None).0),
                        scale: 1.0,
                    }
                },
            )
            .collect();
        let mut sides = split.iter().map(|s| s.0).zip(sides).peekable();
        for (i, (&(id, _, _, open, _), (leaf, on_face))) in finals.iter().zip(leaves).enumerate() {
            let two = sides.next_if(|s| s.0 == i).map(|(_, two)| two);
            self.push_leaf(id, leaf, on_face, open, two);
        }
    }

    /// The short tapes of the leaves of the whole formula, and the bounds
    /// of its creased leaves that wait for them ([`Builder::waiting`]):
    /// from their short tapes where they get one, else (and for a leaf
    /// whose ∇f does not jump there) from the whole formula, as any leaf.
    pub(super) fn bound_whole_leaves(&mut self) -> ShortTapes {
        let plan = self.plan;
        // Leaves of the whole formula past the compiled shapes (or all, with
        // specialisation off) get short tapes; with shapes to spare, a leaf
        // of the whole formula settled nothing.
        let unserved = !self.options.specialise || self.shapes.full();
        let mut waiting: Vec<Option<ToLeaf>> = vec![None; self.leaves.len()];
        for &(i, to_leaf, _) in &self.waiting {
            waiting[i] = Some(to_leaf);
        }
        let nodes = &self.nodes;
        let parent_box = |parent: Option<NodeId>| parent.map(|p| (p, nodes[p as usize].bounds));
        let pool = Workspaces::new(plan, &self.shapes.list);
        let (short, made) = if self.options.short_tapes && self.options.leaf_bounds && unserved {
            let bounds = |ws: &mut Lent, i: usize, short: (&Tape, bool)| {
                let (id, rounding, _, _, parent) = waiting[i]?;
                let b = &nodes[id as usize].bounds;
                ws.whole_leaf_from_short(plan, b, (rounding, parent_box(parent)), short)
            };
            let (formula, shapes) = (plan.formula, self.shapes.list.as_slice());
            let walk = (|| pool.lend(), bounds);
            ShortTapes::build(nodes, &self.leaves, (formula, shapes), plan.pad, walk)
        } else {
            (ShortTapes::default(), Vec::new())
        };
        let mut bounded = vec![false; self.leaves.len()];
        for (i, leaf) in made {
            self.leaves[i] = leaf;
            bounded[i] = true;
        }
        let rest: Vec<&Waiting> = self.waiting.iter().filter(|w| !bounded[w.0]).collect();
        let rest: Vec<(usize, Leaf)> = rest
            .par_iter()
            .map_init(
                || pool.lend(),
                |ws, &&(i, (id, rounding, shape, open, parent), known)| {
                    let b = &nodes[id as usize].bounds;
                    let over_parents = (rounding, parent_box(parent));
                    (
                        i,
                        ws.leaf(plan, b, over_parents, (shape, open), known.as_ref())
                            .0,
                    )
                },
            )
            .collect();
        for (i, leaf) in rest {
            self.leaves[i] = leaf;
        }
        short
    }
}
