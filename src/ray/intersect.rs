//! Guaranteed ray intersection (Kalra–Barr §6.2).
//!
//! Leaves of the [`Octree`] that a ray crosses are visited nearest first. On
//! each leaf's segment `[t1, t2]`, with `tₘ` its middle and `h` its half
//! length, F(t) = f(o + t·d) and g(t) = F′(t):
//!
//! * **L-test** — if `|F(tₘ)| > L·|d|·h` the segment holds no root (F is
//!   `L|d|`-Lipschitz in t);
//! * **G-test** — if `|g(tₘ)| > G·h`, g keeps its sign, F is monotone, and the
//!   segment holds exactly one root when F(t1), F(t2) differ in sign (refined by
//!   safeguarded Newton, which never leaves its bracket) and none otherwise;
//! * otherwise the segment is halved, nearer half first.
//!
//! G comes from the leaf's interval Hessian: `|dᵀ[H]d|`. Where a leaf's L or
//! G is unbounded, or f is undefined somewhere in it, an interval of F over the
//! segment decides instead of the two tests. A segment that reaches the
//! tolerance unresolved counts as a hit: a grazing ray touches.

use super::octree::{Leaf, NodeId, Octree, OctreeStats};
use crate::expr::{Evaluator, Tape};
use crate::formula::{Formula, Output};
use crate::types::Interval;
use crate::types::{Aabb, Segment};
use glam::DVec3;

/// Segment halvings a single ray may spend before it is counted as a hit.
const MAX_STEPS_PER_RAY: u32 = 200_000;

/// A surface compiled for ray queries: its octree and tapes.
#[derive(Debug, Clone)]
pub struct Intersector {
    octree: Octree,
    f: Tape,
    fg: Tape,
    grad: Tape,
    /// Distance below which a segment is not split further.
    tolerance: f64,
}

/// Work done answering rays, for the summary line and benchmarks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayStats {
    /// Rays answered.
    pub rays: u64,
    /// Point evaluations of f (and g).
    pub f_evals: u64,
    /// Interval evaluations of f over a segment.
    pub interval_evals: u64,
    /// Leaves visited.
    pub leaves: u64,
}

impl RayStats {
    /// The work done since `earlier`, a snapshot of the same tally.
    pub fn since(&self, earlier: &RayStats) -> RayStats {
        RayStats {
            rays: self.rays - earlier.rays,
            f_evals: self.f_evals - earlier.f_evals,
            interval_evals: self.interval_evals - earlier.interval_evals,
            leaves: self.leaves - earlier.leaves,
        }
    }

    /// Adds another tally to this one.
    pub fn add(&mut self, other: &RayStats) {
        self.rays += other.rays;
        self.f_evals += other.f_evals;
        self.interval_evals += other.interval_evals;
        self.leaves += other.leaves;
    }
}

impl Intersector {
    /// Prunes `bounds` to `depth` and compiles the tapes rays need.
    pub fn new(formula: &Formula, bounds: &Aabb, depth: u32) -> Intersector {
        Intersector {
            octree: Octree::build(formula, bounds, depth),
            f: formula.tape(&[Output::F]),
            fg: formula.tape(&[Output::F, Output::G]),
            grad: formula.tape(&[Output::Dfdx, Output::Dfdy, Output::Dfdz]),
            tolerance: 1e-10 * (bounds.hi - bounds.lo).length(),
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

    /// The bounding box.
    pub fn bounds(&self) -> Aabb {
        self.octree.bounds
    }

    /// Per-thread state for answering rays.
    pub fn tracer(&self) -> Tracer<'_> {
        Tracer {
            scene: self,
            f: Evaluator::new(&self.f),
            fg: Evaluator::new(&self.fg),
            fi: Evaluator::new(&self.f),
            grad: Evaluator::new(&self.grad),
            stats: RayStats::default(),
            stack: Vec::new(),
            segments: Vec::new(),
            last: (f64::NAN, f64::NAN),
            hit_leaf: (f64::INFINITY, 0.0),
        }
    }
}

/// Answers rays against one [`Intersector`]; one per thread.
pub struct Tracer<'s> {
    scene: &'s Intersector,
    f: Evaluator<'s, f64>,
    fg: Evaluator<'s, f64>,
    fi: Evaluator<'s, Interval>,
    grad: Evaluator<'s, f64>,
    /// Work done so far.
    pub stats: RayStats,
    stack: Vec<(NodeId, f64, f64)>,
    segments: Vec<Piece>,
    /// F at the last leaf exit of the current ray: usually the next entry.
    last: (f64, f64),
    /// L and size of the leaf where the last hit was found, for normals.
    hit_leaf: (f64, f64),
}

/// A piece of a ray inside one leaf, with F at its ends.
#[derive(Clone, Copy)]
struct Piece {
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
}

/// The parameter range in which the ray `o + t·d` is inside the closed box
/// `b` (empty, `near > far`, when it misses).
#[inline]
fn slab(b: &Aabb, o: DVec3, d: DVec3, inv_d: DVec3) -> (f64, f64) {
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

/// True when `a` and `b` have opposite signs or either is 0.
#[inline]
fn brackets(a: f64, b: f64) -> bool {
    (a <= 0.0 && b >= 0.0) || (a >= 0.0 && b <= 0.0)
}

impl Tracer<'_> {
    #[inline]
    fn f_at(&mut self, o: DVec3, d: DVec3, t: f64) -> f64 {
        self.stats.f_evals += 1;
        let p = o + t * d;
        self.f.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0]
    }

    #[inline]
    fn fg_at(&mut self, o: DVec3, d: DVec3, t: f64) -> (f64, f64) {
        self.stats.f_evals += 1;
        let p = o + t * d;
        let v = self.fg.eval(&[p.x, p.y, p.z, d.x, d.y, d.z]);
        (v[0], v[1])
    }

    /// The interval of F over `[a, b]`.
    fn f_over(&mut self, o: DVec3, d: DVec3, a: f64, b: f64) -> Interval {
        self.stats.interval_evals += 1;
        let s = Segment {
            origin: o,
            direction: d,
            t0: a,
            t1: b,
        };
        self.fi.eval(&s.inputs())[0]
    }

    /// The smallest `t` in `[t_min, t_max]` where the ray `o + t·d` meets the
    /// surface inside the box, or `None`. `d` need not be normalised.
    pub fn first_hit(&mut self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        self.stats.rays += 1;
        if d == DVec3::ZERO || !o.is_finite() || !d.is_finite() {
            return None;
        }
        let scene = self.scene;
        let inv_d = d.recip();
        let root = &scene.octree.nodes[0];
        let (near, far) = slab(&root.bounds, o, d, inv_d);
        let (near, far) = (near.max(t_min), far.min(t_max));
        if near > far {
            return None;
        }
        let mut budget = MAX_STEPS_PER_RAY;
        self.last = (f64::NAN, f64::NAN);
        self.stack.clear();
        self.stack.push((0, near, far));
        while let Some((id, t0, t1)) = self.stack.pop() {
            let node = &scene.octree.nodes[id as usize];
            if let Some(leaf) = &node.leaf {
                self.stats.leaves += 1;
                if let Some(t) = self.in_leaf(leaf, o, d, t0, t1, &mut budget) {
                    self.hit_leaf = (leaf.lipschitz, (node.bounds.hi - node.bounds.lo).length());
                    return Some(t);
                }
                continue;
            }
            let Some(first) = node.first_child else {
                continue;
            };
            // The children the ray crosses, in order, come from the times at
            // which it crosses the three mid-planes (Revelles et al. 2000):
            // each crossing flips one octant bit. No box tests, no sorting.
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
            cross.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
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
            for &(k, a, b) in pieces[..n].iter().rev() {
                let child = first + k as NodeId;
                if scene.octree.nodes[child as usize].alive {
                    self.stack.push((child, a, b));
                }
            }
        }
        None
    }

    /// The first root on `[t0, t1]` inside one leaf.
    fn in_leaf(
        &mut self,
        leaf: &Leaf,
        o: DVec3,
        d: DVec3,
        t0: f64,
        t1: f64,
        budget: &mut u32,
    ) -> Option<f64> {
        let speed = d.length();
        let lt = leaf.lipschitz * speed * (1.0 + 1e-9);
        let g_bound = leaf.grad_lipschitz(d) * (1.0 + 1e-9);
        let exact_tests = !leaf.needs_intervals && lt.is_finite();
        let tol = self.scene.tolerance / speed;
        let fa = if self.last.0 == t0 {
            self.last.1
        } else {
            self.f_at(o, d, t0)
        };
        let fb = self.f_at(o, d, t1);
        self.last = (t1, fb);
        self.segments.clear();
        self.segments.push(Piece {
            a: t0,
            b: t1,
            fa,
            fb,
        });
        while let Some(Piece { a, b, fa, fb }) = self.segments.pop() {
            if fa == 0.0 {
                return Some(a);
            }
            let h = 0.5 * (b - a);
            let m = a + h;
            if *budget == 0 {
                return Some(m); // undecidable within the budget: never a miss
            }
            *budget -= 1;
            let (fm, gm) = self.fg_at(o, d, m);
            if exact_tests && !fm.is_nan() {
                if fm.abs() > lt * h {
                    continue; // L-test: no root here
                }
                if g_bound.is_finite() && gm.abs() > g_bound * h {
                    // G-test: F is monotone on [a, b].
                    if brackets(fa, fb) {
                        return Some(self.newton(o, d, a, b, fa, fb));
                    }
                    continue;
                }
            } else {
                let span = self.f_over(o, d, a, b);
                if span.is_empty() || !span.contains(0.0) {
                    continue; // interval test: no root here
                }
            }
            if h <= tol {
                // Unresolved at the tolerance: a sign change is a root, and a
                // touch that no test could exclude counts as a hit.
                if brackets(fa, fm) {
                    return Some(self.newton(o, d, a, m, fa, fm));
                }
                if brackets(fm, fb) {
                    return Some(self.newton(o, d, m, b, fm, fb));
                }
                return Some(m);
            }
            self.segments.push(Piece {
                a: m,
                b,
                fa: fm,
                fb,
            });
            self.segments.push(Piece {
                a,
                b: m,
                fa,
                fb: fm,
            });
        }
        None
    }

    /// The root in `[a, b]`, where F changes sign, by Newton's method kept
    /// inside its bracket (bisection whenever a step would leave it).
    fn newton(&mut self, o: DVec3, d: DVec3, mut a: f64, mut b: f64, mut fa: f64, fb: f64) -> f64 {
        if fa == 0.0 {
            return a;
        }
        if fb == 0.0 {
            return b;
        }
        let mut x = a - fa * (b - a) / (fb - fa);
        if !(x > a && x < b) {
            x = 0.5 * (a + b);
        }
        for _ in 0..200 {
            let (fx, gx) = self.fg_at(o, d, x);
            if fx == 0.0 || fx.is_nan() {
                return x;
            }
            if (fx < 0.0) == (fa < 0.0) {
                a = x;
                fa = fx;
            } else {
                b = x;
            }
            let newton = x - fx / gx;
            let next = if newton > a && newton < b {
                newton
            } else {
                0.5 * (a + b)
            };
            if (next - x).abs() <= 2.0 * f64::EPSILON * x.abs().max(f64::MIN_POSITIVE)
                || b - a <= 4.0 * f64::EPSILON * a.abs().max(b.abs())
            {
                return next;
            }
            x = next;
        }
        x
    }

    /// The unit surface normal at `p`, the last hit: the normalised gradient.
    /// Where the gradient is below a millionth of the hit leaf's L (singular
    /// curves such as the heart's rim, where it is only rounding noise), the
    /// direction in which f grows across a small neighbourhood (central
    /// differences at a thousandth of the leaf) stands in; `None` if that
    /// vanishes too.
    pub fn normal(&mut self, p: DVec3) -> Option<DVec3> {
        let g = self.grad.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
        let n = DVec3::new(g[0], g[1], g[2]);
        let (l, size) = self.hit_leaf;
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
        let mut f = |q: DVec3| self.f.eval(&[q.x, q.y, q.z, 0.0, 0.0, 0.0])[0];
        let diff = |f: &mut dyn FnMut(DVec3) -> f64, axis: DVec3| f(p + h * axis) - f(p - h * axis);
        let m = DVec3::new(
            diff(&mut f, DVec3::X),
            diff(&mut f, DVec3::Y),
            diff(&mut f, DVec3::Z),
        );
        m.try_normalize().or_else(|| n.try_normalize())
    }
}
