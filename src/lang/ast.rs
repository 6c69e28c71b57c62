//! The syntax tree of a formula, stored flat in an arena.
//!
//! Nodes refer to each other by [`AstId`], never by `Box`, so a formula nested
//! 100,000 levels deep is built, walked and dropped without recursion.

use std::ops::Range;

/// Byte range of a piece of source text.
pub type Span = Range<usize>;

/// Index of a node in an [`Ast`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AstId(pub u32);

/// A binary operator as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    /// `a + b`
    Add,
    /// `a - b`
    Sub,
    /// `a * b`
    Mul,
    /// `a / b`
    Div,
    /// `a ^ b`
    Pow,
}

/// One syntax node.
#[derive(Debug, Clone, PartialEq)]
pub enum AstKind {
    /// A number literal.
    Number(f64),
    /// A bare name: variable, constant or `let` binding.
    Name(String),
    /// A function call `name(args…)`; `name_span` covers the name alone.
    Call {
        /// The function name as written.
        name: String,
        /// Where the name alone stands.
        name_span: Span,
        /// The arguments, in order.
        args: Vec<AstId>,
    },
    /// A tuple `(a, b, …)` of two or more values: a vector or a box.
    Tuple(Vec<AstId>),
    /// Unary minus.
    Neg(AstId),
    /// A binary operation.
    Binary(BinOp, AstId, AstId),
}

/// A node together with the source text it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct AstNode {
    /// What the node is.
    pub kind: AstKind,
    /// The source text it came from.
    pub span: Span,
}

/// A `let name = value;` binding.
#[derive(Debug, Clone, PartialEq)]
pub struct Binding {
    /// The bound name.
    pub name: String,
    /// Where the name stands.
    pub name_span: Span,
    /// The bound expression.
    pub value: AstId,
}

/// A user function `fn name(params) = body;` of a scene file.
#[derive(Debug, Clone, PartialEq)]
pub struct FunctionDef {
    /// The function's name.
    pub name: String,
    /// Where the name stands.
    pub name_span: Span,
    /// Parameter names.
    pub params: Vec<(String, Span)>,
    /// The body.
    pub body: AstId,
}

/// One `field = value;` of a block.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// The field's name.
    pub name: String,
    /// Where the name stands.
    pub name_span: Span,
    /// The value.
    pub value: AstId,
}

/// A block `kind [label] { fields }` of a scene file.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// What it is: `camera`, `light`, `object`, `sphere`, …
    pub kind: String,
    /// Where the kind stands.
    pub kind_span: Span,
    /// An optional name (`material glass { … }`).
    pub label: Option<(String, Span)>,
    /// The fields, in order.
    pub fields: Vec<Field>,
    /// The whole block.
    pub span: Span,
}

/// A top-level item of a scene file, in source order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Item {
    /// Index into [`Ast::bindings`].
    Binding(usize),
    /// Index into [`Ast::functions`].
    Function(usize),
    /// Index into [`Ast::blocks`].
    Block(usize),
}

/// A parsed program: `let` bindings followed by the formula itself; or, for a
/// scene file, its items.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Ast {
    nodes: Vec<AstNode>,
    /// The bindings, in source order.
    pub bindings: Vec<Binding>,
    /// The final expression of a formula; `None` for a scene.
    pub body: Option<AstId>,
    /// User functions of a scene.
    pub functions: Vec<FunctionDef>,
    /// Blocks of a scene.
    pub blocks: Vec<Block>,
    /// A scene's items in source order.
    pub items: Vec<Item>,
}

impl Ast {
    /// Adds a node and returns its id.
    pub fn push(&mut self, kind: AstKind, span: Span) -> AstId {
        let id = AstId(u32::try_from(self.nodes.len()).expect("more than 2^32 syntax nodes"));
        self.nodes.push(AstNode { kind, span });
        id
    }

    /// The node behind `id`.
    pub fn node(&self, id: AstId) -> &AstNode {
        &self.nodes[id.0 as usize]
    }

    /// Every node, in creation order.
    pub fn nodes(&self) -> impl Iterator<Item = &AstNode> {
        self.nodes.iter()
    }

    /// Number of nodes stored.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when no node has been stored.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The ids of a node's direct children, in source order.
    pub fn children(&self, id: AstId) -> Vec<AstId> {
        match &self.node(id).kind {
            AstKind::Number(_) | AstKind::Name(_) => vec![],
            AstKind::Call { args, .. } | AstKind::Tuple(args) => args.clone(),
            AstKind::Neg(a) => vec![*a],
            AstKind::Binary(_, a, b) => vec![*a, *b],
        }
    }
}
