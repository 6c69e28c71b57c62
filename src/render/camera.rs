//! A pinhole camera: pixel coordinates to rays.

use crate::types::Aabb;
use glam::DVec3;

/// A pinhole camera looking from `eye` towards a point.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half_fov: f64,
    width: u32,
    height: u32,
}

/// Why a camera cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// The eye is at the point it looks at.
    #[error("the eye and the look-at point coincide")]
    EyeAtTarget,
    /// The up vector is parallel to the viewing direction.
    #[error("the up vector is parallel to the viewing direction")]
    UpParallel,
    /// The field of view is not in (0, 180) degrees.
    #[error("the field of view must be at least 1e-6 and below 180 degrees, not {0:?}")]
    FieldOfView(f64),
    /// The up vector is zero.
    #[error("the up vector cannot be (0, 0, 0)")]
    UpZero,
    /// A position too far from the origin to compute with.
    #[error("the {0} is too far away to compute with: keep coordinates within 1e150")]
    OutOfRange(&'static str),
    /// The default view would put the eye too far away.
    #[error("the box is too large, or the field of view too small, to frame it: place the camera with --eye and --look-at")]
    CannotFrame,
}

/// The vertical fields of view accepted, in degrees.
const FIELD_OF_VIEW: std::ops::Range<f64> = 1e-6..180.0;

/// The largest coordinate a camera accepts: squares of differences stay finite.
const MAX_COORDINATE: f64 = 1e150;

fn in_range(v: DVec3) -> bool {
    v.is_finite() && v.abs().max_element() <= MAX_COORDINATE
}

impl Camera {
    /// A camera at `eye` looking at `look_at`, with `up` roughly upwards and a
    /// vertical field of view of `fov_degrees`, for an image of the given size.
    pub fn new(
        eye: DVec3,
        look_at: DVec3,
        up: DVec3,
        fov_degrees: f64,
        width: u32,
        height: u32,
    ) -> Result<Camera, CameraError> {
        if !FIELD_OF_VIEW.contains(&fov_degrees) {
            return Err(CameraError::FieldOfView(fov_degrees));
        }
        if !in_range(eye) {
            return Err(CameraError::OutOfRange("eye"));
        }
        if !in_range(look_at) {
            return Err(CameraError::OutOfRange("look-at point"));
        }
        if !up.is_finite() || up == DVec3::ZERO {
            return Err(CameraError::UpZero);
        }
        // Scaled first, so that tiny or huge vectors normalise.
        let up = up / up.abs().max_element();
        let forward = (look_at - eye)
            .try_normalize()
            .ok_or(CameraError::EyeAtTarget)?;
        let right = forward
            .cross(up)
            .try_normalize()
            .ok_or(CameraError::UpParallel)?;
        let up = right.cross(forward);
        Ok(Camera {
            eye,
            forward,
            right,
            up,
            tan_half_fov: (fov_degrees.to_radians() * 0.5).tan(),
            width,
            height,
        })
    }

    /// The default view of a box: a three-quarter view from above, with z up,
    /// far enough away that the box's bounding sphere fills the frame.
    pub fn framing(
        bounds: &Aabb,
        fov_degrees: f64,
        width: u32,
        height: u32,
    ) -> Result<Camera, CameraError> {
        let centre = bounds.center();
        let radius = bounds.half_diagonal().max(1e-12);
        let aspect = f64::from(width) / f64::from(height);
        let half = (fov_degrees.to_radians() * 0.5).min(1.5);
        // The sphere must fit the narrower of the two fields of view.
        let half_narrow = if aspect < 1.0 {
            (half.tan() * aspect).atan()
        } else {
            half
        };
        let distance = radius / half_narrow.sin() * 1.02;
        let direction = DVec3::new(2.0, -3.0, 1.7).normalize();
        if !FIELD_OF_VIEW.contains(&fov_degrees) {
            return Err(CameraError::FieldOfView(fov_degrees));
        }
        if !in_range(centre + distance * direction) {
            return Err(CameraError::CannotFrame);
        }
        Camera::new(
            centre + distance * direction,
            centre,
            DVec3::Z,
            fov_degrees,
            width,
            height,
        )
    }

    /// The eye position.
    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    /// Unit vectors: right, up, and forward (towards the scene).
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        (self.right, self.up, self.forward)
    }

    /// The ray through image position `(px, py)` in pixels (origin at the top
    /// left; `(0.5, 0.5)` is the centre of the first pixel). The direction is
    /// unit length.
    pub fn ray(&self, px: f64, py: f64) -> (DVec3, DVec3) {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let sx = (2.0 * px / w - 1.0) * self.tan_half_fov * (w / h);
        let sy = (1.0 - 2.0 * py / h) * self.tan_half_fov;
        let dir = (self.forward + sx * self.right + sy * self.up).normalize();
        (self.eye, dir)
    }
}
