//! # vrrt-ash
//!
//! The raw-Vulkan backend of VRRT-rs, on [`ash`]. It runs the kernels of `vrrt-core` from the one
//! SPIR-V module built by rust-gpu (`shaders/vrrt.spv`, shipped by `vrrt-spirv`), either on a
//! device it creates itself ([`AshExecutor::new_headless`]) or inside an engine's device
//! ([`AshExecutor::from_raw`] + [`AshExecutor::record_into`]).
//!
//! ## What it does with Vulkan
//! - **Buffers**: device-local storage buffers (usage `STORAGE | TRANSFER_SRC | TRANSFER_DST |
//!   INDIRECT`), one memory allocation each, zero-filled at creation with `vkCmdFillBuffer`.
//!   Uploads go through a host-visible staging ring, readbacks through a host-visible (preferably
//!   host-cached) buffer; both use host-coherent memory.
//! - **Pipelines**: one compute pipeline per [`KernelDesc::entry`], created on first use and
//!   cached; descriptor set 0 holds one storage buffer per binding, in order (a sampled image
//!   where the kernel reads an engine texture: [`AshExecutor::import_image`]); one push-constant
//!   range of `params_size` bytes (none if 0).
//! - **Recording**: everything (fills, uploads, dispatches, readback copies) is recorded, in call
//!   order, into one command buffer that is submitted by [`Executor::finish`] /
//!   [`Executor::read_buffer`] (or [`AshExecutor::flush`]) and waited on with a fence. Descriptor
//!   sets come from pools that are reset once that submission has completed.
//! - **Synchronization**: every buffer's accesses are tracked; before a command, buffer memory
//!   barriers are inserted exactly where a hazard exists (compute→compute read-after-write,
//!   write-after-write and write-after-read; transfer↔compute around uploads and readbacks;
//!   compute→indirect for [`Groups::Indirect`]). Independent passes get no barrier.
//! - **Timestamps**: when the queue family has `timestampValidBits > 0`, each dispatch is
//!   bracketed by two timestamps (at the compute-shader stage); [`Executor::timings`] reports them
//!   in milliseconds once the work has completed.
//!
//! No per-pixel math lives here: the backend only moves bytes and launches work.
//!
//! ## Source layout
//! One responsibility per module: `executor` (the executor's state, construction, accessors and
//! the [`Executor`] impl), `buffers` (storage buffers), `transfer` (uploads and readbacks),
//! `stream` (the executor's command buffer: recording, submission, waiting), `pipelines`,
//! `dispatch` (checking and recording a pass), `embed` (recording into an engine's command
//! buffer), and below them `setup` (instance and device), `alloc` (memory), `arena` (descriptor
//! sets and timestamp queries), `track` (barriers), `spirv` (module parsing) and `error`.

#![deny(unsafe_op_in_unsafe_fn)]

mod alloc;
mod arena;
mod buffers;
mod dispatch;
mod embed;
mod error;
mod executor;
mod pipelines;
mod setup;
mod spirv;
mod stream;
mod textures;
mod track;
mod transfer;

pub use ash;
pub use embed::{RawVulkan, Recording};
pub use error::AshError;
pub use executor::AshExecutor;
pub use vrrt_core::executor::ExecError;

#[cfg(doc)]
use vrrt_core::executor::{Executor, Groups, KernelDesc};

/// Options of [`AshExecutor::new_headless`].
#[derive(Clone, Debug)]
pub struct AshOptions {
    /// Enable `VK_LAYER_KHRONOS_validation` with a `VK_EXT_debug_utils` messenger that logs to
    /// stderr and counts errors (see [`AshExecutor::validation_errors`]). Construction fails if the
    /// layer is not installed. Default: `true` iff the environment has `VRRT_VALIDATION=1`.
    pub validation: bool,
    /// With `validation`, also turn on the layer's synchronization validation (hazards between
    /// commands are reported as errors) when `VK_EXT_validation_features` is available.
    /// Default: `true`.
    pub sync_validation: bool,
}

impl Default for AshOptions {
    fn default() -> Self {
        AshOptions {
            validation: std::env::var("VRRT_VALIDATION").is_ok_and(|v| v == "1"),
            sync_validation: true,
        }
    }
}

/// Kind of physical device.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum AdapterType {
    /// A discrete GPU.
    DiscreteGpu,
    /// A GPU integrated with the CPU.
    IntegratedGpu,
    /// A virtualized GPU.
    VirtualGpu,
    /// A software implementation on the CPU (e.g. lavapipe).
    Cpu,
    /// Anything else.
    Other,
}

/// The physical device an executor runs on.
#[derive(Clone, Debug, PartialEq)]
pub struct AdapterInfo {
    /// `deviceName`, e.g. `llvmpipe (LLVM 15, 256 bits)`.
    pub name: String,
    /// Kind of device.
    pub adapter_type: AdapterType,
    /// PCI vendor id.
    pub vendor_id: u32,
    /// Vendor-specific device id.
    pub device_id: u32,
    /// Vulkan version the device supports (`vk::api_version_*` to decode).
    pub api_version: u32,
    /// Vendor-specific driver version.
    pub driver_version: u32,
    /// Whether the executor's queue writes timestamps (`timestampValidBits > 0`).
    pub timestamps: bool,
    /// Nanoseconds per timestamp tick (`timestampPeriod`).
    pub timestamp_period_ns: f32,
}
