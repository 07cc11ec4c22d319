//! IEEE binary16 (half) conversions, in integer operations so the host gives the same codes as
//! the GPU's conversion instructions. Below the lane vectors and the history's quantization,
//! which both convert.

/// Largest finite binary16 value.
pub const F16_MAX: f32 = 65504.0;
/// Largest binary16 code below infinity (`0x7BFF` = 65504).
pub const F16_MAX_CODE: u32 = 0x7bff;

/// binary16 code of `x`, rounded to nearest, ties to even (as IEEE conversion does). Overflow
/// gives infinity (`0x7C00`), NaN a quiet NaN; [`crate::quantize::quantize`] never lets either through.
pub fn f32_to_f16(x: f32) -> u32 {
    let b = x.to_bits();
    let sign = (b >> 16) & 0x8000;
    let a = b & 0x7fff_ffff;
    if a >= 0x7f80_0000 {
        return sign | 0x7c00 | if a > 0x7f80_0000 { 0x200 } else { 0 };
    }
    // Exponent rebiased from 127 to 15.
    let e = (a >> 23) as i32 - 112;
    if e >= 31 {
        return sign | 0x7c00;
    }
    let (h, rem, half) = if e <= 0 {
        // Subnormal half (or zero): the unit is 2^-24, i.e. the f32 mantissa with its implicit
        // bit shifted right by 14 - e.
        if e < -10 {
            // Below 2^-25: rounds to zero.
            return sign;
        }
        let m = (a & 0x7f_ffff) | 0x80_0000;
        let shift = (14 - e) as u32;
        (m >> shift, m & ((1 << shift) - 1), 1u32 << (shift - 1))
    } else {
        (((e as u32) << 10) | ((a >> 13) & 0x3ff), a & 0x1fff, 0x1000)
    };
    // A carry out of the mantissa correctly bumps the exponent (up to infinity).
    let h = if rem > half || (rem == half && (h & 1) == 1) {
        h + 1
    } else {
        h
    };
    sign | h
}

/// Value of a binary16 code (exact). Infinity and NaN codes decode as infinity/NaN bit patterns;
/// [`quantize`](crate::quantize::quantize) never produces them.
///
/// On the GPU the conversion instruction (`UnpackHalf2x16`), which is exact everywhere: every
/// binary16 value is an f32.
#[inline]
pub fn f16_to_f32(h: u32) -> f32 {
    #[cfg(target_arch = "spirv")]
    return spirv_std::float::f16x2_to_vec2(h).x;
    #[cfg(not(target_arch = "spirv"))]
    f16_to_f32_bits(h)
}

/// [`f16_to_f32`] in integer operations: the host's form (vector code over lanes).
#[cfg(not(target_arch = "spirv"))]
#[inline]
fn f16_to_f32_bits(h: u32) -> f32 {
    let sign = (h & 0x8000) << 16;
    let e = (h >> 10) & 0x1f;
    let m = h & 0x3ff;
    // Zero or subnormal: m · 2^-24, exact in f32 (m < 2^10, so the signed conversion is exact).
    let small = f32::from_bits((m as i32 as f32 * (1.0 / 16_777_216.0)).to_bits() | sign);
    let e32 = if e == 31 { 255 } else { e + 112 };
    let normal = f32::from_bits(sign | (e32 << 23) | (m << 13));
    // A select, not a branch: decodes in a loop over lanes become vector code.
    if e == 0 {
        small
    } else {
        normal
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every finite half round-trips, and f32 values around every midpoint between consecutive
    /// halves round to the nearer one (ties to the even code): the conversion is exhaustively
    /// IEEE round-to-nearest-even over the non-negative range.
    #[test]
    fn f16_round_trip_and_midpoints_exhaustive() {
        for h in 0..=F16_MAX_CODE {
            let v = f16_to_f32(h);
            assert_eq!(f32_to_f16(v), h, "{h:#x}");
            assert_eq!(f32_to_f16(-v), h | 0x8000, "-{h:#x}");
            if h < F16_MAX_CODE {
                let next = f16_to_f32(h + 1);
                let mid = ((v as f64 + next as f64) / 2.0) as f32;
                assert_eq!(mid as f64, (v as f64 + next as f64) / 2.0, "mid exact");
                let even = if h & 1 == 0 { h } else { h + 1 };
                assert_eq!(f32_to_f16(mid), even, "tie at {h:#x}");
                assert_eq!(f32_to_f16(f32::from_bits(mid.to_bits() - 1)), h);
                assert_eq!(f32_to_f16(f32::from_bits(mid.to_bits() + 1)), h + 1);
            }
        }
        // Overflow: 65520 (midpoint to 2^16) ties to even = infinity; just below stays max.
        assert_eq!(f32_to_f16(65520.0), 0x7c00);
        assert_eq!(f32_to_f16(65519.996), F16_MAX_CODE);
        assert_eq!(f32_to_f16(f32::INFINITY), 0x7c00);
        assert_eq!(f32_to_f16(1e-30), 0);
        assert_eq!(f16_to_f32(1), 5.960_464_5e-8);
    }
}
