//! The `vrrt` command: `run`, `reference`, `info`, `bench` and `fetch`. Every error is one line on
//! stderr and exit code 2.

use clap::Parser;
use std::process::ExitCode;
use vrrt_cli::{bench, fetch, info, reference, run, Cli, Command};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Run(a) => run::run(a),
        Command::Reference(a) => reference::run(a),
        Command::Info(a) => info::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Fetch(a) => fetch::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", vrrt_cli::one_line(&e));
            ExitCode::from(2)
        }
    }
}
