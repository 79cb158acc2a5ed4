//! Draws from the prior predictive distribution (what `slipbayes validate` simulates): the
//! members of a pooled population are drawn from it, each reported column's truth is the
//! value at the drawn parameters, and the data are the model plus noise of the drawn σ.

use std::path::Path;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use slipbayes::data::Series;
use slipbayes::model::data::RunData;
use slipbayes::model::Posterior;
use slipbayes::run_file::RunFile;

/// The pooled SBC model over placeholder data at its simulated design's times.
fn pooled_design() -> Posterior {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/sbc_pooled.toml");
    let spec = RunFile::load(&path).unwrap();
    let data = spec
        .model
        .file
        .runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let (duration, interval) = if r.name.ends_with("first") {
                (20_000.0, 100.0)
            } else {
                (2_000.0, 40.0)
            };
            let time_s = slipbayes::simulate::sample_times(duration, interval).unwrap();
            let series = Series {
                force_n: vec![0.0; time_s.len()],
                time_s,
                normal_force_n: None,
            };
            RunData::for_series(&spec.model, i, series).unwrap()
        })
        .collect();
    Posterior::from_data(&spec.model, spec.blocking(), data).unwrap()
}

fn column(posterior: &Posterior, name: &str) -> usize {
    posterior
        .quantities()
        .iter()
        .position(|q| q.column == name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

#[test]
fn pooled_members_come_from_their_population_and_data_from_the_model() {
    let posterior = pooled_design();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (median, log_sd) = (
        column(&posterior, "t0_pop_median[PTFE]"),
        column(&posterior, "t0_pop_log_sd[PTFE]"),
    );
    let members: Vec<usize> = ["t0[c1-first]", "t0[c2-first]", "t0[c3-first]"]
        .iter()
        .map(|c| column(&posterior, c))
        .collect();
    let sigma = column(&posterior, "sigma[c2]");
    let (mut z, mut redraws) = (Vec::new(), 0);
    let mut noise = Vec::new();
    for _ in 0..400 {
        let draw = posterior.draw_prior_predictive(&mut rng, 1000).unwrap();
        redraws += draw.redraws;
        let (mu, s) = (draw.values[median].ln(), draw.values[log_sd]);
        z.extend(members.iter().map(|&m| (draw.values[m].ln() - mu) / s));
        // Run 2 is c2's first slide; its σ is the column's truth.
        let clean = posterior.run_forces(&draw.coords, 2).unwrap();
        assert_eq!(draw.sigma_n[2], draw.values[sigma]);
        noise.extend(
            clean
                .iter()
                .zip(&draw.forces_n[2])
                .map(|(c, f)| (f - c) / draw.sigma_n[2]),
        );
    }
    let moments = |v: &[f64]| {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        (mean, sd)
    };
    // 1,200 standardised members: the mean within 4 standard errors of 0, the sd within 4
    // of 1 (se of a normal sample's sd ≈ 1/√(2n)).
    let (mean, sd) = moments(&z);
    let n = z.len() as f64;
    assert!(mean.abs() < 4.0 / n.sqrt(), "mean of z {mean}");
    assert!((sd - 1.0).abs() < 4.0 / (2.0 * n).sqrt(), "sd of z {sd}");
    // Noise: 80,400 standardised residuals.
    let (mean, sd) = moments(&noise);
    let n = noise.len() as f64;
    assert!(mean.abs() < 4.0 / n.sqrt(), "mean of noise {mean}");
    assert!(
        (sd - 1.0).abs() < 4.0 / (2.0 * n).sqrt(),
        "sd of noise {sd}"
    );
    assert!(redraws < 400, "{redraws} redraws for stick-slip");
}

#[test]
fn the_same_stream_gives_the_same_draw() {
    let posterior = pooled_design();
    let draw = |seed| {
        posterior
            .draw_prior_predictive(&mut ChaCha8Rng::seed_from_u64(seed), 1000)
            .unwrap()
    };
    assert_eq!(draw(3), draw(3));
    assert_ne!(draw(3).coords, draw(4).coords);
}
