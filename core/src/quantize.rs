//! Storage precision of the history: rounds a moment to what a narrower format can hold, with the
//! seed's "stuck" correction.
//!
//! Seed: vrrt-call-of-duty-2026, "Numerical precision issues when undersampling"
//! (`Fp16QuantizationCorrection`). With a long history each new ray moves the mean by
//! `(x - mean) / count`; once that step is below half a unit of the storage format, rounding
//! throws it away every frame and the pixel never converges (an r8 shadow stuck near 0.8 instead
//! of 1.0). The correction: if the f32 value changed but its quantized value did not, step the
//! quantized value one unit toward the f32 value.
//!
//! History buffers are packed ([`crate::payload::PackedPayload`]: binary16 fields); a moment
//! is rounded here to its storage precision (binary16, or unorm8 for signals in `[0, 1]`, which
//! binary16 then holds to well within half a unorm8 step) with the correction against the value
//! actually stored last frame.
//!
//! Conversions use integer operations only (plus exact float scalings), so they give the same bits
//! on the CPU and on every GPU, independent of the target's `f32tof16` rounding mode. Stored
//! signals are non-negative: every format's range starts at 0.

use crate::binary16::{f16_to_f32, f32_to_f16, F16_MAX, F16_MAX_CODE};
use crate::lanes::Lanes;
use crate::math;

/// Precision of the stored history moments
/// ([`TemporalSettings::storage`](crate::settings::TemporalSettings::storage)); the buffers are
/// packed binary16 either way (see the module docs). In settings files: `"f16"` or `"unorm8"`.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum StoragePrecision {
    /// IEEE binary16 precision, `[0, 65504]`; the rng index wraps at 2^16.
    #[default]
    F16,
    /// 8-bit unsigned normalized precision, `[0, 1]`, for shadow-only signals; the rng index
    /// wraps at 2^8.
    Unorm8,
}

impl StoragePrecision {
    /// The code passed to kernels (`STORAGE_*`).
    pub fn code(self) -> u32 {
        match self {
            StoragePrecision::F16 => STORAGE_F16,
            StoragePrecision::Unorm8 => STORAGE_UNORM8,
        }
    }

    /// Where the rng index wraps when stored alongside the moments in this format.
    pub fn rng_wrap(self) -> u32 {
        match self {
            StoragePrecision::F16 => 1 << 16,
            StoragePrecision::Unorm8 => 1 << 8,
        }
    }

    /// Largest storable value; samples above it are clamped.
    pub fn max_value(self) -> f32 {
        max_value(self.code())
    }
}

/// IEEE binary16 (half), range `[0, 65504]`.
pub const STORAGE_F16: u32 = 1;
/// 8-bit unsigned normalized, range `[0, 1]` (shadow visibility and other signals in `[0, 1]`).
pub const STORAGE_UNORM8: u32 = 2;

/// Flag or-ed into a storage code to turn the stuck correction off (plain round-to-nearest), only
/// to demonstrate the stuck pixel it prevents.
pub const STORAGE_NO_CORRECTION: u32 = 0x100;

/// Unorm8 code of `x` in `[0, 1]` (clamped; NaN gives 0), rounded to nearest, ties to even.
pub fn f32_to_unorm8(x: f32) -> u32 {
    let t = math::saturate(x) * 255.0;
    let i = math::floor_small(t);
    // Exact: `t` and `i` are within one unit of each other in [0, 255].
    let frac = t - i as f32;
    if frac > 0.5 || (frac == 0.5 && (i & 1) == 1) {
        i + 1
    } else {
        i
    }
}

/// Value of a unorm8 code: `q · fl(1/255)`, and exactly 1 for 255. A multiply, not `q / 255`:
/// GPU compilers may turn division by a constant into a multiply by its reciprocal (llvmpipe
/// does), which is 1 ulp off correctly rounded division for some codes; a multiply gives the same
/// bits everywhere. The stored values are monotonic in `q` and round-trip through
/// [`f32_to_unorm8`].
pub fn unorm8_to_f32(q: u32) -> f32 {
    if q >= 255 {
        1.0
    } else {
        q as f32 * (1.0 / 255.0)
    }
}

/// Largest value format `storage` holds (and the ceiling samples are clamped to).
pub fn max_value(storage: u32) -> f32 {
    match storage & 0xff {
        STORAGE_UNORM8 => 1.0,
        _ => F16_MAX,
    }
}

/// Code of `x` in format `storage`, clamped to `[0, max_value]`.
fn encode(storage: u32, x: f32) -> u32 {
    if storage & 0xff == STORAGE_UNORM8 {
        f32_to_unorm8(x)
    } else {
        f32_to_f16(math::clamp(x, 0.0, F16_MAX))
    }
}

fn decode(storage: u32, q: u32) -> f32 {
    if storage & 0xff == STORAGE_UNORM8 {
        unorm8_to_f32(q)
    } else {
        f16_to_f32(q)
    }
}

fn max_code(storage: u32) -> u32 {
    if storage & 0xff == STORAGE_UNORM8 {
        255
    } else {
        F16_MAX_CODE
    }
}

/// `x` rounded to format `storage` (to nearest, clamped to its range).
pub fn quantize(storage: u32, x: f32) -> f32 {
    decode(storage, encode(storage, x))
}

/// The smallest value of format `storage` that is `>= x` (clamped to the format's range): used to
/// keep the stored second moment at or above the square of the stored mean.
pub fn quantize_up(storage: u32, x: f32) -> f32 {
    quantize_up_lanes(storage, Lanes::<f32, 1>([x])).0[0]
}

/// [`quantize_up`] of every lane.
#[inline(always)]
pub fn quantize_up_lanes<const N: usize>(storage: u32, x: Lanes<f32, N>) -> Lanes<f32, N> {
    let q = encode_lanes(storage, x);
    let top = max_code(storage);
    let up = decode_lanes(storage, q).zip(x, |d, x| d < x);
    let q = Lanes::<u32, N>::from_index(|l| {
        let l = l as usize;
        q.0[l] + (up.0[l] && q.0[l] < top) as u32
    });
    decode_lanes(storage, q)
}

/// Stores `accum` (this frame's merged f32 value) in format `storage`, given the value `prev` it
/// was merged from and the value `target` of this frame's samples it moved toward: rounds to
/// nearest, but if rounding would undo a change (`accum != prev` while both quantize to the same
/// code) steps one unit toward `accum`, clamped to the format's range. Without the step a long
/// history never converges in low precision (the seed's stuck pixel).
///
/// One guard beyond the seed: the step never goes past `target`. When the true value lies
/// between two codes, the unguarded rule steps over it every other frame and the stored value
/// dithers one unit around it (e.g. 1e-6 in f16 alternates between 16 and 17 units of 2^-24);
/// with the guard it stays on the nearest code, and a value far from its target still moves one
/// unit a frame. With [`STORAGE_NO_CORRECTION`] set this is plain [`quantize`].
pub fn store_with_correction(storage: u32, accum: f32, prev: f32, target: f32) -> f32 {
    let one = |x| Lanes::<f32, 1>([x]);
    store_with_correction_lanes(storage, one(accum), one(prev), one(target)).0[0]
}

/// [`store_with_correction`] of every lane: both candidate codes computed, then selected (so a
/// row of pixels is vector code; the same bits as deciding first).
#[inline(always)]
pub fn store_with_correction_lanes<const N: usize>(
    storage: u32,
    accum: Lanes<f32, N>,
    prev: Lanes<f32, N>,
    target: Lanes<f32, N>,
) -> Lanes<f32, N> {
    let qa = encode_lanes(storage, accum);
    let qp = encode_lanes(storage, prev);
    let correct = storage & STORAGE_NO_CORRECTION == 0;
    let top = max_code(storage);
    let step = Lanes::<u32, N>::from_index(|l| {
        let (l, qa) = (l as usize, qa.0[l as usize]);
        if accum.0[l] > prev.0[l] {
            math_min_u32(qa + 1, top)
        } else if qa > 0 {
            qa - 1
        } else {
            0
        }
    });
    let stepped = decode_lanes(storage, step);
    let q = Lanes::<u32, N>::from_index(|l| {
        let l = l as usize;
        let (a, p, t, s) = (accum.0[l], prev.0[l], target.0[l], stepped.0[l]);
        let overshoots = if a > p { s > t } else { s < t };
        if correct && a != p && qa.0[l] == qp.0[l] && !overshoots {
            step.0[l]
        } else {
            qa.0[l]
        }
    });
    decode_lanes(storage, q)
}

/// [`encode`] of every lane (binary16 through the lanes conversion: the same codes).
#[inline(always)]
fn encode_lanes<const N: usize>(storage: u32, x: Lanes<f32, N>) -> Lanes<u32, N> {
    if storage & 0xff == STORAGE_UNORM8 {
        x.map(f32_to_unorm8)
    } else {
        x.map(|x| math::clamp(x, 0.0, F16_MAX)).f32_to_f16()
    }
}

/// [`decode`] of every lane.
#[inline(always)]
fn decode_lanes<const N: usize>(storage: u32, q: Lanes<u32, N>) -> Lanes<f32, N> {
    if storage & 0xff == STORAGE_UNORM8 {
        q.map(unorm8_to_f32)
    } else {
        q.f16_to_f32()
    }
}

#[inline]
fn math_min_u32(a: u32, b: u32) -> u32 {
    if a < b {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unorm8_round_trip_and_ties() {
        for q in 0..=255 {
            assert_eq!(f32_to_unorm8(unorm8_to_f32(q)), q);
        }
        assert_eq!(f32_to_unorm8(0.5 / 255.0), 0);
        assert_eq!(f32_to_unorm8(1.5 / 255.0), 2);
        assert_eq!(f32_to_unorm8(-1.0), 0);
        assert_eq!(f32_to_unorm8(7.0), 255);
        assert_eq!(f32_to_unorm8(f32::NAN), 0);
    }

    #[test]
    fn stuck_correction_steps_one_unit_toward_the_change() {
        // r8 at 230/255 ≈ 0.9 with 64 rays of history: a ray of 1.0 moves the mean by
        // 0.098 / 65 ≈ 0.0015, under half a unit (0.5 / 255 ≈ 0.002).
        let prev = unorm8_to_f32(230);
        let accum = prev + (1.0 - prev) / 65.0;
        assert_eq!(
            quantize(STORAGE_UNORM8, accum),
            prev,
            "plain rounding is stuck"
        );
        assert_eq!(
            store_with_correction(STORAGE_UNORM8, accum, prev, 1.0),
            unorm8_to_f32(231)
        );
        let down = prev - prev / 300.0;
        assert_eq!(
            store_with_correction(STORAGE_UNORM8, down, prev, 0.0),
            unorm8_to_f32(229)
        );
        // Clamped at the ends of the range.
        assert_eq!(
            store_with_correction(STORAGE_UNORM8, 1.0, 0.999_9, 1.0),
            1.0
        );
        assert_eq!(store_with_correction(STORAGE_F16, 0.0, 1e-9, 0.0), 0.0);
        assert_eq!(
            store_with_correction(STORAGE_F16, F16_MAX, 65503.0, F16_MAX),
            F16_MAX
        );
        // Without the correction rounding is stuck.
        assert_eq!(
            store_with_correction(STORAGE_UNORM8 | STORAGE_NO_CORRECTION, accum, prev, 1.0),
            prev
        );
        // Unchanged values stay put.
        assert_eq!(
            store_with_correction(STORAGE_F16, 0.3, 0.3, 0.3),
            quantize(STORAGE_F16, 0.3)
        );
        // The guard: 1e-6 lies between f16 codes 16 and 17 (nearest 17). History on 17 moving
        // toward 1e-6 would be stepped to 16 by the unguarded rule; it stays on 17.
        let (q17, target) = (f16_to_f32(17), 1e-6);
        let accum = (q17 + target) / 2.0;
        assert_eq!(store_with_correction(STORAGE_F16, accum, q17, target), q17);
    }

    /// The lanes forms (F16C where the CPU has it, 16 lanes) give the bits of one lane at a
    /// time (the integer conversions), in both formats, with and without the correction.
    #[test]
    fn lanes_store_and_ceiling_match_one_lane_at_a_time() {
        let mut rng = 0x9e37_79b9u32;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 17;
            rng ^= rng << 5;
            rng
        };
        for storage in [
            STORAGE_F16,
            STORAGE_UNORM8,
            STORAGE_F16 | STORAGE_NO_CORRECTION,
        ] {
            for _ in 0..4096 {
                // Values spread over every binary16 exponent, with neighbours one code apart.
                let value = |bits: u32| f32::from_bits(0x3300_0000 + bits % 0x1000_0000);
                let draw: [u32; 16] = core::array::from_fn(|_| next());
                let a = Lanes::<f32, 16>::from_index(|l| value(draw[l as usize]));
                let same: [u32; 16] = core::array::from_fn(|_| next() & 3);
                let p = Lanes::<f32, 16>::from_index(|l| {
                    let a = a.0[l as usize];
                    if same[l as usize] == 0 {
                        a
                    } else {
                        a * 1.0004
                    }
                });
                let t = Lanes::<f32, 16>::from_index(|l| value(draw[(l as usize + 3) % 16]));
                let got = store_with_correction_lanes(storage, a, p, t);
                let up = quantize_up_lanes(storage, a);
                for l in 0..16 {
                    let want = store_with_correction(storage, a.0[l], p.0[l], t.0[l]);
                    assert_eq!(got.0[l].to_bits(), want.to_bits(), "{storage} {:?}", a.0[l]);
                    let want = quantize_up(storage, a.0[l]);
                    assert_eq!(up.0[l].to_bits(), want.to_bits(), "{storage} {:?}", a.0[l]);
                }
            }
        }
    }

    #[test]
    fn quantize_up_is_the_ceiling() {
        for x in [0.0f32, 1e-7, 0.1, 0.333, 1.0, 1000.1, 65500.0] {
            let u = quantize_up(STORAGE_F16, x);
            assert!(u >= x && f32_to_f16(u) <= f32_to_f16(x) + 1, "{x} -> {u}");
        }
        assert_eq!(quantize_up(STORAGE_UNORM8, 0.5), unorm8_to_f32(128));
        assert_eq!(quantize_up(STORAGE_F16, 1e9), F16_MAX);
    }
}
