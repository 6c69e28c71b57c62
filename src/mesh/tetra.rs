//! Marching tetrahedra: each cell split into six tetrahedra around its main
//! diagonal (Kuhn's split, the same in every cell, so neighbouring cells
//! split their shared face along the same diagonal), and in each tetrahedron
//! the triangles that separate its inside corners from its outside ones.
//!
//! The triangles' corners are lattice edges, named by [`EdgeKey`]; a vertex
//! placed anywhere strictly inside its edge keeps every triangle inside its
//! own tetrahedron, meeting its neighbours only along shared faces. So the
//! mesh is closed, 2-manifold and free of self-intersections whatever the
//! vertices' places on their edges.

use super::lattice::{pack, unpack, PointKey};

/// A lattice edge: its lower end's key times 8, plus the step to its upper
/// end as three bits (x, y, z), each 0 or 1.
pub type EdgeKey = u64;

/// The edge between lattice points `a` and `b`, which differ by 0 or 1 on
/// each axis, in the same direction on all.
pub fn edge(a: [u32; 3], b: [u32; 3]) -> EdgeKey {
    let lo = [0, 1, 2].map(|i| a[i].min(b[i]));
    let step = (0..3).fold(0u64, |s, i| s | ((a[i] != b[i]) as u64) << i);
    pack(lo) << 3 | step
}

/// The two lattice ends of an edge, lower first.
pub fn ends(e: EdgeKey) -> ([u32; 3], [u32; 3]) {
    let lo = unpack(e >> 3);
    let hi = [0, 1, 2].map(|i| lo[i] + (e >> i & 1) as u32);
    (lo, hi)
}

/// The lower end's key of an edge.
pub fn lower(e: EdgeKey) -> PointKey {
    e >> 3
}

/// The six orders of the axes; tetrahedron `π` of a cell walks from its
/// lowest corner to its highest one, one axis at a time in the order `π`.
pub const ORDERS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

/// The triangles of cell `corner`, given which lattice points are inside,
/// appended to `out` as edge triples, each wound so that its normal (by the
/// right-hand rule) points from the inside corners to the outside ones.
pub fn cell_triangles(
    corner: [u32; 3],
    inside: impl Fn([u32; 3]) -> bool,
    out: &mut Vec<[EdgeKey; 3]>,
) {
    let mut cube = [[0u32; 3]; 8];
    let mut is_in = [false; 8];
    for (o, (p, s)) in cube.iter_mut().zip(is_in.iter_mut()).enumerate() {
        *p = [0, 1, 2].map(|a| corner[a] + (o as u32 >> a & 1));
        *s = inside(*p);
    }
    if is_in.iter().all(|&s| s) || is_in.iter().all(|&s| !s) {
        return;
    }
    for order in ORDERS {
        let mut corners = [0usize; 4];
        for k in 0..3 {
            corners[k + 1] = corners[k] | 1 << order[k];
        }
        let tet = corners.map(|o| (cube[o], is_in[o]));
        tetra_triangles(tet, out);
    }
}

/// A cell's triangles for one set of inside corners, as
/// [`cell_triangles`] gives them for the cell at the origin: its distinct
/// edges in the order its triangles first meet them, and each triangle as
/// three numbers in that list.
#[derive(Debug, Default)]
pub struct CellCase {
    /// The edges, as keys for the cell at the origin ([`CellCase::edges_at`]
    /// moves them).
    pub edges: Vec<EdgeKey>,
    /// The triangles, wound as [`cell_triangles`] winds them.
    pub triangles: Vec<[u8; 3]>,
}

impl CellCase {
    /// The edges of the cell whose lowest corner is `corner`: a key's lower
    /// end moves with the cell, which adds to each axis's bits without a
    /// carry (coordinates stay below `2^AXIS_BITS`).
    pub fn edges_at(&self, corner: [u32; 3]) -> impl Iterator<Item = EdgeKey> + '_ {
        let base = pack(corner) << 3;
        self.edges.iter().map(move |&e| base + e)
    }
}

/// Every [`CellCase`], by the mask of the cell's inside corners (bit `o`
/// for corner `o`, the lowest corner plus bit `a` of `o` on axis `a`).
pub fn cell_cases() -> &'static [CellCase] {
    static CASES: std::sync::LazyLock<Vec<CellCase>> = std::sync::LazyLock::new(|| {
        let mut triangles = Vec::new();
        (0..256u32)
            .map(|mask| {
                triangles.clear();
                let inside = |p: [u32; 3]| mask >> (p[0] | p[1] << 1 | p[2] << 2) & 1 == 1;
                cell_triangles([0; 3], inside, &mut triangles);
                let mut case = CellCase::default();
                for t in &triangles {
                    let corners = t.map(|e| match case.edges.iter().position(|&k| k == e) {
                        Some(j) => j as u8,
                        None => {
                            case.edges.push(e);
                            (case.edges.len() - 1) as u8
                        }
                    });
                    case.triangles.push(corners);
                }
                case
            })
            .collect()
    });
    &CASES
}

/// The triangles of one tetrahedron (corners with their sides).
fn tetra_triangles(tet: [([u32; 3], bool); 4], out: &mut Vec<[EdgeKey; 3]>) {
    let (mut ins, mut outs) = ([[0u32; 3]; 4], [[0u32; 3]; 4]);
    let (mut n_in, mut n_out) = (0, 0);
    for (p, inside) in tet {
        if inside {
            ins[n_in] = p;
            n_in += 1;
        } else {
            outs[n_out] = p;
            n_out += 1;
        }
    }
    let (ins, outs) = (&ins[..n_in], &outs[..n_out]);
    match (n_in, n_out) {
        (1, 3) => out.push(wound([0, 1, 2].map(|k| (ins[0], outs[k])), ins, outs)),
        (3, 1) => out.push(wound([0, 1, 2].map(|k| (ins[k], outs[0])), ins, outs)),
        (2, 2) => {
            // The four crossing edges form a cycle a–c, b–c, b–d, a–d
            // (a, b inside; c, d outside); the diagonal a–c to b–d joins
            // opposite edges, so it runs inside the tetrahedron.
            let (a, b, c, d) = (ins[0], ins[1], outs[0], outs[1]);
            out.push(wound([(a, c), (b, c), (b, d)], ins, outs));
            out.push(wound([(a, c), (b, d), (a, d)], ins, outs));
        }
        _ => {}
    }
}

/// A triangle of crossing edges wound outward. The winding is decided on
/// the edges' midpoints in doubled lattice coordinates, exact integers: the
/// midpoint triangle separates the same corners as the placed one, so the
/// side it faces is the placed one's side too.
fn wound(t: [([u32; 3], [u32; 3]); 3], ins: &[[u32; 3]], outs: &[[u32; 3]]) -> [EdgeKey; 3] {
    let mid = |(a, b): ([u32; 3], [u32; 3])| [0, 1, 2].map(|i| a[i] as i64 + b[i] as i64);
    let [m0, m1, m2] = t.map(mid);
    let u = [0, 1, 2].map(|i| m1[i] - m0[i]);
    let v = [0, 1, 2].map(|i| m2[i] - m0[i]);
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    // From the inside corners' centroid to the outside ones', scaled by
    // both counts to stay in integers.
    let sum = |ps: &[[u32; 3]], axis: usize| ps.iter().map(|p| p[axis] as i64).sum::<i64>();
    let d = [0, 1, 2].map(|i| sum(outs, i) * ins.len() as i64 - sum(ins, i) * outs.len() as i64);
    let facing = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    debug_assert!(facing != 0, "a midpoint triangle separates its corners");
    let keys = t.map(|(a, b)| edge(a, b));
    if facing > 0 {
        keys
    } else {
        [keys[0], keys[2], keys[1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_name_the_same_segment_from_either_end() {
        let a = [3, 4, 5];
        let b = [4, 4, 6];
        assert_eq!(edge(a, b), edge(b, a));
        assert_eq!(ends(edge(a, b)), (a, b));
    }

    #[test]
    fn one_inside_corner_gives_one_triangle_per_tetrahedron_touching_it() {
        let mut out = Vec::new();
        // Only the cell's lowest corner is inside: it is in all six
        // tetrahedra, each cut once around it.
        cell_triangles([0, 0, 0], |p| p == [0, 0, 0], &mut out);
        assert_eq!(out.len(), 6);
        // The highest corner is in all six too.
        out.clear();
        cell_triangles([0, 0, 0], |p| p == [1, 1, 1], &mut out);
        assert_eq!(out.len(), 6);
        // Corner (1, 0, 0) is in the two tetrahedra that step along x first.
        out.clear();
        cell_triangles([0, 0, 0], |p| p == [1, 0, 0], &mut out);
        assert_eq!(out.len(), 2);
    }

    /// Each case, moved to a cell, gives that cell's triangles, in order.
    #[test]
    fn cell_cases_are_the_cells_triangles_moved() {
        let cases = cell_cases();
        let mut out = Vec::new();
        let mut nonempty = 0;
        for corner in [[0, 0, 0], [5, 17, 2], [(1 << 19) - 1, 3, (1 << 19) - 1]] {
            for (mask, case) in cases.iter().enumerate() {
                let inside = |p: [u32; 3]| {
                    let o = (0..3).map(|a| (p[a] - corner[a]) << a).sum::<u32>();
                    mask >> o & 1 == 1
                };
                out.clear();
                cell_triangles(corner, inside, &mut out);
                let edges: Vec<EdgeKey> = case.edges_at(corner).collect();
                let moved: Vec<[EdgeKey; 3]> = case
                    .triangles
                    .iter()
                    .map(|t| t.map(|j| edges[j as usize]))
                    .collect();
                assert_eq!(moved, out, "mask {mask:08b} at {corner:?}");
                nonempty += usize::from(!out.is_empty());
            }
        }
        assert_eq!(nonempty, 3 * 254);
    }
}
