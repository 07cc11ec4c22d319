//! GPU timestamps of the passes [`Executor::dispatch`](vrrt_core::executor::Executor::dispatch)
//! records. One query set is reused by successive batches: each submission resolves the queries
//! of its passes into a readback buffer of its own (queue order makes the resolve of a batch run
//! before the next batch's writes), and the durations are read when the executor next waits for
//! the device. Readback buffers are recycled.

use crate::WgpuError;
use vrrt_core::executor::PassTiming;

/// Timestamped passes per query-set batch (two queries each); a full batch is submitted.
pub(crate) const TIMESTAMP_PASSES: u32 = 256;

/// Timestamps of passes submitted together, copied to `readback`.
pub(crate) struct TimestampBatch {
    pub(crate) readback: wgpu::Buffer,
    pub(crate) entries: Vec<&'static str>,
}

impl TimestampBatch {
    /// Bytes of `readback` holding the batch's queries.
    pub(crate) fn bytes(&self) -> u64 {
        2 * self.entries.len() as u64 * wgpu::QUERY_SIZE as u64
    }
}

/// GPU timestamp state: one query set reused by successive batches.
pub(crate) struct Timer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    /// Nanoseconds per tick.
    period: f32,
    /// Passes recorded into the pending encoder, in order.
    pub(crate) recording: Vec<&'static str>,
    /// Batches submitted and not yet read.
    submitted: Vec<TimestampBatch>,
    /// Readback buffers of read batches, for reuse.
    free: Vec<wgpu::Buffer>,
}

impl Timer {
    /// The timer of `device`, `None` without [`wgpu::Features::TIMESTAMP_QUERY`].
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Option<Timer> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        Some(Timer {
            query_set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("vrrt timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * TIMESTAMP_PASSES,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt timestamp resolve"),
                size: 2 * TIMESTAMP_PASSES as u64 * wgpu::QUERY_SIZE as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            period: queue.get_timestamp_period(),
            recording: Vec::new(),
            submitted: Vec::new(),
            free: Vec::new(),
        })
    }

    /// Whether the query set is used up: the pending encoder must be submitted first.
    pub(crate) fn full(&self) -> bool {
        self.recording.len() as u32 == TIMESTAMP_PASSES
    }

    /// The queries of the next pass recorded.
    pub(crate) fn next_writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        let i = 2 * self.recording.len() as u32;
        wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        }
    }

    /// Records the resolve and readback copy of the passes recorded into `encoder`, which is
    /// about to be submitted.
    pub(crate) fn resolve(&mut self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder) {
        if self.recording.is_empty() {
            return;
        }
        let n = self.recording.len() as u32;
        let bytes = 2 * n as u64 * wgpu::QUERY_SIZE as u64;
        let readback = self.free.pop().unwrap_or_else(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vrrt timestamp readback"),
                size: self.resolve.size(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        encoder.resolve_query_set(&self.query_set, 0..2 * n, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &readback, 0, bytes);
        self.submitted.push(TimestampBatch {
            readback,
            entries: std::mem::take(&mut self.recording),
        });
    }

    /// The batches submitted since the last call, to map.
    pub(crate) fn take_submitted(&mut self) -> Vec<TimestampBatch> {
        std::mem::take(&mut self.submitted)
    }

    /// Appends the durations of mapped `batches` to `timings`.
    pub(crate) fn read(
        &self,
        batches: &[TimestampBatch],
        timings: &mut Vec<PassTiming>,
    ) -> Result<(), WgpuError> {
        let ns_per_tick = self.period as f64;
        for batch in batches {
            let view = batch
                .readback
                .get_mapped_range(0..batch.bytes())
                .map_err(|e| WgpuError::Device(e.to_string()))?;
            let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&view);
            drop(view);
            for (entry, t) in batch.entries.iter().zip(ticks.chunks_exact(2)) {
                let ticks = t[1].saturating_sub(t[0]);
                timings.push(PassTiming {
                    entry,
                    ms: ticks as f64 * ns_per_tick * 1e-6,
                });
            }
        }
        Ok(())
    }

    /// Keeps the (unmapped) readback buffer of a read batch for reuse.
    pub(crate) fn recycle(&mut self, readback: wgpu::Buffer) {
        self.free.push(readback);
    }
}
