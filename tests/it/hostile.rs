//! Hostile input: bounded memory, located errors, every value checked. Each
//! test is named after what once went wrong.

use glam::DVec3;
use lgc::ray::octree::{Octree, MAX_NODES};
use lgc::scene::parse_scene;
use lgc::{Aabb, ErrorKind, Formula};
use std::process::Output;

fn lgc(args: &[&str], stdin: &str) -> Output {
    crate::common::lgc_with_stdin(args, stdin)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn unprunable_formulas_at_any_depth_stay_within_the_node_budget() {
    let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    // 0*z is 0 everywhere, but at most quadratic: its root is a leaf.
    for (src, capped) in [
        ("0*z", false),
        ("dirac(z)", true),
        ("sin(1000*x)*sin(1000*y)*sin(1000*z)", true),
    ] {
        let f = Formula::parse(src).unwrap();
        let tree = Octree::build(&f, &b, 10);
        assert!(
            tree.nodes.len() <= MAX_NODES,
            "{src}: {} nodes",
            tree.nodes.len()
        );
        assert_eq!(tree.stats.capped_at_depth.is_some(), capped, "{src}");
        assert!(tree.stats.leaves > 0, "{src}");
    }
}

#[test]
fn a_capped_octree_says_so_and_still_answers() {
    // Nothing can be pruned, and along the ray f is 0: it meets the surface
    // where it enters the box, as a touch (no sign change), within the
    // tolerance.
    let o = lgc(
        &[
            "trace",
            "sin(1000*x)*sin(1000*y)*sin(1000*z)",
            "--depth",
            "9",
        ],
        "0 0 -5 0 0 1\n",
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the octree stopped at depth"),
        "{}",
        stderr(&o)
    );
    let out = String::from_utf8_lossy(&o.stdout);
    let t: f64 = out.trim().strip_prefix("touch ").unwrap().parse().unwrap();
    assert!((t - 3.0).abs() <= 1e-9, "{out}");
}

#[test]
fn depth_is_checked_the_same_way_by_every_command() {
    for args in [
        vec!["render", "x", "--depth", "11"],
        vec!["trace", "x", "--depth", "11"],
        vec!["bench", "--depth", "11"],
    ] {
        let o = lgc(&args, "");
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(
            stderr(&o).contains("use a whole number from 0 to 10"),
            "{args:?}: {}",
            stderr(&o)
        );
        assert_eq!(stderr(&o).lines().count(), 1, "{args:?}");
    }
}

fn scene_error(src: &str) -> lgc::FormulaError {
    parse_scene(src)
        .err()
        .unwrap_or_else(|| panic!("parsed: {src}"))
}

const BALL: &str = "sphere { center = (0, 0, 0); radius = 1; }";

#[test]
fn camera_mistakes_in_a_scene_file_are_located() {
    let src = format!("camera {{ fov = 200; }} {BALL}");
    let e = scene_error(&src);
    assert_eq!(
        (e.kind, e.line_column(&src)),
        (ErrorKind::BadCamera, (1, 10))
    );
    let src = format!("camera {{ eye = (0, 0, 0); look_at = (0, 0, 0); }} {BALL}");
    let e = scene_error(&src);
    assert_eq!(e.kind, ErrorKind::BadCamera);
    assert_eq!(e.line_column(&src), (1, 27), "{}", e.message);
    let src = format!("camera {{ up = (0, 0, 0); }} {BALL}");
    assert_eq!(scene_error(&src).kind, ErrorKind::BadCamera);
}

#[test]
fn a_camera_whose_default_up_runs_along_the_view_is_located_at_render_time() {
    let dir = std::env::temp_dir().join(format!("lgc-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("up.lgc");
    std::fs::write(&file, format!("camera {{ eye = (0, 0, 5); }}\n{BALL}\n")).unwrap();
    let out = dir.join("never.png");
    let o = lgc(
        &[
            "render",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--size",
            "8x8",
        ],
        "",
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("up.lgc:1:10") && err.contains('^'), "{err}");
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn material_values_out_of_range_are_errors() {
    for (field, value) in [
        ("ior", "0"),
        ("ior", "-1"),
        ("transparency", "2"),
        ("reflect", "-5"),
        ("diffuse", "-1"),
    ] {
        let src = format!("material m {{ {field} = {value}; }} {BALL}");
        let e = scene_error(&src);
        assert_eq!(
            e.kind,
            ErrorKind::OutOfRange,
            "{field} = {value}: {}",
            e.message
        );
        assert!(e.message.contains(field), "{}", e.message);
    }
    let src = format!("material m {{ checker = (0, 0, 0); tile = 0; }} {BALL}");
    assert_eq!(scene_error(&src).kind, ErrorKind::OutOfRange);
    let src = format!("material m {{ color = (2, 0, 0); }} {BALL}");
    assert_eq!(scene_error(&src).kind, ErrorKind::OutOfRange);
    let src = format!("material m {{ reflect = 0.6; transparency = 0.6; }} {BALL}");
    assert_eq!(scene_error(&src).kind, ErrorKind::OutOfRange);
}

#[test]
fn bad_camera_options_say_the_real_problem() {
    for (args, needle) in [
        (vec!["--up", "0,0,0"], "the up vector cannot be (0, 0, 0)"),
        (vec!["--eye", "1e200,0,0"], "too far away"),
        (vec!["--fov", "1e-300"], "field of view"),
        (vec!["--box", "-1e200,-1,-1,1e200,1,1"], "too large"),
    ] {
        let mut full = vec![
            "render",
            "x^2+y^2+z^2-1",
            "-o",
            "/tmp/lgc-never.png",
            "--size",
            "8x8",
        ];
        full.extend(args.iter().copied());
        let o = lgc(&full, "");
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("coincide"), "{args:?}: {err}");
    }
}

#[test]
fn an_unwritable_output_is_reported_once() {
    let o = lgc(
        &["render", "x", "-o", "nodir/sub/o.png", "--size", "8x8"],
        "",
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
}

#[test]
fn a_zero_direction_is_not_a_ray() {
    let o = lgc(&["trace", "x"], "1 0 0 1 0 0\n0 0 0 0 0 0\n");
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("line 2: the direction (0, 0, 0) is not a ray"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_trailing_comment_on_a_ray_line_is_allowed() {
    let o = lgc(
        &["trace", "x^2+y^2+z^2-1"],
        "-3 0 0 1 0 0 # towards the sphere\n",
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        "2.0000000000000000e0"
    );
}

/// `R⁻¹·p` for `rotate(…, ax, ay, az)` (degrees about x, then y, then z).
fn unrotate(p: DVec3, [ax, ay, az]: [f64; 3]) -> DVec3 {
    let (sx, cx) = ax.to_radians().sin_cos();
    let (sy, cy) = ay.to_radians().sin_cos();
    let (sz, cz) = az.to_radians().sin_cos();
    let p = DVec3::new(cz * p.x + sz * p.y, -sz * p.x + cz * p.y, p.z);
    let p = DVec3::new(cy * p.x - sy * p.z, p.y, sy * p.x + cy * p.z);
    DVec3::new(p.x, cx * p.y + sx * p.z, -sx * p.y + cx * p.z)
}

#[test]
fn two_hundred_nested_rotations_compile_to_the_tape_of_ten() {
    let nest = |n: usize| {
        let mut s = String::from("x^2 + 2*y^2 + 3*z^2 - 1");
        for _ in 0..n {
            s = format!("rotate({s}, 1, 2, 3)");
        }
        Formula::parse(&s).unwrap()
    };
    let (ten, two_hundred) = (nest(10), nest(200));
    let body = |f: &Formula| f.tape(&[lgc::Output::F]).body().len();
    assert_eq!(
        body(&ten),
        body(&two_hundred),
        "the composed rotation is a constant"
    );
    // And it is the rotation: f(p) is the ellipsoid at R⁻²⁰⁰·p.
    let p = DVec3::new(0.3, -0.7, 0.5);
    let mut q = p;
    for _ in 0..200 {
        q = unrotate(q, [1.0, 2.0, 3.0]);
    }
    let want = q.x * q.x + 2.0 * q.y * q.y + 3.0 * q.z * q.z - 1.0;
    let got = lgc::Evaluator::<f64>::new(&two_hundred.tape(&[lgc::Output::F]))
        .eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0];
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
}

/// A chain that alternates transforms with blends and CSG, `n` links long,
/// as source text and as a plain Rust function of the point (the oracle).
fn alternating_chain(n: usize) -> (String, impl Fn(DVec3) -> f64) {
    let mut s = String::from("x^2 + y^2 + z^2 - 1");
    for k in 0..n {
        let c = 0.01 * (k % 7) as f64;
        let ball = format!("(x - {c})^2 + y^2 + z^2 - 0.1");
        s = match k % 3 {
            0 => format!("blend({s}, {ball}, 0.1)"),
            1 => format!("union({s}, {ball})"),
            _ => format!("subtract({s}, {ball})"),
        };
        s = match k % 4 {
            0 => format!("translate({s}, 0.001, -0.002, 0)"),
            1 => format!("rotate({s}, 1, 2, 3)"),
            2 => format!("scale({s}, 1.001)"),
            _ => format!("rotate(translate({s}, 0, 0, 0.003), 0, 0, 5)"),
        };
    }
    let eval = move |p: DVec3| {
        // Link k is a(k)·C_k(F_k, ball)(τ_k(q)): the point in every link's
        // coordinates from the outside in, then the values from the inside out.
        let mut r = vec![p; n + 1];
        for k in (0..n).rev() {
            let q = r[k + 1];
            r[k] = match k % 4 {
                0 => q - DVec3::new(0.001, -0.002, 0.0),
                1 => unrotate(q, [1.0, 2.0, 3.0]),
                2 => q / 1.001,
                _ => unrotate(q, [0.0, 0.0, 5.0]) - DVec3::new(0.0, 0.0, 0.003),
            };
        }
        let mut f = r[0].length_squared() - 1.0;
        for (k, q) in r.iter().take(n).enumerate() {
            let c = 0.01 * (k % 7) as f64;
            let ball = (q.x - c).powi(2) + q.y * q.y + q.z * q.z - 0.1;
            let combined = match k % 3 {
                0 => {
                    let h = (0.1 - (f - ball).abs()).max(0.0) / 0.1;
                    f.min(ball) - h * h * 0.1 / 4.0
                }
                1 => f.min(ball),
                _ => f.max(-ball),
            };
            f = if k % 4 == 2 {
                1.001 * combined
            } else {
                combined
            };
        }
        f
    };
    (s, eval)
}

#[test]
fn chains_alternating_transforms_and_blends_build_in_linear_time() {
    // Each link used to rebuild everything beneath it: 3200 links took 25 s
    // and 1.5 GB. Nodes built count the work, with no clock involved.
    let built = |n: usize| {
        let (src, _) = alternating_chain(n);
        let mut ctx = lgc::Context::new();
        let ast = lgc::lang::parse(&src).unwrap();
        lgc::lang::lower(&mut ctx, &ast).unwrap();
        ctx.len()
    };
    let (small, large) = (built(200), built(800));
    assert!(
        large <= 5 * small,
        "four times the links built {large} nodes against {small}"
    );
}

#[test]
fn a_long_alternating_chain_evaluates_to_its_definition() {
    let (src, oracle) = alternating_chain(120);
    let f = Formula::parse(&src).unwrap();
    let tape = f.tape(&[lgc::Output::F]);
    let mut eval = lgc::Evaluator::<f64>::new(&tape);
    for p in [
        DVec3::new(0.3, -0.7, 0.5),
        DVec3::new(-1.1, 0.2, 0.05),
        DVec3::new(0.9, 0.4, -0.3),
    ] {
        let got = eval.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0];
        let want = oracle(p);
        assert!(
            (got - want).abs() <= 1e-9 * (1.0 + want.abs()),
            "at {p}: {got} vs {want}"
        );
    }
}

#[test]
fn a_long_formula_stops_the_octree_within_its_work_budget() {
    // An 800-link chain spent 5 minutes building its octree at depth 5.
    let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    let (src, _) = alternating_chain(40);
    let f = Formula::parse(&src).unwrap();
    let budget = 20_000_000;
    let options = lgc::ray::octree::BuildOptions {
        max_work: budget,
        ..lgc::ray::octree::BuildOptions::to_depth(10)
    };
    let tree = Octree::build_with(&f, &b, &options);
    assert!(tree.stats.capped_at_depth.is_some());
    assert!(tree.stats.work <= budget, "{} > {budget}", tree.stats.work);
    assert!(tree.stats.leaves > 0);
    // Ordinary formulas do not meet the default budget at depth 8.
    let tangle = Formula::parse("x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 11.8").unwrap();
    let wide = Aabb::new(DVec3::splat(-3.0), DVec3::splat(3.0)).unwrap();
    let tree = Octree::build(&tangle, &wide, 8);
    assert_eq!(tree.stats.capped_at_depth, None);
    assert!(tree.stats.work <= lgc::ray::octree::MAX_WORK);
}
