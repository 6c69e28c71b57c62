//! Changes of coordinates (`translate`, `rotate`, `scale`) left in the graph
//! as remaps, and their expansion into plain operations.

use super::context::Context;
use super::op::{Node, Op, Var};

/// Why no pass but [`Context::expand`] may meet a remap.
pub(crate) const UNEXPANDED: &str =
    "a remap reached a pass that needs an expanded graph: lowering expands every result";

/// A change of coordinates `q ↦ m·q + b`. Entries are nodes, so they may be
/// symbolic constants or even depend on the coordinates; composition and
/// application stay exact algebra either way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct AffineMap {
    pub m: [[Node; 3]; 3],
    pub b: [Node; 3],
}

impl AffineMap {
    fn entries(&self) -> impl Iterator<Item = Node> + '_ {
        self.m.iter().flatten().chain(&self.b).copied()
    }
}

impl Context {
    /// `f` in the coordinates `q ↦ m·q + b` of `change`, left for
    /// [`Context::expand`]: a chain of transforms costs one node each, and
    /// expansion composes them top-down, so building stays linear however
    /// transforms and operations alternate.
    pub(crate) fn remap(&mut self, f: Node, change: AffineMap) -> Node {
        let id = u32::try_from(self.remaps.len()).expect("more than 2^32 transforms");
        self.remaps.push(change);
        self.intern(Op::Remap(f, id))
    }

    /// The identity change of coordinates.
    pub(crate) fn identity_affine(&mut self) -> AffineMap {
        let (zero, one) = (self.constant(0.0), self.constant(1.0));
        AffineMap {
            m: std::array::from_fn(|i| std::array::from_fn(|j| if i == j { one } else { zero })),
            b: [zero; 3],
        }
    }

    /// `m·v` for a vector of nodes.
    pub(crate) fn apply_linear(&mut self, m: &[[Node; 3]; 3], v: [Node; 3]) -> [Node; 3] {
        std::array::from_fn(|i| {
            let t0 = self.mul(m[i][0], v[0]);
            let t1 = self.mul(m[i][1], v[1]);
            let t2 = self.mul(m[i][2], v[2]);
            let s = self.add(t0, t1);
            self.add(s, t2)
        })
    }

    /// The id of the frame `a`, interned with its coordinate nodes.
    fn frame(&mut self, a: AffineMap) -> u32 {
        if let Some(&id) = self.frame_ids.get(&a) {
            return id;
        }
        let xyz = [Var::X, Var::Y, Var::Z].map(|v| self.var(v));
        let linear = self.apply_linear(&a.m, xyz);
        let coords = std::array::from_fn(|i| self.add(linear[i], a.b[i]));
        let id = u32::try_from(self.frames.len()).expect("more than 2^32 frames");
        self.frames.push((a, coords));
        self.frame_ids.insert(a, id);
        id
    }

    /// `root` with every [`Op::Remap`] beneath it carried out: each operand
    /// rebuilt (through the folding builders) in its own coordinates, nested
    /// changes of coordinates composed into one affine map per frame. Each
    /// node is rebuilt once per frame it is used in, so the work is the size
    /// of the result. Walks with an explicit stack.
    pub(crate) fn expand(&mut self, root: Node) -> Node {
        if self.remaps.is_empty() {
            return root;
        }
        enum Task {
            Enter(Node, u32),
            Leave(Node, u32),
            /// A remap's own entries are expanded: descend into its operand.
            Descend(Node, u32),
            /// A remap's operand is expanded in frame `.2`.
            Done(Node, u32, u32),
        }
        let identity = self.identity_affine();
        let top = self.frame(identity);
        let mut stack = vec![Task::Enter(root, top)];
        while let Some(task) = stack.pop() {
            // Its memo may grow by hash hits alone: it counts against the
            // limit too (four entries a node).
            if self.exhausted || self.expanded.len() / 4 >= self.node_limit {
                self.exhausted = true;
                return Node(0);
            }
            match task {
                Task::Enter(n, f) => {
                    if self.expanded.contains_key(&(n, f)) {
                        continue;
                    }
                    match *self.get(n) {
                        Op::Const(_) => {
                            self.expanded.insert((n, f), n);
                        }
                        Op::Var(v) => {
                            let coords = self.frames[f as usize].1;
                            let value = coords.get(v.index()).copied().unwrap_or(n);
                            self.expanded.insert((n, f), value);
                        }
                        Op::Remap(_, r) => {
                            stack.push(Task::Descend(n, f));
                            let change = self.remaps[r as usize];
                            stack.extend(change.entries().map(|e| Task::Enter(e, f)));
                        }
                        op => {
                            stack.push(Task::Leave(n, f));
                            stack.extend(op.children().map(|c| Task::Enter(c, f)));
                        }
                    }
                }
                Task::Leave(n, f) => {
                    let m = |k: Node| self.expanded[&(k, f)];
                    let rebuilt = match *self.get(n) {
                        Op::Unary(op, a) => {
                            let a = m(a);
                            self.unary(op, a)
                        }
                        Op::Binary(op, a, b) => {
                            let (a, b) = (m(a), m(b));
                            self.binary(op, a, b)
                        }
                        Op::PowI(a, k) => {
                            let a = m(a);
                            self.powi(a, k)
                        }
                        Op::Choose(c, p, q) => {
                            let (c, p, q) = (m(c), m(p), m(q));
                            self.choose(c, p, q)
                        }
                        Op::Const(_) | Op::Var(_) | Op::Remap(..) => {
                            unreachable!("leaves and remaps are finished on entry")
                        }
                    };
                    self.expanded.insert((n, f), rebuilt);
                }
                Task::Descend(n, f) => {
                    let Op::Remap(operand, r) = *self.get(n) else {
                        unreachable!("only remaps descend")
                    };
                    let change = self.remaps[r as usize];
                    let e = |k: Node| self.expanded[&(k, f)];
                    let rel = AffineMap {
                        m: change.m.map(|row| row.map(e)),
                        b: change.b.map(e),
                    };
                    // The operand sees q' = rel.m·q + rel.b with q = F.m·p + F.b.
                    let outer = self.frames[f as usize].0;
                    let columns: [[Node; 3]; 3] =
                        std::array::from_fn(|j| self.apply_linear(&rel.m, outer.m.map(|r| r[j])));
                    let m = std::array::from_fn(|i| std::array::from_fn(|j| columns[j][i]));
                    let mb = self.apply_linear(&rel.m, outer.b);
                    let b = std::array::from_fn(|i| self.add(mb[i], rel.b[i]));
                    let inner = self.frame(AffineMap { m, b });
                    stack.push(Task::Done(n, f, inner));
                    stack.push(Task::Enter(operand, inner));
                }
                Task::Done(n, f, inner) => {
                    let Op::Remap(operand, _) = *self.get(n) else {
                        unreachable!("only remaps finish as remaps")
                    };
                    let value = self.expanded[&(operand, inner)];
                    self.expanded.insert((n, f), value);
                }
            }
        }
        self.expanded[&(root, top)]
    }

    /// The variables that `node` depends on.
    pub fn vars_used(&self, node: Node) -> Vec<Var> {
        let mut used: Vec<Var> = self
            .topological_order(&[node])
            .into_iter()
            .filter_map(|n| match self.get(n) {
                Op::Var(v) => Some(*v),
                _ => None,
            })
            .collect();
        used.sort();
        used
    }
}
