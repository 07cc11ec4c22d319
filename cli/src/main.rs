//! The `vrrt` command.
fn main() {}
