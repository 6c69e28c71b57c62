//! The search of one leaf: Kalra and Barr's tests on pieces of the ray.

use super::bounds::*;
use super::piece::*;
use super::*;
use crate::ray::answer::{placement, Answer};
use crate::ray::octree::{Leaf, SplitLeaf};
use crate::ray::seam::Seam;
use crate::ray::taylor::Expansion;
use crate::types::rounding::up_test as up;
use crate::types::rounding::{ROUNDINGS_3, ROUNDINGS_7};

/// Pieces of a split leaf longer than this fraction of the leaf's part of
/// the ray are halved rather than enclosed when no side holds on them.
pub(super) const SPLIT_HALVINGS: f64 = 1.0 / 1024.0;

impl<'s> Tracer<'s> {
    /// The start test of a ray leaving the surface at `t0`, with bounds `k`
    /// (second order) of the current shape over a box the ray crosses from
    /// t0: where F(t0) and g(t0) share a certified sign, F keeps it while its
    /// lower (upper) Taylor parabola does, for `t − t0 < 2·(|g(t0)| − err)/G`.
    /// `Ok(end)`: no root on `[t0, end)` (up to where the box's G holds);
    /// `Err((f, sign))`: F's value at t0 and its certified sign (maybe 0).
    pub(super) fn leave_start(&mut self, ray: &Ray, k: &Bounds, t0: f64) -> Result<f64, (f64, i8)> {
        let (fa, ga) = self.fg_at(ray, t0);
        let sa = certified_sign(fa, k.f_err);
        if sa == 0 || certified_sign(ga, k.g_err) != sa {
            return Err((fa, sa));
        }
        // Lowered by a bound of the subtraction's rounding.
        let slope = ga.abs() - k.g_err - ROUNDINGS_3 * ga.abs();
        let reach = if k.g > 0.0 {
            2.0 * slope / k.g
        } else {
            f64::INFINITY
        };
        // A thousandth off the reach covers the roundings of it and of the
        // sum, when the reach is not lost beside t0 itself.
        if slope > 0.0 && reach > 1e-9 * t0.abs() {
            Ok(t0 + 0.999 * reach)
        } else {
            Err((fa, sa))
        }
    }

    /// The side of `split` that F is on the whole piece of the ray within
    /// `hh` of `m`, and that side's F and g at m: the sides' difference
    /// `C = F₁ − F₂` at m is farther from 0 than C can move over the piece
    /// (`(L₁ + L₂)·|d|·hh`, or where both sides have G,
    /// `|C′(m)|·hh + ½(G₁ + G₂)·hh²`) plus the error of its value, so C keeps
    /// its sign there and F is the larger (smaller) side throughout.
    /// [`Side::Clear`] where a side alone proves the piece has no root (the
    /// other side is then not evaluated), [`Side::Undecided`] where neither
    /// is proved, with both sides' values where they have first-order
    /// bounds. Leaves `self.current` at the last side evaluated. Each side's
    /// bounds along the ray are made on first use.
    #[inline(always)]
    pub(super) fn side_of(
        &mut self,
        split: &SplitLeaf,
        bounds: &mut [Option<Bounds>; 2],
        ray: &Ray,
        m: f64,
        hh: f64,
    ) -> Side {
        let mut values = [(f64::NAN, f64::NAN); 2];
        let mut reach = 0.0;
        let mut err = 0.0;
        // C′ = g₁ − g₂ and |C″| ≤ G₁ + G₂, where both sides have them.
        let (mut g_err, mut curvature, mut second_order) = (0.0, 0.0, true);
        let first = self.side_first;
        for at in [first, 1 - first] {
            let side = &split.sides[at];
            let k = *bounds[at].get_or_insert_with(|| Bounds::new(side, ray));
            if !k.first_order {
                return Side::Undecided(None);
            }
            reach += k.lt;
            err += k.f_err;
            g_err += k.g_err;
            curvature += k.g;
            second_order &= k.second_order;
            self.current = side.shape as usize;
            values[at] = self.fg_at(ray, m);
            // F is at least (most) this side: where the side has no root on
            // the piece and is above (below) 0 there, neither has F.
            if (values[at].0 > 0.0) == split.larger && k.excludes(values[at], hh) {
                self.side_first = at;
                return Side::Clear;
            }
        }
        let c = values[0].0 - values[1].0;
        // |fl(x − y) − (x − y)| ≤ ε/2·|fl(x − y)|; a further 3.5ε covers the
        // roundings of this bound itself.
        let low = c.abs() * (1.0 - ROUNDINGS_7) - up(err);
        let mut moves = up(up(reach) * hh);
        if second_order {
            // Second order, as Kalra and Barr's test on F: C moves by at
            // most |C′(m)|·hh + ½·|C″|·hh², with C′(m) computed within both
            // g errors and the subtraction's rounding.
            let slope = (values[0].1 - values[1].1).abs() * (1.0 + ROUNDINGS_7) + up(g_err);
            let second = up(up(slope * hh) + up(0.5 * curvature * hh * hh));
            if second < moves {
                moves = second;
            }
        }
        if c.is_nan() || low.partial_cmp(&moves) != Some(std::cmp::Ordering::Greater) {
            return Side::Undecided(Some(values));
        }
        let at = if (c > 0.0) == split.larger { 0 } else { 1 };
        Side::On(at as u8 + 1, values[at])
    }

    /// The first root on `[t0, t1]` inside one leaf.
    #[inline(always)]
    pub(super) fn in_leaf(
        &mut self,
        leaf: &Leaf,
        index: usize,
        ray: &Ray,
        t0: f64,
        t1: f64,
        budget: &mut u32,
    ) -> Answer {
        // Split leaves (all creased) get their own copy of the search, so
        // the others pay nothing for the choice of sides.
        let intersector = self.intersector;
        // The leaf's short tapes serve only its own search: its bounds are
        // the ones their f64 values are judged by.
        self.leaf = index;
        let answer = match (leaf.needs_intervals && ray.fast)
            .then(|| intersector.octree.split(index))
            .flatten()
        {
            Some(split) => self.search_leaf::<true>(leaf, Some(split), ray, t0, t1, budget),
            None => self.search_leaf::<false>(leaf, None, ray, t0, t1, budget),
        };
        self.leaf = usize::MAX;
        // Kept parts are this ray's, in this leaf (only a search cuts
        // pieces for cells, so none are kept between searches).
        self.parts.clear();
        answer
    }

    /// [`Tracer::in_leaf`], for a split leaf (`SPLIT`, and the ray fast) or
    /// any other: pieces of the ray are taken nearest first, and each is
    /// excluded, answered, or cut into pieces searched in turn.
    #[inline(always)]
    pub(super) fn search_leaf<const SPLIT: bool>(
        &mut self,
        leaf: &Leaf,
        split: Option<&SplitLeaf>,
        ray: &Ray,
        t0: f64,
        t1: f64,
        budget: &mut u32,
    ) -> Answer {
        let mut s = match self.start_leaf::<SPLIT>(leaf, split, ray, t0, t1) {
            Ok(s) => s,
            Err(answer) => return answer,
        };
        self.segments.clear();
        loop {
            let mut piece = match s.next.take() {
                Some(piece) => piece,
                None => match self.segments.pop() {
                    Some(piece) => piece,
                    None => break,
                },
            };
            let Piece { a, b, .. } = piece;
            if *budget == 0 {
                return Answer::Undecided(a);
            }
            *budget -= 1;
            let h = 0.5 * (b - a);
            let m = a + h;
            // Every t of [a, b] is within `hh` of m.
            let hh = up((m - a).max(b - m));
            let mid = step!(self.middle::<SPLIT>(&mut s, ray, &mut piece, m, hh));
            let mut slope = step!(self.slope_tests::<SPLIT>(&mut s, ray, &piece, &mid));
            // The first piece of a creased leaf that F at its middle does
            // not clear: march from its start.
            if !SPLIT && !s.marched && s.leaf.needs_intervals && self.march_on {
                s.marched = true;
                match self.march(&s.k, ray, &mut piece) {
                    Some(true) => continue,
                    Some(false) => {
                        s.next = Some(piece);
                        continue;
                    }
                    None => {}
                }
            }
            step!(self.taylor_parabolas(&mut s, ray, &piece, &mid, &slope));
            // A long piece across a split leaf's crease is halved first:
            // its halves may each lie on one side.
            let halve = mid.undecided_split && hh > s.shortest;
            step!(self.enclosure_tests(&s, ray, &mut piece, &mid, &mut slope, halve));
            step!(self.monotone_piece(&mut s, ray, &mut piece, &mid, &slope));
            let sm = certified_sign(mid.fm, s.k.f_err);
            if hh <= s.tol {
                match self.settle(ray, &s.k, piece, m, mid.fm, sm, s.tol) {
                    Answer::Miss => continue,
                    answer => return answer,
                }
            }
            if halve && self.cut_around_crease(&mut s, &piece, mid.crease) {
                continue;
            }
            if self.clear_around_middle(&mut s, &piece, &mid) {
                continue;
            }
            self.segments.push(Piece {
                a: m,
                b,
                fa: mid.fm,
                fb: piece.fb,
                sa: sm,
                sb: piece.sb,
                side: piece.side,
                lip: piece.lip,
            });
            s.next = Some(Piece {
                a,
                b: m,
                fa: piece.fa,
                fb: mid.fm,
                sa: piece.sa,
                sb: sm,
                side: piece.side,
                lip: piece.lip,
            });
        }
        Answer::Miss
    }

    /// The search's state before its first piece, the leaf's range of the
    /// ray; for a ray that leaves the surface here, the start test first
    /// (`Err`: it proves the whole range clear).
    #[inline(always)]
    fn start_leaf<'l, const SPLIT: bool>(
        &mut self,
        leaf: &'l Leaf,
        split: Option<&'l SplitLeaf>,
        ray: &Ray,
        t0: f64,
        t1: f64,
    ) -> Result<LeafSearch<'l>, Answer> {
        // G waits until a piece passes the L-test: most leaves a ray
        // crosses never need it.
        let mut own = Bounds::first_order_of(leaf, ray);
        let mut second_order_known = false;
        let tol = self.intersector.tolerance / ray.speed;
        self.current = leaf.shape as usize;
        // F at the ends is evaluated only when a test needs it (most leaves
        // a ray crosses are excluded by F and g at the middle alone).
        let mut first = Piece {
            a: t0,
            b: t1,
            fa: f64::NAN,
            fb: f64::NAN,
            sa: 0,
            sb: 0,
            side: 0,
            lip: f64::INFINITY,
        };
        if ray.start == Some(t0) {
            own = own.with_second_order(leaf, ray);
            second_order_known = true;
        }
        if ray.start == Some(t0) && own.second_order {
            match self.leave_start(ray, &own, t0) {
                Ok(end) if end >= t1 => return Err(Answer::Miss),
                Ok(end) => first.a = end,
                Err((fa, sa)) => (first.fa, first.sa) = (fa, sa),
            }
        }
        // A creased leaf with two smooth sides: each piece whose sides'
        // difference keeps one sign runs the tests with that side's bounds.
        let split = if SPLIT { split } else { None };
        // Undecided pieces longer than this are halved (or cut) rather than
        // enclosed: the length they would have in a leaf at the full depth.
        let shortest = (t1 - t0) * SPLIT_HALVINGS * split.map_or(1.0, |s| s.scale);
        Ok(LeafSearch {
            leaf,
            split,
            t1,
            tol,
            shortest,
            own,
            second_order_known,
            k: own,
            side_bounds: [None; 2],
            next: Some(first),
            marched: false,
        })
    }

    /// F and g at the middle m of `piece`, with the bounds that hold there
    /// (`s.k`): the leaf's own, or in a split leaf those of the side F is
    /// proved to be on. A split leaf's piece may be cleared by a side, cut
    /// where the sides' difference keeps its sign, or answered in closed
    /// form here.
    #[inline(always)]
    fn middle<const SPLIT: bool>(
        &mut self,
        s: &mut LeafSearch,
        ray: &Ray,
        piece: &mut Piece,
        m: f64,
        hh: f64,
    ) -> Step<Middle> {
        let plain = |(fm, gm): Values| Middle {
            m,
            hh,
            fm,
            gm,
            undecided_split: false,
            crease: f64::NAN,
        };
        let Some(split) = s.split else {
            // Where intervals decide (creased leaves), no test reads g at
            // m but Newton's step in `monotone_piece`, which evaluates it
            // there: f alone costs its share of the tape.
            if s.leaf.needs_intervals {
                return Step::Go(plain((self.f_at(ray, m), f64::NAN)));
            }
            return Step::Go(plain(self.fg_at(ray, m)));
        };
        if piece.side > 0 {
            let at = usize::from(piece.side - 1);
            self.current = split.sides[at].shape as usize;
            s.k = s.side_bounds[at].unwrap_or(Bounds::UNKNOWN);
            return Step::Go(plain(self.fg_at(ray, m)));
        }
        match self.side_of(split, &mut s.side_bounds, ray, m, hh) {
            Side::Clear => Step::Next,
            Side::On(side, values) => {
                piece.side = side;
                // Certified signs hold for F whatever formula computes it;
                // other values were the leaf's own.
                if piece.sa == 0 {
                    piece.fa = f64::NAN;
                }
                if piece.sb == 0 {
                    piece.fb = f64::NAN;
                }
                let at = usize::from(side - 1);
                s.k = s.side_bounds[at].unwrap_or(Bounds::UNKNOWN);
                self.current = split.sides[at].shape as usize;
                Step::Go(plain(values))
            }
            Side::Undecided(values) => {
                self.current = s.leaf.shape as usize;
                s.k = s.own;
                match values {
                    Some(sides) => self.undecided_sides(s, split, piece, sides, m, hh),
                    None => Step::Go(plain(self.fg_at(ray, m))),
                }
            }
        }
    }

    /// A piece of a split leaf where neither side is proved to hold, from
    /// both sides' values at its middle m. F is the larger (smaller) side:
    /// its value is theirs, within the larger of their errors (and own
    /// values stay within the leaf's own).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn undecided_sides(
        &mut self,
        s: &mut LeafSearch,
        split: &SplitLeaf,
        piece: &Piece,
        [one, two]: [Values; 2],
        m: f64,
        hh: f64,
    ) -> Step<Middle> {
        // Where a side has no root on the piece, it keeps its sign there. A
        // side that keeps the winning sign (above 0 under a max, below under
        // a min) cleared the piece in `side_of`; where both keep the other,
        // so does F.
        let kept = [one, two]
            .iter()
            .zip(&s.side_bounds)
            .all(|(&v, b)| b.is_some_and(|b| b.excludes(v, hh)));
        if kept {
            return Step::Next;
        }
        // Taylor's bounds of the sides' difference C (C″ between the ends of
        // theirs) give where C keeps its sign around m: F is one side there.
        // Cut that range out with its side, rather than halving towards the
        // crease.
        if let [Some(b1), Some(b2)] = s.side_bounds {
            // Both sides quadratic: the piece is answered from their values
            // at m alone.
            let answer = self
                .closed_form_seams
                .then(|| closed_form(split, [one, two], [b1, b2], piece, m, s.tol))
                .flatten();
            if let Some(answer) = answer {
                self.stats.seams += 1;
                return match answer {
                    Seam::Clear => Step::Next,
                    Seam::Hit { t, .. } => Step::Done(Answer::Hit(t)),
                };
            }
            if let Some((near, middle, far)) = crease_free(split, [one, two], [b1, b2], piece, m) {
                if let Some(far) = far {
                    self.segments.push(far);
                }
                match near {
                    Some(near) => {
                        self.segments.push(middle);
                        s.next = Some(near);
                    }
                    None => s.next = Some(middle),
                }
                return Step::Next;
            }
        }
        let pick = (one.0 >= two.0) == split.larger;
        let (fm, gm) = if pick { one } else { two };
        for b in s.side_bounds.iter().flatten() {
            s.k.f_err = s.k.f_err.max(b.f_err);
        }
        // Only where C is linear on the piece (to G's rounding allowance) is
        // the estimate of its zero close enough: measured, cutting around a
        // curved crease's estimate cost more pieces than halving.
        let slope = one.1 - two.1;
        let bend: f64 = s.side_bounds.iter().flatten().map(|b| b.g).sum();
        let crease = if bend * hh <= 1e-9 * slope.abs() {
            m - (one.0 - two.0) / slope
        } else {
            f64::NAN
        };
        Step::Go(Middle {
            m,
            hh,
            fm,
            gm,
            undecided_split: true,
            crease,
        })
    }

    /// Kalra and Barr's tests from F and g at the middle: the L-test, then
    /// (with G, made on first need) the second-order test; what they prove
    /// of g's sign on the piece.
    #[inline(always)]
    fn slope_tests<const SPLIT: bool>(
        &mut self,
        s: &mut LeafSearch,
        ray: &Ray,
        piece: &Piece,
        mid: &Middle,
    ) -> Step<Slope> {
        let Middle { fm, gm, hh, .. } = *mid;
        let mut slope = Slope {
            monotone: false,
            slope_min: 0.0,
            slope_sign: 0.0,
            decided: false,
        };
        if s.k.first_order && !fm.is_nan() {
            // The leaf's L, or the slope bound a piece holding this one
            // found (often far smaller, in creased leaves).
            let f_low = fm.abs() - s.k.f_err;
            if f_low > up(s.k.lt.min(piece.lip) * hh) {
                return Step::Next; // L-test: no root here
            }
        }
        if !s.second_order_known && !SPLIT {
            s.k = s.k.with_second_order(s.leaf, ray);
            s.second_order_known = true;
        } else if !s.second_order_known && piece.side == 0 {
            s.own = s.own.with_second_order(s.leaf, ray);
            s.second_order_known = true;
            s.k = Bounds {
                f_err: s.k.f_err,
                ..s.own
            };
        }
        let k = &s.k;
        if k.first_order && !fm.is_nan() {
            let f_low = fm.abs() - k.f_err;
            if k.second_order && !gm.is_nan() {
                if f_low > up((gm.abs() + k.g_err) * hh + 0.5 * k.g * hh * hh) {
                    return Step::Next; // second-order test: no root here
                }
                let low = gm.abs() - k.g_err - up(k.g * hh);
                slope = Slope {
                    monotone: low > 0.0,
                    slope_min: low.max(0.0),
                    slope_sign: gm.signum(),
                    decided: true,
                };
            }
        }
        Step::Go(slope)
    }

    /// Taylor's bounds around m (see `taylor`): F keeps its sign up to the
    /// lower parabola's roots on either side, and has the opposite sign past
    /// the upper one's. Where nothing before the clear range is left, a
    /// crossing ahead brackets the first root; else the clear range is cut
    /// out when it is a good part of the piece.
    ///
    /// Only where F is quadratic along the ray (F″ known to a millionth) are
    /// the parabolas close enough to pay (measured: the torus took 1 % more
    /// instructions with them), and where F is linear and monotone,
    /// slope_bracket's Newton step lands as well, for less (the cube).
    #[inline(always)]
    fn taylor_parabolas(
        &mut self,
        s: &mut LeafSearch,
        ray: &Ray,
        piece: &Piece,
        mid: &Middle,
        slope: &Slope,
    ) -> Step<()> {
        let k = s.k;
        let Middle { m, fm, gm, .. } = *mid;
        let Piece { a, b, .. } = *piece;
        if !(slope.decided && k.quadratic() && !(slope.monotone && k.g == 0.0)) {
            return Step::Go(());
        }
        let Some(e) = Expansion::new(fm, k.f_err, gm, k.g_err, k.curvature) else {
            return Step::Go(());
        };
        let (lo, hi) = e.clear_range(m);
        // (NaN ends count as reaching past the piece.)
        let (before, short) = (lo > a, hi < b);
        if !before && !short {
            return Step::Next; // Taylor's bound: no root here
        }
        // What is left past the clear range.
        let after = Piece {
            a: hi,
            fa: f64::NAN,
            sa: 0,
            ..*piece
        };
        if !before {
            // A side's bounds hold only on its piece; the leaf's own on the
            // whole leaf.
            let reach = if piece.side > 0 { b } else { s.t1 };
            if let Some(t) = e.crossing(m, 1.0, reach - m) {
                let start = hi.max(a);
                if t - start <= placement(s.tol) {
                    // The root is in [start, t]: any point of it is within
                    // the width of the root.
                    let best = e.estimate(m, 1.0).unwrap_or(start);
                    return Step::Done(Answer::Hit(best.clamp(start, t)));
                }
                let far = up((t - m).abs().max((start - m).abs()));
                let slope = (gm.abs() - k.g_err - up(k.g * far)).max(0.0);
                let sign = e.sign as i8;
                let bracket = Piece {
                    a: start,
                    b: t,
                    fa: f64::NAN,
                    fb: f64::NAN,
                    sa: sign,
                    sb: -sign,
                    side: piece.side,
                    lip: f64::INFINITY,
                };
                let answer = self.refine_from(ray, &k, bracket, slope, s.tol, m - fm / gm);
                return Step::Done(answer);
            }
            // (Where the clear range ends near b, the root is on the leaf's
            // face, and the tests below keep a's certified sign for it.)
            if hi - a >= 0.25 * (b - a) && b - hi >= 0.25 * (b - a) {
                s.next = Some(after);
                return Step::Next;
            }
        } else if (lo - a) + (b - hi.min(b)) <= 0.75 * (b - a) {
            if hi < b {
                self.segments.push(after);
            }
            s.next = Some(Piece {
                b: lo,
                fb: f64::NAN,
                sb: 0,
                ..*piece
            });
            return Step::Next;
        }
        Step::Go(())
    }

    /// Enclosures of F over the whole piece where the f64 tests could not
    /// decide: where they did not run (then the enclosure of g says whether
    /// F is monotone), and where F at m is lost in its rounding noise.
    #[inline(always)]
    fn enclosure_tests(
        &mut self,
        s: &LeafSearch,
        ray: &Ray,
        piece: &mut Piece,
        mid: &Middle,
        slope: &mut Slope,
        halve: bool,
    ) -> Step<()> {
        let Piece { a, b, .. } = *piece;
        // Where G is so loose against g at m that the f64 tests would
        // decide only pieces many halvings shorter, one enclosure over the
        // piece costs less than the point evaluations of those halvings.
        let loose = slope.decided
            && !slope.monotone
            && !halve
            && s.k.g * mid.hh > LOOSE_G * (mid.gm.abs() + s.k.g_err);
        if (!slope.decided || loose) && !halve {
            let (span, g, continuous) = self.fg_over_shared(ray, a, b);
            if span.is_empty() || !span.contains(0.0) {
                return Step::Next; // interval test: no root here
            }
            // The mean-value form: F continuous on the piece moves from F(m)
            // by at most |g|·hh, and g's enclosure over the piece is often
            // far tighter than F's (long chains of blends, whose natural
            // enclosures of F widen with every blend they cannot decide).
            // It can exclude only where that is below |F| somewhere on the
            // piece, so F(m) is enclosed (where its f64 value has no error
            // bound) only then.
            let moves = up(g.mag() * mid.hh);
            if continuous && !g.is_empty() && moves < span.mag() {
                let f_low = if s.k.first_order && !mid.fm.is_nan() {
                    mid.fm.abs() - s.k.f_err
                } else {
                    let (at, _, _) = self.fg_over(ray, mid.m, mid.m);
                    if at.is_empty() {
                        0.0
                    } else {
                        at.mig()
                    }
                };
                if f_low > moves {
                    return Step::Next; // mean-value test: no root here
                }
            }
            // F continuous with g bounded moves at most |g| a unit of t on
            // the piece and on every part of it: a bound the halves' L-tests
            // take where it is below the leaf's.
            if continuous && g.is_bounded() {
                piece.lip = piece.lip.min(g.mag());
            }
            // Continuous with a (Clarke) slope of one sign: monotone.
            let monotone = continuous && !g.is_empty() && !g.contains(0.0);
            slope.monotone = monotone;
            slope.slope_min = if monotone { g.mig() } else { 0.0 };
            slope.slope_sign = if monotone { g.inf().signum() } else { 0.0 };
        }
        // F at m lost in its rounding noise, on a piece longer than the
        // tolerance: the f64 tests cannot tell it from 0 anywhere near (a ray
        // along a singular curve, where ∇f vanishes: the heart's equator),
        // and halving would crawl along it a tolerance at a time. An
        // enclosure over the whole piece is tighter than the leaf's error
        // bound there, and may exclude it at once (measured: the heart's
        // scene 0.12× the time).
        if slope.decided
            && !loose
            && !halve
            && mid.hh > s.tol
            && certified_sign(mid.fm, s.k.f_err) == 0
        {
            let (span, _, _) = self.fg_over(ray, a, b);
            if span.is_empty() || !span.contains(0.0) {
                return Step::Next; // interval test: no root here
            }
        }
        Step::Go(())
    }

    /// A piece on which F is monotone: a bracket from the slope bound, or
    /// the signs at its ends, decide it.
    #[inline(always)]
    fn monotone_piece(
        &mut self,
        s: &mut LeafSearch,
        ray: &Ray,
        piece: &mut Piece,
        mid: &Middle,
        slope: &Slope,
    ) -> Step<()> {
        let (k, tol) = (s.k, s.tol);
        let Middle { m, hh, fm, gm, .. } = *mid;
        let Slope {
            monotone,
            slope_min,
            slope_sign,
            ..
        } = *slope;
        let Piece { a, b, .. } = *piece;
        if monotone && slope_min > 0.0 && !fm.is_nan() {
            // g at m, where the middle took f alone: the same value as
            // evaluating both there.
            let gm = if gm.is_nan() {
                self.fg_at(ray, m).1
            } else {
                gm
            };
            if let Some((bracket, start)) =
                slope_bracket(&k, piece, m, fm, gm, slope_min, slope_sign)
            {
                // Newton's step from m already lands within a thousandth of
                // the tolerance of the bracket's root (the test `refine_from`
                // makes after each evaluation, made at m): a plane's hits,
                // whose F is linear, take no evaluation past m.
                let lands = newton_lands(&k, m, fm, gm, slope_min) <= placement(tol);
                if lands && start > bracket.a && start < bracket.b {
                    return Step::Done(Answer::Hit(start));
                }
                return Step::Done(self.refine_from(ray, &k, bracket, slope_min, tol, start));
            }
        }
        if !monotone {
            return Step::Go(());
        }
        // F is strictly monotone on [a, b]: its end signs decide.
        self.evaluate_ends(ray, &k, piece);
        if piece.sa == 0 {
            piece.sa = self.sign_at(ray, a, piece.fa, k.f_err);
        }
        // Where the far end can be stepped across (below), its interval sign
        // is not worth computing first.
        if piece.sb == 0 && (piece.sa == 0 || hh <= tol) {
            piece.sb = self.sign_at(ray, b, piece.fb, k.f_err);
        }
        if piece.sa != 0 && piece.sa == piece.sb {
            return Step::Next; // monotone with equal signs: no root here
        }
        if piece.sa != 0 && piece.sb != 0 {
            return Step::Done(self.refine(ray, &k, *piece, slope_min, tol));
        }
        if piece.sa != 0 && hh > tol {
            // F at b is lost in its rounding noise (a surface on the leaf's
            // face): rather than bisect down to b, certify the sign half a
            // tolerance before it. Monotone, so nothing lies in between; a
            // change of sign is a root there.
            let c = b - 0.5 * tol;
            let fc = self.f_at(ray, c);
            let sc = self.sign_at(ray, c, fc, k.f_err);
            if sc == piece.sa {
                if let Some(hit) = self.across_face(ray, c, b, sc, tol) {
                    return Step::Done(hit);
                }
                s.next = Some(Piece {
                    a: c,
                    fa: fc,
                    sa: sc,
                    ..*piece
                });
                return Step::Next;
            }
            if sc == -piece.sa {
                let bracket = Piece {
                    b: c,
                    fb: fc,
                    sb: sc,
                    ..*piece
                };
                return Step::Done(self.refine(ray, &k, bracket, slope_min, tol));
            }
        }
        Step::Go(())
    }

    /// Cuts out the part of `piece` around its middle m where F has no
    /// root by its slope bound on the piece (`piece.lip`, from g's
    /// enclosure): |F(t)| ≥ |F(m)| − lip·|t − m| > 0 there. The rest is
    /// searched in turn (nothing, where the cut holds the whole piece).
    /// Whether it cut: only where the range is a twentieth of the piece or
    /// more; below that, halves keep F(m) as a known end.
    #[inline(always)]
    fn clear_around_middle(&mut self, s: &mut LeafSearch, piece: &Piece, mid: &Middle) -> bool {
        let Piece { a, b, lip, .. } = *piece;
        let Middle { m, hh, fm, .. } = *mid;
        if !s.k.first_order {
            return false;
        }
        // The radius rounded down: a relative margin for the subtraction's
        // and the quotient's roundings, an absolute one for those of m ± r
        // (|m ± r| ≤ |m| + hh once r ≤ hh). No bound (lip = ∞), a zero one
        // or F(m) undefined leave it 0, infinite or NaN: no cut.
        let radius = (fm.abs() - s.k.f_err) / lip;
        if !(radius.is_finite() && radius > 0.0) {
            return false;
        }
        let r = radius.min(hh) * (1.0 - 1e-12) - 4.0 * f64::EPSILON * (m.abs() + hh);
        if r <= 0.05 * hh {
            return false;
        }
        let (lo, hi) = (m - r, m + r);
        if hi < b {
            self.segments.push(Piece {
                a: hi,
                fa: f64::NAN,
                sa: 0,
                ..*piece
            });
        }
        if lo > a {
            s.next = Some(Piece {
                b: lo,
                fb: f64::NAN,
                sb: 0,
                ..*piece
            });
        }
        true
    }

    /// Cuts a short piece out of `piece` around where a split leaf's crease
    /// is estimated to be: the pieces on either side may each lie on one
    /// side (any cut is sound; this one only saves halvings). Whether it
    /// could.
    #[inline(always)]
    fn cut_around_crease(&mut self, s: &mut LeafSearch, piece: &Piece, crease: f64) -> bool {
        let Piece { a, b, .. } = *piece;
        let (near, far) = (crease - s.shortest, crease + s.shortest);
        if !(near > a && far < b) {
            return false;
        }
        let cut = |a: f64, b: f64| Piece {
            a,
            b,
            fa: f64::NAN,
            fb: f64::NAN,
            sa: 0,
            sb: 0,
            side: 0,
            lip: f64::INFINITY,
        };
        self.segments.push(Piece {
            fb: piece.fb,
            sb: piece.sb,
            ..cut(far, b)
        });
        self.segments.push(cut(near, far));
        s.next = Some(Piece {
            fa: piece.fa,
            sa: piece.sa,
            ..cut(a, near)
        });
        true
    }
}

/// What one phase of the leaf search decides about the piece in hand.
enum Step<T> {
    /// The piece is done with (excluded, or cut into pieces queued to be
    /// searched): on to the next.
    Next,
    /// The ray's answer.
    Done(Answer),
    /// Undecided: the next phase runs, with what this one found.
    Go(T),
}

/// Runs a phase of the leaf search: on to the next piece, out with the
/// answer, or on with the phase's result.
macro_rules! step {
    ($phase:expr) => {
        match $phase {
            Step::Next => continue,
            Step::Done(answer) => return answer,
            Step::Go(value) => value,
        }
    };
}
use step;

/// The search of one leaf under way: what holds for all its pieces.
struct LeafSearch<'l> {
    leaf: &'l Leaf,
    /// The leaf's two smooth sides, searching a split leaf.
    split: Option<&'l SplitLeaf>,
    /// The end of the leaf's range of the ray: the leaf's own bounds hold
    /// up to it.
    t1: f64,
    /// The tolerance, in t.
    tol: f64,
    /// Undecided pieces of a split leaf longer than this are halved (or cut)
    /// rather than enclosed.
    shortest: f64,
    /// The leaf's own bounds along the ray (G and g's error from the first
    /// piece that needs them, `second_order_known`).
    own: Bounds,
    second_order_known: bool,
    /// The bounds of the piece in hand: the leaf's own, or a side's.
    k: Bounds,
    /// Each side's bounds along the ray, made on first use.
    side_bounds: [Option<Bounds>; 2],
    /// The next piece to search, kept out of the stack (most leaves a ray
    /// crosses need one piece).
    next: Option<Piece>,
    /// Whether the march has run ([`Tracer::march`]): once, on the first
    /// piece the tests at its middle leave.
    marched: bool,
}

/// How many times |g| at a piece's middle (with its error) G times the
/// piece's half-length must be before the piece is enclosed rather than
/// halved: the second-order tests then need eight halvings or more to
/// decide it, and where G is loose against g's true rate of change (long
/// smooth formulas, whose interval Hessians widen with every blend) they
/// may need thousands. Measured on the corpus: 16 made barth_decic 14 %
/// slower (enclosures its halvings did not need), 256 left every corpus
/// surface as it was.
const LOOSE_G: f64 = 256.0;

/// F and g at the middle of a piece.
struct Middle {
    m: f64,
    /// Every t of the piece is within this of m.
    hh: f64,
    fm: f64,
    gm: f64,
    /// Whether neither side of a split leaf is proved to hold on the piece.
    undecided_split: bool,
    /// Where the sides' difference C crosses 0 near m, from C and C′ there
    /// (a split leaf's undecided pieces are cut around it); NaN if unknown.
    crease: f64,
}

/// What the tests prove of g on a piece.
#[derive(Clone, Copy)]
struct Slope {
    /// F is monotone on the piece.
    monotone: bool,
    /// A lower bound of |g| on the piece where F is monotone.
    slope_min: f64,
    /// The sign g keeps there.
    slope_sign: f64,
    /// Whether the f64 second-order tests ran (else intervals decide).
    decided: bool,
}
