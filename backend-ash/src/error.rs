//! Errors of the ash backend: what only a Vulkan device can report, next to the errors every
//! backend shares ([`ExecError`]: unknown buffers, ranges, sizes, passes that do not match their
//! kernel or alias buffers), which come from `vrrt-core` so that all backends report them alike.

use ash::vk;
use std::fmt;
use vrrt_core::executor::{BufferId, ExecError, PlanError};

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
    /// An error every backend reports alike: a pass that does not match its kernel, an unknown
    /// (or destroyed) buffer, an access out of range, an unaligned size, a buffer bound twice in
    /// one pass or an indirect-count buffer that the pass also writes.
    Exec(ExecError),
    /// An engine image that cannot be bound, or image data that does not fit its size.
    Texture(String),
    /// A buffer is larger than the device's `maxStorageBufferRange`.
    BindingTooLarge {
        /// The buffer.
        buffer: BufferId,
        /// Its size in bytes.
        size: u64,
        /// The device limit in bytes.
        max: u32,
    },
    /// A buffer larger than the device allows at all (`limit`, e.g. `maxMemoryAllocationSize`):
    /// refused before any Vulkan call.
    BufferTooLarge {
        /// Bytes asked for.
        size: u64,
        /// The device limit in bytes.
        max: u64,
        /// The limit's name.
        limit: &'static str,
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
            AshError::Exec(e) => write!(f, "{e}"),
            AshError::Texture(why) => write!(f, "texture: {why}"),
            AshError::BindingTooLarge { buffer, size, max } => write!(
                f,
                "buffer {buffer:?} of {size} bytes exceeds maxStorageBufferRange ({max} bytes)"
            ),
            AshError::BufferTooLarge { size, max, limit } => write!(
                f,
                "a buffer of {size} bytes exceeds the device's {limit} ({max} bytes)"
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

impl From<ExecError> for AshError {
    fn from(e: ExecError) -> Self {
        AshError::Exec(e)
    }
}

impl From<PlanError> for AshError {
    fn from(e: PlanError) -> Self {
        AshError::Exec(ExecError::Plan(e))
    }
}
