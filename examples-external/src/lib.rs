//! A crate of another project that reuses `vrrt-core`'s per-pixel functions in its own passes.
//!
//! The same source builds two ways:
//! - natively, as a `#![no_std]` library (`cargo build`; float functions come from `libm`);
//! - to SPIR-V, as a rust-gpu shader crate with entry points of its own
//!   (`shaders-builder/build.sh --crate examples-external --out <file.spv>`, which reuses VRRT-rs's
//!   pinned nightly and cached codegen backend). `spirv-unknown-vulkan1.2` has no `std` at all, so
//!   this build also proves the whole dependency tree is `no_std`.
#![no_std]

use vrrt_core::glam::UVec3;
use vrrt_core::payload::{self, Payload, Sample};
use vrrt_core::surface::{self, Surface};

/// Push constants of the `resolve` entry point.
#[repr(C)]
#[derive(Copy, Clone, Debug)]
pub struct ResolveParams {
    /// Pixels in the flat lists.
    pub pixels: u32,
    /// History length clamp in rays.
    pub max_history: f32,
}

/// Merges one pixel's samples into its history with VRRT's rules: moments weighted by ray
/// counts, history clamped to `max_history`, non-finite samples dropped.
pub fn accumulate_pixel(history: Payload, sample: Sample, max_history: f32) -> Payload {
    payload::accumulate(history, sample, max_history, 0)
}

/// The `resolve` kernel: [`accumulate_pixel`] over a flat list of pixels, in place.
pub fn resolve(id: UVec3, p: &ResolveParams, history: &mut [Payload], samples: &[Sample]) {
    let i = id.x as usize;
    if id.x < p.pixels {
        history[i] = accumulate_pixel(history[i], samples[i], p.max_history);
    }
}

/// Push constants of the `blur` entry point.
#[repr(C)]
#[derive(Copy, Clone, Debug)]
pub struct BlurParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Plane-distance tolerance: σ times the angle one pixel subtends.
    pub plane_scale: f32,
    /// Normal edge-stopping exponent.
    pub normal_power: f32,
}

/// The `blur` kernel: a 3×3 blur of a row-major image that stops at geometric edges with
/// VRRT's G-buffer weights ([`surface::geometry_weight`]), one invocation per pixel.
pub fn blur(id: UVec3, p: &BlurParams, input: &[f32], surfaces: &[Surface], out: &mut [f32]) {
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let i = (id.y * p.width + id.x) as usize;
    let c = surfaces[i];
    let (mut sum, mut weights) = (0.0, 0.0);
    let mut dy = -1i32;
    while dy <= 1 {
        let mut dx = -1i32;
        while dx <= 1 {
            let (x, y) = (id.x as i32 + dx, id.y as i32 + dy);
            if x >= 0 && y >= 0 && x < p.width as i32 && y < p.height as i32 {
                let j = (y as u32 * p.width + x as u32) as usize;
                let offset = if dx == 0 && dy == 0 { 1.0 } else { 1.5 };
                let w = surface::geometry_weight(
                    &c,
                    &surfaces[j],
                    offset,
                    p.plane_scale,
                    p.normal_power,
                );
                sum += w * input[j];
                weights += w;
            }
            dx += 1;
        }
        dy += 1;
    }
    out[i] = if weights > 0.0 {
        sum / weights
    } else {
        input[i]
    };
}

/// The rust-gpu entry points: one line each, forwarding to the functions above (public, or
/// rust-gpu drops them as dead code).
#[cfg(target_arch = "spirv")]
pub mod entries {
    use super::*;
    use spirv_std::spirv;

    /// [`super::resolve`], 64 pixels per workgroup.
    #[spirv(compute(threads(64)))]
    pub fn resolve(
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(push_constant)] p: &ResolveParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] history: &mut [Payload],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] samples: &[Sample],
    ) {
        super::resolve(id, p, history, samples);
    }

    /// [`super::blur`], 8×8 pixels per workgroup.
    #[spirv(compute(threads(8, 8, 1)))]
    pub fn blur(
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(push_constant)] p: &BlurParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] input: &[f32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] surfaces: &[Surface],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] out: &mut [f32],
    ) {
        super::blur(id, p, input, surfaces, out);
    }
}
