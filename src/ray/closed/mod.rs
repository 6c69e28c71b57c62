//! Formulas whose rays are answered in closed form, with no octree walk:
//! planes (affine over the box) and polynomials of low degree with no
//! branch point (in Bernstein form).

pub mod affine;
pub mod polynomial;
