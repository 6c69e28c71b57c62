//! A surface formula with its derivatives: the unit every later stage works on.

use crate::expr::specialise::{self, Branch, BranchPoint};
use crate::expr::{Context, GraphTooLarge, Node, Tape, Var};
use crate::lang::ast::AstKind;
use crate::lang::{ErrorKind, FormulaError};
use std::sync::Arc;

/// The quantities lgc derives from a formula `f(x, y, z)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Output {
    /// f itself.
    F,
    /// ∂f/∂x.
    Dfdx,
    /// ∂f/∂y.
    Dfdy,
    /// ∂f/∂z.
    Dfdz,
    /// g = d·∇f, the derivative of f along the ray direction d = (dx, dy, dz).
    G,
    /// g′ = dᵀHd, the derivative of g along d (H is the Hessian of f).
    Dg,
    /// ∂²f/∂x².
    Hxx,
    /// ∂²f/∂y².
    Hyy,
    /// ∂²f/∂z².
    Hzz,
    /// ∂²f/∂x∂y.
    Hxy,
    /// ∂²f/∂x∂z.
    Hxz,
    /// ∂²f/∂y∂z.
    Hyz,
}

impl Output {
    /// Every output, in the order f, ∂f/∂x, ∂f/∂y, ∂f/∂z, g, g′.
    pub const ALL: [Output; 6] = [
        Output::F,
        Output::Dfdx,
        Output::Dfdy,
        Output::Dfdz,
        Output::G,
        Output::Dg,
    ];

    /// The six distinct entries of the Hessian: xx, yy, zz, xy, xz, yz.
    pub const HESSIAN: [Output; 6] = [
        Output::Hxx,
        Output::Hyy,
        Output::Hzz,
        Output::Hxy,
        Output::Hxz,
        Output::Hyz,
    ];
}

/// A parsed surface formula `f(x, y, z)` with its symbolic derivatives.
#[derive(Debug, Clone)]
pub struct Formula {
    /// Shared: a copy of a formula (each bounder holds one) costs nothing.
    ctx: Arc<Context>,
    f: Node,
    grad: [Node; 3],
    g: Node,
    dg: Node,
    hessian: [Node; 6],
}

impl Formula {
    /// Parses `source` and derives ∇f, g and g′.
    ///
    /// ```
    /// let f = lgc::Formula::parse("x^2 + y^2 + z^2 - 1").unwrap();
    /// let text: Vec<String> = f.gradient().iter().map(|&d| f.print(d)).collect();
    /// assert_eq!(text, ["2*x", "2*y", "2*z"]);
    /// ```
    pub fn parse(source: &str) -> Result<Formula, FormulaError> {
        let ast = crate::lang::parse(source)?;
        if let Some(node) = ast.nodes().find(|n| {
            matches!(&n.kind, AstKind::Name(name) if matches!(Var::from_name(name), Some(Var::Dx | Var::Dy | Var::Dz)))
        }) {
            return Err(FormulaError::new(
                ErrorKind::DirectionInSurface,
                node.span.clone(),
                "a surface formula depends on x, y and z only",
            )
            .with_label("dx, dy and dz name the ray direction in printed derivatives"));
        }
        let mut ctx = Context::new();
        let f = crate::lang::lower(&mut ctx, &ast)?;
        // The syntax tree is as large as the graph: not kept while deriving.
        drop(ast);
        Formula::from_node(ctx, f).map_err(|e| derivatives_too_large(source, e))
    }

    /// Reads a model in fidget's `.vm` format (one operation per line, the
    /// last the surface; see [`crate::lang::parse_vm`]) and derives ∇f, g
    /// and g′.
    ///
    /// ```
    /// let f = lgc::Formula::parse_vm("_0 var-x\n_1 var-y\n_2 max _0 _1\n").unwrap();
    /// assert_eq!(f.print(f.f()), "max(x, y)");
    /// ```
    pub fn parse_vm(source: &str) -> Result<Formula, FormulaError> {
        let mut ctx = Context::new();
        let f = crate::lang::parse_vm(&mut ctx, source)?;
        Formula::from_node(ctx, f).map_err(|e| derivatives_too_large(source, e))
    }

    /// Derives ∇f, g, g′ and the Hessian for the node `f` of `ctx`; `Err`
    /// when `ctx` has passed its node limit, before or while deriving.
    pub fn from_node(mut ctx: Context, f: Node) -> Result<Formula, GraphTooLarge> {
        ctx.check_size()?;
        let (grad, g, hessian) = first_and_second_derivatives(&mut ctx, f);
        let dg = ctx.directional(g);
        ctx.check_size()?;
        Ok(Formula {
            ctx: Arc::new(ctx),
            f,
            grad,
            g,
            dg,
            hessian,
        })
    }

    /// The graph holding f and its derivatives.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// The node of `output`.
    pub fn node(&self, output: Output) -> Node {
        match output {
            Output::F => self.f,
            Output::Dfdx => self.grad[0],
            Output::Dfdy => self.grad[1],
            Output::Dfdz => self.grad[2],
            Output::G => self.g,
            Output::Dg => self.dg,
            Output::Hxx => self.hessian[0],
            Output::Hyy => self.hessian[1],
            Output::Hzz => self.hessian[2],
            Output::Hxy => self.hessian[3],
            Output::Hxz => self.hessian[4],
            Output::Hyz => self.hessian[5],
        }
    }

    /// f.
    pub fn f(&self) -> Node {
        self.f
    }

    /// ∂f/∂x, ∂f/∂y, ∂f/∂z.
    pub fn gradient(&self) -> [Node; 3] {
        self.grad
    }

    /// g = d·∇f, with the direction as the inputs dx, dy, dz.
    pub fn g(&self) -> Node {
        self.g
    }

    /// g′ = dᵀHd.
    pub fn dg(&self) -> Node {
        self.dg
    }

    /// One tape computing `outputs`, in that order.
    pub fn tape(&self, outputs: &[Output]) -> Tape {
        let nodes: Vec<Node> = outputs.iter().map(|&o| self.node(o)).collect();
        Tape::new(&self.ctx, &nodes)
    }

    /// The branch points of f (`min`, `max`, `abs`, `sign`, `choose`,
    /// `dirac`), children before parents.
    pub fn branch_points(&self) -> Vec<BranchPoint> {
        specialise::branch_points(&self.ctx, self.f)
    }

    /// f with the branch points of [`Formula::branch_points`] decided as
    /// `branches` say, derived anew: on a region where those branches hold,
    /// the same function, with derivatives free of the creases decided away.
    /// `None` when its derivatives would pass the node limit (see
    /// [`crate::expr::MAX_NODES`]): f itself then serves.
    pub fn specialised(&self, points: &[BranchPoint], branches: &[Branch]) -> Option<Formula> {
        let (ctx, f) = specialise::specialise(&self.ctx, self.f, points, branches);
        Formula::from_node(ctx, f).ok()
    }

    /// `node` as formula text that parses back to the same function.
    pub fn print(&self, node: Node) -> String {
        crate::expr::to_source(&self.ctx, node)
    }
}

/// ∇f, g = d·∇f and the Hessian (xx, yy, zz, xy, xz, yz) of `f`, derived
/// in `ctx`: all but g′, which the octree's shapes never read.
pub(crate) fn first_and_second_derivatives(
    ctx: &mut Context,
    f: Node,
) -> ([Node; 3], Node, [Node; 6]) {
    let (grad, g) = first_derivatives(ctx, f);
    let [fx, fy, fz] = grad;
    let hessian = [
        ctx.partial(fx, Var::X),
        ctx.partial(fy, Var::Y),
        ctx.partial(fz, Var::Z),
        ctx.partial(fx, Var::Y),
        ctx.partial(fx, Var::Z),
        ctx.partial(fy, Var::Z),
    ];
    (grad, g, hessian)
}

/// ∇f and g = d·∇f of `f`, derived in `ctx`.
pub(crate) fn first_derivatives(ctx: &mut Context, f: Node) -> ([Node; 3], Node) {
    let grad = [Var::X, Var::Y, Var::Z].map(|v| ctx.partial(f, v));
    (grad, ctx.directional(f))
}

/// The error of a formula whose derivatives pass the node limit, at the
/// formula's first character.
fn derivatives_too_large(source: &str, e: GraphTooLarge) -> FormulaError {
    let first = source
        .char_indices()
        .find(|(_, c)| !c.is_whitespace())
        .map_or(0, |(i, _)| i);
    let end = source[first..]
        .chars()
        .next()
        .map_or(first, |c| first + c.len_utf8());
    FormulaError::too_large(first..end, "the formula's derivatives", e)
        .with_label("in the derivatives of this formula")
}
