//! The vocabulary of the expression graph: node handles, inputs, operations,
//! and the point semantics every evaluator shares.

use crate::types::{real, Interval};
use std::fmt;

/// Handle to a node of a [`Context`](super::Context).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Node(pub(super) u32);

impl Node {
    /// The node's position in its context; nodes are numbered in creation order,
    /// so children always have smaller indices than their parents.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// An input of a formula: a coordinate, or a component of the ray direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Var {
    /// The x coordinate.
    X,
    /// The y coordinate.
    Y,
    /// The z coordinate.
    Z,
    /// x-component of the ray direction, the extra input of `g` and `g′`.
    Dx,
    /// y-component of the ray direction.
    Dy,
    /// z-component of the ray direction.
    Dz,
}

impl Var {
    /// All inputs, in input-slot order.
    pub const ALL: [Var; 6] = [Var::X, Var::Y, Var::Z, Var::Dx, Var::Dy, Var::Dz];

    /// The input slot (0..6) of this variable.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The variable's name in the formula language.
    pub fn name(self) -> &'static str {
        ["x", "y", "z", "dx", "dy", "dz"][self as usize]
    }

    /// The variable called `name`, if any.
    pub fn from_name(name: &str) -> Option<Var> {
        Var::ALL.into_iter().find(|v| v.name() == name)
    }
}

/// Functions of one argument.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    /// `-a`.
    Neg,
    /// Square root, for `a ≥ 0`.
    Sqrt,
    /// `|a|`.
    Abs,
    /// −1, 0 or 1; over an interval holding 0 it is `[-1, 1]`.
    Sign,
    /// Sine.
    Sin,
    /// Cosine.
    Cos,
    /// Tangent.
    Tan,
    /// Arcsine, for `|a| ≤ 1`.
    Asin,
    /// Arccosine, for `|a| ≤ 1`.
    Acos,
    /// Arctangent.
    Atan,
    /// `e^a`.
    Exp,
    /// Natural logarithm, for `a > 0`.
    Ln,
    /// Hyperbolic sine.
    Sinh,
    /// Hyperbolic cosine.
    Cosh,
    /// Hyperbolic tangent.
    Tanh,
    /// Hyperbolic secant `1/cosh(a)`, computed without overflow for large `|a|`.
    Sech,
    /// The derivative of a unit step: 0 at every point, `[0, ∞]` over an
    /// interval holding 0. It carries the jump of `sign`/`min`/`max` into
    /// second derivatives, so a kink crossed by a ray makes G infinite.
    Dirac,
    /// The largest integer not above `a`; it jumps at every integer.
    Floor,
    /// The smallest integer not below `a`; it jumps at every integer.
    Ceil,
    /// The nearest integer, halves away from zero; it jumps at every half.
    Round,
}

impl UnaryOp {
    /// Whether the function may jump (or leave the reals) somewhere in `x`:
    /// `sign` and `dirac` across 0, `tan` across a pole, `ln` at 0.
    pub fn may_jump(self, x: Interval) -> bool {
        use UnaryOp::*;
        let straddles = x.contains(0.0) && !(x.inf() == 0.0 && x.sup() == 0.0);
        match self {
            Sign | Dirac => straddles,
            Ln => x.contains(0.0),
            Tan => !x.tan().is_bounded(),
            // Monotone steps: continuous on x exactly where both ends give
            // the same step.
            Floor | Ceil | Round => x.is_empty() || self.eval(x.inf()) != self.eval(x.sup()),
            _ => false,
        }
    }

    /// Where the function is defined, when that is not the whole line. Its
    /// interval extension encloses it over the part of an argument inside.
    pub fn domain(self) -> Option<Interval> {
        use UnaryOp::*;
        match self {
            Sqrt | Ln => Some(Interval::NON_NEGATIVE),
            Asin | Acos => Some(Interval::UNIT),
            _ => None,
        }
    }

    /// Name of the function in the formula language (`-` for negation).
    pub fn name(self) -> &'static str {
        use UnaryOp::*;
        match self {
            Neg => "-",
            Sqrt => "sqrt",
            Abs => "abs",
            Sign => "sign",
            Sin => "sin",
            Cos => "cos",
            Tan => "tan",
            Asin => "asin",
            Acos => "acos",
            Atan => "atan",
            Exp => "exp",
            Ln => "ln",
            Sinh => "sinh",
            Cosh => "cosh",
            Tanh => "tanh",
            Sech => "sech",
            Dirac => "dirac",
            Floor => "floor",
            Ceil => "ceil",
            Round => "round",
        }
    }

    /// The value at a point.
    pub fn eval(self, a: f64) -> f64 {
        use UnaryOp::*;
        match self {
            Neg => -a,
            Sqrt => a.sqrt(),
            Abs => a.abs(),
            Sign => real::sign(a),
            Sin => a.sin(),
            Cos => a.cos(),
            Tan => a.tan(),
            Asin => a.asin(),
            Acos => a.acos(),
            Atan => a.atan(),
            Exp => a.exp(),
            Ln => a.ln(),
            Sinh => a.sinh(),
            Cosh => a.cosh(),
            Tanh => a.tanh(),
            Sech => real::sech(a),
            Dirac => a * 0.0,
            Floor => a.floor(),
            Ceil => a.ceil(),
            Round => a.round(),
        }
    }
}

/// Functions of two arguments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    /// `a + b`.
    Add,
    /// `a - b`.
    Sub,
    /// `a * b`.
    Mul,
    /// `a / b`.
    Div,
    /// The smaller of `a` and `b`.
    Min,
    /// The larger of `a` and `b`.
    Max,
    /// `atan2(y, x)`, the angle of the point (x, y).
    Atan2,
    /// `a^b` for a non-integer or non-constant exponent (`a ≥ 0`).
    Pow,
}

impl BinaryOp {
    /// Whether the function may jump (or leave the reals) somewhere in
    /// `a × b`: `atan2` across its cut or at the origin, a power of a base
    /// that reaches 0. (A quotient by an interval holding 0 may have no
    /// value: [`BinaryOp::may_be_undefined`] says so.)
    pub fn may_jump(self, a: Interval, b: Interval) -> bool {
        match self {
            BinaryOp::Atan2 => a.contains(0.0) && b.inf() <= 0.0,
            BinaryOp::Pow => a.contains(0.0),
            _ => false,
        }
    }

    /// Whether the function may have no value somewhere in `a × b` for a
    /// reason its first argument's domain does not say: a quotient by 0,
    /// `atan2` at the origin.
    pub fn may_be_undefined(self, a: Interval, b: Interval) -> bool {
        match self {
            BinaryOp::Div => b.contains(0.0),
            BinaryOp::Atan2 => a.contains(0.0) && b.contains(0.0),
            _ => false,
        }
    }

    /// Where the function is defined in its first argument, when that is not
    /// the whole line (the base of a non-integer power).
    pub fn domain(self) -> Option<Interval> {
        match self {
            BinaryOp::Pow => Some(Interval::NON_NEGATIVE),
            _ => None,
        }
    }

    /// The value at a point. `min` and `max` propagate NaN, unlike `f64::min`.
    pub fn eval(self, a: f64, b: f64) -> f64 {
        use BinaryOp::*;
        match self {
            Add => a + b,
            Sub => a - b,
            Mul => a * b,
            Div => quotient(a, b),
            Min => {
                if a.is_nan() || b.is_nan() {
                    f64::NAN
                } else {
                    a.min(b)
                }
            }
            Max => {
                if a.is_nan() || b.is_nan() {
                    f64::NAN
                } else {
                    a.max(b)
                }
            }
            // atan2(0, 0) is no angle (f64 gives 0 or ±π by the zeros' signs).
            Atan2 if a == 0.0 && b == 0.0 => f64::NAN,
            Atan2 => a.atan2(b),
            // The documented domain is a ≥ 0 (integer constant exponents are
            // PowI); outside it there is no value, as for sqrt.
            // IEEE powf(1, NaN) and powf(NaN, 0) are 1: an undefined operand
            // must stay undefined, as it does in every other operation.
            Pow => {
                if a < 0.0 || a.is_nan() || b.is_nan() {
                    f64::NAN
                } else {
                    a.powf(b)
                }
            }
        }
    }
}

/// `a / b` at a point: NaN where `b` is 0, where no quotient exists.
///
/// f64 gives ±∞ by the sign of the zero, which no interval records (1/+0 at
/// the end of [-1, 0] would lie outside [-∞, -1]): as in IEEE 1788, a pole
/// has no value, and a quotient's enclosure holds those that exist.
#[inline(always)]
pub fn quotient(a: f64, b: f64) -> f64 {
    if b == 0.0 {
        f64::NAN
    } else {
        a / b
    }
}

/// `x^n` at a point, computed the same way by every evaluator; a negative
/// power of 0 has no value, as a quotient by 0 has none.
///
/// Small powers are products, which inline and vectorise where `powi` is a
/// call per value.
#[inline]
pub fn powi(x: f64, n: i32) -> f64 {
    match n {
        2 => x * x,
        3 => x * x * x,
        4 => {
            let s = x * x;
            s * s
        }
        _ if n < 0 && x == 0.0 => f64::NAN,
        _ => x.powi(n),
    }
}

/// `choose(c, p, n)` at a point: `p` where `c < 0`, `n` where `c > 0`, their mean at 0.
pub fn choose(c: f64, p: f64, n: f64) -> f64 {
    if c < 0.0 {
        p
    } else if c > 0.0 {
        n
    } else if c == 0.0 {
        0.5 * (p + n)
    } else {
        f64::NAN
    }
}

/// A finite constant, compared and hashed by its bits.
#[derive(Clone, Copy)]
pub struct Constant(pub(super) f64);

impl Constant {
    /// The constant's value.
    pub fn value(self) -> f64 {
        self.0
    }
}

impl PartialEq for Constant {
    fn eq(&self, other: &Self) -> bool {
        self.0.to_bits() == other.0.to_bits()
    }
}
impl Eq for Constant {}
impl std::hash::Hash for Constant {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.to_bits().hash(state)
    }
}
impl fmt::Debug for Constant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// One operation of the graph; operands are earlier nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Op {
    /// A finite constant.
    Const(Constant),
    /// An input.
    Var(Var),
    /// A function of one operand.
    Unary(UnaryOp, Node),
    /// A function of two operands.
    Binary(BinaryOp, Node, Node),
    /// `a^n` for an integer `n`.
    PowI(Node, i32),
    /// `choose(c, p, n)`: see [`choose`].
    Choose(Node, Node, Node),
    /// The operand in changed coordinates, awaiting expansion: only lowering
    /// builds these (see `Context::expand`), and no evaluator, derivative or
    /// printer ever sees one.
    Remap(Node, u32),
}

impl Op {
    /// The operands, in order.
    pub fn children(&self) -> impl DoubleEndedIterator<Item = Node> {
        let [a, b, c] = self.child_slots();
        a.into_iter().chain(b).chain(c)
    }

    /// The operands, in order, then `None` up to three.
    pub fn child_slots(&self) -> [Option<Node>; 3] {
        match *self {
            Op::Const(_) | Op::Var(_) => [None, None, None],
            Op::Unary(_, a) | Op::PowI(a, _) | Op::Remap(a, _) => [Some(a), None, None],
            Op::Binary(_, a, b) => [Some(a), Some(b), None],
            Op::Choose(a, b, c) => [Some(a), Some(b), Some(c)],
        }
    }
}
