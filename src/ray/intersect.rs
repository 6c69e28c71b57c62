//! Guaranteed ray intersection (Kalra–Barr §6.2), every answer certified.
//!
//! Leaves of the [`Octree`] that a ray crosses are visited nearest first, each
//! only where the ray crosses its hull (the part of its box that can hold the
//! surface, [`Octree::leaf_hull`]). On
//! each piece `[a, b]` of the ray inside a leaf, with `m` its middle and `h`
//! its half length, F(t) = f(o + t·d), g(t) = F′(t), and G a bound of |g′|
//! from the leaf's interval Hessian (`|dᵀ[H]d|`), the tests run in this order:
//!
//! * **L-test** — `|F(m)| > L·|d|·h`: no root (F is `L|d|`-Lipschitz in t);
//! * **second-order test** — `|F(m)| > |g(m)|·h + G·h²/2`: no root (Taylor's
//!   bound; it excludes a ray parallel to a plane at once);
//! * **G-test** — `|g(m)| > G·h`: g keeps its sign, F is monotone, so equal
//!   certified signs at a and b exclude the piece and opposite ones hold
//!   exactly one root, refined by Newton's method inside its bracket;
//! * **Taylor's parabolas** — where F is quadratic along the ray (a quadric
//!   or a plane: the bounds of F″ meet), F(m), g(m) and F″'s bounds give a
//!   parabola below and one above F ([`taylor`](super::taylor)): F keeps its
//!   sign up to the lower one's roots, and where nothing is left before
//!   them, has the opposite sign past the upper one's first root, a
//!   certified crossing with no evaluation at the root; otherwise the range
//!   with no root is cut out of the piece;
//! * otherwise the piece is halved, nearer half first.
//!
//! The f64 values these tests read are not the exact F and g: each leaf holds
//! a bound of their rounding error anywhere in it ([`RoundingBound`]), and the
//! error of computing the point `o + t·d` itself is added, so a test passes
//! only when its rounding cannot have decided it. Where a leaf's bounds are
//! unbounded (a crease of `abs`/`min`/`max`, a cusp, f undefined somewhere),
//! intervals of F and g over the piece decide instead — except where a
//! creased leaf is the larger (or smaller) of two smooth sides F₁, F₂
//! ([`SplitLeaf`]): on a piece where `|F₁(m) − F₂(m)|` exceeds what their
//! difference C can move over it (`(L₁ + L₂)·|d|·h`, or to second order
//! `|C′(m)|·h + ½(G₁ + G₂)·h²`, plus rounding), F is one side throughout, and
//! the tests above run with that side's bounds. Elsewhere, F is excluded
//! where a side keeps the winning sign (above 0 under a max) over the piece,
//! and Taylor's bounds of C from m give the range around m where C keeps its
//! sign, cut out with its side; pieces near the crease are halved (cut
//! around C's zero where C is linear) and enclosed only when short. Where
//! both sides are quadratic along the ray (planes and quadrics), such a
//! piece is first answered in closed form ([`seam`](super::seam)): the roots
//! of both sides' parabolas from m estimate where F first changes sign, and
//! their Taylor bounds prove it, a clear piece or a bracket a thousandth of
//! the tolerance wide, with no further evaluation. A sign is certified
//! by the f64 value and its error bound, or else by an interval enclosure of F
//! at the point.
//!
//! A piece that reaches the tolerance unexcluded ends the ray: a certified sign
//! change across it is a [`Answer::Hit`]; otherwise the enclosure of F over
//! it contains 0 and the answer is a [`Answer::Touch`] (a tangency, or |F|
//! below its rounding noise). Everything before either was excluded by a sound
//! test, so the answer is the first root. A ray that would need more than
//! [`MAX_PIECES_PER_RAY`] pieces stops with [`Answer::Undecided`] at the first
//! piece not yet excluded: never a guess.
//!
//! [`RoundingBound`]: crate::expr::RoundingBound

use super::bundle::{LeafList, Listed};
use super::octree::{BuildOptions, Leaf, NodeId, Octree, OctreeStats, Shape, SplitLeaf};
use super::polynomial;
use super::seam::{self, Parabola, Seam};
use super::taylor::Expansion;
use crate::expr::{DecoratedEvaluator, Evaluator, PointEvaluator};
use crate::formula::Formula;
use crate::types::{Aabb, Segment};
use crate::types::{DecInterval, Decoration, Interval};
use glam::DVec3;

/// Pieces a single ray may examine before it stops as [`Answer::Undecided`].
/// No ray of the tests, the corpus or the examples comes near it.
pub const MAX_PIECES_PER_RAY: u32 = 1 << 22;

/// Octree nodes a region query may visit before f's enclosure decides.
const MAX_REGION_VISITS: usize = 64;

/// Unit roundoff of f64.
const U: f64 = f64::EPSILON / 2.0;

/// A ray's certified answer on `[t_min, t_max]` inside the box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer {
    /// No surface: every piece of the ray was excluded by a sound test.
    Miss,
    /// The first root: F changes sign (certified) within the tolerance of t,
    /// or t is the unique root of a piece where F is monotone.
    Hit(f64),
    /// No sign change, but the enclosure of F over a piece within the
    /// tolerance of t contains 0: a tangency, or |F| below its rounding
    /// noise. Everything before it was excluded.
    Touch(f64),
    /// Everything before t was excluded, but the ray needed more pieces than
    /// [`MAX_PIECES_PER_RAY`] to settle what follows.
    Undecided(f64),
}

impl Answer {
    /// The t a renderer shades: hits and touches (and undecided rays, which
    /// are shown rather than hidden).
    pub fn t(self) -> Option<f64> {
        match self {
            Answer::Miss => None,
            Answer::Hit(t) | Answer::Touch(t) | Answer::Undecided(t) => Some(t),
        }
    }

    /// The same answer at `t + offset`.
    fn moved_by(self, offset: f64) -> Answer {
        match self {
            Answer::Miss => Answer::Miss,
            Answer::Hit(t) => Answer::Hit(t + offset),
            Answer::Touch(t) => Answer::Touch(t + offset),
            Answer::Undecided(t) => Answer::Undecided(t + offset),
        }
    }
}

/// A surface compiled for ray queries: its octree, whose leaves refer to the
/// compiled shapes of the formula as they see it.
#[derive(Debug, Clone)]
pub struct Intersector {
    octree: Octree,
    /// Distance below which a segment is not split further.
    tolerance: f64,
    /// Every computed point of a ray lies in the padded box, so `|p|` is at
    /// most this.
    radius: f64,
}

/// Work done answering rays, for the summary line and benchmarks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayStats {
    /// Rays answered.
    pub rays: u64,
    /// Point evaluations of f (and g).
    pub f_evals: u64,
    /// Interval evaluations of f (over a piece, or at a point whose sign
    /// the f64 value could not certify).
    pub interval_evals: u64,
    /// Leaves visited.
    pub leaves: u64,
    /// Rays answered with a hit.
    pub hits: u64,
    /// Rays answered with a touch.
    pub touches: u64,
    /// Rays answered undecided.
    pub undecided: u64,
    /// Pieces of split leaves answered in closed form (see
    /// [`Tracer::set_closed_form_seams`]).
    pub seams: u64,
    /// Rays that searched a bundle's leaf list instead of walking the
    /// octree ([`Tracer::first_hit_in`]).
    pub listed: u64,
    /// Rays answered in closed form: the formula is affine over the box
    /// (see [`Tracer::set_closed_form_planes`]).
    pub closed_form: u64,
}

impl RayStats {
    /// The work done since `earlier`, a snapshot of the same tally.
    pub fn since(&self, earlier: &RayStats) -> RayStats {
        RayStats {
            rays: self.rays - earlier.rays,
            f_evals: self.f_evals - earlier.f_evals,
            interval_evals: self.interval_evals - earlier.interval_evals,
            leaves: self.leaves - earlier.leaves,
            hits: self.hits - earlier.hits,
            touches: self.touches - earlier.touches,
            undecided: self.undecided - earlier.undecided,
            seams: self.seams - earlier.seams,
            listed: self.listed - earlier.listed,
            closed_form: self.closed_form - earlier.closed_form,
        }
    }

    /// Adds another tally to this one.
    pub fn add(&mut self, other: &RayStats) {
        self.rays += other.rays;
        self.f_evals += other.f_evals;
        self.interval_evals += other.interval_evals;
        self.leaves += other.leaves;
        self.hits += other.hits;
        self.touches += other.touches;
        self.undecided += other.undecided;
        self.seams += other.seams;
        self.listed += other.listed;
        self.closed_form += other.closed_form;
    }
}

impl Intersector {
    /// Prunes `bounds` to `depth` and compiles the tapes rays need.
    pub fn new(formula: &Formula, bounds: &Aabb, depth: u32) -> Intersector {
        Self::with_options(formula, bounds, &BuildOptions::to_depth(depth))
    }

    /// [`Intersector::new`] with the octree's limits chosen.
    pub fn with_options(formula: &Formula, bounds: &Aabb, options: &BuildOptions) -> Intersector {
        let octree = Octree::build_with(formula, bounds, options);
        let b = &octree.bounds;
        let radius = up((b.lo.abs().max(b.hi.abs()) + DVec3::splat(octree.pad)).length());
        Intersector {
            octree,
            tolerance: 1e-10 * (bounds.hi - bounds.lo).length(),
            radius,
        }
    }

    /// The octree's build statistics.
    pub fn octree_stats(&self) -> OctreeStats {
        self.octree.stats
    }

    /// Where the surface may be: the bounds of the kept leaves.
    pub fn surface_bounds(&self) -> Option<Aabb> {
        self.octree.surface_bounds()
    }

    /// The view frame found with the octree (see [`Octree::frame`]).
    pub fn frame(&self) -> Option<Option<Aabb>> {
        self.octree.frame()
    }

    /// The bounding box.
    pub fn bounds(&self) -> Aabb {
        self.octree.bounds
    }

    /// Per-thread state for answering rays.
    pub fn tracer(&self) -> Tracer<'_> {
        let whole = &self.octree.shapes[0];
        Tracer {
            scene: self,
            shapes: vec![None; self.octree.shapes.len()],
            current: 0,
            whole_f: PointEvaluator::new(&whole.f),
            whole_fi: Evaluator::new(&whole.f),
            grad: PointEvaluator::new(&whole.grad),
            stats: RayStats::default(),
            stack: Vec::new(),
            taken: Vec::new(),
            query: Vec::new(),
            segments: Vec::new(),
            hit_leaf: (f64::INFINITY, 0.0),
            hit_shape: 0,
            side_first: 0,
            closed_form_seams: true,
            closed_form_planes: true,
            polynomial: self.octree.polynomial.as_ref().map(|p| p.scratch()),
            closed_form: self.octree.affine.is_some() || self.octree.polynomial.is_some(),
        }
    }
}

/// Answers rays against one [`Intersector`]; one per thread.
pub struct Tracer<'s> {
    scene: &'s Intersector,
    /// Evaluators of each shape, made when a ray first meets it.
    shapes: Vec<Option<ShapeEvaluators<'s>>>,
    /// The shape of the leaf being searched.
    current: usize,
    /// The whole formula's f and ∇f, for normals.
    whole_f: PointEvaluator<'s>,
    /// The whole formula's f over boxes, for bundles of rays (undecorated:
    /// only the values are read).
    whole_fi: Evaluator<'s, Interval>,
    grad: PointEvaluator<'s>,
    /// Work done so far.
    pub stats: RayStats,
    stack: Vec<(NodeId, f64, f64)>,
    /// Scratch space of [`Tracer::next_listed`]: leaves taken, not yet searched.
    taken: Vec<(f64, f64, NodeId)>,
    /// Scratch space of octree queries.
    query: Vec<NodeId>,
    segments: Vec<Piece>,
    /// L and size of the leaf where the last hit was found, for normals.
    hit_leaf: (f64, f64),
    /// The shape that found the last hit: f itself near the hit, so its
    /// gradient is f's there (see [`Tracer::normal`]).
    hit_shape: usize,
    /// The side of a split leaf that [`Tracer::side_of`] evaluates first:
    /// the last one that cleared a piece on its own (neighbouring rays
    /// cross the same leaves the same way).
    side_first: usize,
    /// Whether split leaves' pieces are answered in closed form where both
    /// sides are quadratic ([`seam`](super::seam)).
    closed_form_seams: bool,
    /// Whether an affine formula's rays are answered in closed form
    /// ([`Affine`](super::affine::Affine)).
    closed_form_planes: bool,
    /// Scratch space for a polynomial formula's rays, answered in Bernstein
    /// form ([`Polynomial`](super::polynomial::Polynomial); an octree built
    /// without [`BuildOptions::polynomial_form`] has none).
    polynomial: Option<polynomial::Scratch>,
    /// Whether either closed form answers this formula's rays.
    closed_form: bool,
}

/// Point and interval evaluators of one shape.
#[derive(Clone)]
struct ShapeEvaluators<'s> {
    f: PointEvaluator<'s>,
    fg: PointEvaluator<'s>,
    /// Enclosures of f and g; only f's decoration is read.
    fgi: DecoratedEvaluator<'s>,
    /// ∇f, made at the first normal taken on the shape.
    grad: Option<PointEvaluator<'s>>,
}

impl<'s> ShapeEvaluators<'s> {
    fn new(shape: &'s Shape) -> Self {
        ShapeEvaluators {
            f: PointEvaluator::new(&shape.f),
            fg: PointEvaluator::new(&shape.fg),
            fgi: DecoratedEvaluator::reading(&shape.fg, &[0]),
            grad: None,
        }
    }
}

/// A piece of a ray inside one leaf, with F at its ends and their certified
/// signs (0: not certified yet).
#[derive(Clone, Copy)]
struct Piece {
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
    sa: i8,
    sb: i8,
    /// Which formula F is on the piece: 0 for the leaf's own, `k + 1` for
    /// the k-th side of a split leaf ([`SplitLeaf`]), proved to hold there.
    side: u8,
}

/// The ray being answered, as the tracer evaluates it.
#[derive(Clone, Copy)]
struct Ray {
    /// Origin: the given one, or a point on the ray near the box when the
    /// given one is so far away that rounding would blur the leaves.
    o: DVec3,
    d: DVec3,
    /// `|d|`, rounded up.
    speed: f64,
    /// A power of two at least every `|dᵢ|`: the scale of g's rounding bound.
    d_scale: f64,
    /// How far the evaluated ray may lie from the given one (the shift of the
    /// origin).
    shift: f64,
    /// How far any computed point `o + t·d` of the ray inside the box may lie
    /// from the exact point of the given ray: two roundings per coordinate,
    /// of t·dᵢ and of the sum, plus the shift.
    moved: f64,
    /// Whether the leaves' f64 bounds cover this ray (its rounding stays
    /// within the octree's pad); if not, intervals decide everything.
    fast: bool,
    /// For a ray that leaves a surface, its first t inside the box, where
    /// F and g are tested first (see [`Tracer::answer_from_surface`]).
    start: Option<f64>,
}

/// A ray ready to be traced ([`Tracer::setup`]).
struct Setup {
    ray: Ray,
    inv_d: DVec3,
    /// How far along the given ray the evaluated ray's origin lies.
    offset: f64,
    near: f64,
    far: f64,
}

/// The parameter range in which the ray `o + t·d` is inside the closed box
/// `b` (empty, `near > far`, when it misses).
#[inline]
pub(crate) fn slab(b: &Aabb, o: DVec3, d: DVec3, inv_d: DVec3) -> (f64, f64) {
    slab_from(b, &o, &d, inv_d)
}

/// [`slab`], reading the ray's origin and direction where they are: in a
/// loop, a copy of them made for each call was read back across two of its
/// stores, which the processor cannot forward (a stall each time).
#[inline(always)]
fn slab_from(b: &Aabb, o: &DVec3, d: &DVec3, inv_d: DVec3) -> (f64, f64) {
    if inv_d.is_finite() {
        // No time is NaN (a finite difference times a finite 1/dᵢ): plain
        // comparisons give what f64's min and max, which skip NaN at the
        // cost of several instructions each, would.
        let mut near = f64::NEG_INFINITY;
        let mut far = f64::INFINITY;
        for i in 0..3 {
            let (lo, hi) = ((b.lo[i] - o[i]) * inv_d[i], (b.hi[i] - o[i]) * inv_d[i]);
            let (enter, leave) = if lo < hi { (lo, hi) } else { (hi, lo) };
            if enter > near {
                near = enter;
            }
            if leave < far {
                far = leave;
            }
        }
        return (near, far);
    }
    slab_with_zeros(b, *o, *d, inv_d)
}

/// [`slab`] for a ray with a direction component 0 (or so small that its
/// reciprocal overflows).
#[cold]
fn slab_with_zeros(b: &Aabb, o: DVec3, d: DVec3, inv_d: DVec3) -> (f64, f64) {
    let mut near = f64::NEG_INFINITY;
    let mut far = f64::INFINITY;
    for i in 0..3 {
        if d[i] == 0.0 {
            // Parallel to this axis's faces: inside the slab or never. (The
            // product form would give 0·∞ = NaN for a ray in a face's plane.)
            if o[i] < b.lo[i] || o[i] > b.hi[i] {
                return (f64::INFINITY, f64::NEG_INFINITY);
            }
            continue;
        }
        let t0 = (b.lo[i] - o[i]) * inv_d[i];
        let t1 = (b.hi[i] - o[i]) * inv_d[i];
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    (near, far)
}

/// `x ≥ 0` raised to cover the few roundings of a bound's own arithmetic
/// (each at most `u` relative; the smallest normal covers underflow).
#[inline]
fn up(x: f64) -> f64 {
    x * (1.0 + 64.0 * U) + f64::MIN_POSITIVE
}

/// The sign of a value known to within `err`: ±1, or 0 when the error could
/// flip it (or the value is undefined).
#[inline]
fn certified_sign(v: f64, err: f64) -> i8 {
    if v > err {
        1
    } else if v < -err {
        -1
    } else {
        0
    }
}

/// The sign an interval certifies: ±1, or 0 when it holds 0 or is empty.
fn interval_sign(i: Interval) -> i8 {
    if i.is_empty() {
        0
    } else if i.inf() > 0.0 {
        1
    } else if i.sup() < 0.0 {
        -1
    } else {
        0
    }
}

/// The f64 values of F and g at a point.
type Values = (f64, f64);

/// What [`Tracer::side_of`] proves of a piece of a ray in a split leaf.
enum Side {
    /// F is side `k` (1 or 2) on the whole piece; its values at the middle.
    On(u8, Values),
    /// A side alone proves F has no root on the piece.
    Clear,
    /// Neither: both sides' values at the middle, where they have
    /// first-order bounds.
    Undecided(Option<[Values; 2]>),
}

/// Pieces of a split leaf longer than this fraction of the leaf's part of
/// the ray are halved rather than enclosed when no side holds on them.
const SPLIT_HALVINGS: f64 = 1.0 / 1024.0;

/// The bounds of one leaf as a ray sees them.
#[derive(Clone, Copy)]
struct Bounds {
    /// `L·|d|`, the Lipschitz constant of F in t; `+∞` if unknown.
    lt: f64,
    /// `G`, a bound of |g′| on the leaf's part of the ray.
    g: f64,
    /// Bounds of g′ itself (signed) on the leaf's part of the ray.
    curvature: (f64, f64),
    /// Error bounds of the computed f and g at any computed point of the ray
    /// in the leaf: their rounding, and how far the point may have moved;
    /// `+∞` where the f64 tests may not run.
    f_err: f64,
    g_err: f64,
    /// Whether the first-order (L) test may run: f defined on the whole leaf,
    /// L and f's error finite. Creases of min/max/abs allow it.
    first_order: bool,
    /// Whether the second-order and G-tests may run too: G and g's error
    /// finite as well.
    second_order: bool,
}

impl Bounds {
    /// No bound known: every decision by intervals.
    const UNKNOWN: Bounds = Bounds {
        lt: f64::INFINITY,
        g: f64::INFINITY,
        curvature: (f64::NEG_INFINITY, f64::INFINITY),
        f_err: f64::INFINITY,
        g_err: f64::INFINITY,
        first_order: false,
        second_order: false,
    };

    #[inline(always)]
    fn new(leaf: &Leaf, ray: &Ray) -> Bounds {
        Self::first_order_of(leaf, ray).with_second_order(leaf, ray)
    }

    /// The bounds without G and g's error (as if unknown): all the L-test
    /// reads, which excludes most leaves a ray crosses.
    #[inline]
    fn first_order_of(leaf: &Leaf, ray: &Ray) -> Bounds {
        let lt = up(leaf.lipschitz * ray.speed);
        // |f(p̂) − f(p)| ≤ L·|p̂ − p|.
        let f_err = up(leaf.f_error + leaf.lipschitz * ray.moved);
        let first_order = ray.fast && leaf.continuous && lt.is_finite() && f_err.is_finite();
        Bounds {
            lt,
            f_err: if first_order { f_err } else { f64::INFINITY },
            first_order,
            ..Bounds::UNKNOWN
        }
    }

    /// `self` (from [`Bounds::first_order_of`] for the same leaf and ray)
    /// with G and g's error.
    #[inline(always)]
    fn with_second_order(self, leaf: &Leaf, ray: &Ray) -> Bounds {
        // G is never read where intervals decide (creased leaves among them).
        if !self.first_order || leaf.needs_intervals {
            return self;
        }
        // A Hessian enclosed by zeros (a plane's): g is constant, G is 0
        // (exactly: a tiny G would make the tests' products subnormal).
        let (curvature, g) = if leaf.hessian_norm == 0.0 {
            ((0.0, 0.0), 0.0)
        } else {
            let (lo, hi) = leaf.curvature(ray.d);
            ((lo, hi), up(lo.abs().max(hi.abs())))
        };
        // |g(p̂) − g(p)| ≤ |d|·‖H‖·|p̂ − p|.
        let g_err = up(leaf.g_error * ray.d_scale + leaf.hessian_norm * ray.speed * ray.moved);
        let second_order = g.is_finite() && g_err.is_finite();
        Bounds {
            g,
            curvature,
            g_err: if second_order { g_err } else { f64::INFINITY },
            second_order,
            ..self
        }
    }
}

/// Where a split leaf's sides' difference C keeps its sign around the middle
/// m of `piece` (Taylor's bounds of C from both sides' values at m, their
/// error bounds and their bounds of F″), the piece cut in three: before that
/// range (if any), the range itself with the side F is there, and after it
/// (if any). `None` where C's sign at m is not certified, a side has no
/// second-order bounds, or the range is under a quarter of the piece.
#[inline(always)]
fn crease_free(
    split: &SplitLeaf,
    values: [Values; 2],
    bounds: [Bounds; 2],
    piece: &Piece,
    m: f64,
) -> Option<(Option<Piece>, Piece, Option<Piece>)> {
    let [(f1, g1), (f2, g2)] = values;
    let [b1, b2] = bounds;
    if !(b1.second_order && b2.second_order) {
        return None;
    }
    const E: f64 = 4.0 * f64::EPSILON;
    let (c, slope) = (f1 - f2, g1 - g2);
    // The subtractions' roundings on top of both sides' error bounds.
    let c_err = up(b1.f_err + b2.f_err) + E * c.abs();
    let slope_err = up(b1.g_err + b2.g_err) + E * slope.abs();
    let ((lo1, hi1), (lo2, hi2)) = (b1.curvature, b2.curvature);
    let bend = (
        (lo1 - hi2) - E * (lo1.abs() + hi2.abs()),
        (hi1 - lo2) + E * (hi1.abs() + lo2.abs()),
    );
    let e = Expansion::new(c, c_err, slope, slope_err, bend)?;
    let Piece { a, b, .. } = *piece;
    let (lo, hi) = e.clear_range(m);
    let (lo, hi) = (lo.max(a), hi.min(b));
    if hi - lo < 0.25 * (b - a) || (hi - lo).is_nan() {
        return None;
    }
    // C > 0 where the first side is the larger.
    let side = if (e.sign > 0.0) == split.larger { 1 } else { 2 };
    let undecided = |a: f64, b: f64| Piece {
        a,
        b,
        fa: f64::NAN,
        fb: f64::NAN,
        sa: 0,
        sb: 0,
        side: 0,
    };
    let near = (lo > a).then(|| Piece {
        fa: piece.fa,
        sa: piece.sa,
        ..undecided(a, lo)
    });
    let far = (hi < b).then(|| Piece {
        fb: piece.fb,
        sb: piece.sb,
        ..undecided(hi, b)
    });
    // Certified signs at the piece's ends hold for F whatever formula
    // computes it; other values were the leaf's own.
    let middle = Piece {
        side,
        fa: if lo == a && piece.sa != 0 {
            piece.fa
        } else {
            f64::NAN
        },
        sa: if lo == a { piece.sa } else { 0 },
        fb: if hi == b && piece.sb != 0 {
            piece.fb
        } else {
            f64::NAN
        },
        sb: if hi == b { piece.sb } else { 0 },
        ..undecided(lo, hi)
    };
    Some((near, middle, far))
}

/// The closed-form answer on `piece` of a split leaf ([`seam::first_root`])
/// from both sides' values at its middle m, where both sides are quadratic
/// along the ray (F″ known to a millionth, as for Taylor's parabolas) and
/// have second-order bounds; `None` where they are not or the proof fails.
/// A hit's bracket is a thousandth of the tolerance `tol` wide.
#[inline(always)]
fn closed_form(
    split: &SplitLeaf,
    values: [Values; 2],
    bounds: [Bounds; 2],
    piece: &Piece,
    m: f64,
    tol: f64,
) -> Option<Seam> {
    let side = |(v, w): Values, k: &Bounds| {
        let (lo, hi) = k.curvature;
        let quadratic = k.second_order && k.quadratic();
        let p = Parabola {
            v,
            e: k.f_err,
            w,
            u: k.g_err,
            lo,
            hi,
        };
        // The smaller of two sides is the negated larger of their negations,
        // with the same roots.
        quadratic.then_some(if split.larger { p } else { p.negated() })
    };
    let sides = [side(values[0], &bounds[0])?, side(values[1], &bounds[1])?];
    // The piece's ends as steps from m, moved out past the roundings of the
    // subtractions (the leaves' bounds hold on their padded boxes).
    let out = |s: f64| s * (1.0 + 2.0 * f64::EPSILON) + f64::MIN_POSITIVE.copysign(s);
    let (s_a, s_b) = (out(piece.a - m), out(piece.b - m));
    seam::first_root(&sides, m, s_a, s_b, tol / 2048.0)
}

impl Bounds {
    /// Whether F is quadratic along the ray, to a millionth: the bounds of
    /// F″ meet (a quadric's or a plane's), so Taylor's parabolas nearly do.
    #[inline(always)]
    fn quadratic(&self) -> bool {
        let (lo, hi) = self.curvature;
        hi - lo <= 1e-6 * self.g
    }

    /// Whether F, with value `f` and slope `g` at the middle of a piece
    /// whose every t is within `hh` of it, has no root on the piece: the
    /// L-test, or the second-order test where G is known.
    #[inline]
    fn excludes(&self, (f, g): Values, hh: f64) -> bool {
        if !self.first_order || f.is_nan() {
            return false;
        }
        let f_low = f.abs() - self.f_err;
        f_low > up(self.lt * hh)
            || (self.second_order
                && !g.is_nan()
                && f_low > up((g.abs() + self.g_err) * hh + 0.5 * self.g * hh * hh))
    }
}

/// Where F is monotone on `piece` with `|g| ≥ slope_min` and sign
/// `slope_sign`, and its value at the middle `m` is `fm` (certified sign):
/// the root, if any, lies on the side where F falls toward 0, within
/// `δ = (|f(m)| + err)/slope_min` of m (|F(m)| ≥ slope_min·|m − r|). When that
/// side's end of `[m − δ, m]` or `[m, m + δ]` lies inside the piece, F has
/// the opposite sign there without an evaluation: a bracket of the one root
/// on the piece (none lies before it: F is monotone), with Newton's step from
/// m to start. `None` when the bracket would reach past the piece.
#[allow(clippy::too_many_arguments)]
fn slope_bracket(
    k: &Bounds,
    piece: &Piece,
    m: f64,
    fm: f64,
    gm: f64,
    slope_min: f64,
    slope_sign: f64,
) -> Option<(Piece, f64)> {
    let sm = certified_sign(fm, k.f_err);
    if sm == 0 || slope_sign == 0.0 || slope_sign.is_nan() {
        return None;
    }
    // A millionth more covers the roundings of δ; four ulps of m, those of
    // m ± δ.
    let delta = (fm.abs() + k.f_err) / slope_min * (1.0 + 1e-6) + 4.0 * f64::EPSILON * m.abs();
    if !delta.is_finite() {
        return None;
    }
    let newton = m - fm / gm;
    // F falls toward 0 to the left of m when F(m) and g have one sign.
    if (f64::from(sm) > 0.0) == (slope_sign > 0.0) {
        let lo = m - delta;
        (lo > piece.a).then_some((
            Piece {
                a: lo,
                b: m,
                fa: f64::NAN,
                fb: fm,
                sa: -sm,
                sb: sm,
                side: piece.side,
            },
            newton,
        ))
    } else {
        let hi = m + delta;
        (hi < piece.b).then_some((
            Piece {
                a: m,
                b: hi,
                fa: fm,
                fb: f64::NAN,
                sa: sm,
                sb: -sm,
                side: piece.side,
            },
            newton,
        ))
    }
}

/// A bound of the distance from Newton's step `x − f/g` (values at x, with
/// the leaf's error bounds) to the root r of a bracket on which F is
/// monotone with `|g| ≥ slope_min` and `|g′| ≤ G`; `+∞` when the leaf has no
/// finite G. From `0 = F(r) = F(x) + g(x)(r − x) + ½g′(ξ)(r − x)²`:
/// `|r − step| ≤ |F(x)/g(x) − f/g| + ½G(r − x)²/|g(x)|`, where
/// `|r − x| ≤ (|f| + err)/slope_min` and
/// `|F(x)/g(x) − f/g| ≤ (err + |f|·g_err/|g|)/slope_min`; doubled to cover
/// the roundings of the bound, plus ulps of x and of f/g for those of the
/// step `x − f/g` itself.
fn newton_lands(k: &Bounds, x: f64, f: f64, g: f64, slope_min: f64) -> f64 {
    if !k.second_order || slope_min <= 0.0 || g == 0.0 || g.is_nan() || f.is_nan() {
        return f64::INFINITY;
    }
    let to_root = (f.abs() + k.f_err) / slope_min;
    // A plane's g error is the smallest normal (g is exact there): times
    // |f|, a subnormal, which costs a hundred cycles an operation. A larger
    // error bound is as sound, and keeps the products normal.
    let g_err = k.g_err.max(1e-150);
    let values = (k.f_err + f.abs() * g_err / g.abs()) / slope_min;
    let curvature = 0.5 * k.g * to_root * to_root / slope_min;
    let bound = 2.0 * (values + curvature) + 4.0 * f64::EPSILON * (x.abs() + (f / g).abs());
    if bound.is_nan() {
        f64::INFINITY
    } else {
        bound
    }
}

impl<'s> Tracer<'s> {
    /// The evaluators of the current leaf's shape.
    #[inline(always)]
    fn evals(&mut self) -> &mut ShapeEvaluators<'s> {
        let shape = &self.scene.octree.shapes[self.current];
        self.shapes[self.current].get_or_insert_with(|| ShapeEvaluators::new(shape))
    }

    #[inline]
    fn f_at(&mut self, ray: &Ray, t: f64) -> f64 {
        self.stats.f_evals += 1;
        let p = ray.o + t * ray.d;
        let [f] = self.evals().f.eval_array(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
        f
    }

    #[inline]
    fn fg_at(&mut self, ray: &Ray, t: f64) -> (f64, f64) {
        self.stats.f_evals += 1;
        let p = ray.o + t * ray.d;
        let d = ray.d;
        let [f, g] = self.evals().fg.eval_array(&[p.x, p.y, p.z, d.x, d.y, d.z]);
        (f, g)
    }

    /// The interval inputs of the exact points `o + t·d`, t in `[a, b]`.
    fn inputs(ray: &Ray, a: f64, b: f64) -> [Interval; 6] {
        Segment {
            origin: ray.o,
            direction: ray.d,
            t0: a,
            t1: b,
        }
        .inputs()
    }

    /// Enclosures of F and g over `[a, b]` (a point when `a = b`), and
    /// whether F is defined and continuous on all of it.
    fn fg_over(&mut self, ray: &Ray, a: f64, b: f64) -> (Interval, Interval, bool) {
        self.stats.interval_evals += 1;
        let mut inputs = Self::inputs(ray, a, b);
        if ray.shift > 0.0 {
            // The evaluated ray was moved by up to `shift` from the given one.
            let s = Interval::new(-ray.shift, ray.shift);
            for x in &mut inputs[..3] {
                *x = *x + s;
            }
        }
        let v = self.evals().fgi.eval(&inputs.map(DecInterval::defined));
        let continuous = v[0].decoration() == Decoration::Dac;
        (v[0].interval(), v[1].interval(), continuous)
    }

    /// F at the ends of `piece` where it was not evaluated yet (NaN) and the
    /// sign there is not known, with the signs its f64 value certifies.
    fn evaluate_ends(&mut self, ray: &Ray, k: &Bounds, piece: &mut Piece) {
        if piece.sa == 0 && piece.fa.is_nan() {
            piece.fa = self.f_at(ray, piece.a);
            piece.sa = certified_sign(piece.fa, k.f_err);
        }
        if piece.sb == 0 && piece.fb.is_nan() {
            piece.fb = self.f_at(ray, piece.b);
            piece.sb = certified_sign(piece.fb, k.f_err);
        }
    }

    /// The certified sign of F at t, given its f64 value and error bound;
    /// an interval enclosure at the point decides when the value cannot.
    fn sign_at(&mut self, ray: &Ray, t: f64, f: f64, err: f64) -> i8 {
        match certified_sign(f, err) {
            0 => interval_sign(self.fg_over(ray, t, t).0),
            s => s,
        }
    }

    /// The certified sign of F at t (evaluated here).
    fn sign_at_t(&mut self, ray: &Ray, k: &Bounds, t: f64) -> i8 {
        let f = self.f_at(ray, t);
        self.sign_at(ray, t, f, k.f_err)
    }

    /// Whether the box `region` is proved to hold no point of the surface
    /// inside the bounding box: it meets no kept leaf of the octree, or the
    /// enclosure of f over it (where f is defined) excludes 0, as the
    /// intersector's own interval test. The second counts as an interval
    /// evaluation.
    pub(crate) fn region_is_clear(&mut self, region: [Interval; 3]) -> bool {
        let octree = &self.scene.octree;
        if octree.meets_kept_leaf(&region, MAX_REGION_VISITS, &mut self.query) == Some(false) {
            return true;
        }
        self.f_excludes(region)
    }

    /// Whether the enclosure of f over the box `region` (where f is defined)
    /// excludes 0: an interval evaluation.
    pub(crate) fn f_excludes(&mut self, region: [Interval; 3]) -> bool {
        self.stats.interval_evals += 1;
        let zero = Interval::ZERO;
        let [x, y, z] = region;
        let [f] = self.whole_fi.eval_array(&[x, y, z, zero, zero, zero]);
        f.is_empty() || !f.contains(0.0)
    }

    /// The smallest `t` in `[t_min, t_max]` where the ray `o + t·d` meets the
    /// surface inside the box (a hit or a touch, see [`Tracer::answer`]), or
    /// `None`. `d` need not be normalised.
    pub fn first_hit(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        self.answer(o, d, t_min, t_max).t()
    }

    /// [`Tracer::first_hit`] for a camera ray of a bundle, with `t_max` = +∞:
    /// the ray searches the leaves `list` gives for it rather than walking the
    /// octree (and walks when the list does not cover it: another origin, a
    /// direction outside the bundle, an earlier `t_min`, or an origin so far
    /// away that it is moved to the box). The answer is the walk's, to the
    /// bit.
    #[inline]
    pub fn first_hit_in(&mut self, list: &LeafList, o: DVec3, d: DVec3, t_min: f64) -> Option<f64> {
        self.first_hit_in_until(list, o, d, t_min, f64::INFINITY)
    }

    /// [`Tracer::first_hit_in`] up to `t_max`: the answer of
    /// [`Tracer::first_hit`] on `[t_min, t_max]`, to the bit (the list's
    /// ranges are the walk's, clipped to the same range).
    #[inline]
    pub fn first_hit_in_until(
        &mut self,
        list: &LeafList,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<f64> {
        if self.closed_form() {
            return self.first_hit(o, d, t_min, t_max);
        }
        let listed = list.for_ray(o, d, t_min);
        match listed.and_then(|listed| self.trace_listed(listed, o, d, t_min, t_max)) {
            Some(answer) => {
                self.stats.rays += 1;
                self.stats.listed += 1;
                self.count(answer);
                answer.t()
            }
            None => self.first_hit(o, d, t_min, t_max),
        }
    }

    /// Whether pieces of split leaves whose sides are both quadratic along
    /// the ray are answered in closed form from the sides' values at their
    /// middle ([`seam`](super::seam); on by default), or searched by the
    /// general tests alone, as a reference to compare with.
    pub fn set_closed_form_seams(&mut self, on: bool) {
        self.closed_form_seams = on;
    }

    /// Whether rays against a formula that is affine over the box (a plane)
    /// are answered in closed form ([`Affine`](super::affine::Affine); on by
    /// default), or by the octree search, as a reference to compare with.
    pub fn set_closed_form_planes(&mut self, on: bool) {
        self.closed_form_planes = on;
        self.update_closed_form();
    }

    /// Counts `rays` answered as misses without a search: their bundle's
    /// sweep proved they leave the box before any root (the answer
    /// [`Tracer::first_hit_in`] would give each).
    #[inline]
    pub fn count_proved_misses(&mut self, rays: u64) {
        self.stats.rays += rays;
    }

    /// The octree rays walk.
    pub(crate) fn octree(&self) -> &'s Octree {
        &self.scene.octree
    }

    /// The certified answer for the ray `o + t·d`, t in `[t_min, t_max]`,
    /// inside the box. `d` need not be normalised.
    pub fn answer(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Answer {
        self.answer_with(o, d, t_min, t_max, false)
    }

    /// [`Tracer::first_hit`] for a ray that starts at (or just off) a
    /// surface point: a shadow, reflected or refracted ray.
    pub fn first_hit_from_surface(
        &mut self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<f64> {
        self.answer_from_surface(o, d, t_min, t_max).t()
    }

    /// [`Tracer::answer`] for a ray that starts at (or just off) a surface
    /// point. The middle of a piece tells little there: F is small at its
    /// start, so the tests at the middle fail until the pieces are as short
    /// as F's distance to zero allows. F and g at the start tell more: when
    /// they share a sign, `F(t) ≥ F(a) + g(a)(t−a) − G(t−a)²/2` keeps F off
    /// zero for `t − a < 2|g(a)|/G`, one evaluation for the stretch where
    /// rays leaving a surface spend most of their pieces.
    pub fn answer_from_surface(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Answer {
        self.answer_with(o, d, t_min, t_max, true)
    }

    #[inline(never)]
    fn answer_with(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64, leaving: bool) -> Answer {
        self.stats.rays += 1;
        let closed = if self.closed_form {
            self.answer_in_closed_form(o, d, t_min, t_max)
        } else {
            None
        };
        let answer = match closed {
            Some(answer) => answer,
            None => self.trace_ray(o, d, t_min, t_max, leaving),
        };
        self.count(answer);
        answer
    }

    /// Whether this formula's rays are answered in closed form (it is
    /// affine over the box, a plane, or a polynomial with no branch point),
    /// so bundles' leaf lists would not pay.
    pub fn closed_form(&self) -> bool {
        self.closed_form
    }

    /// [`Tracer::closed_form`] from the switches and the octree.
    fn update_closed_form(&mut self) {
        let octree = &self.scene.octree;
        self.closed_form =
            (self.closed_form_planes && octree.affine.is_some()) || octree.polynomial.is_some();
    }

    /// The ray's answer in closed form, on its range in the box, for a
    /// formula affine over it ([`Affine`](super::affine::Affine): a plane)
    /// or a polynomial ([`Polynomial`](super::polynomial::Polynomial), in
    /// Bernstein form); `None` where the general search answers: another
    /// formula, a ray the form declines (an end where F's enclosure holds 0,
    /// a tangency, a root in the noise), or, for a plane, a ray whose
    /// rounding could move its points out of the padded box (where f is
    /// known to be affine). (Out of line and marked cold: inlined, or laid
    /// out in the search's path, it slows the search for every other
    /// formula by 1–2 %.)
    #[inline(never)]
    #[cold]
    fn answer_in_closed_form(
        &mut self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<Answer> {
        let scene = self.scene;
        let octree = &scene.octree;
        let affine = octree.affine.as_ref().filter(|_| self.closed_form_planes);
        let polynomial = octree.polynomial.as_ref();
        if affine.is_none() && polynomial.is_none() {
            return None;
        }
        if t_min == f64::INFINITY || d == DVec3::ZERO || !o.is_finite() || !d.is_finite() {
            return None;
        }
        let root = &octree.nodes[0];
        let (near, far) = slab(&root.bounds, o, d, d.recip());
        let (near, far) = (near.max(t_min), far.min(t_max));
        if near > far || near.is_nan() || far.is_nan() {
            return Some(Answer::Miss);
        }
        let speed = up(d.length());
        let tol = scene.tolerance / speed;
        let place = tol / 2048.0;
        let (answer, evals) = match (affine, polynomial) {
            (Some(affine), _) => {
                // (Sums of magnitudes bound the lengths, without roots.)
                let (o_size, d_size) = (o.abs().element_sum(), d.abs().element_sum());
                let reach = up(16.0 * U * (o_size + near.abs().max(far.abs()) * d_size));
                if reach > octree.pad {
                    return None;
                }
                affine.answer(o, d, near, far, place)?
            }
            (None, Some(form)) => {
                let scratch = self.polynomial.as_mut()?;
                form.answer(scratch, (o, d), (near, far), place, tol)?
            }
            (None, None) => return None,
        };
        self.stats.f_evals += evals;
        self.stats.leaves += 1;
        self.stats.closed_form += 1;
        if answer != Answer::Miss {
            // A plane's normal is its gradient, and a polynomial's hit leaf
            // is found only if the normal needs its bounds.
            self.hit_leaf = (f64::NAN, 0.0);
            self.hit_shape = 0;
        }
        Some(answer)
    }

    fn count(&mut self, answer: Answer) {
        match answer {
            Answer::Hit(_) => self.stats.hits += 1,
            Answer::Touch(_) => self.stats.touches += 1,
            Answer::Undecided(_) => self.stats.undecided += 1,
            _ => {}
        }
    }

    /// Answers one ray by walking the octree from its root, nearest leaf
    /// first (the walk every ray but a listed camera ray takes).
    #[inline(always)]
    fn trace_ray(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64, leaving: bool) -> Answer {
        let Some(Setup {
            ray,
            inv_d,
            offset,
            near,
            far,
        }) = self.setup(o, d, t_min, t_max, leaving)
        else {
            return Answer::Miss;
        };
        let mut budget = MAX_PIECES_PER_RAY;
        self.stack.clear();
        self.stack.push((0, near, far));
        while let Some((id, t0, t1)) = self.next_walked(&ray, inv_d) {
            let answer = self.visit(id, &ray, t0, t1, &mut budget);
            if answer != Answer::Miss {
                return answer.moved_by(offset);
            }
        }
        Answer::Miss
    }

    /// [`Tracer::trace_ray`] for a camera ray of a bundle, over the leaves
    /// its list gives (no start test); `None` for a ray whose origin would
    /// be moved (far from the box), which walks instead.
    #[inline(never)]
    fn trace_listed(
        &mut self,
        listed: &[Listed],
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<Answer> {
        let Some(Setup {
            ray,
            inv_d,
            offset,
            near,
            far,
        }) = self.setup(o, d, t_min, t_max, false)
        else {
            return Some(Answer::Miss);
        };
        if offset != 0.0 {
            return None;
        }
        let mut budget = MAX_PIECES_PER_RAY;
        let mut next = 0;
        self.taken.clear();
        while let Some((id, t0, t1)) = self.next_listed(listed, &mut next, &ray, inv_d, near, far) {
            let answer = self.visit(id, &ray, t0, t1, &mut budget);
            if answer != Answer::Miss {
                return Some(answer.moved_by(offset));
            }
        }
        Some(Answer::Miss)
    }

    /// The ray as the tracer evaluates it, with `1/d` and its range
    /// `[near, far]` in the box (relative to the moved origin, `offset`
    /// along the ray); `None` when it misses the box.
    #[inline(always)]
    fn setup(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64, leaving: bool) -> Option<Setup> {
        // (t_min = +∞: a bundle's rays that all leave the box before any root.)
        if t_min == f64::INFINITY || d == DVec3::ZERO || !o.is_finite() || !d.is_finite() {
            return None;
        }
        let scene = self.scene;
        let inv_d = d.recip();
        let root = &scene.octree.nodes[0];
        let (near, far) = slab(&root.bounds, o, d, inv_d);
        let (near, far) = (near.max(t_min), far.min(t_max));
        if near > far || near.is_nan() || far.is_nan() {
            return None;
        }
        let speed = up(d.length());
        let d_scale = {
            let m = d.abs().max_element();
            let mut s = 1.0f64;
            while s < m {
                s *= 2.0;
            }
            s
        };
        // Rounding moves computed crossings and points by about u·(|o| + |t·d|);
        // within the pad, the leaves' proofs and bounds cover it. A far origin
        // is first moved along the ray to the entry, with one rounding (FMA).
        let reach = |o: DVec3, t: f64| 16.0 * U * (o.length() + t.abs() * speed);
        let pad = scene.octree.pad;
        let radius = scene.radius;
        let moved = |t: f64, shift: f64| up(U * (t * speed + radius) + shift);
        let (ray, offset, near, far) = if reach(o, near.abs().max(far.abs())) <= pad {
            let ray = Ray {
                o,
                d,
                speed,
                d_scale,
                shift: 0.0,
                moved: moved(near.abs().max(far.abs()), 0.0),
                fast: true,
                // The start test applies where the ray starts inside the box.
                start: (leaving && near == t_min).then_some(near),
            };
            (ray, 0.0, near, far)
        } else {
            let start = DVec3::new(
                near.mul_add(d.x, o.x),
                near.mul_add(d.y, o.y),
                near.mul_add(d.z, o.z),
            );
            let shift = up(U * start.length());
            let span = up(far - near);
            let ray = Ray {
                o: start,
                d,
                speed,
                d_scale,
                shift,
                moved: moved(span, shift),
                fast: reach(start, span) + shift <= pad,
                start: None,
            };
            (ray, near, 0.0, span)
        };
        Some(Setup {
            ray,
            inv_d,
            offset,
            near,
            far,
        })
    }

    /// Searches the leaf of node `id` on `[t0, t1]`, and notes where a hit
    /// was found (for its normal).
    #[inline(always)]
    fn visit(&mut self, id: NodeId, ray: &Ray, t0: f64, t1: f64, budget: &mut u32) -> Answer {
        let scene = self.scene;
        let node = &scene.octree.nodes[id as usize];
        let Some(index) = node.leaf_index() else {
            return Answer::Miss;
        };
        let leaf = &scene.octree.leaves[index];
        self.stats.leaves += 1;
        let answer = self.in_leaf(leaf, index, ray, t0, t1, budget);
        if answer != Answer::Miss {
            self.hit_leaf = (leaf.lipschitz, (node.bounds.hi - node.bounds.lo).length());
            self.hit_shape = self.current;
        }
        answer
    }

    /// The next leaf the ray crosses (its node and range), from a walk of
    /// the octree: nodes on [`Tracer::stack`] hold the ray's unvisited
    /// ranges, nearest on top; an inner node is replaced by its children.
    #[inline(always)]
    fn next_walked(&mut self, ray: &Ray, inv_d: DVec3) -> Option<(NodeId, f64, f64)> {
        let scene = self.scene;
        while let Some((id, t0, t1)) = self.stack.pop() {
            let node = &scene.octree.nodes[id as usize];
            if let Some(index) = node.leaf_index() {
                if !node.is_tight() {
                    return Some((id, t0, t1));
                }
                // Only the leaf's hull holds surface: clipped to its slab
                // test, the ray's range is the list's (`next_listed`).
                let (a, b) = slab(scene.octree.leaf_hull(index), ray.o, ray.d, inv_d);
                let t0 = if a > t0 { a } else { t0 };
                let t1 = if b < t1 { b } else { t1 };
                if t0 < t1 {
                    return Some((id, t0, t1));
                }
                continue;
            }
            let Some(first) = node.first_child() else {
                continue;
            };
            // A ray leaving the surface inside this node: its bounds, coarser
            // than a leaf's, may prove it leaves across several leaves at once.
            let mut t0 = t0;
            if let (Some(i), true) = (node.start_index(), ray.start == Some(t0)) {
                let bounds = &scene.octree.start_bounds[i];
                let k = Bounds::new(bounds, ray);
                if k.second_order {
                    self.current = bounds.shape as usize;
                    if let Ok(end) = self.leave_start(ray, &k, t0) {
                        if end >= t1 {
                            continue;
                        }
                        t0 = end;
                    }
                }
            }
            // The children the ray crosses, in order, come from the times at
            // which it crosses the three mid-planes (Revelles et al. 2000):
            // each crossing flips one octant bit. No box tests, no sorting.
            let (o, d) = (ray.o, ray.d);
            let c = node.bounds.center();
            let mut octant = 0usize;
            let mut cross = [(f64::INFINITY, 0usize); 3];
            for axis in 0..3 {
                if d[axis] == 0.0 {
                    if o[axis] >= c[axis] {
                        octant |= 1 << axis;
                    }
                    continue;
                }
                let tm = (c[axis] - o[axis]) * inv_d[axis];
                // At the entry t0 the ray is on the side it has not yet left.
                let upper = if d[axis] > 0.0 { t0 >= tm } else { t0 < tm };
                if upper {
                    octant |= 1 << axis;
                }
                if tm > t0 && tm < t1 {
                    cross[axis] = (tm, axis);
                }
            }
            // Three compare-and-swaps sort them (no crossing time is NaN: one
            // is kept only when it compares inside (t0, t1)).
            let order = |cross: &mut [(f64, usize); 3], i: usize, j: usize| {
                if cross[j].0 < cross[i].0 {
                    cross.swap(i, j);
                }
            };
            order(&mut cross, 0, 1);
            order(&mut cross, 1, 2);
            order(&mut cross, 0, 1);
            let mut pieces = [(0usize, 0.0f64, 0.0f64); 4];
            let mut n = 0;
            let mut start = t0;
            for &(tm, axis) in cross.iter().filter(|c| c.0.is_finite()) {
                pieces[n] = (octant, start, tm);
                n += 1;
                octant ^= 1 << axis;
                start = tm;
            }
            pieces[n] = (octant, start, t1);
            n += 1;
            // Nearest first: push the farthest first.
            let alive = node.alive_children();
            for &(k, a, b) in pieces[..n].iter().rev() {
                if alive & (1 << k) != 0 {
                    self.stack.push((first + k as NodeId, a, b));
                }
            }
        }
        None
    }

    /// The next leaf the ray crosses (its node and range) from a bundle's
    /// [`LeafList`], `listed[..*next]` already taken. A leaf is taken once
    /// no leaf yet to be taken can be entered before it (the list says when
    /// each can be entered first), so a ray that finds its hit early tests
    /// few boxes. Each range is the ray's slab test of the leaf's hull,
    /// clipped to `[near, far]`: the walk clips the times it computes for
    /// the leaf's box (the box's faces are its ancestors' mid-planes: the
    /// same floating-point times) to that test, which lies within them, so
    /// these are the walk's ranges, in the same order, and the answers are
    /// the walk's.
    #[inline(always)]
    fn next_listed(
        &mut self,
        listed: &[Listed],
        next: &mut usize,
        ray: &Ray,
        inv_d: DVec3,
        near: f64,
        far: f64,
    ) -> Option<(NodeId, f64, f64)> {
        let octree = &self.scene.octree;
        // Taken leaves not yet searched, farthest first: (t0, t1, node).
        let taken = &mut self.taken;
        while let Some(l) = listed.get(*next) {
            if taken.last().is_some_and(|&(t0, _, _)| l.enter > t0) {
                break;
            }
            *next += 1;
            let (t0, t1) = slab_from(octree.leaf_hull(l.leaf as usize), &ray.o, &ray.d, inv_d);
            // (No time is NaN: plain comparisons clip.)
            let t0 = if t0 < near { near } else { t0 };
            let t1 = if t1 > far { far } else { t1 };
            if t0 < t1 {
                // Kept sorted by insertion (they are few); of equal t0, the
                // shorter goes first.
                taken.push((t0, t1, l.node));
                let mut at = taken.len() - 1;
                while at > 0 && (taken[at - 1].0, taken[at - 1].1) < (t0, t1) {
                    taken.swap(at - 1, at);
                    at -= 1;
                }
            }
        }
        taken.pop().map(|(t0, t1, id)| (id, t0, t1))
    }

    /// The start test of a ray leaving the surface at `t0`, with bounds `k`
    /// (second order) of the current shape over a box the ray crosses from
    /// t0: where F(t0) and g(t0) share a certified sign, F keeps it while its
    /// lower (upper) Taylor parabola does, for `t − t0 < 2·(|g(t0)| − err)/G`.
    /// `Ok(end)`: no root on `[t0, end)` (up to where the box's G holds);
    /// `Err((f, sign))`: F's value at t0 and its certified sign (maybe 0).
    fn leave_start(&mut self, ray: &Ray, k: &Bounds, t0: f64) -> Result<f64, (f64, i8)> {
        let (fa, ga) = self.fg_at(ray, t0);
        let sa = certified_sign(fa, k.f_err);
        if sa == 0 || certified_sign(ga, k.g_err) != sa {
            return Err((fa, sa));
        }
        // Lowered by a bound of the subtraction's rounding.
        let slope = ga.abs() - k.g_err - 2.0 * f64::EPSILON * ga.abs();
        let reach = if k.g > 0.0 {
            2.0 * slope / k.g
        } else {
            f64::INFINITY
        };
        // A thousandth off the reach covers the roundings of it and of the
        // sum, when the reach is not lost beside t0 itself.
        if slope > 0.0 && reach > 1e-9 * t0.abs() {
            Ok(t0 + 0.999 * reach)
        } else {
            Err((fa, sa))
        }
    }

    /// The side of `split` that F is on the whole piece of the ray within
    /// `hh` of `m`, and that side's F and g at m: the sides' difference
    /// `C = F₁ − F₂` at m is farther from 0 than C can move over the piece
    /// (`(L₁ + L₂)·|d|·hh`, or where both sides have G,
    /// `|C′(m)|·hh + ½(G₁ + G₂)·hh²`) plus the error of its value, so C keeps
    /// its sign there and F is the larger (smaller) side throughout.
    /// [`Side::Clear`] where a side alone proves the piece has no root (the
    /// other side is then not evaluated), [`Side::Undecided`] where neither
    /// is proved, with both sides' values where they have first-order
    /// bounds. Leaves `self.current` at the last side evaluated. Each side's
    /// bounds along the ray are made on first use.
    #[inline(always)]
    fn side_of(
        &mut self,
        split: &SplitLeaf,
        bounds: &mut [Option<Bounds>; 2],
        ray: &Ray,
        m: f64,
        hh: f64,
    ) -> Side {
        let mut values = [(f64::NAN, f64::NAN); 2];
        let mut reach = 0.0;
        let mut err = 0.0;
        // C′ = g₁ − g₂ and |C″| ≤ G₁ + G₂, where both sides have them.
        let (mut g_err, mut curvature, mut second_order) = (0.0, 0.0, true);
        let first = self.side_first;
        for at in [first, 1 - first] {
            let side = &split.sides[at];
            let k = *bounds[at].get_or_insert_with(|| Bounds::new(side, ray));
            if !k.first_order {
                return Side::Undecided(None);
            }
            reach += k.lt;
            err += k.f_err;
            g_err += k.g_err;
            curvature += k.g;
            second_order &= k.second_order;
            self.current = side.shape as usize;
            values[at] = self.fg_at(ray, m);
            // F is at least (most) this side: where the side has no root on
            // the piece and is above (below) 0 there, neither has F.
            if (values[at].0 > 0.0) == split.larger && k.excludes(values[at], hh) {
                self.side_first = at;
                return Side::Clear;
            }
        }
        let c = values[0].0 - values[1].0;
        // |fl(x − y) − (x − y)| ≤ ε/2·|fl(x − y)|; a further 3.5ε covers the
        // roundings of this bound itself.
        let low = c.abs() * (1.0 - 4.0 * f64::EPSILON) - up(err);
        let mut moves = up(up(reach) * hh);
        if second_order {
            // Second order, as Kalra and Barr's test on F: C moves by at
            // most |C′(m)|·hh + ½·|C″|·hh², with C′(m) computed within both
            // g errors and the subtraction's rounding.
            let slope = (values[0].1 - values[1].1).abs() * (1.0 + 4.0 * f64::EPSILON) + up(g_err);
            let second = up(up(slope * hh) + up(0.5 * curvature * hh * hh));
            if second < moves {
                moves = second;
            }
        }
        if c.is_nan() || low.partial_cmp(&moves) != Some(std::cmp::Ordering::Greater) {
            return Side::Undecided(Some(values));
        }
        let at = if (c > 0.0) == split.larger { 0 } else { 1 };
        Side::On(at as u8 + 1, values[at])
    }

    /// The first root on `[t0, t1]` inside one leaf.
    #[inline(always)]
    fn in_leaf(
        &mut self,
        leaf: &Leaf,
        index: usize,
        ray: &Ray,
        t0: f64,
        t1: f64,
        budget: &mut u32,
    ) -> Answer {
        // Split leaves (all creased) get their own copy of the search, so
        // the others pay nothing for the choice of sides.
        let scene = self.scene;
        match (leaf.needs_intervals && ray.fast)
            .then(|| scene.octree.split(index))
            .flatten()
        {
            Some(split) => self.search_leaf::<true>(leaf, Some(split), ray, t0, t1, budget),
            None => self.search_leaf::<false>(leaf, None, ray, t0, t1, budget),
        }
    }

    /// [`Tracer::in_leaf`], for a split leaf (`SPLIT`, and the ray fast) or
    /// any other.
    #[inline(always)]
    fn search_leaf<const SPLIT: bool>(
        &mut self,
        leaf: &Leaf,
        split: Option<&SplitLeaf>,
        ray: &Ray,
        t0: f64,
        t1: f64,
        budget: &mut u32,
    ) -> Answer {
        // G waits until a piece passes the L-test: most leaves a ray
        // crosses never need it.
        let mut own = Bounds::first_order_of(leaf, ray);
        let mut second_order_known = false;
        let tol = self.scene.tolerance / ray.speed;
        self.current = leaf.shape as usize;
        // F at the ends is evaluated only when a test needs it (most leaves
        // a ray crosses are excluded by F and g at the middle alone).
        let mut first = Piece {
            a: t0,
            b: t1,
            fa: f64::NAN,
            fb: f64::NAN,
            sa: 0,
            sb: 0,
            side: 0,
        };
        if ray.start == Some(t0) {
            own = own.with_second_order(leaf, ray);
            second_order_known = true;
        }
        if ray.start == Some(t0) && own.second_order {
            match self.leave_start(ray, &own, t0) {
                Ok(end) if end >= t1 => return Answer::Miss,
                Ok(end) => first.a = end,
                Err((fa, sa)) => (first.fa, first.sa) = (fa, sa),
            }
        }
        // A creased leaf with two smooth sides: each piece whose sides'
        // difference keeps one sign runs the tests with that side's bounds.
        let split = if SPLIT { split } else { None };
        // Undecided pieces longer than this are halved (or cut) rather than
        // enclosed: the length they would have in a leaf at the full depth.
        let shortest = (t1 - t0) * SPLIT_HALVINGS * split.map_or(1.0, |s| s.scale);
        let mut side_bounds = [None; 2];
        let mut k = own;
        // Pieces still to search, nearest last; the next one is kept out of
        // the stack (most leaves a ray crosses need one piece).
        self.segments.clear();
        let mut next = Some(first);
        loop {
            let mut piece = match next.take() {
                Some(piece) => piece,
                None => match self.segments.pop() {
                    Some(piece) => piece,
                    None => break,
                },
            };
            let Piece { a, b, .. } = piece;
            if *budget == 0 {
                return Answer::Undecided(a);
            }
            *budget -= 1;
            let h = 0.5 * (b - a);
            let m = a + h;
            // Every t of [a, b] is within `hh` of m.
            let hh = up((m - a).max(b - m));
            let (fm, gm);
            let mut undecided_split = false;
            // Where the sides' difference C crosses 0 near m, from C and C′
            // there (a split leaf's undecided pieces are cut around it).
            let mut crease = f64::NAN;
            match split {
                None => (fm, gm) = self.fg_at(ray, m),
                Some(split) if piece.side > 0 => {
                    let at = usize::from(piece.side - 1);
                    self.current = split.sides[at].shape as usize;
                    k = side_bounds[at].unwrap_or(Bounds::UNKNOWN);
                    (fm, gm) = self.fg_at(ray, m);
                }
                Some(split) => match self.side_of(split, &mut side_bounds, ray, m, hh) {
                    Side::Clear => continue,
                    Side::On(side, values) => {
                        piece.side = side;
                        // Certified signs hold for F whatever formula
                        // computes it; other values were the leaf's own.
                        if piece.sa == 0 {
                            piece.fa = f64::NAN;
                        }
                        if piece.sb == 0 {
                            piece.fb = f64::NAN;
                        }
                        let at = usize::from(side - 1);
                        k = side_bounds[at].unwrap_or(Bounds::UNKNOWN);
                        self.current = split.sides[at].shape as usize;
                        (fm, gm) = values;
                    }
                    Side::Undecided(values) => {
                        self.current = leaf.shape as usize;
                        k = own;
                        match values {
                            // F is the larger (smaller) side: its value is
                            // theirs, within the larger of their errors (and
                            // own values stay within the leaf's own).
                            Some([one, two]) => {
                                // Where a side has no root on the piece, it
                                // keeps its sign there. A side that keeps
                                // the winning sign (above 0 under a max,
                                // below under a min) cleared the piece in
                                // `side_of`; where both keep the other, so
                                // does F.
                                let kept = [one, two]
                                    .iter()
                                    .zip(&side_bounds)
                                    .all(|(&v, b)| b.is_some_and(|b| b.excludes(v, hh)));
                                if kept {
                                    continue;
                                }
                                // Taylor's bounds of the sides' difference C
                                // (C″ between the ends of theirs) give where C
                                // keeps its sign around m: F is one side
                                // there. Cut that range out with its side,
                                // rather than halving towards the crease.
                                if let [Some(b1), Some(b2)] = side_bounds {
                                    // Both sides quadratic: the piece is
                                    // answered from their values at m alone.
                                    let answer = self
                                        .closed_form_seams
                                        .then(|| {
                                            closed_form(split, [one, two], [b1, b2], &piece, m, tol)
                                        })
                                        .flatten();
                                    if let Some(answer) = answer {
                                        self.stats.seams += 1;
                                        match answer {
                                            Seam::Clear => continue,
                                            Seam::Hit { t, .. } => return Answer::Hit(t),
                                        }
                                    }
                                    if let Some(cut) =
                                        crease_free(split, [one, two], [b1, b2], &piece, m)
                                    {
                                        let (near, middle, far) = cut;
                                        if let Some(far) = far {
                                            self.segments.push(far);
                                        }
                                        match near {
                                            Some(near) => {
                                                self.segments.push(middle);
                                                next = Some(near);
                                            }
                                            None => next = Some(middle),
                                        }
                                        continue;
                                    }
                                }
                                let pick = (one.0 >= two.0) == split.larger;
                                (fm, gm) = if pick { one } else { two };
                                for b in side_bounds.iter().flatten() {
                                    k.f_err = k.f_err.max(b.f_err);
                                }
                                undecided_split = true;
                                // Only where C is linear on the piece (to
                                // G's rounding allowance) is the estimate
                                // close enough: measured, cutting around a
                                // curved crease's estimate cost more
                                // pieces than halving.
                                let slope = one.1 - two.1;
                                let bend: f64 = side_bounds.iter().flatten().map(|b| b.g).sum();
                                if bend * hh <= 1e-9 * slope.abs() {
                                    crease = m - (one.0 - two.0) / slope;
                                }
                            }
                            None => (fm, gm) = self.fg_at(ray, m),
                        }
                    }
                },
            }
            let mut monotone = false;
            // A lower bound of |g| on the piece where F is monotone, and
            // the sign g keeps there.
            let mut slope_min = 0.0;
            let mut slope_sign = 0.0;
            let mut decided = false;
            if k.first_order && !fm.is_nan() {
                let f_low = fm.abs() - k.f_err;
                if f_low > up(k.lt * hh) {
                    continue; // L-test: no root here
                }
            }
            if !second_order_known && !SPLIT {
                k = k.with_second_order(leaf, ray);
                second_order_known = true;
            } else if !second_order_known && piece.side == 0 {
                own = own.with_second_order(leaf, ray);
                second_order_known = true;
                k = Bounds {
                    f_err: k.f_err,
                    ..own
                };
            }
            if k.first_order && !fm.is_nan() {
                let f_low = fm.abs() - k.f_err;
                if k.second_order && !gm.is_nan() {
                    if f_low > up((gm.abs() + k.g_err) * hh + 0.5 * k.g * hh * hh) {
                        continue; // second-order test: no root here
                    }
                    let low = gm.abs() - k.g_err - up(k.g * hh);
                    monotone = low > 0.0;
                    slope_min = low.max(0.0);
                    slope_sign = gm.signum();
                    decided = true;
                }
            }
            // Taylor's bounds around m (see `taylor`): F keeps its sign
            // up to the lower parabola's roots on either side, and has the
            // opposite sign past the upper one's. Where nothing before the
            // clear range is left, a crossing ahead brackets the first
            // root; else the clear range is cut out when it is a good part
            // of the piece.
            // Only where F is quadratic along the ray (F″ known to a
            // millionth) are the parabolas close enough to pay (measured:
            // the torus took 1 % more instructions with them), and where F
            // is linear and monotone, slope_bracket's Newton step below
            // lands as well, for less (the cube).
            if decided && k.quadratic() && !(monotone && k.g == 0.0) {
                if let Some(e) = Expansion::new(fm, k.f_err, gm, k.g_err, k.curvature) {
                    let (lo, hi) = e.clear_range(m);
                    // (NaN ends count as reaching past the piece.)
                    let (before, short) = (lo > a, hi < b);
                    if !before && !short {
                        continue; // Taylor's bound: no root here
                    }
                    // What is left past the clear range.
                    let after = Piece {
                        a: hi,
                        fa: f64::NAN,
                        sa: 0,
                        ..piece
                    };
                    if !before {
                        // A side's bounds hold only on its piece; the
                        // leaf's own on the whole leaf.
                        let reach = if piece.side > 0 { b } else { t1 };
                        if let Some(t) = e.crossing(m, 1.0, reach - m) {
                            let start = hi.max(a);
                            if t - start <= tol / 1024.0 {
                                // The root is in [start, t]: any point of
                                // it is within the width of the root.
                                let best = e.estimate(m, 1.0).unwrap_or(start);
                                return Answer::Hit(best.clamp(start, t));
                            }
                            let far = up((t - m).abs().max((start - m).abs()));
                            let slope = (gm.abs() - k.g_err - up(k.g * far)).max(0.0);
                            let sign = e.sign as i8;
                            let bracket = Piece {
                                a: start,
                                b: t,
                                fa: f64::NAN,
                                fb: f64::NAN,
                                sa: sign,
                                sb: -sign,
                                side: piece.side,
                            };
                            return self.refine_from(ray, &k, bracket, slope, tol, m - fm / gm);
                        }
                        // (Where the clear range ends near b, the root is
                        // on the leaf's face, and the tests below keep a's
                        // certified sign for it.)
                        if hi - a >= 0.25 * (b - a) && b - hi >= 0.25 * (b - a) {
                            next = Some(after);
                            continue;
                        }
                    } else if (lo - a) + (b - hi.min(b)) <= 0.75 * (b - a) {
                        if hi < b {
                            self.segments.push(after);
                        }
                        next = Some(Piece {
                            b: lo,
                            fb: f64::NAN,
                            sb: 0,
                            ..piece
                        });
                        continue;
                    }
                }
            }
            // A long piece across a split leaf's crease is halved first:
            // its halves may each lie on one side.
            let halve = undecided_split && hh > shortest;
            if !decided && !halve {
                let (span, slope, continuous) = self.fg_over(ray, a, b);
                if span.is_empty() || !span.contains(0.0) {
                    continue; // interval test: no root here
                }
                // Continuous with a (Clarke) slope of one sign: monotone.
                monotone = continuous && !slope.is_empty() && !slope.contains(0.0);
                slope_min = if monotone { slope.mig() } else { 0.0 };
                slope_sign = if monotone { slope.inf().signum() } else { 0.0 };
            }
            // F at m lost in its rounding noise, on a piece longer than the
            // tolerance: the f64 tests cannot tell it from 0 anywhere near
            // (a ray along a singular curve, where ∇f vanishes: the heart's
            // equator), and halving would crawl along it a tolerance at a
            // time. An enclosure over the whole piece is tighter than the
            // leaf's error bound there, and may exclude it at once
            // (measured: the heart's scene 0.12× the time).
            if decided && !halve && hh > tol && certified_sign(fm, k.f_err) == 0 {
                let (span, _, _) = self.fg_over(ray, a, b);
                if span.is_empty() || !span.contains(0.0) {
                    continue; // interval test: no root here
                }
            }
            if monotone && slope_min > 0.0 && !fm.is_nan() {
                if let Some((bracket, start)) =
                    slope_bracket(&k, &piece, m, fm, gm, slope_min, slope_sign)
                {
                    // Newton's step from m already lands within a thousandth
                    // of the tolerance of the bracket's root (the test
                    // `refine_from` makes after each evaluation, made at m):
                    // a plane's hits, whose F is linear, take no evaluation
                    // past m.
                    let lands = newton_lands(&k, m, fm, gm, slope_min) <= tol / 1024.0;
                    if lands && start > bracket.a && start < bracket.b {
                        return Answer::Hit(start);
                    }
                    return self.refine_from(ray, &k, bracket, slope_min, tol, start);
                }
            }
            if monotone {
                // F is strictly monotone on [a, b]: its end signs decide.
                self.evaluate_ends(ray, &k, &mut piece);
                if piece.sa == 0 {
                    piece.sa = self.sign_at(ray, a, piece.fa, k.f_err);
                }
                // Where the far end can be stepped across (below), its
                // interval sign is not worth computing first.
                if piece.sb == 0 && (piece.sa == 0 || hh <= tol) {
                    piece.sb = self.sign_at(ray, b, piece.fb, k.f_err);
                }
                if piece.sa != 0 && piece.sa == piece.sb {
                    continue; // monotone with equal signs: no root here
                }
                if piece.sa != 0 && piece.sb != 0 {
                    return self.refine(ray, &k, piece, slope_min, tol);
                }
                if piece.sa != 0 && hh > tol {
                    // F at b is lost in its rounding noise (a surface on the
                    // leaf's face): rather than bisect down to b, certify the
                    // sign half a tolerance before it. Monotone, so nothing
                    // lies in between; a change of sign is a root there.
                    let c = b - 0.5 * tol;
                    let fc = self.f_at(ray, c);
                    let sc = self.sign_at(ray, c, fc, k.f_err);
                    if sc == piece.sa {
                        if let Some(hit) = self.across_face(ray, c, b, sc, tol) {
                            return hit;
                        }
                        next = Some(Piece {
                            a: c,
                            fa: fc,
                            sa: sc,
                            ..piece
                        });
                        continue;
                    }
                    if sc == -piece.sa {
                        let bracket = Piece {
                            b: c,
                            fb: fc,
                            sb: sc,
                            ..piece
                        };
                        return self.refine(ray, &k, bracket, slope_min, tol);
                    }
                }
            }
            let sm = certified_sign(fm, k.f_err);
            if hh <= tol {
                match self.settle(ray, &k, piece, m, fm, sm, tol) {
                    Answer::Miss => continue,
                    answer => return answer,
                }
            }
            if halve {
                // Cut out a short piece around where the crease is
                // estimated to be: the pieces on either side may each lie on
                // one side (any cut is sound; this one only saves halvings).
                let (near, far) = (crease - shortest, crease + shortest);
                if near > a && far < b {
                    let cut = |a: f64, b: f64| Piece {
                        a,
                        b,
                        fa: f64::NAN,
                        fb: f64::NAN,
                        sa: 0,
                        sb: 0,
                        side: 0,
                    };
                    self.segments.push(Piece {
                        fb: piece.fb,
                        sb: piece.sb,
                        ..cut(far, b)
                    });
                    self.segments.push(cut(near, far));
                    next = Some(Piece {
                        fa: piece.fa,
                        sa: piece.sa,
                        ..cut(a, near)
                    });
                    continue;
                }
            }
            self.segments.push(Piece {
                a: m,
                b,
                fa: fm,
                fb: piece.fb,
                sa: sm,
                sb: piece.sb,
                side: piece.side,
            });
            next = Some(Piece {
                a,
                b: m,
                fa: piece.fa,
                fb: fm,
                sa: piece.sa,
                sb: sm,
                side: piece.side,
            });
        }
        Answer::Miss
    }

    /// A root on the leaf's far face `b`, F's sign at `c` (just before it,
    /// nothing in between) being `sc`: certified when the whole formula has
    /// the opposite sign half a tolerance past `b`, continuous across. The
    /// point past `b` lies outside the leaf, where only the whole formula and
    /// intervals are sound; the current shape is kept when this fails.
    fn across_face(&mut self, ray: &Ray, c: f64, b: f64, sc: i8, tol: f64) -> Option<Answer> {
        let beyond = b + 0.5 * tol;
        if beyond <= b || beyond.is_nan() {
            return None;
        }
        // The whole formula's f64 value and its error bound over the whole
        // (padded) box decide first, where the point lies in the box; the
        // exact point is within twice `moved` of it (beyond may pass the
        // ray's far end by half a tolerance), well inside the pad.
        // Intervals decide where these cannot.
        let whole = self.scene.octree.whole;
        let p = ray.o + beyond * ray.d;
        let bounds = &self.scene.octree.bounds;
        let in_box = p.cmpge(bounds.lo).all() && p.cmple(bounds.hi).all();
        let shape = self.current;
        self.current = 0;
        let mut sign = 0;
        if ray.fast && in_box {
            self.stats.f_evals += 1;
            let [f] = self.whole_f.eval_array(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
            sign = certified_sign(f, up(whole.f_error + whole.lipschitz * 2.0 * ray.moved));
        }
        if sign == 0 {
            sign = interval_sign(self.fg_over(ray, beyond, beyond).0);
        }
        // Both ends in the (convex) box: the whole segment is.
        if sign == -sc && ((in_box && whole.continuous) || self.fg_over(ray, c, beyond).2) {
            return Some(Answer::Hit(b));
        }
        self.current = shape;
        None
    }

    /// A piece at the tolerance that no test excluded: a miss if the interval
    /// of F over it excludes 0, a hit if F's sign changes across it
    /// (certified), a touch otherwise.
    #[allow(clippy::too_many_arguments)]
    fn settle(
        &mut self,
        ray: &Ray,
        k: &Bounds,
        mut piece: Piece,
        m: f64,
        fm: f64,
        mut sm: i8,
        tol: f64,
    ) -> Answer {
        let (span, _, continuous) = self.fg_over(ray, piece.a, piece.b);
        if span.is_empty() || !span.contains(0.0) {
            return Answer::Miss;
        }
        self.evaluate_ends(ray, k, &mut piece);
        // A sign change proves a root only where F is continuous: across a
        // jump or a pole the piece can only be a touch.
        let continuous = continuous || k.first_order;
        if piece.sa == 0 {
            piece.sa = self.sign_at(ray, piece.a, piece.fa, k.f_err);
        }
        if piece.sb == 0 {
            piece.sb = self.sign_at(ray, piece.b, piece.fb, k.f_err);
        }
        if sm == 0 {
            sm = self.sign_at(ray, m, fm, k.f_err);
        }
        let crossing = |x: i8, y: i8| continuous && x != 0 && y != 0 && x != y;
        if crossing(piece.sa, sm) {
            let left = Piece {
                b: m,
                fb: fm,
                sb: sm,
                ..piece
            };
            return self.refine(ray, k, left, 0.0, tol);
        }
        if crossing(sm, piece.sb) {
            let right = Piece {
                a: m,
                fa: fm,
                sa: sm,
                ..piece
            };
            return self.refine(ray, k, right, 0.0, tol);
        }
        if crossing(piece.sa, piece.sb) {
            return self.refine(ray, k, piece, 0.0, tol);
        }
        // F exactly 0 at a point (its enclosure is {0}): a root there.
        for t in [piece.a, m, piece.b] {
            let (at, _, _) = self.fg_over(ray, t, t);
            if at.inf() == 0.0 && at.sup() == 0.0 {
                return Answer::Hit(t);
            }
        }
        // A root within rounding noise of an end: certify the crossing with a
        // point one piece further, F continuous across both pieces. That
        // point may lie outside the leaf, where its specialised shape need
        // not be f: from here on the whole formula decides, by intervals
        // (the leaf's bounds are its shape's). Every path below ends the ray.
        let unknown;
        let k = if self.current == 0 {
            k
        } else {
            self.current = 0;
            unknown = Bounds::UNKNOWN;
            &unknown
        };
        let w = piece.b - piece.a;
        let (outer_a, outer_b) = (piece.a - w, piece.b + w);
        let (_, _, wide_continuous) = self.fg_over(ray, outer_a, outer_b);
        if wide_continuous || k.first_order {
            let inner = if piece.sa != 0 { piece.sa } else { sm };
            if piece.sb == 0 && inner != 0 {
                let beyond = interval_sign(self.fg_over(ray, outer_b, outer_b).0);
                if beyond == -inner {
                    let bracket = Piece {
                        a: if piece.sa != 0 { piece.a } else { m },
                        b: outer_b,
                        fa: if piece.sa != 0 { piece.fa } else { fm },
                        fb: f64::NAN,
                        sa: inner,
                        sb: beyond,
                        side: 0,
                    };
                    return self.refine(ray, k, bracket, 0.0, tol);
                }
            }
            let inner = if piece.sb != 0 { piece.sb } else { sm };
            if piece.sa == 0 && inner != 0 {
                let before = interval_sign(self.fg_over(ray, outer_a, outer_a).0);
                if before == -inner {
                    let bracket = Piece {
                        a: outer_a,
                        b: if piece.sb != 0 { piece.b } else { m },
                        fa: f64::NAN,
                        fb: if piece.sb != 0 { piece.fb } else { fm },
                        sa: before,
                        sb: inner,
                        side: 0,
                    };
                    return self.refine(ray, k, bracket, 0.0, tol);
                }
            }
        }
        Answer::Touch(m)
    }

    /// The root in `[a, b]`, whose ends have certified opposite signs (F
    /// monotone with `|g| ≥ slope_min` there when that is positive), by
    /// Newton's method kept inside the bracket (bisection whenever a step
    /// would leave it). The bracket shrinks only on certified signs, until
    /// the steps stall or it is within the tolerance: a hit. If F's sign at
    /// an iterate is lost in its rounding noise first, the root cannot be
    /// placed to the tolerance: a touch at the last point of certified sign
    /// (a wide bracket is monotone, so nothing lies before it).
    fn refine(&mut self, ray: &Ray, k: &Bounds, piece: Piece, slope_min: f64, tol: f64) -> Answer {
        self.refine_from(ray, k, piece, slope_min, tol, f64::NAN)
    }

    /// [`Tracer::refine`] with a first iterate `start` (used when inside the
    /// bracket; otherwise the secant or the middle).
    fn refine_from(
        &mut self,
        ray: &Ray,
        k: &Bounds,
        piece: Piece,
        slope_min: f64,
        tol: f64,
        start: f64,
    ) -> Answer {
        let Piece {
            mut a,
            mut b,
            fa,
            fb,
            sa,
            ..
        } = piece;
        let mut x = if start > a && start < b {
            start
        } else if fa.is_finite() && fb.is_finite() && fa != fb {
            a - fa * (b - a) / (fb - fa)
        } else {
            0.5 * (a + b)
        };
        if !(x > a && x < b) {
            x = 0.5 * (a + b);
        }
        // How close to the root an answer is placed when that costs little.
        let place = tol / 1024.0;
        // Brackets from the tolerance (up to three pieces wide) count as placed.
        let within = |a: f64, b: f64| b - a <= 8.0 * tol;
        for _ in 0..200 {
            let (fx, gx) = self.fg_at(ray, x);
            let err = k.f_err;
            // Monotone with |g| ≥ slope_min between ends of opposite sign:
            // the one root r has |F(x)| = |F(x) − F(r)| ≥ slope_min·|x − r|,
            // so |x − r| ≤ (|f(x)| + err)/slope_min. Within a thousandth of
            // the tolerance, x places it, however far F(x) is from rounding
            // noise: Newton's next step would gain nothing a user could see,
            // and answers stay the same to far below the tolerance whatever
            // the octree (a thousandth off covers the roundings of the test).
            if up(fx.abs() + err) <= 0.999 * slope_min * place {
                return Answer::Hit(x);
            }
            let mut sx = certified_sign(fx, err);
            if sx == 0 {
                // Monotone with |g| ≥ slope_min: the root is within
                // 2·err/slope_min of x (|F(x)| ≤ 2·err).
                if within(a, b) || 2.0 * err <= slope_min * tol {
                    return Answer::Hit(x);
                }
                // x is within rounding noise of a root: a tolerance-wide
                // bracket around it, certified at both ends, places it.
                let (lo, hi) = ((x - tol).max(a), (x + tol).min(b));
                let s_lo = if lo == a {
                    sa
                } else {
                    self.sign_at_t(ray, k, lo)
                };
                let s_hi = if hi == b {
                    -sa
                } else {
                    self.sign_at_t(ray, k, hi)
                };
                if s_lo == sa && s_hi == -sa {
                    return Answer::Hit(x);
                }
                // The f64 value cannot tell; an enclosure at x may.
                sx = self.sign_at(ray, x, fx, f64::INFINITY);
                if sx == 0 {
                    // The root cannot be placed to the tolerance: F is
                    // monotone here, so nothing lies before a; move a up to
                    // the noise (bisecting on certified signs) and touch there.
                    let mut noisy = x;
                    for _ in 0..64 {
                        let mid = 0.5 * (a + noisy);
                        if mid <= a || mid >= noisy {
                            break;
                        }
                        if self.sign_at_t(ray, k, mid) == sa {
                            a = mid;
                        } else {
                            noisy = mid;
                        }
                    }
                    return Answer::Touch(a);
                }
            }
            if sx == sa {
                a = x;
            } else {
                b = x;
            }
            let newton = x - fx / gx;
            if newton > a && newton < b && newton_lands(k, x, fx, gx, slope_min) <= place {
                return Answer::Hit(newton);
            }
            let next = if newton > a && newton < b {
                newton
            } else {
                0.5 * (a + b)
            };
            if (next - x).abs() <= 2.0 * f64::EPSILON * x.abs().max(f64::MIN_POSITIVE)
                || b - a <= (4.0 * f64::EPSILON * a.abs().max(b.abs())).max(1e-6 * tol)
            {
                return Answer::Hit(next);
            }
            x = next;
        }
        if within(a, b) {
            Answer::Hit(x)
        } else {
            Answer::Touch(a)
        }
    }

    /// The unit surface normal at `p`, the last hit: the normalised gradient
    /// of the shape that found the hit (f itself around it, and shorter than
    /// the whole formula where a leaf settled its branch points).
    /// Where the gradient is below a millionth of the hit leaf's L (singular
    /// curves such as the heart's rim, where it is only rounding noise), the
    /// direction in which f grows across a small neighbourhood (central
    /// differences at a thousandth of the leaf) stands in; `None` if that
    /// vanishes too.
    pub fn normal(&mut self, p: DVec3) -> Option<DVec3> {
        if let Some(affine) = &self.scene.octree.affine {
            return affine.normal();
        }
        let at = [p.x, p.y, p.z, 0.0, 0.0, 0.0];
        let n = DVec3::from(if self.hit_shape == 0 {
            self.grad.eval_array(&at)
        } else {
            self.current = self.hit_shape;
            let shape = &self.scene.octree.shapes[self.current];
            let evals = self.evals();
            evals
                .grad
                .get_or_insert_with(|| PointEvaluator::new(&shape.grad))
                .eval_array(&at)
        });
        let (mut l, mut size) = self.hit_leaf;
        if l.is_nan() {
            // A hit in Bernstein form: the box's bound of |∇f| first, and
            // the leaf's own where that cannot tell.
            let octree = &self.scene.octree;
            l = octree.whole.lipschitz;
            if n.length() <= 1e-6 * l {
                (l, size) = octree.leaf_bounds_at(p);
            }
        }
        let reliable = n.length() > 1e-6 * l || !l.is_finite() || size == 0.0;
        if let (true, Some(unit)) = (reliable, n.try_normalize()) {
            return Some(unit);
        }
        let h = 1e-3
            * if size > 0.0 {
                size
            } else {
                (self.scene.octree.bounds.hi - self.scene.octree.bounds.lo).length()
            };
        let mut f = |q: DVec3| {
            self.whole_f
                .eval_array::<1>(&[q.x, q.y, q.z, 0.0, 0.0, 0.0])[0]
        };
        let diff = |f: &mut dyn FnMut(DVec3) -> f64, axis: DVec3| f(p + h * axis) - f(p - h * axis);
        let m = DVec3::new(
            diff(&mut f, DVec3::X),
            diff(&mut f, DVec3::Y),
            diff(&mut f, DVec3::Z),
        );
        m.try_normalize().or_else(|| n.try_normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_slab_test_without_min_and_max_gives_their_times() {
        // Boxes and rays at random, some starting on a face or a corner, some
        // nearly parallel to an axis: the fast slab test's times are those of
        // the careful one (f64's min and max), which axis-parallel rays take.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        let mut compared = 0;
        for k in 0..20_000 {
            let (a, b) = (
                DVec3::new(next(), next(), next()),
                DVec3::new(next(), next(), next()),
            );
            let bounds = Aabb::new(a.min(b), a.max(b)).unwrap();
            let mut o = DVec3::new(next(), next(), next());
            let mut d = DVec3::new(next(), next(), next());
            match k % 4 {
                1 => o.x = bounds.lo.x,
                2 => o = bounds.hi,
                3 => d.y *= 1e-300,
                _ => {}
            }
            let inv_d = d.recip();
            if !inv_d.is_finite() {
                continue;
            }
            let (fast, careful) = (
                slab(&bounds, o, d, inv_d),
                slab_with_zeros(&bounds, o, d, inv_d),
            );
            assert_eq!(fast, careful, "box {bounds:?}, ray {o} + t·{d}");
            compared += 1;
        }
        assert!(compared > 19_000);
    }
}
