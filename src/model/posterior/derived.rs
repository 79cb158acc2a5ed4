//! The reported values of a draw: every parameter in SI units, σ of a marginalised group
//! drawn from its conditional posterior, a per contact and material, the peak of each slide
//! and the predicted peak of a new contact of a pooled material.
//!
//! Where a derived value needs randomness (σ's conditional draw, a new contact's t0), the
//! random numbers are a deterministic function of the bits of the draw itself, so that the
//! density stays a pure function of `x` and the sampler stays reproducible.

use super::blocks::{Block, Changed, Owners};
use super::layout::{PeakField, Source};
use super::Posterior;
use crate::law::{Elastic, Law, Peak};
use crate::model::spec::{Aging, Param};

impl Posterior {
    /// Writes the value of every reported column at `x`, in column order, into `derived`
    /// (of length `quantities().len()`), from the runs' weighted sums of squared residuals
    /// `ssr` at `x` (for the conditional draw of σ). With `block`, only the peaks of the runs
    /// it reads and the σ of the groups it touches are computed (the others keep their
    /// values: the block update did not change them).
    pub(super) fn derived_values(
        &self,
        x: &[f64],
        ssr: &[f64],
        derived: &mut [f64],
        changed: Changed,
    ) {
        let mut peaks = PeakCache::default();
        for (out, source) in derived.iter_mut().zip(&self.sources) {
            // A block update leaves the values of the coordinates it does not move as they
            // were: recomputing them would cost every contact's values per contact update.
            if self.rewrites(source, changed) {
                *out = self.column_value(*source, x, &|i| ssr[i], &mut peaks);
            }
        }
    }

    /// The value at `x` of the column computed from `source`, each run's weighted sum of
    /// squared residuals from `ssr_of`; `peaks` keeps the last run's peak, which several
    /// columns read.
    pub(super) fn column_value(
        &self,
        source: Source,
        x: &[f64],
        ssr_of: &dyn Fn(usize) -> f64,
        peaks: &mut PeakCache,
    ) -> f64 {
        match source {
            Source::Coord(i) => x[i].exp(),
            Source::Sigma(g) => self.sigma_draw(g, ssr_of),
            Source::AContact { ratio, f_d } => x[ratio].exp() * x[f_d].exp(),
            Source::AMaterial(m) => self.materials[m]
                .aging
                .map_or(f64::NAN, |a| x[a.coord].exp() * self.mean_fd(x, m)),
            Source::Peak { run, field } => {
                let (peak, kv) = peaks.of(run, || {
                    let r = &self.runs[run];
                    let peak = r.law(x).ok().and_then(|law| law.peak().interior());
                    let kv = match r.elastic(x) {
                        Ok(Elastic::Spring { kv }) => Some(kv),
                        _ => None,
                    };
                    (peak, kv)
                });
                let r = &self.runs[run];
                peak.map_or(f64::NAN, |p| match field {
                    PeakField::Force => p.force_n,
                    PeakField::InterfaceTime => p.tau_s,
                    PeakField::SlipDistance => p.slip_m(r.velocity),
                    PeakField::ObservedTime => p.observed_time_s(kv),
                    PeakField::StaticCoefficient => {
                        r.normal_force.map_or(f64::NAN, |f_n| p.force_n / f_n)
                    }
                })
            }
            Source::PeakNew(m) => self.new_contact_peak(x, m),
        }
    }

    /// Whether an evaluation that changed `changed` rewrites the column computed from
    /// `source`.
    pub(super) fn rewrites(&self, source: &Source, changed: Changed) -> bool {
        let by_block = |b: &Block| match *source {
            Source::Coord(i) => b.moves[i],
            Source::AContact { ratio, f_d } => b.moves[ratio] || b.moves[f_d],
            Source::Peak { run, .. } => b.reads[run],
            Source::Sigma(g) => b.groups[g],
            Source::AMaterial(_) | Source::PeakNew(_) => true,
        };
        let owner = |owners: &Owners| owner_in(owners, source);
        match changed {
            Changed::All => true,
            Changed::Block(b) => by_block(b),
            Changed::NoRun => !matches!(source, Source::Peak { .. } | Source::Sigma(_)),
            Changed::Merged => matches!(source, Source::AMaterial(_) | Source::PeakNew(_)),
            Changed::Share(b, owners, start, end) => {
                by_block(b) && Owners::within(owner(owners), start, end)
            }
            Changed::Rest(b, owners) => by_block(b) && owner(owners).is_none(),
        }
    }

    /// The independent block (its position among them) whose update writes the column
    /// computed from `source`, if one does.
    pub(super) fn owner_of(&self, source: &Source) -> Option<usize> {
        owner_in(&self.owners, source)
    }

    /// The reported σ of marginalised group `g`: a draw from its conditional posterior given
    /// the runs' sums of squared residuals `ssr`. Seeded by the group's own residuals, not by
    /// all of `x`: the draw then changes exactly when a block update changes the group.
    pub(super) fn sigma_draw(&self, g: usize, ssr_of: impl Fn(usize) -> f64) -> f64 {
        let (fit, n) = self.group_fit(g, ssr_of);
        let group = &self.sigma_groups[g];
        group.conditional_draw(hash_bits(&[fit], group.salt), fit, n)
    }

    /// The peak of a new contact of material `m`, at its slow velocity: t0 drawn from the
    /// material's t0 population; F_d from its population when pooled, else the mean of the
    /// material's contacts; a (or a/F_d) the material's, or drawn from its population.
    fn new_contact_peak(&self, x: &[f64], m: usize) -> f64 {
        // The standard-normal draws are deterministic functions of the draw itself so that the
        // sampler stays reproducible; hashing the bits makes them independent of the values.
        self.new_contact_peak_with(x, m, &mut |salt| hashed_normal(x, salt))
    }

    /// The peak of a new contact of material `m` as [`Self::new_contact_peak`] computes it,
    /// with the standard-normal draw of each new member from `normal` (given a salt that
    /// names the member).
    pub(super) fn new_contact_peak_with(
        &self,
        x: &[f64],
        m: usize,
        normal: &mut dyn FnMut(u64) -> f64,
    ) -> f64 {
        let material = &self.materials[m];
        let Some(v) = material.slow_velocity else {
            return f64::NAN;
        };
        let mut new_member = |param: Param, salt: u64| {
            self.populations
                .iter()
                .find(|p| p.param == param && p.material == m)
                .map(|p| (x[p.mu] + x[p.ln_s].exp() * normal(salt)).exp())
        };
        let salt = m as u64;
        let Some(t0) = new_member(Param::T0, salt) else {
            return f64::NAN;
        };
        let f_d = new_member(Param::FD, salt | 1 << 32).unwrap_or_else(|| self.mean_fd(x, m));
        let (amplitude, ratio) = match material.aging {
            Some(aging) => (x[aging.coord].exp(), aging.ratio),
            None => match new_member(Param::A, salt | 2 << 32) {
                Some(v) => (v, self.spec.file.aging == Aging::Ratio),
                None => return f64::NAN,
            },
        };
        let a = if ratio { amplitude * f_d } else { amplitude };
        let alpha = material.alpha.map_or(f64::NAN, |i| x[i].exp());
        Law::from_rate(alpha * v, a, f_d, t0)
            .ok()
            .and_then(|law| law.peak().interior())
            .map_or(f64::NAN, |p| p.force_n)
    }

    /// Mean F_d (N) of the contacts of `material`.
    fn mean_fd(&self, x: &[f64], material: usize) -> f64 {
        let (mut sum, mut n) = (0.0, 0.0);
        for (c, &m) in self.spec.contact_material.iter().enumerate() {
            if m == material {
                if let Some(i) = self.contact_fd[c] {
                    sum += x[i].exp();
                    n += 1.0;
                }
            }
        }
        sum / n
    }
}

/// The independent block (its position among them) in `owners` that owns what the column
/// computed from `source` is computed from.
fn owner_in(owners: &Owners, source: &Source) -> Option<usize> {
    match *source {
        Source::Coord(i) => owners.coord[i],
        Source::AContact { ratio, f_d } => owners.coord[ratio].or(owners.coord[f_d]),
        Source::Peak { run, .. } => owners.run[run],
        Source::Sigma(g) => owners.group[g],
        Source::AMaterial(_) | Source::PeakNew(_) => None,
    }
}

/// The peak of the run last asked for, with the machine's stiffness times the velocity:
/// the columns of one run's peak follow one another.
#[derive(Default)]
pub(super) struct PeakCache {
    last: Option<(usize, Option<Peak>, Option<f64>)>,
}

impl PeakCache {
    /// The peak and kv of `run`, computed by `compute` unless it is the run last asked for.
    fn of(
        &mut self,
        run: usize,
        compute: impl FnOnce() -> (Option<Peak>, Option<f64>),
    ) -> (Option<Peak>, Option<f64>) {
        match self.last {
            Some((r, peak, kv)) if r == run => (peak, kv),
            _ => {
                let (peak, kv) = compute();
                self.last = Some((run, peak, kv));
                (peak, kv)
            }
        }
    }
}

/// A standard-normal number that is a deterministic function of the bits of `x` and `salt`
/// (hashing, then the Box–Muller transform).
fn hashed_normal(x: &[f64], salt: u64) -> f64 {
    let h = hash_bits(x, salt);
    let u1 = ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let h2 = hash_bits(&[f64::from_bits(h)], salt ^ 1);
    let u2 = ((h2 >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// SplitMix64 hash of the bits of `x` and `salt`.
fn hash_bits(x: &[f64], salt: u64) -> u64 {
    fn mix(h: &mut u64, v: u64) {
        *h = h.wrapping_add(v).wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *h;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        *h = z ^ (z >> 31);
    }
    let mut h = 0x9E37_79B9_7F4A_7C15_u64 ^ salt;
    for v in x {
        mix(&mut h, v.to_bits());
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashed_normal_is_standard_normal() {
        let draws: Vec<f64> = (0..20_000).map(|i| hashed_normal(&[i as f64], 7)).collect();
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        let var = draws.iter().map(|z| (z - mean).powi(2)).sum::<f64>() / draws.len() as f64;
        // 4 standard errors.
        assert!(mean.abs() < 4.0 / (draws.len() as f64).sqrt(), "{mean}");
        assert!(
            (var - 1.0).abs() < 4.0 * (2.0 / draws.len() as f64).sqrt(),
            "{var}"
        );
    }
}
