//! Tile classification for the spatial filter: how many à-trous iterations each 8×8 tile needs.
//!
//! Seed: stochastic-ssr-frostbite-2015 (tile classification: decide per tile, from what the tile
//! holds, which work later passes do, so empty tiles cost nothing) applied to SVGF's filter. A tile
//! with no geometry needs no filtering. Elsewhere the rule is: each à-trous iteration at least
//! halves the standard deviation of the estimate (a 5×5 B3 pass with every weight 1 divides it by
//! 2.2; edge stopping only lowers the gain), so a tile whose largest standard deviation is `σ`
//! needs `ceil(log2(σ / skip_sigma))` iterations to bring every pixel below `skip_sigma`, capped at
//! the configured count. Converged tiles (long history, so a small variance of the estimate) skip
//! the filter's wide late iterations; fresh history (disocclusion, a dropped gradient, the spatial
//! fallback) always gets the full filter. A NaN or infinite variance also gets the full filter.
//!
//! The tile is the à-trous workgroup (8×8), so on a GPU the skip is uniform per workgroup.
//!
//! The variance pass gathers each tile's worst variance as it writes it ([`tile_key`], an atomic
//! max per tile each row of pixels crosses), so this pass reads one word per tile, not the
//! image: what it would read again
//! (depth and the filter input, 8 bytes a pixel) is the pass's whole traffic otherwise.

use super::ClassifyIo;
use crate::atomic;
use crate::math;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Tile edge in pixels (the à-trous workgroup).
pub const TILE: u32 = 8;
/// Words of the histogram: `[empty tiles, tiles needing 0, 1, …, 5 iterations, padding]`.
pub const HISTOGRAM_LEN: u32 = 8;

/// Tile word of a tile whose worst variance is NaN, infinite or negative, less one.
pub const BAD: u32 = 0x7f80_0000;

/// What a pixel with a surface folds into its tile's word with an atomic max: 1 + the bits of its
/// stored `variance` (non-negative floats order as their bits), or 1 + [`BAD`] for a NaN,
/// infinite or negative one. A word of 0 is a tile without geometry.
#[inline]
pub fn tile_key(variance: f32) -> u32 {
    let bits = if !(variance >= 0.0 && math::is_finite(variance)) {
        BAD
    } else if variance > 0.0 {
        variance.to_bits()
    } else {
        0
    };
    bits + 1
}

/// Push constants of [`classify`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ClassifyParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// À-trous iterations configured (the cap).
    pub iterations: u32,
    /// Standard deviation of the estimate below which a pixel needs no more filtering; 0 = never
    /// skip.
    pub skip_sigma: f32,
}

/// Tiles across and down a `width × height` image.
#[inline]
pub fn tile_grid(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(TILE), height.div_ceil(TILE))
}

/// Index of the tile holding pixel `(x, y)`.
#[inline]
pub fn tile_index(x: u32, y: u32, width: u32) -> usize {
    ((y / TILE) * width.div_ceil(TILE) + x / TILE) as usize
}

/// Iterations a tile whose largest variance of the estimate is `variance` needs (module rule).
#[inline]
pub fn iterations_needed(variance: f32, p: &ClassifyParams) -> u32 {
    if p.skip_sigma <= 0.0 || !(variance >= 0.0 && math::is_finite(variance)) {
        return p.iterations;
    }
    let ratio = math::sqrt(variance) / p.skip_sigma;
    if ratio <= 1.0 {
        return 0;
    }
    let n = -math::floor(-math::log2(ratio));
    if n >= p.iterations as f32 {
        p.iterations
    } else {
        n as u32
    }
}

/// One invocation per tile: turns the tile's word (the variance pass's [`tile_key`] maximum)
/// into the iterations the tile needs, in place (0 for a tile without geometry: invalid pixels
/// are passed through by every iteration anyway), and counts the tile in `histogram` (cleared by
/// the host before).
pub fn classify(id: UVec3, p: &ClassifyParams, io: ClassifyIo<'_>) {
    let ClassifyIo { tiles, histogram } = io;
    let (tw, th) = tile_grid(p.width, p.height);
    if id.x >= tw || id.y >= th {
        return;
    }
    let t = (id.y * tw + id.x) as usize;
    let word = tiles[t];
    let (level, slot) = if word == 0 {
        (0, 0)
    } else {
        let n = if word > BAD {
            p.iterations
        } else {
            iterations_needed(f32::from_bits(word - 1), p)
        };
        (n, 1 + n)
    };
    tiles[t] = level;
    atomic::add(&mut histogram[slot as usize], 1);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(skip_sigma: f32) -> ClassifyParams {
        ClassifyParams {
            iterations: 5,
            skip_sigma,
            ..Default::default()
        }
    }

    #[test]
    fn iterations_follow_the_halving_rule() {
        let p = params(0.01);
        assert_eq!(iterations_needed(0.0, &p), 0);
        assert_eq!(iterations_needed(0.01 * 0.01, &p), 0, "at the threshold");
        assert_eq!(iterations_needed(0.015 * 0.015, &p), 1);
        assert_eq!(iterations_needed(0.03 * 0.03, &p), 2);
        assert_eq!(iterations_needed(0.1 * 0.1, &p), 4);
        assert_eq!(iterations_needed(1.0, &p), 5, "capped");
        assert_eq!(iterations_needed(f32::NAN, &p), 5);
        assert_eq!(iterations_needed(f32::INFINITY, &p), 5);
        assert_eq!(iterations_needed(0.0, &params(0.0)), 5, "off");
    }

    #[test]
    fn tile_keys_order_as_variances_and_flag_bad_ones() {
        let keys = [0.0f32, 1e-30, 1e-4, 0.5, 1.0, 3e38].map(tile_key);
        assert!(keys.windows(2).all(|k| k[0] < k[1]), "{keys:?}");
        assert_eq!(tile_key(-0.0), tile_key(0.0));
        assert!(keys.iter().all(|&k| k > 0), "0 is the empty tile");
        for bad in [f32::NAN, f32::INFINITY, -1e-6, f32::NEG_INFINITY] {
            assert_eq!(tile_key(bad), BAD + 1);
            assert!(tile_key(bad) > keys[5]);
        }
    }
}
