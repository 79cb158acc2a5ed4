//! Simulation-based calibration in CI: 30 replications of the whole pipeline (prior draw,
//! simulation, fit, ranks) must show no gross miscalibration; replications are reproducible
//! from (seed, index) on any thread count and a run continues where it stopped.
#![cfg(feature = "parquet")]

use std::collections::BTreeMap;
use std::path::PathBuf;

use slipbayes_cli::validate::{
    run_sbc, summarise, table, GrossLimits, Replication, SbcSettings, ValidateError,
};

fn settings(replications: usize) -> SbcSettings {
    SbcSettings {
        model: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../models/sbc.toml"),
        replications,
        // Not the published run's seed: CI checks other replications than the report shows.
        seed: 2026,
        ..SbcSettings::default()
    }
}

fn without_timing(mut r: Replication) -> Replication {
    r.wall_s = 0.0;
    r
}

#[test]
fn thirty_replications_are_not_grossly_miscalibrated() {
    let dir = tempfile::tempdir().unwrap();
    let s = settings(30);
    let reps = run_sbc(&s, dir.path(), false, &|_| {}).unwrap();
    assert_eq!(reps.len(), 30);
    let report = summarise(&s, &reps);
    let problems = report.gross_problems(&GrossLimits::default());
    assert!(problems.is_empty(), "{problems:#?}\n{report:#?}");
    // Every parameter of the one-contact model and F_peak were ranked.
    let columns: Vec<&str> = report
        .quantities
        .iter()
        .map(|q| q.column.as_str())
        .collect();
    for c in [
        "alpha[PTFE]",
        "a_over_F_d[PTFE]",
        "F_d[c]",
        "t0[first]",
        "k[c]",
        "F_peak[first]",
    ] {
        assert!(columns.contains(&c), "{c} not ranked: {columns:?}");
    }

    // A replication re-run on one thread, after its result was removed, is bit-identical;
    // the others are read back, not re-run.
    let index = 7;
    let path = dir.path().join(table::REPLICATIONS_TABLE);
    let mut t = table::read(&path).unwrap().unwrap();
    assert_eq!(t.rows.len(), 30);
    t.rows.remove(&index);
    table::write(&path, &t.quantities, &t.rows).unwrap();
    let rerun = std::sync::Mutex::new(Vec::new());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let again = pool
        .install(|| {
            run_sbc(&s, dir.path(), false, &|r| {
                rerun.lock().unwrap().push(r.index);
            })
        })
        .unwrap();
    assert_eq!(rerun.into_inner().unwrap(), vec![index]);
    assert_eq!(
        without_timing(again[index].clone()),
        without_timing(reps[index].clone())
    );
    // The table holds every replication once, in index order, as the first run left it.
    let rows = table::read(&path).unwrap().unwrap().rows;
    assert_eq!(
        rows.into_values().map(without_timing).collect::<Vec<_>>(),
        reps.iter().cloned().map(without_timing).collect::<Vec<_>>()
    );
    let text = std::fs::read_to_string(&path).unwrap();
    let indices: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    let expected: Vec<String> = (0..30).map(|i| i.to_string()).collect();
    assert_eq!(indices, expected);

    // Other settings in the same directory are refused, naming what changed.
    let other = SbcSettings {
        steps: 500,
        ..s.clone()
    };
    let err = run_sbc(&other, dir.path(), false, &|_| {}).unwrap_err();
    assert!(
        matches!(&err, ValidateError::SettingsMismatch { problem, .. } if problem.contains("steps")),
        "{err}"
    );
}

/// The gate fails on an overconfident posterior: truths far outside the draws.
#[test]
fn the_gate_catches_overconfident_posteriors() {
    let s = settings(30);
    let reps: Vec<Replication> = (0..30)
        .map(|i| {
            // Half the truths sit below every draw, half inside.
            let (rank, q) = if i % 2 == 0 { (0, 0.0) } else { (50, 0.5) };
            Replication {
                index: i,
                truth: BTreeMap::from([("alpha[m]".to_string(), 1e6)]),
                redraws: 0,
                fit_seed: 0,
                ranks: BTreeMap::from([("alpha[m]".to_string(), rank)]),
                quantiles: BTreeMap::from([("alpha[m]".to_string(), q)]),
                converged: true,
                r_hat_max: Some(1.0),
                tau_max: Some(10.0),
                burn_in: 20,
                min_gap_over_tau: Some(10.0),
                wall_s: 1.0,
                failure: None,
            }
        })
        .collect();
    let report = summarise(&s, &reps);
    let q = &report.quantities[0];
    assert!((q.coverage95.rate - 0.5).abs() < 1e-12);
    let problems = report.gross_problems(&GrossLimits::default());
    assert!(
        problems.iter().any(|p| p.contains("95 %"))
            && problems.iter().any(|p| p.contains("not uniform")),
        "{problems:?}"
    );
}

/// A pooled campaign goes through the same pipeline: populations drawn before their members,
/// every population, member and a new contact's peak ranked.
#[test]
fn pooled_models_are_validated_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let s = SbcSettings {
        model: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../models/sbc_pooled.toml"),
        steps: 400,
        ..settings(2)
    };
    let reps = run_sbc(&s, dir.path(), false, &|_| {}).unwrap();
    for r in &reps {
        assert_eq!(r.failure, None, "replication {}", r.index);
        for c in [
            "t0_pop_median[PTFE]",
            "t0_pop_log_sd[PTFE]",
            "F_d_pop_median[PTFE]",
            "F_d_pop_log_sd[PTFE]",
            "t0[c3-first]",
            "F_d[c2]",
            "F_peak_new[PTFE]",
        ] {
            assert!(
                r.truth[c].is_finite() && r.truth[c] > 0.0,
                "{c}: {:?}",
                r.truth
            );
            assert!(r.ranks[c] <= s.rank_draws, "{c}");
        }
    }
}
