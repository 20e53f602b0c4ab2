//! The `minos` command line. Each subcommand lives in `cmd/<name>.rs` and only turns flags
//! into library configuration and reports results; the work happens in the library.

mod cmd;

fn main() -> std::process::ExitCode {
    cmd::main()
}
