//! Triangle meshes of `f = 0` that are closed, 2-manifold, free of
//! self-intersections and wound with f increasing outward, with every vertex
//! placed within a proved distance of the surface.
//!
//! The box is split into a lattice of `2^depth` cells per axis; interval
//! subdivision drops every box whose enclosure of f excludes 0
//! ([`lattice::find_cells`]). Each remaining cell is split into six
//! tetrahedra ([`tetra`]), each lattice point is inside or outside by its
//! proved sign, and each tetrahedron gets the triangles between its inside
//! and outside corners. A triangle's corners lie on lattice edges, where
//! bisection on proved signs places them ([`vertex`]). Whatever f does, the
//! triangles are those of a surface separating lattice points, so the mesh
//! is a closed 2-manifold; [`topology()`] checks that on the result. Where a
//! `min`/`max` crease crosses an uncertified cell, [`crease`] fans the cell
//! from a point on the crease, so edges and corners come out sharp.
//!
//! The solid `f < 0` is cut by the box: lattice points on the box's wall are
//! outside, so where the solid reaches the wall the mesh closes just inside
//! it, and those vertices say so ([`Witness::Wall`]).

pub mod certify;
pub mod crease;
pub mod distance;
pub mod hausdorff;
pub mod lattice;
pub mod point;
pub mod scene;
pub mod tetra;
pub mod topology;
pub mod vertex;
pub mod write;

use crate::expr::DecoratedEvaluator;
use crate::formula::{Formula, Output};
use crate::types::rounding::{f32_move, up_bound};
use crate::types::Aabb;
pub use certify::{Certificate, Doubt, Uncertified};
use lattice::{find_cells, Lattice, Signs};
use point::PointEnclosures;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use tetra::{cell_cases, EdgeKey};
pub use topology::{topology, Topology};
pub use vertex::Witness;

/// How finely to mesh.
#[derive(Debug, Clone, Copy)]
pub struct MeshOptions {
    /// Cells per axis: `2^depth`.
    pub depth: u32,
    /// How far the mesh may be from the surface where a cell is certified,
    /// both ways; `None` for [`DEFAULT_TOLERANCE`] of a cell's shortest side. Vertices
    /// are placed within a sixteenth of it of their witness points.
    pub tolerance: Option<f64>,
    /// The most cells kept at one level; a level that would hold more stops
    /// the splitting at the one before.
    pub max_cells: usize,
}

/// Why a mesh cannot be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    /// The depth is past what lattice keys hold.
    #[error("depth {0} is too deep: use a whole number from 0 to {max}", max = lattice::MAX_DEPTH)]
    Depth(u32),
    /// Neighbouring lattice points would round to the same coordinate.
    #[error("the box is too thin for depth {0}: neighbouring lattice points round to the same coordinate")]
    Thin(u32),
    /// The tolerance is not a positive number.
    #[error("the tolerance {0} must be a positive number")]
    Tolerance(f64),
    /// The construction's promise was broken (a bug, never a property of f).
    #[error("internal error: the mesh is not a closed 2-manifold ({0:?})")]
    Topology(Topology),
}

/// A triangle mesh with what is proved of each vertex.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<glam::DVec3>,
    /// Triangles, wound counter-clockwise seen from outside (where f > 0).
    pub triangles: Vec<[u32; 3]>,
    /// What lies near each vertex.
    pub witnesses: Vec<Witness>,
    /// Each vertex's distance bound to its witness point.
    pub radii: Vec<f64>,
}

impl Mesh {
    /// How many vertices have the witness `w`.
    pub fn count(&self, w: Witness) -> usize {
        self.witnesses.iter().filter(|&&x| x == w).count()
    }
}

/// A mesh with how it was made.
#[derive(Debug, Clone)]
pub struct Meshed {
    /// The mesh.
    pub mesh: Mesh,
    /// Its topology, checked.
    pub topology: Topology,
    /// The lattice level the cells stopped at (the depth asked for unless
    /// `max_cells` stopped it).
    pub level: u32,
    /// Cells f may cross at that level.
    pub cells: usize,
    /// Of those, cells where f may jump or lack a value.
    pub discontinuous_cells: usize,
    /// Which cells the mesh is isotopic to the surface in.
    pub certificate: Certificate,
    /// The creased cells fanned from a point on their crease.
    pub sharpened: crease::Sharpened,
}

/// The triangles one job lists for its cells.
#[derive(Debug, Default)]
struct CellChunk {
    /// Each cell's distinct edges, with the cell's number.
    edges: Vec<(EdgeKey, u32)>,
    /// Each triangle's corners, as numbers in `edges`.
    corners: Vec<[u32; 3]>,
    /// Each triangle's cell.
    cell_of: Vec<u32>,
}

/// Vertices placed by one job (and reported at once).
const PLACE_CHUNK: usize = 1024;

/// Cells whose triangles one job lists.
const CELL_CHUNK: usize = 1024;

/// Meshes `f = 0` inside `b`.
pub fn mesh(formula: &Formula, b: &Aabb, options: &MeshOptions) -> Result<Meshed, MeshError> {
    mesh_with_progress(formula, b, options, &|_| {})
}

/// A stage of [`mesh_with_progress`], reported as it starts or advances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// Finding the cells f may cross, level by level.
    Cells,
    /// Placing `n` vertices, reported as `Placed` as they are placed.
    Vertices(u64),
    /// This many more vertices placed.
    Placed(u64),
    /// Certifying `n` cells, reported as `Certified` as they are done.
    Certify(u64),
    /// This many more cells certified (or not).
    Certified(u64),
    /// Checking the result.
    Check,
}

/// [`mesh`], telling `report` what it is doing (from any thread), for a
/// progress display.
pub fn mesh_with_progress(
    formula: &Formula,
    b: &Aabb,
    options: &MeshOptions,
    report: &(dyn Fn(Progress) + Sync),
) -> Result<Meshed, MeshError> {
    mesh_with_room(formula, b, options, 0.0, report)
}

/// [`mesh_with_progress`], with a certified cell's distances leaving `room`
/// for moving each vertex after meshing (placing it in a scene), as they
/// leave room for rounding it to f32.
pub(crate) fn mesh_with_room(
    formula: &Formula,
    b: &Aabb,
    options: &MeshOptions,
    room: f64,
    report: &(dyn Fn(Progress) + Sync),
) -> Result<Meshed, MeshError> {
    if options.depth > lattice::MAX_DEPTH {
        return Err(MeshError::Depth(options.depth));
    }
    if let Some(t) = options.tolerance.filter(|t| !(*t > 0.0 && t.is_finite())) {
        return Err(MeshError::Tolerance(t));
    }
    let lattice = Lattice::new(b);
    if !lattice.is_resolved(options.depth) {
        return Err(MeshError::Thin(options.depth));
    }
    let tape = formula.tape(&[Output::F]);
    report(Progress::Cells);
    let found = find_cells(&tape, &lattice, options.depth, options.max_cells);
    let level = found.level;
    let signs = Signs::of_corners(&tape, &lattice, &found.cells, level);

    // Triangles, in the cells' order, each with its cell; each cell's
    // distinct edges (with the cell), and each triangle corner as the
    // number of its cell's edge within the chunk.
    let cases = cell_cases();
    let chunks: Vec<CellChunk> = found
        .cells
        .par_chunks(CELL_CHUNK)
        .enumerate()
        .map(|(k, cells)| {
            let mut chunk = CellChunk::default();
            for (i, c) in cells.iter().enumerate() {
                let at = signs.cube(c.corner);
                let mask = (0..8u32).fold(0, |m, o| {
                    let p = [0, 1, 2].map(|a| c.corner[a] + (o >> a & 1));
                    m | usize::from(signs.inside_with(p, at[o as usize])) << o
                });
                let case = &cases[mask];
                let cell = (k * CELL_CHUNK + i) as u32;
                let first = chunk.edges.len() as u32;
                chunk
                    .edges
                    .extend(case.edges_at(c.corner).map(|e| (e, cell)));
                chunk.corners.extend(
                    case.triangles
                        .iter()
                        .map(|t| t.map(|j| first + u32::from(j))),
                );
                chunk.cell_of.resize(chunk.corners.len(), cell);
            }
            chunk
        })
        .collect();
    // Each cell's edges by key, sorted, so each edge's cells are together:
    // the edge becomes one vertex, continuous where any cell holding it is
    // (then so is the edge). A cell lists an edge once however many of its
    // triangles meet there, so this sorts a third as many as the corners.
    let mut offset = 0;
    let offsets: Vec<usize> = chunks
        .iter()
        .map(|c| {
            offset += c.edges.len();
            offset - c.edges.len()
        })
        .collect();
    let cell_edges: Vec<(EdgeKey, u32)> = chunks
        .iter()
        .flat_map(|c| c.edges.iter().copied())
        .collect();
    let mut slots: Vec<(EdgeKey, usize)> = cell_edges
        .par_iter()
        .enumerate()
        .map(|(n, &(e, _))| (e, n))
        .collect();
    slots.par_sort_unstable_by_key(|s| s.0);
    let (unique, vertex_of_edge) =
        number_edges(&slots, |n| found.cells[cell_edges[n].1 as usize].continuous);
    drop(slots);
    let (triangles, cell_of): (Vec<[u32; 3]>, Vec<u32>) = {
        let mut all = (Vec::new(), Vec::new());
        for (c, &offset) in chunks.iter().zip(&offsets) {
            all.0.extend(
                c.corners
                    .iter()
                    .map(|t| t.map(|local| vertex_of_edge[offset + local as usize])),
            );
            all.1.extend_from_slice(&c.cell_of);
        }
        all
    };
    drop(chunks);

    let tolerance = options.tolerance.unwrap_or_else(|| {
        let first = lattice.cell([0; 3], level);
        (first.hi - first.lo).min_element() * DEFAULT_TOLERANCE
    });
    let radius = tolerance / VERTEX_SHARE;
    report(Progress::Vertices(unique.len() as u64));
    // Placed in chunks, each reported once: a report per vertex cost more
    // than placing it on the sphere.
    let placed: Vec<vertex::Placed> = unique
        .par_chunks(PLACE_CHUNK)
        .flat_map_iter(|chunk| {
            // Each vertex evaluates f a few times: blocks down to two cells.
            let mut f = PointEnclosures::new(&tape, &lattice, level, 1);
            let mut decorated = DecoratedEvaluator::new(&tape);
            let out: Vec<vertex::Placed> = chunk
                .iter()
                .map(|&(e, cont)| {
                    vertex::place(
                        &mut f,
                        &mut decorated,
                        &lattice,
                        &signs,
                        level,
                        e,
                        radius,
                        cont,
                    )
                })
                .collect();
            report(Progress::Placed(chunk.len() as u64));
            out
        })
        .collect();
    let mut mesh = Mesh {
        positions: placed.iter().map(|p| p.position).collect(),
        witnesses: placed.iter().map(|p| p.witness).collect(),
        radii: placed.iter().map(|p| p.radius).collect(),
        triangles,
    };
    let gradient = formula.tape(&[Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz]);
    report(Progress::Certify(found.cells.len() as u64));
    let second = formula.tape(&distance::OUTPUTS);
    let (mut certificate, verdicts) = certify::certify(
        &tape,
        &gradient,
        &second,
        &lattice,
        &found.cells,
        &signs,
        level,
        mesh.radii.iter().copied().fold(0.0, f64::max),
        report,
    );
    let mut cell_of = cell_of;
    let edges: Vec<EdgeKey> = unique.iter().map(|u| u.0).collect();
    let sharpened = crease::sharpen(
        &crease::Sharpening {
            tape: &tape,
            gradient: &gradient,
            lattice: &lattice,
            level,
            cells: &found.cells,
            verdicts: &verdicts,
            edges: &edges,
            radius,
        },
        &mut mesh,
        &mut cell_of,
    );
    report(Progress::Check);
    let topology = topology(mesh.positions.len(), &mesh.triangles);
    if !(topology.closed && topology.manifold) {
        return Err(MeshError::Topology(topology));
    }
    let on = hausdorff::MeshedCells {
        cells: &found.cells,
        verdicts: &verdicts,
        signs: &signs,
        lattice: &lattice,
        level,
        second: &second,
        fanned: &sharpened.fanned,
    };
    let apart = hausdorff::apart(&on, &mesh, &cell_of);
    within(&mut certificate, &apart, &verdicts, tolerance, room, |c| {
        lattice.cell(found.cells[c].corner, level)
    });
    Ok(Meshed {
        certificate,
        mesh,
        topology,
        level,
        sharpened,
        cells: found.cells.len(),
        discontinuous_cells: found.cells.iter().filter(|c| !c.continuous).count(),
    })
}

/// The default tolerance, as a part of a cell's shortest side: the proof
/// of how far the mesh and a smooth surface are apart finds them within it
/// once a cell is an eighth or so of the surface's radius of curvature.
pub const DEFAULT_TOLERANCE: f64 = 0.25;

/// How much finer than the tolerance a vertex's radius is: a vertex's
/// distance to its root adds about its radius to a triangle's, and the
/// rest is left for the triangle's sag.
pub const VERTEX_SHARE: f64 = 16.0;

/// How far rounding a point of `b` to f32 moves it, at most.
pub(crate) fn single_rounding(b: &Aabb) -> f64 {
    f32_move(b.lo.abs().max(b.hi.abs()).max_element())
}

/// Keeps certified only the cells of `certificate` whose mesh and surface
/// are proved within `tolerance` of each other (`apart`, by cell), leaving
/// `room` for moving the vertices and room for rounding them to f32; the
/// others become [`Doubt::Far`]. Sets the tolerance, and the distances to
/// the certified cells' largest.
fn within(
    certificate: &mut Certificate,
    apart: &[Option<hausdorff::Apart>],
    verdicts: &[certify::Verdict],
    tolerance: f64,
    room: f64,
    cell: impl Fn(usize) -> Aabb,
) {
    certificate.tolerance = tolerance;
    let mut far = Vec::new();
    for (c, (a, v)) in apart.iter().zip(verdicts).enumerate() {
        if !matches!(v, certify::Verdict::Certified(_)) {
            continue;
        }
        let b = cell(c);
        // The mesh near the cell's surface may lie in the cells around it.
        let around = Aabb {
            lo: b.lo - (b.hi - b.lo),
            hi: b.hi + (b.hi - b.lo),
        };
        match a {
            Some(a) if up_bound(a.both() + single_rounding(&around) + room) <= tolerance => {
                certificate.mesh_to_surface = certificate.mesh_to_surface.max(a.mesh_to_surface);
                certificate.surface_to_mesh = certificate.surface_to_mesh.max(a.surface_to_mesh);
                certificate.hausdorff = certificate.hausdorff.max(a.both());
            }
            _ => far.push(Uncertified {
                cell: b,
                doubt: Doubt::Far,
            }),
        }
    }
    certificate.certified -= far.len();
    if !far.is_empty() {
        certificate.uncertified.append(&mut far);
        let key = |u: &Uncertified| [u.cell.lo.z, u.cell.lo.y, u.cell.lo.x];
        certificate.uncertified.sort_by(|a, b| {
            key(a)
                .partial_cmp(&key(b))
                .expect("lattice points are numbers")
        });
    }
}

/// The vertices of the cells' edges in `slots` (each an edge and its slot,
/// a number below the slots' count, sorted by edge): each run of one edge
/// is one vertex, in the runs' order, continuous where the cell of any
/// slot in it is (`continuous(slot)`). Returns each vertex's edge and
/// continuity, and each slot's vertex.
fn number_edges(
    slots: &[(EdgeKey, usize)],
    continuous: impl Fn(usize) -> bool + Sync,
) -> (Vec<(EdgeKey, bool)>, Vec<u32>) {
    let n = slots.len();
    let starts_run = |i: usize| i == 0 || slots[i - 1].0 != slots[i].0;
    // Pieces numbered in parallel: first each piece's runs are counted, so
    // each knows the number of its first.
    let piece = n.div_ceil(4 * rayon::current_num_threads()).max(1);
    let pieces = n.div_ceil(piece);
    let range = |p: usize| p * piece..((p + 1) * piece).min(n);
    let counts: Vec<usize> = (0..pieces)
        .into_par_iter()
        .map(|p| range(p).filter(|&i| starts_run(i)).count())
        .collect();
    let before: Vec<usize> = counts
        .iter()
        .scan(0, |sum, &c| {
            let first = *sum;
            *sum += c;
            Some(first)
        })
        .collect();
    let vertex_of: Vec<AtomicU32> = (0..n).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    let unique: Vec<(EdgeKey, bool)> = (0..pieces)
        .into_par_iter()
        .flat_map_iter(|p| {
            let mut runs = Vec::with_capacity(counts[p]);
            let mut started = before[p];
            for i in range(p) {
                if starts_run(i) {
                    // A run may reach into the next piece; it is this one's.
                    let e = slots[i].0;
                    let cont = slots[i..]
                        .iter()
                        .take_while(|s| s.0 == e)
                        .any(|s| continuous(s.1));
                    runs.push((e, cont));
                    started += 1;
                }
                vertex_of[slots[i].1].store((started - 1) as u32, Ordering::Relaxed);
            }
            runs
        })
        .collect();
    let vertex_of = vertex_of.into_iter().map(AtomicU32::into_inner).collect();
    (unique, vertex_of)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn edges_are_numbered_as_a_scan_in_order_numbers_them(
            mut keys in prop::collection::vec(0u64..40, 0..3000),
            odd in 1usize..7,
        ) {
            // Runs of every length, some across the pieces' boundaries.
            keys.sort_unstable();
            let slots: Vec<(EdgeKey, usize)> = keys
                .iter()
                .enumerate()
                .map(|(i, &k)| (k, (i * 7919) % keys.len().max(1)))
                .collect();
            let continuous = |slot: usize| slot.is_multiple_of(odd);
            let (unique, vertex_of) = number_edges(&slots, continuous);
            let mut expected_unique: Vec<(EdgeKey, bool)> = Vec::new();
            let mut expected_of = vec![0u32; slots.len()];
            for &(e, slot) in &slots {
                match expected_unique.last_mut() {
                    Some(last) if last.0 == e => last.1 |= continuous(slot),
                    _ => expected_unique.push((e, continuous(slot))),
                }
                expected_of[slot] = (expected_unique.len() - 1) as u32;
            }
            prop_assert_eq!(unique, expected_unique);
            prop_assert_eq!(vertex_of, expected_of);
        }
    }
}
