//! Errors of the diagnostics, and the one place where input series are validated.

use thiserror::Error;

/// Why a diagnostic could not be computed. Every variant names the offending chain, index or
/// value and says what would fix it.
#[derive(Debug, Error)]
pub enum DiagnosticsError {
    /// No chains (walkers, ensembles) were given at all.
    #[error("no chains given: pass at least {needed} chain(s) of draws")]
    NoChains {
        /// How many chains the diagnostic needs.
        needed: usize,
    },
    /// Chains of different lengths.
    #[error(
        "ragged chains: chain {chain} has {len} draws but chain 0 has {expected}; \
         all chains must have the same number of draws (trim them to a common length)"
    )]
    RaggedChains {
        /// Index of the first chain whose length differs from chain 0.
        chain: usize,
        /// Its length.
        len: usize,
        /// The length of chain 0.
        expected: usize,
    },
    /// Too few draws per chain for this diagnostic.
    #[error(
        "too few draws for {what}: {have} per chain, at least {needed} needed \
         (run the sampler for more steps or thin less)"
    )]
    TooFewDraws {
        /// The diagnostic that was asked for.
        what: &'static str,
        /// Draws per chain that were given.
        have: usize,
        /// Minimum draws per chain that it needs.
        needed: usize,
    },
    /// Too few chains for this diagnostic (R-hat needs at least two).
    #[error("too few chains for {what}: {have} given, at least {needed} needed")]
    TooFewChains {
        /// The diagnostic that was asked for.
        what: &'static str,
        /// Chains given.
        have: usize,
        /// Chains needed.
        needed: usize,
    },
    /// A draw is NaN or infinite.
    #[error(
        "non-finite draw {value} in chain {chain} at index {index}; \
         the sampler must store only finite parameter values"
    )]
    NonFinite {
        /// Chain (or walker) index.
        chain: usize,
        /// Draw index within that chain.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A series has zero variance, so its autocorrelation is undefined.
    #[error(
        "chain {chain} is constant (value {value}); its autocorrelation is undefined \
         (a stuck walker, or a parameter that is fixed rather than sampled)"
    )]
    ConstantChain {
        /// Chain (or walker) index.
        chain: usize,
        /// The constant value.
        value: f64,
    },
    /// An argument (a probability, a window factor, a shape) is out of its domain.
    #[error("invalid argument {name} = {value}: {reason}")]
    InvalidArgument {
        /// Name of the argument.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must satisfy.
        reason: &'static str,
    },
    /// A working file of a summary could not be created, written or read back (see
    /// [`super::summary`]).
    #[error(
        "{0} (a working file of the summary: the summary of a long run keeps its sorted draws \
         there; free some disk space)"
    )]
    Scratch(#[source] crate::IoError),
}

/// Checks that `chains` is non-empty, rectangular, at least `min_draws` long and finite.
/// Returns the common number of draws per chain.
pub(crate) fn validate_chains(
    chains: &[&[f64]],
    min_draws: usize,
    what: &'static str,
) -> Result<usize, DiagnosticsError> {
    let first = chains
        .first()
        .ok_or(DiagnosticsError::NoChains { needed: 1 })?;
    let n = first.len();
    for (c, chain) in chains.iter().enumerate() {
        if chain.len() != n {
            return Err(DiagnosticsError::RaggedChains {
                chain: c,
                len: chain.len(),
                expected: n,
            });
        }
    }
    if n < min_draws {
        return Err(DiagnosticsError::TooFewDraws {
            what,
            have: n,
            needed: min_draws,
        });
    }
    for (c, chain) in chains.iter().enumerate() {
        if let Some((i, &v)) = chain.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(DiagnosticsError::NonFinite {
                chain: c,
                index: i,
                value: v,
            });
        }
    }
    Ok(n)
}

/// Checks that a probability lies strictly inside (0, 1) (or in (0, 1] when `allow_one`).
pub(crate) fn check_prob(
    name: &'static str,
    p: f64,
    allow_one: bool,
) -> Result<(), DiagnosticsError> {
    let ok = p > 0.0 && (p < 1.0 || (allow_one && p <= 1.0));
    if ok {
        Ok(())
    } else {
        Err(DiagnosticsError::InvalidArgument {
            name,
            value: p,
            reason: if allow_one {
                "a probability in (0, 1] is required"
            } else {
                "a probability strictly between 0 and 1 is required"
            },
        })
    }
}
