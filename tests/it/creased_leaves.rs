//! Creased leaves (a `min`, `max` or `abs` left open in them): the march
//! along a ray's first piece, and the further level for boxes where f may
//! be undefined.

use crate::common::{answer_alike, rays, Rng};
use glam::DVec3;
use lgc::ray::octree::{BuildOptions, Octree};
use lgc::ray::Intersector;
use lgc::{Aabb, Formula};

/// Soft blends as the bear model writes them (`-ln(e^(-k·a) + e^(-k·b))/k`)
/// of a `min` and a `max`: every leaf near the surface is creased, and its
/// f runs as machine code.
const BLENDS: &str = "-ln(exp(-12*min(sqrt(x^2+y^2+z^2)-0.9, sqrt((x-0.8)^2+y^2+z^2)-0.5)) \
     + exp(-12*max(abs(z)-0.3, sqrt(x^2+(y-0.7)^2)-0.4)))/12";

/// A union whose second part divides by x, as the bear's ears do: f is
/// undefined on the plane x = 0, where the quotient's part tends to +∞ and
/// the union takes the ball.
const POLE: &str = "min(sqrt(x^2+y^2+z^2)-0.9, max(abs(y-0.05/x)-0.3, abs(z)-0.5))";

fn cube(side: f64) -> Aabb {
    Aabb::new(DVec3::splat(-side), DVec3::splat(side)).unwrap()
}

/// The march only moves a piece's start past what F's Lipschitz bound
/// proves clear: rays answer as the search by halving and enclosures
/// alone does (the same roots, to the tolerance), and with fewer
/// enclosures, spent on values of f instead.
#[test]
fn marching_creased_leaves_answers_as_halving_does() {
    let bounds = cube(1.5);
    let tol = 1e-10 * (bounds.hi - bounds.lo).length();
    let mut rng = Rng::new(61);
    for src in [BLENDS, POLE] {
        let f = Formula::parse(src).unwrap();
        let ix = Intersector::with_options(&f, &bounds, &BuildOptions::to_depth(5));
        let (mut halving, mut marching) = (ix.tracer(), ix.tracer());
        halving.set_march(false);
        for ray in rays(&mut rng, &f) {
            answer_alike(&format!("{src}: "), &mut halving, &mut marching, ray, tol);
        }
        let (h, m) = (&halving.stats, &marching.stats);
        if src != BLENDS {
            // Few creased leaves are left open here: its branches settle.
            continue;
        }
        if cfg!(feature = "jit") {
            assert!(
                m.interval_evals * 10 < h.interval_evals * 9 && m.f_evals > h.f_evals,
                "{src}: {} interval and {} point evaluations marching, {} and {} halving",
                m.interval_evals,
                m.f_evals,
                h.interval_evals,
                h.f_evals
            );
        } else {
            // Interpreted f: no march.
            assert_eq!(m.interval_evals, h.interval_evals, "{src}");
        }
    }
}

/// The volume of the leaves with no Lipschitz bound (f may be undefined
/// in them), and the number of leaves.
fn unbounded_volume(octree: &Octree) -> (f64, usize) {
    let mut volume = 0.0;
    for node in &octree.nodes {
        if let Some(i) = node.leaf_index() {
            if !octree.leaves[i].lipschitz.is_finite() {
                let s = node.bounds.hi - node.bounds.lo;
                volume += s.x * s.y * s.z;
            }
        }
    }
    (volume, octree.leaves.len())
}

/// Creased boxes the pole of a quotient crosses go a level further: the
/// leaves with no Lipschitz bound, where every piece of a ray takes an
/// enclosure, shrink to the boxes the plane x = 0 crosses, and rays answer
/// as without the level.
#[test]
fn boxes_where_f_may_be_undefined_go_a_level_deeper() {
    let bounds = cube(1.5);
    let tol = 1e-10 * (bounds.hi - bounds.lo).length();
    let f = Formula::parse(POLE).unwrap();
    let flat = BuildOptions {
        pole_levels: 0,
        ..BuildOptions::to_depth(5)
    };
    let (a, b) = (
        Intersector::with_options(&f, &bounds, &flat),
        Intersector::with_options(&f, &bounds, &BuildOptions::to_depth(5)),
    );
    let (without, leaves_without) = unbounded_volume(a.octree());
    let (with, leaves_with) = unbounded_volume(b.octree());
    assert!(
        without > 0.0,
        "no leaf without a bound: the test sees no pole"
    );
    assert!(
        leaves_with > leaves_without && with < 0.75 * without,
        "{leaves_with} leaves against {leaves_without}, unbounded volume {with} against {without}"
    );
    let (mut r, mut s) = (a.tracer(), b.tracer());
    let mut rng = Rng::new(67);
    for ray in rays(&mut rng, &f) {
        answer_alike(&format!("{POLE}: "), &mut r, &mut s, ray, tol);
    }
    assert!(
        s.stats.interval_evals < r.stats.interval_evals,
        "{} interval evaluations against {}",
        s.stats.interval_evals,
        r.stats.interval_evals
    );
}
