//! The gradient-based peer: NumPyro's NUTS on JAX (CPU, float64) fitting the same one-contact
//! posterior (`benches/peer/friction_nuts.py`), from our initial walkers, with the gradient
//! taken through the elastic solve. Its log-density is checked against ours at the emcee
//! peer's points and its medians against ours; its chains come back as CSV and go through
//! the same estimator as ours and emcee's (each NUTS chain one independent chain).
//!
//! The NUTS peer is optional: when jax, jaxlib or numpyro cannot be installed or imported,
//! or its run fails, the bench goes on and the report says why it was skipped.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::chains::{median_error, min_ess, CoordStats};
use super::peer::{
    self, median_checks, peer_err, read_peer_chains, run_script, LogDensityCheck, MedianCheck,
    PeerCommand, PeerInputs,
};
use super::throughput::{Measured, Reference};
use super::BenchError;

/// The NUTS peer's script, relative to the repository root.
pub const NUTS_SCRIPT: &str = "benches/peer/friction_nuts.py";

/// The NUTS peer's packages, at the versions it was measured with.
pub const NUTS_PACKAGES: [&str; 3] = ["jax==0.10.2", "jaxlib==0.10.2", "numpyro==0.22.0"];

/// Largest difference allowed between the NUTS peer's autodiff gradient and central
/// differences of its log-density, relative to the gradient's largest component (the
/// differences themselves are good to about 1e-6 there; a wrong derivative through the
/// elastic solve is off by far more).
pub const GRADIENT_RTOL: f64 = 1e-5;

/// The NUTS peer's gradient against central differences.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GradientCheck {
    /// Posterior draws checked.
    pub points: usize,
    /// Largest |autodiff − central difference| / max |autodiff| over them.
    pub max_error: f64,
}

impl GradientCheck {
    /// Whether the gradient agrees within [`GRADIENT_RTOL`].
    pub fn agrees(&self) -> bool {
        self.points > 0 && self.max_error <= GRADIENT_RTOL
    }
}

/// How NumPyro's NUTS is run.
#[derive(Debug, Clone, Serialize)]
pub struct NutsPlan {
    /// Warmup iterations per chain (step size and dense mass matrix adapted, then dropped).
    pub warmup: u64,
    /// Draws kept per chain.
    pub draws: u64,
    /// Target acceptance probability of the step-size adaptation.
    pub target_accept: f64,
    /// Largest tree depth (at most 2^depth leapfrog steps per draw).
    pub max_tree_depth: u32,
    /// Whether the mass matrix is dense (the posterior's coordinates are correlated up to
    /// 0.999) rather than diagonal.
    pub dense_mass: bool,
    /// Chains of each run: several chains run in parallel, one per host device.
    pub chains: Vec<usize>,
}

impl Default for NutsPlan {
    /// The full bench's sizes: NumPyro's default target acceptance (0.8) and tree depth (10),
    /// a dense mass matrix, 300 warmup iterations and 300 draws per chain (an ESS of the
    /// order of our side-by-side run's), two chains in parallel, one per core. A one-chain
    /// run would cost as much wall time again, so it is not in the default plan.
    fn default() -> Self {
        Self {
            warmup: 300,
            draws: 300,
            target_accept: 0.8,
            max_tree_depth: 10,
            dense_mass: true,
            chains: vec![2],
        }
    }
}

/// One run of NUTS with some number of chains.
#[derive(Debug, Clone, Serialize)]
pub struct NutsRun {
    /// Chains, run in parallel.
    pub chains: usize,
    /// Wall time of the warmup, compile time excluded (s).
    pub warmup_s: f64,
    /// JAX's tracing and compiling during the warmup (s).
    pub warmup_compile_s: f64,
    /// Wall time of the kept draws, compile time excluded (s).
    pub sampling_s: f64,
    /// JAX's tracing and compiling during the draws (s).
    pub sampling_compile_s: f64,
    /// Gradient evaluations (leapfrog steps) of the kept draws, all chains.
    pub gradients: u64,
    /// Divergent transitions among the kept draws.
    pub divergences: u64,
    /// Mean acceptance statistic of the kept draws.
    pub accept_prob: f64,
    /// Adapted step size of each chain.
    pub step_size: Vec<f64>,
    /// Smallest bulk ESS over coordinates (all kept draws).
    pub ess_min: f64,
    /// `ess_min / (warmup_s + sampling_s)`: a fit's cost includes its warmup, as ours
    /// includes the burn-in.
    pub ess_per_s: f64,
    /// `ess_min / sampling_s`: the kept draws alone.
    pub ess_per_s_draws: f64,
    /// Medians against ours.
    pub medians: Vec<MedianCheck>,
    /// Whether every median agrees within the MCSE factor.
    pub medians_agree: bool,
    /// Largest |median − reference median| / reference sd.
    pub error: f64,
}

/// NUTS against ours.
#[derive(Debug, Clone, Serialize)]
pub struct NutsComparison {
    /// Versions of Python, JAX, jaxlib, NumPyro, numpy.
    pub versions: serde_json::Value,
    /// Its log-density against ours.
    #[serde(flatten)]
    pub log_density: LogDensityCheck,
    /// Its gradient against central differences.
    pub gradient: GradientCheck,
    /// Settings.
    pub plan: NutsPlan,
    /// Cost of one log-density with its gradient, one point per call (µs).
    pub us_per_gradient: f64,
    /// One entry per chain count.
    pub runs: Vec<NutsRun>,
    /// Whether its ratios may be quoted (log-density, gradient and every run's medians
    /// agree).
    pub quoted: bool,
}

/// Whether the NUTS peer ran.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum NutsOutcome {
    /// It ran; its figures.
    Ran(NutsComparison),
    /// It was not run, or failed; why.
    Skipped {
        /// What went wrong (the pip or Python error).
        reason: String,
    },
}

impl From<Result<NutsComparison, BenchError>> for NutsOutcome {
    fn from(result: Result<NutsComparison, BenchError>) -> Self {
        match result {
            Ok(comparison) => Self::Ran(comparison),
            Err(e) => Self::Skipped {
                reason: e.to_string(),
            },
        }
    }
}

#[derive(Debug, Deserialize)]
struct ScriptRun {
    chains: usize,
    warmup_s: f64,
    warmup_compile_s: f64,
    sampling_s: f64,
    sampling_compile_s: f64,
    gradients: u64,
    divergences: u64,
    accept_prob: f64,
    step_size: Vec<f64>,
}

#[derive(Debug, Deserialize)]
struct ScriptResult {
    log_density: Vec<Option<f64>>,
    gradient_check: GradientCheck,
    seconds_per_gradient: f64,
    runs: Vec<ScriptRun>,
    versions: serde_json::Value,
}

const IMPORT_CHECK: &str = "import jax, jaxlib, numpyro";

/// Makes jax, jaxlib and numpyro importable by `py`: installs [`NUTS_PACKAGES`] into the
/// bench's venv, or says what the given interpreter lacks.
fn ensure_packages(command: &PeerCommand, py: &Path) -> Result<(), BenchError> {
    peer::ensure_packages(command, py, IMPORT_CHECK, &NUTS_PACKAGES)
}

/// Runs the NUTS peer and compares it with our measured run and reference.
///
/// # Errors
/// [`BenchError::Peer`] when its packages cannot be installed or imported, the script fails
/// or its output is unusable: `NutsOutcome::from` turns that into the reason it was
/// skipped.
pub fn compare(
    command: &PeerCommand,
    py: &Path,
    plan: &NutsPlan,
    inputs: &PeerInputs,
    ours: &Measured,
    reference: &Reference,
) -> Result<NutsComparison, BenchError> {
    ensure_packages(command, py)?;
    let outputs: Vec<_> = plan
        .chains
        .iter()
        .map(|c| inputs.dir.join(format!("nuts-{c}-chains.csv")))
        .collect();
    let mut problem = inputs.problem.clone();
    problem["nuts"] = serde_json::json!({
        "warmup": plan.warmup,
        "draws": plan.draws,
        "target_accept": plan.target_accept,
        "max_tree_depth": plan.max_tree_depth,
        "dense_mass": plan.dense_mass,
        "runs": plan.chains.iter().zip(&outputs)
            .map(|(c, out)| serde_json::json!({"chains": c, "out": out}))
            .collect::<Vec<_>>(),
    });
    let problem_path = inputs.write("nuts-problem.json", &problem)?;
    let result_path = inputs.dir.join("nuts-result.json");
    run_script(py, NUTS_SCRIPT, &[&problem_path, &result_path])?;
    let result: ScriptResult = serde_json::from_str(
        &std::fs::read_to_string(&result_path).map_err(BenchError::io(&result_path))?,
    )
    .map_err(|e| peer_err(format!("{}: {e}", result_path.display())))?;
    if result.runs.len() != plan.chains.len() {
        return Err(peer_err(format!(
            "{} holds {} NUTS runs, expected {}",
            result_path.display(),
            result.runs.len(),
            plan.chains.len()
        )));
    }
    let log_density = LogDensityCheck::new(&inputs.lp_ours, &result.log_density);
    let names = &inputs.names;
    let runs = result
        .runs
        .iter()
        .zip(&outputs)
        .map(|(r, out)| {
            // One "ensemble" of one walker per chain: every chain is a chain to the estimator.
            let draws = read_peer_chains(out, r.chains, 1, plan.draws as usize, names.len())?;
            let stats: Vec<CoordStats> = draws.stats(names, 0).map_err(|e| {
                peer_err(format!(
                    "diagnostics of the NUTS chains ({}): {e}",
                    out.display()
                ))
            })?;
            let (medians, medians_agree) = median_checks(&ours.stats, &stats);
            let ess_min = min_ess(&stats);
            Ok(NutsRun {
                chains: r.chains,
                warmup_s: r.warmup_s,
                warmup_compile_s: r.warmup_compile_s,
                sampling_s: r.sampling_s,
                sampling_compile_s: r.sampling_compile_s,
                gradients: r.gradients,
                divergences: r.divergences,
                accept_prob: r.accept_prob,
                step_size: r.step_size.clone(),
                ess_min,
                ess_per_s: ess_min / (r.warmup_s + r.sampling_s),
                ess_per_s_draws: ess_min / r.sampling_s,
                medians,
                medians_agree,
                error: median_error(&stats, &reference.stats),
            })
        })
        .collect::<Result<Vec<_>, BenchError>>()?;
    Ok(NutsComparison {
        versions: result.versions,
        quoted: log_density.log_density_agrees
            && result.gradient_check.agrees()
            && runs.iter().all(|r| r.medians_agree),
        log_density,
        gradient: result.gradient_check,
        plan: plan.clone(),
        us_per_gradient: result.seconds_per_gradient * 1e6,
        runs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interpreter_without_jax_is_named_with_what_to_install() {
        let py = Path::new("/bin/false");
        let err = ensure_packages(&PeerCommand::Python(py.into()), py)
            .expect_err("/bin/false imports nothing")
            .to_string();
        assert!(err.contains("/bin/false cannot `import jax"), "{err}");
        assert!(
            err.contains("jax==0.10.2 jaxlib==0.10.2 numpyro==0.22.0"),
            "{err}"
        );
    }

    #[test]
    fn a_failed_pip_install_into_the_venv_is_the_reason() {
        let py = Path::new("/bin/false");
        let err = ensure_packages(&PeerCommand::Venv("target/no-such-venv".into()), py)
            .expect_err("/bin/false installs nothing")
            .to_string();
        assert!(
            err.contains("pip install jax==0.10.2 jaxlib==0.10.2 numpyro==0.22.0 into target/no-such-venv failed"),
            "{err}"
        );
    }

    #[test]
    fn the_gradient_agrees_only_when_checked_and_within_the_tolerance() {
        let check = |points, max_error| GradientCheck { points, max_error };
        assert!(check(12, 3e-9).agrees());
        assert!(!check(12, 1e-3).agrees());
        assert!(!check(12, f64::NAN).agrees());
        assert!(!check(0, 0.0).agrees());
    }
}
