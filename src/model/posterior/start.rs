//! The start of the optimiser that places the walkers: rough features of each run's data
//! (the loading slope and plateau of repeat slides), then every first or fast slide fitted on
//! its own by least squares, the results combined over the runs that share a parameter.
//! Under rate-and-state a first slide alone is fitted from the features of its peak
//! (`Posterior::fit_rate_state_alone`).

use std::borrow::Cow;

use rayon::prelude::*;

use super::layout::{CoordPrior, SigmaSource};
use super::likelihood::{RunModel, RunResiduals};
use super::Posterior;
use crate::density::LogDensity;
use crate::law::{Elastic, InterfaceLaw, Law, LawError, LawKind, LogAging, ObservedSlide, Scene};
use crate::optimize::{nelder_mead, NelderMeadOptions};

/// The optimiser's start and what the data said about each coordinate on the way.
#[derive(Debug, Clone)]
pub(super) struct StartPoint {
    /// The start, on the sampled scale (inside every prior).
    pub point: Vec<f64>,
    /// Per coordinate, the natural-scale value the runs' rough features and fits alone gave,
    /// before it was kept inside its prior (NaN where no run voted): where it lies outside the
    /// prior, the prior excludes what the data say.
    pub estimates: Vec<f64>,
}

/// Estimates from one slide fitted alone (a start for the joint fit).
#[derive(Debug, Clone, Copy)]
struct RunAlone {
    /// Root-mean-square residual (N).
    sigma: f64,
    alpha: f64,
    ratio: f64,
    t0: f64,
    f_d: f64,
    k: Option<f64>,
    /// Rate-and-state b and D_c (NaN under the other laws).
    b: f64,
    d_c: f64,
}

impl Posterior {
    /// A start near the mode, so that one optimisation finds the right basin: k and F_d from
    /// each repeat slide (its loading slope and plateau), then every first or fast slide
    /// fitted on its own (α, a/F_d, t0, F_d and, without a repeat slide, k; σ profiled out)
    /// from a few values of α spanning the record, and the results combined by level
    /// (geometric means for shared parameters).
    pub(super) fn heuristic_start(&self) -> StartPoint {
        // Shared parameters collect one estimate per run and take the geometric mean.
        let mut votes: Vec<Vec<f64>> = vec![Vec::new(); self.coords.len()];
        let mut k_known = vec![None; self.spec.file.contacts.len()];
        for r in self.runs.iter().filter(|r| r.scene == Scene::Repeat) {
            let d = &r.data;
            let kv = d.initial_slope();
            if let Some(k) = r.k {
                votes[k].push(kv / r.velocity);
                k_known[r.contact] = Some(kv / r.velocity);
            }
            if let Some(f_d) = r.f_d {
                votes[f_d].push(d.late_level());
            }
        }
        // A σ sampled explicitly (a prior other than log-uniform) starts at the residual
        // noise of its run: from the run's own fit, or from successive differences on the
        // piecewise-linear repeat slide.
        let vote_sigma = |votes: &mut Vec<Vec<f64>>, r: &RunModel, sigma: f64| {
            if let SigmaSource::Coord(i) = r.sigma {
                votes[i].push(sigma);
            }
        };
        for r in self.runs.iter().filter(|r| r.scene == Scene::Repeat) {
            vote_sigma(&mut votes, r, r.data.noise_estimate());
        }
        // Each slide's fit is independent of the others': on every core, then voted in the
        // runs' order, so that the start does not depend on the number of threads.
        let slides: Vec<&RunModel> = self
            .runs
            .iter()
            .filter(|r| r.scene != Scene::Repeat)
            .collect();
        let fits: Vec<RunAlone> = slides
            .par_iter()
            .map(|r| match r.law {
                LawKind::RateState => self.fit_rate_state_alone(r, k_known[r.contact]),
                _ => self.fit_run_alone(r, k_known[r.contact]),
            })
            .collect();
        for (r, fitted) in slides.into_iter().zip(fits) {
            vote_sigma(&mut votes, r, fitted.sigma);
            if let Some(i) = r.alpha {
                votes[i].push(fitted.alpha);
            }
            if let Some(i) = r.a {
                votes[i].push(if r.ratio {
                    fitted.ratio
                } else {
                    fitted.ratio * fitted.f_d
                });
            }
            if let Some(f_d) = r.f_d {
                votes[f_d].push(fitted.f_d);
            }
            if let (Some(k), Some(v)) = (r.k, fitted.k) {
                if k_known[r.contact].is_none() {
                    votes[k].push(v);
                }
            }
            if let Some(i) = r.t0 {
                votes[i].push(fitted.t0);
            }
            if let Some(i) = r.b {
                votes[i].push(fitted.b);
            }
            if let Some(i) = r.d_c {
                votes[i].push(fitted.d_c);
            }
        }
        // Natural-scale values from the centre of each coordinate's log estimates.
        let by_level = |log_centre: fn(&[f64]) -> f64| -> Vec<f64> {
            votes
                .iter()
                .map(|v| {
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        log_centre(v).exp()
                    }
                })
                .collect()
        };
        let estimates = by_level(mean_of_logs);
        let point = self.coordinates(estimates.clone());
        if self.finite_at(&point) {
            return StartPoint { point, estimates };
        }
        // A slide fitted alone can end far off (a ratio of e^13, a t0 of e^-20 in a campaign
        // of 50 contacts), and a geometric mean takes such an outlier in: the median of the
        // runs' estimates does not.
        let estimates = by_level(median_of_logs);
        let mut point = self.coordinates(estimates.clone());
        if !self.finite_at(&point) {
            self.repair_contacts(&mut point);
        }
        StartPoint { point, estimates }
    }

    /// Whether the density is finite at `x`.
    fn finite_at(&self, x: &[f64]) -> bool {
        let mut derived = vec![0.0; self.quantities.len()];
        self.log_density(x, &mut derived)
            .is_ok_and(|v| v.is_finite())
    }

    /// The sampler coordinates of natural-scale estimates, kept strictly inside each prior;
    /// a t0 population placed at its members' mean ln t0 with a moderate spread.
    fn coordinates(&self, mut natural: Vec<f64>) -> Vec<f64> {
        for p in &self.populations {
            let logs: Vec<f64> = self
                .coords
                .iter()
                .zip(&natural)
                .filter(|(c, v)| {
                    matches!(c.prior, CoordPrior::Population { mu, .. } if mu == p.mu)
                        && v.is_finite()
                })
                .map(|(_, v)| v.ln())
                .collect();
            if logs.is_empty() {
                continue;
            }
            natural[p.mu] = (logs.iter().sum::<f64>() / logs.len() as f64).exp();
            natural[p.ln_s] = 0.5;
        }
        self.coords
            .iter()
            .zip(&natural)
            .map(|(c, &v)| match c.prior {
                CoordPrior::Population { .. } => {
                    if v.is_finite() && v > 0.0 {
                        v.ln()
                    } else {
                        0.0
                    }
                }
                CoordPrior::Log(ref prior) => {
                    let (lo, hi) = prior.bounds();
                    let v = if v.is_finite() && v > 0.0 { v } else { 1.0 };
                    // Keep the start strictly inside the prior.
                    v.clamp(lo.max(f64::MIN_POSITIVE) * 1.01, hi * 0.99).ln()
                }
            })
            .collect()
    }

    /// Re-fits the own coordinates of every contact whose runs cannot be evaluated at `x`
    /// (those no other contact's runs read: its t0, F_d, k, σ), with the shared coordinates
    /// held: the contact-level values from a slide fitted alone need not suit the shared
    /// values the other contacts voted for.
    fn repair_contacts(&self, x: &mut [f64]) {
        let contacts = self.spec.file.contacts.len();
        let mut readers = vec![Vec::new(); self.coords.len()];
        for r in &self.runs {
            for c in r.coords_read() {
                if !readers[c].contains(&r.contact) {
                    readers[c].push(r.contact);
                }
            }
        }
        // A contact's runs read only its own coordinates and shared ones that no repair
        // moves, so the contacts are repaired independently, on every core, from the same x.
        let x_in: &[f64] = x;
        let repairs: Vec<(Vec<usize>, Vec<f64>)> = (0..contacts)
            .into_par_iter()
            .filter_map(|contact| {
                let runs: Vec<usize> = self
                    .order
                    .iter()
                    .copied()
                    .filter(|&i| self.runs[i].contact == contact)
                    .collect();
                let own: Vec<usize> = (0..self.coords.len())
                    .filter(|&c| readers[c] == [contact])
                    .collect();
                if own.is_empty() || self.contact_ln_ssr(&runs, x_in).is_finite() {
                    return None;
                }
                // Every evaluation sets all of the contact's own coordinates, so one scratch
                // point serves them all.
                let mut y = x_in.to_vec();
                let objective = |p: &[f64]| {
                    for (&c, &v) in own.iter().zip(p) {
                        y[c] = v;
                    }
                    self.contact_ln_ssr(&runs, &y)
                };
                let p0: Vec<f64> = own.iter().map(|&c| x_in[c]).collect();
                let options = NelderMeadOptions {
                    initial_step: 1.0,
                    max_evals: 400 * own.len(),
                    restarts: 2,
                    ..NelderMeadOptions::default()
                };
                let (p, f, _) = nelder_mead(objective, &p0, &options);
                f.is_finite().then_some((own, p))
            })
            .collect();
        for (own, p) in repairs {
            for (&c, &v) in own.iter().zip(&p) {
                x[c] = v;
            }
        }
    }

    /// Σ ln SSR of `runs` (in evaluation order) at `x`: infinite where a run cannot be
    /// evaluated or a coordinate leaves its prior.
    fn contact_ln_ssr(&self, runs: &[usize], x: &[f64]) -> f64 {
        if self
            .coords
            .iter()
            .zip(x)
            .any(|(c, &v)| !c.prior_contains(v))
        {
            return f64::INFINITY;
        }
        self.fits_at(runs, x)
            .try_fold(0.0, |total, (_, fit)| match fit {
                Ok(fit) if fit.ssr.is_finite() => Some(total + fit.ssr.max(f64::MIN_POSITIVE).ln()),
                _ => None,
            })
            .unwrap_or(f64::INFINITY)
    }

    /// Each of `runs` (in evaluation order) fitted at `x`; a repeat slide loads from where
    /// the slide it follows stopped, or from F_d when that slide is not among `runs` or failed.
    pub(super) fn fits_at<'s>(
        &'s self,
        runs: &'s [usize],
        x: &'s [f64],
    ) -> impl Iterator<Item = (usize, Result<RunResiduals, LawError>)> + 's {
        let mut last = vec![f64::NAN; self.runs.len()];
        runs.iter().map(move |&i| {
            let r = &self.runs[i];
            let fit = r.residuals(x, r.follows.map(|j| last[j]).filter(|v| v.is_finite()));
            if let Ok(f) = &fit {
                last[i] = f.last_force;
            }
            (i, fit)
        })
    }

    /// Least squares of one first or fast slide alone, σ profiled out (minimises ln SSR),
    /// with k fixed when a repeat slide gave it, under the run's law and elasticity (a law
    /// without α or F_d reads a = (a/F_d)·F_d and leaves α alone).
    fn fit_run_alone(&self, r: &RunModel, k_known: Option<f64>) -> RunAlone {
        let d = &r.data;
        let late = d.late_level();
        let peak = d.max_force();
        let f_d0 = late.min(peak);
        let t_end = d.model_times[d.n_obs - 1].max(f64::MIN_POSITIVE);
        let k0 = k_known.unwrap_or(1.5 * d.initial_slope() / r.velocity);
        let spring = r.scene == Scene::First && r.k.is_some();
        let free_k = spring && k_known.is_none();
        // A long record is fitted on evenly spread points of it, so that this rough start
        // costs the same for 10⁴ points as for 10⁶ (its thousands of evaluations took
        // minutes there); the mode search that follows reads every point.
        let picked = subsample(d.n_obs);
        let times: Cow<[f64]> = match &picked {
            Some(p) => Cow::Owned(p.iter().map(|&j| d.model_times[j]).collect()),
            None => Cow::Borrowed(&d.model_times),
        };
        let n_fitted = picked.as_ref().map_or(d.n_obs, Vec::len);
        let ssr = |p: &[f64]| -> f64 {
            let (alpha, ratio, t0, f_d) = (p[0].exp(), p[1].exp(), p[2].exp(), p[3].exp());
            let k = if free_k { p[4].exp() } else { k0 };
            let law: Result<InterfaceLaw, LawError> = match r.law {
                LawKind::AgingRejuvenation => {
                    Law::from_rate(alpha * r.velocity, ratio * f_d, f_d, t0).map(Into::into)
                }
                LawKind::LogAging => LogAging::new(ratio * f_d, t0).map(Into::into),
                LawKind::RateState => return f64::INFINITY,
            };
            let Ok(law) = law else {
                return f64::INFINITY;
            };
            let elastic = if spring {
                match Elastic::spring(k, r.velocity) {
                    Ok(e) => e,
                    Err(_) => return f64::INFINITY,
                }
            } else {
                Elastic::Stiff
            };
            let mut sum = 0.0;
            let obs = &d.force;
            let ok = ObservedSlide::new(law, elastic).for_each_force(&times, |m, _, f| {
                let j = picked.as_ref().map_or(m, |p| p[m]);
                if j < d.n_obs {
                    sum += (obs[j] - f).powi(2);
                }
            });
            if ok.is_err() {
                f64::INFINITY
            } else {
                sum.ln()
            }
        };
        // The simplex's edge is relative to |ln θ|: 0.05 is a factor of about 2 in α (ln α ≈
        // 13) and 1.3 in F_d. At 0.5 (a factor of 665 in α) the searches wandered off to
        // ratios of 1e28 and F_d of 1e-33 in SBC draws with large α.
        let options = NelderMeadOptions {
            initial_step: 0.05,
            max_evals: 800,
            restarts: 1,
            ..NelderMeadOptions::default()
        };
        // α such that the record spans x = αvt of 1, 5 and 25 at its end.
        let starts = [1.0, 5.0, 25.0].map(|x_end| {
            let alpha = x_end / (r.velocity * t_end);
            let overshoot = ((peak - late) / late).clamp(0.05, 5.0);
            let t0 = 1e-3 / (alpha * r.velocity);
            let mut p = vec![alpha.ln(), overshoot.ln(), t0.ln(), f_d0.ln()];
            if free_k {
                p.push(k0.ln());
            }
            p
        });
        let (x, ln_ssr) = best_search(ssr, starts, &options);
        let get = |i: usize| x.get(i).map_or(f64::NAN, |v| v.exp());
        RunAlone {
            sigma: (ln_ssr.exp() / n_fitted as f64).sqrt(),
            alpha: get(0),
            ratio: get(1),
            t0: get(2),
            f_d: get(3),
            k: if free_k { Some(get(4)) } else { None },
            b: f64::NAN,
            d_c: f64::NAN,
        }
    }

    /// Least squares of one rate-and-state first slide alone, σ profiled out, with k fixed
    /// when a repeat slide gave it. The start reads the slide's features: F0 is the late
    /// level, k the slope of the elastic loading, D_c the slip over which the force falls
    /// halfway from its peak to the late level; at the peak V = v, so the excess of the peak
    /// over F0 is b ln(v θ_peak/D_c) with θ_peak ≈ θ(0) + t_peak. From a few hold ages θ(0)
    /// (a tenth, once and ten times t_peak), each with the b that gives the excess.
    fn fit_rate_state_alone(&self, r: &RunModel, k_known: Option<f64>) -> RunAlone {
        let d = &r.data;
        let v = r.velocity;
        let late = d.late_level();
        let n = d.n_obs;
        let times = &d.model_times[..n];
        let force = &d.force[..n];
        let t_end = times[n - 1].max(f64::MIN_POSITIVE);
        let k0 = k_known.unwrap_or(d.initial_slope() / v);
        let free_k = k_known.is_none();
        let (i_peak, &peak) = force
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &late));
        let t_peak = times[i_peak].max(t_end / n as f64);
        let excess = (peak - late).max(0.01 * late.abs()).max(f64::MIN_POSITIVE);
        let t_half = times[i_peak..]
            .iter()
            .zip(&force[i_peak..])
            .find(|(_, &f)| f - late < 0.5 * excess)
            .map_or(t_end, |(&t, _)| t);
        let d_c0 = (v * (t_half - t_peak)).max(v * t_end / (10.0 * n as f64));
        let picked = subsample(n);
        let fit_times: Vec<f64> = match &picked {
            Some(p) => p.iter().map(|&j| times[j]).collect(),
            None => times.to_vec(),
        };
        let n_fitted = fit_times.len();
        let mut scratch = r.clone();
        // The coordinates of the copy: [ln a, ln b, ln D_c, ln F0, ln t0, ln k].
        scratch.a = Some(0);
        scratch.b = Some(1);
        scratch.d_c = Some(2);
        scratch.f_d = Some(3);
        scratch.t0 = Some(4);
        scratch.k = Some(5);
        scratch.scene = Scene::First;
        let ssr = |p: &[f64]| -> f64 {
            let mut x = p.to_vec();
            if !free_k {
                x.push(k0.ln());
            }
            let mut sum = 0.0;
            let ok = scratch.visit_forces_at(&x, None, &fit_times, |m, f| {
                let j = picked.as_ref().map_or(m, |p| p[m]);
                sum += (force[j] - f).powi(2);
            });
            if ok.is_err() || !sum.is_finite() {
                f64::INFINITY
            } else {
                sum.ln()
            }
        };
        let options = NelderMeadOptions {
            initial_step: 0.05,
            max_evals: 600,
            restarts: 1,
            ..NelderMeadOptions::default()
        };
        let starts = [0.1, 1.0, 10.0].map(|hold_per_peak| {
            let t0 = hold_per_peak * t_peak;
            let b = excess / (v * (t0 + t_peak) / d_c0).ln().max(1.0);
            let mut p = vec![
                (0.5 * b).ln(),
                b.ln(),
                d_c0.ln(),
                late.max(f64::MIN_POSITIVE).ln(),
                t0.ln(),
            ];
            if free_k {
                p.push(k0.ln());
            }
            p
        });
        let (x, ln_ssr) = best_search(ssr, starts, &options);
        let get = |i: usize| x.get(i).map_or(f64::NAN, |v| v.exp());
        RunAlone {
            sigma: (ln_ssr.exp() / n_fitted as f64).sqrt(),
            alpha: f64::NAN,
            ratio: get(0) / get(3),
            t0: get(4),
            f_d: get(3),
            k: free_k.then(|| get(5)),
            b: get(1),
            d_c: get(2),
        }
    }
}

/// The lowest point of Nelder–Mead searches of `objective` from each of `starts` and its
/// value (the earliest start wins a tie); empty and 0 when there is no start.
fn best_search(
    objective: impl Fn(&[f64]) -> f64,
    starts: impl IntoIterator<Item = Vec<f64>>,
    options: &NelderMeadOptions,
) -> (Vec<f64>, f64) {
    let mut best: Option<(Vec<f64>, f64)> = None;
    for p in starts {
        let (x, f, _) = nelder_mead(&objective, &p, options);
        if best.as_ref().is_none_or(|(_, fb)| f < *fb) {
            best = Some((x, f));
        }
    }
    best.unwrap_or_default()
}

/// Records up to this many points are fitted whole by [`Posterior::fit_run_alone`].
const START_MAX_POINTS: usize = 10_000;

/// The observations a longer record is fitted on: every m-th from the first, about
/// [`START_MAX_POINTS`] / 2 of them, and the last (where a repeat slide takes its F_end and a
/// first slide has relaxed most); `None` for a record short enough to fit whole.
fn subsample(n_obs: usize) -> Option<Vec<usize>> {
    if n_obs <= START_MAX_POINTS {
        return None;
    }
    let stride = n_obs.div_ceil(START_MAX_POINTS / 2);
    let mut picked: Vec<usize> = (0..n_obs).step_by(stride).collect();
    if picked.last() != Some(&(n_obs - 1)) {
        picked.push(n_obs - 1);
    }
    Some(picked)
}

/// Mean of the logarithms of positive estimates (the log of their geometric mean).
fn mean_of_logs(v: &[f64]) -> f64 {
    v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64
}

/// Median of the logarithms of positive estimates (the lower middle of an even count, so that
/// it is one of the runs' own values).
fn median_of_logs(v: &[f64]) -> f64 {
    let mut logs: Vec<f64> = v.iter().map(|x| x.ln()).collect();
    logs.sort_by(f64::total_cmp);
    logs[(logs.len() - 1) / 2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_records_are_fitted_on_a_bounded_spread_of_their_points() {
        assert_eq!(subsample(START_MAX_POINTS), None);
        for n in [START_MAX_POINTS + 1, 123_457, 1_000_000, 10_000_000] {
            let picked = subsample(n).unwrap();
            assert!(
                picked.len() <= START_MAX_POINTS / 2 + 1,
                "{n}: {}",
                picked.len()
            );
            assert!(
                picked.len() >= START_MAX_POINTS / 4,
                "{n}: {}",
                picked.len()
            );
            assert_eq!(picked[0], 0);
            assert_eq!(*picked.last().unwrap(), n - 1);
            assert!(picked.windows(2).all(|w| w[0] < w[1]));
        }
    }
}
