//! How tight each enclosure method's L is on one surface: L over the box
//! split `8^n` ways by every method that applies, timed, against a
//! certified bracket of the true maximum. `lgc bounds --corpus` prints it
//! for a whole corpus.

use super::bracket::{bracket_lipschitz_by, Bracket};
use super::convergence::applies;
use super::lipschitz::{Bounder, Method};
use crate::types::Aabb;
use std::time::Instant;

/// The relative width of the bracket the bounds are measured against.
pub const REFERENCE_TOLERANCE: f64 = 1e-4;

/// One method's bound and the time it took.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodBound {
    /// The method.
    pub method: Method,
    /// L over the split box (`+∞` where unbounded).
    pub bound: f64,
    /// Seconds it took, on the calling thread.
    pub seconds: f64,
}

/// Every applicable method's L on one box, beside the true maximum.
#[derive(Debug, Clone, PartialEq)]
pub struct Tightness {
    /// A certified bracket of `max |∇f|` to [`REFERENCE_TOLERANCE`]: no
    /// sound bound is below its lower end.
    pub maximum: Bracket,
    /// The methods that apply, in [`Method::ALL`]'s order.
    pub methods: Vec<MethodBound>,
}

/// L over `region` split `8^split` ways by every method that applies.
pub fn tightness(bounder: &Bounder, region: &Aabb, split: u32) -> Tightness {
    let maximum = bracket_lipschitz_by(
        bounder,
        region,
        REFERENCE_TOLERANCE,
        1_000_000,
        Method::Best,
    );
    let methods = Method::ALL
        .into_iter()
        .filter(|&m| applies(bounder, region, m))
        .map(|method| {
            let start = Instant::now();
            let bound = bounder.lipschitz_bound_by(region, split, method).value;
            MethodBound {
                method,
                bound,
                seconds: start.elapsed().as_secs_f64(),
            }
        })
        .collect();
    Tightness { maximum, methods }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::Formula;
    use glam::DVec3;

    #[test]
    fn every_bound_is_above_the_certified_maximum_and_bernstein_only_for_polynomials() {
        let cube = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        for (text, polynomial) in [("x^4+y^4+z^4-x*y", true), ("sin(3*x)*cos(y)+z", false)] {
            let b = Bounder::new(&Formula::parse(text).unwrap());
            let t = tightness(&b, &cube, 1);
            let names: Vec<_> = t.methods.iter().map(|m| m.method).collect();
            assert_eq!(names.contains(&Method::Bernstein), polynomial, "{text}");
            assert!(t.maximum.reached, "{text}");
            for m in &t.methods {
                assert!(m.bound >= t.maximum.lower, "{text} {:?}", m.method);
            }
        }
    }
}
