//! What a proposal is evaluated with: the density behind each kind of update.

use crate::density::{
    BlockedDensity, ExactConditional, IndependentBlocks, LogDensity, LogDensityError,
};

/// Which evaluation a half-step's proposals need (the same for all of them), with the
/// density's capability that computes it.
#[derive(Clone, Copy)]
pub(crate) enum EvalKind<'a> {
    /// [`LogDensity::log_density`]: the whole density (joint updates).
    Full,
    /// [`BlockedDensity::log_density_with_state`]: the whole density, filling the walker's
    /// state (the start, or a resume, of blocked updates).
    FullWithState(&'a dyn BlockedDensity),
    /// [`BlockedDensity::log_density_after_block`] of this block, from the walker's state.
    Block(usize, &'a dyn BlockedDensity),
    /// [`ExactConditional::log_density_after_draw`] of this block (an exact draw), from the
    /// walker's state.
    ExactDraw(usize, &'a dyn ExactConditional),
    /// [`IndependentBlocks::update_block_state`] of this independent block, from its own
    /// entries of the walker's state: the value is the block's own terms.
    Own(usize, &'a dyn IndependentBlocks),
}

impl std::fmt::Debug for EvalKind<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Full => write!(f, "Full"),
            Self::FullWithState(_) => write!(f, "FullWithState"),
            Self::Block(b, _) => write!(f, "Block({b})"),
            Self::ExactDraw(b, _) => write!(f, "ExactDraw({b})"),
            Self::Own(b, _) => write!(f, "Own({b})"),
        }
    }
}

impl EvalKind<'_> {
    #[cfg(any(test, feature = "mpi"))]
    /// Whether the evaluation reads what the proposal carries of its walker's derived values
    /// and state (a block update changes only their parts of the block): they must travel
    /// with the point.
    pub(crate) fn reads_state(self) -> bool {
        !matches!(self, Self::Full | Self::FullWithState(_))
    }

    /// Evaluates at `x` this way (`density` for a full evaluation), writing `derived` and
    /// `state`.
    ///
    /// # Errors
    /// As the density's method.
    pub fn evaluate<D: LogDensity + ?Sized>(
        self,
        density: &D,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        match self {
            Self::Full => density.log_density(x, derived),
            Self::FullWithState(blocked) => blocked.log_density_with_state(x, derived, state),
            Self::Block(b, blocked) => blocked.log_density_after_block(b, x, derived, state),
            Self::ExactDraw(b, conditional) => {
                conditional.log_density_after_draw(b, x, derived, state)
            }
            Self::Own(b, own) => own.update_block_state(b, x, derived, state),
        }
    }
}
