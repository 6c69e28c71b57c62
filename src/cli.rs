//! Command-line interface: argument definitions and the subcommands.

use anyhow::Context as _;
use clap::{Args, Parser, Subcommand};
use lgc::{Evaluator, Formula, FormulaError, Output};
use std::fmt;
use std::io::Read;

/// Compile an implicit surface f(x,y,z) = 0 into exact derivatives (and, later,
/// guaranteed bounds and pictures).
#[derive(Parser, Debug)]
#[command(name = "lgc", version, after_long_help = lgc::functions::language_reference())]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the simplified partial derivatives of f (and with --directional, g and g').
    #[command(after_long_help = lgc::functions::language_reference())]
    Grad {
        #[command(flatten)]
        source: SourceArgs,
        /// Also print g = dx*df/dx + dy*df/dy + dz*df/dz and g' = d^T H d.
        #[arg(long)]
        directional: bool,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Evaluate f and its gradient (and g, g' with --dir) at a point.
    #[command(after_long_help = lgc::functions::language_reference())]
    Eval {
        #[command(flatten)]
        source: SourceArgs,
        /// The point X,Y,Z (negative values are fine: --at -1,-2,-3).
        #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_triple)]
        at: [f64; 3],
        /// A ray direction DX,DY,DZ: also print g and g' along it.
        #[arg(long, value_name = "DX,DY,DZ", allow_hyphen_values = true, value_parser = parse_triple)]
        dir: Option<[f64; 3]>,
        /// Print one JSON object: {"f", "grad"} plus {"g", "dg"} with --dir.
        #[arg(long)]
        json: bool,
    },
}

/// Where the formula comes from: the command line or a file.
#[derive(Args, Debug)]
struct SourceArgs {
    /// The formula, such as "x^2+y^2+z^2-1".
    #[arg(
        value_name = "EXPR",
        required_unless_present = "file",
        allow_hyphen_values = true
    )]
    expr: Option<String>,
    /// Read the formula from FILE ("-" reads standard input).
    #[arg(
        short = 'f',
        long = "file",
        value_name = "FILE",
        conflicts_with = "expr"
    )]
    file: Option<String>,
}

/// Parses `A,B,C` into three finite numbers.
fn parse_triple(text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected three comma-separated numbers, found {}",
            parts.len()
        ));
    }
    let mut out = [0.0; 3];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("`{p}` is not a finite number"))?;
    }
    Ok(out)
}

/// Why a command failed, already worded for the user.
pub enum Failure {
    /// A mistake in the formula, rendered with its source line and caret.
    Formula(String),
    /// Anything else: one line.
    Other(anyhow::Error),
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::Formula(rendered) => f.write_str(rendered),
            Failure::Other(e) => writeln!(f, "error: {e:#}"),
        }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Other(e)
    }
}

/// The formula text and the name to show in diagnostics.
struct Source {
    text: String,
    origin: String,
}

impl SourceArgs {
    fn read(&self) -> anyhow::Result<Source> {
        match (&self.expr, &self.file) {
            (_, Some(path)) if path == "-" => {
                let mut text = String::new();
                std::io::stdin()
                    .read_to_string(&mut text)
                    .context("cannot read the formula from standard input")?;
                Ok(Source {
                    text,
                    origin: "<stdin>".into(),
                })
            }
            (_, Some(path)) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read formula file `{path}`"))?;
                Ok(Source {
                    text,
                    origin: path.clone(),
                })
            }
            (Some(expr), None) => Ok(Source {
                text: expr.clone(),
                origin: "<formula>".into(),
            }),
            (None, None) => anyhow::bail!("give a formula or --file"),
        }
    }

    fn formula(&self) -> Result<Formula, Failure> {
        let source = self.read()?;
        Formula::parse(&source.text)
            .map_err(|e: FormulaError| Failure::Formula(e.render(&source.text, &source.origin)))
    }
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Grad {
            source,
            directional,
            json,
        } => grad(&source.formula()?, directional, json),
        Command::Eval {
            source,
            at,
            dir,
            json,
        } => eval(&source.formula()?, at, dir, json),
    }
}

fn grad(formula: &Formula, directional: bool, json: bool) -> Result<(), Failure> {
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
    Ok(())
}

fn eval(formula: &Formula, at: [f64; 3], dir: Option<[f64; 3]>, json: bool) -> Result<(), Failure> {
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
        obj.insert("f".into(), number(values[0]));
        obj.insert(
            "grad".into(),
            serde_json::Value::Array(values[1..4].iter().map(|&v| number(v)).collect()),
        );
        if dir.is_some() {
            obj.insert("g".into(), number(values[4]));
            obj.insert("dg".into(), number(values[5]));
        }
        println!("{}", serde_json::Value::Object(obj));
    } else {
        let names = ["f", "df/dx", "df/dy", "df/dz", "g", "dg"];
        for (name, v) in names.iter().zip(&values) {
            println!("{name:<6} = {v}");
        }
    }
    Ok(())
}

/// A JSON number; NaN (a point outside the formula's domain) becomes null.
fn number(v: f64) -> serde_json::Value {
    serde_json::Number::from_f64(v).map_or(serde_json::Value::Null, serde_json::Value::Number)
}
