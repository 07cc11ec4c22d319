//! SPIR-V entry points. Each is one line that forwards to the kernel in `vrrt-core`; the
//! `threads(...)` and bindings must match the kernel's `KernelDesc` (the tests crate checks the
//! workgroup sizes against the built module). Built by `shaders-builder` into `shaders/vrrt.spv`.
#![cfg_attr(target_arch = "spirv", no_std)]
#![allow(missing_docs)]

use spirv_std::glam::UVec3;
use spirv_std::spirv;
use vrrt_core::gbuffer::Surface;
use vrrt_core::kernels::{accumulate, atrous, buckets};
use vrrt_core::payload::{Payload, Sample};

#[spirv(compute(threads(8, 8, 1)))]
pub fn accumulate(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &accumulate::AccumulateParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] history: &[Payload],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] samples: &[Sample],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] out: &mut [Payload],
) {
    accumulate::accumulate(id, p, history, samples, out);
}

#[spirv(compute(threads(8, 8, 1)))]
pub fn atrous(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] p: &atrous::AtrousParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] input: &[atrous::Filtered],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] surfaces: &[Surface],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] out: &mut [atrous::Filtered],
) {
    atrous::atrous(id, p, input, surfaces, out);
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
