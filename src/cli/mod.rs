//! The command-line front end. `main` parses arguments, dispatches to one command, and prints
//! an error once with its chain of causes. All real work lives in the library.

pub mod progress;
mod simulate;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Bayesian inference of the onset of frictional slip.
#[derive(Debug, Parser)]
#[command(name = "slipbayes", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Simulate(simulate::SimulateArgs),
}

/// Entry point of the `slipbayes` binary.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {err}");
            for cause in err.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Simulate(args) => simulate::run(&args),
    }
}
