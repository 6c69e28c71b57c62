//! fidget's `.vm` text format, read into the expression graph with every
//! mistake located by line and column.
//!
//! A model is one SSA operation per line, `_id op arg…`: `_0 const 2.5`,
//! `_1 var-x`, `_2 mul _1 _0`. Blank lines and `#` comments are skipped; each
//! argument names an operation above it, and the last operation is the
//! surface. fidget's `compare`, `and`, `or` and `not` lower to `sign` and
//! products, and `mod` to `a − b·floor(a/b)`, as fidget computes them.
//!
//! ```
//! use lgc::expr::{to_source, Context};
//! let model = "# a sphere\n_0 var-x\n_1 square _0\n_2 var-y\n_3 square _2\n\
//!              _4 var-z\n_5 square _4\n_6 add _1 _3\n_7 add _6 _5\n\
//!              _8 const 1\n_9 sub _7 _8\n";
//! let mut ctx = Context::new();
//! let f = lgc::lang::parse_vm(&mut ctx, model).unwrap();
//! assert_eq!(to_source(&ctx, f), "x^2+y^2+z^2-1");
//!
//! let typo = "_0 var-x\n_1 mull _0 _0\n";
//! let err = lgc::lang::parse_vm(&mut ctx, typo).unwrap_err();
//! assert_eq!(err.message, "unknown operation `mull`, did you mean `mul`?");
//! assert!(err.render(typo, "bear.vm").contains("bear.vm:2:4"));
//! ```

use super::ast::Span;
use super::error::{ErrorKind, FormulaError};
use super::functions::closest;
use crate::expr::{BinaryOp, Context, Node, UnaryOp, Var};
use rustc_hash::FxHashMap;

/// What an operation of the format computes from its arguments.
#[derive(Clone, Copy)]
enum VmOp {
    /// A coordinate.
    Var(Var),
    /// A number, given as the operation's one argument.
    Const,
    /// A function of one operand.
    Unary(fn(&mut Context, Node) -> Node),
    /// A function of two operands.
    Binary(fn(&mut Context, Node, Node) -> Node),
}

/// Every operation of fidget's format, by name.
const OPERATIONS: &[(&str, VmOp)] = &[
    ("var-x", VmOp::Var(Var::X)),
    ("var-y", VmOp::Var(Var::Y)),
    ("var-z", VmOp::Var(Var::Z)),
    ("const", VmOp::Const),
    ("add", VmOp::Binary(|c, a, b| c.add(a, b))),
    ("sub", VmOp::Binary(|c, a, b| c.sub(a, b))),
    ("mul", VmOp::Binary(|c, a, b| c.mul(a, b))),
    ("div", VmOp::Binary(|c, a, b| c.div(a, b))),
    ("min", VmOp::Binary(|c, a, b| c.binary(BinaryOp::Min, a, b))),
    ("max", VmOp::Binary(|c, a, b| c.binary(BinaryOp::Max, a, b))),
    (
        "atan2",
        VmOp::Binary(|c, a, b| c.binary(BinaryOp::Atan2, a, b)),
    ),
    ("compare", VmOp::Binary(compare)),
    ("and", VmOp::Binary(and)),
    ("or", VmOp::Binary(or)),
    ("neg", VmOp::Unary(|c, a| c.neg(a))),
    ("square", VmOp::Unary(|c, a| c.powi(a, 2))),
    ("sqrt", VmOp::Unary(|c, a| c.unary(UnaryOp::Sqrt, a))),
    ("abs", VmOp::Unary(|c, a| c.unary(UnaryOp::Abs, a))),
    ("recip", VmOp::Unary(recip)),
    ("exp", VmOp::Unary(|c, a| c.unary(UnaryOp::Exp, a))),
    ("ln", VmOp::Unary(|c, a| c.unary(UnaryOp::Ln, a))),
    ("sin", VmOp::Unary(|c, a| c.unary(UnaryOp::Sin, a))),
    ("cos", VmOp::Unary(|c, a| c.unary(UnaryOp::Cos, a))),
    ("tan", VmOp::Unary(|c, a| c.unary(UnaryOp::Tan, a))),
    ("asin", VmOp::Unary(|c, a| c.unary(UnaryOp::Asin, a))),
    ("acos", VmOp::Unary(|c, a| c.unary(UnaryOp::Acos, a))),
    ("atan", VmOp::Unary(|c, a| c.unary(UnaryOp::Atan, a))),
    ("not", VmOp::Unary(not)),
    ("copy", VmOp::Unary(|_, a| a)),
    ("mod", VmOp::Binary(|c, a, b| c.modulo(a, b))),
    ("floor", VmOp::Unary(|c, a| c.unary(UnaryOp::Floor, a))),
    ("ceil", VmOp::Unary(|c, a| c.unary(UnaryOp::Ceil, a))),
    ("round", VmOp::Unary(|c, a| c.unary(UnaryOp::Round, a))),
];

/// `1/a`.
fn recip(ctx: &mut Context, a: Node) -> Node {
    let one = ctx.constant(1.0);
    ctx.div(one, a)
}

/// fidget's `compare`: −1, 0 or 1 as `a` is below, equal to or above `b`.
fn compare(ctx: &mut Context, a: Node, b: Node) -> Node {
    let d = ctx.sub(a, b);
    ctx.unary(UnaryOp::Sign, d)
}

/// 1 where `a` is not 0, 0 where it is: `|sign(a)|`.
fn nonzero(ctx: &mut Context, a: Node) -> Node {
    let s = ctx.unary(UnaryOp::Sign, a);
    ctx.unary(UnaryOp::Abs, s)
}

/// fidget's `and`: `b` where `a` is not 0, else 0.
fn and(ctx: &mut Context, a: Node, b: Node) -> Node {
    let keep = nonzero(ctx, a);
    ctx.mul(keep, b)
}

/// fidget's `or`: `a` where it is not 0, else `b`.
fn or(ctx: &mut Context, a: Node, b: Node) -> Node {
    let other = not(ctx, a);
    let second = ctx.mul(other, b);
    ctx.add(a, second)
}

/// fidget's `not`: 1 where `a` is 0, else 0.
fn not(ctx: &mut Context, a: Node) -> Node {
    let one = ctx.constant(1.0);
    let keep = nonzero(ctx, a);
    ctx.sub(one, keep)
}

/// The words of one line with their byte ranges in the whole source.
fn words(line: &str, start: usize) -> Vec<(&str, Span)> {
    let mut out = Vec::new();
    let mut at = 0;
    for word in line.split_whitespace() {
        let offset = at + line[at..].find(word).unwrap_or(0);
        out.push((word, start + offset..start + offset + word.len()));
        at = offset + word.len();
    }
    out
}

/// Reads a model in fidget's `.vm` format into `ctx`; the node of its last
/// operation, the surface.
pub fn parse_vm(ctx: &mut Context, source: &str) -> Result<Node, FormulaError> {
    let mut ids: FxHashMap<&str, Node> = FxHashMap::default();
    let mut last = None;
    let mut start = 0;
    for line in source.split_inclusive('\n') {
        let line_start = start;
        start += line.len();
        let code = line.split('#').next().unwrap_or("");
        let words = words(code, line_start);
        let Some(((id, id_span), rest)) = words.split_first() else {
            continue;
        };
        let Some(((op, op_span), args)) = rest.split_first() else {
            return Err(FormulaError::new(
                ErrorKind::UnexpectedEnd,
                id_span.end..id_span.end,
                format!("`{id}` has no operation"),
            )
            .with_label("expected an operation such as `add _1 _2`"));
        };
        let node = operation(ctx, &ids, (op, op_span), args)?;
        ctx.check_size()
            .map_err(|e| FormulaError::too_large(id_span.clone(), "the model", e))?;
        if ids.insert(id, node).is_some() {
            return Err(FormulaError::new(
                ErrorKind::RepeatedField,
                id_span.clone(),
                format!("`{id}` is defined twice"),
            )
            .with_label("each operation needs a name of its own"));
        }
        last = Some(node);
    }
    last.ok_or_else(|| {
        FormulaError::new(ErrorKind::EmptyInput, 0..0, "the model has no operation")
            .with_label("expected lines such as `_0 var-x`")
    })
}

/// The node one line computes: `op` applied to the operations `args` name.
fn operation(
    ctx: &mut Context,
    ids: &FxHashMap<&str, Node>,
    (op, op_span): (&str, &Span),
    args: &[(&str, Span)],
) -> Result<Node, FormulaError> {
    let Some(&(_, kind)) = OPERATIONS.iter().find(|(name, _)| *name == op) else {
        let names = OPERATIONS.iter().map(|(name, _)| *name);
        let mut err = FormulaError::new(
            ErrorKind::UnknownFunction,
            op_span.clone(),
            format!("unknown operation `{op}`"),
        );
        if let Some(near) = closest(op, names) {
            err.message = format!("unknown operation `{op}`, did you mean `{near}`?");
            err = err.with_label(format!("did you mean `{near}`?"));
        }
        return Err(err);
    };
    let arity = match kind {
        VmOp::Var(_) => 0,
        VmOp::Const | VmOp::Unary(_) => 1,
        VmOp::Binary(_) => 2,
    };
    if args.len() != arity {
        // At the first argument too many, or after the last one given.
        let span = match args.get(arity) {
            Some((_, extra)) => extra.clone(),
            None => {
                let end = args.last().map_or(op_span.end, |(_, s)| s.end);
                end..end
            }
        };
        let plural = if arity == 1 { "" } else { "s" };
        return Err(FormulaError::new(
            ErrorKind::WrongArity,
            span,
            format!("`{op}` takes {arity} argument{plural}, not {}", args.len()),
        )
        .with_label(format!("expected {arity} argument{plural}")));
    }
    let operand = |(name, span): &(&str, Span)| {
        ids.get(name).copied().ok_or_else(|| {
            FormulaError::new(
                ErrorKind::UnknownName,
                span.clone(),
                format!("`{name}` names no operation above this line"),
            )
            .with_label("an argument names an earlier operation")
        })
    };
    Ok(match kind {
        VmOp::Var(var) => ctx.var(var),
        VmOp::Const => {
            let (text, span) = &args[0];
            match text.parse::<f64>() {
                Ok(v) if super::lexer::in_range(text, v) => ctx.constant(v),
                // (A number written out; `inf` and `nan` are no numbers.)
                Ok(_) if text.bytes().any(|b| b.is_ascii_digit()) => {
                    return Err(FormulaError::new(
                        ErrorKind::NumberOutOfRange,
                        span.clone(),
                        format!("`{text}` is beyond f64's range"),
                    )
                    .with_label("f64 holds magnitudes from about 4.9e-324 to 1.8e308, and 0"))
                }
                _ => {
                    return Err(FormulaError::new(
                        ErrorKind::MalformedNumber,
                        span.clone(),
                        format!("`{text}` is not a finite number"),
                    )
                    .with_label("expected a number such as 0.25"))
                }
            }
        }
        VmOp::Unary(f) => {
            let a = operand(&args[0])?;
            f(ctx, a)
        }
        VmOp::Binary(f) => {
            let (a, b) = (operand(&args[0])?, operand(&args[1])?);
            f(ctx, a, b)
        }
    })
}
