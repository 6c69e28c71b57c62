//! Symbolic differentiation in the same graph.
//!
//! One walk, [`Context::derivative`], differentiates along a *seed*: the
//! derivative of each input variable. `∂f/∂x` is the seed `{x: 1}`; the
//! directional derivative `g = d·∇f` is the seed `{x: dx, y: dy, z: dz}`; and
//! `g′ = dᵀHd` is the same seed applied to `g`.
//!
//! Non-smooth functions get derivatives that stay valid Lipschitz information:
//! `d|u| = sign(u)·u′`, `d min(a,b) = choose(a−b, a′, b′)` and
//! `d max(a,b) = choose(a−b, b′, a′)`. Over an interval where the kink may lie,
//! `sign` is `[-1, 1]` and `choose` is the hull of both branches: exactly the
//! range of generalised (Clarke) gradients, so `|∇f|` bounds stay true. The jump
//! of such a derivative is carried into the next derivative by `dirac`, which is
//! 0 at points but `[0, ∞]` over an interval holding the kink: a ray crossing a
//! crease of `abs`, `min` or `max` gets an infinite G, which is the truth, since
//! `g` is discontinuous there.

use crate::expr::{BinaryOp, Context, Node, Op, UnaryOp, Var};

impl Context {
    /// The derivative of `root` when each input `v` changes at rate `seed[v]`
    /// (`None` means rate 0). Walks with an explicit stack and a memo.
    /// Its folds may drop operands undefined somewhere (`0*u = 0`): a
    /// derivative is read only where f is defined, and f holds every such u.
    pub fn derivative(&mut self, root: Node, seed: &[Option<Node>; 6]) -> Node {
        self.dropping_domains(|ctx| {
            let order = ctx.topological_order(&[root]);
            // By node index: the walk reads only nodes that exist now (the
            // octree build derives eleven outputs per specialised shape;
            // measured, a hash map cost each derivative a sixth more).
            let mut memo: Vec<Node> = vec![Node(u32::MAX); ctx.len()];
            for node in order {
                if ctx.exhausted() {
                    // Past the node limit the result is void anyway.
                    return Node(0);
                }
                let d = ctx.derivative_step(node, seed, &memo);
                memo[node.index()] = d;
            }
            memo[root.index()]
        })
    }

    /// `∂root/∂var`.
    pub fn partial(&mut self, root: Node, var: Var) -> Node {
        let mut seed = [None; 6];
        seed[var.index()] = Some(self.constant(1.0));
        self.derivative(root, &seed)
    }

    /// The derivative along the ray direction `(dx, dy, dz)`, whose components
    /// are the inputs [`Var::Dx`], [`Var::Dy`], [`Var::Dz`].
    pub fn directional(&mut self, root: Node) -> Node {
        let seed = [
            Some(self.var(Var::Dx)),
            Some(self.var(Var::Dy)),
            Some(self.var(Var::Dz)),
            None,
            None,
            None,
        ];
        self.derivative(root, &seed)
    }

    /// The derivative of one node, given its children's derivatives in `memo`.
    fn derivative_step(&mut self, node: Node, seed: &[Option<Node>; 6], memo: &[Node]) -> Node {
        let d = |n: Node| {
            let dn = memo[n.index()];
            debug_assert_ne!(dn, Node(u32::MAX), "a child's derivative before it");
            dn
        };
        match *self.get(node) {
            Op::Const(_) => self.constant(0.0),
            Op::Var(v) => seed[v.index()].unwrap_or_else(|| self.constant(0.0)),
            Op::Unary(op, a) => {
                let da = d(a);
                if self.const_value(da) == Some(0.0) {
                    return da;
                }
                if op == UnaryOp::Ln {
                    if let Some((_, d_log)) = self.log_of_exps(a, &d, MAX_EXP_DEPTH) {
                        return d_log;
                    }
                }
                match self.unary_derivative(op, a) {
                    Chain::Times(outer) => self.mul(outer, da),
                    Chain::Over(denominator) => self.div(da, denominator),
                }
            }
            Op::PowI(a, n) => {
                let da = d(a);
                if self.const_value(da) == Some(0.0) {
                    return da;
                }
                let p = self.powi(a, n - 1);
                let np = self.scale(f64::from(n), p);
                self.mul(np, da)
            }
            Op::Binary(op, a, b) => self.binary_derivative(op, a, b, d(a), d(b)),
            Op::Choose(c, p, n) => {
                // choose(c,p,n) = p + (n−p)·step(c): the branches' derivatives,
                // plus the jump times dirac(c)·c′.
                let branches = self.choose(c, d(p), d(n));
                let dc = d(c);
                if self.const_value(dc) == Some(0.0) {
                    return branches;
                }
                let jump = self.sub(n, p);
                let spike = self.unary(UnaryOp::Dirac, c);
                let js = self.mul(jump, spike);
                let jump_term = self.mul(js, dc);
                self.add(branches, jump_term)
            }
            Op::Remap(..) => unreachable!("{}", super::context::UNEXPANDED),
        }
    }

    /// `ln(u)` and its derivative, where `u` is a sum of exponentials (a
    /// tree of sums at most `depth` deep), else `None`: `A` for `u =
    /// exp(A)`, and for `u = p + q` the derivative of `ln(exp(ln p) +
    /// exp(ln q))` by [`Context::log_sum_exp_derivative`]. (Recursive:
    /// `depth` bounds the stack, and the calls to 2^depth where the
    /// sums share terms.)
    fn log_of_exps(
        &mut self,
        u: Node,
        d: &dyn Fn(Node) -> Node,
        depth: usize,
    ) -> Option<(Node, Node)> {
        match *self.get(u) {
            Op::Unary(UnaryOp::Exp, a) => Some((a, d(a))),
            Op::Binary(BinaryOp::Add, p, q) if depth > 0 => {
                let (lp, dp) = self.log_of_exps(p, d, depth - 1)?;
                let (lq, dq) = self.log_of_exps(q, d, depth - 1)?;
                let log = self.unary(UnaryOp::Ln, u);
                Some((log, self.log_sum_exp_derivative(lp, lq, dp, dq)))
            }
            _ => None,
        }
    }

    /// The derivative of `ln(exp(A) + exp(B))` (the exponential smooth
    /// minimum and maximum), given `A′` and `B′`: the weighted mean
    /// `σ(A−B)·A′ + σ(B−A)·B′` of the logistic function σ, written
    /// `½(A′+B′) + ½·tanh((A−B)/2)·(A′−B′)`.
    ///
    /// The same real number as the chain rule's `(exp(A)·A′ +
    /// exp(B)·B′)/(exp(A) + exp(B))`, whose enclosure over a box is the
    /// numerator's over the denominator's: where the exponents vary by w
    /// over the box it is e^w too wide, and nested blends multiply their
    /// factors (a model's gradient bound 10³–10⁶ times its true value).
    /// Here the weight is a tanh, within [−1, 1], and its derivative a
    /// sech², within [0, 1], so neither L nor G meets a quotient of
    /// exponentials.
    fn log_sum_exp_derivative(&mut self, a: Node, b: Node, da: Node, db: Node) -> Node {
        let sum = self.add(da, db);
        let half_sum = self.scale(0.5, sum);
        let diff = self.sub(da, db);
        if self.const_value(diff) == Some(0.0) {
            return half_sum;
        }
        let half_diff = self.scale(0.5, diff);
        let gap = self.sub(a, b);
        let half_gap = self.scale(0.5, gap);
        let weight = self.unary(UnaryOp::Tanh, half_gap);
        let lean = self.mul(weight, half_diff);
        self.add(half_sum, lean)
    }

    /// `dirac((floor(v) − ceil(v))·v)`: 0 at every point, `[0, ∞]` over an
    /// interval that holds an integer (the jumps of the steps). The argument
    /// is 0 exactly at the integers (`floor − ceil` is −1 between them, and
    /// the factor `v` is 0 only at the integer 0), and its enclosure holds 0
    /// exactly over intervals that hold an integer. Its derivative, `floor −
    /// ceil` between jumps, is not 0, so the spike's own derivative (the
    /// next order's) stays unbounded across a jump too.
    fn spike_at_integers(&mut self, v: Node) -> Node {
        let f = self.unary(UnaryOp::Floor, v);
        let c = self.unary(UnaryOp::Ceil, v);
        let gap = self.sub(f, c);
        let at_jump = self.mul(gap, v);
        self.unary(UnaryOp::Dirac, at_jump)
    }

    /// `op′(a)`, as the factor that multiplies `a′` in the chain rule or as
    /// the denominator that divides it (`u′/(2*sqrt(u))` reads better and
    /// folds further than `1/(2*sqrt(u))*u′`).
    fn unary_derivative(&mut self, op: UnaryOp, a: Node) -> Chain {
        use UnaryOp::*;
        match op {
            Neg => Chain::Times(self.constant(-1.0)),
            Sqrt => {
                let s = self.unary(Sqrt, a);
                Chain::Over(self.scale(2.0, s))
            }
            Abs => Chain::Times(self.unary(Sign, a)),
            Sign => {
                let spike = self.unary(Dirac, a);
                Chain::Times(self.scale(2.0, spike))
            }
            Sin => Chain::Times(self.unary(Cos, a)),
            Cos => {
                let s = self.unary(Sin, a);
                Chain::Times(self.neg(s))
            }
            // 1/cos² rather than 1+tan²: both are infinite at a pole, and this
            // one is tighter over intervals.
            Tan => {
                let c = self.unary(Cos, a);
                Chain::Over(self.powi(c, 2))
            }
            Asin | Acos => {
                let one = self.constant(1.0);
                let a2 = self.powi(a, 2);
                let r = self.sub(one, a2);
                let s = self.unary(Sqrt, r);
                Chain::Over(if op == Asin { s } else { self.neg(s) })
            }
            Atan => {
                let one = self.constant(1.0);
                let a2 = self.powi(a, 2);
                Chain::Over(self.add(a2, one))
            }
            Exp => Chain::Times(self.unary(Exp, a)),
            Ln => Chain::Over(a),
            Sinh => Chain::Times(self.unary(Cosh, a)),
            Cosh => Chain::Times(self.unary(Sinh, a)),
            // tanh′ = sech², and sech′ = −tanh·sech: both stay finite where
            // cosh overflows, unlike 1/cosh² whose derivative is ∞/∞ there.
            Tanh => {
                let s = self.unary(Sech, a);
                Chain::Times(self.powi(s, 2))
            }
            Sech => {
                let t = self.unary(Tanh, a);
                let s = self.unary(Sech, a);
                let ts = self.mul(t, s);
                Chain::Times(self.neg(ts))
            }
            // Only third derivatives meet dirac′; like dirac it is 0 at points and
            // unbounded over an interval holding 0, which is all a bound needs.
            Dirac => Chain::Times(self.unary(Dirac, a)),
            // 0 between the jumps, a spike at each (see `spike_at_integers`);
            // `v` is `u` for floor and ceil, `u + ½` for round, whose jumps
            // are at the halves.
            Floor | Ceil => Chain::Times(self.spike_at_integers(a)),
            Round => {
                let half = self.constant(0.5);
                let shifted = self.add(a, half);
                Chain::Times(self.spike_at_integers(shifted))
            }
        }
    }

    fn binary_derivative(&mut self, op: BinaryOp, a: Node, b: Node, da: Node, db: Node) -> Node {
        use BinaryOp::*;
        let zero_a = self.const_value(da) == Some(0.0);
        let zero_b = self.const_value(db) == Some(0.0);
        if zero_a && zero_b {
            return self.constant(0.0);
        }
        match op {
            Add => self.add(da, db),
            Sub => self.sub(da, db),
            Mul => {
                let l = self.mul(da, b);
                let r = self.mul(a, db);
                self.add(l, r)
            }
            Div => {
                // (a′·b − a·b′)/b², written so that a constant numerator or
                // denominator leaves no dead terms.
                if zero_b {
                    return self.div(da, b);
                }
                let b2 = self.powi(b, 2);
                let adb = self.mul(a, db);
                if zero_a {
                    let q = self.div(adb, b2);
                    return self.neg(q);
                }
                let dab = self.mul(da, b);
                let num = self.sub(dab, adb);
                self.div(num, b2)
            }
            Min | Max => {
                let c = self.sub(a, b);
                if op == Min {
                    self.choose(c, da, db)
                } else {
                    self.choose(c, db, da)
                }
            }
            Atan2 => {
                // atan2(y, x): (x·y′ − y·x′)/(x² + y²)
                let (y, x, dy, dx) = (a, b, da, db);
                let xdy = self.mul(x, dy);
                let ydx = self.mul(y, dx);
                let num = self.sub(xdy, ydx);
                let x2 = self.powi(x, 2);
                let y2 = self.powi(y, 2);
                let den = self.add(x2, y2);
                self.div(num, den)
            }
            Pow => {
                let p = self.binary(Pow, a, b);
                if zero_b {
                    // c·a^(c−1)·a′ for a constant exponent.
                    let one = self.constant(1.0);
                    let bm1 = self.sub(b, one);
                    let q = self.pow(a, bm1);
                    let bq = self.mul(b, q);
                    return self.mul(bq, da);
                }
                // a^b·(b′·ln a + b·a′/a)
                let ln_a = self.unary(UnaryOp::Ln, a);
                let t1 = self.mul(db, ln_a);
                let sum = if zero_a {
                    t1
                } else {
                    let bda = self.mul(b, da);
                    let t2 = self.div(bda, a);
                    self.add(t1, t2)
                };
                self.mul(p, sum)
            }
        }
    }
}

/// The deepest tree of sums of exponentials under `ln` whose derivative is
/// written as a weighted mean ([`Context::log_sum_exp_derivative`]); deeper
/// ones take the chain rule's quotient.
const MAX_EXP_DEPTH: usize = 8;

/// How the outer derivative enters the chain rule.
enum Chain {
    /// `op′(a) = factor`: the derivative is `factor * a′`.
    Times(Node),
    /// `op′(a) = 1/denominator`: the derivative is `a′ / denominator`.
    Over(Node),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivative_of_a_square_is_twice_the_variable() {
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let f = ctx.powi(x, 2);
        let df = ctx.partial(f, Var::X);
        let two_x = ctx.scale(2.0, x);
        assert_eq!(df, two_x);
        let dfdy = ctx.partial(f, Var::Y);
        assert_eq!(ctx.const_value(dfdy), Some(0.0));
    }

    #[test]
    fn directional_derivative_of_a_linear_function_is_the_dot_product() {
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let y = ctx.var(Var::Y);
        let three_y = ctx.scale(3.0, y);
        let f = ctx.add(x, three_y);
        let g = ctx.directional(f);
        let inputs = [0.3, -1.0, 2.0, 0.5, 0.25, 7.0];
        assert_eq!(ctx.eval(g, &inputs), 0.5 + 3.0 * 0.25);
        let dg = ctx.directional(g);
        assert_eq!(ctx.const_value(dg), Some(0.0));
    }
}
