//! Submission and readback: the pending encoder is submitted (with the resolve of its
//! timestamps) when work must run, and the only waits for the device happen here, when a buffer
//! is read back or [`Executor::finish`](vrrt_core::executor::Executor::finish) is called. A wait maps
//! the readback buffer and the timestamp batches together, so one poll serves both.

use std::sync::{Arc, Mutex};

use crate::{WgpuError, WgpuExecutor};
use vrrt_core::executor::{BufferId, ExecError};

impl WgpuExecutor {
    /// Submits the pending encoder (with the resolve of its timestamps), without waiting.
    pub(crate) fn submit(&mut self) -> Result<(), WgpuError> {
        let Some(mut encoder) = self.encoder.take() else {
            return Ok(());
        };
        if let Some(timer) = &mut self.timer {
            timer.resolve(&self.device, &mut encoder);
        }
        self.scoped(|| {
            self.queue.submit([encoder.finish()]);
        })
    }

    /// Submits pending work, waits for the device, maps `extra` (a buffer and a byte count) and
    /// the timestamp batches, collects the timings, and hands the mapped `extra` to `read`.
    pub(crate) fn submit_and_wait(
        &mut self,
        extra: Option<(&wgpu::Buffer, u64)>,
        read: impl FnOnce(&[u8]),
    ) -> Result<(), WgpuError> {
        self.submit()?;
        let status: Arc<Mutex<Vec<Result<(), wgpu::BufferAsyncError>>>> = Arc::default();
        let map = |buffer: &wgpu::Buffer, bytes: u64| {
            let status = status.clone();
            buffer.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
                status.lock().unwrap_or_else(|p| p.into_inner()).push(r)
            });
        };
        let batches = self
            .timer
            .as_mut()
            .map(|t| t.take_submitted())
            .unwrap_or_default();
        for batch in &batches {
            map(&batch.readback, batch.bytes());
        }
        if let Some((buffer, bytes)) = extra {
            map(buffer, bytes);
        }
        let expected = batches.len() + usize::from(extra.is_some());
        let polled = self
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| WgpuError::Device(e.to_string()));
        let results = std::mem::take(&mut *status.lock().unwrap_or_else(|p| p.into_inner()));
        let mapped = if let Err(e) = polled {
            Err(e)
        } else if results.len() != expected {
            Err(WgpuError::Device(format!(
                "{} of {expected} buffers mapped",
                results.len()
            )))
        } else if let Some(Err(e)) = results.into_iter().find(Result::is_err) {
            Err(WgpuError::Device(e.to_string()))
        } else {
            Ok(())
        };
        if mapped.is_ok() {
            if let Some(timer) = &self.timer {
                timer.read(&batches, &mut self.timings)?;
            }
            if let Some((buffer, bytes)) = extra {
                let view = buffer
                    .get_mapped_range(0..bytes)
                    .map_err(|e| WgpuError::Device(e.to_string()))?;
                read(&view);
            }
        }
        // Unmap everything that was mapped, also on failure, and recycle the timestamp buffers.
        if let Some((buffer, _)) = extra {
            buffer.unmap();
        }
        for batch in batches {
            batch.readback.unmap();
            if let Some(timer) = &mut self.timer {
                timer.recycle(batch.readback);
            }
        }
        mapped
    }

    /// Copies `out.len()` bytes at `offset` of `id` into `out` (waits for pending work).
    pub(crate) fn read_range(
        &mut self,
        id: BufferId,
        offset: u64,
        out: &mut [u8],
    ) -> Result<(), WgpuError> {
        let src = self.require(id, wgpu::BufferUsages::COPY_SRC)?.clone();
        ExecError::check_range(id, offset + out.len() as u64, src.size())?;
        let bytes = (out.len() as u64).next_multiple_of(4);
        if bytes == 0 {
            return self.submit_and_wait(None, |_| {});
        }
        let readback = match self.readback.take() {
            Some(b) if b.size() >= bytes => b,
            _ => self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt readback"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        };
        let mut encoder = self.pending_encoder();
        encoder.copy_buffer_to_buffer(&src, offset, &readback, 0, bytes);
        self.encoder = Some(encoder);
        // Mapped memory need not be aligned for `T`: copy bytes.
        let result = self.submit_and_wait(Some((&readback, bytes)), |m| {
            out.copy_from_slice(&m[..out.len()])
        });
        self.readback = Some(readback);
        result
    }
}
