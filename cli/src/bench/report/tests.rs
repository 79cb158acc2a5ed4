use super::*;
use crate::bench::nuts::{GradientCheck, NutsComparison, NutsPlan, NutsRun};
use crate::bench::peer::{EnsemblePeer, MedianCheck};

fn medians() -> Vec<MedianCheck> {
    vec![MedianCheck {
        name: "ln_k[c]".into(),
        ours: 9.4,
        peer: 9.4,
        z: 0.5,
    }]
}

/// ESS 250 from 50,000 evaluations in 100 s (5 per 1,000 evaluations, 2.5 per second)
/// against ours, 250 from 2,500 evaluations (100 per 1,000) in 1 s on 2 threads.
fn emcee() -> PeerComparison {
    PeerComparison {
        sampler: EnsemblePeer::Stretch,
        versions: serde_json::json!({"emcee": "3"}),
        log_density: LogDensityCheck::new(&[Some(1.0)], &[Some(1.0)]),
        medians: medians(),
        medians_agree: true,
        walkers: 32,
        ensembles: 2,
        steps: 600,
        ours_us_per_eval: 40.0,
        peer_us_per_eval_single: 4000.0,
        peer_us_per_eval_vectorised: 3000.0,
        ours_sampling_s: [2.0, 1.0],
        peer_sampling_s: 100.0,
        ours_evaluations: 2_500,
        peer_evaluations: 50_000,
        ours_ess_min: 250.0,
        peer_ess_min: 250.0,
        ours_ess_per_kilo_eval: 100.0,
        peer_ess_per_kilo_eval: 5.0,
        ours_ess_per_s: [125.0, 250.0],
        peer_ess_per_s: 2.5,
        ours_error: 0.02,
        peer_error: 0.03,
        quoted: true,
    }
}

/// Another ensemble peer: `ess` from `evaluations` in `seconds`.
fn other(sampler: EnsemblePeer, ess: f64, evaluations: u64, seconds: f64) -> PeerOutcome {
    PeerOutcome::Ran(Box::new(PeerComparison {
        sampler,
        peer_sampling_s: seconds,
        peer_evaluations: evaluations,
        peer_ess_min: ess,
        peer_ess_per_kilo_eval: crate::bench::peer::ess_per_kilo_eval(ess, evaluations),
        peer_ess_per_s: ess / seconds,
        ..emcee()
    }))
}

/// Two chains, 300 draws each, ESS 500 in 60 s of warmup and 40 s of draws.
fn nuts(quoted: bool) -> NutsOutcome {
    NutsOutcome::Ran(NutsComparison {
        versions: serde_json::json!({"numpyro": "0.22.0"}),
        log_density: LogDensityCheck::new(&[Some(1.0)], &[Some(1.0)]),
        gradient: GradientCheck {
            points: 12,
            max_error: 1e-9,
        },
        plan: NutsPlan::default(),
        us_per_gradient: 2000.0,
        runs: vec![NutsRun {
            chains: 2,
            warmup_s: 60.0,
            warmup_compile_s: 20.0,
            sampling_s: 40.0,
            sampling_compile_s: 30.0,
            gradients: 30_000,
            divergences: 0,
            accept_prob: 0.9,
            step_size: vec![0.1, 0.2],
            ess_min: 500.0,
            ess_per_s: 5.0,
            ess_per_s_draws: 12.5,
            medians: medians(),
            medians_agree: quoted,
            error: 0.04,
        }],
        quoted,
    })
}

#[test]
fn nuts_is_a_row_of_the_samplers_table_with_our_ratio_to_it() {
    let mut s = String::new();
    peer_section(&mut s, 2, 4000, &emcee(), None, &[], Some(&nuts(true)));
    // 250 ESS/s against emcee's 2.5 and NUTS's 5 (warmup + draws); 2×300 draws.
    assert!(s.contains("| emcee stretch + numpy/scipy |"), "{s}");
    assert!(
        s.contains("| 50000 | 100 | 250 | 5.000 | 2.500 | 100 |"),
        "{s}"
    );
    assert!(
        s.contains("| NumPyro NUTS, 2 chain(s) | 2×300 draws after 300 warmup |"),
        "{s}"
    );
    assert!(s.contains("| 500 |  | 5.000 | 50.000 |"), "{s}");
    // The detail table: per draw 30,000 / 600 gradients, 250 / 12.5 on the draws alone.
    assert!(s.contains("| 30000 | 50.000 | 0 |"), "{s}");
    assert!(s.contains("| 12.500 | 20.000 |"), "{s}");
    assert!(s.contains("NUTS peer: log-density at 1 points"), "{s}");
    assert!(s.contains("NUTS 2 chain(s) **agree**"), "{s}");
}

#[test]
fn the_headline_quotes_nuts_only_when_it_passed_and_says_why_it_is_missing() {
    let line = |outcome: Option<&NutsOutcome>| {
        let mut s = String::new();
        nuts_headline(&mut s, outcome, 250.0, 2);
        s
    };
    assert!(line(Some(&nuts(true))).contains("ESS/s **50.000× NUTS's** on 2 threads"));
    assert!(line(Some(&nuts(true))).contains("20.000× against its kept draws alone"));
    assert!(line(Some(&nuts(false))).contains("did **not** pass"));
    let skipped = NutsOutcome::Skipped {
        reason: "pip install jax failed".into(),
    };
    assert!(line(Some(&skipped)).contains("**skipped**: pip install jax failed"));
    assert!(line(None).contains("`--no-nuts`"));
}

/// `slipbayes fit`'s moves: ESS 1,000 from 2,500 evaluations (400 per 1,000) in 2 s.
fn fit_moves() -> MovesRun {
    MovesRun {
        moves: "student-t 0.5, de 0.5".into(),
        threads: 2,
        sampling_s: 2.0,
        evaluations: 2_500,
        ess_min: 1000.0,
        ess_per_s: 500.0,
        ess_per_kilo_eval: 400.0,
        same_start: true,
    }
}

fn others() -> [PeerOutcome; 2] {
    [
        // 40 per 1,000 evaluations, 1 per second.
        other(EnsemblePeer::DeSnooker, 200.0, 5_000, 200.0),
        // 10 per 1,000 evaluations, 4 per second.
        other(EnsemblePeer::Zeus, 400.0, 40_000, 100.0),
    ]
}

#[test]
fn every_ensemble_peer_is_a_row_with_its_evaluations_and_our_ratios() {
    let mut s = String::new();
    peer_section(
        &mut s,
        2,
        4000,
        &emcee(),
        Some(&fit_moves()),
        &others(),
        None,
    );
    let rows = [
        "| emcee DE + snooker + numpy/scipy |",
        "| 5000 | 200 | 200 | 40.000 | 1.000 | 250 |",
        "| zeus + numpy/scipy |",
        "| 40000 | 100 | 400 | 10.000 | 4.000 | 62.500 |",
        // Our stretch move: 2,500 evaluations, 100 per 1,000.
        "| 2500 | 1.000 | 250 | 100 | 250 | 1.000 |",
        "| slipbayes, `fit`'s default moves (student-t 0.5, de 0.5), 2 threads |",
        "| 2500 | 2.000 | 1000 | 400 | 500 | 0.500 |",
    ];
    for row in rows {
        assert!(s.contains(row), "{row} in {s}");
    }
    assert!(s.contains("The same script with `--sampler zeus`"), "{s}");
    assert!(s.contains("3. zeus peer: log-density"), "{s}");
    assert!(
        s.contains("emcee DE + snooker **agree**, zeus **agree**"),
        "{s}"
    );
    assert!(
        s.contains(
            "| coordinate | our median | emcee median | |Δ| / MCSE | emcee DE + snooker median |"
        ),
        "{s}"
    );
    // The best by evaluations is DE + snooker (40), by time zeus (4 per second).
    assert!(
        s.contains(
            "default moves (student-t 0.5, de 0.5): ESS per 1,000 log-density evaluations \
             400 against the best Python ensemble sampler's (emcee DE + snooker 40.000): \
             **10.000×**; ESS/s on 2 threads **125×** the fastest's (zeus). Target ≥ 10× \
             the best Python ensemble sampler's: **met**."
        ),
        "{s}"
    );
    assert!(
        s.contains(
            "- slipbayes with the stretch move: ESS per 1,000 log-density evaluations 100 \
             against the best Python ensemble sampler's (emcee DE + snooker 40.000): \
             **2.500×**; ESS/s on 2 threads **62.500×** the fastest's (zeus).\n"
        ),
        "{s}"
    );
}

#[test]
fn the_headline_compares_with_the_best_peer_that_passed_and_names_the_skipped() {
    let line = |fit: Option<&MovesRun>, others: &[PeerOutcome]| {
        let mut s = String::new();
        best_peer_headline(&mut s, &emcee(), fit, others, 2);
        s
    };
    // Stretch alone, ours and the peer's: 100 against 5 per 1,000 evaluations; the target
    // is then judged on our stretch move.
    let alone = line(None, &[]);
    assert!(
        alone.contains(
            "(emcee stretch 5.000): **20.000×**; ESS/s on 2 threads **100×** the fastest's \
             (emcee stretch). Target ≥ 10× the best Python ensemble sampler's: **met**."
        ),
        "{alone}"
    );

    let skipped = PeerOutcome::Skipped {
        sampler: EnsemblePeer::Zeus,
        reason: "pip install zeus-mcmc failed".into(),
    };
    let mut failed = other(EnsemblePeer::DeSnooker, 1e4, 1_000, 1.0);
    if let PeerOutcome::Ran(c) = &mut failed {
        c.quoted = false;
    }
    let s = line(Some(&fit_moves()), &[failed, skipped]);
    // The DE peer's figures would win, but it did not pass the checks.
    assert!(s.contains("(emcee stretch 5.000): **80.000×**"), "{s}");
    assert!(
        s.contains("The emcee DE + snooker peer did **not** pass"),
        "{s}"
    );
    assert!(
        s.contains("The zeus peer was **skipped**: pip install zeus-mcmc failed"),
        "{s}"
    );

    // 40 per 1,000 evaluations: our stretch move is 2.5×, a factor 4 short of the target,
    // which is judged on the fit's moves alone when they ran.
    let s = line(None, &[others()[0].clone()]);
    assert!(s.contains("(emcee DE + snooker 40.000): **2.500×**"), "{s}");
    assert!(s.contains("**missed** (a factor 4.000 short)"), "{s}");
    let s = line(Some(&fit_moves()), &[others()[0].clone()]);
    assert_eq!(s.matches("Target").count(), 1, "{s}");
    assert!(s.contains("**10.000×**") && s.contains("**met**"), "{s}");
}
