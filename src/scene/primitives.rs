//! The primitives of scene files, built directly as graphs (no formula text)
//! with the boxes that hold them.
//!
//! Each builds, call for call, the graph its textbook formula lowers to, so a
//! primitive and the same formula written as an `object` render alike.

use crate::expr::{BinaryOp, Context, Node, UnaryOp, Var};
use crate::types::Aabb;
use glam::DVec3;

/// How much a primitive's box exceeds the shape: 1 %, plus a hair for shapes
/// at the origin.
fn padded(center: DVec3, half: DVec3) -> Aabb {
    let h = half * 1.01 + DVec3::splat(1e-9);
    Aabb {
        lo: center - h,
        hi: center + h,
    }
}

/// `(x-cx, y-cy, z-cz)`: the coordinates relative to `c`.
fn relative(ctx: &mut Context, c: DVec3) -> [Node; 3] {
    [Var::X, Var::Y, Var::Z].map(|v| {
        let coordinate = ctx.var(v);
        let offset = ctx.constant(c[v.index()]);
        ctx.sub(coordinate, offset)
    })
}

/// `a^2`.
fn square(ctx: &mut Context, a: Node) -> Node {
    ctx.powi(a, 2)
}

/// `v^2` of a constant.
fn constant_squared(ctx: &mut Context, v: f64) -> Node {
    let c = ctx.constant(v);
    ctx.powi(c, 2)
}

/// `(x-cx)^2 + (y-cy)^2 + (z-cz)^2 - r^2`.
pub fn sphere(ctx: &mut Context, center: DVec3, radius: f64) -> (Node, Aabb) {
    let [u, v, w] = relative(ctx, center);
    let (u2, v2, w2) = (square(ctx, u), square(ctx, v), square(ctx, w));
    let uv = ctx.add(u2, v2);
    let sum = ctx.add(uv, w2);
    let r2 = constant_squared(ctx, radius);
    let node = ctx.sub(sum, r2);
    (node, padded(center, DVec3::splat(radius)))
}

/// `nx*x + ny*y + nz*z - offset` for a unit normal, in a slab `extent` wide
/// across and a hundredth of that along the axes the normal runs along.
pub fn plane(ctx: &mut Context, normal: DVec3, offset: f64, extent: f64) -> (Node, Aabb) {
    let terms = [Var::X, Var::Y, Var::Z].map(|v| {
        let n = ctx.constant(normal[v.index()]);
        let coordinate = ctx.var(v);
        ctx.mul(n, coordinate)
    });
    let xy = ctx.add(terms[0], terms[1]);
    let xyz = ctx.add(xy, terms[2]);
    let d = ctx.constant(offset);
    let node = ctx.sub(xyz, d);
    let c = normal * offset;
    let half = |component: f64| {
        if component.abs() > 0.999_999 {
            0.01 * extent
        } else {
            extent
        }
    };
    let h = DVec3::new(half(normal.x), half(normal.y), half(normal.z));
    (
        node,
        Aabb {
            lo: c - h,
            hi: c + h,
        },
    )
}

/// `max(abs(x-cx)-hx, abs(y-cy)-hy, abs(z-cz)-hz)` for the box `[lo, hi]`.
pub fn cuboid(ctx: &mut Context, lo: DVec3, hi: DVec3) -> (Node, Aabb) {
    let c = 0.5 * (lo + hi);
    let h = 0.5 * (hi - lo);
    let rel = relative(ctx, c);
    let sides: Vec<Node> = (0..3)
        .map(|i| {
            let a = ctx.unary(UnaryOp::Abs, rel[i]);
            let half = ctx.constant(h[i]);
            ctx.sub(a, half)
        })
        .collect();
    let xy = ctx.binary(BinaryOp::Max, sides[0], sides[1]);
    let node = ctx.binary(BinaryOp::Max, xy, sides[2]);
    (node, padded(c, h))
}

/// `(u^2 + v^2 + w^2 + R^2 - r^2)^2 - 4*R^2*(u^2 + v^2)` with `(u, v, w)` the
/// coordinates relative to the centre: a torus about the z axis.
pub fn torus(ctx: &mut Context, center: DVec3, major: f64, minor: f64) -> (Node, Aabb) {
    let [u, v, w] = relative(ctx, center);
    let (u2, v2, w2) = (square(ctx, u), square(ctx, v), square(ctx, w));
    let big2 = constant_squared(ctx, major);
    let small2 = constant_squared(ctx, minor);
    let uv = ctx.add(u2, v2);
    let uvw = ctx.add(uv, w2);
    let shifted = ctx.add(uvw, big2);
    let inner = ctx.sub(shifted, small2);
    let first = square(ctx, inner);
    let four = ctx.constant(4.0);
    let factor = ctx.mul(four, big2);
    let second = ctx.mul(factor, uv);
    let node = ctx.sub(first, second);
    let h = DVec3::new(major + minor, major + minor, minor);
    (node, padded(center, h))
}

/// `max((x-cx)^2 + (y-cy)^2 - r^2, abs(z-cz) - height/2)`: a capped cylinder
/// along z.
pub fn cylinder(ctx: &mut Context, center: DVec3, radius: f64, height: f64) -> (Node, Aabb) {
    let [u, v, w] = relative(ctx, center);
    let (u2, v2) = (square(ctx, u), square(ctx, v));
    let uv = ctx.add(u2, v2);
    let r2 = constant_squared(ctx, radius);
    let round = ctx.sub(uv, r2);
    let a = ctx.unary(UnaryOp::Abs, w);
    let half = ctx.constant(height / 2.0);
    let caps = ctx.sub(a, half);
    let node = ctx.binary(BinaryOp::Max, round, caps);
    (
        node,
        padded(center, DVec3::new(radius, radius, height / 2.0)),
    )
}
