//! An executor adapter that records what each dispatched pass moves, and the bandwidth
//! yardstick measured through it.

use anyhow::{bail, Result};
use std::collections::HashMap;
use vrrt_core::executor::{
    BindingLimit, BufferId, Executor, KernelDesc, Pass, PassBytes, PassTiming, SharedBytes,
};
use vrrt_core::kernels::copy::{CopyParams, WORDS_PER_INVOCATION};
use vrrt_core::kernels::CopyBindings;

/// One dispatched pass: its kernel and the bytes it moves ([`Pass::bytes_moved`]).
#[derive(Copy, Clone, Debug)]
pub struct Dispatched {
    /// The kernel.
    pub kernel: &'static KernelDesc,
    /// Compulsory traffic of the pass.
    pub bytes: PassBytes,
}

/// Forwards every call to the executor it wraps, and records each dispatched pass with the bytes
/// it moves, from the sizes its buffers were created with. The records are forgotten with the
/// timings ([`Executor::clear_timings`]), so both cover the same passes.
pub struct Recorder<E> {
    inner: E,
    sizes: HashMap<BufferId, u64>,
    dispatched: Vec<Dispatched>,
}

impl<E: Executor> Recorder<E> {
    /// Wraps `inner`, which must not have created buffers yet (their sizes would be unknown).
    pub fn new(inner: E) -> Self {
        Recorder {
            inner,
            sizes: HashMap::new(),
            dispatched: Vec::new(),
        }
    }

    /// The wrapped executor.
    pub fn inner(&self) -> &E {
        &self.inner
    }

    /// Passes dispatched since the last [`Executor::clear_timings`], in order.
    pub fn dispatched(&self) -> &[Dispatched] {
        &self.dispatched
    }
}

impl<E: Executor> Executor for Recorder<E> {
    type Error = E::Error;

    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn binding_limit(&self) -> BindingLimit {
        self.inner.binding_limit()
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, E::Error> {
        let id = self.inner.create_buffer(size_bytes)?;
        self.sizes.insert(id, size_bytes);
        Ok(id)
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), E::Error> {
        self.inner.write_buffer(buffer, data)
    }

    fn create_buffer_shared(
        &mut self,
        data: std::sync::Arc<dyn SharedBytes>,
    ) -> Result<BufferId, E::Error> {
        let size = (data.bytes().len() as u64).max(4).next_multiple_of(4);
        let id = self.inner.create_buffer_shared(data)?;
        self.sizes.insert(id, size);
        Ok(id)
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), E::Error> {
        self.inner.dispatch(pass)?;
        // The inner executor has checked that every bound buffer exists.
        let bytes = pass.bytes_moved(|id| self.sizes.get(&id).copied().unwrap_or(0));
        self.dispatched.push(Dispatched {
            kernel: pass.kernel,
            bytes,
        });
        Ok(())
    }

    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), E::Error> {
        self.inner.read_buffer(buffer, out)
    }

    fn finish(&mut self) -> Result<(), E::Error> {
        self.inner.finish()
    }

    fn timings(&self) -> &[PassTiming] {
        self.inner.timings()
    }

    fn clear_timings(&mut self) {
        self.inner.clear_timings();
        self.dispatched.clear();
    }
}

/// Bytes copied per repeat: large enough to spill any GPU's L2 and a CPU's last-level cache.
pub const COPY_BYTES: u64 = 128 << 20;
/// Invocations per row of a copy pass's grid (64 workgroups of 64 across).
const COPY_ROW: u32 = 4096;
/// Timed repeats of the copy, after the untimed spin-up.
pub const COPY_REPEATS: usize = 5;
/// Untimed copies run at least this long first: pipeline creation, first touch of the pages,
/// and a GPU's clocks, which rise only under sustained load (see `docs/results/per-pass.md`).
pub const SPIN_UP: std::time::Duration = std::time::Duration::from_millis(1500);

/// A measured memory bandwidth.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Bandwidth {
    /// Bytes per second.
    pub bytes_per_second: f64,
    /// Bytes copied per repeat (`COPY_BYTES` rounded up to whole chunks).
    pub copied: u64,
}

/// The memory bandwidth of `exec`: the best of `COPY_REPEATS` copies of `COPY_BYTES` by the
/// `copy` kernel, (read + written bytes, as [`Pass::bytes_moved`] counts them) / the passes' own
/// timings. Best, not median: the floor is what the memory allows.
pub fn bandwidth<E: Executor>(exec: &mut Recorder<E>) -> Result<Bandwidth> {
    let row_bytes = (COPY_ROW * WORDS_PER_INVOCATION) as u64 * 4;
    // One pass per repeat where the device allows it (every Vulkan device binds 128 MiB).
    let chunk = COPY_BYTES.min(exec.binding_limit().bytes / row_bytes * row_bytes);
    if chunk == 0 {
        bail!(
            "the {} backend cannot bind a buffer of {row_bytes} bytes",
            exec.name()
        );
    }
    let words = (chunk / 4) as u32;
    // Nonzero sources: a zero-filled allocation may still be the OS's shared zero page, which
    // reads from cache.
    let pattern: Vec<u32> = (0..words).collect();
    let mut chunks = Vec::new();
    for _ in 0..COPY_BYTES.div_ceil(chunk) {
        let b = CopyBindings {
            src: exec.create_buffer(chunk).map_err(err)?,
            dst: exec.create_buffer(chunk).map_err(err)?,
        };
        exec.write_buffer(b.src, bytemuck::cast_slice(&pattern))
            .map_err(err)?;
        chunks.push(b);
    }
    let params = CopyParams {
        row: COPY_ROW,
        len: words,
    };
    let rows = words / COPY_ROW / WORDS_PER_INVOCATION;
    let copy = |exec: &mut Recorder<E>| -> Result<()> {
        exec.clear_timings();
        for b in &chunks {
            exec.dispatch(&b.over_grid(&params, COPY_ROW, rows, 1))
                .map_err(err)?;
        }
        exec.finish().map_err(err)
    };
    let start = std::time::Instant::now();
    while start.elapsed() < SPIN_UP {
        copy(exec)?;
    }
    let mut best = 0.0f64;
    for _ in 0..COPY_REPEATS {
        copy(exec)?;
        let ms: f64 = exec.timings().iter().map(|t| t.ms).sum();
        let bytes: u64 = exec.dispatched().iter().map(|d| d.bytes.total()).sum();
        if ms.is_nan() || ms <= 0.0 {
            bail!(
                "the {} backend reported no pass timings (GPU timestamps unsupported?)",
                exec.name()
            );
        }
        best = best.max(bytes as f64 / (ms * 1e-3));
    }
    exec.clear_timings();
    Ok(Bandwidth {
        bytes_per_second: best,
        copied: chunk * chunks.len() as u64,
    })
}

fn err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("{e}")
}
