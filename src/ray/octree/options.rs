//! How far an octree is built: the options and the tuning constants behind them.

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
    /// Further levels still for creased boxes where f may be undefined (see
    /// [`POLE_LEVELS`]); only where `leaf_bounds` is on.
    pub pole_levels: u32,
    /// Whether leaves see the formula specialised to their region (off: every
    /// leaf sees the whole formula, as a reference for tests).
    pub specialise: bool,
    /// Whether boxes where f is at most quadratic become leaves at any level
    /// before `depth` (see [`quadric_leaf`](super::quadric_leaf)); off: every kept box goes to
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
    ///
    /// [`Octree::surface_bounds`]: super::Octree::surface_bounds
    /// [`Octree::frame`]: super::Octree::frame
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
    ///
    /// [`Octree::polynomial`]: super::Octree::polynomial
    pub polynomial_form: bool,
    /// Whether leaves of the whole formula past the compiled shapes (all of
    /// them, with `specialise` off) get short tapes
    /// ([`ShortTapes`](super::ShortTapes)), which rays in them evaluate;
    /// off: they evaluate the whole formula, as a reference for tests.
    pub short_tapes: bool,
}

impl BuildOptions {
    /// `depth` levels, the default budget and crease levels.
    pub fn to_depth(depth: u32) -> BuildOptions {
        BuildOptions {
            depth,
            max_work: MAX_WORK,
            crease_levels: CREASE_LEVELS,
            pole_levels: POLE_LEVELS,
            specialise: true,
            coarse_quadrics: true,
            leaf_bounds: true,
            frame_depth: None,
            hull_levels: HULL_LEVELS,
            tight_leaves: true,
            polynomial_form: true,
            short_tapes: true,
        }
    }
}

/// How many levels past the requested depth a box that a crease may cross is
/// subdivided further by default, to settle its branches. One: creased
/// leaves with two smooth sides ([`SplitLeaf`](super::SplitLeaf)) decide most pieces of rays
/// by those sides, and each level more doubles the build. Measured at 1024²
/// (instructions, no shadows): a second level cost the gyroid in a ball about
/// 15 % more and the cube minus a ball 9 %; with none, the cube minus a ball
/// took 15 % more (measured before boxes with two quadratic sides stopped at
/// the depth as split leaves: see `SPLIT_LEVELS_EARLY`).
pub const CREASE_LEVELS: u32 = 1;

/// How many levels past the crease levels a creased box where f may be
/// undefined (a quotient's pole, a root's or logarithm's domain edge) is
/// subdivided further, within the work budget. Its leaf has no Lipschitz
/// bound, and no f64 value of f certifies a sign there: every piece of a
/// ray in it is enclosed, even far from the surface. A level more confines
/// such leaves to the boxes the pole crosses. Measured on the bear model,
/// whose f divides by a coordinate, at 1024² (2 threads, AMD EPYC): 12,848
/// leaves became 14,661, interval evaluations a ray 0.98 → 0.91, processor
/// time 5 % less. A second level (with twice the budget, and creased leaves'
/// pieces marched: see the intersector's search) took 0.56 a ray against
/// 0.61, and no less time.
pub const POLE_LEVELS: u32 = 1;

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
///
/// [`Octree::leaf_hull`]: super::Octree::leaf_hull
pub const HULL_LEVELS: u32 = 2;

/// The most levels [`BuildOptions::hull_levels`] may ask for.
pub(super) const MAX_HULL_LEVELS: u32 = 4;

/// How many levels above the leaves the rounding bounds of the whole formula
/// are computed, once per node, for every leaf below (a leaf computes its own
/// where they are coarse against its scale).
pub const ROUNDING_LEVELS: u32 = 3;

/// How many levels above the requested depth a creased box whose two sides
/// are both quadratic may already be a leaf (see [`SplitLeaf`]); at the
/// depth it is one, not subdivided for [`CREASE_LEVELS`].
pub(super) const SPLIT_LEVELS_EARLY: u32 = 1;

/// The most shapes an octree compiles; leaves past it, or past
/// [`MAX_SHAPE_INSTRUCTIONS`], get short tapes of the whole formula. (A
/// union of 300 balls, shapes of a few hundred instructions each, fills
/// 1,232: at 1024² it rendered in 5.5 s against 19 s with 512.)
pub const MAX_SHAPES: usize = 4096;

/// The most body instructions the compiled shapes hold together, past the
/// whole formula's: a memory and time budget (each shape is compiled from
/// the formula, and rays make evaluators of it), so that a long formula
/// gets fewer shapes rather than gigabytes (a chain of 400 nested blends
/// once filled 512 shapes with 12 million instructions, 1.3 GB). Twice as
/// many would take the prospero slab's creased boxes a level deeper (1,478
/// shapes become 4,090), where its octree builds in 2.9 s instead of 0.8,
/// for rays 0.4 s faster at 1024².
pub const MAX_SHAPE_INSTRUCTIONS: usize = 1 << 21;

/// A region's shape is compiled only where it leaves at most one branch
/// point open (smooth, so its rays get second-order bounds, or perhaps the
/// larger or smaller of two smooth sides) or its f is at most this share
/// of the whole formula's; elsewhere the region sees the whole formula (and
/// its leaves get short tapes). CSG settles nearly all of a long formula in
/// a small region (the shapes of the prospero slab and of unions of balls
/// are mostly under a tenth of the whole), but a formula of soft blends
/// around a few `min` and `max` settles little: fidget's bear's creased
/// shapes are 60–99 % of it, and cost it a third of its build and nine
/// tenths of its memory for no faster rays.
pub const SHAPE_WORTH: f64 = 0.5;

/// The most body instructions an octree's short tapes hold together
/// ([`ShortTapes`](super::ShortTapes)); leaves past it evaluate the whole
/// formula.
pub const MAX_SHORT_INSTRUCTIONS: usize = 1 << 22;

/// How many levels of cells a leaf's region is cut into for rays' short
/// tapes ([`Cells`](super::Cells)): its eighths, and theirs.
pub const CELL_LEVELS: usize = 2;

/// The most body instructions the tapes of an octree's cells hold together
/// ([`Cells`](super::Cells)); cells made past it keep none.
pub const MAX_CELL_INSTRUCTIONS: usize = 1 << 22;

/// The most groups of eight cells an octree's leaves may have made
/// ([`Cells`](super::Cells)), about 100 MB; rays make a few thousand on
/// the prospero slab at 1024².
pub const MAX_CELL_GROUPS: usize = 1 << 18;

/// A leaf keeps a short tape only when it is at most this share of the
/// whole formula's: a little shorter saves less than a tape of its own costs.
pub const SHORT_ENOUGH: f64 = 0.75;

/// The most nodes an octree may hold (about 0.5 GB), whatever the formula and
/// the requested depth.
pub const MAX_NODES: usize = 1 << 21;

/// The most work an octree build may do, in tape instructions (interval
/// ones count 1, point ones ¼): under 10 s on one core of this project's
/// machine, whatever the formula's length. The tangle cube uses half of it
/// at depth 8; a formula of 10⁵ instructions stops after a few levels.
pub const MAX_WORK: u64 = 1 << 28;
