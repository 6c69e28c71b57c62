//! Short tapes: a tape with the branches a box decides taken computes the
//! same real function over the box, and rays answer alike with and without
//! them.

use crate::common::{answer_alike, rays, Rng};
use glam::DVec3;
use lgc::ray::octree::{
    BuildOptions, Kept, Octree, MAX_SHAPES, MAX_SHAPE_INSTRUCTIONS, SHAPE_WORTH,
};
use lgc::ray::{Answer, Intersector, Tracer};
use lgc::types::{DecInterval, Interval};
use lgc::{Aabb, Evaluator, Formula, Output};

/// Branches of every kind: unions and intersections, `abs`, `sign`,
/// `choose`, a blend, a step function, and a branch whose other side is
/// undefined in places.
const BRANCHING: &[&str] = &[
    "max(x^2+y^2+z^2-1, z-0.3)",
    "max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))",
    "min(min((x-0.6)^2+y^2+z^2-0.5, (x+0.6)^2+y^2+z^2-0.5), x^2+(y-0.6)^2+z^2-0.3)",
    "min(x^2+y^2+z^2-1, (x-1)^2+y^2+z^2-0.5) - max(0.3 - abs(x^2+y^2+z^2-1 - ((x-1)^2+y^2+z^2-0.5)), 0)^2/1.2",
    "sign(x)*0.2 + y^2 + z^2 - 1 + choose(z, 0.1, -0.1)*x^2",
    "min(x^2+y^2+z^2-1, sqrt(y) + 2) + floor(2*z)*0.01",
];

/// A union of `n` balls at random places, as CAD models and fidget's
/// examples are built: the formula any one region sees is one or two of
/// them.
fn balls(n: usize, seed: u64) -> String {
    let mut rng = Rng::new(seed);
    let mut f = String::new();
    for k in 0..n {
        let [x, y, z] = rng.point([-1.5; 3], [1.5; 3]);
        let r = rng.uniform(0.1, 0.3);
        let ball = format!("sqrt((x-{x})^2+(y-{y})^2+(z-{z})^2)-{r}");
        f = if k == 0 {
            ball
        } else {
            format!("min({f}, {ball})")
        };
    }
    f
}

/// A ball with `n` steps applied in turn, alternately a small translation
/// and a blend with another small ball, the balls packed closer than the
/// blend radius: every region sees dozens of blends.
fn chain_of_blends(n: u32) -> String {
    let mut src = String::from("x^2+y^2+z^2-0.25");
    for k in 0..n {
        src = if k % 2 == 0 {
            format!("translate({src}, 0.0003, 0.0002, 0)")
        } else {
            let (a, b) = (
                f64::from(k % 37) / 40.0 - 0.45,
                f64::from(k % 23) / 25.0 - 0.45,
            );
            format!("blend({src}, (x-{a})^2+(y-{b})^2+z^2-0.01, 0.05)")
        };
    }
    src
}

fn cube(side: f64) -> Aabb {
    Aabb::new(DVec3::splat(-side), DVec3::splat(side)).unwrap()
}

/// At random points of random boxes, the short tape's enclosure and the
/// tape's own (both of f and g at the point, in intervals) meet: they
/// enclose the same real numbers. A branch taken wrongly would give a
/// different value, and miss.
#[test]
fn short_tapes_enclose_the_same_values_as_their_tape_in_the_box() {
    let mut rng = Rng::new(41);
    let formulas: Vec<String> = BRANCHING
        .iter()
        .map(|s| s.to_string())
        .chain([balls(40, 7)])
        .collect();
    let mut shortened = 0;
    for src in &formulas {
        let f = Formula::parse(src).unwrap();
        let tape = f.tape(&[Output::F, Output::G]);
        for _ in 0..60 {
            let c = rng.point([-1.8; 3], [1.8; 3]);
            let half = rng.uniform(0.001, 0.6);
            let lo = c.map(|v| v - half);
            let hi = c.map(|v| v + half);
            let any = DecInterval::defined(Interval::ENTIRE);
            let [x, y, z] = [0, 1, 2].map(|k| DecInterval::defined(Interval::new(lo[k], hi[k])));
            let decisions = tape.settled_over(&[x, y, z, any, any, any]);
            let short = tape.shortened(&decisions);
            assert!(short.body().len() <= tape.body().len());
            shortened += usize::from(short.body().len() < tape.body().len());
            let mut long = Evaluator::<Interval>::new(&tape);
            let mut brief = Evaluator::<Interval>::new(&short);
            for _ in 0..20 {
                let p = rng.point(lo, hi);
                let d = rng.direction();
                let inputs = [p[0], p[1], p[2], d[0], d[1], d[2]].map(Interval::point);
                let a = long.eval(&inputs).to_vec();
                let b = brief.eval(&inputs).to_vec();
                for (k, (a, b)) in a.iter().zip(&b).enumerate() {
                    if a.is_empty() || b.is_empty() {
                        // Undefined at the point: so must the short tape be.
                        assert_eq!(a.is_empty(), b.is_empty(), "{src}, output {k} at {p:?}");
                        continue;
                    }
                    assert!(
                        a.inf() <= b.sup() && b.inf() <= a.sup(),
                        "{src}, output {k} at {p:?} in {lo:?}..{hi:?}: tape {a:?}, short {b:?}"
                    );
                }
            }
        }
    }
    // Most boxes decide something: the test is not vacuous.
    assert!(shortened > formulas.len() * 20, "{shortened} shortened");
}

/// The octree's options with short tapes on or off, and no specialised
/// shapes: every leaf's short tape then comes from the whole formula.
fn with_short(on: bool) -> BuildOptions {
    BuildOptions {
        short_tapes: on,
        specialise: false,
        ..BuildOptions::to_depth(5)
    }
}

#[test]
fn rays_answer_alike_with_and_without_short_tapes() {
    let mut rng = Rng::new(43);
    let bounds = cube(2.0);
    let tol = 1e-10 * (bounds.hi - bounds.lo).length();
    let formulas: Vec<String> = BRANCHING
        .iter()
        .map(|s| s.to_string())
        .chain([balls(30, 11)])
        .collect();
    for src in &formulas {
        let f = Formula::parse(src).unwrap();
        let reference = Intersector::with_options(&f, &bounds, &with_short(false));
        let short = Intersector::with_options(&f, &bounds, &with_short(true));
        let (mut r, mut s) = (reference.tracer(), short.tracer());
        for ray in rays(&mut rng, &f) {
            answer_alike(&format!("{src}: "), &mut r, &mut s, ray, tol);
        }
    }
}

/// Interval evaluations of the union of 30 balls' rays (seeded by `seed`)
/// with the tracer's defaults and with `reference` applied, after checking
/// that every ray answers the same, to the bit, both ways.
fn evaluations_against(seed: u64, reference: impl Fn(&mut Tracer)) -> (u64, u64) {
    let f = Formula::parse(&balls(30, 11)).unwrap();
    let octree = Intersector::with_options(&f, &cube(2.0), &with_short(true));
    let (mut default, mut other) = (octree.tracer(), octree.tracer());
    reference(&mut other);
    let mut rng = Rng::new(seed);
    for (o, d) in rays(&mut rng, &f) {
        let (a, b) = (
            default.answer(o, d, 0.0, f64::INFINITY),
            other.answer(o, d, 0.0, f64::INFINITY),
        );
        assert_eq!(a, b, "ray {o} {d}");
    }
    (default.stats.interval_evals, other.stats.interval_evals)
}

/// A piece of a ray cut in parts for its leaf's cells, and then halved by
/// the search where it was cut, takes the parts' enclosures already made,
/// its halves' and theirs: the same answers, to the bit, for fewer
/// evaluations.
#[test]
fn the_parts_of_a_cut_piece_are_enclosed_once() {
    let (k, n) = evaluations_against(47, |t| t.set_keep_parts(false));
    // Parts are looked up at every cut, not only where the search asks for
    // a whole piece: 0.72 of the evaluations here, 0.86 with the search's
    // pieces alone.
    assert!(k * 5 < n * 4, "{k} interval evaluations against {n}");
}

/// A piece cut in parts for its leaf's cells whose first half leaves every
/// test of the search open (F's enclosure holds 0, g's is unbounded) has
/// its second half enclosed only when the search gets there: the same
/// answers, to the bit, for fewer evaluations.
#[test]
fn a_cut_piece_open_in_its_first_half_is_not_enclosed_further() {
    let (l, e) = evaluations_against(53, |t| t.set_first_halves(false));
    assert!(l < e, "{l} interval evaluations against {e}");
}

/// Leaves without a compiled shape of their own (here, with specialisation
/// off) see a few balls of a union of 200, not all of them.
#[test]
fn a_union_of_many_balls_gets_short_tapes_in_its_leaves() {
    let f = Formula::parse(&balls(200, 13)).unwrap();
    let whole = f.tape(&[Output::F, Output::G]).body().len();
    let stats = Intersector::with_options(&f, &cube(2.0), &with_short(true)).octree_stats();
    assert!(stats.short_tapes > 0, "{stats:?}");
    let average = stats.short_instructions / stats.short_tapes;
    assert!(average * 10 < whole, "{average} of {whole}");
}

/// The cells of leaves that rays make: each tape of a cell at most half
/// the one it was cut from, and each clear cell holding no root: f's
/// enclosure over it excludes 0, and f at points sampled in it has that
/// sign (rays answer alike with them:
/// `rays_answer_alike_with_and_without_short_tapes`).
#[test]
fn cells_keep_tapes_at_most_half_their_parents_and_clear_ones_hold_no_root() {
    let f = Formula::parse(&balls(200, 13)).unwrap();
    let ix = Intersector::with_options(&f, &cube(2.0), &with_short(true));
    let mut rng = Rng::new(53);
    let mut tracer = ix.tracer();
    for (o, d) in rays(&mut rng, &f) {
        tracer.answer(o, d, 0.0, f64::INFINITY);
    }
    let octree = ix.octree();
    let whole = f.tape(&[Output::F]);
    let mut at = Evaluator::<Interval>::new(&whole);
    let (mut tapes, mut clear) = (0, 0);
    for leaf in 0..octree.short.of_leaf.len() {
        octree
            .short
            .each_cell(leaf, &octree.shapes, |b, kept, from| match kept {
                Kept::Parent => {}
                Kept::Tape(_, t) => {
                    let (len, parent) = (t.body().len(), from.body().len());
                    assert!(2 * len <= parent, "a cell's tape of {len} from {parent}");
                    tapes += 1;
                }
                Kept::Clear(e) => {
                    let e = e.interval();
                    assert!(!e.contains(0.0) && !e.is_empty(), "{e:?} over {b:?}");
                    for _ in 0..8 {
                        let p = rng.point(b.lo.to_array(), b.hi.to_array());
                        let zero = Interval::point(0.0);
                        let [x, y, z] = p.map(Interval::point);
                        let v = at.eval(&[x, y, z, zero, zero, zero])[0];
                        assert!(
                            v.inf() <= e.sup() && e.inf() <= v.sup(),
                            "f at {p:?} is {v:?}, outside the cell's {e:?}"
                        );
                    }
                    clear += 1;
                }
            });
    }
    assert!(
        tapes > 10 && clear > 10,
        "{tapes} tapes, {clear} clear cells"
    );
}

/// A hit's normal, found from its leaf's short tape, is the direction of
/// f's gradient there by the whole formula (the two differ only by
/// rounding): a short tape with a wrong branch would tilt it.
#[test]
fn normals_from_short_tapes_are_the_whole_formulas_gradient() {
    let mut rng = Rng::new(47);
    let f = Formula::parse(&balls(60, 19)).unwrap();
    let bounds = cube(2.0);
    let short = Intersector::with_options(&f, &bounds, &with_short(true));
    assert!(short.octree_stats().short_tapes > 0);
    let grad = f.tape(&[Output::Dfdx, Output::Dfdy, Output::Dfdz]);
    let mut grad = Evaluator::<f64>::new(&grad);
    let mut tracer = short.tracer();
    let mut hits = 0;
    for (o, d) in rays(&mut rng, &f) {
        let lgc::ray::Answer::Hit(t) = tracer.answer(o, d, 0.0, f64::INFINITY) else {
            continue;
        };
        let p = o + t * d;
        let g = grad.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
        let expected = DVec3::new(g[0], g[1], g[2]).normalize();
        let n = tracer.normal(p).unwrap();
        assert!(
            (n - expected).length() < 1e-9,
            "{o} {d}: {n} against {expected}"
        );
        hits += 1;
    }
    assert!(hits > 100, "{hits} hits");
}

/// A chain of 400 nested blends, each shape of it tens of thousands of
/// instructions, once compiled 512 shapes of 12 million instructions in all
/// (1.3 GB): the shapes stay within their instruction budget, creased ones
/// only where they are short against the whole formula.
#[test]
fn a_long_chain_of_blends_keeps_its_shapes_within_their_instruction_budget() {
    let f = Formula::parse(&chain_of_blends(400)).unwrap();
    let octree = Octree::build(&f, &cube(1.2), 5);
    let stats = &octree.stats;
    assert!(stats.shapes < MAX_SHAPES, "{stats:?}");
    assert!(
        stats.shape_instructions <= MAX_SHAPE_INSTRUCTIONS,
        "{stats:?}"
    );
    assert_creased_shapes_are_short(&octree);
}

/// Every shape past the whole formula that leaves two or more branch
/// points open has at most [`SHAPE_WORTH`] of the whole formula's f.
fn assert_creased_shapes_are_short(octree: &Octree) {
    let whole = octree.shapes[0].f.body().len() as f64;
    for (k, shape) in octree.shapes.iter().enumerate().skip(1) {
        let len = shape.f.body().len();
        assert!(
            shape.open <= 1 || len as f64 <= SHAPE_WORTH * whole,
            "shape {k}: {len} instructions of f, {} open, against {whole}",
            shape.open
        );
    }
}

/// A soft union of two balls, cut by three planes (fidget's bear is soft
/// blends around a few `min` and `max`): a region that settles one cut
/// but not the others still holds the whole blend and two creases. Such
/// shapes cost most of the bear's memory and a third of its build, for no
/// faster rays; the shapes where every cut settles (smooth) are still
/// compiled.
#[test]
fn creased_shapes_nearly_the_whole_formula_are_not_compiled() {
    let ball = |c: f64| format!("exp(-8*(sqrt((x-{c})^2+y^2+z^2)-0.5))");
    let blend = format!("-ln({} + {})/8", ball(0.3), ball(-0.3));
    let cut = format!("max(max(max({blend}, z-0.3), -0.4-y), x-0.5)");
    let f = Formula::parse(&cut).unwrap();
    let octree = Octree::build(&f, &cube(1.2), 5);
    assert_creased_shapes_are_short(&octree);
    let smooth = octree.shapes.iter().filter(|s| s.open == 0).count();
    assert!(smooth > 0, "{:?}", octree.stats);
}

/// Rays through a long chain of blends: F's natural enclosure over a piece
/// widens with every blend the piece cannot decide, and the mean-value form
/// (F at the middle, g's enclosure over the piece) excludes what it cannot.
/// Every answer agrees with f sampled along the ray, and rays take few
/// interval evaluations.
#[test]
fn rays_through_a_chain_of_blends_are_cleared_by_the_mean_value_form() {
    let f = Formula::parse(&chain_of_blends(200)).unwrap();
    let bounds = cube(1.2);
    let ix = Intersector::new(&f, &bounds, 5);
    let mut tracer = ix.tracer();
    let tape = f.tape(&[Output::F]);
    let mut e = Evaluator::<f64>::new(&tape);
    let mut f_at = |p: DVec3| e.eval(&[p.x, p.y, p.z, 0.0, 0.0, 0.0])[0];
    let mut rng = Rng::new(11);
    let (mut count, mut hits) = (0u64, 0);
    for (o, d) in rays(&mut rng, &f).into_iter().take(150) {
        let answer = tracer.answer(o, d, 0.0, f64::INFINITY);
        // Where the ray is inside the box, t in [enter, leave].
        let (lo, hi) = ((bounds.lo - o) / d, (bounds.hi - o) / d);
        let enter = lo.min(hi).max_element().max(0.0);
        let leave = lo.max(hi).min_element();
        if enter >= leave {
            assert!(matches!(answer, Answer::Miss), "{o} + t·{d}: {answer:?}");
            continue;
        }
        let end = match answer {
            Answer::Miss => leave,
            Answer::Hit(t) | Answer::Touch(t) => {
                hits += 1;
                t
            }
            Answer::Undecided(t) => panic!("{o} + t·{d}: undecided at {t}"),
        };
        // A sign change of f64 values well clear of 0, sampled before the
        // answer, is a root the answer missed.
        let samples = 4000;
        let mut last = f_at(o + enter * d);
        for i in 1..=samples {
            let t = enter + (end - enter) * f64::from(i) / f64::from(samples);
            if t > end - 1e-6 {
                break;
            }
            let v = f_at(o + t * d);
            assert!(
                !(last.abs() > 1e-9 && v.abs() > 1e-9 && last.signum() != v.signum()),
                "{o} + t·{d}: a root before {end} ({answer:?}), near t = {t}"
            );
            last = v;
        }
        count += 1;
    }
    let per_ray = tracer.stats.interval_evals as f64 / count as f64;
    assert!(hits > 20, "{hits} hits");
    // 23.5 here; 32.9 without the mean-value form.
    assert!(per_ray < 28.0, "{per_ray} interval evaluations per ray");
}
