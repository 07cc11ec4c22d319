//! Library side of the `vrrt` command: backend selection, shared by the CLI, the bench and the
//! tests.

pub mod backend;
