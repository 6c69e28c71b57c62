//! `lgc mesh` and `lgc::mesh`: closed 2-manifold meshes of the right
//! topology, every vertex within its proved distance of f = 0 (checked by an
//! enclosure of f over a box around it, not by the mesher's bisection), and
//! the hard cases: thin gaps, tangencies, cone tips, jumps and the box's wall.

use glam::DVec3;
use lgc::mesh::{mesh, MeshError, MeshOptions, Meshed, Witness};
use lgc::{Aabb, Evaluator, Formula, Interval, Output};
use std::process::Command;

fn cube(h: f64) -> Aabb {
    Aabb::new(DVec3::splat(-h), DVec3::splat(h)).unwrap()
}

/// `formula` meshed in `b` at `depth`, tolerance 1e-6.
pub fn meshed(formula: &str, b: &Aabb, depth: u32) -> Meshed {
    let f = Formula::parse(formula).unwrap();
    let options = MeshOptions {
        depth,
        tolerance: Some(1e-6),
        max_cells: 1 << 22,
    };
    mesh(&f, b, &options).unwrap()
}

/// Every vertex whose witness is a root or a zero enclosure: f's enclosure
/// over the cube of its radius around it holds 0, and the radius is within
/// the tolerance asked for.
fn assert_vertices_near_surface(formula: &str, m: &Meshed, tolerance: f64) {
    let f = Formula::parse(formula).unwrap();
    let tape = f.tape(&[Output::F]);
    let mut eval = Evaluator::<Interval>::new(&tape);
    let zero = Interval::point(0.0);
    for (k, (&p, &r)) in m.mesh.positions.iter().zip(&m.mesh.radii).enumerate() {
        if !matches!(m.mesh.witnesses[k], Witness::Root | Witness::Tolerance) {
            continue;
        }
        assert!(
            r <= tolerance,
            "vertex {k} at {p}: radius {r} > {tolerance}"
        );
        let around = |c: f64| Interval::new(c - r, c + r);
        let v = eval.eval(&[around(p.x), around(p.y), around(p.z), zero, zero, zero])[0];
        assert!(v.contains(0.0), "vertex {k} at {p}: f over ±{r} is {v:?}");
    }
}

fn assert_closed_manifold(m: &Meshed) {
    assert!(m.topology.closed && m.topology.manifold, "{:?}", m.topology);
    assert!(!m.mesh.triangles.is_empty());
}

#[test]
fn sphere_and_torus_have_their_euler_characteristics() {
    for (formula, euler) in [("x^2+y^2+z^2-1", 2), ("(sqrt(x^2+y^2)-1)^2+z^2-0.25^2", 0)] {
        let m = meshed(formula, &cube(2.0), 5);
        assert_closed_manifold(&m);
        assert_eq!(m.topology.euler, euler, "{formula}");
        assert_eq!(m.topology.components, 1, "{formula}");
        assert_vertices_near_surface(formula, &m, 1e-6);
        assert!(m
            .mesh
            .witnesses
            .iter()
            .all(|&w| w != Witness::Uncertain && w != Witness::Wall));
    }
}

#[test]
fn a_torus_with_a_short_gradient_tape_is_certified_with_more_pieces() {
    // Each piece of a cell costs a run of ∇f's tape, so a short one may
    // enclose more: 1,316 of the torus's 1,840 cells were certified when
    // every tape had the budget a model's does, and nearly all are now.
    let f = Formula::parse("(sqrt(x^2+y^2)-0.6)^2+z^2-0.04").unwrap();
    let options = MeshOptions {
        depth: 5,
        tolerance: Some(1e-4),
        max_cells: 1 << 22,
    };
    let m = mesh(&f, &cube(1.0), &options).unwrap();
    let c = &m.certificate;
    let all = c.certified + c.uncertified.len();
    assert_eq!(all, 1840);
    // Cells not within the tolerance are isotopic all the same.
    let isotopic = c.certified + c.count(lgc::mesh::Doubt::Far);
    assert!(isotopic >= 1600, "{isotopic} of {all} isotopic");
}

#[test]
fn triangles_face_the_way_f_increases() {
    // The gradient of the sphere at a triangle's centre points outward; the
    // wound normal must agree with it on every triangle.
    let m = meshed("x^2+y^2+z^2-1", &cube(2.0), 4);
    for t in &m.mesh.triangles {
        let [a, b, c] = t.map(|v| m.mesh.positions[v as usize]);
        let normal = (b - a).cross(c - a);
        let centre = (a + b + c) / 3.0;
        assert!(normal.dot(centre) > 0.0, "triangle {t:?} faces inward");
    }
}

#[test]
fn a_solid_cut_by_the_box_is_closed_at_its_wall() {
    // The half-space z < 0.3 fills most of the box: the mesh is the box's
    // lower part, closed, a sphere topologically, with its wall vertices
    // said to be at the wall.
    let m = meshed("z-0.3", &cube(1.0), 4);
    assert_closed_manifold(&m);
    assert_eq!(m.topology.euler, 2);
    let walls = m.mesh.count(Witness::Wall);
    let roots = m.mesh.count(Witness::Root);
    assert!(
        walls > 0 && roots > 0,
        "{walls} wall vertices, {roots} roots"
    );
    // Wall vertices lie within a cell of the wall.
    let cell = 2.0 / 16.0;
    for (p, w) in m.mesh.positions.iter().zip(&m.mesh.witnesses) {
        if *w == Witness::Wall {
            let to_wall = (1.0 - p.abs().max_element()).abs();
            assert!(
                to_wall <= cell,
                "wall vertex {p} is {to_wall} from the wall"
            );
        }
    }
}

#[test]
fn two_spheres_a_millionth_apart_still_give_a_valid_mesh() {
    let formula = "min((x-0.5000005)^2+y^2+z^2-0.25, (x+0.5000005)^2+y^2+z^2-0.25)";
    let m = meshed(formula, &cube(1.5), 5);
    assert_closed_manifold(&m);
    assert_vertices_near_surface(formula, &m, 1e-6);
}

#[test]
fn a_torus_thinner_than_a_cell_still_gives_a_valid_mesh() {
    // The tube's radius is a fifth of a cell at depth 3: its topology may be
    // lost, but the mesh stays closed and each vertex is proved near f = 0.
    let formula = "(sqrt(x^2+y^2)-1)^2+z^2-0.1^2";
    for depth in 2..=5 {
        let m = meshed(formula, &cube(2.0), depth);
        if m.mesh.triangles.is_empty() {
            continue;
        }
        assert_closed_manifold(&m);
        assert_vertices_near_surface(formula, &m, 1e-6);
    }
}

#[test]
fn a_surface_on_lattice_points_and_a_cone_tip_give_valid_meshes() {
    // z = 0 passes through a whole plane of lattice points, whose enclosures
    // hold 0; the double cone has its tip at a lattice point.
    for formula in ["z", "x^2+y^2-z^2", "x^2+y^2-(z-0.5)^2"] {
        let m = meshed(formula, &cube(1.0), 4);
        assert_closed_manifold(&m);
        assert_vertices_near_surface(formula, &m, 1e-6);
    }
}

#[test]
fn jumps_make_vertices_uncertain_not_wrong() {
    // sign(x) - 0.5 changes sign across x = 0 without a root: its vertices
    // there are not claimed to be near a surface.
    let m = meshed("sign(x)-0.5+0*y", &cube(1.0), 3);
    assert_closed_manifold(&m);
    assert!(m.discontinuous_cells > 0);
    let uncertain = m.mesh.count(Witness::Uncertain);
    assert!(uncertain > 0);
    assert!(m.mesh.witnesses.iter().all(|&w| w != Witness::Root));
}

#[test]
fn max_cells_stops_the_lattice_early_and_still_meshes() {
    let f = Formula::parse("x^2+y^2+z^2-1").unwrap();
    let options = MeshOptions {
        depth: 8,
        tolerance: Some(1e-3),
        max_cells: 5_000,
    };
    let m = mesh(&f, &cube(2.0), &options).unwrap();
    assert!(m.level < 8 && m.cells <= 5_000);
    assert_closed_manifold(&m);
    assert_eq!(m.topology.euler, 2);
}

#[test]
fn bad_options_are_errors() {
    let f = Formula::parse("x").unwrap();
    let mut options = MeshOptions {
        depth: 30,
        tolerance: Some(1e-3),
        max_cells: 10,
    };
    assert_eq!(
        mesh(&f, &cube(1.0), &options).unwrap_err(),
        MeshError::Depth(30)
    );
    options.depth = 3;
    options.tolerance = Some(-1.0);
    assert!(matches!(
        mesh(&f, &cube(1.0), &options),
        Err(MeshError::Tolerance(_))
    ));
    options.tolerance = Some(1e-3);
    let thin = Aabb::new(DVec3::ZERO, DVec3::new(1.0, 1.0, 2e-323)).unwrap();
    assert_eq!(mesh(&f, &thin, &options).unwrap_err(), MeshError::Thin(3));
}

fn lgc(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn every_format_is_written_and_reads_back() {
    let dir = std::env::temp_dir().join(format!("lgc-mesh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sphere = "x^2+y^2+z^2-1";
    let reference = meshed(sphere, &cube(2.0), 3);
    let triangles = reference.mesh.triangles.len();
    for ext in ["stl", "obj", "ply", "glb", "3mf"] {
        let path = dir.join(format!("sphere.{ext}"));
        let out = lgc(&["mesh", sphere, "--depth", "3", "-o", path.to_str().unwrap()]);
        assert!(
            out.status.success(),
            "{ext}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let summary = String::from_utf8_lossy(&out.stdout);
        assert!(
            summary.contains(&format!("{triangles} triangles")),
            "{summary}"
        );
        assert!(summary.contains("Euler characteristic 2"), "{summary}");
        let bytes = std::fs::read(&path).unwrap();
        match ext {
            "stl" => {
                let read = stl_io::read_stl(&mut std::io::Cursor::new(&bytes)).unwrap();
                assert_eq!(read.faces.len(), triangles);
            }
            "obj" => {
                let text = String::from_utf8(bytes).unwrap();
                assert_eq!(
                    text.lines().filter(|l| l.starts_with("f ")).count(),
                    triangles
                );
            }
            "ply" => {
                let text = String::from_utf8_lossy(&bytes);
                assert!(text.starts_with("ply\nformat binary_little_endian 1.0"));
                assert!(text.contains(&format!("element face {triangles}\n")));
            }
            "glb" => {
                assert_eq!(&bytes[..4], b"glTF");
                let glb = gltf::binary::Glb::from_slice(&bytes).unwrap();
                let json = String::from_utf8_lossy(&glb.json);
                assert!(
                    json.contains(&format!("\"count\":{}", 3 * triangles)),
                    "{json}"
                );
            }
            "3mf" => {
                let models = threemf::read(std::io::Cursor::new(bytes)).unwrap();
                let mesh = models[0].resources.object[0].mesh.as_ref().unwrap();
                assert_eq!(mesh.triangles.triangle.len(), triangles);
            }
            _ => unreachable!(),
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_bad_extension_or_tolerance_is_one_line_and_writes_nothing() {
    let dir = std::env::temp_dir().join(format!("lgc-mesh-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let target = dir.join("sphere.xyz");
    let out = lgc(&["mesh", "x^2+y^2+z^2-1", "-o", target.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("unsupported mesh format"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    let stl = dir.join("sphere.stl");
    let out = lgc(&[
        "mesh",
        "x^2+y^2+z^2-1",
        "--tolerance",
        "-1",
        "-o",
        stl.to_str().unwrap(),
    ]);
    assert_ne!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--tolerance"));
    // A cell budget past what memory allows is refused, not tried.
    let out = lgc(&[
        "mesh",
        "x",
        "--max-cells",
        "99999999",
        "-o",
        stl.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--max-cells 99999999: use at most"));
    // A scene's objects have their own boxes, so `--box` is refused in one
    // line.
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/barth_sextic.lgc");
    let out = lgc(&[
        "mesh",
        scene,
        "--box",
        "0,0,0,1,1,1",
        "-o",
        stl.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("barth_sextic.lgc is a scene, and each of its objects"),
        "{err}"
    );
    // Nothing written, not even the temporary file.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Two spheres of different sizes and colours, away from the origin.
const TWO_SPHERES: &str = "material red { color = (1, 0, 0); }
material blue { color = (0, 0, 1); }
sphere { center = (3, 0, 0); radius = 0.5; material = red; }
  sphere { center = (-3, 1, 0); radius = 2; material = blue; }
";

#[test]
fn a_scene_is_meshed_object_by_object_where_the_scene_puts_them() {
    let dir = std::env::temp_dir().join(format!("lgc-mesh-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene_path = dir.join("two.lgc");
    std::fs::write(&scene_path, TWO_SPHERES).unwrap();
    let scene = lgc::scene::parse_scene(TWO_SPHERES).unwrap();
    let options = MeshOptions {
        depth: 3,
        tolerance: Some(1e-5),
        max_cells: 1 << 20,
    };
    let meshes = lgc::mesh::scene::mesh_scene(&scene, &options).unwrap();
    assert_eq!(meshes.len(), 2);
    let centres = [
        (DVec3::new(3.0, 0.0, 0.0), 0.5),
        (DVec3::new(-3.0, 1.0, 0.0), 2.0),
    ];
    for (m, (c, r)) in meshes.iter().zip(centres) {
        assert_closed_manifold(m);
        assert_eq!(m.topology.euler, 2);
        for (p, radius) in m.mesh.positions.iter().zip(&m.mesh.radii) {
            let off = ((*p - c).length() - r).abs();
            assert!(off <= *radius && *radius <= 1e-5, "{p}: {off} > {radius}");
        }
    }
    let triangles: Vec<usize> = meshes.iter().map(|m| m.mesh.triangles.len()).collect();
    let run = |ext: &str, json: bool| {
        let path = dir.join(format!("two.{ext}"));
        let mut args = vec![
            "mesh",
            scene_path.to_str().unwrap(),
            "--depth",
            "3",
            "--tolerance",
            "1e-5",
            "-o",
            path.to_str().unwrap(),
        ];
        if json {
            args.push("--json");
        }
        let out = lgc(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (
            String::from_utf8(out.stdout).unwrap(),
            std::fs::read(&path).unwrap(),
        )
    };
    // glTF: a node, a mesh and a material for each object, in the scene's
    // colours made linear, each mesh's box around its own sphere.
    let (summary, bytes) = run("glb", false);
    let total = triangles[0] + triangles[1];
    assert!(summary.contains("2 objects, "), "{summary}");
    assert!(summary.contains(&format!("{total} triangles")), "{summary}");
    assert!(summary.contains("sphere at 3:1: "), "{summary}");
    assert!(summary.contains("sphere at 4:3: "), "{summary}");
    let glb = gltf::binary::Glb::from_slice(&bytes).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&glb.json).unwrap();
    let nodes = json["nodes"].as_array().unwrap();
    let names: Vec<&str> = nodes.iter().map(|n| n["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["sphere at 3:1", "sphere at 4:3"]);
    let colours: Vec<Vec<f64>> = json["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            let f = &m["pbrMetallicRoughness"]["baseColorFactor"];
            f.as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(
        colours,
        [vec![1.0, 0.0, 0.0, 1.0], vec![0.0, 0.0, 1.0, 1.0]]
    );
    for (k, node) in nodes.iter().enumerate() {
        let mesh = &json["meshes"][node["mesh"].as_u64().unwrap() as usize];
        let primitive = &mesh["primitives"][0];
        assert_eq!(primitive["material"].as_u64(), Some(k as u64));
        let positions =
            &json["accessors"][primitive["attributes"]["POSITION"].as_u64().unwrap() as usize];
        let (c, r) = centres[k];
        for (axis, centre) in c.to_array().into_iter().enumerate() {
            let lo = positions["min"][axis].as_f64().unwrap();
            let hi = positions["max"][axis].as_f64().unwrap();
            assert!(
                (lo - (centre - r)).abs() < 0.2 * r && (hi - (centre + r)).abs() < 0.2 * r,
                "{lo}..{hi} around {centre}"
            );
        }
        let indices = &json["accessors"][primitive["indices"].as_u64().unwrap() as usize];
        assert_eq!(indices["count"].as_u64(), Some(3 * triangles[k] as u64));
    }
    // STL holds every triangle; OBJ and 3MF an object for each.
    let (_, bytes) = run("stl", false);
    let read = stl_io::read_stl(&mut std::io::Cursor::new(&bytes)).unwrap();
    assert_eq!(read.faces.len(), total);
    let (_, bytes) = run("obj", false);
    let text = String::from_utf8(bytes).unwrap();
    let objects: Vec<&str> = text.lines().filter(|l| l.starts_with("o ")).collect();
    assert_eq!(objects, ["o sphere at 3:1", "o sphere at 4:3"]);
    let (_, bytes) = run("3mf", false);
    let models = threemf::read(std::io::Cursor::new(bytes)).unwrap();
    let objects = &models[0].resources.object;
    assert_eq!(objects.len(), 2);
    for (o, &n) in objects.iter().zip(&triangles) {
        assert_eq!(o.mesh.as_ref().unwrap().triangles.triangle.len(), n);
    }
    // The JSON summary lists each object with its own certificate.
    let (summary, _) = run("ply", true);
    let json: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let listed = json["objects"].as_array().unwrap();
    assert_eq!(listed.len(), 2);
    for (o, m) in listed.iter().zip(&meshes) {
        assert_eq!(o["triangles"].as_u64(), Some(m.mesh.triangles.len() as u64));
        assert_eq!(
            o["certified"].as_u64(),
            Some(m.certificate.certified as u64)
        );
        assert_eq!(o["hausdorff"].as_f64(), Some(m.certificate.hausdorff));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The distance from `p` to the triangle `t`.
fn point_triangle_distance(p: DVec3, t: [DVec3; 3]) -> f64 {
    let [a, b, c] = t;
    let segment = |u: DVec3, v: DVec3| {
        let s = ((p - u).dot(v - u) / (v - u).length_squared()).clamp(0.0, 1.0);
        (p - (u + s * (v - u))).length()
    };
    let edges = segment(a, b).min(segment(b, c)).min(segment(c, a));
    let n = (b - a).cross(c - a);
    let q = p - (p - a).dot(n) / n.length_squared() * n;
    let inside = [(a, b), (b, c), (c, a)]
        .iter()
        .all(|&(u, v)| (v - u).cross(q - u).dot(n) >= 0.0);
    if inside {
        edges.min((p - q).length())
    } else {
        edges
    }
}

/// The distance from `p` to the mesh.
fn distance_to_mesh(m: &Meshed, p: DVec3) -> f64 {
    let corner = |v: u32| m.mesh.positions[v as usize];
    m.mesh
        .triangles
        .iter()
        .map(|t| point_triangle_distance(p, t.map(corner)))
        .fold(f64::INFINITY, f64::min)
}

/// The volume the mesh encloses, by the divergence theorem.
fn volume(m: &Meshed) -> f64 {
    let corner = |v: u32| m.mesh.positions[v as usize];
    m.mesh
        .triangles
        .iter()
        .map(|t| corner(t[0]).dot(corner(t[1]).cross(corner(t[2]))) / 6.0)
        .sum()
}

#[test]
fn a_cubes_edges_and_corners_come_out_sharp() {
    // Marching tetrahedra alone cut each edge off by up to half a cell
    // (0.03 here), and the volume short by 0.008.
    let formula = "max(max(abs(x),abs(y)),abs(z))-0.55";
    let m = meshed(formula, &cube(1.0), 5);
    assert_closed_manifold(&m);
    assert_eq!(m.topology.euler, 2);
    assert_vertices_near_surface(formula, &m, 1e-6);
    assert!(m.sharpened.cells > 0 && m.sharpened.face_vertices > 0);
    let h = 0.55;
    let mut far: f64 = 0.0;
    for axis in 0..3 {
        for (s, t) in [(-h, -h), (-h, h), (h, -h), (h, h)] {
            for k in 0..=40 {
                let mut p = DVec3::ZERO;
                p[axis] = -h + 2.0 * h * k as f64 / 40.0;
                p[(axis + 1) % 3] = s;
                p[(axis + 2) % 3] = t;
                far = far.max(distance_to_mesh(&m, p));
            }
        }
    }
    assert!(far < 1e-5, "an edge point is {far} from the mesh");
    let exact = (2.0 * h).powi(3);
    assert!(
        (volume(&m) - exact).abs() < 1e-5,
        "volume {} against {exact}",
        volume(&m)
    );
}

#[test]
fn a_drilled_hole_keeps_its_rim_within_a_small_part_of_a_cell() {
    // A cube drilled through along z: the rims are circles where the
    // cylinder meets the top and bottom faces, curved creases.
    let formula = "max(max(max(abs(x),abs(y)),abs(z))-0.55, 0.3-sqrt(x^2+y^2))";
    let m = meshed(formula, &cube(1.0), 6);
    assert_closed_manifold(&m);
    assert_eq!(m.topology.euler, 0);
    assert_vertices_near_surface(formula, &m, 1e-6);
    let cell = 2.0 / 64.0;
    let rim: Vec<f64> = (0..200)
        .flat_map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 200.0;
            [-0.55, 0.55].map(|z| DVec3::new(0.3 * a.cos(), 0.3 * a.sin(), z))
        })
        .map(|p| distance_to_mesh(&m, p))
        .collect();
    let far = rim.iter().copied().fold(0.0, f64::max);
    let mean = rim.iter().sum::<f64>() / rim.len() as f64;
    assert!(
        far < 0.2 * cell && mean < 0.01 * cell,
        "rim: farthest {far}, mean {mean} (cell {cell})"
    );
}

#[test]
fn creased_surfaces_fanned_at_their_creases_stay_closed_manifolds() {
    // Creases whose cells do not all fan: a face vertex is used only where
    // both cells of its face are fanned, or the mesh would open there.
    let cases = [
        (
            "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-0.81)",
            -2,
        ),
        (
            "max(max(max(abs(x),abs(y)),abs(z))-1, -min(min(sqrt(x^2+y^2)-0.5, sqrt(y^2+z^2)-0.5), sqrt(x^2+z^2)-0.5))",
            -8,
        ),
    ];
    for (formula, euler) in cases {
        let m = meshed(formula, &cube(1.3), 5);
        assert_closed_manifold(&m);
        assert_eq!(m.topology.euler, euler, "{formula}");
        assert!(m.sharpened.cells > 0, "{formula}");
        assert_vertices_near_surface(formula, &m, 1e-6);
    }
}
