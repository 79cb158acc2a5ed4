//! The stopping rule: long enough in units of τ, τ settled, and R̂ between the ensembles
//! below its bound, judged on several windows of the chains.

use std::time::Instant;

use super::super::config::StopRule;
use super::super::moves::SLICE_ADAPT_STEPS;
use super::super::report::{rhat_from_history, tau_windows};
use super::step::{CARRY_FIT_STEPS, CARRY_TUNE_STEPS};
use super::{EnsembleSampler, SHOWN_R_HAT_EVERY};
use crate::density::LogDensity;

impl<D: LogDensity + ?Sized> EnsembleSampler<'_, D> {
    /// Applies the stopping rule and returns whether it holds. Each window
    /// of `TAU_WINDOWS` is judged on its own τ: long enough (more than `tau_factor` τ_max
    /// steps from its start), settled (τ changed by less than the rule allows since the last
    /// check of the same window), and R̂ below the bound after the burn-in
    /// max(start, 2 τ_max, the slice move's tuning). The first window that passes stops the run.
    /// Keeps τ_max of the window closest to being long enough for progress, and with
    /// `show_r_hat` its R̂.
    pub(super) fn check_stop(&mut self, rule: &StopRule, show_r_hat: bool) -> bool {
        let windows = tau_windows(&self.history, self.ndim, self.step, self.config.parallel());
        // Every coordinate's τ, averaged over the ensembles (each estimates the same τ, and
        // the maximum change over ensembles × coordinates single estimates would mostly
        // measure their noise), changed by less than the rule allows.
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
        for (i, (from_step, tau)) in windows.into_iter().enumerate() {
            let previous = std::mem::replace(&mut self.last_tau[i], tau.clone());
            let Some(tau) = tau else {
                continue;
            };
            let tmax = tau
                .iter()
                .flatten()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let length = (self.step - from_step) as f64;
            // The τ shown in progress is the one of the window closest to being long enough.
            if shown.is_none_or(|(l, _, _)| length / tmax > l) {
                shown = Some((length / tmax, tmax, from_step));
            }
            if met {
                continue;
            }
            let long_enough = length > rule.tau_factor * tmax;
            let settled = previous.is_some_and(|prev| {
                mean_tau(&prev)
                    .iter()
                    .zip(mean_tau(&tau))
                    .all(|(p, t)| ((t - p) / t).abs() < rule.tau_rel_change)
            });
            if !(long_enough && settled) {
                continue;
            }
            let burn_in = self.window_burn_in(from_step, tmax);
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
