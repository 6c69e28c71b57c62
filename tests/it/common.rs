//! Helpers shared by the integration tests.

use glam::DVec3;
use lgc::ray::{Answer, Intersector, Tracer};
use lgc::render::{render, Camera, RenderSettings, Rendering, Shading};
use lgc::Aabb;
use lgc::{Evaluator, Formula, Output, Tape};
use std::io::Write;
use std::process::{Command, Stdio};

/// Runs the `lgc` binary with `args`, `stdin` as its standard input.
pub fn lgc_with_stdin(args: &[&str], stdin: &str) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let written = child.stdin.take().unwrap().write_all(stdin.as_bytes());
    let output = child.wait_with_output().unwrap();
    // A child that exits before reading all its input closes the pipe: its
    // status and standard error say why, not the write.
    if let Err(e) = written {
        assert_eq!(
            e.kind(),
            std::io::ErrorKind::BrokenPipe,
            "writing to lgc {args:?}: {e}"
        );
        assert!(
            !output.status.success(),
            "lgc {args:?} succeeded without reading its input: {}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    output
}

/// Formulas beyond the corpus, each with a box where it is defined and smooth
/// almost everywhere. Together they use every function of the language.
pub const FORMULAS: &[(&str, [f64; 3], [f64; 3])] = &[
    ("sqrt(x^2+y^2+1) - z", [-2.0; 3], [2.0; 3]),
    ("abs(x) + abs(y - z) - 1", [-2.0; 3], [2.0; 3]),
    (
        "sin(x)*cos(y) + tan(z/2)",
        [-3.0, -3.0, -1.5],
        [3.0, 3.0, 1.5],
    ),
    ("asin(x/2) + acos(y/2) + atan(z)", [-1.5; 3], [1.5; 3]),
    ("atan2(y, x + 3) - z", [-1.0; 3], [1.0; 3]),
    ("exp(x*y) - ln(z + 3)", [-1.0; 3], [1.0; 3]),
    ("log(x^2 + 1) + z", [-2.0; 3], [2.0; 3]),
    ("sinh(x) + cosh(y) - tanh(z)", [-2.0; 3], [2.0; 3]),
    ("min(x, y, z) + max(x^2, y^2, z)", [-2.0; 3], [2.0; 3]),
    ("pow(x^2 + 1, 1.5) - y", [-2.0; 3], [2.0; 3]),
    ("pow(x + 3, y) - z", [-1.0; 3], [1.0; 3]),
    ("hypot(x, y) - 1 + z^2", [-2.0; 3], [2.0; 3]),
    ("1/(x^2 + y^2 + z^2 + 0.1) - 1", [-2.0; 3], [2.0; 3]),
    ("2^x + e^(x*y) - z", [-1.0; 3], [1.0; 3]),
    ("(x + 3)^(y/2) - z", [-1.0; 3], [1.0; 3]),
    ("x^2.5 + y^-2 - z", [0.1, 0.5, -1.0], [2.0, 2.0, 1.0]),
    (
        "let r = x^2 + y^2; let s = sqrt(r + 1); s*z - r",
        [-2.0; 3],
        [2.0; 3],
    ),
    ("sin(cos(tan(x/3))) + exp(sin(y)) - z", [-2.0; 3], [2.0; 3]),
    ("-x^2 + 2^3^2*y - z", [-2.0; 3], [2.0; 3]),
    ("(x - y)/(1 + x^2 + y^2) + z", [-2.0; 3], [2.0; 3]),
    ("sign(x)*y^2 + z", [-2.0; 3], [2.0; 3]),
    ("floor(2*x)*y^2 + ceil(y)*z + x", [-2.0; 3], [2.0; 3]),
    (
        "round(x*y)*z^2 + mod(x, 0.7)*y - mod(z, -1.3)",
        [-2.0; 3],
        [2.0; 3],
    ),
    ("choose(x, y^2, z^2) - 1", [-2.0; 3], [2.0; 3]),
    ("x*y*z - 0.1", [-2.0; 3], [2.0; 3]),
    ("(x + y + z)^3 - 1", [-2.0; 3], [2.0; 3]),
    ("(x*y - z)^5 - x^10", [-1.2; 3], [1.2; 3]),
    ("cos(x)^2 + sin(x)^2*y - z", [-3.0; 3], [3.0; 3]),
    ("x/(y^2 + 1)/(z^2 + 2)", [-2.0; 3], [2.0; 3]),
    ("sqrt(sqrt(x^2 + 1) + y^2) - 1.5 + 0*z", [-2.0; 3], [2.0; 3]),
    ("exp(-(x^2 + y^2 + z^2)) - 0.3", [-2.0; 3], [2.0; 3]),
    // Exponential smooth minima: two, three and nested terms, whose
    // derivatives are written as weighted means.
    (
        "-ln(exp(-8*(sqrt(x^2+y^2+z^2) - 0.8)) + exp(-8*(abs(x - 0.6) - 0.3)))/8",
        [-1.5; 3],
        [1.5; 3],
    ),
    (
        "ln(exp(3*x) + exp(y^2 - z) + exp(sin(z)*2))",
        [-2.0; 3],
        [2.0; 3],
    ),
    (
        "-ln(exp(-5*x) + (exp(-5*y) + exp(-5*ln(exp(z) + exp(x*y)))))/5",
        [-1.0; 3],
        [1.0; 3],
    ),
    ("ln(cosh(x)) + atan(y*z)", [-2.0; 3], [2.0; 3]),
    ("tanh(3*x)*sinh(y/2) - cos(z*pi)", [-2.0; 3], [2.0; 3]),
    ("sech(x*y) + tanh(z^3)", [-2.0; 3], [2.0; 3]),
    (
        "rotate(x^2 + 2*y^2 + 3*z^2 - 1, 30, 45, 60)",
        [-2.0; 3],
        [2.0; 3],
    ),
    (
        "blend(x^2+y^2+z^2-1, (x-1.5)^2+y^2+z^2-1, 0.5)",
        [-2.0; 3],
        [2.0; 3],
    ),
    (
        "translate(x^3 + y*z, 1, 2, 3) + scale(sin(x) + y^2, 2)",
        [-2.0; 3],
        [2.0; 3],
    ),
    (
        "union(x - 1, y^2 - 0.5, z) + intersect(x, y + z) + subtract(x^2 - 1, y)",
        [-2.0; 3],
        [2.0; 3],
    ),
    ("max(abs(x), abs(y), abs(z)) - 1", [-2.0; 3], [2.0; 3]),
    (
        "min(x^2 + y^2 + z^2 - 1, (x - 1.2)^2 + y^2 + z^2 - 0.5)",
        [-2.0; 3],
        [2.0; 3],
    ),
    ("atan2(x*y, z^2 + 1) + acos(tanh(x))", [-2.0; 3], [2.0; 3]),
    ("x^3 - 3*x*y^2 - z # monkey saddle", [-2.0; 3], [2.0; 3]),
    (
        "(x^2 + y^2 - 1)^2 + z^2*(x - 0.5) - 0.1",
        [-2.0; 3],
        [2.0; 3],
    ),
    ("sin(x + y*z)^3 - cos(x*y)^2 + z", [-2.0; 3], [2.0; 3]),
];

/// A small deterministic generator (SplitMix64), so failures reproduce.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A random point of the box [lo, hi].
    pub fn point(&mut self, lo: [f64; 3], hi: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| self.uniform(lo[i], hi[i]))
    }

    /// A random direction, not normalised, with components in [-1, 1].
    pub fn direction(&mut self) -> [f64; 3] {
        [0, 1, 2].map(|_| self.uniform(-1.0, 1.0))
    }
}

/// One surface of the corpus (`examples/surfaces.json`).
pub struct Surface {
    pub name: String,
    pub expr: String,
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

/// The corpus surfaces in `examples/surfaces.json`.
pub fn corpus() -> Vec<Surface> {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/surfaces.json"
    ))
    .expect("examples/surfaces.json is part of the repository");
    let json: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
    json.as_object()
        .expect("an object of surfaces")
        .iter()
        .map(|(name, s)| {
            let b: Vec<f64> = s["box"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            Surface {
                name: name.clone(),
                expr: s["expr"].as_str().unwrap().to_string(),
                lo: [b[0], b[1], b[2]],
                hi: [b[3], b[4], b[5]],
            }
        })
        .collect()
}

/// f, ∇f, g and g′ of a formula at a point and direction, from one tape.
pub struct Values {
    pub f: f64,
    pub grad: [f64; 3],
    pub g: f64,
    pub dg: f64,
}

pub fn all_outputs(formula: &Formula) -> Tape {
    formula.tape(&Output::ALL)
}

pub fn values(eval: &mut Evaluator<'_, f64>, p: [f64; 3], d: [f64; 3]) -> Values {
    let v = eval.eval(&[p[0], p[1], p[2], d[0], d[1], d[2]]);
    Values {
        f: v[0],
        grad: [v[1], v[2], v[3]],
        g: v[4],
        dg: v[5],
    }
}

/// The derivative of `h` at 0 by Richardson-extrapolated central differences
/// (error O(step⁴)).
pub fn central_difference(mut h: impl FnMut(f64) -> f64, step: f64) -> f64 {
    let mut d = |s: f64| (h(s) - h(-s)) / (2.0 * s);
    let coarse = d(step);
    (4.0 * d(step / 2.0) - coarse) / 3.0
}

/// True when `a` and `b` agree to `rel` relative to `scale` (at least 1).
pub fn close(a: f64, b: f64, rel: f64, scale: f64) -> bool {
    (a - b).abs() <= rel * scale.max(a.abs()).max(b.abs()).max(1.0)
}

/// Every test formula: the list above and the corpus, with their boxes.
pub fn all_formulas() -> Vec<(String, [f64; 3], [f64; 3])> {
    FORMULAS
        .iter()
        .map(|&(e, lo, hi)| (e.to_string(), lo, hi))
        .chain(corpus().into_iter().map(|s| (s.expr, s.lo, s.hi)))
        .collect()
}

/// Rays at random, and rays through points of the surface (where creases
/// lie) in random directions, pushed off by tiny amounts.
pub fn rays(rng: &mut Rng, f: &Formula) -> Vec<(DVec3, DVec3)> {
    let tape = f.tape(&[Output::F]);
    let mut eval = Evaluator::<f64>::new(&tape);
    let mut out = Vec::new();
    while out.len() < 600 {
        let d = DVec3::from(rng.direction());
        let target = DVec3::from(rng.point([-1.5; 3], [1.5; 3]));
        if out.len() % 2 == 0 {
            out.push((target - 4.0 * d, d));
            continue;
        }
        // Walk towards the surface along a random line, then aim through it.
        let (mut a, mut b) = (target, target + d);
        let fa = eval.eval(&[a.x, a.y, a.z, 0.0, 0.0, 0.0])[0];
        let fb = eval.eval(&[b.x, b.y, b.z, 0.0, 0.0, 0.0])[0];
        if fa.signum() == fb.signum() {
            continue;
        }
        for _ in 0..60 {
            let m = 0.5 * (a + b);
            let fm = eval.eval(&[m.x, m.y, m.z, 0.0, 0.0, 0.0])[0];
            if fm.signum() == fa.signum() {
                a = m;
            } else {
                b = m;
            }
        }
        let off = [1e-6, 1e-9, 1e-12][out.len() % 3];
        let dir = DVec3::from(rng.direction());
        let p = a + DVec3::splat(off * (rng.uniform(-1.0, 1.0)));
        out.push((p - 3.0 * dir, dir));
    }
    out
}

/// Whether two certified answers for one ray agree: both misses, a graze
/// within the tolerance that one proves absent, or roots within four
/// tolerances `tol_t` (in t).
pub fn agree(a: Answer, b: Answer, tol_t: f64) -> bool {
    match (a, b) {
        (Answer::Miss, Answer::Miss) => true,
        (Answer::Touch(_), Answer::Miss) | (Answer::Miss, Answer::Touch(_)) => true,
        (Answer::Miss, _) | (_, Answer::Miss) => false,
        (x, y) => (x.t().unwrap() - y.t().unwrap()).abs() <= 4.0 * tol_t,
    }
}

/// The answers of `reference` and `other` tracers for the ray `o + t·d`,
/// checked to agree, the other one decided; the other's answer. `what` names
/// the case in messages.
pub fn answer_alike(
    what: &str,
    reference: &mut Tracer<'_>,
    other: &mut Tracer<'_>,
    (o, d): (DVec3, DVec3),
    tol: f64,
) -> Answer {
    let (a, b) = (
        reference.answer(o, d, 0.0, f64::INFINITY),
        other.answer(o, d, 0.0, f64::INFINITY),
    );
    assert!(
        agree(a, b, tol / d.length()),
        "{what}ray {o} {d}: reference {a:?}, other {b:?}"
    );
    assert!(!matches!(b, Answer::Undecided(_)), "{what}{o} {d}: {b:?}");
    b
}

/// 64×48 pictures with shadows and bundles of `reference` and `other`,
/// framing `bounds`, and how many pixels differ by more than `by` in a
/// channel.
pub fn render_both(
    reference: &Intersector,
    other: &Intersector,
    bounds: &Aabb,
    by: u8,
) -> (Rendering, Rendering, usize) {
    let camera = Camera::framing(bounds, 30.0, 64, 48).unwrap();
    let shading = Shading::studio(camera.basis(), DVec3::new(0.85, 0.45, 0.25));
    let settings = RenderSettings {
        width: 64,
        height: 48,
        samples: 1,
        shadows: true,
        bundles: true,
    };
    let a = render(reference, &camera, &shading, &settings, &|| {});
    let b = render(other, &camera, &shading, &settings, &|| {});
    let differing = a
        .rgb
        .chunks(3)
        .zip(b.rgb.chunks(3))
        .filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > by))
        .count();
    (a, b, differing)
}
