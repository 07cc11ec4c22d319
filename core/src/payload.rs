//! The denoiser payload: per pixel and signal, the first and second moments of the signal, how
//! many rays they hold, and where this pixel's random sequence continues.
//!
//! Seed: vrrt-call-of-duty-2026, "Denoising basics" (moments), "How to handle rng?" (reprojected
//! rng index) and "Undersampling" (`TemporalAccumulation`, clamp after accumulation).

use crate::math;
use bytemuck::{Pod, Zeroable};

/// History of one signal at one pixel.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Payload {
    /// Mean of the signal over the history.
    pub m1: f32,
    /// Mean of the squared signal over the history.
    pub m2: f32,
    /// Rays the moments hold; fractional after bilinear reprojection, `< 1` means empty.
    pub count: f32,
    /// Index of the next unused number in this pixel's random sequence (point-sampled, never
    /// interpolated).
    pub rng_index: u32,
}

/// What raygen traced this frame at one pixel for one signal.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Sample {
    /// Mean of the ray results.
    pub m1: f32,
    /// Mean of the squared ray results.
    pub m2: f32,
    /// Rays traced (0 for an undersampled pixel).
    pub rays: u32,
    /// Padding to 16 bytes.
    pub _pad: u32,
}

impl Payload {
    /// Temporal variance from the moments, never negative.
    #[inline]
    pub fn variance(&self) -> f32 {
        math::max(self.m2 - self.m1 * self.m1, 0.0)
    }
}

/// Merges this frame's rays into the reprojected history.
///
/// Moments are weighted by ray counts; the history length is clamped *after* merging, so a pixel
/// at `max_history` that receives a ray still gives it weight `1 / (max_history + 1)` instead of
/// dissipating. A pixel that traced no ray keeps its history unchanged (it is not decayed). The
/// rng index advances by the rays traced, so no ray is ever re-traced; it wraps at `rng_wrap`
/// (0 = no wrap), the width of the index in the storage format. A sample whose moments are not
/// finite (NaN/Inf from a broken raygen) is dropped like an untraced pixel, so it never enters
/// history.
#[inline]
pub fn accumulate(prev: Payload, curr: Sample, max_history: f32, rng_wrap: u32) -> Payload {
    if curr.rays == 0 || !math::is_finite(curr.m1) || !math::is_finite(curr.m2) {
        return prev;
    }
    let n = curr.rays as f32;
    let prev_count = math::max(prev.count, 0.0);
    let count = prev_count + n;
    let m1 = (prev.m1 * prev_count + curr.m1 * n) / count;
    let m2 = (prev.m2 * prev_count + curr.m2 * n) / count;
    let next = prev.rng_index.wrapping_add(curr.rays);
    Payload {
        m1,
        m2,
        count: math::min(count, max_history),
        rng_index: if rng_wrap == 0 { next } else { next % rng_wrap },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(v: f32, rays: u32) -> Sample {
        Sample {
            m1: v,
            m2: v * v,
            rays,
            _pad: 0,
        }
    }

    #[test]
    fn clamp_after_accumulation_keeps_new_sample_weight() {
        let prev = Payload {
            m1: 0.0,
            m2: 0.0,
            count: 64.0,
            rng_index: 10,
        };
        let out = accumulate(prev, sample(1.0, 1), 64.0, 256);
        // Weight of the new ray is 1/65, not 0: history is clamped only after the merge.
        approx::assert_relative_eq!(out.m1, 1.0 / 65.0);
        assert_eq!(out.count, 64.0);
        assert_eq!(out.rng_index, 11);
    }

    #[test]
    fn converges_from_stale_history() {
        // The seed's r8 case: unshadowed pixel with stale 0 history reaches 1.
        let mut p = Payload {
            m1: 0.0,
            m2: 0.0,
            count: 64.0,
            rng_index: 0,
        };
        for _ in 0..2000 {
            p = accumulate(p, sample(1.0, 1), 64.0, 0);
        }
        assert!(p.m1 > 0.999_99, "{}", p.m1);
    }

    #[test]
    fn zero_rays_carry_history_and_rng_wraps() {
        let prev = Payload {
            m1: 0.3,
            m2: 0.2,
            count: 5.0,
            rng_index: 255,
        };
        assert_eq!(accumulate(prev, sample(1.0, 0), 64.0, 256), prev);
        let out = accumulate(prev, sample(1.0, 4), 64.0, 256);
        assert_eq!(out.rng_index, 3);
        assert_eq!(out.count, 9.0);
    }

    #[test]
    fn non_finite_samples_never_enter_history() {
        let prev = Payload {
            m1: 0.3,
            m2: 0.2,
            count: 5.0,
            rng_index: 7,
        };
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(
                accumulate(
                    prev,
                    Sample {
                        m1: bad,
                        m2: 1.0,
                        rays: 1,
                        _pad: 0
                    },
                    64.0,
                    0
                ),
                prev
            );
            assert_eq!(
                accumulate(
                    prev,
                    Sample {
                        m1: 1.0,
                        m2: bad,
                        rays: 1,
                        _pad: 0
                    },
                    64.0,
                    0
                ),
                prev
            );
        }
    }

    #[test]
    fn variance_is_never_negative() {
        let p = Payload {
            m1: 0.5,
            m2: 0.2499,
            count: 1.0,
            rng_index: 0,
        };
        assert_eq!(p.variance(), 0.0);
    }
}
