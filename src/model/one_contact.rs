//! The one-contact model that needs no model file (the command line's quick path): a first
//! slide, optionally the repeat slide that followed it, one contact of one material.

use std::path::{Path, PathBuf};

use crate::data::ImportOptions;
use crate::law::{LawKind, Scene};

use super::spec::{
    ContactSpec, ForwardModel, Level, MaterialSpec, ModelFile, Param, PoolingSpec, RunSpec,
};
use super::{ModelSpec, SpecError};

/// Where the quick path's data are and how to read them.
#[derive(Debug, Clone, PartialEq)]
pub struct OneContact {
    /// Data of the first slide (CSV, Parquet or RheoCompass export).
    pub first: PathBuf,
    /// Data of the repeat slide that followed it, if any.
    pub repeat: Option<PathBuf>,
    /// Sliding velocity (m/s) of both slides.
    pub velocity_m_per_s: f64,
    /// The first slide is fast and declared stiff: no elastic correction (and no repeat).
    pub stiff: bool,
    /// Normal force (N), for the friction coefficient μ_s.
    pub normal_force_n: Option<f64>,
    /// Fit the first slide only within [start, end] s of instrument time.
    pub window_s: Option<[f64; 2]>,
    /// Largest error of each long slide's log-likelihood when it is evaluated on sufficient
    /// statistics (0: every point exactly); the model file's default when `None`.
    pub likelihood_tolerance: Option<f64>,
    /// Format, column mapping, moment arm, intervals and drop rule of every file.
    pub import: ImportOptions,
    /// The law and whether the machine's spring is modelled (the model file's `law` and
    /// `elastic`).
    pub forward: ForwardModel,
}

/// The name of the one source the quick path's errors point to.
const COMMAND_LINE: &str = "<command line>";

impl ModelSpec {
    /// The model of one contact: runs `first` and `repeat`, contact `contact` of material
    /// `material`, the law's α and a per contact, default priors and sampler. Relative data paths are
    /// made absolute so the run directory's `model.toml` can be fitted again from anywhere.
    ///
    /// # Errors
    /// [`SpecError::Invalid`] (naming `--repeat` or the run's key) when a repeat slide follows
    /// a stiff first slide, a path cannot be resolved, or a value is invalid.
    pub fn one_contact(q: &OneContact) -> Result<Self, SpecError> {
        let invalid = |key: &str, message: String| SpecError::Invalid {
            path: PathBuf::from(COMMAND_LINE),
            key: key.to_owned(),
            message,
        };
        let absolute = |key: &str, p: &Path| {
            std::path::absolute(p)
                .map_err(|e| invalid(key, format!("resolving {}: {e}", p.display())))
        };
        // The mapping, drop rule and likelihood tolerance apply to every file; the window to
        // the first slide only.
        let read_like_every_file = |mut run: RunSpec| {
            run.format = q.import.format;
            run.columns = q.import.columns.clone();
            run.moment_arm_m = Some(q.import.moment_arm_m);
            run.interval = Some(q.import.intervals.clone());
            run.drop_invalid = q.import.drop_invalid;
            run.likelihood_tolerance = q.likelihood_tolerance;
            run
        };
        let scene = if q.stiff {
            Scene::StiffFast
        } else {
            Scene::First
        };
        let mut first = read_like_every_file(RunSpec::new(
            "first",
            "contact",
            absolute("first", &q.first)?,
            q.velocity_m_per_s,
            scene,
        ));
        first.window_s = q.window_s;
        let mut runs = vec![first];
        if let Some(repeat) = &q.repeat {
            if q.stiff {
                return Err(invalid(
                    "repeat",
                    "a repeat slide needs a first slide with the elastic correction; \
                     drop --stiff"
                        .into(),
                ));
            }
            let mut run = read_like_every_file(RunSpec::new(
                "repeat",
                "contact",
                absolute("repeat", repeat)?,
                q.velocity_m_per_s,
                Scene::Repeat,
            ));
            run.follows = Some("first".into());
            runs.push(run);
        }
        let file = ModelFile {
            materials: vec![MaterialSpec {
                name: "material".into(),
            }],
            contacts: vec![ContactSpec {
                name: "contact".into(),
                material: "material".into(),
                normal_force_n: q.normal_force_n,
            }],
            runs,
            // α and a per contact, where the law has them.
            levels: [(Param::Alpha, Level::Contact), (Param::A, Level::Contact)]
                .into_iter()
                .filter(|(p, _)| q.forward.law_params().contains(p))
                .collect(),
            law: q.forward.law,
            state_law: (q.forward.law == LawKind::RateState).then_some(q.forward.state_law),
            reference_velocity_m_per_s: None,
            elastic: q.forward.elastic,
            aging: Default::default(),
            pooling: PoolingSpec::default(),
            priors: Default::default(),
            sampler: Default::default(),
            likelihood: Default::default(),
        };
        ModelSpec::validate(file, PathBuf::from("."), PathBuf::from(COMMAND_LINE))
    }
}
