//! Models of friction data: which runs share which parameters, with which priors, and the
//! joint posterior they define.
//!
//! - [`spec`]: the model's part of a run file (`models/*.toml`), validated once with errors
//!   naming the key.
//! - [`blocking`]: how the posterior groups its blocks and updates its populations, a setting of
//!   the sampler handed to the posterior as an argument.
//! - [`prior`]: prior distributions and their log-scale Jacobians.
//! - [`data`]: a run's data loaded, checked and windowed for the likelihood.
//! - [`sufficient`]: a long run's likelihood from sufficient statistics of bins of its points,
//!   exact to a stated bound.
//! - [`posterior`]: the posterior as a [`crate::density::LogDensity`], with every reported
//!   quantity (parameters in SI, peaks, μ_s, predictions) as derived values.
//!
//! This module joins the friction law to data and priors; it knows nothing of how the
//! posterior is sampled or stored, nor of the run file's sampler settings.

pub mod blocking;
pub mod data;
mod one_contact;
pub mod posterior;
pub mod prior;
pub mod spec;
pub mod sufficient;

pub use blocking::{BlockSettings, Blocking, PopulationUpdates};
pub use one_contact::OneContact;
pub use posterior::{
    Band, DataShare, DataShareError, ModelLoo, PointwiseError, Posterior, PosteriorError,
    PriorDraw, PriorDrawError,
};
pub use spec::{LikelihoodSpec, ModelFile, ModelSpec, SpecError};
