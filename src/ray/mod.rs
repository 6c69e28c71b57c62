//! Guaranteed ray intersection: octree space pruning (Kalra–Barr §6.1) and
//! the intersector that answers each ray (§6.2).

pub mod affine;
mod awake;
pub mod bundle;
pub mod intersect;
pub mod octree;
pub mod polynomial;
mod seam;
mod taylor;
#[cfg(test)]
mod test_rng;

pub use intersect::{Answer, Intersector, RayStats, Tracer};
pub use octree::{Octree, OctreeStats};
