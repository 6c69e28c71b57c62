//! Per-region specialisation: each leaf's shape has the formula's sign there
//! (and most are the formula itself), and rays answer as they do with the
//! whole formula in every leaf.

use crate::common::{answer_alike, rays, render_both, Rng};
use glam::DVec3;
use lgc::ray::octree::{BuildOptions, Octree};
use lgc::ray::{Answer, Intersector};
use lgc::{Aabb, Evaluator, Formula, Output};

/// CSG shapes: a ball cut by a plane, a cube with a ball taken out, a union
/// of spheres, a gyroid cut by a ball, a blend, and branch points of every
/// other kind.
const CSG: &[&str] = &[
    "max(x^2+y^2+z^2-1, z-0.3)",
    "max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))",
    "min(min((x-0.6)^2+y^2+z^2-0.5, (x+0.6)^2+y^2+z^2-0.5), x^2+(y-0.6)^2+z^2-0.3)",
    "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-1)",
    "min(x^2+y^2+z^2-1, (x-1)^2+y^2+z^2-0.5) - max(0.3 - abs(x^2+y^2+z^2-1 - ((x-1)^2+y^2+z^2-0.5)), 0)^2/1.2",
    "sign(x)*0.2 + y^2 + z^2 - 1 + choose(z, 0.1, -0.1)*x^2",
];

/// Intersectors of `f` at depth 5: every leaf seeing the whole formula, and
/// the default (specialised, creases refined).
fn with_and_without(f: &Formula, bounds: &Aabb) -> (Intersector, Intersector) {
    let plain = BuildOptions {
        specialise: false,
        crease_levels: 0,
        ..BuildOptions::to_depth(5)
    };
    (
        Intersector::with_options(f, bounds, &plain),
        Intersector::new(f, bounds, 5),
    )
}

fn cube(side: f64) -> Aabb {
    Aabb::new(DVec3::splat(-side), DVec3::splat(side)).unwrap()
}

/// Whether `a` and `b`, values of f and of a leaf's shape at one point,
/// have the same sign (either within rounding of 0 counts as both).
fn same_sign(a: f64, b: f64) -> bool {
    let near_zero = |v: f64| v.abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()));
    near_zero(a) || near_zero(b) || a.signum() == b.signum()
}

#[test]
fn every_leaf_shape_has_the_formulas_sign_in_its_leaf() {
    // Where a branch wins on the whole leaf the shape is f there; where a
    // side of a max (min) at the root stays below (above) 0 it is dropped,
    // and the shape has only f's sign: both hold the same surface.
    let mut rng = Rng::new(11);
    let mut values_differ = 0;
    for src in CSG {
        let f = Formula::parse(src).unwrap();
        let tree = Octree::build(&f, &cube(2.0), 4);
        assert!(
            tree.stats.specialised > 0,
            "{src}: nothing specialised ({:?})",
            tree.stats
        );
        let whole = f.tape(&[lgc::Output::F]);
        let mut whole = Evaluator::<f64>::new(&whole);
        let mut checked = 0;
        for node in &tree.nodes {
            let Some(leaf) = tree.leaf(node) else {
                continue;
            };
            let shape = &tree.shapes[leaf.shape as usize];
            let mut own = Evaluator::<f64>::new(&shape.f);
            // The padded box: rays evaluate there too.
            let pad = tree.pad;
            let lo = (node.bounds.lo - pad).to_array();
            let hi = (node.bounds.hi + pad).to_array();
            for _ in 0..8 {
                let p = rng.point(lo, hi);
                let input = [p[0], p[1], p[2], 0.0, 0.0, 0.0];
                let (a, b) = (whole.eval(&input)[0], own.eval(&input)[0]);
                assert!(
                    same_sign(a, b),
                    "{src}: at {p:?} the whole formula is {a}, leaf shape {} gives {b}",
                    leaf.shape
                );
                values_differ += usize::from((a - b).abs() > 1e-12 * (1.0 + a.abs()));
                checked += 1;
            }
        }
        assert!(checked > 0);
    }
    // Some shapes keep only the sign (else the test would not see them).
    assert!(values_differ > 0);
}

#[test]
fn creased_leaves_of_a_max_or_min_are_the_larger_or_smaller_of_two_smooth_sides() {
    let mut rng = Rng::new(17);
    // A ball cut by a plane, a union of three balls, the gyroid in a ball;
    // sign and choose have no sides.
    for (src, expect_split) in [
        (CSG[0], true),
        (CSG[2], true),
        (CSG[3], true),
        (CSG[5], false),
    ] {
        let f = Formula::parse(src).unwrap();
        let tree = Octree::build(&f, &cube(2.0), 4);
        assert_eq!(
            tree.stats.split > 0,
            expect_split,
            "{src}: {} split leaves ({:?})",
            tree.stats.split,
            tree.stats
        );
        assert!(tree.stats.split <= tree.stats.creased);
        let mut leaves = 0;
        for node in &tree.nodes {
            let Some(leaf) = tree.leaf(node) else {
                continue;
            };
            let at = node.leaf_index().unwrap();
            leaves += 1;
            let Some(split) = tree.split(at) else {
                continue;
            };
            assert!(leaf.needs_intervals, "{src}: a split leaf is creased");
            let mut own = Evaluator::<f64>::new(&tree.shapes[leaf.shape as usize].f);
            let mut sides = split.sides.map(|side| {
                let shape = &tree.shapes[side.shape as usize];
                assert_eq!(shape.open, 0, "{src}: a side is smooth");
                Evaluator::<f64>::new(&shape.f)
            });
            let (lo, hi) = (node.bounds.lo.to_array(), node.bounds.hi.to_array());
            for _ in 0..8 {
                let p = rng.point(lo, hi);
                let input = [p[0], p[1], p[2], 0.0, 0.0, 0.0];
                let f = own.eval(&input)[0];
                let [a, b] = [0, 1].map(|k| sides[k].eval(&input)[0]);
                let g = if split.larger { a.max(b) } else { a.min(b) };
                assert!(
                    (f - g).abs() <= 1e-12 * (1.0 + f.abs()),
                    "{src}: at {p:?} the leaf's shape is {f}, its sides give {a} and {b}"
                );
            }
        }
        assert!(leaves > 0);
    }
}

#[test]
fn rays_answer_alike_with_and_without_specialisation() {
    let mut rng = Rng::new(29);
    let bounds = cube(2.0);
    let tol = 1e-10 * (bounds.hi - bounds.lo).length();
    for src in CSG {
        let f = Formula::parse(src).unwrap();
        let (reference, special) = with_and_without(&f, &bounds);
        let (mut r, mut s) = (reference.tracer(), special.tracer());
        for ray in rays(&mut rng, &f) {
            answer_alike(&format!("{src}: "), &mut r, &mut s, ray, tol);
        }
    }
}

#[test]
fn specialised_leaves_get_finite_kalra_barr_bounds() {
    // Away from the crease, the ball cut by a plane is a sphere or a plane:
    // finite G, and no interval evaluation needed.
    // (Every box to the full depth, so that leaves compare by count; the
    // sphere's and the plane's boxes otherwise stop as soon as they settle.)
    let f = Formula::parse(CSG[0]).unwrap();
    let full = BuildOptions {
        coarse_quadrics: false,
        ..BuildOptions::to_depth(5)
    };
    let tree = Octree::build_with(&f, &cube(2.0), &full);
    let mut smooth = 0;
    for node in &tree.nodes {
        let Some(leaf) = tree.leaf(node) else {
            continue;
        };
        if tree.shapes[leaf.shape as usize].open == 0 {
            smooth += 1;
            assert!(!leaf.needs_intervals && leaf.hessian_norm.is_finite());
            continue;
        }
        // A leaf still creased lies by the crease: the circle z = 0.3,
        // r = √0.91, within a few of its diagonals (enclosures overlap there).
        let c = node.bounds.center();
        let from_circle = DVec3::new(c.truncate().length() - 0.91f64.sqrt(), c.z - 0.3, 0.0);
        let diagonal = (node.bounds.hi - node.bounds.lo).length();
        assert!(
            from_circle.length() <= 3.0 * diagonal,
            "creased leaf at {c}"
        );
    }
    assert!(
        smooth * 3 >= tree.stats.leaves * 2,
        "{smooth} of {} leaves smooth",
        tree.stats.leaves
    );
    assert_eq!(tree.stats.creased, tree.stats.leaves - smooth);
}

#[test]
fn csg_shapes_render_the_same_picture_with_and_without_specialisation() {
    let bounds = cube(1.2);
    for src in &CSG[..4] {
        let f = Formula::parse(src).unwrap();
        let (reference, special) = with_and_without(&f, &bounds);
        let (a, b, differing) = render_both(&reference, &special, &bounds, 2);
        assert_eq!(differing, 0, "{src}: {differing} pixels differ");
        assert!(
            b.primary.interval_evals < a.primary.interval_evals,
            "{src}: specialisation should save interval evaluations ({} vs {})",
            b.primary.interval_evals,
            a.primary.interval_evals
        );
    }
}

#[test]
fn creased_boxes_with_two_quadratic_sides_are_split_leaves_early_or_at_the_depth() {
    // The cube's edges are the larger of two planes, the ball cut by a
    // plane's seam the larger of a sphere and a plane: their boxes stop one
    // level above the requested depth, and f there has the larger side's
    // sign. The cube minus a ball's rim (where a face meets the hole) is
    // first settled to one such seam at the depth: its boxes stop there
    // rather than go on to the crease levels (where eight would take its
    // place).
    let mut rng = Rng::new(41);
    for (src, at_depth) in [
        ("max(abs(x),abs(y),abs(z))-1", false),
        (CSG[0], false),
        (CSG[1], true),
    ] {
        let f = Formula::parse(src).unwrap();
        let bounds = cube(1.2);
        let tree = Octree::build(&f, &bounds, 5);
        let whole = f.tape(&[lgc::Output::F]);
        let mut whole = Evaluator::<f64>::new(&whole);
        let side_at = |level: i32| 2.4 * 0.5f64.powi(level);
        let (mut early, mut at_five) = (0, 0);
        for node in &tree.nodes {
            let Some(at) = node.leaf_index() else {
                continue;
            };
            let Some(split) = tree.split(at) else {
                continue;
            };
            let size = node.bounds.hi.x - node.bounds.lo.x;
            let quadric = split.sides.iter().all(lgc::ray::octree::quadric_leaf);
            if (size - side_at(4)).abs() <= 1e-9 {
                early += 1;
                assert!(
                    quadric,
                    "{src}: an early split leaf has two quadratic sides"
                );
                assert_eq!(split.scale, 0.5);
            } else if (size - side_at(5)).abs() <= 1e-9 {
                at_five += usize::from(quadric);
                assert_eq!(split.scale, 1.0);
            } else {
                // (Past the depth: boxes two branches crossed at the depth.)
                assert!(size < side_at(5), "{src}: a split leaf of side {size}");
            }
            let mut sides = split
                .sides
                .map(|s| Evaluator::<f64>::new(&tree.shapes[s.shape as usize].f));
            let (lo, hi) = (node.bounds.lo.to_array(), node.bounds.hi.to_array());
            for _ in 0..8 {
                let p = rng.point(lo, hi);
                let input = [p[0], p[1], p[2], 0.0, 0.0, 0.0];
                let [a, b] = [0, 1].map(|k| sides[k].eval(&input)[0]);
                let f = whole.eval(&input)[0];
                let g = if split.larger { a.max(b) } else { a.min(b) };
                assert!(
                    same_sign(f, g),
                    "{src}: at {p:?} f is {f}, its sides {a}, {b}"
                );
            }
        }
        if at_depth {
            assert!(
                at_five > 0,
                "{src}: no split leaf at the depth ({:?})",
                tree.stats
            );
        } else {
            assert!(early > 0, "{src}: no early split leaf ({:?})", tree.stats);
        }
    }
}

#[test]
fn rays_across_the_cubes_edges_answer_alike_with_and_without_specialisation() {
    // Where a split leaf's sides are planes, pieces are cut around where
    // their difference crosses 0 (the edge's plane of symmetry): rays aimed
    // at points on and beside the edges, from every side.
    let mut rng = Rng::new(43);
    let f = Formula::parse("max(abs(x),abs(y),abs(z))-1").unwrap();
    let bounds = cube(1.2);
    let tol = 1e-10 * (bounds.hi - bounds.lo).length();
    let (reference, special) = with_and_without(&f, &bounds);
    let (mut r, mut s) = (reference.tracer(), special.tracer());
    let mut hits = 0;
    for i in 0..1500 {
        // A point on one of the twelve edges, moved off it a little.
        let along = rng.uniform(-1.0, 1.0);
        let (sa, sb) = (
            if rng.uniform(-1.0, 1.0) < 0.0 {
                -1.0
            } else {
                1.0
            },
            if rng.uniform(-1.0, 1.0) < 0.0 {
                -1.0
            } else {
                1.0
            },
        );
        let mut p = match i % 3 {
            0 => DVec3::new(along, sa, sb),
            1 => DVec3::new(sa, along, sb),
            _ => DVec3::new(sa, sb, along),
        };
        let off = [0.0, 1e-9, 1e-5, 1e-2][i % 4];
        p += off * DVec3::from(rng.direction());
        let d = DVec3::from(rng.direction());
        let o = p - 3.0 * d;
        let b = answer_alike("", &mut r, &mut s, (o, d), tol);
        hits += usize::from(matches!(b, Answer::Hit(_)));
    }
    assert!(hits > 500, "{hits} hits");
}

#[test]
fn normals_at_specialised_hits_are_the_whole_formulas() {
    // A hit's normal is the gradient of the shape that found it (the leaf's,
    // or one side's): that shape is f near the hit, so its gradient is the
    // whole formula's, except beside a crease, where that one jumps.
    let mut rng = Rng::new(31);
    let bounds = cube(2.0);
    let mut compared = 0;
    for src in CSG {
        let f = Formula::parse(src).unwrap();
        let tape = f.tape(&[Output::Dfdx, Output::Dfdy, Output::Dfdz]);
        let mut grad = Evaluator::<f64>::new(&tape);
        let mut whole = |p: DVec3| {
            DVec3::from_slice(grad.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])).normalize_or_zero()
        };
        let special = Intersector::new(&f, &bounds, 5);
        let mut tracer = special.tracer();
        for (o, d) in rays(&mut rng, &f) {
            let Some(t) = tracer.first_hit(o, d, 0.0, f64::INFINITY) else {
                continue;
            };
            let p = o + t * d;
            let (n, w) = (tracer.normal(p).unwrap(), whole(p));
            if w == DVec3::ZERO || (n - w).length() <= 1e-12 {
                compared += 1;
                continue;
            }
            let mut beside =
                |e: DVec3| [1e-7, -1e-7].map(|h| (whole(p + h * e) - w).length() > 1e-3);
            let crease = [DVec3::X, DVec3::Y, DVec3::Z]
                .into_iter()
                .any(|e| beside(e).contains(&true));
            assert!(crease, "{src}: normal {n} at {p}, whole formula's {w}");
        }
    }
    assert!(compared > 1500, "only {compared} normals compared");
}
