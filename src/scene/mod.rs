//! Scene files: several objects with materials, lights and a camera.
//!
//! ```text
//! # comments, `let` bindings and user functions as in formulas
//! let r = 0.8;
//! fn blob(cx, cy, cz, s) = exp(-((x-cx)^2 + (y-cy)^2 + (z-cz)^2)/s);
//!
//! camera { eye = (0, -6, 2); look_at = (0, 0, 0); fov = 35; }
//! light { position = (-4, -5, 6); intensity = 1; }
//! light { direction = (1, -1, 1); color = (0.6, 0.7, 1); intensity = 0.3; }
//! material glass { color = (0.9, 1, 0.95); transparency = 0.9; ior = 1.5; reflect = 0.05; }
//! object { surface = 0.3 - blob(-0.5, 0, 0, 0.3) - blob(0.5, 0, 0, 0.3);
//!          box = (-2, -1.5, -1.5, 2, 1.5, 1.5); material = glass; }
//! sphere { center = (0, 0, -101); radius = 100; }
//! ```
//!
//! Blocks: `camera` (eye, look_at, up, fov), `light` (position or direction;
//! color, intensity), `material NAME` (color, diffuse, specular, shininess,
//! reflect, transparency, ior, checker, tile), `object` (surface, box,
//! material), and primitives that set their own box: `sphere` (center,
//! radius), `plane` (normal, offset, extent), `box` (min, max), `torus` (center,
//! major, minor; about the z axis) and `cylinder` (center, radius, height;
//! along z). Vectors are tuples `(x, y, z)`; a box is `(x0, y0, z0, x1, y1, z1)`.

mod lower;
pub mod model;
pub mod primitives;
pub mod schema;

pub use lower::parse_scene;
pub use model::{
    CameraSpans, CameraSpec, LightKind, Material, Placement, Scene, SceneLight, SceneObject,
};

/// True when `source` looks like a scene file (it has a `{` block) rather
/// than a formula.
pub fn is_scene(source: &str) -> bool {
    crate::lang::Lexer::new(source)
        .flatten()
        .any(|(_, t, _)| t == crate::lang::Token::LBrace)
}
