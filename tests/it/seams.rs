//! Split leaves whose two sides are quadratic along a ray answer pieces in
//! closed form: the answers are those the general search gives, for fewer
//! evaluations, through the seams where the sides meet and beside them.

use crate::common::{answer_alike, rays, Rng};
use glam::DVec3;
use lgc::ray::{Answer, Intersector};
use lgc::{Aabb, Formula};

/// CSG of planes and quadrics (every split leaf's sides are quadratic), with
/// points on their seams: where the two sides of a max or min are both 0.
fn shapes() -> Vec<(&'static str, Vec<DVec3>)> {
    let circle = |centre: DVec3, u: DVec3, v: DVec3, r: f64| -> Vec<DVec3> {
        (0..24)
            .map(|k| {
                let a = std::f64::consts::TAU * f64::from(k) / 24.0;
                centre + r * (a.cos() * u + a.sin() * v)
            })
            .collect()
    };
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    // The cube minus a ball: the holes' rims, radius √0.69, on each face.
    let mut rims = Vec::new();
    for (n, u, v) in [(x, y, z), (y, z, x), (z, x, y)] {
        for s in [-1.0, 1.0] {
            rims.extend(circle(s * n, u, v, 0.69f64.sqrt()));
        }
    }
    vec![
        ("max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))", rims),
        // The ball cut by a plane: the rim at z = 0.3.
        (
            "max(x^2+y^2+z^2-1, z-0.3)",
            circle(0.3 * z, x, y, 0.91f64.sqrt()),
        ),
        // Two balls' union: where they meet, x = 0.
        (
            "min((x-0.5)^2+y^2+z^2-0.36, (x+0.5)^2+y^2+z^2-0.36)",
            circle(DVec3::ZERO, y, z, 0.11f64.sqrt()),
        ),
    ]
}

/// Rays through each seam point pushed off by 10⁻³ to 10⁻¹² (and not at
/// all), from random places around the box.
fn seam_rays(rng: &mut Rng, points: &[DVec3]) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for &p in points {
        for k in [0, 3, 6, 9, 12] {
            let push = if k == 0 { 0.0 } else { 10f64.powi(-k) };
            let target = p + push * DVec3::from(rng.direction());
            let d = DVec3::from(rng.direction());
            out.push((target - 4.0 * d, d));
        }
    }
    out
}

#[test]
fn split_leaves_answer_alike_in_closed_form_and_by_search() {
    let mut rng = Rng::new(2026);
    for (src, points) in shapes() {
        let f = Formula::parse(src).unwrap();
        let bounds = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
        let tol = 1e-10 * (bounds.hi - bounds.lo).length();
        let scene = Intersector::new(&f, &bounds, 5);
        let (mut searched, mut solved) = (scene.tracer(), scene.tracer());
        searched.set_closed_form_seams(false);
        let mut all = rays(&mut rng, &f);
        all.extend(seam_rays(&mut rng, &points));
        let mut hits = 0;
        for ray in all {
            let answer = answer_alike(&format!("{src}: "), &mut searched, &mut solved, ray, tol);
            hits += usize::from(matches!(answer, Answer::Hit(_)));
        }
        // Not vacuous: many hits, many pieces answered in closed form, none
        // by the reference, and fewer evaluations for them.
        assert!(hits > 300, "{src}: {hits} hits");
        assert_eq!(searched.stats.seams, 0);
        assert!(
            solved.stats.seams > 20,
            "{src}: {} pieces in closed form",
            solved.stats.seams
        );
        assert!(
            solved.stats.f_evals < searched.stats.f_evals,
            "{src}: {} evaluations in closed form, {} by search",
            solved.stats.f_evals,
            searched.stats.f_evals
        );
    }
}

#[test]
fn rays_along_a_seam_are_answered_alike() {
    // Rays lying in the plane of the cube minus a ball's face, x = 1, across
    // its hole's rim: the plane side is 0 along the whole ray, where no
    // closed-form bracket can be proved; and rays just inside and outside it.
    let f = Formula::parse("max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))").unwrap();
    let bounds = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
    let tol = 1e-10 * (bounds.hi - bounds.lo).length();
    let scene = Intersector::new(&f, &bounds, 5);
    let (mut searched, mut solved) = (scene.tracer(), scene.tracer());
    searched.set_closed_form_seams(false);
    let mut rng = Rng::new(7);
    for k in 0..200 {
        let x = 1.0 + [0.0, 1e-12, -1e-12, 1e-7, -1e-7][k % 5];
        let a = std::f64::consts::TAU * rng.next_u64() as f64 / u64::MAX as f64;
        let d = DVec3::new(0.0, a.cos(), a.sin());
        let o = DVec3::new(x, 0.0, 0.0) - 1.5 * d
            + 0.4 * (rng.next_u64() % 3) as f64 * DVec3::new(0.0, -d.z, d.y);
        answer_alike("along the face: ", &mut searched, &mut solved, (o, d), tol);
    }
}
