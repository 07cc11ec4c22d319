//! The denoiser payload: per pixel and signal, the first and second moments of the signal, how
//! many rays they hold, and where this pixel's random sequence continues.
//!
//! Seed: vrrt-call-of-duty-2026, "Denoising basics" (moments), "How to handle rng?" (reprojected
//! rng index), "Undersampling" (`TemporalAccumulation`, clamp after accumulation) and "Numerical
//! precision issues when undersampling" (stuck correction, see [`quantize`]).
//!
//! # Input clean-up policy
//!
//! Raygen output is untrusted: one NaN in history would spread through the spatial filter and stay
//! for the whole history length. Before merging, each traced sample goes through [`clean`]:
//! - a sample whose `m1` or `m2` is NaN or ±Inf is **dropped** (treated as an untraced pixel, the
//!   history is carried) and counted in [`COUNTER_NON_FINITE`];
//! - the signals are non-negative (visibility, occlusion, radiance), so negative moments are
//!   **clamped** to 0, and moments above the storage format's largest value
//!   ([`quantize::max_value`]: 65504 for f16, 1 for unorm8) are
//!   clamped to it; both count in [`COUNTER_CLAMPED`];
//! - `m2` is raised to `m1²` (within the format's range) if it is below: a mean of squares is
//!   never below the square of the mean, and raygen's rounding may break that. Not counted.
//!
//! Untraced samples (`rays == 0`) are not inspected: their moments are not read. The accumulated
//! moments are then stored at the storage precision ([`store`]).

use crate::binary16;
use crate::lanes::Lanes;
use crate::math;
use crate::packing;
use crate::quantize;
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

/// Longest history length (rays) the stored binary16 length holds exactly.
pub const MAX_EXACT_COUNT: f32 = 2048.0;

/// A [`Payload`] as the history buffers hold it (8 bytes): the two moments as binary16 (`m1` in
/// the low half), the history length as binary16 (exact for whole counts up to 2048, the
/// longest history allowed) and the rng index's 16 bits (it wraps at 2^16, or 2^8 with unorm8
/// precision). Conversions are core's integer-op binary16 ([`crate::packing`]), so every backend
/// stores the same bits; moments are rounded to their storage precision with the stuck correction
/// before packing ([`store`]), so packing them is exact.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PackedPayload {
    /// `m1 | m2 << 16`, binary16.
    pub moments: u32,
    /// `count | rng_index << 16`, count as binary16.
    pub count_rng: u32,
}

impl PackedPayload {
    /// The payload, widened to f32.
    #[inline]
    pub fn unpack(self) -> Payload {
        PayloadLanes::unpack(Lanes::<PackedPayload, 1>([self])).lane(0)
    }

    /// The rng index alone (ray generation reads nothing else).
    #[inline]
    pub fn rng_index(self) -> u32 {
        self.count_rng >> 16
    }
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
    /// Value of the pixel's 0th ray this frame (the one with the rng index the history carried;
    /// 0 when none was traced). Kept so next frame's temporal-gradient pass can compare a re-trace
    /// of that very ray against it: the mean alone does not say what one ray returned.
    pub first: f32,
}

/// A [`Sample`] as the samples buffer holds it (8 bytes, what the engine's ray tracing writes):
/// the two moments as binary16 (`m1` low; NaN and ±∞ survive, so the clean-up policy still
/// drops them), and `rays` (16 bits) with the 0th ray's value as binary16 in the high half.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PackedSample {
    /// `m1 | m2 << 16`, binary16.
    pub moments: u32,
    /// `rays | first << 16`, `first` as binary16.
    pub rays_first: u32,
}

impl PackedSample {
    /// The sample, widened to f32.
    #[inline]
    pub fn unpack(self) -> Sample {
        let (m1, m2) = packing::unpack_f16x2(self.moments);
        Sample {
            m1,
            m2,
            rays: self.rays_first & 0xffff,
            first: binary16::f16_to_f32(self.rays_first >> 16),
        }
    }

    /// The rays the sample holds, without unpacking the rest.
    #[inline]
    pub fn rays(self) -> u32 {
        self.rays_first & 0xffff
    }
}

impl Sample {
    /// The packed form: moments and `first` rounded to binary16, `rays` to 16 bits (at most 16
    /// rays a pixel are granted).
    #[inline]
    pub fn pack(&self) -> PackedSample {
        PackedSample {
            moments: packing::pack_signal_f16x2(self.m1, self.m2),
            rays_first: (self.rays & 0xffff) | (packing::pack_signal_f16x2(self.first, 0.0) << 16),
        }
    }
}

impl Payload {
    /// The payload as stored ([`PackedPayload`]): moments and count rounded to binary16 (to
    /// nearest, saturating at 65504), the rng index to its low 16 bits.
    #[inline]
    pub fn pack(&self) -> PackedPayload {
        let one = PayloadLanes::<1> {
            m1: Lanes([self.m1]),
            m2: Lanes([self.m2]),
            count: Lanes([self.count]),
            rng_index: Lanes([self.rng_index]),
        };
        one.pack().0[0]
    }

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
// One select at the end, not an early return: called per lane, a row of pixels is vector code.
#[inline]
pub fn accumulate(prev: Payload, curr: Sample, max_history: f32, rng_wrap: u32) -> Payload {
    let traced = curr.rays != 0 && math::is_finite(curr.m1) && math::is_finite(curr.m2);
    let n = curr.rays as f32;
    let prev_count = math::max(prev.count, 0.0);
    let count = prev_count + n;
    let merged = Payload {
        m1: (prev.m1 * prev_count + curr.m1 * n) / count,
        m2: (prev.m2 * prev_count + curr.m2 * n) / count,
        count: math::min(count, max_history),
        rng_index: wrap_rng(prev.rng_index.wrapping_add(curr.rays), rng_wrap),
    };
    if traced {
        merged
    } else {
        prev
    }
}

/// `next` modulo `wrap` (0 = no wrap). The storage widths are powers of two, taken by a mask: a
/// division has no vector form.
#[inline]
pub fn wrap_rng(next: u32, wrap: u32) -> u32 {
    let mask = wrap.wrapping_sub(1);
    if wrap & mask == 0 {
        next & mask
    } else {
        next % wrap
    }
}

/// Slot of the counters buffer: samples dropped because a moment was NaN or ±Inf.
pub const COUNTER_NON_FINITE: usize = 0;
/// Slot of the counters buffer: samples with a moment clamped into `[0, max]`.
pub const COUNTER_CLAMPED: usize = 1;
/// Words in the counters buffer.
pub const COUNTERS_LEN: u32 = 2;

/// [`clean`] kept the sample as it was (or the pixel traced nothing).
pub const CLEAN_KEPT: u32 = 0;
/// [`clean`] clamped a moment of the sample into range.
pub const CLEAN_CLAMPED: u32 = 1;
/// [`clean`] dropped the sample (non-finite moment).
pub const CLEAN_DROPPED: u32 = 2;

/// Applies the input clean-up policy (module docs) to one sample whose signal may not exceed
/// `max`; returns the sample to merge and what was done (`CLEAN_*`). A dropped sample comes back
/// with `rays == 0`, so [`accumulate`] carries the history.
// Every outcome computed, then selected: called per lane, a row of pixels is vector code.
#[inline]
pub fn clean(s: Sample, max: f32) -> (Sample, u32) {
    let finite = math::is_finite(s.m1) && math::is_finite(s.m2);
    let m1 = math::clamp(s.m1, 0.0, max);
    let m2 = math::clamp(s.m2, 0.0, max);
    let clamped = m1 != s.m1 || m2 != s.m2;
    let kept = Sample {
        m1,
        m2: math::max(m2, math::min(m1 * m1, max)),
        ..s
    };
    if s.rays == 0 {
        (s, CLEAN_KEPT)
    } else if !finite {
        (Sample { rays: 0, ..s }, CLEAN_DROPPED)
    } else if clamped {
        (kept, CLEAN_CLAMPED)
    } else {
        (kept, CLEAN_KEPT)
    }
}

/// Stores `merged` (the f32 result of [`accumulate`] of sample `curr` into `prev`) at storage
/// precision `storage` (`quantize::STORAGE_*`): each moment is rounded to the format with the
/// stuck correction against its value in `prev`, never stepping past the sample's value, and
/// `m2` is kept at or above `m1²` (within the format's range: above √65504 ≈ 256 the f16 second
/// moment saturates and the variance reads 0) so the variance stays non-negative after rounding.
/// The history length and rng index are not moments and are kept as they are (the rng index
/// already wraps at the format's width).
#[inline]
pub fn store(prev: Payload, curr: Sample, merged: Payload, storage: u32) -> Payload {
    let one = |m1, m2| MomentLanes::<1> {
        m1: Lanes([m1]),
        m2: Lanes([m2]),
    };
    let m = store_lanes(
        one(prev.m1, prev.m2),
        one(curr.m1, curr.m2),
        one(merged.m1, merged.m2),
        storage,
    );
    Payload {
        m1: m.m1.0[0],
        m2: m.m2.0[0],
        ..merged
    }
}

/// `N` payloads field by field ([`crate::lanes`]): the lanes of one field are one vector.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PayloadLanes<const N: usize> {
    /// First moments.
    pub m1: Lanes<f32, N>,
    /// Second moments.
    pub m2: Lanes<f32, N>,
    /// History lengths.
    pub count: Lanes<f32, N>,
    /// Rng indices.
    pub rng_index: Lanes<u32, N>,
}

impl<const N: usize> PayloadLanes<N> {
    /// [`PackedPayload::unpack`] of every lane (binary16 through the lanes conversion).
    #[inline(always)]
    pub fn unpack(packed: Lanes<PackedPayload, N>) -> Self {
        let (m1, m2) = packing::unpack_f16x2_lanes(packed.map(|q| q.moments));
        PayloadLanes {
            m1,
            m2,
            count: packed.map(|q| q.count_rng).f16_to_f32(),
            rng_index: packed.map(|q| q.rng_index()),
        }
    }

    /// [`Payload::pack`] of every lane.
    #[inline(always)]
    pub fn pack(&self) -> Lanes<PackedPayload, N> {
        let moments = packing::pack_f16x2_lanes(self.m1, self.m2);
        let count = packing::pack_f16x2_lanes(self.count, Lanes::splat(0.0));
        Lanes::from_index(|l| {
            let l = l as usize;
            PackedPayload {
                moments: moments.0[l],
                count_rng: (count.0[l] & 0xffff) | (self.rng_index.0[l] << 16),
            }
        })
    }

    /// Lane `l`.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Payload {
        Payload {
            m1: self.m1.0[l],
            m2: self.m2.0[l],
            count: self.count.0[l],
            rng_index: self.rng_index.0[l],
        }
    }

    /// Sets lane `l` to `v`.
    #[inline(always)]
    pub fn set(&mut self, l: usize, v: Payload) {
        self.m1.0[l] = v.m1;
        self.m2.0[l] = v.m2;
        self.count.0[l] = v.count;
        self.rng_index.0[l] = v.rng_index;
    }

    /// The moments alone.
    #[inline(always)]
    pub fn moments(&self) -> MomentLanes<N> {
        MomentLanes {
            m1: self.m1,
            m2: self.m2,
        }
    }
}

/// `N` samples field by field ([`crate::lanes`]), without the 0th ray (accumulation does not
/// read it): a row of [`Sample`]s is an array of structs that the CPU's vector code would
/// re-gather field by field at every use.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SampleLanes<const N: usize> {
    /// Means of the ray results.
    pub m1: Lanes<f32, N>,
    /// Means of the squared ray results.
    pub m2: Lanes<f32, N>,
    /// Rays traced.
    pub rays: Lanes<u32, N>,
}

impl<const N: usize> SampleLanes<N> {
    /// Lane `l` (`first` 0).
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Sample {
        Sample {
            m1: self.m1.0[l],
            m2: self.m2.0[l],
            rays: self.rays.0[l],
            first: 0.0,
        }
    }

    /// Sets lane `l` to `s` (its `first` is not kept).
    #[inline(always)]
    pub fn set(&mut self, l: usize, s: Sample) {
        self.m1.0[l] = s.m1;
        self.m2.0[l] = s.m2;
        self.rays.0[l] = s.rays;
    }

    /// The moments alone.
    #[inline(always)]
    pub fn moments(&self) -> MomentLanes<N> {
        MomentLanes {
            m1: self.m1,
            m2: self.m2,
        }
    }
}

/// The two moments of `N` pixels, field by field ([`crate::lanes`]).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MomentLanes<const N: usize> {
    /// First moments.
    pub m1: Lanes<f32, N>,
    /// Second moments.
    pub m2: Lanes<f32, N>,
}

/// [`store`]'s moments for every lane.
#[inline(always)]
pub fn store_lanes<const N: usize>(
    prev: MomentLanes<N>,
    curr: MomentLanes<N>,
    merged: MomentLanes<N>,
    storage: u32,
) -> MomentLanes<N> {
    let max = quantize::max_value(storage);
    let m1 = quantize::store_with_correction_lanes(storage, merged.m1, prev.m1, curr.m1);
    let m2 = quantize::store_with_correction_lanes(storage, merged.m2, prev.m2, curr.m2);
    let floor = quantize::quantize_up_lanes(storage, m1.map(|m1| math::min(m1 * m1, max)));
    MomentLanes {
        m1,
        m2: m2.zip(floor, math::max),
    }
}

/// A filtered signal value and its variance: what the variance pass and each à-trous iteration
/// write, and the denoised output.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Filtered {
    /// Signal estimate.
    pub value: f32,
    /// Variance of the estimate.
    pub variance: f32,
}

/// A [`Filtered`] as the filter's buffers and the output hold it: value and variance as two
/// binary16 in one word (value in the low half; RG16F), saturated to ±65504.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PackedFiltered {
    /// `value | variance << 16`, binary16.
    pub bits: u32,
}

impl PackedFiltered {
    /// Value and variance, widened to f32.
    #[inline]
    pub fn unpack(self) -> Filtered {
        let (value, variance) = packing::unpack_f16x2(self.bits);
        Filtered { value, variance }
    }
}

impl Filtered {
    /// The packed form, rounded to nearest binary16.
    #[inline]
    pub fn pack(&self) -> PackedFiltered {
        PackedFiltered {
            bits: packing::pack_f16x2(self.value, self.variance),
        }
    }
}

/// [`PackedFiltered::unpack`] of `N` lanes ([`crate::lanes`]): values and variances.
#[inline(always)]
pub fn unpack_filtered<const N: usize>(
    packed: Lanes<PackedFiltered, N>,
) -> (Lanes<f32, N>, Lanes<f32, N>) {
    packing::unpack_f16x2_lanes(packed.map(|p| p.bits))
}

/// [`Filtered::pack`] of `N` lanes ([`crate::lanes`]).
#[inline(always)]
pub fn pack_filtered<const N: usize>(
    value: Lanes<f32, N>,
    variance: Lanes<f32, N>,
) -> Lanes<PackedFiltered, N> {
    packing::pack_f16x2_lanes(value, variance).map(|bits| PackedFiltered { bits })
}

/// Test inputs the kernels' unit tests share.
#[cfg(test)]
impl Sample {
    /// `rays` rays that all read `value` (the 0th one too).
    pub(crate) fn uniform(value: f32, rays: u32) -> Self {
        Sample {
            m1: value,
            m2: value * value,
            rays,
            first: value,
        }
    }
}

#[cfg(test)]
impl Payload {
    /// The history of a binary signal (lit or not per ray): mean `mean` over `count` rays, so
    /// its second moment is its mean.
    pub(crate) fn binary(mean: f32, count: f32) -> Self {
        Payload {
            m1: mean,
            m2: mean,
            count,
            rng_index: 0,
        }
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
            first: 0.0,
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
                        first: 0.0
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
                        first: 0.0
                    },
                    64.0,
                    0
                ),
                prev
            );
        }
    }

    #[test]
    fn clean_up_policy() {
        let s = |m1, m2| Sample {
            m1,
            m2,
            rays: 1,
            ..Sample::default()
        };
        assert_eq!(clean(s(f32::NAN, 0.0), 1.0).1, CLEAN_DROPPED);
        assert_eq!(clean(s(0.0, f32::INFINITY), 1.0).0.rays, 0);
        let (c, w) = clean(s(-0.5, 0.25), 65504.0);
        assert_eq!((c.m1, c.m2, w), (0.0, 0.25, CLEAN_CLAMPED));
        let (c, w) = clean(s(1e30, 1e30), 65504.0);
        assert_eq!((c.m1, c.m2, w), (65504.0, 65504.0, CLEAN_CLAMPED));
        // m2 below m1² is raised, not counted.
        let (c, w) = clean(s(0.5, 0.2), 1.0);
        assert_eq!((c.m1, c.m2, w), (0.5, 0.25, CLEAN_KEPT));
        // Untraced samples are not inspected.
        let untraced = Sample {
            rays: 0,
            ..s(f32::NAN, -1.0)
        };
        assert_eq!(clean(untraced, 1.0).1, CLEAN_KEPT);
    }

    #[test]
    fn store_keeps_m2_above_m1_squared() {
        let prev = Payload {
            m1: 0.3,
            m2: 0.0,
            count: 3.0,
            rng_index: 0,
        };
        for storage in [quantize::STORAGE_F16, quantize::STORAGE_UNORM8] {
            let merged = Payload {
                m1: 0.3337,
                m2: 0.1,
                ..prev
            };
            let p = store(prev, Sample::default(), merged, storage);
            assert!(p.m2 >= p.m1 * p.m1, "{storage}: {p:?}");
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
