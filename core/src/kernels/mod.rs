//! One module per pass. Each exposes plain functions over one invocation id plus its bindings and
//! the push-constant struct; `kernels/table.rs` declares every kernel once, and from it come the
//! [`KernelDesc`](crate::executor::KernelDesc)s (`ATROUS`, `REPROJECT`, …), the named bindings structs
//! (`AtrousBindings`, …), [`ALL`] and the SPIR-V entry points.

pub mod accumulate;
pub mod ao_guide;
pub mod apply;
pub mod atrous;
pub mod balance;
pub mod buckets;
pub mod classify;
pub mod copy;
pub mod detect;
pub mod fill;
pub mod gbuffer;
pub mod gradient;
pub mod ingest;
pub mod penumbra;
pub mod raygen;
pub mod refill;
pub mod reflect;
pub mod reproject;
pub mod requests;
mod table;
pub mod trim;
pub mod variance;
pub mod work_list;

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

/// Whether plane `plane` is in the bit mask `planes` (bit `z` for plane `z`; e.g.
/// `Layout::shadow_planes`).
#[inline]
pub fn plane_in(planes: u32, plane: u32) -> bool {
    plane < 32 && (planes >> plane) & 1 != 0
}

/// Most signal planes a packed plane-group map holds (4 bits each).
pub const MAX_GROUPED_PLANES: u32 = 8;

/// Group of signal plane `plane` in a packed plane→group map (4 bits per plane, plane 0 in the
/// lowest bits; `Layout::plane_groups`). Planes of one group (one signal: AO, the shadows of
/// every light, reflections) share one ray request and one work list; 0 puts every plane in
/// group 0, one request per pixel for all.
#[inline]
pub fn plane_group(groups: u32, plane: u32) -> u32 {
    if plane < MAX_GROUPED_PLANES {
        (groups >> (4 * plane)) & 0xf
    } else {
        0
    }
}

/// Planes of group `group` among the first `planes` of a packed plane→group map: what one ray
/// of the group costs (one ray per plane).
#[inline]
pub fn group_planes(groups: u32, planes: u32, group: u32) -> u32 {
    let mut n = 0;
    let mut z = 0;
    while z < planes {
        n += (plane_group(groups, z) == group) as u32;
        z += 1;
    }
    n
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
    pub use crate::inputs::{self, IngestParams};
    pub use crate::payload::{PackedFiltered, PackedPayload, PackedSample};
    pub use crate::textures::Texel;
    pub use crate::trace::{BvhNode, Triangle, TriangleNormals};

    // Storage formats carried by plain words: a binding declares one of these instead of the
    // bare word, so the declaration names what it stores ([`format_of`]).

    /// Linear view depth (`crate::surface::has_surface`).
    pub type Depth = f32;
    /// Octahedral normal and linear roughness (`crate::packing::pack_normal_roughness`).
    pub type NormalRoughness = u32;
    /// 2.5D motion as RGBA16F (`crate::packing::pack_motion`).
    pub type Motion = [u32; 2];
    /// The built-in renderer's geometric normal and instance (`crate::packing::pack_hit`).
    pub type Geometry = [u32; 2];
    /// Requested bucket and reprojection flags (`requests::request_word`).
    pub type Request = u32;
    /// Work-list entry: pixel and rays (`work_list::work_entry`).
    pub type WorkEntry = u32;
    /// The engine's VRS mask (0 = no ray).
    pub type VrsMask = u32;
    /// Tile word: worst variance key, then iterations (`classify::tile_key`).
    pub type TileWord = u32;
    /// Gradient cell key: hash and previous pixel (`gradient::EMPTY_KEY` when empty).
    pub type GradientKey = u32;

    /// The storage format of a binding's element type, as written in `kernels::table`
    /// ([`crate::executor::Binding::ty`]); `None` for a type not listed here.
    pub fn format_of(ty: &str) -> Option<&'static str> {
        Some(match ty {
            "Depth" => "R32F view depth",
            "NormalRoughness" => "R32UI: oct normal 11+11, sqrt(roughness) unorm10",
            "Motion" => "RGBA16F: dx, dy (pixels), view-depth change",
            "Geometry" => "RG32UI: oct16 geometric normal, instance",
            "Request" => "R32UI: bucket 16 | flags 16",
            "WorkEntry" => "R32UI: pixel 28 | rays - 1 4",
            "VrsMask" | "u32" => "R32UI",
            "TileWord" => "R32UI: variance key, then iterations",
            "GradientKey" => "R32UI: hash | pixel",
            "f32" => "R32F",
            "[f32; 2]" => "RG32F",
            "PackedPayload" => "RGBA16: m1, m2, length (f16), rng index (u16)",
            "PackedSample" => "RGBA16: m1, m2 (f16), rays (u16), 0th ray (f16)",
            "PackedFiltered" => "RG16F: value, variance",
            "GradientSample" => "RG32F: |change|, max",
            "View" => "two cameras (104 bytes)",
            "Texel" => "engine texture: texel fetch (RGBA32F slice on the CPU)",
            "IngestParams" => "struct",
            "Balance" | "InstanceData" | "AreaLight" | "RayHit" | "BvhNode" | "Triangle"
            | "TriangleNormals" => "struct",
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_binding_declares_a_known_format() {
        for kernel in super::ALL {
            for b in kernel.bindings {
                assert!(
                    super::names::format_of(b.ty).is_some(),
                    "{}.{}: `{}` has no format in kernels::names::format_of",
                    kernel.entry,
                    b.name,
                    b.ty
                );
            }
        }
    }
}
