//! Constructive solid geometry and rigid transforms, as graph builders.
//!
//! Solids are `f ≤ 0`. Union, intersection and difference are `min`, `max` and
//! `max(a, -b)`; a blend is a smooth union. Transforms substitute the inverse
//! transform into the formula. Everything is an ordinary expression graph, so
//! derivatives, L and G come from the same machinery as for any formula.

use crate::context::{BinaryOp, Context, Node, UnaryOp, Var};

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

#[cfg(test)]
mod tests {
    use crate::Formula;

    fn f_at(src: &str, p: [f64; 3]) -> f64 {
        let f = Formula::parse(src).unwrap();
        f.context().eval(f.f(), &[p[0], p[1], p[2], 0.0, 0.0, 0.0])
    }

    const SPHERE: &str = "x^2+y^2+z^2-1";
    const CUBE: &str = "max(abs(x), abs(y), abs(z)) - 0.8";

    #[test]
    fn csg_point_membership() {
        let inside = |src: &str, p: [f64; 3]| f_at(src, p) < 0.0;
        let u = format!("union({SPHERE}, translate({SPHERE}, 1.5, 0, 0))");
        assert!(
            inside(&u, [0.0, 0.0, 0.0])
                && inside(&u, [1.5, 0.0, 0.0])
                && !inside(&u, [0.75, 0.9, 0.0])
        );
        let i = format!("intersect({SPHERE}, {CUBE})");
        assert!(
            inside(&i, [0.0, 0.0, 0.0])
                && !inside(&i, [0.9, 0.0, 0.0])
                && !inside(&i, [0.7, 0.7, 0.7])
        );
        // The CSG part: a cube minus a sphere.
        let d = format!("subtract({CUBE}, scale({SPHERE}, 0.95))");
        assert!(!inside(&d, [0.0, 0.0, 0.0]), "the centre is carved out");
        assert!(inside(&d, [0.78, 0.78, 0.78]), "the corners remain");
        assert!(!inside(&d, [0.9, 0.0, 0.0]), "outside the cube");
    }

    #[test]
    fn transforms_move_points_as_documented() {
        let t = format!("translate({SPHERE}, 2, -1, 0.5)");
        assert!(f_at(&t, [2.0, -1.0, 0.5]) == -1.0);
        let s = format!("scale({SPHERE}, 2)");
        assert!((f_at(&s, [2.0, 0.0, 0.0])).abs() < 1e-12, "radius 2");
        // A box long in x, turned 90° about z, is long in y.
        let slab = "max(abs(x) - 2, abs(y) - 0.5, abs(z) - 0.5)";
        let r = format!("rotate({slab}, 0, 0, 90)");
        assert!(f_at(&r, [0.0, 1.5, 0.0]) < 0.0 && f_at(&r, [1.5, 0.0, 0.0]) > 0.0);
        let r = format!("rotate({slab}, 0, 90, 0)");
        assert!(f_at(&r, [0.0, 0.0, 1.5]) < 0.0 && f_at(&r, [1.5, 0.0, 0.0]) > 0.0);
    }

    #[test]
    fn blend_is_min_far_from_the_seam_and_below_it_near() {
        let a = "x^2+y^2+z^2-1";
        let b = "(x-1.5)^2+y^2+z^2-1";
        let src = format!("blend({a}, {b}, 0.5)");
        let far = [-0.5, 0.0, 0.0];
        assert_eq!(f_at(&src, far), f_at(&format!("min({a}, {b})"), far));
        let seam = [0.75, 0.0, 0.0];
        assert!(f_at(&src, seam) < f_at(&format!("min({a}, {b})"), seam));
    }
}
