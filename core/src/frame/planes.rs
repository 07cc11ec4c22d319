//! The raygen stage: which raygen kernel traces which plane of a [`Signal`], over a work list.

use super::target::RaygenTarget;
use super::{FrameScene, PlaneLayout, Signal};
use crate::executor::Executor;
use crate::kernels::{self, raygen};
use crate::reflections::Reflections;

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
        depth: target.gbuffer.inputs.depth,
        normal_roughness: target.gbuffer.inputs.normal_roughness,
        geometry: target.gbuffer.geometry,
        view: target.gbuffer.view,
        history: target.history,
        nodes: scene.nodes,
        tris: scene.tris,
        out: target.out,
    };
    if let (Some(max_distance), Some(plane)) = (signal.ao_distance(), layout.ao) {
        let p = raygen::AoParams {
            width,
            height,
            planes: 1,
            max_distance,
            list: target.list(plane),
            frame: target.frame,
            sampling: target.sampling,
            _pad: 0,
        };
        exec.dispatch(&ao.pass(&p, target.groups(p.list)))?;
    }
    if let Some((first_plane, planes)) = layout.shadows {
        let p = raygen::ShadowParams {
            width,
            height,
            planes,
            first_plane,
            list: target.list(first_plane),
            frame: target.frame,
            sampling: target.sampling,
            blocker_plane: target.blocker_plane,
        };
        let shadow = kernels::RaygenShadowBindings {
            work: ao.work,
            args: ao.args,
            depth: ao.depth,
            normal_roughness: ao.normal_roughness,
            geometry: ao.geometry,
            view: ao.view,
            history: ao.history,
            nodes: ao.nodes,
            tris: ao.tris,
            lights: scene.lights,
            out: ao.out,
            blockers: target.blockers,
        };
        exec.dispatch(&shadow.pass(&p, target.groups(p.list)))?;
    }
    if let Some(r) = reflections {
        r.raygen(exec, &scene.reflection_scene(), target)?;
    }
    Ok(())
}
