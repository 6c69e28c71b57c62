//! Graph to formula text, in lgc's own syntax, so that what is printed parses back.
//!
//! Parentheses appear only where precedence needs them. A subexpression used
//! more than once (common in derivatives) is printed once, as a `let` binding,
//! so the text stays as small as the graph instead of growing exponentially.
//! The printer walks with an explicit stack and writes into one buffer.

use crate::expr::{BinaryOp, Context, Node, Op, UnaryOp};
use rustc_hash::FxHashMap;

/// Precedence levels, loosest first.
const SUM: u8 = 1;
const PRODUCT: u8 = 2;
const UNARY: u8 = 3;
const POWER: u8 = 4;
const ATOM: u8 = 5;

/// Shared subexpressions at least this large (in printed nodes) get a `let`.
const SHARE_MIN_SIZE: usize = 4;

/// Formats a constant so that it parses back to the same f64.
pub fn format_number(v: f64) -> String {
    if v == std::f64::consts::PI {
        return "pi".into();
    }
    if v == std::f64::consts::E {
        return "e".into();
    }
    if v == v.trunc() && v.abs() < 1e15 {
        return format!("{}", v as i64);
    }
    // Debug gives the shortest text that round-trips, in exponent form for
    // very large or small magnitudes (`1e-7`, `1.5e20`), which lgc reads.
    format!("{v:?}")
}

fn precedence(ctx: &Context, node: Node) -> u8 {
    match *ctx.get(node) {
        Op::Const(c) if c.value() < 0.0 => UNARY,
        Op::Const(_) | Op::Var(_) | Op::Choose(..) | Op::Remap(..) => ATOM,
        Op::Unary(UnaryOp::Neg, _) => UNARY,
        Op::Unary(..) => ATOM,
        Op::Binary(BinaryOp::Add | BinaryOp::Sub, ..) => SUM,
        Op::Binary(BinaryOp::Mul | BinaryOp::Div, ..) => PRODUCT,
        Op::Binary(BinaryOp::Pow, ..) | Op::PowI(..) => POWER,
        Op::Binary(..) => ATOM,
    }
}

enum Task {
    Node(Node, u8),
    Text(&'static str),
    Owned(String),
}

/// Prints `root` as formula text that parses back to the same function.
///
/// ```
/// let f = lgc::Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
/// let [dx, _, _] = f.gradient();
/// assert_eq!(lgc::to_source(f.context(), dx), "2*x");
/// ```
pub fn to_source(ctx: &Context, root: Node) -> String {
    let order = ctx.topological_order(&[root]);
    let mut uses: FxHashMap<Node, usize> = FxHashMap::default();
    for &n in &order {
        for c in ctx.get(n).children() {
            *uses.entry(c).or_default() += 1;
        }
    }
    // Decide the shared nodes bottom-up: a node's printed size counts a named
    // child as one.
    let mut size: FxHashMap<Node, usize> = FxHashMap::default();
    let mut names: FxHashMap<Node, String> = FxHashMap::default();
    let mut lets: Vec<Node> = Vec::new();
    for &n in &order {
        let s = 1 + ctx
            .get(n)
            .children()
            .map(|c| if names.contains_key(&c) { 1 } else { size[&c] })
            .sum::<usize>();
        size.insert(n, s);
        if n != root && uses.get(&n).copied().unwrap_or(0) >= 2 && s >= SHARE_MIN_SIZE {
            names.insert(n, format!("s{}", lets.len() + 1));
            lets.push(n);
        }
    }
    let mut out = String::new();
    for &n in &lets {
        out.push_str("let ");
        out.push_str(&names[&n]);
        out.push_str(" = ");
        write_expr(ctx, n, &names, &mut out);
        out.push_str("; ");
    }
    write_expr(ctx, root, &names, &mut out);
    out
}

fn write_expr(ctx: &Context, root: Node, names: &FxHashMap<Node, String>, out: &mut String) {
    let mut stack = vec![Task::Node(root, 0)];
    let mut top = true;
    while let Some(task) = stack.pop() {
        let (node, min) = match task {
            Task::Text(t) => {
                out.push_str(t);
                continue;
            }
            Task::Owned(t) => {
                out.push_str(&t);
                continue;
            }
            Task::Node(node, min) => (node, min),
        };
        if !top {
            if let Some(name) = names.get(&node) {
                out.push_str(name);
                continue;
            }
        }
        top = false;
        let parens = precedence(ctx, node) < min;
        if parens {
            out.push('(');
            stack.push(Task::Text(")"));
        }
        // Tasks are pushed in reverse: the last pushed is written first.
        match *ctx.get(node) {
            Op::Const(c) => out.push_str(&format_number(c.value())),
            Op::Var(v) => out.push_str(v.name()),
            Op::Unary(UnaryOp::Neg, a) => {
                stack.push(Task::Node(a, UNARY));
                out.push('-');
            }
            Op::Unary(op, a) => {
                stack.push(Task::Text(")"));
                stack.push(Task::Node(a, 0));
                out.push_str(op.name());
                out.push('(');
            }
            Op::PowI(a, n) => {
                stack.push(Task::Owned(format!("^{n}")));
                stack.push(Task::Node(a, ATOM));
            }
            Op::Binary(op, a, b) => {
                let (symbol, left, right) = match op {
                    BinaryOp::Add => ("+", SUM, PRODUCT),
                    BinaryOp::Sub => ("-", SUM, PRODUCT),
                    BinaryOp::Mul => ("*", PRODUCT, UNARY),
                    BinaryOp::Div => ("/", PRODUCT, UNARY),
                    // ^ is right-associative and its exponent is a unary.
                    BinaryOp::Pow => ("^", ATOM, UNARY),
                    BinaryOp::Min => ("min", 0, 0),
                    BinaryOp::Max => ("max", 0, 0),
                    BinaryOp::Atan2 => ("atan2", 0, 0),
                };
                // c*(p*q) and c*(p/q) print without parentheses when p is not a
                // constant: the parser pulls c outward again, rebuilding the
                // same graph.
                let leads_with_variable = |n: Node| match *ctx.get(n) {
                    Op::Binary(BinaryOp::Mul | BinaryOp::Div, p, _) => ctx.const_value(p).is_none(),
                    _ => false,
                };
                let right = if op == BinaryOp::Mul
                    && ctx.const_value(a).is_some()
                    && leads_with_variable(b)
                {
                    PRODUCT
                } else {
                    right
                };
                if left == 0 {
                    stack.push(Task::Text(")"));
                    stack.push(Task::Node(b, 0));
                    stack.push(Task::Text(", "));
                    stack.push(Task::Node(a, 0));
                    out.push_str(symbol);
                    out.push('(');
                } else {
                    stack.push(Task::Node(b, right));
                    stack.push(Task::Text(symbol));
                    stack.push(Task::Node(a, left));
                }
            }
            Op::Choose(c, p, n) => {
                stack.push(Task::Text(")"));
                stack.push(Task::Node(n, 0));
                stack.push(Task::Text(", "));
                stack.push(Task::Node(p, 0));
                stack.push(Task::Text(", "));
                stack.push(Task::Node(c, 0));
                out.push_str("choose(");
            }
            Op::Remap(..) => unreachable!("{}", super::context::UNEXPANDED),
        }
    }
}
