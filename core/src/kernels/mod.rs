//! One module per pass. Each exposes plain functions over one invocation id plus its bindings, the
//! push-constant struct, and (on the host) its [`KernelDesc`](crate::plan::KernelDesc).

pub mod accumulate;
pub mod apply;
pub mod atrous;
pub mod balance;
pub mod buckets;
pub mod classify;
pub mod clear;
pub mod gbuffer;
pub mod gradient;
pub mod raygen;
pub mod reflect;
pub mod reproject;
pub mod variance;

use glam::UVec3;

/// Index of element `(x, y)` of signal plane `z` in a row-major, plane-stacked image.
#[inline]
pub fn plane_index(id: UVec3, width: u32, height: u32) -> usize {
    ((id.z * height + id.y) * width + id.x) as usize
}

/// Index of pixel `(x, y)` in a row-major image.
#[inline]
pub fn pixel_index(x: u32, y: u32, width: u32) -> usize {
    (y * width + x) as usize
}

/// Every kernel, for backends that build all pipelines up front and for the equivalence tests.
#[cfg(not(target_arch = "spirv"))]
pub static ALL: &[&crate::plan::KernelDesc] = &[
    &accumulate::KERNEL,
    &atrous::KERNEL,
    &buckets::KERNEL,
    &gbuffer::KERNEL,
    &raygen::AO_KERNEL,
    &raygen::SHADOW_KERNEL,
    &reproject::KERNEL,
    &variance::KERNEL,
    &balance::KERNEL,
    &apply::KERNEL,
    &clear::KERNEL,
    &classify::KERNEL,
    &gradient::PROJECT_KERNEL,
    &gradient::AO_KERNEL,
    &gradient::SHADOW_KERNEL,
    &gradient::ATROUS_KERNEL,
    &reflect::RAYGEN_KERNEL,
    &reflect::TILES_KERNEL,
    &reflect::MOTION_KERNEL,
    &reflect::REUSE_KERNEL,
];
