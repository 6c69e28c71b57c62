//! The number and geometry types every stage shares: sound intervals, boxes
//! and ray segments. Nothing here knows about formulas.

pub mod affine;
pub mod geom;
pub mod interval;
pub mod real;
pub mod rounding;

pub use affine::Affine;
pub use geom::{Aabb, Segment};
pub use interval::{DecInterval, Decoration, Interval};
