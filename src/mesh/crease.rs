//! Sharp creases: where an edge or corner of f (a `min`, `max` or `abs`
//! crease) crosses a cell, the cell's triangles are replaced by a fan from a
//! point on the crease, and each lattice face the crease crosses gets a
//! vertex where it crosses, so the mesh follows the crease instead of
//! bevelling it at the scale of a cell.
//!
//! Why the mesh stays closed, 2-manifold, free of self-intersections and
//! wound outward. A cell's triangles form a patch whose boundary lies on
//! the cell's surface: a path through each lattice square of it whose
//! corners differ in sign (a segment in each Kuhn triangle of the square
//! that needs one). A cell is fanned only when its patch is one disc
//! (connected, Euler characteristic 1, one boundary loop); its loop is then
//! a simple closed polygon on the cell's surface. A square the loop crosses
//! once may get a face vertex `q` strictly inside it: the path from `e₁` to
//! `e₂` becomes `e₁ q e₂`, still a simple arc inside the square with the
//! same ends, and it cuts off the same corners (a corner is an extreme
//! point of the square, so it lies on neither arc). The cell is convex, so
//! every ray from a point `p` strictly inside it leaves it once: the cone
//! from `p` over the loop is an embedded disc inside the cell that meets
//! the cell's surface only in the loop. Cells' interiors are disjoint, so
//! two cones meet only where their loops do, and a face vertex is used
//! only when both cells of its square are fanned, so both sides of a
//! square carry the same arc. Each arc and each disc is replaced inside
//! its own square or cell, with its ends or boundary kept: the surface is
//! still closed, 2-manifold and free of crossings, still separates the same
//! lattice points, and is isotopic to the one marching tetrahedra gave.
//! Fan triangles follow the loop's direction, which the patch's winding
//! gave, so they face outward too; the topology check reads them back.
//!
//! Each new vertex carries a proved root of f within its radius, as edge
//! vertices do: two points either side of it, within the radius, whose
//! signs f's enclosure proves opposite, with f continuous between them. A
//! fanned cell is always an uncertified one: its topology was never
//! vouched for, and the fan keeps every promise uncertified cells make.

use super::certify::{inputs as box_inputs, Verdict};
use super::lattice::{point_value, Cell, Lattice, Sign};
use super::tetra::{ends, EdgeKey};
use super::vertex::{continuous_on, Witness};
use super::Mesh;
use crate::expr::tape::simplify::Decisions;
use crate::expr::{DecoratedEvaluator, Evaluator, Tape};
use crate::types::rounding::up_bound;
use crate::types::{Aabb, Interval};
use glam::{DMat2, DMat3, DVec2, DVec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::hash::{Hash, Hasher};

/// The most distinct smooth pieces kept, each a short tape: past this,
/// vertices get no piece and their cells are left as they are.
const MAX_PIECES: usize = 4096;

/// The part of a cell's side (or a lattice square's) kept clear of its
/// boundary by a new vertex, so that rounding to f32 cannot move a fan
/// across its cell's faces.
const MARGIN: f64 = 0.01;

/// Newton steps towards a crease point.
const NEWTON_STEPS: usize = 30;

/// The most triangles of a cell that is fanned (a cell has at most twelve
/// from its six tetrahedra).
const MAX_CELL_TRIANGLES: usize = 12;

/// What sharpening did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Sharpened {
    /// Cells fanned from a point on a crease.
    pub cells: usize,
    /// Their numbers, in order: their triangles are no longer marching
    /// tetrahedra's.
    pub fanned: Vec<u32>,
    /// Vertices added where a crease crosses a lattice face.
    pub face_vertices: usize,
}

/// What sharpening reads: the tapes, the lattice and the mesh's cells.
pub struct Sharpening<'a> {
    /// f.
    pub tape: &'a Tape,
    /// f and its gradient, in that order.
    pub gradient: &'a Tape,
    /// The lattice the mesh lives on.
    pub lattice: &'a Lattice,
    /// The level of the cells.
    pub level: u32,
    /// The cells.
    pub cells: &'a [Cell],
    /// Each cell's certificate.
    pub verdicts: &'a [Verdict],
    /// Each vertex's lattice edge.
    pub edges: &'a [EdgeKey],
    /// The radius a new vertex may have.
    pub radius: f64,
}

/// Fans each creased, uncertified cell of `mesh` from a point on its crease
/// (see the module's doc), updating `cell_of` (each triangle's cell, in
/// non-decreasing order) and dropping vertices no triangle uses any more.
pub fn sharpen(inputs: &Sharpening<'_>, mesh: &mut Mesh, cell_of: &mut Vec<u32>) -> Sharpened {
    if !inputs.tape.has_branches() {
        return Sharpened::default();
    }
    let ranges = cell_ranges(cell_of);
    // Uncertified, continuous cells whose patch is one disc, its loop on
    // proved roots, and where f has a branch open: a crease may cross them.
    let discs: Vec<Patch> = ranges
        .par_iter()
        .filter_map(|&(c, start, end)| {
            let cell = &inputs.cells[c as usize];
            let Verdict::Uncertified { creased } = inputs.verdicts[c as usize] else {
                return None;
            };
            if end - start > MAX_CELL_TRIANGLES || !cell.continuous || creased == Some(false) {
                return None;
            }
            let boundary = boundary_loop(&mesh.triangles[start..end])?;
            let roots = boundary
                .iter()
                .all(|&v| matches!(mesh.witnesses[v as usize], Witness::Root));
            let b = inputs.lattice.cell(cell.corner, inputs.level);
            // Certification has mostly asked already.
            let creased = roots
                && creased
                    .unwrap_or_else(|| inputs.tape.settled_all_over(&box_inputs(&b)).is_none());
            creased.then_some(Patch { cell: c, boundary })
        })
        .collect();
    if discs.is_empty() {
        return Sharpened::default();
    }
    let pieces = Pieces::of(inputs, mesh, &discs);
    // Those whose loop meets two pieces, or a crease.
    let patches: Vec<Patch> = discs
        .into_iter()
        .filter(|p| {
            let of = |v: &u32| pieces.of[*v as usize];
            let first = of(&p.boundary[0]);
            p.boundary.iter().all(|v| of(v) != NO_PIECE)
                && p.boundary
                    .iter()
                    .any(|v| of(v) != first || of(v) == ON_CREASE)
        })
        .collect();

    // Where the crease crosses each lattice square whose path in a loop
    // runs between two pieces.
    let runs: Vec<Vec<Run>> = patches.par_iter().map(|p| p.runs(inputs.edges)).collect();
    let mut crossings: Vec<Run> = runs
        .iter()
        .flatten()
        .filter(|r| {
            let (pa, pb) = (pieces.of[r.ends.0 as usize], pieces.of[r.ends.1 as usize]);
            pa != pb && pa != ON_CREASE && pb != ON_CREASE
        })
        .map(Run::key)
        .collect();
    crossings.par_sort_unstable_by_key(|r| (r.square, r.ends));
    crossings.dedup_by_key(|r| (r.square, r.ends));
    let face_points: Vec<Option<(DVec3, f64)>> = crossings
        .par_iter()
        .map_init(
            || (Provers::new(inputs.tape), PieceEvaluators::new(&pieces)),
            |(provers, evals), run| face_point(inputs, evals, mesh, provers, run),
        )
        .collect();

    // Each patch's apex, where one is proved near a root.
    let apexes: Vec<Option<(DVec3, f64)>> = patches
        .par_iter()
        .map_init(
            || (Provers::new(inputs.tape), PieceEvaluators::new(&pieces)),
            |(provers, evals), patch| apex(inputs, evals, mesh, provers, patch),
        )
        .collect();

    // A face vertex is used when both cells of its square are fanned.
    let find = |r: &Run| {
        let r = r.key();
        crossings
            .binary_search_by_key(&(r.square, r.ends), |c| (c.square, c.ends))
            .ok()
    };
    let mut uses = vec![0u8; crossings.len()];
    for (patch_runs, a) in runs.iter().zip(&apexes) {
        if a.is_some() {
            for k in patch_runs.iter().filter_map(find) {
                uses[k] += 1;
            }
        }
    }
    let mut face_vertex = vec![u32::MAX; crossings.len()];
    let mut sharpened = Sharpened::default();
    for (k, point) in face_points.iter().enumerate() {
        if let (Some((p, r)), 2) = (point, uses[k]) {
            face_vertex[k] = push_vertex(mesh, *p, *r);
            sharpened.face_vertices += 1;
        }
    }

    // The triangles again, each fanned cell's replaced by its fan.
    let mut fan_of: FxHashMap<u32, (usize, u32)> = FxHashMap::default();
    for (i, (patch, a)) in patches.iter().zip(&apexes).enumerate() {
        if let Some((p, r)) = a {
            fan_of.insert(patch.cell, (i, push_vertex(mesh, *p, *r)));
            sharpened.cells += 1;
            sharpened.fanned.push(patch.cell);
        }
    }
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    let mut cells = Vec::with_capacity(cell_of.len());
    for &(c, start, end) in &ranges {
        let Some(&(i, apex)) = fan_of.get(&c) else {
            triangles.extend_from_slice(&mesh.triangles[start..end]);
            cells.resize(triangles.len(), c);
            continue;
        };
        let boundary = &patches[i].boundary;
        let n = boundary.len();
        // Walk the loop from a run's start; a run with a face vertex is
        // replaced by the path through it.
        let mut k = 0;
        let mut by_start: FxHashMap<usize, (usize, u32)> = FxHashMap::default();
        for r in &runs[i] {
            if let Some(q) = find(r).map(|s| face_vertex[s]).filter(|&q| q != u32::MAX) {
                by_start.insert(r.first, (r.segments, q));
            }
        }
        let start_at = runs[i].first().map_or(0, |r| r.first);
        while k < n {
            let at = (start_at + k) % n;
            match by_start.get(&at) {
                Some(&(len, q)) => {
                    let (a, b) = (boundary[at], boundary[(at + len) % n]);
                    triangles.push([a, q, apex]);
                    triangles.push([q, b, apex]);
                    k += len;
                }
                None => {
                    triangles.push([boundary[at], boundary[(at + 1) % n], apex]);
                    k += 1;
                }
            }
        }
        cells.resize(triangles.len(), c);
    }
    mesh.triangles = triangles;
    *cell_of = cells;
    drop_unused(mesh);
    sharpened.fanned.sort_unstable();
    sharpened
}

/// Each run of equal cells in `cell_of`: the cell and its triangles' range.
fn cell_ranges(cell_of: &[u32]) -> Vec<(u32, usize, usize)> {
    let mut ranges = Vec::new();
    let mut start = 0;
    for i in 1..=cell_of.len() {
        if i == cell_of.len() || cell_of[i] != cell_of[start] {
            ranges.push((cell_of[start], start, i));
            start = i;
        }
    }
    ranges
}

/// A cell whose patch is one disc, with its boundary loop in order.
struct Patch {
    cell: u32,
    boundary: Vec<u32>,
}

impl Patch {
    /// The loop's paths through lattice squares: maximal runs of
    /// consecutive segments in one square, for squares the loop passes
    /// through once.
    fn runs(&self, edges: &[EdgeKey]) -> Vec<Run> {
        let n = self.boundary.len();
        let square = |k: usize| {
            let (a, b) = (self.boundary[k], self.boundary[(k + 1) % n]);
            square_of(edges[a as usize], edges[b as usize])
        };
        let squares: Vec<Option<Square>> = (0..n).map(square).collect();
        if squares.iter().any(Option::is_none) {
            return Vec::new();
        }
        // Start where the square changes, so no run wraps around.
        let Some(first) = (0..n).find(|&k| squares[k] != squares[(k + n - 1) % n]) else {
            return Vec::new();
        };
        let mut runs: Vec<Run> = Vec::new();
        for j in 0..n {
            let k = (first + j) % n;
            match runs.last_mut() {
                Some(r) if squares[k] == Some(r.square) => {
                    r.segments += 1;
                    r.ends.1 = self.boundary[(k + 1) % n];
                }
                _ => runs.push(Run {
                    square: squares[k].expect("checked above"),
                    first: k,
                    segments: 1,
                    ends: (self.boundary[k], self.boundary[(k + 1) % n]),
                }),
            }
        }
        // A square the loop passes through twice keeps its segments.
        let once = |r: &Run| runs.iter().filter(|s| s.square == r.square).count() == 1;
        runs.iter().filter(|r| once(r)).cloned().collect()
    }
}

/// A lattice square: the axis it is normal to and its lowest corner.
type Square = (usize, [u32; 3]);

/// The square a face triangle lies in, from the two crossing edges of its
/// segment.
fn square_of(a: EdgeKey, b: EdgeKey) -> Option<Square> {
    let corners = face_corners(a, b)?;
    let fixed = (0..3).find(|&k| corners.iter().all(|c| c[k] == corners[0][k]))?;
    let low = [0, 1, 2].map(|k| corners.iter().map(|c| c[k]).min().unwrap_or(0));
    Some((fixed, low))
}

/// A run of a loop's segments through one lattice square.
#[derive(Debug, Clone, Copy)]
struct Run {
    square: Square,
    /// The loop index of its first vertex.
    first: usize,
    /// How many segments it has.
    segments: usize,
    /// Its first and last vertices, in the loop's direction.
    ends: (u32, u32),
}

impl Run {
    /// The run as both cells of its square see it: its ends sorted.
    fn key(&self) -> Run {
        Run {
            ends: key(self.ends.0, self.ends.1),
            ..*self
        }
    }
}

/// A pair's key: its ends, sorted.
fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// The boundary of a patch of triangles, as one loop of vertices in the
/// direction the triangles' winding gives it, when the patch is one disc:
/// connected, of Euler characteristic 1, with one boundary loop.
fn boundary_loop(triangles: &[[u32; 3]]) -> Option<Vec<u32>> {
    let directed: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .collect();
    let boundary: Vec<(u32, u32)> = directed
        .iter()
        .copied()
        .filter(|&(a, b)| !directed.contains(&(b, a)))
        .collect();
    if boundary.is_empty() {
        return None;
    }
    // One loop through every boundary edge.
    let mut lp = vec![boundary[0].0];
    let mut at = boundary[0].1;
    while at != lp[0] {
        if lp.len() > boundary.len() {
            return None;
        }
        lp.push(at);
        let from = at;
        let mut next = boundary.iter().filter(|e| e.0 == from);
        at = next.next()?.1;
        if next.next().is_some() {
            return None;
        }
    }
    if lp.len() != boundary.len() {
        return None;
    }
    // Euler characteristic 1: V − E + F with E = (3F + B)/2.
    let mut vertices: Vec<u32> = triangles.iter().flatten().copied().collect();
    vertices.sort_unstable();
    vertices.dedup();
    let f = triangles.len() as i64;
    let edges = (3 * f + boundary.len() as i64) / 2;
    if vertices.len() as i64 - edges + f != 1 {
        return None;
    }
    // Connected through shared edges.
    let mut reached = vec![false; triangles.len()];
    let mut stack = vec![0];
    reached[0] = true;
    while let Some(i) = stack.pop() {
        for (j, t) in triangles.iter().enumerate() {
            let shares =
                |u: &[u32; 3], v: &[u32; 3]| u.iter().filter(|x| v.contains(x)).count() >= 2;
            if !reached[j] && shares(&triangles[i], t) {
                reached[j] = true;
                stack.push(j);
            }
        }
    }
    reached.iter().all(|&r| r).then_some(lp)
}

/// No piece: the vertex is not in a candidate cell, or the pieces ran out.
const NO_PIECE: u32 = u32::MAX;

/// On a crease: a branch still read is open at the vertex.
const ON_CREASE: u32 = u32::MAX - 1;

/// The smooth pieces of f the candidate cells' vertices lie on: f's tape
/// with every branch taken the way it goes at the vertex.
struct Pieces {
    /// Each vertex's piece, or [`NO_PIECE`].
    of: Vec<u32>,
    /// Each piece's tape: f and its gradient.
    tapes: Vec<Tape>,
}

impl Pieces {
    /// The pieces of the loops' vertices. A vertex's piece is named by the
    /// branches f's tape takes there; pieces whose short tapes are the same
    /// program are one. Each piece's tape is the gradient's tape shortened
    /// at one of its vertices.
    fn of(inputs: &Sharpening<'_>, mesh: &Mesh, patches: &[Patch]) -> Pieces {
        let none = || Pieces {
            of: vec![NO_PIECE; mesh.positions.len()],
            tapes: Vec::new(),
        };
        let mut vertices: Vec<u32> = patches
            .iter()
            .flat_map(|p| p.boundary.iter().copied())
            .collect();
        vertices.par_sort_unstable();
        vertices.dedup();
        let at = |v: u32| {
            let p = mesh.positions[v as usize];
            [p.x, p.y, p.z, 0.0, 0.0, 0.0]
        };
        // Each vertex's branches, kept as a hash (and whether one still read
        // is open): a collision only merges two pieces, which moves a new
        // vertex's first guess, never what is proved of it.
        // Whether a branch is left open is asked once per decisions a job
        // meets: neighbouring vertices mostly share them.
        let named: Vec<(u64, bool)> = vertices
            .par_chunks(VERTEX_CHUNK)
            .flat_map_iter(|chunk| {
                let mut open: FxHashMap<Decisions, bool> = FxHashMap::default();
                chunk.iter().map(move |&v| {
                    let d = inputs.tape.settled_at(&at(v));
                    let mut h = rustc_hash::FxHasher::default();
                    d.hash(&mut h);
                    let open = match open.get(&d) {
                        Some(&o) => o,
                        None => {
                            let o = inputs.tape.leaves_open(&d);
                            open.insert(d, o);
                            o
                        }
                    };
                    (h.finish(), open)
                })
            })
            .collect();
        let mut index: FxHashMap<u64, usize> = FxHashMap::default();
        let mut representative: Vec<u32> = Vec::new();
        let mut first = vec![usize::MAX; vertices.len()];
        for (i, &(h, open)) in named.iter().enumerate() {
            if open {
                continue;
            }
            let next = representative.len();
            first[i] = *index.entry(h).or_insert_with(|| {
                representative.push(vertices[i]);
                next
            });
        }
        if representative.len() > MAX_PIECES {
            return none();
        }
        let short: Vec<Tape> = representative
            .par_iter()
            .map(|&v| inputs.tape.shortened(&inputs.tape.settled_at(&at(v))))
            .collect();
        // Branches that differ only where no output reads them give the same
        // program: one piece. Grouped by size, then compared.
        let mut order: Vec<usize> = (0..short.len()).collect();
        order.sort_by_key(|&k| (short[k].body.len(), short[k].slot_count));
        let mut piece = vec![0u32; short.len()];
        let mut kept: Vec<usize> = Vec::new();
        let mut group_start = 0;
        for (n, &k) in order.iter().enumerate() {
            let size = |t: &Tape| (t.body.len(), t.slot_count);
            if n > 0 && size(&short[order[n - 1]]) != size(&short[k]) {
                group_start = kept.len();
            }
            match (group_start..kept.len()).find(|&j| short[kept[j]].same_program(&short[k])) {
                Some(j) => piece[k] = j as u32,
                None => {
                    piece[k] = kept.len() as u32;
                    kept.push(k);
                }
            }
        }
        let gradient = inputs.gradient;
        let tapes: Vec<Tape> = kept
            .par_iter()
            .map(|&k| gradient.shortened(&gradient.settled_at(&at(representative[k]))))
            .collect();
        let mut of = vec![NO_PIECE; mesh.positions.len()];
        for (&v, &u) in vertices.iter().zip(&first) {
            of[v as usize] = if u == usize::MAX { ON_CREASE } else { piece[u] };
        }
        Pieces { of, tapes }
    }
}

/// Vertices one job names the pieces of.
const VERTEX_CHUNK: usize = 1024;

/// Evaluators of the pieces' tapes one job keeps at most (a job's runs and
/// patches are neighbours, which meet few pieces).
const KEPT_EVALUATORS: usize = 64;

/// Evaluators of the pieces' tapes for one job, each made when first
/// needed: making one per evaluation cost as much as the evaluation.
struct PieceEvaluators<'p> {
    pieces: &'p Pieces,
    evals: Vec<Option<Evaluator<'p, f64>>>,
    kept: usize,
}

impl<'p> PieceEvaluators<'p> {
    fn new(pieces: &'p Pieces) -> Self {
        PieceEvaluators {
            pieces,
            evals: (0..pieces.tapes.len()).map(|_| None).collect(),
            kept: 0,
        }
    }

    /// Piece `k`'s value and gradient at `p`.
    fn at(&mut self, k: u32, p: DVec3) -> (f64, DVec3) {
        if self.evals[k as usize].is_none() {
            if self.kept == KEPT_EVALUATORS {
                self.evals.iter_mut().for_each(|e| *e = None);
                self.kept = 0;
            }
            self.kept += 1;
        }
        let tapes = &self.pieces.tapes;
        let eval = self.evals[k as usize].get_or_insert_with(|| Evaluator::new(&tapes[k as usize]));
        let [f, dx, dy, dz]: [f64; 4] = eval.eval_array(&[p.x, p.y, p.z, 0.0, 0.0, 0.0]);
        (f, DVec3::new(dx, dy, dz))
    }

    /// Piece `k`'s unit normal at `p`, where it has one.
    fn normal(&mut self, k: u32, p: DVec3) -> Option<DVec3> {
        let n = self.at(k, p).1;
        let len = n.length();
        (len > 0.0 && len.is_finite()).then(|| n / len)
    }
}

/// Evaluators of f proving signs.
struct Provers<'t> {
    eval: Evaluator<'t, Interval>,
    decorated: DecoratedEvaluator<'t>,
}

impl<'t> Provers<'t> {
    fn new(tape: &'t Tape) -> Self {
        Provers {
            eval: Evaluator::new(tape),
            decorated: DecoratedEvaluator::new(tape),
        }
    }

    /// A bound of the distance from `x` to a root of f, when f's signs at
    /// `x ± r·d` for one of `directions` are proved opposite and f is
    /// continuous between them.
    fn root_near(&mut self, x: DVec3, r: f64, directions: &[DVec3]) -> Option<f64> {
        for &d in directions {
            let (a, b) = (x - r * d, x + r * d);
            if self.opposite(a, b) {
                return Some(reach(x, a, b));
            }
        }
        None
    }

    /// Whether f's signs at `a` and `b` are proved opposite and f is
    /// defined and continuous on the box they span.
    fn opposite(&mut self, a: DVec3, b: DVec3) -> bool {
        let sa = Sign::of(point_value(&mut self.eval, a));
        let sb = Sign::of(point_value(&mut self.eval, b));
        let proved = matches!(
            (sa, sb),
            (Sign::Negative, Sign::Positive) | (Sign::Positive, Sign::Negative)
        );
        proved && continuous_on(&mut self.decorated, a, b)
    }

    /// A point within `r` of a root on the segment from `a` to `b`, found
    /// by bisection on proved signs, when the ends' signs are proved
    /// opposite; with its radius.
    fn bisect(&mut self, mut a: DVec3, mut b: DVec3, r: f64) -> Option<(DVec3, f64)> {
        let sa = Sign::of(point_value(&mut self.eval, a));
        let sb = Sign::of(point_value(&mut self.eval, b));
        if !matches!(
            (sa, sb),
            (Sign::Negative, Sign::Positive) | (Sign::Positive, Sign::Negative)
        ) {
            return None;
        }
        for _ in 0..200 {
            if 0.5 * (b - a).length() <= r {
                break;
            }
            let m = 0.5 * (a + b);
            match Sign::of(point_value(&mut self.eval, m)) {
                s if s == sa => a = m,
                s if s == sb => b = m,
                _ => return None,
            }
        }
        // A segment f64 cannot halve to the radius is no vertex (its
        // radius would pass the tolerance).
        let m = 0.5 * (a + b);
        (0.5 * (b - a).length() <= r && self.opposite(a, b)).then(|| (m, reach(m, a, b)))
    }
}

/// A bound, rounded up, of the distance from `x` to any point of the
/// segment from `a` to `b`.
fn reach(x: DVec3, a: DVec3, b: DVec3) -> f64 {
    up_bound((a - x).length().max((b - x).length()) * (1.0 + 8.0 * f64::EPSILON))
}

/// Where the crease between the pieces of a run's ends crosses its
/// square, strictly inside it, with a proved root within the radius
/// returned.
fn face_point(
    inputs: &Sharpening<'_>,
    evals: &mut PieceEvaluators<'_>,
    mesh: &Mesh,
    provers: &mut Provers<'_>,
    run: &Run,
) -> Option<(DVec3, f64)> {
    let pieces = evals.pieces;
    let (a, b) = run.ends;
    let (fixed, low) = run.square;
    let (i, j) = ((fixed + 1) % 3, (fixed + 2) % 3);
    let (pa, pb) = (pieces.of[a as usize], pieces.of[b as usize]);
    let mut q = 0.5 * (mesh.positions[a as usize] + mesh.positions[b as usize]);
    for _ in 0..NEWTON_STEPS {
        let ((fa, ga), (fb, gb)) = (evals.at(pa, q), evals.at(pb, q));
        let jac = DMat2::from_cols(DVec2::new(ga[i], gb[i]), DVec2::new(ga[j], gb[j]));
        let det = jac.determinant();
        if !regular(
            det,
            1e-12 * (ga.length() * gb.length()).max(f64::MIN_POSITIVE),
        ) {
            return None;
        }
        let step = jac.inverse() * DVec2::new(fa, fb);
        q[i] -= step.x;
        q[j] -= step.y;
        if !q.is_finite() {
            return None;
        }
        if step.length() <= 1e-14 * (1.0 + q.abs().max_element()) {
            break;
        }
    }
    // Strictly inside the square, by a margin.
    let mut high = low;
    high[i] += 1;
    high[j] += 1;
    let (lo, hi) = (
        inputs.lattice.point(low, inputs.level),
        inputs.lattice.point(high, inputs.level),
    );
    let inner = |k: usize| {
        let m = MARGIN * (hi[k] - lo[k]);
        (lo[k] + m, hi[k] - m)
    };
    let inside = |p: DVec3| {
        [i, j]
            .iter()
            .all(|&k| (inner(k).0..=inner(k).1).contains(&p[k]))
    };
    let (na, nb) = (evals.normal(pa, q)?, evals.normal(pb, q)?);
    let r = 0.5 * inputs.radius;
    if inside(q) {
        let directions: Vec<DVec3> = [(na + nb).normalize_or_zero(), na, nb]
            .into_iter()
            .filter(|d| *d != DVec3::ZERO)
            .collect();
        return provers
            .root_near(q, r, &directions)
            .map(|radius| (q, radius));
    }
    // The crease crosses a neighbouring square (the lattice's surface is
    // not the true one): the root nearest it in this square, found along
    // the pieces' mean normal within the square.
    for k in [i, j] {
        q[k] = q[k].clamp(inner(k).0, inner(k).1);
    }
    let mut d = na + nb;
    d[fixed] = 0.0;
    let d = d.normalize_or_zero();
    if d == DVec3::ZERO {
        return None;
    }
    // The line through q along d, clipped to the inner square.
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in [i, j] {
        if d[k] != 0.0 {
            let (u, v) = ((inner(k).0 - q[k]) / d[k], (inner(k).1 - q[k]) / d[k]);
            t0 = t0.max(u.min(v));
            t1 = t1.min(u.max(v));
        }
    }
    let (a, b) = (q + t0 * d, q + t1 * d);
    (t0 < t1 && inside(a) && inside(b))
        .then(|| provers.bisect(a, b, r))
        .flatten()
}

/// The three lattice points of the face triangle two crossing edges share.
fn face_corners(a: EdgeKey, b: EdgeKey) -> Option<[[u32; 3]; 3]> {
    let (a0, a1) = ends(a);
    let (b0, b1) = ends(b);
    let mut points = vec![a0, a1, b0, b1];
    points.sort_unstable();
    points.dedup();
    (points.len() == 3).then(|| [points[0], points[1], points[2]])
}

/// A point strictly inside the patch's cell, on its crease where Newton's
/// method finds one, with a proved root within the radius returned.
fn apex(
    inputs: &Sharpening<'_>,
    evals: &mut PieceEvaluators<'_>,
    mesh: &Mesh,
    provers: &mut Provers<'_>,
    patch: &Patch,
) -> Option<(DVec3, f64)> {
    let pieces = evals.pieces;
    let cell = inputs
        .lattice
        .cell(inputs.cells[patch.cell as usize].corner, inputs.level);
    let inner = shrunk(&cell);
    let points: Vec<DVec3> = patch
        .boundary
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let mass = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    // The loop's pieces, most frequent first.
    let mut counts: Vec<(u32, usize)> = Vec::new();
    for &v in &patch.boundary {
        let k = pieces.of[v as usize];
        if k == ON_CREASE {
            continue;
        }
        match counts.iter_mut().find(|c| c.0 == k) {
            Some(c) => c.1 += 1,
            None => counts.push((k, 1)),
        }
    }
    counts.sort_by_key(|c| std::cmp::Reverse(c.1));
    let r = 0.5 * inputs.radius;
    for n in (2..=counts.len().min(3)).rev() {
        let used: Vec<u32> = counts[..n].iter().map(|c| c.0).collect();
        let Some(x) = crease_point(evals, &used, mass) else {
            continue;
        };
        if !within(&cell, x) {
            continue;
        }
        let x = x.clamp(inner.lo, inner.hi);
        let normals: Vec<DVec3> = used.iter().filter_map(|&k| evals.normal(k, x)).collect();
        let mut directions = vec![normals.iter().copied().sum::<DVec3>().normalize_or_zero()];
        directions.extend(normals);
        directions.retain(|d| *d != DVec3::ZERO);
        if let Some(radius) = provers.root_near(x, r, &directions) {
            return Some((x, radius));
        }
    }
    // No crease point proved: a root on the line through the loop's mean
    // along its mean normal, inside the cell.
    let normal: DVec3 = patch
        .boundary
        .iter()
        .filter(|&&v| pieces.of[v as usize] != ON_CREASE)
        .filter_map(|&v| evals.normal(pieces.of[v as usize], mesh.positions[v as usize]))
        .sum::<DVec3>()
        .normalize_or_zero();
    if normal == DVec3::ZERO {
        return None;
    }
    let x = mass.clamp(inner.lo, inner.hi);
    let mut h = 0.5 * (inner.hi - inner.lo).min_element();
    for _ in 0..4 {
        let (a, b) = (x - h * normal, x + h * normal);
        if within(&inner, a) && within(&inner, b) {
            return provers.bisect(a, b, r);
        }
        h *= 0.5;
    }
    None
}

/// Where the pieces `used` are all 0, by Newton's method with the least
/// step (the crease's point nearest `start` for two pieces, the corner for
/// three).
fn crease_point(evals: &mut PieceEvaluators<'_>, used: &[u32], start: DVec3) -> Option<DVec3> {
    let mut x = start;
    for _ in 0..NEWTON_STEPS {
        let values: Vec<(f64, DVec3)> = used.iter().map(|&k| evals.at(k, x)).collect();
        // step = Jᵀ (J Jᵀ)⁻¹ F, the least step that zeroes the linear model.
        let step = match values[..] {
            [(fa, ga), (fb, gb)] => {
                let m = DMat2::from_cols(
                    DVec2::new(ga.dot(ga), ga.dot(gb)),
                    DVec2::new(ga.dot(gb), gb.dot(gb)),
                );
                if !regular(
                    m.determinant(),
                    1e-12 * ga.length_squared() * gb.length_squared(),
                ) {
                    return None;
                }
                let w = m.inverse() * DVec2::new(fa, fb);
                w.x * ga + w.y * gb
            }
            [(fa, ga), (fb, gb), (fc, gc)] => {
                let j = DMat3::from_cols(ga, gb, gc).transpose();
                let scale = ga.length() * gb.length() * gc.length();
                if !regular(j.determinant(), 1e-9 * scale) {
                    return None;
                }
                j.inverse() * DVec3::new(fa, fb, fc)
            }
            _ => return None,
        };
        x -= step;
        if !x.is_finite() {
            return None;
        }
        if step.length() <= 1e-14 * (1.0 + x.abs().max_element()) {
            break;
        }
    }
    Some(x)
}

/// Whether a determinant is large against `scale` (false for NaN), so its
/// matrix is safely inverted.
fn regular(det: f64, scale: f64) -> bool {
    det.abs() > scale
}

/// The box `b` with a margin of its sides kept clear.
fn shrunk(b: &Aabb) -> Aabb {
    let m = MARGIN * (b.hi - b.lo);
    Aabb {
        lo: b.lo + m,
        hi: b.hi - m,
    }
}

/// Whether `p` lies in the closed box `b`.
fn within(b: &Aabb, p: DVec3) -> bool {
    p.cmpge(b.lo).all() && p.cmple(b.hi).all()
}

/// Appends a vertex with a proved root within `radius`; its index.
fn push_vertex(mesh: &mut Mesh, p: DVec3, radius: f64) -> u32 {
    mesh.positions.push(p);
    mesh.witnesses.push(Witness::Root);
    mesh.radii.push(radius);
    (mesh.positions.len() - 1) as u32
}

/// Removes the vertices no triangle uses, renumbering the rest in order.
fn drop_unused(mesh: &mut Mesh) {
    let mut used = vec![false; mesh.positions.len()];
    for &v in mesh.triangles.iter().flatten() {
        used[v as usize] = true;
    }
    let mut renumber = vec![u32::MAX; used.len()];
    let mut next = 0u32;
    for (v, &u) in used.iter().enumerate() {
        if u {
            renumber[v] = next;
            next += 1;
        }
    }
    let keep = |v: &usize| used[*v];
    mesh.positions = (0..used.len())
        .filter(keep)
        .map(|v| mesh.positions[v])
        .collect();
    mesh.witnesses = (0..used.len())
        .filter(keep)
        .map(|v| mesh.witnesses[v])
        .collect();
    mesh.radii = (0..used.len())
        .filter(keep)
        .map(|v| mesh.radii[v])
        .collect();
    for t in &mut mesh.triangles {
        *t = t.map(|v| renumber[v as usize]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_disc_has_one_loop_in_its_winding() {
        // Two triangles sharing the edge 1–2, wound alike.
        let lp = boundary_loop(&[[0, 1, 2], [2, 1, 3]]).unwrap();
        let n = lp.len();
        assert_eq!(n, 4);
        // The loop runs the way the triangles do: 0→1 is one of its steps.
        let steps: Vec<(u32, u32)> = (0..n).map(|k| (lp[k], lp[(k + 1) % n])).collect();
        assert!(
            steps.contains(&(0, 1)) && steps.contains(&(1, 3)),
            "{steps:?}"
        );
    }

    #[test]
    fn patches_that_are_not_one_disc_have_no_loop() {
        // Two triangles apart: two loops.
        assert_eq!(boundary_loop(&[[0, 1, 2], [3, 4, 5]]), None);
        // Two triangles meeting at a corner only: one walk would have to
        // choose between two ways on at vertex 0.
        assert_eq!(boundary_loop(&[[0, 1, 2], [0, 3, 4]]), None);
        // A closed tetrahedron: no boundary.
        assert_eq!(
            boundary_loop(&[[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]),
            None
        );
        // An annulus of eight triangles: two loops.
        let annulus: Vec<[u32; 3]> = (0..4)
            .flat_map(|k| {
                let (a, b, c, d) = (k, (k + 1) % 4, 4 + k, 4 + (k + 1) % 4);
                [[a, b, d], [a, d, c]]
            })
            .collect();
        assert_eq!(boundary_loop(&annulus), None);
    }

    #[test]
    fn runs_group_a_loops_segments_by_lattice_square() {
        // Edges on the face z = 0 of the cell at the origin: (1,0,0)–(1,1,0)
        // is a side of the square, (0,0,0)–(1,1,0) its diagonal.
        use super::super::tetra::edge;
        let edges = [
            edge([0, 0, 0], [1, 0, 0]),
            edge([0, 0, 0], [1, 1, 0]),
            edge([0, 0, 0], [0, 1, 0]),
        ];
        // Two segments in the square z = 0 (through the diagonal's vertex).
        assert_eq!(square_of(edges[0], edges[1]), Some((2, [0, 0, 0])));
        assert_eq!(square_of(edges[1], edges[2]), Some((2, [0, 0, 0])));
        let patch = Patch {
            cell: 0,
            boundary: vec![0, 1, 2],
        };
        // The closing segment 2→0 lies in the same square, so the whole
        // loop is in one square and has no run.
        assert!(patch.runs(&edges).is_empty());
    }
}
