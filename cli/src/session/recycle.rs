//! Buffers of finished sequences handed to the next one on the same executor.
//!
//! Executors have no call that frees a buffer, so every denoiser a bench cell creates kept its
//! buffers for the life of the executor: memory grew with the number of cells (about 1.6 MB a
//! cell at 160x90). A sequence's renderer instead allocates through [`Recycling`], which takes
//! a buffer of the same size that an earlier sequence released, zeroed (a new buffer's
//! contract), before asking the executor for a new one.

use std::collections::HashMap;
use vrrt_backend::{Backend, BackendError};
use vrrt_core::executor::{BindingLimit, BufferId, Executor, Pass, PassTiming, SharedBytes};

/// Buffers by size: released ones, free for the taking, and those taken since the last release.
#[derive(Default)]
pub struct BufferPool {
    free: HashMap<u64, Vec<BufferId>>,
    taken: Vec<(u64, BufferId)>,
}

impl BufferPool {
    /// Makes every buffer taken since the last release free again: their user is done.
    pub fn release(&mut self) {
        for (size, id) in self.taken.drain(..) {
            self.free.entry(size).or_default().push(id);
        }
    }
}

/// An executor whose new buffers come from `pool` where one of the size is free.
pub struct Recycling<'a> {
    /// The executor.
    pub exec: &'a mut Backend,
    /// Where buffers are taken from and recorded.
    pub pool: &'a mut BufferPool,
}

impl Executor for Recycling<'_> {
    type Error = BackendError;

    fn name(&self) -> &'static str {
        self.exec.name()
    }

    fn binding_limit(&self) -> BindingLimit {
        self.exec.binding_limit()
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, BackendError> {
        let reused = self.pool.free.get_mut(&size_bytes).and_then(Vec::pop);
        let id = match reused {
            Some(id) => {
                let len = usize::try_from(size_bytes).map_err(|_| {
                    BackendError(format!(
                        "a buffer of {size_bytes} bytes does not fit memory"
                    ))
                })?;
                self.exec.write_buffer(id, &vec![0u8; len])?;
                id
            }
            None => self.exec.create_buffer(size_bytes)?,
        };
        self.pool.taken.push((size_bytes, id));
        Ok(id)
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), BackendError> {
        self.exec.write_buffer(buffer, data)
    }

    /// Shared bytes are the executor's to keep (no copy on the CPU backend); the buffer is
    /// pooled by its size like any other, and zeroing it for its next user drops them.
    fn create_buffer_shared(
        &mut self,
        data: std::sync::Arc<dyn SharedBytes>,
    ) -> Result<BufferId, BackendError> {
        let size = (data.bytes().len() as u64).max(4).next_multiple_of(4);
        let id = self.exec.create_buffer_shared(data)?;
        self.pool.taken.push((size, id));
        Ok(id)
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), BackendError> {
        self.exec.dispatch(pass)
    }

    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), BackendError> {
        self.exec.read_buffer(buffer, out)
    }

    fn finish(&mut self) -> Result<(), BackendError> {
        self.exec.finish()
    }

    fn timings(&self) -> &[PassTiming] {
        self.exec.timings()
    }

    fn clear_timings(&mut self) {
        self.exec.clear_timings()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn released_buffers_come_back_zeroed_and_others_are_new() {
        let mut exec = Backend::Cpu(vrrt_cpu::CpuExecutor::new());
        let mut pool = BufferPool::default();
        let mut rec = Recycling {
            exec: &mut exec,
            pool: &mut pool,
        };
        let a = rec.create_buffer(16).unwrap();
        rec.write_buffer(a, &[7u8; 16]).unwrap();
        rec.pool.release();
        let b = rec.create_buffer(16).unwrap();
        assert_eq!(a, b, "the released buffer is taken again");
        let mut out = [1u8; 16];
        rec.read_buffer(b, &mut out).unwrap();
        assert_eq!(out, [0u8; 16]);
        // Taken and not released: a second buffer of the size is new.
        assert_ne!(rec.create_buffer(16).unwrap(), b);
        assert_ne!(rec.create_buffer(32).unwrap(), b);
    }
}
