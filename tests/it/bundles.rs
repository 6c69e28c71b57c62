//! Bundles of camera rays: the space a bundle proves empty holds no root of
//! any of its rays, rays started there answer as rays started at the eye, and
//! pictures do not change when bundles are off.

use crate::common::{corpus, Rng};
use glam::DVec3;
use lgc::ray::bundle::{clear_until, clear_until_listed, LeafList};
use lgc::ray::{Answer, Intersector};
use lgc::render::{render, Camera, RenderSettings, Shading};
use lgc::{Aabb, Formula};

/// Corpus surfaces, the CSG shapes, and formulas undefined or unbounded on
/// part of the box.
fn surfaces() -> Vec<(String, Aabb)> {
    let mut all: Vec<(String, Aabb)> = corpus()
        .into_iter()
        .map(|s| {
            let b = Aabb::new(DVec3::from(s.lo), DVec3::from(s.hi)).unwrap();
            (s.expr, b)
        })
        .collect();
    let cube = Aabb::new(DVec3::splat(-1.2), DVec3::splat(1.2)).unwrap();
    for expr in [
        "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-1)",
        "max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))",
        "min(min((x-0.5)^2+y^2+z^2-0.36, (x+0.5)^2+y^2+z^2-0.36), x^2+(y-0.6)^2+z^2-0.25)",
        "sqrt(x) + y^2 + z^2 - 0.5",
        "1/(x+0.3) - y",
    ] {
        all.push((expr.to_string(), cube));
    }
    all
}

/// The t of an answer, with whether it is a miss.
fn t_of(a: Answer) -> Option<f64> {
    a.t()
}

#[test]
fn bundles_never_pass_a_root_and_rays_started_there_answer_the_same() {
    let mut rng = Rng::new(0xb0d1e5);
    let (mut bundles, mut listed_sweeps, mut rays_with_roots) = (0, 0, 0);
    // Sweeps that proved something, and that proved every ray leaves the box
    // before any root (+∞): walking the octree, and over a list.
    let (mut moved, mut passed_through) = ([0; 2], [0; 2]);
    let mut list = LeafList::default();
    for (expr, b) in surfaces() {
        let f = Formula::parse(&expr).unwrap();
        let scene = Intersector::new(&f, &b, 4);
        let mut tracer = scene.tracer();
        let size = (b.hi - b.lo).length();
        let tolerance = 1e-10 * size;
        for _ in 0..12 {
            let (eye, directions) = tile_of_rays(&mut rng, &b);
            let entry = directions
                .iter()
                .filter_map(|&d| entry_into(&b, eye, d))
                .fold(f64::INFINITY, f64::min);
            // The sweep walking the octree, and the sweep over the tile's
            // list of leaves (where the list was kept).
            let mut clears = vec![(false, clear_until(&mut tracer, &b, eye, &directions, 0.0))];
            if list.gather(&tracer, eye, &directions, 0.0) {
                clears.push((true, clear_until_listed(&mut tracer, &b, &list)));
            }
            for (listed, clear) in clears {
                bundles += usize::from(!listed);
                listed_sweeps += usize::from(listed);
                passed_through[usize::from(listed)] += usize::from(clear == f64::INFINITY);
                if entry.is_finite() && clear > entry {
                    moved[usize::from(listed)] += 1;
                }
                for &d in &directions {
                    let from_eye = tracer.answer(eye, d, 0.0, f64::INFINITY);
                    let from_clear = tracer.answer(eye, d, clear, f64::INFINITY);
                    let slack = 8.0 * tolerance / d.length();
                    if let Some(t) = t_of(from_eye) {
                        rays_with_roots += 1;
                        assert!(
                            t >= clear - slack,
                            "{expr}: the bundle proved [0, {clear}] empty, but {eye} + t·{d} meets the surface at {t} ({from_eye:?})"
                        );
                    }
                    match (t_of(from_eye), t_of(from_clear)) {
                        (Some(a), Some(c)) => assert!(
                            (a - c).abs() <= slack,
                            "{expr}: {eye} + t·{d}: {from_eye:?} from the eye, {from_clear:?} from {clear}"
                        ),
                        (None, None) => {}
                        _ => panic!(
                            "{expr}: {eye} + t·{d}: {from_eye:?} from the eye, {from_clear:?} from {clear}"
                        ),
                    }
                }
            }
        }
    }
    // Not vacuous: most bundles that enter a box prove some of it empty, and
    // many rays meet a surface; so do sweeps over lists.
    assert!(
        moved[0] * 2 > bundles && moved[1] * 2 > listed_sweeps && listed_sweeps * 2 > bundles,
        "of {bundles} bundles, {moved:?} proved anything ({listed_sweeps} over lists)"
    );
    assert!(
        rays_with_roots > 2000,
        "{rays_with_roots} rays met a surface"
    );
    assert!(
        passed_through[0] * 20 > bundles && passed_through[1] * 20 > listed_sweeps,
        "only {passed_through:?} of {bundles} bundles were proved to pass through"
    );
}

/// An eye outside the box `b`, looking at a point in it through a narrow
/// cone of 6×6 rays, like one tile of a picture.
fn tile_of_rays(rng: &mut Rng, b: &Aabb) -> (DVec3, Vec<DVec3>) {
    let size = (b.hi - b.lo).length();
    let away = DVec3::from(rng.direction()).normalize_or(DVec3::X);
    let eye = b.center() + away * size * rng.uniform(0.8, 2.0);
    let target = DVec3::from(rng.point(b.lo.into(), b.hi.into()));
    let forward = (target - eye).normalize();
    let right = forward.any_orthonormal_vector();
    let up = forward.cross(right);
    let width = rng.uniform(0.002, 0.06);
    let directions = (0..36)
        .map(|k| {
            let (u, v) = ((k % 6) as f64 / 5.0 - 0.5, (k / 6) as f64 / 5.0 - 0.5);
            (forward + width * (u * right + v * up)).normalize()
        })
        .collect();
    (eye, directions)
}

#[test]
fn rays_over_a_leaf_list_answer_as_rays_that_walk_the_octree() {
    // The same answers to the bit, and the same normals (which depend on
    // the leaf that found the hit), from a tile's list of leaves and from
    // quarters of it, as from walking the octree.
    let mut rng = Rng::new(0x1157);
    let (mut lists, mut hits, mut cut_short) = (0, 0, 0);
    let (mut tile, mut quarter) = (LeafList::default(), LeafList::default());
    for (expr, b) in surfaces() {
        let f = Formula::parse(&expr).unwrap();
        let scene = Intersector::new(&f, &b, 5);
        let mut tracer = scene.tracer();
        for _ in 0..12 {
            let (eye, directions) = tile_of_rays(&mut rng, &b);
            // As a picture's tiles: the list, the sweep over it, and the
            // list from where the sweep ends.
            if !tile.gather(&tracer, eye, &directions, 0.0) {
                continue;
            }
            let clear = clear_until_listed(&mut tracer, &b, &tile);
            if clear == f64::INFINITY {
                continue;
            }
            tile.advance(clear);
            lists += usize::from(!tile.is_empty());
            let some = &directions[..12];
            let (lo, hi) = some
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &d| {
                    (lo.min(d), hi.max(d))
                });
            quarter.narrow(&tracer, &tile, lo, hi);
            for (list, rays) in [(&tile, &directions[..]), (&quarter, some)] {
                for &d in rays {
                    let listed = tracer.first_hit_in(list, eye, d, clear);
                    let listed_normal = listed.and_then(|t| tracer.normal(eye + t * d));
                    let walked = tracer.first_hit(eye, d, clear, f64::INFINITY);
                    let walked_normal = walked.and_then(|t| tracer.normal(eye + t * d));
                    assert_eq!(
                        (listed.map(f64::to_bits), listed_normal),
                        (walked.map(f64::to_bits), walked_normal),
                        "{expr}: {eye} + t·{d} from {clear}"
                    );
                    hits += usize::from(listed.is_some());
                    // Up to a limit (a nearer object's hit, in a scene):
                    // one around the hit, which cuts some rays short.
                    let limit = walked.unwrap_or(clear + 1.0) * rng.uniform(0.9, 1.1);
                    let listed = tracer.first_hit_in_until(list, eye, d, clear, limit);
                    let walked = tracer.first_hit(eye, d, clear, limit);
                    assert_eq!(
                        listed.map(f64::to_bits),
                        walked.map(f64::to_bits),
                        "{expr}: {eye} + t·{d} on [{clear}, {limit}]"
                    );
                    cut_short += usize::from(listed.is_none() && walked_normal.is_some());
                }
            }
        }
    }
    assert!(
        lists > 50 && hits > 1000 && cut_short > 100,
        "{lists} lists, {hits} hits, {cut_short} cut short by a limit"
    );
}

/// Where the ray `o + t·d` enters the box (t ≥ 0), if it does.
fn entry_into(b: &Aabb, o: DVec3, d: DVec3) -> Option<f64> {
    let (mut near, mut far) = (0.0f64, f64::INFINITY);
    for i in 0..3 {
        let (t0, t1) = ((b.lo[i] - o[i]) / d[i], (b.hi[i] - o[i]) / d[i]);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    (near <= far).then_some(near)
}

#[test]
fn pictures_do_not_change_when_bundles_are_off() {
    for (expr, b) in surfaces().into_iter().step_by(3) {
        let f = Formula::parse(&expr).unwrap();
        let scene = Intersector::new(&f, &b, 4);
        let eye = b.center() + (b.hi - b.lo) * DVec3::new(1.1, -1.5, 1.0);
        let camera = Camera::new(eye, b.center(), DVec3::Z, 30.0, 64, 48).unwrap();
        let shading = Shading::studio(camera.basis(), DVec3::new(0.9, 0.5, 0.2));
        let image = |bundles: bool| {
            let settings = RenderSettings {
                width: 64,
                height: 48,
                samples: 1,
                shadows: true,
                bundles,
            };
            render(&scene, &camera, &shading, &settings, &|| {})
        };
        let (with, without) = (image(true), image(false));
        // Hits placed from other starting points agree to the tolerance, so
        // a channel may round to the next level, and no further.
        let off: Vec<u8> = with
            .rgb
            .iter()
            .zip(&without.rgb)
            .map(|(a, b)| a.abs_diff(*b))
            .collect();
        let moved = off.iter().filter(|&&d| d > 0).count();
        assert!(
            off.iter().all(|&d| d <= 1) && moved * 200 <= off.len(),
            "{expr}: {moved} channels differ, by up to {}",
            off.iter().max().unwrap()
        );
        assert_eq!(with.primary.rays, without.primary.rays);
        assert_eq!(with.primary.hits, without.primary.hits, "{expr}");
    }
}
