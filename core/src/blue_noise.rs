//! Spatio-temporal blue-noise thresholds for the stochastic tests of fractional ray rates.
//!
//! Seed: vrrt-call-of-duty-2026, "Undersampling" (`BlueNoiseSpatioTemporal(dtid, frameIndex)`) and
//! q2vkpt-2019 ("blue noise dither mask … white noise with a low pass filter leaves lots of noise").
//! A 64×64 void-and-cluster mask (Ulichney 1993) gives the spatial distribution; each frame adds
//! the golden ratio to every threshold (mod 1), so a pixel's thresholds over time form a
//! low-discrepancy sequence: a pixel asking for rate 1/4 is traced once every ~4 frames, evenly,
//! and neighbours take turns.
//!
//! [`screen_point`] is the blue noise of the ray directions ([`crate::sampling::SamplePattern`]):
//! procedural, so the ray kernels and the gradient re-trace need no mask buffer.

use crate::sequence::{pcg_hash, R2_STEP};

/// Levels of the pixel hierarchy [`screen_point`] orders: the pattern repeats every `2^12` pixels.
const LEVELS: u32 = 12;

/// A 2D point in `[0, 1)²` (32-bit fixed point) for pixel `(x, y)` of plane `plane` in frame
/// `frame`, blue across the screen and low-discrepancy over frames.
///
/// Ahmed & Wonka 2020, "Screen-space blue-noise diffusion of Monte Carlo sampling error via
/// hierarchical ordering of pixels": pixels are numbered in Morton order with the four children
/// of every quad-tree node permuted by a hash of the node, and pixel `n` takes point `n` of the
/// 2D Sobol sequence. Every aligned `2^k × 2^k` block then holds `4^k` consecutive Sobol points,
/// a (0, 2k, 2)-net, so neighbours' samples stratify the square at every scale: the error of a
/// neighbourhood cancels, leaving high frequencies. The frame adds `frame · R2` (mod 1) to every
/// point, which keeps the screen pattern and makes a still pixel's points over frames the R2
/// sequence. Depends on where the pixel is now and the frame, never on the history it carries.
#[inline]
pub fn screen_point(x: u32, y: u32, plane: u32, frame: u32) -> (u32, u32) {
    let salt = pcg_hash(plane ^ 0x5bd1_e995);
    let (a, b) = pixel_point(x, y, salt);
    (
        a.wrapping_add(frame.wrapping_mul(R2_STEP[0]))
            .wrapping_add(salt),
        b.wrapping_add(frame.wrapping_mul(R2_STEP[1]))
            .wrapping_add(pcg_hash(salt)),
    )
}

/// The unshifted point of [`screen_point`]: Sobol point number `n` of the pixel's scrambled
/// Morton number `n`, built bit by bit (32-bit fixed point).
#[inline]
fn pixel_point(x: u32, y: u32, salt: u32) -> (u32, u32) {
    let (mut a, mut b) = (0u32, 0u32);
    // Sobol direction number of the second dimension for the current bit (x + 1 polynomial).
    let mut v = 1u32 << 31;
    let mut l = 0;
    while l < LEVELS {
        let parent = (((y >> (l + 1)) & 0xfff) << 12) | ((x >> (l + 1)) & 0xfff);
        let flip = pcg_hash(parent ^ (l << 24) ^ salt) >> 30;
        let digit = (((x >> l) & 1) | (((y >> l) & 1) << 1)) ^ flip;
        // Bits 2l and 2l + 1 of the pixel's number: van der Corput and Sobol bits.
        let mut bit = 0;
        while bit < 2 {
            if (digit >> bit) & 1 != 0 {
                a ^= 1u32 << (31 - (2 * l + bit));
                b ^= v;
            }
            v ^= v >> 1;
            bit += 1;
        }
        l += 1;
    }
    (a, b)
}

/// Edge of the tiled mask.
pub const SIZE: u32 = 64;
/// Number of thresholds in the mask.
pub const LEN: usize = (SIZE * SIZE) as usize;

/// Threshold in `[0, 1)` of pixel `(x, y)` in frame `frame`, from a mask of [`LEN`] thresholds.
// Always inlined: called per lane from the lanes runners, it takes their instructions
// (a call is compiled for the baseline, where `floor` is a library call).
#[inline(always)]
pub fn blue_noise(mask: &[f32], x: u32, y: u32, frame: u32) -> f32 {
    animate(mask[mask_index(x, y) as usize], frame)
}

/// Where pixel `(x, y)` reads the tiled mask. Apart from [`animate`] so that a row of lanes
/// gathers first and computes after (a loop that indexes a slice is not vector code).
#[inline(always)]
pub fn mask_index(x: u32, y: u32) -> u32 {
    (y % SIZE) * SIZE + (x % SIZE)
}

/// Mask threshold `v` in frame `frame`.
#[inline(always)]
pub fn animate(v: f32, frame: u32) -> f32 {
    // Frame offset in 2^-24 units of the golden ratio, so large frame numbers stay exact.
    let offset = ((frame.wrapping_mul(10_368_890) & 0x00ff_ffff) as f32) * (1.0 / 16_777_216.0);
    // `t − floor(t)` for `t` in `[0, 2)`, without a floor (a library call in the CPU's scalar
    // runners).
    let t = v + offset;
    if t >= 1.0 {
        t - 1.0
    } else {
        t
    }
}

/// Builds the void-and-cluster mask (deterministic).
#[cfg(not(target_arch = "spirv"))]
pub fn generate_mask() -> [f32; LEN] {
    const SIGMA: f32 = 1.5;
    const RADIUS: i32 = 7;
    let n = SIZE as i32;
    let mut kernel = [[0.0f32; (2 * RADIUS + 1) as usize]; (2 * RADIUS + 1) as usize];
    for (dy, row) in kernel.iter_mut().enumerate() {
        for (dx, k) in row.iter_mut().enumerate() {
            let (fx, fy) = ((dx as i32 - RADIUS) as f32, (dy as i32 - RADIUS) as f32);
            *k = crate::math::exp(-(fx * fx + fy * fy) / (2.0 * SIGMA * SIGMA));
        }
    }
    let mut energy = [0.0f32; LEN];
    let mut on = [false; LEN];
    let splat = |energy: &mut [f32; LEN], i: usize, sign: f32| {
        let (x, y) = ((i as i32) % n, (i as i32) / n);
        for dy in -RADIUS..=RADIUS {
            for dx in -RADIUS..=RADIUS {
                let j = ((y + dy).rem_euclid(n) * n + (x + dx).rem_euclid(n)) as usize;
                energy[j] += sign * kernel[(dy + RADIUS) as usize][(dx + RADIUS) as usize];
            }
        }
    };
    // Tightest cluster (max energy among `want`) or largest void (min energy among `want`).
    let extreme = |energy: &[f32; LEN], on: &[bool; LEN], want: bool, max: bool| -> usize {
        let mut best = usize::MAX;
        for i in 0..LEN {
            if on[i] == want
                && (best == usize::MAX
                    || (max && energy[i] > energy[best])
                    || (!max && energy[i] < energy[best]))
            {
                best = i;
            }
        }
        best
    };
    // Initial pattern: 10% of pixels from a fixed xorshift sequence, then relaxed.
    let mut state = 0x9e37_79b9u32;
    let mut ones = 0;
    while ones < LEN / 10 {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        let i = (state as usize) % LEN;
        if !on[i] {
            on[i] = true;
            splat(&mut energy, i, 1.0);
            ones += 1;
        }
    }
    loop {
        let c = extreme(&energy, &on, true, true);
        on[c] = false;
        splat(&mut energy, c, -1.0);
        let v = extreme(&energy, &on, false, false);
        on[v] = true;
        splat(&mut energy, v, 1.0);
        if v == c {
            break;
        }
    }
    let mut rank = [0u32; LEN];
    // Phase 1: rank the initial ones by removing clusters.
    let (mut e1, mut on1) = (energy, on);
    for r in (0..ones).rev() {
        let c = extreme(&e1, &on1, true, true);
        on1[c] = false;
        splat(&mut e1, c, -1.0);
        rank[c] = r as u32;
    }
    // Phases 2 and 3: fill voids until every pixel is ranked.
    for r in ones..LEN {
        let v = extreme(&energy, &on, false, false);
        on[v] = true;
        splat(&mut energy, v, 1.0);
        rank[v] = r as u32;
    }
    let mut mask = [0.0f32; LEN];
    for i in 0..LEN {
        mask[i] = (rank[i] as f32 + 0.5) / LEN as f32;
    }
    mask
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    /// Cell of `(a, b)` in a `cells × cells` grid of the unit square.
    fn cell(a: u32, b: u32, cells: u32) -> usize {
        let k = cells.trailing_zeros();
        ((a >> (32 - k)) * cells + (b >> (32 - k))) as usize
    }

    #[test]
    fn screen_blocks_stratify_the_square() {
        // Every aligned 2^k × 2^k block holds one point per cell of a 2^k × 2^k grid.
        for k in 1..=3u32 {
            let side = 1u32 << k;
            for (bx, by) in [(0, 0), (3, 1), (17, 40)] {
                let mut seen = std::vec![0u32; (side * side) as usize];
                for y in by * side..(by + 1) * side {
                    for x in bx * side..(bx + 1) * side {
                        let (a, b) = pixel_point(x, y, 77);
                        seen[cell(a, b, side)] += 1;
                    }
                }
                assert!(
                    seen.iter().all(|&c| c == 1),
                    "k {k} block {bx},{by}: {seen:?}"
                );
            }
        }
    }

    #[test]
    fn screen_neighbours_are_farther_apart_than_white_noise() {
        // Mean toroidal distance between a pixel's point and its right neighbour's: white noise
        // gives ~0.38; the stratified blocks push neighbours apart.
        let dist = |p: (u32, u32), q: (u32, u32)| {
            let d = |u: u32, v: u32| {
                let t = u.wrapping_sub(v) as f64 / 4_294_967_296.0;
                t.min(1.0 - t)
            };
            (d(p.0, q.0).powi(2) + d(p.1, q.1).powi(2)).sqrt()
        };
        let mut sum = 0.0;
        for y in 0..64 {
            for x in 0..64 {
                sum += dist(screen_point(x, y, 1, 9), screen_point(x + 1, y, 1, 9));
            }
        }
        let mean = sum / 4096.0;
        assert!(mean > 0.42, "mean neighbour distance {mean}");
    }

    #[test]
    fn still_pixel_stratifies_over_frames() {
        // 256 frames of one pixel: every cell of a 4×4 grid holds 16 ± 3 (the R2 sequence).
        let mut cells = [0u32; 16];
        for f in 0..256 {
            let (a, b) = screen_point(13, 7, 2, f);
            cells[cell(a, b, 4)] += 1;
        }
        assert!(cells.iter().all(|&c| (13..=19).contains(&c)), "{cells:?}");
        assert_ne!(screen_point(13, 7, 2, 5), screen_point(13, 7, 3, 5));
    }

    #[test]
    fn mask_is_a_permutation_of_uniform_thresholds() {
        let m = generate_mask();
        let mut ranks: std::vec::Vec<u32> = m.iter().map(|&v| (v * LEN as f32) as u32).collect();
        ranks.sort();
        assert!(ranks.iter().enumerate().all(|(i, &r)| r == i as u32));
    }

    #[test]
    fn mask_is_blue_neighbours_differ() {
        // Blue noise: adjacent thresholds are anti-correlated compared with white noise (whose
        // mean absolute neighbour difference is 1/3).
        let m = generate_mask();
        let mut sum = 0.0;
        for y in 0..SIZE {
            for x in 0..SIZE {
                let a = m[(y * SIZE + x) as usize];
                let b = m[(y * SIZE + (x + 1) % SIZE) as usize];
                sum += (a - b).abs();
            }
        }
        let mean = sum / LEN as f32;
        assert!(mean > 0.38, "mean neighbour difference {mean}");
    }

    #[test]
    fn fractional_rate_is_met_over_time() {
        let m = generate_mask();
        for rate in [1.0 / 64.0, 0.25, 0.5] {
            let traced = (0..256u32)
                .filter(|&f| rate > blue_noise(&m, 5, 9, f))
                .count() as f32;
            assert!(
                (traced / 256.0 - rate).abs() < 0.02,
                "rate {rate}: {traced}/256"
            );
        }
    }
}
