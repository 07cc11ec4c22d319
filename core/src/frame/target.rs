//! Where a frame's rays are traced from and written to: the G-buffer ray generation reads and
//! the work list, history and samples of one raygen pass. Below both the planes' raygen
//! ([`super::trace_planes`]) and the reflections' ([`crate::reflections`]), which share them.

use crate::denoiser::{Denoiser, Inputs};
use crate::executor::{BufferId, Executor, Groups};
use crate::kernels::{self, work_list};

/// What the renderer's ray generation reads of the G-buffer: the denoiser's inputs, the
/// renderer's own `geometry` (geometric normal, instance) and the cameras.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct GBuffer {
    /// Depth, normal + roughness, motion.
    pub inputs: Inputs,
    /// `[u32; 2]` per pixel: [`crate::packing::pack_hit`].
    pub geometry: BufferId,
    /// The one-element [`crate::camera::View`].
    pub view: BufferId,
}

impl GBuffer {
    /// A G-buffer of its own (no denoiser): for references and tests. Write the cameras into
    /// `view` before use.
    pub fn create<E: Executor>(exec: &mut E, width: u32, height: u32) -> Result<Self, E::Error> {
        let pixels = width as u64 * height as u64;
        Ok(GBuffer {
            inputs: Inputs {
                depth: exec.create_buffer(pixels * 4)?,
                normal_roughness: exec.create_buffer(pixels * 4)?,
                motion: exec.create_buffer(pixels * 8)?,
            },
            geometry: exec.create_buffer(pixels * 8)?,
            view: exec.create_buffer(core::mem::size_of::<crate::camera::View>() as u64)?,
        })
    }

    /// This frame's inputs and view of `denoiser`, with the renderer's `geometry`.
    pub fn of(denoiser: &Denoiser, geometry: BufferId) -> Self {
        GBuffer {
            inputs: denoiser.inputs(),
            geometry,
            view: denoiser.view(),
        }
    }
}

/// What a raygen pass traces and where it writes, besides the scene: a compacted work list
/// (dispatched indirectly from `args` at byte offset 4), the G-buffer, the history whose rng
/// indices seed the rays, and the `Sample`s of a `size` image.
#[derive(Copy, Clone, Debug)]
pub struct RaygenTarget {
    /// Image width and height in pixels.
    pub size: (u32, u32),
    /// Compacted work list (`apply`).
    pub work: BufferId,
    /// Indirect dispatch arguments of the work list.
    pub args: BufferId,
    /// The G-buffer.
    pub gbuffer: GBuffer,
    /// Payloads whose rng indices seed the rays.
    pub history: BufferId,
    /// Samples written.
    pub out: BufferId,
    /// The shadow raygen's blocker records (`f32` per pixel, `Denoiser::blockers`) of plane
    /// `blocker_plane`, or `NO_PLANE` and a buffer of one element for none.
    pub blockers: BufferId,
    /// The plane whose blocker records raygen writes.
    pub blocker_plane: u32,
    /// Frame index: the reflection ray records' stamp and the screen-blue pattern's shift.
    pub frame: u32,
    /// Which plane group (work list) traces each plane (`Layout::plane_groups`).
    pub plane_groups: u32,
    /// [`crate::sampling::SamplePattern::code`] of the rays' first two random numbers.
    pub sampling: u32,
    /// The refill lists' pass: reflection rays add to the pixel's sample (`RaygenParams::merge`).
    pub merge: bool,
}

impl RaygenTarget {
    /// The denoiser's own work list, inputs, reprojected history and samples this frame, with
    /// the renderer's `geometry` (geometric normal, instance).
    pub fn of(denoiser: &Denoiser, geometry: BufferId) -> Self {
        RaygenTarget {
            size: denoiser.size(),
            work: denoiser.work(),
            args: denoiser.args(),
            gbuffer: GBuffer::of(denoiser, geometry),
            history: denoiser.history(),
            out: denoiser.samples(),
            blockers: denoiser.blockers(),
            blocker_plane: denoiser
                .layout()
                .penumbra_plane
                .unwrap_or(kernels::reproject::NO_PLANE),
            frame: denoiser.frame().index,
            plane_groups: denoiser.layout().plane_groups,
            sampling: denoiser.settings().temporal.sampling.code(),
            merge: false,
        }
    }

    /// As [`Self::of`], over the denoiser's refill lists ([`Denoiser::detect_changes`]).
    pub fn refill(denoiser: &Denoiser, geometry: BufferId) -> Self {
        RaygenTarget {
            work: denoiser.refill_work(),
            args: denoiser.refill_args(),
            merge: true,
            ..Self::of(denoiser, geometry)
        }
    }

    /// The work list that traces plane `plane`.
    pub fn list(&self, plane: u32) -> u32 {
        kernels::plane_group(self.plane_groups, plane)
    }

    /// The indirect dispatch of work list `list`.
    pub fn groups(&self, list: u32) -> Groups {
        Groups::Indirect {
            buffer: self.args,
            offset: 4 * work_list::ARGS_LEN as u64 * list as u64 + 4,
        }
    }
}
