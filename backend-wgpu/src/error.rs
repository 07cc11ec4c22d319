//! Errors of the wgpu backend: what only a wgpu device can report, next to the errors every
//! backend shares ([`ExecError`]: unknown buffers, ranges, sizes, passes that do not match their
//! kernel or alias buffers), which come from `vrrt-core` so that all backends report them alike.

use std::fmt;
use vrrt_core::executor::{BufferId, ExecError, PlanError};

/// Errors of the wgpu backend.
#[derive(Debug)]
pub enum WgpuError {
    /// No Vulkan adapter could be found (no driver, or the loader is missing).
    NoAdapter(String),
    /// The adapter refused to create a device.
    RequestDevice(String),
    /// The device lacks features the executor needs.
    MissingFeatures(wgpu::Features),
    /// A device limit is too low for a kernel or for the executor.
    Limit(String),
    /// The embedded module is not SPIR-V.
    InvalidSpirv(String),
    /// wgpu reported an error (validation, out of memory, internal) for an operation of the
    /// executor. Also counted by [`WgpuExecutor::validation_errors`](crate::WgpuExecutor::validation_errors).
    Wgpu(String),
    /// Mapping a buffer or waiting for the device failed.
    Device(String),
    /// An error every backend reports alike: a pass that does not match its kernel, an unknown
    /// buffer, an access out of range, an unaligned size, aliased bindings.
    Exec(ExecError),
    /// An application's texture cannot be imported (`WgpuExecutor::import_texture`).
    Texture(String),
    /// A buffer (typically an imported one) lacks a usage the operation needs.
    MissingUsage {
        /// The buffer.
        buffer: BufferId,
        /// Usages it lacks.
        missing: wgpu::BufferUsages,
    },
}

impl fmt::Display for WgpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WgpuError::NoAdapter(why) => write!(f, "no Vulkan adapter: {why}"),
            WgpuError::RequestDevice(why) => write!(f, "cannot create a wgpu device: {why}"),
            WgpuError::MissingFeatures(missing) => {
                write!(f, "the wgpu device lacks required features: {missing:?}")
            }
            WgpuError::Limit(why) => write!(f, "device limit too low: {why}"),
            WgpuError::InvalidSpirv(why) => write!(f, "invalid SPIR-V module: {why}"),
            WgpuError::Wgpu(e) => write!(f, "wgpu error: {e}"),
            WgpuError::Device(e) => write!(f, "device error: {e}"),
            WgpuError::Exec(e) => write!(f, "{e}"),
            WgpuError::Texture(why) => write!(f, "cannot import the texture: it {why}"),
            WgpuError::MissingUsage { buffer, missing } => {
                write!(f, "buffer {buffer:?} lacks usages {missing:?}")
            }
        }
    }
}

impl std::error::Error for WgpuError {}

impl From<ExecError> for WgpuError {
    fn from(e: ExecError) -> Self {
        WgpuError::Exec(e)
    }
}

impl From<PlanError> for WgpuError {
    fn from(e: PlanError) -> Self {
        WgpuError::Exec(ExecError::Plan(e))
    }
}
