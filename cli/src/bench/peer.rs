//! The Python peer: emcee + numpy + scipy fitting the same one-contact posterior
//! (`benches/peer/friction_peer.py`), run from here with the same data, priors, initial
//! walkers, walkers and steps. Before any ratio is quoted, its log-density must equal ours at
//! many points and its medians must agree with ours within 3 Monte-Carlo standard errors.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::chains::{median_error, min_ess, CoordStats, Draws};
use super::throughput::{Measured, Reference};
use super::{BenchError, BenchSettings};
use slipbayes::data::write_atomically;
use slipbayes::density::LogDensity;
use slipbayes::model::prior::Prior;
use slipbayes::model::{ModelSpec, Posterior};

/// Relative agreement required of the peer's log-density (relative to max(|ours|, 1)).
pub const LOG_DENSITY_RTOL: f64 = 1e-9;
/// Medians must agree within this many combined MCSEs.
pub const MEDIAN_MCSE_FACTOR: f64 = 3.0;
/// Points at which the log-densities are compared.
const CHECK_POINTS: usize = 240;

/// How to run the peer's Python.
#[derive(Debug, Clone)]
pub enum PeerCommand {
    /// An interpreter that already has numpy, scipy and emcee.
    Python(PathBuf),
    /// A venv to create (if absent) with `python3 -m venv` and fill with pip.
    Venv(PathBuf),
}

/// The peer's script, relative to the repository root.
pub const PEER_SCRIPT: &str = "benches/peer/friction_peer.py";

/// Agreement of one coordinate's median.
#[derive(Debug, Clone, Serialize)]
pub struct MedianCheck {
    /// Coordinate.
    pub name: String,
    /// Our median.
    pub ours: f64,
    /// The peer's median.
    pub peer: f64,
    /// |difference| / sqrt(MCSE_ours² + MCSE_peer²).
    pub z: f64,
}

/// Ours against the peer.
#[derive(Debug, Clone, Serialize)]
pub struct PeerComparison {
    /// Versions of Python, numpy, scipy, emcee.
    pub versions: serde_json::Value,
    /// Points at which both log-densities were computed.
    pub points_compared: usize,
    /// Points where one side is finite and the other not.
    pub finiteness_mismatches: usize,
    /// Largest relative difference of the log-densities.
    pub max_rel_diff: f64,
    /// Whether the log-densities agree within [`LOG_DENSITY_RTOL`].
    pub log_density_agrees: bool,
    /// Median checks per coordinate.
    pub medians: Vec<MedianCheck>,
    /// Whether every median agrees within [`MEDIAN_MCSE_FACTOR`] MCSE.
    pub medians_agree: bool,
    /// Walkers per ensemble, ensembles, steps (the same on both sides).
    pub walkers: usize,
    /// Ensembles.
    pub ensembles: usize,
    /// Steps.
    pub steps: u64,
    /// Our cost of one log-density (µs), one call at a time.
    pub ours_us_per_eval: f64,
    /// The peer's, one point per call.
    pub peer_us_per_eval_single: f64,
    /// The peer's, half an ensemble per vectorised call (what its sampler does).
    pub peer_us_per_eval_vectorised: f64,
    /// Our sampling time on one thread and on all (s).
    pub ours_sampling_s: [f64; 2],
    /// The peer's sampling time (s, all ensembles).
    pub peer_sampling_s: f64,
    /// Our smallest bulk ESS (same estimator, same burn-in).
    pub ours_ess_min: f64,
    /// The peer's.
    pub peer_ess_min: f64,
    /// Our ESS/s on one thread and on all.
    pub ours_ess_per_s: [f64; 2],
    /// The peer's ESS/s.
    pub peer_ess_per_s: f64,
    /// Largest |median − reference median| / reference sd over coordinates, ours (all
    /// threads, at `ours_sampling_s[1]`).
    pub ours_error: f64,
    /// The peer's (at `peer_sampling_s`).
    pub peer_error: f64,
    /// Whether the ratios may be quoted (both checks passed).
    pub quoted: bool,
}

#[derive(Debug, Deserialize)]
struct PeerResult {
    log_density: Vec<Option<f64>>,
    seconds_per_eval_single: f64,
    seconds_per_eval_vectorised: f64,
    sampling_s: Vec<f64>,
    versions: serde_json::Value,
}

fn peer_err(message: impl Into<String>) -> BenchError {
    BenchError::Peer(message.into())
}

/// The interpreter to use, creating the venv first if needed.
fn python(command: &PeerCommand) -> Result<PathBuf, BenchError> {
    match command {
        PeerCommand::Python(p) => Ok(p.clone()),
        PeerCommand::Venv(dir) => {
            let py = dir.join("bin").join("python");
            if !py.exists() {
                let status = Command::new("python3")
                    .args(["-m", "venv"])
                    .arg(dir)
                    .status()
                    .map_err(|e| peer_err(format!("python3 -m venv {}: {e}", dir.display())))?;
                if !status.success() {
                    return Err(peer_err(format!(
                        "python3 -m venv {} failed ({status}); pass --python with an interpreter that has numpy, scipy and emcee",
                        dir.display()
                    )));
                }
                let status = Command::new(&py)
                    .args(["-m", "pip", "install", "-q", "numpy", "scipy", "emcee"])
                    .status()
                    .map_err(|e| peer_err(format!("pip install into {}: {e}", dir.display())))?;
                if !status.success() {
                    return Err(peer_err(format!(
                        "pip install numpy scipy emcee into {} failed ({status})",
                        dir.display()
                    )));
                }
            }
            Ok(py)
        }
    }
}

/// Prior bounds of every coordinate, which must all be log-uniform (the peer's prior).
fn log_uniform_bounds(spec: &ModelSpec, names: &[String]) -> Result<Vec<[f64; 2]>, BenchError> {
    names
        .iter()
        .map(|n| {
            let name = n
                .strip_prefix("ln_")
                .and_then(|s| s.split('[').next())
                .ok_or_else(|| peer_err(format!("coordinate {n} is not a log-parameter")))?;
            match spec.prior(name) {
                Prior::LogUniform { low, high } => Ok([low, high]),
                other => Err(peer_err(format!(
                    "the peer implements log-uniform priors only; {name} has {other:?}"
                ))),
            }
        })
        .collect()
}

/// Reads the peer's chains (`ensemble,walker,step,coords...`).
fn read_peer_chains(
    path: &Path,
    ensembles: usize,
    walkers: usize,
    steps: usize,
    ndim: usize,
) -> Result<Draws, BenchError> {
    let text = std::fs::read_to_string(path).map_err(BenchError::io(path))?;
    let mut buffers = vec![vec![f64::NAN; steps * walkers * ndim]; ensembles];
    let mut rows = 0;
    for (line_no, line) in text.lines().enumerate().skip(1) {
        let bad = || peer_err(format!("{}:{}: malformed row", path.display(), line_no + 1));
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 3 + ndim {
            return Err(bad());
        }
        let idx = |i: usize| fields[i].parse::<usize>().map_err(|_| bad());
        let (e, w, s) = (idx(0)?, idx(1)?, idx(2)?);
        if e >= ensembles || w >= walkers || s >= steps {
            return Err(bad());
        }
        for d in 0..ndim {
            buffers[e][(s * walkers + w) * ndim + d] =
                fields[3 + d].parse::<f64>().map_err(|_| bad())?;
        }
        rows += 1;
    }
    if rows != ensembles * walkers * steps {
        return Err(peer_err(format!(
            "{} holds {rows} rows, expected {}",
            path.display(),
            ensembles * walkers * steps
        )));
    }
    Ok(Draws {
        ensembles: buffers,
        walkers,
        steps,
        ndim,
    })
}

/// Points at which both log-densities are compared: draws spread over our chains, and the
/// same draws pushed out by up to ±5 posterior sd (tails, where rounding matters most).
fn check_points(ours: &Measured) -> Vec<Vec<f64>> {
    let d = &ours.draws;
    let half = CHECK_POINTS / 2;
    let mut points = Vec::with_capacity(CHECK_POINTS);
    for i in 0..half {
        let e = i % d.ensembles.len();
        let w = (i * 7) % d.walkers;
        let s = d.steps / 4 + (i * (d.steps - d.steps / 4)) / half;
        points.push(d.draw(e, s.min(d.steps - 1), w).to_vec());
    }
    for i in 0..half {
        let mut x = points[i].clone();
        for (j, v) in x.iter_mut().enumerate() {
            // A fixed pattern in [−5, 5] sd, different per coordinate.
            let u = (((i * 31 + j * 17) % 101) as f64 / 50.0) - 1.0;
            *v += 5.0 * u * ours.stats[j].sd;
        }
        points.push(x);
    }
    points
}

/// Runs the peer and compares it with our measured run and reference.
///
/// # Errors
/// [`BenchError::Peer`] when the peer cannot be run or its output is unusable.
pub fn compare(
    command: &PeerCommand,
    settings: &BenchSettings,
    posterior: &Posterior,
    ours: &Measured,
    reference: &Reference,
) -> Result<PeerComparison, BenchError> {
    let spec = ModelSpec::load(&settings.one_contact_model).map_err(|e| BenchError::Input {
        what: format!("model {}", settings.one_contact_model.display()),
        message: e.to_string(),
    })?;
    if spec.file.runs.len() != 1 {
        return Err(peer_err(
            "the peer fits a model with exactly one first slide",
        ));
    }
    let names = posterior.param_names();
    let bounds = log_uniform_bounds(&spec, &names)?;
    let sigma = match spec.prior("sigma") {
        Prior::LogUniform { low, high } => [low, high],
        other => {
            return Err(peer_err(format!(
                "σ must have a log-uniform prior, has {other:?}"
            )))
        }
    };
    let points = check_points(ours);
    let mut none = [0.0; 0];
    let clock = Instant::now();
    let lp_ours: Vec<Option<f64>> = points
        .iter()
        .map(|x| posterior.log_density(x, &mut none).ok())
        .collect();
    let ours_us_per_eval = clock.elapsed().as_secs_f64() * 1e6 / points.len() as f64;

    let t = &ours.summary;
    let dir = settings.scratch.join("peer");
    std::fs::create_dir_all(&dir).map_err(BenchError::io(&dir))?;
    let problem = serde_json::json!({
        "data_csv": std::path::absolute(spec.data_path(0)).map_err(BenchError::io(&spec.data_path(0)))?,
        "velocity_m_per_s": spec.file.runs[0].velocity_m_per_s,
        "names": names,
        "bounds": bounds,
        "sigma_bounds": sigma,
        "points": points,
        "initial": ours.initial,
        "steps": t.steps,
        "seed": super::BENCH_SEED,
    });
    let problem_path = dir.join("problem.json");
    let result_path = dir.join("result.json");
    let chains_path = dir.join("chains.csv");
    let text = serde_json::to_vec(&problem).map_err(|e| peer_err(e.to_string()))?;
    write_atomically(&problem_path, &text).map_err(BenchError::io(&problem_path))?;
    let py = python(command)?;
    let output = Command::new(&py)
        .arg(PEER_SCRIPT)
        .args([&problem_path, &result_path, &chains_path])
        .output()
        .map_err(|e| peer_err(format!("running {} {PEER_SCRIPT}: {e}", py.display())))?;
    if !output.status.success() {
        return Err(peer_err(format!(
            "{} {PEER_SCRIPT} failed ({}): {}",
            py.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr)
        )));
    }
    let result: PeerResult = serde_json::from_str(
        &std::fs::read_to_string(&result_path).map_err(BenchError::io(&result_path))?,
    )
    .map_err(|e| peer_err(format!("{}: {e}", result_path.display())))?;

    let mut max_rel_diff: f64 = 0.0;
    let mut mismatches = 0;
    let mut compared = 0;
    for (a, b) in lp_ours.iter().zip(&result.log_density) {
        match (a, b) {
            (Some(a), Some(b)) => {
                compared += 1;
                max_rel_diff = max_rel_diff.max((a - b).abs() / a.abs().max(1.0));
            }
            (None, None) => {}
            _ => mismatches += 1,
        }
    }
    let log_density_agrees = mismatches == 0 && compared > 0 && max_rel_diff <= LOG_DENSITY_RTOL;

    let steps = t.steps as usize;
    let peer_draws = read_peer_chains(&chains_path, t.ensembles, t.walkers, steps, names.len())?;
    let peer_stats: Vec<CoordStats> = peer_draws
        .stats(&names, t.burn_in)
        .map_err(|e| peer_err(format!("diagnostics of the peer's chains: {e}")))?;
    let medians: Vec<MedianCheck> = ours
        .stats
        .iter()
        .zip(&peer_stats)
        .map(|(a, b)| MedianCheck {
            name: a.name.clone(),
            ours: a.median,
            peer: b.median,
            z: (a.median - b.median).abs() / a.mcse_median.hypot(b.mcse_median),
        })
        .collect();
    let medians_agree = medians.iter().all(|m| m.z <= MEDIAN_MCSE_FACTOR);
    let peer_sampling_s: f64 = result.sampling_s.iter().sum();
    let peer_ess_min = min_ess(&peer_stats);
    let ours_ess_min = t.runs[1].ess_min;
    Ok(PeerComparison {
        versions: result.versions,
        points_compared: compared,
        finiteness_mismatches: mismatches,
        max_rel_diff,
        log_density_agrees,
        medians,
        medians_agree,
        walkers: t.walkers,
        ensembles: t.ensembles,
        steps: t.steps,
        ours_us_per_eval,
        peer_us_per_eval_single: result.seconds_per_eval_single * 1e6,
        peer_us_per_eval_vectorised: result.seconds_per_eval_vectorised * 1e6,
        ours_sampling_s: [t.runs[0].sampling_s, t.runs[1].sampling_s],
        peer_sampling_s,
        ours_ess_min,
        peer_ess_min,
        ours_ess_per_s: [t.runs[0].ess_per_s, t.runs[1].ess_per_s],
        peer_ess_per_s: peer_ess_min / peer_sampling_s,
        ours_error: median_error(&ours.stats, &reference.stats),
        peer_error: median_error(&peer_stats, &reference.stats),
        quoted: log_density_agrees && medians_agree,
    })
}
