//! Placing a vertex on its lattice edge: false position, then bisection,
//! each step narrowing the segment between proved signs until the part of
//! the edge that holds the surface is short enough, so every vertex comes
//! with the distance within which a root of f lies.

use super::lattice::{estimate, pack, Lattice, Sign, Signs};
use super::point::PointEnclosures;
use super::tetra::{ends, lower, EdgeKey};
use crate::expr::DecoratedEvaluator;
use crate::types::interval::{DecInterval, Decoration};
use crate::types::rounding::up_bound;
use crate::types::Interval;
use glam::DVec3;

/// Why a vertex is where it is: what shows the surface is near it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Witness {
    /// f changes sign, proved, between two points of the edge within the
    /// vertex's radius, and f is continuous on the edge: a root lies there.
    Root,
    /// f's enclosure holds 0 at a point within the radius (a root up to
    /// the rounding of f's evaluation, as the tracer's `touch`).
    Tolerance,
    /// The vertex closes the mesh at the box's wall, where the solid f < 0
    /// is cut by the box; no surface need be near it.
    Wall,
    /// f may jump or lack a value on the edge, so its change of sign may
    /// not be a root.
    Uncertain,
}

/// A placed vertex.
#[derive(Debug, Clone, Copy)]
pub struct Placed {
    /// Where it is.
    pub position: DVec3,
    /// A bound of its distance to the witness point, rounded up.
    pub radius: f64,
    /// What lies within `radius`.
    pub witness: Witness,
}

/// The most steps on one edge (an f64 segment halves to a point in fewer).
const MAX_STEPS: u32 = 1100;

/// False-position guesses on one edge before plain bisection.
const GUESSES: u32 = 3;

/// Places the vertex of edge `e` (one end inside, one outside) to within
/// `radius` of its witness, by bisection on signs proved by f's enclosure.
/// `continuous` says whether f is defined and continuous on the edge.
#[allow(clippy::too_many_arguments)]
pub fn place(
    f: &mut PointEnclosures<'_>,
    decorated: &mut DecoratedEvaluator<'_>,
    lattice: &Lattice,
    signs: &Signs,
    level: u32,
    e: EdgeKey,
    radius: f64,
    continuous: bool,
) -> Placed {
    let (lo, hi) = ends(e);
    let (mut a, mut b) = (lattice.point(lo, level), lattice.point(hi, level));
    let (lo_f, hi_f) = (signs.enclosure(lower(e)), signs.enclosure(pack(hi)));
    let ((in_f, _), (out_f, out_p)) = if signs.inside_with(lo, lo_f) {
        ((lo_f, lo), (hi_f, hi))
    } else {
        std::mem::swap(&mut a, &mut b);
        ((hi_f, hi), (lo_f, lo))
    };
    // a stays inside, b outside. An end's sign is proved unless it is the
    // lattice point's own and says otherwise: a wall point outside by
    // definition, or one whose enclosure holds 0 or has no value.
    let (mut a_sign, mut fa) = (Sign::of(in_f), estimate(in_f));
    let (out_sign, mut fb) = (Sign::of(out_f), estimate(out_f));
    let mut b_sign = if signs.inside_with(out_p, out_f) || out_sign != Sign::Positive {
        Sign::Undefined
    } else {
        Sign::Positive
    };
    let wall_end = out_sign.inside();
    let mut guesses = 0;
    let mut steps = 0;
    while half_length(a, b) > radius && steps < MAX_STEPS {
        steps += 1;
        // First, where f's values put the root (false position): two points
        // within the radius either side of the guess, if their signs are
        // proved opposite, finish in two evaluations. Each proved sign
        // narrows the segment whatever it is.
        if guesses < GUESSES && fa <= 0.0 && fb > 0.0 && b_sign == Sign::Positive {
            guesses += 1;
            let t = fa / (fa - fb);
            let dt = 0.9 * radius / (b - a).length();
            let (a0, b0) = (a, b);
            for s in [t - dt, t + dt] {
                if !(s > 0.0 && s < 1.0) {
                    continue;
                }
                let p = a0 + s * (b0 - a0);
                if p == a || p == b {
                    continue;
                }
                let v = f.at(p, lo);
                match Sign::of(v) {
                    Sign::Negative => (a, a_sign, fa) = (p, Sign::Negative, estimate(v)),
                    Sign::Positive => {
                        (b, b_sign, fb) = (p, Sign::Positive, estimate(v));
                        break;
                    }
                    Sign::Zero => return at_zero(p),
                    Sign::Undefined => {
                        (b, b_sign, fb) = (p, Sign::Undefined, f64::NAN);
                        break;
                    }
                }
            }
            continue;
        }
        let m = 0.5 * (a + b);
        if m == a || m == b {
            break;
        }
        let v = f.at(m, lo);
        match Sign::of(v) {
            Sign::Negative => (a, a_sign, fa) = (m, Sign::Negative, estimate(v)),
            Sign::Positive => (b, b_sign, fb) = (m, Sign::Positive, estimate(v)),
            Sign::Zero => return at_zero(m),
            Sign::Undefined => (b, b_sign, fb) = (m, Sign::Undefined, f64::NAN),
        }
    }
    let position = 0.5 * (a + b);
    let radius = half_length(a, b);
    let witness = if a_sign == Sign::Negative && b_sign == Sign::Positive {
        // f continuous on the cell, or on the short segment left, where
        // its enclosure is much tighter than over the cell.
        if continuous || continuous_on(decorated, a, b) {
            Witness::Root
        } else {
            Witness::Uncertain
        }
    } else if a_sign == Sign::Zero {
        // The inside end's own enclosure holds 0.
        Witness::Tolerance
    } else if wall_end && b_sign != Sign::Positive {
        Witness::Wall
    } else {
        Witness::Uncertain
    };
    // The witness is an end of [a, b] or between them, so within half its
    // length of the exact midpoint; the computed one is off by at most an
    // ulp of its largest coordinate.
    let radius = up_bound(radius + position.abs().max_element() * f64::EPSILON);
    Placed {
        position,
        radius,
        witness,
    }
}

/// Whether f is defined and continuous on the box spanned by `a` and `b`
/// (and so on the segment between them).
pub(super) fn continuous_on(decorated: &mut DecoratedEvaluator<'_>, a: DVec3, b: DVec3) -> bool {
    let span = |k: usize| DecInterval::defined(Interval::new(a[k].min(b[k]), a[k].max(b[k])));
    let zero = DecInterval::defined(Interval::point(0.0));
    let f = decorated.eval(&[span(0), span(1), span(2), zero, zero, zero])[0];
    f.decoration() == Decoration::Dac
}

/// A vertex at a point where f's enclosure holds 0.
fn at_zero(p: DVec3) -> Placed {
    Placed {
        position: p,
        radius: 0.0,
        witness: Witness::Tolerance,
    }
}

/// Half the distance between two points, rounded up.
fn half_length(a: DVec3, b: DVec3) -> f64 {
    up_bound(0.5 * (b - a).length())
}
