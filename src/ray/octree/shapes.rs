//! The formula compiled as each region sees it, by the branches the region settles.

use super::leaf::*;
use super::options::*;
use crate::expr::specialise::{
    branch_points, normalise, Branch, BranchPoint, PointIndex, RootSplit,
};
use crate::expr::tape::instr::Instr;
use crate::expr::{BinaryOp, Evaluator, Tape, UnaryOp};
use crate::expr::{Context, GraphTooLarge, Node};
use crate::formula::{first_and_second_derivatives, first_derivatives, Formula, Output};
use crate::ray::closed::affine::Affine;
use crate::types::{Aabb, DecInterval, Decoration, Interval};
use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

/// The formula compiled as a region sees it: the whole formula
/// ([`Octree::shapes`](super::Octree::shapes)`[0]`), or one with the branch points that the region
/// settles replaced by their branches.
#[derive(Debug, Clone)]
pub struct Shape {
    /// f.
    pub f: Tape,
    /// f and g ([`FG`]).
    pub fg: Tape,
    /// ∇f, cut from `f_grad` when first read: only normals read it, at
    /// the hits in the leaves of the shapes rays hit.
    grad: std::sync::OnceLock<Tape>,
    /// The body instructions of `grad`, made or not.
    grad_len: usize,
    pub(super) f_grad: Tape,
    /// f, ∇f and the Hessian (xx, yy, zz, xy, xz, yz), for leaves (one
    /// tape: their common subexpressions are computed once); none in a
    /// specialised shape with a branch point open, where ∇f may jump and
    /// its leaves take L and intervals alone (deriving the Hessian was
    /// most of such a shape's cost).
    pub(super) local: Option<Tape>,
    /// Branch points left in it: creases or jumps the region may hold.
    pub open: usize,
    /// Whether f takes only arithmetic, integer powers and square roots:
    /// each evaluation then costs a few instructions, no more than a step
    /// of the octree walk it could spare (see [`TIGHT_RATIO`]).
    pub(super) algebraic: bool,
}

impl Shape {
    pub(super) fn is_algebraic(f: &Tape) -> bool {
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

    pub(super) fn new(formula: &Formula) -> Shape {
        let derived = Derived {
            f: formula.f(),
            grad: formula.gradient(),
            g: formula.g(),
            hessian: Some(Output::HESSIAN.map(|o| formula.node(o))),
        };
        let (ctx, f) = (formula.context(), formula.tape(&[Output::F]));
        Shape::compiled(ctx, &derived, f, formula.branch_points().len())
    }

    /// The shape of `derived`'s nodes in `ctx`, given its f tape and the
    /// branch points `open` in f.
    fn compiled(ctx: &Context, derived: &Derived, f: Tape, open: usize) -> Shape {
        let Derived {
            f: root,
            grad,
            g,
            hessian,
        } = *derived;
        let f_grad = [root, grad[0], grad[1], grad[2]];
        let local = hessian.map(|h| {
            let nodes: Vec<Node> = f_grad.iter().chain(&h).copied().collect();
            Tape::new(ctx, &nodes)
        });
        let f_grad = Tape::new(ctx, &f_grad);
        Shape {
            algebraic: Self::is_algebraic(&f),
            f,
            fg: Tape::new(ctx, &[root, g]),
            grad: std::sync::OnceLock::new(),
            grad_len: f_grad.keeping_len(&GRADIENT),
            f_grad,
            local,
            open,
        }
    }

    /// ∇f's tape (made on first use, from the tape of f and ∇f: the same
    /// operations, so the same values).
    pub fn grad(&self) -> &Tape {
        self.grad.get_or_init(|| self.f_grad.keeping(&GRADIENT))
    }

    /// The body instructions of all its tapes.
    pub(super) fn instructions(&self) -> usize {
        let tapes = [&self.f, &self.fg, &self.f_grad]
            .into_iter()
            .chain(&self.local);
        tapes.map(|t| t.body().len()).sum::<usize>() + self.grad_len
    }
}

/// The outputs ∇f of a shape's tape of f and ∇f.
const GRADIENT: [bool; 4] = [false, true, true, true];

/// The outputs the intersector evaluates in f64 (its `fg` tape): their
/// rounding is bounded per leaf over this same tape.
pub const FG: [Output; 2] = [Output::F, Output::G];

/// The specialised shapes compiled so far, by the branches they decide.
pub(super) struct Shapes {
    /// The whole formula first.
    pub(super) list: Vec<Shape>,
    /// Whether each shape is at most quadratic in the whole (padded) box.
    pub(super) quadratic: Vec<bool>,
    /// The padded bounding box.
    pub(super) bounds: Aabb,
    /// The (normalised) branches each shape decides.
    pub(super) patterns: Vec<Vec<Branch>>,
    pub(super) ids: FxHashMap<Vec<Branch>, u32>,
    /// Answers of [`Shapes::id`] by the pattern as given, before it is
    /// normalised (a walk of the whole formula): neighbouring boxes settle
    /// the same branches, so most patterns recur. At most
    /// [`MAX_REMEMBERED_BRANCHES`] branches in all, whatever the formula.
    pub(super) remembered: FxHashMap<Vec<Branch>, (u32, usize)>,
    /// Each creased shape's two smooth sides, where it has them.
    pub(super) splits: FxHashMap<u32, Option<Split>>,
    /// Body instructions of the shapes past the whole formula (at most
    /// [`MAX_SHAPE_INSTRUCTIONS`]).
    pub(super) instructions: usize,
    /// Whether a shape was refused for the budget: later ones are too.
    pub(super) closed: bool,
    /// The (normalised) patterns whose shapes were not worth compiling
    /// (see [`SHAPE_WORTH`]): their regions see the whole formula.
    pub(super) unworthy: rustc_hash::FxHashSet<Vec<Branch>>,
    /// The normalised forms of the patterns the last [`Shapes::compile`]
    /// saw, for [`Shapes::id`] to take rather than walk the formula again
    /// (at most [`MAX_REMEMBERED_BRANCHES`] branches in all).
    pub(super) normalised: FxHashMap<Vec<Branch>, Vec<Branch>>,
}

/// What specialising the formula to a pattern gives.
enum Specialised {
    /// A shape to keep.
    Shape(Box<Shape>),
    /// A formula too long to derive: no larger one is worth trying.
    TooLarge,
    /// A shape with two or more branch points open whose f is not short
    /// enough against the whole formula's.
    Unworthy,
}

/// The shape of `formula` specialised to the normalised pattern `pattern`,
/// where it has at most one branch point open (it is smooth, and its
/// regions' rays get second-order bounds, or it may be the larger or
/// smaller of two smooth sides) or its f has at most [`SHAPE_WORTH`] of the
/// `whole` formula's instructions (f's tape is made first; the derivatives
/// and the other tapes, most of a shape's cost, only for a shape kept).
fn specialise(
    formula: &Formula,
    points: &[BranchPoint],
    pattern: &[Branch],
    whole: usize,
) -> Specialised {
    let (ctx, root) =
        crate::expr::specialise::specialise(formula.context(), formula.f(), points, pattern);
    let f = Tape::new(&ctx, &[root]);
    let open = branch_points(&ctx, root).len();
    if f.body().len() as f64 > SHAPE_WORTH * whole as f64 && open > 1 {
        return Specialised::Unworthy;
    }
    match Derived::of(ctx, root, open == 0) {
        Ok((ctx, derived)) => {
            Specialised::Shape(Box::new(Shape::compiled(&ctx, &derived, f, open)))
        }
        Err(_) => Specialised::TooLarge,
    }
}

/// The nodes of f and of the derivatives a shape compiles: ∇f, g = d·∇f
/// and, where no branch point is open, the Hessian; not g′ (a
/// [`Formula`]'s), which no shape reads.
#[derive(Debug, Clone, Copy)]
struct Derived {
    f: Node,
    grad: [Node; 3],
    g: Node,
    hessian: Option<[Node; 6]>,
}

impl Derived {
    /// The derivatives of `f`, derived in `ctx`, the Hessian where
    /// `second`; `Err` when `ctx` passes its node limit, before or while
    /// deriving.
    fn of(mut ctx: Context, f: Node, second: bool) -> Result<(Context, Derived), GraphTooLarge> {
        ctx.check_size()?;
        let (grad, g, hessian) = if second {
            let (grad, g, hessian) = first_and_second_derivatives(&mut ctx, f);
            (grad, g, Some(hessian))
        } else {
            let (grad, g) = first_derivatives(&mut ctx, f);
            (grad, g, None)
        };
        ctx.check_size()?;
        let derived = Derived {
            f,
            grad,
            g,
            hessian,
        };
        Ok((ctx, derived))
    }
}

/// A shape that is the larger or smaller of two smooth shapes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Split {
    pub(super) larger: bool,
    pub(super) sides: [u32; 2],
}

/// The shape a kept box sees, as its branches settle it.
pub(super) enum Settled {
    /// Its parent's: no branch point was open there.
    Inherited,
    /// A shape compiled before, and the branch points it leaves open.
    Known(u32, usize),
    /// A pattern not seen before, for [`Shapes::id`].
    New(Vec<Branch>),
}

/// Branches (one byte each) of the patterns [`Shapes`] remembers; past it,
/// each new pattern is normalised again.
pub(super) const MAX_REMEMBERED_BRANCHES: usize = 1 << 24;

impl Shapes {
    /// Compiles, in parallel, the shapes of the `patterns` not compiled yet
    /// (in order, while fewer than [`MAX_SHAPES`] are and their
    /// instructions fit [`MAX_SHAPE_INSTRUCTIONS`]), so that [`Shapes::id`]
    /// then finds them.
    pub(super) fn compile(
        &mut self,
        formula: &Formula,
        (points, index): (&[BranchPoint], &PointIndex),
        patterns: &[&[Branch]],
    ) {
        let mut seen = rustc_hash::FxHashSet::default();
        let fresh: Vec<&[Branch]> = patterns
            .iter()
            .copied()
            .filter(|&p| seen.insert(p) && self.known(p).is_none())
            .collect();
        // Each a walk of the whole formula: in parallel, in order.
        let normalised: Vec<Vec<Branch>> = fresh
            .par_iter()
            .map(|p| normalise(formula.context(), formula.f(), points, index, p))
            .collect();
        self.normalised.clear();
        let mut todo: Vec<Vec<Branch>> = Vec::new();
        let mut queued = rustc_hash::FxHashSet::default();
        for (&pattern, normalised) in fresh.iter().zip(normalised) {
            if self.list.len() + todo.len() < MAX_SHAPES && !self.full() {
                let tried =
                    self.ids.contains_key(&normalised) || self.unworthy.contains(&normalised);
                if !tried && queued.insert(normalised.clone()) {
                    todo.push(normalised.clone());
                }
            }
            if (self.normalised.len() + 1) * pattern.len() <= MAX_REMEMBERED_BRANCHES {
                self.normalised.insert(pattern.to_vec(), normalised);
            }
        }
        // In batches compiled in parallel, kept in order until the budget
        // is full: which shapes are kept depends neither on the batch size
        // nor on the thread count.
        let mut rest = todo.as_slice();
        while !rest.is_empty() && !self.full() {
            let (batch, later) = rest.split_at(self.batch_size().min(rest.len()));
            rest = later;
            let whole = self.whole_length();
            let compiled: Vec<Specialised> = batch
                .par_iter()
                .map(|n| specialise(formula, points, n, whole))
                .collect();
            for (normalised, shape) in batch.iter().zip(compiled) {
                if self.full() {
                    break;
                }
                match shape {
                    Specialised::Shape(shape) => _ = self.keep(normalised.clone(), *shape),
                    Specialised::Unworthy => _ = self.unworthy.insert(normalised.clone()),
                    Specialised::TooLarge => self.closed = true,
                }
            }
        }
    }

    /// How many shapes [`Shapes::compile`] compiles at once: as many as the
    /// instruction budget left would hold were each as long as the whole
    /// formula's, so that a batch's memory stays within the budget and
    /// little is compiled past it, and at least two per thread.
    fn batch_size(&self) -> usize {
        let whole = self.list.first().map_or(1, Shape::instructions).max(1);
        let left = MAX_SHAPE_INSTRUCTIONS.saturating_sub(self.instructions);
        (left / whole).max(2 * rayon::current_num_threads().max(1))
    }

    /// Whether no more shapes may be compiled: [`MAX_SHAPES`] are (or were
    /// tried and found not worth it), or one did not fit
    /// [`MAX_SHAPE_INSTRUCTIONS`].
    pub(super) fn full(&self) -> bool {
        self.closed || self.list.len() + self.unworthy.len() >= MAX_SHAPES
    }

    /// The instructions of the whole formula's f.
    fn whole_length(&self) -> usize {
        self.list.first().map_or(0, |s| s.f.body().len())
    }

    /// Adds `shape`, compiled for the normalised pattern `normalised`, while
    /// the budgets allow: its id.
    fn keep(&mut self, normalised: Vec<Branch>, shape: Shape) -> Option<u32> {
        let len = shape.instructions();
        if self.list.len() >= MAX_SHAPES || self.instructions + len > MAX_SHAPE_INSTRUCTIONS {
            self.closed = true;
            return None;
        }
        self.instructions += len;
        let id = self.list.len() as u32;
        self.quadratic.push(at_most_quadratic(&shape, &self.bounds));
        self.list.push(shape);
        self.patterns.push(normalised.clone());
        self.ids.insert(normalised, id);
        Some(id)
    }

    /// The two smooth sides of `shape`, a shape with one open branch point,
    /// where it is the larger or smaller of them (compiled on first use);
    /// `None` otherwise, or when no more shapes may be compiled.
    pub(super) fn split(
        &mut self,
        formula: &Formula,
        (points, index): (&[BranchPoint], &PointIndex),
        shape: u32,
    ) -> Option<Split> {
        if let Some(&split) = self.splits.get(&shape) {
            return split;
        }
        let pattern = self.patterns[shape as usize].clone();
        let root = RootSplit::of(formula.context(), formula.f(), points, index, &pattern);
        let split = root.and_then(|root| {
            let mut sides = [0; 2];
            for (side, branch) in sides.iter_mut().zip([Branch::First, Branch::Second]) {
                let mut decided = pattern.clone();
                decided[root.point] = branch;
                match self.id(formula, (points, index), &decided) {
                    (id, 0) if id != 0 => *side = id,
                    _ => return None,
                }
            }
            Some(Split {
                larger: root.larger,
                sides,
            })
        });
        self.splits.insert(shape, split);
        split
    }

    /// [`Shapes::id`] for a pattern seen before (no compiling, no walk of
    /// the formula); `None` for a new one.
    pub(super) fn known(&self, pattern: &[Branch]) -> Option<(u32, usize)> {
        if pattern.iter().all(|&b| b == Branch::Open) {
            return Some((0, pattern.len()));
        }
        self.remembered.get(pattern).copied()
    }

    /// The shape for `pattern` (compiled on first use) and how many branch
    /// points it leaves open; the whole formula when nothing is decided or
    /// no more may be compiled ([`Shapes::full`]).
    pub(super) fn id(
        &mut self,
        formula: &Formula,
        (points, index): (&[BranchPoint], &PointIndex),
        pattern: &[Branch],
    ) -> (u32, usize) {
        let whole = (0, points.len());
        if pattern.iter().all(|&b| b == Branch::Open) {
            return whole;
        }
        if let Some(&answer) = self.remembered.get(pattern) {
            return answer;
        }
        let normalised = match self.normalised.remove(pattern) {
            Some(n) => n,
            None => normalise(formula.context(), formula.f(), points, index, pattern),
        };
        let answer = if let Some(&id) = self.ids.get(&normalised) {
            (id, self.list[id as usize].open)
        } else if self.full() || self.unworthy.contains(&normalised) {
            whole
        } else {
            match specialise(formula, points, &normalised, self.whole_length()) {
                Specialised::Shape(shape) => {
                    let open = shape.open;
                    match self.keep(normalised, *shape) {
                        Some(id) => (id, open),
                        None => whole,
                    }
                }
                Specialised::Unworthy => {
                    self.unworthy.insert(normalised);
                    whole
                }
                Specialised::TooLarge => {
                    self.closed = true;
                    whole
                }
            }
        };
        if (self.remembered.len() + 1) * pattern.len() <= MAX_REMEMBERED_BRANCHES {
            self.remembered.insert(pattern.to_vec(), answer);
        }
        answer
    }
}

/// f as an affine form over `b`, when it is one there: no branch point, f,
/// ∇f and the Hessian defined and continuous over `b`, and the Hessian's
/// enclosure exactly 0 (so ∇f is constant on the box: a plane).
/// `over` is f, ∇f and the Hessian enclosed over `b` ([`local_over`]).
pub(super) fn affine_form(shape: &Shape, over: &[DecInterval], b: &Aabb) -> Option<Affine> {
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

/// The interval inputs of the box `b`, the direction 0: what f, ∇f and
/// the Hessian are enclosed over (none of them reads the direction).
pub(super) fn inputs_over(b: &Aabb) -> [DecInterval; 6] {
    let [x, y, z] = b.intervals().map(DecInterval::defined);
    let zero = DecInterval::defined(Interval::point(0.0));
    [x, y, z, zero, zero, zero]
}

/// The shape's f, ∇f and Hessian (xx, yy, zz, xy, xz, yz) enclosed over
/// `b`; `None` where it holds no Hessian.
pub(super) fn local_over(shape: &Shape, b: &Aabb) -> Option<Vec<DecInterval>> {
    let local = shape.local.as_ref()?;
    Some(Evaluator::new(local).eval(&inputs_over(b)).to_vec())
}

/// Whether the shape's interval Hessian over `b` has no width: f is at most
/// quadratic there (a sphere, a plane, a placed quadric primitive). A shape
/// with no Hessian has a branch point open: not known to be.
pub(super) fn at_most_quadratic(shape: &Shape, b: &Aabb) -> bool {
    local_over(shape, b).is_some_and(|over| quadratic_over(&over))
}

/// [`at_most_quadratic`] from the enclosures [`local_over`] gives.
pub(super) fn quadratic_over(over: &[DecInterval]) -> bool {
    let h = &over[4..];
    !partly_undefined(h) && h.iter().all(|v| constant(v.interval()))
}

/// Half the box's diagonal, enclosed (the f64 value may round low).
/// The inputs of a decorated evaluation at the point `p` (direction 0).
pub(super) fn point_inputs(p: DVec3) -> [DecInterval; 6] {
    let pt = |v: f64| DecInterval::defined(Interval::point(v));
    let zero = pt(0.0);
    [pt(p.x), pt(p.y), pt(p.z), zero, zero, zero]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shapes compiled for patterns deciding the formula's two `min`s
    /// either way, from a budget that fits `left` more instructions.
    fn kept_from(f: &Formula, patterns: &[Vec<Branch>], left: usize, threads: usize) -> usize {
        let whole = Shape::new(f);
        let points = f.branch_points();
        let bounds = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
        let mut shapes = Shapes {
            quadratic: vec![false],
            bounds,
            list: vec![whole],
            patterns: vec![vec![Branch::Open; points.len()]],
            ids: FxHashMap::default(),
            remembered: FxHashMap::default(),
            splits: FxHashMap::default(),
            instructions: MAX_SHAPE_INSTRUCTIONS - left,
            closed: false,
            unworthy: Default::default(),
            normalised: FxHashMap::default(),
        };
        let index = PointIndex::new(&points);
        let patterns: Vec<&[Branch]> = patterns.iter().map(Vec::as_slice).collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| shapes.compile(f, (&points, &index), &patterns));
        shapes.list.len() - 1
    }

    /// A shape that leaves a branch point open holds no Hessian (its leaves
    /// take L and intervals alone); a smooth one holds it, and its
    /// enclosure matches the whole formula's where the region decides.
    #[test]
    fn only_shapes_with_no_branch_point_open_derive_the_hessian() {
        use Branch::{First, Open};
        // min(min(ball, plane), plane): the inner `min` is point 0.
        let f = Formula::parse("min(min(x^2+y^2+z^2-1, z-0.5), x-0.3)").unwrap();
        let points = f.branch_points();
        let shape = |pattern: &[Branch]| match specialise(&f, &points, pattern, 0) {
            Specialised::Shape(shape) => shape,
            _ => panic!("{pattern:?} is a shape"),
        };
        let creased = shape(&[Open, First]);
        assert_eq!(creased.open, 1);
        assert!(creased.local.is_none());
        let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
        assert!(!at_most_quadratic(&creased, &b));
        let ball = shape(&[First, First]);
        assert_eq!(ball.open, 0);
        assert!(at_most_quadratic(&ball, &b));
        let hessian = local_over(&ball, &b).unwrap();
        for (k, h) in hessian[4..].iter().enumerate() {
            let diagonal = if k < 3 { 2.0 } else { 0.0 };
            assert_eq!(h.interval(), Interval::point(diagonal), "Hessian entry {k}");
        }
        // The whole formula always holds its Hessian.
        assert!(Shape::new(&f).local.is_some());
    }

    /// Regression: a batch of shapes (two per thread) was kept past the
    /// first that the budget refused, so a later, shorter one in the same
    /// batch was kept, and which were depended on the thread count.
    #[test]
    fn no_shape_is_kept_past_the_first_the_budget_refuses() {
        // min(min(long, ball), plane): the long side first, then the ball.
        let long = "sin(x)*exp(y)+cos(y*z)*atan(x*z)+sqrt(1+x^2*y^2)*tanh(z)";
        let f = Formula::parse(&format!("min(min({long}, x^2+y^2+z^2-1), z-0.5)")).unwrap();
        use Branch::{First, Second};
        let patterns = [vec![First, First], vec![Second, First]];
        let points = f.branch_points();
        let ball = match specialise(&f, &points, &patterns[1], 0) {
            Specialised::Shape(shape) => shape.instructions(),
            _ => panic!("the ball is a shape"),
        };
        // Room for the ball, not the long side: nothing is kept, with one
        // thread or three.
        assert_eq!(kept_from(&f, &patterns, ball, 1), 0);
        assert_eq!(kept_from(&f, &patterns, ball, 3), 0);
        // With room for both, both are.
        assert_eq!(kept_from(&f, &patterns, MAX_SHAPE_INSTRUCTIONS / 2, 1), 2);
    }
}
