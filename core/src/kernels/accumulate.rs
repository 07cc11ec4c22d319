//! Temporal accumulation: merges this frame's rays into the reprojected history (after raygen).
//!
//! Seed: vrrt-call-of-duty-2026, "Undersampling" (`TemporalAccumulation`).

use super::plane_index;
use crate::payload::{self, Payload, Sample};
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`accumulate`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AccumulateParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// History length clamp, applied after merging (e.g. 64).
    pub max_history: f32,
    /// The rng index wraps at this value (0 = never), matching its storage width.
    pub rng_wrap: u32,
}

/// One invocation per pixel and signal plane: `out = merge(history, samples)`.
pub fn accumulate(
    id: UVec3,
    p: &AccumulateParams,
    history: &[Payload],
    samples: &[Sample],
    out: &mut [Payload],
) {
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let i = plane_index(id, p.width, p.height);
    out[i] = payload::accumulate(history[i], samples[i], p.max_history, p.rng_wrap);
}

#[cfg(not(target_arch = "spirv"))]
crate::per_invocation_kernel!(
    /// Kernel description of [`accumulate`]: bindings `history`, `samples`, `out`.
    KERNEL = "accumulate", accumulate, threads(8, 8, 1),
    params: AccumulateParams,
    bindings: [history: Read Payload, samples: Read Sample, out: ReadWrite Payload]
);
