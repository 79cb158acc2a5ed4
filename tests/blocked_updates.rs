//! Blocked updates (Metropolis-within-Gibbs over a density's blocks) target the right
//! distribution: a hierarchical Gaussian whose posterior is known exactly, sampled with the
//! group parameters updated one group at a time given the shared ones. Also: the cache the
//! block updates reuse always equals a full evaluation, and a blocked run resumes
//! bit-identically. Slow in debug builds: run with `cargo test --release`.

mod sampler_util;

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sampler_util::{assert_within, mean_and_mcse};
use slipbayes::density::{
    BlockLinks, BlockPlan, BlockUpdate, BlockedDensity, LogDensity, LogDensityError, PlannedBlock,
    Target,
};
use slipbayes::optimize::initial_around_optimum;
use slipbayes::sampler::{
    CarryFit, EnsembleSampler, MemorySink, Move, SamplerConfig, SamplerError, Silent, Steps,
    Updates, CARRY_FIT_STEPS,
};

/// Allowed distance from the truth in Monte-Carlo standard errors.
const K_MCSE: f64 = 4.0;

/// μ ∈ R² ~ N(0, 10² I); per group j, θ_j ∈ R² ~ N(μ, P⁻¹) and one observation
/// y_j ~ N(θ_j, R⁻¹). Coordinates: μ, then θ_1, θ_2, …; blocks: μ, then each θ_j. The cache
/// holds the prior of μ and each group's two terms; the derived values are θ_j0 + θ_j1 per
/// group (written only by the evaluations that touch θ_j).
struct Hierarchy {
    y: Vec<[f64; 2]>,
    /// Precision of θ_j about μ (strongly correlated, so that μ and the θ_j are too).
    p: [[f64; 2]; 2],
    /// Precision of an observation.
    r: [[f64; 2]; 2],
}

impl Hierarchy {
    fn new(groups: usize) -> Self {
        let y = (0..groups)
            .map(|j| {
                let t = j as f64;
                [1.0 + 0.7 * (1.3 * t).sin(), -0.5 + 0.9 * (0.7 * t).cos()]
            })
            .collect();
        // Covariance [[1, 0.9], [0.9, 1]] / 4 and [[1, −0.5], [−0.5, 1]] / 9, inverted.
        let inv = |c: [[f64; 2]; 2]| {
            let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
            [
                [c[1][1] / det, -c[0][1] / det],
                [-c[1][0] / det, c[0][0] / det],
            ]
        };
        Self {
            y,
            p: inv([[0.25, 0.225], [0.225, 0.25]]),
            r: inv([[1.0 / 9.0, -0.5 / 9.0], [-0.5 / 9.0, 1.0 / 9.0]]),
        }
    }

    fn groups(&self) -> usize {
        self.y.len()
    }

    fn quad(m: &[[f64; 2]; 2], d: [f64; 2]) -> f64 {
        d[0] * (m[0][0] * d[0] + m[0][1] * d[1]) + d[1] * (m[1][0] * d[0] + m[1][1] * d[1])
    }

    fn mu_prior(x: &[f64]) -> f64 {
        -0.5 * (x[0] * x[0] + x[1] * x[1]) / 100.0
    }

    /// Group j's terms given μ and θ_j.
    fn group_term(&self, j: usize, x: &[f64]) -> f64 {
        let th = [x[2 + 2 * j], x[3 + 2 * j]];
        let y = self.y[j];
        -0.5 * Self::quad(&self.p, [th[0] - x[0], th[1] - x[1]])
            - 0.5 * Self::quad(&self.r, [y[0] - th[0], y[1] - th[1]])
    }

    fn total(cache: &[f64]) -> f64 {
        cache.iter().sum()
    }

    /// The exact posterior mean and covariance (it is Gaussian).
    fn exact(&self) -> (DVector<f64>, DMatrix<f64>) {
        let n = self.dim();
        let mut prec = DMatrix::<f64>::zeros(n, n);
        let mut b = DVector::<f64>::zeros(n);
        for a in 0..2 {
            prec[(a, a)] += 1.0 / 100.0;
        }
        for (j, y) in self.y.iter().enumerate() {
            let t = 2 + 2 * j;
            for a in 0..2 {
                for c in 0..2 {
                    // (θ − μ)ᵀ P (θ − μ) and (y − θ)ᵀ R (y − θ).
                    prec[(a, c)] += self.p[a][c];
                    prec[(t + a, t + c)] += self.p[a][c] + self.r[a][c];
                    prec[(a, t + c)] -= self.p[a][c];
                    prec[(t + a, c)] -= self.p[a][c];
                    b[t + a] += self.r[a][c] * y[c];
                }
            }
        }
        let cov = prec.try_inverse().expect("precision invertible");
        let mean = &cov * b;
        (mean, cov)
    }
}

impl LogDensity for Hierarchy {
    fn dim(&self) -> usize {
        2 + 2 * self.groups()
    }

    fn derived_names(&self) -> Vec<String> {
        (0..self.groups()).map(|j| format!("sum[{j}]")).collect()
    }

    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let mut cache = vec![0.0; self.state_len()];
        self.log_density_with_state(x, derived, &mut cache)
    }
}

/// Blocks μ, then each θ_j; μ is given to every group, and every θ_j follows μ.
impl BlockedDensity for Hierarchy {
    fn state_len(&self) -> usize {
        1 + self.groups()
    }

    fn log_density_with_state(
        &self,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        cache[0] = Self::mu_prior(x);
        for j in 0..self.groups() {
            cache[1 + j] = self.group_term(j, x);
            if !derived.is_empty() {
                derived[j] = x[2 + 2 * j] + x[3 + 2 * j];
            }
        }
        Ok(Self::total(cache))
    }

    fn log_density_after_block(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        if block == 0 {
            // μ enters its prior and every group's term; its followers (every θ_j) may have
            // moved with it.
            cache[0] = Self::mu_prior(x);
            for j in 0..self.groups() {
                cache[1 + j] = self.group_term(j, x);
                if !derived.is_empty() {
                    derived[j] = x[2 + 2 * j] + x[3 + 2 * j];
                }
            }
        } else {
            let j = block - 1;
            cache[1 + j] = self.group_term(j, x);
            if !derived.is_empty() {
                derived[j] = x[2 + 2 * j] + x[3 + 2 * j];
            }
        }
        Ok(Self::total(cache))
    }

    fn block_plan(&self) -> BlockPlan<'_> {
        let mu = vec![0, 1];
        let mut blocks = vec![PlannedBlock {
            coords: mu.clone(),
            links: BlockLinks {
                given: Vec::new(),
                followers: (2..self.dim()).collect(),
            },
            update: BlockUpdate::Moves { carry: None },
            split: None,
        }];
        blocks.extend((0..self.groups()).map(|j| PlannedBlock {
            coords: vec![2 + 2 * j, 3 + 2 * j],
            links: BlockLinks {
                given: mu.clone(),
                followers: Vec::new(),
            },
            update: BlockUpdate::Moves { carry: None },
            split: None,
        }));
        BlockPlan { blocks }
    }
}

fn blocked_sampler(
    h: &Hierarchy,
    moves: Vec<(Move, f64)>,
    walkers: usize,
    seed: u64,
    updates: Updates,
) -> EnsembleSampler<'_, Hierarchy> {
    carried_sampler(h, moves, walkers, seed, (updates, CarryFit::Auto))
}

fn carried_sampler(
    h: &Hierarchy,
    moves: Vec<(Move, f64)>,
    walkers: usize,
    seed: u64,
    (updates, carry): (Updates, CarryFit),
) -> EnsembleSampler<'_, Hierarchy> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let start = initial_around_optimum(
        Target::blocked(h),
        &vec![0.3; h.dim()],
        walkers,
        4,
        &mut rng,
    )
    .unwrap();
    let config = SamplerConfig::new(walkers, 4, seed)
        .unwrap()
        .with_moves(moves)
        .unwrap()
        .with_updates(updates)
        .with_carry(carry);
    EnsembleSampler::new(Target::blocked(h), config, start.walkers).unwrap()
}

/// A labelled sampler setting: its moves, updates and how the followers are carried.
type Case = (&'static str, Vec<(Move, f64)>, (Updates, CarryFit));

/// Means, variances and the μ–θ covariance of the blocked chains match the exact posterior,
/// for the stretch move and for the Student-t independence mixture, with plain blocked
/// updates and with hierarchical ones (μ carrying the θ_j along, each θ_j proposed from its
/// conditional given μ), for every move of the default mixture.
#[test]
fn blocked_updates_sample_a_hierarchical_gaussian() {
    let h = Hierarchy::new(6);
    let (mean, cov) = h.exact();
    let t_and = |m: Move| vec![(Move::student_t(), 0.5), (m, 0.5)];
    let cases: Vec<Case> = vec![
        (
            "stretch",
            vec![(Move::stretch(), 1.0)],
            (Updates::Blocked, CarryFit::Auto),
        ),
        (
            "student-t=0.9,stretch=0.1",
            vec![(Move::student_t(), 0.9), (Move::stretch(), 0.1)],
            (Updates::Blocked, CarryFit::Auto),
        ),
        (
            "hierarchical student-t=0.5,de=0.5",
            t_and(Move::differential_evolution()),
            (Updates::Hierarchical, CarryFit::Auto),
        ),
        // The followers' regressions fitted to the complement of each half-step (12
        // followers, 6 walkers in the complement: Auto tunes them).
        (
            "hierarchical student-t=0.5,de=0.5, complement",
            t_and(Move::differential_evolution()),
            (Updates::Hierarchical, CarryFit::Complement),
        ),
        (
            "hierarchical slice, complement",
            vec![(Move::slice(), 1.0)],
            (Updates::Hierarchical, CarryFit::Complement),
        ),
        (
            "hierarchical student-t=0.5,stretch=0.5",
            t_and(Move::stretch()),
            (Updates::Hierarchical, CarryFit::Auto),
        ),
        // The slice move in each block's subspace, and with μ carrying the θ_j along by
        // regression (a line in the whole space).
        (
            "blocked slice",
            vec![(Move::slice(), 1.0)],
            (Updates::Blocked, CarryFit::Auto),
        ),
        (
            "hierarchical slice",
            vec![(Move::slice(), 1.0)],
            (Updates::Hierarchical, CarryFit::Auto),
        ),
        (
            "hierarchical student-t=0.4,de=0.4,slice=0.2",
            vec![
                (Move::student_t(), 0.4),
                (Move::differential_evolution(), 0.4),
                (Move::slice(), 0.2),
            ],
            (Updates::Hierarchical, CarryFit::Auto),
        ),
    ];
    for (label, moves, updates) in cases {
        // Fewer walkers than 2 × 14 dimensions: blocked updates need only 2 × the largest
        // block.
        let mut sampler = carried_sampler(&h, moves, 12, 11, updates);
        let mut sink = MemorySink::new();
        sampler
            .run(Steps::Fixed(3000), &mut sink, &mut Silent)
            .unwrap();
        let burn = 300.max(CARRY_FIT_STEPS as usize);
        for p in 0..h.dim() {
            assert_within(
                &format!("{label}: mean of x{p}"),
                mean_and_mcse(&sink.chains, burn, |x| x[p]),
                mean[p],
                K_MCSE,
            );
            let m = mean[p];
            assert_within(
                &format!("{label}: variance of x{p}"),
                mean_and_mcse(&sink.chains, burn, |x| (x[p] - m).powi(2)),
                cov[(p, p)],
                K_MCSE,
            );
        }
        // μ_0 with θ_{1,0}: the coupling between the shared block and a group's.
        let (m0, m2) = (mean[0], mean[2]);
        assert_within(
            &format!("{label}: covariance of μ0 and θ1,0"),
            mean_and_mcse(&sink.chains, burn, |x| (x[0] - m0) * (x[2] - m2)),
            cov[(0, 2)],
            K_MCSE,
        );
    }
}

/// A shared block with far more followers than the complement has walkers (40 groups, 80
/// followers, 8 walkers in the complement): its regression tuned on the ensembles' own draws
/// and then frozen targets the exact posterior, and mixes where one fitted to each half-step's
/// complement barely moves μ (its errors in 80 coefficients add up in μ's acceptance ratio).
#[test]
fn a_tuned_carry_samples_many_groups_exactly_and_mixes() {
    let h = Hierarchy::new(40);
    let (mean, cov) = h.exact();
    let moves = vec![
        (Move::student_t(), 0.5),
        (Move::differential_evolution(), 0.5),
    ];
    let steps = 3000;
    // τ of μ0 (in steps, pooled over the ensembles) for each way of carrying.
    let mut tau_mu = Vec::new();
    for carry in [CarryFit::Tuned, CarryFit::Complement] {
        let mut sampler =
            carried_sampler(&h, moves.clone(), 16, 21, (Updates::Hierarchical, carry));
        let mut sink = MemorySink::new();
        let report = sampler
            .run(Steps::Fixed(steps), &mut sink, &mut Silent)
            .unwrap();
        let tau = report.tau.expect("a τ estimate after 3000 steps");
        tau_mu.push(tau.per_parameter[0]);
        if carry != CarryFit::Tuned {
            continue;
        }
        let burn = 2 * CARRY_FIT_STEPS as usize;
        for p in [0, 1, 2, 3, 40, 81] {
            assert_within(
                &format!("tuned: mean of x{p}"),
                mean_and_mcse(&sink.chains, burn, |x| x[p]),
                mean[p],
                K_MCSE,
            );
            let m = mean[p];
            assert_within(
                &format!("tuned: variance of x{p}"),
                mean_and_mcse(&sink.chains, burn, |x| (x[p] - m).powi(2)),
                cov[(p, p)],
                K_MCSE,
            );
        }
        let (m0, m2) = (mean[0], mean[2]);
        assert_within(
            "tuned: covariance of μ0 and θ1,0",
            mean_and_mcse(&sink.chains, burn, |x| (x[0] - m0) * (x[2] - m2)),
            cov[(0, 2)],
            K_MCSE,
        );
    }
    eprintln!(
        "τ of μ0: tuned {:.1}, complement {:.1}",
        tau_mu[0], tau_mu[1]
    );
    assert!(
        tau_mu[0] < 0.5 * tau_mu[1],
        "τ of μ0: tuned {} against complement {}",
        tau_mu[0],
        tau_mu[1]
    );
}

/// After blocked steps every walker's stored log-density and derived values are exactly a
/// full evaluation at its position; the state resumes bit-identically, and refuses joint
/// updates. Hierarchical updates too.
#[test]
fn blocked_state_is_a_full_evaluation_and_resumes() {
    let moves = vec![(Move::student_t(), 0.5), (Move::stretch(), 0.5)];
    for updates in [Updates::Blocked, Updates::Hierarchical] {
        blocked_state_check(updates, moves.clone());
    }
}

/// The same with the slice move, whose last evaluation of each walker becomes its state, and
/// whose μ per ensemble and block resumes with the chains (the resume falls within its
/// tuning).
#[test]
fn blocked_slice_state_is_a_full_evaluation_and_resumes() {
    let moves = vec![(Move::student_t(), 0.5), (Move::slice(), 0.5)];
    for updates in [Updates::Blocked, Updates::Hierarchical] {
        blocked_state_check(updates, moves.clone());
    }
}

fn blocked_state_check(updates: Updates, moves: Vec<(Move, f64)>) {
    let h = Hierarchy::new(4);
    let mut whole = blocked_sampler(&h, moves.clone(), 12, 5, updates);
    whole
        .run(Steps::Fixed(60), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    let state = whole.state();
    let mut derived = vec![0.0; h.groups()];
    for e in &state.ensembles {
        for (w, x) in e.positions.chunks(h.dim()).enumerate() {
            let lp = h.log_density(x, &mut derived).unwrap();
            assert_eq!(lp, e.log_density[w]);
            assert_eq!(derived, e.derived[w * h.groups()..(w + 1) * h.groups()]);
        }
    }

    let mut first = blocked_sampler(&h, moves.clone(), 12, 5, updates);
    first
        .run(Steps::Fixed(25), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    let config = first.config().clone();
    let mut resumed =
        EnsembleSampler::from_state(Target::blocked(&h), config.clone(), first.state()).unwrap();
    resumed
        .run(Steps::Fixed(35), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    assert_eq!(resumed.state(), state);

    let joint = config.with_updates(Updates::Joint);
    match EnsembleSampler::from_state(Target::blocked(&h), joint, first.state()) {
        Err(SamplerError::StateMismatch { detail }) => {
            assert!(detail.contains(updates.as_str()), "{detail}")
        }
        other => panic!("expected a state mismatch, got {other:?}"),
    }
}
