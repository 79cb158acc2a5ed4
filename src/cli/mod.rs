//! The command-line front end: parses arguments and calls the library.
pub mod progress;

use std::process::ExitCode;

/// Entry point of the `slipbayes` binary.
pub fn main() -> ExitCode {
    ExitCode::SUCCESS
}
