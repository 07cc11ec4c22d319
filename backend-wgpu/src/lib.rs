//! The wgpu backend of VRRT-rs: runs the rust-gpu kernels of `vrrt-spirv` (`shaders/vrrt.spv`)
//! through wgpu on Vulkan.
//!
//! The SPIR-V module is embedded at build time and translated by naga (`ShaderSource::SpirV`),
//! which wgpu validates like any other shader; one compute pipeline per
//! [`KernelDesc::entry`](vrrt_core::executor::KernelDesc) is created on first use and cached.
//! Kernels take their parameters as *immediates* (Vulkan push constants,
//! [`wgpu::Features::IMMEDIATES`]) and their storage buffers at group 0, binding `i`.
//!
//! Two ways to use it:
//! - **Standalone** ([`WgpuExecutor::new_headless`]): the executor owns a device and queue and
//!   implements [`Executor`](vrrt_core::executor::Executor): passes are recorded into a pending
//!   command encoder, submitted by [`Executor::read_buffer`](vrrt_core::executor::Executor::read_buffer)
//!   / [`Executor::finish`](vrrt_core::executor::Executor::finish), which wait for the GPU.
//! - **Embedded in an engine** ([`WgpuExecutor::from_device`] + [`WgpuExecutor::encode`]): the
//!   executor uses the application's device and queue and records passes into the
//!   application's own [`wgpu::CommandEncoder`]. Buffers can be shared both ways
//!   ([`WgpuExecutor::buffer`], [`WgpuExecutor::import_buffer`]), and the denoiser reads the
//!   engine's G-buffer textures where they are ([`WgpuExecutor::import_texture`]).
//!
//! wgpu tracks buffer usages itself: the barriers between a pass that writes a buffer and a later
//! pass, copy or indirect dispatch that reads it are inserted automatically, within one command
//! encoder and across submissions on the same queue.
//!
//! Source layout, one responsibility per module: `executor` (device setup, the embedding API and
//! the [`Executor`](vrrt_core::executor::Executor) impl), `buffers`, `textures`, `pipelines`, `dispatch`
//! (recording passes), `submit` (submission and readback), `timings` (GPU timestamps), `error`,
//! and [`validation`] (counting validation errors).

mod buffers;
mod dispatch;
mod error;
mod executor;
mod pipelines;
mod submit;
mod textures;
mod timings;
pub mod validation;

pub use error::WgpuError;
pub use executor::{WgpuExecutor, WgpuOptions};
pub use vrrt_core::executor::ExecError;

/// The embedded SPIR-V module, from `vrrt-spirv` (which ships `shaders/vrrt.spv`).
pub use vrrt_spirv::SPIRV;

/// Immediate (push-constant) bytes a headless device is created with, at least.
pub const MIN_IMMEDIATE_SIZE: u32 = 128;

/// Buffer usages of every buffer the executor creates.
pub const BUFFER_USAGES: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::INDIRECT);
