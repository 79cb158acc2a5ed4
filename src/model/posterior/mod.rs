//! The joint posterior of a model over all its runs, as a [`LogDensity`] for the sampler.
//!
//! Built in three steps ([`Posterior::from_data`]): the `layout` of sampled coordinates and
//! reported columns, the runs with their data, and the evaluation order. Each part of the
//! density has a file of its own:
//!
//! - `layout`: which coordinate each parameter of each run reads (levels, pooling, the
//!   marginalised σ groups) and which column each reported value goes to.
//! - `likelihood`: a sum over runs; each run's term reads only its contact's and
//!   material's coordinates.
//! - `sigma`: σ integrated out of the likelihood and drawn from its conditional posterior.
//! - `derived`: the reported values of a draw (SI parameters, peaks, a new contact's peak).
//! - `start`: the optimiser's start from rough features of the data (computed on first use).
//! - `long_records`: long runs reduced to sufficient statistics of bins of their points.
//! - `predictive`: curves of single runs and the posterior predictive bands.
//! - `prior_predictive`: parameters and data drawn from the prior (simulation-based
//!   calibration).
//!
//! The model itself is described in `docs/model.md`.

mod blocks;
mod derived;
mod explain;
mod independent;
mod layout;
mod likelihood;
mod long_records;
mod pointwise;
mod predictive;
mod prior_predictive;
mod share;
mod sigma;
mod start;

use std::ops::Range;
use std::path::PathBuf;
use std::sync::OnceLock;

use blocks::{Block, Cache};
use layout::{Coord, CoordPrior, Layout, MaterialModel, Population, SigmaGroup, Source};
use likelihood::RunModel;

use super::blocking::{BlockSettings, Blocking, PopulationUpdates};
use super::data::RunData;
use super::spec::ModelSpec;
use crate::density::{
    BlockPlan, BlockUpdate, BlockedDensity, CarriedMove, CarryFollowers, ColumnUnit,
    ExactConditional, LogDensity, LogDensityError, OwnEntries, PlannedBlock, Quantity, ShareError,
    SplitByPart,
};
use crate::law::Scene;
use crate::optimize::{SearchMap, SearchStart};

pub use likelihood::{REJECT_LAW, REJECT_PRIOR, REJECT_RATE_STATE, REJECT_STICK_SLIP};
pub use pointwise::{ModelLoo, PointwiseError};
pub use predictive::Band;
pub use prior_predictive::{PriorDraw, PriorDrawError};
pub use share::{DataShare, DataShareError};

/// The posterior of a validated model with its data loaded.
#[derive(Debug, Clone)]
pub struct Posterior {
    /// The model it was built from.
    spec: ModelSpec,
    /// How its blocks are grouped and its populations updated.
    blocking: BlockSettings,
    coords: Vec<Coord>,
    /// The reported columns, in the order of the derived values.
    quantities: Vec<Quantity>,
    /// How each reported column is computed.
    sources: Vec<Source>,
    runs: Vec<RunModel>,
    /// Run indices in evaluation order: slides that others follow come first.
    order: Vec<usize>,
    /// Blocks of coordinates for blocked updates (see `blocks`).
    blocks: Vec<Block>,
    /// The blocks from this one on are independent of one another given the others
    /// (`blocks::independent_last`).
    first_independent: usize,
    /// Which independent block owns each coordinate, run and σ group.
    owners: blocks::Owners,
    /// Where each independent block's update finds its entries of a walker's state.
    own: Vec<independent::OwnLayout>,
    sigma_groups: Vec<SigmaGroup>,
    populations: Vec<Population>,
    materials: Vec<MaterialModel>,
    /// Per contact: coordinate of ln F_d.
    contact_fd: Vec<Option<usize>>,
    /// The optimiser's start, computed on first use (it fits every slide on its own).
    start: OnceLock<start::StartPoint>,
    /// The parameter points the long runs' bins were chosen at (`long_records`; empty when
    /// no run is long): a process that holds a share of the data chooses its runs' bins there.
    reduced_at: Vec<Vec<f64>>,
}

/// Errors building a posterior.
#[derive(Debug, thiserror::Error)]
pub enum PosteriorError {
    /// A run's data could not be loaded or is unusable.
    #[error(transparent)]
    Data(#[from] super::data::RunDataError),
    /// A structural problem (e.g. a parameter at a level that does not fit the scenes).
    #[error("{source_file}: {message}")]
    Model {
        /// Model file.
        source_file: PathBuf,
        /// What is wrong and what to do.
        message: String,
    },
}

impl Posterior {
    /// Loads every run's data (with its format, columns and window) and builds the posterior
    /// over them, its blocks grouped as `blocking` says; a long run is reduced to sufficient
    /// statistics (`long_records`).
    ///
    /// # Errors
    /// [`PosteriorError`] naming the file, line or key at fault.
    pub fn new(spec: &ModelSpec, blocking: BlockSettings) -> Result<Self, PosteriorError> {
        let data = (0..spec.file.runs.len())
            .map(|i| RunData::for_run(spec, i))
            .collect::<Result<Vec<_>, _>>()?;
        Self::from_data(spec, blocking, data)
    }

    /// The posterior of `spec` over data already in memory, one [`RunData`] per run of the
    /// model in its order (the runs' data paths are not read).
    ///
    /// # Errors
    /// [`PosteriorError::Model`] when the number of data sets is not the number of runs.
    pub fn from_data(
        spec: &ModelSpec,
        blocking: BlockSettings,
        data: Vec<RunData>,
    ) -> Result<Self, PosteriorError> {
        let mut posterior = Self::unreduced(spec, blocking, data)?;
        posterior.reduce_long_runs();
        Ok(posterior)
    }

    /// The posterior of `spec` over `data` with every run exact (no long run reduced yet).
    fn unreduced(
        spec: &ModelSpec,
        blocking: BlockSettings,
        data: Vec<RunData>,
    ) -> Result<Self, PosteriorError> {
        if data.len() != spec.file.runs.len() {
            return Err(PosteriorError::Model {
                source_file: spec.source.clone(),
                message: format!(
                    "{} data sets for {} runs; give one per [[run]], in the model's order",
                    data.len(),
                    spec.file.runs.len()
                ),
            });
        }
        let layout = Layout::new(spec, data);
        let order = evaluation_order(&layout.runs);
        let group = |r: &RunModel| match blocking.blocks {
            Blocking::Material => spec.contact_material[r.contact],
            Blocking::Contact => r.contact,
        };
        let population = |b: &Block| blocks::holds_population(b, &layout.populations);
        let (blocks, first_independent) = blocks::independent_last(
            blocks::blocks(
                &layout.coords,
                &layout.runs,
                &order,
                layout.sigma_groups.len(),
                group,
            ),
            population,
        );
        let group_runs: Vec<&[usize]> = layout.sigma_groups.iter().map(|g| &g.runs[..]).collect();
        let owners = blocks::Owners::new(
            &blocks,
            first_independent,
            layout.coords.len(),
            &layout.runs,
            &group_runs,
        );
        let mut posterior = Self {
            spec: spec.clone(),
            blocking,
            coords: layout.coords,
            quantities: layout.quantities,
            sources: layout.sources,
            runs: layout.runs,
            order,
            blocks,
            first_independent,
            owners,
            own: Vec::new(),
            sigma_groups: layout.sigma_groups,
            populations: layout.populations,
            materials: layout.materials,
            contact_fd: layout.contact_fd,
            start: OnceLock::new(),
            reduced_at: Vec::new(),
        };
        posterior.own = independent::own_layouts(&posterior);
        Ok(posterior)
    }

    /// Whether block `b` holds populations (each a pooled parameter's μ and ln s in a material).
    fn is_population(&self, b: usize) -> bool {
        blocks::holds_population(&self.blocks[b], &self.populations)
    }

    /// The model this posterior was built from.
    pub fn spec(&self) -> &ModelSpec {
        &self.spec
    }

    /// How its blocks are grouped and its populations updated.
    pub fn blocking(&self) -> BlockSettings {
        self.blocking
    }

    /// The reported columns, in the order of the derived values: every parameter in SI units
    /// and every derived quantity.
    pub fn quantities(&self) -> &[Quantity] {
        &self.quantities
    }

    /// Each sampled coordinate with a sentence describing its prior.
    pub fn prior_descriptions(&self) -> Vec<(String, String)> {
        self.coords
            .iter()
            .map(|c| {
                let d = match &c.prior {
                    CoordPrior::Log(p) => format!("ln of a parameter with prior {}", p.describe()),
                    CoordPrior::Population { mu, ln_s } => format!(
                        "normal with mean {} and sd exp({}) (pooled, centred)",
                        self.coords[*mu].name, self.coords[*ln_s].name
                    ),
                };
                (c.name.clone(), d)
            })
            .collect()
    }

    /// Where each run's data came from and what was done to them (the `data` of
    /// `summary.json`).
    pub fn data_provenance(&self) -> Vec<crate::data::Provenance> {
        self.runs
            .iter()
            .map(|r| r.data.provenance.clone())
            .collect()
    }

    /// Each run's name with the instrument time of its last observation (s).
    pub fn record_ends(&self) -> Vec<(&str, f64)> {
        self.runs
            .iter()
            .map(|r| (r.name.as_str(), r.data.model_times[r.data.n_obs - 1]))
            .collect()
    }

    /// Observations in the longest run.
    pub fn max_points(&self) -> usize {
        self.runs.iter().map(|r| r.data.n_obs).max().unwrap_or(0)
    }

    /// Material names, in model order.
    pub fn materials(&self) -> Vec<&str> {
        self.materials.iter().map(|m| m.name.as_str()).collect()
    }

    /// A starting point for the optimiser, from rough features of the data; computed the
    /// first time it is asked for.
    pub fn start(&self) -> &[f64] {
        &self.start.get_or_init(|| self.heuristic_start()).point
    }

    /// Starts the optimiser at `point` (sampled coordinates) instead of the rough start from
    /// the data: an earlier fit of the same model on part of these data is nearer the mode,
    /// and skips fitting each slide alone. Returns `false`, changing nothing, when the start
    /// was already set or the density is not finite at `point`.
    pub fn warm_start(&self, point: Vec<f64>) -> bool {
        if point.len() != self.dim() || self.start.get().is_some() {
            return false;
        }
        let mut derived = vec![0.0; self.derived_names().len()];
        if !self
            .log_density(&point, &mut derived)
            .is_ok_and(f64::is_finite)
        {
            return false;
        }
        let estimates = vec![f64::NAN; point.len()];
        self.start
            .set(start::StartPoint { point, estimates })
            .is_ok()
    }

    /// Where the optimiser searches for the mode that the first walkers are drawn around:
    /// from [`start`](Self::start), in the non-centred coordinates when parameters are pooled
    /// (the centred posterior has no mode).
    pub fn search_start(&self) -> SearchStart<'_> {
        SearchStart {
            point: self.start(),
            map: self.search_map(),
        }
    }

    /// With pooling, the non-centred coordinates ([`SearchMap`]); none without.
    pub fn search_map(&self) -> Option<&dyn SearchMap> {
        (!self.populations.is_empty()).then_some(self as &dyn SearchMap)
    }

    /// How the populations are updated: the one setting of the run file the posterior's
    /// blocks read.
    fn population_updates(&self) -> PopulationUpdates {
        self.blocking.populations
    }

    /// Whether block `b` is a population drawn exactly from its conditional (which reads no
    /// data) given its members.
    fn drawn_exactly(&self, b: usize) -> bool {
        self.population_updates() != PopulationUpdates::Carried && self.is_population(b)
    }

    /// Whether block `b` is a population that carries its members along when it moves (they
    /// follow it: one block per contact).
    fn carries_members(&self, b: usize) -> bool {
        self.population_updates() != PopulationUpdates::Exact
            && self.is_population(b)
            && self.blocks[b]
                .links
                .followers
                .iter()
                .any(|&i| matches!(self.coords[i].prior, CoordPrior::Population { .. }))
    }
}

/// Runs that are followed (first and fast slides) before the repeat slides that follow them.
fn evaluation_order(runs: &[RunModel]) -> Vec<usize> {
    let (mut order, repeats): (Vec<usize>, Vec<usize>) =
        (0..runs.len()).partition(|&i| runs[i].scene != Scene::Repeat);
    order.extend(repeats);
    order
}

impl LogDensity for Posterior {
    fn dim(&self) -> usize {
        self.coords.len()
    }

    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        self.evaluate_full(x, derived, None)
    }

    fn param_names(&self) -> Vec<String> {
        self.coords.iter().map(|c| c.name.clone()).collect()
    }

    fn derived_names(&self) -> Vec<String> {
        self.quantities.iter().map(|q| q.column.clone()).collect()
    }

    /// Every coordinate is u = ln θ of the quantity reported from it.
    fn param_units(&self) -> Vec<ColumnUnit> {
        let mut units = vec![ColumnUnit::default(); self.coords.len()];
        for (q, source) in self.quantities.iter().zip(&self.sources) {
            if let Source::Coord(i) = *source {
                units[i] = ColumnUnit {
                    unit: q.unit.clone(),
                    log: true,
                };
            }
        }
        units
    }

    fn explain(&self, x: &[f64]) -> Option<String> {
        self.failures_at(x)
    }
}

/// The state of a walker is the cache of `blocks`: each block's prior, each run's fit and
/// each marginalised σ group's likelihood.
impl BlockedDensity for Posterior {
    fn state_len(&self) -> usize {
        self.cache_size()
    }

    fn log_density_with_state(
        &self,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        let cache = Cache::split(state, self.blocks.len(), self.runs.len());
        self.evaluate_full(x, derived, Some(cache))
    }

    fn log_density_after_block(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        let cache = Cache::split(state, self.blocks.len(), self.runs.len());
        self.evaluate_block(block, x, derived, cache)
    }

    /// The shared parameters and populations first, then every contact's own block (see
    /// `blocks::independent_last`). A population is drawn exactly and carries its members
    /// as `populations` in the run file says; a shared block's update splits by contact when
    /// every run and σ group it re-fits belongs to a contact (`blocks::Owners`).
    fn block_plan(&self) -> BlockPlan<'_> {
        let blocks = self
            .blocks
            .iter()
            .enumerate()
            .map(|(b, block)| {
                let carry = self
                    .carries_members(b)
                    .then_some(self as &dyn CarryFollowers);
                let update = if b >= self.first_independent {
                    BlockUpdate::Independent {
                        own: self,
                        entries: self.own_layout(b).entries.clone(),
                    }
                } else if self.drawn_exactly(b) {
                    BlockUpdate::Exact {
                        conditional: self,
                        carry: carry.map(|map| CarriedMove {
                            map,
                            optional: self.population_updates() == PopulationUpdates::Auto,
                        }),
                    }
                } else {
                    BlockUpdate::Moves { carry }
                };
                let splits = b < self.first_independent && self.owners.splits[b];
                PlannedBlock {
                    coords: block.coords.clone(),
                    links: block.links.clone(),
                    update,
                    split: splits.then_some(self as &dyn SplitByPart),
                }
            })
            .collect();
        BlockPlan { blocks }
    }
}

/// A population's conditional: its prior and its members' normal priors (the priors of the
/// block and of its followers: the rest of the density does not depend on it).
impl ExactConditional for Posterior {
    fn conditional_log_density(&self, block: usize, x: &[f64]) -> f64 {
        let mut lp = 0.0;
        for &p in &self.blocks[block].priors {
            match self.block_prior(p, x) {
                Ok(v) => lp += v,
                Err(_) => return f64::NEG_INFINITY,
            }
        }
        lp
    }

    fn log_density_after_draw(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        let cache = Cache::split(state, self.blocks.len(), self.runs.len());
        if self.is_population(block) {
            self.evaluate_block_alone(block, x, derived, cache)
        } else {
            self.evaluate_block(block, x, derived, cache)
        }
    }
}

/// The non-centred map of a block's populations: each member's ln θ keeps its standardised
/// offset (ln θ − μ)/s; the other followers stay. Jacobian s'/s per member.
impl CarryFollowers for Posterior {
    fn carry_followers(&self, block: usize, from: &[f64], to: &mut [f64]) -> f64 {
        let mut ln_jacobian = 0.0;
        for &i in &self.blocks[block].links.followers {
            let CoordPrior::Population { mu, ln_s } = self.coords[i].prior else {
                continue;
            };
            if self.blocks[block].coords.contains(&mu) {
                let ln_ratio = to[ln_s] - from[ln_s];
                to[i] = to[mu] + ln_ratio.exp() * (from[i] - from[mu]);
                ln_jacobian += ln_ratio;
            }
        }
        ln_jacobian
    }
}

/// A shared block's update split by contact (see `blocks::Owners`): what the ranks of an MPI
/// job that hold a share of the contacts evaluate.
impl SplitByPart for Posterior {
    fn share_entries(&self, block: usize, parts: Range<usize>) -> OwnEntries {
        let (derived, state) = self.share_entries_of(block, parts);
        OwnEntries { state, derived }
    }

    fn evaluate_share(
        &self,
        block: usize,
        parts: Range<usize>,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<(), ShareError> {
        let cache = Cache::split(state, self.blocks.len(), self.runs.len());
        self.evaluate_share_of(block, parts, x, derived, cache)
    }

    fn log_density_from_shares(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &[f64],
    ) -> f64 {
        self.evaluate_rest(block, x, derived, state)
    }
}

/// The non-centred coordinates of pooled parameters: each member's ln θ replaced by its
/// standardised offset z = (ln θ − μ)/s from its population, everything else as it is.
impl SearchMap for Posterior {
    fn search_point(&self, x: &[f64], y: &mut [f64]) {
        y.copy_from_slice(x);
        for (i, c) in self.coords.iter().enumerate() {
            if let CoordPrior::Population { mu, ln_s } = c.prior {
                y[i] = (x[i] - x[mu]) * (-x[ln_s]).exp();
            }
        }
    }

    fn density_point(&self, y: &[f64], x: &mut [f64]) -> f64 {
        x.copy_from_slice(y);
        let mut ln_jacobian = 0.0;
        for (i, c) in self.coords.iter().enumerate() {
            if let CoordPrior::Population { mu, ln_s } = c.prior {
                x[i] = y[mu] + y[ln_s].exp() * y[i];
                ln_jacobian += y[ln_s];
            }
        }
        ln_jacobian
    }
}
