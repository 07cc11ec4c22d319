//! The CPU backend: the same kernel functions the GPU runs, called natively.
//!
//! Runs of workgroups ([`GroupSpan`]) run in parallel on rayon's pool; within a workgroup,
//! invocations run in order (and kernels with barriers run phase by phase, see
//! `vrrt_core::executor::KernelDesc::cpu`). Storage
//! buffers are plain `Vec<u32>`, so the CPU backend is also the easiest way to use VRRT-rs from a
//! Rust program: create buffers, write slices, dispatch, read back.
//!
//! A buffer made by [`Executor::create_buffer_shared`] keeps the caller's bytes instead of a
//! copy for as long as nothing writes it: a scene's triangles and BVH are then held once in the
//! process, by the scene, however many renderers bind them.

use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;
use vrrt_core::executor::{
    BufferId, CpuBindings, ExecError, Executor, GroupSpan, Groups, Pass, PassTiming, RawBuffer,
    SharedBytes,
};
use vrrt_core::textures::Texel;

/// Errors of the CPU backend: only those every backend shares (the CPU has no device that could
/// fail), so this is [`ExecError`] itself.
pub type CpuError = ExecError;

/// Runs plans on the CPU.
///
/// The denoiser on plain slices: a static wall in front of the camera whose rays all return 0.5,
/// denoised over a few frames.
///
/// ```
/// use vrrt_core::camera::{Camera, View};
/// use vrrt_core::denoiser::{Denoiser, FrameInfo};
/// use vrrt_core::glam::Vec3;
/// use vrrt_core::packing::{pack_motion, pack_normal_roughness};
/// use vrrt_core::payload::{PackedFiltered, Sample};
/// use vrrt_core::executor::Executor;
/// use vrrt_core::settings::Settings;
/// use vrrt_cpu::CpuExecutor;
///
/// let (width, height) = (32, 24);
/// let pixels = (width * height) as usize;
/// let mut cpu = CpuExecutor::new();
/// // Full VRRT at its default budget (1 ray per pixel), one signal plane (say AO).
/// let settings = Settings::default();
/// let mut denoiser = Denoiser::new(&mut cpu, width, height, settings)?;
///
/// // The G-buffer: a wall 10 units away facing a camera that does not move.
/// let tan_half_fov = 0.577;
/// let camera = Camera::from_basis(Vec3::ZERO, Vec3::X, -Vec3::Y, Vec3::Z, tan_half_fov);
/// let depth = vec![10.0f32; pixels];
/// let normal_roughness = vec![pack_normal_roughness(-Vec3::Z, 1.0); pixels];
/// let motion = vec![pack_motion(0.0, 0.0, 0.0); pixels];
///
/// for index in 0..4 {
///     let frame = FrameInfo {
///         index,
///         reset: index == 0,
///         pixel_angle: 2.0 * tan_half_fov / height as f32,
///         view: View { camera, prev_camera: camera },
///         ..FrameInfo::default()
///     };
///     denoiser.begin_frame(&mut cpu, frame)?;
///     let inputs = denoiser.inputs();
///     cpu.write_buffer(inputs.depth, bytemuck::cast_slice(&depth))?;
///     cpu.write_buffer(inputs.normal_roughness, bytemuck::cast_slice(&normal_roughness))?;
///     cpu.write_buffer(inputs.motion, bytemuck::cast_slice(&motion))?;
///     denoiser.plan_rays(&mut cpu)?;
///     // The application traces the rays each pixel was granted; here every ray returns 0.5.
///     let samples: Vec<_> = denoiser
///         .read_rays(&mut cpu)?
///         .into_iter()
///         .map(|rays| {
///             let v = if rays > 0 { 0.5 } else { 0.0 };
///             Sample { m1: v, m2: v * v, rays, first: v }.pack()
///         })
///         .collect();
///     cpu.write_buffer(denoiser.samples(), bytemuck::cast_slice(&samples))?;
///     denoiser.resolve(&mut cpu)?;
/// }
///
/// let mut out = vec![PackedFiltered::default(); pixels];
/// cpu.read_buffer(denoiser.output(), bytemuck::cast_slice_mut(&mut out))?;
/// assert!(out.iter().all(|f| (f.unpack().value - 0.5).abs() < 1e-3));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Default)]
pub struct CpuExecutor {
    buffers: Vec<Storage>,
    /// The buffers that hold an engine texture (`Access::Sampled` and `Access::Storage` bindings).
    textures: std::collections::HashSet<BufferId>,
    timings: Vec<PassTiming>,
}

/// A buffer's memory: the executor's own, or bytes it shares with the caller (read-only, 4-byte
/// aligned, a whole number of words), copied into its own the first time anything writes them.
enum Storage {
    Owned(Vec<u32>),
    Shared(Arc<dyn SharedBytes>),
}

impl Storage {
    fn words(&self) -> &[u32] {
        match self {
            Storage::Owned(v) => v,
            // Checked aligned and a whole number of words when it was shared.
            Storage::Shared(s) => bytemuck::cast_slice(s.bytes()),
        }
    }

    /// The buffer's words to write, copying shared bytes into the executor's own first.
    fn owned(&mut self) -> &mut Vec<u32> {
        if let Storage::Shared(s) = self {
            *self = Storage::Owned(bytemuck::cast_slice(s.bytes()).to_vec());
        }
        match self {
            Storage::Owned(v) => v,
            Storage::Shared(_) => unreachable!("made owned above"),
        }
    }
}

impl CpuExecutor {
    /// A new executor with no buffers.
    pub fn new() -> Self {
        Self::default()
    }

    fn buffer(&self, id: BufferId) -> Result<&[u32], CpuError> {
        self.buffers
            .get(id.0 as usize)
            .map(Storage::words)
            .ok_or(ExecError::UnknownBuffer(id))
    }

    fn buffer_mut(&mut self, id: BufferId) -> Result<&mut Vec<u32>, CpuError> {
        self.buffers
            .get_mut(id.0 as usize)
            .map(Storage::owned)
            .ok_or(ExecError::UnknownBuffer(id))
    }

    /// Contents of a buffer, without copying (for a shared buffer nothing has written, the very
    /// bytes it was created from).
    pub fn contents(&self, id: BufferId) -> Result<&[u8], CpuError> {
        Ok(bytemuck::cast_slice(self.buffer(id)?))
    }

    /// Bytes of the buffers this executor holds itself: shared buffers
    /// ([`Executor::create_buffer_shared`]) that nothing has written are the caller's memory
    /// and not counted.
    pub fn owned_bytes(&self) -> u64 {
        self.buffers
            .iter()
            .map(|b| match b {
                Storage::Owned(v) => v.len() as u64 * 4,
                Storage::Shared(_) => 0,
            })
            .sum()
    }

    /// An engine texture for `Denoiser::ingest`: `width × height` texels, row-major, each what a
    /// texel fetch of the engine's format returns ([`Texel`]). Rewrite it each frame with
    /// [`Executor::write_buffer`].
    pub fn create_texture(
        &mut self,
        width: u32,
        height: u32,
        texels: &[Texel],
    ) -> Result<BufferId, CpuError> {
        let id = BufferId(self.buffers.len() as u32);
        let len = width as u64 * height as u64;
        if texels.len() as u64 != len {
            return Err(ExecError::OutOfRange {
                buffer: id,
                bytes: texels.len() as u64 * 16,
                size: len * 16,
            });
        }
        self.buffers
            .push(Storage::Owned(bytemuck::cast_slice(texels).to_vec()));
        self.textures.insert(id);
        Ok(id)
    }

    /// Size in bytes of buffer `id`, `None` if unknown.
    fn size_of(&self, id: BufferId) -> Option<u64> {
        self.buffer(id).ok().map(|b| b.len() as u64 * 4)
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
        self.buffers
            .push(Storage::Owned(vec![0u32; (size_bytes / 4) as usize]));
        Ok(BufferId(self.buffers.len() as u32 - 1))
    }

    /// Keeps `data` itself when it is a non-empty whole number of 4-byte-aligned words (a
    /// kernel reads it in place); anything else is copied, as by the default.
    fn create_buffer_shared(&mut self, data: Arc<dyn SharedBytes>) -> Result<BufferId, CpuError> {
        let bytes = data.bytes();
        let words = !bytes.is_empty()
            && bytes.len().is_multiple_of(4)
            && bytes.as_ptr().align_offset(4) == 0;
        if !words {
            let id = self.create_buffer((bytes.len() as u64).max(4).next_multiple_of(4))?;
            self.write_buffer(id, bytes)?;
            return Ok(id);
        }
        self.buffers.push(Storage::Shared(data));
        Ok(BufferId(self.buffers.len() as u32 - 1))
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), CpuError> {
        let size = self
            .size_of(buffer)
            .ok_or(ExecError::UnknownBuffer(buffer))?;
        ExecError::check_range(buffer, data.len() as u64, size)?;
        let b = self.buffer_mut(buffer)?;
        bytemuck::cast_slice_mut::<u32, u8>(b)[..data.len()].copy_from_slice(data);
        Ok(())
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), CpuError> {
        pass.check(|id| self.size_of(id), |id| self.textures.contains(&id))?;
        let groups = self.group_counts(pass.groups)?;
        let raw: Vec<RawBuffer> = pass
            .buffers
            .iter()
            .zip(pass.kernel.bindings)
            .map(|(id, binding)| {
                let b = &mut self.buffers[id.0 as usize];
                if binding.access.writes() {
                    let v = b.owned();
                    return RawBuffer {
                        ptr: v.as_mut_ptr() as *mut u8,
                        len: v.len() * 4,
                    };
                }
                let words = b.words();
                RawBuffer {
                    ptr: words.as_ptr() as *mut u8,
                    len: words.len() * 4,
                }
            })
            .collect();
        let start = Instant::now();
        // SAFETY: every pointer comes from a distinct live buffer (aliasing checked above) that
        // is not touched until the dispatch returns; shared bytes are bound only where the
        // kernel declares a read, and kernels write only what they declare.
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
