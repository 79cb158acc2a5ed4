//! `slipbayes._native`: the slipbayes library seen from Python.
//!
//! A thin layer: every number comes from the `slipbayes` crate, called as the command line
//! calls it. Arrays cross the boundary as native-endian `f64` bytes (numpy's `tobytes()` and
//! `frombuffer`), so they keep their bits and nothing here depends on numpy's C API. The
//! Python package `slipbayes` (beside this crate) turns them into numpy arrays and ArviZ
//! objects.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

use slipbayes::fit::run_dir::PYTHON_RUN_OUTPUT;
use slipbayes::fit::{
    fit_model, replicate_rng, FitError, FitSettings, RunDir, RunLock, SettingOverrides,
};
use slipbayes::law::{Elastic, Law, LawParams};
use slipbayes::model::data::RunData;
use slipbayes::model::{ModelFile, ModelSpec, SpecError};
use slipbayes::output_dir::OutputDir;
use slipbayes::run_file::{RunFile, SamplerSpec};
use slipbayes::sampler::{Observer, Parallelism, Progress};
use slipbayes::simulate::{simulate as simulate_run, SimulationSpec};

create_exception!(
    _native,
    SlipbayesError,
    PyValueError,
    "An error reported by slipbayes, with the message the command line prints: the file, \
     line, column, key or parameter at fault and what to change."
);

/// How often a running fit looks for Ctrl-C and for its end.
const POLL: Duration = Duration::from_millis(20);
/// How often it hands its progress to Python after the first time, which is as soon as there
/// is progress (a short fit may sample for less than this: its callback still sees it under way).
const PROGRESS_EVERY: Duration = Duration::from_millis(200);

/// The error and its causes in one message, as the command line prints them.
fn error(e: &dyn std::error::Error) -> PyErr {
    SlipbayesError::new_err(message(e))
}

fn message(e: &dyn std::error::Error) -> String {
    let mut message = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        // Many variants already repeat their cause's text (`#[error(transparent)]`, `{source}`).
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
        source = cause.source();
    }
    message
}

fn floats(name: &str, bytes: &[u8]) -> PyResult<Vec<f64>> {
    if bytes.len() % 8 != 0 {
        return Err(SlipbayesError::new_err(format!(
            "{name}: {} bytes are not whole float64 values",
            bytes.len()
        )));
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|b| f64::from_ne_bytes(b.try_into().expect("chunks of 8 bytes")))
        .collect())
}

fn to_bytes<'py>(py: Python<'py>, values: &[f64]) -> Bound<'py, PyBytes> {
    let mut out = Vec::with_capacity(values.len() * 8);
    for v in values {
        out.extend_from_slice(&v.to_ne_bytes());
    }
    PyBytes::new(py, &out)
}

/// Equal-length parameter arrays (broadcast by the caller), read from bytes.
fn columns<const N: usize>(named: [(&str, &[u8]); N]) -> PyResult<[Vec<f64>; N]> {
    let mut out: [Vec<f64>; N] = std::array::from_fn(|_| Vec::new());
    for (slot, (name, bytes)) in out.iter_mut().zip(named) {
        *slot = floats(name, bytes)?;
    }
    let n = out[0].len();
    if let Some((i, c)) = out.iter().enumerate().find(|(_, c)| c.len() != n) {
        return Err(SlipbayesError::new_err(format!(
            "argument {i} has {} values where {n} were expected (broadcast the arrays first)",
            c.len()
        )));
    }
    Ok(out)
}

/// The law at element `i`, reusing the previous element's when its parameters are the same
/// bits (the common case: one parameter set over many τ).
fn law_at(
    cache: &mut Option<([u64; 5], Law)>,
    i: usize,
    [alpha, a, f_d, t0, v]: [f64; 5],
) -> PyResult<Law> {
    let key = [alpha, a, f_d, t0, v].map(f64::to_bits);
    if let Some((k, law)) = cache.as_ref() {
        if *k == key {
            return Ok(law.clone());
        }
    }
    let law = LawParams::new(alpha, a, f_d, t0)
        .and_then(|p| Law::new(&p, v))
        .map_err(|e| SlipbayesError::new_err(format!("element {i}: {e}")))?;
    *cache = Some((key, law.clone()));
    Ok(law)
}

/// F(τ) and dF/dτ of the law in interface time, elementwise: `Law::new` and
/// `Law::force_and_rate`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn law<'py>(
    py: Python<'py>,
    tau_s: &[u8],
    alpha_per_m: &[u8],
    a_n: &[u8],
    f_d_n: &[u8],
    t0_s: &[u8],
    velocity_m_per_s: &[u8],
) -> PyResult<(Bound<'py, PyBytes>, Bound<'py, PyBytes>)> {
    let [tau, alpha, a, f_d, t0, v] = columns([
        ("tau_s", tau_s),
        ("alpha_per_m", alpha_per_m),
        ("a_n", a_n),
        ("f_d_n", f_d_n),
        ("t0_s", t0_s),
        ("velocity_m_per_s", velocity_m_per_s),
    ])?;
    let mut force = Vec::with_capacity(tau.len());
    let mut rate = Vec::with_capacity(tau.len());
    let mut cache = None;
    for i in 0..tau.len() {
        let law = law_at(&mut cache, i, [alpha[i], a[i], f_d[i], t0[i], v[i]])?;
        let (f, r) = law.force_and_rate(tau[i]);
        force.push(f);
        rate.push(r);
    }
    Ok((to_bytes(py, &force), to_bytes(py, &rate)))
}

/// The static friction peak, elementwise: τ_peak (s), F_peak (N), s_peak (m) and t_peak (s,
/// instrument time; `k_n_per_m` NaN for a stiff slide, t_peak = τ_peak), NaN where the law has
/// no interior peak (a = 0). `Law::peak`, as the fit's derived columns compute it.
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn peak<'py>(
    py: Python<'py>,
    alpha_per_m: &[u8],
    a_n: &[u8],
    f_d_n: &[u8],
    t0_s: &[u8],
    velocity_m_per_s: &[u8],
    k_n_per_m: &[u8],
) -> PyResult<[Bound<'py, PyBytes>; 4]> {
    let [alpha, a, f_d, t0, v, k] = columns([
        ("alpha_per_m", alpha_per_m),
        ("a_n", a_n),
        ("f_d_n", f_d_n),
        ("t0_s", t0_s),
        ("velocity_m_per_s", velocity_m_per_s),
        ("k_n_per_m", k_n_per_m),
    ])?;
    let mut out: [Vec<f64>; 4] = std::array::from_fn(|_| Vec::with_capacity(alpha.len()));
    let mut cache = None;
    for i in 0..alpha.len() {
        let law = law_at(&mut cache, i, [alpha[i], a[i], f_d[i], t0[i], v[i]])?;
        let kv = if k[i].is_nan() {
            None
        } else {
            match Elastic::spring(k[i], v[i]) {
                Ok(Elastic::Spring { kv }) => Some(kv),
                Ok(Elastic::Stiff) => None,
                Err(e) => return Err(SlipbayesError::new_err(format!("element {i}: {e}"))),
            }
        };
        let values = law.peak().interior().map_or([f64::NAN; 4], |p| {
            [p.tau_s, p.force_n, p.slip_m(v[i]), p.observed_time_s(kv)]
        });
        for (o, x) in out.iter_mut().zip(values) {
            o.push(x);
        }
    }
    Ok(out.map(|o| to_bytes(py, &o)))
}

fn simulation_spec(spec_json: &str) -> PyResult<SimulationSpec> {
    serde_json::from_str(spec_json)
        .map_err(|e| SlipbayesError::new_err(format!("simulation settings: {e}")))
}

/// The noiseless force a slide records at instrument times `time_s` (increasing):
/// `SimulationSpec::clean_forces` (the elastic solve of a first slide, τ = t for a stiff fast
/// one, the loading and plateau of a repeat slide).
#[pyfunction]
fn observed_forces<'py>(
    py: Python<'py>,
    spec_json: &str,
    time_s: &[u8],
) -> PyResult<Bound<'py, PyBytes>> {
    let spec = simulation_spec(spec_json)?;
    let times = floats("time_s", time_s)?;
    let (forces, _) = py
        .allow_threads(|| spec.clean_forces(&times))
        .map_err(|e| error(&e))?;
    Ok(to_bytes(py, &forces))
}

/// A simulated run as `slipbayes simulate` writes it: times, noisy forces, noiseless forces,
/// normal forces (or None) and F_end (or None).
#[pyfunction]
#[allow(clippy::type_complexity)]
fn simulate<'py>(
    py: Python<'py>,
    spec_json: &str,
) -> PyResult<(
    Bound<'py, PyBytes>,
    Bound<'py, PyBytes>,
    Bound<'py, PyBytes>,
    Option<Bound<'py, PyBytes>>,
    Option<f64>,
)> {
    let spec = simulation_spec(spec_json)?;
    let run = py
        .allow_threads(|| simulate_run(&spec))
        .map_err(|e| error(&e))?;
    Ok((
        to_bytes(py, &run.series.time_s),
        to_bytes(py, &run.series.force_n),
        to_bytes(py, &run.clean_force_n),
        run.series
            .normal_force_n
            .as_deref()
            .map(|n| to_bytes(py, n)),
        run.f_end_n,
    ))
}

/// A run from a JSON object of the model file's structure, validated by the same code as a
/// model file. Its errors name the key path in the dict (`run[2].velocity_m_per_s`), since the
/// dict has no lines to point at. Data paths are relative to `base_dir`.
fn model_from_json(json: &str, base_dir: &Path) -> PyResult<RunFile> {
    let source = base_dir.join("<model dict>");
    let value: serde_json::Value = serde_json::from_str(json)
        .map_err(|e| SlipbayesError::new_err(format!("model dict: {e}")))?;
    let invalid = |key: String, message: String| {
        error(&SpecError::Invalid {
            path: source.clone(),
            key,
            message,
        })
    };
    // The model's tables, then the `[sampler]` table the model lets through, as a file is read.
    let sampler = match value.get("sampler") {
        None => SamplerSpec::default(),
        Some(table) => serde_path_to_error::deserialize(table.clone()).map_err(|e| {
            let key = match e.path().to_string() {
                inner if inner == "." => "sampler".to_owned(),
                inner => format!("sampler.{inner}"),
            };
            invalid(key, e.into_inner().to_string())
        })?,
    };
    let file: ModelFile = serde_path_to_error::deserialize(value)
        .map_err(|e| invalid(e.path().to_string(), e.into_inner().to_string()))?;
    RunFile::new(file, sampler, base_dir.to_path_buf(), source).map_err(|e| error(&e))
}

/// A held lock on a run directory (`RunLock`, the command line's): `fit` writes only into a
/// directory whose lock the caller holds, from before it writes the run's data files until
/// the fit ends.
#[pyclass(module = "slipbayes._native")]
struct RunDirLock {
    lock: Option<RunLock>,
}

#[pymethods]
impl RunDirLock {
    /// Locks `run_dir` (created if need be) and claims it as a run directory (one that is not
    /// new, empty or a slipbayes run is refused unless `overwrite`, as `slipbayes fit --out`);
    /// raises SlipbayesError naming the holder and the lock file when another live process
    /// holds it, or the directory and the files it would replace.
    #[new]
    #[pyo3(signature = (run_dir, overwrite=false))]
    fn new(run_dir: PathBuf, overwrite: bool) -> PyResult<Self> {
        let lock = RunLock::acquire(&run_dir).map_err(|e| error(&e))?;
        // Locked first, so that a directory another fit holds is left as it is; a refused
        // one keeps nothing of this call (the lock goes with it).
        OutputDir::claim(&run_dir, PYTHON_RUN_OUTPUT, overwrite).map_err(|e| error(&e))?;
        Ok(Self { lock: Some(lock) })
    }

    /// Releases the lock (removes the lock file); releasing twice does nothing.
    fn release(&mut self) {
        self.lock = None;
    }

    fn __enter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __exit__(
        &mut self,
        _kind: Option<PyObject>,
        _value: Option<PyObject>,
        _traceback: Option<PyObject>,
    ) -> bool {
        self.release();
        false
    }
}

/// What a running fit shares with the thread that waits for it.
#[derive(Default)]
struct Shared {
    latest: Mutex<Option<Progress>>,
    /// Notes not yet handed to Python (why the fit samples on after its summaries).
    notes: Mutex<Vec<String>>,
    stop: AtomicBool,
}

impl Shared {
    fn take_notes(&self) -> Vec<String> {
        self.notes
            .lock()
            .map(|mut n| std::mem::take(&mut *n))
            .unwrap_or_default()
    }
}

struct SharedObserver {
    shared: Arc<Shared>,
    shows: bool,
}

impl Observer for SharedObserver {
    fn on_step(&mut self, progress: &Progress) {
        if let Ok(mut latest) = self.shared.latest.lock() {
            *latest = Some(*progress);
        }
    }
    fn on_note(&mut self, note: &str) {
        if let Ok(mut notes) = self.shared.notes.lock() {
            notes.push(note.to_owned());
        }
    }
    fn stop_requested(&mut self) -> bool {
        self.shared.stop.load(Ordering::Relaxed)
    }
    fn shows_progress(&self) -> bool {
        self.shows
    }
}

/// Fits a model into the run directory that `lock` holds (as `slipbayes fit MODEL --out OUT`)
/// and returns the directory. The sampler runs on a thread pool of its own (`threads`, default: every
/// core) with the GIL released; meanwhile this thread hands the progress to `progress(step,
/// last_step, acceptance, tau_max, r_hat_max, eta_s)`, each of the fit's notes (a line saying
/// why it samples on after its summaries) to `note(text)`, and watches for Ctrl-C, which stops
/// the fit after its current step and a checkpoint (resumable with `resume=True`).
#[pyfunction]
#[pyo3(signature = (
    lock, model_path=None, model_json=None, base_dir=None, seed=None, walkers=None, steps=None,
    max_steps=None, max_time_s=None, threads=None, overwrite=false, resume=false,
    report=false, progress=None, note=None
))]
#[allow(clippy::too_many_arguments)]
fn fit(
    py: Python<'_>,
    lock: PyRef<'_, RunDirLock>,
    model_path: Option<PathBuf>,
    model_json: Option<String>,
    base_dir: Option<PathBuf>,
    seed: Option<u64>,
    walkers: Option<usize>,
    steps: Option<u64>,
    max_steps: Option<u64>,
    max_time_s: Option<f64>,
    threads: Option<usize>,
    overwrite: bool,
    resume: bool,
    report: bool,
    progress: Option<PyObject>,
    note: Option<PyObject>,
) -> PyResult<String> {
    let run = match (model_path, model_json) {
        (Some(path), None) => RunFile::load(&path).map_err(|e| error(&e))?,
        (None, Some(json)) => model_from_json(&json, &base_dir.unwrap_or_default())?,
        _ => {
            return Err(PyValueError::new_err(
                "give model_path or model_json, not both",
            ))
        }
    };
    let posterior = py
        .allow_threads(|| run.posterior())
        .map_err(|e| error(&e))?;
    let overrides = SettingOverrides {
        seed,
        walkers,
        steps,
        max_steps,
        max_time_s,
        quiet: progress.is_none(),
        overwrite,
        ..SettingOverrides::default()
    };
    let settings = FitSettings::for_model(&posterior, &run.sampler, &overrides);
    let lock = lock
        .lock
        .as_ref()
        .ok_or_else(|| PyValueError::new_err("the run directory's lock was released"))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| SlipbayesError::new_err(format!("threads = {threads:?}: {e}")))?;
    let shared = Arc::new(Shared::default());
    let mut observer = SharedObserver {
        shared: Arc::clone(&shared),
        shows: progress.is_some(),
    };
    let command = vec!["python: slipbayes.fit".to_owned()];
    let mut interrupt: Option<PyErr> = None;
    let mut last_progress: Option<std::time::Instant> = None;
    let result = std::thread::scope(|scope| -> PyResult<_> {
        let worker = scope.spawn(|| {
            pool.install(|| {
                let outcome = fit_model(
                    &run,
                    &posterior,
                    &settings,
                    lock,
                    resume,
                    command,
                    &mut observer,
                    Parallelism::default(),
                )?;
                if report {
                    slipbayes::report::write_report(&outcome.dir)
                        .map_err(|e| ReportFailed(message(&e)))?;
                }
                Ok::<_, FitOrReport>(outcome)
            })
        });
        // A note is handed on when it comes, whatever the progress's pace, and the last ones
        // once the fit has ended.
        let pass_notes = |interrupt: &mut Option<PyErr>| {
            for text in shared.take_notes() {
                if let Some(Err(e)) = note.as_ref().map(|f| f.call1(py, (text,))) {
                    shared.stop.store(true, Ordering::Relaxed);
                    interrupt.get_or_insert(e);
                }
            }
        };
        loop {
            if worker.is_finished() {
                pass_notes(&mut interrupt);
                return Ok(worker.join().expect("the fit thread does not panic"));
            }
            py.allow_threads(|| std::thread::sleep(POLL));
            pass_notes(&mut interrupt);
            if let Err(e) = py.check_signals() {
                // Ctrl-C: stop after the current step and its checkpoint; wait for that.
                shared.stop.store(true, Ordering::Relaxed);
                interrupt.get_or_insert(e);
                continue;
            }
            if last_progress.is_some_and(|t| t.elapsed() < PROGRESS_EVERY) {
                continue;
            }
            let latest = shared.latest.lock().ok().and_then(|p| *p);
            if let (Some(callback), Some(p)) = (&progress, latest) {
                last_progress = Some(std::time::Instant::now());
                if let Err(e) = callback.call1(
                    py,
                    (
                        p.step,
                        p.last_step,
                        p.acceptance,
                        p.tau_max,
                        p.r_hat_max,
                        p.eta.map(|d| d.as_secs_f64()),
                    ),
                ) {
                    shared.stop.store(true, Ordering::Relaxed);
                    interrupt.get_or_insert(e);
                }
                // A Ctrl-C during the callback stops the fit now rather than a poll later, by
                // when a short fit may have ended.
                if let Err(e) = py.check_signals() {
                    shared.stop.store(true, Ordering::Relaxed);
                    interrupt.get_or_insert(e);
                }
            }
        }
    })?;
    match result {
        // A Ctrl-C that came as the last step ended is not swallowed: the caller's script
        // stops as it would anywhere else, and the message says the fit is whole.
        Ok(outcome) => match interrupt {
            Some(e) if e.is_instance_of::<PyKeyboardInterrupt>(py) => {
                Err(PyKeyboardInterrupt::new_err(format!(
                    "interrupted as the fit ended: it finished, and its results are in {}",
                    outcome.dir.path().display()
                )))
            }
            Some(e) => Err(e),
            None => Ok(outcome.dir.path().display().to_string()),
        },
        Err(FitOrReport::Fit(FitError::Interrupted { dir, step })) => {
            let message = format!(
                "interrupted at step {step}: the chains and checkpoint in {} are written; \
                 continue with slipbayes.fit(..., out={:?}, resume=True)",
                dir.display(),
                dir.display().to_string()
            );
            match interrupt {
                Some(e) if !e.is_instance_of::<PyKeyboardInterrupt>(py) => Err(e),
                _ => Err(PyKeyboardInterrupt::new_err(message)),
            }
        }
        Err(FitOrReport::Fit(e)) => Err(error(&e)),
        Err(FitOrReport::Report(ReportFailed(message))) => Err(SlipbayesError::new_err(message)),
    }
}

/// A report that could not be written (its message).
struct ReportFailed(String);

enum FitOrReport {
    Fit(FitError),
    Report(ReportFailed),
}

impl From<FitError> for FitOrReport {
    fn from(e: FitError) -> Self {
        Self::Fit(e)
    }
}

impl From<ReportFailed> for FitOrReport {
    fn from(e: ReportFailed) -> Self {
        Self::Report(e)
    }
}

/// Values in the posterior predictive group at most (8 bytes each, 200 MB): replicating a
/// 10⁶-point record at 2,000 draws would take 16 GB.
const MAX_PREDICTIVE_VALUES: usize = 25_000_000;

/// The draws a pointwise group holds: the kept steps `steps` (indices from the first kept
/// step) of the chains `chains`, chain-major.
#[derive(Debug, Clone, PartialEq, Eq)]
struct DrawGrid {
    chains: Vec<usize>,
    steps: Vec<usize>,
}

impl DrawGrid {
    /// About `draws` draws: every n-th kept step of every chain, n the smallest that gives
    /// each chain ⌈draws / chains⌉ steps at most (one at least).
    fn every_chain(chains: usize, kept: usize, draws: usize) -> Self {
        let every = kept.div_ceil(draws.div_ceil(chains).max(1)).max(1);
        Self {
            chains: (0..chains).collect(),
            steps: (0..kept).step_by(every).collect(),
        }
    }

    /// At most `draws` draws (one at least): every chain at evenly spaced kept steps while
    /// there are draws enough for every chain, else the first kept step of every m-th chain.
    fn at_most(chains: usize, kept: usize, draws: usize) -> Self {
        let draws = draws.max(1);
        if draws >= chains {
            let per_chain = (draws / chains).min(kept);
            Self {
                chains: (0..chains).collect(),
                steps: (0..kept).step_by(kept.div_ceil(per_chain)).collect(),
            }
        } else {
            Self {
                chains: (0..chains).step_by(chains.div_ceil(draws)).collect(),
                steps: vec![0],
            }
        }
    }

    fn len(&self) -> usize {
        self.chains.len() * self.steps.len()
    }

    /// `{group}_chains` and `{group}_steps` (step numbers, burn-in included) of `out`.
    fn set_items(&self, out: &Bound<'_, PyDict>, group: &str, burn_in: u64) -> PyResult<()> {
        out.set_item(format!("{group}_chains"), self.chains.clone())?;
        let steps: Vec<u64> = self.steps.iter().map(|&s| s as u64 + burn_in).collect();
        out.set_item(format!("{group}_steps"), steps)
    }

    /// Every (chain, kept step) of the grid, chain-major.
    fn draws(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.chains
            .iter()
            .flat_map(|&c| self.steps.iter().map(move |&s| (c, s)))
    }
}

/// Per run, its values of every draw one after the other (draw-major): `values[draw][run]`
/// laid out as the InferenceData's (chain, draw, observation).
fn per_run<'py>(
    py: Python<'py>,
    spec: &ModelSpec,
    values: &[Vec<Vec<f64>>],
) -> PyResult<Bound<'py, PyList>> {
    let out = PyList::empty(py);
    for (i, run) in spec.file.runs.iter().enumerate() {
        let run_values: Vec<f64> = values.iter().flat_map(|v| v[i].iter().copied()).collect();
        out.append((run.name.clone(), to_bytes(py, &run_values)))?;
    }
    Ok(out)
}

/// Everything of a finished run directory that its InferenceData holds, as plain Python
/// values and `f64` bytes. Draws are the kept (post-burn-in) steps, laid out chain-major with
/// one chain per walker of each ensemble (`chain = ensemble * walkers + walker`), each
/// chain's steps contiguous.
///
/// With `log_likelihood_draws` (and the run's data readable), also, at about that many draws
/// (every n-th kept step of every chain, n the smallest that evaluates at most that many),
/// laid out (chain, draw, observation):
/// - every run's pointwise log-likelihood (`Posterior::pointwise_log_likelihood`), or, when a
///   run is evaluated on sufficient statistics, `log_likelihood_missing` saying so;
/// - every run's replicated observations (`Posterior::replicated_observations`, the draw at
///   row `row` of the chains from `replicate_rng(seed, row)`), at the same draws unless they
///   would hold more than `MAX_PREDICTIVE_VALUES` values, then at fewer.
#[pyfunction]
#[pyo3(signature = (run_dir, log_likelihood_draws=None))]
fn load_run<'py>(
    py: Python<'py>,
    run_dir: PathBuf,
    log_likelihood_draws: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let dir = RunDir::new(&run_dir);
    let read = |name: &str| dir.read(name).map_err(|e| error(&e));
    let summary_json = read(slipbayes::fit::run_dir::SUMMARY_JSON)?;
    let settings_json = read(slipbayes::fit::run_dir::SETTINGS_JSON)?;
    let summary = dir.read_summary().map_err(|e| error(&e))?;
    let run_file = dir.read_model().map_err(|e| error(&e))?;
    let spec = &run_file.model;
    // Checked against the summary: a run replaced while it was read is refused.
    let reader = dir.finished_chain_reader(&summary).map_err(|e| error(&e))?;
    let (ensembles, walkers, steps) = (reader.ensembles(), reader.walkers(), reader.steps());
    let burn_in = summary.sampler.burn_in;
    if burn_in >= steps {
        return Err(SlipbayesError::new_err(format!(
            "{}: burn-in {burn_in} leaves none of the {steps} steps",
            run_dir.display()
        )));
    }
    let kept = (steps - burn_in) as usize;
    let chains = ensembles * walkers;
    let storage = |e| error(&e as &dyn std::error::Error);
    // Row order on disk is (step, ensemble, walker): chain c = e * walkers + w of step s is
    // row s * chains + c, counted from the first step read.
    let chain_major = |values: &[f64], skip: usize| -> Vec<f64> {
        let mut out = vec![0.0; chains * kept];
        for c in 0..chains {
            for s in 0..kept {
                out[c * kept + s] = values[(s + skip) * chains + c];
            }
        }
        out
    };
    let columns = PyList::empty(py);
    let names = std::iter::once(slipbayes::storage::LOG_DENSITY_COLUMN.to_owned())
        .chain(reader.derived_names().iter().cloned());
    for name in names {
        let values = reader.column_from(&name, burn_in).map_err(storage)?;
        columns.append((name, to_bytes(py, &chain_major(&values, 0))))?;
    }
    // Whether each walker moved at each kept step: any sampled coordinate changed since the
    // step before (NaN at step 0, which has no step before).
    let first = burn_in.saturating_sub(1);
    let skip = (burn_in - first) as usize;
    let mut moved = vec![0.0; chains * kept];
    let mut params = Vec::with_capacity(reader.param_names().len());
    for name in reader.param_names() {
        let values = reader.column_from(name, first).map_err(storage)?;
        params.push(values);
        let values = params.last().expect("just pushed");
        for c in 0..chains {
            for s in 0..kept {
                let row = (s + skip) * chains + c;
                let changed = skip == 1 && values[row].to_bits() != values[row - chains].to_bits();
                if changed {
                    moved[c * kept + s] = 1.0;
                }
            }
        }
    }
    if skip == 0 {
        for c in 0..chains {
            moved[c * kept] = f64::NAN;
        }
    }
    let out = PyDict::new(py);
    let observed = PyList::empty(py);
    let mut observed_error = None;
    for (i, run) in spec.file.runs.iter().enumerate() {
        match RunData::for_run(spec, i) {
            Ok(data) => observed.append((
                run.name.clone(),
                to_bytes(py, &data.model_times[..data.n_obs]),
                to_bytes(py, &data.force[..data.n_obs]),
            ))?,
            Err(e) => {
                observed_error = Some(format!("run `{}`: {e}", run.name));
                break;
            }
        }
    }
    let draws = log_likelihood_draws.filter(|&d| d > 0 && observed_error.is_none());
    if let Some(draws) = draws {
        let posterior = py
            .allow_threads(|| run_file.posterior())
            .map_err(|e| error(&e))?;
        let points: usize = (0..spec.file.runs.len())
            .map(|i| posterior.observed_forces(i).len())
            .sum();
        // Sampler coordinates of (chain, kept step).
        let at = |(c, s): (usize, usize)| -> Vec<f64> {
            params.iter().map(|p| p[(s + skip) * chains + c]).collect()
        };
        let failed = |e: slipbayes::model::PointwiseError| {
            SlipbayesError::new_err(format!(
                "{}: a kept draw has no finite density: {e}",
                run_dir.display()
            ))
        };
        let log_likelihood = DrawGrid::every_chain(chains, kept, draws);
        match posterior.pointwise_available() {
            Ok(()) => {
                let grid: Vec<Vec<f64>> = log_likelihood.draws().map(at).collect();
                let terms = py.allow_threads(|| {
                    use rayon::prelude::*;
                    grid.par_iter()
                        .map(|x| posterior.pointwise_log_likelihood(x))
                        .collect::<Result<Vec<_>, _>>()
                });
                out.set_item(
                    "log_likelihood",
                    per_run(py, spec, &terms.map_err(failed)?)?,
                )?;
                log_likelihood.set_items(&out, "log_likelihood", burn_in)?;
            }
            Err(e) => out.set_item("log_likelihood_missing", e.to_string())?,
        }
        let predictive = if log_likelihood.len() * points <= MAX_PREDICTIVE_VALUES {
            log_likelihood
        } else {
            DrawGrid::at_most(chains, kept, MAX_PREDICTIVE_VALUES / points.max(1))
        };
        let seed = summary.sampler.seed;
        let grid: Vec<(u64, Vec<f64>)> = predictive
            .draws()
            .map(|(c, s)| {
                (
                    ((s as u64 + burn_in) * chains as u64 + c as u64),
                    at((c, s)),
                )
            })
            .collect();
        let replicates = py.allow_threads(|| {
            use rayon::prelude::*;
            grid.par_iter()
                .map(|(row, x)| {
                    posterior.replicated_observations(x, &mut replicate_rng(seed, *row))
                })
                .collect::<Result<Vec<_>, _>>()
        });
        out.set_item(
            "posterior_predictive",
            per_run(py, spec, &replicates.map_err(failed)?)?,
        )?;
        predictive.set_items(&out, "posterior_predictive", burn_in)?;
    }
    out.set_item("summary_json", summary_json)?;
    out.set_item("settings_json", settings_json)?;
    out.set_item("ensembles", ensembles)?;
    out.set_item("walkers", walkers)?;
    out.set_item("steps", steps)?;
    out.set_item("burn_in", burn_in)?;
    out.set_item("columns", columns)?;
    out.set_item("moved", to_bytes(py, &moved))?;
    out.set_item(
        "materials",
        spec.file
            .materials
            .iter()
            .map(|m| m.name.clone())
            .collect::<Vec<_>>(),
    )?;
    out.set_item(
        "contacts",
        spec.file
            .contacts
            .iter()
            .map(|c| (c.name.clone(), c.material.clone()))
            .collect::<Vec<_>>(),
    )?;
    out.set_item(
        "runs",
        spec.file
            .runs
            .iter()
            .map(|r| (r.name.clone(), r.contact.clone(), r.scene.to_string()))
            .collect::<Vec<_>>(),
    )?;
    if observed_error.is_none() {
        out.set_item("observed", observed)?;
    }
    out.set_item("observed_error", observed_error)?;
    Ok(out)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SlipbayesError", m.py().get_type::<SlipbayesError>())?;
    m.add_function(wrap_pyfunction!(law, m)?)?;
    m.add_function(wrap_pyfunction!(peak, m)?)?;
    m.add_function(wrap_pyfunction!(observed_forces, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_class::<RunDirLock>()?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(load_run, m)?)?;
    Ok(())
}
