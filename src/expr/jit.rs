//! Point tapes compiled to machine code, with Cranelift.
//!
//! Rays evaluate f and g at single points millions of times; even with one
//! dispatch per operation ([`super::tape::point`]), the interpreter spends more on
//! reading opcodes and operand slots than on the arithmetic. Here a tape's
//! f64 body becomes one straight-line function: intermediate values stay in
//! registers, and only the outputs are written back.
//!
//! The compiled code computes exactly what the interpreter computes, bit for
//! bit, so the rounding bounds proved for the tape hold for it unchanged:
//! `+ − × ÷`, negation, `|·|` and `sqrt` are single correctly rounded (or
//! exact) IEEE operations in both, powers 2–4 are the interpreter's products
//! in its order, and every other operation (min and max, whose result for
//! `±0` is the compiler's choice, `choose`, other powers, transcendental
//! functions) calls the very function the interpreter calls. Cranelift never
//! fuses a product into an addition unless asked. Where the host has no
//! Cranelift backend, or compiling fails, the interpreter runs instead.

use super::op::{choose, powi, BinaryOp};
use super::tape::instr::Slot;
use super::tape::point::PointOp;
use super::tape::{Tape, Tier};
use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{self, types, AbiParam, InstBuilder, MemFlagsData, Value};
use cranelift_codegen::isa::OwnedTargetIsa;
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, Linkage, Module};
use std::any::Any;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// The machine code of one tape's f64 body: `code(slots)` runs the body over
/// the register file `slots` (inputs and constants in place) and writes its
/// outputs' slots.
pub(crate) struct Compiled {
    /// Owns the code's memory (freed on drop).
    module: Option<JITModule>,
    code: unsafe extern "C" fn(*mut f64),
    /// The program, whose operations the code passes by address to
    /// [`unary`] and [`binary`].
    _program: Box<[PointOp]>,
}

// SAFETY: after `finalize_definitions` the module's code and data are never
// written again; the code reads only the register file it is given and the
// program owned here, which lives as long as the code.
unsafe impl Send for Compiled {}
// SAFETY: as above; running the code from several threads at once shares
// nothing mutable but each caller's own register file.
unsafe impl Sync for Compiled {}

impl std::fmt::Debug for Compiled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Compiled").finish_non_exhaustive()
    }
}

impl Drop for Compiled {
    fn drop(&mut self) {
        if let Some(module) = self.module.take() {
            // SAFETY: the only pointer into the module's memory is `code`,
            // dropped with `self`.
            unsafe { module.free_memory() };
        }
        LIVE.fetch_sub(1, Ordering::Relaxed);
    }
}

impl Compiled {
    /// Runs the body over `slots`.
    ///
    /// # Safety
    /// `slots` holds at least the tape's slot count, with its inputs and
    /// constants in place.
    #[inline]
    pub(crate) unsafe fn run(&self, slots: &mut [f64]) {
        // SAFETY: the caller's contract; the code reads and writes only slots
        // the tape names, all below its slot count.
        unsafe { (self.code)(slots.as_mut_ptr()) }
    }
}

extern "C" fn min(a: f64, b: f64) -> f64 {
    BinaryOp::Min.eval(a, b)
}

extern "C" fn max(a: f64, b: f64) -> f64 {
    BinaryOp::Max.eval(a, b)
}

extern "C" fn power(a: f64, n: i32) -> f64 {
    powi(a, n)
}

extern "C" fn choice(c: f64, p: f64, n: f64) -> f64 {
    choose(c, p, n)
}

/// # Safety
/// `op` points to a live [`PointOp::Unary`].
unsafe extern "C" fn unary(op: *const PointOp, a: f64) -> f64 {
    // SAFETY: the caller's contract (the compiled code passes an element of
    // its own program).
    match unsafe { *op } {
        PointOp::Unary(op, ..) => op.eval(a),
        _ => f64::NAN,
    }
}

/// # Safety
/// `op` points to a live [`PointOp::Binary`].
unsafe extern "C" fn binary(op: *const PointOp, a: f64, b: f64) -> f64 {
    // SAFETY: as for `unary`.
    match unsafe { *op } {
        PointOp::Binary(op, ..) => op.eval(a, b),
        _ => f64::NAN,
    }
}

/// At most this much machine code is held at once (a tape's at each tier,
/// each a few pages): a formula whose min and max make thousands of
/// specialised shapes runs the rest in the interpreter, so memory stays
/// bounded.
const MAX_LIVE: usize = 2048;

/// Longer tapes run in the interpreter: compiling time and memory grow
/// faster than the tape (register allocation), and on a tape this long the
/// interpreter's dispatch is a small share of the work anyway.
const MAX_OPERATIONS: usize = 20_000;

/// The machine code of `tape` at `tier`, compiled on first call and cached
/// in the tape (shared by every evaluator and thread); `None` where it
/// cannot be.
pub(crate) fn machine_code(tape: &Tape, tier: Tier) -> Option<Arc<Compiled>> {
    let cached = tape.machine_code.at(tier).get_or_init(|| {
        compile(tape, tier).map(|code| Arc::new(code) as Arc<dyn Any + Send + Sync>)
    });
    cached
        .clone()
        .and_then(|code| code.downcast::<Compiled>().ok())
}

/// The machine code of `tape` at `tier` if some evaluator compiled it
/// already (`Some(None)`: it cannot be compiled); `None` if nobody has tried.
pub(crate) fn compiled_already(tape: &Tape, tier: Tier) -> Option<Option<Arc<Compiled>>> {
    let cached = tape.machine_code.at(tier).get()?;
    Some(
        cached
            .clone()
            .and_then(|code| code.downcast::<Compiled>().ok()),
    )
}

/// Machine code held now, at either tier.
static LIVE: AtomicUsize = AtomicUsize::new(0);

/// Compiles `tape`'s f64 body at `tier`; `None` where the host has no
/// backend, Cranelift refuses the function, the tape is longer than
/// [`MAX_OPERATIONS`] or [`MAX_LIVE`] pieces of code are held already (what
/// ran before then goes on running).
pub(crate) fn compile(tape: &Tape, tier: Tier) -> Option<Compiled> {
    if tape.point_program().len() > MAX_OPERATIONS {
        return None;
    }
    if LIVE.fetch_add(1, Ordering::Relaxed) >= MAX_LIVE {
        LIVE.fetch_sub(1, Ordering::Relaxed);
        return None;
    }
    let compiled = compile_program(
        tape.point_program(),
        tape.output_slots(),
        tape.slot_count(),
        tier,
    );
    if compiled.is_err() {
        LIVE.fetch_sub(1, Ordering::Relaxed);
    }
    compiled.ok()
}

/// Tapes of at most this many operations are compiled without Cranelift's
/// optimisations even at [`Tier::Optimised`]: there is little for them to
/// find in a short tape that was simplified as it was built, and compiling
/// takes less.
const QUICK_OPERATIONS: usize = 16;

/// The host's instruction set, as Cranelift targets it (detected once),
/// with optimisations and the backtracking register allocator, or neither.
fn host_isa(optimise: bool) -> Option<OwnedTargetIsa> {
    static ISA: [OnceLock<Option<OwnedTargetIsa>>; 2] = [OnceLock::new(), OnceLock::new()];
    ISA[usize::from(optimise)]
        .get_or_init(|| {
            let mut flags = settings::builder();
            let (level, allocator) = match optimise {
                true => ("speed", "backtracking"),
                false => ("none", "single_pass"),
            };
            flags.set("opt_level", level).ok()?;
            flags.set("regalloc_algorithm", allocator).ok()?;
            flags.set("use_colocated_libcalls", "false").ok()?;
            flags.set("is_pic", "false").ok()?;
            // Cranelift's own check of each function's IR took a sixth of
            // every compile (the octree build compiles tens of tapes); the
            // conformance suite holds every compiled tape to the
            // interpreter's bits instead.
            flags.set("enable_verifier", "false").ok()?;
            cranelift_native::builder()
                .ok()?
                .finish(settings::Flags::new(flags))
                .ok()
        })
        .clone()
}

/// Why a program was not compiled (only ever reported as "not compiled").
#[derive(Debug)]
struct NotCompiled;

impl<E: std::fmt::Display> From<E> for NotCompiled {
    fn from(_: E) -> NotCompiled {
        NotCompiled
    }
}

fn compile_program(
    program: &[PointOp],
    outputs: &[Slot],
    slot_count: usize,
    tier: Tier,
) -> Result<Compiled, NotCompiled> {
    // Offsets are i32 bytes.
    if slot_count > (i32::MAX / 8) as usize {
        return Err(NotCompiled);
    }
    let optimise = tier == Tier::Optimised && program.len() > QUICK_OPERATIONS;
    let isa = host_isa(optimise).ok_or(NotCompiled)?;
    let mut module = JITModule::new(JITBuilder::with_isa(isa, default_libcall_names()));
    let frontend = module.target_config();
    let pointer = frontend.pointer_type();
    let call_conv = frontend.default_call_conv;

    // Unary and binary operations are passed to their functions by address
    // in this copy of the program, which the code owns and never moves.
    let program: Box<[PointOp]> = program.into();

    let mut ctx = module.make_context();
    ctx.func.signature.params.push(AbiParam::new(pointer));
    let signature = |params: &[ir::Type]| {
        let mut s = ir::Signature::new(call_conv);
        s.params.extend(params.iter().map(|&t| AbiParam::new(t)));
        s.returns.push(AbiParam::new(types::F64));
        s
    };
    let mut builder_context = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut builder_context);
        let f64_f64 = b.import_signature(signature(&[types::F64, types::F64]));
        let f64_i32 = b.import_signature(signature(&[types::F64, types::I32]));
        let f64x3 = b.import_signature(signature(&[types::F64, types::F64, types::F64]));
        let ptr_f64 = b.import_signature(signature(&[pointer, types::F64]));
        let ptr_f64_f64 = b.import_signature(signature(&[pointer, types::F64, types::F64]));
        let block = b.create_block();
        b.append_block_params_for_function_params(block);
        b.switch_to_block(block);
        b.seal_block(block);
        let slots = b.block_params(block)[0];
        // The register file never aliases anything the code reads otherwise.
        let flags = MemFlagsData::trusted();
        // Each slot's current value: loaded once where it is first read
        // (an input or a constant), then whatever the program last wrote.
        let mut values: Vec<Option<Value>> = vec![None; slot_count];
        let read = |b: &mut FunctionBuilder, values: &mut Vec<Option<Value>>, s: Slot| {
            let s = s as usize;
            *values[s].get_or_insert_with(|| b.ins().load(types::F64, flags, slots, (8 * s) as i32))
        };
        let call = |b: &mut FunctionBuilder, sig, f: usize, args: &[Value]| {
            let callee = b.ins().iconst(pointer, f as i64);
            let inst = b.ins().call_indirect(sig, callee, args);
            b.inst_results(inst)[0]
        };
        for op in program.iter() {
            let (out, v) = match *op {
                PointOp::Add(o, x, y)
                | PointOp::Sub(o, x, y)
                | PointOp::Mul(o, x, y)
                | PointOp::MulPos(o, x, y, _)
                | PointOp::MulNeg(o, x, y, _)
                | PointOp::Div(o, x, y)
                | PointOp::Min(o, x, y)
                | PointOp::Max(o, x, y) => {
                    let (x, y) = (read(&mut b, &mut values, x), read(&mut b, &mut values, y));
                    let v = match op {
                        PointOp::Add(..) => b.ins().fadd(x, y),
                        PointOp::Sub(..) => b.ins().fsub(x, y),
                        PointOp::Mul(..) | PointOp::MulPos(..) | PointOp::MulNeg(..) => {
                            b.ins().fmul(x, y)
                        }
                        PointOp::Div(..) => {
                            // `quotient`: NaN where the divisor is ±0.
                            let q = b.ins().fdiv(x, y);
                            let zero = b.ins().f64const(0.0);
                            let at_pole = b.ins().fcmp(FloatCC::Equal, y, zero);
                            let nan = b.ins().f64const(f64::NAN);
                            b.ins().select(at_pole, nan, q)
                        }
                        PointOp::Min(..) => {
                            call(&mut b, f64_f64, min as *const () as usize, &[x, y])
                        }
                        _ => call(&mut b, f64_f64, max as *const () as usize, &[x, y]),
                    };
                    (o, v)
                }
                PointOp::Neg(o, x)
                | PointOp::Abs(o, x)
                | PointOp::Sqrt(o, x)
                | PointOp::Square(o, x)
                | PointOp::Cube(o, x)
                | PointOp::Fourth(o, x) => {
                    let x = read(&mut b, &mut values, x);
                    let v = match op {
                        PointOp::Neg(..) => b.ins().fneg(x),
                        PointOp::Abs(..) => b.ins().fabs(x),
                        PointOp::Sqrt(..) => b.ins().sqrt(x),
                        // `powi`'s own products, in its order.
                        PointOp::Square(..) => b.ins().fmul(x, x),
                        PointOp::Cube(..) => {
                            let s = b.ins().fmul(x, x);
                            b.ins().fmul(s, x)
                        }
                        _ => {
                            let s = b.ins().fmul(x, x);
                            b.ins().fmul(s, s)
                        }
                    };
                    (o, v)
                }
                PointOp::PowI(o, x, n) => {
                    let x = read(&mut b, &mut values, x);
                    let n = b.ins().iconst(types::I32, i64::from(n));
                    (
                        o,
                        call(&mut b, f64_i32, power as *const () as usize, &[x, n]),
                    )
                }
                PointOp::Choose(o, c, p, n) => {
                    let c = read(&mut b, &mut values, c);
                    let p = read(&mut b, &mut values, p);
                    let n = read(&mut b, &mut values, n);
                    (
                        o,
                        call(&mut b, f64x3, choice as *const () as usize, &[c, p, n]),
                    )
                }
                PointOp::Unary(_, o, x) => {
                    let x = read(&mut b, &mut values, x);
                    let op = b.ins().iconst(pointer, op as *const PointOp as i64);
                    (
                        o,
                        call(&mut b, ptr_f64, unary as *const () as usize, &[op, x]),
                    )
                }
                PointOp::Binary(_, o, x, y) => {
                    let (x, y) = (read(&mut b, &mut values, x), read(&mut b, &mut values, y));
                    let op = b.ins().iconst(pointer, op as *const PointOp as i64);
                    (
                        o,
                        call(
                            &mut b,
                            ptr_f64_f64,
                            binary as *const () as usize,
                            &[op, x, y],
                        ),
                    )
                }
            };
            values[out as usize] = Some(v);
        }
        // Only the outputs are written back: no caller reads other slots.
        let mut stored = vec![false; slot_count];
        for &o in outputs {
            let o = o as usize;
            if let (Some(v), false) = (values[o], stored[o]) {
                b.ins().store(flags, v, slots, (8 * o) as i32);
                stored[o] = true;
            }
        }
        b.ins().return_(&[]);
        b.finalize(frontend);
    }
    let id = module.declare_function("body", Linkage::Local, &ctx.func.signature)?;
    module.define_function(id, &mut ctx)?;
    module.clear_context(&mut ctx);
    module.finalize_definitions()?;
    let address = module.get_finalized_function(id);
    // SAFETY: the function was declared with exactly this signature (one
    // pointer argument, no results, the platform's calling convention).
    let code = unsafe { std::mem::transmute::<*const u8, unsafe extern "C" fn(*mut f64)>(address) };
    Ok(Compiled {
        module: Some(module),
        code,
        _program: program,
    })
}
