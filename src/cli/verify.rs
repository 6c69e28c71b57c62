//! `lgc verify`: prove or refute a hand-derived L or G by branch and bound.

use super::args::{fmt3, json_number, num, parse_count, Failure, Outcome, RegionArgs, SourceArgs};
use clap::Args;
use lgc::bounds::ProveError;
use lgc::file::PendingFile;
use lgc::lang::NotConstant;
use lgc::proof::terms::TermError;
use lgc::proof::Claim;
use lgc::{Aabb, Bounder, Interval, Segment, Verdict};
use std::path::PathBuf;

/// Options of `lgc verify`.
#[derive(Args, Debug)]
pub struct VerifyArgs {
    #[command(flatten)]
    source: SourceArgs,
    #[command(flatten)]
    region: RegionArgs,
    /// The claimed L: a number or a constant expression such as "2*sqrt(3)".
    #[arg(
        long,
        value_name = "C",
        allow_hyphen_values = true,
        conflicts_with = "grad_lipschitz",
        required_unless_present = "grad_lipschitz"
    )]
    lipschitz: Option<String>,
    /// The claimed G (needs --ray and --t).
    #[arg(long, value_name = "C", allow_hyphen_values = true, requires = "ray")]
    grad_lipschitz: Option<String>,
    /// Give up after examining this many pieces.
    #[arg(long, value_name = "N", default_value_t = 1_000_000, value_parser = parse_count)]
    max_boxes: u64,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Write a proof file anyone can re-check (`lgc check-proof FILE`): the
    /// proved claim's subdivision tree, each leaf bounded by the natural
    /// interval extension alone, or the refuting witness.
    #[arg(long, value_name = "FILE.json")]
    proof: Option<PathBuf>,
}

/// Proves or refutes the claim; the exit code says which (0, 3, 4).
pub fn run(args: &VerifyArgs) -> Outcome {
    let source = args.source.read()?;
    if args.proof.is_some() && source.is_vm() {
        return Err(anyhow::anyhow!(
            "--proof: a proof's formula is written in lgc's formula language, and {} is a .vm model",
            source.origin
        )
        .into());
    }
    let formula = source.formula()?;
    let bounder = Bounder::new(&formula);
    let max = usize::try_from(args.max_boxes).unwrap_or(usize::MAX);
    // Reserve the proof file first: an unwritable path fails before any work.
    let pending = args
        .proof
        .as_deref()
        .map(PendingFile::create)
        .transpose()
        .map_err(anyhow::Error::from)?;
    let (code, written) = if let Some(c) = &args.lipschitz {
        let b = args
            .region
            .aabb()?
            .ok_or_else(|| anyhow::anyhow!("verify --lipschitz needs --box X0,Y0,Z0,X1,Y1,Z1"))?;
        let claim = constant(c, "--lipschitz")?;
        let verdict = lgc::verify_lipschitz(&bounder, &b, claim, max);
        let claim = Claim::Lipschitz {
            constant: c.clone(),
            region: [b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z],
        };
        let written = pending.map(|p| {
            (
                p,
                lgc::bounds::certificate(&source.text, claim, &verdict, max),
            )
        });
        let code = report_verdict(verdict, "|grad f|", c, args.json, |b: &Aabb| {
            vec![b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z]
        });
        (code, written)
    } else {
        let c = args.grad_lipschitz.clone().unwrap_or_default();
        let seg = args
            .region
            .segment()?
            .ok_or_else(|| anyhow::anyhow!("verify --grad-lipschitz needs --ray and --t"))?;
        let claim = constant(&c, "--grad-lipschitz")?;
        let verdict = lgc::verify_grad_lipschitz(&bounder, &seg, claim, max);
        let (o, d) = (seg.origin, seg.direction);
        let claim = Claim::GradLipschitz {
            constant: c.clone(),
            ray: [o.x, o.y, o.z, d.x, d.y, d.z],
            t: [seg.t0, seg.t1],
        };
        let written = pending.map(|p| {
            (
                p,
                lgc::bounds::certificate(&source.text, claim, &verdict, max),
            )
        });
        let code = report_verdict(verdict, "|g'|", &c, args.json, |s: &Segment| {
            vec![s.t0, s.t1]
        });
        (code, written)
    };
    if let Some((pending, proof)) = written {
        let proof = proof.map_err(|e| match e {
            ProveError::Unreadable(TermError::Formula(e)) => source.located(e),
            e => anyhow::anyhow!("no proof written: {e}").into(),
        })?;
        std::fs::write(pending.temp(), proof.to_json())
            .map_err(|e| anyhow::Error::from(pending.io_error(e)))?;
        let name = pending.name();
        pending.rename().map_err(anyhow::Error::from)?;
        eprintln!("proof written to {name}; `lgc check-proof {name}` re-checks it");
    }
    Ok(code)
}

/// Encloses a claimed constant given as a number or a constant expression.
fn constant(text: &str, flag: &str) -> Result<Interval, Failure> {
    let located = |e: lgc::FormulaError| Failure::Formula(e.render(text, flag));
    let ast = lgc::lang::parse(text).map_err(located)?;
    let mut ctx = lgc::Context::new();
    let node = lgc::lang::lower(&mut ctx, &ast).map_err(located)?;
    match lgc::lang::enclose_constant(&ctx, node) {
        Ok(v) => Ok(v),
        Err(NotConstant::DependsOnCoordinates) => Err(anyhow::anyhow!(
            "{flag} {text}: the claimed constant may not depend on x, y or z"
        )
        .into()),
        Err(NotConstant::NotFinite) => {
            Err(anyhow::anyhow!("{flag} {text} is not a finite number").into())
        }
    }
}

/// Prints a verdict; returns the exit code (0 proved, 3 refuted, 4 undecided).
fn report_verdict<R>(
    verdict: Verdict<R>,
    what: &str,
    claim: &str,
    json: bool,
    region: impl Fn(&R) -> Vec<f64>,
) -> u8 {
    match verdict {
        Verdict::Proved { pieces } => {
            if json {
                let obj =
                    serde_json::json!({"verdict": "proved", "claim": claim, "pieces": pieces});
                println!("{obj}");
            } else {
                println!("proved: max {what} <= {claim} ({pieces} pieces checked)");
            }
            0
        }
        Verdict::Refuted {
            witness,
            t,
            value,
            pieces,
        } => {
            if json {
                let mut obj = serde_json::json!({
                    "verdict": "refuted", "claim": claim,
                    "witness": [witness.x, witness.y, witness.z],
                    "value": value, "pieces": pieces
                });
                if let Some(t) = t {
                    obj["t"] = json_number(t);
                }
                println!("{obj}");
            } else {
                let at_t = t.map(|t| format!(" (t = {})", num(t))).unwrap_or_default();
                let p = fmt3(witness).replace(',', ", ");
                let value = num(value);
                println!("refuted: {what} >= {value} > {claim} at ({p}){at_t}");
            }
            3
        }
        Verdict::Undecided {
            worst,
            bound,
            pieces,
        } => {
            let r = region(&worst);
            if json {
                let obj = serde_json::json!({
                    "verdict": "undecided", "claim": claim, "worst": r,
                    "bound": json_number(bound), "pieces": pieces
                });
                println!("{obj}");
            } else {
                let r: Vec<String> = r.into_iter().map(num).collect();
                println!(
                    "undecided after {pieces} pieces: the worst piece [{}] still has bound {} > {claim}",
                    r.join(", "),
                    num(bound)
                );
            }
            4
        }
    }
}
