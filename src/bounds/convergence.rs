//! How each enclosure method's L converges as the box is subdivided: the
//! figure a paper on a new bound would show.

use super::bracket::bracket_lipschitz_by;
use super::lipschitz::{Bounder, Method};
use crate::types::Aabb;
use glam::DVec3;

/// L by each method at each subdivision depth, against a certified lower
/// end of the true maximum.
#[derive(Debug, Clone, PartialEq)]
pub struct Convergence {
    /// `|∇f|` at [`Convergence::point`] is at least this (the lower end of a
    /// 0.01 % bracket): no sound bound is below it.
    pub reference: f64,
    /// Where the reference holds.
    pub point: DVec3,
    /// The depths: depth d splits the box into `8^d` sub-boxes.
    pub depths: Vec<u32>,
    /// Per method that applies, its bound at each depth (`+∞` if unbounded).
    pub methods: Vec<(Method, Vec<f64>)>,
}

/// Whether `method` applies to f over `region`: Bernstein to polynomials,
/// Taylor models to other formulas they expand (for a polynomial they are
/// its Bernstein form), the others everywhere.
pub fn applies(bounder: &Bounder, region: &Aabb, method: Method) -> bool {
    match method {
        Method::Bernstein => bounder.is_polynomial(),
        Method::Taylor => !bounder.is_polynomial() && bounder.expands(region),
        _ => true,
    }
}

/// L over `region` by every method that applies, at depths `0..=max_depth`.
pub fn convergence(bounder: &Bounder, region: &Aabb, max_depth: u32) -> Convergence {
    let reference = bracket_lipschitz_by(bounder, region, 1e-4, 1_000_000, Method::Best);
    let depths: Vec<u32> = (0..=max_depth).collect();
    let methods = Method::ALL
        .into_iter()
        .filter(|&m| applies(bounder, region, m))
        .map(|m| {
            let values = depths
                .iter()
                .map(|&d| bounder.lipschitz_bound_by(region, d, m).value)
                .collect();
            (m, values)
        })
        .collect();
    Convergence {
        reference: reference.lower,
        point: reference.point,
        depths,
        methods,
    }
}
