//! The engine against ArviZ's functions, in memory and through working files.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::diagnostics::arviz::{eti_sorted, hdi_sorted, mean, median_of_sorted, sorted, var};
use crate::diagnostics::{
    ess_bulk, ess_mean, ess_tail, mcse_mean, mcse_sd, pooled_integrated_time, rhat,
    DEFAULT_WINDOW_FACTOR,
};

/// Draws walker-major: a random walk that repeats its value (a rejected move) about half
/// the time, rounded to a few values so that ties fall in different runs, with -0.0 and
/// 0.0 among them.
fn draws(ensembles: usize, walkers: usize, steps: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut data = Vec::with_capacity(ensembles * walkers * steps);
    for e in 0..ensembles {
        for _ in 0..walkers {
            let mut x: f64 = 0.3 * e as f64;
            for _ in 0..steps {
                if rng.random::<f64>() < 0.5 {
                    x += rng.random::<f64>() - 0.5;
                }
                let v = (x * 4.0).round() / 4.0;
                data.push(if v == 0.0 && rng.random::<bool>() {
                    -0.0
                } else {
                    v
                });
            }
        }
    }
    data
}

/// Writes walker-major `data` in the chains' order (step, ensemble, walker), in pieces
/// of uneven length.
fn write<'w>(
    ws: &'w Workspace,
    data: &[f64],
    shape: (usize, usize, usize),
) -> Result<WalkerDraws<'w>, DiagnosticsError> {
    let (e, w, t) = shape;
    let step_major: Vec<f64> = (0..t)
        .flat_map(|s| (0..e * w).map(move |c| data[c * t + s]))
        .collect();
    let mut writer = DrawsWriter::new(ws, e, w, t)?;
    let mut rest = &step_major[..];
    let mut k = 0;
    while !rest.is_empty() {
        let take = (1 + (k * 7) % 23).min(rest.len());
        writer.push(&rest[..take])?;
        rest = &rest[take..];
        k += 1;
    }
    writer.finish()
}

/// The summary of walker-major `data` as ArviZ's functions give it, quantity by quantity:
/// statistics of every draw pooled, ESS and MCSE with every walker as a chain, and R̂ with
/// each ensemble as one chain whose split halves are its walkers' halves laid end to end
/// (ArviZ splits a chain in its first and last halves: here, every walker's first half, then
/// every walker's last half). The oracle the engine is held to.
fn arviz_summary(data: &[f64], shape: (usize, usize, usize), ci: f64, hdi: f64) -> Summary {
    let (e, w, t) = shape;
    let walkers: Vec<&[f64]> = data.chunks(t).collect();
    let half = t / 2;
    let ensembles: Vec<Vec<f64>> = (0..e)
        .map(|k| {
            let mine = &walkers[k * w..(k + 1) * w];
            let firsts = mine.iter().flat_map(|s| s[..half].iter().copied());
            let lasts = mine.iter().flat_map(|s| s[t - half..].iter().copied());
            firsts.chain(lasts).collect()
        })
        .collect();
    let ensembles: Vec<&[f64]> = ensembles.iter().map(Vec::as_slice).collect();
    let s = sorted(data);
    let (ci_low, ci_high) = eti_sorted(&s, ci);
    let (hdi_low, hdi_high) = hdi_sorted(&s, hdi).expect("enough draws for the HDI");
    let tau = pooled_integrated_time(&walkers, w, DEFAULT_WINDOW_FACTOR).ok();
    Summary {
        mean: mean(data),
        sd: var(data, 1).sqrt(),
        median: median_of_sorted(&s),
        ci_low,
        ci_high,
        ci_prob: ci,
        hdi_low,
        hdi_high,
        hdi_prob: hdi,
        ess_bulk: ess_bulk(&walkers).expect("valid"),
        ess_tail: ess_tail(&walkers).expect("valid"),
        r_hat: (e >= 2)
            .then(|| rhat(&ensembles).expect("valid"))
            .filter(|r| !r.is_nan()),
        mcse_mean: mcse_mean(&walkers).expect("valid"),
        mcse_sd: mcse_sd(&walkers).expect("valid"),
        ess_mean: ess_mean(&walkers).expect("valid"),
        tau: tau.map(|a| a.tau),
        tau_reliable: tau.map(|a| a.reliable),
    }
}

fn bits(s: &Summary) -> Vec<u64> {
    let opt = |v: Option<f64>| v.map_or(u64::MAX - 1, f64::to_bits);
    vec![
        s.mean.to_bits(),
        s.sd.to_bits(),
        s.median.to_bits(),
        s.ci_low.to_bits(),
        s.ci_high.to_bits(),
        s.hdi_low.to_bits(),
        s.hdi_high.to_bits(),
        s.ess_bulk.to_bits(),
        s.ess_tail.to_bits(),
        opt(s.r_hat),
        s.mcse_mean.to_bits(),
        s.mcse_sd.to_bits(),
        s.ess_mean.to_bits(),
        opt(s.tau),
        s.tau_reliable.map_or(2, u64::from),
    ]
}

/// The engine gives ArviZ's numbers to the bit: in memory ([`summarize`] of
/// [`EnsembleDraws`], and a writer into the in-memory workspace), and through working files
/// with runs of a few draws (so that every merge reads many runs, ties span runs, and the
/// scores go through many partitions).
#[test]
fn the_summary_is_arvizs_to_the_bit_in_memory_and_out_of_core() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let shapes = [(2, 3, 40), (3, 2, 41), (1, 4, 30), (4, 5, 17), (2, 2, 4)];
    for (k, &(e, w, t)) in shapes.iter().enumerate() {
        let data = draws(e, w, t, k as u64);
        let reference = arviz_summary(&data, (e, w, t), 0.9, 0.8);
        let in_memory = EnsembleDraws::new(data.clone(), e, w, t).expect("valid draws");
        let s = summarize(&in_memory, 0.9, 0.8).expect("summary");
        assert_eq!(
            bits(&s),
            bits(&reference),
            "{e}×{w}×{t}: {s:?} against {reference:?}"
        );
        if e >= 2 {
            assert_eq!(
                ensemble_rhat(&in_memory).ok().map(f64::to_bits),
                Some(reference.r_hat.expect("draws that differ").to_bits())
            );
        }
        for run_draws in [1, 3, 7, 50, 1 << 16] {
            let ws = Workspace::new(dir.path(), Limits { run_draws });
            let x = write(&ws, &data, (e, w, t)).expect("written");
            let s = summarize_draws(&x, 0.9, 0.8).expect("external summary");
            assert_eq!(
                bits(&s),
                bits(&reference),
                "{e}×{w}×{t}, runs of {run_draws}: {s:?} against {reference:?}"
            );
            if run_draws < e * w * t {
                assert!(ws.files_created() > 0, "working files were used");
                assert!(ws.most_runs_merged() > 1, "merges read several runs");
            } else {
                assert_eq!(ws.files_created(), 0, "a short quantity stays in memory");
            }
        }
        let ws = Workspace::in_memory();
        let s = summarize_draws(&write(&ws, &data, (e, w, t)).unwrap(), 0.9, 0.8).unwrap();
        assert_eq!(bits(&s), bits(&reference));
    }
    // No working file is left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn constant_draws_and_mean_and_mcse() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let ws = Workspace::new(dir.path(), Limits { run_draws: 5 });
    let (e, w, t) = (2, 3, 11);
    let constant = vec![2.5; e * w * t];
    let reference = arviz_summary(&constant, (e, w, t), 0.95, 0.95);
    let s = summarize_draws(&write(&ws, &constant, (e, w, t)).unwrap(), 0.95, 0.95).unwrap();
    assert_eq!(bits(&s), bits(&reference));
    assert_eq!(s.r_hat, None);

    // Indicators, as a comparison's P(A > B) takes them.
    let data: Vec<f64> = draws(e, w, t, 9)
        .into_iter()
        .map(|v| if v > 0.1 { 1.0 } else { 0.0 })
        .collect();
    let x = write(&ws, &data, (e, w, t)).unwrap();
    let chains: Vec<&[f64]> = data.chunks(t).collect();
    let (mean, mcse) = x.mean_and_mcse().unwrap();
    assert_eq!(
        mean.to_bits(),
        (data.iter().sum::<f64>() / data.len() as f64).to_bits()
    );
    assert_eq!(
        mcse.to_bits(),
        crate::diagnostics::mcse_mean(&chains).unwrap().to_bits()
    );
}

#[test]
fn writer_checks_what_it_is_given() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let ws = Workspace::new(dir.path(), Limits { run_draws: 4 });
    let (e, w, t) = (2, 2, 5);
    let mut data = draws(e, w, t, 3);
    data[2 * t + 3] = f64::NAN;
    data[3 * t + 1] = f64::INFINITY;
    let expected = EnsembleDraws::new(data.clone(), e, w, t).unwrap_err();
    // NaN is not equal to itself: compare the words.
    assert_eq!(
        format!("{:?}", write(&ws, &data, (e, w, t)).unwrap_err()),
        format!("{expected:?}")
    );
    let mut short = DrawsWriter::new(&ws, e, w, t).unwrap();
    short.push(&[1.0; 7]).unwrap();
    assert!(short.finish().is_err());
    let mut long = DrawsWriter::new(&ws, e, w, t).unwrap();
    assert!(long.push(&[1.0; 21]).is_err());
    assert!(DrawsWriter::new(&ws, e, w, 3).is_err());
    let s = summarize_draws(
        &write(&ws, &draws(e, w, t, 4), (e, w, t)).unwrap(),
        1.0,
        0.5,
    );
    assert!(s.is_err());
}
