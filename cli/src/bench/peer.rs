//! The Python ensemble peers fitting the same one-contact posterior over numpy + scipy
//! (`benches/peer/friction_peer.py`, one run per [`EnsemblePeer`]): emcee's stretch move,
//! emcee's differential-evolution and snooker moves, and zeus' ensemble slice sampler, each
//! run from here with the same data, priors, initial walkers, walkers and steps. Before any
//! ratio is quoted, a peer's log-density must equal ours at many points and its medians must
//! agree with ours within 3 Monte-Carlo standard errors.
//!
//! The stretch peer is required whenever peers run; the other two are optional, like the NUTS
//! peer: when their packages cannot be installed or their run fails, the bench goes on and the
//! report says why they were skipped.

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
use slipbayes::run_file::RunFile;

/// Relative agreement required of the peer's log-density (relative to max(|ours|, 1)).
pub const LOG_DENSITY_RTOL: f64 = 1e-9;
/// Medians must agree within this many combined MCSEs.
pub const MEDIAN_MCSE_FACTOR: f64 = 3.0;
/// Points at which the log-densities are compared.
const CHECK_POINTS: usize = 240;

/// How to run the peer's Python.
#[derive(Debug, Clone)]
pub enum PeerCommand {
    /// An interpreter that already has numpy, scipy and emcee (and zeus for its peer).
    Python(PathBuf),
    /// A venv to create (if absent) with `python3 -m venv` and fill with pip.
    Venv(PathBuf),
}

/// The peer's script, relative to the repository root.
pub const PEER_SCRIPT: &str = "benches/peer/friction_peer.py";

/// An ensemble sampler of [`PEER_SCRIPT`], which runs one per call (its `--sampler` option).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EnsemblePeer {
    /// emcee's stretch move (a = 2): the peer of the headline's ESS/s ratio.
    Stretch,
    /// emcee's differential-evolution move (weight 0.8) and snooker move (0.2), as emcee's
    /// documentation advises for posteriors the stretch move mixes slowly on.
    DeSnooker,
    /// zeus' ensemble slice sampler with its default moves (differential directions, the
    /// scale tuned during the run).
    Zeus,
}

impl EnsemblePeer {
    /// The script's `--sampler` value.
    pub fn option(self) -> &'static str {
        match self {
            Self::Stretch => "stretch",
            Self::DeSnooker => "de-snooker",
            Self::Zeus => "zeus",
        }
    }

    /// Name in the report.
    pub fn label(self) -> &'static str {
        match self {
            Self::Stretch => "emcee stretch",
            Self::DeSnooker => "emcee DE + snooker",
            Self::Zeus => "zeus",
        }
    }

    /// What the report says the peer does.
    pub fn description(self) -> &'static str {
        match self {
            Self::Stretch => "emcee's stretch move (a = 2)",
            Self::DeSnooker => {
                "emcee's differential-evolution and snooker moves (`[(DEMove(), 0.8), \
                 (DESnookerMove(), 0.2)]`, as emcee's documentation advises)"
            }
            Self::Zeus => "zeus' ensemble slice sampling (its default moves and tuning)",
        }
    }

    /// The import its Python needs, and what to pip install when it fails.
    fn requires(self) -> (&'static str, &'static [&'static str]) {
        match self {
            Self::Stretch | Self::DeSnooker => ("import numpy, scipy, emcee", &PEER_PACKAGES),
            Self::Zeus => ("import numpy, scipy, zeus", &ZEUS_PACKAGES),
        }
    }
}

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

/// A peer's log-density against ours at the same points.
#[derive(Debug, Clone, Serialize)]
pub struct LogDensityCheck {
    /// Points at which both log-densities were computed.
    pub points_compared: usize,
    /// Points where one side is finite and the other not.
    pub finiteness_mismatches: usize,
    /// Largest relative difference of the log-densities.
    pub max_rel_diff: f64,
    /// Whether the log-densities agree within [`LOG_DENSITY_RTOL`].
    pub log_density_agrees: bool,
}

impl LogDensityCheck {
    /// Compares point by point; the relative difference is taken against max(|ours|, 1).
    pub fn new(ours: &[Option<f64>], peer: &[Option<f64>]) -> Self {
        let mut max_rel_diff: f64 = 0.0;
        let mut mismatches = 0;
        let mut compared = 0;
        for (a, b) in ours.iter().zip(peer) {
            match (a, b) {
                (Some(a), Some(b)) => {
                    compared += 1;
                    max_rel_diff = max_rel_diff.max((a - b).abs() / a.abs().max(1.0));
                }
                (None, None) => {}
                _ => mismatches += 1,
            }
        }
        // A peer that returned fewer values than asked is not in agreement.
        mismatches += ours.len().abs_diff(peer.len());
        Self {
            points_compared: compared,
            finiteness_mismatches: mismatches,
            max_rel_diff,
            log_density_agrees: mismatches == 0 && compared > 0 && max_rel_diff <= LOG_DENSITY_RTOL,
        }
    }
}

/// Our medians against a peer's, coordinate by coordinate, in combined MCSEs; and whether
/// all agree within [`MEDIAN_MCSE_FACTOR`].
pub fn median_checks(ours: &[CoordStats], peer: &[CoordStats]) -> (Vec<MedianCheck>, bool) {
    let checks: Vec<MedianCheck> = ours
        .iter()
        .zip(peer)
        .map(|(a, b)| MedianCheck {
            name: a.name.clone(),
            ours: a.median,
            peer: b.median,
            z: (a.median - b.median).abs() / a.mcse_median.hypot(b.mcse_median),
        })
        .collect();
    let agree = checks.len() == ours.len() && checks.iter().all(|m| m.z <= MEDIAN_MCSE_FACTOR);
    (checks, agree)
}

/// Ours against one ensemble peer.
#[derive(Debug, Clone, Serialize)]
pub struct PeerComparison {
    /// Which peer.
    pub sampler: EnsemblePeer,
    /// Versions of Python, numpy, scipy and emcee or zeus.
    pub versions: serde_json::Value,
    /// The peer's log-density against ours.
    #[serde(flatten)]
    pub log_density: LogDensityCheck,
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
    /// Our log-density evaluations (the all-threads run, as the sampler counts them).
    pub ours_evaluations: u64,
    /// The peer's: every point its sampler asked the log-density for, all ensembles.
    pub peer_evaluations: u64,
    /// Our smallest bulk ESS (same estimator, same burn-in).
    pub ours_ess_min: f64,
    /// The peer's.
    pub peer_ess_min: f64,
    /// Our ESS per 1,000 log-density evaluations.
    pub ours_ess_per_kilo_eval: f64,
    /// The peer's.
    pub peer_ess_per_kilo_eval: f64,
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

/// An optional peer's comparison, or why it was skipped.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum PeerOutcome {
    /// It ran; its figures (boxed: far larger than the reason it was skipped).
    Ran(Box<PeerComparison>),
    /// It was not run, or failed; why.
    Skipped {
        /// Which peer.
        sampler: EnsemblePeer,
        /// What went wrong (the pip or Python error).
        reason: String,
    },
}

#[derive(Debug, Deserialize)]
struct PeerResult {
    log_density: Vec<Option<f64>>,
    seconds_per_eval_single: f64,
    seconds_per_eval_vectorised: f64,
    sampling_s: Vec<f64>,
    /// Points evaluated by each ensemble's sampler.
    evaluations: Vec<u64>,
    versions: serde_json::Value,
}

/// ESS per 1,000 log-density evaluations.
pub fn ess_per_kilo_eval(ess: f64, evaluations: u64) -> f64 {
    1e3 * ess / evaluations as f64
}

pub(super) fn peer_err(message: impl Into<String>) -> BenchError {
    BenchError::Peer(message.into())
}

/// The interpreter to use, creating the venv first if needed.
///
/// # Errors
/// [`BenchError::Peer`] when the venv cannot be made or filled.
pub fn python(command: &PeerCommand) -> Result<PathBuf, BenchError> {
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
                pip_install(&py, dir, &PEER_PACKAGES)?;
            }
            Ok(py)
        }
    }
}

/// The emcee peer's packages (unpinned: it has been measured with several versions).
pub const PEER_PACKAGES: [&str; 3] = ["numpy", "scipy", "emcee"];

/// What the zeus peer adds to them (unpinned like emcee; its API has been stable across
/// releases).
pub const ZEUS_PACKAGES: [&str; 1] = ["zeus-mcmc"];

/// Whether `py` can run `import_check` (Python statements); else the end of its error.
fn imports(py: &Path, import_check: &str) -> Result<(), String> {
    match Command::new(py).args(["-c", import_check]).output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(last_lines(&o.stderr)),
        Err(e) => Err(e.to_string()),
    }
}

/// Makes `import_check` work in `py`: installs `packages` into the bench's venv, or says what
/// the given interpreter lacks.
///
/// # Errors
/// [`BenchError::Peer`] naming the packages when they cannot be installed or imported.
pub(super) fn ensure_packages(
    command: &PeerCommand,
    py: &Path,
    import_check: &str,
    packages: &[&str],
) -> Result<(), BenchError> {
    if imports(py, import_check).is_ok() {
        return Ok(());
    }
    match command {
        PeerCommand::Venv(dir) => {
            pip_install(py, dir, packages)?;
            imports(py, import_check).map_err(|e| {
                peer_err(format!(
                    "`{import_check}` fails after pip install into {}: {e}",
                    dir.display()
                ))
            })
        }
        PeerCommand::Python(_) => Err(peer_err(format!(
            "{} cannot `{import_check}` (install {} into it, or leave --python out to use the \
             bench's venv)",
            py.display(),
            packages.join(" ")
        ))),
    }
}

/// `pip install` of `packages` into the venv at `dir` whose interpreter is `py`.
pub(super) fn pip_install(py: &Path, dir: &Path, packages: &[&str]) -> Result<(), BenchError> {
    let what = || format!("pip install {} into {}", packages.join(" "), dir.display());
    let output = Command::new(py)
        .args(["-m", "pip", "install", "-q"])
        .args(packages)
        .output()
        .map_err(|e| peer_err(format!("{}: {e}", what())))?;
    if output.status.success() {
        Ok(())
    } else {
        Err(peer_err(format!(
            "{} failed ({}): {}",
            what(),
            output.status,
            last_lines(&output.stderr)
        )))
    }
}

/// The last few lines of a process's stderr, where Python puts the error.
pub(super) fn last_lines(stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(6)..].join("\n")
}

/// Runs `script` with `args` under `py` from the repository root.
pub(super) fn run_script(py: &Path, script: &str, args: &[&Path]) -> Result<(), BenchError> {
    run_script_with(py, script, args, &[])
}

/// Runs `script` with the paths `args`, then the `options`, under `py` from the repository
/// root.
fn run_script_with(
    py: &Path,
    script: &str,
    args: &[&Path],
    options: &[&str],
) -> Result<(), BenchError> {
    let output = Command::new(py)
        .arg(script)
        .args(args)
        .args(options)
        .output()
        .map_err(|e| peer_err(format!("running {} {script}: {e}", py.display())))?;
    if output.status.success() {
        Ok(())
    } else {
        Err(peer_err(format!(
            "{} {script} failed ({}): {}",
            py.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr)
        )))
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
pub(super) fn read_peer_chains(
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

/// What both peers are given: the problem file's contents and our log-density at its
/// check points.
#[derive(Debug, Clone)]
pub struct PeerInputs {
    /// The problem file's JSON: data, velocity, coordinate names, prior bounds, check points,
    /// initial walkers, steps and seed.
    pub problem: serde_json::Value,
    /// Our log-density at the problem's points (`None` where −∞ or an error).
    pub lp_ours: Vec<Option<f64>>,
    /// Our cost of one log-density (µs), one call at a time.
    pub ours_us_per_eval: f64,
    /// Coordinate names.
    pub names: Vec<String>,
    /// Scratch directory of the peers' files.
    pub dir: PathBuf,
}

impl PeerInputs {
    /// The one-contact problem of `settings`, our measured run's initial walkers and check
    /// points drawn from its chains.
    ///
    /// # Errors
    /// [`BenchError::Peer`] when the model is not the one-first-slide, log-uniform model the
    /// peers implement; [`BenchError::Input`]/[`BenchError::Io`] for its files.
    pub fn new(
        settings: &BenchSettings,
        posterior: &Posterior,
        ours: &Measured,
    ) -> Result<Self, BenchError> {
        let spec = RunFile::load(&settings.one_contact_model)
            .map_err(|e| BenchError::Input {
                what: format!("model {}", settings.one_contact_model.display()),
                message: e.to_string(),
            })?
            .model;
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
        let data = spec.data_path(0);
        let problem = serde_json::json!({
            "data_csv": std::path::absolute(&data).map_err(BenchError::io(&data))?,
            "velocity_m_per_s": spec.file.runs[0].velocity_m_per_s,
            "names": names,
            "bounds": bounds,
            "sigma_bounds": sigma,
            "points": points,
            "initial": ours.initial,
            "steps": ours.summary.steps,
            "seed": super::BENCH_SEED,
        });
        let dir = settings.scratch.join("peer");
        std::fs::create_dir_all(&dir).map_err(BenchError::io(&dir))?;
        Ok(Self {
            problem,
            lp_ours,
            ours_us_per_eval,
            names,
            dir,
        })
    }

    /// Writes `problem` (this problem, possibly extended) to `<dir>/<name>`.
    pub(super) fn write(
        &self,
        name: &str,
        problem: &serde_json::Value,
    ) -> Result<PathBuf, BenchError> {
        let path = self.dir.join(name);
        let text = serde_json::to_vec(problem).map_err(|e| peer_err(e.to_string()))?;
        write_atomically(&path, &text).map_err(BenchError::io(&path))?;
        Ok(path)
    }
}

/// Runs one ensemble peer and compares it with our measured run and reference.
///
/// # Errors
/// [`BenchError::Peer`] when the peer cannot be run or its output is unusable.
pub fn compare(
    py: &Path,
    sampler: EnsemblePeer,
    inputs: &PeerInputs,
    ours: &Measured,
    reference: &Reference,
) -> Result<PeerComparison, BenchError> {
    let t = &ours.summary;
    let problem_path = inputs.write("problem.json", &inputs.problem)?;
    let result_path = inputs.dir.join(format!("{}-result.json", sampler.option()));
    let chains_path = inputs.dir.join(format!("{}-chains.csv", sampler.option()));
    run_script_with(
        py,
        PEER_SCRIPT,
        &[&problem_path, &result_path, &chains_path],
        &["--sampler", sampler.option()],
    )?;
    let result: PeerResult = serde_json::from_str(
        &std::fs::read_to_string(&result_path).map_err(BenchError::io(&result_path))?,
    )
    .map_err(|e| peer_err(format!("{}: {e}", result_path.display())))?;
    let log_density = LogDensityCheck::new(&inputs.lp_ours, &result.log_density);

    let steps = t.steps as usize;
    let names = &inputs.names;
    let peer_draws = read_peer_chains(&chains_path, t.ensembles, t.walkers, steps, names.len())?;
    let peer_stats: Vec<CoordStats> = peer_draws
        .stats(names, t.burn_in)
        .map_err(|e| peer_err(format!("diagnostics of the peer's chains: {e}")))?;
    let (medians, medians_agree) = median_checks(&ours.stats, &peer_stats);
    let peer_sampling_s: f64 = result.sampling_s.iter().sum();
    let peer_evaluations: u64 = result.evaluations.iter().sum();
    let peer_ess_min = min_ess(&peer_stats);
    let ours_ess_min = t.runs[1].ess_min;
    let ours_evaluations = t.runs[1].evaluations;
    Ok(PeerComparison {
        sampler,
        versions: result.versions,
        quoted: log_density.log_density_agrees && medians_agree,
        log_density,
        medians,
        medians_agree,
        walkers: t.walkers,
        ensembles: t.ensembles,
        steps: t.steps,
        ours_us_per_eval: inputs.ours_us_per_eval,
        peer_us_per_eval_single: result.seconds_per_eval_single * 1e6,
        peer_us_per_eval_vectorised: result.seconds_per_eval_vectorised * 1e6,
        ours_sampling_s: [t.runs[0].sampling_s, t.runs[1].sampling_s],
        peer_sampling_s,
        ours_evaluations,
        peer_evaluations,
        ours_ess_min,
        peer_ess_min,
        ours_ess_per_kilo_eval: ess_per_kilo_eval(ours_ess_min, ours_evaluations),
        peer_ess_per_kilo_eval: ess_per_kilo_eval(peer_ess_min, peer_evaluations),
        ours_ess_per_s: [t.runs[0].ess_per_s, t.runs[1].ess_per_s],
        peer_ess_per_s: peer_ess_min / peer_sampling_s,
        ours_error: median_error(&ours.stats, &reference.stats),
        peer_error: median_error(&peer_stats, &reference.stats),
    })
}

/// Runs an optional peer (installing what it needs into the bench's venv first); a failure
/// becomes the reason it was skipped.
pub fn compare_optional(
    command: &PeerCommand,
    py: &Path,
    sampler: EnsemblePeer,
    inputs: &PeerInputs,
    ours: &Measured,
    reference: &Reference,
) -> PeerOutcome {
    let (import_check, packages) = sampler.requires();
    ensure_packages(command, py, import_check, packages)
        .and_then(|()| compare(py, sampler, inputs, ours, reference))
        .map_or_else(
            |e| PeerOutcome::Skipped {
                sampler,
                reason: e.to_string(),
            },
            |c| PeerOutcome::Ran(Box::new(c)),
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_densities_agree_only_within_the_tolerance_and_at_the_same_points() {
        let ours = [Some(-2.0e4), Some(1.0), None];
        let close = LogDensityCheck::new(&ours, &[Some(-2.0e4 * (1.0 + 1e-12)), Some(1.0), None]);
        assert!(close.log_density_agrees, "{close:?}");
        assert_eq!(close.points_compared, 2);

        let far = LogDensityCheck::new(&ours, &[Some(-2.0e4 * (1.0 + 1e-8)), Some(1.0), None]);
        assert!(!far.log_density_agrees, "{far:?}");

        let finiteness = LogDensityCheck::new(&ours, &[Some(-2.0e4), None, None]);
        assert_eq!(finiteness.finiteness_mismatches, 1);
        assert!(!finiteness.log_density_agrees);

        let short = LogDensityCheck::new(&ours, &[Some(-2.0e4)]);
        assert_eq!(short.finiteness_mismatches, 2);
        assert!(!short.log_density_agrees);
    }

    #[test]
    fn medians_agree_within_the_mcse_factor() {
        let s = |median: f64| CoordStats {
            name: "x".into(),
            median,
            sd: 1.0,
            mcse_median: 0.1,
            ess_bulk: 100.0,
        };
        // Combined MCSE 0.1·√2: 0.4 apart is 2.8 MCSE, 0.5 apart 3.5.
        let (checks, agree) = median_checks(&[s(0.0)], &[s(0.4)]);
        assert!(agree && (checks[0].z - 0.4 / 0.1f64.hypot(0.1)).abs() < 1e-12);
        assert!(!median_checks(&[s(0.0)], &[s(0.5)]).1);
        // A peer with fewer coordinates does not agree.
        assert!(!median_checks(&[s(0.0), s(0.0)], &[s(0.0)]).1);
    }
}
