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
