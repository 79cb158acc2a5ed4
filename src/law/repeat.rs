//! The repeat slide: a slide started right after a first slide on the same contact shows no
//! transient, only elastic loading at slope kv up to the force where the previous slide
//! stopped, then sliding at that force: F(t) = min(kvt, F_end).

use super::{non_negative, observed::Elastic, positive, LawError};

/// A repeat slide's force as the instrument records it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepeatSlide {
    kv: f64,
    f_end: f64,
}

impl RepeatSlide {
    /// Loading at `kv` (N/s) up to `f_end_n` (N).
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] when kv is not finite and positive or F_end is negative.
    pub fn new(kv: f64, f_end_n: f64) -> Result<Self, LawError> {
        Ok(Self {
            kv: positive("k*v", kv)?,
            f_end: non_negative("F_end", f_end_n)?,
        })
    }

    /// From a spring description; a stiff machine has no repeat-slide model.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming `k` for [`Elastic::Stiff`].
    pub fn from_elastic(elastic: Elastic, f_end_n: f64) -> Result<Self, LawError> {
        match elastic {
            Elastic::Spring { kv } => Self::new(kv, f_end_n),
            Elastic::Stiff => Err(LawError::InvalidParameter {
                name: "k",
                value: f64::INFINITY,
                expected: "a finite stiffness: a repeat slide is elastic loading",
            }),
        }
    }

    /// The time (s) where the loading line reaches F_end: the kink of the slide.
    pub fn loading_ends(&self) -> f64 {
        self.f_end / self.kv
    }

    /// F(t) = min(kvt, F_end), zero before t = 0.
    #[inline]
    pub fn force(&self, time_s: f64) -> f64 {
        (self.kv * time_s.max(0.0)).min(self.f_end)
    }

    /// Forces at each time of `times` into `forces`.
    ///
    /// # Errors
    /// [`LawError::LengthMismatch`] when the slices differ in length.
    pub fn forces(&self, times: &[f64], forces: &mut [f64]) -> Result<(), LawError> {
        if times.len() != forces.len() {
            return Err(LawError::LengthMismatch {
                expected: times.len(),
                got: forces.len(),
            });
        }
        for (f, &t) in forces.iter_mut().zip(times) {
            *f = self.force(t);
        }
        Ok(())
    }
}
