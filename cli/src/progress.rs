//! A progress bar on stderr for sampler runs (indicatif), silent when stderr is not a
//! terminal or when asked to be quiet.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use slipbayes::sampler::{Observer, Progress, RunReport, RunStart};

/// How often the text next to the bar is refreshed (formatting it every step would cost
/// more than a cheap step).
const REFRESH: Duration = Duration::from_millis(100);

/// Shows steps, acceptance, the current τ_max estimate and the ETA.
#[derive(Debug)]
pub struct ProgressBarObserver {
    bar: Option<ProgressBar>,
    last_refresh: Option<Instant>,
}

impl ProgressBarObserver {
    /// A bar on stderr; hidden when `quiet` or when stderr is not a terminal.
    pub fn new(quiet: bool) -> Self {
        let visible = !quiet && std::io::stderr().is_terminal();
        Self {
            bar: visible.then(|| {
                let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::stderr());
                let style = ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} steps {msg}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar());
                bar.set_style(style);
                bar
            }),
            last_refresh: None,
        }
    }

    /// Whether anything will be drawn.
    pub fn is_visible(&self) -> bool {
        self.bar.is_some()
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

impl Observer for ProgressBarObserver {
    fn on_start(&mut self, start: &RunStart) {
        if let Some(bar) = &self.bar {
            bar.set_length(start.last_step);
            bar.set_position(start.first_step);
            bar.set_message(if start.until_converged {
                "(until converged; length is the cap)"
            } else {
                ""
            });
        }
    }

    fn on_step(&mut self, p: &Progress) {
        let Some(bar) = &self.bar else { return };
        bar.set_position(p.step);
        let now = Instant::now();
        if self
            .last_refresh
            .is_some_and(|t| now.duration_since(t) < REFRESH)
        {
            return;
        }
        self.last_refresh = Some(now);
        let tau = p
            .tau_max
            .map_or_else(|| "τ ?".to_string(), |t| format!("τ_max {t:.1}"));
        let eta = p.eta.map_or_else(|| "?".to_string(), format_eta);
        // NaN when every update so far was a slice update (no proposal to accept).
        let acc = if p.acceptance.is_nan() {
            "acc –".to_string()
        } else {
            format!("acc {:.2}", p.acceptance)
        };
        bar.set_message(format!("{acc}  {tau}  ETA {eta}"));
    }

    fn on_finish(&mut self, _report: Option<&RunReport>) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quiet_bar_is_hidden_and_eta_is_readable() {
        let mut o = ProgressBarObserver::new(true);
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
}
