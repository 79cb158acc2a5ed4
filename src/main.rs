use std::process::ExitCode;

fn main() -> ExitCode {
    slipbayes::cli::main()
}
