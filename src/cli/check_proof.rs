//! `lgc check-proof`: re-check a proof file with the independent checker.

use super::args::{num, Failure, Outcome};
use anyhow::Context as _;
use clap::Args;
use lgc::proof::format::MAX_FILE_BYTES;
use lgc::proof::terms::TermError;
use lgc::proof::{check, Claim, Proof, Rejection};
use std::path::PathBuf;

/// Options of `lgc check-proof`.
#[derive(Args, Debug)]
pub struct CheckProofArgs {
    /// The proof file, as `lgc verify --proof` writes it.
    #[arg(value_name = "FILE.json")]
    file: PathBuf,
    /// Print one JSON object: `valid`, and what the proof shows or why not.
    #[arg(long)]
    json: bool,
}

/// Checks the proof; exit 0 when it is valid, 1 when it is not.
pub fn run(args: &CheckProofArgs) -> Outcome {
    let name = args.file.display().to_string();
    let size = std::fs::metadata(&args.file)
        .with_context(|| format!("cannot read proof file `{name}`"))?
        .len();
    if size > MAX_FILE_BYTES {
        return Err(anyhow::anyhow!(
            "`{name}` is {size} bytes; the checker reads proof files of at most {MAX_FILE_BYTES} bytes"
        )
        .into());
    }
    let text = std::fs::read_to_string(&args.file)
        .with_context(|| format!("cannot read proof file `{name}`"))?;
    let proof = Proof::from_json(&text).with_context(|| format!("`{name}` is not a proof"))?;
    let (what, region) = match &proof.claim {
        Claim::Lipschitz { region: b, .. } => (
            "|grad f|",
            format!(
                "over the box {}",
                b.iter().map(|&v| num(v)).collect::<Vec<_>>().join(",")
            ),
        ),
        Claim::GradLipschitz { ray, t, .. } => (
            "|g'|",
            format!(
                "on the ray {} for t in [{}, {}]",
                ray.iter().map(|&v| num(v)).collect::<Vec<_>>().join(","),
                num(t[0]),
                num(t[1])
            ),
        ),
    };
    let constant = proof.claim.constant();
    match check(&proof) {
        Ok(c) if args.json => {
            let obj = serde_json::json!({
                "valid": true,
                "verdict": if c.proved { "proved" } else { "refuted" },
                "claim": constant, "leaves": c.leaves, "largest": c.largest,
            });
            println!("{obj}");
            Ok(0)
        }
        Ok(c) if c.proved => {
            println!(
                "valid: proves max {what} <= {constant} {region} ({} {}; the largest leaf bound {})",
                c.leaves,
                if c.leaves == 1 { "leaf" } else { "leaves" },
                num(c.largest)
            );
            Ok(0)
        }
        Ok(c) => {
            println!(
                "valid: refutes max {what} <= {constant} {region}: {what} >= {} at the witness",
                num(c.largest)
            );
            Ok(0)
        }
        Err(r) if args.json => {
            let obj = serde_json::json!({"valid": false, "reason": r.to_string()});
            println!("{obj}");
            Ok(1)
        }
        Err(Rejection::Unreadable {
            what,
            error: TermError::Formula(e),
        }) => {
            let source = if what == "formula" {
                &proof.formula
            } else {
                constant
            };
            Err(Failure::Formula(format!(
                "rejected: the proof's {what} is not read by the checker\n{}",
                e.render(source, &format!("{name}: {what}"))
            )))
        }
        Err(r) => Err(anyhow::anyhow!("rejected: {r}").into()),
    }
}
