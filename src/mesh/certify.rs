//! Which cells the mesh follows the surface in: in a certified cell the
//! surface and the mesh meet the same tetrahedra, faces and edges, each in
//! one disc, arc or point, so there the two are isotopic, and each lies
//! within the cell's diagonal of the other.
//!
//! The argument (written out in `docs/mesh.md`): let l be the linear
//! interpolant of f's values at the corners on each Kuhn tetrahedron, and
//! `F_s = (1 − s)·f + s·l`. The zero set of l is the mesh with its vertices
//! slid along their edges. If 0 is a regular value of `F_s` on every
//! simplex of the cell (tetrahedra, faces, edges, corners) for every s in
//! `[0, 1]`, the zero sets of f and l in the cell are isotopic (Thom's
//! isotopy lemma). A simplex passes, piece by piece of the cell (halved up
//! to `REFINE` times), when on each piece
//! - f and l have one strict sign, so no `F_s` is 0 there; or
//! - along one of the simplex's edges, `F_s`'s slope keeps one strict sign
//!   wherever `F_s` is 0 (`changes`).
//!
//! The slopes come from ∇f's enclosure, so f must be smooth in the cell:
//! the decorations show f and ∇f continuous and bounded, and every
//! operation of the language is smooth where it and its derivative are.

use super::distance::{Slope, WIDENINGS};
use super::lattice::{Cell, Lattice, Sign, Signs};
use super::tetra::ORDERS;
use super::Progress;
use crate::expr::tape::simplify::Decisions;
use crate::expr::DecoratedEvaluator;
use crate::expr::{Evaluator, Tape};
use crate::types::interval::{DecInterval, Decoration};
use crate::types::rounding::up_bound;
use crate::types::{Aabb, Interval};
use rayon::prelude::*;
use std::collections::HashMap;

/// Why a cell is not certified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Doubt {
    /// f may jump or lack a value in the cell.
    Jump,
    /// ∇f may jump, lack a value or be unbounded in the cell: a crease, a
    /// cone's tip.
    Kink,
    /// A corner's enclosure of f holds 0: the surface may pass through it.
    Corner,
    /// The solid reaches the box's wall, where the mesh closes it instead.
    Wall,
    /// ∇f may be at right angles to a lattice edge: the surface may fold
    /// between lattice points, touch an edge or face, or hide in the cell.
    Fold,
    /// The mesh is isotopic to the surface in the cell, but they are not
    /// proved within the tolerance of each other: the cell is too large
    /// for the surface's curvature, or a neighbour has no bound.
    Far,
}

impl Doubt {
    /// Every doubt, in the order the summary lists them.
    pub const ALL: [Doubt; 6] = [
        Doubt::Jump,
        Doubt::Kink,
        Doubt::Corner,
        Doubt::Wall,
        Doubt::Fold,
        Doubt::Far,
    ];

    /// What the doubt means, for a summary.
    pub fn describe(self) -> &'static str {
        match self {
            Doubt::Jump => "f may jump",
            Doubt::Kink => "∇f may jump or be unbounded",
            Doubt::Corner => "the surface may pass through a lattice point",
            Doubt::Wall => "the solid reaches the box's wall",
            Doubt::Fold => "the surface may fold between lattice points",
            Doubt::Far => {
                "the mesh is isotopic to the surface but not proved within the tolerance of it"
            }
        }
    }
}

/// A cell the mesh may not follow the surface in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertified {
    /// The cell.
    pub cell: Aabb,
    /// The first reason found.
    pub doubt: Doubt,
}

/// What is certified of a mesh's cells.
#[derive(Debug, Clone, Default)]
pub struct Certificate {
    /// Cells where the mesh and the surface are isotopic and within the
    /// tolerance of each other.
    pub certified: usize,
    /// The other cells, ordered by their lowest corner.
    pub uncertified: Vec<Uncertified>,
    /// In a certified cell, the mesh and the surface are within this of
    /// each other, both ways.
    pub tolerance: f64,
    /// In a certified cell, each point of the surface is within this of the
    /// mesh and each point of the mesh within this of the surface: the
    /// larger of the two below, at most `tolerance`; 0 where no cell is
    /// certified.
    pub hausdorff: f64,
    /// In a certified cell, each point of the mesh is within this of the
    /// surface ([`super::hausdorff`]).
    pub mesh_to_surface: f64,
    /// In a certified cell, each point of the surface is within this of the
    /// mesh ([`super::hausdorff`]).
    pub surface_to_mesh: f64,
}

impl Certificate {
    /// Whether every cell is certified, so the whole mesh is isotopic to
    /// the surface in the box and within the tolerance of it.
    pub fn is_complete(&self) -> bool {
        self.uncertified.is_empty()
    }

    /// The distances after the mesh is scaled by `scale` and each vertex
    /// then moved by at most `moved` (placed in a scene, rounded to f32),
    /// with the tolerance scaled to `tolerance`. Certification left room
    /// for the moves within the tolerance, so no distance passes it.
    pub fn moved(&mut self, scale: f64, moved: f64, tolerance: f64) {
        self.tolerance = tolerance;
        if self.certified > 0 {
            let grow = |d: f64| up_bound(scale * d + moved).min(tolerance);
            self.hausdorff = grow(self.hausdorff);
            self.mesh_to_surface = grow(self.mesh_to_surface);
            self.surface_to_mesh = grow(self.surface_to_mesh);
        }
    }

    /// How many cells have the doubt `d`.
    pub fn count(&self, d: Doubt) -> usize {
        self.uncertified.iter().filter(|u| u.doubt == d).count()
    }
}

/// Certifies every cell, and gives each certified one f's slope around it
/// where one is found for triangles whose corners are within `radius` of
/// roots. `f` is f's tape, `gradient` that of f, ∂f/∂x, ∂f/∂y and ∂f/∂z,
/// `second` that of [`super::distance::OUTPUTS`].
#[allow(clippy::too_many_arguments)]
pub fn certify(
    f: &Tape,
    gradient: &Tape,
    second: &Tape,
    lattice: &Lattice,
    cells: &[Cell],
    signs: &Signs,
    level: u32,
    radius: f64,
    report: &(dyn Fn(Progress) + Sync),
) -> (Certificate, Vec<Verdict>) {
    let simplices = simplices();
    let branches = gradient.has_branches();
    // In chunks, each reported once it is done.
    let results: Vec<(Option<Doubt>, Aabb, Verdict)> = cells
        .par_chunks(CHUNK)
        .flat_map_iter(|chunk| {
            let mut decorated = DecoratedEvaluator::new(gradient);
            let mut plain = Evaluator::<Interval>::new(gradient);
            let mut curvature = DecoratedEvaluator::new(second);
            // Short tapes by how the cell settles the branches (none where a
            // branch ∇f reads is left open): neighbouring cells mostly
            // settle them alike.
            let mut short: HashMap<Decisions, Option<Tape>> = HashMap::new();
            // How many of the chunk's cells each widening gave a slope:
            // neighbouring cells mostly need the same.
            let mut widenings = [0u32; WIDENINGS.len()];
            let out: Vec<(Option<Doubt>, Aabb, Verdict)> = chunk
                .iter()
                .map(|c| {
                    let b = lattice.cell(c.corner, level);
                    let mut creased = None;
                    let doubt = corners(c, signs).and_then(|corners| {
                        if !branches {
                            creased = Some(false);
                            return fold(&mut decorated, &mut plain, &b, corners, &simplices);
                        }
                        // A branch the cell leaves open may put a crease
                        // through it. f's are asked first, stopping at the
                        // first open one: its tape is the shorter, and on
                        // models most cells have one. An open branch of f
                        // that only settled ones read is taken for a crease
                        // too; finding it dead costs f's whole tape, which
                        // doubled the bear's certification to certify half
                        // a percent more of its cells.
                        let open = match c.settled {
                            Some(settled) => !settled,
                            None => f.settled_all_over(&inputs(&b)).is_none(),
                        };
                        creased = Some(open);
                        if open {
                            return Err(Doubt::Kink);
                        }
                        // ∇f's open branches count only where read.
                        let decisions = gradient.settled_over(&inputs(&b));
                        if short.len() >= SHORT_TAPES && !short.contains_key(&decisions) {
                            short.clear();
                        }
                        let tape = short.entry(decisions).or_insert_with_key(|d| {
                            (!gradient.leaves_open(d)).then(|| gradient.shortened(d))
                        });
                        let Some(tape) = tape else {
                            return Err(Doubt::Kink);
                        };
                        let mut decorated = DecoratedEvaluator::new(tape);
                        let mut plain = Evaluator::new(tape);
                        fold(&mut decorated, &mut plain, &b, corners, &simplices)
                    });
                    let verdict = match doubt {
                        Ok(()) => {
                            // The widening most of the chunk's cells needed
                            // so far (the narrowest of those tied).
                            let first = (0..WIDENINGS.len())
                                .rev()
                                .max_by_key(|&i| widenings[i])
                                .unwrap_or(0);
                            let (slope, used) =
                                Slope::around_from(&mut curvature, &b, radius, first);
                            if slope.is_some() {
                                widenings[used] += 1;
                            }
                            Verdict::Certified(slope)
                        }
                        Err(_) => Verdict::Uncertified { creased },
                    };
                    (doubt.err(), b, verdict)
                })
                .collect();
            report(Progress::Certified(chunk.len() as u64));
            out
        })
        .collect();
    let mut certificate = Certificate::default();
    let mut verdicts = Vec::with_capacity(results.len());
    for (d, b, verdict) in results {
        verdicts.push(verdict);
        match d {
            None => certificate.certified += 1,
            Some(doubt) => certificate.uncertified.push(Uncertified { cell: b, doubt }),
        }
    }
    (certificate, verdicts)
}

/// What certification found of one cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// The mesh and the surface may differ in topology in it; `creased`
    /// says whether a branch of f is open over it, where that was asked.
    Uncertified {
        /// `Some(true)` where f's enclosure over the cell leaves a
        /// `min`/`max`-like branch open, `Some(false)` where it settles all,
        /// `None` where certification stopped before asking.
        creased: Option<bool>,
    },
    /// The mesh is isotopic to the surface in it; f's slope around it, where
    /// one was found, bounds how far each triangle is from the surface.
    Certified(Option<Slope>),
}

/// The inputs of a tape over the box `b`.
pub(super) fn inputs(b: &Aabb) -> [DecInterval; 6] {
    let [x, y, z] = b.intervals().map(DecInterval::defined);
    let zero = DecInterval::defined(Interval::ZERO);
    [x, y, z, zero, zero, zero]
}

/// The sign of an interval: `Some(true)` if positive, `Some(false)` if
/// negative, `None` if it may hold 0 or has no value.
fn strict_sign(x: Interval) -> Option<bool> {
    if x.is_empty() || x.inf().is_nan() || x.sup().is_nan() {
        None
    } else if x.inf() > 0.0 {
        Some(true)
    } else if x.sup() < 0.0 {
        Some(false)
    } else {
        None
    }
}

/// Cells certified by one job between reports.
const CHUNK: usize = 1024;

/// Short tapes one job keeps (a model's can be thousands of instructions).
const SHORT_TAPES: usize = 64;

/// How many times a cell is halved, at most, to certify its simplices
/// piece by piece.
const REFINE: u32 = 2;

/// The fewest pieces one cell may enclose: each costs an evaluation of f and
/// ∇f, which on a model of thousands of operations costs more than the rest
/// of the cell's meshing.
const PIECES: u32 = 16;

/// The most pieces one cell may enclose, where ∇f's tape is short.
const MOST_PIECES: u32 = 64;

/// Instructions of ∇f's tape a cell may run on its pieces: [`PIECES`] runs of
/// a tape of 512.
const PIECE_WORK: usize = PIECES as usize * 512;

/// How many pieces a cell whose ∇f is `tape` may enclose: as many as
/// [`PIECE_WORK`] pays for, from [`PIECES`] to [`MOST_PIECES`].
fn pieces_for(tape: &Tape) -> u32 {
    let runs = PIECE_WORK / tape.body().len().max(1);
    runs.clamp(PIECES as usize, MOST_PIECES as usize) as u32
}

/// What is known of f and of l over the part of a simplex in one piece of
/// the cell.
#[derive(Debug, Clone, Copy)]
struct Enclosure {
    /// f there.
    f: Interval,
    /// l there.
    l: Interval,
    /// f's slope along each direction (bit `a` for a step of the cell along
    /// axis `a`) there.
    slopes: [Interval; 8],
}

/// One cell's test, with the enclosures of its pieces found so far.
struct CellTest<'e, 't> {
    plain: &'e mut Evaluator<'t, Interval>,
    b: Aabb,
    /// The cell's lower corner, and its edge along each axis, enclosed: the
    /// ends are floats, their difference is not always one.
    lo: [Interval; 3],
    width: [Interval; 3],
    /// f's enclosure at each corner.
    at: [Interval; 8],
    /// Each corner's proved sign.
    positive: [bool; 8],
    /// The enclosures found so far, by halving, piece and simplex (a mask of
    /// corners): `None` where ∇f is unbounded, `Some(None)` where the
    /// simplex misses the piece.
    pieces: std::collections::HashMap<(u32, [u32; 3], u8), Option<Option<Enclosure>>>,
    /// Pieces the cell may still enclose.
    budget: u32,
}

impl CellTest<'_, '_> {
    /// The point of the cell at `u` (in the cell's coordinates), enclosed,
    /// and kept in `within`.
    fn space(&self, u: [Interval; 3], within: &Aabb) -> [Interval; 3] {
        [0, 1, 2].map(|a| {
            let v = if u[a].sup() == 0.0 {
                Interval::point(self.b.lo[a])
            } else if u[a].inf() == 1.0 {
                Interval::point(self.b.hi[a])
            } else {
                self.lo[a] + self.width[a] * u[a]
            };
            v.intersection(Interval::new(within.lo[a], within.hi[a]))
        })
    }

    /// The enclosures over the part of simplex `corners` in piece `i` at
    /// halving `k` (see [`CellTest::pieces`]).
    fn piece(&mut self, k: u32, i: [u32; 3], corners: &[usize]) -> Option<Option<Enclosure>> {
        let mask = corners.iter().fold(0u8, |m, &c| m | 1 << c);
        let key = (k, i, mask);
        if let Some(e) = self.pieces.get(&key) {
            return *e;
        }
        if self.budget == 0 {
            return None;
        }
        self.budget -= 1;
        let e = self.enclose(k, i, corners);
        self.pieces.insert(key, e);
        e
    }

    /// [`CellTest::piece`], found.
    fn enclose(&mut self, k: u32, i: [u32; 3], corners: &[usize]) -> Option<Option<Enclosure>> {
        // The pieces are the cells of the cell's own lattice.
        let pb = Lattice::new(&self.b).cell(i, k);
        let local = [0, 1, 2].map(|a| {
            let u = (Interval::new(pb.lo[a], pb.hi[a]) - self.lo[a]) / self.width[a];
            u.intersection(Interval::new(0.0, 1.0))
        });
        let Some(t) = tails(corners, local) else {
            return Some(None);
        };
        let m = corners.len();
        let axis = |t: &[Interval], a: usize| {
            let j = (0..m).find(|&j| corners[j] >> a & 1 == 1).unwrap_or(m);
            t[j]
        };
        let zero = Interval::ZERO;
        // The corner of the part with every tail sum least, for the
        // mean-value form below.
        let least: Vec<Interval> = t.iter().map(|x| Interval::point(x.inf())).collect();
        let [x, y, z] = self.space([0, 1, 2].map(|a| axis(&least, a)), &pb);
        let f_least = self
            .plain
            .eval_first_then(&[x, y, z, zero, zero, zero], |_| false)
            .0;
        let [x, y, z] = self.space([0, 1, 2].map(|a| axis(&t, a)), &pb);
        let out = self.plain.eval(&[x, y, z, zero, zero, zero]);
        let (f, gradient) = (out[0], [out[1], out[2], out[3]]);
        if !gradient.iter().all(|g| g.is_bounded()) {
            return None;
        }
        let slopes = slopes(gradient, self.width);
        // A point of the simplex is c₀ + Σ tⱼ·(cⱼ − cⱼ₋₁): f there is f at the
        // least corner plus Σ (slope along cⱼ − cⱼ₋₁)·(tⱼ − its least), and
        // l is linear in the tⱼ.
        let (mut f_mean, mut l) = (f_least, self.at[corners[0]]);
        for j in 1..m {
            let step = Interval::new(0.0, t[j].wid());
            f_mean = f_mean + slopes[corners[j] ^ corners[j - 1]] * step;
            l = l + (self.at[corners[j]] - self.at[corners[j - 1]]) * t[j];
        }
        Some(Some(Enclosure {
            f: f.intersection(f_mean),
            l,
            slopes,
        }))
    }

    /// Whether `0` is a regular value of every `F_s` on the part of each
    /// simplex of `hard` in the cell, halving pieces where needed.
    fn regular(&mut self, hard: &[&[usize]]) -> bool {
        // Level by level, every simplex at once: each failed piece needs
        // its eight halves, so as soon as a level's failures and its pieces
        // still to enclose need more than the budget, the cell fails (most
        // cells that fail would otherwise spend it all). Success needs the
        // same pieces in any order, so the verdict is that of a search in
        // any order.
        let mut pieces: Vec<(&[usize], [u32; 3])> = hard.iter().map(|&s| (s, [0; 3])).collect();
        for k in 0..=REFINE {
            let mut failed = Vec::new();
            for (n, &(simplex, i)) in pieces.iter().enumerate() {
                match self.piece(k, i, simplex) {
                    None => return false,
                    Some(None) => {}
                    Some(Some(e)) => {
                        if !self.regular_on(simplex, &e) {
                            failed.push((simplex, i));
                            let later = pieces.len() - n - 1;
                            if k == REFINE || later + 8 * failed.len() > self.budget as usize {
                                return false;
                            }
                        }
                    }
                }
            }
            if failed.is_empty() {
                return true;
            }
            pieces = failed
                .iter()
                .flat_map(|&(simplex, i)| {
                    (0..8u32).map(move |o| (simplex, [0, 1, 2].map(|a| 2 * i[a] + (o >> a & 1))))
                })
                .collect();
        }
        false
    }

    /// The test on one piece: there F_s is never 0 (f and l have one strict
    /// sign), or F_s changes along an edge of the simplex wherever it is 0.
    fn regular_on(&self, corners: &[usize], e: &Enclosure) -> bool {
        let one_sign = corners
            .iter()
            .all(|&k| self.positive[k] == self.positive[corners[0]]);
        let l = if one_sign {
            Interval::point(if self.positive[corners[0]] { 1.0 } else { -1.0 })
        } else {
            e.l
        };
        if strict_sign(l).is_some() && strict_sign(e.f) == strict_sign(l) {
            return true;
        }
        corners.iter().enumerate().any(|(j, &v)| {
            // The corners nest: `v`'s bits are in `w`'s.
            corners[j + 1..]
                .iter()
                .any(|&w| changes(e.f, e.l, e.slopes[v ^ w], self.at[w] - self.at[v]))
        })
    }
}

/// Whether `F_s = (1 − s)·f + s·l` has a nonzero derivative along a
/// direction wherever it is 0, for every `s` in `[0, 1]`, given f and l
/// over a piece and their slopes `f_u`, `l_u` along the direction.
///
/// Where `F_s = 0`, `r = s/(1 − s) = −f/l` lies between `|f|`'s least over
/// `|l|`'s greatest and the other way round, and the slope is a positive
/// multiple of `f_u + r·l_u`, which is affine in r: it keeps one sign if it
/// has that sign at both ends (at `r = ∞`, l_u's).
fn changes(f: Interval, l: Interval, f_u: Interval, l_u: Interval) -> bool {
    if l.mag() == 0.0 || strict_sign(l_u).is_none() {
        return false;
    }
    let r_lo = (Interval::point(f.mig()) / Interval::point(l.mag())).inf();
    let at_lo = strict_sign(f_u + Interval::point(r_lo) * l_u);
    if at_lo.is_none() {
        return false;
    }
    if l.mig() == 0.0 {
        return at_lo == strict_sign(l_u);
    }
    let r_hi = (Interval::point(f.mag()) / Interval::point(l.mig())).sup();
    r_hi.is_finite() && at_lo == strict_sign(f_u + Interval::point(r_hi) * l_u)
}

/// The ranges of the tail sums `t₀ … t_m` of the part of the simplex
/// `corners` in the box `local` (in the cell's coordinates), or `None` where
/// they do not meet.
///
/// The corners nest, each one's bits holding the one before's, so a point
/// of the simplex is `Σ λⱼ·cⱼ` and its coordinate on axis `a` is the tail
/// sum `tⱼ = λⱼ + … + λ_{m−1}` from the first corner `j` with bit `a` on
/// (`t₀ = 1`; `t_m = 0` for axes of no corner), with `t₀ ≥ t₁ ≥ … ≥ t_m`.
fn tails(corners: &[usize], local: [Interval; 3]) -> Option<Vec<Interval>> {
    let m = corners.len();
    let mut t: Vec<(f64, f64)> = (0..=m)
        .map(|j| match j {
            0 => (1.0, 1.0),
            j if j == m => (0.0, 0.0),
            _ => (0.0, 1.0),
        })
        .collect();
    for (a, u) in local.iter().enumerate() {
        let j = (0..m).find(|&j| corners[j] >> a & 1 == 1).unwrap_or(m);
        t[j] = (t[j].0.max(u.inf()), t[j].1.min(u.sup()));
    }
    for j in 1..=m {
        t[j].1 = t[j].1.min(t[j - 1].1);
    }
    for j in (0..m).rev() {
        t[j].0 = t[j].0.max(t[j + 1].0);
    }
    if t.iter()
        .any(|&(lo, hi)| lo > hi || lo.is_nan() || hi.is_nan())
    {
        return None;
    }
    Some(
        t.into_iter()
            .map(|(lo, hi)| Interval::new(lo, hi))
            .collect(),
    )
}

/// f's slope along each lattice direction `d` (bit `a` set for a step of
/// the cell along axis `a`), from ∇f's enclosure.
fn slopes(gradient: [Interval; 3], width: [Interval; 3]) -> [Interval; 8] {
    // Each axis's term once, summed in the order of the axes (0 + x is x).
    let [x, y, z] = [0, 1, 2].map(|a| gradient[a] * width[a]);
    let xy = x + y;
    [Interval::ZERO, x, y, xy, z, x + z, y + z, xy + z]
}

/// The corners' signs and f's enclosures at them, if every sign is proved
/// and the mesh takes it, else why the cell is not certified.
type Corners = ([bool; 8], [Interval; 8]);

/// [`Corners`] of cell `c`.
fn corners(c: &Cell, signs: &Signs) -> Result<Corners, Doubt> {
    if !c.continuous {
        return Err(Doubt::Jump);
    }
    // Corner `o` is `c.corner` plus bit `a` of `o` on axis `a`.
    let mut positive = [false; 8];
    let at = signs.cube(c.corner);
    let mut worst = None;
    for (o, s) in positive.iter_mut().enumerate() {
        let p = [0, 1, 2].map(|a| c.corner[a] + (o as u32 >> a & 1));
        let on_wall = signs.on_wall(p);
        match Sign::of(at[o]) {
            Sign::Positive => *s = true,
            Sign::Negative if on_wall => worst = worst.max(Some(Doubt::Wall)),
            Sign::Negative => {}
            Sign::Zero | Sign::Undefined => worst = Some(Doubt::Corner),
        }
    }
    match worst {
        Some(d) => Err(d),
        None => Ok((positive, at)),
    }
}

/// Whether every simplex of the cell `b` (corners' signs `positive`) passes,
/// with evaluators of f and ∇f there; else why not.
fn fold(
    decorated: &mut DecoratedEvaluator<'_>,
    plain: &mut Evaluator<'_, Interval>,
    b: &Aabb,
    corners: Corners,
    simplices: &[Simplex],
) -> Result<(), Doubt> {
    fold_by(decorated, plain, b, corners, simplices, |test, hard| {
        test.regular(hard)
    })
}

/// [`fold`], with the simplices that fail their quick test passed to
/// `search`, the test piece by piece.
fn fold_by(
    decorated: &mut DecoratedEvaluator<'_>,
    plain: &mut Evaluator<'_, Interval>,
    b: &Aabb,
    (positive, at): Corners,
    simplices: &[Simplex],
    search: impl FnOnce(&mut CellTest<'_, '_>, &[&[usize]]) -> bool,
) -> Result<(), Doubt> {
    let [x, y, z] = b.intervals().map(DecInterval::defined);
    let zero = DecInterval::defined(Interval::point(0.0));
    let out = decorated.eval(&[x, y, z, zero, zero, zero]);
    let smooth = out[..4]
        .iter()
        .all(|v| v.decoration() == Decoration::Dac && v.interval().is_bounded());
    if !smooth {
        return Err(Doubt::Kink);
    }
    let lo = [0, 1, 2].map(|a| Interval::point(b.lo[a]));
    let width = [0, 1, 2].map(|a| Interval::point(b.hi[a]) - lo[a]);
    let cell_slopes = slopes([1, 2, 3].map(|k| out[k].interval()), width);
    let budget = pieces_for(plain.tape());
    let mut test = CellTest {
        plain,
        b: *b,
        lo,
        width,
        at,
        positive,
        pieces: Default::default(),
        budget,
    };
    // Most simplices pass on the cell's own enclosures: f is monotone along
    // one of their edges over the whole cell (then so is l, the same way),
    // or keeps its corners' sign by the mean-value form. The rest are
    // split into pieces, after every simplex has had its quick test.
    let positive_mask = (0..8).fold(0u8, |m, k| m | (positive[k] as u8) << k);
    // The lattice directions f is monotone along over the whole cell.
    let monotone = (0..8).fold(0u8, |m, d| {
        m | (strict_sign(cell_slopes[d]).is_some() as u8) << d
    });
    let mut hard: Vec<&[usize]> = Vec::new();
    for simplex in simplices {
        let signs = positive_mask & simplex.mask;
        let one_sign = signs == 0 || signs == simplex.mask;
        let quick = if one_sign {
            keeps_sign(&test.at, &cell_slopes, &simplex.corners)
        } else {
            simplex.directions & monotone != 0
        };
        if !quick {
            hard.push(&simplex.corners);
        }
    }
    if !search(&mut test, &hard) {
        return Err(Doubt::Fold);
    }
    Ok(())
}

/// A simplex of a cell's Kuhn tetrahedra, with the masks its quick tests
/// read.
#[derive(Debug, Clone)]
struct Simplex {
    /// Its corners in order, each one's bits holding the one before's.
    corners: Vec<usize>,
    /// Bit `k` for corner `k`.
    mask: u8,
    /// Bit `d` for each lattice direction `d` between two of its corners.
    directions: u8,
}

/// Every simplex of two or more corners of the cell's Kuhn tetrahedra, each
/// once.
fn simplices() -> Vec<Simplex> {
    corner_lists()
        .into_iter()
        .map(|corners| {
            let mask = corners.iter().fold(0u8, |m, &c| m | 1 << c);
            let directions = corners.iter().fold(0u8, |m, &v| {
                corners
                    .iter()
                    .filter(|&&w| w != v)
                    .fold(m, |m, &w| m | 1 << (v ^ w))
            });
            Simplex {
                corners,
                mask,
                directions,
            }
        })
        .collect()
}

/// The corners of every simplex of two or more corners of the cell's Kuhn
/// tetrahedra, each once, in order (each one's bits holding the one
/// before's).
fn corner_lists() -> Vec<Vec<usize>> {
    let mut all: Vec<(u8, Vec<usize>)> = Vec::new();
    for order in ORDERS {
        let mut tet = [0usize; 4];
        for k in 0..3 {
            tet[k + 1] = tet[k] | 1 << order[k];
        }
        for subset in 1u32..16 {
            if subset.count_ones() < 2 {
                continue;
            }
            let simplex: Vec<usize> = (0..4)
                .filter(|k| subset >> k & 1 == 1)
                .map(|k| tet[k])
                .collect();
            // A simplex is named by its corners; faces and edges are
            // shared between tetrahedra. Fewer than 64 distinct ones.
            let mask = simplex.iter().fold(0u8, |m, &c| m | 1 << c);
            if !all.iter().any(|(m, _)| *m == mask) {
                all.push((mask, simplex));
            }
        }
    }
    all.into_iter().map(|(_, s)| s).collect()
}

/// Whether f keeps one strict sign over the simplex `corners`, by the
/// mean-value theorem: f(p) = f(v) + Σ λ_w·(f's slope from v to w somewhere),
/// with λ_w ≥ 0 summing to at most 1, for some corner v.
fn keeps_sign(at: &[Interval; 8], slopes: &[Interval; 8], corners: &[usize]) -> bool {
    corners.iter().any(|&v| {
        let worst = corners
            .iter()
            .filter(|&&w| w != v)
            .fold(Interval::ZERO, |h, &w| {
                let s = slopes[v ^ w];
                h.hull(if w > v { s } else { -s })
            });
        strict_sign(at[v] + worst).is_some()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formula::{Formula, Output};
    use crate::mesh::lattice::find_cells;
    use proptest::prelude::*;

    /// The search piece by piece as first written: depth first, each
    /// simplex in turn, until a piece fails at the last halving or the
    /// budget runs out.
    fn depth_first(test: &mut CellTest<'_, '_>, hard: &[&[usize]]) -> bool {
        fn regular(test: &mut CellTest<'_, '_>, corners: &[usize], k: u32, i: [u32; 3]) -> bool {
            let e = match test.piece(k, i, corners) {
                None => return false,
                Some(None) => return true,
                Some(Some(e)) => e,
            };
            if test.regular_on(corners, &e) {
                return true;
            }
            k < REFINE
                && (0..8u32).all(|o| {
                    let child = [0, 1, 2].map(|a| 2 * i[a] + (o >> a & 1));
                    regular(test, corners, k + 1, child)
                })
        }
        hard.iter().all(|s| regular(test, s, 0, [0; 3]))
    }

    /// Searching level by level, failing as soon as the budget cannot hold
    /// a level, certifies exactly the cells the depth-first search does, on
    /// coarse lattices where many cells need pieces and many fail.
    #[test]
    fn pieces_searched_level_by_level_give_the_depth_first_verdicts() {
        let b = Aabb::new(glam::DVec3::splat(-1.0), glam::DVec3::splat(1.0)).unwrap();
        let lattice = Lattice::new(&b);
        let simplices = simplices();
        let (mut passed, mut failed) = (0, 0);
        for (formula, level) in [
            ("(sqrt(x^2+y^2)-0.6)^2+z^2-0.04", 4),
            ("sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x)", 3),
            (
                "exp(-8*((x-0.3)^2+y^2+z^2))+exp(-8*((x+0.3)^2+y^2+z^2))-0.6",
                3,
            ),
        ] {
            let formula = Formula::parse(formula).unwrap();
            let f = formula.tape(&[Output::F]);
            let gradient = formula.tape(&[Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz]);
            let found = find_cells(&f, &lattice, level, usize::MAX);
            let signs = Signs::of_corners(&f, &lattice, &found.cells, found.level);
            let mut decorated = DecoratedEvaluator::new(&gradient);
            let mut plain = Evaluator::new(&gradient);
            for c in &found.cells {
                let Ok(at) = corners(c, &signs) else { continue };
                let cell = lattice.cell(c.corner, found.level);
                let ours = fold(&mut decorated, &mut plain, &cell, at, &simplices);
                let reference = fold_by(
                    &mut decorated,
                    &mut plain,
                    &cell,
                    at,
                    &simplices,
                    depth_first,
                );
                assert_eq!(ours, reference, "{formula:?} at {cell:?}");
                match ours {
                    Ok(()) => passed += 1,
                    Err(Doubt::Fold) => failed += 1,
                    Err(_) => {}
                }
            }
        }
        assert!(
            passed > 50 && failed > 50,
            "{passed} passed, {failed} failed"
        );
    }

    proptest! {
        #[test]
        fn tails_hold_every_point_of_the_simplex_in_the_box(
            pick in 0usize..64,
            lo in prop::array::uniform3(0.0f64..1.0),
            size in prop::array::uniform3(0.0f64..0.6),
            weights in prop::collection::vec(0.0f64..1.0, 4),
        ) {
            let all = corner_lists();
            let simplex = &all[pick % all.len()];
            let local = [0, 1, 2].map(|a| Interval::new(lo[a], (lo[a] + size[a]).min(1.0)));
            // A point of the simplex, from barycentric weights.
            let w = &weights[..simplex.len()];
            let total: f64 = w.iter().sum::<f64>().max(1e-9);
            let u = [0, 1, 2].map(|a| {
                simplex
                    .iter()
                    .zip(w)
                    .filter(|(&c, _)| c >> a & 1 == 1)
                    .map(|(_, &x)| x / total)
                    .sum::<f64>()
            });
            let inside = (0..3).all(|a| local[a].contains(u[a]));
            match tails(simplex, local) {
                Some(t) if inside => {
                    for (a, &ua) in u.iter().enumerate() {
                        let j = (0..simplex.len()).find(|&j| simplex[j] >> a & 1 == 1).unwrap_or(simplex.len());
                        // u is a rounded sum; the tails' ends are exact.
                        let tolerance = 1e-12;
                        prop_assert!(t[j].inf() - tolerance <= ua && ua <= t[j].sup() + tolerance);
                    }
                }
                Some(_) => {}
                None => prop_assert!(!inside, "{simplex:?} misses {local:?}, yet holds {u:?}"),
            }
        }

        #[test]
        fn changes_means_one_sign_of_the_slope_wherever_the_blend_is_zero(
            f in (-1.0f64..1.0, 0.0f64..1.0),
            l in (-1.0f64..1.0, 0.0f64..1.0),
            f_u in (-1.0f64..1.0, 0.0f64..1.0),
            l_u in (-1.0f64..1.0, 0.0f64..1.0),
            picks in prop::collection::vec(prop::array::uniform4(0.0f64..=1.0), 32),
        ) {
            let iv = |(lo, w): (f64, f64)| Interval::new(lo, lo + w);
            let (fi, li, fui, lui) = (iv(f), iv(l), iv(f_u), iv(l_u));
            prop_assume!(changes(fi, li, fui, lui));
            let at = |x: Interval, t: f64| x.inf() + t * (x.sup() - x.inf());
            let mut signs = Vec::new();
            for p in &picks {
                let (fv, lv) = (at(fi, p[0]), at(li, p[1]));
                // Where (1 − s)·f + s·l = 0 for some s in [0, 1] …
                if fv == lv || (fv > 0.0) == (lv > 0.0) && fv != 0.0 && lv != 0.0 {
                    continue;
                }
                let s = fv / (fv - lv);
                let slope = (1.0 - s) * at(fui, p[2]) + s * at(lui, p[3]);
                prop_assert!(slope != 0.0);
                signs.push(slope > 0.0);
            }
            // … the slope along the direction has one sign.
            prop_assert!(signs.windows(2).all(|w| w[0] == w[1]), "{fi:?} {li:?} {fui:?} {lui:?}");
        }
    }
}
