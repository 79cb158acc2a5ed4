use std::process::ExitCode;

fn main() -> ExitCode {
    slipbayes_cli::main()
}
