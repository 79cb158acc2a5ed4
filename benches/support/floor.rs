//! The floor of the sampler's per-step overhead, shared by `benches/sampler.rs` and
//! `examples/sampler_peer.rs`: exactly the random numbers and proposal vectors one stretch
//! step needs (random half split, partner, z, Y = X_j + z (X_k − X_j), acceptance uniform),
//! drawn from per-walker ChaCha8 streams as determinism requires, with no bookkeeping.

use std::hint::black_box;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One ensemble of `WALKERS` walkers in `NDIM` dimensions; the sizes are compile-time
/// constants, as they are in the sampler's inner loops after inlining.
pub struct Floor<const WALKERS: usize, const NDIM: usize> {
    positions: Vec<f64>,
    perm: Vec<usize>,
    proposals: Vec<f64>,
    ensemble_rng: ChaCha8Rng,
    walker_rngs: Vec<ChaCha8Rng>,
    accept_u: Vec<f64>,
}

impl<const WALKERS: usize, const NDIM: usize> Floor<WALKERS, NDIM> {
    /// Walkers at `positions` (`WALKERS × NDIM`, row-major), streams seeded with `seed`.
    pub fn new(positions: Vec<f64>, seed: u64) -> Self {
        assert_eq!(
            positions.len(),
            WALKERS * NDIM,
            "positions must be WALKERS × NDIM"
        );
        let stream = |s: u64| {
            let mut r = ChaCha8Rng::seed_from_u64(seed);
            r.set_stream(s);
            r
        };
        Self {
            positions,
            perm: (0..WALKERS).collect(),
            proposals: vec![0.0; WALKERS / 2 * NDIM],
            ensemble_rng: stream(0),
            walker_rngs: (1..=WALKERS as u64).map(stream).collect(),
            accept_u: vec![0.0; WALKERS / 2],
        }
    }

    /// The proposals of the last half-step (`WALKERS / 2 × NDIM`, row-major).
    pub fn proposals(&self) -> &[f64] {
        &self.proposals
    }

    /// One stretch step's random numbers and proposals for both halves.
    pub fn step(&mut self) {
        let half = WALKERS / 2;
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        for i in 0..half {
            let j = self.ensemble_rng.random_range(i..WALKERS);
            self.perm.swap(i, j);
        }
        let a = 2.0_f64;
        for (active, comp) in [(0, half), (half, 0)] {
            for k in 0..half {
                let w = self.perm[active + k];
                let rng = &mut self.walker_rngs[w];
                let j = self.perm[comp + rng.random_range(0..half)];
                let u: f64 = rng.random();
                let z = ((a - 1.0) * u + 1.0).powi(2) / a;
                let x = &self.positions[w * NDIM..(w + 1) * NDIM];
                let xj = &self.positions[j * NDIM..(j + 1) * NDIM];
                for ((o, &xi), &xji) in self.proposals[k * NDIM..(k + 1) * NDIM]
                    .iter_mut()
                    .zip(x)
                    .zip(xj)
                {
                    *o = xji + z * (xi - xji);
                }
                self.accept_u[k] = rng.random();
            }
            black_box(&mut self.proposals);
            black_box(&mut self.accept_u);
        }
    }
}
