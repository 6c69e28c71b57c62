//! f's enclosure at points of the lattice and of its edges, from an f64
//! value where its rounding cannot hide the sign.
//!
//! A point's f64 value is `f̂`; evaluating the tape in [`RoundingBound`] over
//! a box bounds `|f̂(p) − f(p)|` by one `err` for every f64 point p of the
//! box. So `[f̂ − err, f̂ + err]` encloses f(p), and where it excludes 0 it
//! proves the sign as an interval evaluation at p would, at the cost of an
//! f64 evaluation (compiled once the tape has run a few hundred times). The
//! bound is found once per block of `2^BLOCK` cells a side and kept; a point
//! whose f64 enclosure holds 0, or outside the block it names, or in a block
//! with no finite bound, is enclosed by interval evaluation at the point.

use super::lattice::{point_value, Lattice};
use crate::expr::{Evaluator, PointEvaluator, RoundingBound, Tape};
use crate::types::{Aabb, Interval};
use glam::DVec3;
use rustc_hash::FxHashMap;

/// Blocks are `2^BLOCK` cells a side: large enough that one bound serves
/// many points, small enough that it is often finite on long models.
pub const BLOCK: u32 = 3;

/// Blocks one [`PointEnclosures`] keeps before it forgets them all.
const KEPT_BLOCKS: usize = 4096;

/// Enclosures of f at points near the lattice at one level.
pub struct PointEnclosures<'t> {
    lattice: Lattice,
    level: u32,
    /// The smallest blocks tried, `2^finest` cells a side.
    finest: u32,
    point: PointEvaluator<'t>,
    interval: Evaluator<'t, Interval>,
    rounding: Evaluator<'t, RoundingBound>,
    /// Each block met so far (by its index at `level − shift`, and shift):
    /// its box, and the rounding bound of f̂ over it (`+∞` where none is
    /// known).
    blocks: FxHashMap<([u32; 3], u32), (Aabb, f64)>,
    /// Enclosures proved by an f64 value so far (the others by intervals).
    pub(crate) from_f64: u64,
}

impl<'t> PointEnclosures<'t> {
    /// Enclosures of the value of `f` (a tape whose first output is f) near
    /// `lattice`'s points at `level`; where a block of [`BLOCK`] has no
    /// finite bound, its eighths are tried, down to blocks of `2^finest`
    /// cells a side. (A bound costs about six interval evaluations: worth
    /// it where a block's points are evaluated many times.)
    pub fn new(f: &'t Tape, lattice: &Lattice, level: u32, finest: u32) -> Self {
        PointEnclosures {
            lattice: *lattice,
            level,
            finest,
            point: PointEvaluator::new(f),
            interval: Evaluator::new(f),
            rounding: Evaluator::new(f),
            blocks: FxHashMap::default(),
            from_f64: 0,
        }
    }

    /// f's enclosure at `p`, a point in a cell whose lowest corner is the
    /// lattice point `near` (or at `near` itself).
    pub fn at(&mut self, p: DVec3, near: [u32; 3]) -> Interval {
        let (block, err) = self.block(near);
        if err.is_finite() && block.contains(p) {
            let [v] = self.point.eval_array(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
            if v.is_finite() {
                // Outward-rounded: the interval sum rounds each end out.
                let f = Interval::point(v) + Interval::new(-err, err);
                if f.inf() > 0.0 || f.sup() < 0.0 {
                    self.from_f64 += 1;
                    return f;
                }
            }
        }
        point_value(&mut self.interval, p)
    }

    /// f's enclosure at the lattice point `p`.
    pub fn at_lattice(&mut self, p: [u32; 3]) -> Interval {
        let x = self.lattice.point(p, self.level);
        self.at(x, p)
    }

    /// The block holding the cells whose lowest corner is `near` (its box,
    /// closed, holds those cells): its box and f̂'s rounding bound there.
    fn block(&mut self, near: [u32; 3]) -> (Aabb, f64) {
        // Where a block has no finite bound, its eighth holding the point
        // may: bounds grow with the ranges they are taken over.
        let top = BLOCK.min(self.level);
        let mut found = self.block_at(near, top);
        for shift in (self.finest.max(1)..top).rev() {
            if found.1.is_finite() {
                break;
            }
            found = self.block_at(near, shift);
        }
        found
    }

    /// The block of `2^shift` cells a side holding the cells whose lowest
    /// corner is `near`: its box and f̂'s rounding bound there.
    fn block_at(&mut self, near: [u32; 3], shift: u32) -> (Aabb, f64) {
        let index = near.map(|i| i >> shift);
        if let Some(&known) = self.blocks.get(&(index, shift)) {
            return known;
        }
        if self.blocks.len() >= KEPT_BLOCKS {
            self.blocks.clear();
        }
        // Lattice coordinates grow with the index (each is one monotone f64
        // expression), so every point of the block lies in this box.
        let lo = self.lattice.point(index.map(|i| i << shift), self.level);
        let hi = self
            .lattice
            .point(index.map(|i| (i + 1) << shift), self.level);
        let b = Aabb { lo, hi };
        let [x, y, z] = b.intervals().map(RoundingBound::exact);
        let zero = RoundingBound::exact(Interval::ZERO);
        let err = self.rounding.eval(&[x, y, z, zero, zero, zero])[0].err;
        let err = if err >= 0.0 { err } else { f64::INFINITY };
        self.blocks.insert((index, shift), (b, err));
        (b, err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::{Formula, Output};

    /// Every enclosure holds f, checked against the interval enclosure at the
    /// same point (both hold f, so they meet, and a sign either proves the
    /// other does not contradict), at lattice points and at points along
    /// the lattice's edges, for formulas with roots, exponentials of large
    /// arguments (a soft union), and square roots near 0.
    #[test]
    fn enclosures_from_f64_values_hold_f_as_intervals_do() {
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        let lattice = Lattice::new(&b);
        let level = 5;
        for source in [
            "x^2+y^2+z^2-0.81",
            "-ln(exp(-40*(sqrt((x-0.3)^2+y^2+z^2)-0.4))+exp(-40*(sqrt((x+0.3)^2+y^2+z^2)-0.4)))/40",
            "sqrt(x^2+y^2)-0.5+0.1*sin(9*z)",
        ] {
            let formula = Formula::parse(source).unwrap();
            let tape = formula.tape(&[Output::F]);
            let mut f = PointEnclosures::new(&tape, &lattice, level, 1);
            let mut check = Evaluator::<Interval>::new(&tape);
            let n = 1u32 << level;
            let mut points = 0;
            for i in (0..=n).step_by(3) {
                for j in (0..=n).step_by(2) {
                    for k in 0..=n {
                        let near = [i, j, k].map(|c| c.min(n - 1));
                        let corner = lattice.point([i, j, k], level);
                        let step = lattice.point(near.map(|c| c + 1), level);
                        for s in [0.0, 0.37, 0.5, 0.999] {
                            // On the edge from the corner, or the corner.
                            let p = if [i, j, k] == near {
                                corner + s * (step - corner)
                            } else {
                                corner
                            };
                            let got = f.at(p, near);
                            let expected = point_value(&mut check, p);
                            assert!(!got.is_empty(), "{source} at {p}");
                            assert!(
                                got.inf() <= expected.sup() && expected.inf() <= got.sup(),
                                "{source} at {p}: {got:?} and {expected:?} are apart"
                            );
                            points += 1;
                        }
                    }
                }
            }
            // Most points are proved by their f64 value, not by intervals.
            assert!(
                f.from_f64 * 2 > points,
                "{source}: {} of {points}",
                f.from_f64
            );
        }
    }

    #[test]
    fn a_sign_its_f64_rounding_flips_is_left_to_intervals() {
        // f = x − 0.3 exactly, but its f64 value rounds x + 10¹⁵ to eighths:
        // on (0.3, 0.3125) it is −0.05 where f is positive.
        let formula = Formula::parse("(x+1e15)-1e15-0.3").unwrap();
        let tape = formula.tape(&[Output::F]);
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        let lattice = Lattice::new(&b);
        let level = 4;
        let mut f = PointEnclosures::new(&tape, &lattice, level, 1);
        let mut flipped = 0;
        for k in 0..=2000 {
            let x = -0.5 + 1.5 * k as f64 / 2000.0;
            let near = [((x + 1.0) * 8.0).floor() as u32, 3, 3];
            let p = DVec3::new(
                x,
                lattice.point(near, level).y,
                lattice.point(near, level).z,
            );
            let [computed] = Evaluator::<f64>::new(&tape).eval_array(&[x, p.y, p.z, 0.0, 0.0, 0.0]);
            let exact = x - 0.3;
            flipped += usize::from(computed < 0.0 && exact > 1e-9);
            let got = f.at(p, near);
            assert!(
                got.inf() <= exact + 1e-15 && exact - 1e-15 <= got.sup(),
                "at x = {x}: {got:?} misses {exact}"
            );
        }
        assert!(flipped > 10, "{flipped}");
        // Away from the root its f64 value proves the sign.
        assert!(f.from_f64 > 1000, "{}", f.from_f64);
        assert!(f.from_f64 < 2000, "{}", f.from_f64);
    }
}
