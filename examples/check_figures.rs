//! Reads SVG figures and lists what makes them hard to read (`slipbayes::plot::check`): axes
//! without two tick labels, text over data or over other text, legend boxes over data, text
//! cut off at the edge or smaller than 11 pixels.
//!
//! `cargo run --release --example check_figures -- reports/demo/figures/*.svg`
//! Exit status 1 when any figure has a problem.

use std::process::ExitCode;

fn main() -> ExitCode {
    let mut failed = false;
    for path in std::env::args().skip(1) {
        let svg = match std::fs::read_to_string(&path) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{path}: {e}");
                failed = true;
                continue;
            }
        };
        let check = slipbayes::plot::check::check_svg(&svg);
        if check.problems.is_empty() {
            println!(
                "{path}: ok ({} axes, {} texts)",
                check.axes.len(),
                check.texts.len()
            );
        } else {
            failed = true;
            println!("{path}: {} problem(s)", check.problems.len());
            for p in &check.problems {
                println!("  {p}");
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
