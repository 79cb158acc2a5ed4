//! A quantity's draws as the summary reads them: [`EnsembleDraws`] in memory, or
//! [`WalkerDraws`] written once by a [`DrawsWriter`] into a [`Workspace`] and read back one
//! walker (or one half-walker) at a time.

use super::sort::{RunWriter, Runs};
use super::store::{Store, Workspace};
use crate::diagnostics::arviz::{Autocov, EssRows, SeqSum, MIN_DRAWS};
use crate::diagnostics::DiagnosticsError;

/// Draws of one scalar quantity from independent ensembles of walkers: `ensembles x walkers x
/// steps`, stored walker-major (`[e][w][t]`, each walker's series contiguous). Validated on
/// construction: rectangular, at least [`MIN_DRAWS`] steps, all finite.
#[derive(Debug, Clone)]
pub struct EnsembleDraws {
    data: Vec<f64>,
    ensembles: usize,
    walkers: usize,
    steps: usize,
}

impl EnsembleDraws {
    /// Wraps `data` laid out as `data[(e * walkers + w) * steps + t]`.
    ///
    /// # Errors
    /// No ensembles or walkers, `data.len()` not equal to the product of the shape, fewer
    /// than [`MIN_DRAWS`] steps, or a non-finite draw (reported as chain `e * walkers + w`
    /// at index `t`).
    pub fn new(
        data: Vec<f64>,
        ensembles: usize,
        walkers: usize,
        steps: usize,
    ) -> Result<Self, DiagnosticsError> {
        if ensembles == 0 || walkers == 0 {
            return Err(DiagnosticsError::NoChains { needed: 1 });
        }
        let expected = ensembles * walkers * steps;
        if data.len() != expected {
            return Err(DiagnosticsError::InvalidArgument {
                name: "data.len()",
                value: data.len() as f64,
                reason: "must equal ensembles * walkers * steps",
            });
        }
        if steps < MIN_DRAWS {
            return Err(DiagnosticsError::TooFewDraws {
                what: "ensemble diagnostics",
                have: steps,
                needed: MIN_DRAWS,
            });
        }
        if let Some((i, &v)) = data.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(DiagnosticsError::NonFinite {
                chain: i / steps,
                index: i % steps,
                value: v,
            });
        }
        Ok(EnsembleDraws {
            data,
            ensembles,
            walkers,
            steps,
        })
    }

    /// Builds the draws from `f(ensemble, walker, step)`, e.g. reading one parameter out of
    /// the sampler's step-major storage.
    ///
    /// # Errors
    /// As [`EnsembleDraws::new`].
    pub fn from_fn(
        ensembles: usize,
        walkers: usize,
        steps: usize,
        mut f: impl FnMut(usize, usize, usize) -> f64,
    ) -> Result<Self, DiagnosticsError> {
        let mut data = Vec::with_capacity(ensembles * walkers * steps);
        for e in 0..ensembles {
            for w in 0..walkers {
                for t in 0..steps {
                    data.push(f(e, w, t));
                }
            }
        }
        Self::new(data, ensembles, walkers, steps)
    }

    /// Builds the draws from `draws[e][w][t]`.
    ///
    /// # Errors
    /// As [`EnsembleDraws::new`], and ragged input (reported as chain `e * walkers + w`).
    pub fn from_nested(draws: &[Vec<Vec<f64>>]) -> Result<Self, DiagnosticsError> {
        let ensembles = draws.len();
        let walkers = draws.first().map_or(0, Vec::len);
        let steps = draws.first().and_then(|e| e.first()).map_or(0, Vec::len);
        for (e, ens) in draws.iter().enumerate() {
            if ens.len() != walkers {
                return Err(DiagnosticsError::InvalidArgument {
                    name: "walkers in an ensemble",
                    value: ens.len() as f64,
                    reason: "every ensemble must have as many walkers as ensemble 0",
                });
            }
            for (w, series) in ens.iter().enumerate() {
                if series.len() != steps {
                    return Err(DiagnosticsError::RaggedChains {
                        chain: e * walkers + w,
                        len: series.len(),
                        expected: steps,
                    });
                }
            }
        }
        let data = draws.iter().flatten().flatten().copied().collect();
        Self::new(data, ensembles, walkers, steps)
    }

    /// Number of independent ensembles.
    pub fn ensembles(&self) -> usize {
        self.ensembles
    }

    /// Walkers per ensemble.
    pub fn walkers(&self) -> usize {
        self.walkers
    }

    /// Steps per walker.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Walker `w` of ensemble `e`, over steps. Panics if out of range (a programming error).
    pub fn series(&self, e: usize, w: usize) -> &[f64] {
        assert!(
            e < self.ensembles && w < self.walkers,
            "walker out of range"
        );
        let start = (e * self.walkers + w) * self.steps;
        &self.data[start..start + self.steps]
    }

    /// The draws as the summary engine reads them, in `ws` (in memory, whatever their number,
    /// when `ws` is [`Workspace::in_memory`]).
    pub(super) fn to_walker_draws<'w>(
        &self,
        ws: &'w Workspace,
    ) -> Result<WalkerDraws<'w>, DiagnosticsError> {
        let mut store = ws.store(ws.spills(self.data.len()))?;
        store.write_f64(0, &self.data, &mut Vec::new())?;
        Ok(WalkerDraws {
            store,
            ensembles: self.ensembles,
            walkers: self.walkers,
            steps: self.steps,
        })
    }
}

/// Draws of one quantity from `ensembles × walkers` walkers of `steps` steps each, walker
/// by walker (`[e][w][t]`), as [`EnsembleDraws`] lays them out, kept in
/// a [`Workspace`]. Written by a [`DrawsWriter`].
#[derive(Debug)]
pub struct WalkerDraws<'w> {
    pub(super) store: Store<'w>,
    pub(super) ensembles: usize,
    pub(super) walkers: usize,
    pub(super) steps: usize,
}

/// Writes the draws of one quantity, in the order the chains hold them (step, then
/// ensemble, then walker), into [`WalkerDraws`].
#[derive(Debug)]
pub struct DrawsWriter<'w> {
    draws: WalkerDraws<'w>,
    written: usize,
    /// The first non-finite draw in walker order: (index, value).
    first_bad: Option<(usize, f64)>,
    per_walker: Vec<Vec<f64>>,
    bytes: Vec<u8>,
}

impl<'w> DrawsWriter<'w> {
    /// A writer of `ensembles × walkers × steps` draws in `ws`.
    ///
    /// # Errors
    /// No ensembles or walkers, fewer than [`MIN_DRAWS`] steps, 2³² draws or more; a working
    /// file that cannot be created.
    pub fn new(
        ws: &'w Workspace,
        ensembles: usize,
        walkers: usize,
        steps: usize,
    ) -> Result<Self, DiagnosticsError> {
        if ensembles == 0 || walkers == 0 {
            return Err(DiagnosticsError::NoChains { needed: 1 });
        }
        if steps < MIN_DRAWS {
            return Err(DiagnosticsError::TooFewDraws {
                what: "ensemble diagnostics",
                have: steps,
                needed: MIN_DRAWS,
            });
        }
        let n = ensembles * walkers * steps;
        if u32::try_from(n).is_err() {
            return Err(DiagnosticsError::InvalidArgument {
                name: "draws",
                value: n as f64,
                reason: "a summary takes fewer than 2^32 draws of a quantity",
            });
        }
        Ok(Self {
            draws: WalkerDraws {
                store: ws.store(ws.spills(n))?,
                ensembles,
                walkers,
                steps,
            },
            written: 0,
            first_bad: None,
            per_walker: vec![Vec::new(); ensembles * walkers],
            bytes: Vec::new(),
        })
    }

    /// Appends the next draws in the chains' order (step, then ensemble, then walker),
    /// continuing where the last call stopped.
    ///
    /// # Errors
    /// More draws than the shape holds; a working file that cannot be written.
    pub fn push(&mut self, values: &[f64]) -> Result<(), DiagnosticsError> {
        let d = &mut self.draws;
        let chains = d.ensembles * d.walkers;
        let n = chains * d.steps;
        if self.written + values.len() > n {
            return Err(DiagnosticsError::InvalidArgument {
                name: "draws written",
                value: (self.written + values.len()) as f64,
                reason: "must not exceed ensembles * walkers * steps",
            });
        }
        let first_step = self.written / chains;
        let mut starts = vec![usize::MAX; chains];
        for (k, &v) in values.iter().enumerate() {
            let row = self.written + k;
            let (t, c) = (row / chains, row % chains);
            if starts[c] == usize::MAX {
                starts[c] = t;
            }
            self.per_walker[c].push(v);
            if !v.is_finite() {
                let at = c * d.steps + t;
                if self.first_bad.is_none_or(|(i, _)| at < i) {
                    self.first_bad = Some((at, v));
                }
            }
        }
        debug_assert!(starts.iter().all(|&s| s == usize::MAX || s >= first_step));
        for (c, series) in self.per_walker.iter_mut().enumerate() {
            if !series.is_empty() {
                d.store
                    .write_f64(c * d.steps + starts[c], series, &mut self.bytes)?;
                series.clear();
            }
        }
        self.written += values.len();
        Ok(())
    }

    /// The draws written.
    ///
    /// # Errors
    /// Fewer draws than the shape holds; a non-finite draw (reported as chain
    /// `e * walkers + w` at index `t`, as [`EnsembleDraws::new`] does).
    pub fn finish(self) -> Result<WalkerDraws<'w>, DiagnosticsError> {
        let d = self.draws;
        let n = d.ensembles * d.walkers * d.steps;
        if self.written != n {
            return Err(DiagnosticsError::InvalidArgument {
                name: "draws written",
                value: self.written as f64,
                reason: "must equal ensembles * walkers * steps",
            });
        }
        if let Some((i, value)) = self.first_bad {
            return Err(DiagnosticsError::NonFinite {
                chain: i / d.steps,
                index: i % d.steps,
                value,
            });
        }
        Ok(d)
    }
}

impl<'w> WalkerDraws<'w> {
    pub(super) fn ws(&self) -> &'w Workspace {
        self.store.ws
    }

    pub(super) fn chains(&self) -> usize {
        self.ensembles * self.walkers
    }

    pub(super) fn len(&self) -> usize {
        self.chains() * self.steps
    }

    /// Walker `c` (`e * walkers + w`) from step `t` on, `out.len()` steps.
    fn read(
        &self,
        c: usize,
        t: usize,
        out: &mut [f64],
        bytes: &mut Vec<u8>,
    ) -> Result<(), DiagnosticsError> {
        self.store.read_f64(c * self.steps + t, out, bytes)
    }

    /// Calls `f(c, series)` for every walker in order.
    pub(super) fn each_walker(
        &self,
        mut f: impl FnMut(usize, &[f64]) -> Result<(), DiagnosticsError>,
    ) -> Result<(), DiagnosticsError> {
        let mut series = vec![0.0; self.steps];
        let mut bytes = Vec::new();
        for c in 0..self.chains() {
            self.read(c, 0, &mut series, &mut bytes)?;
            f(c, &series)?;
        }
        Ok(())
    }

    /// Calls `f(segment)` for every row of the split chains in ArviZ's order: the first
    /// `steps/2` steps of every walker, then the last `steps/2` of every walker.
    pub(super) fn each_half(&self, mut f: impl FnMut(&[f64])) -> Result<(), DiagnosticsError> {
        let half = self.steps / 2;
        let mut segment = vec![0.0; half];
        let mut bytes = Vec::new();
        for first in [0, self.steps - half] {
            for c in 0..self.chains() {
                self.read(c, first, &mut segment, &mut bytes)?;
                f(&segment);
            }
        }
        Ok(())
    }

    /// Whether draw `i` (walker-major) is in the split chains (the middle step of an odd
    /// number of steps is not).
    pub(super) fn in_split(&self, i: u32) -> bool {
        self.steps % 2 == 0 || i as usize % self.steps != self.steps / 2
    }

    /// The mean of the draws and the Monte-Carlo standard error of the mean (ArviZ
    /// `mcse(method="mean")` with every walker as a chain), as
    /// [`mean`](crate::diagnostics::arviz) and [`mcse_mean`](crate::diagnostics::mcse_mean) give them on the same
    /// draws.
    ///
    /// # Errors
    /// A working file that cannot be read.
    pub fn mean_and_mcse(&self) -> Result<(f64, f64), DiagnosticsError> {
        let moments = self.moments()?;
        let mut ess = EssRows::new(self.steps / 2);
        let mut autocov = Autocov::new(self.steps / 2);
        self.each_half(|segment| ess.push(segment, &mut autocov))?;
        Ok((moments.mean, moments.var.sqrt() / ess.finish().sqrt()))
    }

    /// The mean and the sums of squares about it, in walker order.
    pub(super) fn moments(&self) -> Result<Moments, DiagnosticsError> {
        let n = self.len() as f64;
        let mut total = SeqSum::default();
        self.each_walker(|_, s| {
            total.add_all(s.iter().copied());
            Ok(())
        })?;
        let mean = total.0 / n;
        let (mut c2, mut c4) = (SeqSum::default(), SeqSum::default());
        self.each_walker(|_, s| {
            for &v in s {
                let d = (v - mean) * (v - mean);
                c2.0 += d;
                c4.0 += d * d;
            }
            Ok(())
        })?;
        Ok(Moments {
            mean,
            var: c2.0 / (n - 1.0),
            evar: c2.0 / n,
            mean_sq: c4.0 / n,
        })
    }

    /// The draws (or the values `f` gives of them) sorted in runs, with their indices; only
    /// the draws `keep` accepts.
    pub(super) fn sorted_runs(
        &self,
        keep: impl Fn(u32) -> bool,
        f: impl Fn(f64) -> f64,
    ) -> Result<Runs<'_>, DiagnosticsError> {
        let ws = self.ws();
        let mut runs = RunWriter::new(ws, ws.spills(self.len()))?;
        let steps = self.steps;
        self.each_walker(|c, s| {
            for (t, &v) in s.iter().enumerate() {
                let i = (c * steps + t) as u32;
                if keep(i) {
                    runs.push((f(v), i))?;
                }
            }
            Ok(())
        })?;
        runs.finish()
    }
}

/// Mean, variance (`ddof = 1`) and the mean of squared and fourth-power deviations.
pub(super) struct Moments {
    pub(super) mean: f64,
    pub(super) var: f64,
    pub(super) evar: f64,
    pub(super) mean_sq: f64,
}
