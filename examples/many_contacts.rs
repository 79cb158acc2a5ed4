//! A campaign of many contacts, from loading to sampling: one material, N contacts of a first
//! and a repeat slide each (as `data/make_campaign.py` makes them: a 201-point first slide and
//! a 51-point repeat slide, contact-to-contact spread in F_d, k and t0), simulated in memory.
//! Each phase is timed on its own:
//!
//! - building the posterior (`Posterior::from_data`),
//! - the rough start (`Posterior::start`: each first slide fitted alone),
//! - the sampler's start (`EnsembleSampler::new` under hierarchical updates: every walker
//!   evaluated in full, around the rough start),
//! - sweeps (one step: every block of every walker updated once), their mean, and that mean
//!   per contact.
//!
//! - the fit's mode search with its Laplace covariance and the walkers drawn from it
//!   (`initial_around_optimum` from the posterior's search start, as `slipbayes fit` starts;
//!   by the contacts' blocks from 64 coordinates on, at a cost linear in the contacts);
//!   `--mode-up-to M` times it only for campaigns of at most M contacts, for a build whose
//!   search is the dense one (its Hessian's evaluations grow with the square of the
//!   dimension: hours at a thousand contacts).
//!
//! `cargo run --release --example many_contacts [-- N ...] [--mode-up-to M] [--sweeps K]`
//! (default N = 10, 50, 120, 500 and 2,000: the last is 4,000 runs; K = 3). The last column is
//! the process's CPU time over the sweeps per sweep per contact: run on one thread
//! (`RAYON_NUM_THREADS=1`), it is the sweeps' own work, which the machine's load moves far less
//! than the wall time.

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
use slipbayes::optimize::initial_around_optimum;
use slipbayes::run_file::RunFile;
use slipbayes::sampler::{
    CarryFit, EnsembleSampler, NullSink, SamplerConfig, Silent, Steps, Updates,
};
use slipbayes::simulate::{simulate, SimulationSpec};

/// Sweeps timed per campaign, unless `--sweeps K` says otherwise.
const SWEEPS: u64 = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut sizes = Vec::new();
    let (mut mode_up_to, mut sweeps) = (usize::MAX, SWEEPS);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--mode-up-to" {
            mode_up_to = args.next().ok_or("--mode-up-to needs a number")?.parse()?;
        } else if a == "--sweeps" {
            sweeps = args.next().ok_or("--sweeps needs a number")?.parse()?;
        } else {
            sizes.push(a.parse::<usize>()?);
        }
    }
    if sizes.is_empty() {
        sizes = vec![10, 50, 120, 500, 2000];
    }
    println!(
        "| contacts | runs | dimensions | posterior built (s) | rough start (s) | mode search (s) \
         | sampler's start (s) | per sweep (s) | per sweep per contact (ms) \
         | CPU per sweep per contact (ms) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
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
        let mode = if contacts <= mode_up_to {
            let started = Instant::now();
            let search = initial_around_optimum(
                Target::blocked(&posterior),
                posterior.search_start(),
                walkers,
                4,
                &mut ChaCha8Rng::seed_from_u64(2),
            );
            let elapsed = started.elapsed().as_secs_f64();
            match search {
                Ok(_) => format!("{elapsed:.2}"),
                Err(e) => format!("failed after {elapsed:.2}: {e}"),
            }
        } else {
            "not run".to_string()
        };
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
        let (started, cpu) = (Instant::now(), cpu_seconds());
        sampler.run(Steps::Fixed(sweeps), &mut NullSink, &mut Silent)?;
        let per_sweep = started.elapsed().as_secs_f64() / sweeps.max(1) as f64;
        let cpu_per_sweep = match (cpu, cpu_seconds()) {
            (Some(a), Some(b)) => {
                let sweeps_contacts = sweeps.max(1) as f64 * contacts as f64;
                format!("{:.3}", 1e3 * (b - a) / sweeps_contacts)
            }
            _ => "unknown".to_string(),
        };
        println!(
            "| {contacts} | {} | {} | {built:.2} | {rough:.2} | {mode} | {sampler_start:.2} \
             | {per_sweep:.3} | {:.3} | {cpu_per_sweep} |",
            2 * contacts,
            posterior.dim(),
            1e3 * per_sweep / contacts as f64
        );
    }
    Ok(())
}

/// CPU time of this process so far (user and system, all threads), where `/proc` says it.
/// On one thread (`RAYON_NUM_THREADS=1`) the difference over the sweeps is their own work,
/// which other processes on the machine lengthen far less than the wall time.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The fields after the command's name (in parentheses, which may hold spaces).
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i)?.parse::<f64>().ok();
    // utime and stime, fields 14 and 15 of proc(5), in clock ticks of 1/100 s on Linux.
    Some((ticks(11)? + ticks(12)?) / 100.0)
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
