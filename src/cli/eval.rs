//! `lgc eval`: f, ∇f (and g, g′) at one point, in f64.

use super::args::{json_number, num, parse_numbers, Outcome, SourceArgs};
use clap::Args;
use lgc::{Evaluator, Output};

/// Options of `lgc eval`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    #[command(flatten)]
    source: SourceArgs,
    /// The point X,Y,Z (negative values are fine: --at -1,-2,-3).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_numbers::<3>)]
    at: [f64; 3],
    /// A ray direction DX,DY,DZ: also print g and g' along it.
    #[arg(long, value_name = "DX,DY,DZ", allow_hyphen_values = true, value_parser = parse_numbers::<3>)]
    dir: Option<[f64; 3]>,
    /// Print one JSON object: {"f", "grad"} plus {"g", "dg"} with --dir.
    #[arg(long)]
    json: bool,
}

/// Prints f and ∇f at a point (and g, g′ along a direction).
pub fn run(args: &EvalArgs) -> Outcome {
    let formula = args.source.formula()?;
    let (at, dir, json) = (args.at, args.dir, args.json);
    let mut outputs = vec![Output::F, Output::Dfdx, Output::Dfdy, Output::Dfdz];
    if dir.is_some() {
        outputs.extend([Output::G, Output::Dg]);
    }
    let tape = formula.tape(&outputs);
    let d = dir.unwrap_or([0.0; 3]);
    let values = Evaluator::<f64>::new(&tape)
        .eval(&[at[0], at[1], at[2], d[0], d[1], d[2]])
        .to_vec();
    if json {
        let mut obj = serde_json::Map::new();
        obj.insert("f".into(), json_number(values[0]));
        obj.insert(
            "grad".into(),
            serde_json::Value::Array(values[1..4].iter().map(|&v| json_number(v)).collect()),
        );
        if dir.is_some() {
            obj.insert("g".into(), json_number(values[4]));
            obj.insert("dg".into(), json_number(values[5]));
        }
        println!("{}", serde_json::Value::Object(obj));
    } else {
        let names = ["f", "df/dx", "df/dy", "df/dz", "g", "dg"];
        for (name, v) in names.iter().zip(&values) {
            println!("{name:<6} = {}", num(*v));
        }
    }
    Ok(0)
}
