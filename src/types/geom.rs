//! Boxes and ray segments: the regions bounds are taken over and rays are
//! clipped to.

use super::interval::Interval;
use super::rounding::binade;
use glam::DVec3;

/// The Euclidean length of `v`, computed at a scale where its squares
/// neither overflow nor underflow (glam's `length` is ∞ from components of
/// 1e155 up). Rounded to nearest, as `length` is: callers that need a bound
/// raise it.
pub fn norm(v: DVec3) -> f64 {
    let m = v.abs().max_element();
    if m > 1e-150 && m < 1e150 || m == 0.0 || !m.is_finite() {
        return v.length();
    }
    let s = binade(m);
    (v / s).length() * s
}

/// An axis-aligned box `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub lo: DVec3,
    /// The corner with the largest coordinates.
    pub hi: DVec3,
}

impl Aabb {
    /// The box between two corners; `None` unless `lo ≤ hi` on every axis and
    /// both are finite.
    pub fn new(lo: DVec3, hi: DVec3) -> Option<Aabb> {
        (lo.is_finite() && hi.is_finite() && lo.cmple(hi).all()).then_some(Aabb { lo, hi })
    }

    /// The centre.
    pub fn center(&self) -> DVec3 {
        0.5 * (self.lo + self.hi)
    }

    /// Half the length of the main diagonal (the `d` of Kalra–Barr pruning).
    pub fn half_diagonal(&self) -> f64 {
        norm(0.5 * self.hi - 0.5 * self.lo)
    }

    /// The length of the main diagonal, finite for every finite box.
    pub fn diagonal(&self) -> f64 {
        2.0 * self.half_diagonal()
    }

    /// The three coordinate intervals.
    pub fn intervals(&self) -> [Interval; 3] {
        [0, 1, 2].map(|i| Interval::new(self.lo[i], self.hi[i]))
    }

    /// Whether the (closed) box holds the point `p`.
    pub fn contains(&self, p: DVec3) -> bool {
        self.lo.cmple(p).all() && p.cmple(self.hi).all()
    }

    /// Whether the (closed) box meets the box `region` (both may touch at a
    /// face, edge or corner).
    pub fn meets(&self, region: &[Interval; 3]) -> bool {
        (0..3).all(|i| region[i].inf() <= self.hi[i] && self.lo[i] <= region[i].sup())
    }

    /// The eight halves-by-axis of the box.
    pub fn octants(&self) -> [Aabb; 8] {
        let c = self.center();
        std::array::from_fn(|k| {
            let pick = |axis: usize, lo: f64, hi: f64| {
                if k >> axis & 1 == 0 {
                    (lo, c[axis])
                } else {
                    (c[axis], hi)
                }
            };
            let (x0, x1) = pick(0, self.lo.x, self.hi.x);
            let (y0, y1) = pick(1, self.lo.y, self.hi.y);
            let (z0, z1) = pick(2, self.lo.z, self.hi.z);
            Aabb {
                lo: DVec3::new(x0, y0, z0),
                hi: DVec3::new(x1, y1, z1),
            }
        })
    }

    /// The two halves of the box across its longest edge.
    pub fn bisect(&self) -> [Aabb; 2] {
        let size = self.hi - self.lo;
        let axis = if size.x >= size.y && size.x >= size.z {
            0
        } else if size.y >= size.z {
            1
        } else {
            2
        };
        self.bisect_along(axis)
    }

    /// The two halves of the box across `axis` (0, 1, 2 for x, y, z).
    pub fn bisect_along(&self, axis: usize) -> [Aabb; 2] {
        let mid = 0.5 * (self.lo[axis] + self.hi[axis]);
        let mut left = *self;
        let mut right = *self;
        left.hi[axis] = mid;
        right.lo[axis] = mid;
        [left, right]
    }

    /// The smallest box holding both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    /// The sub-boxes of `depth` rounds of octant splitting (`8^depth` boxes).
    pub fn split(&self, depth: u32) -> Vec<Aabb> {
        let mut boxes = vec![*self];
        for _ in 0..depth {
            boxes = boxes.iter().flat_map(|b| b.octants()).collect();
        }
        boxes
    }
}

/// A piece of a ray: `{origin + t·direction : t ∈ [t0, t1]}`; the direction is
/// used as given, not normalised, so G is per unit of t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// The ray origin.
    pub origin: DVec3,
    /// The ray direction.
    pub direction: DVec3,
    /// Start parameter.
    pub t0: f64,
    /// End parameter.
    pub t1: f64,
}

impl Segment {
    /// The segment; `None` unless everything is finite and `t0 ≤ t1`.
    pub fn new(origin: DVec3, direction: DVec3, t0: f64, t1: f64) -> Option<Segment> {
        (origin.is_finite()
            && direction.is_finite()
            && t0.is_finite()
            && t1.is_finite()
            && t0 <= t1)
            .then_some(Segment {
                origin,
                direction,
                t0,
                t1,
            })
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.direction
    }

    /// Interval inputs (x, y, z, dx, dy, dz) covering every point of the segment.
    #[inline]
    pub fn inputs(&self) -> [Interval; 6] {
        #[cfg(target_arch = "x86_64")]
        if super::rounding::has_fma() {
            // SAFETY: the CPU has FMA.
            return unsafe { self.inputs_with_fma() };
        }
        self.inputs_portable()
    }

    /// [`Segment::inputs`] compiled for CPUs with FMA, so the roundings'
    /// error terms inline (the intersector encloses a piece of a ray this
    /// way for every interval test).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "fma")]
    unsafe fn inputs_with_fma(&self) -> [Interval; 6] {
        self.inputs_portable()
    }

    #[inline(always)]
    fn inputs_portable(&self) -> [Interval; 6] {
        let t = Interval::new(self.t0, self.t1);
        let (o, d) = (self.origin, self.direction);
        let [x, y, z] = [o.x, o.y, o.z].map(Interval::point);
        let [dx, dy, dz] = [d.x, d.y, d.z].map(Interval::point);
        [x + t * dx, y + t * dy, z + t * dz, dx, dy, dz]
    }

    /// The segment cut into `2^depth` equal pieces.
    pub fn split(&self, depth: u32) -> Vec<Segment> {
        let n = 1usize << depth.min(20);
        (0..n)
            .map(|k| {
                let a = self.t0 + (self.t1 - self.t0) * k as f64 / n as f64;
                let b = if k + 1 == n {
                    self.t1
                } else {
                    self.t0 + (self.t1 - self.t0) * (k + 1) as f64 / n as f64
                };
                Segment {
                    t0: a,
                    t1: b,
                    ..*self
                }
            })
            .collect()
    }
}
