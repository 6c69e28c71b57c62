//! The short tapes of leaves past the compiled shapes: the f and g a ray's
//! tests evaluate there, with the branches the leaf's (padded) box decides
//! taken.
//!
//! A leaf's shape settles the branch points its box settles, but shapes are
//! few ([`MAX_SHAPES`](super::MAX_SHAPES)), and past them a leaf keeps the
//! whole formula. Short tapes are cheaper to make: one interval evaluation
//! and one pass over a tape, no derivatives. The whole formula's `fg` tape is
//! shortened from the root down, each alive node evaluating its parent's
//! short tape over its own box (so the work follows the live code, not the
//! formula's length). Leaves with a shape of their own need none: it was
//! specialised over the same box, by the same enclosures.
//!
//! A short tape equals the whole formula's `fg`, as a real function, on the
//! region it was found on ([`crate::expr::tape::simplify`]); the intersector
//! evaluates it only while searching its leaf, at points and over pieces
//! inside that region.

use super::leaf::Leaf;
use super::node::{NodeId, OctreeNode};
use super::options::{MAX_SHORT_INSTRUCTIONS, SHORT_ENOUGH};
use super::pad::padded;
use super::shapes::Shape;
use crate::expr::Tape;
use crate::types::{Aabb, DecInterval, Interval};
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
}

/// The short tapes of an octree's leaves.
#[derive(Debug, Clone, Default)]
pub struct ShortTapes {
    /// The tapes, each shared by the leaves whose walk from the root
    /// settled the same branches (siblings, mostly).
    pub tapes: Vec<Arc<Tape>>,
    /// Per kept leaf (by [`OctreeNode::leaf_index`]).
    pub of_leaf: Vec<LeafShort>,
    /// Body instructions of all `tapes` (at most [`MAX_SHORT_INSTRUCTIONS`]
    /// for the leaves' and as many again for their octants').
    pub instructions: usize,
    /// Per kept leaf, the short tapes of the eighths of its region (see
    /// [`Octants`]); empty where no leaf has them.
    pub octants: Vec<Octants>,
}

/// The short tapes of a leaf's eighths, for rays' interval evaluations: a
/// piece of a ray inside an eighth evaluates its tape, shortened from the
/// leaf's over that eighth alone. Long formulas settle far more branches a
/// level down (fidget's prospero text: a leaf's tape of 1,153 instructions
/// on average near the surface, its eighths' 392), and building the
/// octree a level deeper costs far more than these tapes.
///
/// The eighths of a leaf's padded region `r` overlap: along each axis the
/// lower is `[r.lo, c + δ]` and the upper `[c − δ, r.hi]`, with `c` the
/// centre and `δ` an eighth of the width ([`OCTANT_OVERLAP`]), so that most
/// pieces near the middle planes still fit in one.
#[derive(Debug, Clone, Copy)]
pub struct Octants {
    /// The shape whose tape was shortened: the leaf's own.
    pub shape: u32,
    /// Each eighth's tape ([`NO_SHORT`]: none; the leaf's serves), by the
    /// eighth's index: bit k set for the upper half along axis k.
    pub tapes: [u32; 8],
}

/// How far each eighth of a leaf's region reaches past the middle plane,
/// as a share of the region's width.
pub const OCTANT_OVERLAP: f64 = 0.125;

/// The middle of the region `r`, and how far its eighths reach past it.
fn middle(r: &Aabb) -> (DVec3, DVec3) {
    (r.center(), (r.hi - r.lo) * OCTANT_OVERLAP)
}

/// The eighth `k` of the region `r` (see [`Octants`]).
fn octant(r: &Aabb, k: usize) -> Aabb {
    let (c, d) = middle(r);
    let upper = DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64);
    let lo = DVec3::select(upper.cmpgt(DVec3::ZERO), c - d, r.lo);
    let hi = DVec3::select(upper.cmpgt(DVec3::ZERO), r.hi, c + d);
    Aabb {
        lo: lo.max(r.lo),
        hi: hi.min(r.hi),
    }
}

/// The eighth of the region `r` that holds the box `inputs` (x, y, z), if
/// one does.
#[inline]
fn octant_holding(r: &Aabb, inputs: &[Interval]) -> Option<usize> {
    // The same f64 middle planes as `octant`'s, so a box it places lies
    // inside the eighth whose tape was made for it.
    let (c, d) = middle(r);
    let mut k = 0;
    for axis in 0..3 {
        let (lo, hi) = (inputs[axis].inf(), inputs[axis].sup());
        if lo < r.lo[axis] || hi > r.hi[axis] {
            return None;
        }
        if hi > c[axis] + d[axis] {
            if lo < c[axis] - d[axis] {
                return None;
            }
            k |= 1 << axis;
        }
    }
    Some(k)
}

/// The interval inputs of a box, for every direction.
fn box_inputs(b: &Aabb) -> [DecInterval; 6] {
    let [x, y, z] = b.intervals();
    let any = Interval::ENTIRE;
    [x, y, z, any, any, any].map(DecInterval::defined)
}

/// Whether a tape of `len` instructions is worth keeping for a shape of
/// `long` ([`SHORT_ENOUGH`]).
fn short_enough(len: usize, long: usize) -> bool {
    len as f64 <= SHORT_ENOUGH * long as f64
}

/// A leaf's short tape as the walk finds it: shared with its siblings
/// where their boxes decide nothing more.
type Found = (usize, Arc<Tape>);

/// The short tapes of the whole formula's leaves below `id`, whose
/// parent's tape is `tape`: depth first, with an explicit stack, so only
/// the tapes on the way down are held (at most eight per level).
/// Only leaves of shape 0 whose tape is short enough against `long`
/// instructions are kept, while the distinct tapes kept hold at most
/// `budget` instructions (so memory stays bounded however many leaves
/// there are; the leaves past it get none).
fn walk_whole(
    nodes: &[OctreeNode],
    leaves: &[Leaf],
    (id, tape): (NodeId, Arc<Tape>),
    (pad, long, budget): (f64, usize, usize),
    out: &mut Vec<Found>,
) {
    let mut held = 0;
    let mut stack = vec![(id, tape)];
    while let Some((id, tape)) = stack.pop() {
        let node = &nodes[id as usize];
        if !node.is_alive() {
            continue;
        }
        let decisions = tape.settled_over(&box_inputs(&padded(&node.bounds, pad)));
        let tape = if decisions.is_empty() {
            tape
        } else {
            Arc::new(tape.shortened(&decisions))
        };
        if let Some(i) = node.leaf_index() {
            let len = tape.body().len();
            let new = out.last().is_none_or(|(_, last)| !Arc::ptr_eq(last, &tape));
            if leaves[i].shape == 0 && short_enough(len, long) && (!new || held + len <= budget) {
                held += if new { len } else { 0 };
                out.push((i, Arc::clone(&tape)));
            }
        }
        if let Some(first) = node.first_child() {
            stack.extend((0..8).map(|k| (first + k, Arc::clone(&tape))));
        }
    }
}

impl ShortTapes {
    /// The short tapes of the kept leaves of `nodes` (boxes widened by
    /// `pad`) whose shape is the whole formula (`shapes[0]`): its `fg`
    /// shortened from the root down. A leaf keeps one where it is at most
    /// [`SHORT_ENOUGH`] of the whole, while the budget
    /// [`MAX_SHORT_INSTRUCTIONS`] allows; none where the whole formula has
    /// no branch.
    pub(super) fn build(
        nodes: &[OctreeNode],
        leaves: &[Leaf],
        shapes: &[Shape],
        pad: f64,
    ) -> ShortTapes {
        let whole = &shapes[0];
        if !whole.fg.has_branches() || !leaves.iter().any(|l| l.shape == 0) {
            return ShortTapes::default();
        }
        let region = |i: usize| padded(&nodes[i].bounds, pad);
        let mut of_leaf = vec![
            LeafShort {
                region: nodes[0].bounds,
                tape: NO_SHORT,
            };
            leaves.len()
        ];
        for (id, node) in nodes.iter().enumerate() {
            if let Some(i) = node.leaf_index() {
                of_leaf[i].region = region(id);
            }
        }
        // One walk per child of the root, in parallel.
        let full = Arc::new(whole.fg.clone());
        let long = full.body().len();
        let mut found: Vec<Found> = Vec::new();
        match nodes[0].first_child() {
            None => {
                let limits = (pad, long, MAX_SHORT_INSTRUCTIONS);
                walk_whole(nodes, leaves, (0, full), limits, &mut found);
            }
            Some(first) => {
                let root = full.settled_over(&box_inputs(&region(0)));
                let top = Arc::new(full.shortened(&root));
                found = (0..8)
                    .into_par_iter()
                    .map(|k| {
                        let mut out = Vec::new();
                        let start = (first + k, Arc::clone(&top));
                        // Each walk an eighth of the budget: the same
                        // leaves keep tapes whatever the threads' timing.
                        let limits = (pad, long, MAX_SHORT_INSTRUCTIONS / 8);
                        walk_whole(nodes, leaves, start, limits, &mut out);
                        out
                    })
                    .flatten()
                    .collect();
            }
        }
        // Kept in leaf order while the budget allows, each distinct tape once
        // (by address: every one is alive until the end).
        found.sort_by_key(|&(i, _)| i);
        let mut tapes = Vec::new();
        let mut ids: FxHashMap<*const Tape, u32> = FxHashMap::default();
        let mut instructions = 0;
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
                None => continue,
            };
            of_leaf[i].tape = id;
        }
        let mut short = ShortTapes {
            tapes,
            of_leaf,
            instructions,
            octants: Vec::new(),
        };
        short.add_octants(leaves, shapes);
        short
    }

    /// Each leaf's [`Octants`]: its tape (its short tape, or its shape's
    /// `fg`) shortened over each eighth of its region, kept where at most
    /// [`SHORT_ENOUGH`] of it, in leaf order while the distinct tapes hold at
    /// most [`MAX_SHORT_INSTRUCTIONS`].
    fn add_octants(&mut self, leaves: &[Leaf], shapes: &[Shape]) {
        let of_leaf = &self.of_leaf;
        let tapes = &self.tapes;
        let found: Vec<[Option<Arc<Tape>>; 8]> = (0..leaves.len())
            .into_par_iter()
            .map(|i| {
                let shape = leaves[i].shape as usize;
                let tape = match of_leaf[i].tape {
                    NO_SHORT => &shapes[shape].fg,
                    k => &*tapes[k as usize],
                };
                let region = &of_leaf[i].region;
                std::array::from_fn(|k| {
                    let decisions = tape.settled_over(&box_inputs(&octant(region, k)));
                    if decisions.is_empty() {
                        return None;
                    }
                    let short = tape.shortened(&decisions);
                    let keep = short.body().len() * 2 <= tape.body().len();
                    keep.then(|| Arc::new(short))
                })
            })
            .collect();
        // Distinct tapes once each (eighths of neighbouring leaves that
        // settle alike are rare enough not to look for).
        let mut held = 0;
        self.octants = found
            .into_iter()
            .enumerate()
            .map(|(i, eighths)| {
                let mut octants = Octants {
                    shape: leaves[i].shape,
                    tapes: [NO_SHORT; 8],
                };
                for (k, tape) in eighths.into_iter().enumerate() {
                    let Some(tape) = tape else { continue };
                    let len = tape.body().len();
                    if held + len <= MAX_SHORT_INSTRUCTIONS {
                        held += len;
                        octants.tapes[k] = self.tapes.len() as u32;
                        self.tapes.push(tape);
                    }
                }
                octants
            })
            .collect();
        self.instructions += held;
    }

    /// The short tape of `shape` in leaf `leaf` when the box `inputs` (x, y,
    /// z) lies inside the region it holds on; `None` otherwise.
    #[inline]
    pub fn find(&self, leaf: usize, shape: usize, inputs: &[Interval]) -> Option<u32> {
        if let Some(octants) = self.octants.get(leaf).filter(|o| o.shape as usize == shape) {
            let r = &self.of_leaf[leaf].region;
            let k = octant_holding(r, inputs).map(|k| octants.tapes[k]);
            if let Some(k) = k.filter(|&k| k != NO_SHORT) {
                return Some(k);
            }
        }
        let (short, r) = self.of(leaf, shape)?;
        let inside = (0..3).all(|k| inputs[k].inf() >= r.lo[k] && inputs[k].sup() <= r.hi[k]);
        inside.then_some(short)
    }

    /// [`ShortTapes::find`] for the point `p`.
    #[inline]
    pub fn find_point(&self, leaf: usize, shape: usize, p: DVec3) -> Option<u32> {
        if let Some(octants) = self.octants.get(leaf).filter(|o| o.shape as usize == shape) {
            let r = &self.of_leaf[leaf].region;
            let at = p.to_array().map(Interval::point);
            let k = octant_holding(r, &at).map(|k| octants.tapes[k]);
            if let Some(k) = k.filter(|&k| k != NO_SHORT) {
                return Some(k);
            }
        }
        let (short, r) = self.of(leaf, shape)?;
        let inside = p.cmpge(r.lo).all() && p.cmple(r.hi).all();
        inside.then_some(short)
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
