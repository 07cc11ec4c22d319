//! Temporal accumulation: merges this frame's rays into the reprojected history (after raygen).
//!
//! Seed: vrrt-call-of-duty-2026, "Undersampling" (`TemporalAccumulation`) and "Full pipeline"
//! ("temporal accumulation is a good place to do firefly clamping, and variance-based clamp, if you
//! still want to use it"). The variance clamp is the SVGF baseline's history rectification; VRRT
//! runs without it and relies on temporal gradients instead.
//!
//! Order per pixel and plane: input clean-up ([`payload::clean`], counted in the counters buffer),
//! firefly clamp, history shortened where [`super::detect`] found a change, optional variance
//! clamp of the history, f32 merge, then storage at the history's
//! precision with the stuck correction ([`payload::store`]).

use super::plane_index;
use super::AccumulateIo;
use crate::payload::{self, PackedSample, Payload};
use crate::{atomic, math, quantize};
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
    /// Radius of the neighbourhood of this frame's samples the history mean is clamped to
    /// (`mean ± clamp_gamma · σ`); 0 turns the variance clamp off.
    pub clamp_radius: u32,
    /// Width of the clamp window in standard deviations.
    pub clamp_gamma: f32,
    /// This frame's per-pixel mean is clamped to this (fireflies); 0 or less turns it off.
    pub firefly_max: f32,
    /// Storage precision of the history moments (`quantize::STORAGE_*`, optionally with
    /// `quantize::STORAGE_NO_CORRECTION`); also sets the ceiling samples are clamped to.
    pub storage: u32,
    /// Read `changes` ([`super::detect`]'s `λ`): history is shortened to `count · (1 − λ)`, and
    /// dropped like a disocclusion above `change_threshold`; 0 leaves `changes` unread.
    pub use_changes: u32,
    /// `λ` above which history is dropped.
    pub change_threshold: f32,
    /// Padding.
    pub _pad: [u32; 2],
}

/// Clamps the history mean to `mean ± gamma·σ` of this frame's traced samples around `id`,
/// keeping the history's own variance (its second moment moves with the mean).
fn clamp_history(
    id: UVec3,
    p: &AccumulateParams,
    samples: &[PackedSample],
    prev: Payload,
) -> Payload {
    let r = p.clamp_radius as i32;
    let (mut s1, mut s2, mut n) = (0.0f32, 0.0f32, 0.0f32);
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let (qx, qy) = (id.x as i32 + dx, id.y as i32 + dy);
            if qx >= 0 && qy >= 0 && qx < p.width as i32 && qy < p.height as i32 {
                let q = samples
                    [plane_index(UVec3::new(qx as u32, qy as u32, id.z), p.width, p.height)]
                .unpack();
                if q.rays > 0 && math::is_finite(q.m1) {
                    s1 += q.m1;
                    s2 += q.m1 * q.m1;
                    n += 1.0;
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    if n < 1.0 || prev.count <= 0.0 {
        return prev;
    }
    let mean = s1 / n;
    let sigma = math::sqrt(math::max(s2 / n - mean * mean, 0.0));
    let m1 = math::clamp(
        prev.m1,
        mean - p.clamp_gamma * sigma,
        mean + p.clamp_gamma * sigma,
    );
    Payload {
        m1,
        m2: prev.variance() + m1 * m1,
        ..prev
    }
}

/// One invocation per pixel and signal plane: `history = merge(history, samples)`, in place.
pub fn accumulate(id: UVec3, p: &AccumulateParams, io: AccumulateIo<'_>) {
    let AccumulateIo {
        history,
        samples,
        changes,
        counters,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let i = plane_index(id, p.width, p.height);
    let (mut curr, what) = payload::clean(samples[i].unpack(), quantize::max_value(p.storage));
    if what == payload::CLEAN_DROPPED {
        atomic::add(&mut counters[payload::COUNTER_NON_FINITE], 1);
    } else if what == payload::CLEAN_CLAMPED {
        atomic::add(&mut counters[payload::COUNTER_CLAMPED], 1);
    }
    if p.firefly_max > 0.0 {
        curr.m1 = math::min(curr.m1, p.firefly_max);
        curr.m2 = math::min(curr.m2, p.firefly_max * p.firefly_max);
    }
    let mut prev = history[i].unpack();
    if p.use_changes != 0 {
        let lambda = changes[i];
        // Not `max(…, 0)`-guarded: λ is in [0, 1] by construction.
        prev.count = if lambda > p.change_threshold {
            0.0
        } else {
            prev.count * (1.0 - lambda)
        };
    }
    let prev = if p.clamp_radius > 0 {
        clamp_history(id, p, samples, prev)
    } else {
        prev
    };
    let merged = payload::accumulate(prev, curr, p.max_history, p.rng_wrap);
    history[i] = payload::store(prev, curr, merged, p.storage).pack();
}
