//! Sampler throughput: steps/s and ESS/s (the smallest bulk ESS over the sampled
//! coordinates) on one thread and on all, with the same seed, so the chains must also be
//! bit-identical.

use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::chains::{min_ess, CoordStats, Draws};
use super::{BenchError, BENCH_SEED};
use slipbayes::density::{LogDensity, Target};
use slipbayes::fit::INIT_STREAM;
use slipbayes::model::Posterior;
use slipbayes::optimize::initial_around_optimum;
use slipbayes::sampler::{
    EnsembleSampler, MemorySink, Move, SamplerConfig, Silent, Steps, DEFAULT_ENSEMBLES,
};

/// One run at one thread count.
#[derive(Debug, Clone, Serialize)]
pub struct ThreadRun {
    /// Threads of the pool.
    pub threads: usize,
    /// Seconds of sampling (the start-point optimisation excluded).
    pub sampling_s: f64,
    /// Steps per second (one step moves every walker of every ensemble).
    pub steps_per_s: f64,
    /// Log-density evaluations, the initial walkers' included, as the sampler counts them.
    pub evaluations: u64,
    /// Log-density evaluations per second.
    pub evals_per_s: f64,
    /// Smallest bulk ESS over the sampled coordinates, after the burn-in.
    pub ess_min: f64,
    /// `ess_min / sampling_s`.
    pub ess_per_s: f64,
}

/// Throughput of one posterior.
#[derive(Debug, Clone, Serialize)]
pub struct Throughput {
    /// Which posterior.
    pub posterior: String,
    /// Sampled dimensions.
    pub dim: usize,
    /// Walkers per ensemble.
    pub walkers: usize,
    /// Independent ensembles.
    pub ensembles: usize,
    /// Steps.
    pub steps: u64,
    /// Steps dropped before the ESS (a quarter of the run).
    pub burn_in: usize,
    /// One thread, then all threads.
    pub runs: Vec<ThreadRun>,
    /// Speed-up over one thread divided by the threads.
    pub scaling_efficiency: f64,
    /// Whether the chains of the two runs are bit-identical.
    pub identical_chains: bool,
}

/// A measured posterior: the summary and the chains of the all-threads run.
#[derive(Debug, Clone)]
pub struct Measured {
    /// The summary.
    pub summary: Throughput,
    /// Chains of the all-threads run.
    pub draws: Draws,
    /// Statistics of the all-threads run.
    pub stats: Vec<CoordStats>,
    /// Initial walkers of every ensemble (for the peer).
    pub initial: Vec<Vec<Vec<f64>>>,
}

/// A long run whose medians and sds stand for the exact posterior.
#[derive(Debug, Clone)]
pub struct Reference {
    /// Steps.
    pub steps: u64,
    /// Statistics after the burn-in.
    pub stats: Vec<CoordStats>,
    /// Seconds of sampling.
    pub sampling_s: f64,
}

/// Walkers per ensemble as `slipbayes fit` chooses them.
pub fn default_walkers(dim: usize) -> usize {
    (2 * dim + 4).max(32).next_multiple_of(2)
}

/// One sampled run.
pub struct Sampled {
    /// Chains.
    pub draws: Draws,
    /// Seconds of `run` alone.
    pub sampling_s: f64,
    /// Log-density evaluations.
    pub evaluations: u64,
    /// Initial walkers.
    pub initial: Vec<Vec<Vec<f64>>>,
}

/// Samples `steps` steps of `posterior` with stretch moves in a pool of `threads` threads.
///
/// # Errors
/// [`BenchError::Run`] when the start or the sampler fails.
pub fn sample(
    posterior: &Posterior,
    walkers: usize,
    ensembles: usize,
    steps: u64,
    seed: u64,
    threads: usize,
) -> Result<Sampled, BenchError> {
    sample_with(posterior, walkers, ensembles, steps, seed, threads, None)
}

/// [`sample`] with a mixture of `moves` instead of the stretch move alone; the start depends
/// on the seed only, so it is the same whatever the moves.
///
/// # Errors
/// [`BenchError::Run`] when the start or the sampler fails.
pub fn sample_with(
    posterior: &Posterior,
    walkers: usize,
    ensembles: usize,
    steps: u64,
    seed: u64,
    threads: usize,
    moves: Option<Vec<(Move, f64)>>,
) -> Result<Sampled, BenchError> {
    let what = format!("{walkers} walkers, {steps} steps, {threads} threads, seed {seed}");
    let fail = |e: String| BenchError::run(what.clone())(e);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| fail(e.to_string()))?;
    pool.install(|| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(INIT_STREAM);
        let start = initial_around_optimum(
            Target::blocked(posterior),
            posterior.search_start(),
            walkers,
            ensembles,
            &mut rng,
        )
        .map_err(|e| fail(e.to_string()))?;
        let initial = start.walkers.clone();
        let config = SamplerConfig::new(walkers, ensembles, seed)
            .and_then(|c| c.with_checkpoint_every(None))
            .and_then(|c| match moves {
                Some(moves) => c.with_moves(moves),
                None => Ok(c),
            })
            .map_err(|e| fail(e.to_string()))?;
        let mut sampler = EnsembleSampler::new(posterior, config, start.walkers)
            .map_err(|e| fail(e.to_string()))?;
        let mut sink = MemorySink::new();
        let clock = Instant::now();
        let report = sampler
            .run(Steps::Fixed(steps), &mut sink, &mut Silent)
            .map_err(|e| fail(e.to_string()))?;
        let sampling_s = clock.elapsed().as_secs_f64();
        Ok(Sampled {
            draws: Draws::from_memory(&sink.chains),
            sampling_s,
            evaluations: report.evaluations(),
            initial,
        })
    })
}

fn thread_run(threads: usize, s: &Sampled, steps: u64, ess_min: f64) -> ThreadRun {
    ThreadRun {
        threads,
        sampling_s: s.sampling_s,
        steps_per_s: steps as f64 / s.sampling_s,
        evaluations: s.evaluations,
        evals_per_s: s.evaluations as f64 / s.sampling_s,
        ess_min,
        ess_per_s: ess_min / s.sampling_s,
    }
}

/// Steps/s and ESS/s of `posterior` on one thread and on `threads`, with `ensembles`
/// independent ensembles of the default walkers.
///
/// # Errors
/// [`BenchError::Run`] when a run fails or is too short for the ESS.
pub fn measure(
    name: &str,
    posterior: &Posterior,
    ensembles: usize,
    steps: u64,
    threads: usize,
) -> Result<Measured, BenchError> {
    let dim = posterior.dim();
    let walkers = default_walkers(dim);
    let names = posterior.param_names();
    let burn_in = (steps / 4) as usize;
    let serial = sample(posterior, walkers, ensembles, steps, BENCH_SEED, 1)?;
    let parallel = sample(posterior, walkers, ensembles, steps, BENCH_SEED, threads)?;
    let stats = parallel
        .draws
        .stats(&names, burn_in)
        .map_err(BenchError::run(format!("ESS of the {name} run")))?;
    let ess = min_ess(&stats);
    // Bit for bit: the same seed must give the same chains on any thread count.
    let bits =
        |d: &Draws| -> Vec<u64> { d.ensembles.iter().flatten().map(|v| v.to_bits()).collect() };
    let identical = bits(&serial.draws) == bits(&parallel.draws);
    let runs = vec![
        thread_run(1, &serial, steps, ess),
        thread_run(threads, &parallel, steps, ess),
    ];
    let scaling_efficiency = runs[1].steps_per_s / runs[0].steps_per_s / threads as f64;
    Ok(Measured {
        summary: Throughput {
            posterior: name.into(),
            dim,
            walkers,
            ensembles,
            steps,
            burn_in,
            runs,
            scaling_efficiency,
            identical_chains: identical,
        },
        draws: parallel.draws,
        stats,
        initial: parallel.initial,
    })
}

/// Our sampler with another mixture of moves, on all threads, from the same start and with the
/// same walkers, steps, burn-in and estimator as a measured run.
#[derive(Debug, Clone, Serialize)]
pub struct MovesRun {
    /// The moves and their weights.
    pub moves: String,
    /// Threads of the pool.
    pub threads: usize,
    /// Seconds of sampling.
    pub sampling_s: f64,
    /// Log-density evaluations, the initial walkers' included, as the sampler counts them.
    pub evaluations: u64,
    /// Smallest bulk ESS over the sampled coordinates, after the burn-in.
    pub ess_min: f64,
    /// `ess_min / sampling_s`.
    pub ess_per_s: f64,
    /// ESS per 1,000 log-density evaluations.
    pub ess_per_kilo_eval: f64,
    /// Whether its initial walkers are those of the measured run (and so of the peers).
    pub same_start: bool,
}

/// Runs `moves` like `like` was run (walkers, ensembles, steps, seed), on `threads` threads.
///
/// # Errors
/// [`BenchError::Run`] when the run fails or is too short for the ESS.
pub fn measure_moves(
    posterior: &Posterior,
    like: &Measured,
    moves: Vec<(Move, f64)>,
    threads: usize,
) -> Result<MovesRun, BenchError> {
    let t = &like.summary;
    let label = moves
        .iter()
        .map(|(m, w)| format!("{m} {w}"))
        .collect::<Vec<_>>()
        .join(", ");
    let run = sample_with(
        posterior,
        t.walkers,
        t.ensembles,
        t.steps,
        BENCH_SEED,
        threads,
        Some(moves),
    )?;
    let stats = run
        .draws
        .stats(&posterior.param_names(), t.burn_in)
        .map_err(BenchError::run(format!(
            "ESS of the run with moves {label}"
        )))?;
    let ess_min = min_ess(&stats);
    Ok(MovesRun {
        threads,
        sampling_s: run.sampling_s,
        evaluations: run.evaluations,
        ess_min,
        ess_per_s: ess_min / run.sampling_s,
        ess_per_kilo_eval: super::peer::ess_per_kilo_eval(ess_min, run.evaluations),
        same_start: run.initial == like.initial,
        moves: label,
    })
}

/// A long run with a different seed: the stand-in for the exact posterior.
///
/// # Errors
/// [`BenchError::Run`] when the run fails.
pub fn reference(
    posterior: &Posterior,
    steps: u64,
    threads: usize,
) -> Result<Reference, BenchError> {
    let walkers = default_walkers(posterior.dim());
    let run = sample(
        posterior,
        walkers,
        DEFAULT_ENSEMBLES,
        steps,
        BENCH_SEED + 1,
        threads,
    )?;
    let stats = run
        .draws
        .stats(&posterior.param_names(), (steps / 4) as usize)
        .map_err(BenchError::run("the one-contact reference run"))?;
    Ok(Reference {
        steps,
        stats,
        sampling_s: run.sampling_s,
    })
}
