//! Rays against a formula that is affine over its whole box (a plane): F
//! along a ray is then a line, so two enclosures at the ends of its range
//! decide a miss, and two around the root a hit, with no octree walk.
//!
//! The certificate is the general search's: a hit is a sign change enclosed
//! within a thousandth of the tolerance, a miss is F keeping one certified
//! sign over the whole range (a line has no other root). Where an end's
//! enclosure holds 0 (a ray starting on the plane, or running along it),
//! `Affine::answer` declines and the general search answers.

use crate::types::geom::norm;
use glam::DVec3;

use crate::types::Interval;

use crate::ray::answer::Answer;
use crate::types::rounding::{up_few, ROUNDINGS_31};

/// f(p) = f(c) + ∇f·(p − c) on the padded box, with f(c) and the constant
/// ∇f known to within a radius of the f64 values kept.
#[derive(Debug, Clone, Copy)]
pub struct Affine {
    /// The point c (the box's centre).
    at: DVec3,
    /// f(c) is within `value_radius` of this.
    value: f64,
    value_radius: f64,
    /// ∇f is within `gradient_radius` of this, component by component.
    gradient: DVec3,
    gradient_radius: DVec3,
    /// A bound of |∇f| (for the normal's reliability test after a hit).
    lipschitz: f64,
}

/// A bound of the rounding errors of a few dozen operations on the sizes
/// they add up: each is off by at most u relative, and `F̃` takes at most
/// ten in a row (γ₁₀ < 11u), so 32u leaves room for the bound's own rounding.
const ROUNDING: f64 = ROUNDINGS_31;

/// F(t) = f(o + t·d) for a ray: the f64 line `start + t·slope` with a bound
/// of its distance to the real F, `radius + t·spread` up to rounding.
#[derive(Debug, Clone, Copy)]
struct Line {
    start: f64,
    slope: f64,
    /// What the enclosures' radii and the roundings of `start` add.
    radius: f64,
    /// What they add per unit of |t|.
    spread: f64,
}

impl Line {
    /// F's sign at `t` when its f64 value certifies it (±1), else 0.
    #[inline(always)]
    fn sign(&self, t: f64) -> i8 {
        let v = self.start + t * self.slope;
        let err = up_few(self.radius + t.abs() * self.spread + ROUNDING * v.abs());
        if v > err {
            1
        } else if v < -err {
            -1
        } else {
            0
        }
    }
}

/// Half the width of the enclosure `v` about `m`, rounded up; exactly 0 for
/// a point. (Rounding 0 up to the least normal would make every product of
/// the radius with a coordinate below 1 subnormal, and on Intel cores each
/// such product takes a microcode assist: a third of a plane scene's time.
/// A difference of f64 values is 0 only where they are equal, so 0 is exact.)
fn radius_about(v: Interval, m: f64) -> f64 {
    let r = (v.sup() - m).max(m - v.inf());
    if r == 0.0 {
        0.0
    } else {
        up_few(r)
    }
}

impl Affine {
    /// The form from f's enclosure at `at` and ∇f's over the box, for a
    /// formula whose interval Hessian over the box is exactly 0 and whose
    /// derivatives are defined and continuous there (so ∇f is constant on
    /// the box, and f affine on it); `None` if an enclosure is unbounded.
    pub(crate) fn new(at: DVec3, value: Interval, gradient: [Interval; 3]) -> Option<Affine> {
        let bounded = |v: &Interval| !v.is_empty() && v.is_bounded();
        if !(bounded(&value) && gradient.iter().all(bounded) && at.is_finite()) {
            return None;
        }
        let g = DVec3::from(gradient.map(Interval::mid));
        let gradient_radius = DVec3::new(
            radius_about(gradient[0], g[0]),
            radius_about(gradient[1], g[1]),
            radius_about(gradient[2], g[2]),
        );
        Some(Affine {
            at,
            value: value.mid(),
            value_radius: radius_about(value, value.mid()),
            gradient: g,
            gradient_radius,
            lipschitz: up_few(norm(g.abs() + gradient_radius)),
        })
    }

    /// The unit normal, ∇f's direction (the same at every point).
    pub fn normal(&self) -> Option<DVec3> {
        // Scaled by its largest component first: |∇f| itself may overflow.
        let g = self.gradient;
        (g / g.abs().max_element()).try_normalize()
    }

    /// A bound of |∇f|.
    pub fn lipschitz(&self) -> f64 {
        self.lipschitz
    }

    /// F along the ray `o + t·d`. Each real term g_i·(o_i − c_i + t·d_i)
    /// is within rad(g_i)·(|o_i| + |c_i| + |t|·|d_i|) of the f64 gradient's,
    /// and the f64 sums are within [`ROUNDING`] of the sizes they add.
    #[inline(always)]
    fn line(&self, o: DVec3, d: DVec3) -> Line {
        let offset = o - self.at;
        let g = self.gradient;
        let start = self.value + g.dot(offset);
        let slope = g.dot(d);
        let size = self.value.abs() + g.abs().dot(o.abs() + self.at.abs());
        let spread = self.gradient_radius.dot(d.abs()) + ROUNDING * g.abs().dot(d.abs());
        let radius =
            self.value_radius + self.gradient_radius.dot(o.abs() + self.at.abs()) + ROUNDING * size;
        Line {
            start,
            slope,
            radius: up_few(radius),
            spread: up_few(spread),
        }
    }

    /// The certified answer for the ray `o + t·d` on `[t0, t1]` (its range
    /// in the box), placing a hit within `place` of the root, with the
    /// number of evaluations taken; `None` where a value cannot decide (the
    /// general search answers).
    #[inline]
    pub(crate) fn answer(
        &self,
        o: DVec3,
        d: DVec3,
        t0: f64,
        t1: f64,
        place: f64,
    ) -> Option<(Answer, u64)> {
        let line = self.line(o, d);
        let (s0, s1) = (line.sign(t0), line.sign(t1));
        if s0 == 0 || s1 == 0 {
            return None;
        }
        if s0 == s1 {
            return Some((Answer::Miss, 2));
        }
        // One root, strictly inside: where the f64 line crosses 0,
        // certified by the signs a little before and after it.
        let estimate = -line.start / line.slope;
        if !(estimate > t0 && estimate < t1) {
            return None;
        }
        let (a, b) = ((estimate - place).max(t0), (estimate + place).min(t1));
        let sa = if a == t0 { s0 } else { line.sign(a) };
        let sb = if b == t1 { s1 } else { line.sign(b) };
        (sa == s0 && sb == s1).then_some((Answer::Hit(estimate), 4))
    }
}

#[cfg(test)]
mod tests {
    use crate::expr::Evaluator;
    use crate::formula::{Formula, Output};
    use crate::ray::test_rng::Rng;
    use crate::ray::{Answer, Intersector};
    use crate::types::{Aabb, Interval};
    use glam::DVec3;

    const PLANES: [&str; 6] = [
        "z + 0.5",
        "0.1*x + 0.3*y - 0.7*z + 0.2",
        "(x - 2*y + 3*z)/7 - 0.05",
        "2*(x + 0.1) - (y - 0.3)*0.7 + z/3",
        // Coefficients far apart in size: the bound of the rounding holds.
        "1e200*x + z - 0.1",
        "1e-200*x + z - 0.1",
    ];

    fn unit_box() -> Aabb {
        Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap()
    }

    /// F's sign at `o + t·d`, from an enclosure of the point and of f there
    /// (0 when it holds 0): independent of both searches.
    fn enclosed_sign(f: &Formula, o: DVec3, d: DVec3, t: f64) -> i8 {
        let tape = f.tape(&[Output::F]);
        let mut eval = Evaluator::<Interval>::new(&tape);
        let p = |i: usize| Interval::point(o[i]) + Interval::point(t) * Interval::point(d[i]);
        let zero = Interval::point(0.0);
        let v = eval.eval(&[p(0), p(1), p(2), zero, zero, zero])[0];
        if v.inf() > 0.0 {
            1
        } else if v.sup() < 0.0 {
            -1
        } else {
            0
        }
    }

    #[test]
    fn exact_plane_radii_are_zero_not_the_least_normal_whose_products_are_subnormal() {
        // Every radius is 0 or far enough above the least normal that its
        // products with coordinates down to 1e-6 stay normal, so the line's
        // bound costs no subnormal arithmetic.
        let clear = |r: f64| r == 0.0 || r * 1e-6 >= f64::MIN_POSITIVE;
        for src in PLANES {
            let f = Formula::parse(src).unwrap();
            let scene = Intersector::new(&f, &unit_box(), 4);
            let a = scene.tracer().octree().affine.unwrap();
            assert!(clear(a.value_radius), "{src}: {a:?}");
            assert!(
                a.gradient_radius.to_array().into_iter().all(clear),
                "{src}: {a:?}"
            );
        }
        // A plane whose value and gradient are exact has no radius at all.
        let f = Formula::parse("z + 0.5").unwrap();
        let a = Intersector::new(&f, &unit_box(), 4)
            .tracer()
            .octree()
            .affine
            .unwrap();
        assert_eq!((a.value_radius, a.gradient_radius), (0.0, DVec3::ZERO));
    }

    #[test]
    fn only_formulas_affine_over_the_box_are_answered_in_closed_form() {
        for src in PLANES {
            let f = Formula::parse(src).unwrap();
            let scene = Intersector::new(&f, &unit_box(), 4);
            assert!(scene.tracer().octree().affine.is_some(), "{src}");
        }
        // Curved, however slightly; creased; or affine only where the
        // search would first have to prove a branch settled.
        for src in [
            "x^2 + y^2 + z^2 - 1",
            "z - 0.5 + 1e-12*x^2",
            "abs(z) - 0.5",
            "max(z - 0.5, x - 2)",
            "z*y - 0.5",
        ] {
            let f = Formula::parse(src).unwrap();
            let scene = Intersector::new(&f, &unit_box(), 4);
            assert!(scene.tracer().octree().affine.is_none(), "{src}");
        }
    }

    #[test]
    fn planes_answered_in_closed_form_agree_with_the_search_and_an_enclosure() {
        let mut rng = Rng(0x5eed_affe);
        let mut hits = 0;
        let mut misses = 0;
        let mut leaving = 0;
        for src in PLANES {
            let f = Formula::parse(src).unwrap();
            let scene = Intersector::new(&f, &unit_box(), 4);
            let mut closed = scene.tracer();
            let mut search = scene.tracer();
            search.set_closed_form_planes(false);
            let tol = 1e-10 * (2.0 * 3f64.sqrt());
            for k in 0..3_000 {
                // From outside towards a point of the box; a quarter from a
                // surface point of the plane (shadow and reflected rays),
                // some nearly along it.
                let target = rng.vec();
                let (o, d, t_min) = match k % 4 {
                    0 => {
                        // A root of the first search, as a start point.
                        let o = rng.vec() * 3.0;
                        let Some(t) = search.first_hit(o, target - o, 0.0, f64::INFINITY) else {
                            continue;
                        };
                        let p = o + t * (target - o);
                        leaving += 1;
                        (p, rng.vec(), 1e-7)
                    }
                    1 => {
                        let o = rng.vec() * 3.0;
                        let n = closed.normal(DVec3::ZERO).unwrap();
                        let along = (target - o).reject_from(n) + n * 1e-9 * rng.between(-1.0, 1.0);
                        (o, along, 0.0)
                    }
                    _ => {
                        let o = rng.vec() * 3.0;
                        (o, target - o, 0.0)
                    }
                };
                let (a, b) = (
                    closed.answer(o, d, t_min, f64::INFINITY),
                    search.answer(o, d, t_min, f64::INFINITY),
                );
                let tol_t = tol / d.length();
                match (a, b) {
                    (Answer::Hit(ta), Answer::Hit(tb)) => {
                        // (The search counts a bracket up to eight
                        // tolerances wide as placed where rounding noise
                        // hides F's sign, as with a gradient of 1e200.)
                        assert!(
                            (ta - tb).abs() <= 8.0 * tol_t,
                            "{src}: {o} + t·{d}: {ta} vs {tb}"
                        );
                        // The root is enclosed: F changes sign across
                        // [ta − tol, ta + tol].
                        let (s0, s1) = (
                            enclosed_sign(&f, o, d, ta - tol_t),
                            enclosed_sign(&f, o, d, ta + tol_t),
                        );
                        assert!(s0 * s1 == -1, "{src}: {o} + t·{d} at {ta}: {s0} {s1}");
                        hits += 1;
                    }
                    (Answer::Miss, Answer::Miss) => misses += 1,
                    // Only where F's value cannot decide does the closed form
                    // hand the ray to the search, which then answers alike.
                    (a, b) => assert_eq!(a, b, "{src}: {o} + t·{d}"),
                }
            }
            // The closed form answered nearly every ray that met the box
            // itself; the search none.
            let (c, s) = (closed.stats, search.stats);
            assert!(c.closed_form >= c.leaves - c.leaves / 50, "{src}: {c:?}");
            assert!(
                c.closed_form > c.rays / 2 && s.closed_form == 0,
                "{src}: {c:?} {s:?}"
            );
        }
        assert!(
            hits > 3_000 && misses > 1_000 && leaving > 500,
            "{hits} {misses} {leaving}"
        );
    }
}
