//! Per-step overhead of the ensemble sampler, judged against the floor measured in the same
//! run: drawing exactly the random numbers a stretch step needs and forming its proposals.
//!
//! Run: `cargo bench --bench sampler`, then `python3 benches/peer/report_overhead.py` turns
//! criterion's estimates into the table of `reports/performance.md` (ns per walker-step and
//! the ratio (step − density) / floor).
//!
//! Every benchmark's throughput is in walker-steps (one proposal of one walker), so the
//! per-element times can be compared and subtracted directly:
//! - `floor`: per step a random half split (partial Fisher–Yates into a reused buffer, from
//!   the ensemble's stream), and per walker a partner index, `u` for `z`, `z`, the proposal
//!   `Y = X_j + z (X_k − X_j)` and the acceptance uniform, all from the walker's own ChaCha8
//!   stream, as the deterministic sampler needs them. No logarithms, no acceptance, no
//!   bookkeeping.
//! - `density`: one call of the negligible-cost density (a 10-D standard normal).
//! - `run_serial` / `run_parallel`: a fresh sampler running `STEPS` steps into a
//!   [`NullSink`] (history for τ, final checkpoint and report included).
//! - `run_serial_long`: `2 STEPS` steps; `2 long − run_serial` is the marginal cost of a
//!   step of a long run, free of one-time costs.
//! - `run_end`: the end-of-run work alone (final checkpoint, τ and R̂ report), as
//!   `run(Fixed(0))` on the state after `STEPS` steps, per walker-step of that run.
//! - `*_4ens`: the same with four ensembles (elements count all ensembles' walkers).
//! - group `sampler_medium`: a density costing a few µs (four ensembles, 1000 steps), where
//!   parallel evaluation pays off.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slipbayes::density::{LogDensity, LogDensityError};
use slipbayes::sampler::{EnsembleSampler, NullSink, SamplerConfig, Silent, Steps};

#[path = "support/floor.rs"]
mod floor;
use floor::Floor;

const WALKERS: usize = 32;
const NDIM: usize = 10;
const STEPS: u64 = 20_000;
const SEED: u64 = 2024;
/// Steps of the medium-density runs (about 0.5 s each serially).
const MEDIUM_STEPS: u64 = 1000;

/// A 10-D standard normal: about as cheap as a density can be.
struct Cheap;

impl LogDensity for Cheap {
    fn dim(&self) -> usize {
        NDIM
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        Ok(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
    }
}

/// The same normal plus a fixed amount of work (800 logarithms, a few µs): 64 of them per
/// half-step (four ensembles) are worth spreading over threads.
struct Medium;

impl LogDensity for Medium {
    fn dim(&self) -> usize {
        NDIM
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        let mut acc = 0.0;
        for k in 0..800 {
            acc += (x[k % NDIM] * 1e-3 + (k + 1) as f64).ln();
        }
        Ok(-0.5 * x.iter().map(|v| v * v).sum::<f64>() + 1e-300 * acc)
    }
}

fn start(ensembles: usize) -> Vec<Vec<Vec<f64>>> {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    (0..ensembles)
        .map(|_| {
            (0..WALKERS)
                .map(|_| (0..NDIM).map(|_| rng.random::<f64>() - 0.5).collect())
                .collect()
        })
        .collect()
}

fn sampler<D: LogDensity>(d: &D, ensembles: usize, parallel: bool) -> EnsembleSampler<'_, D> {
    let config = SamplerConfig::new(WALKERS, ensembles, SEED)
        .expect("valid config")
        .with_parallel(parallel);
    EnsembleSampler::new(d, config, start(ensembles)).expect("valid start")
}

fn bench_run<D: LogDensity>(
    c: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    d: &D,
    ensembles: usize,
    parallel: bool,
    steps: u64,
) {
    c.throughput(Throughput::Elements(steps * (WALKERS * ensembles) as u64));
    c.bench_function(name, |b| {
        b.iter_batched(
            || sampler(d, ensembles, parallel),
            |mut s| {
                s.run(Steps::Fixed(steps), &mut NullSink, &mut Silent)
                    .expect("run succeeds")
            },
            BatchSize::PerIteration,
        )
    });
}

fn overhead(c: &mut Criterion) {
    let mut g = c.benchmark_group("sampler");
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(4));

    g.throughput(Throughput::Elements(STEPS * WALKERS as u64));
    g.bench_function("floor", |b| {
        let mut f = Floor::<WALKERS, NDIM>::new(start(1).concat().concat(), SEED);
        b.iter(|| {
            for _ in 0..STEPS {
                f.step();
            }
        })
    });

    // Per-call cost of the density over points of the shape the sampler proposes.
    let mut f = Floor::<WALKERS, NDIM>::new(start(1).concat().concat(), SEED);
    let mut points = Vec::with_capacity(STEPS as usize * WALKERS * NDIM);
    for _ in 0..STEPS * 2 {
        f.step();
        points.extend_from_slice(f.proposals());
    }
    let mut derived = [0.0; 0];
    g.bench_function("density", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for x in black_box(&points).chunks(NDIM) {
                acc += Cheap.log_density(x, &mut derived).unwrap_or(0.0);
            }
            acc
        })
    });

    bench_run(&mut g, "run_serial", &Cheap, 1, false, STEPS);
    bench_run(&mut g, "run_parallel", &Cheap, 1, true, STEPS);
    // Twice as long: the difference is the marginal cost of a step (no one-time costs).
    bench_run(&mut g, "run_serial_long", &Cheap, 1, false, 2 * STEPS);
    bench_run(&mut g, "run_serial_4ens", &Cheap, 4, false, STEPS);
    bench_run(&mut g, "run_parallel_4ens", &Cheap, 4, true, STEPS);

    // End-of-run work (final checkpoint and report) on the state after STEPS steps.
    let mut s = sampler(&Cheap, 1, false);
    s.run(Steps::Fixed(STEPS), &mut NullSink, &mut Silent)
        .expect("run succeeds");
    let state = s.state();
    let config = s.config().clone();
    g.throughput(Throughput::Elements(STEPS * WALKERS as u64));
    g.bench_function("run_end", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let mut s = EnsembleSampler::from_state(&Cheap, config.clone(), state.clone())
                    .expect("same density");
                let t = Instant::now();
                black_box(
                    s.run(Steps::Fixed(0), &mut NullSink, &mut Silent)
                        .expect("run succeeds"),
                );
                total += t.elapsed();
            }
            total
        })
    });
    g.finish();

    let mut g = c.benchmark_group("sampler_medium");
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(5));
    g.throughput(Throughput::Elements(WALKERS as u64 * 512));
    g.bench_function("density", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for x in black_box(&points[..WALKERS * NDIM * 512]).chunks(NDIM) {
                acc += Medium.log_density(x, &mut derived).unwrap_or(0.0);
            }
            acc
        })
    });
    bench_run(&mut g, "run_serial_4ens", &Medium, 4, false, MEDIUM_STEPS);
    bench_run(&mut g, "run_parallel_4ens", &Medium, 4, true, MEDIUM_STEPS);
    g.finish();
}

criterion_group!(benches, overhead);
criterion_main!(benches);
