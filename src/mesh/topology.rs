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

/// Fans this long or shorter are searched by a scan; longer ones are
/// sorted first.
const SHORT_FAN: usize = 16;

/// The links of one vertex a's fan: for each triangle's edge a → b, the
/// corner c opposite it, as (b, c); sorted by b when the fan is long.
struct Fan<'a>(&'a [(u32, u32)]);

impl Fan<'_> {
    /// How many links leave a towards `b`, and the corner of the first.
    fn find(&self, b: u32) -> (usize, Option<u32>) {
        if self.0.len() <= SHORT_FAN {
            let mut hits = self.0.iter().filter(|l| l.0 == b);
            let first = hits.next().map(|l| l.1);
            (first.is_some() as usize + hits.count(), first)
        } else {
            let lo = self.0.partition_point(|l| l.0 < b);
            let hi = self.0.partition_point(|l| l.0 <= b);
            (hi - lo, (hi > lo).then(|| self.0[lo].1))
        }
    }
}

/// Reads the topology of `triangles` over `vertices` vertices.
pub fn topology(vertices: usize, triangles: &[[u32; 3]]) -> Topology {
    if triangles.iter().flatten().any(|&v| v as usize >= vertices) {
        return Topology {
            closed: false,
            manifold: false,
            components: count_components(vertices, &[]),
            euler: vertices as i64,
        };
    }
    // The components are counted on one thread, a union-find, while the
    // fans are read.
    let ((closed, cycles, euler), components) = rayon::join(
        || fans(vertices, triangles),
        || count_components(vertices, triangles),
    );
    Topology {
        closed,
        manifold: closed && cycles,
        components,
        euler,
    }
}

/// Whether every directed edge of `triangles` appears once and its reverse
/// once, whether the links around each vertex form one cycle, and V − E + F.
fn fans(vertices: usize, triangles: &[[u32; 3]]) -> (bool, bool, i64) {
    // Each triangle's directed edges a → b, with the corner c opposite,
    // gathered by a (a counting sort: a's fan). Each edge must appear once
    // and its reverse once; around vertex a, the edges a → b link b to c,
    // and in a closed manifold those links form one cycle.
    let mut start = vec![0usize; vertices + 1];
    for &v in triangles.iter().flatten() {
        start[v as usize + 1] += 1;
    }
    for v in 0..vertices {
        start[v + 1] += start[v];
    }
    let mut next = start.clone();
    let mut links = vec![(0u32, 0u32); 3 * triangles.len()];
    for t in triangles {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            links[next[a as usize]] = (b, c);
            next[a as usize] += 1;
        }
    }
    drop(next);
    for a in 0..vertices {
        if start[a + 1] - start[a] > SHORT_FAN {
            links[start[a]..start[a + 1]].sort_unstable();
        }
    }
    let fan = |a: usize| Fan(&links[start[a]..start[a + 1]]);
    // For each vertex: whether its links are closed (each edge once, its
    // reverse present, no corner repeated), whether they form one cycle,
    // and the undirected edges it is the first end of.
    let (closed, cycles, edges) = (0..vertices)
        .into_par_iter()
        .map(|a| {
            let around = fan(a);
            let mut closed = true;
            let mut edges = 0i64;
            for &(b, c) in around.0 {
                let back = fan(b as usize).find(a as u32).0;
                closed &= b != a as u32 && c != a as u32 && b != c;
                closed &= around.find(b).0 == 1 && back > 0;
                edges += (a < b as usize || back == 0) as i64;
            }
            // Follow b → c from the first link; a single cycle visits all.
            let cycle = match around.0.first() {
                None => true,
                Some(&(first, c)) => {
                    let (mut at, mut steps) = (c, 1);
                    while at != first && steps <= around.0.len() {
                        match around.find(at).1 {
                            Some(c) => at = c,
                            None => break,
                        }
                        steps += 1;
                    }
                    at == first && steps == around.0.len()
                }
            };
            (closed, cycle, edges)
        })
        .reduce(
            || (true, true, 0),
            |x, y| (x.0 && y.0, x.1 && y.1, x.2 + y.2),
        );
    let euler = vertices as i64 - edges + triangles.len() as i64;
    (closed, cycles, euler)
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
    use proptest::prelude::*;

    /// The topology by one global sort of directed edges and binary
    /// searches in it: slower, and written apart from the fans above.
    fn reference(vertices: usize, triangles: &[[u32; 3]]) -> Topology {
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

    /// A triangle soup on `n` vertices: some triangles of a closed mesh
    /// (so most edges pair up), some flipped, some repeated, some random.
    fn soup() -> impl Strategy<Value = (usize, Vec<[u32; 3]>)> {
        (4usize..40).prop_flat_map(|n| {
            let t = (0..n as u32, 0..n as u32, 0..n as u32).prop_map(|(a, b, c)| [a, b, c]);
            (Just(n), prop::collection::vec(t, 0..60))
        })
    }

    proptest! {
        #[test]
        fn fans_agree_with_one_global_sort((n, triangles) in soup(), closed in 0usize..3) {
            // Mix in closed pieces: tetrahedra, some twice, so closed and
            // manifold both hold and fail.
            let mut all = triangles;
            for k in 0..closed {
                let base = (4 * k) as u32 % (n as u32 - 3);
                all.extend(TETRAHEDRON.iter().map(|t| t.map(|v| v + base)));
            }
            prop_assert_eq!(topology(n, &all), reference(n, &all));
            if closed > 0 {
                let closed_only: Vec<[u32; 3]> = all[all.len() - 4 * closed..].to_vec();
                prop_assert_eq!(topology(n, &closed_only), reference(n, &closed_only));
            }
        }
    }

    /// Fans longer than a scan's: a double cone of 40 triangles around an
    /// axis, closed and manifold, then with a triangle flipped.
    #[test]
    fn long_fans_are_searched_sorted() {
        let rim = 20u32;
        let (top, bottom) = (rim, rim + 1);
        let mut cone: Vec<[u32; 3]> = (0..rim)
            .flat_map(|i| {
                let j = (i + 1) % rim;
                [[top, i, j], [bottom, j, i]]
            })
            .collect();
        let n = rim as usize + 2;
        let t = topology(n, &cone);
        assert_eq!(t, reference(n, &cone));
        assert!(t.closed && t.manifold);
        assert_eq!(t.euler, 2);
        cone[7].swap(1, 2);
        assert_eq!(topology(n, &cone), reference(n, &cone));
        assert!(!topology(n, &cone).closed);
    }

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
