//! A campaign of many contacts, from loading to sampling: one material, N contacts of a first
//! and a repeat slide each (as `data/make_campaign.py` makes them: a 201-point first slide and
//! a 51-point repeat slide, contact-to-contact spread in F_d, k and t0), simulated in memory.
//! Each phase is timed on its own:
//!
//! - building the posterior (`Posterior::from_data`),
//! - the rough start (`Posterior::start`: each first slide fitted alone),
//! - the sampler's start (`EnsembleSampler::new` under hierarchical updates: every walker
//!   evaluated in full, around the rough start),
//! - sweeps (one step: every block of every walker updated once), their mean.
//!
//! The optimiser's mode search and Laplace covariance are left out: their cost grows with the
//! square of the dimension.
//!
//! `cargo run --release --example many_contacts [-- N ...]` (default N = 10, 50, 120, 500 and
//! 2,000: the last is 4,000 runs).

use std::fmt::Write as _;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use slipbayes::density::{LogDensity, Target};
use slipbayes::fit::default_walkers;
use slipbayes::law::{LawParams, Scene};
use slipbayes::model::data::RunData;
use slipbayes::model::Posterior;
use slipbayes::run_file::RunFile;
use slipbayes::sampler::{
    CarryFit, EnsembleSampler, NullSink, SamplerConfig, Silent, Steps, Updates,
};
use slipbayes::simulate::{simulate, SimulationSpec};

/// Sweeps timed per campaign.
const SWEEPS: u64 = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut sizes = std::env::args()
        .skip(1)
        .map(|a| a.parse::<usize>())
        .collect::<Result<Vec<_>, _>>()?;
    if sizes.is_empty() {
        sizes = vec![10, 50, 120, 500, 2000];
    }
    println!("| contacts | runs | dimensions | posterior built (s) | rough start (s) | sampler's start (s) | per sweep (s) |");
    println!("|---|---|---|---|---|---|---|");
    let dir = tempfile::tempdir()?;
    for contacts in sizes {
        let (run_file, data) = campaign(dir.path(), contacts)?;
        let started = Instant::now();
        let posterior = Posterior::from_data(&run_file.model, run_file.blocking(), data)?;
        let built = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let start = posterior.start().to_vec();
        let rough = started.elapsed().as_secs_f64();
        let walkers = default_walkers(
            Target::blocked(&posterior),
            Updates::Hierarchical,
            CarryFit::Auto,
        );
        let config = SamplerConfig::new(walkers, 4, 1)?.with_updates(Updates::Hierarchical);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        // Around the rough start, each walker redrawn until the density takes it (a contact
        // near stick-slip refuses some).
        let mut derived = vec![0.0; posterior.derived_names().len()];
        let mut walker = || loop {
            let x: Vec<f64> = start
                .iter()
                .map(|v| v + 1e-3 * rng.sample::<f64, _>(StandardNormal))
                .collect();
            if posterior
                .log_density(&x, &mut derived)
                .is_ok_and(f64::is_finite)
            {
                break x;
            }
        };
        let initial: Vec<Vec<Vec<f64>>> = (0..4)
            .map(|_| (0..walkers).map(|_| walker()).collect())
            .collect();
        let started = Instant::now();
        let mut sampler = EnsembleSampler::new(Target::blocked(&posterior), config, initial)?;
        let sampler_start = started.elapsed().as_secs_f64();
        let started = Instant::now();
        sampler.run(Steps::Fixed(SWEEPS), &mut NullSink, &mut Silent)?;
        let per_sweep = started.elapsed().as_secs_f64() / SWEEPS as f64;
        println!(
            "| {contacts} | {} | {} | {built:.2} | {rough:.2} | {sampler_start:.2} | {per_sweep:.3} |",
            2 * contacts,
            posterior.dim()
        );
    }
    Ok(())
}

/// The model file and simulated data of a campaign of `contacts` contacts, written into
/// `dir` (the model only: the data stay in memory).
fn campaign(
    dir: &std::path::Path,
    contacts: usize,
) -> Result<(RunFile, Vec<RunData>), Box<dyn std::error::Error>> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut model = String::from("[[material]]\nname = \"M\"\n");
    let mut runs = String::new();
    let mut series = Vec::with_capacity(2 * contacts);
    for c in 1..=contacts {
        let mut spread = |sd: f64| (sd * rng.sample::<f64, _>(StandardNormal)).exp();
        let (f_d, k, t0) = (
            10e-3 * spread(0.15),
            1.2e4 * spread(0.2),
            15.0 * spread(0.5),
        );
        let params = LawParams::new(0.92e6, 0.62 * f_d, f_d, t0)?;
        let name = format!("c{c:04}");
        write!(
            model,
            "\n[[contact]]\nname = \"{name}\"\nmaterial = \"M\"\n"
        )?;
        for (scene, duration_s, interval_s, after_first_s) in [
            (Scene::First, 20_000.0, 100.0, None),
            (Scene::Repeat, 2_000.0, 40.0, Some(20_000.0)),
        ] {
            let label = if scene == Scene::First {
                "first"
            } else {
                "repeat"
            };
            write!(
                runs,
                "\n[[run]]\nname = \"{name}-{label}\"\ncontact = \"{name}\"\n\
                 data = \"{name}-{label}.csv\"\nvelocity_m_per_s = 1e-9\nscene = \"{label}\"\n"
            )?;
            series.push(
                simulate(&SimulationSpec {
                    scene,
                    params,
                    stiffness_n_per_m: Some(k),
                    law: Default::default(),
                    rigid: false,
                    velocity_m_per_s: 1e-9,
                    duration_s,
                    interval_s,
                    noise_sd_n: 1e-4,
                    seed: 10 * c as u64 + u64::from(scene == Scene::Repeat),
                    f_end_n: None,
                    after_first_s,
                    normal_force_n: None,
                    normal_noise_sd_n: 0.0,
                })?
                .series,
            );
        }
    }
    let path = dir.join(format!("campaign-{contacts}.toml"));
    std::fs::write(&path, model + &runs)?;
    let run_file = RunFile::load(&path)?;
    let data = series
        .into_iter()
        .enumerate()
        .map(|(i, s)| RunData::for_series(&run_file.model, i, s))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((run_file, data))
}
