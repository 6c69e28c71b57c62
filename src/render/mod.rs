//! Pictures: a pinhole camera, the film's tile loop shared by every
//! integrator, the single-surface integrator, Whitted ray tracing of scenes,
//! shading and optics, where the camera stands, and image files written
//! atomically.

pub mod bvh;
pub mod camera;
pub mod film;
pub mod optics;
pub mod output;
pub mod shade;
pub mod surface;
pub mod tile_lists;
pub mod view;
pub mod whitted;

pub use camera::Camera;
pub use film::{render_rows, render_tiles, Integrator, RenderSettings, Rendering};
pub use output::{ImageStream, PendingImage};
pub use shade::Shading;
pub use surface::{render, render_into};
pub use view::{framed_intersector, place_camera, scene_frame};
pub use whitted::{
    render_scene, render_scene_into, Prepared, RayTree, DEFAULT_RAY_DEPTH, MAX_RAY_DEPTH,
    MIN_WEIGHT,
};
