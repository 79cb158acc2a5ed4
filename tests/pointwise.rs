//! PSIS-LOO of a model from each observation's log-likelihood (the values themselves are
//! checked in tests/model.rs, `pointwise_log_likelihood_is_each_observations_gaussian_term`).

use std::path::Path;

use slipbayes::model::{PointwiseError, Posterior};
use slipbayes::run_file::RunFile;

/// One PTFE contact: its 1 nm/s first slide and the repeat slide that follows it, σ of each
/// run integrated out (the default log-uniform prior) and reported as a derived column.
fn model(extra: &str) -> String {
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/data");
    format!(
        r#"
[[material]]
name = "PTFE"
[[contact]]
name = "c1"
material = "PTFE"
[[run]]
name = "first"
contact = "c1"
data = "{data}/ptfe-c1-first.csv"
velocity_m_per_s = 1e-9
scene = "first"
[[run]]
name = "repeat"
contact = "c1"
data = "{data}/ptfe-c1-repeat.csv"
velocity_m_per_s = 1e-9
scene = "repeat"
follows = "first"
{extra}
"#
    )
}

fn posterior(extra: &str) -> Posterior {
    let spec = RunFile::parse(&model(extra), Path::new("model.toml")).expect("model");
    spec.posterior().expect("posterior")
}

/// PSIS-LOO over draws near the mode: one result per run, and the model's total is their union.
#[test]
fn loo_of_a_model_is_the_union_of_its_runs() {
    let post = posterior("");
    let start = post.start().to_vec();
    // 60 draws around the start, a few thousandths of a unit apart in the log coordinates.
    let draws: Vec<Vec<f64>> = (0..60)
        .map(|s| {
            start
                .iter()
                .enumerate()
                .map(|(d, v)| v + 2e-3 * (((s * 7 + d * 13) % 11) as f64 / 10.0 - 0.5))
                .collect()
        })
        .collect();
    let loo = post.psis_loo(&draws, 1.0).expect("loo");
    assert_eq!(loo.runs.len(), 2);
    let points: usize = loo.runs.iter().map(|(_, l)| l.pointwise.len()).sum();
    assert_eq!(loo.total.pointwise.len(), points);
    let elpd: f64 = loo.runs.iter().map(|(_, l)| l.elpd).sum();
    assert!((loo.total.elpd - elpd).abs() <= 1e-9 * elpd.abs());
    assert!(loo.total.elpd.is_finite() && loo.total.se > 0.0);
    assert_eq!(loo.runs[0].0, "first");
    assert_eq!(loo.runs[1].0, "repeat");
}

/// A run evaluated on sufficient statistics has no likelihood per point: refused, naming it.
#[test]
fn a_reduced_run_is_refused_with_what_to_do() {
    let post = posterior("[likelihood]\nexact_up_to = 1000\n");
    let x = post.start().to_vec();
    let error = post.pointwise_log_likelihood(&x).unwrap_err();
    assert!(
        matches!(&error, PointwiseError::Reduced { run, points: 3001 } if run == "first"),
        "{error}"
    );
    assert!(error.to_string().contains("exact_up_to"), "{error}");
    assert!(post.psis_loo(&[x], 1.0).is_err());
}

/// One block of observations left out of a run.
fn block(points: std::ops::Range<usize>) -> Vec<std::ops::Range<usize>> {
    std::iter::once(points).collect()
}

/// A fold that leaves nothing out scores every observation exactly as the full posterior does
/// (the same σ and end force, bit for bit); one that leaves out the end of the first slide
/// keeps the repeat slide's model (the first slide still stops at the end of its record), and
/// another model's posterior is refused.
#[test]
fn a_fold_scores_with_its_own_noise_and_the_full_data_model() {
    let post = posterior("");
    let x = post.start().to_vec();
    let full = post.pointwise_log_likelihood(&x).expect("pointwise");
    let same = post.without(&[Vec::new(), Vec::new()]).expect("fold");
    assert_eq!(post.log_likelihood_under(&same, &x).expect("under"), full);

    let first_points = post.run_points()[0].1;
    let end = post
        .without(&[block(first_points - 50..first_points), Vec::new()])
        .expect("fold without the end of the first slide");
    let under = post.log_likelihood_under(&end, &x).expect("under");
    assert_eq!(under[0].len(), full[0].len());
    // σ of each run is the fold's own conditional draw, but the model, and so every residual,
    // is the full data's: within a run the values differ from the full posterior's by one
    // scale, −r²/(2σ²), and one shift. The repeat slide's residuals being the same says its
    // first slide still stops where its record ends.
    for (u, f) in under.iter().zip(&full) {
        let ratio = |i: usize| (u[i] - u[0]) / (f[i] - f[0]);
        let scale = ratio(1);
        for i in 2..u.len() {
            assert!(
                (ratio(i) - scale).abs() <= 1e-6 * scale,
                "point {i}: {} against {scale}",
                ratio(i)
            );
        }
    }
    let absolute = format!("aging = \"absolute\"\n{}", model(""));
    let spec = RunFile::parse(&absolute, Path::new("model.toml")).expect("model");
    let other = spec.posterior().expect("posterior");
    let refused = post
        .log_likelihood_under(&other, &x)
        .unwrap_err()
        .to_string();
    assert!(refused.contains("another model"), "{refused}");
    let too_short = post.without(&[block(0..first_points - 3), Vec::new()]);
    assert!(too_short.is_err());
}
