//! # vrrt-core
//!
//! The `no_std` heart of VRRT-rs. Every piece of per-pixel logic (denoiser, load balancer,
//! sampling, tracing) is a plain function here, compiled twice: to SPIR-V by rust-gpu (through the
//! thin entry points of `vrrt-shaders`) and natively for the CPU backend. Backends only move bytes
//! and launch work; they read *what* to launch from [`executor`].
//!
//! Layout rules shared by every kernel:
//! - Images are row-major storage buffers; signal planes are stacked along `z`
//!   (`index = (z * height + y) * width + x`), so one dispatch serves up to four signals.
//! - Buffer element types are `#[repr(C)]` structs of 4-byte scalars (no `Vec3`/`Vec4`, whose
//!   alignment differs between targets).
//! - Float functions that differ between targets go through [`math`]; atomics through [`atomic`].
#![no_std]
// `math::rsqrt` emits GLSL.std.450 `InverseSqrt` by `asm!`, as spirv-std does for its own
// extended instructions (the shader build runs on the pinned nightly).
#![cfg_attr(target_arch = "spirv", feature(asm_experimental_arch))]
// The kernel table (`kernels::table`) is expanded by one recursive macro, a few steps per binding.
#![recursion_limit = "512"]
#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > 0.0)` is how kernels say "not positive, or NaN" in one comparison; `partial_cmp` would
// not compile to the same single instruction on every target.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

#[cfg(feature = "std")]
extern crate std;

pub mod atomic;
pub mod binary16;
pub mod blue_noise;
#[cfg(not(target_arch = "spirv"))]
pub mod budget;
#[cfg(not(target_arch = "spirv"))]
pub mod buffers;
pub mod camera;
pub mod declare;
#[cfg(not(target_arch = "spirv"))]
pub mod denoiser;
#[cfg(not(target_arch = "spirv"))]
pub mod executor;
#[cfg(not(target_arch = "spirv"))]
pub mod frame;
pub mod inputs;
pub mod kernels;
pub mod lanes;
#[cfg(not(target_arch = "spirv"))]
pub mod layout;
pub mod math;
pub mod packing;
pub mod payload;
pub mod quantize;
#[cfg(not(target_arch = "spirv"))]
pub mod reflections;
pub mod sampling;
pub mod sequence;
#[cfg(not(target_arch = "spirv"))]
pub mod settings;
pub mod surface;
pub mod textures;
pub mod trace;

pub use glam;
