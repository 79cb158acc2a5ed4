//! Affine-invariant ensemble MCMC over any log-density (placeholder: filled in by its own work).
pub mod sink;
