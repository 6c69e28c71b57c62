//! The mesh's certificate: in a certified cell, every lattice edge and face
//! of its tetrahedra meets the surface as the mesh does (checked here by
//! sampling f densely, independently of the certifier), and the cells where
//! that fails, by construction, are reported where they are.

use glam::DVec3;
use lgc::mesh::lattice::Lattice;
use lgc::mesh::{mesh, Doubt, MeshOptions, Meshed};
use lgc::{Aabb, Evaluator, Formula, Output};

/// `formula` meshed in `b` at `depth`, to the default tolerance (a quarter
/// of a cell's side).
fn meshed(formula: &str, b: &Aabb, depth: u32) -> Meshed {
    let options = MeshOptions {
        depth,
        tolerance: None,
        max_cells: 1 << 22,
    };
    mesh(&Formula::parse(formula).unwrap(), b, &options).unwrap()
}

/// f in f64 along the segment from `a` to `b`, at `n + 1` points.
fn samples(eval: &mut Evaluator<f64>, a: DVec3, b: DVec3, n: usize) -> Vec<f64> {
    (0..=n)
        .map(|i| {
            let p = a.lerp(b, i as f64 / n as f64);
            eval.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0]
        })
        .collect()
}

/// Sign changes in a row of samples, skipping samples too near 0 for f64 to
/// tell their sign.
fn sign_changes(values: &[f64]) -> usize {
    let signs: Vec<bool> = values
        .iter()
        .filter(|v| v.abs() > 1e-12)
        .map(|&v| v > 0.0)
        .collect();
    signs.windows(2).filter(|w| w[0] != w[1]).count()
}

/// Every edge of every Kuhn tetrahedron of every certified cell is crossed
/// once if its ends' signs differ and never if not; every face whose
/// corners share a sign keeps it on a grid of samples. Returns how many
/// cells were checked.
fn assert_certified_cells_cross_as_the_mesh(formula: &str, b: &Aabb, depth: u32) -> usize {
    let m = meshed(formula, b, depth);
    let f = Formula::parse(formula).unwrap();
    let tape = f.tape(&[Output::F]);
    let mut eval = Evaluator::<f64>::new(&tape);
    let lattice = Lattice::new(b);
    let n = 1u32 << m.level;
    let mut checked = 0;
    for c in (0..n * n * n).map(|i| [i % n, i / n % n, i / (n * n)]) {
        let cell = lattice.cell(c, m.level);
        if m.certificate.uncertified.iter().any(|u| u.cell == cell) {
            continue;
        }
        let corner =
            |o: usize| lattice.point([0, 1, 2].map(|a| c[a] + (o as u32 >> a & 1)), m.level);
        let value = |eval: &mut Evaluator<f64>, o: usize| {
            let p = corner(o);
            eval.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0]
        };
        let at: Vec<f64> = (0..8).map(|o| value(&mut eval, o)).collect();
        checked += 1;
        for (p, q) in (0..8usize).flat_map(|p| (0..8usize).map(move |q| (p, q))) {
            // The Kuhn edges: q's bits hold p's.
            if p == q || p & q != p {
                continue;
            }
            let values = samples(&mut eval, corner(p), corner(q), 200);
            let expected = usize::from((at[p] > 0.0) != (at[q] > 0.0));
            assert_eq!(
                sign_changes(&values),
                expected,
                "{formula}: certified cell {cell:?}, edge {p}–{q}"
            );
        }
        for (p, q, r) in (0..8usize)
            .flat_map(|p| (0..8usize).flat_map(move |q| (0..8usize).map(move |r| (p, q, r))))
        {
            if !(p != q && q != r && p & q == p && q & r == q) {
                continue;
            }
            if (at[p] > 0.0) != (at[q] > 0.0) || (at[q] > 0.0) != (at[r] > 0.0) {
                continue;
            }
            let (a, b, c) = (corner(p), corner(q), corner(r));
            for i in 0..=12 {
                for j in 0..=12 - i {
                    let (s, t) = (i as f64 / 12.0, j as f64 / 12.0);
                    let x = a + (b - a) * s + (c - a) * t;
                    let v = eval.eval(&[x.x, x.y, x.z, 0.0, 0.0, 0.0])[0];
                    assert!(
                        v.abs() < 1e-12 || (v > 0.0) == (at[p] > 0.0),
                        "{formula}: certified cell {cell:?}, face {p}–{q}–{r} at {x}: {v}"
                    );
                }
            }
        }
    }
    checked
}

#[test]
fn certified_cells_meet_the_surface_as_the_mesh_does() {
    let off = Aabb::new(DVec3::new(-1.3, -1.2, -1.1), DVec3::new(1.4, 1.5, 1.25)).unwrap();
    let cube = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    for (formula, b, depth) in [
        ("x^2+y^2+z^2-1", &off, 4),
        ("x^2+2*y^2+3*z^2-1.1", &cube, 4),
        ("(sqrt(x^2+y^2)-1)^2+z^2-0.3", &cube, 4),
        ("x^2+y^2+z^2-1+0.3*sin(4*x)*sin(4*y)", &off, 4),
    ] {
        let checked = assert_certified_cells_cross_as_the_mesh(formula, b, depth);
        assert!(checked > 0, "{formula}");
    }
}

#[test]
fn smooth_surfaces_are_certified_in_nearly_every_cell() {
    // The sphere is within the tolerance nearly everywhere at depth 6; the
    // torus's tube curves too much for cells that size, but is isotopic.
    let b = Aabb::new(DVec3::new(-1.3, -1.2, -1.1), DVec3::new(1.4, 1.5, 1.25)).unwrap();
    for (formula, depth, share) in [
        ("x^2+y^2+z^2-1", 6, 0.99),
        ("(sqrt(x^2+y^2)-0.8)^2+z^2-0.1", 6, 0.0),
        ("(sqrt(x^2+y^2)-0.8)^2+z^2-0.1", 7, 0.98),
    ] {
        let m = meshed(formula, &b, depth);
        let c = &m.certificate;
        assert_eq!(c.certified + c.uncertified.len(), m.cells, "{formula}");
        let isotopic = c.certified + c.count(Doubt::Far);
        assert!(
            isotopic as f64 >= 0.95 * m.cells as f64
                && c.certified as f64 >= share * m.cells as f64,
            "{formula}: {} of {} cells certified, {isotopic} isotopic",
            c.certified,
            m.cells
        );
        // Within the tolerance, a quarter of a cell's side.
        let side = (b.hi - b.lo).min_element() / f64::from(1 << depth);
        assert!(
            (c.tolerance / (side * lgc::mesh::DEFAULT_TOLERANCE) - 1.0).abs() < 1e-12,
            "{formula}"
        );
        assert!(c.hausdorff <= c.tolerance, "{formula}");
        assert!(c.certified == 0 || c.hausdorff > 0.0, "{formula}");
        assert!(c
            .uncertified
            .iter()
            .all(|u| matches!(u.doubt, Doubt::Fold | Doubt::Far)));
    }
}

#[test]
fn a_sphere_inside_one_cell_is_missed_and_its_cell_reported() {
    // At depth 3 of [-1, 1]^3 the cell [0, 0.25]^3 holds the whole sphere,
    // and all its corners are outside: the mesh has no triangles, which only
    // the certificate can tell.
    let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    let m = meshed("(x-0.1)^2+(y-0.12)^2+(z-0.13)^2-0.05^2", &b, 3);
    assert!(m.mesh.triangles.is_empty());
    let centre = DVec3::new(0.1, 0.12, 0.13);
    let c = &m.certificate;
    assert!(!c.is_complete());
    assert!(c.uncertified.iter().any(|u| u.doubt == Doubt::Fold
        && (0..3).all(|a| u.cell.lo[a] <= centre[a] && centre[a] <= u.cell.hi[a])));
}

#[test]
fn a_lattice_edge_crossed_twice_is_reported() {
    // The parabolic sheet dips 0.01 below the lattice plane z = 0 between
    // the lattice points x = 0 and x = 0.25: the edge between them crosses
    // it twice, its ends are both below it, and the mesh cannot follow.
    let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    let m = meshed("z+0.01-4*(x-0.125)^2+0*y", &b, 3);
    let c = &m.certificate;
    assert!(c.uncertified.iter().any(|u| u.doubt == Doubt::Fold
        && u.cell.lo.x == 0.0
        && u.cell.hi.x == 0.25
        && (u.cell.lo.z == 0.0 || u.cell.hi.z == 0.0)));
}

#[test]
fn creases_jumps_and_surfaces_through_lattice_points_are_reported() {
    let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    // Two spheres a millionth apart: min's crease runs between them.
    let two = "min((x-0.5000005)^2+y^2+z^2-0.25, (x+0.5000005)^2+y^2+z^2-0.25)";
    // The cone's tip is the lattice point (0, 0, 0.5); z = 0 is a lattice
    // plane; sign jumps.
    for (formula, doubt, near) in [
        (two, Doubt::Kink, DVec3::ZERO),
        (
            "x^2+y^2-(z-0.5)^2",
            Doubt::Corner,
            DVec3::new(0.0, 0.0, 0.5),
        ),
        ("sign(x)-0.5+0*y+0*z", Doubt::Jump, DVec3::ZERO),
    ] {
        let m = meshed(formula, &b, 4);
        let c = &m.certificate;
        let cell = 2.0 / 16.0;
        assert!(
            c.uncertified.iter().any(|u| u.doubt == doubt
                && (0.5 * (u.cell.lo + u.cell.hi) - near).abs().max_element() <= cell),
            "{formula}: {:?}",
            c.uncertified.iter().map(|u| u.doubt).collect::<Vec<_>>()
        );
    }
    // A surface through a whole plane of lattice points: both layers of
    // 8 × 8 cells beside it (the cells below it at the box's wall are kept
    // too, as the solid reaches the wall there).
    let m = meshed("z+0*x", &b, 3);
    assert_eq!(m.certificate.count(Doubt::Corner), 2 * 8 * 8);
    assert_eq!(m.certificate.certified, 0);
}

#[test]
fn the_summary_counts_and_locates_uncertified_cells() {
    let dir = std::env::temp_dir().join(format!("lgc-certificate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cone.stl");
    // A double cone, its tip inside a cell.
    let cone = "x^2+y^2-(z-0.1)^2";
    let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    let m = meshed(cone, &b, 4);
    let c = &m.certificate;
    assert!(c.certified > 0 && !c.is_complete());
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args(["mesh", cone, "--depth", "4", "-o", path.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success());
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        summary.contains(&format!("certified: {} of {} cells", c.certified, m.cells)),
        "{summary}"
    );
    assert!(
        summary.contains(&format!("uncertified: {} cells: ", c.uncertified.len())),
        "{summary}"
    );
    let first = c.uncertified[0].cell;
    let centre = 0.5 * (first.lo + first.hi);
    assert!(
        summary.contains(&format!(
            "the first centred at {},{},{}",
            centre.x, centre.y, centre.z
        )),
        "{summary}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_json_summary_lists_every_uncertified_cell() {
    let dir = std::env::temp_dir().join(format!("lgc-certificate-json-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cone.ply");
    let cone = "x^2+y^2-(z-0.1)^2";
    let b = Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)).unwrap();
    let m = meshed(cone, &b, 4);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lgc"))
        .args([
            "mesh",
            cone,
            "--depth",
            "4",
            "--json",
            "-o",
            path.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(summary["triangles"], m.mesh.triangles.len());
    assert_eq!(summary["euler"], m.topology.euler);
    assert_eq!(summary["certified"], m.certificate.certified);
    assert_eq!(summary["hausdorff"], m.certificate.hausdorff);
    let listed = summary["uncertified"].as_array().unwrap();
    assert_eq!(listed.len(), m.certificate.uncertified.len());
    for (json, u) in listed.iter().zip(&m.certificate.uncertified) {
        assert_eq!(
            json["lo"],
            serde_json::json!([u.cell.lo.x, u.cell.lo.y, u.cell.lo.z])
        );
        assert_eq!(
            json["hi"],
            serde_json::json!([u.cell.hi.x, u.cell.hi.y, u.cell.hi.z])
        );
        assert_eq!(
            json["doubt"].as_str().unwrap(),
            format!("{:?}", u.doubt).to_lowercase()
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_open_max_is_a_kink_and_a_settled_one_is_not() {
    // Where max's sides may cross (near x = 0.5 on the sphere) cells are
    // kinks; where it settles on the sphere's side everywhere, the cells are
    // as certified as the sphere's.
    let b = Aabb::new(DVec3::new(-1.3, -1.2, -1.1), DVec3::new(1.4, 1.5, 1.25)).unwrap();
    let plain = meshed("x^2+y^2+z^2-1", &b, 4);
    let settled = meshed("max(x-10, x^2+y^2+z^2-1)", &b, 4);
    assert_eq!(settled.mesh.triangles.len(), plain.mesh.triangles.len());
    assert_eq!(settled.certificate.certified, plain.certificate.certified);
    let open = meshed("max(x-0.5, x^2+y^2+z^2-1)", &b, 4);
    let kinks = open.certificate.count(Doubt::Kink);
    assert!(
        kinks > 0 && kinks < open.cells / 2,
        "{kinks} of {}",
        open.cells
    );
}

/// Every point of the mesh in a certified cell lies within the summary's
/// `mesh_to_surface` of the surface: checked on a grid of points of every
/// such triangle, against the exact distance to a sphere and to a torus.
#[test]
fn the_mesh_in_certified_cells_is_within_its_bound_of_the_surface() {
    let sphere = |p: DVec3| (p.length() - 0.9).abs();
    let torus = |p: DVec3| {
        let ring = (p.x * p.x + p.y * p.y).sqrt() - 0.6;
        ((ring * ring + p.z * p.z).sqrt() - 0.2).abs()
    };
    let cases: [(&str, &dyn Fn(DVec3) -> f64); 2] = [
        ("x^2+y^2+z^2-0.81", &sphere),
        ("(sqrt(x^2+y^2)-0.6)^2+z^2-0.04", &torus),
    ];
    let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    for (formula, distance) in cases {
        let m = meshed(formula, &b, 7);
        let c = &m.certificate;
        // Nearly every cell of these smooth surfaces is within the bound,
        // and it is far below the cell's diagonal (0.027): the sag of a
        // triangle, not its size.
        assert!(c.certified as f64 >= 0.99 * m.cells as f64, "{formula}");
        assert!(
            c.mesh_to_surface < 0.25 * 0.027,
            "{formula}: {}",
            c.mesh_to_surface
        );
        let uncertified = |p: DVec3| {
            c.uncertified
                .iter()
                .any(|u| p.cmpge(u.cell.lo).all() && p.cmple(u.cell.hi).all())
        };
        let (mut checked, mut farthest) = (0, 0.0f64);
        for t in &m.mesh.triangles {
            let [a, b, d] = t.map(|v| m.mesh.positions[v as usize]);
            // A triangle lies in one cell; one touching an uncertified cell
            // is skipped whole.
            if [a, b, d].into_iter().any(uncertified) {
                continue;
            }
            for i in 0..=4 {
                for j in 0..=4 - i {
                    let p = a + (i as f64 / 4.0) * (b - a) + (j as f64 / 4.0) * (d - a);
                    farthest = farthest.max(distance(p));
                }
            }
            checked += 1;
        }
        assert!(checked > 1000, "{formula}: {checked} triangles");
        // The bound is not slack by orders of magnitude: the sag is there.
        assert_bound_holds_closely(formula, farthest, c.mesh_to_surface, 0.05);
    }
}

/// The closest point to `p` of the triangle `a b c` (Ericson, "Real-Time
/// Collision Detection", 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + d1 / (d1 - d3) * ab;
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + d2 / (d2 - d6) * ac;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Every point of the surface in a certified cell lies within the
/// summary's `surface_to_mesh` of the mesh: checked at points of a sphere
/// and a torus, each against the nearest point of the triangles around it.
#[test]
fn the_surface_in_certified_cells_is_within_its_bound_of_the_mesh() {
    let sphere = |u: f64, v: f64| 0.9 * DVec3::new(u.cos() * v.sin(), u.sin() * v.sin(), v.cos());
    let torus = |u: f64, v: f64| {
        let ring = 0.6 + 0.2 * v.cos();
        DVec3::new(ring * u.cos(), ring * u.sin(), 0.2 * v.sin())
    };
    type Surface<'a> = &'a dyn Fn(f64, f64) -> DVec3;
    let cases: [(&str, Surface); 2] = [
        ("x^2+y^2+z^2-0.81", &sphere),
        ("(sqrt(x^2+y^2)-0.6)^2+z^2-0.04", &torus),
    ];
    let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
    let side = 2.0 / 128.0;
    let cell = |p: DVec3| ((p - b.lo) / side).floor().as_ivec3();
    for (formula, surface) in cases {
        let m = meshed(formula, &b, 7);
        let c = &m.certificate;
        assert!(c.certified as f64 >= 0.99 * m.cells as f64, "{formula}");
        // The triangles by the cell their centroid lies in.
        let mut by_cell: std::collections::HashMap<glam::IVec3, Vec<usize>> = Default::default();
        for (k, t) in m.mesh.triangles.iter().enumerate() {
            let centroid = t
                .iter()
                .map(|&v| m.mesh.positions[v as usize])
                .sum::<DVec3>()
                / 3.0;
            by_cell.entry(cell(centroid)).or_default().push(k);
        }
        let uncertified = |p: DVec3| {
            c.uncertified
                .iter()
                .any(|u| p.cmpge(u.cell.lo).all() && p.cmple(u.cell.hi).all())
        };
        let (mut checked, mut farthest) = (0, 0.0f64);
        for i in 0..200 {
            for j in 0..100 {
                let q = surface(
                    i as f64 * std::f64::consts::TAU / 200.0 + 0.0123,
                    (j as f64 + 0.5) * std::f64::consts::TAU / 100.0,
                );
                if uncertified(q) {
                    continue;
                }
                // The bound is far below a cell's side, so the nearest
                // point of the mesh is in a triangle of a cell around q's.
                let at = cell(q);
                let mut nearest = f64::INFINITY;
                for d in 0..27 {
                    let step = glam::IVec3::new(d % 3 - 1, d / 3 % 3 - 1, d / 9 - 1);
                    for &k in by_cell.get(&(at + step)).into_iter().flatten() {
                        let [p0, p1, p2] =
                            m.mesh.triangles[k].map(|v| m.mesh.positions[v as usize]);
                        nearest = nearest.min((closest_on_triangle(q, p0, p1, p2) - q).length());
                    }
                }
                farthest = farthest.max(nearest);
                checked += 1;
            }
        }
        assert!(checked > 10_000, "{formula}: {checked} points");
        assert_bound_holds_closely(formula, farthest, c.surface_to_mesh, 0.02);
    }
}

/// The farthest distance found is within the bound, and past `share` of
/// it: the bound is not slack by orders of magnitude.
fn assert_bound_holds_closely(formula: &str, farthest: f64, bound: f64, share: f64) {
    assert!(
        farthest <= bound,
        "{formula}: a point {farthest} away, past {bound}"
    );
    assert!(
        farthest > share * bound,
        "{formula}: {farthest} against {bound}"
    );
}
