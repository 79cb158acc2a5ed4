//! Peak resident memory of a streamed fit at two chain lengths. Each length runs in its own
//! process (the running binary with `bench --probe-memory`), because the peak of a process
//! only grows: one process per measurement is the only clean reading.

use std::path::Path;
use std::process::Command;

use serde::Serialize;

use super::{BenchError, BenchSettings, BENCH_SEED};
use slipbayes::sampler::Steps;

/// What a probe process runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ProbeKind {
    /// The sampler alone, chains streamed to Parquet.
    Sample,
    /// A whole `run_fit`: sampling, then the summary, which reads the chains back.
    Fit,
}

/// Peak resident memory at two chain lengths.
#[derive(Debug, Clone, Serialize)]
pub struct MemoryProbe {
    /// Model fitted (first + repeat slide, every 10th point).
    pub model: String,
    /// Walkers per ensemble × ensembles.
    pub walkers_total: usize,
    /// Chain lengths (steps).
    pub steps: [u64; 2],
    /// Peak resident memory (VmHWM) of the sampler alone streaming to Parquet, kB.
    pub sample_peak_kb: [u64; 2],
    /// Peak resident memory (VmHWM) of a whole fit (sampling and summary), kB.
    pub peak_kb: [u64; 2],
    /// Size of the chains written (bytes), to show what would have been held in memory.
    pub chain_bytes: [u64; 2],
}

/// The peak resident memory of this process (`VmHWM` of `/proc/self/status`), kB.
pub fn peak_rss_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

fn dir_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir).map_or(0, |entries| {
        entries
            .flatten()
            .map(|e| match e.metadata() {
                Ok(m) if m.is_dir() => dir_bytes(&e.path()),
                Ok(m) => m.len(),
                Err(_) => 0,
            })
            .sum()
    })
}

/// What a probe process reports.
#[derive(Debug, Clone, Copy, Serialize, serde::Deserialize)]
pub struct ProbeReading {
    /// Peak resident memory, kB.
    pub peak_kb: u64,
    /// Bytes of chains written.
    pub chain_bytes: u64,
}

/// The sampler alone, streaming every step to Parquet in `out`.
fn sample_streamed(model: &Path, steps: u64, out: &Path) -> Result<(), BenchError> {
    use rand::SeedableRng;
    use slipbayes::density::LogDensity;
    use slipbayes::fit::RunDir;
    use slipbayes::sampler::{EnsembleSampler, SamplerConfig, Silent, DEFAULT_ENSEMBLES};
    use slipbayes::storage::{ParquetSink, SinkOptions};
    let (_, posterior) = super::load_posterior(model)?;
    let fail = |e: String| BenchError::run(format!("memory probe of {steps} steps"))(e);
    let walkers = super::throughput::default_walkers(posterior.dim());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(BENCH_SEED);
    rng.set_stream(slipbayes::fit::INIT_STREAM);
    let start = slipbayes::optimize::initial_around_optimum(
        slipbayes::density::Target::blocked(&posterior),
        posterior.search_start(),
        walkers,
        DEFAULT_ENSEMBLES,
        &mut rng,
    )
    .map_err(|e| fail(e.to_string()))?;
    let config = SamplerConfig::new(walkers, DEFAULT_ENSEMBLES, BENCH_SEED)
        .map_err(|e| fail(e.to_string()))?;
    let mut sampler =
        EnsembleSampler::new(&posterior, config, start.walkers).map_err(|e| fail(e.to_string()))?;
    let options = SinkOptions {
        overwrite: true,
        ..SinkOptions::default()
    };
    let mut sink = ParquetSink::create(
        &RunDir::new(out).chain_files(),
        &posterior.param_names(),
        &posterior.derived_names(),
        options,
    )
    .map_err(|e| fail(e.to_string()))?;
    sampler
        .run(Steps::Fixed(steps), &mut sink, &mut Silent)
        .map_err(|e| fail(e.to_string()))?;
    sink.finish().map_err(|e| fail(e.to_string()))
}

/// The probe itself (run in a child process): the sampler alone or a whole fit of `model` for
/// `steps` steps into `out`, chains streamed to Parquet, then this process's peak memory.
///
/// # Errors
/// [`BenchError`] when the run fails or the peak cannot be read.
pub fn probe(
    kind: ProbeKind,
    model: &Path,
    steps: u64,
    out: &Path,
) -> Result<ProbeReading, BenchError> {
    std::fs::create_dir_all(out).map_err(BenchError::io(out))?;
    match kind {
        ProbeKind::Sample => sample_streamed(model, steps, out)?,
        ProbeKind::Fit => {
            let threads = rayon::current_num_threads();
            super::knobs::fit_keeping(model, None, Steps::Fixed(steps), BENCH_SEED, out, threads)?;
        }
    }
    let chain_bytes = dir_bytes(out);
    let _ = std::fs::remove_dir_all(out);
    let peak_kb = peak_rss_kb().ok_or_else(|| BenchError::Run {
        what: "memory probe".into(),
        message: "VmHWM not found in /proc/self/status (Linux only)".into(),
    })?;
    Ok(ProbeReading {
        peak_kb,
        chain_bytes,
    })
}

/// Runs `binary bench --probe-memory` at both chain lengths of the plan.
///
/// # Errors
/// [`BenchError::Run`] when a probe fails or prints no reading.
pub fn probe_two_lengths(
    binary: &Path,
    settings: &BenchSettings,
) -> Result<MemoryProbe, BenchError> {
    let (model, _) = super::knobs::decimated_model(settings, 10)?;
    let steps = settings.plan.memory_steps;
    let mut readings = Vec::new();
    for (kind, flag) in [(ProbeKind::Sample, "sample"), (ProbeKind::Fit, "fit")] {
        for &n in &steps {
            let out = settings.scratch.join(format!("memory-{flag}-{n}"));
            let what = format!("memory probe ({flag}) of {n} steps");
            let output = Command::new(binary)
                .args(["bench", "--probe-memory"])
                .arg(&model)
                .args([
                    "--probe-kind",
                    flag,
                    "--probe-steps",
                    &n.to_string(),
                    "--probe-out",
                ])
                .arg(&out)
                .output()
                .map_err(|e| BenchError::run(what.clone())(e.to_string()))?;
            if !output.status.success() {
                return Err(BenchError::run(what)(
                    String::from_utf8_lossy(&output.stderr).into_owned(),
                ));
            }
            let stdout = String::from_utf8_lossy(&output.stdout);
            let reading: ProbeReading = stdout
                .lines()
                .last()
                .and_then(|l| serde_json::from_str(l).ok())
                .ok_or_else(|| {
                    BenchError::run(what)(format!("no reading in its output: {stdout}"))
                })?;
            readings.push((kind, reading));
        }
    }
    let (_, posterior) = super::load_posterior(&model)?;
    Ok(MemoryProbe {
        model: "first + repeat slide of one contact, every 10th point".into(),
        walkers_total: super::throughput::default_walkers(slipbayes::density::LogDensity::dim(
            &posterior,
        )) * slipbayes::sampler::DEFAULT_ENSEMBLES,
        steps,
        sample_peak_kb: [readings[0].1.peak_kb, readings[1].1.peak_kb],
        peak_kb: [readings[2].1.peak_kb, readings[3].1.peak_kb],
        chain_bytes: [readings[0].1.chain_bytes, readings[1].1.chain_bytes],
    })
}
