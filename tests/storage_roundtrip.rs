//! Property: whatever the sampler hands the sink comes back from disk bit for bit.
#![cfg(feature = "parquet")]

use proptest::prelude::*;
use slipbayes::storage::{read_chains, ChainSink, ParquetSink, SinkOptions, StepView};

/// The chain store of a run directory, laid out as a fit's run directory lays it out.
fn files(dir: &std::path::Path) -> slipbayes::storage::ChainFiles {
    slipbayes::fit::RunDir::new(dir).chain_files()
}

/// Finite doubles with the awkward ones over-represented: signed zeros, subnormals, the
/// extremes of the range and values near ±1e300.
fn awkward_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => any::<f64>().prop_filter("NaN-free", |x| !x.is_nan()),
        1 => (1u64..(1u64 << 52)).prop_map(f64::from_bits), // positive subnormals
        1 => (1u64..(1u64 << 52)).prop_map(|b| -f64::from_bits(b)), // negative subnormals
        1 => prop::sample::select(vec![
            0.0,
            -0.0,
            1e300,
            -1e300,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ]),
        1 => (-1.0f64..1.0).prop_map(|x| x * 1e300),
    ]
}

#[derive(Debug, Clone)]
struct Run {
    ndim: usize,
    nderived: usize,
    ensembles: usize,
    walkers: usize,
    steps: usize,
    row_group_rows: usize,
    checkpoint_every: usize,
    /// Every value of every row, in recording order: params, log-density, derived.
    values: Vec<f64>,
}

fn runs() -> impl Strategy<Value = Run> {
    (
        1usize..4,
        0usize..3,
        1usize..4,
        1usize..6,
        1usize..8,
        1usize..12,
        1usize..5,
    )
        .prop_flat_map(|(ndim, nderived, ensembles, walkers, steps, rg, every)| {
            let n = steps * ensembles * walkers * (ndim + 1 + nderived);
            prop::collection::vec(awkward_f64(), n).prop_map(move |values| Run {
                ndim,
                nderived,
                ensembles,
                walkers,
                steps,
                row_group_rows: rg,
                checkpoint_every: every,
                values,
            })
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn random_steps_round_trip_bit_exactly(run in runs()) {
        let tmp = tempfile::tempdir().expect("tmp");
        let params: Vec<String> = (0..run.ndim).map(|i| format!("p{i}")).collect();
        let derived: Vec<String> = (0..run.nderived).map(|i| format!("d{i}")).collect();
        let opts = SinkOptions { row_group_rows: run.row_group_rows, overwrite: false };
        let mut sink = ParquetSink::create(&files(tmp.path()), &params, &derived, opts).expect("create");
        let width = run.ndim + 1 + run.nderived;
        let mut rows = run.values.chunks_exact(width);
        for step in 0..run.steps {
            for e in 0..run.ensembles {
                let (mut pos, mut lp, mut der) = (Vec::new(), Vec::new(), Vec::new());
                for row in rows.by_ref().take(run.walkers) {
                    pos.extend_from_slice(&row[..run.ndim]);
                    lp.push(row[run.ndim]);
                    der.extend_from_slice(&row[run.ndim + 1..]);
                }
                sink.record(&StepView {
                    ensemble: e,
                    step: step as u64,
                    ndim: run.ndim,
                    positions: &pos,
                    log_density: &lp,
                    derived: &der,
                }).expect("record");
            }
            if (step + 1) % run.checkpoint_every == 0 {
                sink.checkpoint(&step).expect("checkpoint");
            }
        }
        sink.finish().expect("finish");

        let chains = read_chains(&files(tmp.path()).chains).expect("read");
        prop_assert_eq!(&chains.param_names, &params);
        prop_assert_eq!(&chains.derived_names, &derived);
        prop_assert_eq!(chains.len(), run.steps * run.ensembles * run.walkers);
        for (i, row) in run.values.chunks_exact(width).enumerate() {
            let walker = i % run.walkers;
            let ensemble = (i / run.walkers) % run.ensembles;
            let step = i / (run.walkers * run.ensembles);
            prop_assert_eq!(chains.walker[i] as usize, walker);
            prop_assert_eq!(chains.ensemble[i] as usize, ensemble);
            prop_assert_eq!(chains.step[i] as usize, step);
            for (c, &x) in row.iter().enumerate() {
                prop_assert_eq!(chains.columns[c][i].to_bits(), x.to_bits(), "row {} column {}", i, c);
            }
        }
    }
}
