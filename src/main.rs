//! The `lgc` command: parse arguments, run, map the outcome to an exit code.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    let args = <cli::Cli as clap::Parser>::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(cli::Failure::Exit(code)) => ExitCode::from(code),
        Err(failure) => {
            eprint!("{failure}");
            ExitCode::from(1)
        }
    }
}
