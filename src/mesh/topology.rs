//! What a triangle mesh is, read off its triangles alone: closed, manifold,
//! consistently wound, its components and its Euler characteristic. The
//! mesher's construction promises the first three; this checks them on the
//! result, so a broken promise is an error rather than a bad file.

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
    // Directed edges, sorted: each must appear once, and its reverse once.
    let mut directed: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .collect();
    directed.sort_unstable();
    let unique = directed.windows(2).all(|w| w[0] != w[1]);
    let paired = directed
        .iter()
        .all(|&(a, b)| directed.binary_search(&(b, a)).is_ok());
    let closed = unique
        && paired
        && triangles
            .iter()
            .all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
    let mut undirected: Vec<(u32, u32)> = directed
        .iter()
        .map(|&(a, b)| (a.min(b), a.max(b)))
        .collect();
    undirected.sort_unstable();
    undirected.dedup();
    let euler = vertices as i64 - undirected.len() as i64 + triangles.len() as i64;

    // Around vertex a, triangle (a, b, c) links b to c; in a closed manifold
    // those links form one cycle per vertex.
    let manifold = closed && {
        let mut links: Vec<(u32, u32, u32)> = triangles
            .iter()
            .flat_map(|t| [(t[0], t[1], t[2]), (t[1], t[2], t[0]), (t[2], t[0], t[1])])
            .collect();
        links.sort_unstable();
        let mut ok = true;
        let mut start = 0;
        while start < links.len() && ok {
            let a = links[start].0;
            let end = start + links[start..].partition_point(|l| l.0 == a);
            let fan = &links[start..end];
            // Follow b → c from the first link; a single cycle visits all.
            let mut at = fan[0].2;
            let mut steps = 1;
            while at != fan[0].1 && steps <= fan.len() {
                match fan.binary_search_by(|l| (l.1).cmp(&at)) {
                    Ok(i) => at = fan[i].2,
                    Err(_) => break,
                }
                steps += 1;
            }
            ok = at == fan[0].1 && steps == fan.len();
            start = end;
        }
        ok
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
