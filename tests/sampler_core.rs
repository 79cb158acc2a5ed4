//! Mechanics of the ensemble sampler: determinism, resume, start checks, rejections, errors.

mod sampler_util;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sampler_util::Gaussian;
use slipbayes::density::{LogDensity, LogDensityError};
use slipbayes::optimize::{
    initial_around_optimum, laplace_covariance, nelder_mead, NelderMeadOptions,
};
use slipbayes::sampler::moves::{Stretch, Walk};
use slipbayes::sampler::{
    EnsembleSampler, MemorySink, Move, SamplerConfig, SamplerError, SamplerState, Silent, Steps,
    StopRule, SLICE_ADAPT_STEPS, SLICE_MU0,
};

/// Bit patterns, compared without printing megabytes on failure.
fn bits(v: &[f64]) -> BitVec {
    BitVec(v.iter().map(|x| x.to_bits()).collect())
}

#[derive(PartialEq)]
struct BitVec(Vec<u64>);
impl std::fmt::Debug for BitVec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} values, hash {:x}",
            self.0.len(),
            self.0.iter().fold(0u64, |h, v| h.rotate_left(5) ^ v)
        )
    }
}

/// A Gaussian restricted to x0 > 0 (rejected as "out_of_support"), NaN for x1 > 4,
/// with the derived value x0 + x1.
struct Truncated;
impl LogDensity for Truncated {
    fn dim(&self) -> usize {
        2
    }
    fn derived_names(&self) -> Vec<String> {
        vec!["sum".into()]
    }
    fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
        d[0] = x[0] + x[1];
        if x[0] <= 0.0 {
            return Err(LogDensityError::rejected("out_of_support"));
        }
        if x[1] > 4.0 {
            return Ok(f64::NAN);
        }
        Ok(-0.5 * (x[0] * x[0] + x[1] * x[1]))
    }
}

fn mixed_moves() -> Vec<(Move, f64)> {
    vec![
        (Move::stretch(), 1.0),
        (Move::differential_evolution(), 1.0),
        (Move::proposal(Walk::new(Some(3)).unwrap()), 0.5),
    ]
}

fn start(d: &impl LogDensity, walkers: usize, ensembles: usize) -> Vec<Vec<Vec<f64>>> {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let x0 = vec![0.5; d.dim()];
    initial_around_optimum(d, &x0, walkers, ensembles, &mut rng)
        .unwrap()
        .walkers
}

/// The moves mixed with ensemble slice sampling (both directions).
fn slice_moves() -> Vec<(Move, f64)> {
    vec![
        (Move::differential_evolution(), 1.0),
        (Move::slice(), 1.0),
        (Move::slice_gaussian(), 0.5),
    ]
}

fn run_in_pool(threads: usize, parallel: bool) -> MemorySink {
    run_moves_in_pool(mixed_moves(), threads, parallel)
}

fn run_moves_in_pool(moves: Vec<(Move, f64)>, threads: usize, parallel: bool) -> MemorySink {
    let g = Gaussian::correlated(3, 0.9);
    let config = SamplerConfig::new(10, 3, 99)
        .unwrap()
        .with_moves(moves)
        .unwrap()
        .with_parallel(parallel);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut sampler = EnsembleSampler::new(&g, config, start(&g, 10, 3)).unwrap();
    let mut sink = MemorySink::new();
    pool.install(|| sampler.run(Steps::Fixed(150), &mut sink, &mut Silent))
        .unwrap();
    sink
}

#[test]
fn same_chains_on_one_or_two_threads_and_serially() {
    let one = run_in_pool(1, true);
    assert_eq!(one.chains.len(), 3);
    assert_same_chains(&one, &run_in_pool(2, true), &run_in_pool(2, false));
    // Ensembles use different streams.
    assert_ne!(
        bits(&one.chains[0].positions),
        bits(&one.chains[1].positions)
    );
}

/// Slice half-steps run every walker's update as its own task on the rayon pool: the chains
/// must still not depend on the threads, nor on running serially.
#[test]
fn slice_chains_are_the_same_on_one_or_two_threads_and_serially() {
    assert_same_chains(
        &run_moves_in_pool(slice_moves(), 1, true),
        &run_moves_in_pool(slice_moves(), 2, true),
        &run_moves_in_pool(slice_moves(), 2, false),
    );
}

/// The chains of one thread, two threads and a serial run agree bit for bit.
fn assert_same_chains(one: &MemorySink, two: &MemorySink, serial: &MemorySink) {
    for e in 0..one.chains.len() {
        assert_eq!(
            bits(&one.chains[e].positions),
            bits(&two.chains[e].positions)
        );
        assert_eq!(
            bits(&one.chains[e].positions),
            bits(&serial.chains[e].positions)
        );
        assert_eq!(
            bits(&one.chains[e].log_density),
            bits(&two.chains[e].log_density)
        );
    }
}

#[test]
fn resumed_run_equals_uninterrupted_run() {
    resumed_run_check(mixed_moves());
}

/// Resumed within the slice move's tuning (at step 40 of 50) and after it: μ is part of the
/// state, so the chains go on as if never stopped.
#[test]
fn resumed_slice_run_equals_uninterrupted_run() {
    resumed_run_check(slice_moves());
}

fn resumed_run_check(moves: Vec<(Move, f64)>) {
    let g = Gaussian::correlated(3, 0.9);
    let config = || {
        SamplerConfig::new(8, 2, 5)
            .unwrap()
            .with_moves(moves.clone())
            .unwrap()
            .with_checkpoint_every(Some(25))
            .unwrap()
    };
    let init = start(&g, 8, 2);

    let mut full = MemorySink::new();
    let mut s = EnsembleSampler::new(&g, config(), init.clone()).unwrap();
    let report_full = s.run(Steps::Fixed(100), &mut full, &mut Silent).unwrap();
    // Checkpoints at 25, 50, 75, 100 (the last also being the end).
    assert_eq!(full.checkpoints, 4);

    let mut part = MemorySink::new();
    let mut s = EnsembleSampler::new(&g, config(), init).unwrap();
    s.run(Steps::Fixed(40), &mut part, &mut Silent).unwrap();
    let json = part.last_checkpoint.clone().unwrap();
    drop(s);
    let mut state: SamplerState = serde_json::from_str(&json).unwrap();
    assert_eq!(state.step, 40);
    assert!(state.history.is_none(), "checkpoints leave the history out");
    state
        .rebuild_history::<SamplerError>(&config(), |p| Ok(part.position_column(p)))
        .unwrap();
    let mut s = EnsembleSampler::from_state(&g, config(), state).unwrap();
    let report_resumed = s.run(Steps::Fixed(60), &mut part, &mut Silent).unwrap();

    for e in 0..2 {
        assert_eq!(full.chains[e].steps, part.chains[e].steps);
        assert_eq!(
            bits(&full.chains[e].positions),
            bits(&part.chains[e].positions)
        );
        assert_eq!(
            bits(&full.chains[e].log_density),
            bits(&part.chains[e].log_density)
        );
    }
    assert_eq!(report_full.ensembles, report_resumed.ensembles);
    assert_eq!(report_resumed.total_steps, 100);
    assert_eq!(report_resumed.steps_run, 60);
}

/// A history released between runs (for the memory of a summary) and restored from the
/// chains' kept rows alone gives the same stopping decisions, chains and state as one that
/// stayed; with 64 history rows the restore crosses two halvings of the thinning. Without the
/// restore the sampler refuses to run on.
#[test]
fn a_released_history_restored_from_the_chains_goes_on_as_if_kept() {
    let g = Gaussian::correlated(3, 0.9);
    let config = SamplerConfig::new(8, 2, 5)
        .unwrap()
        .with_moves(mixed_moves())
        .unwrap()
        .with_history_rows(64)
        .unwrap();
    let rule = StopRule {
        check_every: 20,
        ..StopRule::new(400)
    };
    let init = start(&g, 8, 2);

    let mut kept_sink = MemorySink::new();
    let mut kept = EnsembleSampler::new(&g, config.clone(), init.clone()).unwrap();
    kept.run(Steps::Fixed(150), &mut kept_sink, &mut Silent)
        .unwrap();
    let kept_report = kept
        .run(Steps::UntilConverged(rule), &mut kept_sink, &mut Silent)
        .unwrap();

    let mut sink = MemorySink::new();
    let mut s = EnsembleSampler::new(&g, config, init).unwrap();
    s.run(Steps::Fixed(150), &mut sink, &mut Silent).unwrap();
    s.release_history();
    assert!(s.state().history.is_none());
    assert!(matches!(
        s.run(Steps::Fixed(1), &mut MemorySink::new(), &mut Silent),
        Err(SamplerError::HistoryReleased)
    ));
    let mut asked = Vec::new();
    s.restore_history::<SamplerError>(|p, rows| {
        asked.push(rows.len());
        let column = sink.position_column(p);
        Ok(rows.iter().map(|&r| column[r]).collect())
    })
    .unwrap();
    // Only the kept rows are read: 150 steps thinned to 38 rows of 16 walkers, per parameter.
    assert_eq!(asked, vec![38 * 16; 3]);
    let report = s
        .run(Steps::UntilConverged(rule), &mut sink, &mut Silent)
        .unwrap();
    assert_eq!(report, kept_report);
    assert_eq!(s.state(), kept.state());
    for e in 0..2 {
        assert_eq!(
            bits(&sink.chains[e].positions),
            bits(&kept_sink.chains[e].positions)
        );
    }
}

/// The slice move's μ is tuned during the first `SLICE_ADAPT_STEPS` steps, per ensemble, and
/// then never changes; the suggested burn-in covers the tuning.
#[test]
fn the_slice_scale_is_tuned_and_then_frozen() {
    let g = Gaussian::correlated(3, 0.9);
    let config = SamplerConfig::new(10, 2, 8)
        .unwrap()
        .with_moves(vec![(Move::slice(), 1.0)])
        .unwrap();
    let mut s = EnsembleSampler::new(&g, config, start(&g, 10, 2)).unwrap();
    let scales = |s: &EnsembleSampler<'_, Gaussian>| -> Vec<f64> {
        s.state()
            .ensembles
            .iter()
            .flat_map(|e| e.slice_scales.clone())
            .collect()
    };
    assert_eq!(scales(&s), [SLICE_MU0; 2]);
    s.run(
        Steps::Fixed(SLICE_ADAPT_STEPS - 1),
        &mut MemorySink::new(),
        &mut Silent,
    )
    .unwrap();
    let before_last = scales(&s);
    s.run(Steps::Fixed(1), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    let tuned = scales(&s);
    // Tuned away from μ₀, separately per ensemble, up to the last step of the tuning.
    for (e, (&mu, &prev)) in tuned.iter().zip(&before_last).enumerate() {
        assert!(
            (mu / SLICE_MU0 - 1.0).abs() > 0.05,
            "ensemble {e}: μ {mu} not tuned"
        );
        assert_ne!(
            mu.to_bits(),
            prev.to_bits(),
            "ensemble {e}: the last step tunes"
        );
    }
    assert_ne!(tuned[0].to_bits(), tuned[1].to_bits());
    let report = s
        .run(Steps::Fixed(150), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    assert_eq!(
        bits(&scales(&s)),
        bits(&tuned),
        "μ changed after the tuning"
    );
    let tau = report.tau.as_ref().expect("τ");
    assert!(tau.burn_in >= SLICE_ADAPT_STEPS, "burn-in {}", tau.burn_in);
    // Slice updates always move: they are no proposals to accept.
    assert!(report
        .ensembles
        .iter()
        .flat_map(|e| &e.acceptance)
        .all(|a| a.is_nan()));
    assert!(report.mean_acceptance().is_nan());
}

/// A density that counts its evaluations.
struct Counting<'a, D>(&'a D, std::sync::atomic::AtomicU64);
impl<D: LogDensity> LogDensity for Counting<'_, D> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn derived_names(&self) -> Vec<String> {
        self.0.derived_names()
    }
    fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
        self.1.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.0.log_density(x, d)
    }
}

/// The report counts every evaluation a slice update makes (stepping out, shrinking, points
/// outside the support) and the acceptance fraction only the moves' proposals.
#[test]
fn slice_evaluations_are_all_counted_and_acceptance_is_the_other_moves() {
    let d = Counting(&Truncated, Default::default());
    let config = SamplerConfig::new(8, 2, 3)
        .unwrap()
        .with_moves(vec![(Move::stretch(), 1.0), (Move::slice(), 1.0)])
        .unwrap();
    let mut s = EnsembleSampler::new(&d, config, start(&Truncated, 8, 2)).unwrap();
    let report = s
        .run(Steps::Fixed(400), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    let calls = d.1.load(std::sync::atomic::Ordering::Relaxed);
    assert_eq!(report.evaluations(), calls);
    // More than one evaluation per walker and step: the slice steps cost several.
    assert!(calls > 2 * 8 * 401 * 3 / 2, "{calls} evaluations");
    let state = s.state();
    for (e, r) in state.ensembles.iter().zip(&report.ensembles) {
        // About half the steps were slice updates; the acceptance is over the others.
        let proposals = 400 - e.slice_updates;
        assert!(
            (100..300).contains(&proposals),
            "{proposals} stretch updates"
        );
        for (&a, &acc) in e.accepted.iter().zip(&r.acceptance) {
            assert_eq!(acc.to_bits(), (a as f64 / proposals as f64).to_bits());
        }
        assert!(r.rejections.get("out_of_support").copied().unwrap_or(0) > 0);
    }
}

#[test]
fn resume_with_another_density_is_refused() {
    let g = Gaussian::correlated(3, 0.9);
    let other = Gaussian::correlated(3, 0.5);
    let config = SamplerConfig::new(8, 1, 5).unwrap();
    let mut s = EnsembleSampler::new(&g, config.clone(), start(&g, 8, 1)).unwrap();
    s.run(Steps::Fixed(5), &mut MemorySink::new(), &mut Silent)
        .unwrap();
    let err = EnsembleSampler::from_state(&other, config, s.state()).unwrap_err();
    assert!(matches!(err, SamplerError::StateMismatch { .. }), "{err}");
}

#[test]
fn rejections_counted_per_reason_and_derived_values_stored() {
    let config = SamplerConfig::new(8, 2, 3)
        .unwrap()
        .with_moves(mixed_moves())
        .unwrap();
    let init = start(&Truncated, 8, 2);
    let mut s = EnsembleSampler::new(&Truncated, config, init).unwrap();
    let mut sink = MemorySink::new();
    let report = s.run(Steps::Fixed(400), &mut sink, &mut Silent).unwrap();
    let out: u64 = report
        .ensembles
        .iter()
        .map(|e| e.rejections.get("out_of_support").copied().unwrap_or(0))
        .sum();
    let nan: u64 = report
        .ensembles
        .iter()
        .map(|e| e.rejections.get("nan").copied().unwrap_or(0))
        .sum();
    assert!(out > 100, "out-of-support rejections: {out}");
    assert!(nan > 0, "NaN rejections: {nan}");
    // Evaluations: initial walkers + one proposal per walker per step.
    assert_eq!(report.evaluations(), 2 * 8 * 401);
    for c in &sink.chains {
        assert_eq!(c.derived.len(), c.log_density.len());
        for (i, d) in c.derived.iter().enumerate() {
            let p = &c.positions[2 * i..2 * i + 2];
            assert!((d - (p[0] + p[1])).abs() <= 1e-12 * (1.0 + d.abs()));
            assert!(p[0] > 0.0 && p[1] <= 4.0);
        }
    }
    for a in report.ensembles.iter().flat_map(|e| &e.acceptance) {
        assert!((0.05..0.95).contains(a), "acceptance fraction {a}");
    }
}

#[test]
fn bad_starts_are_refused_with_clear_errors() {
    let g = Gaussian::correlated(2, 0.5);
    let config = SamplerConfig::new(4, 1, 0).unwrap();
    let good = vec![vec![
        vec![0.1, 0.2],
        vec![-0.3, 0.1],
        vec![0.2, -0.4],
        vec![0.5, 0.5],
    ]];

    let mut nonfinite = good.clone();
    nonfinite[0][2][1] = f64::NAN;
    let err = EnsembleSampler::new(&g, config.clone(), nonfinite).unwrap_err();
    assert!(
        matches!(err, SamplerError::BadInitialWalker { walker: 2, .. }),
        "{err}"
    );

    let degenerate = vec![(0..4).map(|i| vec![i as f64, 2.0 * i as f64]).collect()];
    let err = EnsembleSampler::new(&g, config.clone(), degenerate).unwrap_err();
    assert!(
        matches!(err, SamplerError::DegenerateEnsemble { .. }),
        "{err}"
    );

    let mut outside = good.clone();
    outside[0][1] = vec![-1.0, 0.0];
    let err = EnsembleSampler::new(&Truncated, config.clone(), outside).unwrap_err();
    assert!(err.to_string().contains("out_of_support"), "{err}");

    let err = EnsembleSampler::new(&g, config.clone(), vec![good[0][..3].to_vec()]).unwrap_err();
    assert!(matches!(err, SamplerError::Shape { .. }), "{err}");

    let three = Gaussian::correlated(3, 0.5);
    let err = EnsembleSampler::new(&three, config, vec![vec![vec![0.0; 3]; 4]]).unwrap_err();
    assert!(
        matches!(
            err,
            SamplerError::InvalidConfig {
                name: "walkers",
                ..
            }
        ),
        "{err}"
    );

    assert!(SamplerConfig::new(5, 1, 0).is_err());
    assert!(SamplerConfig::new(8, 0, 0).is_err());
    assert!(Stretch::new(0.5).is_err());
    assert!(SamplerConfig::new(4, 1, 0)
        .unwrap()
        .with_moves(vec![(Move::proposal(Walk::new(Some(3)).unwrap()), 1.0)])
        .is_err());
    assert!(SamplerConfig::new(8, 1, 0)
        .unwrap()
        .with_moves(vec![(Move::stretch(), -1.0)])
        .is_err());
}

/// +∞ beyond x0 > 3, a fatal error beyond x1 > 3.
struct Faulty(bool);
impl LogDensity for Faulty {
    fn dim(&self) -> usize {
        2
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        if self.0 && x[0] > 1.0 {
            return Ok(f64::INFINITY);
        }
        if !self.0 && x[1] > 1.0 {
            return Err(LogDensityError::fatal("model integration diverged"));
        }
        Ok(-0.5 * (x[0] * x[0] + x[1] * x[1]))
    }
}

#[test]
fn fatal_density_stops_the_run_naming_walker_and_step() {
    for inf in [true, false] {
        let d = Faulty(inf);
        let config = SamplerConfig::new(8, 2, 1).unwrap();
        let init: Vec<Vec<Vec<f64>>> = (0..2)
            .map(|e| {
                (0..8)
                    .map(|w| vec![0.05 * w as f64 - 0.2, 0.03 * ((w * 5 + e) % 8) as f64 - 0.1])
                    .collect()
            })
            .collect();
        let mut s = EnsembleSampler::new(&d, config, init).unwrap();
        let err = s
            .run(Steps::Fixed(10_000), &mut MemorySink::new(), &mut Silent)
            .unwrap_err();
        match &err {
            SamplerError::FatalDensity {
                position, message, ..
            } => {
                if inf {
                    assert!(position[0] > 1.0 && message.contains("+inf"), "{err}");
                } else {
                    assert!(position[1] > 1.0 && message.contains("diverged"), "{err}");
                }
            }
            other => panic!("unexpected error {other}"),
        }
        let text = err.to_string();
        assert!(text.contains("walker") && text.contains("step"), "{text}");
        let again = s
            .run(Steps::Fixed(1), &mut MemorySink::new(), &mut Silent)
            .unwrap_err();
        assert!(matches!(again, SamplerError::Poisoned));
    }
}

/// The Rosenbrock function as a log-density: mode (1, 1).
struct Rosenbrock;
impl LogDensity for Rosenbrock {
    fn dim(&self) -> usize {
        2
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        Ok(-((1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2)) / 20.0)
    }
}

#[test]
fn nelder_mead_finds_the_rosenbrock_minimum() {
    let f = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
    let (x, fx, evals) = nelder_mead(f, &[-1.2, 1.0], &NelderMeadOptions::default());
    assert!(
        (x[0] - 1.0).abs() < 1e-5 && (x[1] - 1.0).abs() < 1e-5,
        "{x:?} f={fx} after {evals}"
    );
    // A 6-D quadratic with different scales.
    let g = |x: &[f64]| {
        x.iter()
            .enumerate()
            .map(|(i, v)| (v - i as f64).powi(2) * 10f64.powi(i as i32 - 2))
            .sum()
    };
    let (x, _, _) = nelder_mead(g, &[0.0; 6], &NelderMeadOptions::default());
    for (i, v) in x.iter().enumerate() {
        assert!((v - i as f64).abs() < 1e-3, "coordinate {i}: {v}");
    }
}

#[test]
fn laplace_covariance_of_a_gaussian_is_its_covariance() {
    let g = Gaussian::rotated(4, 100.0, 8);
    let mode = [0.0; 4];
    let (cov, pd) = laplace_covariance(|x| g.log_density(x, &mut []).unwrap(), &mode, 1e-3);
    assert!(pd);
    for i in 0..4 {
        for j in 0..4 {
            let truth = g.cov[(i, j)];
            let scale = (g.cov[(i, i)] * g.cov[(j, j)]).sqrt();
            assert!(
                (cov[i * 4 + j] - truth).abs() < 1e-5 * scale,
                "({i},{j}) {} vs {truth}",
                cov[i * 4 + j]
            );
        }
    }
    // Not positive definite (a saddle): the fallback spread is used and reported.
    let (cov, pd) = laplace_covariance(|x| -x[0] * x[0] + x[1] * x[1], &[0.0, 0.0], 1e-3);
    assert!(!pd && cov.iter().all(|v| v.is_finite()) && cov[3] > 0.0 && cov[0] > 0.0);
}

#[test]
fn start_around_optimum_of_rosenbrock() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let start = initial_around_optimum(&Rosenbrock, &[-1.0, 2.0], 16, 4, &mut rng).unwrap();
    assert!(start.optimum.positive_definite);
    assert!((start.optimum.x[0] - 1.0).abs() < 1e-4 && (start.optimum.x[1] - 1.0).abs() < 1e-4);
    assert_eq!(start.walkers.len(), 4);
    assert!(start.walkers.iter().all(|e| e.len() == 16));
    // Laplace covariance at (1, 1) of (1-x)²/20 + 5 (y - x²)²: H = [[0.1+40, -20], [-20, 10]].
    let det = 40.1 * 10.0 - 400.0;
    let truth = [10.0 / det, 20.0 / det, 20.0 / det, 40.1 / det];
    for (c, t) in start.optimum.covariance.to_dense(2).iter().zip(truth) {
        assert!((c - t).abs() < 1e-4 * t.abs(), "{c} vs {t}");
    }
    // The start is usable as it is.
    let config = SamplerConfig::new(16, 4, 1).unwrap();
    EnsembleSampler::new(&Rosenbrock, config, start.walkers).unwrap();
}

#[test]
fn stopping_rule_stops_a_gaussian_and_suggests_burn_in_and_thinning() {
    let g = Gaussian::correlated(2, 0.5);
    let config = SamplerConfig::new(16, 4, 11).unwrap();
    let mut s = EnsembleSampler::new(&g, config, start(&g, 16, 4)).unwrap();
    let rule = StopRule::new(50_000);
    let report = s
        .run(
            Steps::UntilConverged(rule),
            &mut slipbayes::sampler::NullSink,
            &mut Silent,
        )
        .unwrap();
    assert_eq!(
        report.stopped_by,
        slipbayes::sampler::StopReason::Converged,
        "{:?}",
        report.problems
    );
    let tau = report.tau.clone().unwrap();
    // τ pooled over 4 × 16 walkers is trusted on 25 τ after the burn-in (emcee's 50 τ on 32).
    let trusted = slipbayes::diagnostics::tau_trusted_length(64, 50.0);
    assert!((trusted - 25.0).abs() < 1e-12, "{trusted}");
    assert!(report.total_steps as f64 > (trusted * tau.max) + tau.burn_in as f64);
    assert!(report.total_steps < 50_000);
    assert!(tau.reliable && report.converged, "{:?}", report.problems);
    assert!(tau.burn_in >= 2 && tau.burn_in as f64 >= 2.0 * tau.max);
    assert!(report.rhat.unwrap().iter().all(|&r| r < 1.01));
}

#[test]
fn resumed_stopping_rule_run_stops_at_the_same_step() {
    let g = Gaussian::correlated(2, 0.8);
    let config = || {
        SamplerConfig::new(8, 2, 17)
            .unwrap()
            .with_checkpoint_every(Some(100))
            .unwrap()
            .with_history_rows(128)
            .unwrap()
    };
    let mut rule = StopRule::new(30_000);
    rule.check_every = 50;
    let init = start(&g, 8, 2);

    let mut full = MemorySink::new();
    let mut s = EnsembleSampler::new(&g, config(), init.clone()).unwrap();
    let a = s
        .run(Steps::UntilConverged(rule), &mut full, &mut Silent)
        .unwrap();
    assert_eq!(a.stopped_by, slipbayes::sampler::StopReason::Converged);
    // The history was thinned several times on the way (128 rows kept at most).
    assert!(a.total_steps > 1000, "{}", a.total_steps);

    let mut part = MemorySink::new();
    let mut s = EnsembleSampler::new(&g, config(), init).unwrap();
    s.run(Steps::Fixed(700), &mut part, &mut Silent).unwrap();
    let mut state: SamplerState =
        serde_json::from_str(part.last_checkpoint.as_ref().unwrap()).unwrap();
    // The history, thinned several times by step 700, is restored from the chains.
    state
        .rebuild_history::<SamplerError>(&config(), |p| Ok(part.position_column(p)))
        .unwrap();
    let mut s = EnsembleSampler::from_state(&g, config(), state).unwrap();
    let b = s
        .run(Steps::UntilConverged(rule), &mut part, &mut Silent)
        .unwrap();
    assert_eq!(a.total_steps, b.total_steps);
    assert_eq!(a.tau, b.tau);
    assert_eq!(a.rhat, b.rhat);
    for e in 0..2 {
        assert_eq!(
            bits(&full.chains[e].positions),
            bits(&part.chains[e].positions)
        );
    }
}

#[test]
fn tau_from_the_thinned_history_matches_the_full_history() {
    let g = Gaussian::correlated(3, 0.9);
    let run = |rows: usize| {
        let config = SamplerConfig::new(12, 4, 23)
            .unwrap()
            .with_history_rows(rows)
            .unwrap();
        let mut s = EnsembleSampler::new(&g, config, start(&g, 12, 4)).unwrap();
        s.run(
            Steps::Fixed(6000),
            &mut slipbayes::sampler::NullSink,
            &mut Silent,
        )
        .unwrap()
        .tau
        .unwrap()
    };
    let full = run(8192); // every step kept
    let thinned = run(1024); // every 8th step kept at the end
    assert!(full.max > 10.0, "τ_max {}", full.max);
    for (a, b) in full.per_parameter.iter().zip(&thinned.per_parameter) {
        assert!(
            (a - b).abs() < 0.1 * a,
            "τ {a} (all steps) vs {b} (thinned history)"
        );
    }
}
