//! What a run reports: progress after every step, and the run's report at its end (τ, R̂,
//! acceptance, rejections and the problems that say whether it converged).

use std::time::{Duration, Instant};

use super::super::ensemble::Ensemble;
use super::super::observer::Progress;
use super::super::report::{
    chosen_tau_report, rhat_from_history, tau_windows, EnsembleReport, RunReport, StopReason,
};
use super::step::CARRY_TUNE_STEPS;
use super::EnsembleSampler;
use crate::density::LogDensity;
use crate::diagnostics::{stuck_walkers, tau_trusted_length, Problem, RHAT_MAX, TAU_FACTOR};

impl<D: LogDensity + ?Sized> EnsembleSampler<'_, D> {
    /// Updates of each walker per step by the moves: one per block (and one more for a block
    /// drawn exactly whose followers the density carries, which the moves then move too; the
    /// exact draws, always accepted, do not count towards the acceptance rate), one when
    /// joint.
    pub(super) fn updates_per_step(&self) -> u64 {
        self.blocks
            .iter()
            .filter(|b| !b.exact() || b.carry().is_some())
            .count()
            .max(1) as u64
    }

    /// Updates of each walker of ensemble `e` so far by Metropolis–Hastings proposals: the
    /// moves' updates but the slice move's (which always move, so that counting them would
    /// inflate the acceptance fraction) and the carried moves dropped after tuning.
    pub(super) fn proposals_per_walker(&self, e: &Ensemble) -> u64 {
        let dropped: u64 = (0..self.blocks.len())
            .filter(|&b| !self.keeps_carried_move(b, &self.blocks[b], self.step))
            .map(|_| self.step.saturating_sub(CARRY_TUNE_STEPS))
            .sum();
        self.updates_per_step() * self.step - e.s.slice_updates - dropped
    }

    pub(super) fn progress(
        &self,
        first: u64,
        last: u64,
        started: Instant,
        tau_factor: Option<f64>,
    ) -> Progress {
        let tau_max = self.shown_tau;
        // Over the moves' proposals only; NaN when every update was a slice update.
        let (acc, n) = self.ensembles.iter().fold((0u64, 0u64), |(a, n), e| {
            let proposals = self.proposals_per_walker(e) * e.s.accepted.len() as u64;
            (a + e.s.accepted.iter().sum::<u64>(), n + proposals)
        });
        let acceptance = if self.step == 0 {
            0.0
        } else {
            acc as f64 / n as f64
        };
        let done = self.step - first;
        let target = match (tau_factor, tau_max) {
            (Some(f), Some(t)) => {
                let length = tau_trusted_length(self.total_walkers(), f) * t;
                (length.ceil() as u64).clamp(self.step, last)
            }
            (Some(_), None) => last,
            _ => last,
        };
        let eta = (done > 0).then(|| {
            let per_step = started.elapsed().as_secs_f64() / done as f64;
            Duration::from_secs_f64(per_step * (target - self.step) as f64)
        });
        Progress {
            step: self.step,
            last_step: last,
            acceptance,
            tau_max,
            r_hat_max: self.shown_r_hat,
            eta,
        }
    }

    /// The report of the current chains (τ and R̂ from the whole history).
    pub(super) fn report(&self, steps_run: u64, stopped_by: StopReason) -> RunReport {
        let steps = self.step;
        let ensembles: Vec<EnsembleReport> = self
            .ensembles
            .iter()
            .map(|e| EnsembleReport {
                // NaN for walkers updated by the slice move alone: no proposal to accept.
                acceptance: e
                    .s
                    .accepted
                    .iter()
                    .map(|&a| {
                        if steps == 0 {
                            0.0
                        } else {
                            a as f64 / self.proposals_per_walker(e) as f64
                        }
                    })
                    .collect(),
                rejections: e.s.rejections.clone(),
                evaluations: e.s.evaluations,
            })
            .collect();
        let mut problems = Vec::new();
        let parallel = self.config.parallel();
        let tau = chosen_tau_report(
            tau_windows(&self.history, self.ndim, steps, parallel),
            steps,
            tau_trusted_length(self.total_walkers(), TAU_FACTOR),
            self.min_burn_in(),
        );
        match &tau {
            None => problems.push(Problem::NoAutocorrelationTime { steps }),
            Some(t) if !t.reliable => problems.push(Problem::ChainsTooShort {
                steps,
                tau_max: t.max,
                needed: t.needed_steps,
            }),
            Some(_) => {}
        }
        let rhat = tau
            .as_ref()
            .and_then(|t| rhat_from_history(&self.history, self.ndim, t.burn_in, parallel));
        if let Some(r) = &rhat {
            for (name, &v) in self.density.param_names().into_iter().zip(r) {
                if v.is_nan() {
                    problems.push(Problem::RHatUndefined { quantity: name });
                } else if v >= RHAT_MAX {
                    problems.push(Problem::RHat {
                        quantity: name,
                        r_hat: v,
                    });
                }
            }
        } else if self.ensembles.len() > 1 {
            problems.push(Problem::RHatNotComputed);
        }
        problems.extend(stuck_walkers(
            ensembles.iter().map(|e| e.acceptance.as_slice()),
            steps,
        ));
        RunReport {
            steps_run,
            total_steps: steps,
            stopped_by,
            ensembles,
            tau,
            rhat,
            converged: problems.is_empty(),
            problems,
        }
    }
}
