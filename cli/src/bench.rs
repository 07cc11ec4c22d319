//! `vrrt bench`.

use anyhow::Result;

/// Options of `vrrt bench`.
#[derive(Clone, Debug, clap::Args)]
pub struct BenchArgs {
    /// Quick matrix.
    #[arg(long)]
    pub quick: bool,
}

/// Runs `vrrt bench`.
pub fn run(_args: &BenchArgs) -> Result<()> {
    Ok(())
}
