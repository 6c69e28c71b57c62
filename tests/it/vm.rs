//! Models in fidget's `.vm` format: read into the same functions as the
//! formula language, every mistake located, and usable wherever a formula is.

use crate::common::{lgc_with_stdin, Rng};
use lgc::{Evaluator, Formula, FormulaError, Output};

/// f at `p` for a parsed formula.
fn f_at(formula: &Formula, p: [f64; 3]) -> f64 {
    let tape = formula.tape(&[Output::F]);
    let [f] = Evaluator::<f64>::new(&tape).eval_array(&[p[0], p[1], p[2], 0.0, 0.0, 0.0]);
    f
}

/// Each model against the same function in the formula language, at random
/// points: the same values (to rounding, where the graphs fold differently).
#[test]
fn models_compute_what_the_same_formulas_compute() {
    let cases = [
        (
            "_0 var-x\n_1 square _0\n_2 var-y\n_3 square _2\n_4 var-z\n_5 square _4\n\
             _6 add _1 _3\n_7 add _6 _5\n_8 const 1\n_9 sub _7 _8\n",
            "x^2+y^2+z^2-1",
        ),
        (
            "# a ball cut by a plane\n_0 var-x\n_1 var-y\n_2 var-z\n_3 square _0\n\
             _4 square _1\n_5 square _2\n_6 add _3 _4\n_7 add _6 _5\n_8 const 1\n\
             _9 sub _7 _8\n_a const 0.3\n_b sub _2 _a\n_c max _9 _b\n",
            "max(x^2+y^2+z^2-1, z-0.3)",
        ),
        (
            "_0 var-x\n_1 var-y\n_2 var-z\n_3 sin _0\n_4 cos _1\n_5 mul _3 _4\n\
             _6 exp _2\n_7 ln _6\n_8 abs _7\n_9 neg _8\n_a min _5 _9\n_b atan2 _1 _0\n\
             _c add _a _b\n_d recip _c\n_e sqrt _6\n_f div _d _e\n_g tan _3\n\
             _h asin _4\n_i acos _4\n_j atan _g\n_k add _h _i\n_l sub _k _j\n\
             _m copy _l\n_n add _f _m\n",
            "1/(min(sin(x)*cos(y), -abs(ln(exp(z)))) + atan2(y, x))/sqrt(exp(z)) \
             + (asin(cos(y)) + acos(cos(y)) - atan(tan(sin(x))))",
        ),
    ];
    let mut rng = Rng::new(0x5eed_0bea_2026);
    for (model, formula) in cases {
        let (vm, text) = (
            Formula::parse_vm(model).unwrap(),
            Formula::parse(formula).unwrap(),
        );
        for _ in 0..500 {
            let p = [0, 1, 2].map(|_| rng.uniform(-2.0, 2.0));
            let (a, b) = (f_at(&vm, p), f_at(&text, p));
            let close = (a - b).abs() <= 1e-12 * (1.0 + a.abs()) || (a.is_nan() && b.is_nan());
            assert!(
                close,
                "{formula} at {p:?}: {a} from the model, {b} from the formula"
            );
        }
    }
}

/// fidget's `compare`, `and`, `or` and `not`, lowered to `sign` and products,
/// give fidget's values at points where both sides are exact.
#[test]
fn compare_and_or_not_give_fidgets_values() {
    let model = "_0 var-x\n_1 var-y\n_2 compare _0 _1\n_3 and _0 _1\n_4 or _0 _1\n\
                 _5 not _0\n_6 const 10\n_7 mul _3 _6\n_8 add _2 _7\n_9 const 100\n\
                 _a mul _4 _9\n_b add _8 _a\n_c const 1000\n_d mul _5 _c\n_e add _b _d\n";
    let f = Formula::parse_vm(model).unwrap();
    for x in [-2.0, 0.0, 3.0] {
        for y in [-5.0, 0.0, 3.0] {
            let compare = if x < y {
                -1.0
            } else if x > y {
                1.0
            } else {
                0.0
            };
            let and = if x == 0.0 { 0.0 } else { y };
            let or = if x != 0.0 { x } else { y };
            let not = if x == 0.0 { 1.0 } else { 0.0 };
            let expected = compare + 10.0 * and + 100.0 * or + 1000.0 * not;
            assert_eq!(f_at(&f, [x, y, 0.0]), expected, "x = {x}, y = {y}");
        }
    }
}

/// Each mistake, with its class, message and the line and column its caret
/// points at.
#[test]
fn mistakes_in_models_are_located_by_line_and_column() {
    use lgc::ErrorKind::*;
    let cases: &[(&str, lgc::ErrorKind, &str, &str)] = &[
        (
            "_0 var-x\n_1 mull _0 _0\n",
            UnknownFunction,
            "did you mean `mul`?",
            ":2:4",
        ),
        (
            "_0 var-x\n_1 add _0 _7\n",
            UnknownName,
            "`_7` names no operation",
            ":2:11",
        ),
        (
            "_0 var-x\n_1 neg\n",
            WrongArity,
            "`neg` takes 1 argument, not 0",
            ":2:7",
        ),
        (
            "_0 var-x\n_1 sub _0 _0 _0\n",
            WrongArity,
            "takes 2 arguments, not 3",
            ":2:14",
        ),
        (
            "_0 var-x\n_0 var-y\n",
            RepeatedField,
            "`_0` is defined twice",
            ":2:1",
        ),
        (
            "_0 const 1.2.3\n",
            MalformedNumber,
            "`1.2.3` is not a finite number",
            ":1:10",
        ),
        (
            "_0 const inf\n",
            MalformedNumber,
            "not a finite number",
            ":1:10",
        ),
        (
            "_0 var-x\n_1 const 1e-400\n_2 mul _0 _1\n",
            NumberOutOfRange,
            "`1e-400` is beyond f64's range",
            ":2:10",
        ),
        (
            "# nothing\n\n",
            EmptyInput,
            "the model has no operation",
            ":1:1",
        ),
        (
            "_0 var-x\n_1\n",
            UnexpectedEnd,
            "`_1` has no operation",
            ":2:3",
        ),
        (
            "_0 var-x\n_1 const 2\n_2 mod _0\n",
            WrongArity,
            "`mod` takes 2 arguments, not 1",
            ":3:10",
        ),
    ];
    for &(model, kind, message, at) in cases {
        let err: FormulaError = Formula::parse_vm(model).unwrap_err();
        assert_eq!(err.kind, kind, "{model:?}");
        assert!(err.message.contains(message), "{model:?}: {}", err.message);
        let shown = err.render(model, "m.vm");
        assert!(shown.contains(&format!("m.vm{at}")), "{model:?}:\n{shown}");
    }
}

/// Random lines of words from the format, right and wrong, never panic: each
/// model parses or gives a located error.
#[test]
fn random_models_parse_or_fail_without_panicking() {
    let words = [
        "_0", "_1", "_2", "var-x", "var-y", "const", "add", "neg", "max", "1.5", "-2", "nan", "#",
        "mod", "", "\t", "_",
    ];
    let mut rng = Rng::new(7);
    for _ in 0..5000 {
        let mut model = String::new();
        for _ in 0..(rng.next_u64() % 6) {
            for _ in 0..(rng.next_u64() % 5) {
                model.push_str(words[(rng.next_u64() % words.len() as u64) as usize]);
                model.push(' ');
            }
            model.push('\n');
        }
        if let Err(e) = Formula::parse_vm(&model) {
            assert!(
                e.span.start <= e.span.end && e.span.end <= model.len(),
                "{model:?}"
            );
            let _ = e.render(&model, "m.vm");
        }
    }
}

/// The bear, read from its file wherever a formula is read: `eval` gives the
/// model's value, `render` draws it, and a mistake is located in the file.
#[test]
fn the_bear_model_is_read_by_every_command() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/models/bear.vm");
    let text = std::fs::read_to_string(path).unwrap();
    let bear = Formula::parse_vm(&text).unwrap();
    assert!(bear.context().len() > 400, "{} nodes", bear.context().len());
    let o = lgc_with_stdin(&["eval", path, "--at", "0.1,0.2,0.3", "--json"], "");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["f"].as_f64().unwrap(), f_at(&bear, [0.1, 0.2, 0.3]));
    let o = lgc_with_stdin(&["eval", "-f", path, "--at", "0.1,0.2,0.3", "--json"], "");
    assert_eq!(
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap(),
        json
    );

    let out = std::env::temp_dir().join(format!("lgc-bear-{}.png", std::process::id()));
    let args = [
        "render",
        path,
        "--size",
        "24x18",
        "--depth",
        "3",
        "--box=-1.2,-1.2,-1.2,1.2,1.2,1.2",
        "-o",
    ];
    let o = lgc_with_stdin(&[&args[..], &[out.to_str().unwrap()]].concat(), "");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let image = image::open(&out).unwrap().to_rgb8();
    std::fs::remove_file(&out).unwrap();
    let background = *image.get_pixel(0, 0);
    assert!(
        image.pixels().any(|p| *p != background),
        "the bear is drawn"
    );

    let broken = std::env::temp_dir().join(format!("lgc-broken-{}.vm", std::process::id()));
    std::fs::write(&broken, "_0 var-x\n_1 square _0\n_2 sqrtt _1\n").unwrap();
    let o = lgc_with_stdin(&["grad", broken.to_str().unwrap()], "");
    std::fs::remove_file(&broken).unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("did you mean `sqrt`?") && err.contains(":3:4"),
        "{err}"
    );
}

/// fidget's `mod`, `floor`, `ceil` and `round` read from a model give the
/// formula language's functions: `mod` takes the sign of its divisor.
#[test]
fn step_operations_of_models_are_the_languages() {
    let model = "_0 var-x\n_1 var-y\n_2 mod _0 _1\n_3 floor _0\n_4 ceil _1\n_5 round _0\n\
                 _6 const 10\n_7 mul _3 _6\n_8 const 100\n_9 mul _4 _8\n_a const 1000\n\
                 _b mul _5 _a\n_c add _2 _7\n_d add _c _9\n_e add _d _b\n";
    let f = Formula::parse_vm(model).unwrap();
    for (x, y) in [
        (7.5f64, 2.0f64),
        (-7.5, 2.0),
        (7.5, -2.0),
        (-7.5, -2.0),
        (2.5, 0.75),
    ] {
        let m: f64 = x - y * (x / y).floor();
        assert!(m == 0.0 || m.signum() == y.signum(), "mod({x}, {y}) = {m}");
        let expected = m + 10.0 * x.floor() + 100.0 * y.ceil() + 1000.0 * x.round();
        assert_eq!(f_at(&f, [x, y, 0.0]), expected, "x = {x}, y = {y}");
    }
}
