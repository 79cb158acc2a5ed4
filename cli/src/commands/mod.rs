//! The command-line front end. `main` parses arguments, dispatches to one command, and prints
//! an error once with its chain of causes. All real work lives in the library.

#[cfg(feature = "parquet")]
mod bench;
mod compare;
#[cfg(feature = "parquet")]
mod fit;
mod import;
#[cfg(feature = "parquet")]
mod kfold;
#[cfg(feature = "mpi")]
mod ranks;
#[cfg(feature = "report")]
mod report;
mod simulate;
#[cfg(feature = "parquet")]
mod validate;
#[cfg(feature = "parquet")]
mod watch;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Exit status of `fit`/`demo --strict` when the results are written but the run has not
/// converged (distinct from clap's 2 for an invalid command line).
pub(crate) const EXIT_NOT_CONVERGED: u8 = 3;
/// Exit status of `validate` when the calibration is grossly off or a hard case failed (the
/// report is written either way); distinct from clap's 2.
pub(crate) const EXIT_MISCALIBRATED: u8 = 4;

const EXIT_CODES: &str = "\
Exit codes:
  0    done
  1    error (the message says what and what to do)
  2    invalid command line
  3    fit/demo --strict: results written, but the run has not converged
  4    validate: miscalibrated, or a hard case failed (the report is written)
  130  fit/demo interrupted by Ctrl-C (resumable with the --resume command printed)";

/// Bayesian inference of the onset of frictional slip.
#[derive(Debug, Parser)]
#[command(name = "slipbayes", version, about, long_about = None, after_help = EXIT_CODES)]
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
    Compare(compare::CompareArgs),
    #[cfg(feature = "parquet")]
    Kfold(kfold::KFoldArgs),
    Import(import::ImportCommandArgs),
    #[cfg(feature = "parquet")]
    Validate(validate::ValidateArgs),
    #[cfg(feature = "parquet")]
    Watch(watch::WatchArgs),
    #[cfg(feature = "parquet")]
    Bench(bench::BenchArgs),
    #[cfg(feature = "mpi")]
    MpiLatency(ranks::LatencyArgs),
    /// Print the command-line reference (docs/cli.md) in Markdown, generated from these
    /// commands' own definitions.
    #[command(hide = true)]
    Reference,
}

/// Entry point of the `slipbayes` binary.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    #[cfg(feature = "mpi")]
    if ranks::launched_by_mpirun() {
        return ranks::main(cli);
    }
    exit_code(run(cli))
}

/// The exit code of a command's outcome, after printing its error.
fn exit_code(outcome: anyhow::Result<ExitCode>) -> ExitCode {
    match outcome {
        Ok(code) => code,
        Err(err) => {
            for line in error_lines(&err) {
                eprintln!("{line}");
            }
            ExitCode::FAILURE
        }
    }
}

/// `error: ...` and one `caused by: ...` per cause, leaving out a cause whose text the lines
/// above already hold (many errors quote their source in their own message).
fn error_lines(err: &anyhow::Error) -> Vec<String> {
    let mut shown = err.to_string();
    let mut lines = vec![format!("error: {shown}")];
    for cause in err.chain().skip(1) {
        let text = cause.to_string();
        if !shown.contains(&text) {
            lines.push(format!("  caused by: {text}"));
            shown.push('\n');
            shown.push_str(&text);
        }
    }
    lines
}

/// The command-line reference in Markdown: every command's `--help`, as clap renders it
/// from the definitions above, so that the page cannot drift from the parser
/// (`cli/tests/docs.rs` compares it with `docs/cli.md`).
pub fn reference() -> String {
    use clap::CommandFactory;
    let mut cli = Cli::command();
    cli.build();
    let mut md = String::from(
        "# Command-line reference\n\n\
         Every command's `--help`, generated from the argument parser by the hidden command \
         `slipbayes reference` (default features; the MPI build adds `mpi-latency`, see \
         [Clusters](clusters.md)). Regenerate this page with\n\n\
         <!-- not run: rewrites this page in the repository -->\n\
         ```sh\ncargo run --release -- reference > docs/cli.md\n```\n\n\
         `cli/tests/docs.rs` fails while it is stale.\n",
    );
    let section = |md: &mut String, title: &str, help: String| {
        md.push_str(&format!(
            "\n## {title}\n\n```text\n{}\n```\n",
            help.trim_end()
        ));
    };
    section(&mut md, "slipbayes", cli.render_long_help().to_string());
    md.push_str("\nCommands:");
    let commands: Vec<&clap::Command> = cli
        .get_subcommands()
        .filter(|c| !c.is_hide_set() && c.get_name() != "help")
        .collect();
    for (i, c) in commands.iter().enumerate() {
        let sep = if i == 0 { " " } else { ", " };
        md.push_str(&format!("{sep}[`{0}`](#slipbayes-{0})", c.get_name()));
    }
    md.push_str(".\n");
    for c in commands {
        section(
            &mut md,
            &format!("slipbayes {}", c.get_name()),
            c.clone().render_long_help().to_string(),
        );
    }
    md
}

/// A number > 0 (and finite), for flags such as `--velocity`: a negative one is parsed and
/// then refused with this reason, instead of being taken for a flag.
pub(crate) fn positive(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        // clap quotes the flag and the value given.
        Ok(_) => Err("it must be a number > 0".to_owned()),
        Err(_) => Err("not a number".to_owned()),
    }
}

/// A law by the name model files give it, for `--law`.
pub(crate) fn law_name(text: &str) -> Result<slipbayes::law::LawKind, String> {
    use slipbayes::law::LawKind;
    text.parse().map_err(|_| {
        let known: Vec<&str> = LawKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown law; use one of {}", known.join(", "))
    })
}

/// A number ≥ 0 (and finite), for flags such as `--likelihood-tolerance`.
pub(crate) fn non_negative(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(_) => Err("it must be a number >= 0".to_owned()),
        Err(_) => Err("not a number".to_owned()),
    }
}

fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        #[cfg(feature = "parquet")]
        Command::Demo(args) => fit::demo(&args, None),
        #[cfg(feature = "parquet")]
        Command::Fit(args) => fit::run(&args, None),
        #[cfg(feature = "report")]
        Command::Report(args) => report::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Compare(args) => compare::run(&args),
        #[cfg(feature = "parquet")]
        Command::Kfold(args) => kfold::run(&args),
        Command::Import(args) => import::run(&args),
        #[cfg(feature = "parquet")]
        Command::Validate(args) => validate::run(&args),
        #[cfg(feature = "parquet")]
        Command::Watch(args) => watch::run(&args),
        #[cfg(feature = "parquet")]
        Command::Bench(args) => bench::run_bench(&args),
        Command::Reference => {
            print!("{}", reference());
            Ok(ExitCode::SUCCESS)
        }
        #[cfg(feature = "mpi")]
        Command::MpiLatency(_) => {
            anyhow::bail!("mpi-latency measures MPI: run it with mpirun -n R (R ≥ 2)")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cause_quoted_by_the_message_is_printed_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let err = anyhow::Error::new(io)
            .context("m.toml: No such file")
            .context("loading the model");
        assert_eq!(
            error_lines(&err),
            [
                "error: loading the model",
                "  caused by: m.toml: No such file"
            ]
        );
    }

    #[test]
    fn positive_numbers_only() {
        assert_eq!(positive("1e-9"), Ok(1e-9));
        assert!(positive("-1e-9").unwrap_err().contains("> 0"));
        assert!(positive("0").is_err() && positive("inf").is_err() && positive("x").is_err());
        assert_eq!(non_negative("0"), Ok(0.0));
        assert!(non_negative("-0.1").unwrap_err().contains(">= 0"));
        assert!(non_negative("nan").is_err() && non_negative("x").is_err());
    }
}
