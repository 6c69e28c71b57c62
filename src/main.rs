//! The `lgc` command: parse arguments, run, map the outcome to an exit code.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    let args = match <cli::Cli as clap::Parser>::try_parse() {
        Ok(args) => args,
        Err(e) => match e.kind() {
            // A value that does not parse: its one line says which and why.
            clap::error::ErrorKind::ValueValidation | clap::error::ErrorKind::InvalidValue => {
                let text = e.to_string();
                eprintln!("{}", text.lines().next().unwrap_or("error: invalid value"));
                return ExitCode::from(2);
            }
            _ => e.exit(),
        },
    };
    match cli::run(args) {
        Ok(code) => ExitCode::from(code),
        Err(failure) => {
            eprint!("{failure}");
            ExitCode::from(1)
        }
    }
}
