//! One module per pass. Each exposes plain functions over one invocation id plus its bindings and
//! the push-constant struct; `kernels/table.rs` declares every kernel once, and from it come the
//! [`KernelDesc`](crate::plan::KernelDesc)s (`ATROUS`, `REPROJECT`, …), the named bindings structs
//! (`AtrousBindings`, …), [`ALL`] and the SPIR-V entry points.

pub mod accumulate;
pub mod apply;
pub mod atrous;
pub mod balance;
pub mod buckets;
pub mod classify;
pub mod copy;
pub mod fill;
pub mod gbuffer;
pub mod gradient;
pub mod raygen;
pub mod reflect;
pub mod reproject;
mod table;
pub mod variance;

pub use table::*;

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

/// The ids a workgroup kernel's phase gets (see [`crate::declare`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct WorkgroupIds {
    /// Global invocation id.
    pub global: UVec3,
    /// Workgroup id.
    pub group: UVec3,
    /// Index of the invocation within its workgroup, x fastest.
    pub local_index: u32,
}

/// Every name the kernel table uses, so that the generated SPIR-V entry points resolve them at
/// the shader crate's root: every kernel module (a new module needs nothing here; the table names
/// its types as `module::Type`) and the element types kernels share.
#[doc(hidden)]
pub mod names {
    pub use super::balance::Balance;
    pub use super::gbuffer::InstanceData;
    pub use super::gradient::GradientSample;
    pub use super::raygen::AreaLight;
    pub use super::reflect::RayHit;
    pub use super::*;
    pub use crate::camera::View;
    pub use crate::payload::{PackedFiltered, PackedPayload, PackedSample};
    pub use crate::trace::{BvhNode, Triangle, TriangleNormals};
}
