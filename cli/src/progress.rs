//! Progress of a sampler run on stderr: a bar (indicatif) on a terminal, a line at a steady
//! interval otherwise (nohup, SLURM, CI logs), nothing when asked to be quiet. It also carries
//! the Ctrl-C request to the sampler.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use slipbayes::sampler::{Observer, Progress, RunReport, RunStart};

/// How often the text next to the bar is refreshed (formatting it every step would cost
/// more than a cheap step).
const REFRESH: Duration = Duration::from_millis(100);

/// Default interval between progress lines when stderr is not a terminal: often enough to see
/// a batch job move, rarely enough to keep its log short.
pub const DEFAULT_LINE_EVERY: Duration = Duration::from_secs(10);

#[derive(Debug)]
enum Display {
    Hidden,
    Bar(ProgressBar),
    Lines {
        every: Duration,
        started: Instant,
        last_line: Option<Instant>,
        last_step: u64,
        until_converged: bool,
        /// The latest step, when no line showed it: printed when the run ends, so that a
        /// batch log ends on the step, τ and R̂ the run stopped at.
        unprinted: Option<Progress>,
    },
}

/// Set by nothing: the stop flag of an observer that is never interrupted.
static NEVER: AtomicBool = AtomicBool::new(false);

/// Shows steps, acceptance, the current τ_max and R̂ estimates and the ETA, and asks the
/// sampler to stop once its stop flag is set.
#[derive(Debug)]
pub struct ProgressBarObserver {
    display: Display,
    last_refresh: Option<Instant>,
    // Static because a signal handler sets it.
    stop: &'static AtomicBool,
}

impl ProgressBarObserver {
    /// A bar on stderr when it is a terminal, else a line every `line_every`; nothing when
    /// `quiet`.
    pub fn new(quiet: bool, line_every: Duration) -> Self {
        let display = if quiet {
            Display::Hidden
        } else if std::io::stderr().is_terminal() {
            let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::stderr());
            let style = ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} steps {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar());
            bar.set_style(style);
            Display::Bar(bar)
        } else {
            Display::Lines {
                every: line_every,
                started: Instant::now(),
                last_line: None,
                last_step: 0,
                until_converged: false,
                unprinted: None,
            }
        };
        Self {
            display,
            last_refresh: None,
            stop: &NEVER,
        }
    }

    /// Stops the run at its next step (after a checkpoint) once `flag` is set.
    pub fn stop_when(mut self, flag: &'static AtomicBool) -> Self {
        self.stop = flag;
        self
    }

    /// Whether anything will be drawn.
    pub fn is_visible(&self) -> bool {
        !matches!(self.display, Display::Hidden)
    }
}

fn format_eta(eta: Duration) -> String {
    let s = eta.as_secs();
    if s >= 3600 {
        format!("{}h{:02}m", s / 3600, (s % 3600) / 60)
    } else if s >= 60 {
        format!("{}m{:02}s", s / 60, s % 60)
    } else {
        format!("{s}s")
    }
}

/// `acc 0.32  τ_max 8.0  R̂ 1.042  ETA 3m05s`, with `?` for what is not known yet.
fn status(p: &Progress) -> String {
    // NaN when every update so far was a slice update (no proposal to accept).
    let acc = if p.acceptance.is_nan() {
        "acc –".to_string()
    } else {
        format!("acc {:.2}", p.acceptance)
    };
    let tau = p
        .tau_max
        .map_or_else(|| "τ_max ?".to_string(), |t| format!("τ_max {t:.1}"));
    let r_hat = p
        .r_hat_max
        .map_or_else(|| "R̂ ?".to_string(), |r| format!("R̂ {r:.3}"));
    let eta = p.eta.map_or_else(|| "?".to_string(), format_eta);
    format!("{acc}  {tau}  {r_hat}  ETA {eta}")
}

impl Observer for ProgressBarObserver {
    fn on_start(&mut self, start: &RunStart) {
        match &mut self.display {
            Display::Hidden => {}
            Display::Bar(bar) => {
                bar.set_length(start.last_step);
                bar.set_position(start.first_step);
                bar.set_message(if start.until_converged {
                    "(until converged; length is the cap)"
                } else {
                    ""
                });
            }
            Display::Lines {
                last_step,
                until_converged,
                ..
            } => {
                *last_step = start.last_step;
                *until_converged = start.until_converged;
            }
        }
    }

    fn on_step(&mut self, p: &Progress) {
        let now = Instant::now();
        match &mut self.display {
            Display::Hidden => {}
            Display::Bar(bar) => {
                bar.set_position(p.step);
                if self
                    .last_refresh
                    .is_some_and(|t| now.duration_since(t) < REFRESH)
                {
                    return;
                }
                self.last_refresh = Some(now);
                bar.set_message(status(p));
            }
            Display::Lines {
                every,
                started,
                last_line,
                last_step,
                until_converged,
                unprinted,
            } => {
                if now.duration_since(last_line.unwrap_or(*started)) < *every {
                    *unprinted = Some(*p);
                    return;
                }
                *last_line = Some(now);
                *unprinted = None;
                print_line(
                    p,
                    *last_step,
                    *until_converged,
                    now.duration_since(*started),
                );
            }
        }
    }

    fn on_finish(&mut self, _report: Option<&RunReport>) {
        match &mut self.display {
            Display::Hidden => {}
            Display::Bar(bar) => bar.finish_and_clear(),
            Display::Lines {
                started,
                last_step,
                until_converged,
                unprinted,
                ..
            } => {
                if let Some(p) = unprinted.take() {
                    print_line(&p, *last_step, *until_converged, started.elapsed());
                }
            }
        }
    }

    fn on_note(&mut self, note: &str) {
        match &self.display {
            Display::Hidden => {}
            Display::Bar(bar) => bar.println(format!("note: {note}")),
            Display::Lines { .. } => eprintln!("note: {note}"),
        }
    }

    fn stop_requested(&mut self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// One progress line of a batch job (standard error not a terminal).
fn print_line(p: &Progress, last_step: u64, until_converged: bool, elapsed: Duration) {
    let cap = if until_converged { " (cap)" } else { "" };
    eprintln!(
        "progress: step {}/{last_step}{cap}, {} elapsed, {}",
        p.step,
        format_eta(elapsed),
        status(p)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn progress(tau_max: Option<f64>, r_hat_max: Option<f64>) -> Progress {
        Progress {
            step: 300,
            last_step: 20_000,
            acceptance: 0.321,
            tau_max,
            r_hat_max,
            eta: Some(Duration::from_secs(125)),
        }
    }

    #[test]
    fn quiet_bar_is_hidden_and_eta_is_readable() {
        let mut o = ProgressBarObserver::new(true, DEFAULT_LINE_EVERY);
        assert!(!o.is_visible());
        // Callbacks on a hidden bar do nothing (and must not panic).
        o.on_start(&RunStart {
            first_step: 0,
            last_step: 10,
            until_converged: false,
        });
        o.on_finish(None);
        assert_eq!(format_eta(Duration::from_secs(42)), "42s");
        assert_eq!(format_eta(Duration::from_secs(125)), "2m05s");
        assert_eq!(format_eta(Duration::from_secs(7260)), "2h01m");
    }

    #[test]
    fn status_shows_the_running_tau_and_r_hat_once_known() {
        assert_eq!(
            status(&progress(None, None)),
            "acc 0.32  τ_max ?  R̂ ?  ETA 2m05s"
        );
        assert_eq!(
            status(&progress(Some(8.04), Some(1.0423))),
            "acc 0.32  τ_max 8.0  R̂ 1.042  ETA 2m05s"
        );
    }

    #[test]
    fn the_stop_flag_stops_the_run() {
        static FLAG: AtomicBool = AtomicBool::new(false);
        let mut o = ProgressBarObserver::new(true, DEFAULT_LINE_EVERY).stop_when(&FLAG);
        assert!(!o.stop_requested());
        FLAG.store(true, Ordering::Relaxed);
        assert!(o.stop_requested());
        assert!(!ProgressBarObserver::new(true, DEFAULT_LINE_EVERY).stop_requested());
    }
}
