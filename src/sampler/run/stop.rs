//! The stopping rule: long enough in units of τ, τ settled, and R̂ between the ensembles
//! below its bound, judged on several windows of the chains. τ is pooled over the walkers
//! of every ensemble, so "long enough" depends on how many walkers there are
//! ([`tau_trusted_length`]).

use std::time::Instant;

use super::super::config::StopRule;
use super::super::moves::SLICE_ADAPT_STEPS;
use super::super::report::{rhat_from_history, tau_window, TAU_WINDOWS};
use super::step::{CARRY_FIT_STEPS, CARRY_TUNE_STEPS};
use super::{EnsembleSampler, SHOWN_R_HAT_EVERY};
use crate::density::LogDensity;
use crate::diagnostics::tau_trusted_length;

impl<D: LogDensity + ?Sized> EnsembleSampler<'_, D> {
    /// Applies the stopping rule and returns whether it holds. Each window
    /// of `TAU_WINDOWS` is judged on its own pooled τ: long enough (more than
    /// [`tau_trusted_length`] τ_max steps from its start for the rule's `tau_factor` and the
    /// walkers of all ensembles), settled (τ changed by less than the rule allows since the
    /// last check of the same window), and R̂ below the bound after the burn-in
    /// max(start, 2 τ_max, the slice move's tuning). The first window that passes stops the run.
    /// Keeps τ_max of the window closest to being long enough for progress, and with
    /// `show_r_hat` its R̂.
    pub(super) fn check_stop(&mut self, rule: &StopRule, show_r_hat: bool) -> bool {
        let length_factor = tau_trusted_length(self.total_walkers(), rule.tau_factor);
        // The τ of each coordinate at the last check, as one row (a state saved before τ was
        // pooled holds one row per ensemble: their mean is what is compared).
        let mean_tau = |t: &[Vec<f64>]| -> Vec<f64> {
            let mut m = vec![0.0; self.ndim];
            for e in t {
                for (a, v) in m.iter_mut().zip(e) {
                    *a += v / t.len() as f64;
                }
            }
            m
        };
        let mut shown: Option<(f64, f64, u64)> = None;
        let mut met = false;
        // Whether this check already computed an R̂ that progress can show.
        let mut r_hat_computed = false;
        for (i, &fraction) in TAU_WINDOWS.iter().enumerate() {
            // A window far from long enough by its last τ is not estimated again yet: τ over
            // every walker of a campaign's thousand coordinates costs more than the steps
            // between early checks. What is skipped depends only on the chains, so a resumed
            // run skips the same.
            let far = self.last_tau[i].as_deref().is_some_and(|prev| {
                let tmax = mean_tau(prev).into_iter().fold(f64::NEG_INFINITY, f64::max);
                let from_step = (fraction * self.step as f64).floor() as u64;
                let burn_in = self.window_burn_in(from_step, tmax);
                (self.step.saturating_sub(burn_in) as f64) < 0.5 * length_factor * tmax
            });
            if far {
                continue;
            }
            let (from_step, tau) = tau_window(
                &self.history,
                self.ndim,
                self.step,
                fraction,
                self.config.parallel(),
            );
            let previous = std::mem::replace(&mut self.last_tau[i], tau.clone().map(|t| vec![t]));
            let Some(tau) = tau else {
                continue;
            };
            let tmax = tau.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let length = (self.step - from_step) as f64;
            // The τ shown in progress is the one of the window closest to being long enough.
            if shown.is_none_or(|(l, _, _)| length / tmax > l) {
                shown = Some((length / tmax, tmax, from_step));
            }
            if met {
                continue;
            }
            // Counted after the burn-in, as the summary counts the draws it judges.
            let burn_in = self.window_burn_in(from_step, tmax);
            let long_enough = self.step.saturating_sub(burn_in) as f64 > length_factor * tmax;
            let settled = previous.is_some_and(|prev| {
                mean_tau(&prev)
                    .iter()
                    .zip(&tau)
                    .all(|(p, t)| ((t - p) / t).abs() < rule.tau_rel_change)
            });
            if !(long_enough && settled) {
                continue;
            }
            let r_hat =
                rhat_from_history(&self.history, self.ndim, burn_in, self.config.parallel());
            if let Some(r) = &r_hat {
                self.shown_r_hat = Some(r.iter().copied().fold(f64::NEG_INFINITY, f64::max));
                r_hat_computed = true;
            }
            met = match r_hat {
                Some(r) => r.iter().all(|&v| v < rule.rhat_max),
                None => self.ensembles.len() < 2,
            };
        }
        let Some((_, tmax, from_step)) = shown else {
            return met;
        };
        self.shown_tau = Some(tmax);
        // R̂ for display alone is a pass over the whole history (done at every check, a large
        // share of a short fit's time): only for an observer that shows it, and at most every
        // `SHOWN_R_HAT_EVERY`; in between the progress shows the last R̂ computed.
        let due = self
            .shown_r_hat_at
            .is_none_or(|t| t.elapsed() >= SHOWN_R_HAT_EVERY);
        if show_r_hat && due && !r_hat_computed {
            let burn_in = self.window_burn_in(from_step, tmax);
            if let Some(r) =
                rhat_from_history(&self.history, self.ndim, burn_in, self.config.parallel())
            {
                self.shown_r_hat = Some(r.into_iter().fold(f64::NEG_INFINITY, f64::max));
            }
            self.shown_r_hat_at = Some(Instant::now());
        }
        met
    }

    /// The walkers of all ensembles, over which τ is pooled.
    pub(super) fn total_walkers(&self) -> usize {
        self.config.walkers() * self.config.ensembles()
    }

    /// The burn-in of a stopping-rule window that starts at `from_step` with τ_max `tmax`:
    /// max(start, 2 τ_max, the slice move's tuning).
    pub(super) fn window_burn_in(&self, from_step: u64, tmax: f64) -> u64 {
        from_step
            .max((2.0 * tmax).ceil() as u64)
            .max(self.min_burn_in())
    }

    /// The steps the suggested burn-in covers at least: those during which the slice move's
    /// μ was tuned, and those that chose whether to keep optional carried moves (none
    /// without either).
    pub(super) fn min_burn_in(&self) -> u64 {
        let slice = if self.config.moves().iter().any(|(m, _)| m.is_slice()) {
            SLICE_ADAPT_STEPS
        } else {
            0
        };
        let carry = if self.carry_jumps.is_empty() {
            0
        } else {
            CARRY_TUNE_STEPS
        };
        let fit = if self.blocks.iter().any(|b| b.tuned_carry) {
            CARRY_FIT_STEPS
        } else {
            0
        };
        slice.max(carry).max(fit)
    }
}
