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

/// A formula `k · g(M·p + b)`: the untransformed `g` and the composition of
/// the rigid transforms and scales applied to it, kept so that the next
/// transform composes with them (one substitution, one 3×3 linear map per
/// evaluation, however deeply transforms nest).
#[derive(Debug, Clone, Copy)]
pub struct Placed {
    inner: Node,
    factor: Node,
    m: [[Node; 3]; 3],
    b: [Node; 3],
}

impl Placed {
    /// `f` itself: the identity transform.
    fn identity(ctx: &mut Context, f: Node) -> Placed {
        let (zero, one) = (ctx.constant(0.0), ctx.constant(1.0));
        Placed {
            inner: f,
            factor: one,
            m: std::array::from_fn(|i| std::array::from_fn(|j| if i == j { one } else { zero })),
            b: [zero; 3],
        }
    }

    /// What `f` is, if a transform built it; else `f` untransformed.
    fn of(ctx: &mut Context, f: Node) -> Placed {
        match ctx.placed.get(&f) {
            Some(p) => *p,
            None => Placed::identity(ctx, f),
        }
    }

    /// Builds `factor · inner(M·p + b)` and remembers how.
    fn build(self, ctx: &mut Context) -> Node {
        let xyz = coords(ctx);
        let p: [Node; 3] = std::array::from_fn(|i| {
            let terms: Vec<Node> = (0..3).map(|j| ctx.mul(self.m[i][j], xyz[j])).collect();
            let s = ctx.add(terms[0], terms[1]);
            let s = ctx.add(s, terms[2]);
            ctx.add(s, self.b[i])
        });
        let g = ctx.substitute(
            self.inner,
            &[Some(p[0]), Some(p[1]), Some(p[2]), None, None, None],
        );
        let node = ctx.mul(self.factor, g);
        ctx.placed.insert(node, self);
        node
    }

    /// `M·v` for a vector of nodes.
    fn apply(&self, ctx: &mut Context, v: [Node; 3]) -> [Node; 3] {
        std::array::from_fn(|i| {
            let t0 = ctx.mul(self.m[i][0], v[0]);
            let t1 = ctx.mul(self.m[i][1], v[1]);
            let t2 = ctx.mul(self.m[i][2], v[2]);
            let s = ctx.add(t0, t1);
            ctx.add(s, t2)
        })
    }

    /// `M·N`.
    fn times(&self, ctx: &mut Context, n: &[[Node; 3]; 3]) -> [[Node; 3]; 3] {
        let mut out = self.m;
        for (i, row) in out.iter_mut().enumerate() {
            for (j, entry) in row.iter_mut().enumerate() {
                let t0 = ctx.mul(self.m[i][0], n[0][j]);
                let t1 = ctx.mul(self.m[i][1], n[1][j]);
                let t2 = ctx.mul(self.m[i][2], n[2][j]);
                let s = ctx.add(t0, t1);
                *entry = ctx.add(s, t2);
            }
        }
        out
    }
}

/// `f` moved by `offset`: `f(x − dx, y − dy, z − dz)`.
pub fn translate(ctx: &mut Context, f: Node, offset: [Node; 3]) -> Node {
    // f = k·g(M·p + b), so f(p − t) = k·g(M·p + (b − M·t)).
    let placed = Placed::of(ctx, f);
    let mt = placed.apply(ctx, offset);
    let b = std::array::from_fn(|i| ctx.sub(placed.b[i], mt[i]));
    Placed { b, ..placed }.build(ctx)
}

/// `f` scaled by `s` about the origin: `s·f(p/s)` (the factor keeps distances
/// in scale).
pub fn scale(ctx: &mut Context, f: Node, s: Node) -> Node {
    // s·k·g(M·p/s + b).
    let placed = Placed::of(ctx, f);
    let m = placed.m.map(|row| row.map(|e| ctx.div(e, s)));
    let factor = ctx.mul(s, placed.factor);
    Placed {
        m,
        factor,
        ..placed
    }
    .build(ctx)
}

/// `f` rotated by `angles` (degrees) about x, then y, then z: `f(R⁻¹p)`
/// with `R = Rz·Ry·Rx`, so `R⁻¹ = Rxᵀ·Ryᵀ·Rzᵀ`.
pub fn rotate(ctx: &mut Context, f: Node, angles: [Node; 3]) -> Node {
    let deg = ctx.constant(std::f64::consts::PI);
    let per = ctx.constant(180.0);
    let to_rad = ctx.div(deg, per);
    let [(cx, sx), (cy, sy), (cz, sz)] = angles.map(|a| {
        let r = ctx.mul(a, to_rad);
        (ctx.unary(UnaryOp::Cos, r), ctx.unary(UnaryOp::Sin, r))
    });
    let (zero, one) = (ctx.constant(0.0), ctx.constant(1.0));
    let (nsx, nsy, nsz) = (ctx.neg(sx), ctx.neg(sy), ctx.neg(sz));
    // Each inverse (transposed) rotation about one axis.
    let rx_t = [[one, zero, zero], [zero, cx, sx], [zero, nsx, cx]];
    let ry_t = [[cy, zero, nsy], [zero, one, zero], [sy, zero, cy]];
    let rz_t = [[cz, sz, zero], [nsz, cz, zero], [zero, zero, one]];
    // f = k·g(M·p + b), so f(R⁻¹p) = k·g(M·Rxᵀ·Ryᵀ·Rzᵀ·p + b).
    let placed = Placed::of(ctx, f);
    let m = placed.times(ctx, &rx_t);
    let m = Placed { m, ..placed }.times(ctx, &ry_t);
    let m = Placed { m, ..placed }.times(ctx, &rz_t);
    Placed { m, ..placed }.build(ctx)
}
