//! Model files (`models/*.toml`): what is fitted, to which data, with which priors and
//! sampler settings. Deserialised with serde and validated once here, so that everything
//! downstream can trust it; every error names the key at fault and says what to write.

use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::prior::Prior;
use crate::data::units::{parse_unit, KNOWN_UNITS};
use crate::data::{Clock, ColumnMap, Format, ImportOptions, IntervalChoice};
use crate::law::{LawKind, Scene, StateLaw};
use crate::sampler::{CarryFit, Mixture, Updates};

/// Errors loading a model file.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The model file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
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

/// The parameters of the law and its scenes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Param {
    /// Shear-rejuvenation constant α (1/m).
    #[serde(rename = "alpha")]
    Alpha,
    /// Aging amplitude a (N), or a/F_d when `aging = "ratio"`; under rate-and-state the
    /// direct-effect amplitude a (N).
    #[serde(rename = "a")]
    A,
    /// Rate-and-state evolution-effect amplitude b (N).
    #[serde(rename = "b")]
    B,
    /// Rate-and-state critical slip distance D_c (m).
    #[serde(rename = "D_c")]
    Dc,
    /// Steady-state friction F_d (N); under rate-and-state F0, the steady force at the
    /// reference velocity.
    #[serde(rename = "F_d")]
    FD,
    /// Short-time cut-off t0 (s); under rate-and-state the contact's age θ(0) at the start
    /// of a first slide.
    #[serde(rename = "t0")]
    T0,
    /// Machine stiffness k (N/m).
    #[serde(rename = "k")]
    K,
    /// Noise standard deviation σ (N).
    #[serde(rename = "sigma")]
    Sigma,
}

impl Param {
    /// All parameters, in reporting order.
    pub const ALL: [Param; 8] = [
        Self::Alpha,
        Self::A,
        Self::B,
        Self::Dc,
        Self::FD,
        Self::T0,
        Self::K,
        Self::Sigma,
    ];

    /// The name used in files and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Self::Alpha => "alpha",
            Self::A => "a",
            Self::B => "b",
            Self::Dc => "D_c",
            Self::FD => "F_d",
            Self::T0 => "t0",
            Self::K => "k",
            Self::Sigma => "sigma",
        }
    }

    /// SI unit.
    pub fn unit(self) -> &'static str {
        match self {
            Self::Alpha => "1/m",
            Self::A | Self::B | Self::FD | Self::Sigma => "N",
            Self::Dc => "m",
            Self::T0 => "s",
            Self::K => "N/m",
        }
    }

    /// The default level (docs/model.md §5), used when the model file says nothing.
    pub fn default_level(self) -> Level {
        match self {
            Self::Alpha | Self::A | Self::B | Self::Dc => Level::Material,
            Self::FD | Self::K => Level::Contact,
            Self::T0 | Self::Sigma => Level::Run,
        }
    }
}

/// The forward model of a fit: the law its first and fast slides follow (`law`, with
/// `state_law` under rate-and-state) and whether the machine's spring is modelled
/// (`elastic`). It decides which parameters each run uses, and so which are sampled and
/// reported ("model only what a scene needs").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ForwardModel {
    /// The law in interface time, or rate-and-state friction.
    pub law: LawKind,
    /// `false`: the machine is rigid (k → ∞), τ = t on every slide and a repeat slide is
    /// F = F_end from its start.
    pub elastic: bool,
    /// The state law under `law = "rate-state"` (ignored under the other laws).
    pub state_law: StateLaw,
}

impl Default for ForwardModel {
    /// The aging–rejuvenation law through the machine's spring.
    fn default() -> Self {
        Self {
            law: LawKind::default(),
            elastic: true,
            state_law: StateLaw::default(),
        }
    }
}

impl ForwardModel {
    /// The parameters of the law itself, in reporting order.
    pub fn law_params(self) -> &'static [Param] {
        match self.law {
            LawKind::AgingRejuvenation => &[Param::Alpha, Param::A, Param::FD, Param::T0],
            LawKind::LogAging => &[Param::A, Param::T0],
            LawKind::RateState => &[Param::A, Param::B, Param::Dc, Param::FD, Param::T0],
        }
    }

    /// Whether a run of `scene` uses parameter `p`. Under a law in interface time a repeat
    /// slide needs no law, only the force it slides at: F_end of the slide it follows
    /// (`follows_slide`), else F_d; it keeps F_d whenever the law has F_d, so that a
    /// contact's F_d is one parameter. Under rate-and-state a repeat slide is a slide of the
    /// same law from the state steady sliding left (docs/model.md §10): every parameter of
    /// the law but the hold age t0.
    pub fn uses(self, p: Param, scene: Scene, follows_slide: bool) -> bool {
        let in_law = self.law_params().contains(&p);
        match p {
            Param::Sigma => true,
            Param::K => self.elastic && scene != Scene::StiffFast,
            Param::T0 if scene == Scene::Repeat => false,
            _ if scene == Scene::Repeat && self.law == LawKind::RateState => in_law,
            Param::FD if scene == Scene::Repeat => in_law || !follows_slide,
            _ => scene != Scene::Repeat && in_law,
        }
    }

    /// Whether `a` is sampled as a/F_d: under `aging = "ratio"`, when a is the aging
    /// amplitude of a law with F_d (not rate-and-state's direct effect, sampled in newtons).
    pub fn aging_ratio(self, aging: Aging) -> bool {
        aging == Aging::Ratio
            && self.law != LawKind::RateState
            && self.law_params().contains(&Param::FD)
    }
}

impl std::fmt::Display for ForwardModel {
    /// The law as model files name it (with its state law under rate-and-state), and
    /// `, rigid` when the spring is not modelled.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.law.name())?;
        if self.law == LawKind::RateState {
            write!(f, " ({} law)", self.state_law)?;
        }
        if !self.elastic {
            f.write_str(", rigid")?;
        }
        Ok(())
    }
}

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
    pub fn pools(&self, p: Param) -> bool {
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

/// Sampler settings of a fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplerSpec {
    /// Walkers per ensemble (default: max(32, 4·d + 4, 2·f + 4), d the coordinates one update
    /// moves, f the most followers a hierarchical update carries).
    #[serde(default)]
    pub walkers: Option<usize>,
    /// Independent ensembles (default 4).
    #[serde(default = "default_ensembles")]
    pub ensembles: usize,
    /// Fixed number of steps; when absent, run until converged up to `max_steps`.
    #[serde(default)]
    pub steps: Option<u64>,
    /// Step cap of the stopping rule.
    #[serde(default = "default_max_steps")]
    pub max_steps: u64,
    /// Wall-time budget (s) of a fit; none by default.
    #[serde(default)]
    pub max_time_s: Option<f64>,
    /// Seed.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Steps between checkpoints.
    #[serde(default = "default_checkpoint")]
    pub checkpoint_every: u64,
    /// Proposal moves and their weights, e.g. `"student-t=0.8,stretch=0.2"` (see
    /// [`Mixture`]); the fit's default mixture when absent.
    #[serde(default)]
    pub moves: Option<Mixture>,
    /// `"joint"`, `"blocked"` or `"hierarchical"` updates (see [`Updates`]); the fit's default
    /// (hierarchical) when absent.
    #[serde(default)]
    pub updates: Option<Updates>,
    /// What a block of blocked or hierarchical updates is: each contact's own parameters apart
    /// from the ones its material shares (the default), or each material's parameters (its
    /// contacts' and shared ones together).
    #[serde(default)]
    pub blocks: Blocking,
    /// How hierarchical updates carry a shared block's followers: `"auto"` (the fit's
    /// default when absent), `"complement"` or `"tuned"` (see [`CarryFit`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub carry: Option<CarryFit>,
    /// How a pooled parameter's population moves under blocked or hierarchical updates.
    #[serde(default, skip_serializing_if = "PopulationUpdates::is_default")]
    pub populations: PopulationUpdates,
}

/// How the population of a pooled parameter (its μ and ln s) is updated.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PopulationUpdates {
    /// Both, one after the other, during the first
    /// [`CARRY_TUNE_STEPS`](crate::sampler::CARRY_TUNE_STEPS) steps; then the carried move
    /// only where it moved the population at least
    /// [`CARRY_MIN_JUMP_RATIO`](crate::sampler::CARRY_MIN_JUMP_RATIO) as far as the exact draw
    /// (the default): where the data pin the members the exact draw does the work alone and
    /// the carried move's evaluations are saved.
    #[default]
    Auto,
    /// Both, one after the other in every step: neither strong nor weak data stall the chain.
    Interwoven,
    /// Drawn exactly from its conditional given the members (centred): mixes where the data
    /// pin the members, stalls in the funnel where they do not.
    Exact,
    /// Moved by the ensemble's moves with the members carried along the non-centred map:
    /// mixes where the data say little about the members, stalls where they pin them.
    Carried,
}

impl PopulationUpdates {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// The blocks of blocked updates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Blocking {
    /// One block per material: materials share no parameter, so their posteriors are
    /// independent and each block's update evaluates only the material's runs.
    Material,
    /// One block per material for its shared parameters and one per contact for its own
    /// (the default): with hierarchical updates the shared block carries its contacts along
    /// and each contact is proposed from its conditional given the shared parameters; with
    /// plain blocked updates, Metropolis-within-Gibbs across the hierarchy.
    #[default]
    Contact,
}

fn default_ensembles() -> usize {
    4
}
fn default_max_steps() -> u64 {
    20_000
}
fn default_seed() -> u64 {
    1
}
fn default_checkpoint() -> u64 {
    200
}

impl Default for SamplerSpec {
    fn default() -> Self {
        Self {
            walkers: None,
            ensembles: default_ensembles(),
            steps: None,
            max_steps: default_max_steps(),
            max_time_s: None,
            seed: default_seed(),
            checkpoint_every: default_checkpoint(),
            moves: None,
            updates: None,
            blocks: Blocking::default(),
            carry: None,
            populations: PopulationUpdates::default(),
        }
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
    /// Priors per parameter (defaults: [`default_prior`]).
    #[serde(default)]
    pub priors: BTreeMap<String, Prior>,
    /// Sampler settings.
    #[serde(default)]
    pub sampler: SamplerSpec,
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

/// The documented, weakly informative default prior of a parameter (natural scale, SI):
/// log-uniform over many decades around anything physical, so the data decide.
pub fn default_prior(name: &str) -> Option<Prior> {
    let lu = |low, high| Some(Prior::LogUniform { low, high });
    match name {
        // 1/m: rejuvenation over 1 nm to 1 mm of sliding.
        "alpha" => lu(1e3, 1e9),
        // N: aging amplitude (rate-and-state: direct effect) from 1 µN to 10 N.
        "a" => lu(1e-6, 10.0),
        // N: rate-and-state evolution effect, as a.
        "b" => lu(1e-6, 10.0),
        // m: rate-and-state critical slip distance from 1 pm to 1 mm.
        "D_c" => lu(1e-12, 1e-3),
        // a/F_d from 1e-3 to 100.
        "a_over_F_d" => lu(1e-3, 1e2),
        // N: dynamic friction from 1 µN to 10 N.
        "F_d" => lu(1e-6, 10.0),
        // s: from 1 ns to about 3 h.
        "t0" => lu(1e-9, 1e4),
        // N/m.
        "k" => lu(1e1, 1e8),
        // N: noise from 10 nN to 1 N.
        "sigma" => lu(1e-8, 1.0),
        // Pooled t0: median of the material's t0 population (s) and sd of ln t0.
        "t0_pop_median" => Some(Prior::LogNormal {
            median: 1.0,
            sd_log: 5.0,
            low: Some(1e-9),
            high: Some(1e4),
        }),
        // Any pooled parameter: sd of its ln over the material's contacts, up to a factor e^5.
        "t0_pop_log_sd"
        | "F_d_pop_log_sd"
        | "k_pop_log_sd"
        | "a_pop_log_sd"
        | "a_over_F_d_pop_log_sd" => Some(Prior::HalfNormal {
            sd: 1.0,
            high: Some(5.0),
        }),
        // The median of a pooled F_d, k or a (a/F_d) population has the parameter's own
        // default prior (`ModelSpec::prior` follows a prior the file gives the parameter).
        "F_d_pop_median" => default_prior("F_d"),
        "k_pop_median" => default_prior("k"),
        "a_pop_median" => default_prior("a"),
        "a_over_F_d_pop_median" => default_prior("a_over_F_d"),
        _ => None,
    }
}

/// Names a model file may give priors for.
pub const PRIOR_NAMES: [&str; 19] = [
    "alpha",
    "a",
    "b",
    "D_c",
    "a_over_F_d",
    "F_d",
    "t0",
    "k",
    "sigma",
    "t0_pop_median",
    "t0_pop_log_sd",
    "F_d_pop_median",
    "F_d_pop_log_sd",
    "k_pop_median",
    "k_pop_log_sd",
    "a_pop_median",
    "a_pop_log_sd",
    "a_over_F_d_pop_median",
    "a_over_F_d_pop_log_sd",
];

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
    /// Reads and validates a model file.
    ///
    /// # Errors
    /// [`SpecError`] naming the file, the key and what to fix.
    pub fn load(path: &Path) -> Result<Self, SpecError> {
        let text = std::fs::read_to_string(path).map_err(|source| SpecError::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates model text; data paths are relative to `path`'s directory.
    ///
    /// # Errors
    /// As [`ModelSpec::load`].
    pub fn parse(text: &str, path: &Path) -> Result<Self, SpecError> {
        let file: ModelFile = toml::from_str(text).map_err(|e| SpecError::Syntax {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
        let base_dir = path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        Self::validate(file, base_dir, path.to_owned())
    }

    /// Validates a model given as a value (the quick path builds one from flags).
    ///
    /// # Errors
    /// [`SpecError::Invalid`] naming the key.
    pub fn validate(
        file: ModelFile,
        base_dir: PathBuf,
        source: PathBuf,
    ) -> Result<Self, SpecError> {
        let invalid = |key: String, message: String| SpecError::Invalid {
            path: source.clone(),
            key,
            message,
        };
        if file.materials.is_empty() || file.contacts.is_empty() || file.runs.is_empty() {
            return Err(invalid(
                "material/contact/run".into(),
                "a model needs at least one [[material]], one [[contact]] and one [[run]]".into(),
            ));
        }
        unique_names(file.materials.iter().map(|m| m.name.as_str()), "material")
            .map_err(|(k, m)| invalid(k, m))?;
        unique_names(file.contacts.iter().map(|c| c.name.as_str()), "contact")
            .map_err(|(k, m)| invalid(k, m))?;
        unique_names(file.runs.iter().map(|r| r.name.as_str()), "run")
            .map_err(|(k, m)| invalid(k, m))?;
        let mut contact_material = Vec::new();
        for (i, c) in file.contacts.iter().enumerate() {
            let m = file
                .materials
                .iter()
                .position(|m| m.name == c.material)
                .ok_or_else(|| {
                    invalid(
                        format!("contact[{i}].material"),
                        format!(
                            "no [[material]] named `{}`; declare it or fix the name",
                            c.material
                        ),
                    )
                })?;
            if let Some(f) = c.normal_force_n {
                if !(f.is_finite() && f > 0.0) {
                    return Err(invalid(
                        format!("contact[{i}].normal_force_N"),
                        format!("{f} must be a force > 0 in newtons"),
                    ));
                }
            }
            contact_material.push(m);
        }
        let mut run_contact = Vec::new();
        for (i, r) in file.runs.iter().enumerate() {
            let c = file
                .contacts
                .iter()
                .position(|c| c.name == r.contact)
                .ok_or_else(|| {
                    invalid(
                        format!("run[{i}].contact"),
                        format!(
                            "no [[contact]] named `{}`; declare it or fix the name",
                            r.contact
                        ),
                    )
                })?;
            let v = r.velocity_m_per_s;
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(
                    format!("run[{i}].velocity_m_per_s"),
                    format!("{v} must be a sliding velocity > 0 in m/s (e.g. 1e-9 for 1 nm/s)"),
                ));
            }
            if let Some([a, b]) = r.window_s {
                if !(a.is_finite() && b.is_finite() && a < b) {
                    return Err(invalid(
                        format!("run[{i}].window_s"),
                        format!("[{a}, {b}] must be [start, end] with start < end (s)"),
                    ));
                }
            }
            validate_import(r).map_err(|(k, m)| invalid(format!("run[{i}].{k}"), m))?;
            run_contact.push(c);
        }
        let mut run_follows = Vec::new();
        for (i, r) in file.runs.iter().enumerate() {
            let follows = match (r.scene, &r.follows) {
                (Scene::Repeat, Some(name)) => {
                    let j = file
                        .runs
                        .iter()
                        .position(|o| &o.name == name)
                        .ok_or_else(|| {
                            invalid(
                                format!("run[{i}].follows"),
                                format!("no [[run]] named `{name}`"),
                            )
                        })?;
                    if file.runs[j].scene != Scene::First || run_contact[j] != run_contact[i] {
                        return Err(invalid(
                            format!("run[{i}].follows"),
                            format!("`{name}` must be a first slide of the same contact"),
                        ));
                    }
                    Some(j)
                }
                (Scene::Repeat, None) => (0..file.runs.len()).find(|&j| {
                    file.runs[j].scene == Scene::First && run_contact[j] == run_contact[i]
                }),
                (_, Some(_)) => {
                    return Err(invalid(
                        format!("run[{i}].follows"),
                        "only a repeat slide follows another run".into(),
                    ))
                }
                (_, None) => None,
            };
            run_follows.push(follows);
        }
        for (name, prior) in &file.priors {
            if !PRIOR_NAMES.contains(&name.as_str()) {
                return Err(invalid(
                    format!("priors.{name}"),
                    format!(
                        "unknown parameter; priors can be given for {}",
                        PRIOR_NAMES.join(", ")
                    ),
                ));
            }
            prior
                .validate(name)
                .map_err(|m| invalid(format!("priors.{name}"), m))?;
            if !prior.positive_support() {
                return Err(invalid(
                    format!("priors.{name}"),
                    "parameters are positive and sampled on the log scale: give a prior on θ > 0 \
                     (e.g. `low = 0` for uniform or normal)"
                        .into(),
                ));
            }
        }
        validate_rate_state(&file).map_err(|(k, m)| invalid(k, m))?;
        for p in [Param::T0, Param::FD, Param::K, Param::A] {
            let level = file.levels.get(&p).copied().unwrap_or(p.default_level());
            if file.pooling.pools(p) && level == Level::Material {
                return Err(invalid(
                    format!("pooling.{}", p.name()),
                    format!(
                        "{0} pooled within a material needs {0} at the contact or run level: \
                         add `{0} = \"contact\"` under [levels]",
                        p.name()
                    ),
                ));
            }
        }
        let tolerance = file.likelihood.tolerance;
        if !(tolerance.is_finite() && tolerance >= 0.0) {
            return Err(invalid(
                "likelihood.tolerance".into(),
                format!(
                    "{tolerance} must be a log-likelihood error >= 0 (0: every point exactly; \
                     default {DEFAULT_LIKELIHOOD_TOLERANCE})"
                ),
            ));
        }
        let s = &file.sampler;
        if s.ensembles == 0 {
            return Err(invalid(
                "sampler.ensembles".into(),
                "need at least 1 ensemble (4 recommended, for R-hat)".into(),
            ));
        }
        if s.max_time_s.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
            return Err(invalid(
                "sampler.max_time_s".into(),
                "must be a finite number of seconds > 0".into(),
            ));
        }
        if s.steps == Some(0) || s.max_steps == 0 || s.checkpoint_every == 0 {
            return Err(invalid(
                "sampler".into(),
                "steps, max_steps and checkpoint_every must be > 0".into(),
            ));
        }
        let spec = Self {
            file,
            base_dir,
            source: source.clone(),
            contact_material,
            run_contact,
            run_follows,
        };
        spec.refuse_unused_settings()
            .map_err(|(key, message)| invalid(key, message))?;
        Ok(spec)
    }

    /// The parameters some run of the model samples under the forward model `forward`.
    pub fn params_in_use(&self, forward: ForwardModel) -> BTreeSet<Param> {
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
    pub fn prior_names_in_use(&self, forward: ForwardModel) -> BTreeSet<String> {
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

    /// Every `[levels]`, `[pooling]` and `[priors]` key of the file, as `table.name`, with
    /// whether the model reads it under `forward`.
    fn setting_keys(&self, forward: ForwardModel) -> Vec<(String, bool)> {
        let used = self.params_in_use(forward);
        let priors = self.prior_names_in_use(forward);
        let levels = self
            .file
            .levels
            .keys()
            .map(|p| (format!("levels.{}", p.name()), used.contains(p)));
        let pooling = Param::ALL
            .into_iter()
            .filter(|&p| self.file.pooling.pools(p))
            .map(|p| (format!("pooling.{}", p.name()), used.contains(&p)));
        let prior_keys = self
            .file
            .priors
            .keys()
            .map(|n| (format!("priors.{n}"), priors.contains(n)));
        levels.chain(pooling).chain(prior_keys).collect()
    }

    /// The settings of the file that name a parameter this model does not sample but the
    /// default model (the aging–rejuvenation law through the spring) does: left over when a
    /// model file is fitted again under a rival law with one line changed, which is how rival
    /// models are meant to be compared. They are not read; a fit records them
    /// ([`ForwardModelRecord`](crate::fit::ForwardModelRecord)`::unread`) and says so.
    pub fn unread_settings(&self) -> Vec<String> {
        self.setting_keys(self.forward())
            .into_iter()
            .filter(|(_, read)| !read)
            .map(|(key, _)| key)
            .collect()
    }

    /// A prior, level or pooling that no forward model would read (a/F_d sampled in place of
    /// a, a pooled t0's own prior, a level of a parameter no scene uses): an error naming its
    /// key, since a user who wrote it expects it to act.
    fn refuse_unused_settings(&self) -> Result<(), (String, String)> {
        // What the default model reads, and the settings of rate-and-state's own parameters
        // (b, D_c): either are left over when a file is refitted under the other law with
        // the law line changed.
        let rate_state = ForwardModel {
            law: LawKind::RateState,
            ..ForwardModel::default()
        };
        let own_to_rate_state = |key: &str| {
            key.split_once('.')
                .is_some_and(|(_, name)| [Param::B, Param::Dc].map(Param::name).contains(&name))
        };
        let default_reads: BTreeSet<String> = self
            .setting_keys(ForwardModel::default())
            .into_iter()
            .chain(
                self.setting_keys(rate_state)
                    .into_iter()
                    .filter(|(key, _)| own_to_rate_state(key)),
            )
            .filter_map(|(key, read)| read.then_some(key))
            .collect();
        let Some((key, _)) = self
            .setting_keys(self.forward())
            .into_iter()
            .find(|(key, read)| !read && !default_reads.contains(key))
        else {
            return Ok(());
        };
        let aging = match self.file.aging {
            Aging::Ratio => "ratio",
            Aging::Absolute => "absolute",
        };
        let read: Vec<String> = self
            .prior_names_in_use(self.forward())
            .into_iter()
            .collect();
        Err((
            key,
            format!(
                "this model (law = \"{}\", elastic = {}, aging = \"{aging}\") samples no \
                 parameter this setting applies to, so it would have no effect; remove it (priors \
                 are read for {})",
                self.file.law,
                self.file.elastic,
                read.join(", ")
            ),
        ))
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

    /// Prior of a named quantity: the model file's, else the default.
    pub fn prior(&self, name: &str) -> Prior {
        // The median of a pooled F_d, k or a population follows the parameter's prior.
        let follows = name
            .strip_suffix("_pop_median")
            .filter(|p| *p != "t0" && self.file.priors.contains_key(*p));
        self.file
            .priors
            .get(name)
            .cloned()
            .or_else(|| follows.map(|p| self.prior(p)))
            .or_else(|| default_prior(name))
            .unwrap_or(Prior::LogUniform {
                low: 1e-300,
                high: 1e300,
            })
    }

    /// How to read a run's data file.
    pub fn import_options(&self, run: usize) -> ImportOptions {
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
    pub fn reduction_tolerances(&self, points: &[usize]) -> Vec<Option<f64>> {
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

/// Checks the keys of rate-and-state friction: used only under `law = "rate-state"`, which
/// needs the machine's spring (its k is the spring of the spring-slider) on every run.
fn validate_rate_state(file: &ModelFile) -> Result<(), (String, String)> {
    let rate_state = file.law == LawKind::RateState;
    if !rate_state {
        for (key, given) in [
            ("state_law", file.state_law.is_some()),
            (
                "reference_velocity_m_per_s",
                file.reference_velocity_m_per_s.is_some(),
            ),
        ] {
            if given {
                return Err((
                    key.into(),
                    format!(
                        "only rate-and-state friction has a {key}: add `law = \"rate-state\"` \
                         or remove the key"
                    ),
                ));
            }
        }
        return Ok(());
    }
    if let Some(v) = file.reference_velocity_m_per_s {
        if !(v.is_finite() && v > 0.0) {
            return Err((
                "reference_velocity_m_per_s".into(),
                format!("{v} must be a velocity > 0 in m/s (or remove it: each run's own)"),
            ));
        }
    }
    if !file.elastic {
        return Err((
            "elastic".into(),
            "rate-and-state friction is solved on the spring-slider, whose spring is the \
             machine's stiffness k: remove `elastic = false`"
                .into(),
        ));
    }
    if let Some(i) = file.runs.iter().position(|r| r.scene == Scene::StiffFast) {
        return Err((
            format!("run[{i}].scene"),
            "under rate-and-state every slide is solved through the machine's spring: write \
             `scene = \"first\"` for a fast first slide"
                .into(),
        ));
    }
    Ok(())
}

/// Checks a run's import settings; the error names the key below `run[i]`.
fn validate_import(r: &RunSpec) -> Result<(), (String, String)> {
    if let Some(arm) = r.moment_arm_m {
        if !(arm.is_finite() && arm > 0.0) {
            return Err((
                "moment_arm_m".into(),
                format!("{arm} must be a length > 0 in metres (e.g. 7e-3 for 7 mm)"),
            ));
        }
    }
    if r.bins.is_some() {
        return Err((
            "bins".into(),
            "means of consecutive points are no longer fitted (evaluated at the bin's mean \
             time they bias t0); remove `bins`: a run longer than `[likelihood] exact_up_to` \
             points is reduced to sufficient statistics within `likelihood_tolerance` \
             (docs/model.md §5, \"Long records\")"
                .into(),
        ));
    }
    if let Some(tolerance) = r.likelihood_tolerance {
        if !(tolerance.is_finite() && tolerance >= 0.0) {
            return Err((
                "likelihood_tolerance".into(),
                format!("{tolerance} must be a log-likelihood error >= 0 (0: every point exactly)"),
            ));
        }
    }
    if let Some(map) = &r.columns {
        let mut refs = vec![("time", &map.time), ("force", &map.force)];
        if let Some(normal) = &map.normal_force {
            refs.push(("normal_force", normal));
        }
        for (key, column) in refs {
            if column.name.trim().is_empty() {
                return Err((
                    format!("columns.{key}.name"),
                    "give the column's name as in the file's header".into(),
                ));
            }
            if let Some(unit) = &column.unit {
                if parse_unit(unit).is_none() {
                    return Err((
                        format!("columns.{key}.unit"),
                        format!("unknown unit `{unit}`; slipbayes knows {KNOWN_UNITS}"),
                    ));
                }
            }
        }
    }
    Ok(())
}

fn unique_names<'a>(
    names: impl Iterator<Item = &'a str>,
    what: &str,
) -> Result<(), (String, String)> {
    let mut seen = HashSet::new();
    for (i, n) in names.enumerate() {
        if n.trim().is_empty() || n.contains(['[', ']', ',']) {
            return Err((
                format!("{what}[{i}].name"),
                format!("`{n}` must be non-empty and free of `[`, `]` and `,`"),
            ));
        }
        if !seen.insert(n) {
            return Err((
                format!("{what}[{i}].name"),
                format!("`{n}` is used twice; {what} names must be unique"),
            ));
        }
    }
    Ok(())
}
