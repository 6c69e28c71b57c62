//! Re-checking a proof: the claim's constant enclosed, f differentiated
//! afresh, the tree walked (with an explicit stack) to see that its leaves
//! tile the region, and every leaf's bound re-derived from the natural
//! interval extension.

// Every test is written so that a NaN fails it (`!(a <= b)` rejects a NaN,
// `a > b` would let it through): a proof is accepted only on numbers.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::format::{Claim, Entry, Outcome, Proof};
use super::terms::{TermError, TermId, Terms};
use crate::types::interval::euclidean_norm;
use crate::types::Interval;

/// The quantity a claim bounds, ready to be enclosed over regions: |∇f|
/// over boxes (three derivatives by x, y, z), or |g′| = |d²f(o + t·d)/dt²|
/// over t (one).
#[derive(Debug, Clone)]
pub struct Quantity {
    terms: Terms,
    derivatives: Vec<TermId>,
}

/// A region: the box's three ranges, or t's one.
pub type Region = Vec<(f64, f64)>;

impl Quantity {
    /// The quantity of `claim` for `formula`.
    pub fn new(formula: &str, claim: &Claim) -> Result<Quantity, TermError> {
        match claim {
            Claim::Lipschitz { .. } => {
                let (mut terms, f) = Terms::read(formula, None)?;
                let derivatives = (0..3)
                    .map(|v| terms.derivative(f, v))
                    .collect::<Result<_, _>>()?;
                Ok(Quantity { terms, derivatives })
            }
            Claim::GradLipschitz { ray, .. } => {
                let o = [ray[0], ray[1], ray[2]];
                let d = [ray[3], ray[4], ray[5]];
                let (mut terms, f) = Terms::read(formula, Some((o, d)))?;
                let g = terms.derivative(f, 3)?;
                let dg = terms.derivative(g, 3)?;
                Ok(Quantity {
                    terms,
                    derivatives: vec![dg],
                })
            }
        }
    }

    /// The region the claim is about.
    pub fn region_of(claim: &Claim) -> Region {
        match claim {
            Claim::Lipschitz { region: b, .. } => vec![(b[0], b[3]), (b[1], b[4]), (b[2], b[5])],
            Claim::GradLipschitz { t, .. } => vec![(t[0], t[1])],
        }
    }

    fn derivatives_over(&self, region: &[(f64, f64)]) -> Vec<Interval> {
        let r = |k: usize| Interval::new(region[k].0, region[k].1);
        let vars = if region.len() == 3 {
            [r(0), r(1), r(2), Interval::ZERO]
        } else {
            [Interval::ZERO, Interval::ZERO, Interval::ZERO, r(0)]
        };
        let values = self.terms.eval(&vars);
        self.derivatives
            .iter()
            .map(|&d| values[d as usize])
            .collect()
    }

    /// An upper bound of the quantity over `region` from the natural
    /// interval extension: the norm of the derivatives' magnitudes, rounded
    /// up; `+∞` where a derivative is unbounded. A derivative defined
    /// nowhere in the region (empty) adds nothing.
    pub fn upper(&self, region: &[(f64, f64)]) -> f64 {
        let m: Vec<f64> = self
            .derivatives_over(region)
            .iter()
            .map(|d| if d.is_empty() { 0.0 } else { d.mag() })
            .collect();
        if m.iter().any(|v| !v.is_finite()) {
            return f64::INFINITY;
        }
        match m[..] {
            [a] => a,
            [a, b, c] => euclidean_norm([a, b, c]).sup(),
            _ => unreachable!("one or three derivatives"),
        }
    }

    /// A certified lower bound of the quantity at a point (or at t): the
    /// norm of the derivatives' mignitudes, rounded down; 0 where one is
    /// undefined.
    pub fn lower_at(&self, at: &[f64]) -> f64 {
        let region: Region = at.iter().map(|&v| (v, v)).collect();
        let d = self.derivatives_over(&region);
        if d.iter().any(|d| d.is_empty()) {
            return 0.0;
        }
        let m: Vec<f64> = d.iter().map(|d| d.mig()).collect();
        match m[..] {
            [a] => a,
            [a, b, c] => euclidean_norm([a, b, c]).inf().max(0.0),
            _ => unreachable!("one or three derivatives"),
        }
    }
}

/// What a checked proof shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Checked {
    /// Leaves checked (0 for a refutation).
    pub leaves: usize,
    /// The largest bound any leaf's natural extension gives (for a
    /// refutation, the certified value at the witness).
    pub largest: f64,
    /// The claimed constant's enclosure.
    pub constant: Interval,
    /// Whether the claim was proved (else refuted).
    pub proved: bool,
}

/// Why a proof does not check.
#[derive(Debug, thiserror::Error)]
pub enum Rejection {
    /// The formula or the constant does not read.
    #[error("the {what} does not read: {error}")]
    Unreadable {
        /// "formula" or "constant".
        what: &'static str,
        /// Why.
        error: TermError,
    },
    /// The constant depends on x, y or z, or is not finite.
    #[error("the constant `{0}` is not a finite number")]
    Constant(String),
    /// The claim's region is not a region.
    #[error("the claim's region is empty or not finite: {0:?}")]
    Region(Region),
    /// A split off its region's midpoint, or on an axis it does not have.
    #[error("tree entry {entry}: the split [{axis}, {at:?}] is not at the midpoint of its region {region:?}, strictly inside it")]
    BadSplit {
        /// The entry's index.
        entry: usize,
        /// The axis.
        axis: u8,
        /// The split point.
        at: f64,
        /// The region it splits.
        region: Region,
    },
    /// A leaf whose recorded bound its natural extension does not show.
    #[error("tree entry {entry}: the leaf {region:?} records {recorded:?}, but the natural interval extension gives {computed:?}")]
    LeafBound {
        /// The entry's index.
        entry: usize,
        /// Its region.
        region: Region,
        /// The bound recorded.
        recorded: f64,
        /// The bound the checker finds.
        computed: f64,
    },
    /// A leaf whose bound exceeds the claim.
    #[error("tree entry {entry}: the leaf's bound {recorded:?} exceeds the constant's lower end {constant:?}")]
    AboveClaim {
        /// The entry's index.
        entry: usize,
        /// The bound recorded.
        recorded: f64,
        /// The constant's enclosure's lower end.
        constant: f64,
    },
    /// The tree has entries left over, or ends before its leaves cover the
    /// region.
    #[error("the tree's leaves do not tile the region: {0}")]
    Tiling(String),
    /// A witness outside the region, or whose value is not shown.
    #[error("the witness does not refute the claim: {0}")]
    Witness(String),
}

/// Checks a proof. `Ok` says what it shows; `Err` why it does not.
pub fn check(proof: &Proof) -> Result<Checked, Rejection> {
    let constant = match Terms::constant_of(proof.claim.constant()) {
        Ok(Some(c)) if c.inf().is_finite() && c.sup().is_finite() => c,
        Ok(_) => return Err(Rejection::Constant(proof.claim.constant().to_string())),
        Err(error) => {
            return Err(Rejection::Unreadable {
                what: "constant",
                error,
            })
        }
    };
    let root = Quantity::region_of(&proof.claim);
    let ray_ok = match &proof.claim {
        Claim::GradLipschitz { ray, .. } => ray.iter().all(|v| v.is_finite()),
        Claim::Lipschitz { .. } => true,
    };
    if !ray_ok || root.iter().any(|&(lo, hi)| !(lo <= hi)) {
        return Err(Rejection::Region(root));
    }
    let quantity =
        Quantity::new(&proof.formula, &proof.claim).map_err(|error| Rejection::Unreadable {
            what: "formula",
            error,
        })?;
    match &proof.outcome {
        Outcome::Proved(entries) => walk(&quantity, root, entries, constant),
        Outcome::Refuted { point, t, at_least } => {
            let at: Vec<f64> = match (&proof.claim, t) {
                (Claim::Lipschitz { .. }, None) => point.to_vec(),
                (Claim::GradLipschitz { .. }, Some(t)) => vec![*t],
                _ => {
                    return Err(Rejection::Witness(
                        "a box's witness is a point, a ray's a point and its t".into(),
                    ))
                }
            };
            if at
                .iter()
                .zip(&root)
                .any(|(v, &(lo, hi))| !(lo <= *v && *v <= hi))
            {
                return Err(Rejection::Witness(format!(
                    "{at:?} lies outside the region {root:?}"
                )));
            }
            let value = quantity.lower_at(&at);
            if !(*at_least <= value) {
                return Err(Rejection::Witness(format!(
                    "the quantity there is certified at least {value:?}, not the recorded {at_least:?}"
                )));
            }
            if !(*at_least > constant.sup()) {
                return Err(Rejection::Witness(format!(
                    "the recorded value {at_least:?} does not exceed the constant's upper end {:?}",
                    constant.sup()
                )));
            }
            Ok(Checked {
                leaves: 0,
                largest: value,
                constant,
                proved: false,
            })
        }
    }
}

/// The point every split must be at: `lo + (hi − lo)/2` in binary64, so
/// that each checker recomputes it exactly and a moved split is caught.
pub fn midpoint((lo, hi): (f64, f64)) -> f64 {
    lo + 0.5 * (hi - lo)
}

/// Pushes the halves of `region` split along `axis` at `at`, the upper one
/// first, so that the lower one is read next (preorder).
pub fn push_halves(stack: &mut Vec<Region>, region: Region, axis: usize, at: f64) {
    let (mut low, mut high) = (region.clone(), region);
    low[axis].1 = at;
    high[axis].0 = at;
    stack.push(high);
    stack.push(low);
}

/// Walks the preorder tree over `root`.
fn walk(
    quantity: &Quantity,
    root: Region,
    entries: &[Entry],
    constant: Interval,
) -> Result<Checked, Rejection> {
    let mut stack = vec![root];
    let mut leaves = 0;
    let mut largest = 0.0f64;
    for (entry, e) in entries.iter().enumerate() {
        let Some(region) = stack.pop() else {
            return Err(Rejection::Tiling(format!(
                "the region is covered by entry {}, and {} entries are left over",
                entry.saturating_sub(1),
                entries.len() - entry
            )));
        };
        match *e {
            Entry::Split { axis, at } => {
                let k = usize::from(axis);
                let inside = k < region.len() && region[k].0 < at && at < region[k].1;
                if !inside || at != midpoint(region[k]) {
                    return Err(Rejection::BadSplit {
                        entry,
                        axis,
                        at,
                        region,
                    });
                }
                push_halves(&mut stack, region, k, at);
            }
            Entry::Leaf(recorded) => {
                let computed = quantity.upper(&region);
                if !(computed <= recorded) {
                    return Err(Rejection::LeafBound {
                        entry,
                        region,
                        recorded,
                        computed,
                    });
                }
                if !(recorded <= constant.inf()) {
                    return Err(Rejection::AboveClaim {
                        entry,
                        recorded,
                        constant: constant.inf(),
                    });
                }
                leaves += 1;
                largest = largest.max(computed);
            }
        }
    }
    if !stack.is_empty() {
        return Err(Rejection::Tiling(format!(
            "the tree ends with {} regions not covered",
            stack.len()
        )));
    }
    Ok(Checked {
        leaves,
        largest,
        constant,
        proved: true,
    })
}
