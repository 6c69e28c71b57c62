//! The grid the mesh lives on: lattice points of a box split `2^depth` times
//! per axis, the cells f may cross found by interval subdivision, and each
//! lattice point's sign.

use super::point::{self, PointEnclosures};
use crate::expr::{DecoratedEvaluator, SettlingEvaluator};
use crate::expr::{Evaluator, Tape};
use crate::types::interval::{DecInterval, Decoration};
use crate::types::{Aabb, Interval};
use glam::DVec3;
use rayon::prelude::*;

/// Bits of one axis's lattice index in a packed point key.
const AXIS_BITS: u32 = 20;

/// The deepest lattice a key can hold (one more bit for the index `2^depth`).
pub const MAX_DEPTH: u32 = AXIS_BITS - 1;

/// A lattice point `(i, j, k)` packed into one integer, ordered by `k, j, i`.
pub type PointKey = u64;

/// Packs a lattice point.
pub fn pack(p: [u32; 3]) -> PointKey {
    p[0] as u64 | (p[1] as u64) << AXIS_BITS | (p[2] as u64) << (2 * AXIS_BITS)
}

/// Unpacks a lattice point.
pub fn unpack(key: PointKey) -> [u32; 3] {
    let mask = (1u64 << AXIS_BITS) - 1;
    [
        (key & mask) as u32,
        (key >> AXIS_BITS & mask) as u32,
        (key >> (2 * AXIS_BITS) & mask) as u32,
    ]
}

/// What a lattice point's enclosure of f says of its sign.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sign {
    /// f < 0, proved.
    Negative,
    /// f > 0, proved.
    Positive,
    /// The enclosure holds 0: f is 0 within the rounding of its evaluation.
    Zero,
    /// f has no value there.
    Undefined,
}

impl Sign {
    /// The sign of f's enclosure at a point.
    pub fn of(f: Interval) -> Sign {
        if f.is_empty() || f.inf().is_nan() || f.sup().is_nan() {
            Sign::Undefined
        } else if f.sup() < 0.0 {
            Sign::Negative
        } else if f.inf() > 0.0 {
            Sign::Positive
        } else {
            Sign::Zero
        }
    }

    /// The side of the mesh a point is on: inside where f < 0 or where its
    /// enclosure holds 0; outside where f > 0 or has no value. Any fixed
    /// choice gives a closed mesh; this one keeps points at 0 inside, so a
    /// surface touching a lattice point still gets its triangles.
    pub fn inside(self) -> bool {
        matches!(self, Sign::Negative | Sign::Zero)
    }
}

/// The lattice of a box at a depth: point `(i, j, k)` is at
/// `lo + (hi − lo)·(i, j, k)/2^depth`, one f64 expression, so a point's
/// coordinates are the same however it is reached.
#[derive(Debug, Clone, Copy)]
pub struct Lattice {
    lo: DVec3,
    hi: DVec3,
    size: DVec3,
}

impl Lattice {
    /// The lattice over `b`.
    pub fn new(b: &Aabb) -> Lattice {
        Lattice {
            lo: b.lo,
            hi: b.hi,
            size: b.hi - b.lo,
        }
    }

    /// Coordinate `i/2^level` of the way along `axis`, kept in the box.
    pub fn coordinate(&self, axis: usize, i: u32, level: u32) -> f64 {
        let n = 1u64 << level;
        if i as u64 >= n {
            return self.hi[axis];
        }
        // i/2^level is exact, so the same fraction gives the same number at
        // every level.
        let s = i as f64 / n as f64;
        (self.lo[axis] + self.size[axis] * s).clamp(self.lo[axis], self.hi[axis])
    }

    /// The point `p` of the lattice at `level`.
    pub fn point(&self, p: [u32; 3], level: u32) -> DVec3 {
        DVec3::new(
            self.coordinate(0, p[0], level),
            self.coordinate(1, p[1], level),
            self.coordinate(2, p[2], level),
        )
    }

    /// Whether consecutive lattice coordinates at `level` are distinct on
    /// every axis (a box too thin for its depth would make cells flat).
    pub fn is_resolved(&self, level: u32) -> bool {
        (0..3).all(|axis| {
            (0..1u32 << level)
                .all(|i| self.coordinate(axis, i, level) < self.coordinate(axis, i + 1, level))
        })
    }

    /// The box of cell `c` at `level`.
    pub fn cell(&self, c: [u32; 3], level: u32) -> Aabb {
        Aabb {
            lo: self.point(c, level),
            hi: self.point(c.map(|i| i + 1), level),
        }
    }
}

/// A cell of the finest level that f may cross, with the decoration of f's
/// enclosure over it.
#[derive(Debug, Clone, Copy)]
pub struct Cell {
    /// Its lowest lattice point.
    pub corner: [u32; 3],
    /// Whether f is defined and continuous over the whole closed cell.
    pub continuous: bool,
    /// Whether f's enclosure over the cell settles every branching
    /// instruction of its tape ([`Tape::settled_all_over`]), where the
    /// enclosure that found the cell said.
    pub settled: Option<bool>,
}

/// The cells found by [`find_cells`], at the level where they stopped.
#[derive(Debug)]
pub struct Cells {
    /// The cells, each once, in the order of their lowest corners' keys.
    pub cells: Vec<Cell>,
    /// Their level: the depth asked for, or less where `max_cells` stopped it.
    pub level: u32,
}

/// Boxes one job encloses: with a job a box, handing out the jobs cost a
/// small formula's last level as much as enclosing its boxes.
const BOX_CHUNK: usize = 1024;

/// Whether a box must be split further: f's enclosure over it holds 0, or f
/// is negative over it and may be undefined in part of it (a point there is
/// outside), or f is negative over it and it touches the box's wall, where
/// lattice points are outside by definition.
fn may_cross(f: DecInterval, touches_wall: bool) -> bool {
    let x = f.interval();
    if x.is_empty() || x.inf() > 0.0 {
        // Every point where f has a value is outside, and so is every point
        // where it has none: a point's enclosure lies in the box's (or is
        // empty), so the corners' signs agree.
        return false;
    }
    f.decoration() == Decoration::Trv || x.contains(0.0) || touches_wall
}

/// Every cell at `depth` that f may cross, found level by level: a box whose
/// enclosure of f excludes 0 (with f defined all over it) holds lattice
/// points of one sign only, so none of its cells has triangles. Splitting
/// stops early, at a shallower level, where the next would hold more than
/// `max_cells` boxes.
pub fn find_cells(tape: &Tape, lattice: &Lattice, depth: u32, max_cells: usize) -> Cells {
    // Each box with whether f is continuous on its parent: then on it too,
    // and the plain enclosure, cheaper than the decorated one, is enough.
    let mut level_boxes = vec![([0u32; 3], false)];
    let mut level = 0;
    loop {
        let n = 1u32 << level;
        let kept: Vec<Cell> = level_boxes
            .par_chunks(BOX_CHUNK)
            .flat_map_iter(|chunk| {
                let mut decorated = DecoratedEvaluator::new(tape);
                let mut plain = Evaluator::<Interval>::new(tape);
                let mut settling = SettlingEvaluator::new(tape);
                chunk.iter().filter_map(move |&(c, continuous)| {
                    let b = lattice.cell(c, level);
                    let zero = Interval::point(0.0);
                    let mut settled = None;
                    let f = if continuous {
                        let [x, y, z] = b.intervals();
                        let inputs = [x, y, z, zero, zero, zero];
                        // The last level's cells are settled later: noted
                        // now, the same run serves both.
                        DecInterval::defined(if level == depth {
                            let (f, s) = settling.eval(&inputs);
                            settled = s;
                            f
                        } else {
                            plain.eval(&inputs)[0]
                        })
                    } else {
                        let [x, y, z] = b.intervals().map(DecInterval::defined);
                        let zero = DecInterval::defined(zero);
                        // An enclosure that is empty, positive or holds 0
                        // decides the box whether f is defined all over it
                        // or not.
                        decorated.eval_first_unless(&[x, y, z, zero, zero, zero], |x| {
                            x.is_empty() || x.inf() > 0.0 || x.contains(0.0)
                        })
                    };
                    let wall = c.iter().any(|&i| i == 0 || i + 1 == n);
                    may_cross(f, wall).then_some(Cell {
                        corner: c,
                        continuous: f.decoration() == Decoration::Dac,
                        settled,
                    })
                })
            })
            .collect();
        if level == depth || kept.len().saturating_mul(8) > max_cells {
            // In the order of their keys, which is the order of the edges
            // and so of the vertices: the triangles, listed cell by cell,
            // then read their vertices nearly in turn.
            let mut cells = kept;
            cells.par_sort_unstable_by_key(|c| pack(c.corner));
            return Cells { cells, level };
        }
        level_boxes = kept
            .iter()
            .flat_map(|c| {
                (0..8u32).map(move |o| {
                    let child = [0, 1, 2].map(|a| 2 * c.corner[a] + (o >> a & 1));
                    (child, c.continuous)
                })
            })
            .collect();
        level += 1;
    }
}

/// The signs of f at lattice points, looked up by key.
#[derive(Debug)]
pub struct Signs {
    keys: Vec<PointKey>,
    values: Vec<Interval>,
    level: u32,
}

impl Signs {
    /// f's sign at every corner of `cells`, at `level`.
    pub fn of_corners(tape: &Tape, lattice: &Lattice, cells: &[Cell], level: u32) -> Signs {
        // The cells are in the order of their keys, so each corner offset
        // gives the corners in order: eight sorted runs, which the stable
        // sort merges rather than sorts.
        let mut keys: Vec<PointKey> = (0..8 * cells.len())
            .into_par_iter()
            .map(|i| {
                let (o, c) = ((i / cells.len()) as u32, &cells[i % cells.len()]);
                pack([0, 1, 2].map(|a| c.corner[a] + (o >> a & 1)))
            })
            .collect();
        keys.par_sort();
        keys.dedup();
        // One f64 evaluation a corner: a block too small to serve many
        // corners is not worth its rounding bound.
        let values: Vec<Interval> = keys
            .par_iter()
            .map_init(
                || PointEnclosures::new(tape, lattice, level, point::BLOCK),
                |f, &k| f.at_lattice(unpack(k)),
            )
            .collect();
        Signs {
            keys,
            values,
            level,
        }
    }

    /// f's enclosure at a lattice point.
    pub fn enclosure(&self, key: PointKey) -> Interval {
        match self.keys.binary_search(&key) {
            Ok(i) => self.values[i],
            // Every corner of every cell was evaluated; a point outside
            // them lies in a box proved positive or negative, and is never
            // asked for.
            Err(_) => Interval::EMPTY,
        }
    }

    /// Which side of the mesh a lattice point is on: points on the box's
    /// wall are outside, so the mesh closes inside the box.
    pub fn inside(&self, key: PointKey) -> bool {
        self.inside_with(unpack(key), self.enclosure(key))
    }

    /// [`Signs::inside`] for point `p`, given f's enclosure `v` there.
    pub fn inside_with(&self, p: [u32; 3], v: Interval) -> bool {
        !self.on_wall(p) && Sign::of(v).inside()
    }

    /// Whether lattice point `p` lies on the box's wall.
    pub fn on_wall(&self, p: [u32; 3]) -> bool {
        let n = 1u32 << self.level;
        p.iter().any(|&i| i == 0 || i == n)
    }

    /// f's enclosures at the eight corners of the cell whose lowest corner
    /// is `corner`: corner `o` is `corner` plus bit `a` of `o` on axis `a`.
    /// Four searches, not eight: the point one step along x from a point
    /// has the next key, so it is the next entry where it is kept.
    pub fn cube(&self, corner: [u32; 3]) -> [Interval; 8] {
        let mut at = [Interval::EMPTY; 8];
        for o in (0..8).step_by(2) {
            let key = pack([
                corner[0],
                corner[1] + (o >> 1 & 1),
                corner[2] + (o >> 2 & 1),
            ]);
            let found = self.keys.binary_search(&key);
            at[o as usize] = found.map_or(Interval::EMPTY, |i| self.values[i]);
            at[o as usize + 1] = match found {
                Ok(i) if self.keys.get(i + 1) == Some(&(key + 1)) => self.values[i + 1],
                _ => self.enclosure(key + 1),
            };
        }
        at
    }
}

/// An estimate of f from its enclosure at a point (NaN where it has none):
/// for steering a search only, never for deciding a sign.
pub fn estimate(v: Interval) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        0.5 * v.inf() + 0.5 * v.sup()
    }
}

/// f's enclosure at one point.
pub fn point_value(eval: &mut Evaluator<'_, Interval>, p: DVec3) -> Interval {
    let zero = Interval::point(0.0);
    eval.eval(&[
        Interval::point(p.x),
        Interval::point(p.y),
        Interval::point(p.z),
        zero,
        zero,
        zero,
    ])[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::{Formula, Output};

    #[test]
    fn a_cells_cube_is_its_corners_enclosures_each_looked_up() {
        // A torus crossing the box's wall, so some corners are on it.
        let f = Formula::parse("(sqrt(x^2+y^2)-0.7)^2+z^2-0.09").unwrap();
        let tape = f.tape(&[Output::F]);
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::new(1.0, 1.0, 0.2)).unwrap();
        let lattice = Lattice::new(&b);
        let found = find_cells(&tape, &lattice, 5, 1 << 20);
        let signs = Signs::of_corners(&tape, &lattice, &found.cells, found.level);
        assert!(found.cells.len() > 100);
        let mut walls = 0;
        for c in &found.cells {
            let cube = signs.cube(c.corner);
            for (o, v) in cube.iter().enumerate() {
                let p = [0, 1, 2].map(|a| c.corner[a] + (o as u32 >> a & 1));
                let expected = signs.enclosure(pack(p));
                assert!(!v.is_empty(), "corner {p:?} of {:?} not found", c.corner);
                assert_eq!((v.inf(), v.sup()), (expected.inf(), expected.sup()));
                assert_eq!(signs.inside_with(p, *v), signs.inside(pack(p)));
                walls += usize::from(signs.on_wall(p));
            }
        }
        assert!(walls > 0);
    }

    /// A pole in a region where f is positive on both sides keeps no
    /// cells: its points are outside whether f has a value there or not.
    #[test]
    fn cells_along_a_pole_where_f_is_positive_are_dropped() {
        // The sphere of radius 0.5, and past x = 0.71 a positive branch
        // with a pole there: f > 0 wherever it has a value near x = 0.71.
        let f = Formula::parse("max(x^2+y^2+z^2-0.25, 0.01/(x-0.71))").unwrap();
        let tape = f.tape(&[Output::F]);
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        let lattice = Lattice::new(&b);
        let found = find_cells(&tape, &lattice, 5, 1 << 20);
        assert_eq!(found.level, 5);
        assert!(!found.cells.is_empty());
        for c in &found.cells {
            let cell = lattice.cell(c.corner, found.level);
            assert!(cell.lo.x < 0.6, "a cell kept at the pole: {cell:?}");
        }
    }
}
