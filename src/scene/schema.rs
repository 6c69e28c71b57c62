//! The scene file's schema: which blocks exist, which fields each may have,
//! and the checks of kinds, names and repetitions, each error located.

use crate::lang::ast::{AstId, Block, Span};
use crate::lang::functions::closest;
use crate::lang::{ErrorKind, FormulaError};
use rustc_hash::FxHashMap;

/// The kinds of block a scene file may hold.
pub const KINDS: &[&str] = &[
    "camera", "light", "material", "object", "sphere", "plane", "box", "torus", "cylinder",
];

/// The fields a kind of block may have.
pub fn fields_of(kind: &str) -> &'static [&'static str] {
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

/// The fields of one block, looked up by name, each used at most once.
pub struct Fields<'a> {
    /// The block.
    pub block: &'a Block,
    /// Each field's value and the span of its name.
    pub map: FxHashMap<&'a str, (AstId, Span)>,
}

impl<'a> Fields<'a> {
    /// Checks the block's kind and field names and collects the fields.
    pub fn check(block: &'a Block) -> Result<Fields<'a>, FormulaError> {
        if !KINDS.contains(&block.kind.as_str()) {
            let mut err = FormulaError::new(
                ErrorKind::UnknownKeyword,
                block.kind_span.clone(),
                format!("unknown block `{}`", block.kind),
            );
            err = match closest(&block.kind, KINDS.iter().copied()) {
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
                err = match closest(&f.name, allowed.iter().copied()) {
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

    /// The error for a required field that is not there, with an example.
    pub fn missing(&self, name: &str, example: &str) -> FormulaError {
        let b = self.block;
        FormulaError::new(
            ErrorKind::MissingField,
            b.kind_span.clone(),
            format!("`{}` needs `{name}`", b.kind),
        )
        .with_label(format!("add `{name} = {example};`"))
    }
}
