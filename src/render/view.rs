//! Where the camera stands: what the caller asks for, then what a scene file
//! asks for, then a three-quarter view that frames the part of the box that
//! holds the surface. The command line and the Python module both place
//! their cameras here, so the same options give the same picture.

use super::camera::{Camera, CameraError};
use super::film::RenderSettings;
use super::whitted::Prepared;
use crate::formula::Formula;
use crate::lang::ast::Span;
use crate::lang::{ErrorKind, FormulaError};
use crate::ray::octree::{BuildOptions, ViewFrame};
use crate::ray::{Intersector, Octree};
use crate::scene::{CameraSpec, Scene};
use crate::types::Aabb;
use glam::DVec3;

/// Octree depth of the default view's framing: coarse, so that `depth`
/// never moves the camera.
pub const FRAMING_DEPTH: u32 = 4;

/// The largest image side accepted, in pixels.
pub const MAX_SIDE: u32 = 16384;

/// The most rays per pixel accepted.
pub const MAX_SAMPLES: u32 = 1024;

/// The default vertical field of view, in degrees.
pub const DEFAULT_FOV: f64 = 30.0;

/// The camera: `asked`'s choices, then `file`'s (a scene file's camera, or
/// the default), then a three-quarter view that frames `frame`.
pub fn place_camera(
    frame: &Aabb,
    asked: &CameraSpec,
    file: &CameraSpec,
    s: &RenderSettings,
) -> Result<Camera, CameraError> {
    let fov = asked.fov.or(file.fov).unwrap_or(DEFAULT_FOV);
    let up = asked.up.or(file.up).unwrap_or(DVec3::Z);
    let target = asked.look_at.or(file.look_at).unwrap_or(frame.center());
    let eye = match asked.eye.or(file.eye) {
        Some(e) => e,
        None => Camera::framing(frame, fov, s.width, s.height)?.eye(),
    };
    Camera::new(eye, target, up, fov, s.width, s.height)
}

/// The intersector of `formula` in `bounds` at `depth`, and the box the
/// default view frames: the boxes a coarse octree keeps, or `bounds` where
/// it keeps none. Run it on the pool that is to do the work.
///
/// A deeper main build finds the frame on its way; otherwise (or where a
/// budget might stop either tree first) the coarse octree is built on its
/// own, beside the main one where that is known from the start.
pub fn framed_intersector(formula: &Formula, bounds: &Aabb, depth: u32) -> (Intersector, Aabb) {
    let framing = BuildOptions {
        crease_levels: 0,
        coarse_quadrics: false,
        leaf_bounds: false,
        ..BuildOptions::to_depth(FRAMING_DEPTH)
    };
    let frame_of = || Octree::build_with(formula, bounds, &framing).surface_bounds();
    let (scene, framed) = if depth > FRAMING_DEPTH {
        let options = BuildOptions {
            frame_depth: Some(FRAMING_DEPTH),
            ..BuildOptions::to_depth(depth)
        };
        let scene = Intersector::with_options(formula, bounds, &options);
        let framed = match scene.frame() {
            ViewFrame::Found(b) => Some(b),
            ViewFrame::Empty => None,
            ViewFrame::NotFound => frame_of(),
        };
        (scene, framed)
    } else {
        rayon::join(|| Intersector::new(formula, bounds, depth), frame_of)
    };
    (scene, framed.unwrap_or(*bounds))
}

/// The box a scene's default view frames: the first object's box where the
/// eye and the target are both given (the frame then sets nothing that
/// matters), else the objects' kept boxes.
pub fn scene_frame(scene: &Scene, prepared: &Prepared<'_>, asked: &CameraSpec) -> Aabb {
    let eye = asked.eye.or(scene.camera.eye);
    let target = asked.look_at.or(scene.camera.look_at);
    let first = scene.objects[0].bounds;
    if eye.is_some() && target.is_some() {
        first
    } else {
        prepared.surface_bounds().unwrap_or(first)
    }
}

/// A camera that cannot be placed, located in the scene file where the
/// file's own camera is to blame (the part `asked` did not override);
/// `None` where the caller's choices or the default view are.
pub fn blame_scene_camera(
    e: &CameraError,
    asked: &CameraSpec,
    file: &CameraSpec,
) -> Option<FormulaError> {
    let spans = &file.spans;
    let from_file = |overridden: bool, span: &Option<Span>| {
        if overridden {
            None
        } else {
            span.clone()
        }
    };
    let eye_asked = asked.eye.is_some() || asked.look_at.is_some();
    let (span, label) = match e {
        CameraError::EyeAtTarget => from_file(eye_asked, &spans.look_at)
            .or(from_file(eye_asked, &spans.eye))
            .map(|s| (s, "the eye is where it looks")),
        CameraError::UpParallel => from_file(asked.up.is_some(), &spans.up)
            .or(from_file(eye_asked, &spans.eye))
            .or(from_file(eye_asked, &spans.block))
            .map(|s| (s, "the view runs along up, (0, 0, 1) unless set: set `up` across the view, or move the eye")),
        CameraError::OutOfRange(_) => {
            from_file(eye_asked, &spans.eye).map(|s| (s, "keep coordinates within 1e150"))
        }
        _ => None,
    }?;
    Some(
        FormulaError::new(
            ErrorKind::BadCamera,
            span,
            format!("cannot place the camera: {e}"),
        )
        .with_label(label),
    )
}
