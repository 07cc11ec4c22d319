//! Recording passes: the checks a pass must pass before anything is recorded (shared ones from
//! [`Pass::check`], plus buffer usages), its bind group (cached per kernel and buffer list), and
//! the compute pass itself, either into the executor's pending encoder (timed) or into an
//! application's encoder ([`WgpuExecutor::encode`]).

use crate::timings::Timer;
use crate::{WgpuError, WgpuExecutor};
use vrrt_core::executor::{Groups, Pass};

impl WgpuExecutor {
    /// Records `passes` into the application's `encoder` (which must come from this executor's
    /// device), without timestamps.
    ///
    /// Work still pending in the executor (e.g. from
    /// [`Executor::write_buffer`](vrrt_core::executor::Executor::write_buffer)) is submitted first,
    /// so it runs before the application's command buffer once that is submitted. wgpu inserts
    /// the barriers between the passes and with the application's own commands. Nothing runs
    /// until the application finishes and submits `encoder` to the queue; to read results,
    /// submit, then call [`Executor::read_buffer`](vrrt_core::executor::Executor::read_buffer) (or
    /// copy and map them yourself). Validation errors in the recorded passes are reported by wgpu
    /// when the encoder is finished or submitted, to the application's error scopes or handler.
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        passes: &[Pass<'_>],
    ) -> Result<(), WgpuError> {
        self.submit()?;
        for pass in passes {
            self.prepare(pass)?;
        }
        for pass in passes {
            self.record(encoder, pass, None);
        }
        Ok(())
    }

    /// Checks a pass and creates what it needs (pipeline, bind group).
    fn prepare(&mut self, pass: &Pass<'_>) -> Result<(), WgpuError> {
        pass.check(
            |id| match self.imported(id) {
                Some(t) => Some(t.bytes),
                None => self.buffers.get(id.0 as usize).map(wgpu::Buffer::size),
            },
            |id| self.imported(id).is_some(),
        )?;
        for (&id, binding) in pass.buffers.iter().zip(pass.kernel.bindings) {
            if self.imported(id).is_none() {
                self.require(id, wgpu::BufferUsages::STORAGE)?;
            }
            self.check_texture(id, binding.access)?;
        }
        if let Groups::Indirect { buffer, .. } = pass.groups {
            self.require(buffer, wgpu::BufferUsages::INDIRECT)?;
        }
        self.ensure_kernel(pass.kernel)?;
        let key = (pass.kernel.entry, pass.buffers.to_vec());
        if !self.bind_groups.contains_key(&key) {
            let layout = &self.kernels[pass.kernel.entry].layout;
            let entries: Vec<wgpu::BindGroupEntry<'_>> = pass
                .buffers
                .iter()
                .enumerate()
                .map(|(i, &id)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: match self.imported(id) {
                        Some(t) => wgpu::BindingResource::TextureView(&t.view),
                        None => self.buffers[id.0 as usize].as_entire_binding(),
                    },
                })
                .collect();
            let group = self.scoped(|| {
                self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(pass.kernel.entry),
                    layout,
                    entries: &entries,
                })
            })?;
            self.bind_groups.insert(key, group);
        }
        Ok(())
    }

    /// Records a prepared pass.
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pass: &Pass<'_>,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let kernel = &self.kernels[pass.kernel.entry];
        let group = &self.bind_groups[&(pass.kernel.entry, pass.buffers.to_vec())];
        let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(pass.kernel.entry),
            timestamp_writes: timestamps,
        });
        cpass.set_pipeline(&kernel.pipeline);
        cpass.set_bind_group(0, group, &[]);
        if !pass.params.is_empty() {
            cpass.set_immediates(0, pass.params);
        }
        match pass.groups {
            Groups::Direct([x, y, z]) => cpass.dispatch_workgroups(x, y, z),
            Groups::Indirect { buffer, offset } => {
                cpass.dispatch_workgroups_indirect(&self.buffers[buffer.0 as usize], offset)
            }
        }
    }

    /// Records the pass into the pending encoder, with begin/end timestamps when enabled (a full
    /// timestamp batch is submitted first).
    pub(crate) fn record_pending(&mut self, pass: &Pass<'_>) -> Result<(), WgpuError> {
        self.prepare(pass)?;
        if self.timer.as_ref().is_some_and(Timer::full) {
            self.submit()?;
        }
        let mut encoder = self.pending_encoder();
        let writes = self.timer.as_ref().map(Timer::next_writes);
        self.record(&mut encoder, pass, writes);
        if let Some(timer) = &mut self.timer {
            timer.recording.push(pass.kernel.entry);
        }
        self.encoder = Some(encoder);
        Ok(())
    }

    /// The encoder of work not yet submitted (a new one if there is none); put it back in
    /// `self.encoder` after recording.
    pub(crate) fn pending_encoder(&mut self) -> wgpu::CommandEncoder {
        self.encoder.take().unwrap_or_else(|| {
            self.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("vrrt"),
                })
        })
    }
}
