//! What `lgc bounds` reports, computed once for every front end: f's
//! enclosure over a box, L (bound or certified bracket) beside a sampled
//! maximum, and G along a ray segment likewise; with the report's fields by
//! name, so the command line's JSON and the Python module's dict have the
//! same keys and the same numbers.

use super::{bracket_grad_lipschitz_by, bracket_lipschitz_by, Bound, Bounder, Bracket, Method};
use crate::types::{Aabb, Interval, Segment};
use glam::DVec3;

/// Grid points per axis where L's maximum is sampled.
const L_SAMPLES: usize = 24;

/// Points along the segment where G's maximum is sampled.
const G_SAMPLES: usize = 1025;

/// How bounds are refined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refine {
    /// Split the box `8^n` ways (the segment `2^n`), once.
    Split(u32),
    /// Branch and bound until `upper ≤ lower·(1 + tolerance)`, or until
    /// `max_pieces` pieces were bounded.
    Bracket {
        /// The relative width asked for.
        tolerance: f64,
        /// The piece budget.
        max_pieces: usize,
    },
}

/// One constant, L or G: its sound bound beside a sampled (or certified)
/// lower estimate of the true maximum.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// The sound upper bound (a bracket's upper end).
    pub bound: Bound,
    /// The largest sampled value; with a bracket, at least its lower end.
    pub sampled: f64,
    /// Where the estimate holds: the sample's point, or the bracket's.
    pub point: DVec3,
    /// For G, the parameter of `point`.
    pub t: Option<f64>,
    /// With [`Refine::Bracket`], the bracket.
    pub bracket: Option<Bracket>,
}

/// f's enclosure, L and G (see the module's doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// f over the box.
    pub f: Interval,
    /// L over the box.
    pub l: Estimate,
    /// G over the segment, when one is given.
    pub g: Option<Estimate>,
}

/// A report field's value.
#[derive(Debug, Clone, PartialEq)]
pub enum Field {
    /// A number; not finite means unbounded or undefined (JSON `null`).
    Number(f64),
    /// A few numbers (an interval's ends, a point).
    Numbers(Vec<f64>),
    /// A count.
    Count(usize),
    /// Yes or no.
    Flag(bool),
    /// A note.
    Text(String),
}

/// Bounds f, L and (with `segment`) G by `method`, refined as `refine`
/// says.
pub fn report(
    bounder: &Bounder,
    b: &Aabb,
    segment: Option<&Segment>,
    refine: Refine,
    method: Method,
) -> Report {
    let f = bounder.f_and_gradient(b)[0];
    let sampled = bounder.sample_gradient(b, L_SAMPLES);
    let l = match refine {
        Refine::Split(n) => Estimate {
            bound: bounder.lipschitz_bound_by(b, n, method),
            sampled: sampled.value,
            point: sampled.point,
            t: None,
            bracket: None,
        },
        Refine::Bracket {
            tolerance,
            max_pieces,
        } => {
            let br = bracket_lipschitz_by(bounder, b, tolerance, max_pieces, method);
            Estimate {
                sampled: sampled.value.max(br.lower),
                point: br.point,
                t: None,
                bound: Bound {
                    value: br.upper,
                    note: br.note.clone(),
                },
                bracket: Some(br),
            }
        }
    };
    let g = segment.map(|s| {
        let (sampled, t) = bounder.sample_dg(s, G_SAMPLES);
        match refine {
            Refine::Split(n) => Estimate {
                bound: bounder.grad_lipschitz_bound_by(s, n, method),
                sampled: sampled.value,
                point: sampled.point,
                t: Some(t),
                bracket: None,
            },
            Refine::Bracket {
                tolerance,
                max_pieces,
            } => {
                let br = bracket_grad_lipschitz_by(bounder, s, tolerance, max_pieces, method);
                Estimate {
                    sampled: sampled.value.max(br.lower),
                    point: br.point,
                    t: Some(br.t.unwrap_or(t)),
                    bound: Bound {
                        value: br.upper,
                        note: br.note.clone(),
                    },
                    bracket: Some(br),
                }
            }
        }
    });
    Report { f, l, g }
}

impl Report {
    /// The report's fields by name, in order: `f`, then for L and G each
    /// `NAME`, `NAME_sampled`, `NAME_ratio` (bound over sampled, where both
    /// are finite and positive), `NAME_note`, then with a bracket
    /// `NAME_lower` and `NAME_reached` and the pieces (`pieces` for L,
    /// `G_pieces`), then `L_point`, or `G_t` and `G_point`.
    pub fn fields(&self) -> Vec<(String, Field)> {
        let mut out = vec![(
            "f".to_string(),
            Field::Numbers(vec![self.f.inf(), self.f.sup()]),
        )];
        self.l.fields("L", "pieces", &mut out);
        if let Some(g) = &self.g {
            g.fields("G", "G_pieces", &mut out);
        }
        out
    }
}

impl Estimate {
    fn fields(&self, name: &str, pieces: &str, out: &mut Vec<(String, Field)>) {
        let mut put = |key: String, value: Field| out.push((key, value));
        put(name.to_string(), Field::Number(self.bound.value));
        put(format!("{name}_sampled"), Field::Number(self.sampled));
        if self.bound.value.is_finite() && self.sampled > 0.0 {
            put(
                format!("{name}_ratio"),
                Field::Number(self.bound.value / self.sampled),
            );
        }
        if let Some(note) = &self.bound.note {
            put(format!("{name}_note"), Field::Text(note.clone()));
        }
        if let Some(br) = &self.bracket {
            put(format!("{name}_lower"), Field::Number(br.lower));
            put(format!("{name}_reached"), Field::Flag(br.reached));
            put(pieces.to_string(), Field::Count(br.pieces));
        }
        if let Some(t) = self.t {
            put(format!("{name}_t"), Field::Number(t));
        }
        let p = self.point;
        put(format!("{name}_point"), Field::Numbers(vec![p.x, p.y, p.z]));
    }
}
