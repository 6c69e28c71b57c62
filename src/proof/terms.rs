//! The checker's own formulas: f read from the parser's syntax tree into a
//! list of terms, differentiated by the rules of `docs/bounds.md`, and
//! evaluated by the natural interval extension, one term at a time.
//!
//! Nothing here uses lgc's expression graph, simplifier, tapes or bounds:
//! a proof is re-checked by code that shares only the parser and the
//! interval type with the code that found it.

use crate::lang::ast::{Ast, AstId, AstKind, BinOp, Span};
use crate::lang::{ErrorKind, FormulaError};
use crate::types::Interval;
use std::collections::HashMap;

/// The most terms a formula and its derivatives may take.
pub const MAX_TERMS: usize = 1 << 22;

/// A term's index in [`Terms`]; a term's operands come before it.
pub type TermId = u32;

/// A one-argument function the checker reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Func {
    Sqrt,
    Abs,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Exp,
    Ln,
    Sinh,
    Cosh,
    Tanh,
    Sech,
    Sign,
    Dirac,
}

/// One term.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Term {
    /// A constant, enclosed.
    Const(Interval),
    /// Variable 0, 1, 2 (x, y, z) or 3 (t along a ray).
    Var(u8),
    Add(TermId, TermId),
    Sub(TermId, TermId),
    Mul(TermId, TermId),
    Div(TermId, TermId),
    Neg(TermId),
    /// An integer power.
    Powi(TermId, i32),
    /// `a^b`, defined for a ≥ 0.
    Pow(TermId, TermId),
    Call(Func, TermId),
    Min(TermId, TermId),
    Max(TermId, TermId),
    /// `choose(c, a, b)`: a where c < 0, b where c > 0.
    Choose(TermId, TermId, TermId),
}

/// Why a formula cannot be read or differentiated by the checker.
#[derive(Debug, thiserror::Error)]
pub enum TermError {
    /// A mistake in the text, or a part of the language the checker does
    /// not read, located.
    #[error("{}", .0.message)]
    Formula(FormulaError),
    /// More than [`MAX_TERMS`] terms.
    #[error("the formula and its derivatives take more than {MAX_TERMS} terms")]
    TooLarge,
    /// A second derivative of `sign`, `abs`, `min` or `max` would need a
    /// derivative of `dirac`.
    #[error("the derivative asked for is not defined at the formula's kinks")]
    NoDerivative,
}

/// A formula's terms, with its derivatives appended as they are asked for.
#[derive(Debug, Clone)]
pub struct Terms {
    terms: Vec<Term>,
    zero: TermId,
    one: TermId,
    /// Each (term, variable)'s derivative, once made.
    derivatives: HashMap<(TermId, u8), TermId>,
}

impl Terms {
    fn new() -> Terms {
        let mut t = Terms {
            terms: Vec::new(),
            zero: 0,
            one: 0,
            derivatives: HashMap::new(),
        };
        t.zero = t.push_raw(Term::Const(Interval::point(0.0)));
        t.one = t.push_raw(Term::Const(Interval::point(1.0)));
        t
    }

    /// Reads a formula (a body, with `let` bindings before it). With
    /// `ray = Some((o, d))` the variables x, y, z stand for o + t·d, so
    /// derivatives by variable 3 are along the ray.
    pub fn read(
        text: &str,
        ray: Option<([f64; 3], [f64; 3])>,
    ) -> Result<(Terms, TermId), TermError> {
        let ast = crate::lang::parse(text).map_err(TermError::Formula)?;
        let mut terms = Terms::new();
        let mut scope: HashMap<String, TermId> = HashMap::new();
        for (axis, name) in ["x", "y", "z"].iter().enumerate() {
            let v = match ray {
                None => terms.push(Term::Var(axis as u8))?,
                Some((o, d)) => {
                    let t = terms.push(Term::Var(3))?;
                    let (o, d) = (terms.constant(o[axis])?, terms.constant(d[axis])?);
                    let step = terms.mul(t, d)?;
                    terms.add(o, step)?
                }
            };
            scope.insert(name.to_string(), v);
        }
        scope.insert("pi".into(), terms.constant(std::f64::consts::PI)?);
        scope.insert("e".into(), terms.constant(std::f64::consts::E)?);
        for b in &ast.bindings {
            let v = terms.read_tree(&ast, b.value, &scope)?;
            scope.insert(b.name.clone(), v);
        }
        let body = ast.body.ok_or_else(|| {
            TermError::Formula(FormulaError::new(
                ErrorKind::WrongType,
                0..text.len(),
                "a proof's formula is one expression, not a scene",
            ))
        })?;
        let root = terms.read_tree(&ast, body, &scope)?;
        Ok((terms, root))
    }

    /// Reads a constant expression (no x, y or z): its enclosure.
    pub fn constant_of(text: &str) -> Result<Option<Interval>, TermError> {
        let (terms, root) = Terms::read(text, None)?;
        if terms.varies(root) {
            return Ok(None);
        }
        Ok(Some(terms.eval(&[Interval::ENTIRE; 4])[root as usize]))
    }

    /// Whether term `id` depends on a variable.
    fn varies(&self, id: TermId) -> bool {
        !matches!(self.terms[id as usize], Term::Const(_))
    }

    fn push_raw(&mut self, t: Term) -> TermId {
        self.terms.push(t);
        (self.terms.len() - 1) as TermId
    }

    /// Adds a term; operands that are all constant are folded into one
    /// constant (by the same interval operations).
    fn push(&mut self, t: Term) -> Result<TermId, TermError> {
        if self.terms.len() >= MAX_TERMS {
            return Err(TermError::TooLarge);
        }
        let id = self.push_raw(t);
        let operands = self.operands(t);
        if !matches!(t, Term::Const(_) | Term::Var(_)) && operands.iter().all(|&o| !self.varies(o))
        {
            let v = eval_one(t, |i| match self.terms[i as usize] {
                Term::Const(c) => c,
                _ => Interval::ENTIRE,
            });
            self.terms[id as usize] = Term::Const(v);
        }
        Ok(id)
    }

    fn operands(&self, t: Term) -> Vec<TermId> {
        match t {
            Term::Const(_) | Term::Var(_) => vec![],
            Term::Neg(a) | Term::Powi(a, _) | Term::Call(_, a) => vec![a],
            Term::Add(a, b)
            | Term::Sub(a, b)
            | Term::Mul(a, b)
            | Term::Div(a, b)
            | Term::Pow(a, b)
            | Term::Min(a, b)
            | Term::Max(a, b) => vec![a, b],
            Term::Choose(c, a, b) => vec![c, a, b],
        }
    }

    fn constant(&mut self, v: f64) -> Result<TermId, TermError> {
        self.push(Term::Const(Interval::point(v)))
    }

    fn is(&self, id: TermId, v: f64) -> bool {
        self.terms[id as usize] == Term::Const(Interval::point(v))
    }

    fn add(&mut self, a: TermId, b: TermId) -> Result<TermId, TermError> {
        match (self.is(a, 0.0), self.is(b, 0.0)) {
            (true, _) => Ok(b),
            (_, true) => Ok(a),
            _ => self.push(Term::Add(a, b)),
        }
    }

    fn sub(&mut self, a: TermId, b: TermId) -> Result<TermId, TermError> {
        match (self.is(a, 0.0), self.is(b, 0.0)) {
            (_, true) => Ok(a),
            (true, _) => self.push(Term::Neg(b)),
            _ => self.push(Term::Sub(a, b)),
        }
    }

    fn mul(&mut self, a: TermId, b: TermId) -> Result<TermId, TermError> {
        if self.is(a, 0.0) || self.is(b, 0.0) {
            Ok(self.zero)
        } else if self.is(a, 1.0) {
            Ok(b)
        } else if self.is(b, 1.0) {
            Ok(a)
        } else {
            self.push(Term::Mul(a, b))
        }
    }

    fn div(&mut self, a: TermId, b: TermId) -> Result<TermId, TermError> {
        if self.is(a, 0.0) {
            Ok(self.zero)
        } else {
            self.push(Term::Div(a, b))
        }
    }

    fn neg(&mut self, a: TermId) -> Result<TermId, TermError> {
        if self.is(a, 0.0) {
            Ok(self.zero)
        } else {
            self.push(Term::Neg(a))
        }
    }

    fn call(&mut self, f: Func, a: TermId) -> Result<TermId, TermError> {
        self.push(Term::Call(f, a))
    }

    /// Reads the subtree at `root`, operands first, with an explicit stack.
    fn read_tree(
        &mut self,
        ast: &Ast,
        root: AstId,
        scope: &HashMap<String, TermId>,
    ) -> Result<TermId, TermError> {
        let mut done: HashMap<AstId, TermId> = HashMap::new();
        let mut stack = vec![(root, false)];
        while let Some((id, expanded)) = stack.pop() {
            if done.contains_key(&id) {
                continue;
            }
            if !expanded {
                stack.push((id, true));
                stack.extend(ast.children(id).into_iter().map(|c| (c, false)));
                continue;
            }
            let node = ast.node(id);
            let args: Vec<TermId> = ast.children(id).iter().map(|c| done[c]).collect();
            let term = self.read_node(&node.kind, &node.span, &args, scope)?;
            done.insert(id, term);
        }
        Ok(done[&root])
    }

    fn read_node(
        &mut self,
        kind: &AstKind,
        span: &Span,
        args: &[TermId],
        scope: &HashMap<String, TermId>,
    ) -> Result<TermId, TermError> {
        let unread = |what: String| {
            TermError::Formula(FormulaError::new(
                ErrorKind::NotInProofLanguage,
                span.clone(),
                what,
            ))
        };
        match kind {
            AstKind::Number(v) => self.constant(*v),
            AstKind::Name(name) => scope.get(name).copied().ok_or_else(|| {
                unread(format!(
                    "`{name}` is no variable, constant or earlier `let` binding"
                ))
            }),
            AstKind::Neg(_) => self.neg(args[0]),
            AstKind::Tuple(_) => Err(unread("a tuple is not a number".into())),
            AstKind::Binary(op, _, _) => {
                let (a, b) = (args[0], args[1]);
                match op {
                    BinOp::Add => self.add(a, b),
                    BinOp::Sub => self.sub(a, b),
                    BinOp::Mul => self.mul(a, b),
                    BinOp::Div => self.div(a, b),
                    BinOp::Pow => self.power(a, b),
                }
            }
            AstKind::Call {
                name, name_span, ..
            } => {
                let unread = |what: String| {
                    TermError::Formula(FormulaError::new(
                        ErrorKind::NotInProofLanguage,
                        name_span.clone(),
                        what,
                    ))
                };
                let one = |f: Func, terms: &mut Terms| {
                    if args.len() == 1 {
                        terms.call(f, args[0])
                    } else {
                        Err(unread(format!("{name} takes 1 argument")))
                    }
                };
                let func = match name.as_str() {
                    "sqrt" => Some(Func::Sqrt),
                    "abs" => Some(Func::Abs),
                    "sin" => Some(Func::Sin),
                    "cos" => Some(Func::Cos),
                    "tan" => Some(Func::Tan),
                    "asin" => Some(Func::Asin),
                    "acos" => Some(Func::Acos),
                    "atan" => Some(Func::Atan),
                    "exp" => Some(Func::Exp),
                    "ln" => Some(Func::Ln),
                    "sinh" => Some(Func::Sinh),
                    "cosh" => Some(Func::Cosh),
                    "tanh" => Some(Func::Tanh),
                    "sech" => Some(Func::Sech),
                    "sign" => Some(Func::Sign),
                    _ => None,
                };
                if let Some(f) = func {
                    return one(f, self);
                }
                match (name.as_str(), args) {
                    ("log", [a]) => {
                        let ln = self.call(Func::Ln, *a)?;
                        let ten = self.constant(10.0)?;
                        let ln10 = self.call(Func::Ln, ten)?;
                        self.div(ln, ln10)
                    }
                    ("min" | "union", [first, rest @ ..]) if !rest.is_empty() => {
                        rest.iter()
                            .try_fold(*first, |m, &a| self.push(Term::Min(m, a)))
                    }
                    ("max" | "intersect", [first, rest @ ..]) if !rest.is_empty() => {
                        rest.iter()
                            .try_fold(*first, |m, &a| self.push(Term::Max(m, a)))
                    }
                    ("subtract", [a, b]) => {
                        let nb = self.neg(*b)?;
                        self.push(Term::Max(*a, nb))
                    }
                    ("hypot", [a, b]) => {
                        let a2 = self.push(Term::Powi(*a, 2))?;
                        let b2 = self.push(Term::Powi(*b, 2))?;
                        let s = self.add(a2, b2)?;
                        self.call(Func::Sqrt, s)
                    }
                    ("pow", [a, b]) => self.power(*a, *b),
                    _ => Err(unread(format!(
                        "`{name}` with {} arguments is not in the language proofs are checked in (docs/bounds.md lists it)",
                        args.len()
                    ))),
                }
            }
        }
    }

    /// `a^b`: an integer power where b is an integer constant.
    fn power(&mut self, a: TermId, b: TermId) -> Result<TermId, TermError> {
        if let Term::Const(c) = self.terms[b as usize] {
            let n = c.inf();
            if c.inf() == c.sup() && n.fract() == 0.0 && n.abs() <= 1024.0 {
                return match n as i32 {
                    0 => Ok(self.one),
                    1 => Ok(a),
                    n => self.push(Term::Powi(a, n)),
                };
            }
        }
        self.push(Term::Pow(a, b))
    }

    /// The derivative of term `id` by variable `var`, made once.
    pub fn derivative(&mut self, id: TermId, var: u8) -> Result<TermId, TermError> {
        // Operands first, with an explicit stack: a long `let` chain must
        // not exhaust the thread's stack.
        let mut stack = vec![(id, false)];
        while let Some((t, expanded)) = stack.pop() {
            if self.derivatives.contains_key(&(t, var)) {
                continue;
            }
            let term = self.terms[t as usize];
            if !expanded {
                stack.push((t, true));
                stack.extend(self.operands(term).into_iter().map(|o| (o, false)));
                continue;
            }
            let d = self.derive_one(t, term, var)?;
            self.derivatives.insert((t, var), d);
        }
        Ok(self.derivatives[&(id, var)])
    }

    /// One term's derivative, its operands' being made.
    fn derive_one(&mut self, this: TermId, term: Term, var: u8) -> Result<TermId, TermError> {
        let d = |s: &Terms, a: TermId| s.derivatives[&(a, var)];
        Ok(match term {
            Term::Const(_) => self.zero,
            Term::Var(v) => {
                if v == var {
                    self.one
                } else {
                    self.zero
                }
            }
            Term::Add(a, b) => {
                let (da, db) = (d(self, a), d(self, b));
                self.add(da, db)?
            }
            Term::Sub(a, b) => {
                let (da, db) = (d(self, a), d(self, b));
                self.sub(da, db)?
            }
            Term::Neg(a) => {
                let da = d(self, a);
                self.neg(da)?
            }
            Term::Mul(a, b) => {
                let (da, db) = (d(self, a), d(self, b));
                let l = self.mul(da, b)?;
                let r = self.mul(a, db)?;
                self.add(l, r)?
            }
            // (a/b)' = (a' − (a/b)·b') / b
            Term::Div(a, b) => {
                let (da, db) = (d(self, a), d(self, b));
                let q = self.mul(this, db)?;
                let top = self.sub(da, q)?;
                self.div(top, b)?
            }
            // (a^n)' = n·a^(n−1)·a'
            Term::Powi(a, n) => {
                let da = d(self, a);
                let lower = match n - 1 {
                    0 => self.one,
                    1 => a,
                    m => self.push(Term::Powi(a, m))?,
                };
                let k = self.constant(f64::from(n))?;
                let kd = self.mul(k, da)?;
                self.mul(kd, lower)?
            }
            // (a^b)' = a^b·(b'·ln a + b·a'/a)
            Term::Pow(a, b) => {
                let (da, db) = (d(self, a), d(self, b));
                let ln = self.call(Func::Ln, a)?;
                let l = self.mul(db, ln)?;
                let ratio = self.div(da, a)?;
                let r = self.mul(b, ratio)?;
                let sum = self.add(l, r)?;
                self.mul(this, sum)?
            }
            Term::Call(f, a) => {
                let da = d(self, a);
                if self.is(da, 0.0) {
                    return Ok(self.zero);
                }
                if let (Func::Ln, Some((p, q))) = (f, self.sum_of_exps(a)) {
                    let (dp, dq) = (d(self, p), d(self, q));
                    return self.log_sum_exp(p, q, dp, dq);
                }
                let slope = self.slope(f, this, a)?;
                self.mul(slope, da)?
            }
            // min(a, b)' = choose(a − b, a', b'); max(a, b)' = choose(a − b, b', a')
            Term::Min(a, b) | Term::Max(a, b) => {
                let (da, db) = (d(self, a), d(self, b));
                let c = self.sub(a, b)?;
                let (neg, pos) = if matches!(term, Term::Min(..)) {
                    (da, db)
                } else {
                    (db, da)
                };
                self.choose(c, neg, pos)?
            }
            // choose(c, p, q)' = choose(c, p', q') + dirac(c)·c'·(q − p)
            Term::Choose(c, p, q) => {
                let (dc, dp, dq) = (d(self, c), d(self, p), d(self, q));
                let smooth = self.choose(c, dp, dq)?;
                let jump = self.sub(q, p)?;
                let rate = self.mul(dc, jump)?;
                if self.is(rate, 0.0) {
                    smooth
                } else {
                    let delta = self.call(Func::Dirac, c)?;
                    let step = self.mul(delta, rate)?;
                    self.add(smooth, step)?
                }
            }
        })
    }

    /// `(a, b)` where `u` is the term `exp(a) + exp(b)`.
    fn sum_of_exps(&self, u: TermId) -> Option<(TermId, TermId)> {
        let exponent = |t: TermId| match self.terms[t as usize] {
            Term::Call(Func::Exp, a) => Some(a),
            _ => None,
        };
        match self.terms[u as usize] {
            Term::Add(p, q) => Some((exponent(p)?, exponent(q)?)),
            _ => None,
        }
    }

    /// `ln(exp(a) + exp(b))′ = ½·(a′ + b′) + ½·tanh(½·(a − b))·(a′ − b′)`.
    fn log_sum_exp(
        &mut self,
        a: TermId,
        b: TermId,
        da: TermId,
        db: TermId,
    ) -> Result<TermId, TermError> {
        let half = self.constant(0.5)?;
        let sum = self.add(da, db)?;
        let half_sum = self.mul(half, sum)?;
        let diff = self.sub(da, db)?;
        if self.is(diff, 0.0) {
            return Ok(half_sum);
        }
        let gap = self.sub(a, b)?;
        let half_gap = self.mul(half, gap)?;
        let weight = self.call(Func::Tanh, half_gap)?;
        let half_diff = self.mul(half, diff)?;
        let lean = self.mul(weight, half_diff)?;
        self.add(half_sum, lean)
    }

    fn choose(&mut self, c: TermId, p: TermId, q: TermId) -> Result<TermId, TermError> {
        if p == q {
            Ok(p)
        } else {
            self.push(Term::Choose(c, p, q))
        }
    }

    /// f′(a) for `this` = f(a).
    fn slope(&mut self, f: Func, this: TermId, a: TermId) -> Result<TermId, TermError> {
        let one = self.one;
        Ok(match f {
            Func::Sqrt => {
                let two = self.constant(2.0)?;
                let twice = self.mul(two, this)?;
                self.div(one, twice)?
            }
            Func::Abs => self.call(Func::Sign, a)?,
            Func::Sin => self.call(Func::Cos, a)?,
            Func::Cos => {
                let s = self.call(Func::Sin, a)?;
                self.neg(s)?
            }
            Func::Tan => {
                let sq = self.push(Term::Powi(this, 2))?;
                self.add(one, sq)?
            }
            Func::Asin | Func::Acos => {
                let sq = self.push(Term::Powi(a, 2))?;
                let rest = self.sub(one, sq)?;
                let root = self.call(Func::Sqrt, rest)?;
                let inv = self.div(one, root)?;
                if f == Func::Acos {
                    self.neg(inv)?
                } else {
                    inv
                }
            }
            Func::Atan => {
                let sq = self.push(Term::Powi(a, 2))?;
                let den = self.add(one, sq)?;
                self.div(one, den)?
            }
            Func::Exp => this,
            Func::Ln => self.div(one, a)?,
            Func::Sinh => self.call(Func::Cosh, a)?,
            Func::Cosh => self.call(Func::Sinh, a)?,
            Func::Tanh => {
                let sq = self.push(Term::Powi(this, 2))?;
                self.sub(one, sq)?
            }
            Func::Sech => {
                let t = self.call(Func::Tanh, a)?;
                let st = self.mul(this, t)?;
                self.neg(st)?
            }
            // sign jumps by 2 at 0.
            Func::Sign => {
                let delta = self.call(Func::Dirac, a)?;
                let two = self.constant(2.0)?;
                self.mul(two, delta)?
            }
            Func::Dirac => return Err(TermError::NoDerivative),
        })
    }

    /// Every term's enclosure with the variables in `vars` (x, y, z, t):
    /// the natural interval extension.
    pub fn eval(&self, vars: &[Interval; 4]) -> Vec<Interval> {
        let mut out: Vec<Interval> = Vec::with_capacity(self.terms.len());
        for &t in &self.terms {
            let v = match t {
                Term::Var(i) => vars[i as usize],
                t => eval_one(t, |i| out[i as usize]),
            };
            out.push(v);
        }
        out
    }
}

/// One term's enclosure from its operands' (`at`).
fn eval_one(t: Term, at: impl Fn(TermId) -> Interval) -> Interval {
    {
        match t {
            Term::Const(c) => c,
            Term::Var(_) => Interval::ENTIRE,
            Term::Add(a, b) => at(a) + at(b),
            Term::Sub(a, b) => at(a) - at(b),
            Term::Mul(a, b) => at(a) * at(b),
            Term::Div(a, b) => at(a) / at(b),
            Term::Neg(a) => -at(a),
            Term::Powi(a, n) => at(a).powi(n),
            Term::Pow(a, b) => at(a).pow(at(b)),
            Term::Min(a, b) => at(a).min(at(b)),
            Term::Max(a, b) => at(a).max(at(b)),
            Term::Choose(c, p, q) => Interval::choose(at(c), at(p), at(q)),
            Term::Call(f, a) => {
                let a = at(a);
                match f {
                    Func::Sqrt => a.sqrt(),
                    Func::Abs => a.abs(),
                    Func::Sin => a.sin(),
                    Func::Cos => a.cos(),
                    Func::Tan => a.tan(),
                    Func::Asin => a.asin(),
                    Func::Acos => a.acos(),
                    Func::Atan => a.atan(),
                    Func::Exp => a.exp(),
                    Func::Ln => a.ln(),
                    Func::Sinh => a.sinh(),
                    Func::Cosh => a.cosh(),
                    Func::Tanh => a.tanh(),
                    Func::Sech => a.sech(),
                    Func::Sign => a.sign(),
                    Func::Dirac => a.dirac(),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(text: &str, p: [f64; 3], var: u8) -> Interval {
        let (mut terms, f) = Terms::read(text, None).unwrap();
        let d = terms.derivative(f, var).unwrap();
        let v = p.map(Interval::point);
        terms.eval(&[v[0], v[1], v[2], Interval::ZERO])[d as usize]
    }

    /// Each rule against a central difference at a point where f is smooth.
    #[test]
    fn derivatives_match_finite_differences() {
        let cases = [
            "x^3*y - z/(1+x^2)",
            "sqrt(1+x^2+y^2) + abs(z-3)",
            "sin(x)*cos(y) + tan(z/3) + asin(x/3) + acos(y/4) + atan(x*z)",
            "exp(-x^2) + ln(2+y) + log(3+z) + sinh(x) + cosh(y) + tanh(z) + sech(x*y)",
            "min(x, y^2, z) + max(x*y, 1) + hypot(x, z) + pow(1+x^2, 0.3) + (2+y)^z",
            "let r = x^2 + y^2; let s = r*r; s - 2*r + subtract(x, y) + union(z, y) + intersect(x, z)",
            "-ln(exp(-8*(x^2 + y^2 - 1)) + exp(-8*(z - x*y)))/8",
        ];
        let p = [0.31, -0.47, 0.73];
        for text in cases {
            let (terms, f) = Terms::read(text, None).unwrap();
            let value = |q: [f64; 3]| {
                let v = terms.eval(&[q[0], q[1], q[2], 0.0].map(Interval::point));
                v[f as usize].mid()
            };
            for var in 0..3u8 {
                let h = 1e-6;
                let (mut lo, mut hi) = (p, p);
                lo[var as usize] -= h;
                hi[var as usize] += h;
                let fd = (value(hi) - value(lo)) / (2.0 * h);
                let d = at(text, p, var);
                assert!(
                    d.contains(fd) || (d.mid() - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                    "{text} d/d{var}: {d:?} vs {fd}"
                );
            }
        }
    }

    #[test]
    fn second_derivatives_along_a_ray_match_finite_differences() {
        let text = "sin(x*y) + exp(z)*x^3 - sqrt(1 + y^2)";
        let (o, d) = ([0.2, -0.1, 0.3], [0.6, 0.8, -0.5]);
        let (mut terms, f) = Terms::read(text, Some((o, d))).unwrap();
        let g = terms.derivative(f, 3).unwrap();
        let g2 = terms.derivative(g, 3).unwrap();
        let value = |t: f64| {
            terms.eval(&[
                Interval::ZERO,
                Interval::ZERO,
                Interval::ZERO,
                Interval::point(t),
            ])[f as usize]
                .mid()
        };
        let t = 0.4;
        let h = 1e-4;
        let fd = (value(t + h) - 2.0 * value(t) + value(t - h)) / (h * h);
        let v = terms.eval(&[
            Interval::ZERO,
            Interval::ZERO,
            Interval::ZERO,
            Interval::point(t),
        ])[g2 as usize];
        assert!((v.mid() - fd).abs() < 1e-5, "{v:?} vs {fd}");
    }

    #[test]
    fn kinks_give_hulls_and_a_second_derivative_there_is_unbounded() {
        // |x|' over an interval holding 0 is [-1, 1].
        let (mut terms, f) = Terms::read("abs(x)", None).unwrap();
        let d = terms.derivative(f, 0).unwrap();
        let v = terms.eval(&[
            Interval::new(-1.0, 2.0),
            Interval::ZERO,
            Interval::ZERO,
            Interval::ZERO,
        ]);
        assert_eq!(v[d as usize], Interval::new(-1.0, 1.0));
        let d2 = terms.derivative(d, 0).unwrap();
        let v = terms.eval(&[
            Interval::new(-1.0, 2.0),
            Interval::ZERO,
            Interval::ZERO,
            Interval::ZERO,
        ]);
        assert!(!v[d2 as usize].is_bounded());
        assert!(matches!(
            terms.derivative(d2, 0),
            Err(TermError::NoDerivative)
        ));
    }

    #[test]
    fn functions_outside_the_checked_language_are_located() {
        let Err(TermError::Formula(e)) = Terms::read("x + floor(y)", None) else {
            panic!("floor read");
        };
        assert_eq!(e.span, 4..9, "the caret is under `floor`");
        let c = Terms::constant_of("2*sqrt(3)").unwrap().unwrap();
        assert!(c.contains(2.0 * 3f64.sqrt()) && c.wid() < 1e-15);
        assert_eq!(Terms::constant_of("x").unwrap(), None);
    }
}
