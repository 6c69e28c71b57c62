//! The short tapes of leaves past the compiled shapes: the f and g a ray's
//! tests evaluate there, with the branches the leaf's (padded) box decides
//! taken.
//!
//! A leaf's shape settles the branch points its box settles, but shapes are
//! few ([`MAX_SHAPES`](super::MAX_SHAPES)), and past them a leaf keeps the
//! whole formula. Short tapes are cheaper to make: one interval evaluation
//! and one pass over a tape, no derivatives. The whole formula's tape of f,
//! g and ∇f is shortened from the root down, each alive node evaluating its
//! parent's short tape over its own box (so the work follows the live code,
//! not the formula's length); a leaf keeps its f and g for rays, and its
//! creased bounds (f and ∇f enclosed, f's slopes and rounding) are found on
//! the same tape. Leaves with a shape of their own need none: it was
//! specialised over the same box, by the same enclosures.
//!
//! A short tape equals the whole formula's, as a real function, on the
//! region it was found on ([`crate::expr::tape::simplify`]); the intersector
//! evaluates it only while searching its leaf, at points and over pieces
//! inside that region.

use super::cells::{box_inputs, Cells, Kept, Short};
use super::leaf::Leaf;
use super::node::{NodeId, OctreeNode};
use super::options::{MAX_SHORT_INSTRUCTIONS, SHORT_ENOUGH};
use super::pad::padded;
use super::shapes::Shape;
use crate::expr::Tape;
use crate::formula::{Formula, Output};
use crate::types::{Aabb, Interval};
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::sync::Arc;

/// No short tape: the leaf evaluates the whole formula's `fg`.
pub const NO_SHORT: u32 = u32::MAX;

/// A leaf's short tape, and the padded box it holds on.
#[derive(Debug, Clone, Copy)]
pub struct LeafShort {
    /// The leaf's box widened by the octree's pad.
    pub region: Aabb,
    /// The short tape of the whole formula there ([`NO_SHORT`]: none).
    pub tape: u32,
    /// The leaf's shape, whose tape (its short tape, or the shape's `fg`)
    /// its cells shorten.
    pub shape: u32,
}

/// The short tapes of an octree's leaves.
#[derive(Debug, Clone, Default)]
pub struct ShortTapes {
    /// The tapes, each shared by the leaves whose walk from the root
    /// settled the same branches (siblings, mostly).
    pub tapes: Vec<Arc<Tape>>,
    /// Per kept leaf (by [`OctreeNode::leaf_index`]).
    pub of_leaf: Vec<LeafShort>,
    /// Body instructions of all `tapes` (at most [`MAX_SHORT_INSTRUCTIONS`]).
    pub instructions: usize,
    /// The cells of each leaf's region, with tapes of their own (their ids
    /// past those of `tapes`), made as rays need them.
    pub cells: Cells,
}

/// Whether a tape of `len` instructions is worth keeping for a shape of
/// `long` ([`SHORT_ENOUGH`]).
fn short_enough(len: usize, long: usize) -> bool {
    len as f64 <= SHORT_ENOUGH * long as f64
}

/// A leaf's short tape as the walk finds it: shared with its siblings
/// where their boxes decide nothing more.
type Found = (usize, Arc<Tape>);

/// What one walk finds: the leaves' short tapes, and what `bounds` made of
/// them.
type Walked<L> = (Vec<Found>, Vec<(usize, L)>);

/// The outputs of the tape the walk shortens ([`whole_tape`]): f, g and ∇f.
const WALKED: usize = 5;

/// The whole formula's tape the walk shortens: f, g and ∇f, so that a leaf
/// gets its f and g for rays, and its f and ∇f for its bounds, from one
/// settling run a box.
pub(super) fn whole_tape(formula: &Formula) -> Tape {
    formula.tape(&[
        Output::F,
        Output::G,
        Output::Dfdx,
        Output::Dfdy,
        Output::Dfdz,
    ])
}

/// The walked tape's outputs f and g: a leaf's short tape for rays.
const F_AND_G: [bool; WALKED] = [true, true, false, false, false];

/// The walked tape's outputs f and ∇f: what a leaf's bounds enclose.
pub(super) const F_AND_GRADIENT: [bool; WALKED] = [true, false, true, true, true];

/// The walked tape's output f alone.
pub(super) const F_ALONE: [bool; WALKED] = [true, false, false, false, false];

/// The short tapes of the whole formula's leaves below `id`, whose
/// parent's tape (of [`whole_tape`]'s outputs) is `tape`: depth first,
/// with an explicit stack, so only the tapes on the way down are held (at
/// most eight per level). Each leaf of the whole formula is shown its
/// tape (`visit`); only those whose f and g are short enough against
/// `long` instructions keep them, while the distinct tapes kept hold at
/// most `budget` instructions (so memory stays bounded however many
/// leaves there are; the leaves past it get none). Nodes not `wanted`
/// (with no such leaf below them) are passed over.
fn walk_whole(
    (nodes, wanted): (&[OctreeNode], &[bool]),
    leaves: &[Leaf],
    (id, tape): (NodeId, Arc<Tape>),
    (pad, long, budget): (f64, usize, usize),
    (out, visit): (&mut Vec<Found>, &mut impl FnMut(usize, &Tape, bool)),
) {
    let mut held = 0;
    let mut stack = vec![(id, tape)];
    // The last few tapes cut to f and g, and what each gave: siblings that
    // settle nothing more share both (a sibling's subtree may come between).
    let mut cut: Vec<(Arc<Tape>, Arc<Tape>)> = Vec::new();
    while let Some((id, tape)) = stack.pop() {
        let node = &nodes[id as usize];
        if !node.is_alive() || !wanted[id as usize] {
            continue;
        }
        let decisions = tape.settled_over(&box_inputs(&padded(&node.bounds, pad)));
        let tape = if decisions.is_empty() {
            tape
        } else {
            Arc::new(tape.shortened(&decisions))
        };
        if let Some(i) = node.leaf_index().filter(|&i| leaves[i].shape == 0) {
            let fg = match cut.iter().find(|(walked, _)| Arc::ptr_eq(walked, &tape)) {
                Some((_, fg)) => Arc::clone(fg),
                None => {
                    let fg = Arc::new(tape.keeping(&F_AND_G));
                    if cut.len() == 8 {
                        cut.remove(0);
                    }
                    cut.push((Arc::clone(&tape), Arc::clone(&fg)));
                    fg
                }
            };
            let len = fg.body().len();
            let new = out.last().is_none_or(|(_, last)| !Arc::ptr_eq(last, &fg));
            let keep = short_enough(len, long) && (!new || held + len <= budget);
            if keep {
                held += if new { len } else { 0 };
                out.push((i, fg));
            }
            visit(i, &tape, keep);
        }
        if let Some(first) = node.first_child() {
            stack.extend((0..8).map(|k| (first + k, Arc::clone(&tape))));
        }
    }
}

impl ShortTapes {
    /// The short tapes of the kept leaves of `nodes` (boxes widened by
    /// `pad`) whose shape is the whole formula (`shapes[0]`): its f, g and
    /// ∇f ([`whole_tape`]) shortened from the root down, and cut to f and
    /// g. A leaf keeps one where it is at most [`SHORT_ENOUGH`] of the
    /// whole's `fg`, while the budget [`MAX_SHORT_INSTRUCTIONS`] allows;
    /// none where the whole formula has no branch. Each such leaf is also
    /// shown its tape of f, g and ∇f by `bounds` (with a workspace from
    /// `init`, one a walk), and what that gives is returned with its index.
    pub(super) fn build<W, L>(
        nodes: &[OctreeNode],
        leaves: &[Leaf],
        (formula, shapes): (&Formula, &[Shape]),
        pad: f64,
        (init, bounds): (
            impl Fn() -> W + Sync,
            impl Fn(&mut W, usize, (&Tape, bool)) -> Option<L> + Sync,
        ),
    ) -> (ShortTapes, Vec<(usize, L)>)
    where
        L: Send,
    {
        let whole = &shapes[0];
        if !whole.fg.has_branches() || !leaves.iter().any(|l| l.shape == 0) {
            return (ShortTapes::default(), Vec::new());
        }
        let region = |i: usize| padded(&nodes[i].bounds, pad);
        let mut of_leaf = vec![
            LeafShort {
                region: nodes[0].bounds,
                tape: NO_SHORT,
                shape: 0,
            };
            leaves.len()
        ];
        for (id, node) in nodes.iter().enumerate() {
            if let Some(i) = node.leaf_index() {
                of_leaf[i].region = region(id);
                of_leaf[i].shape = leaves[i].shape;
            }
        }
        // Only the nodes with a leaf of the whole formula below them: the
        // others' leaves have shapes of their own (children come after
        // their parent).
        let mut wanted = vec![false; nodes.len()];
        for id in (0..nodes.len()).rev() {
            let node = &nodes[id];
            let whole_leaf = node.leaf_index().is_some_and(|i| leaves[i].shape == 0);
            let below = node
                .first_child()
                .is_some_and(|first| (0..8).any(|k| wanted[(first + k) as usize]));
            wanted[id] = whole_leaf || below;
        }
        let tree = (nodes, wanted.as_slice());
        let full = Arc::new(whole_tape(formula));
        let long = whole.fg.body().len();
        // One walk from the root, or one per child of the root, in
        // parallel; each an eighth of the budget then, so the same leaves
        // keep tapes whatever the threads' timing.
        let starts: Vec<(NodeId, Arc<Tape>, usize)> = match nodes[0].first_child() {
            None => vec![(0, full, MAX_SHORT_INSTRUCTIONS)],
            Some(first) => {
                let root = full.settled_over(&box_inputs(&region(0)));
                let top = Arc::new(full.shortened(&root));
                let budget = MAX_SHORT_INSTRUCTIONS / 8;
                (0..8)
                    .map(|k| (first + k, Arc::clone(&top), budget))
                    .collect()
            }
        };
        let walks: Vec<Walked<L>> = starts
            .into_par_iter()
            .map(|(id, tape, budget)| {
                let (mut found, mut made) = (Vec::new(), Vec::new());
                let mut ws = init();
                let mut visit = |i: usize, tape: &Tape, kept: bool| {
                    made.extend(bounds(&mut ws, i, (tape, kept)).map(|leaf| (i, leaf)));
                };
                let limits = (pad, long, budget);
                walk_whole(tree, leaves, (id, tape), limits, (&mut found, &mut visit));
                (found, made)
            })
            .collect();
        let mut found: Vec<Found> = Vec::new();
        let mut made = Vec::new();
        for (f, m) in walks {
            found.extend(f);
            made.extend(m);
        }
        // Kept in leaf order while the budget allows, each distinct tape once
        // (by address: every one is alive until the end).
        found.sort_by_key(|&(i, _)| i);
        let mut tapes = Vec::new();
        let mut ids: FxHashMap<*const Tape, u32> = FxHashMap::default();
        let mut instructions = 0;
        // The walks' budgets add up to this one, so none is refused here;
        // a leaf that were would have no short tape, and its bounds, found
        // as for one that has, are not returned.
        let mut refused = rustc_hash::FxHashSet::default();
        for (i, tape) in found {
            let len = tape.body().len();
            let id = match ids.get(&Arc::as_ptr(&tape)) {
                Some(&id) => id,
                None if instructions + len <= MAX_SHORT_INSTRUCTIONS => {
                    instructions += len;
                    let id = tapes.len() as u32;
                    ids.insert(Arc::as_ptr(&tape), id);
                    tapes.push(tape);
                    id
                }
                None => {
                    refused.insert(i);
                    continue;
                }
            };
            of_leaf[i].tape = id;
        }
        made.retain(|(i, _)| !refused.contains(i));
        let cells = Cells::new(leaves.len(), tapes.len() as u32);
        let short = ShortTapes {
            tapes,
            of_leaf,
            instructions,
            cells,
        };
        (short, made)
    }

    /// The short tape of `shape` in leaf `leaf` that holds on the box
    /// `inputs` (x, y, z), the deepest one of the leaf's cells that holds
    /// it (made now where not yet), or, where `clear`, the clear cell it
    /// lies in; `None` where none does. `fg` is the shape's own tape.
    #[inline]
    pub fn find<'a>(
        &'a self,
        leaf: usize,
        (shape, fg): (usize, &'a Tape),
        inputs: &[Interval],
        clear: bool,
    ) -> Option<Short<'a>> {
        self.find_made(leaf, (shape, fg), inputs, (true, clear))
    }

    /// The short tape of `shape` in leaf `leaf` that holds at the point
    /// `p`, among the cells made so far (a clear cell's is the one of the
    /// box it was cut from).
    #[inline]
    pub fn find_point<'a>(
        &'a self,
        leaf: usize,
        (shape, fg): (usize, &'a Tape),
        p: DVec3,
    ) -> Option<(u32, &'a Tape)> {
        let at = p.to_array().map(Interval::point);
        match self.find_made(leaf, (shape, fg), &at, (false, false))? {
            Short::Tape(id, tape) => Some((id, tape)),
            Short::Clear(_) => None,
        }
    }

    /// Every cell of leaf `leaf` made so far (see [`Cells::each_made`]);
    /// `shapes` are the octree's.
    pub fn each_cell(&self, leaf: usize, shapes: &[Shape], visit: impl FnMut(&Aabb, &Kept, &Tape)) {
        let Some(of) = self.of_leaf.get(leaf) else {
            return;
        };
        let tape = match of.tape {
            NO_SHORT => &shapes[of.shape as usize].fg,
            k => &*self.tapes[k as usize],
        };
        self.cells.each_made(leaf, (&of.region, tape), visit);
    }

    /// Whether leaf `leaf` is cut into cells where its shape is `shape`.
    #[inline]
    pub fn has_cells(&self, leaf: usize, shape: usize) -> bool {
        matches!(self.of_leaf.get(leaf), Some(of) if of.shape as usize == shape)
    }

    /// Whether the box `inputs` (x, y, z) lies in a cell of leaf `leaf`
    /// where its shape is `shape`, or the leaf has no cells there.
    #[inline]
    pub fn in_a_cell(&self, leaf: usize, shape: usize, inputs: &[Interval]) -> bool {
        match self.of_leaf.get(leaf) {
            Some(of) if of.shape as usize == shape => self.cells.holds(&of.region, inputs),
            _ => true,
        }
    }

    /// [`ShortTapes::find`], making cells where `make`.
    #[inline]
    fn find_made<'a>(
        &'a self,
        leaf: usize,
        (shape, fg): (usize, &'a Tape),
        inputs: &[Interval],
        (make, clear): (bool, bool),
    ) -> Option<Short<'a>> {
        let of = self.of_leaf.get(leaf)?;
        if of.shape as usize == shape {
            let tape = match of.tape {
                NO_SHORT => fg,
                k => &*self.tapes[k as usize],
            };
            let found = self
                .cells
                .find(leaf, (&of.region, tape), inputs, (make, clear));
            if found.is_some() {
                return found;
            }
        }
        let (short, r) = self.of(leaf, shape)?;
        let inside = (0..3).all(|k| inputs[k].inf() >= r.lo[k] && inputs[k].sup() <= r.hi[k]);
        inside.then(|| Short::Tape(short, &self.tapes[short as usize]))
    }

    /// The short tape of `shape` in leaf `leaf`, and its region: only the
    /// whole formula (shape 0) has them.
    #[inline]
    fn of(&self, leaf: usize, shape: usize) -> Option<(u32, &Aabb)> {
        let of = self
            .of_leaf
            .get(leaf)
            .filter(|of| shape == 0 && of.tape != NO_SHORT)?;
        Some((of.tape, &of.region))
    }
}
