//! SPIR-V entry points. Each is one line that forwards to the kernel in `vrrt-core`; the
//! `threads(...)` and bindings must match the kernel's `KernelDesc` (the tests crate checks the
//! workgroup sizes against the built module). Built by `shaders-builder` into `shaders/vrrt.spv`.
#![cfg_attr(target_arch = "spirv", no_std)]
#![allow(missing_docs)]
// Entry points take one argument per binding: long lists are inherent.
#![allow(clippy::too_many_arguments)]

use spirv_std::glam::UVec3;
use spirv_std::spirv;
use vrrt_core::gbuffer::Surface;
use vrrt_core::kernels::{
    accumulate, apply, atrous, balance, buckets, classify, clear, gbuffer, gradient, raygen,
    reflect, reproject, variance,
};
use vrrt_core::payload::{Payload, Sample};
use vrrt_core::trace::{BvhNode, Triangle, TriangleNormals};

#[spirv(compute(threads(8, 8, 1)))]
pub fn accumulate(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &accumulate::AccumulateParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] history: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] samples: &[Sample],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] out: &mut [Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] counters: &mut [u32],
) {
    accumulate::accumulate(id, p, history, samples, out, counters);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn atrous(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &atrous::AtrousParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] input: &[atrous::Filtered],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] tiles: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] out: &mut [atrous::Filtered],
) {
    atrous::atrous(id, p, input, surfaces, tiles, out);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn classify(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &classify::ClassifyParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] filtered: &[atrous::Filtered],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] tiles: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] histogram: &mut [u32],
) {
    classify::classify(id, p, surfaces, filtered, tiles, histogram);
}

#[spirv(compute(threads(16, 16, 1)))]
pub fn count_buckets(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(local_invocation_index)] lid: u32,
    #[spirv(push_constant)] p: &buckets::BucketParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] requests: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] counts: &mut [u32],
    #[spirv(workgroup)] local: &mut [u32; buckets::BUCKET_COUNT as usize],
) {
    buckets::clear(lid, local);
    vrrt_core::atomic::workgroup_barrier();
    buckets::count(id, p, requests, local);
    vrrt_core::atomic::workgroup_barrier();
    buckets::flush(lid, group, p, local, counts);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn gbuffer(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &gbuffer::GbufferParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] tris: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] normals: &[TriangleNormals],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] instances: &[gbuffer::InstanceData],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] out: &mut [Surface],
) {
    gbuffer::gbuffer(id, p, nodes, tris, normals, instances, out);
}

#[spirv(compute(threads(64, 1, 1)))]
pub fn raygen_ao(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &raygen::AoParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] work: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] args: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] rays: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] history: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] tris: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] out: &mut [Sample],
) {
    raygen::raygen_ao(id, p, work, args, rays, surfaces, history, nodes, tris, out);
}

#[spirv(compute(threads(64, 1, 1)))]
pub fn raygen_shadow(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &raygen::ShadowParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] work: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] args: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] rays: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] history: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] tris: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] lights: &[raygen::AreaLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] out: &mut [Sample],
) {
    raygen::raygen_shadow(
        id, p, work, args, rays, surfaces, history, nodes, tris, lights, out,
    );
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn reproject(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &reproject::ReprojectParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] prev_surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] history: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] mask: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)]
    gradient: &[gradient::GradientSample],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] importance: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] parallax: &[[f32; 2]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] out: &mut [Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] flags: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] requests: &mut [u32],
) {
    reproject::reproject(
        id,
        p,
        surfaces,
        prev_surfaces,
        history,
        mask,
        gradient,
        importance,
        parallax,
        out,
        flags,
        requests,
    );
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn variance(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &variance::VarianceParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] payload: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] out: &mut [atrous::Filtered],
) {
    variance::variance(id, p, payload, surfaces, out);
}

#[spirv(compute(threads(1, 1, 1)))]
pub fn balance(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &balance::BalanceParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counts: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] out: &mut [balance::Balance],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] args: &mut [u32],
) {
    balance::balance(id, p, counts, out, args);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn apply(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &apply::ApplyParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] requests: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] decision: &[balance::Balance],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] noise: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] rays: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] work: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] args: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] samples: &mut [Sample],
) {
    apply::apply(id, p, requests, decision, noise, rays, work, args, samples);
}

#[spirv(compute(threads(64, 1, 1)))]
pub fn fill(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &clear::FillParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] buf: &mut [u32],
) {
    clear::fill(id, p, buf);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn gradient_project(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &gradient::ProjectParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] prev_surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] rays: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] next: &[gbuffer::InstanceData],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] keys: &mut [u32],
) {
    gradient::project(id, p, prev_surfaces, surfaces, rays, next, keys);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn gradient_ao(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &gradient::RetraceParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] prev_surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] next: &[gbuffer::InstanceData],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] prev_payload: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] prev_samples: &[Sample],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] tris: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)]
    out: &mut [gradient::GradientSample],
) {
    gradient::retrace_ao(
        id,
        p,
        keys,
        prev_surfaces,
        next,
        prev_payload,
        prev_samples,
        nodes,
        tris,
        out,
    );
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn gradient_shadow(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &gradient::RetraceParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] prev_surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] next: &[gbuffer::InstanceData],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] prev_payload: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] prev_samples: &[Sample],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] tris: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] lights: &[raygen::AreaLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)]
    out: &mut [gradient::GradientSample],
) {
    gradient::retrace_shadow(
        id,
        p,
        keys,
        prev_surfaces,
        next,
        prev_payload,
        prev_samples,
        nodes,
        tris,
        lights,
        out,
    );
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn gradient_atrous(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &gradient::AtrousParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] input: &[gradient::GradientSample],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)]
    out: &mut [gradient::GradientSample],
) {
    gradient::atrous(id, p, input, out);
}

#[spirv(compute(threads(64, 1, 1)))]
pub fn raygen_reflect(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &reflect::RaygenParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] work: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] args: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] rays: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] history: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] tris: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] lights: &[raygen::AreaLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] out: &mut [Sample],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] hits: &mut [reflect::RayHit],
) {
    reflect::raygen_reflect(
        id, p, work, args, rays, surfaces, history, nodes, tris, lights, out, hits,
    );
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn reflect_tiles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &reflect::TileParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] nodes: &[BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] tris: &[Triangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] lights: &[raygen::AreaLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] importance: &mut [f32],
) {
    reflect::reflect_tiles(id, p, surfaces, nodes, tris, lights, importance);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn reflect_motion(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &reflect::MotionParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] hits: &[reflect::RayHit],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] motion: &mut [[f32; 2]],
) {
    reflect::reflect_motion(id, p, surfaces, hits, motion);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn reflect_reuse(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &reflect::ReuseParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] hits: &[reflect::RayHit],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] samples: &mut [Sample],
) {
    reflect::reflect_reuse(id, p, surfaces, hits, samples);
}
