//! A move written outside the crate, mixed with the built-in ones: the sampler still targets
//! the right distribution (seeded runs, tolerances from the Monte-Carlo error), the move's
//! proposals are really drawn, and the checkpoint records it, so that a resume with other
//! moves is refused while one with the same moves continues the same chains. Likewise the
//! slice move along directions of one's own.

mod sampler_util;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use sampler_util::{assert_within, mean_and_mcse, Gaussian};
use slipbayes::density::LogDensity;
use slipbayes::optimize::initial_around_optimum;
use slipbayes::sampler::moves::{
    ActiveHalf, Complement, Correction, DirectionDraw, MoveSpec, ProposalMove, Proposed,
    SliceDirection, WalkerRng,
};
use slipbayes::sampler::{
    EnsembleSampler, MemorySink, Move, SamplerConfig, SamplerError, SamplerState, Silent, Steps,
};

/// Allowed distance from the truth in Monte-Carlo standard errors.
const K_MCSE: f64 = 4.0;

/// Gaussian random-walk Metropolis: `Y = X + s Z`, `Z ~ N(0, I)`, a symmetric proposal that
/// ignores the complement. Counts the walkers it proposed for.
#[derive(Debug)]
struct RandomWalk {
    scale: f64,
    proposals: Arc<AtomicU64>,
}

impl RandomWalk {
    fn new(scale: f64) -> (Self, Arc<AtomicU64>) {
        let proposals = Arc::new(AtomicU64::new(0));
        let mv = Self {
            scale,
            proposals: Arc::clone(&proposals),
        };
        (mv, proposals)
    }
}

impl ProposalMove for RandomWalk {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("random_walk").with("scale", self.scale)
    }

    fn min_complement(&self, _dim: usize) -> usize {
        1
    }

    fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
        self.proposals
            .fetch_add(half.len() as u64, Ordering::Relaxed);
        half.propose_each(|walker, rng, out| {
            for (o, &x) in out.iter_mut().zip(walker.x) {
                *o = x + self.scale * rng.sample::<f64, _>(StandardNormal);
            }
            Correction::SYMMETRIC
        })
    }
}

/// Slice directions along one coordinate axis at a time: axis `i` drawn uniformly, the
/// direction the difference of two complement walkers in coordinate `i` alone. Counts the
/// half-steps it was fitted for.
#[derive(Debug)]
struct AxisDirections {
    fits: Arc<AtomicU64>,
}

#[derive(Debug)]
struct AxisDraw;

impl SliceDirection for AxisDirections {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("slice_axes")
    }

    fn min_complement(&self, _dim: usize) -> usize {
        2
    }

    fn fit(&self, _complement: Complement<'_>) -> Box<dyn DirectionDraw> {
        self.fits.fetch_add(1, Ordering::Relaxed);
        Box::new(AxisDraw)
    }
}

impl DirectionDraw for AxisDraw {
    fn draw(&self, complement: Complement<'_>, mu: f64, rng: &mut WalkerRng, out: &mut [f64]) {
        let i = rng.random_range(0..out.len());
        let (a, b) = complement.pick_two(rng);
        out.fill(0.0);
        out[i] = mu * (a[i] - b[i]);
    }
}

fn start(g: &Gaussian, walkers: usize, ensembles: usize, seed: u64) -> Vec<Vec<Vec<f64>>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    initial_around_optimum(g, &vec![0.3; g.dim()], walkers, ensembles, &mut rng)
        .unwrap()
        .walkers
}

/// Mixed half and half with the stretch move on a correlated Gaussian, the random walk keeps
/// every mean, variance and the outer covariance within the Monte-Carlo error; it is drawn in
/// about half the (ensemble, step) pairs, proposing for every walker each time.
#[test]
fn a_move_of_ones_own_mixed_with_the_stretch_move_samples_a_correlated_gaussian() {
    let g = Gaussian::correlated(3, 0.9);
    let (walkers, ensembles, steps) = (12, 4, 6000_u64);
    let (rw, proposals) = RandomWalk::new(0.8);
    let config = SamplerConfig::new(walkers, ensembles, 31)
        .unwrap()
        .with_moves(vec![(Move::proposal(rw), 0.5), (Move::stretch(), 0.5)])
        .unwrap();
    let mut sampler = EnsembleSampler::new(&g, config, start(&g, walkers, ensembles, 31)).unwrap();
    let mut sink = MemorySink::new();
    let report = sampler
        .run(Steps::Fixed(steps), &mut sink, &mut Silent)
        .unwrap();
    let tau = report.tau.clone().expect("tau");
    assert!(tau.reliable, "τ_max {} not reliable", tau.max);
    let burn = tau.burn_in as usize;
    let n = g.dim();
    for p in 0..n {
        assert_within(
            &format!("mean of x{p}"),
            mean_and_mcse(&sink.chains, burn, |x| x[p]),
            0.0,
            K_MCSE,
        );
        assert_within(
            &format!("variance of x{p}"),
            mean_and_mcse(&sink.chains, burn, |x| x[p] * x[p]),
            g.cov[(p, p)],
            K_MCSE,
        );
    }
    assert_within(
        "covariance of x0 and x2",
        mean_and_mcse(&sink.chains, burn, |x| x[0] * x[n - 1]),
        g.cov[(0, n - 1)],
        K_MCSE,
    );
    // Each (ensemble, step) draws the random walk with probability 1/2 and then proposes for
    // both halves, every walker once: a binomial count of draws, within 5 standard deviations.
    let proposed = proposals.load(Ordering::Relaxed);
    assert_eq!(proposed % walkers as u64, 0, "{proposed}");
    let draws = (proposed / walkers as u64) as f64;
    let trials = (ensembles as u64 * steps) as f64;
    let sd = (trials * 0.25).sqrt();
    assert!(
        (draws - 0.5 * trials).abs() < 5.0 * sd,
        "the random walk was drawn {draws} times in {trials} (ensemble, step) pairs"
    );
}

/// The slice move along axis directions of one's own, mixed with differential evolution,
/// keeps the moments of a correlated Gaussian within the Monte-Carlo error, and is fitted in
/// about half the (ensemble, step, half) triples.
#[test]
fn slice_directions_of_ones_own_mixed_with_de_sample_a_correlated_gaussian() {
    let g = Gaussian::correlated(3, 0.9);
    let (walkers, ensembles, steps) = (12, 4, 3000_u64);
    let fits = Arc::new(AtomicU64::new(0));
    let axes = AxisDirections {
        fits: Arc::clone(&fits),
    };
    let config = SamplerConfig::new(walkers, ensembles, 17)
        .unwrap()
        .with_moves(vec![
            (Move::slice_along(axes), 0.5),
            (Move::differential_evolution(), 0.5),
        ])
        .unwrap();
    let mut sampler = EnsembleSampler::new(&g, config, start(&g, walkers, ensembles, 17)).unwrap();
    let mut sink = MemorySink::new();
    let report = sampler
        .run(Steps::Fixed(steps), &mut sink, &mut Silent)
        .unwrap();
    let burn = report.tau.clone().expect("tau").burn_in as usize;
    for p in 0..g.dim() {
        assert_within(
            &format!("variance of x{p}"),
            mean_and_mcse(&sink.chains, burn, |x| x[p] * x[p]),
            g.cov[(p, p)],
            K_MCSE,
        );
    }
    assert_within(
        "covariance of x0 and x1",
        mean_and_mcse(&sink.chains, burn, |x| x[0] * x[1]),
        g.cov[(0, 1)],
        K_MCSE,
    );
    // Fitted once per half, in each (ensemble, step) that drew the slice move.
    let draws = (fits.load(Ordering::Relaxed) / 2) as f64;
    let trials = (ensembles as u64 * steps) as f64;
    assert!(
        (draws - 0.5 * trials).abs() < 5.0 * (trials * 0.25).sqrt(),
        "the axis slice move was drawn {draws} times in {trials} (ensemble, step) pairs"
    );
}

/// Alone, the random walk moves the walkers: its proposals are accepted at the rate a
/// random-walk Metropolis of this scale has, not never or always.
#[test]
fn the_move_of_ones_own_alone_is_accepted_and_moves_the_walkers() {
    let g = Gaussian::correlated(3, 0.9);
    let (rw, proposals) = RandomWalk::new(0.8);
    let config = SamplerConfig::new(8, 2, 7)
        .unwrap()
        .with_moves(vec![(Move::proposal(rw), 1.0)])
        .unwrap();
    let init = start(&g, 8, 2, 7);
    let mut sampler = EnsembleSampler::new(&g, config, init.clone()).unwrap();
    let report = sampler
        .run(Steps::Fixed(500), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    assert_eq!(proposals.load(Ordering::Relaxed), 2 * 8 * 500);
    let acceptance = report.mean_acceptance();
    assert!(
        (0.2..0.9).contains(&acceptance),
        "acceptance {acceptance} of the random walk"
    );
    assert_ne!(sampler.positions(0), &init[0].concat()[..]);
}

/// The checkpoint records the move of one's own by its spec: a resume with the stretch move
/// alone is refused, naming both mixtures; with the same moves it continues the chains of an
/// uninterrupted run bit for bit.
#[test]
fn a_checkpoint_records_the_move_of_ones_own_and_a_resume_must_use_it() {
    let g = Gaussian::correlated(3, 0.9);
    let config = |moves: Vec<(Move, f64)>| {
        SamplerConfig::new(8, 2, 5)
            .unwrap()
            .with_moves(moves)
            .unwrap()
    };
    let mixed = || {
        vec![
            (Move::proposal(RandomWalk::new(0.5).0), 0.5),
            (Move::differential_evolution(), 0.5),
        ]
    };
    let init = start(&g, 8, 2, 5);

    let mut full = MemorySink::new();
    let mut s = EnsembleSampler::new(&g, config(mixed()), init.clone()).unwrap();
    s.run(Steps::Fixed(60), &mut full, &mut Silent).unwrap();

    let mut part = MemorySink::new();
    let mut s = EnsembleSampler::new(&g, config(mixed()), init).unwrap();
    s.run(Steps::Fixed(25), &mut part, &mut Silent).unwrap();
    let json = part.last_checkpoint.clone().unwrap();
    assert!(
        json.contains(r#"{"kind":"random_walk","scale":0.5}"#),
        "{json}"
    );
    drop(s);
    let state = || {
        let mut state: SamplerState = serde_json::from_str(&json).unwrap();
        state
            .rebuild_history::<SamplerError>(&config(mixed()), |p| Ok(part.position_column(p)))
            .unwrap();
        state
    };
    let err = EnsembleSampler::from_state(&g, config(vec![(Move::stretch(), 1.0)]), state())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("random_walk(scale=0.5)=0.5")
            && err.contains("stretch(a=2)=1")
            && err.contains("resume with the original moves"),
        "{err}"
    );
    // Another scale is another move.
    let other = vec![
        (Move::proposal(RandomWalk::new(0.6).0), 0.5),
        (Move::differential_evolution(), 0.5),
    ];
    assert!(EnsembleSampler::from_state(&g, config(other), state()).is_err());

    let mut s = EnsembleSampler::from_state(&g, config(mixed()), state()).unwrap();
    s.run(Steps::Fixed(35), &mut part, &mut Silent).unwrap();
    for e in 0..2 {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&full.chains[e].positions),
            bits(&part.chains[e].positions)
        );
    }
}
