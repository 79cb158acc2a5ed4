//! Checkpoints: the sampler's complete state ([`SamplerState`]), the borrowed view a
//! checkpoint serialises, and the thinned history that a checkpoint leaves out and the chains
//! restore.

use serde::{Deserialize, Serialize};

use super::super::config::{SamplerConfig, Updates};
use super::super::ensemble::{Ensemble, EnsembleState};
use super::super::error::SamplerError;
use super::super::history::{rebuild, History, RowHistory};
use super::super::moves::{Move, MoveSpec};
use super::super::sink::ChainSink;
use super::EnsembleSampler;
use crate::density::LogDensity;

/// Version of the [`SamplerState`] layout.
pub const STATE_VERSION: u32 = 1;

/// Everything needed to continue a run exactly where it stopped (serde-serialisable).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SamplerState {
    /// Layout version ([`STATE_VERSION`]).
    pub version: u32,
    /// Seed the streams were derived from (informative; the streams themselves are stored).
    pub seed: u64,
    /// Sampled dimensions.
    pub ndim: usize,
    /// Derived values per walker.
    pub nderived: usize,
    /// Walkers per ensemble.
    pub walkers: usize,
    /// The moves (their specs) and weights the chains were drawn with; a resumed run must use
    /// the same to continue the same chains (states written before moves were selectable used
    /// the stretch move alone).
    #[serde(default = "stretch_alone")]
    pub moves: Vec<(MoveSpec, f64)>,
    /// Joint or blocked updates (states written before blocked updates existed were joint).
    #[serde(default)]
    pub updates: Updates,
    /// Steps completed.
    pub step: u64,
    /// Per-ensemble state.
    pub ensembles: Vec<EnsembleState>,
    /// Thinned history used by τ and R̂. Checkpoints leave it out (`None`): which rows it keeps
    /// follows from the step count and the configured history rows, and their values are in
    /// the chains, so [`SamplerState::rebuild_history`] restores it from them and a checkpoint
    /// stays as small as one step of the ensembles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history: Option<History>,
    /// τ per (ensemble, parameter) at the last stopping-rule check, over the whole chains.
    pub last_tau: Option<Vec<Vec<f64>>>,
    /// The same after the first quarter and after the first half of the steps (the later
    /// windows the stopping rule looks at; empty in states written before it did).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub last_tau_later: Vec<Option<Vec<Vec<f64>>>>,
    /// Per block, the squared distances its exact draws and its carried moves moved it over
    /// the tuning steps (empty when no block's carried move is optional).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub carry_jumps: Vec<[f64; 2]>,
}

impl SamplerState {
    /// Restores the history a checkpoint leaves out, from the chains: `column(p)` gives
    /// parameter `p` of every recorded row (step, then ensemble, then walker, steps `0..step`).
    /// `config` is the run's; the rows kept are those an uninterrupted run with it would have
    /// kept, so a resumed run stops where it would have.
    ///
    /// # Errors
    /// What `column` returns, or [`SamplerError::Shape`] when a column has the wrong length.
    pub fn rebuild_history<E: From<SamplerError>>(
        &mut self,
        config: &SamplerConfig,
        mut column: impl FnMut(usize) -> Result<Vec<f64>, E>,
    ) -> Result<(), E> {
        let rows = self.step as usize * self.ensembles.len() * self.walkers;
        self.rebuild_history_rows(config, |p, wanted| {
            let values = column(p)?;
            if values.len() != rows {
                return Err(SamplerError::Shape {
                    what: format!("chains of parameter {p} for the history"),
                    expected: rows,
                    got: values.len(),
                }
                .into());
            }
            Ok(wanted.iter().map(|&r| values[r]).collect())
        })
    }

    /// [`rebuild_history`](Self::rebuild_history) from the rows it keeps alone:
    /// `column(p, rows)` gives parameter `p` at the recorded `rows` (increasing indices in
    /// the chains' order), so that a long run's history is restored without reading whole
    /// columns.
    ///
    /// # Errors
    /// What `column` returns, or [`SamplerError::Shape`] when it gives the wrong number of
    /// values.
    pub(crate) fn rebuild_history_rows<E: From<SamplerError>>(
        &mut self,
        config: &SamplerConfig,
        column: impl FnMut(usize, &[usize]) -> Result<Vec<f64>, E>,
    ) -> Result<(), E> {
        let shape = (self.ensembles.len(), self.walkers, self.ndim);
        let max_rows = config.history_rows_for(self.ndim);
        self.history = Some(rebuild(self.step, max_rows, shape, column)?);
        Ok(())
    }
}

fn stretch_alone() -> Vec<(MoveSpec, f64)> {
    vec![(Move::stretch().spec(), 1.0)]
}

/// The specs and weights of `moves`.
pub(super) fn specs(moves: &[(Move, f64)]) -> Vec<(MoveSpec, f64)> {
    moves.iter().map(|(m, w)| (m.spec(), *w)).collect()
}

/// A mixture's specs and weights as a list, `stretch(a=2)=0.5, ...`.
pub(super) fn written(moves: &[(MoveSpec, f64)]) -> String {
    let parts: Vec<String> = moves.iter().map(|(m, w)| format!("{m}={w}")).collect();
    parts.join(", ")
}

impl<D: LogDensity + ?Sized> EnsembleSampler<'_, D> {
    /// A copy of the complete state, from which [`from_state`](Self::from_state) continues.
    pub fn state(&self) -> SamplerState {
        SamplerState {
            version: STATE_VERSION,
            seed: self.config.seed(),
            ndim: self.ndim,
            nderived: self.nderived,
            walkers: self.config.walkers(),
            moves: specs(self.config.moves()),
            updates: self.config.updates(),
            step: self.step,
            ensembles: self.ensembles.iter().map(|e| e.s.clone()).collect(),
            history: (!self.history_released).then(|| self.history.to_history()),
            last_tau: self.last_tau[0].clone(),
            last_tau_later: self.last_tau[1..].to_vec(),
            carry_jumps: self.carry_jumps.clone(),
        }
    }

    /// Frees the thinned history of the stopping rule (its rows are in the chains), so that
    /// what the caller does between runs (summaries of every recorded draw, say) has its
    /// memory; [`restore_history`](Self::restore_history) brings it back before the next
    /// run, which refuses to start without it. A state taken meanwhile has no history, like a
    /// checkpoint.
    pub fn release_history(&mut self) {
        if self.history_released {
            return;
        }
        let h = &self.history;
        let mut empty = RowHistory::new(0, h.width, h.max_rows);
        (empty.thin, empty.rows) = (h.thin, h.rows);
        self.history = empty;
        self.history_released = true;
    }

    /// Restores a released history from the recorded chains: `column(p, rows)` gives
    /// parameter `p` at the recorded `rows` (increasing indices in the chains' order: step,
    /// then ensemble, then walker). The rows are those the history held, bit for bit. Does
    /// nothing when the history was not released.
    ///
    /// # Errors
    /// What `column` returns; [`SamplerError::Shape`] when it gives the wrong number of
    /// values.
    pub fn restore_history<E: From<SamplerError>>(
        &mut self,
        column: impl FnMut(usize, &[usize]) -> Result<Vec<f64>, E>,
    ) -> Result<(), E> {
        if !self.history_released {
            return Ok(());
        }
        let shape = (self.ensembles.len(), self.config.walkers(), self.ndim);
        let (thin, rows, max_rows) = (self.history.thin, self.history.rows, self.history.max_rows);
        let restored = rebuild(self.step, max_rows, shape, column)?;
        if (restored.thin, restored.rows) != (thin, rows) {
            return Err(SamplerError::Shape {
                what: format!("history restored at step {} (thinning {thin})", self.step),
                expected: rows,
                got: restored.rows,
            }
            .into());
        }
        self.history = RowHistory::from_history(&restored, self.config.walkers() * self.ndim);
        self.history.max_rows = max_rows;
        self.history_released = false;
        Ok(())
    }

    pub(super) fn checkpoint<S: ChainSink>(&self, sink: &mut S) -> Result<(), SamplerError> {
        // A borrowed view serialising exactly like `self.state()`, so that a checkpoint
        // copies nothing unless the sink serialises it.
        sink.checkpoint(&StateView {
            seed: self.config.seed(),
            ndim: self.ndim,
            nderived: self.nderived,
            walkers: self.config.walkers(),
            moves: self.config.moves(),
            updates: self.config.updates(),
            step: self.step,
            ensembles: &self.ensembles,
            last_tau: &self.last_tau,
            carry_jumps: &self.carry_jumps,
        })
        .map_err(|err| SamplerError::Sink {
            step: self.step,
            source: Box::new(err),
        })
    }
}

/// Borrowed form of [`SamplerState`] for checkpoints; serialises to the same fields but the
/// history, which [`SamplerState::rebuild_history`] restores from the chains.
struct StateView<'s> {
    seed: u64,
    ndim: usize,
    nderived: usize,
    walkers: usize,
    moves: &'s [(Move, f64)],
    updates: Updates,
    step: u64,
    ensembles: &'s [Ensemble],
    last_tau: &'s [Option<Vec<Vec<f64>>>],
    carry_jumps: &'s [[f64; 2]],
}

impl Serialize for StateView<'_> {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        struct Ensembles<'s>(&'s [Ensemble]);
        impl Serialize for Ensembles<'_> {
            fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
                ser.collect_seq(self.0.iter().map(|e| &e.s))
            }
        }
        // The exact count of fields written: binary formats write it ahead of them.
        let fields = 11 + usize::from(!self.carry_jumps.is_empty());
        let mut st = ser.serialize_struct("SamplerState", fields)?;
        st.serialize_field("version", &STATE_VERSION)?;
        st.serialize_field("seed", &self.seed)?;
        st.serialize_field("ndim", &self.ndim)?;
        st.serialize_field("nderived", &self.nderived)?;
        st.serialize_field("walkers", &self.walkers)?;
        st.serialize_field("moves", self.moves)?;
        st.serialize_field("updates", &self.updates)?;
        st.serialize_field("step", &self.step)?;
        st.serialize_field("ensembles", &Ensembles(self.ensembles))?;
        st.serialize_field("last_tau", &self.last_tau[0])?;
        st.serialize_field("last_tau_later", &self.last_tau[1..])?;
        if self.carry_jumps.is_empty() {
            st.skip_field("carry_jumps")?;
        } else {
            st.serialize_field("carry_jumps", self.carry_jumps)?;
        }
        st.end()
    }
}
