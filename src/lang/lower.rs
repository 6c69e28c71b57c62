//! Syntax tree to expression graph: names resolved, calls checked, `let`s inlined.

use super::ast::{Ast, AstId, AstKind, BinOp, Binding, FunctionDef, Span};
use super::error::{ErrorKind, FormulaError};
use super::functions::{self, CONSTANTS, FUNCTIONS};
use crate::expr::csg;
use crate::expr::{BinaryOp, Context, Evaluator, Node, Tape, UnaryOp, Var};
use crate::types::Interval;
use rustc_hash::FxHashMap;
use std::cell::Cell;
use std::rc::Rc;

/// User functions may call one another at most this deep; lowering recurses
/// once per level, so the limit also bounds the stack.
pub const MAX_CALL_DEPTH: usize = 64;

/// Names visible to an expression: values (bindings, parameters) and user
/// functions.
#[derive(Default, Clone)]
pub struct Scope<'a> {
    /// Bound values.
    pub values: FxHashMap<&'a str, Node>,
    /// User functions of a scene file.
    pub functions: FxHashMap<&'a str, &'a FunctionDef>,
    /// Syntax nodes lowered so far, shared by every scope cloned from this
    /// one: user functions may call each other into work exponential in the
    /// text (each calling the next twice), which hash-consing alone would
    /// not bound.
    steps: Rc<Cell<usize>>,
}

/// The most syntax nodes one formula or scene may lower, counting a user
/// function's body once per call: twice [`super::MAX_TOKENS`], some seconds.
pub const MAX_LOWERING_STEPS: usize = 1 << 24;

/// Builds the graph of a parsed program in `ctx` and returns its root.
///
/// `let` bindings are inlined (hash-consing shares their uses). Walks the
/// tree with an explicit stack.
pub fn lower(ctx: &mut Context, ast: &Ast) -> Result<Node, FormulaError> {
    let mut scope = Scope::default();
    for (i, binding) in ast.bindings.iter().enumerate() {
        let name = binding.name.as_str();
        check_bindable(name, &binding.name_span)?;
        let value = lower_expr(ctx, ast, binding.value, &scope, &ast.bindings[i + 1..])?;
        scope.values.insert(name, value);
    }
    let body = ast
        .body
        .expect("the parser sets the body of every program it accepts");
    let lazy = lower_expr(ctx, ast, body, &scope, &[])?;
    let f = ctx.expand(lazy);
    ctx.check_size()
        .map_err(|e| FormulaError::too_large(ast.node(body).span.clone(), "the formula", e))?;
    Ok(f)
}

/// Rejects a binding or parameter name that is built in.
pub fn check_bindable(name: &str, span: &Span) -> Result<(), FormulaError> {
    if Var::from_name(name).is_some()
        || functions::constant(name).is_some()
        || functions::function(name).is_some()
    {
        return Err(FormulaError::new(
            ErrorKind::ReservedName,
            span.clone(),
            format!("`{name}` is built in and cannot be rebound"),
        )
        .with_label("choose another name"));
    }
    Ok(())
}

/// Lowers one expression of `ast` with the names of `scope` visible. The
/// result may hold transforms still to expand: bind it as it is, and pass
/// it through [`Context::expand`] before using it.
pub fn lower_in(
    ctx: &mut Context,
    ast: &Ast,
    root: AstId,
    scope: &Scope,
) -> Result<Node, FormulaError> {
    lower_expr_at(ctx, ast, root, scope, &[], 0)
}

fn lower_expr(
    ctx: &mut Context,
    ast: &Ast,
    root: AstId,
    scope: &Scope,
    later: &[Binding],
) -> Result<Node, FormulaError> {
    lower_expr_at(ctx, ast, root, scope, later, 0)
}

fn lower_expr_at(
    ctx: &mut Context,
    ast: &Ast,
    root: AstId,
    scope: &Scope,
    later: &[Binding],
    depth: usize,
) -> Result<Node, FormulaError> {
    let mut done: FxHashMap<AstId, Node> = FxHashMap::default();
    let mut stack = vec![(root, false)];
    while let Some((id, expanded)) = stack.pop() {
        if !expanded {
            stack.push((id, true));
            stack.extend(ast.children(id).into_iter().rev().map(|c| (c, false)));
            continue;
        }
        let node = ast.node(id);
        scope.steps.set(scope.steps.get() + 1);
        if scope.steps.get() > MAX_LOWERING_STEPS {
            return Err(FormulaError::new(
                ErrorKind::TooLarge,
                node.span.clone(),
                format!(
                    "too large to build: user functions expand to more than {MAX_LOWERING_STEPS} operations"
                ),
            )
            .with_label("the limit was reached here")
            .with_note("each call of a user function lowers its body anew: call them fewer times"));
        }
        let value = match &node.kind {
            AstKind::Number(v) => ctx.constant(*v),
            AstKind::Name(name) => resolve_name(ctx, name, &node.span, &scope.values, later)?,
            AstKind::Tuple(_) => {
                return Err(FormulaError::new(
                    ErrorKind::WrongType,
                    node.span.clone(),
                    "a tuple is not a number",
                )
                .with_label("expected a number or a formula here")
                .with_note("tuples such as (1, 2, 3) give vectors and boxes in scene files"))
            }
            AstKind::Neg(a) => ctx.neg(done[a]),
            AstKind::Binary(op, a, b) => {
                let (a, b) = (done[a], done[b]);
                match op {
                    BinOp::Add => ctx.add(a, b),
                    BinOp::Sub => ctx.sub(a, b),
                    BinOp::Mul => ctx.mul(a, b),
                    BinOp::Div => ctx.div(a, b),
                    BinOp::Pow => ctx.pow(a, b),
                }
            }
            AstKind::Call {
                name,
                name_span,
                args,
            } => {
                let spans: Vec<&Span> = args.iter().map(|&a| &ast.node(a).span).collect();
                let args: Vec<Node> = args.iter().map(|a| done[a]).collect();
                if let Some(def) = scope.functions.get(name.as_str()) {
                    call_user(ctx, ast, def, name_span, &node.span, &args, scope, depth)?
                } else {
                    positive_arguments(ctx, name, &spans, &args)?;
                    call(ctx, name, name_span, &node.span, &args, &scope.values)?
                }
            }
        };
        ctx.check_size()
            .map_err(|e| FormulaError::too_large(node.span.clone(), "the formula", e))?;
        done.insert(id, value);
    }
    Ok(done[&root])
}

fn resolve_name(
    ctx: &mut Context,
    name: &str,
    span: &Span,
    env: &FxHashMap<&str, Node>,
    later: &[Binding],
) -> Result<Node, FormulaError> {
    if let Some(var) = Var::from_name(name) {
        return Ok(ctx.var(var));
    }
    if let Some(value) = functions::constant(name) {
        return Ok(ctx.constant(value));
    }
    if let Some(&node) = env.get(name) {
        return Ok(node);
    }
    if let Some(f) = functions::function(name) {
        return Err(FormulaError::new(
            ErrorKind::MissingArguments,
            span.clone(),
            format!("`{name}` is a function and needs arguments"),
        )
        .with_label(format!("call it as {}", f.usage)));
    }
    if later.iter().any(|b| b.name == name) {
        return Err(FormulaError::new(
            ErrorKind::UnknownName,
            span.clone(),
            format!("`{name}` is used before its `let`"),
        )
        .with_label("defined only further down")
        .with_note("a binding can use only the bindings above it"));
    }
    let known = Var::ALL
        .iter()
        .map(|v| v.name())
        .chain(CONSTANTS.iter().map(|(n, _)| *n))
        .chain(env.keys().copied());
    let mut err = FormulaError::new(
        ErrorKind::UnknownName,
        span.clone(),
        format!("unknown name `{name}`"),
    );
    err = match functions::closest(name, known) {
        Some(s) => err.with_label(format!("did you mean `{s}`?")),
        None => err.with_label("expected a variable (x, y, z), a constant (pi, e) or a `let` name"),
    };
    Err(err)
}

/// Inlines a call of a user function: its body, lowered with the parameters
/// bound to the arguments.
#[allow(clippy::too_many_arguments)]
fn call_user(
    ctx: &mut Context,
    ast: &Ast,
    def: &FunctionDef,
    name_span: &Span,
    span: &Span,
    args: &[Node],
    scope: &Scope,
    depth: usize,
) -> Result<Node, FormulaError> {
    if args.len() != def.params.len() {
        let n = def.params.len();
        return Err(FormulaError::new(
            ErrorKind::WrongArity,
            span.clone(),
            format!(
                "`{}` takes {n} argument{}, but {} {} given",
                def.name,
                if n == 1 { "" } else { "s" },
                args.len(),
                if args.len() == 1 { "was" } else { "were" }
            ),
        )
        .with_related(def.name_span.clone(), "defined here"));
    }
    if depth >= MAX_CALL_DEPTH {
        return Err(FormulaError::new(
            ErrorKind::TooDeep,
            name_span.clone(),
            format!("user functions call each other more than {MAX_CALL_DEPTH} deep"),
        ));
    }
    let mut inner = scope.clone();
    for ((param, _), &arg) in def.params.iter().zip(args) {
        inner.values.insert(param.as_str(), arg);
    }
    lower_expr_at(ctx, ast, def.body, &inner, &[], depth + 1)
}

/// Checks the arguments that must be positive (`scale`'s factor, `blend`'s
/// radius) where they are constants: 0 or less would divide by 0 or turn
/// the blend inside out.
fn positive_arguments(
    ctx: &Context,
    name: &str,
    spans: &[&Span],
    args: &[Node],
) -> Result<(), FormulaError> {
    let (index, what) = match (name, args.len()) {
        ("scale", 2) => (1, "the factor s"),
        ("blend", 3) => (2, "the radius r"),
        _ => return Ok(()),
    };
    match enclose_constant(ctx, args[index]) {
        Ok(v) if v.inf() <= 0.0 => Err(FormulaError::new(
            ErrorKind::OutOfRange,
            spans[index].clone(),
            format!("`{name}` needs {what} > 0"),
        )
        .with_label(if v.sup() <= 0.0 {
            "not positive".to_string()
        } else {
            "may not be positive".to_string()
        })),
        _ => Ok(()),
    }
}

fn call(
    ctx: &mut Context,
    name: &str,
    name_span: &Span,
    span: &Span,
    args: &[Node],
    env: &FxHashMap<&str, Node>,
) -> Result<Node, FormulaError> {
    let Some(f) = functions::function(name) else {
        if Var::from_name(name).is_some()
            || functions::constant(name).is_some()
            || env.contains_key(name)
        {
            return Err(FormulaError::new(
                ErrorKind::NotAFunction,
                name_span.clone(),
                format!("`{name}` is not a function"),
            )
            .with_label("a value cannot be called")
            .with_note(format!("to multiply, write `{name}*(...)`")));
        }
        let err = FormulaError::new(
            ErrorKind::UnknownFunction,
            name_span.clone(),
            format!("unknown function `{name}`"),
        );
        return Err(
            match functions::closest(name, FUNCTIONS.iter().map(|f| f.name)) {
                Some(s) => {
                    let err = FormulaError {
                        message: format!("unknown function `{name}`, did you mean `{s}`?"),
                        ..err
                    };
                    err.with_label(format!("did you mean `{s}`?"))
                }
                None => err.with_label("not a built-in function"),
            }
            .with_note("`lgc --help` lists the functions"),
        );
    };
    if !f.arity.accepts(args.len()) {
        return Err(FormulaError::new(
            ErrorKind::WrongArity,
            span.clone(),
            format!(
                "`{name}` takes {}, but {} {} given",
                f.arity.describe(),
                args.len(),
                if args.len() == 1 { "was" } else { "were" }
            ),
        )
        .with_label(format!("expected {}", f.usage)));
    }
    let unary = |ctx: &mut Context, op| ctx.unary(op, args[0]);
    Ok(match name {
        "sqrt" => unary(ctx, UnaryOp::Sqrt),
        "abs" => unary(ctx, UnaryOp::Abs),
        "sign" => unary(ctx, UnaryOp::Sign),
        "sin" => unary(ctx, UnaryOp::Sin),
        "cos" => unary(ctx, UnaryOp::Cos),
        "tan" => unary(ctx, UnaryOp::Tan),
        "asin" => unary(ctx, UnaryOp::Asin),
        "acos" => unary(ctx, UnaryOp::Acos),
        "atan" => unary(ctx, UnaryOp::Atan),
        "exp" => unary(ctx, UnaryOp::Exp),
        "ln" => unary(ctx, UnaryOp::Ln),
        "sinh" => unary(ctx, UnaryOp::Sinh),
        "cosh" => unary(ctx, UnaryOp::Cosh),
        "tanh" => unary(ctx, UnaryOp::Tanh),
        "sech" => unary(ctx, UnaryOp::Sech),
        "dirac" => unary(ctx, UnaryOp::Dirac),
        "floor" => unary(ctx, UnaryOp::Floor),
        "ceil" => unary(ctx, UnaryOp::Ceil),
        "round" => unary(ctx, UnaryOp::Round),
        "log" => {
            let ln = ctx.unary(UnaryOp::Ln, args[0]);
            let ten = ctx.constant(10.0);
            let ln10 = ctx.unary(UnaryOp::Ln, ten);
            ctx.div(ln, ln10)
        }
        "atan2" => ctx.binary(BinaryOp::Atan2, args[0], args[1]),
        // fidget's (floored) modulo: the result takes the sign of b.
        "mod" => ctx.modulo(args[0], args[1]),
        "pow" => ctx.pow(args[0], args[1]),
        "hypot" => {
            let a2 = ctx.powi(args[0], 2);
            let b2 = ctx.powi(args[1], 2);
            let s = ctx.add(a2, b2);
            ctx.unary(UnaryOp::Sqrt, s)
        }
        // CSG union and intersection are min and max of the solids' fields.
        "min" | "max" | "union" | "intersect" => {
            let op = if matches!(name, "min" | "union") {
                BinaryOp::Min
            } else {
                BinaryOp::Max
            };
            args[1..]
                .iter()
                .fold(args[0], |acc, &a| ctx.binary(op, acc, a))
        }
        "choose" => ctx.choose(args[0], args[1], args[2]),
        "subtract" => {
            let nb = ctx.neg(args[1]);
            ctx.binary(BinaryOp::Max, args[0], nb)
        }
        "blend" => csg::blend(ctx, args[0], args[1], args[2]),
        "translate" => csg::translated(ctx, args[0], [args[1], args[2], args[3]]),
        "scale" => csg::scaled(ctx, args[0], args[1]),
        "rotate" => csg::rotated(ctx, args[0], [args[1], args[2], args[3]]),
        _ => unreachable!("function `{name}` is in the table but not lowered"),
    })
}

/// Why a constant expression (a scene field, a claimed bound) has no value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotConstant {
    /// It depends on x, y or z (or the ray direction).
    DependsOnCoordinates,
    /// Its value is unbounded, undefined or not finite.
    NotFinite,
}

/// Encloses the value of `node`, an expression of no variable, so that its
/// own rounding is accounted for (`0.1*3` is not the f64 product).
pub fn enclose_constant(ctx: &Context, node: Node) -> Result<Interval, NotConstant> {
    if !ctx.vars_used(node).is_empty() {
        return Err(NotConstant::DependsOnCoordinates);
    }
    let tape = Tape::new(ctx, &[node]);
    let v = Evaluator::<Interval>::new(&tape).eval(&[Interval::point(0.0); 6])[0];
    if v.is_bounded() && v.mid().is_finite() {
        Ok(v)
    } else {
        Err(NotConstant::NotFinite)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_are_enclosed_and_checked() {
        let mut ctx = Context::new();
        let ast = crate::lang::parse("0.1*3").unwrap();
        let c = lower(&mut ctx, &ast).unwrap();
        assert!(enclose_constant(&ctx, c)
            .unwrap()
            .contains(0.30000000000000004));
        let ast = crate::lang::parse("x + 1").unwrap();
        let v = lower(&mut ctx, &ast).unwrap();
        assert_eq!(
            enclose_constant(&ctx, v),
            Err(NotConstant::DependsOnCoordinates)
        );
        let ast = crate::lang::parse("1/0").unwrap();
        let v = lower(&mut ctx, &ast).unwrap();
        assert_eq!(enclose_constant(&ctx, v), Err(NotConstant::NotFinite));
    }
}
