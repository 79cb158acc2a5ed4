//! The repeat slide: a slide started right after a first slide on the same contact shows no
//! transient, only elastic loading at slope kv up to the force where the previous slide
//! stopped, then sliding at that force: F(t) = min(kvt, F_end). On a rigid machine (k → ∞)
//! the loading line is vertical: F = F_end from the start of the slide.

use super::{non_negative, observed::Elastic, positive, LawError};

/// A repeat slide's force as the instrument records it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepeatSlide {
    /// k·v (N/s); `None` for a rigid machine.
    kv: Option<f64>,
    f_end: f64,
}

impl RepeatSlide {
    /// Loading at `kv` (N/s) up to `f_end_n` (N).
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] when kv is not finite and positive or F_end is negative.
    pub fn new(kv: f64, f_end_n: f64) -> Result<Self, LawError> {
        Ok(Self {
            kv: Some(positive("k*v", kv)?),
            f_end: non_negative("F_end", f_end_n)?,
        })
    }

    /// On a rigid machine (k → ∞): F = F_end from the start.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] when F_end is negative or not finite.
    pub fn rigid(f_end_n: f64) -> Result<Self, LawError> {
        Ok(Self {
            kv: None,
            f_end: non_negative("F_end", f_end_n)?,
        })
    }

    /// From a spring description, or [`rigid`](Self::rigid) for [`Elastic::Stiff`].
    ///
    /// # Errors
    /// As [`new`](Self::new) and [`rigid`](Self::rigid).
    pub fn from_elastic(elastic: Elastic, f_end_n: f64) -> Result<Self, LawError> {
        match elastic {
            Elastic::Spring { kv } => Self::new(kv, f_end_n),
            Elastic::Stiff => Self::rigid(f_end_n),
        }
    }

    /// The time (s) where the loading line reaches F_end: the kink of the slide (0 on a rigid
    /// machine).
    pub fn loading_ends(&self) -> f64 {
        self.kv.map_or(0.0, |kv| self.f_end / kv)
    }

    /// F(t) = min(kvt, F_end), zero up to t = 0; on a rigid machine the limit k → ∞ of it,
    /// F_end after t = 0.
    #[inline]
    pub fn force(&self, time_s: f64) -> f64 {
        match self.kv {
            Some(kv) => (kv * time_s.max(0.0)).min(self.f_end),
            None if time_s > 0.0 => self.f_end,
            None => 0.0,
        }
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
