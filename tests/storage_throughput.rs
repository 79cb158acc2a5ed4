//! Write and read throughput of the chain store (measurement, not a check; run on demand):
//! `cargo test --release --test storage_throughput -- --ignored --nocapture`
#![cfg(feature = "parquet")]

use std::time::Instant;

use slipbayes::storage::{read_chains, ChainSink, ParquetSink, SinkOptions, StepView};

/// The chain store of a run directory, laid out as a fit's run directory lays it out.
fn files(dir: &std::path::Path) -> slipbayes::storage::ChainFiles {
    slipbayes::fit::RunDir::new(dir).chain_files()
}

#[test]
#[ignore = "measurement; run on demand with --ignored --nocapture"]
fn write_and_read_a_million_rows_of_eight_value_columns() {
    const ENSEMBLES: usize = 4;
    const WALKERS: usize = 32;
    const STEPS: u64 = 7_813; // 7 813 × 128 ≈ 1e6 rows
    const CHECKPOINT_EVERY: u64 = 1_000;
    let params: Vec<String> = (0..5).map(|i| format!("p{i}")).collect();
    let derived: Vec<String> = vec!["d0".into(), "d1".into()];
    let tmp = tempfile::tempdir().expect("tmp");

    // A cheap random walk: values as incompressible as real draws.
    let mut x = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut positions = vec![0.0; WALKERS * params.len()];
    let mut log_density = vec![0.0; WALKERS];
    let mut derived_values = vec![0.0; WALKERS * derived.len()];

    let start = Instant::now();
    let mut sink = ParquetSink::create(
        &files(tmp.path()),
        &params,
        &derived,
        SinkOptions::default(),
    )
    .expect("create");
    for step in 0..STEPS {
        for e in 0..ENSEMBLES {
            positions.iter_mut().for_each(|v| *v += next());
            log_density
                .iter_mut()
                .for_each(|v| *v = -next().abs() * 100.0);
            derived_values.iter_mut().for_each(|v| *v = next());
            sink.record(&StepView {
                ensemble: e,
                step,
                ndim: params.len(),
                positions: &positions,
                log_density: &log_density,
                derived: &derived_values,
            })
            .expect("record");
        }
        if (step + 1) % CHECKPOINT_EVERY == 0 {
            sink.checkpoint(&step).expect("checkpoint");
        }
    }
    sink.checkpoint(&STEPS).expect("checkpoint");
    sink.finish().expect("finish");
    let write = start.elapsed();

    let bytes: u64 = std::fs::read_dir(tmp.path().join("chains"))
        .expect("list")
        .map(|e| e.expect("entry").metadata().expect("metadata").len())
        .sum();
    let start = Instant::now();
    let chains = read_chains(&files(tmp.path()).chains).expect("read");
    let read = start.elapsed();
    let rows = chains.len();
    assert_eq!(rows, STEPS as usize * ENSEMBLES * WALKERS);
    let raw = rows * (8 * 8 + 4 + 4 + 8);
    println!(
        "{rows} rows x (8 f64 + 3 index) columns: {:.1} MB on disk ({:.2} of raw {:.1} MB); \
         write {:.2} s ({:.2} Mrows/s), read {:.2} s ({:.2} Mrows/s)",
        bytes as f64 / 1e6,
        bytes as f64 / raw as f64,
        raw as f64 / 1e6,
        write.as_secs_f64(),
        rows as f64 / write.as_secs_f64() / 1e6,
        read.as_secs_f64(),
        rows as f64 / read.as_secs_f64() / 1e6,
    );
}
