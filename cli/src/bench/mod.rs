//! Speed against error: what `slipbayes bench` measures, in one run on the machine at hand.
//!
//! - [`cost`]: the cost of the model per data point for each scene, beside the cost of one
//!   `exp` measured in the same run.
//! - [`throughput`]: steps/s and ESS/s of the sampler on the one-contact and the demo
//!   posteriors, on one thread and on all (and whether the chains are bit-identical).
//! - [`knobs`]: the error of the posterior medians and of the F_peak 95 % interval ends against
//!   a long reference run and against the known truth, for each knob (data decimation,
//!   walkers, chain length), against wall time; the Pareto front and the default.
//! - [`peer`]: the same one-contact posterior fitted by Python ensemble samplers over numpy +
//!   scipy (`benches/peer/friction_peer.py`): emcee's stretch move, emcee's differential
//!   evolution and snooker moves, zeus' ensemble slice sampling; each checked point by point
//!   and by its medians before any ratio (ESS/s, ESS per 1,000 log-density evaluations) is
//!   quoted.
//! - [`nuts`]: the same posterior fitted by NumPyro's NUTS on JAX
//!   (`benches/peer/friction_nuts.py`), gradients through the elastic solve, under the same
//!   checks; skipped, with the reason reported, when JAX cannot be installed.
//! - [`memory`]: peak resident memory of a streamed fit at two chain lengths.
//! - [`report`]: `speed-vs-error.md`, `results.json` and the SVG plots.
//!
//! The library does the measuring; the command line only parses flags. Nothing here prints:
//! progress goes through a callback.

pub mod chains;
pub mod cost;
pub mod knobs;
pub mod memory;
pub mod nuts;
pub mod peer;
pub mod plot;
pub mod report;
pub mod throughput;

use std::path::{Path, PathBuf};

use serde::Serialize;

use slipbayes::model::{ModelSpec, Posterior};
use slipbayes::run_file::RunFile;

/// Seed of every run of the bench (the sampler's default).
pub const BENCH_SEED: u64 = slipbayes::sampler::DEFAULT_SEED;

/// Errors of a bench run; each names what failed and the file involved.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A model or data file could not be used.
    #[error("{what}: {message}")]
    Input {
        /// What was being loaded.
        what: String,
        /// What went wrong.
        message: String,
    },
    /// A fit or a sampler run failed.
    #[error("{what}: {message}")]
    Run {
        /// Which run.
        what: String,
        /// What went wrong.
        message: String,
    },
    /// The Python peer could not be run or gave unusable output.
    #[error("the Python peer: {0}")]
    Peer(String),
    /// A file could not be written or read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl BenchError {
    pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Self + '_ {
        move |source| Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn run(what: impl Into<String>) -> impl FnOnce(String) -> Self {
        let what = what.into();
        move |message| Self::Run { what, message }
    }
}

/// Sizes of the measurements: `quick` finishes in a few minutes, `full` in well under an hour
/// on two cores.
#[derive(Debug, Clone, Serialize)]
pub struct BenchPlan {
    /// Repetitions of each per-point cost measurement (the median is reported).
    pub cost_reps: usize,
    /// Steps of the one-contact throughput runs (and of the peer).
    pub one_contact_steps: u64,
    /// Ensembles of the side-by-side runs with the peer (whose log-density costs ~100× ours).
    pub peer_ensembles: usize,
    /// Steps of the side-by-side runs with the peer.
    pub peer_steps: u64,
    /// The NUTS peer's warmup, draws and chains.
    pub nuts: nuts::NutsPlan,
    /// Steps of the one-contact reference run.
    pub one_contact_reference_steps: u64,
    /// Steps of the demo throughput runs.
    pub demo_steps: u64,
    /// Steps of the first+repeat reference run of the knob study.
    pub reference_steps: u64,
    /// Chain lengths tried.
    pub lengths: Vec<u64>,
    /// Walkers per ensemble tried.
    pub walkers: Vec<usize>,
    /// Decimation factors tried (every k-th point kept).
    pub decimations: Vec<usize>,
    /// Steps of the walker and decimation runs.
    pub knob_steps: u64,
    /// Most steps of the default fit (run until converged).
    pub default_max_steps: u64,
    /// Chain lengths of the two memory probes; both above one Parquet row group (65,536 rows,
    /// 512 steps of 128 walkers), the most the sink buffers.
    pub memory_steps: [u64; 2],
}

impl BenchPlan {
    /// The sizes of `--quick` (a few minutes) or of the full run.
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                cost_reps: 15,
                one_contact_steps: 200,
                peer_ensembles: 2,
                peer_steps: 80,
                nuts: nuts::NutsPlan {
                    warmup: 100,
                    draws: 100,
                    ..nuts::NutsPlan::default()
                },
                one_contact_reference_steps: 800,
                demo_steps: 40,
                reference_steps: 1000,
                lengths: vec![100, 200, 400],
                walkers: vec![12, 48],
                decimations: vec![3, 10],
                knob_steps: 200,
                default_max_steps: 1500,
                memory_steps: [600, 2400],
            }
        } else {
            Self {
                cost_reps: 60,
                one_contact_steps: 1000,
                peer_ensembles: 2,
                peer_steps: 600,
                nuts: nuts::NutsPlan::default(),
                one_contact_reference_steps: 4000,
                demo_steps: 120,
                reference_steps: 6000,
                lengths: vec![250, 500, 1000, 2000, 3000],
                walkers: vec![12, 16, 64],
                decimations: vec![2, 5, 10, 30],
                knob_steps: 800,
                default_max_steps: slipbayes::fit::DEFAULT_MAX_STEPS,
                memory_steps: [1000, 8000],
            }
        }
    }
}

/// Where the bench finds its inputs and how it runs.
#[derive(Debug, Clone)]
pub struct BenchSettings {
    /// Sizes of the measurements.
    pub plan: BenchPlan,
    /// Whether the quick sizes were chosen (recorded in the report).
    pub quick: bool,
    /// Threads of the "all threads" runs.
    pub threads: usize,
    /// The one-contact model (first slide of one contact).
    pub one_contact_model: PathBuf,
    /// The demo model.
    pub demo_model: PathBuf,
    /// First and repeat slide of one contact, with their truth JSON beside them.
    pub first_csv: PathBuf,
    /// The repeat slide that follows `first_csv`.
    pub repeat_csv: PathBuf,
    /// The bundled fast slide (for the stiff-fast scene's cost).
    pub fast_csv: PathBuf,
    /// Velocity of the first and repeat slides (m/s).
    pub velocity_m_per_s: f64,
    /// The peer: how to run it, or `None` to leave it out (and every other peer with it).
    pub peer: Option<peer::PeerCommand>,
    /// The optional ensemble peers that run beside the emcee stretch peer (in its Python).
    pub ensemble_peers: Vec<peer::EnsemblePeer>,
    /// Whether the NUTS peer runs too (in the emcee peer's Python).
    pub nuts: bool,
    /// The binary to run the memory probes with (normally the running `slipbayes`).
    pub probe_binary: Option<PathBuf>,
    /// Scratch directory (decimated data, run directories); removed at the end.
    pub scratch: PathBuf,
}

impl BenchSettings {
    /// The bundled inputs (run from the repository root): `benches/peer/one_contact.toml`,
    /// `models/demo.toml` and PTFE contact 1 of `data/`; no peer, no memory probes.
    pub fn bundled(quick: bool, threads: usize, scratch: PathBuf) -> Self {
        Self {
            plan: BenchPlan::new(quick),
            quick,
            threads,
            one_contact_model: "benches/peer/one_contact.toml".into(),
            demo_model: "models/demo.toml".into(),
            first_csv: "data/ptfe-c1-first.csv".into(),
            repeat_csv: "data/ptfe-c1-repeat.csv".into(),
            fast_csv: "data/ptfe-c1-fast.csv".into(),
            velocity_m_per_s: 1e-9,
            peer: None,
            ensemble_peers: Vec::new(),
            nuts: false,
            probe_binary: None,
            scratch,
        }
    }
}

/// Everything measured, as written to `results.json`.
#[derive(Debug, Clone, Serialize)]
pub struct BenchResults {
    /// When and where.
    pub machine: report::Machine,
    /// Sizes used.
    pub plan: BenchPlan,
    /// Whether `--quick` was given.
    pub quick: bool,
    /// Cost per data point.
    pub cost: cost::CostTable,
    /// Sampler throughput.
    pub throughput: Vec<throughput::Throughput>,
    /// Error against cost.
    pub knobs: knobs::KnobStudy,
    /// Our sampler with `slipbayes fit`'s default moves on the peers' problem, when the peers
    /// ran.
    pub fit_moves: Option<throughput::MovesRun>,
    /// The emcee stretch peer, when run.
    pub peer: Option<peer::PeerComparison>,
    /// The optional ensemble peers asked for (each may have been skipped).
    pub ensemble_peers: Vec<peer::PeerOutcome>,
    /// The NUTS peer, when asked for (it may have been skipped).
    pub nuts: Option<nuts::NutsOutcome>,
    /// Peak memory at two chain lengths, when probed.
    pub memory: Option<memory::MemoryProbe>,
}

/// Loads a model and its posterior, naming the file on error.
pub(crate) fn load_posterior(path: &Path) -> Result<(ModelSpec, Posterior), BenchError> {
    let input = |message: String| BenchError::Input {
        what: format!("model {}", path.display()),
        message,
    };
    let run = RunFile::load(path).map_err(|e| input(e.to_string()))?;
    let posterior = run.posterior().map_err(|e| input(e.to_string()))?;
    Ok((run.model, posterior))
}

/// Runs every measurement and returns the results; `progress` hears what is being done.
///
/// # Errors
/// [`BenchError`] naming the input, run or file at fault.
pub fn run(
    settings: &BenchSettings,
    progress: &mut dyn FnMut(&str),
) -> Result<BenchResults, BenchError> {
    std::fs::create_dir_all(&settings.scratch).map_err(BenchError::io(&settings.scratch))?;
    let machine_start = report::Machine::now(settings.threads);
    let plan = &settings.plan;

    progress("cost per data point");
    let cost = cost::measure(settings)?;

    let (_, one_contact) = load_posterior(&settings.one_contact_model)?;
    progress("one-contact throughput (1 thread, all threads)");
    let one = throughput::measure(
        "one-contact",
        &one_contact,
        slipbayes::sampler::DEFAULT_ENSEMBLES,
        plan.one_contact_steps,
        settings.threads,
    )?;
    progress("one-contact reference run");
    let one_reference = throughput::reference(
        &one_contact,
        plan.one_contact_reference_steps,
        settings.threads,
    )?;

    let (fit_moves, peer, ensemble_peers, nuts) = match &settings.peer {
        Some(command) => {
            progress("the Python peer (emcee stretch + numpy + scipy)");
            let ours = throughput::measure(
                "one-contact (as the peer)",
                &one_contact,
                plan.peer_ensembles,
                plan.peer_steps,
                settings.threads,
            )?;
            progress("one-contact (as the peer) with `slipbayes fit`'s default moves");
            let fit_moves = throughput::measure_moves(
                &one_contact,
                &ours,
                slipbayes::fit::default_moves(),
                settings.threads,
            )?;
            let inputs = peer::PeerInputs::new(settings, &one_contact, &ours)?;
            let py = peer::python(command)?;
            let emcee = peer::compare(
                &py,
                peer::EnsemblePeer::Stretch,
                &inputs,
                &ours,
                &one_reference,
            )?;
            let ensemble_peers = settings
                .ensemble_peers
                .iter()
                .map(|&sampler| {
                    progress(&format!("the Python peer ({})", sampler.label()));
                    peer::compare_optional(command, &py, sampler, &inputs, &ours, &one_reference)
                })
                .collect();
            let nuts = settings.nuts.then(|| {
                progress("the NUTS peer (NumPyro on JAX)");
                nuts::NutsOutcome::from(nuts::compare(
                    command,
                    &py,
                    &plan.nuts,
                    &inputs,
                    &ours,
                    &one_reference,
                ))
            });
            (Some(fit_moves), Some(emcee), ensemble_peers, nuts)
        }
        None => (None, None, Vec::new(), None),
    };

    let (_, demo) = load_posterior(&settings.demo_model)?;
    progress("demo throughput (1 thread, all threads)");
    let demo_throughput = throughput::measure(
        "demo",
        &demo,
        slipbayes::sampler::DEFAULT_ENSEMBLES,
        plan.demo_steps,
        settings.threads,
    )?;

    progress("error against cost (knobs)");
    let knobs = knobs::study(settings, progress)?;

    let memory = match &settings.probe_binary {
        Some(binary) => {
            progress("peak memory at two chain lengths");
            Some(memory::probe_two_lengths(binary, settings)?)
        }
        None => None,
    };

    let mut machine = machine_start;
    machine.finish();
    let results = BenchResults {
        machine,
        plan: plan.clone(),
        quick: settings.quick,
        cost,
        throughput: vec![one.summary, demo_throughput.summary],
        knobs,
        fit_moves,
        peer,
        ensemble_peers,
        nuts,
        memory,
    };
    // Scratch data is regenerated by every run; nothing in it is a result.
    let _ = std::fs::remove_dir_all(&settings.scratch);
    Ok(results)
}
