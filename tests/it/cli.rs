//! The `lgc` binary: output formats, argument forms and exit codes
//! (0 success, 1 bad input or failure, 2 bad usage).

use std::io::Write;
use std::process::{Command, Output, Stdio};

fn lgc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args(args)
        .output()
        .expect("the lgc binary runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).unwrap()
}

#[test]
fn grad_prints_the_sphere_gradient() {
    let o = lgc(&["grad", "x^2+y^2+z^2-1"]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(stdout(&o), "df/dx = 2*x\ndf/dy = 2*y\ndf/dz = 2*z\n");
}

#[test]
fn grad_directional_adds_g_and_its_derivative() {
    let o = lgc(&["grad", "--directional", "x^2+y^2+z^2-1"]);
    assert_eq!(o.status.code(), Some(0));
    let out = stdout(&o);
    assert!(out.contains("\ng = 2*x*dx+2*y*dy+2*z*dz\n"), "{out}");
    assert!(out.contains("\ndg = 2*dx^2+2*dy^2+2*dz^2\n"), "{out}");
}

#[test]
fn grad_json_is_one_object_of_strings() {
    let o = lgc(&["grad", "--json", "--directional", "x*y"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["grad"], serde_json::json!(["y", "x", "0"]));
    assert_eq!(v["g"], "dx*y+x*dy");
}

#[test]
fn eval_json_is_exactly_one_object() {
    let o = lgc(&["eval", "x^2+y^2+z^2-1", "--at", "1,2,3", "--json"]);
    assert_eq!(o.status.code(), Some(0));
    let text = stdout(&o);
    assert_eq!(text.lines().count(), 1);
    let v: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
    let obj = v.as_object().unwrap();
    assert_eq!(obj.len(), 2, "{text}");
    assert_eq!(v["f"], 13.0);
    assert_eq!(v["grad"], serde_json::json!([2.0, 4.0, 6.0]));
}

#[test]
fn eval_with_direction_adds_g_and_dg() {
    let o = lgc(&["eval", "x^3", "--at", "2,0,0", "--dir", "0.5,1,1", "--json"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v.as_object().unwrap().len(), 4);
    assert_eq!(v["g"], 0.5 * 12.0);
    assert_eq!(v["dg"], 0.25 * 12.0);
}

#[test]
fn negative_coordinates_are_values_not_flags() {
    for args in [
        vec!["eval", "x+2*y+3*z", "--at", "-1,-2,-3", "--json"],
        vec!["eval", "x+2*y+3*z", "--at=-1,-2,-3", "--json"],
    ] {
        let o = lgc(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
        assert_eq!(v["f"], -14.0);
    }
    // A formula that starts with a minus is a formula, not a flag.
    let o = lgc(&["eval", "-x^2", "--at", "3,0,0", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn eval_text_lists_every_value() {
    let o = lgc(&["eval", "x*y", "--at", "2,3,0"]);
    let out = stdout(&o);
    assert!(
        out.contains("f      = 6\n") && out.contains("df/dx  = 3\n"),
        "{out}"
    );
}

#[test]
fn formula_from_a_file_and_from_stdin() {
    let dir = std::env::temp_dir().join(format!("lgc-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sphere.lgc");
    std::fs::write(
        &path,
        "# unit sphere\nlet r = 1;\nx^2 + y^2 + z^2\n  - r^2\n",
    )
    .unwrap();
    let o = lgc(&["grad", "-f", path.to_str().unwrap()]);
    assert_eq!(
        stdout(&o),
        "df/dx = 2*x\ndf/dy = 2*y\ndf/dz = 2*z\n",
        "{}",
        stderr(&o)
    );

    let mut child = Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args(["eval", "-f", "-", "--at", "1,1,1", "--json"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(b"x*y*z\n").unwrap();
    let o = child.wait_with_output().unwrap();
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["f"], 1.0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_formulas_exit_1_with_a_caret() {
    let o = lgc(&["grad", "x^2 + sn(y)"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("unknown function `sn`, did you mean `sin`?"),
        "{err}"
    );
    assert!(err.contains("<formula>:1:7"), "{err}");
    assert!(err.contains("1 | x^2 + sn(y)\n  |       ^^"), "{err}");
    assert!(stdout(&o).is_empty());
}

#[test]
fn a_missing_file_exits_1_with_one_line() {
    let o = lgc(&["grad", "-f", "/nonexistent/surface.lgc"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: cannot read formula file"), "{err}");
}

#[test]
fn bad_usage_exits_2() {
    assert_eq!(lgc(&["eval", "x"]).status.code(), Some(2), "missing --at");
    assert_eq!(
        lgc(&["eval", "x", "--at", "1,2"]).status.code(),
        Some(2),
        "two numbers"
    );
    assert_eq!(
        lgc(&["eval", "x", "--at", "1,2,zebra"]).status.code(),
        Some(2)
    );
    assert_eq!(lgc(&["frobnicate"]).status.code(), Some(2));
    assert_eq!(lgc(&["grad"]).status.code(), Some(2), "no formula");
}

#[test]
fn help_documents_the_language() {
    let o = lgc(&["--help"]);
    assert_eq!(o.status.code(), Some(0));
    let out = stdout(&o);
    for f in lgc::lang::functions::FUNCTIONS {
        assert!(out.contains(f.usage), "--help lacks {}", f.usage);
    }
    assert!(out.contains("2^3^2 = 512"));
}

#[test]
fn bounds_json_has_the_documented_keys() {
    let o = lgc(&[
        "bounds",
        "x^2+y^2+z^2-1",
        "--box",
        "-1,-1,-1,1,1,1",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["f"], serde_json::json!([-1.0, 2.0]));
    let l = v["L"].as_f64().unwrap();
    assert!(
        (2.0 * 3f64.sqrt()..2.0 * 3f64.sqrt() + 1e-12).contains(&l),
        "{l}"
    );
    assert!(v["L_sampled"].as_f64().unwrap() <= l);
    assert_eq!(v["L_point"].as_array().unwrap().len(), 3);
    assert!(v.get("G").is_none());

    let o = lgc(&[
        "bounds",
        "x^2+y^2+z^2-1",
        "--box",
        "-1,-1,-1,1,1,1",
        "--ray",
        "-2,0,0,1,2,2",
        "--t",
        "0,3",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["G"], 18.0);
    assert_eq!(v["G_sampled"], 18.0);
}

#[test]
fn bounds_tolerance_brackets_l_and_g_with_their_points() {
    let o = lgc(&[
        "bounds",
        "x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8",
        "--box",
        "-3,-3,-3,3,3,3",
        "--ray",
        "-2,0.5,0.25,1,0.5,-0.25",
        "--t",
        "0,4",
        "--tolerance",
        "0.01",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    let (l, lower) = (v["L"].as_f64().unwrap(), v["L_lower"].as_f64().unwrap());
    assert!(lower <= l && l <= 1.01 * lower, "{v}");
    assert_eq!(v["L_point"].as_array().unwrap().len(), 3);
    assert!(v["pieces"].as_u64().unwrap() >= 1);
    assert_eq!(v["L_reached"], true);
    let (g, g_lower) = (v["G"].as_f64().unwrap(), v["G_lower"].as_f64().unwrap());
    assert!(g_lower <= g && g <= 1.01 * g_lower, "{v}");
    assert!((0.0..=4.0).contains(&v["G_t"].as_f64().unwrap()));

    let o = lgc(&[
        "bounds",
        "x^2",
        "--box",
        "0,0,0,1,1,1",
        "--tolerance",
        "1e-3",
    ]);
    let text = stdout(&o);
    assert!(text.contains("L bracket       = [2, 2]"), "{text}");
    assert!(text.contains("L_lower at      = (1, "), "{text}");
}

#[test]
fn bounds_tolerance_must_be_positive() {
    for bad in ["0", "-0.1", "nan", "inf", "much"] {
        let o = lgc(&["bounds", "x", "--box", "0,0,0,1,1,1", "--tolerance", bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert_eq!(stderr(&o).lines().count(), 1, "{bad}: {}", stderr(&o));
        assert!(stdout(&o).is_empty());
    }
}

#[test]
fn bounds_method_selects_the_enclosure() {
    let kummer =
        "(x^2+y^2+z^2-1.69)^2-3.1*(1-z-sqrt(2)*x)*(1-z+sqrt(2)*x)*(1+z+sqrt(2)*y)*(1+z-sqrt(2)*y)";
    let l = |method: &str| {
        let o = lgc(&[
            "bounds",
            kummer,
            "--box",
            "-3,-3,-3,3,3,3",
            "--split",
            "1",
            "--method",
            method,
            "--json",
        ]);
        assert_eq!(o.status.code(), Some(0), "{method}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
        (v["L"].as_f64().unwrap(), v["L_sampled"].as_f64().unwrap())
    };
    let (natural, sampled) = l("natural");
    let (centred, _) = l("centred");
    let (bernstein, _) = l("bernstein");
    let (affine, _) = l("affine");
    let (best, _) = l("best");
    assert!(sampled <= best && best <= bernstein.min(centred) && centred <= natural);
    assert!(sampled <= affine && affine <= natural && best <= affine);
    // The Bernstein form of |grad f|^2 is far tighter than intervals here.
    assert!(bernstein < 0.5 * natural, "{bernstein} vs {natural}");

    let o = lgc(&[
        "bounds",
        "sin(x)",
        "--box",
        "0,0,0,1,1,1",
        "--method",
        "bernstein",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("needs a polynomial"), "{}", stderr(&o));
    let o = lgc(&[
        "bounds",
        "abs(x)",
        "--box",
        "0,0,0,1,1,1",
        "--method",
        "taylor",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("sin, cos, exp"), "{}", stderr(&o));
    let o = lgc(&[
        "bounds",
        "x",
        "--box",
        "0,0,0,1,1,1",
        "--method",
        "ellipsoid",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
}

#[test]
fn bounds_convergence_writes_the_plot_and_its_table() {
    let dir = std::env::temp_dir().join(format!("lgc-convergence-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let torus = "(x^2+y^2+z^2+0.75)^2-4*(x^2+y^2)";
    for ext in ["png", "svg"] {
        let path = dir.join(format!("torus.{ext}"));
        let o = lgc(&[
            "bounds",
            torus,
            "--box",
            "-2,-2,-1,2,2,1",
            "--convergence",
            path.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let bytes = std::fs::read(&path).unwrap();
        match ext {
            "png" => assert_eq!(&bytes[..4], b"\x89PNG"),
            _ => assert!(String::from_utf8_lossy(&bytes).contains("natural")),
        }
        let text = stdout(&o);
        assert!(text.contains("bernstein"), "{text}");
        // Depth 0 to 5, each with its number of boxes.
        assert!(
            text.lines()
                .any(|l| l.starts_with("5") && l.contains("32768")),
            "{text}"
        );
    }
    let path = dir.join("t.png");
    let o = lgc(&[
        "bounds",
        torus,
        "--box",
        "-2,-2,-1,2,2,1",
        "--convergence",
        path.to_str().unwrap(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    let reference = v["reference"].as_f64().unwrap();
    for m in ["natural", "centred", "bernstein", "best"] {
        let values = v[m].as_array().unwrap();
        assert_eq!(values.len(), 6, "{m}");
        for l in values {
            assert!(l.as_f64().unwrap() >= reference, "{m}: {l} < {reference}");
        }
    }
    // No plot for a format it cannot write, and no file left behind.
    let bad = dir.join("t.jpg");
    let o = lgc(&[
        "bounds",
        torus,
        "--box",
        "-2,-2,-1,2,2,1",
        "--convergence",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!bad.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn infinite_bounds_are_null_with_a_reason() {
    let o = lgc(&["bounds", "sqrt(x)", "--box", "0,0,0,1,1,1", "--json"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert!(v["L"].is_null());
    assert_eq!(v["L_note"], "∂f/∂x is unbounded on this box");
    let o = lgc(&["bounds", "sqrt(x)", "--box", "0,0,0,1,1,1"]);
    assert!(stdout(&o).contains("L               = infinite: ∂f/∂x is unbounded on this box"));
}

#[test]
fn verify_exit_codes_are_0_proved_3_refuted_4_undecided() {
    let sphere = "x^2+y^2+z^2-1";
    let o = lgc(&[
        "verify",
        sphere,
        "--ray",
        "0,0,0,1,2,2",
        "--t",
        "-5,5",
        "--grad-lipschitz",
        "18",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    assert!(stdout(&o).starts_with("proved"));

    let o = lgc(&[
        "verify",
        sphere,
        "--box",
        "-1,-1,-1,1,1,1",
        "--lipschitz",
        "3.4",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(3));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["verdict"], "refuted");
    let w: Vec<f64> = v["witness"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(2.0 * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt() > 3.4);

    let o = lgc(&[
        "verify",
        "sqrt(x^2+y^2)",
        "--box",
        "-1,-1,-1,1,1,1",
        "--lipschitz",
        "1",
        "--max-boxes",
        "500",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(4));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["verdict"], "undecided");
    assert_eq!(v["worst"].as_array().unwrap().len(), 6);

    // A constant expression as the claim: 2*sqrt(3) is the true maximum, which
    // rounded arithmetic cannot prove; a claim just above it is proved.
    let o = lgc(&[
        "verify",
        sphere,
        "--box",
        "-1,-1,-1,1,1,1",
        "--lipschitz",
        "2*sqrt(3) + 1e-9",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
}

#[test]
fn bad_regions_exit_1_with_one_line() {
    let o = lgc(&["bounds", "x", "--box", "1,1,1,0,0,0"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("inverted"), "{err}");
    let o = lgc(&[
        "verify",
        "x",
        "--ray",
        "0,0,0,1,0,0",
        "--t",
        "2,1",
        "--grad-lipschitz",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("inverted"));
    let o = lgc(&["verify", "x", "--box", "0,0,0,1,1,1", "--lipschitz", "x+1"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("may not depend on x, y or z"));
    assert_eq!(
        lgc(&["bounds", "x", "--box", "0,0,0,1,1"]).status.code(),
        Some(2)
    );
    assert_eq!(
        lgc(&["verify", "x", "--box", "0,0,0,1,1,1"]).status.code(),
        Some(2),
        "no claim"
    );
}

#[test]
fn an_empty_picture_says_why_and_is_still_written() {
    // A sphere of radius 10 outside the default box wrote an empty picture
    // with no word.
    let dir = std::env::temp_dir().join(format!("lgc-empty-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("empty.png");
    let out_s = out.to_str().unwrap();
    let o = lgc(&["render", "x^2+y^2+z^2-100", "--size", "32x24", "-o", out_s]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(out.exists());
    assert!(
        err.contains("nothing to see: f is never 0 in the box")
            && err.contains("[-100, -88]")
            && err.contains("--box"),
        "{err}"
    );
    // The surface is in the box, but the camera looks away from it.
    let o = lgc(&[
        "render",
        "x^2+y^2+z^2-1",
        "--size",
        "32x24",
        "--eye",
        "5,0,0",
        "--look-at",
        "10,0,0",
        "-o",
        out_s,
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no camera ray meets the surface"), "{err}");
    // A picture with the surface in it says nothing of the kind.
    let o = lgc(&["render", "x^2+y^2+z^2-1", "--size", "32x24", "-o", out_s]);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("nothing to see"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `bench --models` times whole renders of model files and draws the time
/// plot; a missing model stops it before any row, with one line.
#[test]
fn bench_models_times_each_model_and_draws_the_plot() {
    let dir = std::env::temp_dir().join(format!("lgc-bench-models-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/models/balls_10.vm");
    let plot = dir.join("time.svg");
    let o = lgc(&[
        "bench",
        "--models",
        model,
        "--size",
        "16",
        "--repeat",
        "1",
        "--threads",
        "1",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    let row = text.lines().find(|l| l.starts_with("balls_10")).unwrap();
    // Its operations: the 10 balls' f, 11 instructions each but the last.
    let ops: usize = row.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!((100..=120).contains(&ops), "{row}");
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.contains("balls_10") && svg.contains("lgc"), "{svg}");
    let missing = dir.join("missing.vm");
    let o = lgc(&[
        "bench",
        "--models",
        missing.to_str().unwrap(),
        "--size",
        "16",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stdout(&o), "");
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
    // A plot needs models.
    assert_eq!(lgc(&["bench", "--plot", "x.svg"]).status.code(), Some(2));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_closed_standard_output_ends_the_process_without_a_panic() {
    // The reader goes away before lgc writes: the write fails, and lgc must
    // end as other tools do, not panic in `println!`.
    let mut child = Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args(["eval", "x^2+y", "--at", "1,2,3"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
}

/// `bounds --corpus`: each surface's L by every method that applies, none
/// below the certified maximum, Bernstein only for the polynomial; the
/// table's rows; a bad corpus is one line.
#[test]
fn bounds_corpus_reports_every_method_against_the_certified_maximum() {
    let dir = std::env::temp_dir().join(format!("lgc-corpus-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("corpus.json");
    std::fs::write(
        &file,
        r#"{"quartic": {"expr": "x^4+y^4+z^4-x*y", "box": [-1, -1, -1, 1, 1, 1]},
            "wave": {"expr": "sin(3*x)*cos(y)+z", "box": [-1, -1, -1, 1, 1, 2]}}"#,
    )
    .unwrap();
    let path = file.to_str().unwrap();
    let out = lgc(&["bounds", "--corpus", path, "--split", "1", "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    let surfaces = v["surfaces"].as_array().unwrap();
    assert_eq!(surfaces.len(), 2);
    for s in surfaces {
        let lower = s["max_lower"].as_f64().unwrap();
        assert!(lower > 0.0 && s["max_upper"].as_f64().unwrap() <= lower * 1.0001);
        let methods = s["methods"].as_object().unwrap();
        let polynomial = s["name"] == "quartic";
        assert_eq!(methods.contains_key("bernstein"), polynomial, "{s}");
        assert_eq!(methods.contains_key("taylor"), !polynomial, "{s}");
        for (name, m) in methods {
            assert!(m["L"].as_f64().unwrap() >= lower, "{name}: {m}");
            assert!(m["ratio"].as_f64().unwrap() >= 1.0 && m["seconds"].as_f64().unwrap() >= 0.0);
        }
    }
    let table = stdout(&lgc(&["bounds", "--corpus", path, "--split", "1"]));
    assert!(
        table
            .lines()
            .nth(2)
            .unwrap()
            .starts_with("| quartic | [-1, 1]³ |"),
        "{table}"
    );
    std::fs::write(&file, r#"{"bad": {"expr": "x", "box": [0, 0, 0, 1, 1]}}"#).unwrap();
    let out = lgc(&["bounds", "--corpus", path]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stderr(&out).lines().count(), 1, "{}", stderr(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}
