//! From chains to posterior summaries: the burn-in, one [`Summary`] per quantity, aggregate
//! and comparison, and the verdict on convergence.
//!
//! Every diagnostic sees every post-burn-in draw. Thinning adds no information, and on a
//! thinned chain Geyer's initial-sequence estimator sees few draws per half-chain and
//! overstates the ESS; R̂ and ESS here are what ArviZ computes on the same draws (chain =
//! ensemble for R̂, chain = walker within an ensemble for ESS, see
//! [`EnsembleDraws`](crate::diagnostics::EnsembleDraws)).
//!
//! Memory does not grow with the number of draws: each quantity's draws (a column, a mean of
//! columns, a difference of two) are read one Parquet row group at a time into a working file
//! of the run directory, and summarised from there by
//! [`summarize_draws`] (an external sort for ranks and order statistics; the same numbers
//! as [`summarize`](crate::diagnostics::summarize) to the bit). Quantities are summarised
//! in parallel only as far as [`SUMMARY_MEMORY_BYTES`] allows.

use std::collections::{BTreeMap, HashSet};
use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;

use super::run_dir::{AggregateSummary, Comparison, FitSummary, QuantitySummary, SamplerSummary};
use super::{FitError, FitSettings, SummarySpec};
use crate::density::QuantityKind;
use crate::diagnostics::{
    quantity_problems, stuck_walkers, summarize_draws, DiagnosticsError, DrawsWriter, Limits,
    Problem, Summary, WalkerDraws, Workspace, MIN_DRAWS,
};
use crate::sampler::RunReport;
use crate::storage::ChainReader;

/// One side of a comparison: a reported quantity or an aggregate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Operand {
    Quantity(usize),
    Aggregate(usize),
}

/// One comparison: the quantity's name, its unit, what a mean is over (for an aggregate),
/// and the operands A and B.
type Pair = (String, String, String, Operand, Operand);

/// A validated summary plan: which columns to summarise, which to average, and which pairs to
/// compare.
#[derive(Debug)]
pub(crate) struct SummaryPlan {
    spec: SummarySpec,
    pairs: Vec<Pair>,
}

fn invalid(what: &'static str, problem: String) -> FitError {
    FitError::InvalidSpec { what, problem }
}

impl SummaryPlan {
    /// The plan of `spec` over a density with these columns: every quantity and aggregate
    /// reads columns the density has, each is reported once, and every comparison is of
    /// quantities of one unit reported in at least two groups.
    pub(crate) fn new(
        param_names: &[String],
        derived_names: &[String],
        spec: &SummarySpec,
    ) -> Result<Self, FitError> {
        check_reported(param_names, derived_names, spec)?;
        Ok(Self {
            spec: spec.clone(),
            pairs: comparison_pairs(spec)?,
        })
    }

    /// Summaries of the chains of a finished run.
    pub(crate) fn summarise(
        &self,
        chains: &ChainReader,
        report: &RunReport,
        settings: &FitSettings,
        dir: &Path,
        started: Instant,
    ) -> Result<FitSummary, FitError> {
        let total = report.total_steps;
        check_shape(chains, settings.ensembles, settings.walkers, total, dir)?;
        let mut problems = Vec::new();
        let selection = Selection::new(report, &mut problems)?;
        let ws = Workspace::new(dir, Limits::DEFAULT);
        let reader = DrawsReader {
            chains,
            ws: &ws,
            selection,
            probs: (settings.ci_prob, settings.hdi_prob),
            dir,
        };
        // Quantities are summarised in parallel as far as the memory budget allows (each
        // in the memory of `Limits`), never beyond it whatever the threads; each result is
        // independent of the others, so of the number of threads.
        let jobs = (SUMMARY_MEMORY_BYTES / ws.limits().working_bytes(selection.kept))
            .clamp(1, rayon::current_num_threads().max(1));
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(jobs)
            .build()
            .map_err(|e| FitError::Inconsistent {
                dir: dir.to_path_buf(),
                problem: format!("cannot start the threads of the summary: {e}"),
            })?;
        let (stats, aggregates, comparisons) = pool.install(|| self.summaries(&reader))?;
        problems.extend(self.problems(&stats, report, settings));
        Ok(self.assemble(
            stats,
            aggregates,
            comparisons,
            problems,
            &reader,
            report,
            settings,
            started,
        ))
    }

    /// Every quantity's, aggregate's and comparison's summary, in parallel on the current
    /// thread pool.
    #[allow(clippy::type_complexity)]
    fn summaries(
        &self,
        reader: &DrawsReader,
    ) -> Result<(Vec<Summary>, Vec<AggregateSummary>, Vec<Comparison>), FitError> {
        let stats: Vec<Summary> = (0..self.spec.quantities.len())
            .into_par_iter()
            .map(|i| {
                let (label, names) = self.operand(Operand::Quantity(i));
                reader.summary_of(label, &names, &|c, k| c[0][k])
            })
            .collect::<Result<_, _>>()?;
        let aggregates: Vec<AggregateSummary> = (0..self.spec.aggregates.len())
            .into_par_iter()
            .map(|i| {
                let a = &self.spec.aggregates[i];
                let (label, names) = self.operand(Operand::Aggregate(i));
                Ok(AggregateSummary {
                    name: a.name.clone(),
                    group: a.group.clone(),
                    unit: a.unit.clone(),
                    of: a.of.clone(),
                    note: a.note.clone(),
                    stats: reader.summary_of(label, &names, &|c, k| mean_of(c, k))?,
                })
            })
            .collect::<Result<_, FitError>>()?;
        let comparisons: Vec<Comparison> = self
            .pairs
            .par_iter()
            .map(|pair| self.compare(reader, pair))
            .collect::<Result<_, FitError>>()?;
        Ok((stats, aggregates, comparisons))
    }

    /// One comparison: A − B, A / B and P(A > B) per draw, from one reading of the columns of
    /// A and B.
    fn compare(
        &self,
        reader: &DrawsReader,
        (name, unit, note, a, b): &Pair,
    ) -> Result<Comparison, FitError> {
        let (label_a, names_a) = self.operand(*a);
        let (label_b, names_b) = self.operand(*b);
        let what = format!("{label_a} − {label_b}");
        let diag = |source| FitError::Diagnostics {
            quantity: what.clone(),
            source,
        };
        let split = names_a.len();
        let va = |c: &[Vec<f64>], k: usize| operand_value(*a, &c[..split], k);
        let vb = |c: &[Vec<f64>], k: usize| operand_value(*b, &c[split..], k);
        let mut names = names_a;
        names.extend(names_b);
        let [difference, ratio, above]: [Result<WalkerDraws, DiagnosticsError>; 3] = reader
            .draws(
                &what,
                &names,
                &[
                    &|c, k| va(c, k) - vb(c, k),
                    &|c, k| va(c, k) / vb(c, k),
                    &|c, k| if va(c, k) > vb(c, k) { 1.0 } else { 0.0 },
                ],
            )?
            .try_into()
            .map_err(|_| diag(DiagnosticsError::NoChains { needed: 3 }))?;
        let probs = reader.probs;
        let difference =
            summarize_draws(&difference.map_err(diag)?, probs.0, probs.1).map_err(diag)?;
        // A zero or non-finite ratio draw leaves the ratio undefined, not the fit (a
        // working file that fails does fail it).
        let ratio = match ratio.and_then(|r| summarize_draws(&r, probs.0, probs.1)) {
            Ok(r) => Some(r),
            Err(e @ DiagnosticsError::Scratch(_)) => return Err(diag(e)),
            Err(_) => None,
        };
        // The mean of 0/1 indicators and its MCSE (`None` when every draw agrees, where
        // the MCSE estimate is undefined).
        let (p, p_mcse) = above.and_then(|x| x.mean_and_mcse()).map_err(diag)?;
        let group_of = |o: Operand| match o {
            Operand::Quantity(i) => self.spec.quantities[i].group.clone(),
            Operand::Aggregate(i) => self.spec.aggregates[i].group.clone(),
        };
        Ok(Comparison {
            name: name.clone(),
            unit: unit.clone(),
            group_a: group_of(*a),
            group_b: group_of(*b),
            note: note.clone(),
            difference,
            ratio,
            p_a_greater: p,
            p_a_greater_mcse: Some(p_mcse).filter(|m| m.is_finite() && *m > 0.0),
        })
    }

    /// The convergence problems of the run beyond those of its burn-in: a single ensemble,
    /// each quantity's, and stuck walkers.
    fn problems(
        &self,
        stats: &[Summary],
        report: &RunReport,
        settings: &FitSettings,
    ) -> Vec<Problem> {
        let mut problems = Vec::new();
        if settings.ensembles < 2 {
            problems.push(Problem::SingleEnsemble);
        }
        for (q, s) in self.spec.quantities.iter().zip(stats) {
            problems.extend(quantity_problems(&q.label(), s, settings.ensembles));
        }
        problems.extend(stuck_walkers(
            report.ensembles.iter().map(|e| e.acceptance.as_slice()),
            report.total_steps,
        ));
        problems
    }

    /// The summary of the run from its parts.
    #[allow(clippy::too_many_arguments)]
    fn assemble(
        &self,
        stats: Vec<Summary>,
        aggregates: Vec<AggregateSummary>,
        comparisons: Vec<Comparison>,
        problems: Vec<Problem>,
        reader: &DrawsReader,
        report: &RunReport,
        settings: &FitSettings,
        started: Instant,
    ) -> FitSummary {
        let mut rejections = BTreeMap::new();
        for ens in &report.ensembles {
            for (reason, n) in &ens.rejections {
                *rejections.entry(reason.clone()).or_insert(0) += n;
            }
        }
        let mut parameters = Vec::new();
        let mut derived = Vec::new();
        for (q, s) in self.spec.quantities.iter().zip(stats) {
            let summary = QuantitySummary {
                name: q.name.clone(),
                group: q.group.clone(),
                unit: q.unit.clone(),
                column: q.column.clone(),
                stats: s,
            };
            match q.kind {
                QuantityKind::Parameter => parameters.push(summary),
                QuantityKind::Derived => derived.push(summary),
            }
        }
        let (ensembles, walkers) = (reader.chains.ensembles(), reader.chains.walkers());
        let selection = reader.selection;
        let tau = report.tau.as_ref();
        FitSummary {
            parameters,
            derived,
            aggregates,
            comparisons,
            sampler: SamplerSummary {
                walkers,
                steps: report.total_steps,
                ensembles,
                burn_in: selection.burn_in,
                kept_steps: selection.kept,
                draws: ensembles * walkers * selection.kept,
                acceptance: report.mean_acceptance(),
                tau_max: tau.map(|t| t.max),
                tau_min: tau.map(|t| t.min),
                tau_reliable: tau.is_some_and(|t| t.reliable),
                log_density_evals: report.evaluations(),
                wall_s: started.elapsed().as_secs_f64(),
                converged: problems.is_empty(),
                problems,
                rejections,
                seed: settings.seed,
                stopped_by: report.stopped_by,
                steps_run: report.steps_run,
            },
            data: self.spec.data.clone(),
            model: self.spec.model.clone(),
            notes: Vec::new(),
            loo: None,
            loo_not_computed: None,
            kfold: None,
        }
    }
}

/// Reads the kept draws of a run's quantities into the summary engine's workspace.
struct DrawsReader<'a> {
    chains: &'a ChainReader,
    ws: &'a Workspace,
    selection: Selection,
    /// The probabilities of the equal-tailed interval and of the HDI.
    probs: (f64, f64),
    dir: &'a Path,
}

impl<'a> DrawsReader<'a> {
    /// Reads the columns `names` from the burn-in on, one row group at a time, and writes the
    /// values `fs` give of each row (from the row group's chunks of `names`, in order) as the
    /// draws of as many quantities: memory holds one row group, never a column.
    fn draws(
        &self,
        label: &str,
        names: &[&str],
        fs: &[&Row<'_>],
    ) -> Result<Vec<Result<WalkerDraws<'a>, DiagnosticsError>>, FitError> {
        let diag = |source| FitError::Diagnostics {
            quantity: label.to_owned(),
            source,
        };
        let (ensembles, walkers) = (self.chains.ensembles(), self.chains.walkers());
        let mut writers = fs
            .iter()
            .map(|_| DrawsWriter::new(self.ws, ensembles, walkers, self.selection.kept))
            .collect::<Result<Vec<_>, _>>()
            .map_err(diag)?;
        let mut values = Vec::new();
        self.chains
            .for_each_chunk::<ReadError>(names, self.selection.burn_in, |_, chunks| {
                for (f, writer) in fs.iter().zip(&mut writers) {
                    values.clear();
                    values.extend((0..chunks[0].len()).map(|k| f(chunks, k)));
                    writer.push(&values).map_err(ReadError::Diagnostics)?;
                }
                Ok(())
            })
            .map_err(|e| match e {
                ReadError::Storage(source) => FitError::Storage {
                    context: format!("reading columns {names:?} of {}", self.dir.display()),
                    source,
                },
                ReadError::Diagnostics(source) => diag(source),
            })?;
        Ok(writers.into_iter().map(DrawsWriter::finish).collect())
    }

    /// The summary of the values `f` gives of each row of the columns `names`.
    fn summary_of(&self, label: String, names: &[&str], f: &Row<'_>) -> Result<Summary, FitError> {
        let diag = |source| FitError::Diagnostics {
            quantity: label.clone(),
            source,
        };
        let x = self
            .draws(&label, names, &[f])?
            .pop()
            .expect("one")
            .map_err(diag)?;
        summarize_draws(&x, self.probs.0, self.probs.1).map_err(diag)
    }
}

/// Every quantity and aggregate of `spec` reads columns the density has (`param_names`,
/// `derived_names`), has a name, and is reported once.
fn check_reported(
    param_names: &[String],
    derived_names: &[String],
    spec: &SummarySpec,
) -> Result<(), FitError> {
    let quantities = &spec.quantities;
    if quantities.is_empty() {
        return Err(invalid(
            "quantity",
            "no quantities to report: give at least one".into(),
        ));
    }
    // A set: a campaign of thousands of contacts reports thousands of quantities.
    let columns: HashSet<&str> = param_names
        .iter()
        .chain(derived_names)
        .map(String::as_str)
        .collect();
    let known = |column: &str| columns.contains(column);
    let mut seen = HashSet::new();
    for q in quantities {
        // The kind decides the list a quantity is reported in; its column may be a
        // sampled coordinate or a derived value (e.g. a parameter in SI units computed
        // from its log-scale coordinate).
        if !known(&q.column) {
            return Err(invalid(
                "quantity",
                format!(
                    "{} reads column {:?}, which the density does not have; its columns are {param_names:?} and {derived_names:?}",
                    q.label(),
                    q.column
                ),
            ));
        }
        if q.name.is_empty() {
            return Err(invalid(
                "quantity",
                format!("the quantity of column {:?} has an empty name", q.column),
            ));
        }
        if !seen.insert((q.name.as_str(), q.group.as_str())) {
            return Err(invalid(
                "quantity",
                format!(
                    "{} is reported twice; give each name and group once",
                    q.label()
                ),
            ));
        }
    }
    for a in &spec.aggregates {
        let label = crate::density::label(&a.name, &a.group);
        if a.of.is_empty() {
            return Err(invalid(
                "aggregate",
                format!("{label} averages no columns; give at least one"),
            ));
        }
        if let Some(c) = a.of.iter().find(|c| !known(c)) {
            return Err(invalid(
                "aggregate",
                format!("{label} averages column {c:?}, which the density does not have"),
            ));
        }
        if !seen.insert((a.name.as_str(), a.group.as_str())) {
            return Err(invalid(
                "aggregate",
                format!("{label} is reported twice (as a quantity or an aggregate)"),
            ));
        }
    }
    Ok(())
}

/// The ordered pairs of operands `spec`'s comparisons compare: (name, unit, note, A, B).
fn comparison_pairs(spec: &SummarySpec) -> Result<Vec<Pair>, FitError> {
    let quantities = &spec.quantities;
    let comparisons = &spec.comparisons;
    for (list, what) in [(&comparisons.names, "name"), (&comparisons.groups, "group")] {
        let mut unique = HashSet::new();
        if let Some(dup) = list.iter().find(|n| !unique.insert(n.as_str())) {
            return Err(invalid(
                "comparison",
                format!("{what} {dup:?} is listed twice"),
            ));
        }
    }
    let operand = |name: &str, group: &str| {
        if let Some(i) = quantities
            .iter()
            .position(|q| q.name == name && q.group == group)
        {
            return Some((
                Operand::Quantity(i),
                quantities[i].unit.clone(),
                String::new(),
            ));
        }
        spec.aggregates
            .iter()
            .position(|a| a.name == name && a.group == group)
            .map(|i| {
                let a = &spec.aggregates[i];
                (Operand::Aggregate(i), a.unit.clone(), a.note.clone())
            })
    };
    let mut pairs = Vec::new();
    for name in &comparisons.names {
        let present: Vec<(&String, (Operand, String, String))> = comparisons
            .groups
            .iter()
            .filter_map(|g| operand(name, g).map(|o| (g, o)))
            .collect();
        if present.len() < 2 {
            return Err(invalid(
                "comparison",
                format!(
                    "{name:?} is reported in {} of the groups {:?}; a comparison needs it in at least two",
                    present.len(),
                    comparisons.groups
                ),
            ));
        }
        for (k, (ga, (a, unit_a, note_a))) in present.iter().enumerate() {
            for (gb, (b, unit_b, _)) in &present[k + 1..] {
                if unit_a != unit_b {
                    return Err(invalid(
                        "comparison",
                        format!(
                            "{name}[{ga}] is in {unit_a:?} but {name}[{gb}] in {unit_b:?}; compare quantities of one unit"
                        ),
                    ));
                }
                pairs.push((name.clone(), unit_a.clone(), note_a.clone(), *a, *b));
            }
        }
    }
    Ok(pairs)
}

/// What the summaries may hold in memory at once, beyond the row groups being read: as many
/// quantities are summarised in parallel as fit in it (at least one).
const SUMMARY_MEMORY_BYTES: usize = 96 << 20;

/// The value of a row from the row group's chunks of an operand's columns.
type Row<'a> = dyn Fn(&[Vec<f64>], usize) -> f64 + Sync + 'a;

/// Per row, the mean of the chunks' values: summed in column order from 0.0, then divided,
/// as an aggregate's draws have always been.
fn mean_of(chunks: &[Vec<f64>], k: usize) -> f64 {
    let mut sum = 0.0;
    for c in chunks {
        sum += c[k];
    }
    sum / chunks.len() as f64
}

/// An operand's value in a row, from the chunks of its columns: a quantity's column, or the
/// mean of an aggregate's.
fn operand_value(o: Operand, chunks: &[Vec<f64>], k: usize) -> f64 {
    match o {
        Operand::Quantity(_) => chunks[0][k],
        Operand::Aggregate(_) => mean_of(chunks, k),
    }
}

/// Reading the chains for a summary: the store or the draws' working files.
enum ReadError {
    Storage(crate::storage::StorageError),
    Diagnostics(DiagnosticsError),
}

impl From<crate::storage::StorageError> for ReadError {
    fn from(e: crate::storage::StorageError) -> Self {
        Self::Storage(e)
    }
}

impl SummaryPlan {
    /// An operand's label and the columns it reads.
    fn operand(&self, o: Operand) -> (String, Vec<&str>) {
        match o {
            Operand::Quantity(i) => {
                let q = &self.spec.quantities[i];
                (q.label(), vec![q.column.as_str()])
            }
            Operand::Aggregate(i) => {
                let a = &self.spec.aggregates[i];
                (
                    crate::density::label(&a.name, &a.group),
                    a.of.iter().map(String::as_str).collect(),
                )
            }
        }
    }
}

/// Checks the shape of the chains against the settings and the sampler's report.
fn check_shape(
    chains: &ChainReader,
    ensembles: usize,
    walkers: usize,
    steps: u64,
    dir: &Path,
) -> Result<(), FitError> {
    let found = (chains.ensembles(), chains.walkers(), chains.steps());
    if found == (ensembles, walkers, steps) {
        return Ok(());
    }
    Err(FitError::Inconsistent {
        dir: dir.to_path_buf(),
        problem: format!(
            "the chains hold {} ensembles × {} walkers × {} steps where {ensembles} × {walkers} × {steps} were expected",
            found.0, found.1, found.2
        ),
    })
}

/// Which steps are kept: every step from `burn_in` to the end.
#[derive(Debug, Clone, Copy)]
struct Selection {
    burn_in: u64,
    kept: usize,
}

impl Selection {
    fn new(report: &RunReport, problems: &mut Vec<Problem>) -> Result<Self, FitError> {
        let total = report.total_steps;
        let half = total / 2;
        let (mut burn_in, reliable) = match &report.tau {
            Some(t) => {
                if !t.reliable {
                    problems.push(Problem::ChainsTooShort {
                        steps: total,
                        tau_max: t.max,
                        needed: t.needed_steps,
                    });
                }
                (t.burn_in, t.reliable)
            }
            None => {
                // Without τ, the first half is discarded.
                problems.push(Problem::NoAutocorrelationTime { steps: total });
                (half, false)
            }
        };
        // A trusted τ already means more than its trusted length after the burn-in: a burn-in
        // past half the run is then the steps the sampler spent tuning (a carried
        // regression's fit, the slice move's μ), whose draws must not be kept however short
        // what follows them. Only a burn-in of an untrusted τ is cut to half, as a
        // best effort the verdict already refuses.
        if burn_in > half && !reliable {
            problems.push(Problem::BurnInCapped {
                burn_in,
                used: half,
            });
            burn_in = half;
        }
        let kept = (total - burn_in) as usize;
        if kept < MIN_DRAWS {
            return Err(FitError::TooFewDraws {
                kept,
                burn_in,
                total,
                needed: MIN_DRAWS,
            });
        }
        Ok(Self { burn_in, kept })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::density::Quantity;
    use crate::fit::{Aggregate, ComparisonSpec};

    fn q(column: &str, name: &str, group: &str, kind: QuantityKind) -> Quantity {
        Quantity {
            column: column.into(),
            name: name.into(),
            group: group.into(),
            unit: String::new(),
            kind,
        }
    }

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    fn spec(quantities: Vec<Quantity>, comparisons: ComparisonSpec) -> SummarySpec {
        SummarySpec {
            quantities,
            comparisons,
            ..SummarySpec::default()
        }
    }

    #[test]
    fn plan_refuses_what_it_cannot_report() {
        let params = names(&["a", "b"]);
        let derived = names(&["d_a", "d_b"]);
        let none = ComparisonSpec::default();
        let p = QuantityKind::Parameter;
        let d = QuantityKind::Derived;
        let err = |s: SummarySpec| {
            SummaryPlan::new(&params, &derived, &s)
                .expect_err("must be refused")
                .to_string()
        };
        assert!(err(spec(vec![], none.clone())).contains("no quantities"));
        // A parameter may be reported from a derived column (e.g. in SI units).
        assert!(SummaryPlan::new(
            &params,
            &derived,
            &spec(vec![q("d_a", "x", "", p)], none.clone())
        )
        .is_ok());
        assert!(err(spec(vec![q("zz", "x", "", d)], none.clone())).contains("\"zz\""));
        assert!(err(spec(
            vec![q("a", "x", "g", p), q("b", "x", "g", p)],
            none.clone()
        ))
        .contains("twice"));
        let ab = ComparisonSpec {
            names: names(&["x"]),
            groups: names(&["A", "B"]),
        };
        assert!(err(spec(
            vec![q("a", "x", "A", p), q("b", "x", "C", p)],
            ab.clone()
        ))
        .contains("1 of the groups"));
        let ok = SummaryPlan::new(
            &params,
            &derived,
            &spec(
                vec![
                    q("a", "x", "A", p),
                    q("b", "x", "B", p),
                    q("d_a", "y", "A", d),
                ],
                ab.clone(),
            ),
        )
        .expect("valid plan");
        assert_eq!(ok.pairs.len(), 1);
        assert_eq!(
            (ok.pairs[0].3, ok.pairs[0].4),
            (Operand::Quantity(0), Operand::Quantity(1))
        );
    }

    #[test]
    fn aggregates_are_checked_and_compared_like_quantities() {
        let params = names(&["a", "b"]);
        let derived = names(&["d_a", "d_b"]);
        let p = QuantityKind::Parameter;
        let mean = |group: &str, of: &[&str]| Aggregate {
            name: "y".into(),
            group: group.into(),
            unit: String::new(),
            of: names(of),
            note: "mean".into(),
        };
        let with = |aggregates: Vec<Aggregate>| SummarySpec {
            quantities: vec![q("a", "x", "A", p)],
            aggregates,
            comparisons: ComparisonSpec {
                names: names(&["y"]),
                groups: names(&["A", "B"]),
            },
            data: Vec::new(),
            model: None,
        };
        let err = |s: SummarySpec| {
            SummaryPlan::new(&params, &derived, &s)
                .unwrap_err()
                .to_string()
        };
        assert!(err(with(vec![mean("A", &[]), mean("B", &["b"])])).contains("no columns"));
        assert!(err(with(vec![mean("A", &["zz"]), mean("B", &["b"])])).contains("\"zz\""));
        let ok = SummaryPlan::new(
            &params,
            &derived,
            &with(vec![mean("A", &["a", "b"]), mean("B", &["d_b"])]),
        )
        .expect("valid plan");
        assert_eq!(ok.pairs.len(), 1);
        assert_eq!(ok.pairs[0].2, "mean");
        assert_eq!(
            (ok.pairs[0].3, ok.pairs[0].4),
            (Operand::Aggregate(0), Operand::Aggregate(1))
        );
    }
}
