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

use crate::ast::{Ast, AstId, AstKind, Block, Item, Span};
use crate::bounds::Aabb;
use crate::context::{Context, Node};
use crate::error::{ErrorKind, FormulaError};
use crate::interval::Interval;
use crate::lower::{self, Scope};
use crate::tape::{Evaluator, Tape};
use crate::Formula;
use glam::DVec3;
use rustc_hash::FxHashMap;

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
    /// Colour (linear RGB) times intensity.
    pub color: DVec3,
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
}

/// One object: a formula, its box and its material.
#[derive(Debug, Clone)]
pub struct SceneObject {
    /// The surface f = 0 (solid where f < 0).
    pub formula: Formula,
    /// Where it lies.
    pub bounds: Aabb,
    /// How it looks.
    pub material: Material,
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

/// True when `source` looks like a scene file (it has a `{` block) rather
/// than a formula.
pub fn is_scene(source: &str) -> bool {
    crate::lexer::Lexer::new(source)
        .flatten()
        .any(|(_, t, _)| t == crate::lexer::Token::LBrace)
}

const KINDS: &[&str] = &[
    "camera", "light", "material", "object", "sphere", "plane", "box", "torus", "cylinder",
];

fn fields_of(kind: &str) -> &'static [&'static str] {
    match kind {
        "camera" => &["eye", "look_at", "up", "fov"],
        "light" => &["position", "direction", "color", "intensity"],
        "material" => &[
            "color",
            "diffuse",
            "specular",
            "shininess",
            "reflect",
            "transparency",
            "ior",
            "checker",
            "tile",
        ],
        "object" => &["surface", "box", "material"],
        "sphere" => &["center", "radius", "material"],
        "plane" => &["normal", "offset", "extent", "material"],
        "box" => &["min", "max", "material"],
        "torus" => &["center", "major", "minor", "material"],
        "cylinder" => &["center", "radius", "height", "material"],
        _ => &[],
    }
}

/// Parses and checks a scene file.
pub fn parse_scene(source: &str) -> Result<Scene, FormulaError> {
    let ast = crate::parse::parse_scene(source)?;
    Lowering {
        ast: &ast,
        ctx: Context::new(),
        scope: Scope::default(),
        materials: FxHashMap::default(),
    }
    .run(source)
}

struct Lowering<'a> {
    ast: &'a Ast,
    ctx: Context,
    scope: Scope<'a>,
    materials: FxHashMap<&'a str, Material>,
}

/// The fields of one block, looked up by name, each used at most once.
struct Fields<'a> {
    block: &'a Block,
    map: FxHashMap<&'a str, (AstId, Span)>,
}

impl<'a> Lowering<'a> {
    fn run(mut self, source: &str) -> Result<Scene, FormulaError> {
        let mut camera: Option<(CameraSpec, Span)> = None;
        let mut lights = Vec::new();
        let mut objects = Vec::new();
        for &item in &self.ast.items {
            match item {
                Item::Binding(i) => {
                    let b = &self.ast.bindings[i];
                    lower::check_bindable(&b.name, &b.name_span)?;
                    let v = lower::lower_in(&mut self.ctx, self.ast, b.value, &self.scope)?;
                    self.scope.values.insert(b.name.as_str(), v);
                }
                Item::Function(i) => {
                    let f = &self.ast.functions[i];
                    lower::check_bindable(&f.name, &f.name_span)?;
                    for (p, span) in &f.params {
                        lower::check_bindable(p, span)?;
                    }
                    self.scope.functions.insert(f.name.as_str(), f);
                }
                Item::Block(i) => {
                    let block = &self.ast.blocks[i];
                    let fields = self.fields(block)?;
                    match block.kind.as_str() {
                        "camera" => {
                            if let Some((_, first)) = &camera {
                                return Err(FormulaError::new(
                                    ErrorKind::RepeatedField,
                                    block.kind_span.clone(),
                                    "a scene has one camera",
                                )
                                .with_related(first.clone(), "the first camera")
                                .with_label("second camera"));
                            }
                            camera = Some((self.camera(&fields)?, block.kind_span.clone()));
                        }
                        "light" => lights.push(self.light(&fields)?),
                        "material" => {
                            let Some((name, _)) = &block.label else {
                                return Err(FormulaError::new(
                                    ErrorKind::MissingField,
                                    block.kind_span.clone(),
                                    "a material needs a name",
                                )
                                .with_label(
                                    "write `material NAME { … }` and use it as `material = NAME;`",
                                ));
                            };
                            let m = self.material(&fields)?;
                            self.materials.insert(name.as_str(), m);
                        }
                        _ => objects.push(self.object(&fields)?),
                    }
                }
            }
        }
        if objects.is_empty() {
            let end = source.trim_end().len();
            return Err(FormulaError::new(
                ErrorKind::EmptyScene,
                end..end,
                "the scene has no objects",
            )
            .with_label(
                "expected an object, such as `sphere { center = (0, 0, 0); radius = 1; }`",
            ));
        }
        if lights.is_empty() {
            lights.push(SceneLight {
                kind: LightKind::Directional(DVec3::new(-0.4, -0.6, 0.7).normalize()),
                color: DVec3::ONE,
            });
        }
        Ok(Scene {
            camera: camera.map(|c| c.0).unwrap_or_default(),
            lights,
            objects,
        })
    }

    /// Checks the block's kind and field names and collects the fields.
    fn fields(&self, block: &'a Block) -> Result<Fields<'a>, FormulaError> {
        if !KINDS.contains(&block.kind.as_str()) {
            let mut err = FormulaError::new(
                ErrorKind::UnknownKeyword,
                block.kind_span.clone(),
                format!("unknown block `{}`", block.kind),
            );
            err = match crate::functions::closest(&block.kind, KINDS.iter().copied()) {
                Some(s) => err.with_label(format!("did you mean `{s}`?")),
                None => err.with_label(format!("expected one of {}", KINDS.join(", "))),
            };
            return Err(err);
        }
        if block.kind != "material" {
            if let Some((_, span)) = &block.label {
                return Err(FormulaError::new(
                    ErrorKind::UnexpectedToken,
                    span.clone(),
                    format!("a `{}` block takes no name", block.kind),
                )
                .with_label("only materials are named"));
            }
        }
        let allowed = fields_of(&block.kind);
        let mut map: FxHashMap<&str, (AstId, Span)> = FxHashMap::default();
        for f in &block.fields {
            if !allowed.contains(&f.name.as_str()) {
                let mut err = FormulaError::new(
                    ErrorKind::UnknownKeyword,
                    f.name_span.clone(),
                    format!("`{}` has no field `{}`", block.kind, f.name),
                );
                err = match crate::functions::closest(&f.name, allowed.iter().copied()) {
                    Some(s) => err.with_label(format!("did you mean `{s}`?")),
                    None => err.with_label(format!("its fields are {}", allowed.join(", "))),
                };
                return Err(err);
            }
            if let Some((_, first)) = map.get(f.name.as_str()) {
                return Err(FormulaError::new(
                    ErrorKind::RepeatedField,
                    f.name_span.clone(),
                    format!("`{}` is given twice", f.name),
                )
                .with_related(first.clone(), "first given here")
                .with_label("repeated"));
            }
            map.insert(f.name.as_str(), (f.value, f.name_span.clone()));
        }
        Ok(Fields { block, map })
    }

    fn missing(fields: &Fields, name: &str, example: &str) -> FormulaError {
        let b = fields.block;
        FormulaError::new(
            ErrorKind::MissingField,
            b.kind_span.clone(),
            format!("`{}` needs `{name}`", b.kind),
        )
        .with_label(format!("add `{name} = {example};`"))
    }

    /// A constant: a formula of no variable, evaluated (enclosed) once.
    fn number(&mut self, id: AstId) -> Result<f64, FormulaError> {
        let node = lower::lower_in(&mut self.ctx, self.ast, id, &self.scope)?;
        if !self.ctx.vars_used(node).is_empty() {
            return Err(FormulaError::new(
                ErrorKind::WrongType,
                self.ast.node(id).span.clone(),
                "expected a number, found a formula in x, y, z",
            )
            .with_label("this depends on the coordinates"));
        }
        let tape = Tape::new(&self.ctx, &[node]);
        let v = Evaluator::<Interval>::new(&tape).eval(&[Interval::point(0.0); 6])[0];
        let m = v.mid();
        if !v.is_bounded() || !m.is_finite() {
            return Err(FormulaError::new(
                ErrorKind::WrongType,
                self.ast.node(id).span.clone(),
                "expected a finite number",
            ));
        }
        Ok(m)
    }

    fn tuple(&mut self, id: AstId, n: usize) -> Result<Vec<f64>, FormulaError> {
        let node = self.ast.node(id);
        match &node.kind {
            AstKind::Tuple(items) if items.len() == n => {
                items.iter().map(|&c| self.number(c)).collect()
            }
            AstKind::Tuple(items) => Err(FormulaError::new(
                ErrorKind::WrongType,
                node.span.clone(),
                format!("expected {n} numbers, found {}", items.len()),
            )),
            _ => Err(FormulaError::new(
                ErrorKind::WrongType,
                node.span.clone(),
                format!("expected a tuple of {n} numbers"),
            )
            .with_label(if n == 3 {
                "write it as (x, y, z)"
            } else {
                "write it as (x0, y0, z0, x1, y1, z1)"
            })),
        }
    }

    fn vector(&mut self, id: AstId) -> Result<DVec3, FormulaError> {
        let v = self.tuple(id, 3)?;
        Ok(DVec3::new(v[0], v[1], v[2]))
    }

    fn opt_vector(&mut self, f: &Fields, name: &str) -> Result<Option<DVec3>, FormulaError> {
        f.map.get(name).map(|&(id, _)| self.vector(id)).transpose()
    }

    fn opt_number(&mut self, f: &Fields, name: &str) -> Result<Option<f64>, FormulaError> {
        f.map.get(name).map(|&(id, _)| self.number(id)).transpose()
    }

    fn positive(&mut self, f: &Fields, name: &str, example: &str) -> Result<f64, FormulaError> {
        let &(id, _) = f
            .map
            .get(name)
            .ok_or_else(|| Self::missing(f, name, example))?;
        let v = self.number(id)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(FormulaError::new(
                ErrorKind::WrongType,
                self.ast.node(id).span.clone(),
                format!("`{name}` must be positive, not {v}"),
            ))
        }
    }

    fn camera(&mut self, f: &Fields) -> Result<CameraSpec, FormulaError> {
        Ok(CameraSpec {
            eye: self.opt_vector(f, "eye")?,
            look_at: self.opt_vector(f, "look_at")?,
            up: self.opt_vector(f, "up")?,
            fov: self.opt_number(f, "fov")?,
        })
    }

    fn light(&mut self, f: &Fields) -> Result<SceneLight, FormulaError> {
        let kind = match (
            self.opt_vector(f, "position")?,
            self.opt_vector(f, "direction")?,
        ) {
            (Some(p), None) => LightKind::Point(p),
            (None, Some(d)) => LightKind::Directional(d.try_normalize().ok_or_else(|| {
                FormulaError::new(
                    ErrorKind::WrongType,
                    f.map["direction"].1.clone(),
                    "a light direction cannot be (0, 0, 0)",
                )
            })?),
            (Some(_), Some(_)) => {
                return Err(FormulaError::new(
                    ErrorKind::RepeatedField,
                    f.map["direction"].1.clone(),
                    "a light has a position or a direction, not both",
                )
                .with_related(f.map["position"].1.clone(), "position given here"))
            }
            (None, None) => return Err(Self::missing(f, "position", "(-4, -5, 6)")),
        };
        let color = self.opt_vector(f, "color")?.unwrap_or(DVec3::ONE);
        let intensity = self.opt_number(f, "intensity")?.unwrap_or(1.0);
        Ok(SceneLight {
            kind,
            color: DVec3::from(color.to_array().map(crate::shade::srgb_to_linear)) * intensity,
        })
    }

    fn material(&mut self, f: &Fields) -> Result<Material, FormulaError> {
        let d = Material::default();
        let checker = match self.opt_vector(f, "checker")? {
            Some(c) => Some((c, self.opt_number(f, "tile")?.unwrap_or(1.0))),
            None => None,
        };
        Ok(Material {
            color: self.opt_vector(f, "color")?.unwrap_or(d.color),
            diffuse: self.opt_number(f, "diffuse")?.unwrap_or(d.diffuse),
            specular: self.opt_number(f, "specular")?.unwrap_or(d.specular),
            shininess: self.opt_number(f, "shininess")?.unwrap_or(d.shininess),
            reflect: self.opt_number(f, "reflect")?.unwrap_or(d.reflect),
            transparency: self
                .opt_number(f, "transparency")?
                .unwrap_or(d.transparency),
            ior: self.opt_number(f, "ior")?.unwrap_or(d.ior),
            checker,
        })
    }

    fn object_material(&mut self, f: &Fields) -> Result<Material, FormulaError> {
        let Some(&(id, _)) = f.map.get("material") else {
            return Ok(Material::default());
        };
        let node = self.ast.node(id);
        match &node.kind {
            AstKind::Name(name) => self.materials.get(name.as_str()).cloned().ok_or_else(|| {
                let mut err = FormulaError::new(
                    ErrorKind::UnknownName,
                    node.span.clone(),
                    format!("unknown material `{name}`"),
                );
                err = match crate::functions::closest(name, self.materials.keys().copied()) {
                    Some(s) => err.with_label(format!("did you mean `{s}`?")),
                    None => err.with_label("define it above with `material NAME { … }`"),
                };
                err
            }),
            _ => Err(FormulaError::new(
                ErrorKind::WrongType,
                node.span.clone(),
                "expected the name of a material",
            )),
        }
    }

    /// Parses formula text built by a primitive, in the current scope.
    fn formula(&mut self, text: &str) -> Node {
        let ast = crate::parse(text).expect("primitive formulas are well formed");
        lower::lower(&mut self.ctx, &ast).expect("primitive formulas lower")
    }

    fn object(&mut self, f: &Fields) -> Result<SceneObject, FormulaError> {
        let span = f.block.span.clone();
        let material = self.object_material(f)?;
        let num = |v: f64| format!("({v:?})");
        let (node, bounds) = match f.block.kind.as_str() {
            "object" => {
                let &(sid, _) = f
                    .map
                    .get("surface")
                    .ok_or_else(|| Self::missing(f, "surface", "x^2 + y^2 + z^2 - 1"))?;
                let node = lower::lower_in(&mut self.ctx, self.ast, sid, &self.scope)?;
                let Some(&(bid, _)) = f.map.get("box") else {
                    return Err(FormulaError::new(
                        ErrorKind::MissingBox,
                        f.block.kind_span.clone(),
                        "an object needs a box",
                    )
                    .with_label("add `box = (x0, y0, z0, x1, y1, z1);` around its surface"));
                };
                let b = self.tuple(bid, 6)?;
                let bounds = Aabb::new(DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]))
                    .filter(|a| a.lo.cmplt(a.hi).all())
                    .ok_or_else(|| {
                        FormulaError::new(
                            ErrorKind::WrongType,
                            self.ast.node(bid).span.clone(),
                            "the box is inverted or flat",
                        )
                        .with_label("each of x0, y0, z0 must be below x1, y1, z1")
                    })?;
                (node, bounds)
            }
            "sphere" => {
                let c = self
                    .opt_vector(f, "center")?
                    .ok_or_else(|| Self::missing(f, "center", "(0, 0, 0)"))?;
                let r = self.positive(f, "radius", "1")?;
                let node = self.formula(&format!(
                    "(x-{})^2 + (y-{})^2 + (z-{})^2 - {}^2",
                    num(c.x),
                    num(c.y),
                    num(c.z),
                    num(r)
                ));
                let h = DVec3::splat(r * 1.01 + 1e-9);
                (
                    node,
                    Aabb {
                        lo: c - h,
                        hi: c + h,
                    },
                )
            }
            "plane" => {
                let n = self
                    .opt_vector(f, "normal")?
                    .ok_or_else(|| Self::missing(f, "normal", "(0, 0, 1)"))?;
                let n = n.try_normalize().ok_or_else(|| {
                    FormulaError::new(
                        ErrorKind::WrongType,
                        f.map["normal"].1.clone(),
                        "a plane's normal cannot be (0, 0, 0)",
                    )
                })?;
                let offset = self.opt_number(f, "offset")?.unwrap_or(0.0);
                let extent = match f.map.contains_key("extent") {
                    true => self.positive(f, "extent", "10")?,
                    false => 10.0,
                };
                let node = self.formula(&format!(
                    "{}*x + {}*y + {}*z - {}",
                    num(n.x),
                    num(n.y),
                    num(n.z),
                    num(offset)
                ));
                let c = n * offset;
                // A slab around the plane: thin along the normal's axes only.
                let h = DVec3::new(
                    if n.x.abs() > 0.999_999 {
                        0.01 * extent
                    } else {
                        extent
                    },
                    if n.y.abs() > 0.999_999 {
                        0.01 * extent
                    } else {
                        extent
                    },
                    if n.z.abs() > 0.999_999 {
                        0.01 * extent
                    } else {
                        extent
                    },
                );
                (
                    node,
                    Aabb {
                        lo: c - h,
                        hi: c + h,
                    },
                )
            }
            "box" => {
                let lo = self
                    .opt_vector(f, "min")?
                    .ok_or_else(|| Self::missing(f, "min", "(-1, -1, -1)"))?;
                let hi = self
                    .opt_vector(f, "max")?
                    .ok_or_else(|| Self::missing(f, "max", "(1, 1, 1)"))?;
                if !lo.cmplt(hi).all() {
                    return Err(FormulaError::new(
                        ErrorKind::WrongType,
                        f.map["max"].1.clone(),
                        "`max` must exceed `min` on every axis",
                    ));
                }
                let c = 0.5 * (lo + hi);
                let h = 0.5 * (hi - lo);
                let node = self.formula(&format!(
                    "max(abs(x-{})-{}, abs(y-{})-{}, abs(z-{})-{})",
                    num(c.x),
                    num(h.x),
                    num(c.y),
                    num(h.y),
                    num(c.z),
                    num(h.z)
                ));
                let m = h * 1.01 + DVec3::splat(1e-9);
                (
                    node,
                    Aabb {
                        lo: c - m,
                        hi: c + m,
                    },
                )
            }
            "torus" => {
                let c = self.opt_vector(f, "center")?.unwrap_or(DVec3::ZERO);
                let big = self.positive(f, "major", "1")?;
                let small = self.positive(f, "minor", "0.3")?;
                let node = self.formula(&format!(
                    "let u = x-{cx}; let v = y-{cy}; let w = z-{cz}; (u^2 + v^2 + w^2 + {R}^2 - {r}^2)^2 - 4*{R}^2*(u^2 + v^2)",
                    cx = num(c.x), cy = num(c.y), cz = num(c.z), R = num(big), r = num(small)
                ));
                let h = DVec3::new(big + small, big + small, small) * 1.01 + DVec3::splat(1e-9);
                (
                    node,
                    Aabb {
                        lo: c - h,
                        hi: c + h,
                    },
                )
            }
            _ => {
                // cylinder along z
                let c = self.opt_vector(f, "center")?.unwrap_or(DVec3::ZERO);
                let r = self.positive(f, "radius", "0.5")?;
                let height = self.positive(f, "height", "2")?;
                let node = self.formula(&format!(
                    "max((x-{})^2 + (y-{})^2 - {}^2, abs(z-{}) - {})",
                    num(c.x),
                    num(c.y),
                    num(r),
                    num(c.z),
                    num(height / 2.0)
                ));
                let h = DVec3::new(r, r, height / 2.0) * 1.01 + DVec3::splat(1e-9);
                (
                    node,
                    Aabb {
                        lo: c - h,
                        hi: c + h,
                    },
                )
            }
        };
        // Cameras, octrees and tolerances all measure the box's diagonal.
        if !(bounds.hi - bounds.lo).length().is_finite() {
            return Err(FormulaError::new(
                ErrorKind::WrongType,
                f.block.kind_span.clone(),
                "this object is too large: its box overflows",
            )
            .with_label("keep coordinates and sizes well below 1e300"));
        }
        if self.ctx.vars_used(node).iter().any(|v| v.index() >= 3) {
            return Err(FormulaError::new(
                ErrorKind::DirectionInSurface,
                span,
                "a surface depends on x, y and z only",
            ));
        }
        // Each object gets its own graph, so its derivatives stay small.
        let formula = Formula::from_node(self.ctx.clone(), node);
        Ok(SceneObject {
            formula,
            bounds,
            material,
            span,
        })
    }
}
