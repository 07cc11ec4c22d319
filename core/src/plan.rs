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
    /// Each invocation writes (and may read) only the elements it owns.
    Write,
    /// Invocations contend through integer atomics (`crate::atomic`): counters, histograms,
    /// packed-key min/max.
    Atomic,
}

impl Access {
    /// Whether the kernel may modify the buffer.
    pub fn writes(self) -> bool {
        self != Access::Read
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

/// Native entry of a kernel: runs every invocation of workgroup `group`.
///
/// # Safety
/// `bindings` must describe buffers laid out as the kernel expects (see [`CpuBindings::new`]).
pub type CpuGroupFn = unsafe fn(group: UVec3, bindings: &CpuBindings<'_>);

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
#[derive(
    Copy, Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Pod, Zeroable,
)]
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

/// GPU (or CPU wall) time of one executed pass.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PassTiming {
    /// Kernel entry point.
    pub entry: &'static str,
    /// Duration in milliseconds.
    pub ms: f64,
}

/// What a backend must do to run any plan. Recording may be deferred: work is only guaranteed
/// complete once [`Executor::read_buffer`] or [`Executor::finish`] returns.
pub trait Executor {
    /// Backend error.
    type Error: fmt::Debug + fmt::Display;
    /// Short backend name (`cpu`, `wgpu`, `ash`).
    fn name(&self) -> &'static str;
    /// Allocates a zero-filled storage buffer of `size_bytes` (a multiple of 4).
    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, Self::Error>;
    /// Copies `data` to the start of `buffer`.
    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), Self::Error>;
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

    /// Global invocation ids of workgroup `group`, x fastest.
    pub fn invocations(&self, group: UVec3) -> impl Iterator<Item = UVec3> {
        let size = self.workgroup_size;
        let base = group * size;
        (0..size.z).flat_map(move |z| {
            (0..size.y).flat_map(move |y| (0..size.x).map(move |x| base + UVec3::new(x, y, z)))
        })
    }

    /// Number of invocations per workgroup.
    pub fn workgroup_len(&self) -> u32 {
        self.workgroup_size.x * self.workgroup_size.y * self.workgroup_size.z
    }
}

/// Declares a kernel's [`KernelDesc`] and its native per-workgroup entry: each invocation calls the
/// kernel function with the bindings cast to the given slice types, like the SPIR-V entry does.
#[macro_export]
macro_rules! per_invocation_kernel {
    (
        $(#[$doc:meta])*
        $name:ident = $entry:literal, $kernel:path, threads($x:literal, $y:literal, $z:literal),
        params: $params:ty, bindings: [$($bind:ident: $access:ident $ty:ty),* $(,)?]
    ) => {
        $(#[$doc])*
        pub static $name: $crate::plan::KernelDesc = $crate::plan::KernelDesc {
            entry: $entry,
            workgroup_size: [$x, $y, $z],
            bindings: &[$($crate::plan::Binding {
                name: stringify!($bind),
                ty: stringify!($ty),
                elem_size: core::mem::size_of::<$ty>() as u32,
                access: $crate::per_invocation_kernel!(@access $access),
            }),*],
            params_size: core::mem::size_of::<$params>() as u32,
            cpu: {
                unsafe fn run(group: $crate::glam::UVec3, b: &$crate::plan::CpuBindings<'_>) {
                    let params: $params = b.params();
                    let mut _i = 0usize;
                    $(
                        // SAFETY: bindings laid out as declared (caller's contract).
                        let $bind = unsafe { $crate::per_invocation_kernel!(@bind $access b _i $ty) };
                        _i += 1;
                    )*
                    for id in b.invocations(group) {
                        $kernel(id, &params, $($bind),*);
                    }
                }
                run
            },
        };
    };
    (@access Read) => { $crate::plan::Access::Read };
    (@access ReadWrite) => { $crate::plan::Access::Write };
    (@bind Read $b:ident $i:ident $ty:ty) => { $b.read::<$ty>($i) };
    (@bind ReadWrite $b:ident $i:ident $ty:ty) => { $b.write::<$ty>($i) };
}
