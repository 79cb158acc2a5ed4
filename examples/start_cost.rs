//! Cost of a fit's start against the length of the record: the PTFE contact of docs/model.md
//! §7 (a 20,000 s first slide of N points, a 201-point repeat slide), simulated in memory, then
//! the phases before sampling timed one after the other:
//!
//! - building the posterior (`Posterior::from_data`: for a record longer than 10,000 points
//!   this computes the rough start and reduces the record to sufficient statistics),
//! - the rough start (`Posterior::start`: each first slide fitted alone by Nelder–Mead; already
//!   computed for a reduced record),
//! - the mode search and the walkers around it (`initial_around_optimum`: L-BFGS and
//!   Nelder–Mead rounds on the whole posterior, then the Laplace covariance).
//!
//! `cargo run --release --example start_cost [-- N ...]` (default N = 10⁴, 10⁵ and 10⁶).
//! Reported in reports/long-records.md (`bash reports/regenerate.sh long-records`).

use std::path::PathBuf;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use slipbayes::data::ImportOptions;
use slipbayes::density::Target;
use slipbayes::law::{LawParams, Scene};
use slipbayes::model::data::RunData;
use slipbayes::model::{BlockSettings, ModelSpec, OneContact, Posterior};
use slipbayes::optimize::initial_around_optimum;
use slipbayes::simulate::{simulate, SimulationSpec};

const DURATION_S: f64 = 20_000.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut lengths = std::env::args()
        .skip(1)
        .map(|a| a.parse::<usize>())
        .collect::<Result<Vec<_>, _>>()?;
    if lengths.is_empty() {
        lengths = vec![10_000, 100_000, 1_000_000];
    }
    let spec = ModelSpec::one_contact(&OneContact {
        first: PathBuf::from("first.csv"),
        repeat: Some(PathBuf::from("repeat.csv")),
        velocity_m_per_s: 1e-9,
        stiff: false,
        normal_force_n: None,
        window_s: None,
        likelihood_tolerance: None,
        import: ImportOptions::default(),
        forward: Default::default(),
    })?;
    let params = LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8)?;
    let slide = |scene, duration_s, interval_s, seed, after_first_s| SimulationSpec {
        scene,
        params,
        stiffness_n_per_m: Some(1.2e4),
        law: Default::default(),
        rigid: false,
        velocity_m_per_s: 1e-9,
        duration_s,
        interval_s,
        noise_sd_n: 1e-4,
        seed,
        f_end_n: None,
        after_first_s,
        normal_force_n: None,
        normal_noise_sd_n: 0.0,
    };
    let repeat = simulate(&slide(Scene::Repeat, 2_000.0, 10.0, 2, Some(DURATION_S)))?.series;
    println!("| points of the first slide | posterior built (s) | rough start (s) | mode and walkers (s) | evaluations | per evaluation (ms) |");
    println!("|---|---|---|---|---|---|");
    for n in lengths {
        let interval = DURATION_S / (n.max(2) - 1) as f64;
        let first = simulate(&slide(Scene::First, DURATION_S, interval, 1, None))?.series;
        let data = vec![
            RunData::for_series(&spec, 0, first)?,
            RunData::for_series(&spec, 1, repeat.clone())?,
        ];
        let started = Instant::now();
        let posterior = Posterior::from_data(&spec, BlockSettings::default(), data)?;
        let setup = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let search = posterior.search_start();
        let rough = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let walkers = initial_around_optimum(Target::blocked(&posterior), search, 16, 4, &mut rng)?;
        let mode = started.elapsed().as_secs_f64();
        let evaluations = walkers.optimum.evaluations;
        println!(
            "| {} | {setup:.2} | {rough:.2} | {mode:.2} | {evaluations} | {:.3} |",
            posterior.max_points(),
            1e3 * mode / evaluations as f64
        );
    }
    Ok(())
}
