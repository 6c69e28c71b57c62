//! Octree space pruning (Kalra–Barr §6.1).
//!
//! From the bounding box, boxes are subdivided to a fixed depth. A box whose
//! corners straddle the surface is kept (and subdivided further); otherwise it
//! is discarded when `|f(x₀)| > L·d`, with x₀ its centre, d its half-diagonal
//! and L its own automatic Lipschitz bound (where its shape leaves no branch
//! point open), or when the interval of f over it excludes 0; anything else
//! is subdivided. Both discard reasons are counted.
//! Each kept leaf stores what the intersector needs so that rays pay no
//! interval evaluation: its L and the interval Hessian, from which any ray's G
//! inside the leaf is `|dᵀ[H]d|`.
//!
//! A leaf's data comes from the formula as the leaf sees it: each `min`,
//! `max`, `abs`, `sign`, `choose` or `dirac` whose branch is settled over the
//! leaf's box is replaced by that branch ([`Shape`]). So is a `max` (`min`)
//! at the root, under affine maps, one of whose sides stays below (above) 0
//! over the box: the other side alone then has f's sign everywhere there, so
//! the same surface and the same first root along every ray, though not f's
//! values (a CSG object far from the box is dropped, as a ray tracer drops
//! an object whose bounding box it misses). Away from creases, CSG
//! surfaces then get finite G and the Kalra–Barr tests; leaves deciding the
//! same branches share one compiled shape. Boxes a crease may cross go
//! [`CREASE_LEVELS`] deeper; a creased leaf whose formula is the larger or
//! smaller of two smooth ones (a `max` or `min` left open, under affine maps)
//! also holds the bounds of both ([`SplitLeaf`]), so rays decide the side
//! piece by piece.
//!
//! Last, each kept leaf's box is cut into sub-boxes, and those a test with the
//! leaf's own bounds proves empty are left out of its hull
//! ([`Octree::leaf_hull`]): rays search only the hull, and the many that cross
//! a leaf's box beside the surface in it do not search that leaf at all.

mod build;
mod cells;
mod classify;
mod cost;
mod frame;
mod hull;
mod leaf;
mod leaf_bounds;
mod node;
mod options;
mod pad;
mod shapes;
mod short;

pub use cells::{Cell, Cells, Eighths, Kept, Short, OCTANT_OVERLAP};
pub use frame::ViewFrame;
pub use leaf::{quadric_leaf, Leaf, SplitLeaf};
pub use node::{NodeId, OctreeNode};
pub use options::*;
pub use pad::pad_for;
pub(crate) use pad::padded;
pub use shapes::{Shape, FG};
pub use short::{LeafShort, ShortTapes, NO_SHORT};

use crate::ray::closed::affine::Affine;
use crate::ray::closed::polynomial::Polynomial;
use crate::types::{Aabb, Interval};
use glam::DVec3;
use leaf::*;

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
    /// Leaves whose formula was specialised: some branch point settled.
    pub specialised: usize,
    /// Leaves whose formula still holds a branch point (a crease or a jump
    /// may cross them).
    pub creased: usize,
    /// Shapes compiled, the whole formula included.
    pub shapes: usize,
    /// The body instructions of the shapes past the whole formula (at most
    /// [`MAX_SHAPE_INSTRUCTIONS`]).
    pub shape_instructions: usize,
    /// Creased leaves that carry bounds of their two smooth sides
    /// ([`SplitLeaf`]).
    pub split: usize,
    /// Leaves kept before the requested depth because their Lipschitz bound
    /// was already tight ([`TIGHT_RATIO`]).
    pub tight: usize,
    /// Short tapes made ([`ShortTapes`]).
    pub short_tapes: usize,
    /// Their body instructions, in all.
    pub short_instructions: usize,
}

/// A pruned octree over a bounding box.
#[derive(Debug, Clone)]
pub struct Octree {
    /// All nodes; `nodes[0]` is the root.
    pub nodes: Vec<OctreeNode>,
    /// The kept leaves' data, referred to by [`OctreeNode::leaf_index`].
    pub leaves: Vec<Leaf>,
    /// Per kept leaf, the part of its box that holds the surface there
    /// ([`Octree::leaf_hull`]).
    pub(super) hulls: Vec<Aabb>,
    /// The same data over inner nodes three levels above the leaves
    /// ([`OctreeNode::start_index`]): a ray that starts on the surface
    /// proves with one evaluation that it leaves it for as far as their G
    /// allows, across the leaves below.
    pub start_bounds: Vec<Leaf>,
    /// The bounding box.
    pub bounds: Aabb,
    /// Build statistics.
    pub stats: OctreeStats,
    /// How far every box was widened for its proofs (pruning) and bounds
    /// (leaves): a ray whose rounding moves its points by less than this is
    /// covered by them.
    pub pad: f64,
    /// The compiled shapes leaves refer to; the first is the whole formula.
    pub shapes: Vec<Shape>,
    /// The whole formula with the branches each leaf's box decides taken,
    /// for leaves past the compiled shapes.
    pub short: ShortTapes,
    /// The requested depth (boxes a crease may cross go deeper).
    pub depth: u32,
    /// Bounds of the whole formula over the whole (padded) box, for points
    /// that no single leaf covers.
    pub whole: WholeBounds,
    /// The sides of creased leaves that have two ([`Octree::split`]).
    pub(super) splits: Vec<SplitLeaf>,
    /// Per leaf, one more than the index of its sides in `splits`, or 0.
    pub(super) split_of: Vec<u32>,
    /// See [`Octree::frame`].
    pub(super) frame: ViewFrame,
    /// The whole formula as an affine form over the padded box, when it is
    /// one (a plane): rays are answered in closed form ([`Affine`]).
    pub affine: Option<Affine>,
    /// The whole formula along rays, when it is a polynomial of degree 3
    /// to 8 with no branch point (a torus): rays are answered in Bernstein
    /// form ([`Polynomial`]).
    pub polynomial: Option<Polynomial>,
}

/// What holds for the whole formula anywhere in the padded bounding box.
#[derive(Debug, Clone, Copy)]
pub struct WholeBounds {
    /// Bound of the rounding error of the f64 value of f.
    pub f_error: f64,
    /// Bound of `|∇f|` (may be `+∞`).
    pub lipschitz: f64,
    /// f is defined and continuous everywhere in the box.
    pub continuous: bool,
}

impl Octree {
    /// The view frame of [`BuildOptions::frame_depth`]: the smallest box
    /// holding every box a framing octree to that depth keeps, exactly its
    /// [`Octree::surface_bounds`], where this build could find it.
    pub fn frame(&self) -> ViewFrame {
        self.frame
    }

    /// The smallest box of sub-boxes of the leaf `leaves[index]`'s box that
    /// holds every point of the surface in it (see [`HULL_LEVELS`]; the
    /// sub-boxes left out were proved empty padded, as pruned boxes are): a
    /// ray searches the leaf only where it crosses this box. A point where the
    /// leaf holds no surface at all; the leaf's box where hulls were not
    /// found. A face on the bounding box's own face reaches out to the
    /// padded box, where a ray's widened range may find a root on the wall.
    #[inline]
    pub fn leaf_hull(&self, index: usize) -> &Aabb {
        &self.hulls[index]
    }

    /// The two smooth sides of the leaf `leaves[index]`, where it has them
    /// (creased leaves only).
    #[inline]
    pub fn split(&self, index: usize) -> Option<&SplitLeaf> {
        split_at(&self.splits, &self.split_of, index)
    }

    /// Whether a kept leaf's (closed) hull meets the box `region`: `Some(false)`
    /// proves that `region` holds no point of the surface inside the bounding
    /// box (every such point lies in a kept leaf). `None` when deciding would
    /// visit more than `max_visits` nodes. `stack` is scratch space.
    pub fn meets_kept_leaf(
        &self,
        region: &[Interval; 3],
        max_visits: usize,
        stack: &mut Vec<NodeId>,
    ) -> Option<bool> {
        if region.iter().any(|x| x.is_empty()) {
            return Some(false);
        }
        stack.clear();
        stack.push(0);
        let mut visits = 0;
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id as usize];
            if !node.is_alive() || !node.bounds.meets(region) {
                continue;
            }
            visits += 1;
            if visits > max_visits {
                return None;
            }
            if let Some(i) = node.leaf_index() {
                if self.hulls[i].meets(region) {
                    return Some(true);
                }
                continue;
            }
            if let Some(first) = node.first_child() {
                let alive = node.alive_children();
                stack.extend((0..8).filter(|k| alive & (1 << k) != 0).map(|k| first + k));
            }
        }
        Some(false)
    }

    /// The smallest box holding every kept box at the requested depth (the
    /// part of the bounding box where the surface may be; the levels added
    /// around creases do not move it, but quadric leaves that stop early
    /// count whole: build with `coarse_quadrics` off to frame a view);
    /// `None` when nothing was kept.
    pub fn surface_bounds(&self) -> Option<Aabb> {
        let mut kept: Option<Aabb> = None;
        let mut stack = vec![(0 as NodeId, 0u32)];
        while let Some((id, level)) = stack.pop() {
            let node = &self.nodes[id as usize];
            if !node.alive {
                continue;
            }
            match node.first_child() {
                Some(first) if level < self.depth => {
                    stack.extend((first..first + 8).map(|c| (c, level + 1)));
                }
                _ => kept = Some(kept.map_or(node.bounds, |k| k.union(&node.bounds))),
            }
        }
        kept
    }

    /// The leaf data of `node`, if it is a kept leaf.
    #[inline]
    pub fn leaf(&self, node: &OctreeNode) -> Option<&Leaf> {
        node.leaf_index().map(|i| &self.leaves[i])
    }

    /// The Lipschitz bound and diagonal of the kept leaf holding `p` (the
    /// whole box's where none does): what a hit found there would report.
    pub fn leaf_bounds_at(&self, p: DVec3) -> (f64, f64) {
        let diagonal = |b: &Aabb| b.diagonal();
        let mut node = &self.nodes[0];
        loop {
            if let Some(i) = node.leaf_index() {
                return (self.leaves[i].lipschitz, diagonal(&node.bounds));
            }
            let Some(first) = node.first_child() else {
                break;
            };
            let c = node.bounds.center();
            let octant = usize::from(p.x >= c.x)
                | usize::from(p.y >= c.y) << 1
                | usize::from(p.z >= c.z) << 2;
            node = &self.nodes[first as usize + octant];
        }
        (self.whole.lipschitz, diagonal(&self.bounds))
    }

    /// True when nothing of the surface was kept.
    pub fn is_empty(&self) -> bool {
        self.stats.leaves == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::Formula;

    #[test]
    fn an_octree_without_leaf_bounds_keeps_the_same_boxes() {
        // Framing builds skip the leaves' bounds: the boxes kept, and so the
        // view, must not change.
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        for src in [
            "max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))",
            "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-1)",
            "(x^2+y^2+z^2+0.21)^2-(x^2+y^2)",
        ] {
            let f = Formula::parse(src).unwrap();
            // (Boxes stop early, as quadrics' and tight ones do, only where
            // leaves get bounds.)
            let full = BuildOptions {
                coarse_quadrics: false,
                tight_leaves: false,
                ..BuildOptions::to_depth(4)
            };
            let framing = BuildOptions {
                leaf_bounds: false,
                ..full
            };
            let (a, c) = (
                Octree::build_with(&f, &b, &full),
                Octree::build_with(&f, &b, &framing),
            );
            assert_eq!(a.nodes.len(), c.nodes.len(), "{src}");
            assert_eq!(a.stats.leaves, c.stats.leaves, "{src}");
            assert!(a.surface_bounds().is_some(), "{src}");
            assert_eq!(a.surface_bounds(), c.surface_bounds(), "{src}");
            // Its leaves know nothing: a ray there would decide by intervals.
            assert!(c.leaves.iter().all(|l| l.needs_intervals && !l.continuous));
            assert!(a.leaves.iter().any(|l| !l.needs_intervals), "{src}");
        }
    }

    #[test]
    fn the_frame_found_with_an_octree_is_the_framing_octrees() {
        // The renderer frames its view by the boxes a depth-4 octree keeps;
        // a deeper build finds them on its way, below its early leaves too
        // (a sphere's whole box is one), and must find exactly those.
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let framing = BuildOptions {
            crease_levels: 0,
            coarse_quadrics: false,
            leaf_bounds: false,
            ..BuildOptions::to_depth(4)
        };
        let mut found = 0;
        for src in [
            "x^2+y^2+z^2-1",
            "x^2+y^2+z^2-0.04",
            "x^2+y^2+z^2+1",
            "max(abs(x),abs(y),abs(z))-1",
            "max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))",
            "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-1)",
            "min((x-0.5)^2+y^2+z^2-0.36, x^2+(y-0.6)^2+z^2-0.25)",
            "(x^2+y^2+z^2+0.21)^2-(x^2+y^2)",
            "x-0.3",
        ] {
            let f = Formula::parse(src).unwrap();
            let expected = Octree::build_with(&f, &b, &framing).surface_bounds();
            for depth in [3, 4, 5, 6] {
                let options = BuildOptions {
                    frame_depth: Some(4),
                    ..BuildOptions::to_depth(depth)
                };
                let tree = Octree::build_with(&f, &b, &options);
                match tree.frame() {
                    ViewFrame::NotFound => {
                        // Not deeper than the frame: left to a build of its own.
                        assert!(depth <= 4, "{src} at depth {depth}")
                    }
                    frame => {
                        assert!(depth > 4, "{src} at depth {depth}");
                        let frame = match frame {
                            ViewFrame::Found(b) => Some(b),
                            _ => None,
                        };
                        assert_eq!(frame, expected, "{src} at depth {depth}");
                        found += 1;
                    }
                }
                assert_eq!(Octree::build(&f, &b, depth).frame(), ViewFrame::NotFound);
            }
        }
        assert_eq!(found, 18);
        // A budget that might stop the framing tree leaves it to its own build.
        let f = Formula::parse("x^2+y^2+z^2-1").unwrap();
        let options = BuildOptions {
            frame_depth: Some(4),
            max_work: 1000,
            ..BuildOptions::to_depth(5)
        };
        assert_eq!(
            Octree::build_with(&f, &b, &options).frame(),
            ViewFrame::NotFound
        );
    }

    /// A union of 300 balls: its framing tree's boxes at the whole
    /// formula's cost would not fit the budget, but a deeper build that
    /// keeps no leaf above the frame's depth classifies every box the
    /// framing tree does, and does more work on each: it finds the frame on
    /// its way, the framing tree's exactly, with no second build.
    #[test]
    fn a_long_formula_finds_its_frame_on_the_way() {
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let f = Formula::parse_vm(include_str!("../../../examples/models/balls.vm")).unwrap();
        let framing = BuildOptions {
            crease_levels: 0,
            coarse_quadrics: false,
            leaf_bounds: false,
            ..BuildOptions::to_depth(4)
        };
        let expected = Octree::build_with(&f, &b, &framing).surface_bounds();
        assert!(expected.is_some());
        let options = BuildOptions {
            frame_depth: Some(4),
            ..BuildOptions::to_depth(5)
        };
        assert_eq!(
            Octree::build_with(&f, &b, &options).frame(),
            ViewFrame::Found(expected.unwrap())
        );
    }

    #[test]
    fn a_point_hessians_curvature_is_the_interval_sums_to_the_bit() {
        // The one-product path for quadric leaves gives what the two-ended
        // sums give: for the leaves of a CSG of quadrics, and for random
        // Hessians and directions (components of either sign, zero, huge).
        use crate::ray::test_rng::Rng;
        let f = Formula::parse("max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))").unwrap();
        let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let octree = Octree::build_with(&f, &b, &BuildOptions::to_depth(4));
        let mut leaves: Vec<Leaf> = octree
            .leaves
            .iter()
            .filter(|l| l.point_hessian)
            .copied()
            .collect();
        assert!(leaves.len() > 100, "{} quadric leaves", leaves.len());
        let mut rng = Rng(0xc0_ffee);
        for _ in 0..200 {
            let mut leaf = leaves[0];
            leaf.hessian = std::array::from_fn(|_| {
                let h = rng.between(-1.0, 1.0) * 10f64.powi((rng.next() * 12.0) as i32 - 6);
                Interval::point(if rng.next() < 0.2 { 0.0 } else { h })
            });
            leaves.push(leaf);
        }
        let mut checked = 0;
        for leaf in &leaves {
            let general = Leaf {
                point_hessian: false,
                ..*leaf
            };
            for k in 0..50 {
                let mut d = rng.vec() * 10f64.powi(k % 7 - 3);
                if k % 5 == 0 {
                    d.y = 0.0;
                }
                if k % 11 == 0 {
                    d.z = 1e160;
                }
                let (one, two) = (leaf.curvature(d), general.curvature(d));
                assert_eq!(
                    (one.0.to_bits(), one.1.to_bits()),
                    (two.0.to_bits(), two.1.to_bits()),
                    "{:?} along {d}",
                    leaf.hessian
                );
                checked += 1;
            }
        }
        assert!(checked > 15_000);
    }

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
