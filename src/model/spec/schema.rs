//! The model's tables of a run file as written, deserialised with serde: materials,
//! contacts, runs (with their data files and how to read them), levels, the law, pooling,
//! priors and the likelihood of long runs. [`ModelFile`] is the whole file; its `[sampler]`
//! table passes through unread (see [`ModelFile::sampler`]).

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::de::IgnoredAny;
use serde::{Deserialize, Serialize};

use super::params::Param;
use crate::data::{Clock, ColumnMap, Format, IntervalChoice};
use crate::law::{LawKind, Scene, StateLaw};
use crate::model::prior::Prior;

/// Where a parameter is shared.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// One value per material.
    Material,
    /// One value per contact (shared by its runs).
    Contact,
    /// One value per run.
    Run,
}

/// How the aging amplitude is parameterised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Aging {
    /// Sample r = a/F_d at the level of `a`; a = r·F_d per contact (the default: the paper
    /// reports a/F_d, and it is what stays constant between placements of one sphere).
    #[default]
    Ratio,
    /// Sample a itself.
    Absolute,
}

/// A material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Name, e.g. `PTFE`.
    pub name: String,
}

/// A contact: one placement of a sphere of some material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Name, e.g. `ptfe-c1`.
    pub name: String,
    /// Material name.
    pub material: String,
    /// Normal force F_N (N), when known; otherwise the data's `normal_force_N` column is used.
    #[serde(default, rename = "normal_force_N")]
    pub normal_force_n: Option<f64>,
}

/// A run: one recorded slide.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Name, e.g. `ptfe-c1-first`.
    pub name: String,
    /// Contact name.
    pub contact: String,
    /// Data file, relative to the model file.
    pub data: PathBuf,
    /// Sliding velocity (m/s).
    pub velocity_m_per_s: f64,
    /// `first`, `repeat` or `stiff-fast`.
    pub scene: Scene,
    /// Optional time window [start, end] in seconds of instrument time.
    #[serde(default)]
    pub window_s: Option<[f64; 2]>,
    /// For a repeat slide: the run it follows (default: the contact's first slide).
    #[serde(default)]
    pub follows: Option<String>,
    /// Data format (`csv`, `parquet`, `rheocompass`, `trios`, `rspace`); detected from the
    /// file's content when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub format: Option<Format>,
    /// Which columns hold time, force (or torque) and normal force, with their units; when
    /// absent, the usual names (`time_s`, `force_N`, `normal_force_N`; `Time`, `Torque`, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub columns: Option<ColumnMap>,
    /// Moment arm (m) converting torque to force (default 7 mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moment_arm_m: Option<f64>,
    /// Intervals of a RheoCompass export (steps of a TRIOS export, actions of an rSpace
    /// export): a number, a list, or `"all"` (the default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interval: Option<IntervalChoice>,
    /// The time an export's points are placed on: `"global"` (the instrument's continuous
    /// time, the default) or `"step"` (each interval's, step's or action's own time); unused
    /// when `columns` names the time column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock: Option<Clock>,
    /// Drop points whose cells are not finite numbers (counted in the report) instead of
    /// stopping with an error.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub drop_invalid: bool,
    /// Refused: the means of consecutive points that this key asked for bias a fit (t0 by
    /// 13 % at 10 points per bin); long records are reduced to sufficient statistics instead
    /// (`likelihood_tolerance`). Kept only to say so by name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bins: Option<usize>,
    /// Largest error of this run's log-likelihood allowed when it is evaluated on sufficient
    /// statistics (0: every point exactly); else its share of `[likelihood] tolerance`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub likelihood_tolerance: Option<f64>,
}

impl RunSpec {
    /// A run with its data in the default format and mapping, all points, no binning.
    pub fn new(
        name: &str,
        contact: &str,
        data: PathBuf,
        velocity_m_per_s: f64,
        scene: Scene,
    ) -> Self {
        Self {
            name: name.to_owned(),
            contact: contact.to_owned(),
            data,
            velocity_m_per_s,
            scene,
            window_s: None,
            follows: None,
            format: None,
            columns: None,
            moment_arm_m: None,
            interval: None,
            clock: None,
            drop_invalid: false,
            bins: None,
            likelihood_tolerance: None,
        }
    }
}

/// How a long run's likelihood is evaluated (docs/model.md §5, "Long records").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LikelihoodSpec {
    /// Largest error of the model's log-likelihood allowed when its long runs are evaluated
    /// on sufficient statistics of bins of their points, shared evenly by those runs (0:
    /// every point exactly).
    #[serde(default = "default_likelihood_tolerance")]
    pub tolerance: f64,
    /// Runs of at most this many observations are evaluated point by point whatever the
    /// tolerance (their exact evaluation costs little).
    #[serde(default = "default_exact_up_to")]
    pub exact_up_to: usize,
}

/// Default [`LikelihoodSpec::tolerance`]: a hundredth of a unit of log-likelihood. An error
/// of at most ε in the log-likelihood changes the posterior probability of any event by a
/// factor within e^(±2ε): a posterior median moves by at most 2.5 ε posterior sd and a 95 %
/// interval end by 0.86 ε sd (for a near-normal marginal), here 0.025 and 0.009 sd.
pub const DEFAULT_LIKELIHOOD_TOLERANCE: f64 = 0.01;

/// Default [`LikelihoodSpec::exact_up_to`].
pub const DEFAULT_EXACT_UP_TO: usize = 10_000;

fn default_likelihood_tolerance() -> f64 {
    DEFAULT_LIKELIHOOD_TOLERANCE
}

fn default_exact_up_to() -> usize {
    DEFAULT_EXACT_UP_TO
}

impl Default for LikelihoodSpec {
    fn default() -> Self {
        Self {
            tolerance: DEFAULT_LIKELIHOOD_TOLERANCE,
            exact_up_to: DEFAULT_EXACT_UP_TO,
        }
    }
}

impl LikelihoodSpec {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// Partial pooling of parameters within their material: ln θ ~ Normal(μ_material,
/// s_material) over the material's contacts (or runs), sampled centred (the members' ln θ are
/// coordinates) with the population drawn exactly. Each needs its parameter at the contact or
/// run level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct PoolingSpec {
    /// Pool t0.
    #[serde(default)]
    pub t0: bool,
    /// Pool F_d.
    #[serde(default, rename = "F_d")]
    pub f_d: bool,
    /// Pool k.
    #[serde(default)]
    pub k: bool,
    /// Pool a (a/F_d under `aging = "ratio"`).
    #[serde(default)]
    pub a: bool,
}

impl PoolingSpec {
    /// Whether `p` is pooled.
    pub(crate) fn pools(&self, p: Param) -> bool {
        match p {
            Param::T0 => self.t0,
            Param::FD => self.f_d,
            Param::K => self.k,
            Param::A => self.a,
            Param::Alpha | Param::B | Param::Dc | Param::Sigma => false,
        }
    }

    /// Whether any parameter is pooled.
    pub fn any(&self) -> bool {
        Param::ALL.into_iter().any(|p| self.pools(p))
    }
}

/// A model file as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// Materials.
    #[serde(rename = "material")]
    pub materials: Vec<MaterialSpec>,
    /// Contacts.
    #[serde(rename = "contact")]
    pub contacts: Vec<ContactSpec>,
    /// Runs.
    #[serde(rename = "run")]
    pub runs: Vec<RunSpec>,
    /// Level of each parameter (defaults of docs/model.md §5).
    #[serde(default)]
    pub levels: BTreeMap<Param, Level>,
    /// The law of first and fast slides (`law = "log-aging"`; default the aging–rejuvenation
    /// law).
    #[serde(default, skip_serializing_if = "is_default_law")]
    pub law: LawKind,
    /// Under `law = "rate-state"`: how the state evolves (`"aging"`, the default, or
    /// `"slip"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_law: Option<StateLaw>,
    /// Under `law = "rate-state"`: the reference velocity V0 (m/s) at which F_d is the steady
    /// force F0; by default each run's own driving velocity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_velocity_m_per_s: Option<f64>,
    /// Whether the machine's spring is modelled (`elastic = false`: k → ∞, k not sampled).
    #[serde(
        default = "elastic_default",
        skip_serializing_if = "is_elastic_default"
    )]
    pub elastic: bool,
    /// Parameterisation of the aging amplitude (no effect under a law without F_d).
    #[serde(default)]
    pub aging: Aging,
    /// Partial pooling.
    #[serde(default)]
    pub pooling: PoolingSpec,
    /// Priors per parameter (defaults: [`default_prior`](super::default_prior)).
    #[serde(default)]
    pub priors: BTreeMap<String, Prior>,
    /// The `[sampler]` table: how the posterior is sampled, which the model does not read.
    /// The schema lets it through so that one file holds a whole run; the fit parses it from
    /// the same text (`crate::fit::SamplerSpec`), and writes it back into a run directory's
    /// `model.toml`.
    #[serde(default, skip_serializing)]
    pub sampler: IgnoredAny,
    /// How long runs' likelihoods are evaluated.
    #[serde(default, skip_serializing_if = "LikelihoodSpec::is_default")]
    pub likelihood: LikelihoodSpec,
}

fn is_default_law(law: &LawKind) -> bool {
    *law == LawKind::default()
}

fn elastic_default() -> bool {
    true
}

fn is_elastic_default(elastic: &bool) -> bool {
    *elastic
}
