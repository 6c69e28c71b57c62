//! Guaranteed ray intersection: octree space pruning (Kalra–Barr §6.1) and
//! the intersector that answers each ray (§6.2).
//!
//! Dependencies run one way: [`answer`], [`stats`] and [`slab`] know nothing
//! of the rest; the closed forms ([`closed`]) and the octree ([`octree`])
//! build on them; the intersector ([`intersect`]) reads the octree; bundles
//! of camera rays ([`bundle`]) drive the intersector.

pub mod answer;
mod awake;
pub mod bundle;
pub mod closed;
pub mod intersect;
pub mod octree;
mod seam;
pub mod slab;
pub mod stats;
mod taylor;
#[cfg(test)]
mod test_rng;

pub use answer::Answer;
pub use intersect::{Intersector, Tracer};
pub use octree::{Octree, OctreeStats};
pub use stats::RayStats;
