//! `vrrt info`: backends, adapters and the `auto` choice.

use anyhow::Result;

/// Runs `vrrt info`.
pub fn run() -> Result<()> {
    Ok(())
}
