//! The side-by-side section of `speed-vs-error.md`: every peer's checks against ours, then one
//! table of every sampler (evaluations, ESS per 1,000 evaluations and per second) and NUTS's.

use std::fmt::Write as _;

use super::super::nuts::{NutsComparison, NutsOutcome};
use super::super::peer::{PeerComparison, PeerOutcome};
use super::super::throughput::MovesRun;
use super::{agree, best_peer_lines, g, log_density_line, ran_peers};

/// The side-by-side section: every peer's checks, then one table of every sampler.
pub(super) fn peer_section(
    s: &mut String,
    threads: usize,
    reference_steps: u64,
    p: &PeerComparison,
    fit_moves: Option<&MovesRun>,
    others: &[PeerOutcome],
    outcome: Option<&NutsOutcome>,
) {
    let nuts = match outcome {
        Some(NutsOutcome::Ran(n)) => Some(n),
        _ => None,
    };
    let extras: Vec<&PeerComparison> = ran_peers(p, others).into_iter().skip(1).collect();
    let _ = writeln!(s, "\n## Side by side with the Python peers\n");
    let _ = writeln!(
        s,
        "`{}` (versions: {}) fits the one-contact posterior (`benches/peer/one_contact.toml`) \
         with {}, `vectorize=True`, one process, from the same initial walkers, with the same \
         walkers and steps.",
        super::super::peer::PEER_SCRIPT,
        p.versions,
        p.sampler.description(),
    );
    for outcome in others {
        match outcome {
            PeerOutcome::Ran(c) => {
                let _ = writeln!(
                    s,
                    "The same script with `--sampler {}` (versions: {}) fits it with {}, \
                     vectorised too, from the same walkers, with the same walkers and steps.",
                    c.sampler.option(),
                    c.versions,
                    c.sampler.description(),
                );
            }
            PeerOutcome::Skipped { sampler, reason } => {
                let _ = writeln!(
                    s,
                    "The {} peer (`{} --sampler {}`) was skipped: {reason}",
                    sampler.label(),
                    super::super::peer::PEER_SCRIPT,
                    sampler.option(),
                );
            }
        }
    }
    match outcome {
        Some(NutsOutcome::Ran(n)) => {
            let _ = writeln!(
                s,
                "`{}` (versions: {}) fits the same posterior in the same coordinates with \
                 NumPyro's NUTS on JAX (CPU, float64), the gradient taken through the elastic \
                 solve (implicit derivative of its Newton root): {} warmup iterations (step \
                 size and {} mass matrix adapted, target acceptance {}, tree depth at most {}) \
                 and {} kept draws per chain, chains started from our initial walkers, several \
                 chains in parallel one per core. JAX's compile time is measured apart and \
                 left out of its times.",
                super::super::nuts::NUTS_SCRIPT,
                n.versions,
                n.plan.warmup,
                if n.plan.dense_mass {
                    "dense"
                } else {
                    "diagonal"
                },
                n.plan.target_accept,
                n.plan.max_tree_depth,
                n.plan.draws,
            );
        }
        Some(NutsOutcome::Skipped { reason }) => {
            let _ = writeln!(
                s,
                "The NUTS peer (`{}`) was skipped: {reason}",
                super::super::nuts::NUTS_SCRIPT
            );
        }
        None => {}
    }
    let _ = writeln!(
        s,
        "All chains go through the same estimator here (bulk ESS with every walker of every \
         ensemble, or every NUTS chain, as a chain). Log-density evaluations count every point \
         a sampler asked for, the initial walkers' included: ours as our sampler counts them, \
         the Python ensemble samplers' by a counter around the log-density they are given (a \
         vectorised call adds its number of points; zeus' slice moves make several calls per \
         step).\n"
    );
    if let Some(f) = fit_moves {
        let _ = writeln!(
            s,
            "slipbayes samples this problem twice, from {} initial walkers as the peers: \
             with the stretch move (emcee's, so that per evaluation only the implementations \
             differ) and with `slipbayes fit`'s default moves ({}; joint updates, as every run \
             of this bench).\n",
            if f.same_start {
                "the same"
            } else {
                "NOT the same"
            },
            f.moves,
        );
    }
    log_density_line(s, 1, "emcee peer", &p.log_density);
    let mut item = 2;
    for c in &extras {
        log_density_line(
            s,
            item,
            &format!("{} peer", c.sampler.label()),
            &c.log_density,
        );
        item += 1;
    }
    if let Some(n) = nuts {
        log_density_line(s, item, "NUTS peer", &n.log_density);
        let _ = writeln!(
            s,
            "{}. NUTS peer: its autodiff gradient (through the elastic solve) against central \
             differences of its log-density at {} posterior draws: largest difference {} of \
             the gradient's largest component (required ≤ {:e}) → **{}**.",
            item + 1,
            n.gradient.points,
            g(n.gradient.max_error),
            super::super::nuts::GRADIENT_RTOL,
            agree(n.gradient.agrees()),
        );
        item += 2;
    }
    let _ = writeln!(
        s,
        "{item}. Medians (log-coordinates) within {} MCSE of ours: emcee **{}**{}{}.\n",
        super::super::peer::MEDIAN_MCSE_FACTOR,
        agree(p.medians_agree),
        extras
            .iter()
            .map(|c| format!(", {} **{}**", c.sampler.label(), agree(c.medians_agree)))
            .collect::<String>(),
        nuts.map_or(String::new(), |n| n
            .runs
            .iter()
            .map(|run| format!(
                ", NUTS {} chain(s) **{}**",
                run.chains,
                agree(run.medians_agree)
            ))
            .collect()),
    );
    let mut header = "| coordinate | our median | emcee median | |Δ| / MCSE |".to_owned();
    let mut rule = "|---|---:|---:|---:|".to_owned();
    for c in &extras {
        let _ = write!(header, " {} median | |Δ| / MCSE |", c.sampler.label());
        rule.push_str("---:|---:|");
    }
    for run in nuts.iter().flat_map(|n| &n.runs) {
        let _ = write!(
            header,
            " NUTS {} chain(s) median | |Δ| / MCSE |",
            run.chains
        );
        rule.push_str("---:|---:|");
    }
    let _ = writeln!(s, "{header}\n{rule}");
    for (i, c) in p.medians.iter().enumerate() {
        let _ = write!(
            s,
            "| {} | {:.6} | {:.6} | {} |",
            c.name,
            c.ours,
            c.peer,
            g(c.z)
        );
        for other in &extras {
            let c = &other.medians[i];
            let _ = write!(s, " {:.6} | {} |", c.peer, g(c.z));
        }
        for run in nuts.iter().flat_map(|n| &n.runs) {
            let c = &run.medians[i];
            let _ = write!(s, " {:.6} | {} |", c.peer, g(c.z));
        }
        s.push('\n');
    }
    samplers_table(s, threads, p, fit_moves, &extras, nuts);
    let _ = writeln!(
        s,
        "\nAgainst the best Python ensemble sampler that passed the checks (by ESS per 1,000 \
         evaluations, and by ESS/s):\n"
    );
    best_peer_lines(s, p, fit_moves, others, threads);
    let _ = write!(
        s,
        "\nError of the medians against our long one-contact reference run ({} steps, \
         another seed), in reference sds (largest over coordinates): slipbayes {} after {} s, \
         emcee {} after {} s",
        reference_steps,
        g(p.ours_error),
        g(p.ours_sampling_s[1]),
        g(p.peer_error),
        g(p.peer_sampling_s),
    );
    for c in &extras {
        let _ = write!(
            s,
            ", {} {} after {} s",
            c.sampler.label(),
            g(c.peer_error),
            g(c.peer_sampling_s)
        );
    }
    for run in nuts.iter().flat_map(|n| &n.runs) {
        let _ = write!(
            s,
            ", NUTS ({} chain(s)) {} after {} s",
            run.chains,
            g(run.error),
            g(run.warmup_s + run.sampling_s)
        );
    }
    let _ = writeln!(
        s,
        ". At emcee's wall time slipbayes could have run about {}× more steps.",
        g(p.peer_sampling_s / p.ours_sampling_s[1]),
    );
    if let Some(n) = nuts {
        nuts_table(s, n, threads, p.ours_ess_per_s[1]);
    }
}

/// Every sampler in one table: cost of a density, evaluations, time, ESS, ESS per 1,000
/// evaluations, ESS/s and our stretch move's ratio to it. NUTS's script counts the gradients
/// of its kept draws only, not of its warmup, so its row has no evaluation count.
fn samplers_table(
    s: &mut String,
    threads: usize,
    p: &PeerComparison,
    fit_moves: Option<&MovesRun>,
    extras: &[&PeerComparison],
    nuts: Option<&NutsComparison>,
) {
    let ours = p.ours_ess_per_s[1];
    let _ = writeln!(
        s,
        "\n| sampler | draws for the ESS | time per log-density (µs) | log-density evaluations | \
         sampling s | min ESS | ESS per 1,000 evaluations | ESS/s | slipbayes stretch \
         ({threads} threads) ESS/s ÷ this |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let kept = p.steps - p.steps / 4;
    let ensemble_draws = format!(
        "{}×{} walkers × {} steps after {} burn-in",
        p.ensembles,
        p.walkers,
        kept,
        p.steps - kept
    );
    let mut rows = vec![
        (
            "slipbayes stretch, 1 thread".to_owned(),
            g(p.ours_us_per_eval),
            p.ours_evaluations,
            p.ours_sampling_s[0],
            p.ours_ess_min,
            p.ours_ess_per_s[0],
        ),
        (
            format!("slipbayes stretch, {threads} threads"),
            String::new(),
            p.ours_evaluations,
            p.ours_sampling_s[1],
            p.ours_ess_min,
            p.ours_ess_per_s[1],
        ),
    ];
    if let Some(f) = fit_moves {
        rows.push((
            format!(
                "slipbayes, `fit`'s default moves ({}), {} threads{}",
                f.moves,
                f.threads,
                if f.same_start {
                    ""
                } else {
                    " (NOT the same start)"
                }
            ),
            String::new(),
            f.evaluations,
            f.sampling_s,
            f.ess_min,
            f.ess_per_s,
        ));
    }
    for c in std::iter::once(p).chain(extras.iter().copied()) {
        rows.push((
            format!("{} + numpy/scipy", c.sampler.label()),
            format!(
                "{} vectorised, {} single",
                g(c.peer_us_per_eval_vectorised),
                g(c.peer_us_per_eval_single)
            ),
            c.peer_evaluations,
            c.peer_sampling_s,
            c.peer_ess_min,
            c.peer_ess_per_s,
        ));
    }
    for (who, cost, evaluations, secs, ess, per_s) in rows {
        let _ = writeln!(
            s,
            "| {who} | {ensemble_draws} | {cost} | {evaluations} | {} | {} | {} | {} | {} |",
            g(secs),
            g(ess),
            g(super::super::peer::ess_per_kilo_eval(ess, evaluations)),
            g(per_s),
            g(ours / per_s)
        );
    }
    for (n, run) in nuts
        .iter()
        .flat_map(|n| n.runs.iter().map(move |run| (n, run)))
    {
        let _ = writeln!(
            s,
            "| NumPyro NUTS, {} chain(s) | {}×{} draws after {} warmup | {} with gradient |  | {} \
             (warmup {} + draws {}) | {} |  | {} | {} |",
            run.chains,
            run.chains,
            n.plan.draws,
            n.plan.warmup,
            g(n.us_per_gradient),
            g(run.warmup_s + run.sampling_s),
            g(run.warmup_s),
            g(run.sampling_s),
            g(run.ess_min),
            g(run.ess_per_s),
            g(ours / run.ess_per_s)
        );
    }
}

/// What NUTS spent its time on.
fn nuts_table(s: &mut String, n: &NutsComparison, threads: usize, ours_ess_per_s: f64) {
    let _ = writeln!(
        s,
        "\nNUTS in detail (times without JAX's compiling, which is given apart; gradients are \
         the leapfrog steps of the kept draws):\n"
    );
    let _ = writeln!(
        s,
        "| chains | warmup s | draws s | compile s (warmup, draws) | gradients | per draw | \
         divergences | mean acceptance | step size | ESS/s of the draws alone | slipbayes ({threads} \
         threads) ÷ that |"
    );
    let _ = writeln!(s, "|---:|---:|---:|---|---:|---:|---:|---:|---|---:|---:|");
    for run in &n.runs {
        let draws = (run.chains as u64 * n.plan.draws).max(1);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {}, {} | {} | {} | {} | {} | {} | {} | {} |",
            run.chains,
            g(run.warmup_s),
            g(run.sampling_s),
            g(run.warmup_compile_s),
            g(run.sampling_compile_s),
            run.gradients,
            g(run.gradients as f64 / draws as f64),
            run.divergences,
            g(run.accept_prob),
            run.step_size
                .iter()
                .map(|v| g(*v))
                .collect::<Vec<_>>()
                .join(", "),
            g(run.ess_per_s_draws),
            g(ours_ess_per_s / run.ess_per_s_draws),
        );
    }
}
