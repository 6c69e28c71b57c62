//! Compiling an expression graph to a tape: slots, the prelude, the body.

use super::instr::{instruction, Instr, Slot};
use super::point;
use super::value::register_file;
#[cfg(feature = "jit")]
use super::MachineCode;
use super::Tape;
use crate::expr::context::Context;
use crate::expr::op::{BinaryOp, Node, Op, UnaryOp, Var};
use crate::types::{DecInterval, Decoration};

impl Tape {
    /// Compiles `outputs` of `ctx` into one tape. Walks with explicit stacks.
    ///
    /// ```
    /// use lgc::{Context, Var, Tape, Evaluator};
    /// let mut ctx = Context::new();
    /// let x = ctx.var(Var::X);
    /// let f = ctx.powi(x, 2);
    /// let df = ctx.partial(f, Var::X);
    /// let tape = Tape::new(&ctx, &[f, df]);
    /// let mut eval = Evaluator::<f64>::new(&tape);
    /// assert_eq!(eval.eval(&[3.0, 0.0, 0.0, 0.0, 0.0, 0.0]), &[9.0, 6.0]);
    /// ```
    pub fn new(ctx: &Context, outputs: &[Node]) -> Tape {
        let order = ctx.topological_order(outputs);
        // Per node of the context, indexed by it (a tape is compiled per
        // specialised shape, tens of times per octree: hashing each node's
        // slot and last use was most of the compile).
        let mut slot_of: Vec<Slot> = vec![Slot::MAX; ctx.len()];
        // Slots 0..6 hold the inputs x, y, z, dx, dy, dz (read or not), so an
        // evaluation starts with one copy of six values.
        let mut next_slot: Slot = Var::ALL.len() as Slot;
        let mut fresh = || {
            let s = next_slot;
            next_slot += 1;
            s
        };
        let mut tape = Tape {
            slot_count: 0,
            constants: Vec::new(),
            inputs: Vec::new(),
            prelude: Vec::new(),
            body: Vec::new(),
            point: Vec::new(),
            outputs: Vec::new(),
            keeps_decoration: Vec::new(),
            #[cfg(feature = "jit")]
            machine_code: MachineCode::default(),
            slots_fit: std::sync::OnceLock::new(),
        };

        // Pass 1: constants, inputs and constant subexpressions get pinned slots.
        let mut is_constant = vec![false; ctx.len()];
        let mut body_nodes = Vec::new();
        for &node in &order {
            let op = ctx.get(node);
            let constant = match op {
                Op::Const(_) => true,
                Op::Var(_) => false,
                _ => op.children().all(|c| is_constant[c.index()]),
            };
            is_constant[node.index()] = constant;
            match *op {
                Op::Const(c) => {
                    let s = fresh();
                    tape.constants.push((s, c.value()));
                    slot_of[node.index()] = s;
                }
                Op::Var(v) => {
                    let s = v.index() as Slot;
                    tape.inputs.push((s, v));
                    slot_of[node.index()] = s;
                }
                _ if constant => {
                    let s = fresh();
                    tape.prelude.push(instruction(op, s, &slot_of));
                    slot_of[node.index()] = s;
                }
                _ => body_nodes.push(node),
            }
        }

        // Pass 2: body values live from their instruction to their last use.
        let mut pinned = vec![false; ctx.len()];
        for &n in outputs {
            pinned[n.index()] = true;
        }
        let mut last_use: Vec<usize> = vec![usize::MAX; ctx.len()];
        for (i, &node) in body_nodes.iter().enumerate() {
            for child in ctx.get(node).children() {
                last_use[child.index()] = i;
            }
        }
        let mut free: Vec<Slot> = Vec::new();
        for (i, &node) in body_nodes.iter().enumerate() {
            let op = ctx.get(node);
            // At most three operands, each once: kept on the stack, not
            // collected.
            let mut dying = [Node(0); 3];
            let mut count = 0;
            for c in op.children() {
                if !dying[..count].contains(&c)
                    && last_use[c.index()] == i
                    && !pinned[c.index()]
                    && !is_constant[c.index()]
                    && !matches!(ctx.get(c), Op::Var(_))
                {
                    dying[count] = c;
                    count += 1;
                }
            }
            let dying = &mut dying[..count];
            dying.sort();
            // The result is allocated before the dying operands are freed, so an
            // instruction never writes a slot it also reads: evaluators may
            // stream operands and result without copies.
            let out = free.pop().unwrap_or_else(&mut fresh);
            tape.body.push(instruction(op, out, &slot_of));
            free.extend(dying.iter().map(|c| slot_of[c.index()]));
            slot_of[node.index()] = out;
        }
        tape.outputs = outputs.iter().map(|n| slot_of[n.index()]).collect();
        tape.slot_count = next_slot as usize;
        tape.point = point::compile(&tape.body, &tape.constants);
        tape.keeps_decoration = tape.judge_decorations();
        tape
    }

    /// [`Tape::output_keeps_decoration`] for every output, from the
    /// instructions.
    pub(super) fn judge_decorations(&self) -> Vec<bool> {
        // The prelude's constants (`sqrt(2)`) are decided by their values.
        let constants: Vec<DecInterval> = register_file(self);
        let mut keeps: Vec<bool> = constants
            .iter()
            .map(|v| v.decoration() == Decoration::Dac)
            .collect();
        // Slots are reused, so the flags are followed in execution order:
        // each write sets its slot's flag from what it read.
        for instr in &self.body {
            let (out, ok) = match *instr {
                Instr::Unary { op, out, a } => {
                    let total = op.domain().is_none()
                        && !matches!(
                            op,
                            UnaryOp::Sign
                                | UnaryOp::Dirac
                                | UnaryOp::Tan
                                | UnaryOp::Floor
                                | UnaryOp::Ceil
                                | UnaryOp::Round
                        );
                    (out, total && keeps[a as usize])
                }
                Instr::Binary { op, out, a, b } => {
                    let total = op.domain().is_none()
                        && !matches!(op, BinaryOp::Div | BinaryOp::Atan2 | BinaryOp::Pow);
                    (out, total && keeps[a as usize] && keeps[b as usize])
                }
                Instr::PowI { out, a, n } => (out, n >= 0 && keeps[a as usize]),
                Instr::Choose { out, .. } => (out, false),
            };
            keeps[out as usize] = ok;
        }
        self.outputs.iter().map(|&o| keeps[o as usize]).collect()
    }
}
