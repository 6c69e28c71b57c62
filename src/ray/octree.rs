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

use crate::expr::specialize::{normalise, root_split, Branch, BranchPoint, PointIndex, RootSplit};
use crate::expr::tape::Instr;
use crate::expr::{
    BatchEvaluator, BinaryOp, DecoratedEvaluator, Evaluator, PointEvaluator, RoundingBound, Tape,
    UnaryOp,
};
use crate::formula::{Formula, Output};
use crate::types::{Aabb, DecInterval, Decoration, Interval};

use super::affine::Affine;
use super::polynomial::Polynomial;
use crate::expr::along::AlongLine;
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::num::NonZeroU32;

/// Index of a node in [`Octree::nodes`].
pub type NodeId = u32;

/// What the intersector knows about a kept leaf. Every bound holds over the
/// leaf's box widened by the octree's [`Octree::pad`], so that rays whose
/// computed points stray from the exact ray by rounding stay covered.
#[derive(Debug, Clone, Copy)]
pub struct Leaf {
    /// Sound bound of `|∇f|` over the leaf (may be `+∞`).
    pub lipschitz: f64,
    /// Sound bounds of `|∂f/∂x|`, `|∂f/∂y|` and `|∂f/∂z|` over the leaf (each
    /// may be `+∞`): `lipschitz` bounds their norm.
    pub slopes: [f64; 3],
    /// Interval Hessian over the leaf: xx, yy, zz, xy, xz, yz.
    pub hessian: [Interval; 6],
    /// Bound of the Hessian's Frobenius norm over the leaf (`‖H‖₂ ≤` this).
    pub hessian_norm: f64,
    /// Whether each entry of the Hessian is enclosed by one number (f is at
    /// most quadratic over the leaf: a plane, a sphere, a quadric) and is
    /// finite, so that [`Leaf::curvature`] needs one product per entry.
    pub point_hessian: bool,
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
    /// The index in [`Octree::shapes`] of the formula as the leaf sees it:
    /// f, or a formula with f's sign everywhere in the (padded) leaf.
    pub shape: u32,
}

/// A creased leaf whose formula is the larger (or the smaller) of two smooth
/// formulas, its sides (see [`crate::expr::specialize::root_split`]): where
/// their difference keeps one sign along a piece of a ray, F is one side
/// there, and Kalra–Barr's tests run with that side's bounds.
#[derive(Debug, Clone, Copy)]
pub struct SplitLeaf {
    /// Whether the leaf's formula is the larger side (else the smaller).
    pub larger: bool,
    /// Each side's bounds over the leaf (their `shape` names the formula).
    pub sides: [Leaf; 2],
    /// `2⁻ᵏ` for a leaf k levels above the requested depth (both sides
    /// quadratic: a leaf early, like a quadric's), else 1: pieces of a ray no
    /// side holds on are halved down to the length they would have in a
    /// leaf at that depth.
    pub scale: f64,
}

/// The formula compiled as a region sees it: the whole formula
/// ([`Octree::shapes`]`[0]`), or one with the branch points that the region
/// settles replaced by their branches.
#[derive(Debug, Clone)]
pub struct Shape {
    /// f.
    pub f: Tape,
    /// f and g ([`FG`]).
    pub fg: Tape,
    /// ∇f.
    pub grad: Tape,
    f_grad: Tape,
    /// f, ∇f and the Hessian, for leaves (one tape: their common
    /// subexpressions are computed once).
    local: Tape,
    /// Branch points left in it: creases or jumps the region may hold.
    pub open: usize,
    /// Whether f takes only arithmetic, integer powers and square roots:
    /// each evaluation then costs a few instructions, no more than a step
    /// of the octree walk it could spare (see [`TIGHT_RATIO`]).
    algebraic: bool,
}

impl Shape {
    fn is_algebraic(f: &Tape) -> bool {
        f.body().iter().all(|instr| match *instr {
            Instr::Unary { op, .. } => matches!(op, UnaryOp::Neg | UnaryOp::Abs | UnaryOp::Sqrt),
            Instr::Binary { op, .. } => matches!(
                op,
                BinaryOp::Add
                    | BinaryOp::Sub
                    | BinaryOp::Mul
                    | BinaryOp::Div
                    | BinaryOp::Min
                    | BinaryOp::Max
            ),
            Instr::PowI { .. } => true,
            Instr::Choose { .. } => true,
        })
    }

    fn new(formula: &Formula) -> Shape {
        let f = formula.tape(&[Output::F]);
        Shape {
            algebraic: Self::is_algebraic(&f),
            f,
            fg: formula.tape(&FG),
            grad: formula.tape(&[Output::Dfdx, Output::Dfdy, Output::Dfdz]),
            f_grad: formula.tape(&[Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz]),
            local: formula.tape(&LOCAL),
            open: formula.branch_points().len(),
        }
    }
}

/// The outputs of [`Shape::local`]: f, ∇f, then the Hessian.
const LOCAL: [Output; 10] = [
    Output::F,
    Output::Dfdx,
    Output::Dfdy,
    Output::Dfdz,
    Output::HESSIAN[0],
    Output::HESSIAN[1],
    Output::HESSIAN[2],
    Output::HESSIAN[3],
    Output::HESSIAN[4],
    Output::HESSIAN[5],
];

/// How many levels past the requested depth a box that a crease may cross is
/// subdivided further by default, to settle its branches. One: creased
/// leaves with two smooth sides ([`SplitLeaf`]) decide most pieces of rays
/// by those sides, and each level more doubles the build. Measured at 1024²
/// (instructions, no shadows): a second level cost the gyroid in a ball about
/// 15 % more and the cube minus a ball 9 %; with none, the cube minus a ball
/// took 15 % more (measured before boxes with two quadratic sides stopped at
/// the depth as split leaves: see [`SPLIT_LEVELS_EARLY`]).
pub const CREASE_LEVELS: u32 = 1;

/// How far an octree is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuildOptions {
    /// Levels of subdivision.
    pub depth: u32,
    /// Work budget (see [`MAX_WORK`]): subdivision stops before a level that
    /// would exceed it.
    pub max_work: u64,
    /// Further levels for boxes a crease may cross (see [`CREASE_LEVELS`]).
    pub crease_levels: u32,
    /// Whether leaves see the formula specialised to their region (off: every
    /// leaf sees the whole formula, as a reference for tests).
    pub specialise: bool,
    /// Whether boxes where f is at most quadratic become leaves at any level
    /// before `depth` (see [`quadric_leaf`]); off: every kept box goes to
    /// `depth`.
    pub coarse_quadrics: bool,
    /// Whether leaves get the bounds rays need (off: the octree only says
    /// which boxes are kept, as for framing a view, and its every leaf
    /// defers to intervals).
    pub leaf_bounds: bool,
    /// A level shallower than `depth` whose kept boxes frame a view: the build also
    /// finds what a framing octree to that level (`coarse_quadrics` and
    /// `leaf_bounds` off, no crease levels) would give as its
    /// [`Octree::surface_bounds`] (see [`Octree::frame`]), with the
    /// classifications the two trees share done once.
    pub frame_depth: Option<u32>,
    /// Levels of sub-boxes that find each kept leaf's hull (see
    /// [`HULL_LEVELS`]; 0: a leaf's hull is its box). Only where
    /// `leaf_bounds` is on.
    pub hull_levels: u32,
    /// Whether smooth boxes whose Lipschitz bound is already tight become
    /// leaves before `depth` (see [`TIGHT_RATIO`]); off: they go to `depth`.
    pub tight_leaves: bool,
    /// Whether a polynomial formula's rays are answered in Bernstein form
    /// ([`Octree::polynomial`]); off: by the octree search, as a reference
    /// for tests.
    pub polynomial_form: bool,
}

impl BuildOptions {
    /// `depth` levels, the default budget and crease levels.
    pub fn to_depth(depth: u32) -> BuildOptions {
        BuildOptions {
            depth,
            max_work: MAX_WORK,
            crease_levels: CREASE_LEVELS,
            specialise: true,
            coarse_quadrics: true,
            leaf_bounds: true,
            frame_depth: None,
            hull_levels: HULL_LEVELS,
            tight_leaves: true,
            polynomial_form: true,
        }
    }
}

/// A smooth kept box (no branch point open; f algebraic, and not at most
/// quadratic) from level [`TIGHT_LEVEL`] on is a leaf already where its
/// Lipschitz bound L is at most this many times the least |∇f| at its
/// centre, and ∇f does not swing across it ([`FLAT_RATIO`]). Rays then
/// decide it with a few more evaluations of f than its children would take,
/// each a few instructions, and cross one leaf instead of several; the
/// build makes one leaf's bounds instead of eight or more. A box where ∇f
/// nearly vanishes goes on (there finer bounds pay: the heart's cusps), and
/// so does one where f calls sin, exp and the like, whose evaluations cost
/// more than the walk they would spare (measured: the wavy sphere 1.2×, the
/// gyroid 1.08× the time of full-depth leaves at 1024²). Measured against
/// full depth, 1024², 2 threads: the torus 0.78×, Chmutov 0.86×, Kummer
/// 0.91×; at 640×480 the `torus` scene 0.72×, `glass` 0.68×.
pub const TIGHT_RATIO: f64 = 5.0;

/// A tight box's ∇f must not swing across it: the norm of the widths of
/// its components' enclosures is at most this many times L. (Width 2·L is
/// a gradient that takes opposite values, as over a period of an
/// oscillation.)
pub const FLAT_RATIO: f64 = 1.8;

/// The first level at which tight boxes stop ([`TIGHT_RATIO`]).
pub const TIGHT_LEVEL: u32 = 2;

/// Levels of sub-boxes of a kept leaf's box that find its hull
/// ([`Octree::leaf_hull`]): the box is cut in eight, those of the eight that a
/// test proves empty are dropped, and the others are cut again; the hull is
/// the smallest box holding the last level's kept sub-boxes. Rays then
/// search only the hull, and cross the leaf not at all where they miss it.
/// Two levels (a 4×4×4 grid at most) where every formula tested is at most
/// quadratic (planes and quadrics, and split leaves whose sides are: cheap,
/// nearly exact tests), and for leaves larger than the depth's (tight ones,
/// [`TIGHT_RATIO`]: measured, the torus at 1024² 0.90× the time of one
/// level, the `tangle_cube` scene 0.80×); one for other leaves. Measured at 1024² (instructions,
/// no shadows) against no hulls: the cube minus a ball 0.89×, the torus
/// 0.77×, the gyroid in a ball 0.95×; two levels everywhere cost the gyroid
/// in a ball more to build (at 384², 1.23×) than its rays saved.
pub const HULL_LEVELS: u32 = 2;

/// The most levels [`BuildOptions::hull_levels`] may ask for.
const MAX_HULL_LEVELS: u32 = 4;

/// How many levels above the leaves the rounding bounds of the whole formula
/// are computed, once per node, for every leaf below (a leaf computes its own
/// where they are coarse against its scale).
pub const ROUNDING_LEVELS: u32 = 3;

/// How many levels above the requested depth a creased box whose two sides
/// are both quadratic may already be a leaf (see [`SplitLeaf`]); at the
/// depth it is one, not subdivided for [`CREASE_LEVELS`].
const SPLIT_LEVELS_EARLY: u32 = 1;

/// The most shapes an octree compiles; leaves past it use the whole formula.
pub const MAX_SHAPES: usize = 512;

impl Leaf {
    /// A leaf of shape `shape` with no bounds known: rays decide everything
    /// in it by intervals.
    fn unknown(shape: u32) -> Leaf {
        Leaf {
            lipschitz: f64::INFINITY,
            slopes: [f64::INFINITY; 3],
            hessian: [Interval::ENTIRE; 6],
            hessian_norm: f64::INFINITY,
            point_hessian: false,
            f_error: f64::INFINITY,
            g_error: f64::INFINITY,
            needs_intervals: true,
            continuous: false,
            shape,
        }
    }

    /// A sound bound of `|g′(t)|` for a ray with direction `d` inside the leaf:
    /// `|dᵀ[H]d|`, the larger magnitude of [`Leaf::curvature`]'s ends.
    #[inline]
    pub fn grad_lipschitz(&self, d: DVec3) -> f64 {
        let (lo, hi) = self.curvature(d);
        lo.abs().max(hi.abs())
    }

    /// Sound bounds `(lo, hi)` of `g′(t) = dᵀH d` for a ray with direction `d`
    /// inside the leaf (`(−∞, +∞)` where the Hessian is unknown). With a
    /// point direction this needs no interval products: each term is an
    /// interval end times a number. The sums are rounded to nearest, so each
    /// end is moved out by a rounding allowance (twelve operations, each off
    /// by at most ε relative, bounded by 1e-12 of the sum of magnitudes).
    #[inline]
    pub fn curvature(&self, d: DVec3) -> (f64, f64) {
        let w = [
            d.x * d.x,
            d.y * d.y,
            d.z * d.z,
            2.0 * d.x * d.y,
            2.0 * d.x * d.z,
            2.0 * d.y * d.z,
        ];
        // Straight-line code (this runs for every leaf a ray enters): an
        // empty entry's NaN ends propagate to the result, and a zero weight
        // contributes nothing (0·∞ would be NaN).
        let (mut lo, mut hi, mut size) = (0.0f64, 0.0f64, 0.0f64);
        if self.point_hessian {
            // Both ends' products are one number a: the same sums as below
            // (a finite entry times a zero weight is a zero of either sign,
            // which adds nothing to a sum that starts at +0).
            for (h, &wk) in self.hessian.iter().zip(&w) {
                let a = h.inf() * wk;
                lo += a;
                size += a.abs();
            }
            hi = lo;
        } else {
            for (h, &wk) in self.hessian.iter().zip(&w) {
                let (a, b) = if wk == 0.0 {
                    (0.0, 0.0)
                } else {
                    (h.inf() * wk, h.sup() * wk)
                };
                let (l, u) = if a <= b { (a, b) } else { (b, a) };
                lo += l;
                hi += u;
                size += if a.abs() >= b.abs() { a.abs() } else { b.abs() };
            }
        }
        let (lo, hi) = (lo - 1e-12 * size, hi + 1e-12 * size);
        if lo.is_nan() || hi.is_nan() {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (lo, hi)
        }
    }
}

/// One node: an inner node with eight children, a kept leaf, or a pruned box.
///
/// Traversal reads nodes, not leaves, so a node is kept to one cache line:
/// leaf data lives apart in [`Octree::leaves`], and a node says which of its
/// children hold kept leaves, so dead children are never read.
#[derive(Debug, Clone)]
#[repr(align(64))]
pub struct OctreeNode {
    /// The node's box.
    pub bounds: Aabb,
    /// The first child's id (children never include the root, id 0).
    first_child: Option<NonZeroU32>,
    /// One more than the leaf's index in [`Octree::leaves`].
    leaf: Option<NonZeroU32>,
    /// One more than the index in [`Octree::start_bounds`] of this inner
    /// node's bounds (nodes three levels above the leaves).
    start: Option<NonZeroU32>,
    /// Bit k set when child k holds a kept leaf somewhere below it.
    alive_children: u8,
    /// Whether the node holds a kept leaf somewhere below it.
    alive: bool,
    /// Whether the node is a leaf whose hull is smaller than its box
    /// ([`Octree::leaf_hull`]).
    tight: bool,
}

impl OctreeNode {
    fn new(bounds: Aabb) -> OctreeNode {
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
    #[inline]
    pub fn leaf_index(&self) -> Option<usize> {
        self.leaf.map(|i| i.get() as usize - 1)
    }

    /// The index of the node's bounds in [`Octree::start_bounds`], for rays
    /// that start inside it (inner nodes three levels above the leaves).
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

    /// Whether the node is a leaf whose hull ([`Octree::leaf_hull`]) is
    /// smaller than its box.
    #[inline]
    pub fn is_tight(&self) -> bool {
        self.tight
    }
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
    /// Leaves whose formula was specialised: some branch point settled.
    pub specialised: usize,
    /// Leaves whose formula still holds a branch point (a crease or a jump
    /// may cross them).
    pub creased: usize,
    /// Shapes compiled, the whole formula included.
    pub shapes: usize,
    /// Creased leaves that carry bounds of their two smooth sides
    /// ([`SplitLeaf`]).
    pub split: usize,
    /// Leaves kept before the requested depth because their Lipschitz bound
    /// was already tight ([`TIGHT_RATIO`]).
    pub tight: usize,
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
    /// The kept leaves' data, referred to by [`OctreeNode::leaf_index`].
    pub leaves: Vec<Leaf>,
    /// Per kept leaf, the part of its box that holds the surface there
    /// ([`Octree::leaf_hull`]).
    hulls: Vec<Aabb>,
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
    /// The requested depth (boxes a crease may cross go deeper).
    pub depth: u32,
    /// Bounds of the whole formula over the whole (padded) box, for points
    /// that no single leaf covers.
    pub whole: WholeBounds,
    /// The sides of creased leaves that have two ([`Octree::split`]).
    splits: Vec<SplitLeaf>,
    /// Per leaf, one more than the index of its sides in `splits`, or 0.
    split_of: Vec<u32>,
    /// See [`Octree::frame`].
    frame: Option<Option<Aabb>>,
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
        Self::build_with(formula, bounds, &BuildOptions::to_depth(depth))
    }

    /// [`Octree::build`] with every limit chosen.
    pub fn build_with(formula: &Formula, bounds: &Aabb, options: &BuildOptions) -> Octree {
        super::awake::with_workers_awake(|| Self::build_in_pool(formula, bounds, options))
    }

    /// [`Octree::build_with`], with the pool's workers awake.
    fn build_in_pool(formula: &Formula, bounds: &Aabb, options: &BuildOptions) -> Octree {
        let &BuildOptions {
            depth,
            max_work,
            crease_levels,
            specialise,
            coarse_quadrics,
            leaf_bounds,
            frame_depth,
            hull_levels,
            tight_leaves,
            polynomial_form,
        } = options;
        let whole = Shape::new(formula);
        let points = if specialise {
            formula.branch_points()
        } else {
            Vec::new()
        };
        let operand_nodes: Vec<_> = points.iter().flat_map(|p| p.operands().to_vec()).collect();
        let plan = Plan {
            formula,
            whole: &whole,
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
        };
        // What one box costs to classify (eight corners, f and ∇f over it
        // and at its centre) and to make a leaf (∇f, Hessian, rounding, the
        // branch points' operands).
        let len = |t: &Tape| t.body().len() as u64 + 1;
        let classify_cost = 2 * len(&whole.f) + 2 * len(&whole.f_grad);
        let leaf_cost = len(&whole.f_grad)
            + len(&whole.local)
            + len(&whole.fg)
            + len(&whole.f) * 9 / 2
            + if plan.points.is_empty() {
                0
            } else {
                len(&plan.operands)
            };
        let padded_root = padded(bounds, plan.pad);
        // One enclosure of the whole formula over the padded box for both.
        let over = local_over(&whole, &padded_root);
        let affine = affine_form(&whole, &over, &padded_root);
        let mut shapes = Shapes {
            quadratic: vec![quadratic_over(&over)],
            bounds: padded_root,
            list: vec![whole.clone()],
            patterns: vec![vec![Branch::Open; plan.points.len()]],
            ids: FxHashMap::default(),
            remembered: FxHashMap::default(),
            splits: FxHashMap::default(),
        };
        // The frame: a framing tree classifies every box this one does down
        // to its depth, the same way (a box's shape comes from its parent's
        // settled branches in both), and the children of boxes this one
        // keeps early as leaves. It is found here unless a budget could
        // stop either tree before that depth (then it is left to a build of
        // its own).
        let framing_boxes = frame_depth.map_or(0, |fd| (0..=fd).map(|l| 8u64.pow(l)).sum());
        let mut frame = frame_depth
            .filter(|&fd| {
                fd < depth
                    && framing_boxes <= MAX_NODES as u64
                    && (classify_cost + leaf_cost).saturating_mul(framing_boxes) <= max_work
            })
            .map(|fd| Frame {
                depth: fd,
                hull: None,
                below_leaves: Vec::new(),
            });
        let mut splits = Vec::new();
        let mut split_of = Vec::new();
        let mut stats = OctreeStats::default();
        let mut nodes = vec![OctreeNode::new(*bounds)];
        let mut leaf_data = Vec::new();
        let mut start_bounds = Vec::new();
        // Level by level, each level's boxes in parallel: nodes still to
        // classify, each with the rounding bounds of f and g over its parent's
        // box when it is a leaf-to-be (those hold for it too: one evaluation
        // per eight leaves).
        let mut level_nodes: Vec<Task> = vec![Task {
            id: 0,
            parent: None,
            rounding: None,
            straddles: None,
            shape: 0,
        }];
        let mut level = 0u32;
        while !level_nodes.is_empty() {
            stats.work += classify_cost * level_nodes.len() as u64;
            // Each box is classified by the formula as its parent saw it
            // (the parent's settled branches hold on it too).
            let classes: Vec<Class> = level_nodes
                .par_iter()
                .map_init(
                    || Workspace::new(&plan, &shapes.list),
                    |ws, task| {
                        ws.current = task.shape;
                        ws.classify(&plan, &nodes[task.id as usize].bounds, task.straddles)
                    },
                )
                .collect();
            let mut possible = Vec::new();
            for (task, class) in level_nodes.iter().zip(classes) {
                match class {
                    Class::Possible => {
                        if let Some(frame) = frame.as_mut().filter(|f| f.depth == level) {
                            frame.keep(&nodes[task.id as usize].bounds);
                        }
                        possible.push(*task);
                    }
                    Class::PrunedByLipschitz => stats.pruned_by_lipschitz += 1,
                    Class::PrunedByInterval => stats.pruned_by_interval += 1,
                }
            }
            // The branches each kept box settles, with its parent's: the
            // shape it and its children see.
            // Patterns seen before are looked up here, in parallel; only new
            // ones are kept for [`Shapes::id`].
            let settled: Vec<Settled> = possible
                .par_iter()
                .map_init(
                    || (Workspace::new(&plan, &[]), Vec::new()),
                    |(ws, pattern), task| {
                        if shapes.list[task.shape as usize].open == 0 {
                            return Settled::Inherited;
                        }
                        let inherited = &shapes.patterns[task.shape as usize];
                        let b = &nodes[task.id as usize].bounds;
                        ws.branches(&plan, b, inherited, pattern);
                        match shapes.known(pattern) {
                            Some((shape, open)) => Settled::Known(shape, open),
                            None => Settled::New(pattern.clone()),
                        }
                    },
                )
                .collect();
            // Subdividing must keep the tree within its budgets; where it
            // would not, this level's boxes become the leaves (rays are then
            // slower, never less certain). At the requested depth, boxes a
            // crease may still cross go on for a few levels: most of them
            // then settle their branches.
            let new: Vec<&[Branch]> = settled
                .iter()
                .filter_map(|s| match s {
                    Settled::New(pattern) => Some(pattern.as_slice()),
                    _ => None,
                })
                .collect();
            shapes.compile(formula, &plan.points, &new);
            let mut finals = Vec::new();
            let mut further = Vec::new();
            for (task, pattern) in possible.iter().zip(settled) {
                let (shape, open) = match pattern {
                    Settled::New(pattern) => shapes.id(formula, &plan.points, &pattern),
                    Settled::Known(shape, open) => (shape, open),
                    Settled::Inherited => (task.shape, shapes.list[task.shape as usize].open),
                };
                let (id, rounding, parent) = (task.id, task.rounding, task.parent);
                if level < depth || (open > 0 && level < depth + crease_levels) {
                    further.push((id, shape, open, rounding));
                } else {
                    finals.push((id, rounding, shape, open, parent));
                }
            }
            // Smooth boxes whose Lipschitz bound is already tight are leaves
            // here (see `TIGHT_RATIO`). Like quadrics' boxes, they settle no
            // more branches, so a frame sees their children as their shape.
            let mut tight_finals = Vec::new();
            if tight_leaves && leaf_bounds && level >= TIGHT_LEVEL && level < depth {
                let (quadratic, list) = (&shapes.quadratic, &shapes.list);
                stats.work += 2 * len(&whole.f_grad) * further.len() as u64;
                let tight: Vec<bool> = further
                    .par_iter()
                    .map_init(
                        || Workspace::new(&plan, &shapes.list),
                        |ws, &(id, shape, open, _)| {
                            open == 0
                                && !quadratic[shape as usize]
                                && list[shape as usize].algebraic
                                && ws.is_tight(&plan, &nodes[id as usize].bounds, shape)
                        },
                    )
                    .collect();
                let mut kept = Vec::with_capacity(further.len());
                for (f, tight) in further.drain(..).zip(tight) {
                    if !tight {
                        kept.push(f);
                        continue;
                    }
                    if let Some(frame) = frame.as_mut().filter(|f| level < f.depth) {
                        let b = nodes[f.0 as usize].bounds;
                        frame.below_leaves.push((b, f.1, level));
                    }
                    stats.tight += 1;
                    tight_finals.push((f.0, f.3, f.1, f.2, None));
                }
                further = kept;
            }
            // Boxes where f is at most quadratic are leaves already, from the
            // root down: smaller boxes would not tighten the tests that decide
            // rays there, only make rays cross more leaves. (Along a ray F is
            // then a quadratic whose |F″| is G itself, and the second-order
            // test halves a leaf as well as the octree would; measured, a
            // sphere took 0.82x the instructions of stopping at level 3.)
            // So are creased boxes one level above the requested depth, or
            // at it, whose formula is the larger or smaller of two such sides
            // (a CSG of quadrics along its seam): each piece of a ray runs the
            // tests of the side it is proved to be on. (Instructions at 384²,
            // with the second-order side test, against leaves at the depth
            // without it: one level early, 0.91–0.94x on the CSG shapes; at
            // any level, the ball cut by a plane 0.85x but the cube minus a
            // ball 1.02x, whose rays then cross the hole's rim for long
            // stretches on which neither side holds.) At the depth itself such
            // a box would otherwise go on to the crease levels, eight smaller
            // split leaves for one: stopping there, the cube minus a ball took
            // 0.85x the instructions at 384² and 0.98x at 1024², its build
            // 0.69x.
            // Boxes made leaves here: their ids, open branch points and
            // where `checked` holds their leaves (read in place: copying the
            // leaves, a few hundred bytes each, cost a fresh page every
            // dozen).
            let mut early: Vec<(NodeId, usize, usize)> = Vec::new();
            let mut checked = Vec::new();
            if coarse_quadrics && level <= depth {
                let quadric_splits: Vec<Option<Split>> = further
                    .iter()
                    .map(|&(_, shape, open, _)| {
                        let split =
                            (specialise && open == 1 && level + SPLIT_LEVELS_EARLY >= depth)
                                .then(|| shapes.split(formula, &plan.points, shape))
                                .flatten()?;
                        let quadratic = |side: &u32| shapes.quadratic[*side as usize];
                        split.sides.iter().all(quadratic).then_some(split)
                    })
                    .collect();
                let candidates = further
                    .iter()
                    .zip(&quadric_splits)
                    .map(|(f, split)| match split {
                        Some(_) => 3,
                        None => u64::from(f.2 == 0 && shapes.quadratic[f.1 as usize]),
                    })
                    .sum::<u64>();
                stats.work += leaf_cost * candidates;
                let scale = 0.5f64.powi((depth - level) as i32);
                checked = further
                    .par_iter()
                    .zip(&quadric_splits)
                    .map_init(
                        || Workspace::new(&plan, &shapes.list),
                        |ws, (&(id, shape, open, _), split)| {
                            let b = &nodes[id as usize].bounds;
                            if let Some(split) = split {
                                let sides = split
                                    .sides
                                    .map(|side| ws.leaf(&plan, b, (None, None), side, 0).0);
                                if !sides.iter().all(quadric_leaf) {
                                    return None;
                                }
                                let (leaf, on_face) = ws.leaf(&plan, b, (None, None), shape, open);
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
                            let (leaf, on_face) = ws.leaf(&plan, b, (None, None), shape, 0);
                            quadric_leaf(&leaf).then_some((leaf, on_face, None))
                        },
                    )
                    .collect();
                let mut kept = Vec::with_capacity(further.len());
                for (i, (f, c)) in further.drain(..).zip(&checked).enumerate() {
                    match c {
                        Some(_) => early.push((f.0, f.2, i)),
                        None => kept.push(f),
                    }
                }
                further = kept;
            }
            for (id, open, i) in early {
                let Some((leaf, on_face, two)) = checked[i].take() else {
                    continue;
                };
                if frame.as_ref().is_some_and(|f| level < f.depth) {
                    // A leaf whose formula is at most quadratic settles no
                    // more branches: its children see its shape. (A split
                    // leaf's would settle more: its frame is left to a
                    // build of its own.)
                    match (&mut frame, two.is_none()) {
                        (Some(f), true) => {
                            f.below_leaves
                                .push((nodes[id as usize].bounds, leaf.shape, level))
                        }
                        _ => frame = None,
                    }
                }
                stats.leaves += 1;
                stats.leaves_on_faces += usize::from(on_face);
                stats.specialised += usize::from(leaf.shape != 0);
                stats.creased += usize::from(open > 0);
                if let Some(two) = two {
                    record_split(&mut splits, &mut split_of, leaf_data.len(), two);
                    stats.split += 1;
                }
                leaf_data.push(leaf);
                nodes[id as usize].leaf = NonZeroU32::new(leaf_data.len() as u32);
            }
            let children = 8 * further.len() as u64;
            let next_work = children * (classify_cost + leaf_cost);
            let fits =
                nodes.len() + 8 * further.len() <= MAX_NODES && stats.work + next_work <= max_work;
            if !fits && level < depth {
                stats.capped_at_depth = Some(level);
            }
            if frame.as_ref().is_some_and(|f| level < f.depth) && (!fits || !finals.is_empty()) {
                frame = None;
            }
            finals.append(&mut tight_finals);
            if !fits {
                // Everything left becomes a leaf, with the shape it sees.
                for (id, shape, open, rounding) in further.drain(..) {
                    finals.push((id, rounding, shape, open, None));
                }
            }
            stats.work += leaf_cost * finals.len() as u64;
            let leaves: Vec<(Leaf, bool)> = finals
                .par_iter()
                .map_init(
                    || Workspace::new(&plan, &shapes.list),
                    |ws, &(id, rounding, shape, open, parent)| {
                        if !leaf_bounds {
                            return (Leaf::unknown(shape), false);
                        }
                        let parent = parent.map(|p| (p, nodes[p as usize].bounds));
                        let b = &nodes[id as usize].bounds;
                        ws.leaf(&plan, b, (rounding, parent), shape, open)
                    },
                )
                .collect();
            // Creased leaves that are the larger or smaller of two smooth
            // sides also get each side's bounds (their shapes compiled first).
            let split: Vec<(usize, Split)> = finals
                .iter()
                .enumerate()
                .filter(|&(_, &(_, _, _, open, _))| leaf_bounds && specialise && open == 1)
                .filter_map(|(i, &(_, _, shape, _, _))| {
                    Some((i, shapes.split(formula, &plan.points, shape)?))
                })
                .collect();
            stats.work += leaf_cost * 2 * split.len() as u64;
            let sides: Vec<SplitLeaf> = split
                .par_iter()
                .map_init(
                    || Workspace::new(&plan, &shapes.list),
                    |ws, &(i, split)| {
                        let (id, rounding, _, _, parent) = finals[i];
                        let parent = parent.map(|p| (p, nodes[p as usize].bounds));
                        let b = &nodes[id as usize].bounds;
                        SplitLeaf {
                            larger: split.larger,
                            sides: split
                                .sides
                                .map(|side| ws.leaf(&plan, b, (rounding, parent), side, 0).0),
                            scale: 1.0,
                        }
                    },
                )
                .collect();
            let mut sides = split.iter().map(|s| s.0).zip(sides).peekable();
            for (i, (&(id, _, shape, open, _), (leaf, on_face))) in
                finals.iter().zip(leaves).enumerate()
            {
                stats.leaves += 1;
                stats.leaves_on_faces += usize::from(on_face);
                stats.specialised += usize::from(shape != 0);
                stats.creased += usize::from(open > 0);
                if let Some((_, two)) = sides.next_if(|s| s.0 == i) {
                    record_split(&mut splits, &mut split_of, leaf_data.len(), two);
                    stats.split += 1;
                }
                leaf_data.push(leaf);
                nodes[id as usize].leaf = NonZeroU32::new(leaf_data.len() as u32);
            }
            if !fits {
                break;
            }
            // Per box to subdivide: the rounding bounds its children inherit
            // (near the requested depth) and which children have corners on
            // both sides of the surface, from one 3×3×3 grid of f.
            let rounding_level = leaf_bounds && level + ROUNDING_LEVELS >= depth;
            // Three levels above the leaves, a node's own bounds serve rays that
            // start inside it (see `Octree::start_bounds`). Measured at 384²
            // with shadows: one level above cost more than it saved (the leaf's
            // test repeats where the node's fails), two saved 2 %, three 4 %
            // (torus, tangle cube), four 2–3 %.
            let start_level = leaf_bounds && level >= 1 && level + 3 == depth;
            let inherited: Vec<Inherited> = further
                .par_iter()
                .map_init(
                    || Workspace::new(&plan, &shapes.list),
                    |ws, &(id, shape, open, rounding)| {
                        let b = &nodes[id as usize].bounds;
                        // Only leaves that see the whole formula read them
                        // (a specialised shape's bounds are its own); a
                        // node's own are computed where its parent has none.
                        let rounding = (rounding_level && shape == 0)
                            .then(|| rounding.unwrap_or_else(|| ws.rounding(&plan, b)));
                        let start = start_level
                            .then(|| ws.leaf(&plan, b, (None, None), shape, open).0)
                            .filter(|l| !l.needs_intervals && l.continuous);
                        ws.current = shape;
                        (rounding, ws.children_straddling(b), start)
                    },
                )
                .collect();
            let mut next = Vec::with_capacity(8 * further.len());
            nodes.reserve(8 * further.len());
            for (&(id, shape, ..), (rounding, straddles, start)) in further.iter().zip(inherited) {
                if let Some(start) = start {
                    start_bounds.push(start);
                    nodes[id as usize].start = NonZeroU32::new(start_bounds.len() as u32);
                }
                let b = nodes[id as usize].bounds;
                let first = nodes.len() as NodeId;
                nodes[id as usize].first_child = NonZeroU32::new(first);
                for (k, child) in b.octants().iter().enumerate() {
                    nodes.push(OctreeNode::new(*child));
                    next.push(Task {
                        id: first + k as NodeId,
                        parent: Some(id),
                        rounding,
                        straddles: Some(straddles[k]),
                        shape,
                    });
                }
            }
            level_nodes = next;
            level += 1;
        }
        mark_alive(&mut nodes);
        let frame = frame.map(|f| f.complete(&plan, &shapes.list));
        // Each kept leaf's hull, where the budget allows (at most
        // 8 + 8² + … sub-boxes per leaf, each an evaluation of f, or of both
        // sides of a split leaf).
        let sub_boxes: u64 = (1..=hull_levels).map(|l| 8u64.saturating_pow(l)).sum();
        let hull_work = (2 * len(&whole.fg) * sub_boxes).saturating_mul(leaf_data.len() as u64);
        // (The leaf's box where no hull is found.)
        let leaf_nodes: Vec<(NodeId, usize)> = (0..nodes.len() as NodeId)
            .filter_map(|id| Some((id, nodes[id as usize].leaf_index()?)))
            .collect();
        let mut hulls = vec![*bounds; leaf_data.len()];
        for &(id, i) in &leaf_nodes {
            hulls[i] = nodes[id as usize].bounds;
        }
        let leaf_width = (bounds.hi.x - bounds.lo.x) * 0.5f64.powi(depth as i32);
        if leaf_bounds && hull_levels > 0 && stats.work + hull_work <= max_work {
            stats.work += hull_work;
            let found: Vec<Aabb> = leaf_nodes
                .par_iter()
                .map_init(
                    || HullFinder::new(&shapes.list, &shapes.quadratic),
                    |finder, &(id, i)| {
                        let split = split_at(&splits, &split_of, i);
                        let b = &nodes[id as usize].bounds;
                        // Leaves above the depth (tight ones) are large:
                        // more of them is empty.
                        let early = b.hi.x - b.lo.x > 1.5 * leaf_width;
                        finder.hull(&plan, b, &leaf_data[i], split, hull_levels, early)
                    },
                )
                .collect();
            for (&(id, i), hull) in leaf_nodes.iter().zip(found) {
                let node = &mut nodes[id as usize];
                node.tight = hull != node.bounds;
                hulls[i] = hull;
            }
        }
        let whole = {
            let mut ws = Workspace::new(&plan, &[]);
            let padded_box = padded(bounds, plan.pad);
            let ([f, gx, gy, gz], continuous) = ws.intervals(&padded_box);
            let grad = [gx, gy, gz];
            WholeBounds {
                f_error: ws.rounding(&plan, bounds).0,
                lipschitz: if grad.iter().all(|g| g.is_bounded()) {
                    lipschitz(grad.map(|g| g.mag()))
                } else {
                    f64::INFINITY
                },
                continuous: continuous && !f.is_empty(),
            }
        };
        let polynomial = match (&affine, shapes.list[0].open) {
            (None, 0) if polynomial_form => {
                AlongLine::compile(&shapes.list[0].f).and_then(Polynomial::new)
            }
            _ => None,
        };
        let shapes = shapes.list;
        stats.shapes = shapes.len();
        Octree {
            nodes,
            leaves: leaf_data,
            hulls,
            start_bounds,
            bounds: *bounds,
            stats,
            pad: plan.pad,
            shapes,
            depth,
            whole,
            splits,
            split_of,
            frame,
            affine,
            polynomial,
        }
    }

    /// The view frame of [`BuildOptions::frame_depth`]: the smallest box
    /// holding every box a framing octree to that depth keeps (`Some(None)`
    /// when it keeps none), exactly its [`Octree::surface_bounds`]; `None`
    /// when it was not asked for or could not be found with this tree.
    pub fn frame(&self) -> Option<Option<Aabb>> {
        self.frame
    }

    /// The smallest box of sub-boxes of the leaf `leaves[index]`'s box that
    /// holds every point of the surface in it (see [`HULL_LEVELS`]; the
    /// sub-boxes left out were proved empty padded, as pruned boxes are): a
    /// ray searches the leaf only where it crosses this box. A point where the
    /// leaf holds no surface at all; the leaf's box where hulls were not
    /// found.
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
        let diagonal = |b: &Aabb| (b.hi - b.lo).length();
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

/// f as an affine form over `b`, when it is one there: no branch point, f,
/// ∇f and the Hessian defined and continuous over `b`, and the Hessian's
/// enclosure exactly 0 (so ∇f is constant on the box: a plane).
/// `over` is f, ∇f and the Hessian enclosed over `b` ([`local_over`]).
fn affine_form(shape: &Shape, over: &[DecInterval], b: &Aabb) -> Option<Affine> {
    if shape.open > 0 {
        return None;
    }
    let continuous = over.iter().all(|v| v.decoration() == Decoration::Dac);
    let flat = over[4..]
        .iter()
        .all(|h| h.interval() == Interval::point(0.0));
    if !continuous || !flat {
        return None;
    }
    let c = b.center();
    let value = Evaluator::new(&shape.f).eval(&point_inputs(c))[0];
    if value.decoration() != Decoration::Dac {
        return None;
    }
    Affine::new(c, value.interval(), [1, 2, 3].map(|i| over[i].interval()))
}

/// The shape's f, ∇f and Hessian (xx, yy, zz, xy, xz, yz) enclosed over `b`.
fn local_over(shape: &Shape, b: &Aabb) -> Vec<DecInterval> {
    let [x, y, z] = b.intervals().map(DecInterval::defined);
    let zero = DecInterval::defined(Interval::point(0.0));
    Evaluator::new(&shape.local)
        .eval(&[x, y, z, zero, zero, zero])
        .to_vec()
}

/// Whether the shape's interval Hessian over `b` has no width: f is at most
/// quadratic there (a sphere, a plane, a placed quadric primitive).
fn at_most_quadratic(shape: &Shape, b: &Aabb) -> bool {
    quadratic_over(&local_over(shape, b))
}

/// [`at_most_quadratic`] from the enclosures [`local_over`] gives.
fn quadratic_over(over: &[DecInterval]) -> bool {
    let h = &over[4..];
    !partly_undefined(h) && h.iter().all(|v| constant(v.interval()))
}

/// An enclosure of one number up to the rounding of its computation.
fn constant(h: Interval) -> bool {
    !h.is_empty() && h.is_bounded() && h.wid() <= 1e-9 * (1.0 + h.mag())
}

/// Whether a leaf of a quadratic shape is fine enough: its interval Hessian
/// has no width, so smaller boxes could not tighten G, the bound that decides
/// rays crossing it, and rays would only cross more leaves.
pub fn quadric_leaf(leaf: &Leaf) -> bool {
    !leaf.needs_intervals && leaf.lipschitz.is_finite() && leaf.hessian.iter().all(|&h| constant(h))
}

/// The sides of leaf `index` as [`record_split`] recorded them, if any.
#[inline]
fn split_at<'a>(splits: &'a [SplitLeaf], split_of: &[u32], index: usize) -> Option<&'a SplitLeaf> {
    match split_of.get(index) {
        Some(&k) if k > 0 => splits.get(k as usize - 1),
        _ => None,
    }
}

/// Records `two` as the sides of the leaf about to be pushed as
/// `leaves[leaf]` (see [`Octree::split`]).
fn record_split(splits: &mut Vec<SplitLeaf>, split_of: &mut Vec<u32>, leaf: usize, two: SplitLeaf) {
    splits.push(two);
    split_of.resize(leaf, 0);
    split_of.push(splits.len() as u32);
}

/// The view frame a build finds on the way ([`BuildOptions::frame_depth`]).
struct Frame {
    depth: u32,
    /// The boxes kept at `depth` so far.
    hull: Option<Aabb>,
    /// Leaves kept above `depth` whose formula settles no more branches:
    /// their boxes, shapes and levels.
    below_leaves: Vec<(Aabb, u32, u32)>,
}

impl Frame {
    fn keep(&mut self, b: &Aabb) {
        self.hull = Some(self.hull.map_or(*b, |h| h.union(b)));
    }

    /// The hull, with the boxes a framing tree keeps below the leaves kept
    /// early, classified level by level as it would (same shape, corner
    /// signs from the parent's grid).
    fn complete(mut self, plan: &Plan, shapes: &[Shape]) -> Option<Aabb> {
        let mut boxes = std::mem::take(&mut self.below_leaves);
        while !boxes.is_empty() {
            let kept: Vec<(Aabb, u32, u32)> = boxes
                .par_iter()
                .map_init(
                    || Workspace::new(plan, shapes),
                    |ws, &(b, shape, level)| {
                        ws.current = shape;
                        let straddles = ws.children_straddling(&b);
                        let children = b.octants();
                        (0..8)
                            .filter(|&k| {
                                let class = ws.classify(plan, &children[k], Some(straddles[k]));
                                matches!(class, Class::Possible)
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

/// Marks the nodes that hold a kept leaf, so traversal skips the rest.
/// Children always come after their parent, so one backward pass settles it.
fn mark_alive(nodes: &mut [OctreeNode]) {
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

/// What a subdivided box hands its children: rounding bounds (near the
/// requested depth) and whether each child's corners straddle the surface.
type Inherited = (Option<(f64, f64)>, [bool; 8], Option<Leaf>);

/// A shape's rounding bounds of f and g over a parent box: the parent's id,
/// the shape, the bounds.
type ShapeRounding = (NodeId, u32, (f64, f64));

/// A leaf's parent: its id and box.
type ParentBox = (NodeId, Aabb);

/// A box to classify.
#[derive(Clone, Copy)]
struct Task {
    id: NodeId,
    /// The box this one was split from.
    parent: Option<NodeId>,
    /// Rounding bounds of f and g over the parent's box, for leaves-to-be.
    rounding: Option<(f64, f64)>,
    /// Whether f's f64 values at the box's corners take both signs, when the
    /// parent's grid already says.
    straddles: Option<bool>,
    /// The shape its parent saw: the branches settled there hold here too.
    shape: u32,
}

enum Class {
    /// Discarded because `|f(x₀)| > L·d`.
    PrunedByLipschitz,
    /// Discarded because the interval of f over it excludes 0.
    PrunedByInterval,
    /// May hold the surface.
    Possible,
}

/// The outputs the intersector evaluates in f64 (its `fg` tape): their
/// rounding is bounded per leaf over this same tape.
pub const FG: [Output; 2] = [Output::F, Output::G];

/// What the work on every box reads.
struct Plan<'t> {
    formula: &'t Formula,
    whole: &'t Shape,
    /// The operands of every branch point, in order.
    operands: Tape,
    points: Vec<BranchPoint>,
    index: PointIndex,
    /// Where each point's operands start among the operands.
    starts: Vec<usize>,
    pad: f64,
    bounds: Aabb,
}

/// The specialised shapes compiled so far, by the branches they decide.
struct Shapes {
    /// The whole formula first.
    list: Vec<Shape>,
    /// Whether each shape is at most quadratic in the whole (padded) box.
    quadratic: Vec<bool>,
    /// The padded bounding box.
    bounds: Aabb,
    /// The (normalised) branches each shape decides.
    patterns: Vec<Vec<Branch>>,
    ids: FxHashMap<Vec<Branch>, u32>,
    /// Answers of [`Shapes::id`] by the pattern as given, before it is
    /// normalised (a walk of the whole formula): neighbouring boxes settle
    /// the same branches, so most patterns recur. At most
    /// [`MAX_REMEMBERED_BRANCHES`] branches in all, whatever the formula.
    remembered: FxHashMap<Vec<Branch>, (u32, usize)>,
    /// Each creased shape's two smooth sides, where it has them.
    splits: FxHashMap<u32, Option<Split>>,
}

/// A shape that is the larger or smaller of two smooth shapes.
#[derive(Debug, Clone, Copy)]
struct Split {
    larger: bool,
    sides: [u32; 2],
}

/// The shape a kept box sees, as its branches settle it.
enum Settled {
    /// Its parent's: no branch point was open there.
    Inherited,
    /// A shape compiled before, and the branch points it leaves open.
    Known(u32, usize),
    /// A pattern not seen before, for [`Shapes::id`].
    New(Vec<Branch>),
}

/// Branches (one byte each) of the patterns [`Shapes`] remembers; past it,
/// each new pattern is normalised again.
const MAX_REMEMBERED_BRANCHES: usize = 1 << 24;

impl Shapes {
    /// Compiles, in parallel, the shapes of the `patterns` not compiled yet
    /// (in order, while fewer than [`MAX_SHAPES`] are), so that
    /// [`Shapes::id`] then finds them.
    fn compile(&mut self, formula: &Formula, points: &[BranchPoint], patterns: &[&[Branch]]) {
        let mut todo: Vec<Vec<Branch>> = Vec::new();
        let mut seen = rustc_hash::FxHashSet::default();
        for &pattern in patterns {
            if self.list.len() + todo.len() >= MAX_SHAPES {
                break;
            }
            if !seen.insert(pattern) || self.known(pattern).is_some() {
                continue;
            }
            let normalised = normalise(formula.context(), formula.f(), points, pattern);
            if !self.ids.contains_key(&normalised) && !todo.contains(&normalised) {
                todo.push(normalised);
            }
        }
        let compiled: Vec<Shape> = todo
            .par_iter()
            .map(|n| Shape::new(&formula.specialised(points, n)))
            .collect();
        for (normalised, shape) in todo.into_iter().zip(compiled) {
            let id = self.list.len() as u32;
            self.quadratic.push(at_most_quadratic(&shape, &self.bounds));
            self.list.push(shape);
            self.patterns.push(normalised.clone());
            self.ids.insert(normalised, id);
        }
    }

    /// The two smooth sides of `shape`, a shape with one open branch point,
    /// where it is the larger or smaller of them (compiled on first use);
    /// `None` otherwise, or when [`MAX_SHAPES`] are compiled.
    fn split(&mut self, formula: &Formula, points: &[BranchPoint], shape: u32) -> Option<Split> {
        if let Some(&split) = self.splits.get(&shape) {
            return split;
        }
        let pattern = self.patterns[shape as usize].clone();
        let split =
            root_split(formula.context(), formula.f(), points, &pattern).and_then(|(i, larger)| {
                let mut sides = [0; 2];
                for (side, branch) in sides.iter_mut().zip([Branch::First, Branch::Second]) {
                    let mut decided = pattern.clone();
                    decided[i] = branch;
                    match self.id(formula, points, &decided) {
                        (id, 0) if id != 0 => *side = id,
                        _ => return None,
                    }
                }
                Some(Split { larger, sides })
            });
        self.splits.insert(shape, split);
        split
    }

    /// [`Shapes::id`] for a pattern seen before (no compiling, no walk of
    /// the formula); `None` for a new one.
    fn known(&self, pattern: &[Branch]) -> Option<(u32, usize)> {
        if pattern.iter().all(|&b| b == Branch::Open) {
            return Some((0, pattern.len()));
        }
        self.remembered.get(pattern).copied()
    }

    /// The shape for `pattern` (compiled on first use) and how many branch
    /// points it leaves open; the whole formula when nothing is decided or
    /// [`MAX_SHAPES`] are compiled.
    fn id(
        &mut self,
        formula: &Formula,
        points: &[BranchPoint],
        pattern: &[Branch],
    ) -> (u32, usize) {
        let whole = (0, points.len());
        if pattern.iter().all(|&b| b == Branch::Open) {
            return whole;
        }
        if let Some(&answer) = self.remembered.get(pattern) {
            return answer;
        }
        let normalised = normalise(formula.context(), formula.f(), points, pattern);
        let answer = if let Some(&id) = self.ids.get(&normalised) {
            (id, self.list[id as usize].open)
        } else if self.list.len() >= MAX_SHAPES {
            whole
        } else {
            let shape = Shape::new(&formula.specialised(points, &normalised));
            let open = shape.open;
            let id = self.list.len() as u32;
            self.quadratic.push(at_most_quadratic(&shape, &self.bounds));
            self.list.push(shape);
            self.patterns.push(normalised.clone());
            self.ids.insert(normalised, id);
            (id, open)
        };
        if (self.remembered.len() + 1) * pattern.len() <= MAX_REMEMBERED_BRANCHES {
            self.remembered.insert(pattern.to_vec(), answer);
        }
        answer
    }
}

/// The evaluators of one shape over boxes: those that classify a box, and
/// those that make a leaf of it.
struct ShapeEvaluators<'t> {
    f_grad: DecoratedEvaluator<'t>,
    f_point: PointEvaluator<'t>,
    /// f alone, for enclosures at points.
    f_interval: DecoratedEvaluator<'t>,
    /// f, ∇f and the Hessian, for leaves.
    local: DecoratedEvaluator<'t>,
    rounding: Evaluator<'t, RoundingBound>,
    /// The rounding of f alone (the same operations as f in `rounding`), for
    /// creased leaves, where g's is never read.
    rounding_f: Evaluator<'t, RoundingBound>,
    /// f at many points at once, made on first use where its register file
    /// is small (see [`Workspace::f_at_grid`]).
    f_batch: Option<BatchEvaluator<'t>>,
    f: &'t Tape,
}

impl<'t> ShapeEvaluators<'t> {
    fn new(shape: &'t Shape) -> ShapeEvaluators<'t> {
        ShapeEvaluators {
            f_grad: DecoratedEvaluator::new(&shape.f_grad),
            f_point: PointEvaluator::new(&shape.f),
            f_interval: DecoratedEvaluator::new(&shape.f),
            local: DecoratedEvaluator::new(&shape.local),
            rounding: Evaluator::new(&shape.fg),
            rounding_f: Evaluator::new(&shape.f),
            f_batch: None,
            f: &shape.f,
        }
    }
}

/// The most slots a tape may have for [`Workspace::f_at_grid`] to evaluate
/// it in a batch: its register file is `LANES` values a slot (256 KB here).
const MAX_BATCH_SLOTS: usize = 512;

/// The most batch slots one workspace holds over all its shapes (8 MB of
/// register files), so that a formula with hundreds of large shapes cannot
/// make each thread's evaluators grow past it; shapes after that evaluate
/// point by point.
const MAX_WORKSPACE_BATCH_SLOTS: usize = 16 * 1024;

/// One thread's evaluators of the whole formula, and of the shapes it
/// classifies boxes by.
struct Workspace<'t> {
    /// The rounding bounds of the last few specialised shapes over a parent
    /// box: siblings with the same shape share them (a split leaf's two
    /// sides alternate, so one would not do).
    shape_rounding: [Option<ShapeRounding>; 4],
    whole: ShapeEvaluators<'t>,
    /// Shapes that boxes are classified by ([`Workspace::current`]).
    shapes: &'t [Shape],
    /// Their evaluators, made on first use.
    shaped: FxHashMap<u32, ShapeEvaluators<'t>>,
    /// The shape that `classify` and `children_straddling` evaluate: the
    /// formula as the box's parent saw it (0: the whole formula).
    current: u32,
    operands: DecoratedEvaluator<'t>,
    /// Batch slots still allowed ([`MAX_WORKSPACE_BATCH_SLOTS`]).
    batch_slots_left: usize,
}

impl<'t> Workspace<'t> {
    fn new(plan: &'t Plan, shapes: &'t [Shape]) -> Workspace<'t> {
        Workspace {
            shape_rounding: [None; 4],
            whole: ShapeEvaluators::new(plan.whole),
            shapes,
            shaped: FxHashMap::default(),
            current: 0,
            operands: DecoratedEvaluator::new(&plan.operands),
            batch_slots_left: MAX_WORKSPACE_BATCH_SLOTS,
        }
    }

    /// The evaluators of shape `id` (0: the whole formula).
    fn evaluators(&mut self, id: u32) -> &mut ShapeEvaluators<'t> {
        if id == 0 {
            return &mut self.whole;
        }
        let shape = &self.shapes[id as usize];
        self.shaped
            .entry(id)
            .or_insert_with(|| ShapeEvaluators::new(shape))
    }

    /// The evaluators of the current shape.
    fn classifiers(&mut self) -> &mut ShapeEvaluators<'t> {
        self.evaluators(self.current)
    }

    /// [`Workspace::f_at`] at each of `points`, bit for bit (the batch
    /// evaluator agrees with the point evaluators), in one batch where the
    /// current shape is arithmetic, interpreted and its register file small:
    /// one dispatch per instruction for all of them rather than one per
    /// point.
    fn f_at_grid<const N: usize>(&mut self, points: [DVec3; N]) -> [f64; N] {
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

    fn f_at(&mut self, p: DVec3) -> f64 {
        self.classifiers()
            .f_point
            .eval_array::<1>(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0]
    }

    /// Whether f changes sign on a face this leaf shares with the bounding
    /// box, sampled on a 3×3 grid: the surface then runs into the box's wall.
    fn surface_crosses_outer_face(&mut self, plan: &Plan, b: &Aabb) -> bool {
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

    /// f and ∇f over the box, and whether paths through it support a
    /// Lipschitz argument: f defined and continuous on all of it, and its
    /// (Clarke) gradient defined there.
    fn intervals(&mut self, b: &Aabb) -> ([Interval; 4], bool) {
        let [x, y, z] = b.intervals().map(DecInterval::defined);
        let zero = DecInterval::defined(Interval::point(0.0));
        let v = self.classifiers().f_grad.eval(&[x, y, z, zero, zero, zero]);
        let lipschitz_ok = v[0].decoration() == Decoration::Dac && !partly_undefined(&v[1..4]);
        (
            [v[0], v[1], v[2], v[3]].map(DecInterval::interval),
            lipschitz_ok,
        )
    }

    /// Whether f's f64 values at the corners of each octant of `b` take both
    /// signs (a zero counts as both), from f on the 3×3×3 grid of their
    /// corners: 27 evaluations where the octants one by one take 64.
    fn children_straddling(&mut self, b: &Aabb) -> [bool; 8] {
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
    fn classify(&mut self, plan: &Plan, b: &Aabb, straddles: Option<bool>) -> Class {
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
            return Class::Possible;
        }
        // Proofs of emptiness cover the padded box, so that rays whose
        // rounded crossings stray into it skip nothing.
        let b = &padded(b, plan.pad);
        let ([f, gx, gy, gz], lipschitz_ok) = self.intervals(b);
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
        if f.is_empty() || !f.contains(0.0) {
            return Class::PrunedByInterval;
        }
        Class::Possible
    }

    /// Whether shape `shape`'s Lipschitz bound L over `b` (padded) is tight
    /// ([`TIGHT_RATIO`], [`FLAT_RATIO`]).
    fn is_tight(&mut self, plan: &Plan, b: &Aabb, shape: u32) -> bool {
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

    fn centre_enclosure(&mut self, p: DVec3) -> Interval {
        self.classifiers().f_interval.eval(&point_inputs(p))[0].interval()
    }

    /// Bounds of the rounding error of the whole formula's f64 values of f
    /// and g (for directions in [-1, 1]³) anywhere in the padded box.
    fn rounding(&mut self, plan: &Plan, b: &Aabb) -> (f64, f64) {
        rounding_over(&mut self.whole.rounding, b, plan.pad)
    }

    /// The branch each branch point takes over the padded box `b`, with those
    /// its parent took (`inherited`), into `out` (all open for a formula with
    /// none). A branch is taken where it is the formula's value on the whole
    /// box, or, at a `max` (`min`) at the root, where the other side is below
    /// (above) 0 on the whole box: the formula there is not f but has f's
    /// sign everywhere in the box, so it has the same surface, and rays find
    /// the same first root in it. (Leaves see shapes; only their signs are
    /// certified, and their bounds are the shape's own.)
    fn branches(&mut self, plan: &Plan, b: &Aabb, inherited: &[Branch], out: &mut Vec<Branch>) {
        out.clear();
        if plan.points.is_empty() {
            return;
        }
        let [x, y, z] = padded(b, plan.pad).intervals().map(DecInterval::defined);
        let zero = DecInterval::defined(Interval::point(0.0));
        let values = self.operands.eval(&[x, y, z, zero, zero, zero]);
        // Each point's operands' enclosures, where all are defined: dropping
        // a branch must not drop where f is undefined.
        let mut at = 0;
        let enclosures = |p: &BranchPoint, at: &mut usize| {
            let ops = &values[*at..*at + p.operands().len()];
            *at += ops.len();
            let mut enclosures = [Interval::EMPTY; 3];
            for (e, v) in enclosures.iter_mut().zip(ops) {
                *e = v.interval();
            }
            let defined = ops.iter().all(|v| v.decoration() >= Decoration::Def);
            defined.then_some(enclosures)
        };
        out.extend(plan.points.iter().zip(inherited).map(|(p, &parent)| {
            match enclosures(p, &mut at) {
                _ if parent != Branch::Open => parent,
                Some(e) => p.decide(&e[..p.operands().len()]),
                None => Branch::Open,
            }
        }));
        // Each decision at the root may bring another max or min to it.
        let (ctx, points, index) = (plan.formula.context(), &plan.points, &plan.index);
        let mut split = RootSplit::of(ctx, plan.formula.f(), points, index, out);
        while let Some(s) = split {
            let point = &points[s.point];
            let branch = enclosures(point, &mut { plan.starts[s.point] })
                .map_or(Branch::Open, |e| s.sign_branch(e[0], e[1]));
            if branch == Branch::Open {
                break;
            }
            out[s.point] = branch;
            split = s.then(ctx, points, index, out);
        }
    }

    /// The data of the leaf with box `unpadded`, from the workspace's shape
    /// `shape_id`, and whether the surface crosses an outer face there.
    /// `inherited` are the rounding bounds of the whole formula over its
    /// parent's box and that parent (id and box): bounds over the parent hold
    /// for the leaf, and are used when they are small against its scale.
    fn leaf(
        &mut self,
        plan: &Plan,
        unpadded: &Aabb,
        inherited: (Option<(f64, f64)>, Option<ParentBox>),
        shape_id: u32,
        open: usize,
    ) -> (Leaf, bool) {
        let (inherited, parent) = inherited;
        let on_face = self.surface_crosses_outer_face(plan, unpadded);
        let b = &padded(unpadded, plan.pad);
        let [x, y, z] = b.intervals().map(DecInterval::defined);
        let zero = DecInterval::defined(Interval::point(0.0));
        let inputs = [x, y, z, zero, zero, zero];
        let size = (b.hi - b.lo).length();
        if open > 0 {
            // A branch point the leaf leaves open may make ∇f jump inside it.
            // Where it does, g = d·∇f has no finite rate of change (the
            // Hessian holds a Dirac term), so rays here are decided by L and
            // intervals alone, and neither the Hessian nor g's rounding is
            // worth computing.
            let v = self.evaluators(shape_id).f_grad.eval(&inputs);
            let v: [DecInterval; 4] = std::array::from_fn(|i| v[i]);
            if v[1..].iter().any(|g| g.decoration() < Decoration::Dac) {
                let (f, slopes, lipschitz_bound, lipschitz_ok) = first_order(&v);
                let f_error = match inherited {
                    Some((fe, _)) if shape_id == 0 && fe <= 1e-9 * lipschitz_bound * size => fe,
                    _ => {
                        let e = &mut self.evaluators(shape_id).rounding_f;
                        rounding_of_f(e, unpadded, plan.pad)
                    }
                };
                let leaf = Leaf {
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
                };
                return (leaf, on_face);
            }
        }
        let local = self.evaluators(shape_id).local.eval(&inputs);
        let v: [DecInterval; 4] = std::array::from_fn(|i| local[i]);
        let h: [DecInterval; 6] = std::array::from_fn(|i| local[4 + i]);
        let (f, slopes, lipschitz_bound, lipschitz_ok) = first_order(&v);
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
}

/// Finds the hulls of kept leaves ([`Octree::leaf_hull`]); one per thread.
struct HullFinder<'t> {
    shapes: &'t [Shape],
    quadratic: &'t [bool],
    /// Point evaluators of each shape's f and g (g unread): the tape rays
    /// evaluate, compiled where it is evaluated often (its machine code then
    /// serves them too); made on first use.
    evaluators: FxHashMap<u32, PointEvaluator<'t>>,
    /// Sub-boxes still to test, with their levels.
    stack: Vec<(Aabb, u32)>,
}

impl<'t> HullFinder<'t> {
    fn new(shapes: &'t [Shape], quadratic: &'t [bool]) -> HullFinder<'t> {
        HullFinder {
            shapes,
            quadratic,
            evaluators: FxHashMap::default(),
            stack: Vec::new(),
        }
    }

    fn evaluator(&mut self, shape: u32) -> &mut PointEvaluator<'t> {
        let shapes = self.shapes;
        self.evaluators
            .entry(shape)
            .or_insert_with(|| PointEvaluator::new(&shapes[shape as usize].fg))
    }

    /// The hull of the leaf box `unpadded` ([`Octree::leaf_hull`]): the
    /// sub-boxes that no test proves empty, padded, down to `levels` levels
    /// where every formula tested is at most quadratic, one level elsewhere
    /// (see [`HULL_LEVELS`]).
    ///
    /// The test is the mean-value form with a formula's bounds of its partial
    /// derivatives over the leaf: within `r` of a sub-box's centre c (per
    /// axis), `|F − F(c)| ≤ Σ sᵢ·rᵢ`, so F keeps the sign of F(c) there where
    /// `|F(c)|`, less its rounding error, is larger; one evaluation at a
    /// point, exact for a plane along an axis. F is the formula as the leaf
    /// sees it (its sign is f's in the padded leaf), or for a split leaf each
    /// of its sides: their larger (smaller) has no root where one side stays
    /// above (below) 0 or both below (above). The leaf's box where no such
    /// bound holds; the centre of `unpadded` when no sub-box is left.
    fn hull(
        &mut self,
        plan: &Plan,
        unpadded: &Aabb,
        leaf: &Leaf,
        split: Option<&SplitLeaf>,
        levels: u32,
        early: bool,
    ) -> Aabb {
        let formulas = match split {
            Some(split) => &split.sides[..],
            None => std::slice::from_ref(leaf),
        };
        let bounded = |l: &Leaf| {
            l.continuous && l.f_error.is_finite() && l.slopes.iter().all(|s| s.is_finite())
        };
        if levels == 0 || !formulas.iter().all(bounded) {
            return *unpadded;
        }
        let quadratic = formulas.iter().all(|l| self.quadratic[l.shape as usize]);
        let levels = if quadratic || early {
            levels.min(MAX_HULL_LEVELS)
        } else {
            1
        };
        // Every point of a padded sub-box `level` deep lies within `reach`
        // of its computed centre, per axis: half its width, the pad, and
        // ulps of the coordinates for the roundings of the cuts and centres.
        let width = unpadded.hi - unpadded.lo;
        let ulps = 8.0 * f64::EPSILON * unpadded.lo.abs().max(unpadded.hi.abs());
        let reach = |level: u32| width * 0.5f64.powi(level as i32 + 1) + plan.pad + ulps;
        // Per formula, how far it may move from its value at the centre of a
        // sub-box one level below `level`: products and sums of non-negative
        // numbers, raised to cover their roundings.
        let moves = |l: &Leaf| -> [f64; MAX_HULL_LEVELS as usize] {
            let slopes = DVec3::from(l.slopes);
            std::array::from_fn(|level| {
                let r = reach(level as u32 + 1);
                slopes.dot(r) * (1.0 + 8.0 * f64::EPSILON) + f64::MIN_POSITIVE
            })
        };
        let limits: [_; 2] = std::array::from_fn(|k| {
            formulas
                .get(k)
                .map_or([f64::INFINITY; MAX_HULL_LEVELS as usize], moves)
        });
        // A split leaf's shorter side is evaluated first: the other is not
        // where it decides.
        let length = |l: &Leaf| self.shapes[l.shape as usize].fg.body().len();
        let first = usize::from(formulas.len() == 2 && length(&formulas[1]) < length(&formulas[0]));
        let mut stack = std::mem::take(&mut self.stack);
        let mut hull: Option<Aabb> = None;
        stack.clear();
        stack.push((*unpadded, 0));
        while let Some((b, level)) = stack.pop() {
            if level == levels {
                hull = Some(hull.map_or(b, |h| h.union(&b)));
                continue;
            }
            let kept = stack.len();
            for child in b.octants() {
                let c = child.center();
                // The sign formula k keeps on the child, or 0.
                let mut sign = |k: usize| {
                    let l = &formulas[k];
                    let [v, _] = self
                        .evaluator(l.shape)
                        .eval_array::<2>(&[c.x, c.y, c.z, 0.0, 0.0, 0.0]);
                    // |v| − err, lowered by its own rounding; NaN keeps no sign.
                    let low = (v.abs() - l.f_error) * (1.0 - f64::EPSILON);
                    match low > limits[k][level as usize] {
                        true if v > 0.0 => 1,
                        true => -1,
                        false => 0,
                    }
                };
                let empty = match split {
                    None => sign(0) != 0,
                    Some(split) => {
                        // One side decides F where it keeps the winning sign:
                        // above 0 under a max, below under a min.
                        let winning = if split.larger { 1 } else { -1 };
                        let one = sign(first);
                        one == winning || {
                            let other = sign(1 - first);
                            other == winning || (one == -winning && other == -winning)
                        }
                    }
                };
                if !empty {
                    stack.push((child, level + 1));
                }
            }
            // Where no octant is empty, smaller ones seldom are: the box is
            // kept whole.
            if stack.len() - kept == 8 {
                stack.truncate(kept);
                hull = Some(hull.map_or(b, |h| h.union(&b)));
            }
        }
        self.stack = stack;
        hull.unwrap_or_else(|| {
            let c = unpadded.center();
            Aabb { lo: c, hi: c }
        })
    }
}

/// f's enclosure, the bounds of ∂f/∂x, ∂f/∂y and ∂f/∂z in magnitude, the
/// Lipschitz bound from them, and whether a Lipschitz argument holds (f
/// defined and continuous, its Clarke gradient defined), from f and ∇f over
/// a leaf.
fn first_order(v: &[DecInterval; 4]) -> (Interval, [f64; 3], f64, bool) {
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
fn rounding_of_f(f: &mut Evaluator<RoundingBound>, b: &Aabb, pad: f64) -> f64 {
    let [x, y, z] = padded(b, pad).intervals().map(RoundingBound::exact);
    let unit = RoundingBound::exact(Interval::UNIT);
    f.eval(&[x, y, z, unit, unit, unit])[0].err
}

/// Bounds of the rounding error of the f64 values of f and g (for
/// directions in [-1, 1]³), as `fg` computes them, anywhere in `b` padded.
fn rounding_over(fg: &mut Evaluator<RoundingBound>, b: &Aabb, pad: f64) -> (f64, f64) {
    let [x, y, z] = padded(b, pad).intervals().map(RoundingBound::exact);
    let unit = RoundingBound::exact(Interval::UNIT);
    let e = fg.eval(&[x, y, z, unit, unit, unit]);
    (e[0].err, e[1].err)
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
/// The inputs of a decorated evaluation at the point `p` (direction 0).
fn point_inputs(p: DVec3) -> [DecInterval; 6] {
    let pt = |v: f64| DecInterval::defined(Interval::point(v));
    let zero = pt(0.0);
    [pt(p.x), pt(p.y), pt(p.z), zero, zero, zero]
}

fn half_diagonal(b: &Aabb) -> Interval {
    let [x, y, z] = [0, 1, 2].map(|i| Interval::point(b.hi[i]) - Interval::point(b.lo[i]));
    (x.powi(2) + y.powi(2) + z.powi(2)).sqrt() * Interval::point(0.5)
}

/// `sqrt(a² + b² + c²)` rounded up.
fn lipschitz(m: [f64; 3]) -> f64 {
    crate::types::interval::norm_sup(m)
}

#[cfg(test)]
mod tests {
    use super::*;

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
                    Some(frame) => {
                        assert!(depth > 4, "{src} at depth {depth}");
                        assert_eq!(frame, expected, "{src} at depth {depth}");
                        found += 1;
                    }
                    // Not deeper than the frame: left to a build of its own.
                    None => assert!(depth <= 4, "{src} at depth {depth}"),
                }
                assert_eq!(Octree::build(&f, &b, depth).frame(), None);
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
        assert_eq!(Octree::build_with(&f, &b, &options).frame(), None);
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
