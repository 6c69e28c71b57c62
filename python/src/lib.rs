//! lgc from Python: formulas parsed and differentiated by the library,
//! evaluated over numpy arrays, and rays answered with certificates.
//!
//! Every function calls the same library code as the command line, on the
//! same tapes, so results are the CLI's bit for bit. Long calls release the
//! GIL and run on lgc's thread pool (`threads=` picks its size).

use engine::bounds::ProveError;
use engine::bounds::{Field, Method, Refine};
use engine::file::PendingFile;
use engine::lang::NotConstant;
use engine::proof::terms::TermError;
use engine::proof::Claim;
use engine::ray::{Answer, Intersector};
use engine::render::camera::CameraError;
use engine::render::view::{blame_scene_camera, MAX_SAMPLES, MAX_SIDE};
use engine::render::{
    framed_intersector, place_camera, render_scene, scene_frame, Prepared, RayTree, RenderSettings,
    Shading, DEFAULT_RAY_DEPTH, MAX_RAY_DEPTH, MIN_WEIGHT,
};
use engine::scene::CameraSpec;
use engine::{
    Aabb, BatchEvaluator, Bounder, Formula as Parsed, Interval, Output, Segment, Verdict,
};
use glam::DVec3;
use numpy::ndarray::{Array1, Array2, Array3, ArrayView2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

pyo3::create_exception!(
    lgc,
    FormulaError,
    PyValueError,
    "A formula that does not parse: the message shows the source with a caret under the \
     error and says what was expected; `.line` and `.column` (1-based) say where."
);

/// Points evaluated per parallel task.
const CHUNK: usize = 4096;

/// The octree depth `trace` uses unless told (the CLI's default).
const DEFAULT_DEPTH: u32 = 5;

/// The deepest octree `trace` accepts (the CLI's limit).
const MAX_DEPTH: u32 = 10;

/// The most subdivisions `bounds` accepts (the CLI's limit).
const MAX_SPLIT: u32 = 6;

/// The finest relative tolerance `bracket` accepts (the CLI's limit).
const MIN_TOLERANCE: f64 = 1e-13;

/// The image size `render` makes unless told (the CLI's default).
const DEFAULT_SIZE: (u32, u32) = (1024, 768);

/// The most threads a call may ask for.
const MAX_THREADS: usize = 1024;

/// A formula f(x, y, z), parsed, simplified and differentiated.
#[pyclass(frozen, module = "lgc")]
struct Formula {
    formula: Arc<Parsed>,
    source: String,
    /// Whether `source` is a `.vm` model rather than lgc's language.
    vm: bool,
}

#[pymethods]
impl Formula {
    /// Parses a formula in lgc's language, such as `"x^2+y^2+z^2-1"`.
    #[new]
    fn new(py: Python<'_>, text: &str) -> PyResult<Formula> {
        parse(py, text, "<formula>", false)
    }

    /// Reads a formula from a file: a `.vm` model (fidget's format) or a
    /// formula in lgc's language.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Formula> {
        let text = std::fs::read_to_string(&path)
            .map_err(|e| PyOSError::new_err(format!("cannot read `{}`: {e}", path.display())))?;
        let vm = path.extension().is_some_and(|e| e == "vm");
        parse(py, &text, &path.display().to_string(), vm)
    }

    /// f at each point: `p` of shape (N, 3) to an array of shape (N,).
    #[pyo3(signature = (p, *, threads=None))]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        p: &Bound<'py, PyAny>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let points = points(py, p, "p")?;
        let points = points.as_array();
        let mut columns = at_points(py, &self.formula, points, &[Output::F], threads)?;
        Ok(Array1::from_vec(columns.remove(0)).into_pyarray(py))
    }

    /// ∇f at each point: `p` of shape (N, 3) to an array of shape (N, 3).
    #[pyo3(signature = (p, *, threads=None))]
    fn grad<'py>(
        &self,
        py: Python<'py>,
        p: &Bound<'py, PyAny>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let points = points(py, p, "p")?;
        let points = points.as_array();
        let outputs = &[Output::Dfdx, Output::Dfdy, Output::Dfdz];
        let columns = at_points(py, &self.formula, points, outputs, threads)?;
        let n = columns[0].len();
        let array = Array2::from_shape_fn((n, 3), |(i, k)| columns[k][i]);
        Ok(array.into_pyarray(py))
    }

    /// The three partial derivatives, simplified, as formulas that parse
    /// back (what `lgc grad` prints).
    fn gradient<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let f = &self.formula;
        let rows = [Output::Dfdx, Output::Dfdy, Output::Dfdz].map(|o| f.print(f.node(o)));
        PyTuple::new(py, rows)
    }

    /// The first surface hit of each ray `origins[i] + t·directions[i]`,
    /// `t ≥ 0`, inside `box` (six numbers: the low corner, then the high
    /// one). Returns `(kind, t)`: `kind` an array of `"hit"`, `"touch"`,
    /// `"none"` or `"undecided"`, `t` the distance in units of the
    /// direction's length (NaN for `"none"`), as `lgc trace` prints them.
    #[pyo3(signature = (origins, directions, *, r#box=None, depth=DEFAULT_DEPTH, threads=None))]
    fn trace<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        r#box: Option<&Bound<'py, PyAny>>,
        depth: u32,
        threads: Option<usize>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<f64>>)> {
        let bounds = box_or_default(r#box)?;
        check_depth(depth)?;
        let origins = points(py, origins, "origins")?;
        let directions = points(py, directions, "directions")?;
        let (o, d) = (origins.as_array(), directions.as_array());
        if o.nrows() != d.nrows() {
            return Err(PyValueError::new_err(format!(
                "origins has {} rows and directions {}: give one direction per origin",
                o.nrows(),
                d.nrows()
            )));
        }
        let rays: Vec<(DVec3, DVec3)> = (0..o.nrows())
            .map(|i| {
                (
                    DVec3::new(o[[i, 0]], o[[i, 1]], o[[i, 2]]),
                    DVec3::new(d[[i, 0]], d[[i, 1]], d[[i, 2]]),
                )
            })
            .collect();
        if let Some(i) = rays
            .iter()
            .position(|(o, d)| !o.is_finite() || !d.is_finite() || *d == DVec3::ZERO)
        {
            return Err(PyValueError::new_err(format!(
                "ray {i}: origins and directions must be finite, and a direction not (0, 0, 0)"
            )));
        }
        let formula = self.formula.clone();
        let answers: Vec<Answer> = run_interruptible(py, threads, move || {
            let scene = Intersector::new(&formula, &bounds, depth);
            rays.par_chunks(256)
                .map_init(
                    || scene.tracer(),
                    |tracer, chunk| {
                        chunk
                            .iter()
                            .map(|&(o, d)| tracer.answer(o, d, 0.0, f64::INFINITY))
                            .collect::<Vec<_>>()
                    },
                )
                .flatten()
                .collect()
        })?;
        let kinds: Vec<&str> = answers
            .iter()
            .map(|a| match a {
                Answer::Hit(_) => "hit",
                Answer::Touch(_) => "touch",
                Answer::Undecided(_) => "undecided",
                Answer::Miss => "none",
            })
            .collect();
        let t: Vec<f64> = answers
            .iter()
            .map(|a| match *a {
                Answer::Hit(t) | Answer::Touch(t) | Answer::Undecided(t) => t,
                Answer::Miss => f64::NAN,
            })
            .collect();
        // A numpy array of str (dtype '<U9'), as `np.array` makes of them.
        let kinds = py.import("numpy")?.call_method1("array", (kinds,))?;
        Ok((kinds, PyArray1::from_vec(py, t)))
    }

    /// f's enclosure over `box`, L (a sound bound of |∇f| there) beside a
    /// sampled maximum, and with `ray` and `t` G (a bound of |g′| along the
    /// segment) likewise: `lgc bounds --json`'s fields. `split=n` bounds
    /// `8^n` sub-boxes (`2^n` sub-segments); `method` is `"natural"`,
    /// `"centred"`, `"bernstein"`, `"taylor"`, `"affine"` or `"best"`. An infinite
    /// bound is `None`, with its reason in `L_note` or `G_note`.
    #[pyo3(signature = (r#box, split=0, method="best", *, ray=None, t=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn bounds<'py>(
        &self,
        py: Python<'py>,
        r#box: &Bound<'py, PyAny>,
        split: u32,
        method: &str,
        ray: Option<&Bound<'py, PyAny>>,
        t: Option<&Bound<'py, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        if split > MAX_SPLIT {
            return Err(PyValueError::new_err(format!(
                "split={split}: use a whole number from 0 to {MAX_SPLIT}"
            )));
        }
        self.report(py, r#box, Refine::Split(split), method, ray, t, threads)
    }

    /// A certified bracket of the true maximum of |∇f| over `box` (and of
    /// |g′| along `ray` for `t`): branch and bound until
    /// `L ≤ L_lower·(1 + tolerance)` or `max_boxes` pieces. Returns
    /// `lgc bounds --tolerance --json`'s fields: `L`, `L_lower` (certified
    /// at `L_point`), `L_reached`, `pieces`, and `G`, `G_lower`, … with a
    /// ray.
    #[pyo3(signature = (r#box, tolerance=0.01, method="best", *, ray=None, t=None, max_boxes=engine::bounds::MAX_PIECES, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn bracket<'py>(
        &self,
        py: Python<'py>,
        r#box: &Bound<'py, PyAny>,
        tolerance: f64,
        method: &str,
        ray: Option<&Bound<'py, PyAny>>,
        t: Option<&Bound<'py, PyAny>>,
        max_boxes: usize,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        // As the CLI's --tolerance: outward rounding leaves a few ulps.
        if !(tolerance >= MIN_TOLERANCE && tolerance.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "tolerance={tolerance}: give a finite relative width of at least {MIN_TOLERANCE:e}, such as 0.01"
            )));
        }
        let refine = Refine::Bracket {
            tolerance,
            max_pieces: max_boxes.max(1),
        };
        self.report(py, r#box, refine, method, ray, t, threads)
    }

    /// Proves or refutes a claimed bound: `lipschitz=C` claims
    /// `|∇f| ≤ C` over `box`; `grad_lipschitz=C` claims `|g′| ≤ C` along
    /// the segment `ray` (six numbers: origin, direction) for `t` in
    /// `(t0, t1)`. `C` is a number or a constant expression such as
    /// `"2*sqrt(3)"`. Returns `lgc verify --json`'s fields with `status`
    /// for its `verdict`: `"proved"` (with `pieces`), `"refuted"` (with the
    /// `witness` point, `value`, a certified lower bound of the quantity
    /// there, and `t` on a segment) or `"undecided"` (with the `worst`
    /// piece and its `bound`). With `proof=PATH` it writes the proof file
    /// `lgc verify --proof` writes (see `lgc check-proof`) and adds its
    /// path as `proof`; an undecided claim raises `ValueError`.
    #[pyo3(signature = (r#box=None, lipschitz=None, *, grad_lipschitz=None, ray=None, t=None, max_boxes=1_000_000, threads=None, proof=None))]
    #[allow(clippy::too_many_arguments)]
    fn verify<'py>(
        &self,
        py: Python<'py>,
        r#box: Option<&Bound<'py, PyAny>>,
        lipschitz: Option<&Bound<'py, PyAny>>,
        grad_lipschitz: Option<&Bound<'py, PyAny>>,
        ray: Option<&Bound<'py, PyAny>>,
        t: Option<&Bound<'py, PyAny>>,
        max_boxes: usize,
        threads: Option<usize>,
        proof: Option<std::path::PathBuf>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let formula = self.formula.clone();
        if proof.is_some() && self.vm {
            return Err(PyValueError::new_err(
                "proof=: a proof's formula is written in lgc's formula language, and this one is a .vm model",
            ));
        }
        // Reserve the proof file first: an unwritable path fails before any work.
        let pending = proof
            .as_deref()
            .map(PendingFile::create)
            .transpose()
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        let wanted = pending.is_some();
        let (source, formula_text) = (self.source.clone(), self.source.clone());
        let out = PyDict::new(py);
        let report = |out: &Bound<'py, PyDict>, verdict: Verdict<Vec<f64>>, claim: String| {
            out.set_item("claim", claim)?;
            match verdict {
                Verdict::Proved { pieces } => {
                    out.set_item("status", "proved")?;
                    out.set_item("pieces", pieces)?;
                }
                Verdict::Refuted {
                    witness,
                    t,
                    value,
                    pieces,
                } => {
                    out.set_item("status", "refuted")?;
                    out.set_item("witness", (witness.x, witness.y, witness.z))?;
                    out.set_item("value", value)?;
                    out.set_item("pieces", pieces)?;
                    if let Some(t) = t {
                        out.set_item("t", t)?;
                    }
                }
                Verdict::Undecided {
                    worst,
                    bound,
                    pieces,
                } => {
                    out.set_item("status", "undecided")?;
                    out.set_item("worst", worst)?;
                    out.set_item("bound", bound)?;
                    out.set_item("pieces", pieces)?;
                }
            }
            PyResult::Ok(())
        };
        match (lipschitz, grad_lipschitz) {
            (Some(c), None) => {
                let b = aabb(r#box.ok_or_else(|| {
                    PyValueError::new_err("verify(lipschitz=...) needs box=(x0, y0, z0, x1, y1, z1)")
                })?)?;
                let (text, claim) = constant(c, "lipschitz")?;
                let stated = Claim::Lipschitz {
                    constant: text.clone(),
                    region: [b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z],
                };
                let (verdict, certificate) = run_interruptible(py, threads, move || {
                    let verdict =
                        engine::verify_lipschitz(&Bounder::new(&formula), &b, claim, max_boxes);
                    let certificate = wanted
                        .then(|| engine::bounds::certificate(&source, stated, &verdict, max_boxes));
                    (verdict, certificate)
                })?;
                write_proof(py, pending, certificate, &formula_text, &out)?;
                let verdict = with_region(verdict, |b: &Aabb| {
                    vec![b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z]
                });
                report(&out, verdict, text)?;
            }
            (None, Some(c)) => {
                let (Some(ray), Some(t)) = (ray, t) else {
                    return Err(PyValueError::new_err(
                        "verify(grad_lipschitz=...) needs ray=(ox, oy, oz, dx, dy, dz) and t=(t0, t1)",
                    ));
                };
                let seg = segment(ray, t)?;
                let (text, claim) = constant(c, "grad_lipschitz")?;
                let (o, d) = (seg.origin, seg.direction);
                let stated = Claim::GradLipschitz {
                    constant: text.clone(),
                    ray: [o.x, o.y, o.z, d.x, d.y, d.z],
                    t: [seg.t0, seg.t1],
                };
                let (verdict, certificate) = run_interruptible(py, threads, move || {
                    let verdict = engine::verify_grad_lipschitz(
                        &Bounder::new(&formula),
                        &seg,
                        claim,
                        max_boxes,
                    );
                    let certificate = wanted
                        .then(|| engine::bounds::certificate(&source, stated, &verdict, max_boxes));
                    (verdict, certificate)
                })?;
                write_proof(py, pending, certificate, &formula_text, &out)?;
                let verdict = with_region(verdict, |s: &Segment| vec![s.t0, s.t1]);
                report(&out, verdict, text)?;
            }
            _ => {
                return Err(PyValueError::new_err(
                    "verify needs one claim: lipschitz=C (with box) or grad_lipschitz=C (with ray and t)",
                ))
            }
        }
        Ok(out)
    }

    /// The formula's text as given.
    #[getter]
    fn source(&self) -> &str {
        &self.source
    }

    fn __repr__(&self) -> String {
        let short: String = self.source.chars().take(60).collect();
        let more = if short.len() < self.source.len() {
            "…"
        } else {
            ""
        };
        format!("lgc.Formula({:?}{more})", short)
    }
}

impl Formula {
    /// The report of `lgc bounds` as a dict with its JSON's keys.
    #[allow(clippy::too_many_arguments)]
    fn report<'py>(
        &self,
        py: Python<'py>,
        r#box: &Bound<'py, PyAny>,
        refine: Refine,
        method: &str,
        ray: Option<&Bound<'py, PyAny>>,
        t: Option<&Bound<'py, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let b = aabb(r#box)?;
        let method = Method::from_name(method).ok_or_else(|| {
            PyValueError::new_err(format!("method={method:?}: use {}", Method::names()))
        })?;
        let segment = match (ray, t) {
            (None, None) => None,
            (Some(ray), Some(t)) => Some(segment(ray, t)?),
            _ => {
                return Err(PyValueError::new_err(
                    "give both ray=(ox, oy, oz, dx, dy, dz) and t=(t0, t1) for G, or neither",
                ))
            }
        };
        let formula = self.formula.clone();
        let report = run_interruptible(py, threads, move || {
            let bounder = Bounder::new(&formula);
            if method == Method::Bernstein && !bounder.is_polynomial() {
                return Err("method=\"bernstein\" needs a polynomial f (+, -, *, integer powers >= 0, constants) of degree at most 256 in each variable: use \"best\"");
            }
            if method == Method::Taylor && !bounder.expands(&b) {
                return Err("method=\"taylor\" needs f built from +, -, *, integer powers, constants and sin, cos, exp, sinh, cosh, of degree at most 256 in each variable once expanded: use \"best\"");
            }
            Ok(engine::bounds::report(&bounder, &b, segment.as_ref(), refine, method))
        })?
        .map_err(PyValueError::new_err)?;
        let out = PyDict::new(py);
        for (key, value) in report.fields() {
            // As in the CLI's JSON, a number that is not finite is None.
            let number = |v: f64| v.is_finite().then_some(v);
            match value {
                Field::Number(v) => out.set_item(key, number(v))?,
                Field::Numbers(v) => {
                    out.set_item(key, v.into_iter().map(number).collect::<Vec<_>>())?
                }
                Field::Count(n) => out.set_item(key, n)?,
                Field::Flag(f) => out.set_item(key, f)?,
                Field::Text(text) => out.set_item(key, text)?,
            }
        }
        Ok(out)
    }
}

/// A ray segment from `ray` (origin, direction) and `t` (t0, t1).
fn segment(ray: &Bound<'_, PyAny>, t: &Bound<'_, PyAny>) -> PyResult<Segment> {
    let r = numbers::<6>(ray, "ray", "six numbers: ox, oy, oz, dx, dy, dz")?;
    let [t0, t1] = numbers::<2>(t, "t", "two numbers: t0, t1")?;
    let (o, d) = (DVec3::new(r[0], r[1], r[2]), DVec3::new(r[3], r[4], r[5]));
    Segment::new(o, d, t0, t1).ok_or_else(|| {
        PyValueError::new_err(format!(
            "t=({t0}, {t1}) is not a segment of the ray: the numbers must be finite, t0 at most t1, the direction not 0"
        ))
    })
}

/// Parses `text`, raising [`FormulaError`] with the CLI's message.
fn parse(py: Python<'_>, text: &str, origin: &str, vm: bool) -> PyResult<Formula> {
    let parsed = if vm {
        Parsed::parse_vm(text)
    } else {
        Parsed::parse(text)
    };
    match parsed {
        Ok(formula) => Ok(Formula {
            formula: Arc::new(formula),
            source: text.to_string(),
            vm,
        }),
        Err(e) => Err(formula_error(py, e, text, origin)),
    }
}

/// A mistake in `text` as a [`FormulaError`]: the CLI's message, with the
/// line and column it points at.
fn formula_error(py: Python<'_>, e: engine::FormulaError, text: &str, origin: &str) -> PyErr {
    let (line, column) = e.line_column(text);
    let err = FormulaError::new_err(e.render(text, origin));
    let value = err.value(py);
    match (value.setattr("line", line), value.setattr("column", column)) {
        (Ok(()), Ok(())) => err,
        (Err(e), _) | (_, Err(e)) => e,
    }
}

/// The octree depth `depth`, if within the CLI's limit.
fn check_depth(depth: u32) -> PyResult<()> {
    if depth > MAX_DEPTH {
        return Err(PyValueError::new_err(format!(
            "depth {depth} is too deep: use a whole number from 0 to {MAX_DEPTH}"
        )));
    }
    Ok(())
}

/// `box`, or the CLI's default box [-2, 2]³.
fn box_or_default(b: Option<&Bound<'_, PyAny>>) -> PyResult<Aabb> {
    match b {
        Some(b) => aabb(b),
        None => Ok(Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).expect("a box")),
    }
}

/// `p` as a float64 array of shape (N, 3): anything numpy converts (lists,
/// integer arrays, non-contiguous views), else a `ValueError` or
/// `TypeError` naming `what`.
fn points<'py>(
    py: Python<'py>,
    p: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let numpy = py.import("numpy")?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let array = numpy
        .call_method("asarray", (p,), Some(&kwargs))
        .map_err(|e| {
            let why = e.value(py).to_string();
            pyo3::exceptions::PyTypeError::new_err(format!(
                "{what} must be an array of numbers of shape (N, 3): {why}"
            ))
        })?;
    let shape: Vec<usize> = array.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape (N, 3), one point per row, not {shape:?}"
        )));
    }
    let array = array.cast_into::<PyArray2<f64>>()?;
    Ok(array.readonly())
}

/// Writes a proof file into place and names it in `out` as "proof"; a
/// verdict with no proof raises `ValueError` (or `FormulaError`, located in
/// the formula, for a function the proof checker does not read).
fn write_proof(
    py: Python<'_>,
    pending: Option<PendingFile>,
    certificate: Option<Result<engine::proof::Proof, ProveError>>,
    source: &str,
    out: &Bound<'_, PyDict>,
) -> PyResult<()> {
    let (Some(pending), Some(certificate)) = (pending, certificate) else {
        return Ok(());
    };
    let proof = certificate.map_err(|e| match e {
        ProveError::Unreadable(TermError::Formula(located)) => {
            formula_error(py, located, source, "<formula>")
        }
        e => PyValueError::new_err(format!("no proof written: {e}")),
    })?;
    let io = |e: engine::file::FileError| PyOSError::new_err(e.to_string());
    std::fs::write(pending.temp(), proof.to_json()).map_err(|e| io(pending.io_error(e)))?;
    let name = pending.name();
    pending.rename().map_err(io)?;
    out.set_item("proof", name)
}

/// A claimed constant, a number or a constant expression, enclosed as
/// `lgc verify` encloses its text; with that text.
fn constant(c: &Bound<'_, PyAny>, what: &str) -> PyResult<(String, Interval)> {
    let text = match c.extract::<String>() {
        Ok(text) => text,
        // A float's shortest round-trip text: the number itself.
        Err(_) => match c.extract::<f64>() {
            Ok(v) => format!("{v:?}"),
            Err(_) => {
                return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "{what} must be a number or a constant expression such as \"2*sqrt(3)\""
                )))
            }
        },
    };
    let py = c.py();
    let located = |e: engine::FormulaError| formula_error(py, e, &text, what);
    let ast = engine::lang::parse(&text).map_err(located)?;
    let mut ctx = engine::Context::new();
    let node = engine::lang::lower(&mut ctx, &ast).map_err(located)?;
    match engine::lang::enclose_constant(&ctx, node) {
        Ok(v) => Ok((text, v)),
        Err(NotConstant::DependsOnCoordinates) => Err(PyValueError::new_err(format!(
            "{what}={text}: the claimed constant may not depend on x, y or z"
        ))),
        Err(NotConstant::NotFinite) => Err(PyValueError::new_err(format!(
            "{what}={text} is not a finite number"
        ))),
    }
}

/// A verdict with its worst piece given as numbers.
fn with_region<R>(v: Verdict<R>, numbers: impl Fn(&R) -> Vec<f64>) -> Verdict<Vec<f64>> {
    match v {
        Verdict::Proved { pieces } => Verdict::Proved { pieces },
        Verdict::Refuted {
            witness,
            t,
            value,
            pieces,
        } => Verdict::Refuted {
            witness,
            t,
            value,
            pieces,
        },
        Verdict::Undecided {
            worst,
            bound,
            pieces,
        } => Verdict::Undecided {
            worst: numbers(&worst),
            bound,
            pieces,
        },
    }
}

/// `N` numbers from a sequence, else a `TypeError` or `ValueError` saying
/// what `what` must be.
fn numbers<const N: usize>(v: &Bound<'_, PyAny>, what: &str, must: &str) -> PyResult<[f64; N]> {
    let v: Vec<f64> = v.extract().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!("{what} must be a sequence of {must}"))
    })?;
    v.clone().try_into().map_err(|_| {
        PyValueError::new_err(format!("{what} must have {must}, not {} numbers", v.len()))
    })
}

/// A box from six numbers: the low corner, then the high one.
fn aabb(b: &Bound<'_, PyAny>) -> PyResult<Aabb> {
    let v: Vec<f64> = b.extract().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(
            "box must be a sequence of six numbers: x0, y0, z0, x1, y1, z1",
        )
    })?;
    let [x0, y0, z0, x1, y1, z1] = v[..] else {
        return Err(PyValueError::new_err(format!(
            "box must have six numbers (x0, y0, z0, x1, y1, z1), not {}",
            v.len()
        )));
    };
    let b = Aabb::new(DVec3::new(x0, y0, z0), DVec3::new(x1, y1, z1)).ok_or_else(|| {
        PyValueError::new_err(format!(
            "box {v:?} is not a box: its numbers must be finite, each low corner at most the high one"
        ))
    })?;
    // As the CLI's --box: lengths and pads are fractions of the diagonal.
    if !(b.diagonal() * 2.0).is_finite() || !(b.lo.abs().max(b.hi.abs()) * 2.0).is_finite() {
        return Err(PyValueError::new_err(format!(
            "box {v:?} is too large: its diagonal and coordinates must stay below about 8e307"
        )));
    }
    Ok(b)
}

/// The `outputs` at each row of `points`, one column each, evaluated in
/// parallel with the GIL released. Each value is the one `lgc eval` prints:
/// a node's value depends only on its own operations, whatever else the
/// tape computes, and the batch evaluator runs the same operations as the
/// point one.
fn at_points(
    py: Python<'_>,
    formula: &Arc<Parsed>,
    points: ArrayView2<'_, f64>,
    outputs: &'static [Output],
    threads: Option<usize>,
) -> PyResult<Vec<Vec<f64>>> {
    let columns: [Vec<f64>; 3] = [0, 1, 2].map(|k| points.column(k).to_vec());
    let formula = formula.clone();
    run_detached(py, threads, move || {
        let tape = formula.tape(outputs);
        let n = columns[0].len();
        let chunks: Vec<Vec<Vec<f64>>> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let range = c * CHUNK..((c + 1) * CHUNK).min(n);
                let inputs = columns.each_ref().map(|col| &col[range.clone()]);
                let mut out = vec![vec![0.0; range.len()]; outputs.len()];
                let mut slices: Vec<&mut [f64]> = out.iter_mut().map(|o| &mut o[..]).collect();
                BatchEvaluator::new(&tape).eval(&inputs, &mut slices);
                out
            })
            .collect();
        (0..outputs.len())
            .map(|k| chunks.iter().flat_map(|c| c[k].iter().copied()).collect())
            .collect()
    })
}

/// Runs `work` without the GIL, on the global thread pool or on one of
/// `threads` threads (evaluating points: quick, so not interruptible).
fn run_detached<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let pool = thread_pool(threads)?;
    Ok(py.detach(move || match pool {
        Some(pool) => pool.install(work),
        None => work(),
    }))
}

/// How often a long call looks for Ctrl-C.
const SIGNAL_POLL: std::time::Duration = std::time::Duration::from_millis(50);

/// [`run_detached`] for work that may be long (rays, bounds, proofs): it
/// runs on a thread of its own while this one, holding the GIL only for a
/// moment every [`SIGNAL_POLL`], answers Ctrl-C at once with
/// `KeyboardInterrupt`. The library's searches cannot be stopped midway,
/// so interrupted work finishes in the background and its answer is
/// dropped; each is bounded (by its piece budget or its rays).
fn run_interruptible<T: Send + 'static>(
    py: Python<'_>,
    threads: Option<usize>,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    use std::sync::mpsc::{channel, RecvTimeoutError};
    let pool = thread_pool(threads)?;
    let (send, answer) = channel();
    std::thread::Builder::new()
        .name("lgc".into())
        .spawn(move || {
            let result = match pool {
                Some(pool) => pool.install(work),
                None => work(),
            };
            // The caller may have gone (Ctrl-C): then nobody wants it.
            let _ = send.send(result);
        })
        .map_err(|e| PyOSError::new_err(format!("cannot start a thread: {e}")))?;
    // Behind a lock only so that the waiting closure may cross threads.
    let answer = Mutex::new(answer);
    loop {
        let waited = py.detach(|| {
            let answer = answer.lock().expect("only this thread locks it");
            answer.recv_timeout(SIGNAL_POLL)
        });
        match waited {
            Ok(result) => return Ok(result),
            Err(RecvTimeoutError::Timeout) => py.check_signals()?,
            Err(RecvTimeoutError::Disconnected) => {
                return Err(pyo3::exceptions::PyRuntimeError::new_err(
                    "lgc's worker stopped without an answer: an internal error, please report it",
                ))
            }
        }
    }
}

/// The pool `threads=` asks for (`None`: rayon's global one).
fn thread_pool(threads: Option<usize>) -> PyResult<Option<Arc<rayon::ThreadPool>>> {
    match threads {
        None => Ok(None),
        Some(n) if (1..=MAX_THREADS).contains(&n) => Ok(Some(pool(n)?)),
        Some(n) => Err(PyValueError::new_err(format!(
            "threads={n}: use a whole number from 1 to {MAX_THREADS}"
        ))),
    }
}

/// A thread pool of `n` threads, made once and kept.
fn pool(n: usize) -> PyResult<Arc<rayon::ThreadPool>> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    let mut pools = POOLS
        .get_or_init(Default::default)
        .lock()
        .expect("not poisoned");
    if let Some(p) = pools.get(&n) {
        return Ok(p.clone());
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| PyOSError::new_err(format!("cannot start {n} threads: {e}")))?;
    let p = Arc::new(p);
    pools.insert(n, p.clone());
    Ok(p)
}

/// What `render` draws: a formula, or a scene file's objects.
enum Picture {
    Formula(Arc<Parsed>),
    Scene(Box<engine::scene::Scene>),
}

/// Why `render` could not place the camera: located in the scene's text
/// where the file's own camera is to blame.
enum Unplaced {
    Camera(CameraError),
    InScene(engine::FormulaError),
}

/// Renders a formula, a `Formula` or a scene file into an image: an array
/// of shape (height, width, 3), 8-bit sRGB, the pixels `lgc render` writes.
///
/// `source` is a `Formula`, formula text (or a scene's, with `{ … }`
/// blocks), or a file: an `os.PathLike`, or a `str` ending in `.lgc` or
/// `.vm` as the CLI reads them. The keywords are the CLI's options:
/// `size=(width, height)` (default 1024×768); `box` and `color` for formulas; `max_depth` and
/// `min_weight` for scenes; `eye`, `look_at`, `up` and `fov` override a
/// scene's camera and the default three-quarter view.
#[pyfunction]
#[pyo3(signature = (source, size=None, *, r#box=None, depth=DEFAULT_DEPTH, color=None, eye=None, look_at=None, up=None, fov=None, max_depth=None, min_weight=None, samples=1, threads=None, no_shadows=false))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    source: &Bound<'py, PyAny>,
    size: Option<&Bound<'py, PyAny>>,
    r#box: Option<&Bound<'py, PyAny>>,
    depth: u32,
    color: Option<&Bound<'py, PyAny>>,
    eye: Option<&Bound<'py, PyAny>>,
    look_at: Option<&Bound<'py, PyAny>>,
    up: Option<&Bound<'py, PyAny>>,
    fov: Option<f64>,
    max_depth: Option<u32>,
    min_weight: Option<f64>,
    samples: u32,
    threads: Option<usize>,
    no_shadows: bool,
) -> PyResult<Bound<'py, PyArray3<u8>>> {
    let (width, height) = match size {
        Some(size) => image_size(size)?,
        None => DEFAULT_SIZE,
    };
    if samples == 0 || samples > MAX_SAMPLES {
        return Err(PyValueError::new_err(format!(
            "samples={samples}: use 1 to {MAX_SAMPLES} rays per pixel"
        )));
    }
    check_depth(depth)?;
    let asked = CameraSpec {
        eye: eye.map(|v| vector(v, "eye")).transpose()?,
        look_at: look_at.map(|v| vector(v, "look_at")).transpose()?,
        up: up.map(|v| vector(v, "up")).transpose()?,
        fov,
        spans: Default::default(),
    };
    if asked.up == Some(DVec3::ZERO) {
        return Err(PyValueError::new_err(
            "up=(0, 0, 0): the up vector cannot be (0, 0, 0)",
        ));
    }
    let settings = RenderSettings {
        width,
        height,
        samples,
        shadows: !no_shadows,
        bundles: true,
    };
    let (picture, text, origin) = picture(py, source)?;
    let only = |given: bool, what: &str, kind: &str| {
        if given {
            Err(PyValueError::new_err(format!("{what} applies to {kind}")))
        } else {
            Ok(())
        }
    };
    let rendering = match picture {
        Picture::Formula(formula) => {
            only(
                max_depth.is_some(),
                "max_depth",
                "scenes: a formula's picture has no reflections",
            )?;
            only(
                min_weight.is_some(),
                "min_weight",
                "scenes: a formula's picture has no reflections",
            )?;
            let bounds = box_or_default(r#box)?;
            if bounds.hi.cmple(bounds.lo).any() {
                return Err(PyValueError::new_err(
                    "box is flat: every side must have positive length",
                ));
            }
            let color = match color {
                Some(c) => vector(c, "color")?,
                None => DVec3::new(0.85, 0.45, 0.25),
            };
            if !color.cmpge(DVec3::ZERO).all() || !color.cmple(DVec3::ONE).all() {
                return Err(PyValueError::new_err(format!(
                    "color={:?}: each component must be between 0 and 1",
                    color.to_array()
                )));
            }
            run_interruptible(py, threads, move || {
                let (scene, frame) = framed_intersector(&formula, &bounds, depth);
                let camera = place_camera(&frame, &asked, &CameraSpec::default(), &settings)
                    .map_err(Unplaced::Camera)?;
                let shading = Shading::studio(camera.basis(), color);
                let image = engine::render::render(&scene, &camera, &shading, &settings, &|| {});
                Ok((image, scene.octree_stats().leaves_on_faces > 0))
            })?
        }
        Picture::Scene(scene) => {
            only(
                r#box.is_some(),
                "box",
                "formulas: a scene's objects carry their own",
            )?;
            only(
                color.is_some(),
                "color",
                "formulas: a scene's objects carry their own",
            )?;
            let tree = RayTree {
                max_depth: max_depth.unwrap_or(DEFAULT_RAY_DEPTH),
                min_weight: min_weight.unwrap_or(MIN_WEIGHT),
            };
            if tree.max_depth > MAX_RAY_DEPTH {
                return Err(PyValueError::new_err(format!(
                    "max_depth={}: use a whole number from 0 to {MAX_RAY_DEPTH}",
                    tree.max_depth
                )));
            }
            if !(0.0..=1.0).contains(&tree.min_weight) {
                return Err(PyValueError::new_err(format!(
                    "min_weight={}: use a share from 0 to 1",
                    tree.min_weight
                )));
            }
            run_interruptible(py, threads, move || {
                let prepared = Prepared::new(&scene, depth);
                let frame = scene_frame(&scene, &prepared, &asked);
                let camera =
                    place_camera(&frame, &asked, &scene.camera, &settings).map_err(|e| {
                        match blame_scene_camera(&e, &asked, &scene.camera) {
                            Some(located) => Unplaced::InScene(located),
                            None => Unplaced::Camera(e),
                        }
                    })?;
                Ok((
                    render_scene(&prepared, &camera, &settings, tree, &|| {}),
                    false,
                ))
            })?
        }
    };
    let rendering = rendering.map_err(|e| match e {
        Unplaced::Camera(e) => PyValueError::new_err(format!("cannot place the camera: {e}")),
        Unplaced::InScene(e) => formula_error(py, e, &text, &origin),
    })?;
    let (rendering, clipped) = rendering;
    // What `lgc render` says on stderr, as Python warnings.
    let warn = |message: &str| {
        let message = std::ffi::CString::new(message).expect("no NUL in the message");
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        PyErr::warn(py, &category, &message, 2)
    };
    if clipped {
        warn("the surface reaches the faces of the box and may be clipped there; a larger box shows all of it")?;
    }
    if rendering.primary.hits + rendering.primary.touches == 0 {
        warn("nothing to see: no camera ray meets the surface in the box; try another box, or eye, look_at or fov")?;
    }
    let (w, h) = (rendering.width as usize, rendering.height as usize);
    let pixels = Array3::from_shape_vec((h, w, 3), rendering.rgb)
        .expect("the film holds width·height·3 bytes");
    Ok(pixels.into_pyarray(py))
}

/// `render`'s source, parsed, with its text and the name its errors show.
fn picture(py: Python<'_>, source: &Bound<'_, PyAny>) -> PyResult<(Picture, String, String)> {
    if let Ok(f) = source.cast::<Formula>() {
        let f = f.get();
        return Ok((
            Picture::Formula(f.formula.clone()),
            f.source.clone(),
            "<formula>".into(),
        ));
    }
    let os = py.import("os")?;
    let (text, origin) = match source.extract::<String>() {
        // As the CLI reads `lgc render scene.lgc`.
        Ok(s)
            if (s.ends_with(".lgc") || s.ends_with(".vm")) && !s.contains(['(', '^', '*', '+']) =>
        {
            (read_file(std::path::Path::new(&s))?, s)
        }
        Ok(s) => (s, "<formula>".to_string()),
        Err(_) if source.is_instance(&os.getattr("PathLike")?)? => {
            let path: std::path::PathBuf = source.extract()?;
            (read_file(&path)?, path.display().to_string())
        }
        Err(_) => {
            return Err(pyo3::exceptions::PyTypeError::new_err(
                "source must be a Formula, formula or scene text, or a path to a .lgc or .vm file",
            ))
        }
    };
    let vm = origin.ends_with(".vm");
    if !vm && engine::scene::is_scene(&text) {
        let scene =
            engine::scene::parse_scene(&text).map_err(|e| formula_error(py, e, &text, &origin))?;
        return Ok((Picture::Scene(Box::new(scene)), text, origin));
    }
    let f = parse(py, &text, &origin, vm)?;
    Ok((Picture::Formula(f.formula), text, origin))
}

/// A file's text, or an `OSError` naming it.
fn read_file(path: &std::path::Path) -> PyResult<String> {
    std::fs::read_to_string(path)
        .map_err(|e| PyOSError::new_err(format!("cannot read `{}`: {e}", path.display())))
}

/// `size=(width, height)`, each side 1 to the CLI's limit.
fn image_size(size: &Bound<'_, PyAny>) -> PyResult<(u32, u32)> {
    let (w, h): (i64, i64) = size.extract().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err("size must be (width, height): two whole numbers")
    })?;
    let side = |v: i64| {
        u32::try_from(v)
            .ok()
            .filter(|v| (1..=MAX_SIDE).contains(v))
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "size=({w}, {h}): each side must be between 1 and {MAX_SIDE} pixels"
                ))
            })
    };
    Ok((side(w)?, side(h)?))
}

/// Three finite numbers: a point, a direction or a colour.
fn vector(v: &Bound<'_, PyAny>, what: &str) -> PyResult<DVec3> {
    let v = DVec3::from(numbers::<3>(v, what, "three numbers")?);
    if !v.is_finite() {
        return Err(PyValueError::new_err(format!(
            "{what}={:?}: the numbers must be finite",
            v.to_array()
        )));
    }
    Ok(v)
}

/// lgc: implicit surfaces f(x, y, z) = 0, their derivatives, bounds and
/// certified ray intersections.
#[pymodule(name = "lgc")]
fn lgc_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Formula>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add("FormulaError", m.py().get_type::<FormulaError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
