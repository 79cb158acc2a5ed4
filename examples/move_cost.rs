//! The sampler's steps under one move (or a written mixture) on a 10-D standard normal, for
//! counting instructions per walker-step independently of the machine's load, e.g.
//!
//! ```text
//! cargo build --release --example move_cost
//! valgrind --tool=callgrind --toggle-collect='move_cost::measured' \
//!     target/release/examples/move_cost stretch 2000
//! ```
//!
//! Run at two step counts (2,000 and 4,000): the difference of the collected instruction
//! counts divided by 2,000 × 32 walkers is the marginal cost of a walker-step, free of the
//! run's one-time costs (start, final report). Arguments: a move name (`stretch`, `de`, ...,
//! see `MOVE_NAMES`) or a written mixture (`stretch=1,de=1`), the steps (default 2,000) and
//! the ensembles (default 1). It prints a hash of the final positions, so that two builds
//! can be checked to draw the same chains.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slipbayes::density::{LogDensity, LogDensityError};
use slipbayes::sampler::{EnsembleSampler, Mixture, Move, NullSink, SamplerConfig, Silent, Steps};

const NDIM: usize = 10;
const WALKERS: usize = 32;

/// A 10-D standard normal: about as cheap as a density can be, so the sampler's own work
/// dominates.
struct Cheap;

impl LogDensity for Cheap {
    fn dim(&self) -> usize {
        NDIM
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        Ok(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
    }
}

/// The measured part: `steps` steps, serially, into a sink that keeps nothing.
#[inline(never)]
fn measured(sampler: &mut EnsembleSampler<'_, Cheap>, steps: u64) -> u64 {
    sampler
        .run(Steps::Fixed(steps), &mut NullSink, &mut Silent)
        .expect("the run succeeds")
        .total_steps
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let moves = args.get(1).map_or("stretch", String::as_str);
    let steps: u64 = args.get(2).map_or(Ok(2000), |s| s.parse())?;
    let ensembles: usize = args.get(3).map_or(Ok(1), |s| s.parse())?;
    let mixture: Vec<(Move, f64)> = if moves.contains('=') {
        moves.parse::<Mixture>()?.moves().to_vec()
    } else {
        vec![(Move::named(moves)?, 1.0)]
    };
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let start: Vec<Vec<Vec<f64>>> = (0..ensembles)
        .map(|_| {
            (0..WALKERS)
                .map(|_| (0..NDIM).map(|_| rng.random::<f64>() - 0.5).collect())
                .collect()
        })
        .collect();
    let config = SamplerConfig::new(WALKERS, ensembles, 11)?
        .with_moves(mixture)?
        .with_parallel(false);
    let mut sampler = EnsembleSampler::new(&Cheap, config, start)?;
    let done = measured(&mut sampler, steps);
    let hash = (0..ensembles)
        .flat_map(|e| sampler.positions(e).to_vec())
        .fold(0u64, |h, v| h.rotate_left(7) ^ v.to_bits());
    println!("{moves}: {done} steps, positions hash {hash:016x}");
    Ok(())
}
