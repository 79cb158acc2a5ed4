//! Model specifications: what is fitted, to which data, with which priors. A run file
//! (`models/*.toml`) is parsed at the edge (`crate::fit::RunFile`); the model's part of it is
//! validated here once, so that everything downstream can trust it, and every error names
//! the key at fault and says what to write.
//!
//! - [`schema`]: the model's tables as written (materials, contacts, runs with their data
//!   files, levels, the law, pooling, priors, the likelihood of long runs).
//! - `params`: the parameters of the law and which runs use them under a forward model.
//! - `validate`: the checks of a model file, one function per concern.
//! - `priors`: the default priors and how a model's priors are looked up.
//!
//! The model's schema lets the `[sampler]` table through unread: how the posterior is
//! sampled is not the model's business, and the blocking plan the posterior needs from that
//! table reaches it as an argument ([`super::BlockSettings`]).

mod params;
mod priors;
pub mod schema;
mod validate;

use std::collections::BTreeSet;
use std::path::PathBuf;

pub use params::{ForwardModel, Param};
pub use priors::{default_prior, PRIOR_NAMES};
pub use schema::{
    Aging, ContactSpec, Level, LikelihoodSpec, MaterialSpec, ModelFile, PoolingSpec, RunSpec,
    DEFAULT_EXACT_UP_TO, DEFAULT_LIKELIHOOD_TOLERANCE,
};

use crate::data::ImportOptions;

/// Errors loading a model (run) file.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// The file could not be read.
    #[error(transparent)]
    Io(#[from] crate::IoError),
    /// The TOML does not parse or does not fit the schema (the message names line and key).
    #[error("{path}: {message}")]
    Syntax {
        /// The model file.
        path: PathBuf,
        /// The parser's message, with line, column and key.
        message: String,
    },
    /// A value is invalid.
    #[error("{path}: {key}: {message}")]
    Invalid {
        /// The model file (or `<command line>` for the quick path).
        path: PathBuf,
        /// The key at fault, e.g. `run[2].velocity_m_per_s` or `priors.alpha`.
        key: String,
        /// What is wrong and what to do.
        message: String,
    },
}

/// A validated model: names resolved to indices, data paths made absolute.
#[derive(Debug, Clone)]
pub struct ModelSpec {
    /// The file as written (for the record of a fit).
    pub file: ModelFile,
    /// Directory the data paths are relative to.
    pub base_dir: PathBuf,
    /// Where the spec came from (for messages).
    pub source: PathBuf,
    /// Material index of each contact.
    pub contact_material: Vec<usize>,
    /// Contact index of each run.
    pub run_contact: Vec<usize>,
    /// For each repeat run, the run index it follows (None: F_end = F_d).
    pub run_follows: Vec<Option<usize>>,
}

impl ModelSpec {
    /// The parameters some run of the model samples under the forward model `forward`.
    pub(crate) fn params_in_use(&self, forward: ForwardModel) -> BTreeSet<Param> {
        let mut used = BTreeSet::new();
        for (r, follows) in self.file.runs.iter().zip(&self.run_follows) {
            used.extend(
                Param::ALL
                    .into_iter()
                    .filter(|&p| forward.uses(p, r.scene, follows.is_some())),
            );
        }
        used
    }

    /// The names whose priors the model reads under `forward`: each sampled parameter's
    /// (a/F_d's in place of a's under `aging = "ratio"`), and for a pooled one its
    /// population's, whose median follows the parameter's own prior (except t0's).
    pub(crate) fn prior_names_in_use(&self, forward: ForwardModel) -> BTreeSet<String> {
        let ratio = forward.aging_ratio(self.file.aging);
        let mut names = BTreeSet::new();
        for p in self.params_in_use(forward) {
            let name = if p == Param::A && ratio {
                "a_over_F_d"
            } else {
                p.name()
            };
            if self.file.pooling.pools(p) {
                names.insert(format!("{name}_pop_median"));
                names.insert(format!("{name}_pop_log_sd"));
                if p == Param::T0 {
                    continue;
                }
            }
            names.insert(name.to_owned());
        }
        names
    }

    /// The forward model: the law and whether the spring is modelled.
    pub fn forward(&self) -> ForwardModel {
        ForwardModel {
            law: self.file.law,
            elastic: self.file.elastic,
            state_law: self.file.state_law.unwrap_or_default(),
        }
    }

    /// Whether run `run` uses parameter `p` under the model's forward model.
    pub fn uses(&self, p: Param, run: usize) -> bool {
        let r = &self.file.runs[run];
        self.forward()
            .uses(p, r.scene, self.run_follows[run].is_some())
    }

    /// Level of a parameter.
    pub fn level(&self, p: Param) -> Level {
        self.file
            .levels
            .get(&p)
            .copied()
            .unwrap_or(p.default_level())
    }

    /// How to read a run's data file.
    pub(crate) fn import_options(&self, run: usize) -> ImportOptions {
        let r = &self.file.runs[run];
        let defaults = ImportOptions::default();
        ImportOptions {
            format: r.format,
            columns: r.columns.clone(),
            moment_arm_m: r.moment_arm_m.unwrap_or(defaults.moment_arm_m),
            intervals: r.interval.clone().unwrap_or_default(),
            clock: r.clock.unwrap_or_default(),
            drop_invalid: r.drop_invalid,
        }
    }

    /// For runs of `points` observations each (in model order), the tolerance on each one's
    /// log-likelihood when it is to be evaluated on sufficient statistics; `None` to evaluate
    /// it point by point (a run of at most `[likelihood] exact_up_to` points, or a tolerance
    /// of 0). `[likelihood] tolerance` bounds the error of the whole model's log-likelihood:
    /// it is shared evenly by the long runs that do not set `likelihood_tolerance` themselves.
    pub(crate) fn reduction_tolerances(&self, points: &[usize]) -> Vec<Option<f64>> {
        let long = |i: usize| points[i] > self.file.likelihood.exact_up_to;
        let sharing = (0..points.len())
            .filter(|&i| long(i) && self.file.runs[i].likelihood_tolerance.is_none())
            .count();
        (0..points.len())
            .map(|i| {
                let tolerance = self.file.runs[i]
                    .likelihood_tolerance
                    .unwrap_or(self.file.likelihood.tolerance / sharing.max(1) as f64);
                (long(i) && tolerance > 0.0).then_some(tolerance)
            })
            .collect()
    }

    /// Absolute path of a run's data file.
    pub fn data_path(&self, run: usize) -> PathBuf {
        self.base_dir.join(&self.file.runs[run].data)
    }
}
