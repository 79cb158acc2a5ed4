//! A run's data prepared for the likelihood: loaded, validated, windowed.

use std::path::{Path, PathBuf};

use crate::data::{DataError, Series};
use crate::law::Scene;

/// Errors preparing a run's data; each names the file and says what to fix.
#[derive(Debug, thiserror::Error)]
pub enum RunDataError {
    /// The file could not be read or parsed.
    #[error(transparent)]
    Data(#[from] DataError),
    /// The data cannot be fitted as they are.
    #[error("{path}:{line}: {message}")]
    Unusable {
        /// The data file.
        path: PathBuf,
        /// 1-based line of the offending row (1 = header, for whole-file problems).
        line: usize,
        /// What is wrong and what to do.
        message: String,
    },
}

/// Fewest points a run must keep: more than the parameters one run can bring (α, a, F_d, t0,
/// k, σ).
pub const MIN_POINTS: usize = 7;

/// A run's observations, ready for the likelihood.
#[derive(Debug, Clone)]
pub struct RunData {
    /// Instrument times where the model is evaluated: the observations' times, then — for a
    /// first slide cut short by a window — the slide's last recorded time, where F_end is read.
    pub model_times: Vec<f64>,
    /// Observed forces (N), one per observation.
    pub force: Vec<f64>,
    /// Number of observations (the first `n_obs` model times).
    pub n_obs: usize,
    /// Normal force (N) per observation, when recorded.
    pub normal_force: Option<Vec<f64>>,
}

impl RunData {
    /// Loads `path`, checks it, and keeps the points inside `window` (instrument time, s).
    ///
    /// # Errors
    /// [`RunDataError`] naming the file and line: unreadable or malformed file, non-finite
    /// values, times not strictly increasing, or fewer than [`MIN_POINTS`] points.
    pub fn load(path: &Path, window: Option<[f64; 2]>, scene: Scene) -> Result<Self, RunDataError> {
        let series = Series::read_csv(path)?;
        Self::from_series(series, path, window, scene)
    }

    /// As [`RunData::load`] for a series already in memory; `path` names it in messages.
    ///
    /// # Errors
    /// As [`RunData::load`].
    pub fn from_series(
        series: Series,
        path: &Path,
        window: Option<[f64; 2]>,
        scene: Scene,
    ) -> Result<Self, RunDataError> {
        let unusable = |line: usize, message: String| RunDataError::Unusable {
            path: path.to_owned(),
            line,
            message,
        };
        let n = series.len();
        for i in 0..n {
            let line = i + 2;
            let (t, f) = (series.time_s[i], series.force_n[i]);
            if !t.is_finite() {
                return Err(unusable(
                    line,
                    format!("time_s = {t} is not finite; remove the row or fix the value"),
                ));
            }
            if !f.is_finite() {
                return Err(unusable(
                    line,
                    format!("force_N = {f} is not finite; remove the row or fix the value"),
                ));
            }
            if let Some(normal) = &series.normal_force_n {
                if !normal[i].is_finite() {
                    return Err(unusable(
                        line,
                        format!("normal_force_N = {} is not finite", normal[i]),
                    ));
                }
            }
            if i > 0 && t <= series.time_s[i - 1] {
                let what = if t < series.time_s[i - 1] {
                    "before"
                } else {
                    "equal to"
                };
                return Err(unusable(
                    line,
                    format!(
                        "time_s = {t} is {what} the previous row's {}; times must strictly increase \
                         (sort the file and remove duplicates)",
                        series.time_s[i - 1]
                    ),
                ));
            }
        }
        let end_time = series.time_s.last().copied();
        let keep: Vec<usize> = match window {
            Some([a, b]) => (0..n)
                .filter(|&i| series.time_s[i] >= a && series.time_s[i] <= b)
                .collect(),
            None => (0..n).collect(),
        };
        if keep.len() < MIN_POINTS {
            let within = window.map_or(String::new(), |[a, b]| {
                format!(" within the window [{a}, {b}] s")
            });
            return Err(unusable(
                1,
                format!(
                    "{} points{within}; a run needs at least {MIN_POINTS} to be fitted",
                    keep.len()
                ),
            ));
        }
        let mut model_times: Vec<f64> = keep.iter().map(|&i| series.time_s[i]).collect();
        let force = keep.iter().map(|&i| series.force_n[i]).collect();
        let normal_force = series
            .normal_force_n
            .as_ref()
            .map(|v| keep.iter().map(|&i| v[i]).collect());
        let n_obs = model_times.len();
        if scene == Scene::First {
            if let Some(end) = end_time {
                if end > model_times[n_obs - 1] {
                    model_times.push(end);
                }
            }
        }
        Ok(Self {
            model_times,
            force,
            n_obs,
            normal_force,
        })
    }

    fn times(&self) -> &[f64] {
        &self.model_times[..self.n_obs]
    }

    /// Mean recorded normal force (N), if recorded.
    pub fn mean_normal_force(&self) -> Option<f64> {
        self.normal_force
            .as_ref()
            .map(|v| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// Noise estimate: RMS of successive differences / √2 (insensitive to a smooth trend).
    pub fn noise_estimate(&self) -> f64 {
        let d: f64 = self.force.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum();
        (d / (2.0 * (self.force.len() - 1) as f64)).sqrt()
    }

    /// Mean force over the last tenth of the record.
    pub fn late_level(&self) -> f64 {
        let n = self.force.len();
        let tail = &self.force[n - (n / 10).max(1)..];
        tail.iter().sum::<f64>() / tail.len() as f64
    }

    /// Largest force, smoothed over a few points.
    pub fn max_force(&self) -> f64 {
        let w = (self.force.len() / 100).max(1);
        self.force
            .windows(w)
            .map(|s| s.iter().sum::<f64>() / w as f64)
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Least-squares slope (N/s) of the force over the points below half the late level:
    /// the elastic loading line.
    pub fn initial_slope(&self) -> f64 {
        let half = 0.5 * self.late_level();
        let t = self.times();
        let idx: Vec<usize> = (0..self.n_obs)
            .take_while(|&i| self.force[i] < half)
            .collect();
        let idx = if idx.len() < 3 {
            (0..self.n_obs.min(10)).collect()
        } else {
            idx
        };
        let n = idx.len() as f64;
        let mt = idx.iter().map(|&i| t[i]).sum::<f64>() / n;
        let mf = idx.iter().map(|&i| self.force[i]).sum::<f64>() / n;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for &i in &idx {
            sxy += (t[i] - mt) * (self.force[i] - mf);
            sxx += (t[i] - mt) * (t[i] - mt);
        }
        sxy / sxx
    }
}
