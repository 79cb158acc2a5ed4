//! The command-line front end. `main` parses arguments, dispatches to one command, and prints
//! an error once with its chain of causes. All real work lives in the library.

#[cfg(feature = "parquet")]
mod bench;
#[cfg(feature = "parquet")]
mod fit;
mod import;
#[cfg(feature = "report")]
mod report;
mod simulate;
#[cfg(feature = "parquet")]
mod validate;

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
    #[cfg(feature = "parquet")]
    Demo(fit::DemoArgs),
    #[cfg(feature = "parquet")]
    // Boxed: the fit flags are many times larger than any other command's.
    Fit(Box<fit::FitArgs>),
    #[cfg(feature = "report")]
    Report(report::ReportArgs),
    Simulate(simulate::SimulateArgs),
    Import(import::ImportCommandArgs),
    #[cfg(feature = "parquet")]
    Validate(validate::ValidateArgs),
    #[cfg(feature = "parquet")]
    Bench(bench::BenchArgs),
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
        #[cfg(feature = "parquet")]
        Command::Demo(args) => fit::demo(&args),
        #[cfg(feature = "parquet")]
        Command::Fit(args) => fit::run(&args),
        #[cfg(feature = "report")]
        Command::Report(args) => report::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Import(args) => import::run(&args),
        #[cfg(feature = "parquet")]
        Command::Validate(args) => validate::run(&args),
        #[cfg(feature = "parquet")]
        Command::Bench(args) => bench::run_bench(&args),
    }
}
