//! Embedding in an engine: the engine's Vulkan objects an executor can borrow ([`RawVulkan`],
//! see [`AshExecutor::from_raw`]), and recording passes into the engine's own command buffer
//! ([`AshExecutor::record_into`]) with the resources that command buffer uses kept in a
//! [`Recording`] until the engine hands it back ([`AshExecutor::retire`]).

use crate::{AshError, AshExecutor};
use ash::vk;
use vrrt_core::executor::Pass;
#[cfg(doc)]
use vrrt_core::executor::{Executor, Groups};

/// Vulkan objects of an engine that an executor borrows (see [`AshExecutor::from_raw`]).
#[derive(Clone)]
pub struct RawVulkan {
    /// The instance the device was created from (used for physical-device queries).
    pub instance: ash::Instance,
    /// The logical device. It must have been created with Vulkan 1.2+ and the
    /// `vulkanMemoryModel` feature of `VkPhysicalDeviceVulkan12Features` enabled (rust-gpu's
    /// SPIR-V declares the `VulkanMemoryModel` capability), plus
    /// `vulkanMemoryModelDeviceScope` if the module uses device-scope atomics.
    pub device: ash::Device,
    /// The physical device of `device`.
    pub physical_device: vk::PhysicalDevice,
    /// A queue with compute support. The executor submits its own work (uploads, readbacks,
    /// dispatches not recorded with [`AshExecutor::record_into`]) to it.
    pub queue: vk::Queue,
    /// Family of `queue`; command buffers given to [`AshExecutor::record_into`] must belong to
    /// a pool of this family.
    pub queue_family_index: u32,
}

/// Passes recorded into a user command buffer by [`AshExecutor::record_into`]. Holds the
/// descriptor sets and timestamp queries that command buffer uses; hand it back to
/// [`AshExecutor::retire`] once the command buffer has finished executing.
#[must_use = "retire the recording once its command buffer has completed, or its resources leak"]
#[derive(Debug)]
pub struct Recording {
    id: u64,
    passes: usize,
}

impl Recording {
    /// Number of passes recorded.
    pub fn passes(&self) -> usize {
        self.passes
    }
}

impl AshExecutor {
    /// Records `passes` into the engine's command buffer `cmd`, in order.
    ///
    /// Before recording, any work the executor has pending (buffer creation fills, uploads) is
    /// submitted to [`AshExecutor::queue`] without waiting, so `cmd` must be submitted to that
    /// same queue (later), and it then runs after those uploads.
    ///
    /// **Barriers the executor inserts** (all `vkCmdPipelineBarrier` with buffer memory barriers
    /// on whole buffers): between passes of this call, and against earlier work of the executor
    /// itself (uploads, fills, earlier passes, including earlier `record_into` calls),
    /// read-after-write `COMPUTE_SHADER/SHADER_WRITE` (or `TRANSFER/TRANSFER_WRITE`) →
    /// `COMPUTE_SHADER/SHADER_READ` (`DRAW_INDIRECT/INDIRECT_COMMAND_READ` for the counts of
    /// [`Groups::Indirect`]), write-after-write, and write-after-read execution dependencies.
    ///
    /// **What the engine must insert**:
    /// - *before* this call, for every buffer its own commands accessed (e.g. imported buffers
    ///   its ray-tracing pass wrote): a barrier from that access to
    ///   `COMPUTE_SHADER` with `SHADER_READ | SHADER_WRITE` (plus `DRAW_INDIRECT` /
    ///   `INDIRECT_COMMAND_READ` for indirect-count buffers);
    /// - *after* it, before its own commands use buffers the passes wrote: a barrier from
    ///   `COMPUTE_SHADER` / `SHADER_WRITE` to its consumer's stage and access (and from
    ///   `COMPUTE_SHADER` / `SHADER_READ` before it overwrites a buffer the passes read).
    ///
    /// Timestamp queries are recorded as for the executor's own work when the queue family
    /// supports them (including a `vkCmdResetQueryPool` when a query pool is first used); their
    /// timings are added to [`Executor::timings`] by [`AshExecutor::retire`].
    ///
    /// Fails before recording anything if a pass is invalid.
    ///
    /// # Safety
    /// - `cmd` is a primary or secondary command buffer in the recording state, outside a render
    ///   pass, allocated from a pool of [`AshExecutor::queue_family_index`]; it is submitted to
    ///   [`AshExecutor::queue`] after this call returns, or discarded.
    /// - The returned [`Recording`] is given to [`AshExecutor::retire`] only after `cmd` has
    ///   finished executing (or was discarded), and before the executor is dropped all such
    ///   command buffers have completed.
    pub unsafe fn record_into(
        &mut self,
        cmd: vk::CommandBuffer,
        passes: &[Pass<'_>],
    ) -> Result<Recording, AshError> {
        let pipelines = passes
            .iter()
            .map(|p| self.prepare(p))
            .collect::<Result<Vec<_>, _>>()?;
        self.flush()?;
        let mut arena = self.spare_arenas.pop().unwrap_or_default();
        let id = self.next_recording;
        self.next_recording += 1;
        for (pass, &p) in passes.iter().zip(&pipelines) {
            if let Err(e) = self.emit_pass(cmd, &mut arena, pass, p) {
                // `cmd` may hold some of the arena's sets: keep it until drop.
                self.external.insert(id, arena);
                return Err(e);
            }
        }
        self.external.insert(id, arena);
        Ok(Recording {
            id,
            passes: passes.len(),
        })
    }

    /// Recycles the descriptor sets and queries of a recording and adds its timings to
    /// [`Executor::timings`] (none if the queries were never executed).
    ///
    /// # Safety
    /// The command buffer `recording` was recorded into has finished executing, or was never
    /// submitted.
    pub unsafe fn retire(&mut self, recording: Recording) -> Result<(), AshError> {
        let Some(mut arena) = self.external.remove(&recording.id) else {
            return Ok(());
        };
        let timed = match self.timestamps {
            Some(ts) => arena
                .collect_timings(&self.device, ts, false, &mut self.timings)
                .map(|_| ()),
            None => Ok(()),
        };
        let reset = arena.reset(&self.device);
        self.spare_arenas.push(arena);
        timed.and(reset)
    }
}
