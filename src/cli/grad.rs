//! `lgc grad`: the simplified symbolic derivatives, printed so they parse back.

use super::args::{Outcome, SourceArgs};
use clap::Args;
use lgc::Output;

/// Options of `lgc grad`.
#[derive(Args, Debug)]
pub struct GradArgs {
    #[command(flatten)]
    source: SourceArgs,
    /// Also print g = dx*df/dx + dy*df/dy + dz*df/dz and g' = d^T H d.
    #[arg(long)]
    directional: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Prints the simplified partial derivatives (and g, g′).
pub fn run(args: &GradArgs) -> Outcome {
    let formula = args.source.formula()?;
    let (formula, directional, json) = (&formula, args.directional, args.json);
    let mut rows = vec![
        ("df/dx", formula.print(formula.node(Output::Dfdx))),
        ("df/dy", formula.print(formula.node(Output::Dfdy))),
        ("df/dz", formula.print(formula.node(Output::Dfdz))),
    ];
    if directional {
        rows.push(("g", formula.print(formula.g())));
        rows.push(("dg", formula.print(formula.dg())));
    }
    if json {
        let mut obj = serde_json::Map::new();
        obj.insert(
            "grad".into(),
            serde_json::json!([rows[0].1, rows[1].1, rows[2].1]),
        );
        if directional {
            obj.insert("g".into(), rows[3].1.clone().into());
            obj.insert("dg".into(), rows[4].1.clone().into());
        }
        println!("{}", serde_json::Value::Object(obj));
    } else {
        for (name, text) in rows {
            println!("{name} = {text}");
        }
    }
    Ok(0)
}
