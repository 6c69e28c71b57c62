//! Constructive solid geometry and rigid transforms, as graph builders.
//!
//! Solids are `f ≤ 0`. Union, intersection and difference are `min`, `max` and
//! `max(a, -b)`; a blend is a smooth union. Transforms substitute the inverse
//! transform into the formula. Everything is an ordinary expression graph, so
//! derivatives, L and G come from the same machinery as for any formula.

use crate::expr::{BinaryOp, Context, Node, UnaryOp, Var};

/// Smooth union with blend radius `r`: `min(a,b) − h²·r/4`, `h = max(r − |a−b|, 0)/r`
/// (the polynomial smooth minimum; equal to `min(a, b)` where `|a − b| ≥ r`).
pub fn blend(ctx: &mut Context, a: Node, b: Node, r: Node) -> Node {
    let diff = ctx.sub(a, b);
    let gap = ctx.unary(UnaryOp::Abs, diff);
    let slack = ctx.sub(r, gap);
    let zero = ctx.constant(0.0);
    let clipped = ctx.binary(BinaryOp::Max, slack, zero);
    let h = ctx.div(clipped, r);
    let h2 = ctx.powi(h, 2);
    let h2r = ctx.mul(h2, r);
    let bump = ctx.scale(0.25, h2r);
    let m = ctx.binary(BinaryOp::Min, a, b);
    ctx.sub(m, bump)
}

fn coords(ctx: &mut Context) -> [Node; 3] {
    [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v))
}

fn at(ctx: &mut Context, f: Node, p: [Node; 3]) -> Node {
    ctx.substitute(f, &[Some(p[0]), Some(p[1]), Some(p[2]), None, None, None])
}

/// `f` moved by `offset`: `f(x − dx, y − dy, z − dz)`.
pub fn translate(ctx: &mut Context, f: Node, offset: [Node; 3]) -> Node {
    let [x, y, z] = coords(ctx);
    let p = [
        ctx.sub(x, offset[0]),
        ctx.sub(y, offset[1]),
        ctx.sub(z, offset[2]),
    ];
    at(ctx, f, p)
}

/// `f` scaled by `s` about the origin: `s·f(p/s)` (the factor keeps distances
/// in scale).
pub fn scale(ctx: &mut Context, f: Node, s: Node) -> Node {
    let [x, y, z] = coords(ctx);
    let p = [ctx.div(x, s), ctx.div(y, s), ctx.div(z, s)];
    let g = at(ctx, f, p);
    ctx.mul(s, g)
}

/// `f` rotated by `angles` (degrees) about x, then y, then z: `f(R⁻¹p)`
/// with `R = Rz·Ry·Rx`, so `R⁻¹ = Rxᵀ·Ryᵀ·Rzᵀ`.
pub fn rotate(ctx: &mut Context, f: Node, angles: [Node; 3]) -> Node {
    let [x, y, z] = coords(ctx);
    let deg = ctx.constant(std::f64::consts::PI);
    let per = ctx.constant(180.0);
    let to_rad = ctx.div(deg, per);
    let cs = angles.map(|a| {
        let r = ctx.mul(a, to_rad);
        (ctx.unary(UnaryOp::Cos, r), ctx.unary(UnaryOp::Sin, r))
    });
    // Rotation by angle t about one axis, inverted (transposed): (u, v) → (c·u + s·v, −s·u + c·v).
    let turn = |ctx: &mut Context, (c, s): (Node, Node), u: Node, v: Node| {
        let cu = ctx.mul(c, u);
        let sv = ctx.mul(s, v);
        let su = ctx.mul(s, u);
        let cv = ctx.mul(c, v);
        (ctx.add(cu, sv), ctx.sub(cv, su))
    };
    // Undo z, then y, then x.
    let (x1, y1) = turn(ctx, cs[2], x, y);
    let (z2, x2) = turn(ctx, cs[1], z, x1);
    let (y3, z3) = turn(ctx, cs[0], y1, z2);
    at(ctx, f, [x2, y3, z3])
}
