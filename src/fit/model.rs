//! Fitting a friction model: what its summary reports, how a model file's sampler settings
//! combine with a caller's, and the files a friction fit adds to its run directory.

use super::run_dir::{
    relative_path, ForwardModelRecord, LooPoint, LooSummary, RunLock, RunRecord, RunTruth,
};
use super::{
    default_moves, default_updates, default_walkers, fit_stop_rule, kept_draws, run_fit, Aggregate,
    ComparisonSpec, FitError, FitOutcome, FitSettings, FitSummary, RunDir, RunFile, SamplerSpec,
    SummarySpec,
};
use crate::density::{LogDensity, Target};
use crate::law::Scene;
use crate::model::{ModelSpec, PointwiseError, Posterior};
use crate::sampler::{CarryFit, Move, Observer, Parallelism, Steps, Updates};
use crate::simulate::SimulationSpec;

/// Draws behind the bands of `predictive.csv`: enough for stable 95 % quantiles, few enough
/// to cost seconds.
const PREDICTIVE_DRAWS: usize = 200;
/// Points per run in `predictive.csv`, at most.
const PREDICTIVE_POINTS: usize = 500;

/// Quantities compared between materials when each material reports them.
const COMPARED: [&str; 6] = ["alpha", "a", "a_over_F_d", "F_d", "F_peak", "F_peak_new"];

/// Settings a caller (the command line) may impose over a model file's `[sampler]` table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SettingOverrides {
    /// Seed.
    pub seed: Option<u64>,
    /// Walkers per ensemble.
    pub walkers: Option<usize>,
    /// A fixed number of steps.
    pub steps: Option<u64>,
    /// The step cap when running until converged.
    pub max_steps: Option<u64>,
    /// The wall-time budget (s) when running until converged.
    pub max_time_s: Option<f64>,
    /// Forward no progress.
    pub quiet: bool,
    /// Replace an earlier run in the directory.
    pub overwrite: bool,
    /// Proposal moves and weights.
    pub moves: Option<Vec<(Move, f64)>>,
    /// Joint or blocked updates.
    pub updates: Option<Updates>,
    /// How hierarchical updates carry a block's followers.
    pub carry: Option<CarryFit>,
}

impl FitSettings {
    /// The settings of a fit of `posterior`: its run file's `[sampler]` table `s` under
    /// `overrides`; walkers default to [`default_walkers`].
    pub fn for_model(posterior: &Posterior, s: &SamplerSpec, overrides: &SettingOverrides) -> Self {
        let updates = overrides
            .updates
            .or(s.updates)
            .unwrap_or_else(default_updates);
        let carry = overrides.carry.or(s.carry).unwrap_or_default();
        let walkers = overrides
            .walkers
            .or(s.walkers)
            .unwrap_or_else(|| default_walkers(Target::blocked(posterior), updates, carry));
        let max_steps = overrides.max_steps.unwrap_or(s.max_steps);
        let steps = match overrides.steps.or(s.steps) {
            Some(n) => Steps::Fixed(n),
            None => Steps::UntilConverged(fit_stop_rule(max_steps)),
        };
        Self {
            walkers,
            ensembles: s.ensembles,
            seed: overrides.seed.unwrap_or(s.seed),
            steps,
            checkpoint_every: Some(s.checkpoint_every),
            quiet: overrides.quiet,
            overwrite: overrides.overwrite,
            moves: overrides
                .moves
                .clone()
                .or_else(|| s.moves.as_ref().map(|m| m.moves().to_vec()))
                .unwrap_or_else(default_moves),
            updates,
            carry,
            max_time_s: overrides.max_time_s.or(s.max_time_s),
            ..Self::default()
        }
    }
}

/// What the summary of a fit of `posterior` reports: every parameter and derived quantity;
/// per material, the mean F_d of its contacts and the mean F_peak of its first slides (where
/// F_d, or F_peak, is not a material quantity already); the materials compared on every
/// quantity that two or more of them report; and where each run's data came from.
pub fn summary_spec(posterior: &Posterior) -> SummarySpec {
    let quantities = posterior.quantities().to_vec();
    let spec = posterior.spec();
    let materials: Vec<String> = posterior
        .materials()
        .into_iter()
        .map(String::from)
        .collect();
    let mut aggregates = Vec::new();
    for material in &materials {
        let runs = spec.file.runs.iter().enumerate().filter(|(i, _)| {
            spec.file.materials[spec.contact_material[spec.run_contact[*i]]].name == *material
        });
        let mut contacts: Vec<&str> = Vec::new();
        let mut first_slides: Vec<&str> = Vec::new();
        for (i, run) in runs {
            let contact = spec.file.contacts[spec.run_contact[i]].name.as_str();
            if !contacts.contains(&contact) {
                contacts.push(contact);
            }
            if run.scene == Scene::First {
                first_slides.push(run.name.as_str());
            }
        }
        for (name, groups, note) in [
            ("F_d", contacts, "mean of the material's contacts"),
            (
                "F_peak",
                first_slides,
                "mean of the material's first slides",
            ),
        ] {
            let reported = |group: &str| {
                quantities
                    .iter()
                    .find(|q| q.name == name && q.group == group)
            };
            if reported(material).is_some() {
                continue;
            }
            let members: Vec<&crate::density::Quantity> =
                groups.into_iter().filter_map(reported).collect();
            if let Some(first) = members.first() {
                aggregates.push(Aggregate {
                    name: name.to_owned(),
                    group: material.clone(),
                    unit: first.unit.clone(),
                    of: members.iter().map(|q| q.column.clone()).collect(),
                    note: note.to_owned(),
                });
            }
        }
    }
    let per_material = |name: &str| {
        let in_quantities = quantities
            .iter()
            .filter(|q| q.name == name && materials.contains(&q.group))
            .count();
        let in_aggregates = aggregates.iter().filter(|a| a.name == name).count();
        in_quantities + in_aggregates >= 2
    };
    let comparisons = ComparisonSpec {
        names: COMPARED
            .into_iter()
            .filter(|n| per_material(n))
            .map(String::from)
            .collect(),
        groups: materials,
    };
    SummarySpec {
        quantities,
        aggregates,
        comparisons,
        data: posterior.data_provenance(),
        model: Some(ForwardModelRecord {
            law: spec.file.law.name().to_owned(),
            state_law: (spec.file.law == crate::law::LawKind::RateState)
                .then(|| spec.forward().state_law.name().to_owned()),
            elastic: spec.file.elastic,
            unread: spec.unread_settings(),
        }),
    }
}

/// A sentence for every slide whose peak the posterior places after the end of its record,
/// wholly (the lower end of t_peak's interval) or in part (its upper end): there the height
/// of the peak, and the law's parameters that set it, are extrapolated by the law rather than
/// observed, and they rest on the priors as much as on the data.
pub fn peak_notes(posterior: &Posterior, summary: &FitSummary) -> Vec<String> {
    let mut notes = Vec::new();
    for (run, end) in posterior.record_ends() {
        let Some(t) = summary.find("t_peak", run) else {
            continue;
        };
        let (low, high) = (t.stats.ci_low, t.stats.ci_high);
        let whole = if low > end {
            "lies after"
        } else if high > end {
            "may lie after"
        } else {
            continue;
        };
        notes.push(format!(
            "the peak of run `{run}` {whole} the end of its record: t_peak's interval is \
             [{low:.4e}, {high:.4e}] s, the last point at {end:.4e} s; its F_peak, and α, a/F_d \
             and F_d that set it, are extrapolated by the law, not observed (only a record that \
             reaches past the peak measures them)"
        ));
    }
    notes
}

/// Fits `posterior`, built from the run file `run`, into the run directory that `lock` holds
/// and writes all of it: the chains and checkpoint, `summary.json` and `summary.csv`
/// ([`run_fit`](super::run_fit) with [`summary_spec`]), then `model.toml` (the run file),
/// `settings.json` (recording `command`) and `predictive.csv`. Taking the lock rather than a
/// path, it cannot write a directory another fit is writing. The sampler evaluates as
/// `parallelism` says: with the ranks of an MPI job, tell them first which density to build
/// (`Cluster::share_density` with [`Posterior::data_share`]).
///
/// # Errors
/// As [`run_fit`](super::run_fit); [`FitError::RunDir`] when a file cannot be written;
/// [`FitError::Predictive`] when a posterior draw has no valid law.
// The run file and the posterior built from it go together: the caller builds the posterior
// once, and hands the same one to the ranks of an MPI job through `parallelism`.
#[allow(clippy::too_many_arguments)]
pub fn fit_model<'p>(
    run: &RunFile,
    posterior: &'p Posterior,
    settings: &FitSettings,
    lock: &RunLock,
    resume: bool,
    command: Vec<String>,
    observer: &mut impl Observer,
    parallelism: Parallelism<'p>,
) -> Result<FitOutcome, FitError> {
    let out = lock.dir();
    let dir = RunDir::new(out);
    let mut outcome = run_fit(
        Target::blocked(posterior),
        &summary_spec(posterior),
        posterior.search_start(),
        settings,
        &dir,
        resume,
        observer,
        parallelism,
    )?;
    outcome.summary.notes = peak_notes(posterior, &outcome.summary);
    if !outcome.summary.notes.is_empty() {
        dir.write_summary(&outcome.summary)?;
    }
    write_run_files(run, posterior, settings, command, &mut outcome)?;
    Ok(outcome)
}

/// The files a friction fit adds to its run directory once the chains are summarised: the
/// run file, the record of how it ran, the posterior predictive bands, what the report
/// draws (the curves it redraws from the posterior, the truths behind synthetic data), and
/// PSIS-LOO.
fn write_run_files(
    run: &RunFile,
    posterior: &Posterior,
    settings: &FitSettings,
    command: Vec<String>,
    outcome: &mut FitOutcome,
) -> Result<(), FitError> {
    let dir = outcome.dir.clone();
    let out = dir.path();
    let spec = &run.model;
    dir.write_model(run)?;
    let data_dir = relative_path(out, &spec.base_dir).map_err(|e| {
        super::RunDirError::from(crate::IoError::new(
            "resolve the data directory from",
            out,
            e,
        ))
    })?;
    dir.write_record(&RunRecord {
        slipbayes_version: env!("CARGO_PKG_VERSION").to_owned(),
        command,
        model_file: spec.source.display().to_string(),
        data_dir: Some(data_dir.display().to_string()),
        settings: settings.clone(),
        dimension: posterior.dim(),
        sampled_coordinates: posterior.param_names(),
        priors: posterior.prior_descriptions(),
    })?;
    let draws = kept_draws(outcome, &posterior.param_names(), PREDICTIVE_DRAWS)?;
    let stride = posterior.max_points().div_ceil(PREDICTIVE_POINTS);
    let bands = posterior
        .predictive_bands(&draws, stride, settings.seed)
        .map_err(FitError::Predictive)?;
    dir.write_predictive(&bands)?;
    dir.write_curves(&super::curves::redraw(
        posterior,
        &draws,
        &bands,
        &outcome.summary,
    )?)?;
    dir.write_truths(&truths(spec))?;
    leave_one_out(posterior, outcome)?;
    dir.write_summary(&outcome.summary)?;
    Ok(())
}

/// The simulation behind each run whose data file has one beside it: the JSON that
/// `slipbayes simulate` writes (`first.csv` → `first.json`, with `"synthetic": true`). A run
/// without one, or with one that cannot be read or is not synthetic, has none.
fn truths(spec: &ModelSpec) -> Vec<RunTruth> {
    #[derive(serde::Deserialize)]
    struct TruthFile {
        synthetic: bool,
        spec: SimulationSpec,
    }
    spec.file
        .runs
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let path = spec.data_path(i).with_extension("json");
            let truth: TruthFile =
                serde_json::from_str(&std::fs::read_to_string(&path).ok()?).ok()?;
            let file = path.file_name()?.to_string_lossy().into_owned();
            truth.synthetic.then(|| RunTruth {
                run: r.name.clone(),
                file,
                simulation: truth.spec,
            })
        })
        .collect()
}

/// Posterior draws PSIS-LOO uses, spread evenly over the kept draws: enough for the Pareto
/// fit of each point's tail (good k̂ below 0.62 at 400 draws), few enough that one run's
/// observations × draws stay a few MB.
pub const LOO_DRAWS: usize = 400;

/// PSIS-LOO of a finished fit: `loo.csv` and the summary's `loo` section, or a note saying
/// why not (a run evaluated on sufficient statistics has no likelihood per point).
fn leave_one_out(posterior: &Posterior, outcome: &mut FitOutcome) -> Result<(), FitError> {
    let draws = kept_draws(outcome, &posterior.param_names(), LOO_DRAWS)?;
    // The draws are spread over the whole chain, so they are at most as correlated as the
    // chain: their efficiency is its ESS over their number, capped at independence.
    let ess = &outcome.summary.parameters;
    let mean_ess = ess.iter().map(|q| q.stats.ess_bulk).sum::<f64>() / ess.len() as f64;
    let r_eff = match mean_ess / draws.len() as f64 {
        r if r.is_finite() && r > 0.0 => r.min(1.0),
        _ => 1.0,
    };
    let loo = match posterior.psis_loo(&draws, r_eff) {
        Ok(loo) => loo,
        Err(reason @ PointwiseError::Reduced { .. }) => {
            outcome.summary.loo_not_computed = Some(reason.to_string());
            return Ok(());
        }
        Err(e) => return Err(FitError::Loo(e)),
    };
    let mut points = Vec::with_capacity(loo.total.pointwise.len());
    for (run, (name, run_loo)) in loo.runs.iter().enumerate() {
        let observed = posterior.observed_forces(run);
        for (i, (&elpd, &k)) in run_loo.pointwise.iter().zip(&run_loo.pareto_k).enumerate() {
            points.push(LooPoint {
                run: name.clone(),
                point: i,
                observed_n: observed[i],
                elpd_loo: elpd,
                pareto_k: k,
            });
        }
    }
    outcome.dir.write_loo(&points)?;
    outcome.summary.loo = Some(LooSummary::new(&loo.total, &loo.runs, r_eff));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The truths a fit records are the JSON files `simulate` wrote beside the data, read
    /// where the run file says the data are; data without them record none.
    #[test]
    fn truths_are_read_beside_the_data() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let demo = RunFile::load(&root.join("models/demo.toml")).unwrap();
        let truths = truths(&demo.model);
        assert_eq!(truths.len(), demo.model.file.runs.len());
        assert_eq!(truths[0].run, demo.model.file.runs[0].name);
        assert_eq!(truths[0].file, format!("{}.json", truths[0].run));
        let elsewhere = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string(root.join("models/demo.toml")).unwrap();
        let moved =
            RunFile::parse_in(&text, elsewhere.path().join("models"), "demo.toml".into()).unwrap();
        assert!(super::truths(&moved.model).is_empty());
    }
}
