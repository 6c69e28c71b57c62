//! Leaf hulls: each kept leaf's hull holds every point of the surface in its
//! box, and rays that search only hulls answer as rays that search whole
//! leaves.

use crate::common::{answer_alike, rays, render_both, Rng};
use glam::DVec3;
use lgc::ray::octree::{BuildOptions, Octree};
use lgc::ray::Intersector;
use lgc::{Aabb, Evaluator, Formula, Output};

/// Surfaces whose leaves get hulls of every kind: split leaves with plane
/// and sphere sides (two levels), creased leaves of a cube, smooth quartics,
/// a gyroid side; with the half-side of their cubic box.
const SHAPES: &[(&str, f64)] = &[
    ("max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))", 1.2),
    ("max(abs(x),abs(y),abs(z))-1", 1.2),
    ("max(x^2+y^2+z^2-1, z-0.3)", 1.2),
    (
        "min(min((x-0.5)^2+y^2+z^2-0.36, (x+0.5)^2+y^2+z^2-0.36), x^2+(y-0.6)^2+z^2-0.25)",
        1.2,
    ),
    ("(x^2+y^2+z^2+0.5^2-0.2^2)^2-4*0.5^2*(x^2+y^2)", 1.2),
    (
        "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-1)",
        1.05,
    ),
    ("x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8", 2.5),
];

fn cube(side: f64) -> Aabb {
    Aabb::new(DVec3::splat(-side), DVec3::splat(side)).unwrap()
}

/// Octrees whose rays are all searched (no polynomial answered in
/// Bernstein form): the hulls are what is compared.
fn searched(depth: u32) -> BuildOptions {
    BuildOptions {
        polynomial_form: false,
        ..BuildOptions::to_depth(depth)
    }
}

fn without_hulls(depth: u32) -> BuildOptions {
    BuildOptions {
        hull_levels: 0,
        ..searched(depth)
    }
}

#[test]
fn hulls_hold_every_root_in_their_leaves() {
    // In each kept leaf, f on a 7×7×7 grid of its box: where it changes sign
    // between neighbours, bisection finds a root, which must lie in the
    // leaf's hull (up to the bisection's own rounding). With every leaf at
    // the depth, and with tight leaves above it (larger, their hulls found
    // two levels down).
    for (&(src, side), tight_leaves) in SHAPES.iter().flat_map(|s| [(s, false), (s, true)]) {
        let f = Formula::parse(src).unwrap();
        let tape = f.tape(&[Output::F]);
        let mut eval = Evaluator::<f64>::new(&tape);
        let mut f_at = |p: DVec3| eval.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0];
        let options = BuildOptions {
            tight_leaves,
            ..BuildOptions::to_depth(5)
        };
        let tree = Octree::build_with(&f, &cube(side), &options);
        let (mut roots, mut tight, mut leaves) = (0, 0, 0);
        for node in &tree.nodes {
            let Some(i) = node.leaf_index() else { continue };
            let (cell, hull) = (node.bounds, *tree.leaf_hull(i));
            leaves += 1;
            // (Only on the box's own faces does a hull reach out, by the pad.)
            let outer = Aabb::new(
                DVec3::select(
                    cell.lo.cmpeq(tree.bounds.lo),
                    cell.lo - tree.pad * 1.01,
                    cell.lo,
                ),
                DVec3::select(
                    cell.hi.cmpeq(tree.bounds.hi),
                    cell.hi + tree.pad * 1.01,
                    cell.hi,
                ),
            )
            .unwrap();
            assert!(
                hull.lo.cmpge(outer.lo).all() && hull.hi.cmple(outer.hi).all(),
                "{src}: hull {hull:?} outside its leaf {cell:?}"
            );
            let size = cell.hi - cell.lo;
            if (hull.hi - hull.lo).element_product() < 0.75 * size.element_product() {
                tight += 1;
            }
            const N: usize = 7;
            let at = |i: usize, j: usize, k: usize| {
                cell.lo + size * DVec3::new(i as f64, j as f64, k as f64) / (N - 1) as f64
            };
            let slack = 1e-9 * size.length();
            for (i, j, k) in (0..N * N * N).map(|n| (n % N, n / N % N, n / (N * N))) {
                for step in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    let (i2, j2, k2) = (i + step.0, j + step.1, k + step.2);
                    if i2 == N || j2 == N || k2 == N {
                        continue;
                    }
                    let (mut a, mut b) = (at(i, j, k), at(i2, j2, k2));
                    let (fa, fb) = (f_at(a), f_at(b));
                    if (fa < 0.0) == (fb < 0.0) || fa == 0.0 || fb == 0.0 {
                        continue;
                    }
                    for _ in 0..60 {
                        let m = 0.5 * (a + b);
                        if (f_at(m) < 0.0) == (fa < 0.0) {
                            a = m;
                        } else {
                            b = m;
                        }
                    }
                    let r = 0.5 * (a + b);
                    roots += 1;
                    assert!(
                        r.cmpge(hull.lo - slack).all() && r.cmple(hull.hi + slack).all(),
                        "{src}: root {r} in leaf {cell:?} outside its hull {hull:?}"
                    );
                }
            }
        }
        // Not vacuous: many roots checked, and (at the depth) hulls that
        // leave out a quarter of their leaf or more.
        assert!(roots > 1000, "{src}: {roots} roots");
        assert!(
            tight_leaves || tight * 10 > leaves,
            "{src}: {tight} of {leaves} hulls leave out a quarter of their leaf"
        );
    }
}

#[test]
fn rays_answer_alike_with_and_without_hulls() {
    let mut rng = Rng::new(41);
    for &(src, side) in SHAPES {
        let f = Formula::parse(src).unwrap();
        let bounds = cube(side);
        let tol = 1e-10 * (bounds.hi - bounds.lo).length();
        let whole = Intersector::with_options(&f, &bounds, &without_hulls(5));
        let hulled = Intersector::with_options(&f, &bounds, &searched(5));
        let (mut w, mut h) = (whole.tracer(), hulled.tracer());
        for ray in rays(&mut rng, &f) {
            answer_alike(&format!("{src}: "), &mut w, &mut h, ray, tol);
        }
        // Rays cross fewer leaves: those whose hulls they miss.
        assert!(
            h.stats.leaves < w.stats.leaves,
            "{src}: {} leaves searched with hulls, {} without",
            h.stats.leaves,
            w.stats.leaves
        );
    }
}

#[test]
fn pictures_are_the_same_with_and_without_hulls() {
    // Bundles of camera rays list leaves by their hulls, and shadow rays
    // start on the surface: the picture is the same, for fewer leaf visits.
    for &(src, side) in SHAPES {
        let f = Formula::parse(src).unwrap();
        let bounds = cube(side);
        let whole = Intersector::with_options(&f, &bounds, &without_hulls(5));
        let hulled = Intersector::with_options(&f, &bounds, &searched(5));
        let (a, b, differing) = render_both(&whole, &hulled, &bounds, 1);
        assert_eq!(differing, 0, "{src}: {differing} pixels differ");
        assert!(
            b.primary.leaves < a.primary.leaves,
            "{src}: {} leaf visits with hulls, {} without",
            b.primary.leaves,
            a.primary.leaves
        );
    }
}
