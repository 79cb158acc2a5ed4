//! The curves a report draws where the data do not sample them, redrawn from posterior
//! draws when a friction fit ends (they need the model, which a report does not load): the
//! law in interface time (elastic part removed) and the peak against t0 (the paper's Fig. 4).

use super::run_dir::{Curves, InterfaceCurve, PeakVsT0, RunCurves};
use super::{FitError, FitSummary};
use crate::diagnostics::{pointwise_quantiles, quantile};
use crate::law::{Elastic, InterfaceLaw, LawError, Scene};
use crate::model::{Band, Posterior};

/// Points of a curve in interface time.
pub const CURVE_POINTS: usize = 300;
/// Decades of interface time a redrawn law spans below its end.
pub const CURVE_DECADES: f64 = 6.0;
/// Points of the peak-against-t0 curve.
pub const T0_POINTS: usize = 40;
/// t0 is varied this factor below and above the run's 95 % interval.
pub const T0_SPAN: f64 = 30.0;
/// Quantiles drawn as a median with a 95 % band.
pub const BAND_PROBS: [f64; 3] = [0.025, 0.5, 0.975];

/// Every run's curves over `draws` (sampler coordinates), each first or fast slide's law up
/// to the end of its band in `bands`, and its peak against t0 around the interval `summary`
/// gives its t0 (when t0 is the run's own).
///
/// # Errors
/// [`FitError::Curves`] when a draw gives an invalid law (the sampler rejects those).
pub(super) fn redraw(
    posterior: &Posterior,
    draws: &[Vec<f64>],
    bands: &[Band],
    summary: &FitSummary,
) -> Result<Curves, FitError> {
    let runs = &posterior.spec().file.runs;
    let mut out = Vec::with_capacity(runs.len());
    for (i, r) in runs.iter().enumerate() {
        let end = bands
            .iter()
            .find(|b| b.run == r.name)
            .and_then(|b| b.time_s.last().copied())
            .unwrap_or(1.0);
        let interface =
            interface_curve(posterior, i, draws, end, CURVE_POINTS).map_err(FitError::Curves)?;
        let peak_vs_t0 = match summary.find("t0", &r.name) {
            Some(t0) if r.scene != Scene::Repeat => {
                let range = (t0.stats.ci_low / T0_SPAN, t0.stats.ci_high * T0_SPAN);
                peak_vs_t0(posterior, i, draws, range, T0_POINTS).map_err(FitError::Curves)?
            }
            _ => None,
        };
        out.push(RunCurves {
            run: r.name.clone(),
            interface,
            peak_vs_t0,
        });
    }
    Ok(Curves {
        draws: draws.len(),
        t0_span: T0_SPAN,
        runs: out,
    })
}

/// The law of run `run` on `points` interface times from 0 to `tau_end_s`, over `draws`:
/// 0, then log-spaced from [`CURVE_DECADES`] decades below the end, so that the curve has
/// its rise on a logarithmic distance axis and is smooth on a linear one. `None` for a
/// repeat slide.
///
/// # Errors
/// A draw that gives an invalid law.
pub(crate) fn interface_curve(
    posterior: &Posterior,
    run: usize,
    draws: &[Vec<f64>],
    tau_end_s: f64,
    points: usize,
) -> Result<Option<InterfaceCurve>, LawError> {
    let tau_s: Vec<f64> = std::iter::once(0.0)
        .chain((0..points.saturating_sub(1)).map(|j| {
            let f = j as f64 / points.saturating_sub(2).max(1) as f64;
            tau_end_s * 10f64.powf(CURVE_DECADES * (f - 1.0))
        }))
        .collect();
    let mut forces = Vec::with_capacity(draws.len());
    let mut kvs = Vec::with_capacity(draws.len());
    for x in draws {
        let Some(slide) = posterior.run_slide(x, run)? else {
            return Ok(None);
        };
        if let Elastic::Spring { kv } = slide.elastic() {
            kvs.push(kv);
        }
        let law = slide.law();
        forces.push(tau_s.iter().map(|&t| law.force(t)).collect::<Vec<f64>>());
    }
    let q = pointwise_quantiles(&forces, tau_s.len(), &BAND_PROBS);
    let [low, median, high]: [Vec<f64>; 3] = q.try_into().expect("three quantiles");
    Ok(Some(InterfaceCurve {
        tau_s,
        force_n: [low, median, high],
        kv_n_per_s: quantile(&kvs, 0.5).ok(),
    }))
}

/// F_peak of run `run` on `points` log-spaced values of t0 in `t0_range_s`, keeping each
/// draw's αv, a and F_d; and each draw's own (t0, F_peak). `None` for a repeat slide.
///
/// # Errors
/// A draw that gives an invalid law.
pub(crate) fn peak_vs_t0(
    posterior: &Posterior,
    run: usize,
    draws: &[Vec<f64>],
    t0_range_s: (f64, f64),
    points: usize,
) -> Result<Option<PeakVsT0>, LawError> {
    let (lo, hi) = (t0_range_s.0.ln(), t0_range_s.1.ln());
    let t0_s: Vec<f64> = (0..points)
        .map(|j| (lo + (hi - lo) * j as f64 / (points - 1).max(1) as f64).exp())
        .collect();
    let peak = |law: &InterfaceLaw| law.peak().interior().map_or(f64::NAN, |p| p.force_n);
    let mut curves = Vec::with_capacity(draws.len());
    let mut own = Vec::with_capacity(draws.len());
    for x in draws {
        let Some(slide) = posterior.run_slide(x, run)? else {
            return Ok(None);
        };
        let law = slide.law();
        own.push((law.t0(), peak(law)));
        let curve = t0_s
            .iter()
            .map(|&t0| law.with_t0(t0).map_or(f64::NAN, |l| peak(&l)))
            .collect::<Vec<f64>>();
        curves.push(curve);
    }
    let q = pointwise_quantiles(&curves, t0_s.len(), &BAND_PROBS);
    let [low, median, high]: [Vec<f64>; 3] = q.try_into().expect("three quantiles");
    Ok(Some(PeakVsT0 {
        t0_s,
        peak_n: [low, median, high],
        draws: own,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointwise_quantiles_skip_nan() {
        let rows = vec![vec![1.0, f64::NAN], vec![2.0, 5.0], vec![3.0, 7.0]];
        let q = pointwise_quantiles(&rows, 2, &[0.5]);
        assert!((q[0][0] - 2.0).abs() < 1e-12);
        assert!((q[0][1] - 6.0).abs() < 1e-12);
    }
}
