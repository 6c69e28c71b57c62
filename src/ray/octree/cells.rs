//! The cells of a leaf's region, made when a ray first needs them: its
//! eighths and theirs, each with the leaf's tape of f and g shortened over
//! it, or marked clear where f's enclosure over it excludes 0.
//!
//! Long formulas settle far more branches a level down than a leaf does
//! (fidget's prospero text near its surface: 1,153 instructions of f and g
//! in a leaf, 392 in its eighths, 144 two levels down), while a level more
//! of the octree costs its Hessians and leaf bounds. A piece of a ray
//! inside a cell evaluates the cell's tape instead of the leaf's, and a
//! piece inside a clear cell is excluded with no evaluation at all.
//!
//! Cells are made on first use, one at a time, by whichever thread needs
//! them first, and kept for every later ray: rays meet only the cells near
//! the surface they see, so most are never made (on the prospero slab at
//! 1024², a fifth to a third of the eighths of the regions they enter). A
//! cell's content is a function of its box and its parent's tape alone, so
//! rays answer the same whatever the threads' timing (but for the budgets,
//! which, once spent, leave later cells on their parents' tapes, or
//! unmade).

use super::options::{CELL_LEVELS, MAX_CELL_GROUPS, MAX_CELL_INSTRUCTIONS};
use crate::expr::tape::simplify::Decisions;
use crate::expr::Tape;
use crate::types::{Aabb, DecInterval, Interval};
use glam::DVec3;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// How far each eighth of a region reaches past the middle plane, as a
/// share of the region's width.
///
/// The eighths of a region `r` overlap: along each axis the lower is
/// `[r.lo, c + δ]` and the upper `[c − δ, r.hi]`, with `c` the centre and
/// `δ` this share of the width, so that most pieces near the middle planes
/// still fit in one. Measured on the prospero slab at 1024²: a sixteenth
/// about 0.9× the time of an eighth (smaller cells settle more, and more
/// are clear), a thirty-second alike, a quarter 1.2×, none slower.
pub const OCTANT_OVERLAP: f64 = 0.0625;

/// The middle of the region `r`, and how far its eighths reach past it.
fn middle(r: &Aabb) -> (DVec3, DVec3) {
    (r.center(), (r.hi - r.lo) * OCTANT_OVERLAP)
}

/// The eighth `k` of the region `r` (see [`OCTANT_OVERLAP`]): bit j of `k`
/// set for the upper half along axis j.
fn octant(r: &Aabb, k: usize) -> Aabb {
    let (c, d) = middle(r);
    let upper = DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64);
    let lo = DVec3::select(upper.cmpgt(DVec3::ZERO), c - d, r.lo);
    let hi = DVec3::select(upper.cmpgt(DVec3::ZERO), r.hi, c + d);
    Aabb {
        lo: lo.max(r.lo),
        hi: hi.min(r.hi),
    }
}

/// The eighth of the region `r` that holds the box `inputs` (x, y, z), if
/// one does.
#[inline]
fn octant_holding(r: &Aabb, inputs: &[Interval]) -> Option<usize> {
    // The same f64 middle planes as `octant`'s, so a box it places lies
    // inside the eighth whose cell was made for it.
    let (c, d) = middle(r);
    let mut k = 0;
    for axis in 0..3 {
        let (lo, hi) = (inputs[axis].inf(), inputs[axis].sup());
        if lo < r.lo[axis] || hi > r.hi[axis] {
            return None;
        }
        if hi > c[axis] + d[axis] {
            if lo < c[axis] - d[axis] {
                return None;
            }
            k |= 1 << axis;
        }
    }
    Some(k)
}

/// The interval inputs of a box, for every direction.
pub(super) fn box_inputs(b: &Aabb) -> [DecInterval; 6] {
    let [x, y, z] = b.intervals();
    let any = Interval::ENTIRE;
    [x, y, z, any, any, any].map(DecInterval::defined)
}

/// What a cell keeps.
#[derive(Debug, Clone)]
pub enum Kept {
    /// Nothing: the tape of the box it was cut from serves.
    Parent,
    /// A tape of its own (with its id, past the leaves' short tapes').
    Tape(u32, Arc<Tape>),
    /// f's enclosure over it, which excludes 0.
    Clear(DecInterval),
}

/// A cell of a leaf's region, and its own eighths once made.
#[derive(Debug, Clone)]
pub struct Cell {
    /// What it keeps.
    pub kept: Kept,
    /// Its eighths, each made when a ray first needs it.
    pub children: OnceLock<Box<Eighths>>,
    /// The branches its tape settles (none but for [`Kept::Tape`]), for its
    /// siblings to take its tape where they settle the same.
    settled: Decisions,
}

/// The eight cells of a region, each made on first use.
pub type Eighths = [OnceLock<Cell>; 8];

/// What a ray's piece finds in its leaf's cells.
#[derive(Debug, Clone, Copy)]
pub enum Short<'a> {
    /// The tape (its id, and the tape) that holds on the piece.
    Tape(u32, &'a Tape),
    /// The piece lies in a cell where f's enclosure, given, excludes 0.
    Clear(DecInterval),
}

/// The cells of an octree's leaves, made on first use.
#[derive(Debug, Default)]
pub struct Cells {
    /// Per kept leaf, its eighths.
    roots: Vec<OnceLock<Box<Eighths>>>,
    /// The id the next cell's tape gets.
    next_id: AtomicU32,
    /// Body instructions of the cells' tapes made so far (at most
    /// [`MAX_CELL_INSTRUCTIONS`]).
    held: AtomicUsize,
    /// Groups of eight cells begun, or about to be (at most
    /// [`MAX_CELL_GROUPS`] are); each cell of a group is made when a ray
    /// first needs it.
    groups: AtomicUsize,
}

impl Clone for Cells {
    fn clone(&self) -> Self {
        Cells {
            roots: self.roots.clone(),
            next_id: AtomicU32::new(self.next_id.load(Ordering::Relaxed)),
            held: AtomicUsize::new(self.held.load(Ordering::Relaxed)),
            groups: AtomicUsize::new(self.groups.load(Ordering::Relaxed)),
        }
    }
}

impl Cells {
    /// No cells yet for `leaves` leaves; their tapes' ids start at `first_id`.
    pub(super) fn new(leaves: usize, first_id: u32) -> Cells {
        Cells {
            roots: (0..leaves).map(|_| OnceLock::new()).collect(),
            next_id: AtomicU32::new(first_id),
            held: AtomicUsize::new(0),
            groups: AtomicUsize::new(0),
        }
    }

    /// The ids cells' tapes have taken so far are below this.
    pub fn id_bound(&self) -> u32 {
        self.next_id.load(Ordering::Relaxed)
    }

    /// Body instructions of the cells' tapes made so far.
    pub fn instructions(&self) -> usize {
        self.held.load(Ordering::Relaxed)
    }

    /// Whether the box `inputs` (x, y, z) lies in a cell of a leaf of
    /// region `r`.
    #[inline]
    pub(super) fn holds(&self, r: &Aabb, inputs: &[Interval]) -> bool {
        self.roots.is_empty() || octant_holding(r, inputs).is_some()
    }

    /// The deepest cell of leaf `leaf` (region `r`, tape `tape`) that
    /// holds the box `inputs` (x, y, z) and keeps a tape, or, with
    /// `clear`, a clear cell that holds it; `None` where none does. With
    /// `make`, cells on the way are made where they are not yet.
    pub(super) fn find<'a>(
        &'a self,
        leaf: usize,
        (r, tape): (&Aabb, &'a Tape),
        inputs: &[Interval],
        (make, clear): (bool, bool),
    ) -> Option<Short<'a>> {
        let mut slot = self.roots.get(leaf)?;
        let (mut region, mut from) = (*r, tape);
        let mut found = None;
        for _ in 0..CELL_LEVELS {
            let Some(k) = octant_holding(&region, inputs) else {
                break;
            };
            // Past the budget of groups, only those begun before serve.
            let cells = match slot.get() {
                Some(cells) => cells,
                None if make && self.take_group() => {
                    slot.get_or_init(|| Box::new(std::array::from_fn(|_| OnceLock::new())))
                }
                None => break,
            };
            let cell = match cells[k].get() {
                Some(cell) => cell,
                None if make => {
                    cells[k].get_or_init(|| self.make(from, &octant(&region, k), cells))
                }
                None => break,
            };
            match &cell.kept {
                Kept::Clear(f) if clear => return Some(Short::Clear(*f)),
                Kept::Clear(_) => break,
                Kept::Tape(id, t) => {
                    found = Some(Short::Tape(*id, t));
                    from = t;
                }
                Kept::Parent => {}
            }
            region = octant(&region, k);
            slot = &cell.children;
        }
        found
    }

    /// Every cell of leaf `leaf` (region `r`, tape `tape`) made so far,
    /// each with its box, what it keeps and the tape it was cut from.
    pub fn each_made<'a>(
        &'a self,
        leaf: usize,
        (r, tape): (&Aabb, &'a Tape),
        mut visit: impl FnMut(&Aabb, &Kept, &Tape),
    ) {
        let Some(root) = self.roots.get(leaf) else {
            return;
        };
        let mut stack = vec![(root, *r, tape)];
        while let Some((slot, region, from)) = stack.pop() {
            let Some(cells) = slot.get() else { continue };
            for (k, cell) in cells.iter().enumerate() {
                let Some(cell) = cell.get() else { continue };
                let b = octant(&region, k);
                visit(&b, &cell.kept, from);
                let below = match &cell.kept {
                    Kept::Tape(_, t) => t,
                    _ => from,
                };
                stack.push((&cell.children, b, below));
            }
        }
    }

    /// Whether another group of eight cells may be made
    /// ([`MAX_CELL_GROUPS`]), counting it.
    fn take_group(&self) -> bool {
        let taken = self.groups.fetch_add(1, Ordering::Relaxed);
        taken < MAX_CELL_GROUPS
    }

    /// The cell of box `b`, one of `siblings`, cut from a box whose tape is
    /// `tape`.
    fn make(&self, tape: &Tape, b: &Aabb, siblings: &Eighths) -> Cell {
        let (kept, settled) = self.kept(tape, b, siblings);
        Cell {
            kept,
            children: OnceLock::new(),
            settled,
        }
    }

    /// What the cell of box `b` cut from a box whose tape is `tape` keeps:
    /// clear where f's enclosure excludes 0, else `tape` shortened over it
    /// where that is at most half as long, while the budget allows; with
    /// the branches its tape settles. Where a sibling made already settles
    /// the same branches, its tape serves: neighbouring cells often do.
    fn kept(&self, tape: &Tape, b: &Aabb, siblings: &Eighths) -> (Kept, Decisions) {
        let none = Decisions::default();
        let (decisions, f) = tape.settled_and_first_over(&box_inputs(b));
        let enclosure = f.interval();
        if !enclosure.is_empty() && !enclosure.contains(0.0) {
            return (Kept::Clear(f), none);
        }
        if decisions.is_empty() {
            return (Kept::Parent, none);
        }
        let same = siblings
            .iter()
            .filter_map(OnceLock::get)
            .find(|c| c.settled == decisions);
        if let Some(Cell {
            kept: Kept::Tape(id, short),
            ..
        }) = same
        {
            return (Kept::Tape(*id, Arc::clone(short)), decisions);
        }
        // Most cells' tapes are not short enough: their length is found
        // without writing them.
        let len = tape.shortened_len(&decisions);
        if len * 2 > tape.body().len() {
            return (Kept::Parent, none);
        }
        // An empty body counts one, so the ids stay within the budget too.
        let cost = len.max(1);
        let fits = self
            .held
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |held| {
                (held + cost <= MAX_CELL_INSTRUCTIONS).then_some(held + cost)
            });
        if fits.is_err() {
            return (Kept::Parent, none);
        }
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let short = Arc::new(tape.shortened(&decisions));
        (Kept::Tape(id, short), decisions)
    }
}
