//! A run's data prepared for the likelihood: imported, validated, windowed.

use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::data::import::MAX_MAGNITUDE_SI;
use crate::data::{import, DataError, Imported, Provenance, Series};
use crate::law::Scene;

use super::spec::ModelSpec;

/// Errors preparing a run's data; each names the file and says what to fix.
#[derive(Debug, thiserror::Error)]
pub enum RunDataError {
    /// The file could not be read or parsed.
    #[error(transparent)]
    Data(#[from] DataError),
    /// The data file of a run of a model file could not be read or parsed.
    #[error("{}: run `{run}`: {source}", model.display())]
    Run {
        /// The model file (`<command line>` for the quick path).
        model: PathBuf,
        /// The run whose `data` it is.
        run: String,
        /// What is wrong with the file (boxed: errors travel in every `Result` of a fit).
        #[source]
        source: Box<DataError>,
    },
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

/// Widest smoothing window [`RunData::max_force`] sums point by point (records up to 6,499
/// points); wider ones slide a running sum.
const MAX_FORCE_DIRECT_WINDOW: usize = 64;

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
    /// Where the data came from and what was done to them.
    pub provenance: Provenance,
}

/// Which part of a run's data enters the likelihood.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Selection {
    /// Time window [start, end] (s of instrument time), inclusive.
    pub window_s: Option<[f64; 2]>,
}

impl RunData {
    /// Imports the data of run `run` of `spec` with its format, column mapping and interval
    /// choice, and keeps its window.
    ///
    /// # Errors
    /// [`RunDataError`] naming the file and line: unreadable or malformed file, a missing
    /// column or unknown unit, invalid points (unless dropped explicitly), times not strictly
    /// increasing, or fewer than [`MIN_POINTS`] points left.
    pub fn for_run(spec: &ModelSpec, run: usize) -> Result<Self, RunDataError> {
        let r = &spec.file.runs[run];
        let path = spec.data_path(run);
        let imported =
            import(&path, &spec.import_options(run)).map_err(|source| RunDataError::Run {
                model: spec.source.clone(),
                run: r.name.clone(),
                source: Box::new(source),
            })?;
        let selection = Selection {
            window_s: r.window_s,
        };
        Self::prepare(imported, &path, &r.name, &r.data, selection, r.scene)
    }

    /// A stand-in for run `run` of `spec` whose data another process holds (a rank of an MPI
    /// job holds only its share of the contacts): no observations, only what the model reads
    /// of them besides: their count `n_obs` (the likelihood of a sampled or integrated σ
    /// reads it) and the mean recorded normal force (the static coefficient's column), as
    /// its only value.
    pub(crate) fn held_elsewhere(
        spec: &ModelSpec,
        run: usize,
        n_obs: usize,
        mean_normal_force: Option<f64>,
    ) -> Self {
        let r = &spec.file.runs[run];
        Self {
            model_times: Vec::new(),
            force: Vec::new(),
            n_obs,
            normal_force: mean_normal_force.map(|f| vec![f]),
            provenance: Provenance {
                run: r.name.clone(),
                file: r.data.display().to_string(),
                format: String::new(),
                points_read: 0,
                points_used: n_obs,
                dropped_invalid: 0,
                window_s: r.window_s,
                binning: None,
                conversions: Vec::new(),
            },
        }
    }

    /// The data of run `run` of `spec` from a series already in memory (the run's data file
    /// is not read): the run's window applies as it would to the file.
    ///
    /// # Errors
    /// As [`RunData::from_series`].
    pub fn for_series(spec: &ModelSpec, run: usize, series: Series) -> Result<Self, RunDataError> {
        let r = &spec.file.runs[run];
        let path = spec.data_path(run);
        let mut data = Self::from_series(series, &path, r.window_s, r.scene)?;
        data.provenance.run = r.name.clone();
        Ok(data)
    }

    /// Loads a file in any format with the default mapping, all of it (the simplest case).
    ///
    /// # Errors
    /// As [`RunData::for_run`].
    pub fn load(path: &Path, window: Option<[f64; 2]>, scene: Scene) -> Result<Self, RunDataError> {
        let imported = import(path, &crate::data::ImportOptions::default())?;
        let selection = Selection { window_s: window };
        Self::prepare(imported, path, "", path, selection, scene)
    }

    /// Windows an imported file; `run` and `file` name it in the record.
    ///
    /// # Errors
    /// As [`RunData::for_run`].
    pub(crate) fn prepare(
        imported: Imported,
        path: &Path,
        run: &str,
        file: &Path,
        selection: Selection,
        scene: Scene,
    ) -> Result<Self, RunDataError> {
        let provenance = Provenance {
            run: run.to_owned(),
            file: file.display().to_string(),
            format: imported.format.name().to_owned(),
            points_read: imported.points_read,
            points_used: 0,
            dropped_invalid: imported.dropped_invalid,
            window_s: selection.window_s,
            binning: None,
            conversions: imported.conversions,
        };
        let lines = imported.lines;
        let mut data = Self::from_series(imported.series, path, selection.window_s, scene)
            .map_err(|e| match e {
                // Rows are known by their line in the original file, not by index.
                RunDataError::Unusable {
                    path,
                    line,
                    message,
                } if line >= 2 => RunDataError::Unusable {
                    path,
                    line: lines.get(line - 2).copied().unwrap_or(line),
                    message,
                },
                other => other,
            })?;
        data.provenance = provenance;
        data.provenance.points_used = data.n_obs;
        Ok(data)
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
            for (name, v) in [("time_s", t), ("force_N", f)] {
                if !v.is_finite() {
                    return Err(unusable(
                        line,
                        format!("{name} = {v} is not finite; remove the row or fix the value"),
                    ));
                }
                if v.abs() > MAX_MAGNITUDE_SI {
                    return Err(unusable(
                        line,
                        format!(
                            "{name} = {v:e} is beyond ±{MAX_MAGNITUDE_SI:e}: not a measurement \
                             (its square would overflow the likelihood); fix the value"
                        ),
                    ));
                }
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
            provenance: Provenance {
                run: String::new(),
                file: path.display().to_string(),
                format: "memory".into(),
                points_read: n,
                points_used: n_obs,
                dropped_invalid: 0,
                window_s: window,
                binning: None,
                conversions: Vec::new(),
            },
        })
    }

    /// These data without the observations in `held_out` (ranges of indices into the
    /// observations, in increasing order and disjoint), as a fit that has not seen them needs
    /// them: the model is still evaluated at the slide's last recorded time when `keeps_end`
    /// (a first slide, whose end force a repeat slide loads up to), so leaving out the end of
    /// a record does not move where the slide stopped.
    ///
    /// # Errors
    /// [`RunDataError::Unusable`] when fewer than [`MIN_POINTS`] observations would remain, or
    /// the ranges are not increasing, disjoint and within the observations.
    pub fn without(
        &self,
        held_out: &[Range<usize>],
        keeps_end: bool,
    ) -> Result<Self, RunDataError> {
        let unusable = |message: String| RunDataError::Unusable {
            path: PathBuf::from(&self.provenance.file),
            line: 1,
            message,
        };
        let mut keep = Vec::with_capacity(self.n_obs);
        let mut next = 0;
        for range in held_out {
            if range.start < next || range.start > range.end || range.end > self.n_obs {
                return Err(unusable(format!(
                    "cannot leave out observations {range:?} of {} (ranges must increase and \
                     not overlap)",
                    self.n_obs
                )));
            }
            keep.extend(next..range.start);
            next = range.end;
        }
        keep.extend(next..self.n_obs);
        let n_obs = keep.len();
        if n_obs < MIN_POINTS {
            return Err(unusable(format!(
                "{n_obs} points remain after leaving out {} of {}; a run needs at least \
                 {MIN_POINTS} to be fitted (use fewer folds)",
                self.n_obs - n_obs,
                self.n_obs
            )));
        }
        let kept = |v: &[f64]| -> Vec<f64> { keep.iter().map(|&i| v[i]).collect() };
        let mut model_times = kept(self.times());
        let end = *self.model_times.last().expect("a run has observations");
        if keeps_end && model_times.last() != Some(&end) {
            model_times.push(end);
        }
        let mut provenance = self.provenance.clone();
        provenance.points_used = n_obs;
        Ok(Self {
            model_times,
            force: kept(&self.force),
            n_obs,
            normal_force: self.normal_force.as_deref().map(kept),
            provenance,
        })
    }

    fn times(&self) -> &[f64] {
        &self.model_times[..self.n_obs]
    }

    /// Mean recorded normal force (N), if recorded.
    pub(crate) fn mean_normal_force(&self) -> Option<f64> {
        self.normal_force
            .as_ref()
            .map(|v| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// Noise estimate of one point: RMS of successive differences over √2; insensitive to a
    /// smooth trend.
    pub(crate) fn noise_estimate(&self) -> f64 {
        let d: f64 = (1..self.force.len())
            .map(|j| (self.force[j] - self.force[j - 1]).powi(2) / 2.0)
            .sum();
        (d / (self.force.len() - 1) as f64).sqrt()
    }

    /// Noise estimate of one point from second differences: RMS of y_(j+1) − 2y_j + y_(j−1)
    /// over √6. A linear trend cancels, so a steep, densely sampled rise (where successive
    /// differences see the slope) does not inflate it.
    pub(crate) fn noise_estimate_detrended(&self) -> f64 {
        let f = &self.force;
        if f.len() < 3 {
            return self.noise_estimate();
        }
        let d: f64 = f
            .windows(3)
            .map(|w| (w[2] - 2.0 * w[1] + w[0]).powi(2) / 6.0)
            .sum();
        (d / (f.len() - 2) as f64).sqrt()
    }

    /// Mean force over the last tenth of the record.
    pub(crate) fn late_level(&self) -> f64 {
        let n = self.force.len();
        let tail = &self.force[n - (n / 10).max(1)..];
        tail.iter().sum::<f64>() / tail.len() as f64
    }

    /// Largest force, smoothed over a hundredth of the record.
    pub(crate) fn max_force(&self) -> f64 {
        let w = (self.force.len() / 100).max(1);
        // Each window summed afresh costs n·w additions: nothing for a slide of a few thousand
        // points, but 10¹⁰ at 10⁶, many times the rest of the start (`reports/fit-defaults.md`).
        // Wider windows slide a running sum, whose rounding (about n ε relative) a rough
        // start does not feel.
        if w <= MAX_FORCE_DIRECT_WINDOW {
            return self
                .force
                .windows(w)
                .map(|s| s.iter().sum::<f64>() / w as f64)
                .fold(f64::NEG_INFINITY, f64::max);
        }
        let mut sum: f64 = self.force[..w].iter().sum();
        let mut max = sum;
        for (new, old) in self.force[w..].iter().zip(&self.force) {
            sum += new - old;
            max = max.max(sum);
        }
        max / w as f64
    }

    /// Least-squares slope (N/s) of the force over the points below half the late level:
    /// the elastic loading line. A stiff contact sampled coarsely reaches half the late level
    /// within one or two samples: then the points below 90 % of it (the line still, and at
    /// least two points), and only failing that the first ten points (which may include the
    /// plateau and underestimate the slope: a stiffness 2.4 times too soft in one SBC draw
    /// before the 90 % rule, and a start in the wrong basin).
    pub fn initial_slope(&self) -> f64 {
        let late = self.late_level();
        let t = self.times();
        let below = |fraction: f64| -> Vec<usize> {
            (0..self.n_obs)
                .take_while(|&i| self.force[i] < fraction * late)
                .collect()
        };
        let mut idx = below(0.5);
        if idx.len() < 3 {
            idx = below(0.9);
        }
        if idx.len() < 2 {
            idx = (0..self.n_obs.min(10)).collect();
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Leaving out blocks keeps the other observations in order and, for a first slide, the
    /// time where its record ends; too few points left or overlapping blocks are refused.
    #[test]
    fn data_without_blocks_keep_the_rest_and_the_end_of_a_first_slide() {
        let series = Series {
            time_s: (1..=20).map(f64::from).collect(),
            force_n: (1..=20).map(|i| f64::from(i) * 1e-3).collect(),
            normal_force_n: Some(vec![0.1; 20]),
        };
        let data = RunData::from_series(series, Path::new("x.csv"), None, Scene::First).unwrap();
        let fold = data.without(&[2..5, 17..20], true).unwrap();
        assert_eq!(fold.n_obs, 14);
        assert_eq!(fold.force[..3], [1e-3, 2e-3, 6e-3]);
        assert_eq!(fold.model_times[fold.n_obs - 1].to_bits(), 17f64.to_bits());
        // The record still ends at 20 s: a repeat slide loads up to the force there.
        assert_eq!(fold.model_times[fold.n_obs..], [20.0]);
        assert_eq!(fold.normal_force.as_ref().unwrap().len(), 14);
        assert_eq!(fold.provenance.points_used, 14);
        let repeat = data
            .without(std::slice::from_ref(&(17..20)), false)
            .unwrap();
        assert_eq!(repeat.model_times.len(), repeat.n_obs);
        let untouched = data.without(&[], true).unwrap();
        assert_eq!(untouched.model_times, data.model_times);
        let few = data
            .without(std::slice::from_ref(&(0..14)), true)
            .unwrap_err()
            .to_string();
        assert!(
            few.contains("6 points remain") && few.contains("fewer folds"),
            "{few}"
        );
        let overlapping = data.without(&[2..5, 4..6], true).unwrap_err().to_string();
        assert!(overlapping.contains("must increase"), "{overlapping}");
    }

    /// The running sum of a wide window gives the maximum of the windows' means as summing
    /// each window afresh does, to rounding.
    #[test]
    fn a_wide_smoothing_window_slides_a_running_sum() {
        let n = 20_000;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64).collect();
        // A peak at a fifth of the record on a plateau, with deterministic wiggles.
        let force_n: Vec<f64> = time_s
            .iter()
            .map(|&t| 1e-2 + 5e-3 * (-((t - 4e3) / 1e3).powi(2)).exp() + 1e-4 * (t * 0.7).sin())
            .collect();
        let series = Series {
            time_s,
            force_n: force_n.clone(),
            normal_force_n: None,
        };
        let data = RunData::from_series(series, Path::new("x.csv"), None, Scene::First).unwrap();
        let w = n / 100;
        assert!(w > MAX_FORCE_DIRECT_WINDOW);
        let direct = force_n
            .windows(w)
            .map(|s| s.iter().sum::<f64>() / w as f64)
            .fold(f64::NEG_INFINITY, f64::max);
        let max = data.max_force();
        assert!(
            (max - direct).abs() <= 1e-12 * direct,
            "{max} against {direct}"
        );
    }
}
