//! The `slipbayes` command line, and the tools built on the library.
//!
//! The library crate `slipbayes` does the work; this crate only turns command-line flags into
//! its settings, prints what it returns, and hosts two tools that use it like any outside
//! program would:
//!
//! - [`commands`]: one module per subcommand (`fit`, `demo`, `report`, `simulate`, `import`,
//!   `validate`, `bench`); each parses its flags, calls the library and prints.
//! - [`progress`]: the progress bar (a terminal) or progress lines (batch jobs) of a fit.
//! - [`interrupt`]: Ctrl-C stops a fit after a checkpoint and says how to resume it.
//! - [`validate`]: simulation-based calibration of the one-contact pipeline and the hard cases
//!   (feature `parquet`).
//! - [`mod@bench`]: speed against error, side by side with the Python peer (feature `parquet`).
#![deny(clippy::float_cmp)]

#[cfg(feature = "parquet")]
pub mod bench;
pub mod commands;
pub mod interrupt;
pub mod progress;
#[cfg(feature = "parquet")]
pub mod validate;

pub use commands::main;
