//! The executor's own command stream: one command buffer that everything (fills, uploads,
//! dispatches, readback copies) is recorded into in call order, submitted with a fence by
//! [`AshExecutor::flush`] (or a call that must wait), and recycled with its descriptor sets and
//! queries once the fence has signalled. Timings of the submission are collected then.

use crate::arena::Arena;
use crate::{AshError, AshExecutor};
use ash::vk;

/// Where the stream's command buffer is.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum StreamState {
    /// Nothing recorded; the pool may be reset.
    Idle,
    /// Commands are being recorded.
    Recording,
    /// Submitted; the fence signals completion.
    InFlight,
}

/// The executor's own command buffer and what its submission uses.
pub(crate) struct Stream {
    pub(crate) pool: vk::CommandPool,
    pub(crate) cmd: vk::CommandBuffer,
    pub(crate) fence: vk::Fence,
    pub(crate) state: StreamState,
    pub(crate) arena: Arena,
}

impl AshExecutor {
    /// Submits the work recorded so far without waiting for it (no-op if there is none).
    pub fn flush(&mut self) -> Result<(), AshError> {
        if self.stream.state != StreamState::Recording {
            return Ok(());
        }
        let cmd = self.stream.cmd;
        let result = (|| {
            // SAFETY: `cmd` is recording; the fence is unsignaled and not in use (stream was
            // not in flight); the queue is ours to use (from_raw contract).
            unsafe {
                self.device
                    .end_command_buffer(cmd)
                    .map_err(AshError::vk("vkEndCommandBuffer"))?;
                let cmds = [cmd];
                let submit = vk::SubmitInfo::default().command_buffers(&cmds);
                self.device
                    .queue_submit(self.queue, &[submit], self.stream.fence)
                    .map_err(AshError::vk("vkQueueSubmit"))
            }
        })();
        match result {
            Ok(()) => {
                self.stream.state = StreamState::InFlight;
                Ok(())
            }
            Err(e) => {
                // Nothing was submitted: drop the recorded work.
                self.stream.state = StreamState::Idle;
                let _ = self.stream.arena.reset(&self.device);
                self.staging.reset();
                Err(e)
            }
        }
    }

    /// Waits for the in-flight submission, collects its timings and recycles its resources.
    pub(crate) fn wait(&mut self) -> Result<(), AshError> {
        if self.stream.state != StreamState::InFlight {
            return Ok(());
        }
        // SAFETY: the fence was submitted with the stream's work.
        unsafe {
            self.device
                .wait_for_fences(&[self.stream.fence], true, u64::MAX)
                .map_err(AshError::vk("vkWaitForFences"))?;
            self.device
                .reset_fences(&[self.stream.fence])
                .map_err(AshError::vk("vkResetFences"))?;
        }
        self.stream.state = StreamState::Idle;
        self.staging.reset();
        let timed = match self.timestamps {
            Some(ts) => self
                .stream
                .arena
                .collect_timings(&self.device, ts, true, &mut self.timings)
                .map(|_| ()),
            None => Ok(()),
        };
        self.stream.arena.reset(&self.device)?;
        timed
    }

    /// Makes the stream's command buffer ready to record into.
    pub(crate) fn recording(&mut self) -> Result<vk::CommandBuffer, AshError> {
        match self.stream.state {
            StreamState::Recording => return Ok(self.stream.cmd),
            StreamState::InFlight => self.wait()?,
            StreamState::Idle => {}
        }
        // SAFETY: the pool's command buffer is not pending (stream idle).
        unsafe {
            self.device
                .reset_command_pool(self.stream.pool, vk::CommandPoolResetFlags::empty())
                .map_err(AshError::vk("vkResetCommandPool"))?;
            self.device
                .begin_command_buffer(
                    self.stream.cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .map_err(AshError::vk("vkBeginCommandBuffer"))?;
        }
        self.stream.state = StreamState::Recording;
        Ok(self.stream.cmd)
    }
}
