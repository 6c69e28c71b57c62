//! f64 evaluation over many points per call, one dispatch per instruction
//! per chunk.

use super::Evaluator;
use crate::expr::op::{choose, powi, quotient, BinaryOp, UnaryOp};
use crate::expr::tape::instr::{Instr, Slot};
use crate::expr::tape::Tape;

/// Points per chunk of the batch evaluator: long enough for the per-instruction
/// dispatch to vanish, short enough that the register file stays in cache.
pub const LANES: usize = 64;

/// Evaluates a tape at many points per call, in f64.
///
/// Each instruction runs over a chunk of [`LANES`] points, so the dispatch
/// cost is paid once per chunk and the inner loops vectorise.
#[derive(Debug, Clone)]
pub struct BatchEvaluator<'t> {
    tape: &'t Tape,
    slots: Vec<f64>,
}

impl<'t> BatchEvaluator<'t> {
    /// Prepares the register file (constants broadcast to every lane).
    pub fn new(tape: &'t Tape) -> Self {
        let mut scalar = Evaluator::<f64>::new(tape);
        let mut slots = vec![0.0; tape.slot_count * LANES];
        for (s, v) in scalar.slots.iter_mut().enumerate() {
            slots[s * LANES..(s + 1) * LANES].fill(*v);
        }
        Self { tape, slots }
    }

    /// Evaluates every output at `n = outputs[0].len()` points.
    ///
    /// `inputs[v]` holds the values of variable `v` (x, y, z, dx, dy, dz); a
    /// variable the tape does not read may be given as an empty slice, and
    /// trailing ones may be omitted.
    ///
    /// # Panics
    /// When an input the tape reads is shorter than the outputs, or the number
    /// of output slices differs from the tape's.
    pub fn eval(&mut self, inputs: &[&[f64]], outputs: &mut [&mut [f64]]) {
        assert_eq!(
            outputs.len(),
            self.tape.outputs.len(),
            "one slice per output"
        );
        let n = outputs.first().map_or(0, |o| o.len());
        for &(_, var) in &self.tape.inputs {
            let len = inputs.get(var.index()).map_or(0, |s| s.len());
            assert!(
                len >= n,
                "input `{}` has {len} values for {n} points",
                var.name()
            );
        }
        let mut start = 0;
        while start < n {
            let m = LANES.min(n - start);
            for &(s, var) in &self.tape.inputs {
                let src = &inputs[var.index()][start..start + m];
                self.slots[s as usize * LANES..s as usize * LANES + m].copy_from_slice(src);
            }
            self.run_chunk();
            for (o, &s) in outputs.iter_mut().zip(&self.tape.outputs) {
                o[start..start + m]
                    .copy_from_slice(&self.slots[s as usize * LANES..s as usize * LANES + m]);
            }
            start += m;
        }
    }

    fn run_chunk(&mut self) {
        let slots = &mut self.slots;
        let lane = |s: Slot| s as usize * LANES;
        for instr in &self.tape.body {
            match *instr {
                Instr::Binary { op, out, a, b } => {
                    let mut va = [0.0; LANES];
                    let mut vb = [0.0; LANES];
                    va.copy_from_slice(&slots[lane(a)..lane(a) + LANES]);
                    vb.copy_from_slice(&slots[lane(b)..lane(b) + LANES]);
                    let dst = &mut slots[lane(out)..lane(out) + LANES];
                    match op {
                        BinaryOp::Add => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = x + y),
                        BinaryOp::Sub => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = x - y),
                        BinaryOp::Mul => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = x * y),
                        BinaryOp::Div => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = quotient(*x, *y)),
                        _ => dst
                            .iter_mut()
                            .zip(va.iter().zip(&vb))
                            .for_each(|(d, (x, y))| *d = op.eval(*x, *y)),
                    }
                }
                Instr::Unary { op, out, a } => {
                    let mut va = [0.0; LANES];
                    va.copy_from_slice(&slots[lane(a)..lane(a) + LANES]);
                    let dst = &mut slots[lane(out)..lane(out) + LANES];
                    match op {
                        UnaryOp::Neg => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = -x),
                        _ => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = op.eval(*x)),
                    }
                }
                Instr::PowI { out, a, n } => {
                    let mut va = [0.0; LANES];
                    va.copy_from_slice(&slots[lane(a)..lane(a) + LANES]);
                    let dst = &mut slots[lane(out)..lane(out) + LANES];
                    // One branch per instruction, not per lane; the shared
                    // powi keeps batch and point results identical.
                    match n {
                        2 => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, 2)),
                        3 => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, 3)),
                        4 => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, 4)),
                        _ => dst.iter_mut().zip(&va).for_each(|(d, x)| *d = powi(*x, n)),
                    }
                }
                Instr::Choose { out, c, p, n } => {
                    for k in 0..LANES {
                        slots[lane(out) + k] =
                            choose(slots[lane(c) + k], slots[lane(p) + k], slots[lane(n) + k]);
                    }
                }
            }
        }
    }
}
