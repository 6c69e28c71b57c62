//! Rendering: pixel statistics of small images, file output, and bad options
//! (one line on stderr, non-zero exit, no file left behind).

use glam::DVec3;
use lgc::ray::Intersector;
use lgc::render::Camera;
use lgc::render::Shading;
use lgc::render::{render, RenderSettings};
use lgc::Aabb;
use lgc::Formula;
use std::process::Command;

fn sphere_image(samples: u32, depth: u32) -> lgc::render::Rendering {
    let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    let scene = Intersector::new(&Formula::parse("x^2+y^2+z^2-1").unwrap(), &b, depth);
    let camera = Camera::new(
        DVec3::new(0.0, -5.0, 0.0),
        DVec3::ZERO,
        DVec3::Z,
        30.0,
        64,
        64,
    )
    .unwrap();
    let shading = Shading::studio(camera.basis(), DVec3::new(0.9, 0.5, 0.2));
    let settings = RenderSettings {
        width: 64,
        height: 64,
        samples,
        shadows: true,
        bundles: true,
    };
    render(&scene, &camera, &shading, &settings, &|| {})
}

/// Orange surface pixels have more red than blue; the sky is bluish.
fn is_surface(rgb: &[u8], i: usize) -> bool {
    rgb[3 * i] > rgb[3 * i + 2]
}

#[test]
fn a_sphere_covers_the_pixels_geometry_predicts() {
    let img = sphere_image(1, 5);
    let n = 64 * 64;
    let covered = (0..n).filter(|&i| is_surface(&img.rgb, i)).count();
    // Seen from distance 5 the unit sphere subtends asin(1/5); with a 30°
    // field of view its disc has radius tan(asin 0.2)/tan 15° of the half image.
    let radius_px = (0.2f64.asin().tan() / 15f64.to_radians().tan()) * 32.0;
    let expected = std::f64::consts::PI * radius_px * radius_px;
    let ratio = covered as f64 / expected;
    assert!(
        (0.97..1.03).contains(&ratio),
        "{covered} surface pixels, expected about {expected:.0}"
    );
    // Centred: the middle is surface, the corners are sky, and the disc is
    // balanced left to right.
    assert!(is_surface(&img.rgb, 32 * 64 + 32));
    for corner in [0, 63, 63 * 64, 64 * 64 - 1] {
        assert!(!is_surface(&img.rgb, corner));
    }
    let left = (0..n)
        .filter(|&i| i % 64 < 32 && is_surface(&img.rgb, i))
        .count();
    assert!((left as f64 / covered as f64 - 0.5).abs() < 0.02);
    // The key light comes from the upper left: that quarter is brighter than
    // the lower right.
    let brightness = |x0: usize, y0: usize| -> u32 {
        (y0..y0 + 8)
            .flat_map(|y| (x0..x0 + 8).map(move |x| y * 64 + x))
            .map(|i| u32::from(img.rgb[3 * i]))
            .sum()
    };
    assert!(brightness(20, 20) > brightness(36, 36));
    assert_eq!(img.primary.rays, 64 * 64);
}

#[test]
fn images_do_not_depend_on_octree_depth_or_threads() {
    let a = sphere_image(2, 3);
    let b = sphere_image(2, 6);
    assert_eq!(a.rgb, b.rgb);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let c = pool.install(|| sphere_image(2, 5));
    assert_eq!(a.rgb, c.rgb);
}

fn lgc(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args(args)
        .output()
        .unwrap()
}

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("lgc-render-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn render_writes_png_and_p6_ppm_and_a_summary() {
    let dir = scratch("ok");
    let png = dir.join("torus.png");
    let o = lgc(&[
        "render",
        "(x^2+y^2+z^2+0.75)^2-4*(x^2+y^2)",
        "-o",
        png.to_str().unwrap(),
        "--size",
        "48x32",
        "--samples",
        "2",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (48, 32));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("48x32")
            && err.contains("f evaluations per ray")
            && err.contains("octree leaves kept"),
        "{err}"
    );
    let ppm = dir.join("sphere.ppm");
    let o = lgc(&[
        "render",
        "x^2+y^2+z^2-1",
        "-o",
        ppm.to_str().unwrap(),
        "--size",
        "8x6",
    ]);
    assert_eq!(o.status.code(), Some(0));
    let bytes = std::fs::read(&ppm).unwrap();
    let header: Vec<&str> = std::str::from_utf8(&bytes[..11])
        .unwrap()
        .split_whitespace()
        .collect();
    assert_eq!(header, ["P6", "8", "6", "255"]);
    assert_eq!(bytes.len(), 11 + 8 * 6 * 3);
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_surface_clipped_by_the_box_gets_a_warning() {
    let dir = scratch("clip");
    let out = dir.join("a.png");
    let o = lgc(&[
        "render",
        "x^2+y^2+z^2-1.44",
        "--box",
        "-1,-1,-1,1,1,1",
        "-o",
        out.to_str().unwrap(),
        "--size",
        "8x8",
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stderr)
        .contains("warning: the surface reaches the faces of the box"));
    let o = lgc(&[
        "render",
        "x^2+y^2+z^2-1",
        "--box",
        "-2,-2,-2,2,2,2",
        "-o",
        out.to_str().unwrap(),
        "--size",
        "8x8",
    ]);
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("warning"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_render_options_give_one_line_and_no_file() {
    let dir = scratch("bad");
    let out = dir.join("never.png");
    let o_str = out.to_str().unwrap().to_string();
    for (args, needle) in [
        (vec!["--size", "0x100"], "between 1 and 16384"),
        (vec!["--size", "20000x10"], "between 1 and 16384"),
        (vec!["--size", "axb"], "not a whole number"),
        (vec!["--box", "1,1,1,-1,-1,-1"], "inverted"),
        (vec!["--box", "1,2,3"], "expected 6"),
        (vec!["--box", "0,0,0,1,1,zz"], "not a finite number"),
        (vec!["--color", "2,0,0"], "between 0 and 1"),
        (vec!["--samples", "0"], "1 to 1024"),
        (vec!["--eye", "0,0,0", "--look-at", "0,0,0"], "coincide"),
    ] {
        let mut full = vec!["render", "x^2+y^2+z^2-1", "-o", o_str.as_str()];
        full.extend(args.iter().copied());
        let o = lgc(&full);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} left a file");
    }
    for path in ["/nonexistent-dir/x.png", "/tmp/lgc-unsupported.jpg"] {
        let o = lgc(&["render", "x^2+y^2+z^2-1", "-o", path, "--size", "8x8"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(!std::path::Path::new(path).exists());
    }
    assert!(
        std::fs::read_dir(&dir).unwrap().next().is_none(),
        "nothing may be left behind"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn trace_answers_each_ray_on_its_own_line() {
    let o = crate::common::lgc_with_stdin(
        &["trace", "x^2+y^2+z^2-1", "--box", "-2,-2,-2,2,2,2"],
        "-3 0 0 1 0 0\n# a comment\n-3 2 0 1 0 0\n0 0 0 0 0 2\n1.5 0 0 1 0 0\n",
    );
    let out = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 4, "{out}");
    assert_eq!(lines[0].parse::<f64>().unwrap(), 2.0);
    assert_eq!(lines[1], "none");
    assert_eq!(lines[2].parse::<f64>().unwrap(), 0.5, "d is not normalised");
    assert_eq!(lines[3], "none", "the sphere is behind the origin");
    assert!(
        lines[0].len() >= 17,
        "at least 12 significant digits: {}",
        lines[0]
    );

    let o = Command::new("sh")
        .args([
            "-c",
            &format!("printf '1 2 3\\n' | {} trace x", env!("CARGO_BIN_EXE_lgc")),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("line 1: expected six finite numbers"));
}

#[test]
fn trace_bundle_answers_as_single_rays_and_needs_one_origin() {
    let trace = |extra: &[&str], input: &str| {
        let torus = "(x^2+y^2+z^2+0.75)^2-4*(x^2+y^2)";
        let mut args = vec!["trace", torus, "--box", "-2,-2,-1,2,2,1"];
        args.extend_from_slice(extra);
        crate::common::lgc_with_stdin(&args, input)
    };
    // A tile-like cone of rays from one eye at the torus.
    let rays: String = (0..25)
        .map(|k| {
            let (u, v) = (f64::from(k % 5) * 0.01, f64::from(k / 5) * 0.01);
            format!("-4 -3 2 4 {} {}\n", 3.0 + u, -2.0 + v)
        })
        .collect();
    let single = trace(&[], &rays);
    let bundled = trace(&["--bundle"], &rays);
    assert_eq!(bundled.status.code(), Some(0));
    let (a, b) = (
        String::from_utf8(single.stdout).unwrap(),
        String::from_utf8(bundled.stdout).unwrap(),
    );
    assert_eq!(a.lines().count(), 25);
    let hits = a.lines().filter(|l| *l != "none").count();
    assert!(hits > 5, "the cone meets the torus: {a}");
    for (x, y) in a.lines().zip(b.lines()) {
        match (x.parse::<f64>(), y.parse::<f64>()) {
            (Ok(s), Ok(t)) => assert!((s - t).abs() <= 1e-9 * s.abs(), "{x} vs {y}"),
            _ => assert_eq!(x, y),
        }
    }
    let o = trace(&["--bundle"], "-4 -3 2 4 3 -2\n-4 -3 2.5 4 3 -2\n");
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("ray 2"), "{err}");
}

#[test]
fn trace_from_surface_answers_as_single_rays() {
    let trace = |extra: &[&str], input: &str| {
        let mut args = vec!["trace", "x^2+y^2+z^2-1", "--box", "-2,-2,-2,2,2,2"];
        args.extend_from_slice(extra);
        crate::common::lgc_with_stdin(&args, input)
    };
    // Just off the unit sphere at (1, 0, 0): outward (no root), back through
    // it (the far side at t ≈ 2), and nearly along it (a miss just outside).
    let rays = "1.0000001 0 0 0.6 0.8 0\n0.9999999 0 0 -1 0 0\n1.0000001 0 0 0 1 0.001\n";
    let single = String::from_utf8(trace(&[], rays).stdout).unwrap();
    let leaving = String::from_utf8(trace(&["--from-surface"], rays).stdout).unwrap();
    // The same answers: hits placed within the tolerance (1e-10 of the
    // box's diagonal) of one root, each by its own path to it.
    assert_eq!(single.lines().count(), leaving.lines().count());
    for (x, y) in single.lines().zip(leaving.lines()) {
        match (x.parse::<f64>(), y.parse::<f64>()) {
            (Ok(s), Ok(t)) => assert!((s - t).abs() <= 2e-10 * 48f64.sqrt(), "{x} vs {y}"),
            _ => assert_eq!(x, y),
        }
    }
    let lines: Vec<&str> = leaving.lines().collect();
    assert_eq!(lines[0], "none");
    assert!(
        (lines[1].parse::<f64>().unwrap() - 1.9999999).abs() < 1e-9,
        "{leaving}"
    );
    assert_eq!(lines[2], "none");
    let o = trace(&["--from-surface", "--bundle"], rays);
    assert_eq!(
        o.status.code(),
        Some(2),
        "conflicting options are a usage error"
    );
}

/// A smooth formula of hundreds of operations (the bear with its `max` and
/// `min` made sums): its leaves' G is far looser than g, and rays near a
/// graze there were decided by the f64 tests alone, a piece halved down to
/// where G stopped mattering (65,000 evaluations a ray, some rays spending
/// their whole budget and left undecided). Such pieces are enclosed instead.
#[test]
fn rays_in_a_smooth_leaf_with_a_loose_g_are_enclosed_not_crawled() {
    let bear = include_str!("../../examples/models/bear.vm")
        .replace(" max ", " add ")
        .replace(" min ", " add ");
    let f = Formula::parse_vm(&bear).unwrap();
    let b = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
    let scene = Intersector::new(&f, &b, 5);
    let eye = DVec3::new(4.1097354035283304, -6.164603105292495, 3.49327509299908);
    let d = DVec3::new(-0.532514795631548, 0.6907463853356156, -0.48918035894675094);
    let camera = Camera::new(eye, eye + 8.5 * d, DVec3::Z, 1.0, 16, 16).unwrap();
    let shading = Shading::studio(camera.basis(), DVec3::new(0.9, 0.5, 0.2));
    let settings = RenderSettings {
        width: 16,
        height: 16,
        samples: 1,
        shadows: false,
        bundles: true,
    };
    let img = render(&scene, &camera, &shading, &settings, &|| {});
    let stats = img.primary;
    assert_eq!(stats.rays, 16 * 16);
    assert_eq!(stats.undecided, 0);
    assert!(stats.hits > 0, "{stats:?}");
    assert!(
        stats.f_evals < 1_000 * stats.rays,
        "{} evaluations a ray",
        stats.f_evals / stats.rays
    );
}
