//! Library side of the `vrrt` command: backend selection, shared by the CLI, the bench and the
//! tests, and one module per subcommand.

pub mod backend;
pub mod bench;
pub mod info;
pub mod limits;
pub mod memory;
pub mod outdir;
pub mod passes;
pub mod plot;
pub mod progress;
pub mod reference;
pub mod run;
pub mod session;
pub mod settings;
