//! The `vrrt` command: `run`, `reference`, `info` and `bench`. Every error is one line on
//! stderr and exit code 2.

use clap::{Parser, Subcommand};
use std::process::ExitCode;
use vrrt_cli::{bench, info, reference, run};

/// VRRT-rs: variable rate ray tracing on SVGF.
#[derive(Parser)]
#[command(name = "vrrt", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene through a denoiser and measure it against references.
    Run(run::RunArgs),
    /// Trace (and cache) the references of a scene's frames.
    Reference(reference::ReferenceArgs),
    /// List backends and adapters, and what `auto` would pick (or, with `--settings`, print the
    /// default denoiser settings).
    Info(info::InfoArgs),
    /// Error-versus-cost matrix over denoiser configurations, budgets, signals, scenes and
    /// backends.
    Bench(bench::BenchArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Run(a) => run::run(a),
        Command::Reference(a) => reference::run(a),
        Command::Info(a) => info::run(a),
        Command::Bench(a) => bench::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
