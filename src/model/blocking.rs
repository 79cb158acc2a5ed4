//! The block settings of a posterior: how its coordinates are grouped into blocks for blocked
//! and hierarchical updates, and how a pooled parameter's population moves. A sampler setting
//! in the run file's `[sampler]` table (`blocks`, `populations`), read at the edge and handed
//! to [`Posterior::new`](super::Posterior::new): the posterior builds its blocks from it and
//! tells the sampler which blocks it may draw exactly, and the model never reads how it is
//! sampled.

use serde::{Deserialize, Serialize};

/// How a posterior's blocks are grouped and its populations updated.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BlockSettings {
    /// What a block is.
    pub blocks: Blocking,
    /// How a pooled parameter's population moves.
    pub populations: PopulationUpdates,
}

/// How the population of a pooled parameter (its μ and ln s) is updated.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PopulationUpdates {
    /// Both, one after the other, while the sampler tunes its carried moves; then the
    /// carried move only where it moved the population about as far as the exact draw (the
    /// default): where the data pin the members the exact draw does the work alone and the
    /// carried move's evaluations are saved. The sampler measures this for each block the
    /// posterior marks as optional.
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
    /// Whether this is the default (`auto`), which a run file need not write.
    pub(crate) fn is_default(&self) -> bool {
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
