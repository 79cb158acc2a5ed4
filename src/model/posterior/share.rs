//! A posterior that holds only a share of the data: what a rank of an MPI job other than 0
//! builds, so that each rank holds the data of its share of the contacts and no more.
//!
//! Such a rank only ever evaluates its own contacts' terms: their blocks' updates, and its share
//! of every shared update that splits by contact (`blocks::Owners`). So it needs the data of the
//! runs its independent blocks own and, of every other run, only the number of observations
//! (the likelihood of a sampled or integrated σ reads it) and the normal force (whether the run
//! reports a static coefficient). Rank 0 hands it, in a [`DataShare`], those and what it cannot
//! compute from its share: the parameter points at which the long runs' bins were chosen
//! (`long_records`), which come from the whole posterior's start. At those points its long runs
//! get the same bins, bit for bit, as in the whole posterior, so that every term it evaluates
//! is the whole posterior's.

use std::ops::Range;

use super::blocks::Owners;
use super::{Posterior, PosteriorError};
use crate::model::data::RunData;
use crate::model::spec::ModelSpec;
use crate::model::BlockSettings;

/// What a process needs, besides the model file and its own runs' data, to build its share of
/// a posterior ([`Posterior::share_of`]): every run's number of observations and normal force,
/// and the points at which the long runs' bins were chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct DataShare {
    /// Observations of each run, in model order.
    points: Vec<usize>,
    /// The normal force of each run (the model's, or the mean of its data's column), which
    /// decides whether the run reports a static coefficient.
    normal_force: Vec<Option<f64>>,
    /// The parameter points of the long runs' bins (empty: no run is long).
    reduced_at: Vec<Vec<f64>>,
}

/// A [`DataShare`] that does not decode.
#[derive(Debug, thiserror::Error)]
#[error("the description of this rank's share of the data is malformed: {0}")]
pub struct DataShareError(&'static str);

impl DataShare {
    /// The share as words, to send to another process: the run count, each run's
    /// observations and normal force (the bits of NaN: none), the count and length of the
    /// points, then each point's bits.
    pub fn to_words(&self) -> Vec<u64> {
        let dim = self.reduced_at.first().map_or(0, Vec::len);
        let runs = self.points.len();
        let mut words = Vec::with_capacity(3 + 2 * runs + self.reduced_at.len() * dim);
        words.push(runs as u64);
        words.extend(self.points.iter().map(|&n| n as u64));
        words.extend(
            self.normal_force
                .iter()
                .map(|f| f.unwrap_or(f64::NAN).to_bits()),
        );
        words.push(self.reduced_at.len() as u64);
        words.push(dim as u64);
        for point in &self.reduced_at {
            words.extend(point.iter().map(|v| v.to_bits()));
        }
        words
    }

    /// The share that [`to_words`](Self::to_words) wrote.
    ///
    /// # Errors
    /// [`DataShareError`] when the words are too few or too many for the counts they give.
    pub fn from_words(words: &[u64]) -> Result<Self, DataShareError> {
        let mut rest = words.iter().copied();
        let mut next = |what: &'static str| rest.next().ok_or(DataShareError(what));
        let runs = next("no run count")? as usize;
        let points = (0..runs)
            .map(|_| next("fewer run counts than runs").map(|n| n as usize))
            .collect::<Result<Vec<_>, _>>()?;
        let normal_force = (0..runs)
            .map(|_| {
                next("fewer normal forces than runs")
                    .map(|bits| Some(f64::from_bits(bits)).filter(|f| !f.is_nan()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (count, dim) = (
            next("no point count")? as usize,
            next("no dimension")? as usize,
        );
        let reduced_at = (0..count)
            .map(|_| {
                (0..dim)
                    .map(|_| next("fewer coordinates than points").map(f64::from_bits))
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        if rest.next().is_some() {
            return Err(DataShareError("words left over"));
        }
        Ok(Self {
            points,
            normal_force,
            reduced_at,
        })
    }
}

impl Posterior {
    /// What another process needs to build its share of this posterior
    /// ([`share_of`](Self::share_of)), or `None` when a share cannot do with its own
    /// contacts' data: there are no independent blocks, a run belongs to none, or an update
    /// outside them reads runs and does not split by them (a σ shared by several contacts,
    /// say). Then every process must hold all of the data.
    pub fn data_share(&self) -> Option<DataShare> {
        self.parts_hold_their_data().then(|| DataShare {
            points: self.runs.iter().map(|r| r.data.n_obs).collect(),
            normal_force: self.runs.iter().map(|r| r.normal_force).collect(),
            reduced_at: self.reduced_at.clone(),
        })
    }

    /// Whether a process holding only the runs of some independent blocks can evaluate every
    /// update that reads runs, for its blocks (their own updates, and the shared updates that
    /// split by independent block).
    fn parts_hold_their_data(&self) -> bool {
        self.first_independent < self.blocks.len()
            && self.owners.run.iter().all(Option::is_some)
            && (0..self.first_independent)
                .all(|b| self.blocks[b].runs.is_empty() || self.owners.splits[b])
    }

    /// The share of the posterior of `spec` (its blocks as `blocking` groups them) that holds the data of the runs of the
    /// independent blocks at positions `parts_of(count)` (`count`: the number of independent
    /// blocks) and of no other run, with the counts and long runs' points of `share` (from
    /// the whole posterior's [`data_share`](Self::data_share)). Its own blocks' updates and
    /// its share of a split update are the whole posterior's bits; fitting another run is a
    /// fatal error, and it has no start of its own.
    ///
    /// # Errors
    /// [`PosteriorError`] when a run's data cannot be loaded, when the model has not as many
    /// runs as `share` or a run not as many observations (the processes read different files),
    /// or when the model's updates do not split by independent block.
    pub fn share_of(
        spec: &ModelSpec,
        blocking: BlockSettings,
        share: &DataShare,
        parts_of: impl FnOnce(usize) -> Range<usize>,
    ) -> Result<Self, PosteriorError> {
        let model_error = |message: String| PosteriorError::Model {
            source_file: spec.source.clone(),
            message,
        };
        let runs = spec.file.runs.len();
        if share.points.len() != runs {
            return Err(model_error(format!(
                "rank 0 fits {} runs and this process {runs}; every rank must load the same model",
                share.points.len()
            )));
        }
        if share.normal_force.len() != runs {
            return Err(model_error(format!(
                "rank 0 gives {} normal forces for {runs} runs",
                share.normal_force.len()
            )));
        }
        let elsewhere =
            |i: usize| RunData::held_elsewhere(spec, i, share.points[i], share.normal_force[i]);
        // The structure (blocks, owners) does not depend on the data.
        let skeleton = Self::unreduced(spec, blocking, (0..runs).map(elsewhere).collect())?;
        if !skeleton.parts_hold_their_data() {
            return Err(model_error(
                "this model's updates read other contacts' runs, so that every rank must hold \
                 all of the data; rank 0 should not have handed out shares"
                    .to_owned(),
            ));
        }
        let parts = parts_of(skeleton.blocks.len() - skeleton.first_independent);
        let held: Vec<bool> = skeleton
            .owners
            .run
            .iter()
            .map(|&owner| Owners::within(owner, parts.start, parts.end))
            .collect();
        drop(skeleton);
        let mut data = Vec::with_capacity(runs);
        for (i, &mine) in held.iter().enumerate() {
            if !mine {
                data.push(elsewhere(i));
                continue;
            }
            let d = RunData::for_run(spec, i)?;
            if d.n_obs != share.points[i] {
                return Err(model_error(format!(
                    "run `{}`: rank 0 read {} observations and this process {}; every rank \
                     must read the same data files",
                    spec.file.runs[i].name, share.points[i], d.n_obs
                )));
            }
            data.push(d);
        }
        let mut posterior = Self::unreduced(spec, blocking, data)?;
        for ((r, &mine), f_n) in posterior
            .runs
            .iter_mut()
            .zip(&held)
            .zip(&share.normal_force)
        {
            r.held = mine;
            if r.normal_force.map(f64::to_bits) != f_n.map(f64::to_bits) {
                return Err(model_error(format!(
                    "run `{}`: rank 0 reads a normal force of {f_n:?} N and this process \
                     {:?} N; every rank must read the same data files",
                    r.name, r.normal_force
                )));
            }
        }
        let long: Vec<(usize, f64)> = posterior
            .long_runs()
            .into_iter()
            .filter(|&(i, _)| held[i])
            .collect();
        if !long.is_empty() && !share.reduced_at.is_empty() {
            posterior.install_reductions(&long, &share.reduced_at);
        }
        posterior.reduced_at.clone_from(&share.reduced_at);
        Ok(posterior)
    }

    /// (runs whose data this process holds, runs): all of them, but in a share.
    pub fn held_runs(&self) -> (usize, usize) {
        let held = self.runs.iter().filter(|r| r.held).count();
        (held, self.runs.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The words give back the share bit for bit (a missing normal force included), and a
    /// share cut short or padded is refused.
    #[test]
    fn a_share_reads_back_from_its_words() {
        let share = DataShare {
            points: vec![201, 51, 7],
            normal_force: vec![Some(1.25e-2), None, Some(-0.0)],
            reduced_at: vec![vec![0.1, -3.5, f64::MIN_POSITIVE], vec![1e300, 0.0, -1.0]],
        };
        let words = share.to_words();
        let back = DataShare::from_words(&words).unwrap();
        assert_eq!(back, share);
        assert_eq!(
            back.normal_force[2].map(f64::to_bits),
            Some((-0.0f64).to_bits())
        );
        assert!(DataShare::from_words(&words[..words.len() - 1]).is_err());
        let mut padded = words.clone();
        padded.push(0);
        assert!(DataShare::from_words(&padded).is_err());
        let none = DataShare {
            points: vec![9],
            normal_force: vec![None],
            reduced_at: Vec::new(),
        };
        assert_eq!(DataShare::from_words(&none.to_words()).unwrap(), none);
    }
}
