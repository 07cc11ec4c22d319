//! Uploads and readbacks: copies between host memory and storage buffers, recorded into the
//! executor's stream in call order (so they are ordered with the passes around them) with the
//! transfer barriers `track` derives. Uploads go through the staging ring of `alloc`; readbacks
//! through one reusable host-visible buffer, and wait for the stream.

use crate::alloc::HostBuffer;
use crate::track::BarrierBatch;
use crate::{AshError, AshExecutor};
use ash::vk;
use vrrt_core::executor::{BufferId, ExecError, Executor};

impl AshExecutor {
    /// Copies `data` to the start of `buffer` through the staging ring, recorded into the
    /// stream after a barrier against earlier accesses of `buffer`.
    pub(crate) fn upload(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), AshError> {
        let size = self.entry(buffer)?.size;
        ExecError::check_range(buffer, data.len() as u64, size)?;
        if data.is_empty() {
            return Ok(());
        }
        let cmd = self.recording()?;
        let (src, offset) = self.staging.push(&self.device, &self.mem_props, data)?;
        let e = self.buffers[buffer.0 as usize]
            .as_mut()
            .expect("checked above");
        let mut batch = BarrierBatch::default();
        batch.access(
            &mut e.hazard,
            e.buffer,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        );
        let region = vk::BufferCopy {
            src_offset: offset,
            dst_offset: 0,
            size: data.len() as u64,
        };
        // SAFETY: `cmd` is recording; both buffers are alive until the submission completes.
        unsafe {
            batch.emit(&self.device, cmd);
            self.device.cmd_copy_buffer(cmd, src, e.buffer, &[region]);
        }
        Ok(())
    }

    /// Copies the start of `buffer` into `out`: a copy into the readback buffer is recorded, the
    /// stream is submitted and waited for, then the bytes are read from mapped memory.
    pub(crate) fn readback(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), AshError> {
        let size = self.entry(buffer)?.size;
        ExecError::check_range(buffer, out.len() as u64, size)?;
        if out.is_empty() {
            return self.finish();
        }
        let cmd = self.recording()?;
        let len = out.len() as u64;
        let dst = self.readback_buffer(len)?;
        let e = self.buffers[buffer.0 as usize]
            .as_mut()
            .expect("checked above");
        let mut batch = BarrierBatch::default();
        batch.access(
            &mut e.hazard,
            e.buffer,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_READ,
        );
        let mut to_host = BarrierBatch::default();
        to_host.push(
            dst,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::PipelineStageFlags::HOST,
            vk::AccessFlags::HOST_READ,
        );
        // SAFETY: `cmd` is recording; both buffers are alive until the submission completes.
        unsafe {
            batch.emit(&self.device, cmd);
            self.device.cmd_copy_buffer(
                cmd,
                e.buffer,
                dst,
                &[vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: len,
                }],
            );
            to_host.emit(&self.device, cmd);
        }
        self.finish()?;
        self.readback.as_ref().expect("created above").read(out);
        Ok(())
    }

    /// The host-visible readback buffer, of at least `len` bytes (the last one unless too
    /// small; only used inside reads, whose submissions have completed).
    pub(crate) fn readback_buffer(&mut self, len: u64) -> Result<vk::Buffer, AshError> {
        if self.readback.as_ref().is_none_or(|r| r.size < len) {
            if let Some(old) = self.readback.take() {
                // SAFETY: only used inside reads, whose submissions have completed.
                unsafe { old.destroy(&self.device) };
            }
            self.readback = Some(HostBuffer::new(
                &self.device,
                &self.mem_props,
                len.next_power_of_two(),
                true,
            )?);
        }
        Ok(self.readback.as_ref().expect("just created").alloc.buffer)
    }
}
