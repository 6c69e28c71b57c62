//! A bounding volume hierarchy over a scene's objects: a ray visits only the
//! objects whose boxes it crosses, nearest box first, and stops once every
//! box left starts beyond the nearest hit found.

use crate::ray::slab::crossing as slab_crossing;
use crate::types::Aabb;
use glam::DVec3;

/// Objects per leaf of the hierarchy: a leaf's objects are asked nearest
/// box first, skipping those whose boxes the ray misses.
const LEAF_SIZE: usize = 4;

/// A binary hierarchy of boxes, built by median splits along the widest
/// spread of box centres.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    /// Object indices, leaves owning consecutive runs.
    order: Vec<usize>,
    /// Each object's box, widened (indexed as `order` is).
    boxes: Vec<Aabb>,
}

#[derive(Debug, Clone, Copy)]
struct BvhNode {
    bounds: Aabb,
    /// Leaves: the run `order[first..first + count]`. Inner nodes: `count`
    /// is 0 and the children are `first` and `first + 1`.
    first: usize,
    count: usize,
}

impl Bvh {
    /// The hierarchy over `boxes` (object `i` has box `boxes[i]`), each
    /// widened by a millionth of its size so that rounding in the slab test
    /// never culls a ray the object's own intersector would answer.
    pub fn new(boxes: &[Aabb]) -> Bvh {
        let padded: Vec<Aabb> = boxes
            .iter()
            .map(|b| {
                let pad =
                    DVec3::splat(1e-6 * b.diagonal() + 1e-300) + 1e-12 * b.lo.abs().max(b.hi.abs());
                Aabb {
                    lo: b.lo - pad,
                    hi: b.hi + pad,
                }
            })
            .collect();
        let mut bvh = Bvh {
            nodes: Vec::new(),
            order: (0..boxes.len()).collect(),
            boxes: Vec::new(),
        };
        if boxes.is_empty() {
            return bvh;
        }
        bvh.nodes.push(BvhNode {
            bounds: padded[0],
            first: 0,
            count: boxes.len(),
        });
        // Split nodes with an explicit stack: (node, start of its run).
        let mut stack = vec![(0usize, 0usize)];
        while let Some((node, start)) = stack.pop() {
            let count = bvh.nodes[node].count;
            let run = &mut bvh.order[start..start + count];
            let bounds = run
                .iter()
                .map(|&i| padded[i])
                .reduce(|a, b| a.union(&b))
                .expect("runs are never empty");
            bvh.nodes[node].bounds = bounds;
            bvh.nodes[node].first = start;
            if count <= LEAF_SIZE {
                continue;
            }
            let (lo, hi) = run.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), &i| (lo.min(padded[i].center()), hi.max(padded[i].center())),
            );
            let spread = hi - lo;
            let axis = if spread.x >= spread.y && spread.x >= spread.z {
                0
            } else if spread.y >= spread.z {
                1
            } else {
                2
            };
            let half = count / 2;
            run.select_nth_unstable_by(half, |&a, &b| {
                padded[a].center()[axis].total_cmp(&padded[b].center()[axis])
            });
            let left = bvh.nodes.len();
            bvh.nodes[node].first = left;
            bvh.nodes[node].count = 0;
            for (first, count) in [(start, half), (start + half, count - half)] {
                bvh.nodes.push(BvhNode {
                    bounds,
                    first,
                    count,
                });
            }
            stack.push((left, start));
            stack.push((left + 1, start + half));
        }
        bvh.boxes = bvh.order.iter().map(|&i| padded[i]).collect();
        bvh
    }

    /// Visits the objects whose boxes the ray `o + t·d` crosses within
    /// `[t_min, t_max]`, nearest box first, calling `query(i, limit)` with the
    /// nearest hit so far as the limit; returns the nearest `(i, t)` found.
    /// Boxes starting beyond the nearest hit are never visited. `stack` is
    /// scratch space, kept by the caller from ray to ray.
    pub fn nearest(
        &self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
        stack: &mut Vec<(usize, f64)>,
        query: impl FnMut(usize, f64) -> Option<f64>,
    ) -> Option<(usize, f64)> {
        self.nearest_or(o, d, t_min, t_max, stack, query, |_| false)
    }

    /// [`Bvh::nearest`], except that a hit on an object `enough` accepts
    /// ends the search at once (a shadow ray blocked by an opaque object
    /// need not know whether another is nearer): the hit returned is then
    /// that one, not always the nearest.
    #[allow(clippy::too_many_arguments)]
    pub fn nearest_or(
        &self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
        stack: &mut Vec<(usize, f64)>,
        mut query: impl FnMut(usize, f64) -> Option<f64>,
        enough: impl Fn(usize) -> bool,
    ) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        let root = self.nodes.first()?;
        let inv_d = d.recip();
        let ray = (o, d, inv_d, t_min);
        // A scene of a few objects is one leaf: no stack.
        if root.count > 0 {
            return match self.query_leaf(root, ray, &mut best, t_max, &mut query, &enough) {
                Some(enough) => Some(enough),
                None => best,
            };
        }
        // The stack holds at most one pending sibling per level, and the
        // caller's keeps its capacity: no allocation per ray. The root's box
        // is not tested: its children's are, and a leaf tests its objects'.
        stack.clear();
        stack.push((0, t_min));
        while let Some((id, entry)) = stack.pop() {
            let limit = best.map_or(t_max, |b| b.1);
            if entry > limit {
                continue;
            }
            let node = self.nodes[id];
            if node.count > 0 {
                if let Some(enough) =
                    self.query_leaf(&node, ray, &mut best, t_max, &mut query, &enough)
                {
                    return Some(enough);
                }
                continue;
            }
            let children = [node.first, node.first + 1].map(|c| {
                (
                    c,
                    crossing(&self.nodes[c].bounds, o, d, inv_d, t_min, limit),
                )
            });
            // Nearest first: push the farther one first.
            let [(a, ta), (b, tb)] = children;
            let (near, far) = match (ta, tb) {
                (Some(x), Some(y)) if y < x => ((b, y), Some((a, x))),
                (Some(x), Some(y)) => ((a, x), Some((b, y))),
                (Some(x), None) => ((a, x), None),
                (None, Some(y)) => ((b, y), None),
                (None, None) => continue,
            };
            if let Some(far) = far {
                stack.push(far);
            }
            stack.push(near);
        }
        best
    }
}

impl Bvh {
    /// Queries the objects of the leaf `node` whose boxes the ray crosses,
    /// nearest box first, up to the nearest hit so far, keeping the nearest
    /// in `best` (the lower index on a tie); a hit on an object that is
    /// `enough` is returned at once.
    #[inline(always)]
    fn query_leaf(
        &self,
        node: &BvhNode,
        (o, d, inv_d, t_min): (DVec3, DVec3, DVec3, f64),
        best: &mut Option<(usize, f64)>,
        t_max: f64,
        query: &mut impl FnMut(usize, f64) -> Option<f64>,
        enough: &impl Fn(usize) -> bool,
    ) -> Option<(usize, f64)> {
        let run = node.first..node.first + node.count;
        // The crossed boxes' entries, in order (a leaf holds a few).
        let mut crossed = [(0.0f64, 0usize); LEAF_SIZE];
        let mut count = 0;
        let limit = best.map_or(t_max, |b| b.1);
        for (&i, b) in self.order[run.clone()].iter().zip(&self.boxes[run]) {
            if let Some(entry) = crossing(b, o, d, inv_d, t_min, limit) {
                let mut k = count;
                while k > 0 && crossed[k - 1].0 > entry {
                    crossed[k] = crossed[k - 1];
                    k -= 1;
                }
                crossed[k] = (entry, i);
                count += 1;
            }
        }
        for &(entry, i) in &crossed[..count] {
            let limit = best.map_or(t_max, |b| b.1);
            if entry > limit {
                break;
            }
            if let Some(t) = query(i, limit) {
                if enough(i) {
                    return Some((i, t));
                }
                if best.is_none_or(|b| t < b.1 || (t == b.1 && i < b.0)) {
                    *best = Some((i, t));
                }
            }
        }
        None
    }
}

/// Where the ray enters `b` within `[t_min, t_max]`, if it meets it there.
#[inline(always)]
fn crossing(b: &Aabb, o: DVec3, d: DVec3, inv_d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
    if !inv_d.is_finite() {
        return crossing_with_zeros(b, o, d, inv_d, t_min, t_max);
    }
    // Every 1/dᵢ finite: plain comparisons do what f64's min and max (which
    // skip NaN, at several instructions each) would; a NaN time (a NaN
    // origin) keeps the range, so the object is asked, and answers it.
    let (mut near, mut far) = (t_min, t_max);
    for axis in 0..3 {
        let (t0, t1) = (
            (b.lo[axis] - o[axis]) * inv_d[axis],
            (b.hi[axis] - o[axis]) * inv_d[axis],
        );
        let (enter, leave) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        if enter > near {
            near = enter;
        }
        if leave < far {
            far = leave;
        }
    }
    // Relative slack: the slab times are rounded.
    let slack = 1e-9 * (near.abs().max(far.abs()));
    (near <= far + slack || near.is_nan() || far.is_nan()).then_some(near)
}

/// [`crossing`] for a ray with a direction component 0 (or so small that
/// its reciprocal overflows).
#[cold]
fn crossing_with_zeros(
    b: &Aabb,
    o: DVec3,
    d: DVec3,
    inv_d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<f64> {
    let (mut near, mut far) = (t_min, t_max);
    for axis in 0..3 {
        if d[axis] == 0.0 {
            if o[axis] < b.lo[axis] || o[axis] > b.hi[axis] {
                return None;
            }
            continue;
        }
        let (t0, t1) = (
            slab_crossing(b.lo[axis] - o[axis], d[axis], inv_d[axis]),
            slab_crossing(b.hi[axis] - o[axis], d[axis], inv_d[axis]),
        );
        let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        near = near.max(t0);
        far = far.min(t1);
    }
    // Relative slack: the slab times are rounded.
    let slack = 1e-9 * (near.abs().max(far.abs()));
    (near <= far + slack && !near.is_nan() && !far.is_nan()).then_some(near)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` boxes of side 2 along the x axis, 3 apart, the first at the origin.
    fn boxes_along_x(n: usize) -> Vec<Aabb> {
        (0..n)
            .map(|k| {
                let c = DVec3::new(3.0 * k as f64, 0.0, 0.0);
                Aabb::new(c - DVec3::ONE, c + DVec3::ONE).unwrap()
            })
            .collect()
    }

    #[test]
    fn a_hit_that_is_enough_ends_the_search() {
        // Objects along the ray, every one hit at t = 10: a search that
        // accepts object 1's hit (an opaque blocker, for a shadow ray) stops
        // there; one that accepts none asks every object whose box starts
        // by then and keeps the nearest (of equal t, the first object).
        let bvh = Bvh::new(&boxes_along_x(12));
        let search = |enough: &dyn Fn(usize) -> bool| {
            let mut visited = Vec::new();
            let hit = bvh.nearest_or(
                DVec3::new(-5.0, 0.0, 0.0),
                DVec3::X,
                0.0,
                f64::INFINITY,
                &mut Vec::new(),
                |i, _| {
                    visited.push(i);
                    Some(10.0)
                },
                enough,
            );
            (hit, visited)
        };
        let (hit, visited) = search(&|i| i == 1);
        assert_eq!((hit, visited.last()), (Some((1, 10.0)), Some(&1)));
        let (hit, all) = search(&|_| false);
        assert_eq!(hit, Some((0, 10.0)));
        assert!(
            all.len() > visited.len() && all.contains(&2),
            "{all:?}, {visited:?}"
        );
    }

    #[test]
    fn the_nearest_box_is_found_and_farther_ones_skipped() {
        let bvh = Bvh::new(&boxes_along_x(9));
        let mut visited = Vec::new();
        // Each object is hit at its box's near face.
        let hit = bvh.nearest(
            DVec3::new(-5.0, 0.0, 0.0),
            DVec3::X,
            0.0,
            f64::INFINITY,
            &mut Vec::new(),
            |i, _| {
                visited.push(i);
                Some(3.0 * i as f64 - 1.0 + 5.0)
            },
        );
        assert_eq!(hit, Some((0, 4.0)));
        assert!(
            visited.len() <= LEAF_SIZE && visited.iter().all(|&i| i < LEAF_SIZE),
            "visited {visited:?}"
        );
        // A ray that misses every box visits none.
        let mut none = 0;
        let miss = bvh.nearest(
            DVec3::new(0.0, 5.0, 0.0),
            DVec3::X,
            0.0,
            f64::INFINITY,
            &mut Vec::new(),
            |_, _| {
                none += 1;
                None
            },
        );
        assert_eq!((miss, none), (None, 0));
    }

    #[test]
    fn the_hierarchy_finds_what_a_search_of_every_object_finds() {
        // Random boxes; object i is "hit" where the ray enters its box, if
        // at all: the hierarchy must give the nearest, as a full scan does.
        let mut state = 7u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [1, 2, 3, 17, 200] {
            let boxes: Vec<Aabb> = (0..n)
                .map(|_| {
                    let c = DVec3::new(next(), next(), next()) * 20.0 - DVec3::splat(10.0);
                    let h = DVec3::new(next(), next(), next()) * 1.5 + DVec3::splat(0.01);
                    Aabb::new(c - h, c + h).unwrap()
                })
                .collect();
            let bvh = Bvh::new(&boxes);
            for _ in 0..300 {
                let o = DVec3::new(next(), next(), next()) * 30.0 - DVec3::splat(15.0);
                let d = DVec3::new(next(), next(), next()) * 2.0 - DVec3::ONE;
                let hit = |i: usize, limit: f64| {
                    crossing(&boxes[i], o, d, d.recip(), 0.0, limit).filter(|&t| t <= limit)
                };
                let scan = (0..n)
                    .filter_map(|i| hit(i, f64::INFINITY).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                let found = bvh.nearest(o, d, 0.0, f64::INFINITY, &mut Vec::new(), hit);
                assert_eq!(found, scan, "{n} boxes, ray {o} {d}");
            }
        }
    }
}
