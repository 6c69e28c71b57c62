//! What a scene is once parsed and checked: objects with their boxes and
//! materials, lights, and the camera the file asks for.

use crate::formula::Formula;
use crate::lang::ast::Span;
use crate::types::Aabb;
use glam::DVec3;
use std::sync::Arc;

/// A surface's optical properties.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Diffuse colour (sRGB components in [0, 1]).
    pub color: DVec3,
    /// Diffuse weight.
    pub diffuse: f64,
    /// Specular weight.
    pub specular: f64,
    /// Blinn–Phong exponent.
    pub shininess: f64,
    /// Fraction of light mirrored.
    pub reflect: f64,
    /// Fraction of light transmitted.
    pub transparency: f64,
    /// Index of refraction.
    pub ior: f64,
    /// A second colour for a 3D checker pattern, and the size of its cells.
    pub checker: Option<(DVec3, f64)>,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            color: DVec3::new(0.85, 0.45, 0.25),
            diffuse: 0.9,
            specular: 0.35,
            shininess: 48.0,
            reflect: 0.0,
            transparency: 0.0,
            ior: 1.5,
            checker: None,
        }
    }
}

/// Where a light is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightKind {
    /// A point light at a position.
    Point(DVec3),
    /// A light infinitely far away, in a direction (towards the light).
    Directional(DVec3),
}

/// A light of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneLight {
    /// Position or direction.
    pub kind: LightKind,
    /// Colour (sRGB components in [0, 1], as written; the renderer makes it
    /// linear, as it does material colours).
    pub color: DVec3,
    /// Brightness, a factor on the colour.
    pub intensity: f64,
}

/// Where a scene file wrote its camera and each of its fields, so that a
/// camera that cannot be placed is reported there.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraSpans {
    /// The `camera` keyword.
    pub block: Option<Span>,
    /// The `eye` field's name.
    pub eye: Option<Span>,
    /// The `look_at` field's name.
    pub look_at: Option<Span>,
    /// The `up` field's name.
    pub up: Option<Span>,
}

/// The camera a scene asks for; missing parts are defaulted by the renderer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraSpec {
    /// Eye position.
    pub eye: Option<DVec3>,
    /// The point looked at.
    pub look_at: Option<DVec3>,
    /// Up direction.
    pub up: Option<DVec3>,
    /// Vertical field of view, degrees.
    pub fov: Option<f64>,
    /// Where the scene file wrote them (empty for the command line's).
    pub spans: CameraSpans,
}

/// Where an object's own coordinates sit in the scene: the scene point of
/// the object's point p is `offset + scale·p`. A uniform scale keeps normals
/// and ray parameters: the ray `o + t·d` meets the object where its own ray
/// `(o − offset)/scale + t·d/scale` meets the object's surface, at the same t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Where the object's origin is.
    pub offset: DVec3,
    /// How large its unit is (positive).
    pub scale: f64,
}

impl Placement {
    /// The object's coordinates are the scene's.
    pub const IDENTITY: Placement = Placement {
        offset: DVec3::ZERO,
        scale: 1.0,
    };

    /// A scene point in the object's coordinates.
    pub fn to_object(&self, p: DVec3) -> DVec3 {
        if *self == Placement::IDENTITY {
            p
        } else {
            (p - self.offset) / self.scale
        }
    }

    /// An object box in scene coordinates.
    pub fn to_scene(&self, b: &Aabb) -> Aabb {
        Aabb {
            lo: self.offset + self.scale * b.lo,
            hi: self.offset + self.scale * b.hi,
        }
    }
}

/// One object: a formula in its own coordinates (shared by every object of
/// the same shape), its box, where it is placed, and its material.
#[derive(Debug, Clone)]
pub struct SceneObject {
    /// The surface f = 0 (solid where f < 0), in the object's coordinates.
    pub formula: Arc<Formula>,
    /// The box holding it, in the object's coordinates.
    pub local_bounds: Aabb,
    /// Where the object's coordinates sit in the scene.
    pub placement: Placement,
    /// Where it lies in the scene.
    pub bounds: Aabb,
    /// How it looks.
    pub material: Material,
    /// The kind of block it came from: `object`, `sphere`, `plane`, `box`,
    /// `torus` or `cylinder`.
    pub kind: String,
    /// The block it came from.
    pub span: Span,
}

/// A parsed and checked scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The camera.
    pub camera: CameraSpec,
    /// The lights (a default key light if the file has none).
    pub lights: Vec<SceneLight>,
    /// The objects.
    pub objects: Vec<SceneObject>,
}
