//! The primitives of scene files, built directly as graphs (no formula text).
//!
//! Each is a canonical shape (a unit sphere, a torus of major radius 1, …) in
//! its own coordinates, with the [`Placement`] that puts it in the scene, so
//! every sphere of a scene shares one compiled formula and octree.

use super::model::Placement;
use crate::expr::{BinaryOp, Context, Node, UnaryOp, Var};
use crate::types::Aabb;
use glam::DVec3;

/// A canonical shape: its graph, its box (in its own coordinates).
pub type Shape = (Node, Aabb);

/// How much a shape's box exceeds it: 1 %, plus a hair.
fn padded(half: DVec3) -> Aabb {
    let h = half * 1.01 + DVec3::splat(1e-9);
    Aabb { lo: -h, hi: h }
}

/// `a^2`.
fn square(ctx: &mut Context, a: Node) -> Node {
    ctx.powi(a, 2)
}

fn coordinates(ctx: &mut Context) -> [Node; 3] {
    [Var::X, Var::Y, Var::Z].map(|v| ctx.var(v))
}

/// `x^2 + y^2 + z^2 - 1`, placed at `center` with radius `radius`.
pub fn sphere(ctx: &mut Context) -> Shape {
    let [x, y, z] = coordinates(ctx);
    let (x2, y2, z2) = (square(ctx, x), square(ctx, y), square(ctx, z));
    let xy = ctx.add(x2, y2);
    let sum = ctx.add(xy, z2);
    let one = ctx.constant(1.0);
    (ctx.sub(sum, one), padded(DVec3::ONE))
}

/// The placement of a sphere.
pub fn sphere_placement(center: DVec3, radius: f64) -> Placement {
    Placement {
        offset: center,
        scale: radius,
    }
}

/// `nx*x + ny*y + nz*z - offset` for a unit normal, in a slab `extent` wide
/// across and a hundredth of that along the axes the normal runs along. In
/// scene coordinates (planes are few and not shared).
pub fn plane(ctx: &mut Context, normal: DVec3, offset: f64, extent: f64) -> Shape {
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
    // Off-centre in its slab: a plane on the octree's mid-plane would meet
    // every ray on a leaf face, where F is lost in its rounding noise.
    let thin = |component: f64| {
        if component.abs() > 0.999_999 {
            0.1
        } else {
            0.0
        }
    };
    let shift = DVec3::new(thin(normal.x), thin(normal.y), thin(normal.z)) * h;
    (
        node,
        Aabb {
            lo: c - h + shift,
            hi: c + h + shift,
        },
    )
}

/// `max(abs(x)-hx, abs(y)-hy, abs(z)-hz)` with the largest half size 1: the
/// box `[lo, hi]` once placed by [`cuboid_placement`].
pub fn cuboid(ctx: &mut Context, lo: DVec3, hi: DVec3) -> Shape {
    let half = cuboid_half(lo, hi);
    let xyz = coordinates(ctx);
    let sides: Vec<Node> = (0..3)
        .map(|i| {
            let a = ctx.unary(UnaryOp::Abs, xyz[i]);
            let h = ctx.constant(half[i]);
            ctx.sub(a, h)
        })
        .collect();
    let xy = ctx.binary(BinaryOp::Max, sides[0], sides[1]);
    (ctx.binary(BinaryOp::Max, xy, sides[2]), padded(half))
}

/// The half sizes of the box `[lo, hi]` over the largest of them.
pub fn cuboid_half(lo: DVec3, hi: DVec3) -> DVec3 {
    let h = 0.5 * (hi - lo);
    h / h.max_element()
}

/// The placement of the box `[lo, hi]`.
pub fn cuboid_placement(lo: DVec3, hi: DVec3) -> Placement {
    Placement {
        offset: 0.5 * (lo + hi),
        scale: (0.5 * (hi - lo)).max_element(),
    }
}

/// `(x^2 + y^2 + z^2 + 1 - r^2)^2 - 4*(x^2 + y^2)` with `r = minor/major`: a
/// torus about the z axis of major radius 1, placed with scale `major`.
pub fn torus(ctx: &mut Context, ratio: f64) -> Shape {
    let [x, y, z] = coordinates(ctx);
    let (x2, y2, z2) = (square(ctx, x), square(ctx, y), square(ctx, z));
    let r = ctx.constant(ratio);
    let small2 = square(ctx, r);
    let one = ctx.constant(1.0);
    let xy = ctx.add(x2, y2);
    let xyz = ctx.add(xy, z2);
    let shifted = ctx.add(xyz, one);
    let inner = ctx.sub(shifted, small2);
    let first = square(ctx, inner);
    let four = ctx.constant(4.0);
    let second = ctx.mul(four, xy);
    (
        ctx.sub(first, second),
        padded(DVec3::new(1.0 + ratio, 1.0 + ratio, ratio)),
    )
}

/// `max(x^2 + y^2 - 1, abs(z) - h)` with `h = height/(2·radius)`: a capped
/// cylinder along z of radius 1, placed with scale `radius`.
pub fn cylinder(ctx: &mut Context, half_height: f64) -> Shape {
    let [x, y, z] = coordinates(ctx);
    let (x2, y2) = (square(ctx, x), square(ctx, y));
    let xy = ctx.add(x2, y2);
    let one = ctx.constant(1.0);
    let round = ctx.sub(xy, one);
    let a = ctx.unary(UnaryOp::Abs, z);
    let h = ctx.constant(half_height);
    let caps = ctx.sub(a, h);
    (
        ctx.binary(BinaryOp::Max, round, caps),
        padded(DVec3::new(1.0, 1.0, half_height)),
    )
}
