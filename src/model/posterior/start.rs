//! The start of the optimiser that places the walkers: rough features of each run's data
//! (the loading slope and plateau of repeat slides), then every first or fast slide fitted on
//! its own by least squares, the results combined over the runs that share a parameter.

use super::layout::{CoordPrior, SigmaSource, T0Source};
use super::likelihood::RunModel;
use super::Posterior;
use crate::law::{Elastic, Law, ObservedSlide, Scene};
use crate::optimize::{nelder_mead, NelderMeadOptions};

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
}

impl Posterior {
    /// A start near the mode, so that one optimisation finds the right basin: k and F_d from
    /// each repeat slide (its loading slope and plateau), then every first or fast slide
    /// fitted on its own (α, a/F_d, t0, F_d and, without a repeat slide, k; σ profiled out)
    /// from a few values of α spanning the record, and the results combined by level
    /// (geometric means for shared parameters).
    pub(super) fn heuristic_start(&self) -> Vec<f64> {
        let mut natural = vec![f64::NAN; self.coords.len()];
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
            votes[r.f_d].push(d.late_level());
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
        let mut t0_votes: Vec<(usize, f64)> = Vec::new();
        for r in self.runs.iter().filter(|r| r.scene != Scene::Repeat) {
            let fitted = self.fit_run_alone(r, k_known[r.contact]);
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
            votes[r.f_d].push(fitted.f_d);
            if let (Some(k), Some(v)) = (r.k, fitted.k) {
                if k_known[r.contact].is_none() {
                    votes[k].push(v);
                }
            }
            match r.t0 {
                Some(T0Source::Direct(i)) => votes[i].push(fitted.t0),
                Some(T0Source::Pooled { z, .. }) => t0_votes.push((z, fitted.t0)),
                None => {}
            }
        }
        for (i, v) in votes.iter().enumerate() {
            if !v.is_empty() {
                natural[i] = (v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp();
            }
        }
        // Pooled t0: the population median from its runs, a moderate spread, and each run's
        // standardised offset.
        for p in &self.populations {
            let logs: Vec<(usize, f64)> = t0_votes
                .iter()
                .filter(|(z, _)| self.z_population(*z) == Some(p.mu))
                .map(|&(z, t0)| (z, t0.ln()))
                .collect();
            if logs.is_empty() {
                continue;
            }
            let mu = logs.iter().map(|(_, l)| l).sum::<f64>() / logs.len() as f64;
            natural[p.mu] = mu.exp();
            natural[p.ln_s] = 0.5;
            for (z, l) in logs {
                natural[z] = (l - mu) / 0.5;
            }
        }
        self.coords
            .iter()
            .zip(&natural)
            .map(|(c, &v)| match c.prior {
                CoordPrior::StdNormal => {
                    if v.is_finite() {
                        v
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

    /// The population (its μ coordinate) a pooled z belongs to.
    fn z_population(&self, z: usize) -> Option<usize> {
        self.runs.iter().find_map(|r| match r.t0 {
            Some(T0Source::Pooled { mu, z: zz, .. }) if zz == z => Some(mu),
            _ => None,
        })
    }

    /// Least squares of one first or fast slide alone, σ profiled out (minimises ln SSR),
    /// with k fixed when a repeat slide gave it.
    fn fit_run_alone(&self, r: &RunModel, k_known: Option<f64>) -> RunAlone {
        let d = &r.data;
        let late = d.late_level();
        let peak = d.max_force();
        let f_d0 = late.min(peak);
        let t_end = d.model_times[d.n_obs - 1].max(f64::MIN_POSITIVE);
        let k0 = k_known.unwrap_or(1.5 * d.initial_slope() / r.velocity);
        let free_k = r.scene == Scene::First && k_known.is_none();
        let ssr = |p: &[f64]| -> f64 {
            let (alpha, ratio, t0, f_d) = (p[0].exp(), p[1].exp(), p[2].exp(), p[3].exp());
            let k = if free_k { p[4].exp() } else { k0 };
            let Ok(law) = Law::from_rate(alpha * r.velocity, ratio * f_d, f_d, t0) else {
                return f64::INFINITY;
            };
            let elastic = match r.scene {
                Scene::First => match Elastic::spring(k, r.velocity) {
                    Ok(e) => e,
                    Err(_) => return f64::INFINITY,
                },
                _ => Elastic::Stiff,
            };
            let mut sum = 0.0;
            let obs = &d.force;
            let ok = ObservedSlide::new(law, elastic).for_each_force(&d.model_times, |j, _, f| {
                if j < d.n_obs {
                    sum += d.weight(j) * (obs[j] - f).powi(2);
                }
            });
            if ok.is_err() {
                f64::INFINITY
            } else {
                sum.ln()
            }
        };
        let options = NelderMeadOptions {
            initial_step: 0.5,
            max_evals: 800,
            restarts: 1,
            ..NelderMeadOptions::default()
        };
        let mut best: Option<(Vec<f64>, f64)> = None;
        // α such that the record spans x = αvt of 1, 5 and 25 at its end.
        for x_end in [1.0, 5.0, 25.0] {
            let alpha = x_end / (r.velocity * t_end);
            let overshoot = ((peak - late) / late).clamp(0.05, 5.0);
            let t0 = 1e-3 / (alpha * r.velocity);
            let mut p = vec![alpha.ln(), overshoot.ln(), t0.ln(), f_d0.ln()];
            if free_k {
                p.push(k0.ln());
            }
            let (x, f, _) = nelder_mead(&ssr, &p, &options);
            if best.as_ref().is_none_or(|(_, fb)| f < *fb) {
                best = Some((x, f));
            }
        }
        let (x, ln_ssr) = best.unwrap_or_default();
        let get = |i: usize| x.get(i).map_or(f64::NAN, |v| v.exp());
        RunAlone {
            sigma: (ln_ssr.exp() / d.n_obs as f64).sqrt(),
            alpha: get(0),
            ratio: get(1),
            t0: get(2),
            f_d: get(3),
            k: if free_k { Some(get(4)) } else { None },
        }
    }
}
