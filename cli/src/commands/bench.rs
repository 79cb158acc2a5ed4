//! `slipbayes bench`: flags into [`BenchSettings`], then the library measures and reports.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use crate::bench::peer::{EnsemblePeer, PeerCommand};
use crate::bench::{memory, report, run, BenchSettings};

/// Measure speed against error and compare with the Python peers (emcee's stretch and
/// DE + snooker moves and zeus' ensemble slice sampler, over numpy + scipy; NumPyro's NUTS on
/// JAX).
///
/// Writes <out>/speed-vs-error.md and, in <out>/speed-vs-error/, SVG plots and results.json.
/// Run it from the repository root (it reads models/, data/, benches/peer/).
/// The full run takes about half an hour on two cores; --quick a few minutes.
///
/// Example: slipbayes bench --quick --python /path/to/venv/bin/python
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct BenchArgs {
    /// Small sizes: a few minutes instead of about half an hour.
    #[arg(long)]
    quick: bool,
    /// Directory of speed-vs-error.md.
    #[arg(long, default_value = "reports")]
    out: PathBuf,
    /// Threads of the "all threads" runs (default: every logical CPU).
    #[arg(long)]
    threads: Option<usize>,
    /// Python interpreter with numpy, scipy and emcee for the peers (and zeus-mcmc for the zeus
    /// peer, jax, jaxlib, numpyro for the NUTS peer). Without it a venv is created at --venv
    /// (python3 -m venv, then pip install numpy scipy emcee, zeus-mcmc, and jax jaxlib numpyro
    /// at pinned versions).
    #[arg(long)]
    python: Option<PathBuf>,
    /// Where to create the peer's venv when --python is not given.
    #[arg(long, default_value = "target/peer-venv")]
    venv: PathBuf,
    /// Leave the peers out (emcee, zeus and NUTS).
    #[arg(long)]
    no_peer: bool,
    /// Leave the emcee DE + snooker peer (emcee's differential-evolution and snooker moves)
    /// out; it takes about as long as the emcee stretch peer.
    #[arg(long)]
    no_de_snooker: bool,
    /// Leave the zeus peer (ensemble slice sampling, pip install zeus-mcmc into the venv) out;
    /// its several log-densities per walker and step make it a few times as long as the emcee
    /// peers.
    #[arg(long)]
    no_zeus: bool,
    /// Leave the NUTS peer (NumPyro on JAX, pip install jax jaxlib numpyro into the venv)
    /// out; it adds a few minutes to a full run.
    #[arg(long)]
    no_nuts: bool,
    /// Leave the memory probes out.
    #[arg(long)]
    no_memory: bool,
    /// Internal: run one memory probe of this model (used by the bench itself).
    #[arg(long, hide = true, requires_all = ["probe_steps", "probe_out"])]
    probe_memory: Option<PathBuf>,
    /// Internal: what the memory probe runs.
    #[arg(long, hide = true, value_enum, default_value = "fit")]
    probe_kind: memory::ProbeKind,
    /// Internal: steps of the memory probe.
    #[arg(long, hide = true)]
    probe_steps: Option<u64>,
    /// Internal: run directory of the memory probe.
    #[arg(long, hide = true)]
    probe_out: Option<PathBuf>,
}

pub(super) fn run_bench(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    if let (Some(model), Some(steps), Some(out)) =
        (&args.probe_memory, args.probe_steps, &args.probe_out)
    {
        let reading = memory::probe(args.probe_kind, model, steps, out)?;
        println!("{}", serde_json::to_string(&reading)?);
        return Ok(ExitCode::SUCCESS);
    }
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    anyhow::ensure!(threads >= 1, "--threads must be at least 1");
    let peer = match (&args.python, args.no_peer) {
        (_, true) => None,
        (Some(p), false) => Some(PeerCommand::Python(p.clone())),
        (None, false) => Some(PeerCommand::Venv(args.venv.clone())),
    };
    let probe_binary = if args.no_memory {
        None
    } else {
        Some(
            std::env::current_exe()
                .context("locating the slipbayes binary for the memory probes")?,
        )
    };
    let ensemble_peers = [
        (EnsemblePeer::DeSnooker, args.no_de_snooker),
        (EnsemblePeer::Zeus, args.no_zeus),
    ]
    .into_iter()
    .filter(|&(_, left_out)| peer.is_some() && !left_out)
    .map(|(sampler, _)| sampler)
    .collect();
    let settings = BenchSettings {
        nuts: peer.is_some() && !args.no_nuts,
        ensemble_peers,
        peer,
        probe_binary,
        ..BenchSettings::bundled(
            args.quick,
            threads,
            PathBuf::from("target").join("bench-scratch"),
        )
    };
    let started = std::time::Instant::now();
    let results = run(&settings, &mut |step| {
        eprintln!("[{:>6.0} s] {step}", started.elapsed().as_secs_f64());
    })?;
    let command = std::env::args()
        .enumerate()
        .map(|(i, a)| if i == 0 { "slipbayes".to_owned() } else { a })
        .collect::<Vec<_>>()
        .join(" ");
    let written = report::write(&results, &args.out, &command)?;
    eprintln!("wrote {}", written.markdown.display());
    for f in &written.files {
        eprintln!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}
