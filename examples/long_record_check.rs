//! A fitted run directory's long records checked against the exact likelihood at its own
//! posterior draws: the model as fitted (long runs on sufficient statistics) and the same
//! model with every point evaluated (`[likelihood] tolerance = 0`) are evaluated at up to
//! DRAWS kept draws of the chains; prints the largest difference of the log-densities, the
//! bound each reduced run states, and what one evaluation of each costs.
//!
//! `cargo run --release --example long_record_check -- RUN_DIR [DRAWS]` (default 200 draws).
//! Used by `benches/long_records.sh`.

use std::path::PathBuf;
use std::time::Instant;

use slipbayes::density::LogDensity;
use slipbayes::fit::{kept_rows, RunDir};
use slipbayes::model::{ModelSpec, Posterior};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = RunDir::new(PathBuf::from(args.next().ok_or("usage: RUN_DIR [DRAWS]")?));
    let draws: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(200);
    let spec = dir.read_model()?;
    let summary = dir.read_summary()?;
    let chains = dir.chain_reader()?;
    let reduced = spec.posterior()?;
    let mut file = spec.model.file.clone();
    file.likelihood.tolerance = 0.0;
    for run in &mut file.runs {
        run.likelihood_tolerance = None;
    }
    let exact = Posterior::new(
        &ModelSpec::validate(file, spec.model.base_dir.clone(), spec.model.source.clone())?,
        spec.blocking(),
    )?;
    for d in reduced.data_provenance() {
        match d.binning {
            Some(b) => println!(
                "run `{}`: {} points in {} bins of degree {} and {} exact points, {} model \
                 times per evaluation; stated bound {:.3e} (tolerance {:.3e}, at noise {:.3e} N)",
                d.run,
                d.points_used,
                b.bins,
                b.degree,
                b.exact_points,
                b.evaluations,
                b.bound,
                b.tolerance,
                b.noise_n
            ),
            None => println!("run `{}`: {} points, exact", d.run, d.points_used),
        }
    }
    let rows = kept_rows(&chains, &summary.sampler, draws);
    let names = reduced.param_names();
    let mut points = vec![Vec::with_capacity(names.len()); rows.len()];
    for name in &names {
        for (p, v) in points.iter_mut().zip(chains.rows_of(name, &rows)?) {
            p.push(v);
        }
    }
    let (mut worst, mut reduced_s, mut exact_s) = (0.0_f64, 0.0, 0.0);
    for x in &points {
        let started = Instant::now();
        let r = reduced.log_density(x, &mut [])?;
        reduced_s += started.elapsed().as_secs_f64();
        let started = Instant::now();
        let e = exact.log_density(x, &mut [])?;
        exact_s += started.elapsed().as_secs_f64();
        worst = worst.max((r - e).abs());
    }
    let n = points.len() as f64;
    println!(
        "{} posterior draws: largest |log-density on sufficient statistics − exact| = {worst:.3e}; \
         one evaluation {:.1} µs on sufficient statistics, {:.2} ms exact",
        points.len(),
        1e6 * reduced_s / n,
        1e3 * exact_s / n
    );
    Ok(())
}
