//! How far the mesh in a certified cell lies from the surface: a bound for
//! each triangle from f's Taylor expansion on it and from f's slope along
//! one direction around the cell.
//!
//! Let D be the cell widened by ρ on every side, and let f be twice
//! continuously differentiable on D (the decorations say so), with
//! `|∇f| ≤ L`, `‖H‖ ≤ K` (the largest row sum of |H|, which bounds the
//! spectral norm of a symmetric matrix) and `∇f·u ≥ m > 0` for one unit
//! vector u. Take a triangle of the cell with corners vᵢ, each within rᵢ of
//! a root of f on its lattice edge. A point p = Σλᵢvᵢ of it has
//! `Σλᵢf(vᵢ) = f(p) + ½Σλᵢ(vᵢ−p)ᵀH(ξᵢ)(vᵢ−p)` (Taylor at p, the linear
//! terms summing to 0), and `Σλᵢ|vᵢ−p|² ≤ d²/3`, so `|f(p)| ≤ L·max rᵢ +
//! K·d²/6` with d the
//! triangle's longest side. Walking from p along −u where f(p) > 0 (along u
//! where f(p) < 0), f falls (rises) at least m a unit length while the walk
//! stays in D, so it meets 0 within `|f(p)|/m`; if that is at most ρ the walk
//! never leaves D. The triangle lies within that distance of the surface.

use crate::expr::DecoratedEvaluator;
use crate::types::interval::DecInterval;
use crate::types::rounding::up_bound;
use crate::types::{Aabb, Interval};
use glam::DVec3;

/// What a cell's neighbourhood says of f's first and second derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slope {
    /// A bound of |∇f| over the widened cell.
    pub gradient: f64,
    /// A bound of the Hessian's norm over the widened cell.
    pub hessian: f64,
    /// A lower bound of ∇f·u over it, for one unit vector u; positive.
    pub slope: f64,
    /// How far the cell was widened.
    pub reach: f64,
}

/// How far a cell is widened for its slope, as fractions of its shortest
/// side: a sixteenth, an eighth, a quarter, a half.
pub const WIDENINGS: [f64; 4] = [16.0, 8.0, 4.0, 2.0];

/// f's first or second derivatives may jump or be unbounded in a box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct NotSmooth;

/// f's first derivatives over a box, with bounds of |∇f| and of the
/// Hessian's norm there.
struct Derivatives {
    /// ∂f/∂x, ∂f/∂y, ∂f/∂z.
    g: [Interval; 3],
    /// A bound of |∇f|.
    gradient: f64,
    /// A bound of the Hessian's norm: the largest row sum of |H|.
    hessian: f64,
}

impl Derivatives {
    /// Over the box `xyz`, from an evaluator of [`OUTPUTS`]; `Err` where f's
    /// first or second derivatives may jump or be unbounded there.
    fn over(eval: &mut DecoratedEvaluator<'_>, xyz: [DecInterval; 3]) -> Result<Self, NotSmooth> {
        let zero = DecInterval::defined(Interval::ZERO);
        let [x, y, z] = xyz;
        let Some(out) = eval.eval_continuous(&[x, y, z, zero, zero, zero]) else {
            return Err(NotSmooth);
        };
        if out.iter().any(|v| !v.interval().is_bounded()) {
            return Err(NotSmooth);
        }
        let v: Vec<Interval> = out.iter().map(|v| v.interval()).collect();
        let (g, h) = ([v[0], v[1], v[2]], [v[3], v[4], v[5], v[6], v[7], v[8]]);
        let gradient = up_bound(g.iter().map(|x| x.mag() * x.mag()).sum::<f64>().sqrt());
        // Rows of H: (xx, xy, xz), (xy, yy, yz), (xz, yz, zz).
        let [xx, yy, zz, xy, xz, yz] = h.map(|x| x.mag());
        let hessian = up_bound((xx + xy + xz).max(xy + yy + yz).max(xz + yz + zz));
        Ok(Derivatives {
            g,
            gradient,
            hessian,
        })
    }
}

/// [`Slope::value`] for a box `b` with no slope: an upper bound of f(p) at a
/// point p = Σλᵢwᵢ of `n` points wᵢ of `b`, at most `span` apart, each where
/// f(wᵢ) < 0 or within `radius` of a root along a segment in `b`; `None`
/// where f's first or second derivatives may jump or be unbounded in `b`.
/// `eval` evaluates [`OUTPUTS`].
pub fn value_over(
    eval: &mut DecoratedEvaluator<'_>,
    b: &Aabb,
    radius: f64,
    span: f64,
    n: u32,
) -> Option<f64> {
    let d = Derivatives::over(eval, b.intervals().map(DecInterval::defined)).ok()?;
    Some(hull_value(d.gradient, d.hessian, radius, span, n))
}

/// An upper bound of f(p) at a point p = Σλᵢwᵢ (λᵢ ≥ 0, Σλᵢ = 1) of `n`
/// points wᵢ of a convex box where |∇f| ≤ L (`gradient`) and the Hessian's
/// norm is at most K (`hessian`), the points at most `span` apart and each
/// where f(wᵢ) < 0 or within `radius` of a root along a segment in the box:
/// `L·radius + K·span²·(n − 1)/4n`. With the signs swapped it bounds −f(p).
///
/// Taylor's theorem at p gives `f(p) = Σλᵢf(wᵢ) − ½Σλᵢ(wᵢ−p)ᵀH(ξᵢ)(wᵢ−p)`
/// (the linear terms sum to 0), and `Σλᵢ|wᵢ−p|² = Σᵢ<ⱼ λᵢλⱼ|wᵢ−wⱼ|²`,
/// at most `span²·(1 − Σλᵢ²)/2 ≤ span²·(1 − 1/n)/2`. A point of the hull
/// of more points in space is a convex combination of four of them
/// (Carathéodory), so `n` need never be over 4.
pub fn hull_value(gradient: f64, hessian: f64, radius: f64, span: f64, n: u32) -> f64 {
    let spread = f64::from(n - 1) / f64::from(4 * n);
    up_bound(gradient * radius + hessian * span * span * spread)
}

/// The outputs the evaluator passed to [`Slope::around`] computes, in order.
pub const OUTPUTS: [crate::formula::Output; 9] = {
    use crate::formula::Output::*;
    [Dfdx, Dfdy, Dfdz, Hxx, Hyy, Hzz, Hxy, Hxz, Hyz]
};

impl Slope {
    /// f's slope around the cell `b`, from `eval`, an evaluator of
    /// [`OUTPUTS`], for triangles whose corners are within `radius` of
    /// roots: the cell is widened by a sixteenth of its shortest side, then
    /// an eighth, a quarter and a half ([`WIDENINGS`]), until the widened
    /// box gives a slope whose walk from any such triangle stays in it, or
    /// until one shows f's derivatives may jump. A widening shorter than the
    /// walk a narrower box gave is skipped: a wider box's bounds hold the
    /// narrower one's, so its walk is seldom shorter. `None` where none
    /// does: f's first or second derivatives may jump or be unbounded
    /// there, no direction is found along which f rises throughout, or the
    /// surface curves too much for the cell's size.
    pub fn around(eval: &mut DecoratedEvaluator<'_>, b: &Aabb, radius: f64) -> Option<Slope> {
        Slope::around_from(eval, b, radius, 0).0
    }

    /// [`Slope::around`], with widening `first` (an index into
    /// [`WIDENINGS`]) tried before the others, and kept if it gives a slope:
    /// a neighbouring cell's widening, most often the one this cell needs.
    /// Where it gives none, the widenings are tried as [`Slope::around`]
    /// tries them. Returns the slope and the widening that gave it (`first`
    /// where none did).
    pub fn around_from(
        eval: &mut DecoratedEvaluator<'_>,
        b: &Aabb,
        radius: f64,
        first: usize,
    ) -> (Option<Slope>, usize) {
        let side = (b.hi - b.lo).min_element();
        let diagonal = up_bound((b.hi - b.lo).length());
        // Past a widening where f's derivatives may jump they may on every
        // wider box, whose enclosures hold this one's.
        let mut smooth = WIDENINGS.len();
        if first > 0 {
            match Slope::widened(eval, b, side / WIDENINGS[first]) {
                Ok(Some(slope)) if slope.walk(radius, diagonal, 4) <= slope.reach => {
                    return (Some(slope), first);
                }
                Ok(_) => {}
                Err(NotSmooth) => smooth = first,
            }
        }
        let mut walk = 0.0;
        for (i, k) in WIDENINGS.iter().enumerate().take(smooth) {
            let reach = side / k;
            // The widest box is always tried.
            if i == first && first > 0 || reach < walk && i + 1 < WIDENINGS.len() {
                continue;
            }
            let Ok(slope) = Slope::widened(eval, b, reach) else {
                return (None, first);
            };
            let Some(slope) = slope else {
                continue;
            };
            walk = slope.walk(radius, diagonal, 4);
            if walk <= slope.reach {
                return (Some(slope), i);
            }
        }
        (None, first)
    }

    /// [`Slope::around`] with the cell widened by `reach`: `Err` where f's
    /// first or second derivatives may jump or be unbounded there, `None`
    /// where no direction is found along which f rises throughout.
    fn widened(
        eval: &mut DecoratedEvaluator<'_>,
        b: &Aabb,
        reach: f64,
    ) -> Result<Option<Slope>, NotSmooth> {
        let wide = |a: usize| {
            // Widened outward: the box holds the cell and ρ around it.
            let lo = Interval::point(b.lo[a]) - Interval::point(reach);
            let hi = Interval::point(b.hi[a]) + Interval::point(reach);
            DecInterval::defined(Interval::new(lo.inf(), hi.sup()))
        };
        let Derivatives {
            g,
            gradient,
            hessian,
        } = Derivatives::over(eval, [wide(0), wide(1), wide(2)])?;
        let middle = DVec3::new(g[0].mid(), g[1].mid(), g[2].mid());
        let u = middle.normalize_or_zero();
        if u == DVec3::ZERO {
            return Ok(None);
        }
        // Interval arithmetic rounds outward, so the lower end is a lower
        // bound of ∇f·u for this (rounded) u, a unit vector up to a few
        // ulps, which only makes the walk a hair longer: `walk` allows for
        // |u| ≤ 1 + 1e-15.
        let along =
            g[0] * Interval::point(u.x) + g[1] * Interval::point(u.y) + g[2] * Interval::point(u.z);
        let slope = along.inf();
        Ok((slope > 0.0).then_some(Slope {
            gradient,
            hessian,
            slope,
            reach,
        }))
    }

    /// How far the walk from a point of a convex hull of `points` points
    /// goes at most, for points within `radius` of roots and at most `span`
    /// apart ([`Slope::value`] over the slope).
    fn walk(&self, radius: f64, span: f64, points: u32) -> f64 {
        self.walk_to(self.value(radius, span, points))
    }

    /// [`hull_value`] with this slope's bounds.
    pub fn value(&self, radius: f64, span: f64, n: u32) -> f64 {
        hull_value(self.gradient, self.hessian, radius, span, n)
    }

    /// How far a walk along ±u from a point where f = 0 goes, at most,
    /// before |f| passes `value`: `value` over the slope, times 1 + 1e-15
    /// for a direction whose length rounding put a few ulps past 1. From a
    /// point where |f| ≤ `value`, it bounds the walk to f = 0 likewise.
    pub fn walk_to(&self, value: f64) -> f64 {
        up_bound(value / self.slope * (1.0 + 1e-15))
    }

    /// A bound of the distance from every point of the triangle `corners`
    /// (each within `radii` of a root on its lattice edge in the cell) to
    /// the surface, or `None` if the walk might leave the widened cell.
    pub fn distance(&self, corners: [DVec3; 3], radii: [f64; 3]) -> Option<f64> {
        let side = |a: DVec3, b: DVec3| (a - b).length();
        let [a, b, c] = corners;
        let d = up_bound(side(a, b).max(side(b, c)).max(side(c, a)));
        let r = radii.into_iter().fold(0.0, f64::max);
        let walk = self.walk(r, d, 3);
        (walk <= self.reach).then_some(walk)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::Formula;

    /// On the sphere of radius 0.9, every sampled point of a triangle whose
    /// corners are near roots is within the bound of the sphere.
    #[test]
    fn triangles_near_a_sphere_are_within_their_bound() {
        let f = Formula::parse("x^2+y^2+z^2-0.81").unwrap();
        let tape = f.tape(&OUTPUTS);
        let mut eval = DecoratedEvaluator::new(&tape);
        let h = 1.0 / 64.0;
        let mut checked = 0;
        for k in 0..200 {
            // A cell around a point of the sphere, and a triangle of three
            // points of the sphere (moved off it by up to r) in the cell.
            let t = k as f64 * 0.1;
            let n = DVec3::new(
                t.cos() * (0.3 * t).sin(),
                t.sin() * (0.3 * t).sin(),
                (0.3 * t).cos(),
            );
            let centre = 0.9 * n;
            let b = Aabb::new(
                centre - DVec3::splat(h / 2.0),
                centre + DVec3::splat(h / 2.0),
            )
            .unwrap();
            let Some(slope) = Slope::around(&mut eval, &b, 2.0 * 1e-5) else {
                continue;
            };
            let r = 1e-5;
            let tangent = n.any_orthonormal_vector();
            let other = n.cross(tangent);
            let on = |p: DVec3| 0.9 * p.normalize();
            let corners = [
                on(centre + 0.4 * h * tangent) * (1.0 + r),
                on(centre - 0.4 * h * tangent),
                on(centre + 0.4 * h * other) * (1.0 - r),
            ];
            let Some(bound) = slope.distance(corners, [2.0 * r; 3]) else {
                continue;
            };
            for i in 0..=10 {
                for j in 0..=10 - i {
                    let (a, b) = (i as f64 / 10.0, j as f64 / 10.0);
                    let p =
                        corners[0] + a * (corners[1] - corners[0]) + b * (corners[2] - corners[0]);
                    let off = (p.length() - 0.9).abs();
                    assert!(off <= bound, "{p}: {off} past {bound}");
                }
            }
            checked += 1;
        }
        assert!(checked > 150, "only {checked} cells had a bound");
    }

    /// Starting from any widening finds a slope wherever the search from
    /// the narrowest does, and the same one where it starts at the widening
    /// that search settles on.
    #[test]
    fn a_slope_is_found_from_any_first_widening() {
        let f = Formula::parse("(sqrt(x^2+y^2)-0.6)^2+z^2-0.04").unwrap();
        let tape = f.tape(&OUTPUTS);
        let mut eval = DecoratedEvaluator::new(&tape);
        let (mut found, mut none) = (0, 0);
        for k in 0..400 {
            let t = k as f64 * 0.37;
            let centre = DVec3::new(
                (0.6 + 0.2 * t.cos()) * (2.1 * t).cos(),
                (0.6 + 0.2 * t.cos()) * (2.1 * t).sin(),
                0.2 * t.sin(),
            );
            let h = [1.0 / 64.0, 1.0 / 16.0, 1.0 / 4.0][k % 3];
            let b = Aabb::new(
                centre - DVec3::splat(h / 2.0),
                centre + DVec3::splat(h / 2.0),
            )
            .unwrap();
            let (slope, used) = Slope::around_from(&mut eval, &b, 1e-5, 0);
            assert_eq!(slope, Slope::around(&mut eval, &b, 1e-5));
            for first in 0..WIDENINGS.len() {
                let (other, _) = Slope::around_from(&mut eval, &b, 1e-5, first);
                assert_eq!(other.is_some(), slope.is_some(), "{b:?} from {first}");
            }
            if slope.is_some() {
                let again = Slope::around_from(&mut eval, &b, 1e-5, used).0;
                assert_eq!(again, slope);
                found += 1;
            } else {
                none += 1;
            }
        }
        assert!(found > 100 && none > 20, "{found} {none}");
    }

    /// Where ∇f vanishes in the widened cell, no direction works.
    #[test]
    fn a_critical_point_gives_no_slope() {
        let f = Formula::parse("x^2+y^2+z^2-1e-6").unwrap();
        let tape = f.tape(&OUTPUTS);
        let mut eval = DecoratedEvaluator::new(&tape);
        let b = Aabb::new(DVec3::splat(-0.01), DVec3::splat(0.01)).unwrap();
        assert_eq!(Slope::around(&mut eval, &b, 1e-6), None);
    }
}
