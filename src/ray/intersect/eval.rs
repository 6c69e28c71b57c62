//! Evaluations of F and g along a ray, as points, over pieces, and as certified signs.

use super::bounds::*;
use super::piece::*;
use super::*;
use crate::expr::PointEvaluator;
use crate::ray::octree::Short;
use crate::types::Segment;
use crate::types::{DecInterval, Decoration, Interval};
use glam::DVec3;

/// How many times [`Tracer::fg_over`] halves a piece that lies in no cell.
/// Measured on the prospero slab at 1024² (callgrind, one thread): three
/// cuts take 0.977 of the instructions of two, interval evaluations a ray
/// 0.89 → 0.84, the same picture.
pub(super) const FG_CUTS: u32 = 3;

/// How many parts of cut pieces a search keeps, the latest (keeping all
/// fourteen of three cuts: the same instructions to four digits).
const MAX_PARTS: usize = 6;

/// The enclosures of F and g over a part of a cut piece (see
/// [`Tracer::fg_over_inputs`]), by the shape and the part's ends.
#[derive(Debug, Clone, Copy)]
pub(super) struct Part {
    shape: usize,
    ends: (f64, f64),
    found: (Interval, Interval, bool),
}

impl<'s> Tracer<'s> {
    /// The evaluators of the current leaf's shape.
    #[inline(always)]
    pub(super) fn evals(&mut self) -> &mut RayEvaluators<'s> {
        let shape = &self.intersector.octree.shapes[self.current];
        self.shapes[self.current].get_or_insert_with(|| RayEvaluators::new(shape))
    }

    /// The point evaluator of the current leaf's short tape, where one
    /// holds at `p`.
    ///
    /// Its f64 values are not the shape's, but the leaf's rounding bounds
    /// hold for them: over the leaf, the short tape computes the same real
    /// numbers by a subset of the shape's operations, each decided branch
    /// with an error bound no larger than the branch point's (see the
    /// design notes).
    #[inline(always)]
    fn short_at(&mut self, p: DVec3) -> Option<&mut PointEvaluator<'s>> {
        self.short_of(self.leaf, self.current, p)
    }

    /// The point evaluator of the short tape of `shape` in leaf `leaf`,
    /// where one holds at `p`.
    #[inline(always)]
    fn short_of(&mut self, leaf: usize, shape: usize, p: DVec3) -> Option<&mut PointEvaluator<'s>> {
        let octree = &self.intersector.octree;
        let fg = &octree.shapes[shape].fg;
        let (k, tape) = octree.short.find_point(leaf, (shape, fg), p)?;
        let slot = cached(&mut self.short_points, k);
        Some(slot.get_or_insert_with(|| PointEvaluator::new(tape)))
    }

    /// ∇f at `p` by the short tape of leaf `index`, where one holds there:
    /// g along each axis.
    pub(super) fn short_gradient(&mut self, index: usize, p: DVec3) -> Option<DVec3> {
        let e = self.short_of(index, 0, p)?;
        let g = [DVec3::X, DVec3::Y, DVec3::Z]
            .map(|d| e.eval_array::<2>(&[p.x, p.y, p.z, d.x, d.y, d.z])[1]);
        Some(DVec3::from(g))
    }

    #[inline]
    pub(super) fn f_at(&mut self, ray: &Ray, t: f64) -> f64 {
        self.stats.f_evals += 1;
        let p = ray.o + t * ray.d;
        let input = [p.x, p.y, p.z, 0.0, 0.0, 0.0];
        if let Some(short) = self.short_at(p) {
            return short.eval_first(&input);
        }
        let [f] = self.evals().f.eval_array(&input);
        f
    }

    #[inline]
    pub(super) fn fg_at(&mut self, ray: &Ray, t: f64) -> (f64, f64) {
        self.stats.f_evals += 1;
        let p = ray.o + t * ray.d;
        let d = ray.d;
        let input = [p.x, p.y, p.z, d.x, d.y, d.z];
        if let Some(short) = self.short_at(p) {
            let [f, g] = short.eval_array(&input);
            return (f, g);
        }
        let [f, g] = self.evals().fg.eval_array(&input);
        (f, g)
    }

    /// The interval inputs of the exact points `o + t·d`, t in `[a, b]`.
    pub(super) fn inputs(ray: &Ray, a: f64, b: f64) -> [Interval; 6] {
        Segment {
            origin: ray.o,
            direction: ray.d,
            t0: a,
            t1: b,
        }
        .inputs()
    }

    /// Enclosures of F and g over `[a, b]` (a point when `a = b`), and
    /// whether F is defined and continuous on all of it.
    ///
    /// g is evaluated only where F's enclosure holds 0; elsewhere it is
    /// given as the whole line, which encloses it. Every test that reads g
    /// first needs a root possible, and f's instructions come first in the
    /// tape, so a piece excluded by F (about half of them on long models)
    /// costs f's share of the tape alone.
    ///
    /// A piece inside a cell of its leaf evaluates the cell's tape, or, in
    /// a clear cell, takes f's enclosure over the cell, with no evaluation
    /// (see [`Cells`](crate::ray::octree::Cells)). A piece in no cell is cut
    /// in halves, at most [`FG_CUTS`] times, until its parts are, and their
    /// enclosures are joined: on the prospero slab, a few tapes of a few hundred
    /// instructions cost less than the leaf's of over a thousand, and their
    /// enclosures are tighter.
    ///
    /// A clear cell answers for pieces, not points: a point's own enclosure
    /// is far tighter, for the mean-value test.
    pub(super) fn fg_over(&mut self, ray: &Ray, a: f64, b: f64) -> (Interval, Interval, bool) {
        self.fg_over_parts(ray, a, b, (FG_CUTS, false))
    }

    /// [`Tracer::fg_over`], the piece cut in halves (up to `cuts` times)
    /// while it lies in no cell of its leaf, and the halves' enclosures
    /// joined (g's is the whole line where either half's F excludes 0).
    fn fg_over_parts(
        &mut self,
        ray: &Ray,
        a: f64,
        b: f64,
        (cuts, tests): (u32, bool),
    ) -> (Interval, Interval, bool) {
        if let Some(found) = self.kept_part(a, b) {
            return found;
        }
        self.fg_over_inputs(ray, a, b, &Self::piece_inputs(ray, a, b), (cuts, tests))
    }

    /// [`Tracer::fg_over_parts`] with the piece's inputs already made.
    ///
    /// With `tests`, for the search's tests of a piece alone (exclusion by
    /// F, the mean-value form, monotony, a slope bound), the second half of
    /// a cut piece is not enclosed where the first half already leaves
    /// every test undecided: F's enclosure there holds 0, and g's holds 0
    /// and is unbounded, as the joined one would, so none could pass. The
    /// piece is then given the whole line for F and g, and as not known
    /// continuous, on which the tests decide alike; the search halves it,
    /// and its second half is enclosed only if the search gets there.
    pub(super) fn fg_over_inputs(
        &mut self,
        ray: &Ray,
        a: f64,
        b: f64,
        inputs: &[Interval; 6],
        (cuts, tests): (u32, bool),
    ) -> (Interval, Interval, bool) {
        let m = a + 0.5 * (b - a);
        let octree = &self.intersector.octree;
        let whole = octree
            .short
            .in_a_cell(self.leaf, self.current, &inputs[..3]);
        if cuts > 0 && a < m && m < b && !whole {
            let (f1, g1, c1) = self.fg_over_parts(ray, a, m, (cuts - 1, tests));
            let open = f1.contains(0.0) && g1.contains(0.0) && !g1.is_bounded();
            if tests && self.first_halves && open {
                return (Interval::ENTIRE, Interval::ENTIRE, false);
            }
            let (f2, g2, c2) = self.fg_over_parts(ray, m, b, (cuts - 1, tests));
            return (f1.hull(f2), g1.hull(g2), c1 && c2);
        }
        let found = self.fg_over_one(inputs, a < b);
        // A part of a cut piece that lies in a cell: the search, halving the
        // piece where it was cut, asks for it again, and would make the same
        // evaluation (a part cut further would not be).
        if cuts < FG_CUTS && whole {
            self.keep_part((a, b), found);
        }
        found
    }

    /// Keeps the enclosures of the part `[a, b]` of a cut piece for the
    /// search's next pieces (at most [`MAX_PARTS`], the latest).
    fn keep_part(&mut self, (a, b): (f64, f64), found: (Interval, Interval, bool)) {
        if !self.keep_parts {
            return;
        }
        if self.parts.len() == MAX_PARTS {
            self.parts.remove(0);
        }
        self.parts.push(Part {
            shape: self.current,
            ends: (a, b),
            found,
        });
    }

    /// The enclosures of `[a, b]` kept as a part of a cut piece by the
    /// current shape, if they were: the same evaluation over the same
    /// inputs (the ray and the leaf are the search's own).
    pub(super) fn kept_part(&self, a: f64, b: f64) -> Option<(Interval, Interval, bool)> {
        self.parts
            .iter()
            .rev()
            .find(|p| p.shape == self.current && p.ends == (a, b))
            .map(|p| p.found)
    }

    /// The interval inputs of the points the ray's evaluation may stand
    /// for, t in `[a, b]`: [`Tracer::inputs`] widened by the ray's shift.
    pub(super) fn piece_inputs(ray: &Ray, a: f64, b: f64) -> [Interval; 6] {
        let mut inputs = Self::inputs(ray, a, b);
        if ray.shift > 0.0 {
            // The evaluated ray was moved by up to `shift` from the given one.
            let s = Interval::new(-ray.shift, ray.shift);
            for x in &mut inputs[..3] {
                *x = *x + s;
            }
        }
        inputs
    }

    /// [`Tracer::fg_over`] over the box `inputs` by one evaluation, or none
    /// where `clear` and the box lies in a clear cell.
    pub(super) fn fg_over_one(
        &mut self,
        inputs: &[Interval; 6],
        clear: bool,
    ) -> (Interval, Interval, bool) {
        let octree = &self.intersector.octree;
        let fg = &octree.shapes[self.current].fg;
        let short = octree
            .short
            .find(self.leaf, (self.current, fg), &inputs[..3], clear);
        let inputs = inputs.map(DecInterval::defined);
        if let Some(Short::Clear(f)) = short {
            // f's enclosure over the cell, which excludes 0, encloses F on
            // the piece too.
            self.stats.clear_cells += 1;
            return (
                f.interval(),
                Interval::ENTIRE,
                f.decoration() == Decoration::Dac,
            );
        }
        self.stats.interval_evals += 1;
        let evaluator = match short {
            Some(Short::Tape(k, tape)) => cached(&mut self.short, k)
                .get_or_insert_with(|| DecoratedEvaluator::reading(tape, &[0])),
            _ => &mut self.evals().fgi,
        };
        let (f, all) = evaluator.eval_first_then(&inputs, |f| f.interval().contains(0.0));
        let g = all.map_or(Interval::ENTIRE, |v| v[1].interval());
        let continuous = f.decoration() == Decoration::Dac;
        (f.interval(), g, continuous)
    }

    /// F at the ends of `piece` where it was not evaluated yet (NaN) and the
    /// sign there is not known, with the signs its f64 value certifies.
    pub(super) fn evaluate_ends(&mut self, ray: &Ray, k: &Bounds, piece: &mut Piece) {
        if piece.sa == 0 && piece.fa.is_nan() {
            piece.fa = self.f_at(ray, piece.a);
            piece.sa = certified_sign(piece.fa, k.f_err);
        }
        if piece.sb == 0 && piece.fb.is_nan() {
            piece.fb = self.f_at(ray, piece.b);
            piece.sb = certified_sign(piece.fb, k.f_err);
        }
    }

    /// The certified sign of F at t, given its f64 value and error bound;
    /// an interval enclosure at the point decides when the value cannot.
    pub(super) fn sign_at(&mut self, ray: &Ray, t: f64, f: f64, err: f64) -> i8 {
        match certified_sign(f, err) {
            0 => interval_sign(self.fg_over(ray, t, t).0),
            s => s,
        }
    }

    /// The certified sign of F at t (evaluated here).
    pub(super) fn sign_at_t(&mut self, ray: &Ray, k: &Bounds, t: f64) -> i8 {
        let f = self.f_at(ray, t);
        self.sign_at(ray, t, f, k.f_err)
    }
}

/// The cache entry of the tape with id `k`, the cache grown to hold it
/// (cells' tapes are made, and numbered, as rays go).
#[inline(always)]
fn cached<T>(cache: &mut Vec<Option<T>>, k: u32) -> &mut Option<T> {
    let k = k as usize;
    if k >= cache.len() {
        cache.resize_with(k + 1, || None);
    }
    &mut cache[k]
}
