//! Scene files: every example renders, mistakes get caret errors, objects
//! occlude one another, and glass casts lighter shadows.

use glam::DVec3;
use lgc::render::Camera;
use lgc::render::RenderSettings;
use lgc::render::{render_scene, Prepared, RayTree};
use lgc::scene::parse_scene;
use lgc::ErrorKind;
use std::process::Command;

fn examples() -> Vec<std::path::PathBuf> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "lgc"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_example_renders_from_the_command_line() {
    let files = examples();
    assert!(files.len() >= 10, "{files:?}");
    let out_dir = std::env::temp_dir().join(format!("lgc-examples-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    for file in files {
        let out = out_dir.join(file.with_extension("png").file_name().unwrap());
        let o = Command::new(env!("CARGO_BIN_EXE_lgc"))
            .args([
                "render",
                file.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--size",
                "32x24",
                "--depth",
                "4",
            ])
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}: {}",
            file.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let img = image::open(&out).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (32, 24));
        // Something other than sky: some pixel is not bluish-grey.
        let varied = img
            .pixels()
            .any(|p| p[0] > p[2] + 10 || p[1] > p[2] + 10 || p[2] > p[0] + 60);
        assert!(varied, "{} rendered nothing but sky", file.display());
    }
    std::fs::remove_dir_all(&out_dir).ok();
}

fn expect_error(src: &str, kind: ErrorKind, line: usize, column: usize, message: &str) {
    let err = parse_scene(src)
        .err()
        .unwrap_or_else(|| panic!("parsed: {src}"));
    assert_eq!(err.kind, kind, "{}", err.message);
    assert_eq!(err.line_column(src), (line, column), "{}", err.message);
    assert!(
        err.message.contains(message),
        "`{}` lacks `{message}`",
        err.message
    );
    let rendered = err.render(src, "scene.lgc");
    assert!(
        rendered.contains(&format!("scene.lgc:{line}:{column}")) && rendered.contains('^'),
        "{rendered}"
    );
}

#[test]
fn scene_mistakes_get_located_errors() {
    // Regression: an overflowing box surfaced as a camera error.
    expect_error(
        "sphere { center = (0,0,0); radius = 1e308; }",
        ErrorKind::WrongType,
        1,
        1,
        "its box overflows",
    );
    expect_error(
        "lite { position = (1, 2, 3); }\nsphere { center = (0,0,0); radius = 1; }",
        ErrorKind::UnknownKeyword,
        1,
        1,
        "unknown block `lite`",
    );
    expect_error(
        "sphere { centre = (0,0,0); radius = 1; }",
        ErrorKind::UnknownKeyword,
        1,
        10,
        "has no field `centre`",
    );
    expect_error(
        "sphere { center = (0,0,0); }",
        ErrorKind::MissingField,
        1,
        1,
        "needs `radius`",
    );
    expect_error(
        "sphere { center = (0,0,0); radius = 1; radius = 2; }",
        ErrorKind::RepeatedField,
        1,
        40,
        "given twice",
    );
    expect_error(
        "sphere { center = (0,0,0); radius = (1, 2, 3); }",
        ErrorKind::WrongType,
        1,
        37,
        "a tuple is not a number",
    );
    expect_error(
        "sphere { center = 1; radius = 1; }",
        ErrorKind::WrongType,
        1,
        19,
        "expected a tuple of 3 numbers",
    );
    expect_error(
        "sphere { center = (0,0,0); radius = x; }",
        ErrorKind::WrongType,
        1,
        37,
        "found a formula",
    );
    expect_error(
        "object { surface = x^2 + y^2 + z^2 - 1; }",
        ErrorKind::MissingBox,
        1,
        1,
        "needs a box",
    );
    expect_error(
        "# nothing here\nlet a = 1;\n",
        ErrorKind::EmptyScene,
        2,
        11,
        "no objects",
    );
    expect_error(
        "sphere { center = (0,0,0); radius = 1; material = glas; }\nmaterial glass { }",
        ErrorKind::UnknownName,
        1,
        51,
        "unknown material `glas`",
    );
    expect_error(
        "object { surface = sn(x); box = (0,0,0,1,1,1); }",
        ErrorKind::UnknownFunction,
        1,
        20,
        "did you mean `sin`",
    );
    expect_error(
        "fn f(a) = a*x;\nobject { surface = f(1, 2); box = (0,0,0,1,1,1); }",
        ErrorKind::WrongArity,
        2,
        20,
        "takes 1 argument",
    );
    expect_error(
        "sphere { center = (0,0,0) radius = 1; }",
        ErrorKind::UnexpectedToken,
        1,
        27,
        "unexpected name `radius`",
    );
}

fn two_spheres(front_transparency: f64) -> lgc::scene::Scene {
    parse_scene(&format!(
        "material red {{ color = (0.9, 0.1, 0.1); transparency = {front_transparency}; }}
         material blue {{ color = (0.1, 0.1, 0.9); }}
         material floor {{ color = (0.8, 0.8, 0.8); specular = 0; }}
         light {{ direction = (0, 0, 1); }}
         sphere {{ center = (0, -2, 1.2); radius = 0.7; material = red; }}
         sphere {{ center = (0, 2, 1.2); radius = 1; material = blue; }}
         plane {{ normal = (0, 0, 1); offset = 0; extent = 8; material = floor; }}"
    ))
    .unwrap()
}

fn pixel(scene: &lgc::scene::Scene, eye: DVec3, look: DVec3) -> [u8; 3] {
    pixel_with(scene, eye, look, true)
}

fn pixel_with(scene: &lgc::scene::Scene, eye: DVec3, look: DVec3, shadows: bool) -> [u8; 3] {
    let prepared = Prepared::new(scene, 4);
    let up = if (look - eye).normalize().z.abs() > 0.99 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let camera = Camera::new(eye, look, up, 10.0, 9, 9).unwrap();
    let settings = RenderSettings {
        width: 9,
        height: 9,
        samples: 1,
        shadows,
        bundles: true,
    };
    let img = render_scene(&prepared, &camera, &settings, RayTree::to_depth(4), &|| {});
    let i = (4 * 9 + 4) * 3;
    [img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]]
}

#[test]
fn the_nearer_object_occludes_the_farther() {
    let scene = two_spheres(0.0);
    // Looking along +y through both centres' line: red is in front.
    let from_front = pixel(
        &scene,
        DVec3::new(0.0, -10.0, 1.2),
        DVec3::new(0.0, 0.0, 1.2),
    );
    assert!(
        from_front[0] > 2 * from_front[2],
        "red expected: {from_front:?}"
    );
    // From the other side, blue is in front.
    let from_back = pixel(
        &scene,
        DVec3::new(0.0, 10.0, 1.2),
        DVec3::new(0.0, 0.0, 1.2),
    );
    assert!(
        from_back[2] > 2 * from_back[0],
        "blue expected: {from_back:?}"
    );
}

#[test]
fn glass_casts_a_lighter_shadow() {
    // Looking straight down at the floor under the small sphere, lit from
    // straight above: opaque casts a dark shadow, glass a lighter one.
    let down = |scene: &lgc::scene::Scene| {
        pixel(
            scene,
            DVec3::new(0.0, -2.0, 0.3),
            DVec3::new(0.0, -2.0, 0.0),
        )
    };
    let eye_below = |t: f64| {
        // The camera sits under the sphere, above the floor, so the sphere
        // itself is behind it and only its shadow is seen.
        down(&two_spheres(t))
    };
    let opaque = eye_below(0.0);
    let glass = eye_below(0.8);
    let sum = |p: [u8; 3]| u32::from(p[0]) + u32::from(p[1]) + u32::from(p[2]);
    assert!(
        sum(glass) > sum(opaque) + 30,
        "glass {glass:?} vs opaque {opaque:?}"
    );
}

#[test]
fn command_line_options_override_the_file() {
    let dir = std::env::temp_dir().join(format!("lgc-override-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("s.lgc");
    std::fs::write(&scene, "camera { eye = (0, -5, 0); look_at = (0, 0, 0); fov = 30; }\nsphere { center = (0,0,0); radius = 1; }\n").unwrap();
    let a = dir.join("a.png");
    let b = dir.join("b.png");
    let run = |out: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--size",
            "20x10",
        ];
        args.extend_from_slice(extra);
        let o = Command::new(env!("CARGO_BIN_EXE_lgc"))
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        image::open(out).unwrap().to_rgb8()
    };
    let plain = run(&a, &[]);
    assert_eq!(plain.dimensions(), (20, 10), "--size overrides");
    let moved = run(&b, &["--eye", "0,-5,3"]);
    assert_ne!(
        plain.as_raw(),
        moved.as_raw(),
        "--eye overrides the file's eye"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn no_shadows_lights_the_floor_under_an_opaque_sphere() {
    // Regression: --no-shadows was ignored for scene files.
    let scene = two_spheres(0.0);
    let under = |shadows| {
        pixel_with(
            &scene,
            DVec3::new(0.0, -2.0, 0.3),
            DVec3::new(0.0, -2.0, 0.0),
            shadows,
        )
    };
    let open_floor = pixel_with(
        &scene,
        DVec3::new(3.0, -2.0, 0.3),
        DVec3::new(3.0, -2.0, 0.0),
        true,
    );
    assert_eq!(under(false), open_floor);
    assert_ne!(under(true), open_floor);
}

#[test]
fn adaptive_depth_moves_no_pixel_by_more_than_one_level() {
    // Figure 5 of the report: mirrors facing one another and a glass ball,
    // so ray trees grow deep. Rays that could add under 1/1024 to a pixel
    // are not followed; against following every one, no channel moves by
    // more than one level, and far fewer rays are traced.
    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/figure5.lgc"))
        .unwrap();
    let scene = parse_scene(&src).unwrap();
    let prepared = Prepared::new(&scene, 5);
    let spec = &scene.camera;
    let camera = Camera::new(
        spec.eye.unwrap(),
        spec.look_at.unwrap(),
        DVec3::Z,
        spec.fov.unwrap(),
        160,
        120,
    )
    .unwrap();
    let settings = RenderSettings {
        width: 160,
        height: 120,
        samples: 1,
        shadows: true,
        bundles: true,
    };
    let render = |min_weight| {
        let tree = RayTree {
            max_depth: 5,
            min_weight,
        };
        render_scene(&prepared, &camera, &settings, tree, &|| {})
    };
    let every = render(0.0);
    let adaptive = render(lgc::render::MIN_WEIGHT);
    let worst = every
        .rgb
        .iter()
        .zip(&adaptive.rgb)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(worst <= 1, "a channel moved by {worst}");
    assert!(
        every.rgb != adaptive.rgb,
        "the bailout changed nothing: is it on?"
    );
    assert!(
        (adaptive.primary.rays as f64) < 0.95 * every.primary.rays as f64,
        "{} rays against {}",
        adaptive.primary.rays,
        every.primary.rays
    );
}

#[test]
fn example_scenes_look_the_same_whether_camera_rays_search_leaf_lists_or_walk() {
    // Each tile's camera rays search, per object, the leaves their bundle may
    // cross, from where its sweep proves the space in front empty; without
    // bundles they walk each object's octree from the eye. The answers are
    // the walk's (from the sweep's end: the same roots, placed to the
    // tolerance), so a channel may round to the next level, and no further.
    let (mut leaves, mut listed, mut moved, mut scenes) = ([0, 0], 0, 0, 0u32);
    for path in examples() {
        let src = std::fs::read_to_string(&path).unwrap();
        if !lgc::scene::is_scene(&src) {
            continue;
        }
        let scene = parse_scene(&src).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        scenes += 1;
        let prepared = Prepared::new(&scene, 4);
        let spec = &scene.camera;
        let (Some(eye), Some(look_at)) = (spec.eye, spec.look_at) else {
            continue;
        };
        let fov = spec.fov.unwrap_or(30.0);
        let up = spec.up.unwrap_or(DVec3::Z);
        let camera = Camera::new(eye, look_at, up, fov, 96, 72).unwrap();
        let image = |bundles: bool| {
            let settings = RenderSettings {
                width: 96,
                height: 72,
                samples: 1,
                shadows: true,
                bundles,
            };
            render_scene(&prepared, &camera, &settings, RayTree::to_depth(3), &|| {})
        };
        let (with, without) = (image(true), image(false));
        let worst = with
            .rgb
            .iter()
            .zip(&without.rgb)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        assert!(worst <= 1, "{}: a channel moved by {worst}", path.display());
        moved += with
            .rgb
            .iter()
            .zip(&without.rgb)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            with.primary.rays,
            without.primary.rays,
            "{}",
            path.display()
        );
        assert_eq!(without.primary.listed, 0, "{}", path.display());
        listed += with.primary.listed;
        leaves[0] += with.primary.leaves;
        leaves[1] += without.primary.leaves;
    }
    // Not vacuous: many camera rays searched lists (not those of objects
    // whose octree is one leaf, of objects answered in closed form, nor of
    // tiles whose bundle crosses too many leaves), and the sweeps spared
    // them leaves.
    assert!(scenes >= 8, "{scenes} scenes");
    assert!(listed > 5_000, "{listed} rays searched lists");
    assert!(leaves[0] < leaves[1], "{leaves:?} leaves searched");
    assert!(moved * 1000 < 10 * 96 * 72 * 3, "{moved} channels moved");
}
