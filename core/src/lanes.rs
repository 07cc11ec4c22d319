//! `N` neighbouring invocations of a kernel in one call.
//!
//! Why: on the CPU one pixel at a time, a filter tap is a chain of dependent scalar operations
//! (a binary16 decode, an octahedral decode, seven squarings, an exponential) and the vector
//! units sit idle. A kernel written over [`Lanes`] runs `N` consecutive pixels of a row
//! together: its GPU entry calls it with `N = 1` (one invocation, the scalar instructions), the
//! CPU runner with the `N` the kernel declares (one call per row of `N / 8` workgroups), and
//! every lane loop here is a plain loop over an array that LLVM turns into vector instructions
//! (AVX2 where the CPU has it, AVX-512 for the kernels that gain from it: see `crate::declare`).
//! Wider rows amortise more per-pixel setup until the live values spill: à-trous runs 32 wide
//! on AVX2 and 64 on AVX-512, variance 16 and 32, reprojection 16, the detector 16 and 32,
//! accumulation and `apply` 16 and 64 (each measured fastest).
//!
//! Each lane performs exactly the operations of the scalar code, in the same order; branches
//! become selects between values both computed from the same inputs. Results are therefore the
//! same bits for every `N` on one target; across backends (the GPU takes its own transcendental
//! instructions and fuses multiply-adds) they agree within the equivalence tolerances
//! (`docs/equivalence.md`).

use crate::binary16;
use crate::math;

/// Runs `$body` for every lane index `$l` (a `usize`) of a function generic over `N`. On the GPU,
/// whose kernels run one lane (`N = 1`, checked when compiled), the body runs once with the
/// constant index 0: an array indexed by a loop counter, even one of trip count 1, was kept in
/// memory by an H100's compiler (`Lanes::pow`'s loops cost a quarter of à-trous there).
macro_rules! each_lane {
    ($l:ident in $n:ident $body:block) => {{
        #[cfg(target_arch = "spirv")]
        {
            const { assert!($n == 1, "GPU kernels run one lane") };
            let $l = 0usize;
            $body
        }
        #[cfg(not(target_arch = "spirv"))]
        {
            let mut $l = 0usize;
            while $l < $n {
                $body
                $l += 1;
            }
        }
    }};
}
pub(crate) use each_lane;

/// One value per lane.
///
/// 64-byte aligned on the CPU: rows of lanes live in the runner's stack frame, and at their
/// elements' alignment an AVX-512 register's load or store of one straddled two cache lines
/// wherever the caller's stack depth put the frame, so a kernel's time moved with unrelated
/// changes elsewhere in the binary (`docs/results/per-pass.md`, 2026-11-27, evening).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(not(target_arch = "spirv"), repr(align(64)))]
pub struct Lanes<T, const N: usize>(pub [T; N]);

impl<T: Copy + Default, const N: usize> Lanes<T, N> {
    /// The same value in every lane.
    #[inline(always)]
    pub fn splat(v: T) -> Self {
        Lanes([v; N])
    }

    /// `f` of lane `l`'s index, for every lane.
    #[inline(always)]
    pub fn from_index(f: impl Fn(u32) -> T) -> Self {
        let mut out = [T::default(); N];
        each_lane!(l in N {
            out[l] = f(l as u32);
        });
        Lanes(out)
    }

    /// `f` of every lane.
    #[inline(always)]
    pub fn map<U: Copy + Default>(self, f: impl Fn(T) -> U) -> Lanes<U, N> {
        let mut out = [U::default(); N];
        each_lane!(l in N {
            out[l] = f(self.0[l]);
        });
        Lanes(out)
    }

    /// `f` of every pair of lanes.
    #[inline(always)]
    pub fn zip<U: Copy + Default, V: Copy + Default>(
        self,
        other: Lanes<U, N>,
        f: impl Fn(T, U) -> V,
    ) -> Lanes<V, N> {
        let mut out = [V::default(); N];
        each_lane!(l in N {
            out[l] = f(self.0[l], other.0[l]);
        });
        Lanes(out)
    }

    /// `self` where `mask` is set, `other` elsewhere.
    #[inline(always)]
    pub fn select(self, mask: Lanes<bool, N>, other: Self) -> Self {
        let mut out = other.0;
        each_lane!(l in N {
            if mask.0[l] {
                out[l] = self.0[l];
            }
        });
        Lanes(out)
    }

    /// Elements `start + l` of `s` (`start + N <= s.len()`).
    #[inline(always)]
    pub fn load(s: &[T], start: usize) -> Self {
        #[cfg(not(target_arch = "spirv"))]
        {
            let mut out = [T::default(); N];
            out.copy_from_slice(&s[start..start + N]);
            Lanes(out)
        }
        #[cfg(target_arch = "spirv")]
        {
            let mut out = [T::default(); N];
            each_lane!(l in N {
                out[l] = s[start + l];
            });
            Lanes(out)
        }
    }

    /// Lanes `start + l` of `blocks` read as one row (`start + N` at most `B·N`): a window
    /// sliding across consecutive blocks of lanes.
    #[inline(always)]
    pub fn window<const B: usize>(blocks: &[[T; N]; B], start: usize) -> Self {
        #[cfg(not(target_arch = "spirv"))]
        {
            Self::load(blocks.as_flattened(), start)
        }
        #[cfg(target_arch = "spirv")]
        {
            Self::from_index(|l| {
                let i = start + l as usize;
                blocks[i / N][i % N]
            })
        }
    }

    /// Elements `index[l]` of `s`.
    #[inline(always)]
    pub fn gather(s: &[T], index: Lanes<u32, N>) -> Self {
        let mut out = [T::default(); N];
        each_lane!(l in N {
            out[l] = s[index.0[l] as usize];
        });
        Lanes(out)
    }

    /// Row `row_start` of an image `width` wide, at columns `x0 + l` clamped to the row: one
    /// contiguous load when every column is inside.
    #[inline(always)]
    pub fn load_row(s: &[T], row_start: u32, x0: i32, width: u32) -> Self {
        if x0 >= 0 && x0 + N as i32 <= width as i32 {
            Self::load(s, (row_start + x0 as u32) as usize)
        } else {
            Self::gather(
                s,
                Lanes::from_index(|l| row_start + clamp_column(x0 + l as i32, width)),
            )
        }
    }

    /// Stores the lanes where `mask` is set to `s[start + l]`.
    #[inline(always)]
    pub fn store(self, s: &mut [T], start: usize, mask: Lanes<bool, N>) {
        each_lane!(l in N {
            if mask.0[l] {
                s[start + l] = self.0[l];
            }
        });
    }
}

/// Column `x` clamped to `[0, width)`.
#[inline]
pub fn clamp_column(x: i32, width: u32) -> u32 {
    if x < 0 {
        0
    } else if x >= width as i32 {
        width - 1
    } else {
        x as u32
    }
}

impl<const N: usize> Lanes<bool, N> {
    /// True if any lane is set.
    #[inline(always)]
    pub fn any(self) -> bool {
        let mut r = false;
        each_lane!(l in N {
            r |= self.0[l];
        });
        r
    }

    /// True if every lane is set.
    #[inline(always)]
    pub fn all(self) -> bool {
        let mut r = true;
        each_lane!(l in N {
            r &= self.0[l];
        });
        r
    }
}

impl<const N: usize> Lanes<f32, N> {
    /// Adds `v` in the lanes where `mask` is set: `self + (mask ? v : 0)`, a masked add the
    /// vectorizer handles where a conditional `+=` per lane stays scalar. The same bits as
    /// adding only where set, for sums that started at +0 (such a sum is never −0, and
    /// `x + 0 = x` for every other `x`).
    #[inline(always)]
    pub fn add_where(self, mask: Lanes<bool, N>, v: Self) -> Self {
        let mut out = self.0;
        each_lane!(l in N {
            out[l] += if mask.0[l] { v.0[l] } else { 0.0 };
        });
        Lanes(out)
    }

    /// [`math::pow`] of every lane, with a uniform exponent: the same bits, with the
    /// square-and-multiply steps run across the lanes (a loop over exponent bits cannot be
    /// turned into vector code one lane at a time).
    // Plain comparisons, as in `math::pow`: the same instructions on every target.
    #[allow(clippy::manual_range_contains)]
    #[inline(always)]
    pub fn pow(self, y: f32) -> Self {
        // One lane on the GPU: the scalar form, whose loops carry a float, not an array.
        #[cfg(target_arch = "spirv")]
        return self.map(|x| math::pow(x, y));
        #[cfg(not(target_arch = "spirv"))]
        self.pow_lanes(y)
    }

    /// [`Self::pow`] with the steps across the lanes.
    #[cfg(not(target_arch = "spirv"))]
    #[allow(clippy::manual_range_contains)]
    #[inline(always)]
    fn pow_lanes(self, y: f32) -> Self {
        let whole = y >= 1.0 && y <= 1024.0 && math::floor(y) == y;
        if !whole {
            return self.map(|x| math::pow(x, y));
        }
        let mut e = y as u32;
        let mut base = self;
        while e & 1 == 0 {
            base = base.zip(base, |a, b| a * b);
            e >>= 1;
        }
        let mut acc = base;
        e >>= 1;
        while e != 0 {
            base = base.zip(base, |a, b| a * b);
            if e & 1 == 1 {
                acc = acc.zip(base, |a, b| a * b);
            }
            e >>= 1;
        }
        let acc = acc.map(|a| if a < math::MIN_NORMAL { 0.0 } else { a });
        // math::pow's other cases: 0 gives 0 (as the squares do); negatives, NaN and values above
        // 1 (a dot product of unit vectors can round there) take its exp2/log2 route.
        let general = self.map(|x| !(x >= 0.0 && x <= 1.0));
        if general.any() {
            let other = self.map(|x| math::pow(x, y));
            other.select(general, acc)
        } else {
            acc
        }
    }
}

impl<const N: usize> Lanes<u32, N> {
    /// [`binary16::f16_to_f32`] of every lane's binary16 code (its low 16 bits). On x86-64 with
    /// F16C, eight lanes per conversion instruction: the same values for every code but
    /// signalling NaNs, which the instruction quiets. No buffer holds one: the kernels store
    /// [`binary16::f32_to_f16`]'s codes, whose NaNs are quiet (tested over every code).
    #[inline(always)]
    pub fn f16_to_f32(self) -> Lanes<f32, N> {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if N.is_multiple_of(8) && std::is_x86_feature_detected!("f16c") {
            // SAFETY: the CPU has F16C.
            return unsafe { f16c::widen(self) };
        }
        self.map(|h| binary16::f16_to_f32(h & 0xffff))
    }
}

impl<const N: usize> Lanes<f32, N> {
    /// [`binary16::f32_to_f16`] of every lane, the same codes for every input (tested over
    /// every exponent). On x86-64 with F16C, eight lanes per conversion instruction (round to
    /// nearest even, as `f32_to_f16`); NaNs first become the quiet NaN of their sign, the one
    /// `f32_to_f16` gives.
    #[inline(always)]
    pub fn f32_to_f16(self) -> Lanes<u32, N> {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if N.is_multiple_of(8) && std::is_x86_feature_detected!("f16c") {
            let canonical = self.map(|x| {
                let b = x.to_bits();
                let nan = (b & 0x7fff_ffff) > 0x7f80_0000;
                f32::from_bits(if nan {
                    (b & 0x8000_0000) | 0x7fc0_0000
                } else {
                    b
                })
            });
            // SAFETY: the CPU has F16C.
            return unsafe { f16c::narrow(canonical) };
        }
        self.map(binary16::f32_to_f16)
    }
}

/// The binary16 conversion instructions, eight lanes at a time: inlined into the CPU runners
/// compiled for AVX2 or AVX-512 (which enable F16C), called otherwise.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod f16c {
    use super::Lanes;
    use core::arch::x86_64::{
        _mm256_cvtph_ps, _mm256_cvtps_ph, _mm256_loadu_ps, _mm256_storeu_ps, _mm_loadu_si128,
        _mm_storeu_si128, _MM_FROUND_TO_NEAREST_INT,
    };

    #[target_feature(enable = "f16c")]
    #[inline]
    pub unsafe fn widen<const N: usize>(h: Lanes<u32, N>) -> Lanes<f32, N> {
        let mut out = [0.0f32; N];
        let mut i = 0;
        while i + 8 <= N {
            let codes: [u16; 8] = core::array::from_fn(|k| h.0[i + k] as u16);
            // SAFETY: 8 codes in, 8 floats out, both in bounds.
            unsafe {
                let v = _mm256_cvtph_ps(_mm_loadu_si128(codes.as_ptr().cast()));
                _mm256_storeu_ps(out.as_mut_ptr().add(i), v);
            }
            i += 8;
        }
        Lanes(out)
    }

    #[target_feature(enable = "f16c")]
    #[inline]
    pub unsafe fn narrow<const N: usize>(x: Lanes<f32, N>) -> Lanes<u32, N> {
        let mut out = [0u32; N];
        let mut i = 0;
        while i + 8 <= N {
            let mut codes = [0u16; 8];
            // SAFETY: 8 floats in, 8 codes out, both in bounds.
            unsafe {
                let v = _mm256_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(_mm256_loadu_ps(
                    x.0.as_ptr().add(i),
                ));
                _mm_storeu_si128(codes.as_mut_ptr().cast(), v);
            }
            let mut k = 0;
            while k < 8 {
                out[i + k] = codes[k] as u32;
                k += 1;
            }
            i += 8;
        }
        Lanes(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pow_over_lanes_is_math_pow_bit_for_bit() {
        let xs = [
            0.0,
            -0.0,
            1e-40,
            0.3,
            0.999_999_9,
            1.0,
            1.000_000_1,
            1.5,
            -0.5,
            f32::NAN,
            0.87,
            f32::INFINITY,
        ];
        for y in [128.0, 1.0, 2.0, 7.0, 1024.0, 0.0, 0.5, 3.5, 2000.0] {
            for chunk in xs.chunks(4) {
                let lanes = Lanes::<f32, 4>::from_index(|l| chunk[l as usize]).pow(y);
                for (x, got) in chunk.iter().zip(lanes.0) {
                    assert_eq!(got.to_bits(), math::pow(*x, y).to_bits(), "{x}^{y}");
                }
            }
        }
    }

    #[test]
    fn binary16_decode_over_lanes_is_f16_to_f32_for_every_quiet_code() {
        let quiet = |h: u32| !((h >> 10) & 0x1f == 0x1f && h & 0x3ff != 0 && h & 0x200 == 0);
        let codes: std::vec::Vec<u32> = (0..1u32 << 16).filter(|&h| quiet(h)).collect();
        for chunk in codes.chunks(16) {
            let lanes = Lanes::<u32, 16>::from_index(|l| {
                // Whatever is above the low half is ignored.
                chunk[l as usize % chunk.len()] | 0xabcd_0000
            });
            for (h, got) in lanes.0.iter().zip(lanes.f16_to_f32().0) {
                let want = binary16::f16_to_f32(h & 0xffff);
                assert_eq!(got.to_bits(), want.to_bits(), "{h:#x}");
            }
        }
    }

    #[test]
    fn binary16_encode_over_lanes_is_f32_to_f16_for_every_exponent() {
        // Every sign and exponent with mantissas around each rounding position (the round bit
        // moves from bit 12 for normal halves up to bit 23 for the smallest subnormals), and
        // NaNs with every payload bit.
        let mut xs = std::vec::Vec::new();
        for sign in [0u32, 1 << 31] {
            for e in 0..256u32 {
                for bit in 0..23u32 {
                    for low in [0u32, 1, 2, 3] {
                        let half = 1u32 << bit;
                        for m in [half - 1, half, half + 1, half | (half << 1), half * 3 - 1] {
                            let m = (m ^ (low << 20)) & 0x7f_ffff;
                            xs.push(sign | (e << 23) | m);
                        }
                    }
                }
                for m in [0u32, 0x7f_ffff, 0x40_0000, 0x3f_ffff, 0x55_5555, 0x2a_aaaa] {
                    xs.push(sign | (e << 23) | m);
                }
            }
        }
        let mut rng = 0x1234_5678u32;
        for _ in 0..1 << 20 {
            rng ^= rng << 13;
            rng ^= rng >> 17;
            rng ^= rng << 5;
            xs.push(rng);
        }
        for chunk in xs.chunks(16) {
            let lanes =
                Lanes::<f32, 16>::from_index(|l| f32::from_bits(chunk[l as usize % chunk.len()]));
            for (x, got) in lanes.0.iter().zip(lanes.f32_to_f16().0) {
                let want = binary16::f32_to_f16(*x);
                assert_eq!(got, want, "{:#x}", x.to_bits());
            }
        }
    }

    #[test]
    fn rows_load_contiguously_inside_and_clamp_at_the_edges() {
        let row: [u32; 10] = core::array::from_fn(|i| i as u32 + 100);
        assert_eq!(
            Lanes::<u32, 4>::load_row(&row, 0, 3, 10).0,
            [103, 104, 105, 106]
        );
        assert_eq!(
            Lanes::<u32, 4>::load_row(&row, 0, -2, 10).0,
            [100, 100, 100, 101]
        );
        assert_eq!(
            Lanes::<u32, 4>::load_row(&row, 0, 8, 10).0,
            [108, 109, 109, 109]
        );
        let mut out = [0u32; 4];
        Lanes([1, 2, 3, 4]).store(&mut out, 0, Lanes([true, false, true, false]));
        assert_eq!(out, [1, 0, 3, 0]);
    }
}
