//! Scene syntax tree to [`Scene`]: bindings and user functions in scope,
//! each block checked against the schema and built, every mistake located.

use super::model::{
    CameraSpans, CameraSpec, LightKind, Material, Placement, Scene, SceneLight, SceneObject,
};
use super::primitives;
use super::schema::Fields;
use crate::expr::{Context, GraphTooLarge, Node, MAX_NODES};
use crate::formula::Formula;
use crate::lang::ast::{Ast, AstId, AstKind, Item, Span};
use crate::lang::functions::closest;
use crate::lang::{
    check_bindable, enclose_constant, lower_in, ErrorKind, FormulaError, NotConstant, Scope,
};
use crate::types::Aabb;
use glam::DVec3;
use rustc_hash::FxHashMap;
use std::sync::Arc;

/// Parses and checks a scene file.
pub fn parse_scene(source: &str) -> Result<Scene, FormulaError> {
    let ast = crate::lang::parse_scene(source)?;
    Lowering {
        ast: &ast,
        ctx: Context::new(),
        scope: Scope::default(),
        materials: FxHashMap::default(),
        shapes: FxHashMap::default(),
        surfaces: FxHashMap::default(),
        nodes_left: MAX_NODES,
    }
    .run(source)
}

/// A canonical shape's kind and the bits of its parameters.
type ShapeKey = (&'static str, [u64; 3]);

struct Lowering<'a> {
    ast: &'a Ast,
    ctx: Context,
    scope: Scope<'a>,
    materials: FxHashMap<&'a str, Material>,
    /// Compiled canonical shapes, by kind and parameters.
    shapes: FxHashMap<ShapeKey, (Arc<Formula>, Aabb)>,
    /// Compiled object surfaces, by their node in `ctx`: objects with one
    /// surface share its formula.
    surfaces: FxHashMap<Node, Arc<Formula>>,
    /// Nodes the objects' formulas may still take, together: a scene of many
    /// objects is bounded as one formula is (see [`MAX_NODES`]).
    nodes_left: usize,
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
        let lazy = lower_in(&mut self.ctx, self.ast, id, &self.scope)?;
        let node = self.ctx.expand(lazy);
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
        self.checked(id, name, |v| v > 0.0, "positive")
    }

    /// The constant at `id`, which must satisfy `ok` (`what` says how in words).
    fn checked(
        &mut self,
        id: AstId,
        name: &str,
        ok: impl Fn(f64) -> bool,
        what: &str,
    ) -> Result<f64, FormulaError> {
        let v = self.number(id)?;
        if ok(v) {
            Ok(v)
        } else {
            Err(FormulaError::new(
                ErrorKind::OutOfRange,
                self.ast.node(id).span.clone(),
                format!("`{name}` must be {what}, not {v}"),
            ))
        }
    }

    fn camera(&mut self, f: &Fields) -> Result<CameraSpec, FormulaError> {
        let span = |name: &str| f.map.get(name).map(|(_, s)| s.clone());
        let bad = |name: &str, message: &str| {
            FormulaError::new(
                ErrorKind::BadCamera,
                span(name).unwrap_or_default(),
                message,
            )
        };
        let spec = CameraSpec {
            eye: self.opt_vector(f, "eye")?,
            look_at: self.opt_vector(f, "look_at")?,
            up: self.opt_vector(f, "up")?,
            fov: self.opt_number(f, "fov")?,
            spans: CameraSpans {
                block: Some(f.block.kind_span.clone()),
                eye: span("eye"),
                look_at: span("look_at"),
                up: span("up"),
            },
        };
        if let Some(fov) = spec.fov {
            if !(1e-6..180.0).contains(&fov) {
                return Err(bad("fov", &format!("the field of view must be at least 1e-6 and below 180 degrees, not {fov:?}"))
                    .with_label("a vertical angle in degrees, such as 30"));
            }
        }
        for (name, v) in [("eye", spec.eye), ("look_at", spec.look_at)] {
            if v.is_some_and(|v| v.abs().max_element() > 1e150) {
                return Err(bad(name, "too far away to compute with")
                    .with_label("keep coordinates within 1e150"));
            }
        }
        if spec.up == Some(DVec3::ZERO) {
            return Err(bad("up", "the up vector cannot be (0, 0, 0)"));
        }
        if let (Some(e), Some(l)) = (spec.eye, spec.look_at) {
            if e == l {
                return Err(bad("look_at", "the camera looks at its own eye")
                    .with_related(span("eye").unwrap_or_default(), "the eye is here")
                    .with_label("move the eye or the look-at point"));
            }
            if let Some(up) = spec.up {
                if (l - e).cross(up).length() == 0.0 {
                    return Err(
                        bad("up", "the up vector is parallel to the viewing direction")
                            .with_label("choose an up direction across the view"),
                    );
                }
            }
        }
        Ok(spec)
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
        let color = self.color(f, "color", DVec3::ONE)?;
        let intensity = self.ranged(f, "intensity", 1.0, |v| v >= 0.0, "at least 0")?;
        Ok(SceneLight {
            kind,
            color,
            intensity,
        })
    }

    /// A number field that must lie in `range` (`what` says the range in
    /// words), or its default.
    fn ranged(
        &mut self,
        f: &Fields,
        name: &str,
        default: f64,
        ok: impl Fn(f64) -> bool,
        what: &str,
    ) -> Result<f64, FormulaError> {
        match f.map.get(name) {
            Some(&(id, _)) => self.checked(id, name, ok, what),
            None => Ok(default),
        }
    }

    /// A colour field: three components from 0 to 1, or its default.
    fn color(&mut self, f: &Fields, name: &str, default: DVec3) -> Result<DVec3, FormulaError> {
        let Some(&(id, _)) = f.map.get(name) else {
            return Ok(default);
        };
        let c = self.vector(id)?;
        if c.cmpge(DVec3::ZERO).all() && c.cmple(DVec3::ONE).all() {
            Ok(c)
        } else {
            Err(FormulaError::new(
                ErrorKind::OutOfRange,
                self.ast.node(id).span.clone(),
                format!("`{name}` components must be between 0 and 1"),
            )
            .with_label("an sRGB colour, such as (0.9, 0.4, 0.2)"))
        }
    }

    fn material(&mut self, f: &Fields) -> Result<Material, FormulaError> {
        let d = Material::default();
        let unit = |v: f64| (0.0..=1.0).contains(&v);
        let non_negative = |v: f64| v >= 0.0;
        let positive = |v: f64| v > 0.0;
        let checker = match f.map.contains_key("checker") {
            true => Some((
                self.color(f, "checker", DVec3::ZERO)?,
                self.ranged(f, "tile", 1.0, positive, "positive")?,
            )),
            false => None,
        };
        let material = Material {
            color: self.color(f, "color", d.color)?,
            diffuse: self.ranged(f, "diffuse", d.diffuse, non_negative, "at least 0")?,
            specular: self.ranged(f, "specular", d.specular, non_negative, "at least 0")?,
            shininess: self.ranged(f, "shininess", d.shininess, non_negative, "at least 0")?,
            reflect: self.ranged(f, "reflect", d.reflect, unit, "between 0 and 1")?,
            transparency: self.ranged(
                f,
                "transparency",
                d.transparency,
                unit,
                "between 0 and 1",
            )?,
            ior: self.ranged(f, "ior", d.ior, positive, "positive")?,
            checker,
        };
        if material.reflect + material.transparency > 1.0 {
            let span = f.map["transparency"].1.clone();
            return Err(FormulaError::new(
                ErrorKind::OutOfRange,
                span,
                "`reflect` and `transparency` add up to more than 1",
            )
            .with_related(f.map["reflect"].1.clone(), "reflect given here")
            .with_label("light cannot be both mirrored and passed through"));
        }
        Ok(material)
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

    /// A canonical shape, compiled once per scene and shared by every object
    /// of that shape.
    fn shape(
        &mut self,
        kind: &'static str,
        parameters: [f64; 3],
        build: impl FnOnce(&mut Context) -> primitives::Shape,
        span: &Span,
    ) -> Result<(Arc<Formula>, Aabb), FormulaError> {
        let key = (kind, parameters.map(f64::to_bits));
        if let Some(shape) = self.shapes.get(&key) {
            return Ok(shape.clone());
        }
        let mut ctx = Context::with_limit(self.nodes_left);
        let (node, local) = build(&mut ctx);
        let shape = (self.derive(ctx, node, span)?, local);
        self.shapes.insert(key, shape.clone());
        Ok(shape)
    }

    /// The formula of `node` in `ctx`, derived within what the scene's node
    /// budget has left; an error at `span` past it.
    fn derive(
        &mut self,
        ctx: Context,
        node: Node,
        span: &Span,
    ) -> Result<Arc<Formula>, FormulaError> {
        let formula = Formula::from_node(ctx, node).map_err(|_| {
            // The scene's limit, not what was left of it.
            let e = GraphTooLarge { limit: MAX_NODES };
            FormulaError::too_large(span.clone(), "the scene's objects and their derivatives", e)
        })?;
        self.nodes_left -= formula.context().len();
        Ok(Arc::new(formula))
    }

    fn object(&mut self, f: &Fields) -> Result<SceneObject, FormulaError> {
        let span = f.block.span.clone();
        let material = self.object_material(f)?;
        let (formula, local_bounds, placement) = match f.block.kind.as_str() {
            "object" => {
                let &(sid, _) = f
                    .map
                    .get("surface")
                    .ok_or_else(|| f.missing("surface", "x^2 + y^2 + z^2 - 1"))?;
                let lazy = lower_in(&mut self.ctx, self.ast, sid, &self.scope)?;
                let node = self.ctx.expand(lazy);
                self.ctx.check_size().map_err(|e| {
                    FormulaError::too_large(self.ast.node(sid).span.clone(), "the scene", e)
                })?;
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
                if self.ctx.vars_used(node).iter().any(|v| v.index() >= 3) {
                    return Err(FormulaError::new(
                        ErrorKind::DirectionInSurface,
                        span,
                        "a surface depends on x, y and z only",
                    ));
                }
                let formula = match self.surfaces.get(&node) {
                    Some(formula) => formula.clone(),
                    None => {
                        // Its own small graph, not a copy of the scene's:
                        // memory and derivatives stay proportional to the object.
                        let (ctx, local) = self.ctx.extract(node, self.nodes_left);
                        let span = &self.ast.node(sid).span;
                        let formula = self.derive(ctx, local, span)?;
                        self.surfaces.insert(node, formula.clone());
                        formula
                    }
                };
                (formula, bounds, Placement::IDENTITY)
            }
            "sphere" => {
                let c = self
                    .opt_vector(f, "center")?
                    .ok_or_else(|| f.missing("center", "(0, 0, 0)"))?;
                let r = self.positive(f, "radius", "1")?;
                let (formula, local) =
                    self.shape("sphere", [0.0; 3], primitives::sphere, &f.block.kind_span)?;
                (formula, local, primitives::sphere_placement(c, r))
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
                // In scene coordinates: a plane's slab is its own.
                let mut ctx = Context::with_limit(self.nodes_left);
                let (node, local) = primitives::plane(&mut ctx, n, offset, extent);
                let formula = self.derive(ctx, node, &f.block.kind_span)?;
                (formula, local, Placement::IDENTITY)
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
                let half = primitives::cuboid_half(lo, hi);
                let (formula, local) = self.shape(
                    "box",
                    half.to_array(),
                    |ctx| primitives::cuboid(ctx, lo, hi),
                    &f.block.kind_span,
                )?;
                (formula, local, primitives::cuboid_placement(lo, hi))
            }
            "torus" => {
                let c = self.opt_vector(f, "center")?.unwrap_or(DVec3::ZERO);
                let major = self.positive(f, "major", "1")?;
                let minor = self.positive(f, "minor", "0.3")?;
                let ratio = minor / major;
                let (formula, local) = self.shape(
                    "torus",
                    [ratio, 0.0, 0.0],
                    |ctx| primitives::torus(ctx, ratio),
                    &f.block.kind_span,
                )?;
                (formula, local, primitives::sphere_placement(c, major))
            }
            _ => {
                let c = self.opt_vector(f, "center")?.unwrap_or(DVec3::ZERO);
                let r = self.positive(f, "radius", "0.5")?;
                let height = self.positive(f, "height", "2")?;
                let half = height / (2.0 * r);
                let (formula, local) = self.shape(
                    "cylinder",
                    [half, 0.0, 0.0],
                    |ctx| primitives::cylinder(ctx, half),
                    &f.block.kind_span,
                )?;
                (formula, local, primitives::sphere_placement(c, r))
            }
        };
        let bounds = placement.to_scene(&local_bounds);
        // Cameras, octrees and tolerances all measure the box's diagonal.
        if !(bounds.hi - bounds.lo).length().is_finite() || !bounds.lo.is_finite() {
            return Err(FormulaError::new(
                ErrorKind::WrongType,
                f.block.kind_span.clone(),
                "this object is too large: its box overflows",
            )
            .with_label("keep coordinates and sizes well below 1e300"));
        }
        Ok(SceneObject {
            formula,
            local_bounds,
            placement,
            bounds,
            material,
            kind: f.block.kind.clone(),
            span,
        })
    }
}
