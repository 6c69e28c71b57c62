//! How far the mesh and the surface are from each other, both ways, in each
//! certified cell: from the cell's [`Slope`](super::distance::Slope) and its neighbours'.
//!
//! **Mesh to surface.** Each triangle of the cell is within
//! [`Slope::distance`](super::distance::Slope::distance) of the surface.
//!
//! **Surface to mesh.** The mesh bounds a region, its inside: in each
//! tetrahedron T of a cell, the part on the side of T's corners where
//! f < 0. That part is a polyhedron whose vertices are those corners and
//! the vertices on T's edges, so each of its points p is a convex
//! combination of four of them, at most the cell's diagonal d apart. In a
//! cell with a slope, with corners of proved sign and every vertex within r
//! of a root on its edge, Taylor's theorem at p gives f(p) ≤ τ =
//! L·r + 3K·d²/16 ([`Slope::value`]); likewise f(p) ≥ −τ outside. So a
//! point of the cell where f > τ is outside the mesh, and one where f < −τ
//! inside. In a cell f
//! does not cross, f has one sign, that of the corner it shares with the
//! certified cell, which is the side the cell is on.
//!
//! Let q be a point of the surface in a certified cell C, with f rising at
//! least m a unit length along u over C widened by ρ, and let τ* be the
//! largest τ of C and the 26 cells around it, which hold the widened cell.
//! For t > τ*/m (and t < ρ), f(q + tu) ≥ m·t > τ* and f(q − tu) < −τ*, so
//! q + tu is outside the mesh and q − tu inside: the segment between them
//! meets the mesh, within t of q. The surface in C is within τ*/m of the
//! mesh ([`Slope::walk_to`](super::distance::Slope::walk_to)).
//!
//! A cell without a slope gets L and K from enclosures over the cell
//! itself, and τ grows by how far f at a corner may be past the corner's
//! side (an enclosure holding 0 counts inside, a point on the box's wall
//! outside). A neighbour where f's derivatives may jump or a vertex is not
//! proved near a root, a fanned one (its triangles are not marching
//! tetrahedra's), or one outside the lattice, leaves C without this bound.
//!
//! [`Slope::value`]: super::distance::Slope::value

use super::certify::Verdict;
use super::distance::value_over;
use super::lattice::{pack, Cell, Lattice, PointKey, Signs};
use super::vertex::Witness;
use super::Mesh;
use crate::expr::{DecoratedEvaluator, Tape};
use crate::types::rounding::up_bound;
use rayon::prelude::*;

/// How far f's corners of the cell at `corner` may be past the side of the
/// mesh they are on: f > 0 at most this at a corner inside (its enclosure
/// holds 0), f < 0 at most this at one outside (on the box's wall); `None`
/// where a corner has no value.
fn off_side(signs: &Signs, corner: [u32; 3]) -> Option<f64> {
    let mut most: f64 = 0.0;
    for (o, v) in signs.cube(corner).into_iter().enumerate() {
        if v.is_empty() || v.inf().is_nan() || v.sup().is_nan() {
            return None;
        }
        let p = [0, 1, 2].map(|a| corner[a] + (o as u32 >> a & 1));
        let past = if signs.inside_with(p, v) {
            v.sup()
        } else {
            -v.inf()
        };
        most = most.max(past);
    }
    Some(most)
}

/// How far the mesh and the surface are from each other in one cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Apart {
    /// Each point of the cell's triangles is within this of the surface.
    pub mesh_to_surface: f64,
    /// Each point of the surface in the cell is within this of the mesh.
    pub surface_to_mesh: f64,
}

impl Apart {
    /// The Hausdorff distance's bound: the larger of the two.
    pub fn both(&self) -> f64 {
        self.mesh_to_surface.max(self.surface_to_mesh)
    }
}

/// The cells of a mesh and what is known of them.
pub struct MeshedCells<'a> {
    /// The cells, in the order of their keys.
    pub cells: &'a [Cell],
    /// Each cell's certificate.
    pub verdicts: &'a [Verdict],
    /// f at the cells' corners.
    pub signs: &'a Signs,
    /// The lattice the cells are on.
    pub lattice: &'a Lattice,
    /// The cells' level.
    pub level: u32,
    /// The tape of [`super::distance::OUTPUTS`].
    pub second: &'a Tape,
    /// The cells sharpening fanned, in order.
    pub fanned: &'a [u32],
}

/// Each cell's bounds both ways, `None` where the cell is not certified
/// with a slope, a triangle's corner is not proved near a root, or a bound
/// is not found. `cell_of` gives each triangle's cell.
pub fn apart(on: &MeshedCells<'_>, mesh: &Mesh, cell_of: &[u32]) -> Vec<Option<Apart>> {
    let MeshedCells {
        cells,
        verdicts,
        signs,
        lattice,
        level,
        second,
        fanned,
    } = *on;
    let slope = |c: usize| match verdicts[c] {
        Verdict::Certified(Some(slope)) => Some(slope),
        _ => None,
    };
    // Each cell's triangles: `cell_of` runs in order.
    let mut starts = vec![0usize; cells.len() + 1];
    for &c in cell_of {
        starts[c as usize + 1] += 1;
    }
    for c in 0..cells.len() {
        starts[c + 1] += starts[c];
    }
    let triangles = |c: usize| &mesh.triangles[starts[c]..starts[c + 1]];
    let roots = |t: &[u32; 3]| {
        t.iter()
            .all(|&v| mesh.witnesses[v as usize] == Witness::Root)
    };
    // Each cell's largest vertex radius where every vertex is near a root,
    // and, in a cell with a slope, its farthest triangle from the surface
    // where every one has a bound.
    let (radius, far): (Vec<Option<f64>>, Vec<Option<f64>>) = (0..cells.len())
        .into_par_iter()
        .map(|c| {
            let mut radius = Some(0.0f64);
            for t in triangles(c) {
                radius = radius
                    .filter(|_| roots(t))
                    .map(|r| t.iter().fold(r, |r, &v| r.max(mesh.radii[v as usize])));
            }
            let far = radius.and_then(|_| {
                let slope = slope(c)?;
                triangles(c).iter().try_fold(0.0f64, |far, t| {
                    let corners = t.map(|v| mesh.positions[v as usize]);
                    let d = slope.distance(corners, t.map(|v| mesh.radii[v as usize]))?;
                    Some(far.max(d))
                })
            });
            (radius, far)
        })
        .unzip();
    let keys: Vec<PointKey> = cells.par_iter().map(|c| pack(c.corner)).collect();
    let edge = 1u32 << level;
    // A cell with a slope needs its own τ; another needs one where a cell
    // with a slope lies in its block (blocks are symmetric).
    let needed: Vec<bool> = (0..cells.len())
        .into_par_iter()
        .map_init(
            || Block::new(&keys),
            |block, c| {
                if slope(c).is_some() || radius[c].is_none() {
                    return slope(c).is_some();
                }
                let mut near = false;
                block.visit(cells[c].corner, edge, |i| near |= far[i].is_some());
                near
            },
        )
        .collect();
    // τ of each cell where one is found: f > τ outside the mesh, f < −τ
    // inside.
    let tau: Vec<Option<f64>> = (0..cells.len())
        .into_par_iter()
        .map_init(
            || DecoratedEvaluator::new(second),
            |eval, c| {
                if !needed[c] {
                    return None;
                }
                let r = radius[c]?;
                let b = lattice.cell(cells[c].corner, level);
                let span = up_bound((b.hi - b.lo).length());
                let value = match slope(c) {
                    // Its corners' signs are proved, none inside on the
                    // wall.
                    Some(slope) => return Some(slope.value(r, span, 4)),
                    // A fanned cell's triangles are not marching
                    // tetrahedra's, which the argument reads; where f has
                    // a branch open, its derivatives seldom are smooth.
                    None if cells[c].continuous
                        && verdicts[c]
                            != (Verdict::Uncertified {
                                creased: Some(true),
                            })
                        && fanned.binary_search(&(c as u32)).is_err() =>
                    {
                        value_over(eval, &b, r, span, 4)?
                    }
                    None => return None,
                };
                Some(up_bound(value + off_side(signs, cells[c].corner)?))
            },
        )
        .collect();
    (0..cells.len())
        .into_par_iter()
        .map_init(
            || Block::new(&keys),
            |block, c| {
                let far = far[c]?;
                let slope = slope(c)?;
                let mut most = Some(0.0f64);
                let inside = block.visit(cells[c].corner, edge, |i| {
                    most = most.zip(tau[i]).map(|(m, t)| m.max(t));
                });
                let walk = slope.walk_to(most.filter(|_| inside)?);
                (walk < slope.reach).then_some(Apart {
                    mesh_to_surface: far,
                    surface_to_mesh: walk,
                })
            },
        )
        .collect()
}

/// The cells f crosses in the 3×3×3 block of cells around one, found by
/// keeping a place in the sorted keys for each of the block's nine rows:
/// cells asked for in order move each place forward only.
struct Block<'a> {
    /// The cells' keys, in order.
    keys: &'a [PointKey],
    /// The first key at or past each row's start, for the last cell asked.
    places: [usize; 9],
}

impl<'a> Block<'a> {
    fn new(keys: &'a [PointKey]) -> Self {
        Block {
            keys,
            places: [0; 9],
        }
    }

    /// Calls `visit` with the number of each cell f crosses in the block
    /// around the cell at `corner`, on a lattice `edge` cells wide; returns
    /// whether the block lies in the lattice (where not, some are skipped).
    fn visit(&mut self, corner: [u32; 3], edge: u32, mut visit: impl FnMut(usize)) -> bool {
        let inside = corner.iter().all(|&i| i >= 1 && i + 1 < edge);
        for row in 0..9 {
            let (dy, dz) = (row as u32 % 3, row as u32 / 3);
            let (Some(y), Some(z)) = (
                (corner[1] + dy).checked_sub(1),
                (corner[2] + dz).checked_sub(1),
            ) else {
                continue;
            };
            let first = pack([corner[0].saturating_sub(1), y, z]);
            let last = pack([corner[0] + 1, y, z]);
            let place = &mut self.places[row];
            // Back to a search where the cells came out of order.
            if *place > 0 && self.keys[*place - 1] >= first {
                *place = 0;
            }
            // Galloping forward: cells asked in order move a little.
            let rest = &self.keys[*place..];
            let mut step = 1;
            while step < rest.len() && rest[step - 1] < first {
                step *= 2;
            }
            *place += rest[..step.min(rest.len())].partition_point(|&k| k < first);
            for (i, &k) in self.keys.iter().enumerate().skip(*place) {
                if k > last {
                    break;
                }
                visit(i);
            }
        }
        inside
    }
}
