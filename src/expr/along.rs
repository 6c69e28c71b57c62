//! A polynomial formula restricted to a segment of a line: the
//! coefficients of `F(s) = f(p + s·d)` in `s`, with a certified bound of
//! their error over the segment.
//!
//! Along a ray, a polynomial f of degree n is a polynomial of degree n in the
//! ray's parameter. [`AlongLine`] compiles a tape made only of `+ − ×`,
//! integer powers and division by exact constants into a program over
//! truncated Taylor series (jets) in `s`; run at a point `p = o + t₀·d` of a
//! ray, it gives F's coefficients about `t₀`.
//!
//! The series are taken in the unit parameter `u = s/h` of the segment
//! `|s| ≤ h` the caller names, and errors are measured in the norm
//! `‖c‖ = Σ |c_k|`, which bounds `|Σ c_k u^k|` for `|u| ≤ 1` and is
//! submultiplicative. In `u`, a coefficient's absolute error is its error in
//! the norm, so the least normal f64 that every bound adds covers the
//! coefficients' underflows, however far the ray reaches (in `s`, a
//! coefficient of 10⁻³⁵⁰ flushed to 0 would weigh 10⁻³⁵⁰·h⁴ on the segment).
//! Each jet carries a bound of the distance of its f64
//! coefficients to the real ones of the real line through `o` in direction
//! `d` (the rounding of `p`, of every operation, and the enclosures of the
//! tape's constant subexpressions), and a bound of its own norm: one number
//! each, whatever the degree, so the bound costs a few operations a step.

use super::op::{BinaryOp, UnaryOp, Var};
use super::tape::instr::{Instr, Slot};
use super::tape::value::TapeValue;
use super::tape::Tape;
use crate::types::rounding::{up_sum, U};
use crate::types::Interval;
use glam::DVec3;

/// The highest degree compiled: beyond it the coefficients' radii grow
/// past use, and the ray's own search does better.
pub const MAX_DEGREE: usize = 8;

/// Coefficients a jet holds.
const TERMS: usize = MAX_DEGREE + 1;

/// A truncated power series in the unit parameter `u` with f64
/// coefficients, within `error` of the real one and of norm at most `size`
/// (both in the norm `Σ |c_k|`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet {
    /// Coefficients, by power of `s`.
    pub c: [f64; TERMS],
    /// A bound of the norm of the difference from the real series.
    pub error: f64,
    /// A bound of the norm of `c`.
    pub size: f64,
}

impl Default for Jet {
    fn default() -> Jet {
        Jet {
            c: [0.0; TERMS],
            error: 0.0,
            size: 0.0,
        }
    }
}

impl Jet {
    /// The constant `v`, within `r`.
    fn constant(v: f64, r: f64) -> Jet {
        let mut j = Jet::default();
        j.c[0] = v;
        j.error = r;
        j.size = v.abs();
        j
    }
}

/// A step's arithmetic: `r = x ∘ y` for operands of the degrees given
/// (read only by the kernels whose degrees are left to run time).
type Kernel = fn(&Jet, &Jet, &mut Jet, (usize, usize));

/// One step of the program, on registers: operands of degrees `da` and
/// `db` (or `degree`); terms above a value's degree are not read.
#[derive(Debug, Clone, Copy)]
enum Step {
    /// `a + b`, `a − b` or `a × b`: the kernel, chosen for the degrees when
    /// compiled (a run then dispatches once per step).
    Binary {
        out: Slot,
        a: Slot,
        b: Slot,
        degrees: (usize, usize),
        kernel: Kernel,
    },
    Neg {
        out: Slot,
        a: Slot,
        degree: u8,
    },
    /// `a / by`, `by` an exact nonzero constant.
    Quot {
        out: Slot,
        a: Slot,
        by: f64,
        degree: u8,
    },
}

impl Step {
    /// The register written (above every register read).
    fn out(&self) -> Slot {
        match *self {
            Step::Binary { out, .. } | Step::Neg { out, .. } | Step::Quot { out, .. } => out,
        }
    }

    /// The registers read.
    fn reads(&self) -> [Slot; 2] {
        match *self {
            Step::Binary { a, b, .. } => [a, b],
            Step::Neg { a, .. } | Step::Quot { a, .. } => [a, a],
        }
    }
}

/// The kernel `$kernel::<A, B>` with the degrees fixed where each is at
/// most 4 (the common ones: a quartic's), else with them left to run time.
macro_rules! by_degrees {
    ($da:expr, $db:expr => $kernel:ident) => {
        by_degrees!(@pairs $da, $db, $kernel,
            (0, 0) (0, 1) (0, 2) (0, 3) (0, 4) (1, 0) (1, 1) (1, 2) (1, 3) (1, 4)
            (2, 0) (2, 1) (2, 2) (2, 3) (2, 4) (3, 0) (3, 1) (3, 2) (3, 3) (3, 4)
            (4, 0) (4, 1) (4, 2) (4, 3) (4, 4))
    };
    (@pairs $da:expr, $db:expr, $kernel:ident, $(($a:literal, $b:literal))*) => {
        match ($da, $db) {
            $(($a, $b) => $kernel::<$a, $b> as Kernel,)*
            _ => $kernel::<ANY, ANY> as Kernel,
        }
    };
}

/// A polynomial tape compiled to run on jets along a line.
#[derive(Debug, Clone)]
pub struct AlongLine {
    steps: Vec<Step>,
    /// Slots holding constants (exact ones and the prelude's enclosures), set
    /// once in a register file.
    constants: Vec<(Slot, Jet)>,
    slot_count: usize,
    /// The slots of x, y and z, for those the tape reads.
    inputs: [Option<Slot>; 3],
    output: Slot,
    degree: usize,
}

/// The midpoint and radius of a bounded interval, rounded up; `None` for an
/// empty or unbounded one.
fn mid_rad(v: Interval) -> Option<(f64, f64)> {
    if v.is_empty() || !v.is_bounded() {
        return None;
    }
    if v.inf() == v.sup() {
        return Some((v.inf(), 0.0));
    }
    let m = v.mid();
    Some((m, up_sum((v.sup() - m).max(m - v.inf()))))
}

impl AlongLine {
    /// Compiles output 0 of `tape`, or `None` where it is not a polynomial
    /// in x, y and z of degree at most [`MAX_DEGREE`] built from `+ − ×`,
    /// non-negative integer powers and division by exact constants (the
    /// constant subexpressions, computed once, may use any function).
    pub fn compile(tape: &Tape) -> Option<AlongLine> {
        if [Var::Dx, Var::Dy, Var::Dz].iter().any(|&v| tape.uses(v)) {
            return None;
        }
        let slots = tape.slot_count();
        // The constant subexpressions, enclosed: every slot the prelude or
        // the constants write, with its interval.
        let mut known: Vec<Option<Interval>> = vec![None; slots];
        for &(s, v) in tape.constants() {
            known[s as usize] = Some(Interval::point(v));
        }
        for instr in tape.prelude() {
            let get = |s: Slot| known[s as usize];
            let (out, v) = match *instr {
                Instr::Unary { op, out, a } => (out, get(a).map(|a| Interval::unary(op, a))),
                Instr::Binary { op, out, a, b } => (
                    out,
                    get(a).zip(get(b)).map(|(a, b)| Interval::binary(op, a, b)),
                ),
                Instr::PowI { out, a, n } => (out, get(a).map(|a| Interval::powi(a, n))),
                Instr::Choose { out, c, p, n } => (
                    out,
                    match (get(c), get(p), get(n)) {
                        (Some(c), Some(p), Some(n)) => Some(Interval::choose(c, p, n)),
                        _ => None,
                    },
                ),
            };
            known[out as usize] = Some(v?);
        }
        // Registers in single assignment: the inputs x, y, z first, then
        // the constants, then one per step (so a step never writes what it
        // reads, and no value is moved). Per tape slot as the body runs:
        // its register, degree, and value if an exact constant (a divisor
        // must be one).
        let mut value: Vec<Option<(Slot, u8, Option<f64>)>> = vec![None; slots];
        let mut inputs = [None; 3];
        for (i, var) in [Var::X, Var::Y, Var::Z].into_iter().enumerate() {
            if tape.uses(var) {
                inputs[i] = Some(i as Slot);
                value[var.index()] = Some((i as Slot, 1, None));
            }
        }
        let mut constants = Vec::new();
        for (s, v) in known.iter().enumerate() {
            if let Some(v) = *v {
                let (m, r) = mid_rad(v)?;
                let register = 3 + constants.len() as Slot;
                constants.push((register, Jet::constant(m, r)));
                value[s] = Some((register, 0, (r == 0.0).then_some(m)));
            }
        }
        let mut steps = Vec::new();
        let mut next = 3 + constants.len() as Slot;
        let mut fresh = || {
            next += 1;
            next - 1
        };
        let fits = |d: usize| (d <= MAX_DEGREE).then_some(d as u8);
        for instr in tape.body() {
            let (out, v) = match *instr {
                Instr::Binary { op, out, a, b } => {
                    let ((a, da, _), (b, db, exact)) = (value[a as usize]?, value[b as usize]?);
                    let (da, db) = (usize::from(da), usize::from(db));
                    let mut binary = |kernel: Kernel| Step::Binary {
                        out: fresh(),
                        a,
                        b,
                        degrees: (da, db),
                        kernel,
                    };
                    let step = match op {
                        BinaryOp::Add => (da.max(db) as u8, binary(by_degrees!(da, db => sum_of))),
                        BinaryOp::Sub => (
                            da.max(db) as u8,
                            binary(by_degrees!(da, db => difference_of)),
                        ),
                        BinaryOp::Mul => {
                            (fits(da + db)?, binary(by_degrees!(da, db => product_of)))
                        }
                        BinaryOp::Div => {
                            let by = exact.filter(|&q| q != 0.0 && q.is_finite())?;
                            (
                                da as u8,
                                Step::Quot {
                                    out: fresh(),
                                    a,
                                    by,
                                    degree: da as u8,
                                },
                            )
                        }
                        _ => return None,
                    };
                    steps.push(step.1);
                    (out, (step.1.out(), step.0, None))
                }
                Instr::Unary {
                    op: UnaryOp::Neg,
                    out,
                    a,
                } => {
                    let (a, d, _) = value[a as usize]?;
                    let step = Step::Neg {
                        out: fresh(),
                        a,
                        degree: d,
                    };
                    steps.push(step);
                    (out, (step.out(), d, None))
                }
                Instr::PowI { out, a, n } if n >= 1 => {
                    let (a, da, _) = value[a as usize]?;
                    let d = fits(usize::from(da) * n as usize)?;
                    // Square and multiply.
                    let (mut p, mut dp) = (a, da);
                    let mut result: Option<(Slot, u8)> = None;
                    let mut n = n as u32;
                    loop {
                        if n & 1 == 1 {
                            result = Some(match result {
                                None => (p, dp),
                                Some((r, dr)) => {
                                    let step = multiply(fresh(), (r, dr), (p, dp));
                                    steps.push(step);
                                    (step.out(), dr + dp)
                                }
                            });
                        }
                        n >>= 1;
                        if n == 0 {
                            break;
                        }
                        let step = multiply(fresh(), (p, dp), (p, dp));
                        steps.push(step);
                        (p, dp) = (step.out(), 2 * dp);
                    }
                    (out, (result?.0, d, None))
                }
                _ => return None,
            };
            value[out as usize] = Some(v);
        }
        let (output, degree, _) = value[*tape.output_slots().first()? as usize]?;
        // What `run` relies on: each step writes a register of the file,
        // above those it reads.
        let numbered =
            |step: &Step| step.out() < next && step.reads().iter().all(|&r| r < step.out());
        if !steps.iter().all(numbered) {
            return None;
        }
        Some(AlongLine {
            steps,
            constants,
            slot_count: next as usize,
            inputs,
            output,
            degree: usize::from(degree),
        })
    }

    /// The degree of F in `s`.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// A register file with the constants in place.
    pub fn registers(&self) -> Vec<Jet> {
        let mut regs = vec![Jet::default(); self.slot_count];
        for &(s, j) in &self.constants {
            regs[s as usize] = j;
        }
        regs
    }

    /// F's coefficients about `t0` on the ray `o + t·d`, in the unit
    /// parameter of the segment `|t − t0| ≤ h`: `F(t₀ + h·u) = Σ c_k u^k`
    /// for the real line up to [`AlongLine::degree`], the f64 coefficients
    /// within the jet's `error` in the norm `Σ |c_k|` (so F is within it of
    /// their sum for every `|u| ≤ 1`). `regs` is from
    /// [`AlongLine::registers`]. The bounds may be infinite or NaN where
    /// something overflowed: callers test them.
    ///
    /// # Panics
    /// When `regs` is shorter than [`AlongLine::registers`] makes it.
    pub fn coefficients<'r>(
        &self,
        regs: &'r mut [Jet],
        (o, d): (DVec3, DVec3),
        t0: f64,
        h: f64,
    ) -> &'r Jet {
        assert!(regs.len() >= self.slot_count, "register file too small");
        for (i, slot) in self.inputs.iter().enumerate() {
            if let Some(s) = *slot {
                // The ray's point at t0 (a product and a sum) and its
                // step across the segment (a product), each rounded once.
                let step = t0 * d[i];
                let p = step + o[i];
                let across = d[i] * h;
                let j = &mut regs[s as usize];
                j.c[0] = p;
                j.c[1] = across;
                j.error = up_sum(U * (step.abs() + p.abs() + across.abs()));
                j.size = up_sum(p.abs() + across.abs());
            }
        }
        for step in &self.steps {
            // SAFETY: the steps were compiled for `slot_count` registers
            // (asserted above), each writing one above those it reads.
            unsafe { run(step, regs) };
        }
        &regs[self.output as usize]
    }
}

/// `x·y` into `r`, for operands of degrees `da` and `db`: the real
/// product is within `‖X − x‖·‖Y‖ + ‖x‖·‖Y − y‖` of the f64 mids', and
/// each coefficient sums at most `min(da, db) + 1` products, each rounded
/// with its sum (γ of their sizes, whose norms sum to at most ‖x‖·‖y‖).
#[inline(always)]
fn product(da: usize, db: usize, x: &Jet, y: &Jet, r: &mut Jet) {
    for k in 0..da + db + 1 {
        let mut m = 0.0f64;
        for i in k.saturating_sub(db)..k.min(da) + 1 {
            m += x.c[i] * y.c[k - i];
        }
        r.c[k] = m;
    }
    let gamma = 2.0 * (da.min(db) + 2) as f64 * U;
    let sizes = x.size * y.size;
    r.error = up_sum(x.error * (y.size + y.error) + x.size * y.error + gamma * sizes);
    r.size = up_sum(sizes + gamma * sizes);
}

/// `x ± y` into `r`, for operands of degrees `da` and `db` (each sum
/// rounded once: u of its size).
#[inline(always)]
fn sum(da: usize, db: usize, minus: bool, x: &Jet, y: &Jet, r: &mut Jet) {
    for k in 0..da.max(db) + 1 {
        // Terms above an operand's degree are not its own: they count as 0.
        let xk = if k <= da { x.c[k] } else { 0.0 };
        let yk = if k <= db { y.c[k] } else { 0.0 };
        r.c[k] = if minus { xk - yk } else { xk + yk };
    }
    let sizes = x.size + y.size;
    r.error = up_sum(x.error + y.error + 2.0 * U * sizes);
    r.size = up_sum(sizes);
}

/// A degree left to run time in the kernels.
const ANY: usize = usize::MAX;

/// The degrees `A` and `B` when fixed (not [`ANY`]), else those given.
#[inline(always)]
fn degrees<const A: usize, const B: usize>(given: (usize, usize)) -> (usize, usize) {
    if A == ANY {
        given
    } else {
        (A, B)
    }
}

/// [`product`] with the degrees fixed, so that its loops unroll.
fn product_of<const A: usize, const B: usize>(
    x: &Jet,
    y: &Jet,
    r: &mut Jet,
    given: (usize, usize),
) {
    let (da, db) = degrees::<A, B>(given);
    product(da, db, x, y, r)
}

/// [`sum`] with the degrees fixed.
fn sum_of<const A: usize, const B: usize>(x: &Jet, y: &Jet, r: &mut Jet, given: (usize, usize)) {
    let (da, db) = degrees::<A, B>(given);
    sum(da, db, false, x, y, r)
}

/// [`sum`] of `x − y` with the degrees fixed.
fn difference_of<const A: usize, const B: usize>(
    x: &Jet,
    y: &Jet,
    r: &mut Jet,
    given: (usize, usize),
) {
    let (da, db) = degrees::<A, B>(given);
    sum(da, db, true, x, y, r)
}

/// The step `out = a × b` for operands (register, degree).
fn multiply(out: Slot, (a, da): (Slot, u8), (b, db): (Slot, u8)) -> Step {
    let (da, db) = (usize::from(da), usize::from(db));
    Step::Binary {
        out,
        a,
        b,
        degrees: (da, db),
        kernel: by_degrees!(da, db => product_of),
    }
}

/// Runs one step on the register file: its result goes to a register
/// above every one it reads.
///
/// # Safety
/// The step's registers are below `regs.len()`, and those it reads below
/// the one it writes ([`AlongLine::compile`] checks this of every step), so
/// the per-operand bounds checks (a good share of a run) are left out.
#[inline(always)]
unsafe fn run(step: &Step, regs: &mut [Jet]) {
    let base = regs.as_mut_ptr();
    // SAFETY (all accesses below): in bounds by the contract, and the
    // register written is none of those read, so no reference aliases it.
    let r = unsafe { &mut *base.add(step.out() as usize) };
    let read = |a: Slot| unsafe { &*base.add(a as usize) };
    match *step {
        Step::Binary {
            a,
            b,
            degrees,
            kernel,
            ..
        } => kernel(read(a), read(b), r, degrees),
        Step::Neg { a, degree, .. } => {
            let x = read(a);
            for k in 0..usize::from(degree) + 1 {
                r.c[k] = -x.c[k];
            }
            (r.error, r.size) = (x.error, x.size);
        }
        Step::Quot { a, by, degree, .. } => {
            let x = read(a);
            for k in 0..usize::from(degree) + 1 {
                r.c[k] = x.c[k] / by;
            }
            let size = up_sum(x.size / by.abs());
            r.error = up_sum(x.error / by.abs() + 2.0 * U * size);
            r.size = size;
        }
    }
}
