//! What to run: kernel descriptions, passes, and the executor trait every backend implements.
//!
//! A [`KernelDesc`] says everything a backend needs to launch a kernel — SPIR-V entry point,
//! workgroup size, bindings in order, size of the push constants — plus the native function the
//! CPU backend calls per workgroup. A [`Pass`] binds concrete buffers and parameters to it. Backends
//! implement [`Executor`] once; adding a kernel adds a `KernelDesc` here and an entry point in
//! `vrrt-shaders`, never backend code.

use bytemuck::{Pod, Zeroable};
use core::fmt;
use glam::UVec3;

/// How a kernel uses a storage buffer binding. The shader signature follows from it (`&[T]` for
/// `Read`, `&mut [T]` otherwise); GPU pipeline layouts and barriers are built from it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read-only storage buffer.
    Read,
    /// Each invocation writes only the elements it owns, without reading them.
    Write,
    /// Each invocation reads and rewrites only the elements it owns (an in-place update).
    Update,
    /// Invocations contend through integer atomics (`crate::atomic`): counters, histograms,
    /// packed-key min/max.
    Atomic,
    /// An engine texture, read by texel fetches ([`crate::textures::Texture`]): a sampled 2D image
    /// (float texels) on the GPU backends, a row-major slice of [`crate::textures::Texel`]s on the
    /// CPU.
    Sampled,
    /// An engine texture the kernel writes without reading (the denoised output,
    /// [`crate::textures::Store`]): an R32F storage image on the GPU backends, a row-major
    /// slice of [`crate::textures::Texel`]s on the CPU.
    Storage,
}

impl Access {
    /// Whether the kernel may modify the buffer.
    pub fn writes(self) -> bool {
        !matches!(self, Access::Read | Access::Sampled)
    }

    /// Whether the binding is an engine texture rather than a storage buffer.
    pub fn texture(self) -> bool {
        matches!(self, Access::Sampled | Access::Storage)
    }
}

/// One storage buffer binding of a kernel, as declared in `kernels::table`.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Binding {
    /// Name of the binding (the kernel function's parameter).
    pub name: &'static str,
    /// Element type, as written in the declaration.
    pub ty: &'static str,
    /// Size of one element in bytes.
    pub elem_size: u32,
    /// How the kernel uses it.
    pub access: Access,
}

/// The widest instructions the CPU runners of `lanes` kernels may take: each takes the widest
/// the CPU has ([`CpuLanes::Avx512`], then AVX2 with F16C and FMA, then the baseline) up to
/// this limit ([`set_cpu_lanes`]). Lowered, a machine with AVX-512 runs the code a machine
/// without it would: how the CPU backend fares there, measured here.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[repr(u8)]
pub enum CpuLanes {
    /// The target's baseline (SSE2 on x86-64).
    Baseline = 0,
    /// AVX2, F16C and FMA.
    Avx2 = 1,
    /// AVX-512 (and FMA): every runner the kernel table declares (the default).
    Avx512 = 2,
}

static CPU_LANES: core::sync::atomic::AtomicU8 =
    core::sync::atomic::AtomicU8::new(CpuLanes::Avx512 as u8);

/// Limits the CPU runners to `lanes` from the next dispatch on, for the whole process.
pub fn set_cpu_lanes(lanes: CpuLanes) {
    CPU_LANES.store(lanes as u8, core::sync::atomic::Ordering::Relaxed);
}

/// The limit [`set_cpu_lanes`] set ([`CpuLanes::Avx512`] unless lowered).
pub fn cpu_lanes() -> CpuLanes {
    match CPU_LANES.load(core::sync::atomic::Ordering::Relaxed) {
        0 => CpuLanes::Baseline,
        1 => CpuLanes::Avx2,
        _ => CpuLanes::Avx512,
    }
}

/// Native entry of a kernel: runs every invocation of the workgroups of `span`.
///
/// # Safety
/// `bindings` must describe buffers laid out as the kernel expects (see [`CpuBindings::new`]).
pub type CpuGroupFn = unsafe fn(span: GroupSpan, bindings: &CpuBindings<'_>);

/// A run of workgroups side by side in x, the CPU backend's unit of work: workgroups
/// `x_start..x_end` of group row `y` and layer `z`.
///
/// Why runs and not single workgroups: a [`crate::lanes`] kernel then walks its rows of pixels
/// across the whole run, one image row after another, so each buffer is read as a few long
/// sequential streams the prefetchers follow, instead of eight rows of a narrow tile at a time
/// (tens of short streams per workgroup, which stalled on memory).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct GroupSpan {
    /// First workgroup in x: a multiple of [`GroupSpan::ALIGN`].
    pub x_start: u32,
    /// One past the last workgroup in x: a multiple of [`GroupSpan::ALIGN`], or the dispatch's
    /// last.
    pub x_end: u32,
    /// Workgroup row.
    pub y: u32,
    /// Workgroup layer.
    pub z: u32,
}

impl GroupSpan {
    /// Runs start (and, but for the last of a row, end) at multiples of this many workgroups,
    /// so a lanes kernel's calls of `L` pixels (`L / width` workgroups, which divides it) never
    /// straddle two runs.
    pub const ALIGN: u32 = 16;

    /// Cuts a dispatch of `groups` workgroups into runs: whole rows when there are enough of
    /// them to keep `threads` busy, else rows cut into aligned pieces (a one-dimensional
    /// dispatch, such as a work list's).
    pub fn split(groups: [u32; 3], threads: usize) -> impl Iterator<Item = GroupSpan> {
        let [gx, gy, gz] = groups;
        let rows = gy as u64 * gz as u64;
        let wanted = 8 * threads.max(1) as u64;
        let pieces = wanted.div_ceil(rows.max(1)).max(1);
        let align = Self::ALIGN as u64;
        let chunk = ((gx as u64).div_ceil(pieces).div_ceil(align) * align).max(align);
        let per_row = (gx as u64).div_ceil(chunk);
        (0..rows * per_row).map(move |i| {
            let (row, piece) = (i / per_row, i % per_row);
            let x_start = (piece * chunk) as u32;
            GroupSpan {
                x_start,
                x_end: ((piece + 1) * chunk).min(gx as u64) as u32,
                y: (row % gy as u64) as u32,
                z: (row / gy as u64) as u32,
            }
        })
    }

    /// The workgroups of the run, in x order.
    pub fn groups(self) -> impl Iterator<Item = UVec3> {
        (self.x_start..self.x_end).map(move |x| UVec3::new(x, self.y, self.z))
    }
}

/// Static description of one kernel.
pub struct KernelDesc {
    /// SPIR-V entry point name in the shader module.
    pub entry: &'static str,
    /// `LocalSize` of the entry point.
    pub workgroup_size: [u32; 3],
    /// Storage buffers at `descriptor_set = 0`, `binding = i`.
    pub bindings: &'static [Binding],
    /// Size in bytes of the push-constant struct (0 if none).
    pub params_size: u32,
    /// The same kernel, compiled natively.
    pub cpu: CpuGroupFn,
}

impl fmt::Debug for KernelDesc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("KernelDesc")
            .field("entry", &self.entry)
            .field("workgroup_size", &self.workgroup_size)
            .field("bindings", &self.bindings)
            .field("params_size", &self.params_size)
            .finish()
    }
}

/// A buffer owned by an executor.
#[repr(transparent)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Pod, Zeroable)]
pub struct BufferId(pub u32);

/// How many workgroups a pass launches.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Groups {
    /// A fixed count.
    Direct([u32; 3]),
    /// Three `u32` counts read from a buffer at a byte offset when the pass runs (written by an
    /// earlier pass, e.g. the compacted work list of the VRRT apply pass).
    Indirect {
        /// Buffer holding the counts.
        buffer: BufferId,
        /// Byte offset of the first count (multiple of 4).
        offset: u64,
    },
}

/// One dispatch: a kernel with its buffers and parameters.
#[derive(Copy, Clone, Debug)]
pub struct Pass<'a> {
    /// What to run.
    pub kernel: &'static KernelDesc,
    /// One buffer per binding, in binding order.
    pub buffers: &'a [BufferId],
    /// Push-constant bytes (`kernel.params_size` long).
    pub params: &'a [u8],
    /// Workgroups to launch.
    pub groups: Groups,
}

impl<'a> Pass<'a> {
    /// A pass covering a `width × height × planes` grid with one invocation per element.
    pub fn over_grid(
        kernel: &'static KernelDesc,
        buffers: &'a [BufferId],
        params: &'a [u8],
        width: u32,
        height: u32,
        planes: u32,
    ) -> Self {
        let [x, y, z] = kernel.workgroup_size;
        Pass {
            kernel,
            buffers,
            params,
            groups: Groups::Direct([width.div_ceil(x), height.div_ceil(y), planes.div_ceil(z)]),
        }
    }

    /// This pass's buffers and parameters given to `kernel`, a variant of its kernel that binds
    /// and reads the same (`atrous_tiled` of `atrous`, `detect_refill_tiled` of
    /// `detect_refill`), over a `width × height × planes` grid of `kernel`'s workgroups: a
    /// variant needs no bindings struct of its own.
    ///
    /// # Panics
    /// Where `kernel`'s bindings or push constants differ from this pass's kernel's: it would
    /// read the buffers as something else.
    pub fn variant_over_grid(
        self,
        kernel: &'static KernelDesc,
        width: u32,
        height: u32,
        planes: u32,
    ) -> Self {
        assert!(
            kernel.bindings == self.kernel.bindings
                && kernel.params_size == self.kernel.params_size,
            "{} is no variant of {}: their bindings or parameters differ",
            kernel.entry,
            self.kernel.entry
        );
        Pass::over_grid(kernel, self.buffers, self.params, width, height, planes)
    }

    /// Checks that buffers and parameters match the kernel description.
    pub fn validate(&self) -> Result<(), PlanError> {
        if self.buffers.len() != self.kernel.bindings.len() {
            return Err(PlanError::BindingCount {
                entry: self.kernel.entry,
                expected: self.kernel.bindings.len(),
                got: self.buffers.len(),
            });
        }
        if self.params.len() != self.kernel.params_size as usize {
            return Err(PlanError::ParamsSize {
                entry: self.kernel.entry,
                expected: self.kernel.params_size as usize,
                got: self.params.len(),
            });
        }
        if let Groups::Indirect { offset, .. } = self.groups {
            if offset % 4 != 0 {
                return Err(PlanError::IndirectOffset {
                    entry: self.kernel.entry,
                    offset,
                });
            }
        }
        Ok(())
    }

    /// Everything about a pass that can be checked without a device: [`Pass::validate`], then
    /// the buffers. `buffer_size` returns the size in bytes of a buffer of the executor, `None`
    /// for an id it does not know.
    ///
    /// Buffer checks: every bound buffer exists and none is bound twice; the indirect-count
    /// buffer exists, holds the three counts at `offset`, and is not bound to a binding whose
    /// [`Access::writes`]. Backends add only what depends on their device (buffer usages,
    /// device limits).
    pub fn check(
        &self,
        mut buffer_size: impl FnMut(BufferId) -> Option<u64>,
        is_texture: impl Fn(BufferId) -> bool,
    ) -> Result<(), ExecError> {
        self.validate().map_err(ExecError::Plan)?;
        for (i, (&id, binding)) in self.buffers.iter().zip(self.kernel.bindings).enumerate() {
            buffer_size(id).ok_or(ExecError::UnknownBuffer(id))?;
            if self.buffers[..i].contains(&id) {
                return Err(ExecError::AliasedBinding(id));
            }
            let texture = binding.access.texture();
            if is_texture(id) != texture {
                return Err(ExecError::WrongKind {
                    binding: binding.name,
                    id,
                    texture,
                });
            }
        }
        if let Groups::Indirect { buffer, offset } = self.groups {
            let size = buffer_size(buffer).ok_or(ExecError::UnknownBuffer(buffer))?;
            ExecError::check_range(buffer, offset.saturating_add(12), size)?;
            let written = self
                .buffers
                .iter()
                .zip(self.kernel.bindings)
                .any(|(&b, binding)| b == buffer && binding.access.writes());
            if written {
                return Err(ExecError::IndirectWritten(buffer));
            }
        }
        Ok(())
    }

    /// The compulsory memory traffic of the pass: the bytes its bandwidth floor is made of.
    /// `buffer_size` returns the size in bytes of a bound buffer.
    ///
    /// Rule: every bound buffer moves whole, once — read once if its binding is
    /// [`Access::Read`], written once if [`Access::Write`], read and written once if
    /// [`Access::Update`] or [`Access::Atomic`] (read-modify-write). Neighbourhood taps are assumed to hit in cache
    /// and a `Write` binding is a pure write stream, so a pass that moves more (re-reads,
    /// read-before-write, spills) shows it as `ms / floor`. The declaration is all the host knows:
    /// a binding the kernel skips at run time still counts, buffers are taken as sized to what
    /// the pass uses (as the denoiser allocates them), and the 12-byte indirect-count read is
    /// left out.
    pub fn bytes_moved(&self, buffer_size: impl Fn(BufferId) -> u64) -> PassBytes {
        let mut bytes = PassBytes::default();
        for (&id, binding) in self.buffers.iter().zip(self.kernel.bindings) {
            let size = buffer_size(id);
            if binding.access != Access::Write {
                bytes.read += size;
            }
            if binding.access.writes() {
                bytes.written += size;
            }
        }
        bytes
    }
}

/// Bytes a pass moves between memory and the device: see [`Pass::bytes_moved`].
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct PassBytes {
    /// Bytes read.
    pub read: u64,
    /// Bytes written.
    pub written: u64,
}

impl PassBytes {
    /// Bytes read and written.
    pub fn total(&self) -> u64 {
        self.read + self.written
    }
}

impl core::ops::AddAssign for PassBytes {
    fn add_assign(&mut self, other: PassBytes) {
        self.read += other.read;
        self.written += other.written;
    }
}

/// A pass that does not match its kernel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlanError {
    /// Wrong number of buffers.
    BindingCount {
        /// Kernel entry point.
        entry: &'static str,
        /// Bindings the kernel declares.
        expected: usize,
        /// Buffers given.
        got: usize,
    },
    /// Wrong push-constant size.
    ParamsSize {
        /// Kernel entry point.
        entry: &'static str,
        /// Bytes the kernel declares.
        expected: usize,
        /// Bytes given.
        got: usize,
    },
    /// Indirect offset not 4-byte aligned.
    IndirectOffset {
        /// Kernel entry point.
        entry: &'static str,
        /// The offset given.
        offset: u64,
    },
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanError::BindingCount {
                entry,
                expected,
                got,
            } => {
                write!(
                    f,
                    "pass `{entry}`: kernel has {expected} bindings, {got} buffers given"
                )
            }
            PlanError::ParamsSize {
                entry,
                expected,
                got,
            } => {
                write!(
                    f,
                    "pass `{entry}`: kernel takes {expected} bytes of parameters, {got} given"
                )
            }
            PlanError::IndirectOffset { entry, offset } => {
                write!(
                    f,
                    "pass `{entry}`: indirect offset {offset} is not a multiple of 4"
                )
            }
        }
    }
}

impl core::error::Error for PlanError {}

/// What every executor reports the same way, whatever its backend: a pass that does not match its
/// kernel, or buffer ids, sizes and ranges that do not fit the executor's buffers.
///
/// Backends wrap it in one variant of their own error type (`Exec`), next to the errors only
/// their device can raise; its messages are theirs unchanged.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ExecError {
    /// The pass does not match its kernel.
    Plan(PlanError),
    /// A buffer id the executor did not create (or already destroyed).
    UnknownBuffer(BufferId),
    /// A write, read or indirect-count access beyond the end of a buffer.
    OutOfRange {
        /// The buffer.
        buffer: BufferId,
        /// Bytes asked for (end of the access).
        bytes: u64,
        /// Bytes the buffer has.
        size: u64,
    },
    /// Buffer sizes must be multiples of 4 bytes.
    UnalignedSize(u64),
    /// The same buffer bound twice in one pass (the CPU backend hands the bindings to kernels as
    /// disjoint slices; on GPUs one binding's writes would race the other's accesses).
    AliasedBinding(BufferId),
    /// The indirect-count buffer of a pass is also bound to a binding the pass writes (the counts
    /// would be read while the pass may change them).
    IndirectWritten(BufferId),
    /// A storage buffer bound where the kernel reads a texture (`Access::Sampled`), or a
    /// texture where it binds a buffer.
    WrongKind {
        /// The binding's name.
        binding: &'static str,
        /// What was bound.
        id: BufferId,
        /// Whether the binding takes a texture.
        texture: bool,
    },
}

impl ExecError {
    /// Checks a requested buffer size: a multiple of 4 bytes.
    pub fn check_size(size_bytes: u64) -> Result<(), ExecError> {
        if size_bytes.is_multiple_of(4) {
            Ok(())
        } else {
            Err(ExecError::UnalignedSize(size_bytes))
        }
    }

    /// Checks that an access ending at byte `end` fits `buffer`, which has `size` bytes.
    pub fn check_range(buffer: BufferId, end: u64, size: u64) -> Result<(), ExecError> {
        if end <= size {
            Ok(())
        } else {
            Err(ExecError::OutOfRange {
                buffer,
                bytes: end,
                size,
            })
        }
    }
}

impl From<PlanError> for ExecError {
    fn from(e: PlanError) -> Self {
        ExecError::Plan(e)
    }
}

impl fmt::Display for ExecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExecError::Plan(e) => write!(f, "{e}"),
            ExecError::UnknownBuffer(b) => write!(f, "unknown buffer {b:?}"),
            ExecError::OutOfRange {
                buffer,
                bytes,
                size,
            } => {
                write!(
                    f,
                    "{bytes} bytes do not fit buffer {buffer:?} of {size} bytes"
                )
            }
            ExecError::UnalignedSize(s) => write!(f, "buffer size {s} is not a multiple of 4"),
            ExecError::AliasedBinding(b) => write!(f, "buffer {b:?} bound twice in one pass"),
            ExecError::IndirectWritten(b) => write!(
                f,
                "buffer {b:?} holds the pass's indirect counts and is also written by the pass"
            ),
            ExecError::WrongKind {
                binding,
                id,
                texture: true,
            } => write!(
                f,
                "binding `{binding}` reads a texture, but {id:?} is a buffer"
            ),
            ExecError::WrongKind { binding, id, .. } => write!(
                f,
                "binding `{binding}` is a storage buffer, but {id:?} is a texture"
            ),
        }
    }
}

impl core::error::Error for ExecError {}

/// GPU (or CPU wall) time of one executed pass.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PassTiming {
    /// Kernel entry point.
    pub entry: &'static str,
    /// Duration in milliseconds.
    pub ms: f64,
}

/// The largest storage buffer a kernel may bind on an executor, and the device limit that sets
/// it: sizes are checked against it before any work starts.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct BindingLimit {
    /// Bytes.
    pub bytes: u64,
    /// The device limit's name (e.g. `maxStorageBufferRange`).
    pub name: &'static str,
}

impl BindingLimit {
    /// No limit (the CPU backend: buffers are host memory).
    pub const NONE: BindingLimit = BindingLimit {
        bytes: u64::MAX,
        name: "no limit",
    };
}

/// What a backend must do to run any plan. Recording may be deferred: work is only guaranteed
/// complete once [`Executor::read_buffer`] or [`Executor::finish`] returns.
pub trait Executor {
    /// Backend error.
    type Error: fmt::Debug + fmt::Display;
    /// Short backend name (`cpu`, `wgpu`, `ash`).
    fn name(&self) -> &'static str;
    /// The largest buffer a pass may bind (default: no limit).
    fn binding_limit(&self) -> BindingLimit {
        BindingLimit::NONE
    }
    /// Allocates a zero-filled storage buffer of `size_bytes` (a multiple of 4).
    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, Self::Error>;
    /// Copies `data` to the start of `buffer`.
    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), Self::Error>;
    /// A buffer holding `data` (its size `data`'s length, rounded up to a multiple of 4 and at
    /// least 4), which the caller will not change: an executor whose buffers are host memory
    /// may keep `data` itself instead of a copy, so that large read-only inputs (a scene's
    /// triangles and BVH) are held once in the process rather than once by the host and once
    /// by the executor. The buffer behaves as any other: writing it, or binding it to a pass
    /// that writes it, leaves `data` unchanged. The default creates a buffer and copies `data`.
    #[cfg(feature = "std")]
    fn create_buffer_shared(
        &mut self,
        data: std::sync::Arc<dyn SharedBytes>,
    ) -> Result<BufferId, Self::Error> {
        let bytes = data.bytes();
        let id = self.create_buffer((bytes.len() as u64).max(4).next_multiple_of(4))?;
        self.write_buffer(id, bytes)?;
        Ok(id)
    }
    /// Records (or runs) one pass.
    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), Self::Error>;
    /// Waits for recorded work, then copies the start of `buffer` into `out`.
    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), Self::Error>;
    /// Submits recorded work and waits for it.
    fn finish(&mut self) -> Result<(), Self::Error>;
    /// Timings of the passes completed since the last [`Executor::clear_timings`], in order.
    fn timings(&self) -> &[PassTiming];
    /// Forgets recorded timings.
    fn clear_timings(&mut self);
}

/// Bytes that an executor may keep for the life of a buffer instead of copying them
/// ([`Executor::create_buffer_shared`]); they must not change while it does.
#[cfg(feature = "std")]
pub trait SharedBytes: Send + Sync {
    /// The bytes.
    fn bytes(&self) -> &[u8];
}

#[cfg(feature = "std")]
impl SharedBytes for std::vec::Vec<u32> {
    fn bytes(&self) -> &[u8] {
        bytemuck::cast_slice(self)
    }
}

/// A storage buffer as the CPU backend hands it to a kernel.
#[derive(Copy, Clone, Debug)]
pub struct RawBuffer {
    /// Start of the buffer, 4-byte aligned.
    pub ptr: *mut u8,
    /// Length in bytes.
    pub len: usize,
}

/// The bindings of one CPU dispatch: the native counterpart of a descriptor set plus push
/// constants. Kernels see typed slices, exactly as the shader entry points do.
pub struct CpuBindings<'a> {
    buffers: &'a [RawBuffer],
    params: &'a [u8],
    workgroup_size: UVec3,
}

// SAFETY: workgroups share buffers like GPU invocations do; kernels write only elements their
// invocation owns, or through `crate::atomic`.
unsafe impl Sync for CpuBindings<'_> {}

impl<'a> CpuBindings<'a> {
    /// # Safety
    /// Each buffer must be valid for reads and writes of `len` bytes, 4-byte aligned, and live
    /// for `'a`; nothing else may access them while kernels run.
    pub unsafe fn new(
        buffers: &'a [RawBuffer],
        params: &'a [u8],
        workgroup_size: [u32; 3],
    ) -> Self {
        CpuBindings {
            buffers,
            params,
            workgroup_size: UVec3::from_array(workgroup_size),
        }
    }

    /// Binding `i` as a shared slice.
    ///
    /// # Safety
    /// No invocation may write the elements read through it during the dispatch.
    pub unsafe fn read<T: bytemuck::Pod>(&self, i: usize) -> &'a [T] {
        let b = self.buffers[i];
        assert!(core::mem::align_of::<T>() <= 4);
        // SAFETY: see `new`; alignment checked above, length rounded down to whole elements.
        unsafe { core::slice::from_raw_parts(b.ptr as *const T, b.len / core::mem::size_of::<T>()) }
    }

    /// Binding `i` as a mutable slice.
    ///
    /// # Safety
    /// Concurrent workgroups each get this slice; each invocation may write only the elements it
    /// owns (or use `crate::atomic`).
    #[allow(clippy::mut_from_ref)]
    pub unsafe fn write<T: bytemuck::Pod>(&self, i: usize) -> &'a mut [T] {
        let b = self.buffers[i];
        assert!(core::mem::align_of::<T>() <= 4);
        // SAFETY: as `read`; disjointness of writes is the kernel's contract.
        unsafe {
            core::slice::from_raw_parts_mut(b.ptr as *mut T, b.len / core::mem::size_of::<T>())
        }
    }

    /// The push constants.
    pub fn params<T: bytemuck::Pod>(&self) -> T {
        bytemuck::pod_read_unaligned(&self.params[..core::mem::size_of::<T>()])
    }

    /// Calls `f` with the global id of every invocation of workgroup `group`, x fastest: plain
    /// nested loops, which the compiler fuses with the inlined kernel body (an iterator of ids
    /// cost a tenth of the CPU time of the filter passes).
    #[inline(always)]
    pub fn for_each_invocation(&self, group: UVec3, mut f: impl FnMut(UVec3)) {
        let size = self.workgroup_size;
        let base = group * size;
        for z in 0..size.z {
            for y in 0..size.y {
                for x in 0..size.x {
                    f(base + UVec3::new(x, y, z));
                }
            }
        }
    }

    /// Number of invocations per workgroup.
    pub fn workgroup_len(&self) -> u32 {
        self.workgroup_size.x * self.workgroup_size.y * self.workgroup_size.z
    }
}

#[cfg(test)]
mod tests;
