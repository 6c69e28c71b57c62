//! What a triangle mesh is, read off its triangles alone: closed, manifold,
//! consistently wound, its components and its Euler characteristic. The
//! mesher's construction promises the first three; this checks them on the
//! result, so a broken promise is an error rather than a bad file.

use rayon::prelude::*;

/// The shape of a triangle mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Topology {
    /// Every edge is in exactly two triangles, which run along it in
    /// opposite directions (closed, and wound consistently).
    pub closed: bool,
    /// Around every vertex the triangles form one fan closing on itself.
    pub manifold: bool,
    /// Connected components (by shared vertices).
    pub components: usize,
    /// V − E + F; 2 − 2g summed over the components when closed.
    pub euler: i64,
}

/// Reads the topology of `triangles` over `vertices` vertices.
pub fn topology(vertices: usize, triangles: &[[u32; 3]]) -> Topology {
    // Each triangle's directed edges a → b, with the corner c opposite, as
    // (a·2³² + b, c), sorted. Each edge must appear once and its reverse
    // once; around vertex a, the edges a → b link b to c, and in a closed
    // manifold those links form one cycle.
    let key = |a: u32, b: u32| (a as u64) << 32 | b as u64;
    let mut links: Vec<(u64, u32)> = triangles
        .par_iter()
        .flat_map_iter(|t| {
            [
                (key(t[0], t[1]), t[2]),
                (key(t[1], t[2]), t[0]),
                (key(t[2], t[0]), t[1]),
            ]
        })
        .collect();
    links.par_sort_unstable_by_key(|l| l.0);
    let has = |k: u64| links.binary_search_by_key(&k, |l| l.0).is_ok();
    let reverse = |k: u64| k.rotate_left(32);
    let unique = links.par_windows(2).all(|w| w[0].0 != w[1].0);
    let paired = links.par_iter().all(|l| has(reverse(l.0)));
    let closed = unique
        && paired
        && triangles
            .par_iter()
            .all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
    // Each undirected edge once: the directed edges running upward, plus
    // those running downward whose reverse is missing.
    let edges = links
        .par_iter()
        .filter(|l| l.0 < reverse(l.0) || !has(reverse(l.0)))
        .count();
    let euler = vertices as i64 - edges as i64 + triangles.len() as i64;

    let manifold = closed && {
        // Where each vertex's fan starts in the sorted links.
        let from = |i: usize| links[i].0 >> 32;
        let starts: Vec<usize> = (0..links.len())
            .into_par_iter()
            .filter(|&i| i == 0 || from(i - 1) != from(i))
            .collect();
        starts.par_iter().enumerate().all(|(k, &start)| {
            let end = starts.get(k + 1).copied().unwrap_or(links.len());
            let fan = &links[start..end];
            let to = |l: &(u64, u32)| l.0 as u32;
            // Follow b → c from the first link; a single cycle visits all.
            let first = to(&fan[0]);
            let mut at = fan[0].1;
            let mut steps = 1;
            while at != first && steps <= fan.len() {
                match fan.binary_search_by_key(&at, to) {
                    Ok(i) => at = fan[i].1,
                    Err(_) => break,
                }
                steps += 1;
            }
            at == first && steps == fan.len()
        })
    };

    let components = count_components(vertices, triangles);
    Topology {
        closed,
        manifold,
        components,
        euler,
    }
}

/// Connected components of the triangles (isolated vertices not counted).
fn count_components(vertices: usize, triangles: &[[u32; 3]]) -> usize {
    let mut parent: Vec<u32> = (0..vertices as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            let up = parent[parent[v as usize] as usize];
            parent[v as usize] = up;
            v = up;
        }
        v
    }
    for t in triangles {
        for k in 1..3 {
            let (a, b) = (root(&mut parent, t[0]), root(&mut parent, t[k]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut used = vec![false; vertices];
    for t in triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    (0..vertices as u32)
        .filter(|&v| used[v as usize] && root(&mut parent, v) == v)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TETRAHEDRON: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];

    #[test]
    fn a_tetrahedron_is_a_closed_manifold_sphere() {
        let t = topology(4, &TETRAHEDRON);
        assert_eq!(
            t,
            Topology {
                closed: true,
                manifold: true,
                components: 1,
                euler: 2
            }
        );
    }

    #[test]
    fn a_flipped_or_missing_triangle_is_caught() {
        let mut flipped = TETRAHEDRON;
        flipped[0] = [0, 1, 2];
        assert!(!topology(4, &flipped).closed);
        assert!(!topology(4, &TETRAHEDRON[..3]).closed);
    }

    #[test]
    fn two_tetrahedra_sharing_a_vertex_are_closed_but_not_manifold() {
        let mut both = TETRAHEDRON.to_vec();
        // A second tetrahedron on vertices 3, 4, 5, 6 shares vertex 3.
        both.extend(
            TETRAHEDRON
                .iter()
                .map(|t| t.map(|v| if v == 0 { 3 } else { v + 3 })),
        );
        let t = topology(7, &both);
        assert!(t.closed);
        assert!(!t.manifold);
        assert_eq!(t.components, 1);
    }
}
