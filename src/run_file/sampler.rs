//! The `[sampler]` table of a run file: walkers, ensembles, run length, seed, checkpoints,
//! moves and updates, and the block settings the posterior is built with.

use serde::{Deserialize, Serialize};

use crate::model::{BlockSettings, Blocking, PopulationUpdates};
use crate::sampler::{CarryFit, Mixture, Updates};

/// The `[sampler]` table of a run file: how the posterior is sampled. Every key is optional;
/// the command line's flags override them (`fit::SettingOverrides`).
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

impl SamplerSpec {
    /// The block settings the posterior is built with (`blocks`, `populations`).
    pub fn blocking(&self) -> BlockSettings {
        BlockSettings {
            blocks: self.blocks,
            populations: self.populations,
        }
    }

    /// Checks the values serde cannot: the finding names the key below `sampler` and says
    /// what to write.
    pub(super) fn check(&self) -> Result<(), (String, String)> {
        if self.ensembles == 0 {
            return Err((
                "sampler.ensembles".into(),
                "need at least 1 ensemble (4 recommended, for R-hat)".into(),
            ));
        }
        if self.max_time_s.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
            return Err((
                "sampler.max_time_s".into(),
                "must be a finite number of seconds > 0".into(),
            ));
        }
        if self.steps == Some(0) || self.max_steps == 0 || self.checkpoint_every == 0 {
            return Err((
                "sampler".into(),
                "steps, max_steps and checkpoint_every must be > 0".into(),
            ));
        }
        Ok(())
    }
}
