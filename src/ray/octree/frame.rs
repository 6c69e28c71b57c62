//! The view frame a build finds on the way.

use super::classify::*;
use super::shapes::*;
use crate::types::Aabb;
use rayon::prelude::*;

/// What a build found of the view frame it was asked for
/// ([`BuildOptions::frame_depth`](super::BuildOptions::frame_depth)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ViewFrame {
    /// Not asked for, or left to a framing octree of its own (a budget could
    /// have stopped either tree before the frame's depth).
    NotFound,
    /// The framing octree keeps no box: nothing to frame.
    Empty,
    /// The smallest box holding every box the framing octree keeps.
    Found(Aabb),
}

/// The view frame a build finds on the way.
pub(super) struct Frame {
    pub(super) depth: u32,
    /// The boxes kept at `depth` so far.
    pub(super) hull: Option<Aabb>,
    /// Leaves kept above `depth` whose formula settles no more branches:
    /// their boxes, shapes and levels.
    pub(super) below_leaves: Vec<(Aabb, u32, u32)>,
    /// Whether the framing tree's budget is known to hold whatever this
    /// tree finds: all its boxes down to `depth`, each at the whole
    /// formula's cost, fit. Otherwise it is known to hold only where this
    /// tree keeps no leaf early: the framing tree then classifies no box
    /// this one does not, and counts no work this one does not (it tests no
    /// box for a tight leaf), so it fits each level that this one fits.
    pub(super) budget_known: bool,
}

impl Frame {
    pub(super) fn keep(&mut self, b: &Aabb) {
        self.hull = Some(self.hull.map_or(*b, |h| h.union(b)));
    }

    /// The hull, with the boxes a framing tree keeps below the leaves kept
    /// early, classified level by level as it would (same shape, corner
    /// signs from the parent's grid).
    pub(super) fn complete(mut self, plan: &Plan, shapes: &[Shape]) -> Option<Aabb> {
        let mut boxes = std::mem::take(&mut self.below_leaves);
        let pool = Workspaces::new(plan, shapes);
        while !boxes.is_empty() {
            let kept: Vec<(Aabb, u32, u32)> = boxes
                .par_iter()
                .map_init(
                    || pool.lend(),
                    |ws, &(b, shape, level)| {
                        ws.current = shape;
                        let straddles = ws.children_straddling(&b);
                        let children = b.octants();
                        (0..8)
                            .filter(|&k| {
                                let class = ws.classify(plan, &children[k], Some(straddles[k]));
                                matches!(class, Class::Possible(_))
                            })
                            .map(|k| (children[k], shape, level + 1))
                            .collect::<Vec<_>>()
                    },
                )
                .flatten()
                .collect();
            boxes.clear();
            for (b, shape, level) in kept {
                if level == self.depth {
                    self.keep(&b);
                } else {
                    boxes.push((b, shape, level));
                }
            }
        }
        self.hull
    }
}
