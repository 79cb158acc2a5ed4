//! A chain sink that keeps everything in memory, for tests and small runs.

use std::convert::Infallible;

use serde::Serialize;

use super::sink::{ChainSink, StepView};

/// Draws of one ensemble, stored step-major: row `(step, walker)` at
/// `(step * walkers + walker) * ndim`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MemoryChain {
    /// Step number of each stored step.
    pub steps: Vec<u64>,
    /// Positions, `steps × walkers × ndim`.
    pub positions: Vec<f64>,
    /// Log-densities, `steps × walkers`.
    pub log_density: Vec<f64>,
    /// Derived values, `steps × walkers × nderived`.
    pub derived: Vec<f64>,
    /// Walkers per step (0 until the first step).
    pub walkers: usize,
    /// Parameters.
    pub ndim: usize,
}

impl MemoryChain {
    /// Series of parameter `p` of walker `w` over all stored steps.
    pub fn walker_series(&self, w: usize, p: usize) -> Vec<f64> {
        let stride = self.walkers * self.ndim;
        self.positions
            .iter()
            .skip(w * self.ndim + p)
            .step_by(stride)
            .copied()
            .collect()
    }
}

/// Vec-backed [`ChainSink`]; the last checkpointed state is kept as JSON.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MemorySink {
    /// One chain per ensemble.
    pub chains: Vec<MemoryChain>,
    /// The last checkpoint, serialised as JSON.
    pub last_checkpoint: Option<String>,
    /// Number of checkpoints received.
    pub checkpoints: usize,
}

impl MemorySink {
    /// An empty sink.
    pub fn new() -> Self {
        Self::default()
    }

    /// Parameter `p` of every recorded row in recording order (step, then ensemble, then
    /// walker): the column [`SamplerState::rebuild_history`](super::SamplerState::rebuild_history)
    /// takes.
    pub fn position_column(&self, p: usize) -> Vec<f64> {
        let steps = self.chains.first().map_or(0, |c| c.steps.len());
        let mut column = Vec::new();
        for t in 0..steps {
            for c in &self.chains {
                let row = &c.positions[t * c.walkers * c.ndim..(t + 1) * c.walkers * c.ndim];
                column.extend(row.iter().skip(p).step_by(c.ndim));
            }
        }
        column
    }
}

impl ChainSink for MemorySink {
    type Error = serde_json::Error;

    fn record(&mut self, step: &StepView<'_>) -> Result<(), Self::Error> {
        if self.chains.len() <= step.ensemble {
            self.chains
                .resize_with(step.ensemble + 1, MemoryChain::default);
        }
        let c = &mut self.chains[step.ensemble];
        c.walkers = step.walkers();
        c.ndim = step.ndim;
        c.steps.push(step.step);
        c.positions.extend_from_slice(step.positions);
        c.log_density.extend_from_slice(step.log_density);
        c.derived.extend_from_slice(step.derived);
        Ok(())
    }

    fn checkpoint<S: Serialize>(&mut self, state: &S) -> Result<(), Self::Error> {
        self.last_checkpoint = Some(serde_json::to_string(state)?);
        self.checkpoints += 1;
        Ok(())
    }
}

/// A sink that discards everything (benchmarks, runs watched only through the report).
#[derive(Debug, Clone, Copy, Default)]
pub struct NullSink;

impl ChainSink for NullSink {
    type Error = Infallible;
    fn record(&mut self, _step: &StepView<'_>) -> Result<(), Self::Error> {
        Ok(())
    }
    fn checkpoint<S: Serialize>(&mut self, _state: &S) -> Result<(), Self::Error> {
        Ok(())
    }
}
