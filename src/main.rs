//! `flyarena`: the command line over the flyarena library (see `src/cli.rs`).

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
