//! The raygen stage: which raygen kernel traces which plane of a [`Signal`], over a work list.

use super::{FrameScene, PlaneLayout, Signal};
use crate::denoiser::Denoiser;
use crate::kernels::{self, raygen};
use crate::plan::{BufferId, Executor, Groups};
use crate::reflections::Reflections;

/// What a raygen pass traces and where it writes, besides the scene: a compacted work list
/// (dispatched indirectly from `args` at byte offset 4), the surfaces, the history whose rng
/// indices seed the rays, and the `Sample`s of a `size` image.
#[derive(Copy, Clone, Debug)]
pub struct RaygenTarget {
    /// Image width and height in pixels.
    pub size: (u32, u32),
    /// Compacted work list (`apply`).
    pub work: BufferId,
    /// Indirect dispatch arguments of the work list.
    pub args: BufferId,
    /// Rays per pixel.
    pub rays: BufferId,
    /// The G-buffer.
    pub surfaces: BufferId,
    /// Payloads whose rng indices seed the rays.
    pub history: BufferId,
    /// Samples written.
    pub out: BufferId,
    /// Frame stamp of the reflection ray records.
    pub frame: u32,
}

impl RaygenTarget {
    /// The denoiser's own work list, reprojected history and samples this frame.
    pub fn of(denoiser: &Denoiser) -> Self {
        RaygenTarget {
            size: denoiser.size(),
            work: denoiser.work(),
            args: denoiser.args(),
            rays: denoiser.rays(),
            surfaces: denoiser.surfaces(),
            history: denoiser.reprojected(),
            out: denoiser.samples(),
            frame: denoiser.frame().index,
        }
    }

    /// The indirect dispatch of the work list.
    pub fn groups(&self) -> Groups {
        Groups::Indirect {
            buffer: self.args,
            offset: 4,
        }
    }
}

/// Records the raygen of every plane of `signal` (laid out as `layout`) over `target`'s work
/// list: AO, the shadow of each light, and the reflection rays when `reflections` is given.
pub fn trace_planes<E: Executor>(
    exec: &mut E,
    signal: Signal,
    layout: &PlaneLayout,
    scene: &FrameScene<'_>,
    reflections: Option<&Reflections>,
    target: &RaygenTarget,
) -> Result<(), E::Error> {
    let (width, height) = target.size;
    let ao = kernels::RaygenAoBindings {
        work: target.work,
        args: target.args,
        rays: target.rays,
        surfaces: target.surfaces,
        history: target.history,
        nodes: scene.nodes,
        tris: scene.tris,
        out: target.out,
    };
    if let Some(max_distance) = signal.ao_distance() {
        let p = raygen::AoParams {
            width,
            height,
            planes: 1,
            max_distance,
        };
        exec.dispatch(&ao.pass(&p, target.groups()))?;
    }
    if let Some((first_plane, planes)) = layout.shadows {
        let p = raygen::ShadowParams {
            width,
            height,
            planes,
            first_plane,
        };
        let shadow = kernels::RaygenShadowBindings {
            work: ao.work,
            args: ao.args,
            rays: ao.rays,
            surfaces: ao.surfaces,
            history: ao.history,
            nodes: ao.nodes,
            tris: ao.tris,
            lights: scene.lights,
            out: ao.out,
        };
        exec.dispatch(&shadow.pass(&p, target.groups()))?;
    }
    if let Some(r) = reflections {
        r.raygen(exec, &scene.reflection_scene(), target)?;
    }
    Ok(())
}
