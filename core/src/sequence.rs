//! The stateless integer sources every sampler builds on: a hash and the R2 sequence's step.
//! Below both the per-pixel sequences ([`crate::sampling`]) and the screen-space blue noise
//! ([`crate::blue_noise`]), which draw on them and on each other's results.

/// One round of the PCG output permutation as a 32-bit hash (Jarzynski & Olano 2020, "Hash
/// Functions for GPU Rendering"). A bijection of `u32`, integer ops only.
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// 32-bit fixed-point steps of the R2 sequence (Roberts 2018: `1/g`, `1/g²` for the plastic
/// number `g`), the 2D low-discrepancy sequence with the best known packing.
pub const R2_STEP: [u32; 2] = [3_242_174_889, 2_447_445_414];
