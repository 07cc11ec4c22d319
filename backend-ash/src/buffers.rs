//! Storage buffers: the executor's table of buffers (created or imported), lookup, creation
//! (device-local, one allocation each, zero-filled on the GPU timeline) and destruction. Each
//! entry carries the hazard state from which `track` derives barriers.

use crate::alloc::{self, Allocation, STORAGE_USAGE};
use crate::stream::StreamState;
use crate::track::{BarrierBatch, Hazard};
use crate::{AshError, AshExecutor};
use ash::vk;
use vrrt_core::executor::{BufferId, ExecError, Executor};

/// One buffer of the executor.
pub(crate) struct BufferEntry {
    pub(crate) buffer: vk::Buffer,
    /// Null for imported buffers (not owned).
    pub(crate) memory: vk::DeviceMemory,
    /// Size the user asked for.
    pub(crate) size: u64,
    /// Size of the Vulkan buffer (`size`, at least 4): the descriptor range.
    pub(crate) vk_size: u64,
    pub(crate) hazard: Hazard,
}

impl AshExecutor {
    pub(crate) fn entry(&self, id: BufferId) -> Result<&BufferEntry, AshError> {
        self.buffers
            .get(id.0 as usize)
            .and_then(Option::as_ref)
            .ok_or(AshError::Exec(ExecError::UnknownBuffer(id)))
    }

    pub(crate) fn entry_mut(&mut self, id: BufferId) -> Result<&mut BufferEntry, AshError> {
        self.buffers
            .get_mut(id.0 as usize)
            .and_then(Option::as_mut)
            .ok_or(AshError::Exec(ExecError::UnknownBuffer(id)))
    }

    /// The Vulkan buffer behind `id`, to bind in the engine's own passes. Its size is
    /// [`AshExecutor::buffer_size`] (at least 4 bytes in Vulkan).
    pub fn raw_buffer(&self, id: BufferId) -> Result<vk::Buffer, AshError> {
        Ok(self.entry(id)?.buffer)
    }

    /// Size in bytes of buffer `id`, as created or imported.
    pub fn buffer_size(&self, id: BufferId) -> Result<u64, AshError> {
        Ok(self.entry(id)?.size)
    }

    /// Wraps an engine's buffer so passes can bind it. The executor never destroys it.
    ///
    /// Its first `size_bytes` bytes (a nonzero multiple of 4) are the binding. The executor
    /// assumes the engine has already synchronized earlier accesses to it with the compute-shader
    /// stage (see [`AshExecutor::record_into`]).
    ///
    /// # Safety
    /// `buffer` belongs to this executor's device, is at least `size_bytes` long, is bound to
    /// memory, and outlives its use (until [`AshExecutor::destroy_buffer`] or the executor's
    /// drop). It must have usage `STORAGE_BUFFER`, plus `TRANSFER_DST` to be written with
    /// [`Executor::write_buffer`], `TRANSFER_SRC` to be read with [`Executor::read_buffer`], and
    /// `INDIRECT_BUFFER` to hold [`Groups::Indirect`](vrrt_core::executor::Groups::Indirect) counts.
    pub unsafe fn import_buffer(
        &mut self,
        buffer: vk::Buffer,
        size_bytes: u64,
    ) -> Result<BufferId, AshError> {
        if size_bytes == 0 || !size_bytes.is_multiple_of(4) {
            return Err(ExecError::UnalignedSize(size_bytes).into());
        }
        self.buffers.push(Some(BufferEntry {
            buffer,
            memory: vk::DeviceMemory::null(),
            size: size_bytes,
            vk_size: size_bytes,
            hazard: Hazard::default(),
        }));
        Ok(BufferId(self.buffers.len() as u32 - 1))
    }

    /// Destroys a buffer the executor created (imported buffers are only forgotten). Waits for
    /// the executor's own pending work first. The id becomes invalid.
    ///
    /// Fails with [`AshError::BufferInUse`] if a [`Recording`](crate::Recording) that uses it was not retired.
    pub fn destroy_buffer(&mut self, id: BufferId) -> Result<(), AshError> {
        self.entry(id)?;
        if self.external.values().any(|a| a.buffers.contains(&id)) {
            return Err(AshError::BufferInUse(id));
        }
        if self.stream.state != StreamState::Idle {
            self.finish()?;
        }
        if let Some(e) = self.buffers[id.0 as usize].take() {
            if e.memory != vk::DeviceMemory::null() {
                // SAFETY: no pending work uses it (stream idle, no unretired recording).
                unsafe {
                    Allocation {
                        buffer: e.buffer,
                        memory: e.memory,
                    }
                    .destroy(&self.device)
                };
            }
        }
        Ok(())
    }

    /// A new device-local storage buffer, zero-filled by a `vkCmdFillBuffer` recorded into the
    /// stream.
    pub(crate) fn create(&mut self, size_bytes: u64) -> Result<BufferId, AshError> {
        ExecError::check_size(size_bytes)?;
        let vk_size = size_bytes.max(4);
        if vk_size > self.max_allocation {
            return Err(AshError::BufferTooLarge {
                size: size_bytes,
                max: self.max_allocation,
                limit: "maxMemoryAllocationSize",
            });
        }
        let cmd = self.recording()?;
        let a = alloc::allocate(
            &self.device,
            &self.mem_props,
            vk_size,
            STORAGE_USAGE,
            vk::MemoryPropertyFlags::empty(),
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
            "storage buffer",
        )?;
        let mut hazard = Hazard::default();
        let mut batch = BarrierBatch::default();
        batch.access(
            &mut hazard,
            a.buffer,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        );
        // SAFETY: `cmd` is recording; the buffer was just created.
        unsafe {
            batch.emit(&self.device, cmd);
            self.device
                .cmd_fill_buffer(cmd, a.buffer, 0, vk::WHOLE_SIZE, 0);
        }
        self.buffers.push(Some(BufferEntry {
            buffer: a.buffer,
            memory: a.memory,
            size: size_bytes,
            vk_size,
            hazard,
        }));
        Ok(BufferId(self.buffers.len() as u32 - 1))
    }
}
