//! The proof file: JSON, every float written so that it reads back exactly
//! (the shortest decimal that rounds to it), the tree in preorder.

use serde_json::Value;
use std::fmt::Write as _;

/// The format's version, written as `"lgc_proof"`.
pub const VERSION: u64 = 1;

/// The most entries a proof file may hold: about 130 MB of JSON, read into
/// about as much memory.
pub const MAX_ENTRIES: usize = 1 << 22;

/// The largest proof file read, in bytes.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// What a proof is about.
#[derive(Debug, Clone, PartialEq)]
pub enum Claim {
    /// `max |∇f| ≤ constant` over the box `[x0, y0, z0, x1, y1, z1]`.
    Lipschitz {
        /// The claimed constant as text: a number or a constant expression.
        constant: String,
        /// The box.
        region: [f64; 6],
    },
    /// `max |g′(t)| ≤ constant` on the ray `o + t·d` for t in `[t0, t1]`,
    /// where g(t) = d·∇f(o + t·d).
    GradLipschitz {
        /// The claimed constant as text.
        constant: String,
        /// `[ox, oy, oz, dx, dy, dz]`.
        ray: [f64; 6],
        /// `[t0, t1]`.
        t: [f64; 2],
    },
}

impl Claim {
    /// The claimed constant's text.
    pub fn constant(&self) -> &str {
        match self {
            Claim::Lipschitz { constant, .. } | Claim::GradLipschitz { constant, .. } => constant,
        }
    }
}

/// One entry of the tree, in preorder: a split (its two halves follow, the
/// lower one first) or a leaf.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Entry {
    /// The region split at `at` along `axis` (0, 1, 2 for x, y, z; 0 for t).
    Split {
        /// The axis.
        axis: u8,
        /// The split point, strictly inside the region.
        at: f64,
    },
    /// A leaf and the bound recorded for the quantity over it.
    Leaf(f64),
}

/// What the proof shows.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The claim holds: the tree of [`Entry`]s.
    Proved(Vec<Entry>),
    /// The claim is false: at `point` (or at `t` on the ray) the quantity is
    /// at least `at_least`, which exceeds the constant.
    Refuted {
        /// The witness point (for a ray, o + t·d).
        point: [f64; 3],
        /// For a ray, the witness's parameter.
        t: Option<f64>,
        /// A certified lower bound of the quantity at the witness.
        at_least: f64,
    },
}

/// A proof: the formula, the claim and what shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Proof {
    /// f, in lgc's formula language.
    pub formula: String,
    /// The claim.
    pub claim: Claim,
    /// The certificate.
    pub outcome: Outcome,
}

/// A proof file that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ProofFileError {
    /// Not JSON.
    #[error("not JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// JSON, but not a proof.
    #[error("{0}")]
    Shape(String),
}

/// A finite number, written to read back exactly.
fn number(out: &mut String, v: f64) {
    // Rust's shortest round-trip form; JSON has no "inf" or "NaN", and a
    // proof holds none.
    debug_assert!(v.is_finite());
    let _ = write!(out, "{v:?}");
}

fn numbers(out: &mut String, vs: &[f64]) {
    out.push('[');
    for (k, &v) in vs.iter().enumerate() {
        if k > 0 {
            out.push_str(", ");
        }
        number(out, v);
    }
    out.push(']');
}

impl Proof {
    /// The proof as JSON text: one key a line, the tree ten entries a line.
    pub fn to_json(&self) -> String {
        let text = |s: &str| serde_json::to_string(s).expect("a string serialises");
        let mut out = format!("{{\n  \"lgc_proof\": {VERSION},\n");
        let _ = writeln!(out, "  \"formula\": {},", text(&self.formula));
        out.push_str("  \"claim\": {");
        match &self.claim {
            Claim::Lipschitz { constant, region } => {
                let _ = write!(
                    out,
                    "\"quantity\": \"lipschitz\", \"constant\": {}, \"box\": ",
                    text(constant)
                );
                numbers(&mut out, region);
            }
            Claim::GradLipschitz { constant, ray, t } => {
                let _ = write!(
                    out,
                    "\"quantity\": \"grad_lipschitz\", \"constant\": {}, \"ray\": ",
                    text(constant)
                );
                numbers(&mut out, ray);
                out.push_str(", \"t\": ");
                numbers(&mut out, t);
            }
        }
        out.push_str("},\n");
        match &self.outcome {
            Outcome::Proved(entries) => {
                out.push_str("  \"verdict\": \"proved\",\n  \"tree\": [");
                for (k, e) in entries.iter().enumerate() {
                    out.push_str(if k == 0 {
                        "\n    "
                    } else if k % 10 == 0 {
                        ",\n    "
                    } else {
                        ", "
                    });
                    match *e {
                        Entry::Split { axis, at } => {
                            let _ = write!(out, "[{axis}, ");
                            number(&mut out, at);
                            out.push(']');
                        }
                        Entry::Leaf(b) => number(&mut out, b),
                    }
                }
                out.push_str("\n  ]\n}\n");
            }
            Outcome::Refuted { point, t, at_least } => {
                out.push_str("  \"verdict\": \"refuted\",\n  \"witness\": {\"point\": ");
                numbers(&mut out, point);
                if let Some(t) = t {
                    out.push_str(", \"t\": ");
                    number(&mut out, *t);
                }
                out.push_str(", \"at_least\": ");
                number(&mut out, *at_least);
                out.push_str("}\n}\n");
            }
        }
        out
    }

    /// Reads a proof file's text.
    pub fn from_json(text: &str) -> Result<Proof, ProofFileError> {
        let v: Value = serde_json::from_str(text)?;
        let shape = |m: &str| ProofFileError::Shape(m.to_string());
        let field = |obj: &Value, key: &str| -> Result<Value, ProofFileError> {
            obj.get(key)
                .cloned()
                .ok_or_else(|| shape(&format!("the proof has no \"{key}\"")))
        };
        if field(&v, "lgc_proof")?.as_u64() != Some(VERSION) {
            return Err(shape(&format!(
                "\"lgc_proof\" must be {VERSION}, the version this checker reads"
            )));
        }
        let formula = field(&v, "formula")?
            .as_str()
            .ok_or_else(|| shape("\"formula\" must be a string"))?
            .to_string();
        let claim = field(&v, "claim")?;
        let constant = field(&claim, "constant")?
            .as_str()
            .ok_or_else(|| shape("\"claim\".\"constant\" must be a string"))?
            .to_string();
        let claim = match field(&claim, "quantity")?.as_str() {
            Some("lipschitz") => Claim::Lipschitz {
                constant,
                region: finite(&field(&claim, "box")?, "\"claim\".\"box\"")?,
            },
            Some("grad_lipschitz") => Claim::GradLipschitz {
                constant,
                ray: finite(&field(&claim, "ray")?, "\"claim\".\"ray\"")?,
                t: finite(&field(&claim, "t")?, "\"claim\".\"t\"")?,
            },
            _ => {
                return Err(shape(
                    "\"claim\".\"quantity\" must be \"lipschitz\" or \"grad_lipschitz\"",
                ))
            }
        };
        let outcome = match field(&v, "verdict")?.as_str() {
            Some("proved") => {
                let tree = field(&v, "tree")?;
                let tree = tree
                    .as_array()
                    .ok_or_else(|| shape("\"tree\" must be an array"))?;
                if tree.len() > MAX_ENTRIES {
                    return Err(shape(&format!(
                        "the tree has {} entries; the checker reads at most {MAX_ENTRIES}",
                        tree.len()
                    )));
                }
                let entries = tree
                    .iter()
                    .enumerate()
                    .map(|(k, e)| entry(e).ok_or_else(|| shape(&format!("tree entry {k} is neither a finite number (a leaf) nor [axis, at] (a split)"))))
                    .collect::<Result<Vec<_>, _>>()?;
                Outcome::Proved(entries)
            }
            Some("refuted") => {
                let w = field(&v, "witness")?;
                let t = match w.get("t") {
                    None => None,
                    Some(t) => {
                        Some(finite::<1>(&Value::Array(vec![t.clone()]), "\"witness\".\"t\"")?[0])
                    }
                };
                let [at_least] = finite::<1>(
                    &Value::Array(vec![field(&w, "at_least")?]),
                    "\"witness\".\"at_least\"",
                )?;
                Outcome::Refuted {
                    point: finite(&field(&w, "point")?, "\"witness\".\"point\"")?,
                    t,
                    at_least,
                }
            }
            _ => return Err(shape("\"verdict\" must be \"proved\" or \"refuted\"")),
        };
        Ok(Proof {
            formula,
            claim,
            outcome,
        })
    }
}

/// `N` finite numbers from a JSON array.
fn finite<const N: usize>(v: &Value, what: &str) -> Result<[f64; N], ProofFileError> {
    let bad = || ProofFileError::Shape(format!("{what} must be {N} finite numbers"));
    let a = v.as_array().ok_or_else(bad)?;
    if a.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(a) {
        *o = x.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
    }
    Ok(out)
}

fn entry(e: &Value) -> Option<Entry> {
    if let Some(b) = e.as_f64() {
        return b.is_finite().then_some(Entry::Leaf(b));
    }
    match e.as_array()?.as_slice() {
        [axis, at] => {
            let axis = u8::try_from(axis.as_u64()?).ok()?;
            let at = at.as_f64().filter(|a| a.is_finite())?;
            Some(Entry::Split { axis, at })
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_float_reads_back_exactly() {
        let awkward = [
            0.1,
            1.0 / 3.0,
            5e-324,
            1.7976931348623157e308,
            -2.2250738585072014e-308,
            0.30000000000000004,
        ];
        let proof = Proof {
            formula: "x^2 + \"y\"".into(),
            claim: Claim::GradLipschitz {
                constant: "2*sqrt(3)".into(),
                ray: [0.1, 0.2, 0.3, 1.0 / 3.0, 1e-300, -7.0],
                t: [0.0, 1.0 / 7.0],
            },
            outcome: Outcome::Proved(
                awkward
                    .iter()
                    .map(|&a| Entry::Split { axis: 0, at: a })
                    .chain(awkward.iter().map(|&b| Entry::Leaf(b)))
                    .collect(),
            ),
        };
        let back = Proof::from_json(&proof.to_json()).unwrap();
        assert_eq!(back, proof);
        let refuted = Proof {
            outcome: Outcome::Refuted {
                point: [0.1, -0.2, 1.0 / 3.0],
                t: Some(0.7),
                at_least: 3.4641016151377544,
            },
            ..proof
        };
        assert_eq!(Proof::from_json(&refuted.to_json()).unwrap(), refuted);
    }

    #[test]
    fn malformed_files_say_what_is_wrong() {
        let e = Proof::from_json("{\"lgc_proof\": 1, \"formula\": \"x\"}").unwrap_err();
        assert!(e.to_string().contains("no \"claim\""), "{e}");
        let e = Proof::from_json("{\"lgc_proof\": 2}").unwrap_err();
        assert!(e.to_string().contains("version"), "{e}");
        assert!(matches!(
            Proof::from_json("{"),
            Err(ProofFileError::Json(_))
        ));
    }
}
