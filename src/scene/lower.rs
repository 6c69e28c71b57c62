//! Scene syntax tree to [`Scene`]: bindings and user functions in scope,
//! each block checked against the schema and built, every mistake located.

use super::model::{CameraSpec, LightKind, Material, Scene, SceneLight, SceneObject};
use super::primitives;
use super::schema::Fields;
use crate::expr::Context;
use crate::formula::Formula;
use crate::lang::ast::{Ast, AstId, AstKind, Item, Span};
use crate::lang::functions::closest;
use crate::lang::{
    check_bindable, enclose_constant, lower_in, ErrorKind, FormulaError, NotConstant, Scope,
};
use crate::types::Aabb;
use glam::DVec3;
use rustc_hash::FxHashMap;

/// Parses and checks a scene file.
pub fn parse_scene(source: &str) -> Result<Scene, FormulaError> {
    let ast = crate::lang::parse_scene(source)?;
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

impl<'a> Lowering<'a> {
    fn run(mut self, source: &str) -> Result<Scene, FormulaError> {
        let mut camera: Option<(CameraSpec, Span)> = None;
        let mut lights = Vec::new();
        let mut objects = Vec::new();
        for &item in &self.ast.items {
            match item {
                Item::Binding(i) => {
                    let b = &self.ast.bindings[i];
                    check_bindable(&b.name, &b.name_span)?;
                    let v = lower_in(&mut self.ctx, self.ast, b.value, &self.scope)?;
                    self.scope.values.insert(b.name.as_str(), v);
                }
                Item::Function(i) => {
                    let f = &self.ast.functions[i];
                    check_bindable(&f.name, &f.name_span)?;
                    for (p, span) in &f.params {
                        check_bindable(p, span)?;
                    }
                    self.scope.functions.insert(f.name.as_str(), f);
                }
                Item::Block(i) => {
                    let block = &self.ast.blocks[i];
                    let fields = Fields::check(block)?;
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
                intensity: 1.0,
            });
        }
        Ok(Scene {
            camera: camera.map(|c| c.0).unwrap_or_default(),
            lights,
            objects,
        })
    }

    /// A constant: a formula of no variable, evaluated (enclosed) once.
    fn number(&mut self, id: AstId) -> Result<f64, FormulaError> {
        let node = lower_in(&mut self.ctx, self.ast, id, &self.scope)?;
        let span = self.ast.node(id).span.clone();
        match enclose_constant(&self.ctx, node) {
            Ok(v) => Ok(v.mid()),
            Err(NotConstant::DependsOnCoordinates) => Err(FormulaError::new(
                ErrorKind::WrongType,
                span,
                "expected a number, found a formula in x, y, z",
            )
            .with_label("this depends on the coordinates")),
            Err(NotConstant::NotFinite) => Err(FormulaError::new(
                ErrorKind::WrongType,
                span,
                "expected a finite number",
            )),
        }
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
        let &(id, _) = f.map.get(name).ok_or_else(|| f.missing(name, example))?;
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
            (None, None) => return Err(f.missing("position", "(-4, -5, 6)")),
        };
        let color = self.opt_vector(f, "color")?.unwrap_or(DVec3::ONE);
        let intensity = self.opt_number(f, "intensity")?.unwrap_or(1.0);
        Ok(SceneLight {
            kind,
            color,
            intensity,
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
                err = match closest(name, self.materials.keys().copied()) {
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

    fn object(&mut self, f: &Fields) -> Result<SceneObject, FormulaError> {
        let span = f.block.span.clone();
        let material = self.object_material(f)?;
        let (node, bounds) = match f.block.kind.as_str() {
            "object" => {
                let &(sid, _) = f
                    .map
                    .get("surface")
                    .ok_or_else(|| f.missing("surface", "x^2 + y^2 + z^2 - 1"))?;
                let node = lower_in(&mut self.ctx, self.ast, sid, &self.scope)?;
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
                    .ok_or_else(|| f.missing("center", "(0, 0, 0)"))?;
                let r = self.positive(f, "radius", "1")?;
                primitives::sphere(&mut self.ctx, c, r)
            }
            "plane" => {
                let n = self
                    .opt_vector(f, "normal")?
                    .ok_or_else(|| f.missing("normal", "(0, 0, 1)"))?;
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
                primitives::plane(&mut self.ctx, n, offset, extent)
            }
            "box" => {
                let lo = self
                    .opt_vector(f, "min")?
                    .ok_or_else(|| f.missing("min", "(-1, -1, -1)"))?;
                let hi = self
                    .opt_vector(f, "max")?
                    .ok_or_else(|| f.missing("max", "(1, 1, 1)"))?;
                if !lo.cmplt(hi).all() {
                    return Err(FormulaError::new(
                        ErrorKind::WrongType,
                        f.map["max"].1.clone(),
                        "`max` must exceed `min` on every axis",
                    ));
                }
                primitives::cuboid(&mut self.ctx, lo, hi)
            }
            "torus" => {
                let c = self.opt_vector(f, "center")?.unwrap_or(DVec3::ZERO);
                let major = self.positive(f, "major", "1")?;
                let minor = self.positive(f, "minor", "0.3")?;
                primitives::torus(&mut self.ctx, c, major, minor)
            }
            _ => {
                let c = self.opt_vector(f, "center")?.unwrap_or(DVec3::ZERO);
                let r = self.positive(f, "radius", "0.5")?;
                let height = self.positive(f, "height", "2")?;
                primitives::cylinder(&mut self.ctx, c, r, height)
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
