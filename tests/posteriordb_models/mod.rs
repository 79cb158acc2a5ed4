//! posteriordb's reference posteriors (stan-dev/posteriordb, BSD) as slipbayes densities, the
//! committed reference summaries, and the comparison of a fit with them: shared by
//! `tests/posteriordb.rs` (the assertions) and `benches/posteriordb.rs` (the report), and no
//! part of the library.
//!
//! The data and the reference summaries under `tests/reference/posteriordb/` are written by
//! `tests/reference/posteriordb/make_reference.py` from a posteriordb mirror.
#![allow(dead_code)]

pub mod models;
pub mod ode;

use std::path::PathBuf;

use serde_json::Value;
use slipbayes::density::{BlockPlan, BlockedDensity, LogDensity, Quantity, QuantityKind, Target};
use slipbayes::diagnostics::mcse_mean;
use slipbayes::fit::{
    default_updates, default_walkers, run_fit, FitError, FitOutcome, FitSettings, RunDir,
    SummarySpec,
};
use slipbayes::optimize::SearchStart;
use slipbayes::sampler::{CarryFit, Parallelism, Silent};

use models::{
    ArK, EightSchoolsCentered, EightSchoolsNoncentered, Garch11, GaussMix, LotkaVolterra, OneComp,
    Schools,
};

/// Allowed distance of a mean or sd from the reference, in combined Monte-Carlo standard
/// errors √(MCSE_ours² + MCSE_ref²): 4 leaves a false alarm about once in 16,000 comparisons
/// when the errors are normal, so the ~100 comparisons of the suite fail by chance about once
/// in 160 runs of a new seed.
pub const K_MCSE: f64 = 4.0;

/// `tests/reference/posteriordb/<rest>`.
pub fn reference_path(rest: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/reference/posteriordb")
        .join(rest)
}

fn read_json(rest: &str) -> Value {
    let path = reference_path(rest);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("parsing {}: {e}", path.display()))
}

/// Log-densities of scipy transcriptions of the Stan programs (`density_reference.json`).
pub fn density_reference() -> Value {
    read_json("density_reference.json")
}

/// A posteriordb data set, as the script wrote it.
pub fn data(name: &str) -> Value {
    read_json(&format!("data/{name}.json"))
}

/// The solutions of the ODE models by scipy (`ode_reference.json`).
pub fn ode_reference() -> Value {
    read_json("ode_reference.json")
}

/// The reference summary of one constrained parameter.
#[derive(Debug, Clone)]
pub struct RefParam {
    pub name: String,
    pub mean: f64,
    pub sd: f64,
    /// At [`Reference::quantile_probs`].
    pub quantiles: Vec<f64>,
    pub mcse_mean: f64,
    pub mcse_sd: f64,
    /// The same four of ln x, for a parameter whose sd does not exist (its posterior tail too
    /// heavy: see `HEAVY_TAILED` in the script), which is compared on the log scale instead.
    pub log: Option<Moments>,
}

/// Mean and sd with their Monte-Carlo standard errors.
#[derive(Debug, Clone, Copy)]
pub struct Moments {
    pub mean: f64,
    pub sd: f64,
    pub mcse_mean: f64,
    pub mcse_sd: f64,
}

/// A reference posterior's summaries.
#[derive(Debug, Clone)]
pub struct Reference {
    pub name: String,
    pub commit: String,
    pub chains: usize,
    pub draws: usize,
    pub quantile_probs: Vec<f64>,
    pub params: Vec<RefParam>,
}

fn f(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("reference field `{key}` is not a number"))
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

impl Reference {
    /// The reference named `name` (a posteriordb reference posterior name).
    pub fn load(name: &str) -> Self {
        let v = read_json(&format!("reference/{name}.json"));
        let params = v["parameters"]
            .as_array()
            .expect("parameters")
            .iter()
            .map(|p| RefParam {
                name: p["name"].as_str().expect("name").to_owned(),
                mean: f(p, "mean"),
                sd: f(p, "sd"),
                quantiles: floats(&p["quantiles"]),
                mcse_mean: f(p, "mcse_mean"),
                mcse_sd: f(p, "mcse_sd"),
                log: p.get("log").map(|l| Moments {
                    mean: f(l, "mean"),
                    sd: f(l, "sd"),
                    mcse_mean: f(l, "mcse_mean"),
                    mcse_sd: f(l, "mcse_sd"),
                }),
            })
            .collect();
        Self {
            name: name.to_owned(),
            commit: v["posteriordb_commit"].as_str().expect("commit").to_owned(),
            chains: v["chains"].as_u64().expect("chains") as usize,
            draws: v["draws"].as_u64().expect("draws") as usize,
            quantile_probs: floats(&v["quantile_probs"]),
            params,
        }
    }
}

/// One posterior to fit: its density, where the mode search starts, and its reference.
pub struct Case {
    /// posteriordb's posterior name (with a suffix for a variant of ours).
    pub name: &'static str,
    /// posteriordb's reference posterior name.
    pub reference: &'static str,
    pub density: Box<dyn CaseDensity>,
    /// Start of the mode search, in the density's (unconstrained) coordinates: a modeller's
    /// guess (prior medians, or zeros on the unconstrained scale), not the answer.
    pub start: Vec<f64>,
}

const EIGHT_SCHOOLS_REF: &str = "eight_schools-eight_schools_noncentered";

/// The centred eight schools with the population block declared (`population_block`) or as
/// the bare Stan program.
pub fn eight_schools_centered(population_block: bool) -> Case {
    let schools = Schools::from_json(&data("eight_schools"));
    let mut start = vec![0.0, 1.0];
    start.extend([0.0; 8]);
    Case {
        name: if population_block {
            "eight_schools-eight_schools_centered"
        } else {
            "eight_schools-eight_schools_centered (no population block)"
        },
        reference: EIGHT_SCHOOLS_REF,
        density: Box::new(EightSchoolsCentered {
            schools,
            population_block,
        }),
        start,
    }
}

/// The seven posteriors of the issue, each as its Stan program defines it, the centred eight
/// schools with its population block.
pub fn cases() -> Vec<Case> {
    let mut noncentred_start = vec![0.0; 9];
    noncentred_start.push(1.0);
    vec![
        Case {
            name: "eight_schools-eight_schools_noncentered",
            reference: EIGHT_SCHOOLS_REF,
            density: Box::new(EightSchoolsNoncentered(Schools::from_json(&data(
                "eight_schools",
            )))),
            start: noncentred_start,
        },
        eight_schools_centered(true),
        Case {
            name: "arK-arK",
            reference: "arK-arK",
            density: Box::new(ArK::from_json(&data("arK"))),
            start: vec![0.0; 7],
        },
        Case {
            name: "garch-garch11",
            reference: "garch-garch11",
            density: Box::new(Garch11::from_json(&data("garch"))),
            start: vec![0.0; 4],
        },
        Case {
            name: "low_dim_gauss_mix-low_dim_gauss_mix",
            reference: "low_dim_gauss_mix-low_dim_gauss_mix",
            density: Box::new(GaussMix::from_json(&data("low_dim_gauss_mix"))),
            start: vec![-1.0, 2f64.ln(), 0.0, 0.0, 0.0],
        },
        Case {
            name: "hudson_lynx_hare-lotka_volterra",
            reference: "hudson_lynx_hare-lotka_volterra",
            density: Box::new(LotkaVolterra::from_json(&data("hudson_lynx_hare"))),
            // Prior medians of θ and σ; z_init at the first observation (y_init).
            start: [
                1.0,
                0.05,
                1.0,
                0.05,
                30.0,
                4.0,
                (-1f64).exp(),
                (-1f64).exp(),
            ]
            .map(f64::ln)
            .to_vec(),
        },
        Case {
            name: "one_comp_mm_elim_abs-one_comp_mm_elim_abs",
            reference: "one_comp_mm_elim_abs-one_comp_mm_elim_abs",
            density: Box::new(OneComp::from_json(&data("one_comp_mm_elim_abs"))),
            start: vec![0.0; 4],
        },
    ]
}

/// A reference posterior's density as a fit samples it: jointly, from a mode searched in its
/// own coordinates, unless it says otherwise.
pub trait CaseDensity: LogDensity {
    /// Fits it with `settings` into `dir`, the mode search starting at `start`.
    ///
    /// # Errors
    /// As [`run_fit`].
    fn fit(
        &self,
        spec: &SummarySpec,
        start: &[f64],
        settings: &FitSettings,
        dir: &RunDir,
    ) -> Result<FitOutcome, FitError> {
        run_fit(
            Target::joint(self),
            spec,
            start,
            settings,
            dir,
            false,
            &mut Silent,
            Parallelism::default(),
        )
    }

    /// The default walkers of a fit of it.
    fn walkers(&self) -> usize {
        default_walkers(Target::joint(self), default_updates(), CarryFit::default())
    }

    /// Its blocks, when a fit updates them one at a time.
    fn plan(&self) -> Option<BlockPlan<'_>> {
        None
    }
}

impl CaseDensity for EightSchoolsNoncentered {}
impl CaseDensity for ArK {}
impl CaseDensity for Garch11 {}
impl CaseDensity for GaussMix {}
impl CaseDensity for LotkaVolterra {}
impl CaseDensity for OneComp {}

/// Sampled by its blocks with the population block; either way its mode is searched, and its
/// first walkers drawn, in the non-centred coordinates (the centred density has no mode).
impl CaseDensity for EightSchoolsCentered {
    fn fit(
        &self,
        spec: &SummarySpec,
        start: &[f64],
        settings: &FitSettings,
        dir: &RunDir,
    ) -> Result<FitOutcome, FitError> {
        let start = SearchStart {
            point: start,
            map: Some(self),
        };
        let target = if self.population_block {
            Target::blocked(self)
        } else {
            Target::joint(self)
        };
        run_fit(
            target,
            spec,
            start,
            settings,
            dir,
            false,
            &mut Silent,
            Parallelism::default(),
        )
    }

    fn walkers(&self) -> usize {
        let target = if self.population_block {
            Target::blocked(self)
        } else {
            Target::joint(self)
        };
        default_walkers(target, default_updates(), CarryFit::default())
    }

    fn plan(&self) -> Option<BlockPlan<'_>> {
        self.population_block.then(|| self.block_plan())
    }
}

/// The fit's defaults for `density`: default moves, updates, stopping rule (converged by the
/// strict standard) and seed, 4 ensembles, the default walker rule; quiet.
pub fn default_settings(density: &dyn CaseDensity) -> FitSettings {
    FitSettings {
        walkers: density.walkers(),
        quiet: true,
        overwrite: true,
        ..FitSettings::default()
    }
}

/// Every constrained parameter as a reported quantity.
pub fn spec(density: &dyn CaseDensity) -> SummarySpec {
    SummarySpec::of(
        density
            .derived_names()
            .into_iter()
            .map(|n| Quantity {
                column: n.clone(),
                name: n,
                group: String::new(),
                unit: String::new(),
                kind: QuantityKind::Parameter,
            })
            .collect(),
    )
}

/// Fits `case` with `settings` into `dir`.
///
/// # Errors
/// As [`run_fit`].
pub fn fit(
    case: &Case,
    settings: &FitSettings,
    dir: &std::path::Path,
) -> Result<FitOutcome, FitError> {
    case.density.fit(
        &spec(case.density.as_ref()),
        &case.start,
        settings,
        &RunDir::new(dir),
    )
}

/// One parameter of a fit against its reference.
#[derive(Debug, Clone)]
pub struct Check {
    /// The parameter as posteriordb names it, or `ln <name>` when compared on the log scale.
    pub name: String,
    /// Ours, with MCSEs over the ensembles (see [`ensemble_moments`]).
    pub ours: Moments,
    /// The MCSEs of the mean and sd as the fit's summary reports them (ESS over walkers);
    /// `None` on the log scale, which the summary does not report.
    pub summary_mcse: Option<(f64, f64)>,
    pub reference: Moments,
}

impl Check {
    /// (ours − reference) / √(MCSE_ours² + MCSE_ref²) of the mean.
    pub fn z_mean(&self) -> f64 {
        (self.ours.mean - self.reference.mean) / self.ours.mcse_mean.hypot(self.reference.mcse_mean)
    }
    /// The same of the sd.
    pub fn z_sd(&self) -> f64 {
        (self.ours.sd - self.reference.sd) / self.ours.mcse_sd.hypot(self.reference.mcse_sd)
    }
}

/// Mean, sd and their MCSEs of a column from its draws `series[ensemble][walker][step]` after
/// `burn_in` steps.
///
/// The walkers of one ensemble are coupled (each moves along the others), so their draws at
/// one step are not independent: the per-step average over the walkers of an ensemble is a
/// function of the ensemble's Markov state, and the independent ensembles are the chains
/// whose ESS gives the MCSE (as tests/sampler_util does). The sd's MCSE is that of the mean
/// of (x − x̄)² through the delta method, d sd = d var / (2 sd).
pub fn ensemble_moments(series: &[Vec<Vec<f64>>], burn_in: usize) -> Moments {
    let per_step = |g: &dyn Fn(f64) -> f64| -> Vec<Vec<f64>> {
        series
            .iter()
            .map(|ens| {
                let steps = ens[0].len();
                (burn_in..steps)
                    .map(|t| ens.iter().map(|w| g(w[t])).sum::<f64>() / ens.len() as f64)
                    .collect()
            })
            .collect()
    };
    let means = per_step(&|x| x);
    let steps: usize = means.iter().map(Vec::len).sum();
    let mean = means.iter().flatten().sum::<f64>() / steps as f64;
    let squares = per_step(&|x| (x - mean).powi(2));
    let draws = (steps * series[0].len()) as f64;
    // ddof = 1, as the summary's sd and the reference's.
    let var = squares.iter().flatten().sum::<f64>() / steps as f64 * draws / (draws - 1.0);
    let mcse = |v: &[Vec<f64>]| -> f64 {
        let refs: Vec<&[f64]> = v.iter().map(Vec::as_slice).collect();
        mcse_mean(&refs).expect("MCSE over the ensembles")
    };
    Moments {
        mean,
        sd: var.sqrt(),
        mcse_mean: mcse(&means),
        mcse_sd: mcse(&squares) / (2.0 * var.sqrt()),
    }
}

/// Every parameter of `reference` in the fit `outcome`: on the natural scale, or on the log
/// scale (the sampled coordinate `u_<name>`) where the reference says the sd does not exist.
pub fn compare(outcome: &FitOutcome, reference: &Reference) -> Vec<Check> {
    let chains = outcome.dir.chain_reader().expect("the chains of the fit");
    let burn_in = outcome.summary.sampler.burn_in as usize;
    let moments = |column: &str| {
        let series = chains
            .series(column)
            .unwrap_or_else(|e| panic!("column `{column}` of the fit: {e}"));
        ensemble_moments(&series, burn_in)
    };
    reference
        .params
        .iter()
        .map(|r| match r.log {
            Some(log) => Check {
                name: format!("ln {}", r.name),
                ours: moments(&format!("u_{}", r.name)),
                summary_mcse: None,
                reference: log,
            },
            None => {
                let q = outcome
                    .summary
                    .parameters
                    .iter()
                    .find(|q| q.name == r.name)
                    .unwrap_or_else(|| panic!("the fit reports no `{}`", r.name));
                Check {
                    name: r.name.clone(),
                    ours: moments(&r.name),
                    summary_mcse: Some((q.stats.mcse_mean, q.stats.mcse_sd)),
                    reference: Moments {
                        mean: r.mean,
                        sd: r.sd,
                        mcse_mean: r.mcse_mean,
                        mcse_sd: r.mcse_sd,
                    },
                }
            }
        })
        .collect()
}
