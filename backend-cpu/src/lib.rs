//! The CPU backend: the same kernel functions the GPU runs, called natively.
//!
//! Runs of workgroups ([`GroupSpan`]) run in parallel on rayon's pool; within a workgroup,
//! invocations run in order (and kernels with barriers run phase by phase, see
//! `vrrt_core::plan::KernelDesc::cpu`). Storage
//! buffers are plain `Vec<u32>`, so the CPU backend is also the easiest way to use VRRT-rs from a
//! Rust program: create buffers, write slices, dispatch, read back.

use rayon::prelude::*;
use std::time::Instant;
use vrrt_core::plan::{
    BufferId, CpuBindings, ExecError, Executor, GroupSpan, Groups, Pass, PassTiming, RawBuffer,
};

/// Errors of the CPU backend: only those every backend shares (the CPU has no device that could
/// fail), so this is [`ExecError`] itself.
pub type CpuError = ExecError;

/// Runs plans on the CPU.
#[derive(Default)]
pub struct CpuExecutor {
    buffers: Vec<Vec<u32>>,
    timings: Vec<PassTiming>,
}

impl CpuExecutor {
    /// A new executor with no buffers.
    pub fn new() -> Self {
        Self::default()
    }

    fn buffer(&self, id: BufferId) -> Result<&Vec<u32>, CpuError> {
        self.buffers
            .get(id.0 as usize)
            .ok_or(ExecError::UnknownBuffer(id))
    }

    fn buffer_mut(&mut self, id: BufferId) -> Result<&mut Vec<u32>, CpuError> {
        self.buffers
            .get_mut(id.0 as usize)
            .ok_or(ExecError::UnknownBuffer(id))
    }

    /// Contents of a buffer, without copying.
    pub fn contents(&self, id: BufferId) -> Result<&[u8], CpuError> {
        Ok(bytemuck::cast_slice(self.buffer(id)?))
    }

    /// Size in bytes of buffer `id`, `None` if unknown.
    fn size_of(&self, id: BufferId) -> Option<u64> {
        self.buffers.get(id.0 as usize).map(|b| b.len() as u64 * 4)
    }

    /// Workgroup counts of a checked pass (indirect counts exist: see [`Pass::check`]).
    fn group_counts(&self, groups: Groups) -> Result<[u32; 3], CpuError> {
        match groups {
            Groups::Direct(g) => Ok(g),
            Groups::Indirect { buffer, offset } => {
                let i = (offset / 4) as usize;
                let s = &self.buffer(buffer)?[i..i + 3];
                Ok([s[0], s[1], s[2]])
            }
        }
    }
}

impl Executor for CpuExecutor {
    type Error = CpuError;

    fn name(&self) -> &'static str {
        "cpu"
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, CpuError> {
        ExecError::check_size(size_bytes)?;
        self.buffers.push(vec![0u32; (size_bytes / 4) as usize]);
        Ok(BufferId(self.buffers.len() as u32 - 1))
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), CpuError> {
        let b = self.buffer_mut(buffer)?;
        ExecError::check_range(buffer, data.len() as u64, b.len() as u64 * 4)?;
        bytemuck::cast_slice_mut::<u32, u8>(b)[..data.len()].copy_from_slice(data);
        Ok(())
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), CpuError> {
        pass.check(|id| self.size_of(id))?;
        let groups = self.group_counts(pass.groups)?;
        let raw: Vec<RawBuffer> = pass
            .buffers
            .iter()
            .map(|id| {
                let b = &mut self.buffers[id.0 as usize];
                RawBuffer {
                    ptr: b.as_mut_ptr() as *mut u8,
                    len: b.len() * 4,
                }
            })
            .collect();
        let start = Instant::now();
        // SAFETY: every pointer comes from a distinct live Vec<u32> (aliasing checked above) that
        // is not touched until the dispatch returns.
        let bindings = unsafe { CpuBindings::new(&raw, pass.params, pass.kernel.workgroup_size) };
        let run = pass.kernel.cpu;
        let spans: Vec<GroupSpan> =
            GroupSpan::split(groups, rayon::current_num_threads()).collect();
        spans.into_par_iter().for_each(|span| {
            // SAFETY: bindings match the kernel (validated); see `CpuBindings`.
            unsafe { run(span, &bindings) };
        });
        self.timings.push(PassTiming {
            entry: pass.kernel.entry,
            ms: start.elapsed().as_secs_f64() * 1e3,
        });
        Ok(())
    }

    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), CpuError> {
        let bytes = self.contents(buffer)?;
        ExecError::check_range(buffer, out.len() as u64, bytes.len() as u64)?;
        out.copy_from_slice(&bytes[..out.len()]);
        Ok(())
    }

    fn finish(&mut self) -> Result<(), CpuError> {
        Ok(())
    }

    fn timings(&self) -> &[PassTiming] {
        &self.timings
    }

    fn clear_timings(&mut self) {
        self.timings.clear();
    }
}
