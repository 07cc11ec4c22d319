//! The SPIR-V module of VRRT-rs: every kernel of `vrrt-core` as a `#[spirv(compute)]` entry point,
//! built by rust-gpu 0.11 from the `vrrt-shaders` crate on a pinned nightly.
//!
//! The module is built ahead of time and checked in (`shaders-builder/build.sh` writes it,
//! `--check` fails CI when it is stale), so every crate that embeds it builds on stable Rust
//! alone. It is a crate of its own so that the wgpu and ash backends embed the same file from
//! inside a package: a published crate cannot read files outside its directory.
//!
//! ```
//! // A SPIR-V module starts with its magic number (here little-endian, as rust-gpu writes it).
//! assert_eq!(vrrt_spirv::SPIRV[..4], 0x0723_0203u32.to_le_bytes());
//! assert_eq!(vrrt_spirv::SPIRV.len() % 4, 0);
//! ```
#![no_std]

/// The module's bytes, as rust-gpu wrote them (little-endian words).
///
/// `include_bytes!` guarantees no alignment, so the bytes cannot be cast to `&[u32]` in place:
/// copy them into words first (`ash::util::read_spv`, `bytemuck::pod_collect_to_vec`), as both
/// backends do, which also lets them accept either byte order.
pub static SPIRV: &[u8] = include_bytes!("../vrrt.spv");
