//! Each kept leaf's hull: the sub-boxes of its box that no test proves empty.

use super::classify::*;
use super::leaf::*;
use super::options::*;
use super::shapes::*;
use crate::expr::PointEvaluator;
use crate::types::rounding::{ROUNDINGS_1, ROUNDINGS_15};
use crate::types::Aabb;
use glam::DVec3;
use rustc_hash::FxHashMap;

/// Finds the hulls of kept leaves ([`Octree::leaf_hull`]); one per thread.
pub(super) struct HullFinder<'t> {
    shapes: &'t [Shape],
    quadratic: &'t [bool],
    /// Point evaluators of each shape's f and g (g unread): the tape rays
    /// evaluate, compiled where it is evaluated often (its machine code then
    /// serves them too); made on first use.
    evaluators: FxHashMap<u32, PointEvaluator<'t>>,
    /// Sub-boxes still to test, with their levels.
    stack: Vec<(Aabb, u32)>,
}

impl<'t> HullFinder<'t> {
    pub(super) fn new(shapes: &'t [Shape], quadratic: &'t [bool]) -> HullFinder<'t> {
        HullFinder {
            shapes,
            quadratic,
            evaluators: FxHashMap::default(),
            stack: Vec::new(),
        }
    }

    pub(super) fn evaluator(&mut self, shape: u32) -> &mut PointEvaluator<'t> {
        let shapes = self.shapes;
        self.evaluators
            .entry(shape)
            .or_insert_with(|| PointEvaluator::new(&shapes[shape as usize].fg))
    }

    /// The hull of the leaf box `unpadded` ([`Octree::leaf_hull`]): the
    /// sub-boxes that no test proves empty, padded, down to `levels` levels
    /// where every formula tested is at most quadratic, one level elsewhere
    /// (see [`HULL_LEVELS`]).
    ///
    /// The test is the mean-value form with a formula's bounds of its partial
    /// derivatives over the leaf: within `r` of a sub-box's centre c (per
    /// axis), `|F − F(c)| ≤ Σ sᵢ·rᵢ`, so F keeps the sign of F(c) there where
    /// `|F(c)|`, less its rounding error, is larger; one evaluation at a
    /// point, exact for a plane along an axis. F is the formula as the leaf
    /// sees it (its sign is f's in the padded leaf), or for a split leaf each
    /// of its sides: their larger (smaller) has no root where one side stays
    /// above (below) 0 or both below (above). The leaf's box where no such
    /// bound holds; the centre of `unpadded` when no sub-box is left.
    pub(super) fn hull(
        &mut self,
        plan: &Plan,
        unpadded: &Aabb,
        leaf: &Leaf,
        split: Option<&SplitLeaf>,
        levels: u32,
        early: bool,
    ) -> Aabb {
        let formulas = match split {
            Some(split) => &split.sides[..],
            None => std::slice::from_ref(leaf),
        };
        let bounded = |l: &Leaf| {
            l.continuous && l.f_error.is_finite() && l.slopes.iter().all(|s| s.is_finite())
        };
        if levels == 0 || !formulas.iter().all(bounded) {
            return *unpadded;
        }
        let quadratic = formulas.iter().all(|l| self.quadratic[l.shape as usize]);
        let levels = if quadratic || early {
            levels.min(MAX_HULL_LEVELS)
        } else {
            1
        };
        // Every point of a padded sub-box `level` deep lies within `reach`
        // of its computed centre, per axis: half its width, the pad, and
        // ulps of the coordinates for the roundings of the cuts and centres.
        let width = unpadded.hi - unpadded.lo;
        let ulps = ROUNDINGS_15 * unpadded.lo.abs().max(unpadded.hi.abs());
        let reach = |level: u32| width * 0.5f64.powi(level as i32 + 1) + plan.pad + ulps;
        // Per formula, how far it may move from its value at the centre of a
        // sub-box one level below `level`: products and sums of non-negative
        // numbers, raised to cover their roundings.
        let moves = |l: &Leaf| -> [f64; MAX_HULL_LEVELS as usize] {
            let slopes = DVec3::from(l.slopes);
            std::array::from_fn(|level| {
                let r = reach(level as u32 + 1);
                slopes.dot(r) * (1.0 + ROUNDINGS_15) + f64::MIN_POSITIVE
            })
        };
        let limits: [_; 2] = std::array::from_fn(|k| {
            formulas
                .get(k)
                .map_or([f64::INFINITY; MAX_HULL_LEVELS as usize], moves)
        });
        // A split leaf's shorter side is evaluated first: the other is not
        // where it decides.
        let length = |l: &Leaf| self.shapes[l.shape as usize].fg.body().len();
        let first = usize::from(formulas.len() == 2 && length(&formulas[1]) < length(&formulas[0]));
        let mut stack = std::mem::take(&mut self.stack);
        let mut hull: Option<Aabb> = None;
        stack.clear();
        stack.push((*unpadded, 0));
        while let Some((b, level)) = stack.pop() {
            if level == levels {
                hull = Some(hull.map_or(b, |h| h.union(&b)));
                continue;
            }
            let kept = stack.len();
            for child in b.octants() {
                let c = child.center();
                // The sign formula k keeps on the child, or 0.
                let mut sign = |k: usize| {
                    let l = &formulas[k];
                    let [v, _] = self
                        .evaluator(l.shape)
                        .eval_array::<2>(&[c.x, c.y, c.z, 0.0, 0.0, 0.0]);
                    // |v| − err, lowered by its own rounding; NaN keeps no sign.
                    let low = (v.abs() - l.f_error) * (1.0 - ROUNDINGS_1);
                    match low > limits[k][level as usize] {
                        true if v > 0.0 => 1,
                        true => -1,
                        false => 0,
                    }
                };
                let empty = match split {
                    None => sign(0) != 0,
                    Some(split) => {
                        // One side decides F where it keeps the winning sign:
                        // above 0 under a max, below under a min.
                        let winning = if split.larger { 1 } else { -1 };
                        let one = sign(first);
                        one == winning || {
                            let other = sign(1 - first);
                            other == winning || (one == -winning && other == -winning)
                        }
                    }
                };
                if !empty {
                    stack.push((child, level + 1));
                }
            }
            // Where no octant is empty, smaller ones seldom are: the box is
            // kept whole.
            if stack.len() - kept == 8 {
                stack.truncate(kept);
                hull = Some(hull.map_or(b, |h| h.union(&b)));
            }
        }
        self.stack = stack;
        hull.unwrap_or_else(|| {
            let c = unpadded.center();
            Aabb { lo: c, hi: c }
        })
    }
}
