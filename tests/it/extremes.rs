//! The extremes of f64: numbers near its ends, large degrees, deep nesting,
//! formulas defined nowhere. Each test is named after what once went wrong.

use glam::DVec3;
use lgc::bounds::Bounder;
use lgc::ray::{Answer, Intersector};
use lgc::{Aabb, Formula};

fn unit_box() -> Aabb {
    Aabb::new(DVec3::ZERO, DVec3::ONE).unwrap()
}

#[test]
fn constant_products_that_underflow_do_not_drop_the_variable() {
    // 1e-300·1e-300 rounds to 0 in f64; folding it so made x − 0.5 constant,
    // with L = 0 and a "proved" verdict for any constant.
    let f = Formula::parse("x*1e-300*1e-300*1e300*1e300 - 0.5").unwrap();
    let grad = f.print(f.gradient()[0]);
    assert_ne!(grad, "0", "∂f/∂x folded to 0");
    let b = Bounder::new(&f);
    let [v, dx, _, _] = b.f_and_gradient(&unit_box());
    // The real f ranges over [-0.5, 0.5] and ∂f/∂x is (about) 1.
    assert!(v.inf() <= -0.5 && v.sup() >= 0.4, "f: {v:?}");
    assert!(dx.sup() >= 0.99, "∂f/∂x: {dx:?}");
    assert!(b.lipschitz_bound(&unit_box(), 0).value >= 0.99);
}

#[test]
fn exact_tiny_products_still_fold() {
    // Products into the subnormals that f64 holds exactly keep folding.
    let f = Formula::parse("x*(2^-600*2^-400) + y*(1e-300*1)").unwrap();
    let [dx, dy, _] = f.gradient().map(|n| f.context().const_value(n));
    assert_eq!(dx, Some(2f64.powi(-1000)));
    assert_eq!(dy, Some(1e-300));
}

/// The answer for one ray, traced as `lgc trace` does (default box ±2).
fn answer(src: &str, o: [f64; 3], d: [f64; 3], half: f64) -> Answer {
    let f = Formula::parse(src).unwrap();
    let b = Aabb::new(DVec3::splat(-half), DVec3::splat(half)).unwrap();
    Intersector::new(&f, &b, 7)
        .tracer()
        .answer(o.into(), d.into(), 0.0, f64::INFINITY)
}

fn hit_near(a: Answer, t: f64, rel: f64) {
    match a {
        Answer::Hit(h) => assert!((h - t).abs() <= rel * t, "hit {h}, expected {t}"),
        other => panic!("{other:?}, expected a hit at {t}"),
    }
}

#[test]
fn rays_with_tiny_directions_find_roots_at_huge_t() {
    // |d| = 1e-170 put the sphere at t = 5e169, past what the tracer's
    // tolerances were made for: it answered none.
    hit_near(
        answer("x^2+y^2+z^2-1", [0.0, 0.0, -1.5], [0.0, 0.0, 1e-170], 2.0),
        5e169,
        1e-9,
    );
    hit_near(
        answer("x^2+y^2+z^2-1", [0.0, 0.0, -1.5], [0.0, 0.0, 1e170], 2.0),
        5e-171,
        1e-9,
    );
}

#[test]
fn rays_through_a_surface_scaled_by_1e200_hit_where_f_changes_sign() {
    // The hit was 6.875e199, where f < 0; the root is at 1.5 - √0.75.
    let t = (1.5 - 0.75f64.sqrt()) * 1e200;
    let a = answer(
        "1e200*(x^2+y^2+z^2)-1e200",
        [0.5, 0.0, -1.5],
        [0.0, 0.0, 1e-200],
        2.0,
    );
    hit_near(a, t, 1e-9);
}

#[test]
fn rays_with_subnormal_direction_components_walk_into_the_right_octants() {
    // 1/1e-320 overflows: a ray starting in a mid-plane computed 0·∞ = NaN
    // for its crossing, took the wrong child and answered none.
    for d in [
        [1e-320, 1e-320, 1.0],
        [-1e-320, 0.0, 1.0],
        [1e-310, 1e-310, 1.0],
    ] {
        hit_near(
            answer("ln(x^2+y^2+z^2)", [0.0, 0.0, -3.0], d, 2.0),
            2.0,
            1e-9,
        );
    }
}

#[test]
fn a_surface_on_the_wall_of_the_box_is_hit_where_the_ray_enters() {
    // The cube's faces are the box's: the rounded entry time fell an ulp
    // past the root, and the ray answered its exit instead.
    let o = [-3.954615319081471, 0.47762324501249065, -1.0324676372729522];
    let d = [3726.1110286687654, -1265.051425676977, 263.9244892315902];
    let t = (-2.0 - o[0]) / d[0];
    hit_near(answer("max(abs(x),abs(y),abs(z)) - 2", o, d, 2.0), t, 1e-9);
}

#[test]
fn rays_from_near_the_end_of_f64_never_answer_infinity() {
    // The box's diagonal overflowed to ∞, and with it the pad: a hit at ∞.
    for src in ["x+y+z", "x^2+y^2+z^2-1", "sin(x)+y+z"] {
        let a = answer(src, [1e308; 3], [-1.0; 3], 1e300);
        let t = a.t().unwrap_or_else(|| panic!("{src}: {a:?}"));
        assert!(
            t.is_finite() && (t - 1e308).abs() <= 1e-9 * 1e308,
            "{src}: {a:?}"
        );
    }
}

#[test]
fn formulas_defined_nowhere_have_no_surface() {
    // They answered `touch` at the box's entry on every ray.
    for src in [
        "0/0",
        "1/0",
        "x/0",
        "abs(0/0)",
        "sign(0/0)",
        "atan2(0,0)+x",
        "x/(0*y)",
    ] {
        let f = Formula::parse(src).unwrap();
        assert!(
            Bounder::new(&f).f_and_gradient(&unit_box())[0].is_empty(),
            "{src}"
        );
        for o in [[0.0, 0.0, -3.0], [0.3, -0.2, -3.0]] {
            assert_eq!(answer(src, o, [0.0, 0.0, 1.0], 2.0), Answer::Miss, "{src}");
        }
    }
}

/// `shape` (in X, Y, Z) with coordinates scaled by `s`, in the box (-2, -2,
/// -1, 2, 2, 1)·s, traced along a ray scaled by s: the same t as unscaled.
fn scaled_answer(shape: &str, s: f64, c: f64) -> Answer {
    let k = format!("{:e}", 1.0 / s);
    let src = shape
        .replace('X', &format!("(x*{k})"))
        .replace('Y', &format!("(y*{k})"))
        .replace('Z', &format!("(z*{k})"));
    let f = Formula::parse(&format!("{c:e}*({src})")).unwrap();
    let b = Aabb::new(
        DVec3::new(-2.0, -2.0, -1.0) * s,
        DVec3::new(2.0, 2.0, 1.0) * s,
    )
    .unwrap();
    let o = DVec3::new(12.114757203861798, 13.185270867871594, -5.646224565229684);
    let d = DVec3::new(-1.0, -1.0, 0.5);
    Intersector::new(&f, &b, 5)
        .tracer()
        .answer(o * s, d * s, 0.0, f64::INFINITY)
}

#[test]
fn scaled_coordinates_multiplied_together_do_not_overflow() {
    // Constants moved outward turned (x*1e-200)*(x*1e-200) into
    // 1e-200*(1e-200*x^2), whose x^2 overflows at x = 1e200: f over the box
    // was [-1, inf], and the ray touched where f = -0.25.
    let f = Formula::parse("((x*1e-200)*(x*1e-200))^2 - 1").unwrap();
    let b = Aabb::new(DVec3::splat(-2e200), DVec3::splat(2e200)).unwrap();
    let range = lgc::Bounder::new(&f).f_and_gradient(&b)[0];
    assert!(range.sup() <= 16.0, "{range:?}");
    hit_near(
        scaled_answer("(X*X)^2-1", 1e200, 1.0),
        13.114757203861798,
        1e-9,
    );
}

#[test]
fn surfaces_scaled_by_1e90_to_1e150_are_hit_not_touched() {
    // A Hessian of 2e-180 (a sphere scaled by 1e90) was squared to the least
    // subnormal, whose root, 4e-162, made g's error bound exceed g: rays
    // answered `touch` four tolerances before the surface.
    for s in [1e90, 1e120, 1e150] {
        hit_near(
            scaled_answer("X^2+Y^2+Z^2-1", s, 1.0),
            12.411111424193628,
            1e-9,
        );
        hit_near(
            scaled_answer("(X^2+Y^2+Z^2+0.75)^2-4*(X^2+Y^2)", s, 1.0),
            11.788742107299768,
            1e-9,
        );
    }
}

#[test]
fn taylor_bounds_whose_discriminant_underflows_do_not_pass_the_root() {
    // F of 1e-200, g of 1e-250 and F'' of 1e-300: b² and a·c of the lower
    // parabola rounded to 0, its first root came out past the sphere's, and
    // the ray hit the far side (0.8695 instead of 0.8277).
    let src = "1e-200*((1e-50*x)^2+(1e-50*y)^2+(1e-50*z)^2-1)";
    let o = [-2.3369208626513113e50, -8.899216815631807e49, -3e50];
    let d = [
        3.0127784470443784e50,
        1.6371506398724112e50,
        2.571921425322139e50,
    ];
    hit_near(answer(src, o, d, 2e50), 0.8276803236660168, 1e-9);
    // Where the sphere is smaller than the tolerance, pieces at the tolerance
    // are split further: the same ray at 1e200 hits too.
    hit_near(
        scaled_answer("X^2+Y^2+Z^2-1", 1e200, 1.0),
        12.411111424193628,
        1e-9,
    );
}

#[test]
fn a_curvature_that_underflows_is_not_taken_for_zero() {
    // The tangle scaled by 1e130 and its values by 1e-110: its Hessian is
    // enclosed by the least subnormals, whose products with the direction's
    // weights rounded to 0, so g′ seemed exactly 0, F linear along the ray,
    // and the ray answered `none` (the oracle of scaled rays found it).
    let k = "1.0436434247853204e-130";
    let src = "7.765665850557344e-111*(X^4-5*X^2+Y^4-5*Y^2+Z^4-5*Z^2+11.8)"
        .replace('X', &format!("(x*{k})"))
        .replace('Y', &format!("(y*{k})"))
        .replace('Z', &format!("(z*{k})"));
    let f = Formula::parse(&src).unwrap();
    let half = 2.87454501101955e130;
    let b = Aabb::new(DVec3::splat(-half), DVec3::splat(half)).unwrap();
    let o = DVec3::new(
        -2.7342163511850426e130,
        2.60923879353644e130,
        2.0566335866482993e130,
    );
    let d = DVec3::new(
        5.761963950729964e-5,
        -6.304891609463168e-5,
        -2.0947686512683406e-6,
    );
    let a = Intersector::new(&f, &b, 5)
        .tracer()
        .answer(o, d, 0.0, f64::INFINITY);
    hit_near(a, 1.3919253060235445e134, 1e-9);
}

#[test]
fn polynomial_coefficients_that_underflow_along_long_rays_are_kept() {
    // The tangle at 1e42 with values of 1e-186: along the ray, whose range
    // in the box is 3e42 long once its direction is a unit vector, F's
    // coefficient of t⁴ (about 1e-352) rounded to 0, and the closed form hit
    // at 8.89e-52, where f = 3e-185. The coefficients are now taken in the
    // range's unit parameter, where they are about 1e-184.
    let k = "1.5474792978480266e-42";
    let src = "3.704291293893523e-186*(X^4-5*X^2+Y^4-5*Y^2+Z^4-5*Z^2+11.8)"
        .replace('X', &format!("(x*{k})"))
        .replace('Y', &format!("(y*{k})"))
        .replace('Z', &format!("(z*{k})"));
    let o = [
        2.2568531350451194e42,
        2.8531637231115075e42,
        2.3420937628857798e42,
    ];
    let d = [
        -7.83897681482913e92,
        -2.0371818228613658e93,
        -2.1028834535055383e93,
    ];
    hit_near(answer(&src, o, d, 1.9386e42), 1.4909340580099906e-51, 1e-9);
}

/// A cubic of the corpus (the Clebsch surface), its coordinates scaled by
/// `1/k` (so its box is ±2k) and its values by `c`, as `c·f(p/k)`.
fn scaled_cubic(c: f64, k: f64) -> String {
    format!(
        "{c:e}*({:e}*scale(81*(x^3+y^3+z^3)-189*(x^2*y+x^2*z+y^2*x+y^2*z+z^2*x+z^2*y)\
         +54*x*y*z+126*(x*y+x*z+y*z)-9*(x^2+y^2+z^2)-9*(x+y+z)+1, {k:e}))",
        1.0 / k
    )
}

#[test]
fn pieces_the_natural_enclosure_cannot_exclude_are_split_by_the_slope() {
    // Values of 1e-135 and a Hessian of 1e-319 at 1e92: the leaf's
    // curvature bound (a subnormal allowance) is of no use, and the natural
    // enclosure over pieces at the tolerance held 0 with a hundred times F's
    // value to spare. Splitting on it ran out of its 128 evaluations, and
    // the ray answered `touch` 72 tolerances before the root. The mean value
    // form excludes those pieces.
    let (c, k) = (5.503284107318959e-135, 2.6074060497081422e92);
    let o = [
        -1.023741202776183e91,
        3.216323730404525e92,
        -2.627254873440432e92,
    ];
    let d = [
        2.9500523314400136e91,
        -2.6839260809833357e91,
        6.144790956595538e91,
    ];
    let unscaled = answer(
        &scaled_cubic(1.0, 1.0),
        o.map(|v| v / k),
        d.map(|v| v / k),
        2.0,
    );
    let root = unscaled.t().unwrap();
    hit_near(answer(&scaled_cubic(c, k), o, d, 2.0 * k), root, 1e-9);
    // At 1e205 the gradient (1e-339) underflows too, and g's enclosure is of
    // no use either: the budget runs out, and the ray is undecided before
    // the root, not touched.
    let k = 2.0065826040452475e205;
    let s = k / 2.6074060497081422e92;
    let (o, d) = (o.map(|v| v * s), d.map(|v| v * s));
    match answer(&scaled_cubic(c, k), o, d, 2.0 * k) {
        Answer::Undecided(t) => assert!(t < root, "undecided at {t}"),
        other => hit_near(other, root, 1e-9),
    }
}

#[test]
fn a_quotient_by_a_zero_at_the_end_of_its_divisor_has_no_value() {
    // floor(z) over ±0.001 is [-1, 0], and is +0 for z ≥ 0, where f64 gives
    // 1/+0 = +∞: the enclosure [-∞, -1] of 1/floor(z) missed it, and atan
    // of it (π/2 at points) was enclosed by [-π/2, -π/4]. A quotient by 0
    // now has no value at points either.
    let f = Formula::parse("atan((floor(z))^-1) + atan(1/floor(z))").unwrap();
    let b = Aabb::new(DVec3::splat(-0.001), DVec3::splat(0.001)).unwrap();
    let over = Bounder::new(&f).f_and_gradient(&b)[0];
    let tape = f.tape(&[lgc::Output::F]);
    let mut points = lgc::Evaluator::<f64>::new(&tape);
    assert!(points.eval(&[0.0, 0.0, 0.0005, 0.0, 0.0, 0.0])[0].is_nan());
    assert!(points.eval(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0])[0].is_nan());
    let below = points.eval(&[0.0, 0.0, -0.0005, 0.0, 0.0, 0.0])[0];
    assert_eq!(below, -std::f64::consts::FRAC_PI_2);
    assert!(over.contains(below) && over.sup() < 0.0, "{over:?}");
}

#[test]
fn a_pole_feeding_a_branch_has_no_value() {
    // 0^-1 was +∞ at points, so choose took its positive side, y, while an
    // interval cannot say which zero it holds. It has no value now, nor has
    // the formula, and no ray meets a surface.
    let a = answer(
        "choose((0)^-1, x, y)",
        [0.0, -3.0, 0.0],
        [0.0, 1.0, 0.0],
        2.0,
    );
    assert_eq!(a, Answer::Miss);
    // A pole of 1/x on the plane x = 0 that the octree splits at.
    for o in [[-3.0, 0.0, 0.1], [-2.7, 0.1, 0.1]] {
        assert_eq!(answer("1/x", o, [1.0, 0.0, 0.0], 2.0), Answer::Miss);
    }
}

fn lgc(args: &[&str], stdin: &str) -> std::process::Output {
    crate::common::lgc_with_stdin(args, stdin)
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn negative_option_values_get_the_options_own_range_message() {
    // clap took `-1` for a flag and suggested `-- -1`, which would have
    // made it the formula.
    for args in [
        vec!["render", "x", "-o", "/tmp/lgc-never.png", "--fov", "-5"],
        vec![
            "render",
            "x",
            "-o",
            "/tmp/lgc-never.png",
            "--max-depth",
            "-1",
        ],
        vec![
            "bounds",
            "x",
            "--box=0,0,0,1,1,1",
            "--tolerance",
            "0.1",
            "--max-boxes",
            "-1",
        ],
    ] {
        let o = lgc(&args, "");
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(!err.contains("-- -"), "{args:?}: {err}");
        assert!(err.contains("not") && err.contains('-'), "{args:?}: {err}");
    }
}

#[test]
fn numbers_beyond_f64_in_options_and_rays_are_refused() {
    // `--box=0,0,0,1e-400,1,1` was a flat box, and a ray's 1e-400 was 0.
    for (args, stdin) in [
        (&["bounds", "x", "--box=0,0,0,1e-400,1,1"][..], ""),
        (&["trace", "x^2+y^2+z^2-1"][..], "0 0 -3 1e-400 0 1\n"),
    ] {
        let o = lgc(args, stdin);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            stderr(&o).contains("`1e-400` is beyond f64's range"),
            "{}",
            stderr(&o)
        );
    }
}

#[test]
fn a_ray_tree_deeper_than_the_stack_holds_is_refused() {
    // Two facing mirrors at --max-depth 2000 overflowed the stack.
    let o = lgc(
        &[
            "render",
            "x",
            "-o",
            "/tmp/lgc-never.png",
            "--max-depth",
            "2000",
        ],
        "",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("from 0 to 256"), "{}", stderr(&o));
}

#[test]
fn non_positive_scale_factors_and_blend_radii_get_a_caret() {
    for (src, at) in [
        ("scale(x^2+y^2+z^2-1, 0)", "^ not positive"),
        ("scale(x, -1)", "^^ not positive"),
        ("blend(x, y, -1)", "^^ not positive"),
    ] {
        let o = lgc(&["grad", src], "");
        assert_eq!(o.status.code(), Some(1), "{src}");
        assert!(stderr(&o).contains(at), "{src}: {}", stderr(&o));
    }
    assert!(lgc(&["grad", "blend(x, y, 0.1)"], "").status.success());
}

#[test]
fn large_bounds_print_in_exponent_form_with_their_reason() {
    let o = lgc(&["bounds", "1e200*x", "--box=0,0,0,1,1,1"], "");
    let out = String::from_utf8_lossy(&o.stdout);
    let longest = out.split(|c: char| !c.is_ascii_digit()).map(str::len).max();
    assert!(out.contains("1e200") && longest < Some(20), "{out}");
    // |∇f| = 1e200 is an f64: no longer infinite for its square's overflow.
    assert!(!out.contains("infinite"), "{out}");
    let o = lgc(&["bounds", "exp(x)^1000-1", "--box=0,0,0,1,1,1"], "");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("overflows f64"), "{out}");
    let o = lgc(&["bounds", "x/0", "--box=0,0,0,1,1,1"], "");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("defined nowhere"), "{out}");
    // `verify`'s undecided bound of 5e276 was printed as 277 digits.
    let o = lgc(
        &[
            "verify",
            "x*1e-300*1e-300*1e300*1e300 - 0.5",
            "--box=0,0,0,1,1,1",
            "--lipschitz=0.5",
            "--max-boxes=100",
        ],
        "",
    );
    let out = String::from_utf8_lossy(&o.stdout);
    let longest = out.split(|c: char| !c.is_ascii_digit()).map(str::len).max();
    assert!(out.contains("undecided") && longest < Some(20), "{out}");
}

#[test]
fn a_byte_order_mark_is_accepted_and_invisible_characters_are_named() {
    let o = lgc(&["grad", "\u{feff}x^2+y"], "");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lgc(&["grad", "x^2+\u{200b}y"], "");
    let err = stderr(&o);
    assert!(
        err.contains("U+200B") && err.contains("^ not part"),
        "{err}"
    );
}

#[test]
fn touches_in_a_large_box_say_how_wide_the_tolerance_is() {
    // In a box of ±1e12 the unit sphere is below the tolerance (346): a ray
    // through it answered `touch 265`. Its pieces at the tolerance are now
    // split further on certified tests: a hit within the tolerance of the
    // root at 2, a ray 1e-7 off a miss, and the tangent ray a touch, with a
    // note that says how wide the tolerance is.
    let o = lgc(
        &[
            "trace",
            "x^2+y^2+z^2-1",
            "--box=-1e12,-1e12,-1e12,1e12,1e12,1e12",
        ],
        "0 0 -3 0 0 1\n0 1.0000001 -3 0 0 1\n0 1 -3 0 0 1\n",
    );
    let out = String::from_utf8_lossy(&o.stdout);
    let lines: Vec<&str> = out.lines().collect();
    let t: f64 = lines[0].parse().unwrap();
    assert!((t - 2.0).abs() <= 346.5, "{out}");
    assert_eq!(lines[1], "none", "{out}");
    assert!(lines[2].starts_with("touch"), "{out}");
    assert!(stderr(&o).contains("tolerance 346.4"), "{}", stderr(&o));
    let o = lgc(&["trace", "x/0"], "0 0 -3 0 0 1\n");
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "none");
    assert!(stderr(&o).contains("defined nowhere"), "{}", stderr(&o));
}

#[test]
fn boxes_too_large_for_f64_lengths_are_refused() {
    let o = lgc(
        &["trace", "x", "--box=-1e308,-1,-1,1e308,1,1"],
        "0 0 -3 0 0 1\n",
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("too large"), "{}", stderr(&o));
}

#[test]
fn answers_agree_across_scales_of_space_and_value() {
    // c·f(s·p) in the box scaled by 1/s, along rays from o/s in the
    // direction r·d/s, has the same roots as f at t/r: each answer must be
    // the unscaled one, or undecided.
    let shapes = [
        "(S*x)^2+(S*y)^2+(S*z)^2-1",
        "(sqrt((S*x)^2+(S*y)^2)-1)^2+(S*z)^2-0.25",
        "max(abs(S*x),abs(S*y),abs(S*z))-1",
        "(S*x)^4-5*(S*x)^2+(S*y)^4-5*(S*y)^2+(S*z)^4-5*(S*z)^2+11.8",
    ];
    let mut rng = crate::common::Rng::new(49);
    let rays: Vec<([f64; 3], [f64; 3])> = (0..24)
        .map(|_| {
            let o = [rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0), -3.0];
            let target = rng.point([-1.0; 3], [1.0; 3]);
            (o, std::array::from_fn(|i| target[i] - o[i]))
        })
        .collect();
    let mut compared = 0;
    for shape in shapes {
        let plain = shape.replace('S', "1");
        let reference: Vec<Answer> = rays
            .iter()
            .map(|&(o, d)| answer(&plain, o, d, 2.0))
            .collect();
        for (s, c, r) in [
            (1e-150, 1e200, 1.0),
            (1e-50, 1e-200, 1e-120),
            (1e50, 1.0, 1e100),
            (1e150, 1e-100, 1.0),
            (1e-42, 1e-186, 1e51),
        ] {
            let src = format!("{c:e}*({})", shape.replace('S', &format!("{s:e}")));
            let f = Formula::parse(&src).unwrap();
            let b = Aabb::new(DVec3::splat(-2.0 / s), DVec3::splat(2.0 / s)).unwrap();
            let scene = Intersector::new(&f, &b, 7);
            let mut tracer = scene.tracer();
            for (&(o, d), &want) in rays.iter().zip(&reference) {
                let (o, d) = (DVec3::from(o) / s, DVec3::from(d) * r / s);
                let got = tracer.answer(o, d, 0.0, f64::INFINITY);
                let agree = match (want, got) {
                    (_, Answer::Undecided(_)) => true,
                    (Answer::Miss, Answer::Miss) => true,
                    (Answer::Miss, _) | (_, Answer::Miss) => false,
                    (w, g) => (w.t().unwrap() - g.t().unwrap() * r).abs() <= 1e-6,
                };
                assert!(agree, "{src}: o {o}, d {d}: {got:?}, unscaled {want:?}");
                compared += 1;
            }
        }
    }
    assert_eq!(compared, shapes.len() * 5 * 24);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: 12,
        // A fixed seed keeps CI's time steady: some draws give rays that
        // take seconds a ray (one seed of eight took 137 s).
        // PROPTEST_RNG_SEED explores others.
        rng_seed: match std::env::var_os("PROPTEST_RNG_SEED") {
            Some(_) => proptest::prelude::ProptestConfig::default().rng_seed,
            None => proptest::test_runner::RngSeed::Fixed(2026),
        },
        ..proptest::prelude::ProptestConfig::default()
    })]

    #[test]
    fn corpus_answers_agree_across_random_scales(
        which in 0usize..64,
        (ks, kc, kr) in (-990i32..990, -990i32..990, -300i32..300),
        seed in proptest::prelude::any::<u64>(),
    ) {
        // c·f(σ·p) in the box scaled by 1/σ, along rays from o/σ in the
        // direction r·d/σ, has f's roots at t/r: each answer must be the
        // unscaled one (a touch may stand for a miss), or undecided. The
        // factors are powers of two, so that the scaled rays are exactly
        // the unscaled ones (those that are not are skipped).
        let corpus = crate::common::corpus();
        let s = &corpus[which % corpus.len()];
        let (sigma, c, r) = (2f64.powi(ks), 2f64.powi(kc), 2f64.powi(kr));
        let f = Formula::parse(&s.expr).unwrap();
        let scaled = format!("{c:e}*({sigma:e}*scale({}, {:e}))", s.expr, 1.0 / sigma);
        let g = Formula::parse(&scaled).unwrap();
        let (lo, hi) = (DVec3::from(s.lo), DVec3::from(s.hi));
        let plain = Intersector::new(&f, &Aabb::new(lo, hi).unwrap(), 5);
        let Some(b) = Aabb::new(lo / sigma, hi / sigma) else {
            return Ok(());
        };
        let stretched = Intersector::new(&g, &b, 5);
        let (mut p, mut q) = (plain.tracer(), stretched.tracer());
        let mut rng = crate::common::Rng::new(seed);
        let tol = 1e-9 * (hi - lo).length();
        for (o, d) in crate::common::rays(&mut rng, &f).into_iter().step_by(15) {
            let (so, sd) = (o / sigma, d * r / sigma);
            if so * sigma != o || sd * sigma / r != d {
                continue;
            }
            let want = p.answer(o, d, 0.0, f64::INFINITY);
            let got = q.answer(so, sd, 0.0, f64::INFINITY);
            let mapped = match got {
                Answer::Undecided(_) => continue,
                Answer::Hit(t) => Answer::Hit(t * r),
                Answer::Touch(t) => Answer::Touch(t * r),
                Answer::Miss => Answer::Miss,
            };
            proptest::prop_assert!(
                crate::common::agree(want, mapped, tol / d.length()),
                "{scaled} in {b:?}: o {:?}, d {:?}: {got:?} (×{r:e}: {mapped:?}), unscaled {want:?}", so.to_array(), sd.to_array()
            );
        }
    }
}
