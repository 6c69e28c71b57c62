//! Constructive solid geometry and rigid transforms, as graph builders.
//!
//! Solids are `f ≤ 0`. Union, intersection and difference are `min`, `max` and
//! `max(a, -b)`; a blend is a smooth union. Transforms evaluate the formula
//! in the inverse-transformed coordinates. Everything is an ordinary expression graph, so
//! derivatives, L and G come from the same machinery as for any formula.

use crate::expr::context::AffineMap;
use crate::expr::{BinaryOp, Context, Node, UnaryOp};

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

/// `f` moved by `offset`: `f(x − dx, y − dy, z − dz)`.
///
/// Rebuilds `f`; the language's `translate` defers that, so long chains of
/// transforms stay linear to build.
pub fn translate(ctx: &mut Context, f: Node, offset: [Node; 3]) -> Node {
    let lazy = translated(ctx, f, offset);
    ctx.expand(lazy)
}

/// `f` scaled by `s` about the origin: `s·f(p/s)` (the factor keeps distances
/// in scale).
pub fn scale(ctx: &mut Context, f: Node, s: Node) -> Node {
    let lazy = scaled(ctx, f, s);
    ctx.expand(lazy)
}

/// `f` rotated by `angles` (degrees) about x, then y, then z: `f(R⁻¹p)`
/// with `R = Rz·Ry·Rx`.
pub fn rotate(ctx: &mut Context, f: Node, angles: [Node; 3]) -> Node {
    let lazy = rotated(ctx, f, angles);
    ctx.expand(lazy)
}

/// [`translate`], left for [`Context::expand`].
pub(crate) fn translated(ctx: &mut Context, f: Node, offset: [Node; 3]) -> Node {
    let identity = ctx.identity_affine();
    let b = offset.map(|t| ctx.neg(t));
    ctx.remap(f, AffineMap { b, ..identity })
}

/// [`scale`], left for [`Context::expand`].
pub(crate) fn scaled(ctx: &mut Context, f: Node, s: Node) -> Node {
    let identity = ctx.identity_affine();
    let m = identity.m.map(|row| row.map(|e| ctx.div(e, s)));
    let inner = ctx.remap(f, AffineMap { m, ..identity });
    ctx.mul(s, inner)
}

/// [`rotate`], left for [`Context::expand`]: `R⁻¹ = Rxᵀ·Ryᵀ·Rzᵀ`.
pub(crate) fn rotated(ctx: &mut Context, f: Node, angles: [Node; 3]) -> Node {
    let deg = ctx.constant(std::f64::consts::PI);
    let per = ctx.constant(180.0);
    let to_rad = ctx.div(deg, per);
    let [(cx, sx), (cy, sy), (cz, sz)] = angles.map(|a| {
        let r = ctx.mul(a, to_rad);
        (ctx.unary(UnaryOp::Cos, r), ctx.unary(UnaryOp::Sin, r))
    });
    let identity = ctx.identity_affine();
    let (zero, one) = (ctx.constant(0.0), ctx.constant(1.0));
    let (nsx, nsy, nsz) = (ctx.neg(sx), ctx.neg(sy), ctx.neg(sz));
    // Each inverse (transposed) rotation about one axis.
    let rx_t = [[one, zero, zero], [zero, cx, sx], [zero, nsx, cx]];
    let ry_t = [[cy, zero, nsy], [zero, one, zero], [sy, zero, cy]];
    let rz_t = [[cz, sz, zero], [nsz, cz, zero], [zero, zero, one]];
    let m = times(ctx, &rx_t, &ry_t);
    let m = times(ctx, &m, &rz_t);
    ctx.remap(f, AffineMap { m, ..identity })
}

/// `a·b`.
fn times(ctx: &mut Context, a: &[[Node; 3]; 3], b: &[[Node; 3]; 3]) -> [[Node; 3]; 3] {
    let columns: [[Node; 3]; 3] = std::array::from_fn(|j| ctx.apply_linear(a, b.map(|r| r[j])));
    std::array::from_fn(|i| std::array::from_fn(|j| columns[j][i]))
}
