//! Choosing the bins of a run: as wide as the model's interpolation error allows at every
//! reference parameter point, never across a kink.

use super::moments::{chebyshev_points, interpolation_error_estimate};

/// The model of a run at one parameter point: writes its values at increasing `times` into
/// `out` (of the same length) and says whether it could.
pub type ReferenceModel<'a> = dyn Fn(&[f64], &mut [f64]) -> bool + Sync + 'a;

/// How the bins of a run are chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanSettings {
    /// Degree q of the polynomial that stands in for the model within a bin.
    pub degree: usize,
    /// Largest interpolation error allowed at any point of a bin (N), at every reference.
    pub max_error_n: f64,
    /// Fewest points in a bin (fewer are evaluated one by one: cheaper than q + 1 points).
    pub min_points: usize,
    /// Most points in a bin (a bin that a kink enters at some parameters is evaluated point
    /// by point there, at this cost at most).
    pub max_points: usize,
}

/// One bin chosen by [`plan_bins`]: observations `first..end` and the largest estimated
/// interpolation error over the reference points (N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedBin {
    /// First observation of the bin.
    pub first: usize,
    /// One past its last observation.
    pub end: usize,
    /// Estimated max |m − p| over the bin, the largest over the references (N).
    pub error_n: f64,
}

/// The bins of observations at increasing `times`, each as wide as keeps the estimated
/// interpolation error ([`interpolation_error_estimate`] on 2(q + 1) Chebyshev points of the
/// bin) of every model in `references` within `settings.max_error_n`. No bin reaches into
/// an interval of `excluded` (where the model has a kink at some parameters: its
/// observations stay exact), and the last observation is never binned (a first slide's force
/// there is F_end of the repeat slide that follows it). Points between bins stay exact.
/// Without references nothing is binned.
///
/// Each bin starts from the width of the one before, doubles while the error allows it, then
/// bisects to within an eighth of the widest width that passes: about six trials per bin.
pub fn plan_bins(
    times: &[f64],
    excluded: &[(f64, f64)],
    settings: &PlanSettings,
    references: &[&ReferenceModel],
) -> Vec<PlannedBin> {
    let n = times.len();
    let mut bins = Vec::new();
    if references.is_empty() || n < 2 {
        return bins;
    }
    let mut excluded: Vec<(f64, f64)> = excluded
        .iter()
        .copied()
        .filter(|(a, b)| a.is_finite() && b.is_finite() && a <= b)
        .collect();
    excluded.sort_by(|x, y| x.0.total_cmp(&y.0));
    let check = chebyshev_points(2 * (settings.degree + 1));
    let mut at = vec![0.0; check.len()];
    let mut values = vec![0.0; check.len()];
    // Estimated error of a bin of observations first..first + len, over every reference.
    let mut error_of = |first: usize, len: usize| -> f64 {
        let (lo, hi) = (times[first], times[first + len - 1]);
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        for (a, u) in at.iter_mut().zip(&check) {
            *a = mid + half * u;
        }
        let mut worst: f64 = 0.0;
        for model in references {
            if !model(&at, &mut values) || values.iter().any(|v| !v.is_finite()) {
                return f64::INFINITY;
            }
            worst = worst.max(interpolation_error_estimate(&values, settings.degree));
        }
        worst
    };
    let min = settings.min_points.max(settings.degree + 2);
    let mut guess = min;
    let mut i = 0;
    // The last observation stays exact.
    let binnable = n - 1;
    while i < binnable {
        // A point inside an excluded interval stays exact, and a bin ends before the next one.
        let t = times[i];
        if let Some(&(_, end)) = excluded.iter().find(|(a, b)| *a <= t && t <= *b) {
            i = times.partition_point(|&s| s <= end).max(i + 1);
            continue;
        }
        let before_excluded = excluded
            .iter()
            .find(|(a, _)| *a > t)
            .map_or(binnable, |&(a, _)| times.partition_point(|&s| s < a));
        let cap = before_excluded.min(binnable).min(i + settings.max_points) - i;
        if cap < min {
            // Too few points before the next interval (or the end) for a bin: exact.
            i += cap.max(1);
            continue;
        }
        let ok = |error: f64| error <= settings.max_error_n;
        let (mut good, mut good_error, mut bad) = (0, 0.0, usize::MAX);
        let mut len = guess.clamp(min, cap);
        loop {
            let error = error_of(i, len);
            if ok(error) {
                (good, good_error) = (len, error);
            } else {
                bad = len;
            }
            len = if bad == usize::MAX {
                if good == cap {
                    break;
                }
                (2 * good).min(cap)
            } else if good == 0 {
                if bad <= min {
                    break;
                }
                (bad / 2).max(min)
            } else {
                if bad - good <= (good / 8).max(1) {
                    break;
                }
                good + (bad - good) / 2
            };
        }
        if good == 0 {
            // Not even the narrowest bin is smooth enough here: its points stay exact.
            i += min;
            continue;
        }
        bins.push(PlannedBin {
            first: i,
            end: i + good,
            error_n: good_error,
        });
        guess = good;
        i += good;
    }
    bins
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(max_error_n: f64) -> PlanSettings {
        PlanSettings {
            degree: 5,
            max_error_n,
            min_points: 24,
            max_points: 1 << 14,
        }
    }

    #[test]
    fn bins_never_reach_into_an_excluded_interval_nor_the_last_point() {
        let times: Vec<f64> = (0..20_000).map(|i| i as f64 * 0.01).collect();
        // |t − 61.234| has a kink there, |t − 150| at a sample time; around 100 s an interval
        // of kinks (where a kink lies at other parameters).
        let excluded = [(61.234, 61.234), (150.0, 150.0), (99.5, 100.5)];
        let model = |t: &[f64], out: &mut [f64]| {
            for (o, &t) in out.iter_mut().zip(t) {
                *o = (t - 61.234).abs() + (t - 150.0).abs() + (t - 100.0).abs();
            }
            true
        };
        let bins = plan_bins(&times, &excluded, &settings(1e-9), &[&model]);
        assert!(!bins.is_empty());
        for b in &bins {
            let (lo, hi) = (times[b.first], times[b.end - 1]);
            for (a, z) in excluded {
                assert!(hi < a || lo > z, "bin [{lo}, {hi}] meets [{a}, {z}]");
            }
            assert!(b.end < times.len());
            assert!(b.end - b.first >= 24);
        }
        // Piecewise linear: the bins are as wide as allowed apart from the kinks.
        assert!(bins.len() <= 8, "{} bins", bins.len());
        assert!(bins.windows(2).all(|w| w[0].end <= w[1].first));
        // Every point of the interval around 100 s is left out of the bins.
        let binned = |i: usize| bins.iter().any(|b| b.first <= i && i < b.end);
        assert!((9950..=10050).all(|i| !binned(i)));
        assert!(binned(9900) && binned(10100));
    }

    #[test]
    fn bins_narrow_where_the_model_curves() {
        let times: Vec<f64> = (0..100_000).map(|i| 1.0 + i as f64 * 0.01).collect();
        let model = |t: &[f64], out: &mut [f64]| {
            for (o, &t) in out.iter_mut().zip(t) {
                *o = t.ln();
            }
            true
        };
        let bins = plan_bins(&times, &[], &settings(1e-12), &[&model]);
        let width = |b: &PlannedBin| times[b.end - 1] - times[b.first];
        let first = width(&bins[0]);
        let last = width(&bins[bins.len() - 1]);
        assert!(last > 10.0 * first, "first {first}, last {last}");
        for b in &bins {
            assert!(b.error_n <= 1e-12);
        }
        // A model that fails everywhere bins nothing.
        let failing = |_: &[f64], _: &mut [f64]| false;
        assert!(plan_bins(&times, &[], &settings(1e-12), &[&failing]).is_empty());
    }
}
