//! SPIR-V entry points: one `#[spirv(compute)]` function per kernel, generated from the kernel
//! table in `vrrt-core` (`kernels::table`), so bindings, workgroup sizes and push constants cannot
//! drift from what the backends read. Built by `shaders-builder` into `shaders/vrrt.spv`.
#![cfg_attr(target_arch = "spirv", no_std)]
#![allow(missing_docs)]

use spirv_std::spirv;

vrrt_core::spirv_entries!();
