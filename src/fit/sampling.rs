//! A fit's sampling after its start: sampling into the run directory's sink, summarising,
//! and sampling on by what the summaries' verdict lacks until they agree that the chains
//! converged.

use std::time::Instant;

use super::{summarise, FitError, FitSettings, FitSummary, RunDir, SamplerSummary};
use crate::density::LogDensity;
use crate::sampler::{EnsembleSampler, Observer, RunReport, SamplerError, Steps, StopReason};
use crate::storage::{ChainReader, ParquetSink};

/// The further steps a run needs by its summary's own verdict, when every problem it names
/// says how far it is from passing
/// ([`Problem::steps_needed`](crate::diagnostics::Problem::steps_needed), the estimate the
/// verdict's lines show). A tenth more than that, since τ and ESS move as the chains grow.
/// `None` when some problem does not say (an R̂, stuck walkers, no τ at all): the run then
/// goes on by half its length. A derived quantity's τ a little longer than the parameters'
/// (the sampler's rule sees only those) then costs the few steps it lacks rather than half
/// the run again.
fn steps_lacking(sampler: &SamplerSummary) -> Option<u64> {
    let walkers = sampler.walkers * sampler.ensembles;
    let needed = sampler.problems.iter().try_fold(0.0_f64, |most, p| {
        Some(most.max(p.steps_needed(sampler.steps, sampler.burn_in, walkers)?))
    })?;
    let lack = (needed - sampler.steps as f64).max(0.0);
    Some((lack + lack / 10.0).ceil() as u64)
}

/// Why a run converged by the sampler's rule samples on: the summaries (which took
/// `summarised_s`) of every reported quantity do not pass the strict standard yet. Names the
/// first problem and how many there are.
fn sampling_on(sampler: &SamplerSummary, summarised_s: f64, more: u64) -> String {
    let steps = sampler.steps;
    let why = match sampler.problems.as_slice() {
        [] => "no problem named".to_string(),
        [only] => only.to_string(),
        [first, rest @ ..] => format!("{first}; and {} more", rest.len()),
    };
    format!(
        "the summaries at step {steps} (made in {summarised_s:.1} s) do not pass the strict \
         standard yet, {more} more steps: {why}"
    )
}

/// A fit's sampling: the sampler, its sink, and what the summaries need.
pub(super) struct Sampling<'f, 's, D: LogDensity + ?Sized> {
    pub(super) sampler: EnsembleSampler<'s, D>,
    pub(super) sink: ParquetSink,
    pub(super) plan: summarise::SummaryPlan,
    pub(super) settings: &'f FitSettings,
    pub(super) dir: &'f RunDir,
    pub(super) started: Instant,
    pub(super) param_names: &'f [String],
}

impl<D: LogDensity + ?Sized> Sampling<'_, '_, D> {
    /// Samples `steps` and summarises; under a stopping rule, samples on until the summary
    /// agrees that the chains converged (or the budget ends). A run that had `finished`
    /// sampling before it was resumed only summarises: it stopped where it stopped. Returns
    /// the last run's report and the summary.
    pub(super) fn run(
        &mut self,
        steps: Steps,
        finished: bool,
        observer: &mut dyn Observer,
    ) -> Result<(RunReport, FitSummary), FitError> {
        let mut report = self.run_steps(steps, observer)?;
        let mut summarising = Instant::now();
        let mut summary = self.summarise(&report)?;
        if finished {
            if let Steps::UntilConverged(_) = self.settings.steps {
                // Why the original run stopped is not saved; a time cap reads as a step cap.
                report.stopped_by = if summary.sampler.converged {
                    StopReason::Converged
                } else {
                    StopReason::StepCap
                };
            }
            return Ok((report, summary));
        }
        // The sampler's own rule sees only the parameters' thinned history; the summary judges
        // every reported quantity on every post-burn-in draw. Until it agrees, and while the
        // budget lasts, the run goes on by what the verdict lacks (`steps_lacking`).
        if let Steps::UntilConverged(rule) = steps {
            while !summary.sampler.converged
                && report.stopped_by != StopReason::TimeCap
                && self.sampler.step() < rule.max_steps
            {
                let now = self.sampler.step();
                let more = steps_lacking(&summary.sampler)
                    .map_or(now / 2, |lack| lack.min(now / 2))
                    .max(10)
                    .min(rule.max_steps - now);
                observer.on_note(&sampling_on(
                    &summary.sampler,
                    summarising.elapsed().as_secs_f64(),
                    more,
                ));
                let chains = self.dir.chain_reader()?;
                self.sampler
                    .restore_history(kept_rows_of(&chains, self.param_names, now))
                    .map_err(|source| FitError::Sampler {
                        context: format!(
                            "restoring the sampler's history from {}",
                            self.dir.path().display()
                        ),
                        source,
                    })?;
                drop(chains);
                report = self.run_steps(Steps::Fixed(more), observer)?;
                summarising = Instant::now();
                summary = self.summarise(&report)?;
            }
            report.stopped_by = if summary.sampler.converged {
                StopReason::Converged
            } else if report.stopped_by == StopReason::TimeCap {
                StopReason::TimeCap
            } else {
                StopReason::StepCap
            };
        }
        Ok((report, summary))
    }

    /// Runs `steps` into the sink; the summaries read every recorded draw, so the stopping
    /// rule's history (in the chains too) makes room for them, and comes back only if the
    /// run goes on. The sink writes in the background: the last checkpoint's part must be on
    /// disk before it is read.
    fn run_steps(
        &mut self,
        steps: Steps,
        observer: &mut dyn Observer,
    ) -> Result<RunReport, FitError> {
        let shown = self.dir.path().display();
        let report = self
            .sampler
            .run(steps, &mut self.sink, observer)
            .map_err(|source| FitError::Sampler {
                context: format!("sampling into {shown}"),
                source,
            })?;
        // Every run ends with a checkpoint, which makes all its chains durable and readable.
        if report.stopped_by == StopReason::Interrupted {
            return Err(FitError::Interrupted {
                dir: self.dir.path().to_path_buf(),
                step: report.total_steps,
            });
        }
        self.sampler.release_history();
        self.sink.written().map_err(|source| FitError::Storage {
            context: format!("writing the chains in {shown}"),
            source,
        })?;
        Ok(report)
    }

    /// The summary of the chains so far.
    fn summarise(&self, report: &RunReport) -> Result<FitSummary, FitError> {
        self.plan.summarise(
            &self.dir.chain_reader()?,
            report,
            self.settings,
            self.dir.path(),
            self.started,
        )
    }
}

/// The recorded values of parameter `p` (named by `param_names`) at the given rows of
/// `chains`, read one row group at a time: how the sampler's history is restored from the
/// chains of a run at step `step`.
pub(super) fn kept_rows_of<'c>(
    chains: &'c ChainReader,
    param_names: &'c [String],
    step: u64,
) -> impl FnMut(usize, &[usize]) -> Result<Vec<f64>, SamplerError> + 'c {
    move |p, rows| {
        chains
            .rows_of(&param_names[p], rows)
            .map_err(|e| SamplerError::Sink {
                step,
                source: Box::new(e),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sampler's section of a t0-pooled demo fit stopped by the sampler's rule at 140
    /// steps, where the summary found F_peak's τ (7.57) a little longer than the parameters'.
    fn stopped_at_140(problems: serde_json::Value) -> SamplerSummary {
        serde_json::from_value(serde_json::json!({
            "walkers": 32, "steps": 140, "ensembles": 4, "burn_in": 50, "kept_steps": 90,
            "draws": 11520, "acceptance": 0.32, "tau_max": 7.2, "tau_min": 1.2,
            "tau_reliable": true, "log_density_evals": 156288, "wall_s": 5.3,
            "converged": false, "problems": problems, "rejections": {}, "seed": 2,
            "stopped_by": "Converged", "steps_run": 140
        }))
        .expect("a sampler summary")
    }

    #[test]
    fn a_run_goes_on_by_what_its_verdict_lacks() {
        // 12.5 τ trusted on 128 walkers: 50 + 12.5 × 7.57 = 144.6 steps, 4.6 lacking, 5.1
        // with the tenth more.
        let tau = stopped_at_140(serde_json::json!([
            {"kind": "tau_unreliable", "quantity": "F_peak[c1-first]", "tau": 7.57},
            {"kind": "tau_unreliable", "quantity": "mu_s[c1-first]", "tau": 7.0}
        ]));
        assert_eq!(steps_lacking(&tau), Some(6));
        // An ESS of 300 of 400 over 90 kept steps: 120 kept, 30 lacking, 33 with the tenth.
        let ess = stopped_at_140(serde_json::json!([
            {"kind": "ess", "quantity": "k[c1]", "which": "bulk", "ess": 300.0}
        ]));
        assert_eq!(steps_lacking(&ess), Some(33));
        // An R̂ says nothing of how far it is from passing: half the run again.
        let rhat = stopped_at_140(serde_json::json!([
            {"kind": "tau_unreliable", "quantity": "F_peak[c1-first]", "tau": 7.57},
            {"kind": "r_hat", "quantity": "k[c1]", "r_hat": 1.02}
        ]));
        assert_eq!(steps_lacking(&rhat), None);
    }

    #[test]
    fn the_note_of_a_run_that_samples_on_names_its_first_problem_and_counts_the_rest() {
        let two = stopped_at_140(serde_json::json!([
            {"kind": "tau_unreliable", "quantity": "F_peak[c1-first]", "tau": 7.57},
            {"kind": "ess", "quantity": "k[c1]", "which": "bulk", "ess": 300.0}
        ]));
        let note = sampling_on(&two, 12.34, 6);
        assert!(
            note.starts_with(
                "the summaries at step 140 (made in 12.3 s) do not pass the strict standard yet, \
                 6 more steps: F_peak[c1-first]: autocorrelation time 7.6 steps"
            ),
            "{note}"
        );
        assert!(note.ends_with("; and 1 more"), "{note}");
        let one = stopped_at_140(serde_json::json!([
            {"kind": "ess", "quantity": "k[c1]", "which": "bulk", "ess": 300.0}
        ]));
        assert!(sampling_on(&one, 1.0, 33).ends_with("k[c1]: ESS bulk 300 < 400"));
    }
}
