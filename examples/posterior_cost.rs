//! Cost of one evaluation of the demo posterior (`models/demo.toml`) at its start point, on
//! every instruction set this machine has: `cargo run --release --example posterior_cost`.
//!
//! The start point is found first (an optimisation, not timed); then `REPS` evaluations are
//! timed (`POSTERIOR_COST_REPS` sets how many, for a profiler). Reported in
//! reports/performance.md.

use std::path::Path;
use std::time::Instant;

use slipbayes::density::LogDensity;
use slipbayes::law::{Simd, SIMD_ENV};
use slipbayes::run_file::RunFile;

const REPS: usize = 300;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let spec = RunFile::load(Path::new("models/demo.toml"))?;
    let posterior = spec.posterior()?;
    let x = posterior.start().to_vec();
    let mut derived = vec![0.0; posterior.derived_names().len()];
    let started = Instant::now();
    let mut value = 0.0;
    let reps = std::env::var("POSTERIOR_COST_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(REPS);
    for _ in 0..reps {
        value = posterior.log_density(&x, &mut derived)?;
    }
    let per = started.elapsed().as_secs_f64() / reps as f64;
    println!(
        "{:.1} µs per evaluation on {} (log-density {value:.6}); set {SIMD_ENV}=baseline|avx2|avx512 to choose",
        per * 1e6,
        Simd::active().as_str()
    );
    Ok(())
}
