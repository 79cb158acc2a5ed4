//! The τ a stopped fit is held against: shared by `tests/posteriordb.rs` and
//! `cli/tests/stopping.rs`, which include this file by path.

use slipbayes::diagnostics::{pooled_integrated_time, DEFAULT_WINDOW_FACTOR};
use slipbayes::fit::RunDir;

/// The pooled τ_max over the sampler's coordinates of the run in `dir`, on the second half of
/// its steps: a fixed-length reference chooses its burn-in from its own τ, and an ensemble
/// still arriving after it (one of posteriordb's Lotka–Volterra did, for 70 steps) would
/// inflate τ twenty times.
pub fn reference_tau(dir: &std::path::Path) -> f64 {
    let chains = RunDir::new(dir)
        .read_chains()
        .expect("the reference's chains");
    let per_ensemble = chains.n_walkers();
    let tau = |name: &String| {
        let series = chains.series(name).expect("a coordinate");
        let walkers: Vec<&[f64]> = series.iter().flatten().map(|w| &w[w.len() / 2..]).collect();
        pooled_integrated_time(&walkers, per_ensemble, DEFAULT_WINDOW_FACTOR)
            .expect("a τ")
            .tau
    };
    chains.param_names.iter().map(tau).fold(0.0, f64::max)
}
