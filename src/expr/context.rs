//! The hash-consed expression graph: an arena of [`Op`]s addressed by [`Node`].
//!
//! Every builder method looks its operation up before storing it, so an identical
//! subexpression is stored once, and folds constants and identities as it builds
//! (`x+0`, `x*1`, `0*x`, `x^1`, `x^0`, `--x`, `x*x = x^2`, …), which keeps
//! symbolic derivatives small. The folds are exact: a rewrite never replaces a
//! value by a rounded approximation of it. `2*3` folds to `6`, but `0.1*3`,
//! `sin(1)` and `pi/3` stay symbolic, because their f64 results are not the
//! real numbers the formula means and a sound interval must enclose the latter.

use super::op::{choose, powi, BinaryOp, Constant, Node, Op, UnaryOp, Var};
use crate::types::rounding::TINY;
use rustc_hash::FxHashMap;
use std::fmt;

/// `x + y` when the f64 sum is exact (the TwoSum error term is zero).
fn exact_sum(x: f64, y: f64) -> Option<f64> {
    let s = x + y;
    let yy = s - x;
    let err = (x - (s - yy)) + (y - yy);
    (s.is_finite() && err == 0.0).then_some(s)
}

/// `op(x, y)` when its f64 result is exactly the real result, else `None`.
fn exact_binary(op: BinaryOp, x: f64, y: f64) -> Option<f64> {
    use BinaryOp::*;
    let r = op.eval(x, y);
    if !r.is_finite() {
        return None;
    }
    // The fused residual is exact only while it cannot underflow, which
    // `TINY` (far above the subnormals, by more than 2^106) ensures for every
    // value it is a residual of. A product or quotient of non-zero numbers
    // that rounds to 0 is never exact.
    let clear_of_underflow = |v: f64| v.abs() >= TINY;
    match op {
        Add => exact_sum(x, y),
        Sub => exact_sum(x, -y),
        Mul if x == 0.0 || y == 0.0 => Some(r),
        Mul if clear_of_underflow(r) => (x.mul_add(y, -r) == 0.0).then_some(r),
        // Tiny products are checked at a scale where the residual is exact.
        Mul => {
            let scale = 2f64.powi(600);
            let (xs, rs) = (x * scale, r * scale);
            (xs / scale == x
                && clear_of_underflow(rs)
                && rs / scale == r
                && xs.mul_add(y, -rs) == 0.0)
                .then_some(r)
        }
        Div => (y != 0.0
            && (x == 0.0
                || (clear_of_underflow(r) && clear_of_underflow(x) && r.mul_add(y, -x) == 0.0)))
            .then_some(r),
        Min | Max => Some(r),
        Atan2 | Pow => None,
    }
}

/// `op(x)` when its f64 result is exactly the real result, else `None`.
fn exact_unary(op: UnaryOp, x: f64) -> Option<f64> {
    use UnaryOp::*;
    let r = op.eval(x);
    if !r.is_finite() {
        return None;
    }
    let exact = match op {
        Neg | Abs | Sign | Floor | Ceil | Round => true,
        Sqrt => r.mul_add(r, -x) == 0.0,
        Sin | Tan | Asin | Atan | Sinh | Tanh | Cos | Cosh | Sech | Exp => x == 0.0,
        Ln => x == 1.0,
        Acos => x == 1.0,
        // dirac(0) is a spike, not a number: keep it symbolic.
        Dirac => x != 0.0,
    };
    exact.then_some(r)
}

/// `x^n` when exact: integer bases with results below 2^53, or powers of two.
fn exact_powi(x: f64, n: i32) -> Option<f64> {
    let r = x.powi(n);
    if !r.is_finite() || (r != 0.0 && r.abs() < f64::MIN_POSITIVE) {
        return None;
    }
    let integer = n >= 0 && x == x.trunc() && r.abs() <= 9_007_199_254_740_992.0;
    (integer || (is_power_of_two(x.abs()) && r != 0.0)).then_some(r)
}

/// Whether a constant factor may move outward past other factors, as in
/// `x*(c*y) = c*(x*y)`. The product left inside is larger or smaller than
/// before by |c|, so f64 may overflow or underflow there where the formula
/// as written does not: only factors within 2^±32 of 1 move. (Coordinates
/// scaled by `1e-200` stay scaled: `(x*1e-200)*(x*1e-200)` is `(1e-200*x)^2`,
/// not `1e-200*(1e-200*x^2)`, whose `x^2` overflows for x beyond 1e154.)
fn moves_outward(c: f64) -> bool {
    const RANGE: f64 = 4_294_967_296.0; // 2^32
    (1.0 / RANGE..=RANGE).contains(&c.abs())
}

fn is_power_of_two(v: f64) -> bool {
    v.is_normal() && v > 0.0 && (v.to_bits() & ((1u64 << 52) - 1)) == 0
}

/// Largest integer exponent kept as `PowI` when written as `a^c`.
const MAX_INT_POWER: f64 = 1024.0;

/// The most nodes one [`Context`] holds: some 500 MB, a hundred times what
/// the largest real model and its derivatives take. A graph that would pass
/// it is refused with an error rather than exhausting memory.
pub const MAX_NODES: usize = 1 << 23;

/// A graph that would pass its context's node limit (see [`MAX_NODES`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the expression graph would pass {limit} nodes")]
pub struct GraphTooLarge {
    /// The limit it would pass.
    pub limit: usize,
}

/// Arena of hash-consed expression nodes.
#[derive(Clone)]
pub struct Context {
    ops: Vec<Op>,
    index: FxHashMap<Op, Node>,
    /// The change of coordinates of each [`Op::Remap`], relative to the
    /// coordinates where the remap is used.
    pub(super) remaps: Vec<AffineMap>,
    /// Frames met by [`Context::expand`], interned: each an affine map from
    /// world coordinates, with its three coordinate nodes.
    pub(super) frames: Vec<(AffineMap, [Node; 3])>,
    pub(super) frame_ids: FxHashMap<AffineMap, u32>,
    /// What `expand` built, by node and frame, kept across calls so that a
    /// shape used by many formulas is expanded once per frame.
    pub(super) expanded: FxHashMap<(Node, u32), Node>,
    /// Per node: defined for every real input (see [`Context::is_total`]).
    total: Vec<bool>,
    /// While true, folds may drop an operand that is undefined somewhere
    /// (`0*u = 0` for any u). Only derivatives are built so: they are read
    /// only where f, which holds every such operand, is defined.
    folds_drop_domains: bool,
    /// The most nodes this context stores.
    pub(super) node_limit: usize,
    /// Set once a build would have passed `node_limit`. From then on every
    /// new operation yields node 0 in its place, so builders need no error
    /// path of their own; whatever reads a built graph checks
    /// [`Context::check_size`] first, so a graph built past the limit is
    /// never used.
    pub(super) exhausted: bool,
}

impl Default for Context {
    fn default() -> Self {
        Context {
            ops: Vec::new(),
            index: FxHashMap::default(),
            remaps: Vec::new(),
            frames: Vec::new(),
            frame_ids: FxHashMap::default(),
            expanded: FxHashMap::default(),
            total: Vec::new(),
            folds_drop_domains: false,
            node_limit: MAX_NODES,
            exhausted: false,
        }
    }
}

pub(crate) use super::remap::{AffineMap, UNEXPANDED};

impl fmt::Debug for Context {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Context({} nodes)", self.ops.len())
    }
}

impl Context {
    /// An empty context.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty context with room for `nodes` nodes: a copy of a graph
    /// (a specialised shape, of thousands of nodes) then interns without
    /// regrowing its table.
    pub fn with_capacity(nodes: usize) -> Self {
        let mut ctx = Self::default();
        ctx.ops.reserve(nodes);
        ctx.index.reserve(nodes);
        ctx.total.reserve(nodes);
        ctx
    }

    /// An empty context that stores at most `nodes` nodes (at least one).
    pub fn with_limit(nodes: usize) -> Self {
        Context {
            node_limit: nodes.max(1),
            ..Self::default()
        }
    }

    /// `Err` once a build has passed the node limit: the graphs built since
    /// are not the functions asked for, and must not be used.
    pub fn check_size(&self) -> Result<(), GraphTooLarge> {
        match self.exhausted {
            true => Err(GraphTooLarge {
                limit: self.node_limit,
            }),
            false => Ok(()),
        }
    }

    /// Whether a build has passed the node limit.
    pub(crate) fn exhausted(&self) -> bool {
        self.exhausted
    }

    /// Number of distinct nodes stored.
    pub fn len(&self) -> usize {
        self.ops.len()
    }

    /// True when nothing has been built.
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// The operation behind `node`.
    pub fn get(&self, node: Node) -> &Op {
        &self.ops[node.index()]
    }

    /// The value of `node` if it is a constant.
    pub fn const_value(&self, node: Node) -> Option<f64> {
        match self.get(node) {
            Op::Const(c) => Some(c.0),
            _ => None,
        }
    }

    fn is_const(&self, node: Node, value: f64) -> bool {
        self.const_value(node) == Some(value)
    }

    /// Whether `node` is a real number for every real input: built from
    /// constants and variables by operations defined everywhere (`+ − ×`,
    /// whole powers, `min max abs sign choose`, `sin cos atan exp` and the
    /// hyperbolic functions). `sqrt`, `ln`, division, negative and real
    /// powers, `tan`, `asin`, `acos` and `atan2` are not.
    pub fn is_total(&self, node: Node) -> bool {
        self.total[node.index()]
    }

    /// Whether a fold may drop `node`: it is defined everywhere, or the
    /// graph being built is a derivative.
    fn may_drop(&self, node: Node) -> bool {
        self.folds_drop_domains || self.is_total(node)
    }

    /// Runs `build` with folds that may drop undefined operands, for
    /// derivatives (see [`Context::folds_drop_domains`]).
    pub(crate) fn dropping_domains<T>(&mut self, build: impl FnOnce(&mut Context) -> T) -> T {
        let was = std::mem::replace(&mut self.folds_drop_domains, true);
        let out = build(self);
        self.folds_drop_domains = was;
        out
    }

    fn op_is_total(&self, op: &Op) -> bool {
        use UnaryOp::*;
        let t = |n: Node| self.total[n.index()];
        match *op {
            Op::Const(c) => c.0.is_finite(),
            Op::Var(_) => true,
            Op::Unary(
                Neg | Abs | Sign | Sin | Cos | Atan | Exp | Sinh | Cosh | Tanh | Sech | Dirac
                | Floor | Ceil | Round,
                a,
            ) => t(a),
            // No catch-all: a new function must be placed in one list or the other.
            Op::Unary(Sqrt | Ln | Tan | Asin | Acos, _) => false,
            Op::Binary(BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul, a, b)
            | Op::Binary(BinaryOp::Min | BinaryOp::Max, a, b) => t(a) && t(b),
            Op::Binary(BinaryOp::Div | BinaryOp::Pow | BinaryOp::Atan2, _, _) => false,
            Op::PowI(a, n) => n >= 0 && t(a),
            Op::Choose(c, p, n) => t(c) && t(p) && t(n),
            Op::Remap(..) => false,
        }
    }

    /// Stores `op` unless an identical operation exists; returns its node.
    pub(super) fn intern(&mut self, op: Op) -> Node {
        if let Some(&node) = self.index.get(&op) {
            return node;
        }
        if self.ops.len() >= self.node_limit {
            // Node 0 is a leaf (its operands would precede it), so any walk
            // of the stand-in ends at once.
            self.exhausted = true;
            return Node(0);
        }
        let node = Node(u32::try_from(self.ops.len()).expect("MAX_NODES is below 2^32"));
        let total = self.op_is_total(&op);
        self.total.push(total);
        self.ops.push(op);
        self.index.insert(op, node);
        node
    }

    /// A constant node. Non-finite values are not constants of the language:
    /// callers only fold when the result is finite.
    pub fn constant(&mut self, value: f64) -> Node {
        debug_assert!(value.is_finite(), "constant {value} is not finite");
        // +0 and -0 are one constant: no fold depends on the sign of zero.
        let value = if value == 0.0 { 0.0 } else { value };
        self.intern(Op::Const(Constant(value)))
    }

    /// An input variable.
    pub fn var(&mut self, var: Var) -> Node {
        self.intern(Op::Var(var))
    }

    /// `-a`.
    pub fn neg(&mut self, a: Node) -> Node {
        self.unary(UnaryOp::Neg, a)
    }

    /// `a + b`.
    pub fn add(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinaryOp::Add, a, b)
    }

    /// `a - b`.
    pub fn sub(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinaryOp::Sub, a, b)
    }

    /// `a * b`.
    pub fn mul(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinaryOp::Mul, a, b)
    }

    /// `a / b`.
    pub fn div(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinaryOp::Div, a, b)
    }

    /// `mod(a, b) = a − b·floor(a/b)`: the remainder with the sign of `b`
    /// (fidget's modulo), in the operations the graph already has.
    pub fn modulo(&mut self, a: Node, b: Node) -> Node {
        let q = self.div(a, b);
        let k = self.unary(UnaryOp::Floor, q);
        let bk = self.mul(b, k);
        self.sub(a, bk)
    }

    /// `c * a` for a constant `c`.
    pub fn scale(&mut self, c: f64, a: Node) -> Node {
        let c = self.constant(c);
        self.mul(c, a)
    }

    /// `a^n` for an integer `n`.
    pub fn powi(&mut self, a: Node, n: i32) -> Node {
        match n {
            // a^0 is 1 where a is defined: 0*a + 1 keeps where it is not.
            0 if !self.may_drop(a) => {
                let (zero, one) = (self.constant(0.0), self.constant(1.0));
                let z = self.mul(zero, a);
                return self.add(z, one);
            }
            0 => return self.constant(1.0),
            1 => return a,
            _ => {}
        }
        match *self.get(a) {
            Op::Const(c) => {
                if let Some(v) = exact_powi(c.0, n) {
                    return self.constant(v);
                }
            }
            // (u^m)^n = u^(mn), except that (u^-1)^-1 would define u at 0.
            Op::PowI(base, m) if m > 0 || n > 0 || self.folds_drop_domains => {
                if let Some(mn) = m.checked_mul(n) {
                    return self.powi(base, mn);
                }
            }
            Op::Unary(UnaryOp::Neg, inner) => {
                let p = self.powi(inner, n);
                return if n % 2 == 0 { p } else { self.neg(p) };
            }
            Op::Unary(UnaryOp::Abs, inner) if n % 2 == 0 => return self.powi(inner, n),
            _ => {}
        }
        self.intern(Op::PowI(a, n))
    }

    /// `a^b`: an integer constant exponent becomes [`Context::powi`], `e^b`
    /// becomes `exp(b)` and `a^0.5` becomes `sqrt(a)`.
    pub fn pow(&mut self, a: Node, b: Node) -> Node {
        if let Some(c) = self.const_value(b) {
            if c == c.trunc() && c.abs() <= MAX_INT_POWER {
                return self.powi(a, c as i32);
            }
            if c == 0.5 {
                return self.unary(UnaryOp::Sqrt, a);
            }
        }
        if self.const_value(a) == Some(std::f64::consts::E) {
            return self.unary(UnaryOp::Exp, b);
        }
        self.binary(BinaryOp::Pow, a, b)
    }

    /// `choose(c, p, n)`: `p` where `c < 0`, `n` where `c > 0`.
    pub fn choose(&mut self, c: Node, p: Node, n: Node) -> Node {
        if p == n && self.may_drop(c) {
            return p;
        }
        if let Some(cv) = self.const_value(c) {
            if cv < 0.0 {
                return p;
            }
            if cv > 0.0 {
                return n;
            }
        }
        self.intern(Op::Choose(c, p, n))
    }

    /// A function of one argument, folded where possible.
    pub fn unary(&mut self, op: UnaryOp, a: Node) -> Node {
        use UnaryOp::*;
        if let Some(v) = self.const_value(a) {
            if let Some(r) = exact_unary(op, v) {
                return self.constant(r);
            }
        }
        match (op, *self.get(a)) {
            (Neg, Op::Unary(Neg, inner)) => return inner,
            (Neg, Op::Binary(BinaryOp::Sub, p, q)) => return self.sub(q, p),
            (Neg, Op::Binary(BinaryOp::Mul, p, q)) if self.const_value(p).is_some() => {
                let c = self.const_value(p).unwrap_or_default();
                return self.scale(-c, q);
            }
            (Abs, Op::Unary(Neg | Abs, inner)) => return self.unary(Abs, inner),
            (Abs, Op::PowI(_, n)) if n % 2 == 0 => return a,
            (Abs, Op::Unary(Exp | Sqrt | Cosh, _)) => return a,
            (Sqrt, Op::PowI(inner, 2)) => return self.unary(Abs, inner),
            (Sign, Op::Unary(Sign, _)) => return a,
            (Cos | Cosh | Sech, Op::Unary(Neg, inner)) => return self.unary(op, inner),
            _ => {}
        }
        self.intern(Op::Unary(op, a))
    }

    /// A function of two arguments, folded where possible.
    pub fn binary(&mut self, op: BinaryOp, a: Node, b: Node) -> Node {
        use BinaryOp::*;
        if let (Some(x), Some(y)) = (self.const_value(a), self.const_value(b)) {
            if let Some(r) = exact_binary(op, x, y) {
                return self.constant(r);
            }
        }
        // Constants lead products (`2*x`) and trail sums (`x+1`); other
        // operands keep the order they were written in, which reads best.
        let swap = match op {
            Mul => self.const_value(b).is_some() && self.const_value(a).is_none(),
            Add => self.const_value(a).is_some() && self.const_value(b).is_none(),
            _ => false,
        };
        let (a, b) = if swap { (b, a) } else { (a, b) };
        match op {
            Add => self.fold_add(a, b),
            Sub => self.fold_sub(a, b),
            Mul => self.fold_mul(a, b),
            Div => self.fold_div(a, b),
            Min | Max if a == b => a,
            Min | Max | Atan2 | Pow => self.intern(Op::Binary(op, a, b)),
        }
    }

    /// `(c, q)` when `node` is `c*q` with a constant `c`.
    fn constant_multiple(&self, node: Node) -> Option<(f64, Node)> {
        match *self.get(node) {
            Op::Binary(BinaryOp::Mul, p, q) => self.const_value(p).map(|c| (c, q)),
            _ => None,
        }
    }

    fn negated(&self, node: Node) -> Option<Node> {
        match *self.get(node) {
            Op::Unary(UnaryOp::Neg, inner) => Some(inner),
            _ => None,
        }
    }

    /// `(c, q)` when `node` is `c*q` with a negative constant `c`.
    fn negative_multiple(&self, node: Node) -> Option<(f64, Node)> {
        match *self.get(node) {
            Op::Binary(BinaryOp::Mul, p, q) => {
                self.const_value(p).filter(|&c| c < 0.0).map(|c| (c, q))
            }
            _ => None,
        }
    }

    fn fold_add(&mut self, a: Node, b: Node) -> Node {
        if self.is_const(b, 0.0) {
            return a;
        }
        if a == b {
            return self.scale(2.0, a);
        }
        if let Some(c) = self.const_value(b) {
            if c < 0.0 {
                let m = self.constant(-c);
                return self.sub(a, m);
            }
        }
        if let Some(nb) = self.negated(b) {
            return self.sub(a, nb);
        }
        if let Some(na) = self.negated(a) {
            return self.sub(b, na);
        }
        if let Some((c, q)) = self.negative_multiple(b) {
            let m = self.scale(-c, q);
            return self.sub(a, m);
        }
        self.intern(Op::Binary(BinaryOp::Add, a, b))
    }

    fn fold_sub(&mut self, a: Node, b: Node) -> Node {
        if self.is_const(b, 0.0) {
            return a;
        }
        if self.is_const(a, 0.0) {
            return self.neg(b);
        }
        if a == b && self.may_drop(a) {
            return self.constant(0.0);
        }
        if let Some(c) = self.const_value(b) {
            if c < 0.0 {
                let m = self.constant(-c);
                return self.add(a, m);
            }
        }
        if let Some(nb) = self.negated(b) {
            return self.add(a, nb);
        }
        if let Some(na) = self.negated(a) {
            let s = self.add(na, b);
            return self.neg(s);
        }
        if let Some((c, q)) = self.negative_multiple(b) {
            let m = self.scale(-c, q);
            return self.add(a, m);
        }
        self.intern(Op::Binary(BinaryOp::Sub, a, b))
    }

    fn fold_mul(&mut self, a: Node, b: Node) -> Node {
        if let Some(c) = self.const_value(a) {
            if c == 0.0 && self.may_drop(b) {
                return a;
            }
            if c == 1.0 {
                return b;
            }
            if c == -1.0 {
                return self.neg(b);
            }
            match *self.get(b) {
                // c1*(c2*x) = (c1*c2)*x only when c1*c2 is exact.
                Op::Binary(BinaryOp::Mul, p, q) => {
                    if let Some(cd) = self
                        .const_value(p)
                        .and_then(|d| exact_binary(BinaryOp::Mul, c, d))
                    {
                        return self.scale(cd, q);
                    }
                }
                Op::Unary(UnaryOp::Neg, inner) => return self.scale(-c, inner),
                _ => {}
            }
        }
        // Constant factors move outward, where they meet and fold:
        // (2*x)*(2*y) = 4*(x*y). Real-number identities keep intervals sound.
        if self.const_value(a).is_none() {
            if let Some((c, q)) = self.constant_multiple(b).filter(|&(c, _)| moves_outward(c)) {
                let m = self.mul(a, q);
                return self.scale(c, m);
            }
            if let Some((c, p)) = self.constant_multiple(a).filter(|&(c, _)| moves_outward(c)) {
                let m = self.mul(p, b);
                return self.scale(c, m);
            }
        }
        match (self.negated(a), self.negated(b)) {
            (Some(na), Some(nb)) => return self.mul(na, nb),
            (Some(na), None) => {
                let m = self.mul(na, b);
                return self.neg(m);
            }
            (None, Some(nb)) => {
                let m = self.mul(a, nb);
                return self.neg(m);
            }
            (None, None) => {}
        }
        let (base_a, pow_a) = self.as_power(a);
        let (base_b, pow_b) = self.as_power(b);
        // u^-1 * u = u^0 would define the product at u = 0.
        let same_domain = (pow_a < 0) == (pow_b < 0) || self.folds_drop_domains;
        if base_a == base_b && same_domain {
            if let Some(n) = pow_a.checked_add(pow_b) {
                return self.powi(base_a, n);
            }
        }
        self.intern(Op::Binary(BinaryOp::Mul, a, b))
    }

    fn as_power(&self, node: Node) -> (Node, i32) {
        match *self.get(node) {
            Op::PowI(base, n) => (base, n),
            _ => (node, 1),
        }
    }

    fn fold_div(&mut self, a: Node, b: Node) -> Node {
        // Dividing by the constant 0 has no value anywhere: the formula is
        // undefined, written as 0/0 (NaN at points, empty intervals). Left
        // as a/0, it would be ±∞ at points, which no interval can tell
        // from a value that may be 0.
        if self.is_const(b, 0.0) {
            return self.intern(Op::Binary(BinaryOp::Div, b, b));
        }
        // 0/b is 0 only where b is defined and not 0.
        if self.is_const(a, 0.0) && self.folds_drop_domains {
            return a;
        }
        if let Some(c) = self.const_value(b) {
            if c == 1.0 {
                return a;
            }
            if c == -1.0 {
                return self.neg(a);
            }
            // Dividing by a power of two is multiplying by its exact reciprocal.
            if let Some(r) = exact_binary(BinaryOp::Div, 1.0, c) {
                if is_power_of_two(r) {
                    return self.scale(r, a);
                }
            }
        }
        if let Some((c, p)) = self.constant_multiple(a) {
            // (c*p)/(c*q) = p/q; otherwise the constant moves outward.
            if let Some((k, q)) = self.constant_multiple(b) {
                if k == c && c != 0.0 {
                    return self.div(p, q);
                }
            }
            if moves_outward(c) {
                let d = self.div(p, b);
                return self.scale(c, d);
            }
        }
        match (self.negated(a), self.negated(b)) {
            (Some(na), Some(nb)) => return self.div(na, nb),
            (Some(na), None) => {
                let d = self.div(na, b);
                return self.neg(d);
            }
            (None, Some(nb)) => {
                let d = self.div(a, nb);
                return self.neg(d);
            }
            (None, None) => {}
        }
        self.intern(Op::Binary(BinaryOp::Div, a, b))
    }

    /// Evaluates `node` at `inputs` (indexed by [`Var::index`]) by walking the
    /// graph; a reference for tests and small jobs. Compile a
    /// [`Tape`](crate::Tape) for anything evaluated often.
    pub fn eval(&self, node: Node, inputs: &[f64; 6]) -> f64 {
        let order = self.topological_order(&[node]);
        let mut values = FxHashMap::default();
        for &n in &order {
            let v = |m: Node| values[&m];
            let value = match *self.get(n) {
                Op::Const(c) => c.0,
                Op::Var(var) => inputs[var.index()],
                Op::Unary(op, a) => op.eval(v(a)),
                Op::Binary(op, a, b) => op.eval(v(a), v(b)),
                Op::PowI(a, k) => powi(v(a), k),
                Op::Choose(c, p, q) => choose(v(c), v(p), v(q)),
                Op::Remap(..) => unreachable!("{UNEXPANDED}"),
            };
            values.insert(n, value);
        }
        values[&node]
    }

    /// The nodes reachable from `roots`, children before parents, each once.
    /// Walks with an explicit stack, so depth is limited only by memory.
    pub fn topological_order(&self, roots: &[Node]) -> Vec<Node> {
        self.topological_order_along(roots, |node| self.get(node).child_slots())
    }

    /// [`Context::topological_order`] along the operands `follow` names for
    /// each node (a subset of its own, in order): what a walk that skips
    /// some operands (the branches a region drops) still reaches.
    pub fn topological_order_along(
        &self,
        roots: &[Node],
        follow: impl Fn(Node) -> [Option<Node>; 3],
    ) -> Vec<Node> {
        let mut seen = vec![false; self.ops.len()];
        // Sized for the whole graph up front (the order never holds more,
        // the stack seldom): growing them step by step was most of the
        // walk's cost.
        let mut order = Vec::with_capacity(self.ops.len());
        let mut stack: Vec<(Node, bool)> = Vec::with_capacity(self.ops.len() + roots.len());
        stack.extend(roots.iter().rev().map(|&r| (r, false)));
        while let Some((node, expanded)) = stack.pop() {
            if expanded {
                order.push(node);
                continue;
            }
            if seen[node.index()] {
                continue;
            }
            seen[node.index()] = true;
            stack.push((node, true));
            for child in follow(node).into_iter().rev().flatten() {
                if !seen[child.index()] {
                    stack.push((child, false));
                }
            }
        }
        order
    }

    /// A new context holding only what `root` reaches, node for node (no
    /// refolding), and `root` in it: an object of a scene keeps its own small
    /// graph instead of a copy of the whole scene's. The new context stores
    /// at most `limit` nodes.
    pub fn extract(&self, root: Node, limit: usize) -> (Context, Node) {
        let order = self.topological_order(&[root]);
        let mut out = Context::with_limit(limit);
        let mut new: FxHashMap<Node, Node> = FxHashMap::default();
        for n in order {
            let m = |k: Node| new[&k];
            let op = match *self.get(n) {
                op @ (Op::Const(_) | Op::Var(_)) => op,
                Op::Unary(op, a) => Op::Unary(op, m(a)),
                Op::Binary(op, a, b) => Op::Binary(op, m(a), m(b)),
                Op::PowI(a, k) => Op::PowI(m(a), k),
                Op::Choose(c, p, q) => Op::Choose(m(c), m(p), m(q)),
                Op::Remap(..) => unreachable!("{UNEXPANDED}"),
            };
            let node = out.intern(op);
            new.insert(n, node);
        }
        (out, new[&root])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_subexpressions_are_one_node() {
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let y = ctx.var(Var::Y);
        let a = ctx.mul(x, y);
        let b = ctx.mul(x, y);
        assert_eq!(a, b);
        let s1 = ctx.unary(UnaryOp::Sin, a);
        let s2 = ctx.unary(UnaryOp::Sin, b);
        assert_eq!(s1, s2);
        let two = ctx.constant(2.0);
        assert_eq!(ctx.mul(x, two), ctx.mul(two, x), "constants lead products");
    }

    #[test]
    fn a_graph_past_the_node_limit_is_refused_not_built() {
        let mut ctx = Context::with_limit(80);
        let x = ctx.var(Var::X);
        let mut f = x;
        for _ in 0..30 {
            f = ctx.unary(UnaryOp::Sin, f);
        }
        assert_eq!(ctx.check_size(), Ok(()), "31 nodes fit");
        // The derivative of 30 nested sines needs 60 nodes more: the walk
        // stops at the limit, and the context says the result is void.
        let _ = ctx.partial(f, Var::X);
        assert_eq!(ctx.len(), 80, "nothing is stored past the limit");
        assert_eq!(ctx.check_size(), Err(GraphTooLarge { limit: 80 }));
        // It stays refused: later builds cannot make the graph whole again.
        let _ = ctx.var(Var::Y);
        assert!(ctx.check_size().is_err());
    }

    #[test]
    fn identities_fold_as_built() {
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let zero = ctx.constant(0.0);
        let one = ctx.constant(1.0);
        assert_eq!(ctx.add(x, zero), x);
        assert_eq!(ctx.mul(x, one), x);
        assert_eq!(ctx.mul(zero, x), zero);
        assert_eq!(ctx.powi(x, 1), x);
        assert_eq!(ctx.powi(x, 0), one);
        let nx = ctx.neg(x);
        assert_eq!(ctx.neg(nx), x);
        assert_eq!(ctx.mul(x, x), ctx.powi(x, 2));
        assert_eq!(ctx.sub(x, x), zero);
        let two = ctx.constant(2.0);
        let three = ctx.constant(3.0);
        let six = ctx.mul(two, three);
        assert_eq!(ctx.const_value(six), Some(6.0));
    }

    #[test]
    fn inexact_constant_arithmetic_stays_symbolic() {
        let mut ctx = Context::new();
        let tenth = ctx.constant(0.1);
        let three = ctx.constant(3.0);
        let p = ctx.mul(tenth, three);
        assert_eq!(
            ctx.const_value(p),
            None,
            "0.1*3 is not exactly 0.30000000000000004"
        );
        let s = ctx.unary(UnaryOp::Sin, three);
        assert_eq!(ctx.const_value(s), None);
        let four = ctx.constant(4.0);
        let r = ctx.unary(UnaryOp::Sqrt, four);
        assert_eq!(ctx.const_value(r), Some(2.0));
        let two = ctx.constant(2.0);
        let q = ctx.unary(UnaryOp::Sqrt, two);
        assert_eq!(ctx.const_value(q), None);
        let half = ctx.constant(0.5);
        let h = ctx.powi(half, 3);
        assert_eq!(ctx.const_value(h), Some(0.125));
    }

    #[test]
    fn division_by_three_is_not_rewritten_as_an_inexact_product() {
        let mut ctx = Context::new();
        let x = ctx.var(Var::X);
        let three = ctx.constant(3.0);
        let d = ctx.div(x, three);
        assert!(matches!(ctx.get(d), Op::Binary(BinaryOp::Div, _, _)));
        let four = ctx.constant(4.0);
        let q = ctx.div(x, four);
        assert!(matches!(ctx.get(q), Op::Binary(BinaryOp::Mul, _, _)));
    }

    #[test]
    fn folding_never_creates_an_infinite_constant() {
        let mut ctx = Context::new();
        let one = ctx.constant(1.0);
        let zero = ctx.constant(0.0);
        let q = ctx.div(one, zero);
        assert!(matches!(ctx.get(q), Op::Binary(BinaryOp::Div, _, _)));
        let big = ctx.constant(1e300);
        let p = ctx.powi(big, 2);
        assert!(matches!(ctx.get(p), Op::PowI(_, 2)));
    }

    #[test]
    fn sign_of_zero_is_zero_and_nan_propagates() {
        assert_eq!(UnaryOp::Sign.eval(0.0), 0.0);
        assert_eq!(UnaryOp::Sign.eval(-3.0), -1.0);
        assert!(UnaryOp::Sign.eval(f64::NAN).is_nan());
        assert!(BinaryOp::Min.eval(f64::NAN, 1.0).is_nan());
        assert_eq!(choose(0.0, 1.0, 3.0), 2.0);
    }
}
