//! Storage buffers: creation, import of an application's buffers, lookup with usage checks, and
//! uploads. Uploads are copies recorded into the pending encoder (not `Queue::write_buffer`) so
//! they stay ordered with the passes recorded before and after them.

use crate::{WgpuError, WgpuExecutor};
use vrrt_core::executor::{BufferId, ExecError};

impl WgpuExecutor {
    /// The wgpu buffer behind `id`, to use in the application's own passes.
    pub fn buffer(&self, id: BufferId) -> Option<&wgpu::Buffer> {
        self.buffers.get(id.0 as usize)
    }

    /// Wraps an application's buffer so passes can bind it. It must belong to this executor's
    /// device, have [`wgpu::BufferUsages::STORAGE`] and a size that is a multiple of 4; reading,
    /// writing it or using it for indirect dispatch additionally needs `COPY_SRC`, `COPY_DST` or
    /// `INDIRECT` (checked when used).
    pub fn import_buffer(&mut self, buffer: wgpu::Buffer) -> Result<BufferId, WgpuError> {
        let id = BufferId(self.buffers.len() as u32);
        ExecError::check_size(buffer.size())?;
        if !buffer.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(WgpuError::MissingUsage {
                buffer: id,
                missing: wgpu::BufferUsages::STORAGE,
            });
        }
        self.buffers.push(buffer);
        Ok(id)
    }

    pub(crate) fn get(&self, id: BufferId) -> Result<&wgpu::Buffer, WgpuError> {
        self.buffers
            .get(id.0 as usize)
            .ok_or(WgpuError::Exec(ExecError::UnknownBuffer(id)))
    }

    /// Buffer `id`, which must have `usage`.
    pub(crate) fn require(
        &self,
        id: BufferId,
        usage: wgpu::BufferUsages,
    ) -> Result<&wgpu::Buffer, WgpuError> {
        let b = self.get(id)?;
        let missing = usage - b.usage();
        if missing.is_empty() {
            Ok(b)
        } else {
            Err(WgpuError::MissingUsage {
                buffer: id,
                missing,
            })
        }
    }

    /// A new zero-initialised buffer (wgpu clears new buffers).
    pub(crate) fn create(
        &mut self,
        size_bytes: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<BufferId, WgpuError> {
        ExecError::check_size(size_bytes)?;
        let max = self.device.limits().max_buffer_size;
        if size_bytes > max {
            return Err(WgpuError::Limit(format!(
                "a buffer of {size_bytes} bytes exceeds the device's max_buffer_size ({max} bytes)"
            )));
        }
        let id = BufferId(self.buffers.len() as u32);
        let buffer = self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt buffer"),
                size: size_bytes,
                usage,
                mapped_at_creation: false,
            })
        })?;
        self.buffers.push(buffer);
        Ok(id)
    }

    /// Writes `data` to the start of `buffer` (see [`vrrt_core::executor::Executor::write_buffer`]).
    pub(crate) fn write(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), WgpuError> {
        let dst = self.require(buffer, wgpu::BufferUsages::COPY_DST)?.clone();
        ExecError::check_range(buffer, data.len() as u64, dst.size())?;
        let aligned = data.len() & !3;
        if aligned > 0 {
            self.stage_write(&dst, 0, &data[..aligned])?;
        }
        if aligned < data.len() {
            let mut word = [0u8; 4];
            self.read_range(buffer, aligned as u64, &mut word)?;
            let tail = &data[aligned..];
            word[..tail.len()].copy_from_slice(tail);
            self.stage_write(&dst, aligned as u64, &word)?;
        }
        Ok(())
    }

    /// Records a copy of `data` (a multiple of 4 bytes) to `offset` of `dst` in the pending
    /// encoder, so it stays ordered with recorded passes.
    fn stage_write(
        &mut self,
        dst: &wgpu::Buffer,
        offset: u64,
        data: &[u8],
    ) -> Result<(), WgpuError> {
        // Created and checked before it is mapped: wgpu's `create_buffer_init` panics when the
        // buffer comes back invalid (a lost device), where this returns the error.
        let staging = self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt upload"),
                size: data.len() as u64,
                usage: wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: true,
            })
        })?;
        staging
            .slice(..)
            .get_mapped_range_mut()
            .map_err(|e| WgpuError::Device(format!("upload buffer: {e:?}")))?
            .copy_from_slice(data);
        staging.unmap();
        let mut encoder = self.pending_encoder();
        encoder.copy_buffer_to_buffer(&staging, 0, dst, offset, data.len() as u64);
        self.encoder = Some(encoder);
        Ok(())
    }
}
