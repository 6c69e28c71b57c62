//! The octree's nodes, kept to one cache line each.

use crate::types::Aabb;
use std::num::NonZeroU32;

/// Index of a node in [`Octree::nodes`](super::Octree::nodes).
pub type NodeId = u32;

/// One node: an inner node with eight children, a kept leaf, or a pruned box.
///
/// Traversal reads nodes, not leaves, so a node is kept to one cache line:
/// leaf data lives apart in [`Octree::leaves`](super::Octree::leaves), and a node says which of its
/// children hold kept leaves, so dead children are never read.
#[derive(Debug, Clone)]
#[repr(align(64))]
pub struct OctreeNode {
    /// The node's box.
    pub bounds: Aabb,
    /// The first child's id (children never include the root, id 0).
    pub(super) first_child: Option<NonZeroU32>,
    /// One more than the leaf's index in [`Octree::leaves`](super::Octree::leaves).
    pub(super) leaf: Option<NonZeroU32>,
    /// One more than the index in [`Octree::start_bounds`] of this inner
    /// node's bounds (nodes three levels above the leaves).
    ///
    /// [`Octree::start_bounds`]: super::Octree::start_bounds
    pub(super) start: Option<NonZeroU32>,
    /// Bit k set when child k holds a kept leaf somewhere below it.
    pub(super) alive_children: u8,
    /// Whether the node holds a kept leaf somewhere below it.
    pub(super) alive: bool,
    /// Whether the node is a leaf whose hull is smaller than its box
    /// ([`Octree::leaf_hull`](super::Octree::leaf_hull)).
    pub(super) tight: bool,
}

impl OctreeNode {
    pub(super) fn new(bounds: Aabb) -> OctreeNode {
        OctreeNode {
            bounds,
            first_child: None,
            leaf: None,
            start: None,
            alive_children: 0,
            alive: false,
            tight: false,
        }
    }

    /// The first of eight consecutive children, in octant order (bit 0: upper
    /// half in x, bit 1: in y, bit 2: in z); `None` for leaves and pruned boxes.
    #[inline]
    pub fn first_child(&self) -> Option<NodeId> {
        self.first_child.map(NonZeroU32::get)
    }

    /// The index of the node's leaf data in [`Octree::leaves`] (kept leaves only).
    ///
    /// [`Octree::leaves`]: super::Octree::leaves
    #[inline]
    pub fn leaf_index(&self) -> Option<usize> {
        self.leaf.map(|i| i.get() as usize - 1)
    }

    /// The index of the node's bounds in [`Octree::start_bounds`], for rays
    /// that start inside it (inner nodes three levels above the leaves).
    ///
    /// [`Octree::start_bounds`]: super::Octree::start_bounds
    #[inline]
    pub fn start_index(&self) -> Option<usize> {
        self.start.map(|i| i.get() as usize - 1)
    }

    /// Bit k set when child k holds a kept leaf somewhere below it.
    #[inline]
    pub fn alive_children(&self) -> u8 {
        self.alive_children
    }

    /// Whether the node holds a kept leaf somewhere below it.
    #[inline]
    pub fn is_alive(&self) -> bool {
        self.alive
    }

    /// Whether the node is a leaf whose hull ([`Octree::leaf_hull`](super::Octree::leaf_hull)) is
    /// smaller than its box.
    #[inline]
    pub fn is_tight(&self) -> bool {
        self.tight
    }
}

/// Marks the nodes that hold a kept leaf, so traversal skips the rest.
/// Children always come after their parent, so one backward pass settles it.
pub(super) fn mark_alive(nodes: &mut [OctreeNode]) {
    for i in (0..nodes.len()).rev() {
        let mask = nodes[i].first_child().map_or(0, |c| {
            (0..8).fold(0u8, |m, k| {
                m | (u8::from(nodes[(c + k) as usize].alive) << k)
            })
        });
        nodes[i].alive_children = mask;
        nodes[i].alive = nodes[i].leaf.is_some() || mask != 0;
    }
}
