//! Per-region specialisation: where one branch of a `min`, `max`, `abs`,
//! `sign`, `choose` or `dirac` holds on a whole region, the formula there is
//! that branch; where a `max` (`min`) at the root has a side below (above) 0
//! on the whole region, the other side has the formula's sign there
//! ([`RootSplit::sign_branch`]). Its derivatives are then smooth where the crease is far, so
//! Kalra–Barr's bounds are finite, and its tape is shorter (fidget and libfive
//! call this tape simplification).

use super::{BinaryOp, Context, Node, Op, UnaryOp};
use crate::types::Interval;
use rustc_hash::FxHashMap;

/// A node whose value follows one operand or another depending on a sign.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BranchPoint {
    /// The node itself.
    pub node: Node,
    kind: Kind,
    operands: [Node; 3],
    arity: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Min,
    Max,
    Abs,
    Sign,
    Choose,
    Dirac,
}

/// Which way a branch point goes over a region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Branch {
    /// Either way: the region straddles the crease or jump.
    Open,
    /// `min`/`max`: the first operand; `abs`: `a`; `sign`: 1; `choose`: the
    /// second argument (taken where the condition is negative); `dirac`: 0.
    First,
    /// `min`/`max`: the second operand; `abs`: `−a`; `sign`: −1; `choose`:
    /// the third argument.
    Second,
}

/// Patterns (a branch for each of a formula's branch points, thousands in
/// a long one) key the octree's maps of shapes: hashed as bytes, several at
/// a time, not one discriminant (eight bytes) per branch point.
impl std::hash::Hash for Branch {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        state.write_u8(*self as u8);
    }

    fn hash_slice<H: std::hash::Hasher>(data: &[Self], state: &mut H) {
        let mut bytes = [0u8; 64];
        for chunk in data.chunks(bytes.len()) {
            for (byte, &branch) in bytes.iter_mut().zip(chunk) {
                *byte = branch as u8;
            }
            state.write(&bytes[..chunk.len()]);
        }
    }
}

impl BranchPoint {
    /// The operands whose enclosures decide it: `[a, b]` for `min`/`max`,
    /// `[a]` for `abs`, `sign`, `dirac`, `[c, p, n]` for `choose`. Every one
    /// must be defined on the whole region for a decision to hold: dropping
    /// a branch must not drop where the formula is undefined.
    pub fn operands(&self) -> &[Node] {
        &self.operands[..self.arity]
    }

    /// The operand a decided branch continues into (`abs`'s `−a` counts as
    /// `a`); `None` where the branch is open or a constant (`sign`,
    /// `dirac`).
    fn taken(&self, branch: Branch) -> Option<Node> {
        let first = branch == Branch::First;
        match (self.kind, branch) {
            (_, Branch::Open) | (Kind::Sign | Kind::Dirac, _) => None,
            (Kind::Min | Kind::Max, _) => Some(self.operands[usize::from(!first)]),
            (Kind::Abs, _) => Some(self.operands[0]),
            (Kind::Choose, _) => Some(self.operands[if first { 1 } else { 2 }]),
        }
    }

    /// The branch that holds wherever the operands lie in `enclosures`
    /// (in the order of [`BranchPoint::operands`]).
    pub fn decide(&self, enclosures: &[Interval]) -> Branch {
        if enclosures.iter().any(|e| e.is_empty() || !e.is_bounded()) {
            return Branch::Open;
        }
        let a = enclosures[0];
        let pick = |first: bool, second: bool| match (first, second) {
            (true, _) => Branch::First,
            (_, true) => Branch::Second,
            _ => Branch::Open,
        };
        match self.kind {
            Kind::Min => {
                let b = enclosures[1];
                pick(a.sup() <= b.inf(), b.sup() <= a.inf())
            }
            Kind::Max => {
                let b = enclosures[1];
                pick(a.inf() >= b.sup(), b.inf() >= a.sup())
            }
            Kind::Abs => pick(a.inf() >= 0.0, a.sup() <= 0.0),
            Kind::Sign => pick(a.inf() > 0.0, a.sup() < 0.0),
            Kind::Choose => pick(a.sup() < 0.0, a.inf() > 0.0),
            Kind::Dirac => pick(a.inf() > 0.0 || a.sup() < 0.0, false),
        }
    }
}

/// The branch points `root` reaches, children before parents.
pub fn branch_points(ctx: &Context, root: Node) -> Vec<BranchPoint> {
    ctx.topological_order(&[root])
        .into_iter()
        .filter_map(|node| {
            let (kind, operands, arity) = match *ctx.get(node) {
                Op::Binary(BinaryOp::Min, a, b) => (Kind::Min, [a, b, a], 2),
                Op::Binary(BinaryOp::Max, a, b) => (Kind::Max, [a, b, a], 2),
                Op::Unary(UnaryOp::Abs, a) => (Kind::Abs, [a; 3], 1),
                Op::Unary(UnaryOp::Sign, a) => (Kind::Sign, [a; 3], 1),
                Op::Unary(UnaryOp::Dirac, a) => (Kind::Dirac, [a; 3], 1),
                Op::Choose(c, p, n) => (Kind::Choose, [c, p, n], 3),
                _ => return None,
            };
            Some(BranchPoint {
                node,
                kind,
                operands,
                arity,
            })
        })
        .collect()
}

/// Each branch point's index in `points`, by its node.
fn index_of(points: &[BranchPoint]) -> FxHashMap<Node, usize> {
    points
        .iter()
        .enumerate()
        .map(|(i, p)| (p.node, i))
        .collect()
}

/// `branches` with every branch point that the decided ones cut off from
/// `root` set to [`Branch::Open`]: patterns that specialise `root` to the
/// same formula become equal, so they share one compiled shape. `index` is
/// [`PointIndex::new`] of `points`, made once for the many patterns.
pub fn normalise(
    ctx: &Context,
    root: Node,
    points: &[BranchPoint],
    index: &PointIndex,
    branches: &[Branch],
) -> Vec<Branch> {
    let mut out = vec![Branch::Open; branches.len()];
    each_reached(ctx, root, points, index, branches, |i| out[i] = branches[i]);
    out
}

/// Which branch points `branches` leaves both open and reachable from
/// `root` (the points [`normalise`] keeps open that the formula, so
/// specialised, still computes): those a region's decisions can still
/// change the shape by.
pub fn live_open(
    ctx: &Context,
    root: Node,
    points: &[BranchPoint],
    index: &PointIndex,
    branches: &[Branch],
) -> Vec<bool> {
    let mut live = vec![false; branches.len()];
    each_reached(ctx, root, points, index, branches, |i| {
        live[i] = branches[i] == Branch::Open;
    });
    live
}

/// Visits each branch point reachable from `root` once `branches` are
/// taken (a decided point leads on to its taken branch only), by its
/// index in `points`.
fn each_reached(
    ctx: &Context,
    root: Node,
    points: &[BranchPoint],
    index: &PointIndex,
    branches: &[Branch],
    mut visit: impl FnMut(usize),
) {
    let index = &index.0;
    let mut seen = rustc_hash::FxHashSet::default();
    let mut stack = vec![root];
    while let Some(n) = stack.pop() {
        if !seen.insert(n) {
            continue;
        }
        if let Some(&i) = index.get(&n) {
            visit(i);
            match branches[i] {
                Branch::Open => stack.extend(ctx.get(n).children()),
                branch => stack.extend(points[i].taken(branch)),
            }
            continue;
        }
        stack.extend(ctx.get(n).children());
    }
}

/// Each branch point's index in a list of them, by its node: built once for
/// the many walks of [`RootSplit::of`].
#[derive(Debug, Clone, Default)]
pub struct PointIndex(FxHashMap<Node, usize>);

impl PointIndex {
    /// The index of `points`.
    pub fn new(points: &[BranchPoint]) -> PointIndex {
        PointIndex(index_of(points))
    }
}

/// One affine map on the walk from a root down to its split, `u ↦ −u`,
/// `u + k`, `k − u` or `c·u`.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ScalarMap {
    Neg,
    Add(f64),
    SubFrom(f64),
    Mul(f64),
}

/// A formula that is the larger or the smaller of two sides: its one open
/// branch point at the root is a `max` or `min` that the root reaches through
/// decided branches and affine maps `u ↦ c·u + k` with a constant `c ≠ 0`
/// (which commute with max and min, swapping them when `c < 0`). The sides
/// are the formula with that point decided either way.
#[derive(Debug, Clone, PartialEq)]
pub struct RootSplit {
    /// The index of the `max` or `min` among the branch points.
    pub point: usize,
    /// Whether the formula is the larger of its sides (else the smaller).
    pub larger: bool,
    /// The maps from the root down to the point, root first.
    maps: Vec<ScalarMap>,
}

impl RootSplit {
    /// The split of `root` with `branches` decided; `None` for any other
    /// shape of `root` (the walk stops there).
    pub fn of(
        ctx: &Context,
        root: Node,
        points: &[BranchPoint],
        index: &PointIndex,
        branches: &[Branch],
    ) -> Option<RootSplit> {
        Self::walk(ctx, points, index, branches, root, true, Vec::new())
    }

    /// The split that follows this one once its point is decided (now in
    /// `branches`), found by walking on from that point rather than from
    /// the root again.
    pub fn then(
        self,
        ctx: &Context,
        points: &[BranchPoint],
        index: &PointIndex,
        branches: &[Branch],
    ) -> Option<RootSplit> {
        let point = points[self.point];
        let node = point.taken(branches[self.point])?;
        let increasing = self.larger == (point.kind == Kind::Max);
        Self::walk(ctx, points, index, branches, node, increasing, self.maps)
    }

    /// The walk down from `node`, reached from the root through `maps`,
    /// increasing in it or not.
    fn walk(
        ctx: &Context,
        points: &[BranchPoint],
        index: &PointIndex,
        branches: &[Branch],
        mut node: Node,
        mut increasing: bool,
        mut maps: Vec<ScalarMap>,
    ) -> Option<RootSplit> {
        let constant = |n: Node| match *ctx.get(n) {
            Op::Const(c) => Some(c.value()),
            _ => None,
        };
        // Each step moves to an operand, so the walk ends within the graph's
        // size.
        for _ in 0..=ctx.len() {
            if let Some(&i) = index.0.get(&node) {
                let point = points[i];
                let larger = match (point.kind, branches[i]) {
                    (Kind::Max, Branch::Open) => increasing,
                    (Kind::Min, Branch::Open) => !increasing,
                    (kind, branch) => {
                        // Decided: on into its branch (`−a` for abs's second).
                        if kind == Kind::Abs && branch == Branch::Second {
                            increasing = !increasing;
                            maps.push(ScalarMap::Neg);
                        }
                        node = point.taken(branch)?;
                        continue;
                    }
                };
                return Some(RootSplit {
                    point: i,
                    larger,
                    maps,
                });
            }
            node = match *ctx.get(node) {
                Op::Unary(UnaryOp::Neg, a) => {
                    increasing = !increasing;
                    maps.push(ScalarMap::Neg);
                    a
                }
                Op::Binary(op @ (BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul), a, b) => {
                    let (c, u, u_second) = match (constant(a), constant(b)) {
                        (Some(c), None) => (c, b, true),
                        (None, Some(c)) => (c, a, false),
                        _ => return None,
                    };
                    if !c.is_finite() {
                        return None;
                    }
                    let map = match op {
                        BinaryOp::Add => ScalarMap::Add(c),
                        BinaryOp::Sub if u_second => ScalarMap::SubFrom(c),
                        BinaryOp::Sub => ScalarMap::Add(-c),
                        _ if c == 0.0 => return None,
                        _ => ScalarMap::Mul(c),
                    };
                    increasing ^= matches!(map, ScalarMap::SubFrom(_))
                        || matches!(map, ScalarMap::Mul(c) if c < 0.0);
                    maps.push(map);
                    u
                }
                _ => return None,
            };
        }
        None
    }

    /// An enclosure of a side over a region, from an enclosure of its
    /// operand of the split point there (the maps applied with outward
    /// rounding).
    pub fn side(&self, operand: Interval) -> Interval {
        self.maps.iter().rev().fold(operand, |u, map| match *map {
            ScalarMap::Neg => -u,
            ScalarMap::Add(k) => u + Interval::point(k),
            ScalarMap::SubFrom(k) => Interval::point(k) - u,
            ScalarMap::Mul(c) => u * Interval::point(c),
        })
    }

    /// The branch of the split point that gives the formula's sign wherever
    /// its operands lie in `a` and `b`, though maybe not its value: the
    /// larger of two sides has the first side's sign where the second is
    /// below 0 (and the smaller where it is above 0). `Open` if neither side
    /// is.
    pub fn sign_branch(&self, a: Interval, b: Interval) -> Branch {
        let [first, second] = [a, b].map(|o| self.side(o));
        if [first, second]
            .iter()
            .any(|s| s.is_empty() || !s.is_bounded())
        {
            return Branch::Open;
        }
        let beside = |s: Interval| {
            if self.larger {
                s.sup() < 0.0
            } else {
                s.inf() > 0.0
            }
        };
        if beside(second) {
            Branch::First
        } else if beside(first) {
            Branch::Second
        } else {
            Branch::Open
        }
    }
}

/// Where `root`, with `branches` decided, is the larger or the smaller of
/// two formulas (see [`RootSplit`]): `Some((i, larger))`, `root` is the
/// larger (`larger`) or the smaller of its two sides, `root` with point `i`
/// decided either way. `None` for any other shape of `root`.
pub fn root_split(
    ctx: &Context,
    root: Node,
    points: &[BranchPoint],
    branches: &[Branch],
) -> Option<(usize, bool)> {
    RootSplit::of(ctx, root, points, &PointIndex::new(points), branches)
        .map(|s| (s.point, s.larger))
}

/// `root` with each decided branch point replaced by its branch, in a new
/// context of its own (rebuilt through the folding builders). Only what the
/// root still reaches is rebuilt, so the work follows the result's size.
pub fn specialise(
    ctx: &Context,
    root: Node,
    points: &[BranchPoint],
    branches: &[Branch],
) -> (Context, Node) {
    let decided: FxHashMap<Node, (BranchPoint, Branch)> = points
        .iter()
        .zip(branches)
        .filter(|(_, &b)| b != Branch::Open)
        .map(|(p, &b)| (p.node, (*p, b)))
        .collect();
    let order = live_order(ctx, root, &decided);
    let mut out = Context::with_capacity(order.len());
    // Indexed by node: children come before parents, so each is set
    // before it is read.
    let mut new: Vec<Node> = vec![Node(0); ctx.len()];
    for n in order {
        let m = |k: Node| new[k.index()];
        let rebuilt = if let Some(&(point, branch)) = decided.get(&n) {
            let first = branch == Branch::First;
            match (point.kind, point.taken(branch)) {
                (Kind::Abs, Some(a)) if !first => out.neg(m(a)),
                (_, Some(a)) => m(a),
                (Kind::Sign, None) => out.constant(if first { 1.0 } else { -1.0 }),
                (_, None) => out.constant(0.0),
            }
        } else {
            match *ctx.get(n) {
                Op::Const(c) => out.constant(c.value()),
                Op::Var(v) => out.var(v),
                Op::Unary(op, a) => out.unary(op, m(a)),
                Op::Binary(op, a, b) => out.binary(op, m(a), m(b)),
                Op::PowI(a, k) => out.powi(m(a), k),
                Op::Choose(c, p, q) => out.choose(m(c), m(p), m(q)),
                Op::Remap(..) => unreachable!("{}", super::context::UNEXPANDED),
            }
        };
        new[n.index()] = rebuilt;
    }
    let root = new[root.index()];
    (out, root)
}

/// The nodes `root` reaches with the branch points of `decided` decided,
/// children before parents: a decided point continues into its taken
/// operand alone. A long CSG formula settles most of itself in a small
/// region (fidget's prospero text: shapes of a tenth of it), and the
/// operands not taken are never visited.
fn live_order(
    ctx: &Context,
    root: Node,
    decided: &FxHashMap<Node, (BranchPoint, Branch)>,
) -> Vec<Node> {
    ctx.topological_order_along(&[root], |node| match decided.get(&node) {
        Some(&(point, branch)) => [point.taken(branch), None, None],
        None => ctx.get(node).child_slots(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::Var;

    /// Patterns hash as bytes in chunks: equal ones alike, and ones that
    /// differ only past the first chunk, or only in length, apart.
    #[test]
    fn patterns_hash_every_branch() {
        use std::hash::BuildHasher;
        let hash = |p: &[Branch]| rustc_hash::FxBuildHasher.hash_one(p);
        let long = vec![Branch::Open; 200];
        let mut late = long.clone();
        late[150] = Branch::Second;
        assert_eq!(hash(&long), hash(&long.clone()));
        assert_ne!(hash(&long), hash(&late));
        assert_ne!(hash(&long), hash(&long[..199]));
        let mut first = long.clone();
        first[150] = Branch::First;
        assert_ne!(hash(&first), hash(&late));
    }

    #[test]
    fn a_decided_max_is_its_winning_operand() {
        let mut ctx = Context::new();
        let (x, y) = (ctx.var(Var::X), ctx.var(Var::Y));
        let f = ctx.binary(BinaryOp::Max, x, y);
        let points = branch_points(&ctx, f);
        assert_eq!(points.len(), 1);
        // x in [2, 3], y in [0, 1]: max is x.
        let branch = points[0].decide(&[Interval::new(2.0, 3.0), Interval::new(0.0, 1.0)]);
        assert_eq!(branch, Branch::First);
        let (out, g) = specialise(&ctx, f, &points, &[branch]);
        assert_eq!(out.get(g), &Op::Var(Var::X));
        // Overlapping enclosures decide nothing.
        let open = points[0].decide(&[Interval::new(0.0, 3.0), Interval::new(0.0, 1.0)]);
        assert_eq!(open, Branch::Open);
    }

    #[test]
    fn the_operand_a_decided_branch_drops_is_not_rebuilt() {
        // max(x, sin(y)·y + exp(y)) with the max decided for x: nothing of
        // the other operand is copied into the shape's context.
        let mut ctx = Context::new();
        let (x, y) = (ctx.var(Var::X), ctx.var(Var::Y));
        let s = ctx.unary(UnaryOp::Sin, y);
        let p = ctx.mul(s, y);
        let e = ctx.unary(UnaryOp::Exp, y);
        let dead = ctx.add(p, e);
        let f = ctx.binary(BinaryOp::Max, x, dead);
        let points = branch_points(&ctx, f);
        let (out, g) = specialise(&ctx, f, &points, &[Branch::First]);
        assert_eq!(out.get(g), &Op::Var(Var::X));
        assert_eq!(out.len(), 1, "only x is rebuilt");
        // The other branch rebuilds that operand, and not x.
        let (out, g) = specialise(&ctx, f, &points, &[Branch::Second]);
        assert!(matches!(out.get(g), Op::Binary(BinaryOp::Add, ..)));
        assert_eq!(out.len(), 5, "y, sin y, sin y·y, exp y and the sum");
    }

    /// `root_split` of `build`'s formula (in x and y) with every branch point
    /// open, or every `abs` decided `First` when `decide_abs`.
    fn split_of(
        build: impl Fn(&mut Context, Node, Node) -> Node,
        decide_abs: bool,
    ) -> Option<(usize, bool)> {
        let mut ctx = Context::new();
        let (x, y) = (ctx.var(Var::X), ctx.var(Var::Y));
        let root = build(&mut ctx, x, y);
        let points = branch_points(&ctx, root);
        let branches: Vec<Branch> = points
            .iter()
            .map(|p| match p.kind {
                Kind::Abs if decide_abs => Branch::First,
                _ => Branch::Open,
            })
            .collect();
        root_split(&ctx, root, &points, &branches)
    }

    #[test]
    fn a_max_or_min_under_affine_maps_splits_into_two_sides() {
        use BinaryOp::{Max, Min};
        let larger = |build: &dyn Fn(&mut Context, Node, Node) -> Node| {
            split_of(build, false).map(|(_, larger)| larger)
        };
        assert_eq!(larger(&|c, x, y| c.binary(Max, x, y)), Some(true));
        assert_eq!(larger(&|c, x, y| c.binary(Min, x, y)), Some(false));
        // max(x, y) − 1 and 1 − max(x, y).
        let shifted = |c: &mut Context, x, y, flip: bool| {
            let (m, one) = (c.binary(Max, x, y), c.constant(1.0));
            if flip {
                c.sub(one, m)
            } else {
                c.sub(m, one)
            }
        };
        assert_eq!(larger(&|c, x, y| shifted(c, x, y, false)), Some(true));
        assert_eq!(larger(&|c, x, y| shifted(c, x, y, true)), Some(false));
        // −2·min(x, y) + 3 is the larger of −2x + 3 and −2y + 3.
        let scaled = |c: &mut Context, x, y| {
            let (m, k, three) = (c.binary(Min, x, y), c.constant(-2.0), c.constant(3.0));
            let p = c.mul(k, m);
            c.add(p, three)
        };
        assert_eq!(larger(&scaled), Some(true));
        let negated = |c: &mut Context, x, y| {
            let m = c.binary(Max, x, y);
            c.neg(m)
        };
        assert_eq!(larger(&negated), Some(false));
        // |max(x, y)|: open, no sides; decided (`First`), the max's.
        let abs = |c: &mut Context, x, y| {
            let m = c.binary(Max, x, y);
            c.unary(UnaryOp::Abs, m)
        };
        assert_eq!(larger(&abs), None);
        assert_eq!(split_of(abs, true).map(|s| s.1), Some(true));
        // Not affine in the max, or no max at the root: no sides.
        let sine = |c: &mut Context, x, y| {
            let m = c.binary(Max, x, y);
            c.unary(UnaryOp::Sin, m)
        };
        assert_eq!(larger(&sine), None);
        let square = |c: &mut Context, x, y| {
            let m = c.binary(Max, x, y);
            c.powi(m, 2)
        };
        assert_eq!(larger(&square), None);
        let product = |c: &mut Context, x, y| {
            let m = c.binary(Max, x, y);
            c.mul(x, m)
        };
        assert_eq!(larger(&product), None);
        let plain = |c: &mut Context, x, y| c.add(x, y);
        assert_eq!(larger(&plain), None);
    }

    /// The split of `build`'s formula in x and y, every point open.
    fn root_of(build: impl Fn(&mut Context, Node, Node) -> Node) -> RootSplit {
        let mut ctx = Context::new();
        let (x, y) = (ctx.var(Var::X), ctx.var(Var::Y));
        let root = build(&mut ctx, x, y);
        let points = branch_points(&ctx, root);
        let open = vec![Branch::Open; points.len()];
        RootSplit::of(&ctx, root, &points, &PointIndex::new(&points), &open).unwrap()
    }

    #[test]
    fn a_side_below_zero_under_a_max_leaves_the_sign_to_the_other() {
        use BinaryOp::{Max, Min};
        let i = Interval::new;
        // max(x, y) − 1: the sides are x − 1 and y − 1.
        let shifted = root_of(|c, x, y| {
            let (m, one) = (c.binary(Max, x, y), c.constant(1.0));
            c.sub(m, one)
        });
        assert_eq!(shifted.side(i(2.0, 3.0)), i(1.0, 2.0));
        // y < 1 throughout: the sign is x − 1's.
        assert_eq!(shifted.sign_branch(i(0.0, 3.0), i(0.0, 0.5)), Branch::First);
        assert_eq!(
            shifted.sign_branch(i(0.0, 0.5), i(0.0, 3.0)),
            Branch::Second
        );
        // y − 1 reaches 0: where x − 1 < 0 there, f = 0 and x − 1 is not.
        assert_eq!(shifted.sign_branch(i(0.0, 3.0), i(0.0, 1.0)), Branch::Open);
        // −2·min(x, y) + 3 is the larger of −2x + 3 and −2y + 3: y ≥ 2 puts
        // the second below 0.
        let scaled = root_of(|c, x, y| {
            let (m, k, three) = (c.binary(Min, x, y), c.constant(-2.0), c.constant(3.0));
            let p = c.mul(k, m);
            c.add(p, three)
        });
        assert!(scaled.larger);
        assert_eq!(scaled.side(i(2.0, 3.0)), i(-3.0, -1.0));
        assert_eq!(scaled.sign_branch(i(-1.0, 1.0), i(2.0, 3.0)), Branch::First);
        // 1 − max(x, y), the smaller of 1 − x and 1 − y: y ≤ 0.5 puts the
        // second above 0.
        let flipped = root_of(|c, x, y| {
            let (m, one) = (c.binary(Max, x, y), c.constant(1.0));
            c.sub(one, m)
        });
        assert!(!flipped.larger);
        assert_eq!(flipped.sign_branch(i(0.0, 3.0), i(0.0, 0.5)), Branch::First);
        assert_eq!(flipped.sign_branch(i(0.0, 3.0), i(2.0, 3.0)), Branch::Open);
        // Unbounded enclosures decide nothing.
        let whole = Interval::ENTIRE;
        assert_eq!(shifted.sign_branch(whole, i(0.0, 0.5)), Branch::Open);
    }

    #[test]
    fn branches_cut_off_by_a_decision_do_not_split_the_pattern() {
        let mut ctx = Context::new();
        let (x, y) = (ctx.var(Var::X), ctx.var(Var::Y));
        let ay = ctx.unary(UnaryOp::Abs, y);
        let f = ctx.binary(BinaryOp::Max, x, ay);
        let points = branch_points(&ctx, f);
        let max_at = points.iter().position(|p| p.node == f).unwrap();
        let index = PointIndex::new(&points);
        let mut a = vec![Branch::Open; points.len()];
        a[max_at] = Branch::First;
        let mut b = vec![Branch::First; points.len()];
        b[max_at] = Branch::First;
        assert_eq!(
            normalise(&ctx, f, &points, &index, &a),
            normalise(&ctx, f, &points, &index, &b)
        );
        // Where the max keeps abs(y), its branch still counts.
        let mut c = vec![Branch::First; points.len()];
        c[max_at] = Branch::Second;
        assert_eq!(normalise(&ctx, f, &points, &index, &c), c);
    }
}
