//! Errors of the ash backend.

use ash::vk;
use std::fmt;
use vrrt_core::plan::{BufferId, PlanError};

/// Errors of [`AshExecutor`](crate::AshExecutor).
#[derive(Debug)]
pub enum AshError {
    /// No usable Vulkan implementation: the loader is missing, instance creation failed, or no
    /// physical device offers Vulkan 1.2, a compute queue and the `vulkanMemoryModel` feature.
    /// Displays as `no Vulkan adapter: {reason}`.
    NoAdapter(String),
    /// Validation was requested but `VK_LAYER_KHRONOS_validation` (or `VK_EXT_debug_utils`) is not
    /// installed.
    ValidationUnavailable(String),
    /// A Vulkan call failed.
    Vulkan {
        /// The Vulkan function (or step) that failed.
        call: &'static str,
        /// Its result code.
        result: vk::Result,
    },
    /// The pass does not match its kernel.
    Plan(PlanError),
    /// A buffer id this executor did not create (or already destroyed).
    UnknownBuffer(BufferId),
    /// A write, read or indirect-argument access beyond the end of a buffer.
    OutOfRange {
        /// The buffer.
        buffer: BufferId,
        /// Bytes asked for (end of the access).
        bytes: u64,
        /// Bytes the buffer has.
        size: u64,
    },
    /// Buffer sizes must be multiples of 4 bytes.
    UnalignedSize(u64),
    /// The same buffer bound twice in one pass, or an indirect-argument buffer that the pass also
    /// writes.
    AliasedBinding(BufferId),
    /// A buffer is larger than the device's `maxStorageBufferRange`.
    BindingTooLarge {
        /// The buffer.
        buffer: BufferId,
        /// Its size in bytes.
        size: u64,
        /// The device limit in bytes.
        max: u32,
    },
    /// A direct dispatch exceeds `maxComputeWorkGroupCount`.
    TooManyGroups {
        /// Kernel entry point.
        entry: &'static str,
        /// Workgroups asked for.
        groups: [u32; 3],
        /// The device limit.
        max: [u32; 3],
    },
    /// No memory type satisfies a buffer's requirements.
    NoMemoryType(&'static str),
    /// The embedded SPIR-V module is malformed.
    BadSpirv(String),
    /// The SPIR-V module has no entry point of this name.
    MissingEntryPoint(&'static str),
    /// The buffer is referenced by a [`Recording`](crate::Recording) not yet retired.
    BufferInUse(BufferId),
}

impl AshError {
    pub(crate) fn vk(call: &'static str) -> impl FnOnce(vk::Result) -> AshError {
        move |result| AshError::Vulkan { call, result }
    }
}

impl fmt::Display for AshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AshError::NoAdapter(reason) => write!(f, "no Vulkan adapter: {reason}"),
            AshError::ValidationUnavailable(what) => {
                write!(f, "Vulkan validation requested but unavailable: {what}")
            }
            AshError::Vulkan { call, result } => write!(f, "{call} failed: {result}"),
            AshError::Plan(e) => write!(f, "{e}"),
            AshError::UnknownBuffer(b) => write!(f, "unknown buffer {b:?}"),
            AshError::OutOfRange {
                buffer,
                bytes,
                size,
            } => {
                write!(
                    f,
                    "{bytes} bytes do not fit buffer {buffer:?} of {size} bytes"
                )
            }
            AshError::UnalignedSize(s) => write!(f, "buffer size {s} is not a multiple of 4"),
            AshError::AliasedBinding(b) => write!(f, "buffer {b:?} bound twice in one pass"),
            AshError::BindingTooLarge { buffer, size, max } => write!(
                f,
                "buffer {buffer:?} of {size} bytes exceeds maxStorageBufferRange ({max} bytes)"
            ),
            AshError::TooManyGroups { entry, groups, max } => write!(
                f,
                "pass `{entry}`: {groups:?} workgroups exceed maxComputeWorkGroupCount {max:?}"
            ),
            AshError::NoMemoryType(what) => write!(f, "no suitable memory type for {what}"),
            AshError::BadSpirv(why) => write!(f, "invalid SPIR-V module: {why}"),
            AshError::MissingEntryPoint(e) => write!(f, "SPIR-V module has no entry point `{e}`"),
            AshError::BufferInUse(b) => {
                write!(
                    f,
                    "buffer {b:?} is used by a recording that was not retired"
                )
            }
        }
    }
}

impl std::error::Error for AshError {}

impl From<PlanError> for AshError {
    fn from(e: PlanError) -> Self {
        AshError::Plan(e)
    }
}
