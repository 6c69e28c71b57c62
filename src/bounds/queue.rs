//! The priority queue of branch and bound: pieces ordered by their bound,
//! largest first, shared by `verify` and `bracket`.

use std::cmp::Ordering;

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
