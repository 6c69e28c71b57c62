//! Memory of large scenes, measured in a test binary of its own so that no
//! other test allocates meanwhile (Linux: the process's resident size).

use lgc::render::Prepared;
use lgc::scene::parse_scene;

/// Resident memory of this process in KiB, where the system tells it.
fn resident_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[test]
fn a_thousand_spheres_share_one_compiled_shape_and_stay_small() {
    let mut src = String::from("light { position = (-6, -8, 10); }\n");
    for i in 0..1000 {
        let (x, y, z) = (
            f64::from(i % 10) * 2.0 - 9.0,
            f64::from((i / 10) % 10) * 2.0 - 9.0,
            f64::from(i / 100) * 2.0 - 9.0,
        );
        let r = 0.2 + 0.05 * f64::from(i % 7);
        src += &format!("sphere {{ center = ({x}, {y}, {z}); radius = {r}; }}\n");
    }
    let before = resident_kib();
    let scene = parse_scene(&src).unwrap();
    let prepared = Prepared::new(&scene, 5);
    assert_eq!(
        prepared.shape_count(),
        1,
        "every sphere is the unit sphere, placed"
    );
    if let (Some(a), Some(b)) = (before, resident_kib()) {
        let per_object = (b.saturating_sub(a)) * 1024 / 1000;
        assert!(per_object < 100 * 1024, "{per_object} bytes per sphere");
    }
    // An object's formula holds its own graph only, not the scene's.
    assert!(scene.objects[999].formula.context().len() < 200);
}

#[test]
fn an_object_keeps_its_own_graph_not_the_scenes() {
    let mut src = String::new();
    for i in 0..300 {
        src += &format!(
            "object {{ surface = (x - {i})^2 + y^2 + z^2 - 0.25 + 0.01*sin(7*x*y); box = ({}, -1, -1, {}, 1, 1); }}\n",
            i - 1,
            i + 1
        );
    }
    let scene = parse_scene(&src).unwrap();
    let first = scene.objects[0].formula.context().len();
    let last = scene.objects[299].formula.context().len();
    assert!(
        last <= first + 5,
        "the 300th object's graph has {last} nodes, the first's {first}"
    );
}

/// Runs the lgc binary under an address-space limit of 2 GB (`ulimit -v`):
/// an allocation past it fails, and lgc must not have tried.
fn lgc_within_2_gb(args: &[&str]) -> std::process::Output {
    std::process::Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2097152 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_lgc"))
        .args(args)
        .output()
        .expect("sh runs")
}

/// An answer (exit 0) or a clear error (exit 1 or 2, one `error:` line first),
/// never an abort: no signal, no failed allocation, no panic.
fn answered_or_refused(args: &[&str], expect_error: Option<&str>) {
    // One at a time: each may take up to 2 GB, and CI machines are small.
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let o = lgc_within_2_gb(args);
    let err = String::from_utf8_lossy(&o.stderr);
    let what = format!("lgc {}", args.join(" "));
    assert!(
        !err.contains("memory allocation") && !err.contains("panicked"),
        "{what}: {err}"
    );
    match expect_error {
        None => assert_eq!(o.status.code(), Some(0), "{what}: {err}"),
        Some(text) => {
            assert!(matches!(o.status.code(), Some(1 | 2)), "{what}: {err}");
            assert!(
                err.starts_with("error: ") && err.contains(text),
                "{what}: {err}"
            );
        }
    }
}

/// Writes `text` to a file of this test's own.
fn temp_file(name: &str, text: &str) -> String {
    let path = std::env::temp_dir().join(format!("lgc-memory-{}-{name}", std::process::id()));
    std::fs::write(&path, text).unwrap();
    path.to_string_lossy().into_owned()
}

/// Renders the scene `src` at 8x6 with `options`, as [`answered_or_refused`].
fn render_within_2_gb(name: &str, src: &str, options: &[&str], expect_error: Option<&str>) {
    let path = temp_file(&format!("{name}.lgc"), src);
    let out = temp_file(&format!("{name}.png"), "");
    let mut args = vec!["render", &path, "-o", &out, "--size", "8x6"];
    args.extend(options);
    answered_or_refused(&args, expect_error);
    std::fs::remove_file(path).ok();
    std::fs::remove_file(out).ok();
}

#[test]
fn high_powers_bound_within_2_gb() {
    // The Taylor path's binomial table grew with the exponent: 2.3 GB.
    for f in ["sinh(x)^1000 - 1", "sin(x)^1000 - 0.5"] {
        answered_or_refused(&["bounds", f, "--box=0,0,0,1,1,1"], None);
    }
}

#[test]
fn a_million_nested_sines_are_refused_within_2_gb() {
    // Their derivatives take 21 million nodes: bounds aborted out of
    // memory, and eval took 3.4 GB.
    let n = 1_000_000;
    let path = temp_file(
        "sines.txt",
        &format!("{}x{}-0.5", "sin(".repeat(n), ")".repeat(n)),
    );
    answered_or_refused(
        &["bounds", "-f", &path, "--box=0,0,0,1,1,1"],
        Some("too large"),
    );
    answered_or_refused(&["eval", "-f", &path, "--at=0,0,0"], Some("too large"));
    std::fs::remove_file(path).ok();
}

#[test]
fn user_functions_that_double_at_each_call_are_refused_within_2_gb() {
    // Each calls the next twice, with new arguments: 2^40 calls.
    let mut src = String::from("fn f0(a) = sin(a);\n");
    for i in 0..40 {
        src += &format!("fn f{}(a) = f{i}(a) + f{i}(a + 1);\n", i + 1);
    }
    src += "object { surface = f40(x) + y^2 + z^2 - 1; box = (-1, -1, -1, 1, 1, 1); }\n";
    render_within_2_gb("doubling", &src, &[], Some("too large"));
}

#[test]
fn many_objects_over_one_large_binding_are_refused_within_2_gb() {
    // Each object copies the binding into a graph of its own and derives
    // it: 200 objects of 20,000 nested sines would take 84 million nodes.
    let n = 20_000;
    let mut src = format!("let a = {}x{};\n", "sin(".repeat(n), ")".repeat(n));
    for i in 0..200 {
        src +=
            &format!("object {{ surface = a + y^2 + z^2 - {i}; box = (-1, -1, -1, 1, 1, 1); }}\n");
    }
    render_within_2_gb("objects", &src, &[], Some("too large"));
}

#[test]
fn deep_transform_and_blend_chains_build_within_2_gb() {
    // Chains 1,000 to 5,000 deep took 2.6 to 3.8 GB, or aborted.
    let mut rotated = String::from("x^2 + y^2 + z^2 - 1");
    let mut blended = rotated.clone();
    for i in 0..5000 {
        rotated = match i % 2 {
            0 => format!("rotate({rotated}, 0.01, 0.02, 0)"),
            _ => format!("translate({rotated}, 0.0001, 0, 0)"),
        };
        blended = format!("blend({blended}, (x - {})^2 + y^2 + z^2 - 0.5, 0.1)", i % 7);
    }
    let scene = format!("object {{ surface = {rotated}; box = (-3, -3, -3, 3, 3, 3); }}\n");
    render_within_2_gb("chain", &scene, &[], None);
    let formula = temp_file("blends.txt", &blended);
    answered_or_refused(&["bounds", "-f", &formula, "--box=-1,-1,-1,1,1,1"], None);
    std::fs::remove_file(formula).ok();
}

#[test]
fn glass_nested_fifty_deep_renders_within_2_gb() {
    // Without adaptive depth control the ray tree doubles at each surface:
    // it ran over 120 s at 32x24. Each pixel's secondary rays are capped.
    let mut src =
        String::from("material glass { transparency = 0.9; reflect = 0.1; ior = 1.5; }\n");
    for i in 0..8 {
        src += &format!(
            "sphere {{ center = (0, 0, 0); radius = {}; material = glass; }}\n",
            1.0 - 0.1 * f64::from(i)
        );
    }
    render_within_2_gb(
        "glass",
        &src,
        &["--max-depth", "50", "--min-weight", "0"],
        None,
    );
}
