//! A log-density evaluated at points that differ from a base point in one or two coordinates,
//! as finite-difference gradients and Hessians need: each such point re-evaluates only the
//! block of the coordinate moved, from the base point's state, which by the contract of
//! [`BlockedDensity`] gives the same bits as a full evaluation; and the points
//! are evaluated in parallel, each into its own buffers, so the values do not depend on the
//! number of threads. For a model of many groups (a campaign of 50 contacts has 150 group
//! coordinates and 2 shared ones) a coordinate of one group costs the evaluation of that
//! group's data alone.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::density::{sort, BlockedDensity, Eval, LogDensity, Target};

/// A density seen through one- and two-coordinate moves from a base point.
pub(crate) struct Probe<'d, D: ?Sized> {
    density: &'d D,
    /// The density's blocks with the block of every coordinate; `None` when it is not seen
    /// through its blocks or has fewer than two (every point is then evaluated in full).
    blocked: Option<(&'d dyn BlockedDensity, Vec<usize>)>,
    nderived: usize,
    state_len: usize,
    evaluations: AtomicUsize,
}

/// A point with its log-density and the buffers a block evaluation continues from.
struct Cached {
    log_density: f64,
    x: Vec<f64>,
    derived: Vec<f64>,
    cache: Vec<f64>,
}

fn finite_or_minus_infinity(e: Eval) -> f64 {
    match e {
        Eval::Finite(v) => v,
        _ => f64::NEG_INFINITY,
    }
}

impl<'d, D: LogDensity + ?Sized> Probe<'d, D> {
    pub fn new(target: Target<'d, D>) -> Self {
        let density = target.density();
        let blocked = target.blocked_density().and_then(|blocked| {
            let blocks = blocked.block_plan().coords();
            (blocks.len() >= 2).then(|| {
                let mut of = vec![0; density.dim()];
                for (b, coords) in blocks.iter().enumerate() {
                    for &i in coords {
                        of[i] = b;
                    }
                }
                (blocked, of)
            })
        });
        Self {
            density,
            nderived: density.derived_names().len(),
            state_len: blocked.as_ref().map_or(0, |(b, _)| b.state_len()),
            blocked,
            evaluations: AtomicUsize::new(0),
        }
    }

    /// Evaluations made so far (full or of one block).
    pub fn evaluations(&self) -> usize {
        self.evaluations.load(Ordering::Relaxed)
    }

    /// The log-density at `x`, −∞ where the density refuses it.
    pub fn value(&self, x: &[f64]) -> f64 {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let mut derived = vec![0.0; self.nderived];
        finite_or_minus_infinity(sort(self.density.log_density(x, &mut derived)))
    }

    /// `x` evaluated in full with its cache, when finite there and the density has blocks.
    fn cached(&self, x: &[f64]) -> Option<Cached> {
        let (blocked, _) = self.blocked.as_ref()?;
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let mut c = Cached {
            log_density: f64::NEG_INFINITY,
            x: x.to_vec(),
            derived: vec![0.0; self.nderived],
            cache: vec![0.0; self.state_len],
        };
        match sort(blocked.log_density_with_state(x, &mut c.derived, &mut c.cache)) {
            Eval::Finite(v) => {
                c.log_density = v;
                Some(c)
            }
            _ => None,
        }
    }

    /// `base` with coordinate `i` moved by `d`, evaluated by the block of `i` from the base's
    /// cache (in full without one); with its buffers when `keep` and the value is finite.
    fn moved(&self, base: Option<&Cached>, x: &[f64], i: usize, d: f64) -> (f64, Option<Cached>) {
        let (Some(base), Some((blocked, block_of))) = (base, self.blocked.as_ref()) else {
            let mut y = x.to_vec();
            y[i] += d;
            return (self.value(&y), None);
        };
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let mut c = Cached {
            log_density: f64::NEG_INFINITY,
            x: base.x.clone(),
            derived: base.derived.clone(),
            cache: base.cache.clone(),
        };
        c.x[i] += d;
        let e =
            sort(blocked.log_density_after_block(block_of[i], &c.x, &mut c.derived, &mut c.cache));
        match e {
            Eval::Finite(v) => {
                c.log_density = v;
                (v, Some(c))
            }
            other => (finite_or_minus_infinity(other), None),
        }
    }

    /// The log-density at `x + h_i e_i` and `x − h_i e_i` for every coordinate `i`.
    pub fn axis(&self, x: &[f64], h: &[f64]) -> Vec<[f64; 2]> {
        let base = self.cached(x);
        (0..x.len())
            .into_par_iter()
            .map(|i| {
                [
                    self.moved(base.as_ref(), x, i, h[i]).0,
                    self.moved(base.as_ref(), x, i, -h[i]).0,
                ]
            })
            .collect()
    }

    /// Every point of central second differences at `x` with steps `h`, each evaluated once:
    /// the log-density at `x`; at `x ± h_i e_i` for every `i` (as [`axis`](Self::axis)); and
    /// for every pair `j < i` at `x + s_i h_i e_i + s_j h_j e_j` for the signs (+, +), (+, −),
    /// (−, +), (−, −) (row `i` holds `i` entries). The point with `i` moved is evaluated once
    /// per sign and `j` moved from it, by the block of `j`.
    pub(crate) fn second_differences(&self, x: &[f64], h: &[f64]) -> SecondDifferences {
        let base = self.cached(x);
        let at_x = match &base {
            Some(c) => c.log_density,
            None => self.value(x),
        };
        let (axis, pairs) = (0..x.len())
            .into_par_iter()
            .map(|i| {
                let from_i = |s: f64| {
                    let (value, cached) = self.moved(base.as_ref(), x, i, s * h[i]);
                    let mut xi = x.to_vec();
                    xi[i] += s * h[i];
                    (value, xi, cached)
                };
                let (at_plus, plus, plus_cache) = from_i(1.0);
                let (at_minus, minus, minus_cache) = from_i(-1.0);
                let row = (0..i)
                    .map(|j| {
                        let at =
                            |(xi, c): (&[f64], Option<&Cached>), d: f64| self.moved(c, xi, j, d).0;
                        let p = (&plus[..], plus_cache.as_ref());
                        let m = (&minus[..], minus_cache.as_ref());
                        [at(p, h[j]), at(p, -h[j]), at(m, h[j]), at(m, -h[j])]
                    })
                    .collect();
                ([at_plus, at_minus], row)
            })
            .unzip();
        SecondDifferences { at_x, axis, pairs }
    }
}

/// The points of central second differences, from [`Probe::second_differences`].
pub(crate) struct SecondDifferences {
    /// The log-density at the centre.
    pub at_x: f64,
    /// At `x + h_i e_i` and `x − h_i e_i`.
    pub axis: Vec<[f64; 2]>,
    /// At `x ± h_i e_i ± h_j e_j`, `j < i`, signs (+, +), (+, −), (−, +), (−, −).
    pub pairs: Vec<Vec<[f64; 4]>>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::density::BlockedDensity;
    use crate::run_file::RunFile;

    /// The demo's posterior (17 coordinates in six blocks, with a cache): every point the probe
    /// evaluates by a block gives the bits of a full evaluation at the same point.
    #[test]
    fn block_moves_give_the_bits_of_full_evaluations() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let spec = RunFile::load(&root.join("models/demo.toml")).unwrap();
        let posterior = spec.posterior().unwrap();
        assert!(posterior.block_plan().blocks.len() >= 2 && posterior.state_len() > 0);
        let x = posterior.start().to_vec();
        let h: Vec<f64> = x.iter().map(|v| 1e-3 * v.abs().max(1.0)).collect();
        let probe = Probe::new(Target::blocked(&posterior));
        let full = |moves: &[(usize, f64)]| {
            let mut y = x.clone();
            for &(i, d) in moves {
                y[i] += d;
            }
            let mut derived = vec![0.0; posterior.derived_names().len()];
            posterior.log_density(&y, &mut derived).unwrap().to_bits()
        };
        let axis = probe.axis(&x, &h);
        let evaluations_of_axis = probe.evaluations();
        let second = probe.second_differences(&x, &h);
        assert_eq!(second.at_x.to_bits(), full(&[]));
        assert_eq!(second.axis, axis);
        let pairs = second.pairs;
        for i in 0..x.len() {
            assert_eq!(axis[i][0].to_bits(), full(&[(i, h[i])]), "+h of {i}");
            assert_eq!(axis[i][1].to_bits(), full(&[(i, -h[i])]), "-h of {i}");
            for j in 0..i {
                let got = pairs[i][j].map(f64::to_bits);
                let want = [
                    full(&[(i, h[i]), (j, h[j])]),
                    full(&[(i, h[i]), (j, -h[j])]),
                    full(&[(i, -h[i]), (j, h[j])]),
                    full(&[(i, -h[i]), (j, -h[j])]),
                ];
                assert_eq!(got, want, "pair ({i}, {j})");
            }
        }
        // One full evaluation for the base, two block evaluations per axis; the second
        // differences evaluate each point once: the base, two per row, four per pair.
        let n = x.len();
        assert_eq!(evaluations_of_axis, 1 + 2 * n);
        assert_eq!(
            probe.evaluations() - evaluations_of_axis,
            1 + 2 * n + 2 * n * (n - 1)
        );
    }
}
