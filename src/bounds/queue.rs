//! What `verify` and `bracket` share: the queue of pieces, ordered by their
//! bound, largest first, and how a piece is witnessed and split.

use super::lipschitz::Bounder;
use crate::types::{Aabb, Segment};
use glam::DVec3;
use std::cmp::Ordering;

/// A certified lower bound of `|∇f|` at a box's centre, and the centre.
pub(super) fn box_witness(bounder: &Bounder, b: &Aabb) -> (f64, DVec3, Option<f64>) {
    (bounder.gradient_norm_at_least(b.center()), b.center(), None)
}

/// A certified lower bound of `|g′|` at a segment's middle, the point and t.
pub(super) fn segment_witness(bounder: &Bounder, s: &Segment) -> (f64, DVec3, Option<f64>) {
    let mid = 0.5 * (s.t0 + s.t1);
    (bounder.dg_at_least(s, mid), s.at(mid), Some(mid))
}

/// A segment's two halves.
pub(super) fn halves(s: &Segment) -> [Segment; 2] {
    let mid = 0.5 * (s.t0 + s.t1);
    [Segment { t1: mid, ..*s }, Segment { t0: mid, ..*s }]
}

/// A piece waiting in the queue, ordered by its bound (largest first).
pub(super) struct Queued<R> {
    pub(super) bound: f64,
    pub(super) region: R,
}

impl<R> PartialEq for Queued<R> {
    fn eq(&self, other: &Self) -> bool {
        self.bound.total_cmp(&other.bound) == Ordering::Equal
    }
}
impl<R> Eq for Queued<R> {}
impl<R> PartialOrd for Queued<R> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl<R> Ord for Queued<R> {
    fn cmp(&self, other: &Self) -> Ordering {
        self.bound.total_cmp(&other.bound)
    }
}
