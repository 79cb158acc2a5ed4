//! The command line under `mpirun` (feature `mpi`): rank 0 runs the command as one process
//! would, with its evaluations shared by every rank; the other ranks load the same model, and
//! the data rank 0 tells them to (their own contacts', or all), and serve evaluations until
//! rank 0 releases them (see `slipbayes::distributed`).
//!
//! `fit` and `demo` run on several ranks, and `mpi-latency` measures the collectives they use;
//! `validate` deals its replications over the ranks instead (every rank fits its own, rank 0
//! records them all; see `crate::validate::ranks`); other commands refuse. A rank that fails
//! prints its rank and the cause and aborts the job, so that no rank waits for it; a fit's
//! last checkpoint, and the replications recorded, stay resumable.

use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use slipbayes::density::Target;
use slipbayes::distributed::{Cluster, DensityShare};
use slipbayes::model::{DataShare, Posterior};

use super::{error_lines, exit_code, fit, validate, Cli, Command};
use crate::bench::memory::peak_rss_kb;

/// Whether this process was started by an MPI launcher (Open MPI's `mpirun`, or a PMI/PMIx
/// launcher such as Slurm's `srun`): only then is MPI initialised.
pub(super) fn launched_by_mpirun() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}

/// Measure the latency of the collectives a fit over MPI uses, for a range of request sizes:
/// `mpirun -n R slipbayes mpi-latency`. One request is a broadcast of a header, a scatter of
/// ITEMS points of VALUES numbers over the ranks and two gathers back (as in a fit).
#[derive(Debug, Args)]
pub(super) struct LatencyArgs {
    /// Points per request.
    #[arg(long, default_value_t = 128)]
    items: usize,
    /// Values per point, one request size per value (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1,64,512,2048")]
    values: Vec<usize>,
    /// Requests timed per size.
    #[arg(long, default_value_t = 2000)]
    reps: usize,
}

/// Runs `cli` as one rank of an MPI job.
pub(super) fn main(cli: Cli) -> ExitCode {
    let mut cluster = match Cluster::init() {
        Ok(cluster) => cluster,
        Err(e) => return exit_code(Err(e.into())),
    };
    let rank = cluster.rank();
    if rank == 0 {
        let outcome = root(cli, &mut cluster);
        cluster.release();
        return exit_code(outcome);
    }
    match serve(cli, &mut cluster) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            for line in error_lines(&err) {
                say(format!("rank {rank}: {line}"));
            }
            // Rank 0 waits for this rank's share: end the whole job.
            cluster.abort(1)
        }
    }
}

/// Rank 0: the command itself, with the cluster evaluating.
fn root(cli: Cli, cluster: &mut Cluster) -> anyhow::Result<ExitCode> {
    let started = std::time::Instant::now();
    let outcome = match cli.command {
        Command::Fit(args) => fit::run(&args, Some(&mut *cluster)),
        Command::Demo(args) => fit::demo(&args, Some(&mut *cluster)),
        Command::MpiLatency(args) => latency(&args, cluster),
        Command::Validate(args) => validate::run_root(&args, cluster),
        _ => anyhow::bail!(
            "only fit, demo, validate and mpi-latency run on several ranks; run this command \
             without mpirun"
        ),
    };
    if cluster.size() > 1 && cluster.stats().requests > 0 {
        let wall = started.elapsed().as_secs_f64();
        let stats = cluster.stats();
        say(format!(
            "MPI: {} ranks; rank 0 spent {:.3} s of its {wall:.3} s in MPI calls ({:.1} %), {} \
             requests ({} of them runs of contacts' blocks updated in shares, {} batches of \
             shared updates split by contact), {:.1} MB{}",
            cluster.size(),
            stats.mpi_s,
            100.0 * stats.mpi_s / wall,
            stats.requests,
            stats.runs,
            stats.shared,
            stats.bytes as f64 / 1e6,
            peak_memory()
        ));
    }
    outcome
}

/// ", peak memory N MB" of this rank (its resident high-water mark), where the system says
/// (Linux): what each rank holds of the model and data.
fn peak_memory() -> String {
    peak_rss_kb().map_or_else(String::new, |kb| {
        format!(", peak memory {:.1} MB", kb as f64 / 1e3)
    })
}

/// Writes `line` to stderr in one call: `mpirun` forwards the ranks' output as it comes, and a
/// line written in pieces can be cut by another rank's.
fn say(line: String) {
    use std::io::Write;
    let _ = std::io::stderr().write_all(format!("{line}\n").as_bytes());
}

/// Ranks other than 0: load the model the command fits and evaluate until released (or run
/// their share of `validate`'s replications).
fn serve(cli: Cli, cluster: &mut Cluster) -> anyhow::Result<()> {
    let rank = cluster.rank();
    let run_file = match &cli.command {
        Command::Fit(args) => fit::fit_run_file(args)?,
        Command::Demo(args) => fit::demo_run_file(args)?,
        Command::MpiLatency(args) => {
            latency(args, cluster)?;
            // Then wait for rank 0's release, as after a fit.
            cluster.serve(Target::joint(&NoDensity))?;
            return Ok(());
        }
        Command::Validate(args) => {
            validate::run_rank(args, cluster)?;
            // Then wait for rank 0's release, once it has written the report.
            cluster.serve(Target::joint(&NoDensity))?;
            return Ok(());
        }
        // Rank 0 refuses the command and releases this rank at once.
        _ => {
            cluster.serve(Target::joint(&NoDensity))?;
            return Ok(());
        }
    };
    let started = std::time::Instant::now();
    let loading = || format!("rank {rank}: loading the model");
    // Rank 0 says whether this rank holds only its share of the contacts' data.
    let posterior = match cluster.receive_density()? {
        DensityShare::Released => return Ok(()),
        DensityShare::Whole => run_file.posterior().with_context(loading)?,
        DensityShare::Share(words) => {
            let data_share = DataShare::from_words(&words).with_context(loading)?;
            let own = |parts| cluster.own_parts(parts);
            Posterior::share_of(&run_file.model, run_file.blocking(), &data_share, own)
                .with_context(loading)?
        }
    };
    cluster.serve(Target::blocked(&posterior))?;
    let wall = started.elapsed().as_secs_f64();
    let stats = cluster.stats();
    let (held, runs) = posterior.held_runs();
    say(format!(
        "MPI: rank {rank} held the data of {held} of {runs} runs, served {} requests ({} runs of \
         contacts' blocks, {} batches of shared updates split by contact), {:.1} % of its \
         {wall:.3} s in MPI calls (waiting for rank 0 included){}",
        stats.requests,
        stats.runs,
        stats.shared,
        100.0 * stats.mpi_s / wall,
        peak_memory()
    ));
    Ok(())
}

/// What a rank serves when rank 0 runs a command that evaluates nothing: any request is a
/// mismatch (no coordinates).
struct NoDensity;

impl slipbayes::density::LogDensity for NoDensity {
    fn dim(&self) -> usize {
        0
    }

    fn log_density(
        &self,
        _x: &[f64],
        _derived: &mut [f64],
    ) -> Result<f64, slipbayes::density::LogDensityError> {
        Ok(0.0)
    }
}

/// `mpi-latency`: every rank times the requests; rank 0 prints the table.
fn latency(args: &LatencyArgs, cluster: &mut Cluster) -> anyhow::Result<ExitCode> {
    if cluster.rank() == 0 {
        println!("ranks,items,values_per_item,bytes_per_request,latency_us");
    }
    for &values in &args.values {
        let seconds = cluster.request_latency_s(args.items, values, args.reps);
        if cluster.rank() == 0 {
            // Points out and outcomes back.
            let bytes = 2 * 8 * args.items * values;
            println!(
                "{},{},{values},{bytes},{:.2}",
                cluster.size(),
                args.items,
                seconds * 1e6
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
