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
//!   parabola below and one above F (`taylor`): F keeps its
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
//! piece is first answered in closed form (`seam`): the roots
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
//! [`SplitLeaf`]: crate::ray::octree::SplitLeaf

mod bounds;
mod closed;
mod eval;
mod march;
mod normal;
pub(in crate::ray) mod piece;
mod refine;
mod scale;
mod search;
mod shared;
pub(in crate::ray) mod walk;

use crate::expr::{DecoratedEvaluator, Evaluator, PointEvaluator};
use crate::formula::Formula;
use crate::ray::answer::Answer;
use crate::ray::closed::polynomial;
use crate::ray::octree::{BuildOptions, NodeId, Octree, OctreeStats, Shape, ViewFrame};
use crate::ray::stats::RayStats;
use crate::types::geom::norm;
use crate::types::rounding::up_test as up;
use crate::types::rounding::{mul_down, mul_up};
use crate::types::Aabb;
use crate::types::Interval;
use eval::Part;
use glam::DVec3;
use piece::*;
use scale::{scaled_back, unit_scale};

/// Pieces a single ray may examine before it stops as [`Answer::Undecided`].
/// No ray of the tests, the corpus or the examples comes near it.
pub const MAX_PIECES_PER_RAY: u32 = 1 << 22;

/// Octree nodes a region query may visit before f's enclosure decides.
const MAX_REGION_VISITS: usize = 64;

/// A surface compiled for ray queries: its octree, whose leaves refer to the
/// compiled shapes of the formula as they see it.
#[derive(Debug, Clone)]
pub struct Intersector {
    pub(in crate::ray) octree: Octree,
    /// Distance below which a segment is not split further.
    pub(in crate::ray) tolerance: f64,
    /// Every computed point of a ray lies in the padded box, so `|p|` is at
    /// most this.
    pub(in crate::ray) radius: f64,
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
        let radius = up(norm(b.lo.abs().max(b.hi.abs()) + DVec3::splat(octree.pad)));
        Intersector {
            octree,
            tolerance: 1e-10 * bounds.diagonal(),
            radius,
        }
    }

    /// How close to a root an answer is placed, and how near 0 an enclosure
    /// must come for a touch: 1e-10 of the box's diagonal, in space.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// The octree its rays are answered on (with the cells of its leaves
    /// that rays have made so far).
    pub fn octree(&self) -> &Octree {
        &self.octree
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
    pub fn frame(&self) -> ViewFrame {
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
            intersector: self,
            shapes: vec![None; self.octree.shapes.len()],
            current: 0,
            short: vec![None; self.octree.short.tapes.len()],
            short_points: vec![None; self.octree.short.tapes.len()],
            leaf: usize::MAX,
            whole_f: PointEvaluator::new(&whole.f),
            whole_fi: Evaluator::new(&whole.f),
            grad: PointEvaluator::new(whole.grad()),
            stats: RayStats::default(),
            stack: Vec::new(),
            taken: Vec::new(),
            query: Vec::new(),
            segments: Vec::new(),
            hit_leaf: (f64::INFINITY, 0.0),
            hit_shape: 0,
            hit_index: usize::MAX,
            side_first: 0,
            closed_form_seams: true,
            closed_form_planes: true,
            polynomial: self.octree.polynomial.as_ref().map(|p| p.scratch()),
            closed_form: self.octree.affine.is_some() || self.octree.polynomial.is_some(),
            shared: Default::default(),
            parts: Vec::new(),
            keep_parts: true,
            first_halves: true,
            march_on: true,
        }
    }
}

/// Answers rays against one [`Intersector`]; one per thread.
pub struct Tracer<'s> {
    pub(in crate::ray) intersector: &'s Intersector,
    /// Evaluators of each shape, made when a ray first meets it.
    shapes: Vec<Option<RayEvaluators<'s>>>,
    /// The shape of the leaf being searched.
    current: usize,
    /// Enclosures of f and g by each short tape, made when a ray first
    /// needs it.
    short: Vec<Option<DecoratedEvaluator<'s>>>,
    /// f and g at points by each short tape, made when a ray first needs it.
    short_points: Vec<Option<PointEvaluator<'s>>>,
    /// The leaf being searched (its index), whose short tapes enclose f and
    /// g over pieces inside its region.
    leaf: usize,
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
    pub(in crate::ray) taken: Vec<(f64, f64, NodeId)>,
    /// Scratch space of octree queries.
    query: Vec<NodeId>,
    segments: Vec<Piece>,
    /// L and size of the leaf where the last hit was found, for normals.
    hit_leaf: (f64, f64),
    /// The shape that found the last hit: f itself near the hit, so its
    /// gradient is f's there (see [`Tracer::normal`]).
    hit_shape: usize,
    /// The leaf that found the last hit (its index; `usize::MAX` for none
    /// or a closed form), whose short tape serves its normal.
    hit_index: usize,
    /// The side of a split leaf that [`Tracer::side_of`] evaluates first:
    /// the last one that cleared a piece on its own (neighbouring rays
    /// cross the same leaves the same way).
    side_first: usize,
    /// Whether split leaves' pieces are answered in closed form where both
    /// sides are quadratic (`seam`).
    closed_form_seams: bool,
    /// Whether an affine formula's rays are answered in closed form
    /// ([`Affine`](super::affine::Affine)).
    closed_form_planes: bool,
    /// The enclosures of the parts of pieces [`Tracer::fg_over_inputs`] cut
    /// in the leaf being searched, by shape and ends: the search halves an
    /// undecided piece where it was cut, and asks for them again.
    parts: Vec<Part>,
    /// Whether `parts` are kept ([`Tracer::set_keep_parts`]).
    keep_parts: bool,
    /// Whether a cut piece's second half goes unenclosed where its first
    /// leaves the search's tests undecided ([`Tracer::set_first_halves`]).
    first_halves: bool,
    /// Whether creased leaves' first pieces are marched
    /// ([`Tracer::set_march`]).
    march_on: bool,
    /// Scratch space for a polynomial formula's rays, answered in Bernstein
    /// form ([`Polynomial`](super::polynomial::Polynomial); an octree built
    /// without [`BuildOptions::polynomial_form`] has none).
    polynomial: Option<polynomial::Scratch>,
    /// Whether either closed form answers this formula's rays.
    closed_form: bool,
    /// Enclosures of F and g over leaves that the current bundle's rays
    /// share.
    shared: shared::SharedEnclosures,
}

/// Point and interval evaluators of one shape.
#[derive(Clone)]
pub(super) struct RayEvaluators<'s> {
    pub(super) f: PointEvaluator<'s>,
    pub(super) fg: PointEvaluator<'s>,
    /// Enclosures of f and g; only f's decoration is read.
    pub(super) fgi: DecoratedEvaluator<'s>,
    /// ∇f, made at the first normal taken on the shape.
    pub(super) grad: Option<PointEvaluator<'s>>,
    /// f over boxes, for bundles of rays (undecorated: only the values are
    /// read), made on first use.
    pub(super) fi: Option<Evaluator<'s, Interval>>,
}

impl<'s> RayEvaluators<'s> {
    pub(super) fn new(shape: &'s Shape) -> Self {
        RayEvaluators {
            f: PointEvaluator::new(&shape.f),
            fg: PointEvaluator::new(&shape.fg),
            fgi: DecoratedEvaluator::reading(&shape.fg, &[0]),
            grad: None,
            fi: None,
        }
    }
}

impl<'s> Tracer<'s> {
    /// Whether the box `region` is proved to hold no point of the surface
    /// inside the bounding box: it meets no kept leaf of the octree, or the
    /// enclosure of f over it (where f is defined) excludes 0, as the
    /// intersector's own interval test. The second counts as an interval
    /// evaluation.
    pub(crate) fn region_is_clear(&mut self, region: [Interval; 3]) -> bool {
        let octree = &self.intersector.octree;
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

    /// Whether the enclosure of shape `shape`'s f over `region` excludes 0:
    /// inside the padded box of a leaf of that shape, where the shape has
    /// f's sign, no root of f lies there. Counts as an interval evaluation.
    pub(crate) fn shape_f_excludes(&mut self, shape: usize, region: [Interval; 3]) -> bool {
        self.stats.interval_evals += 1;
        let tape = &self.intersector.octree.shapes[shape].f;
        let evals = self.shapes[shape]
            .get_or_insert_with(|| RayEvaluators::new(&self.intersector.octree.shapes[shape]));
        let e = evals.fi.get_or_insert_with(|| Evaluator::new(tape));
        let zero = Interval::ZERO;
        let [x, y, z] = region;
        let [f] = e.eval_array(&[x, y, z, zero, zero, zero]);
        f.is_empty() || !f.contains(0.0)
    }

    /// The smallest `t` in `[t_min, t_max]` where the ray `o + t·d` meets the
    /// surface inside the box (a hit or a touch, see [`Tracer::answer`]), or
    /// `None`. `d` need not be normalised.
    pub fn first_hit(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        self.answer(o, d, t_min, t_max).t()
    }

    /// Whether pieces of split leaves whose sides are both quadratic along
    /// the ray are answered in closed form from the sides' values at their
    /// middle (`seam`; on by default), or searched by the
    /// general tests alone, as a reference to compare with.
    pub fn set_closed_form_seams(&mut self, on: bool) {
        self.closed_form_seams = on;
    }

    /// Whether the enclosures of the parts of a piece cut for its leaf's
    /// cells serve the search's next pieces (on by default), or each piece
    /// is enclosed anew, as a reference to compare with.
    pub fn set_keep_parts(&mut self, on: bool) {
        self.keep_parts = on;
        self.parts.clear();
    }

    /// Whether the search's tests of a piece cut for its leaf's cells stop
    /// enclosing its parts once its first half leaves every test undecided
    /// (on by default; the search then halves it, as it would), or enclose
    /// every part, as a reference to compare with.
    pub fn set_first_halves(&mut self, on: bool) {
        self.first_halves = on;
    }

    /// Whether a ray's piece of a creased leaf that F at its middle does not
    /// clear is first marched along by steps F's Lipschitz bound proves
    /// clear (on by default), or searched by halving and enclosures alone,
    /// as a reference to compare with.
    pub fn set_march(&mut self, on: bool) {
        self.march_on = on;
    }

    /// Whether rays against a formula that is affine over the box (a plane)
    /// are answered in closed form ([`Affine`](crate::ray::closed::affine::Affine); on by
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
        &self.intersector.octree
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
        // Far from a unit direction, t leaves the range the tolerances and
        // rounding bounds are made for (|d| = 1e-170 puts the sphere at
        // t = 1e170). The ray is traced with d scaled by a power of two to
        // a unit's size, which is exact, and t scaled back.
        match unit_scale(d) {
            Some(s) => {
                let (lo, hi) = (mul_down(t_min, s), mul_up(t_max, s));
                let answer = self.answer_unit(o, d / s, lo, hi, leaving);
                scaled_back(answer, s)
            }
            _ => self.answer_unit(o, d, t_min, t_max, leaving),
        }
    }

    /// [`Tracer::answer_with`] for a direction of about unit size.
    fn answer_unit(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64, leaving: bool) -> Answer {
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
        let octree = &self.intersector.octree;
        self.closed_form =
            (self.closed_form_planes && octree.affine.is_some()) || octree.polynomial.is_some();
    }

    pub(in crate::ray) fn count(&mut self, answer: Answer) {
        match answer {
            Answer::Hit(_) => self.stats.hits += 1,
            Answer::Touch(_) => self.stats.touches += 1,
            Answer::Undecided(_) => self.stats.undecided += 1,
            _ => {}
        }
    }
}
