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

use super::pixel_index;
use super::ClassifyIo;
use crate::atomic;
use crate::math;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Tile edge in pixels (the à-trous workgroup).
pub const TILE: u32 = 8;
/// Words of the histogram: `[empty tiles, tiles needing 0, 1, …, 5 iterations, padding]`.
pub const HISTOGRAM_LEN: u32 = 8;

/// Push constants of [`classify`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ClassifyParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal planes (a tile needs what its worst plane needs).
    pub planes: u32,
    /// À-trous iterations configured (the cap).
    pub iterations: u32,
    /// Standard deviation of the estimate below which a pixel needs no more filtering; 0 = never
    /// skip.
    pub skip_sigma: f32,
    /// Padding.
    pub _pad: [f32; 3],
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

/// One invocation per tile: writes the iterations the tile needs to `tiles` (0 for a tile without
/// geometry: invalid pixels are passed through by every iteration anyway) and counts the tile in
/// `histogram` (cleared by the host before).
pub fn classify(id: UVec3, p: &ClassifyParams, io: ClassifyIo<'_>) {
    let ClassifyIo {
        depth,
        filtered,
        tiles,
        histogram,
    } = io;
    let (tw, th) = tile_grid(p.width, p.height);
    if id.x >= tw || id.y >= th {
        return;
    }
    let plane = (p.width * p.height) as usize;
    let mut any = false;
    let mut worst = 0.0f32;
    let mut bad = false;
    let mut y = id.y * TILE;
    while y < (id.y + 1) * TILE && y < p.height {
        let mut x = id.x * TILE;
        while x < (id.x + 1) * TILE && x < p.width {
            let pix = pixel_index(x, y, p.width);
            if crate::surface::has_surface(depth[pix]) {
                any = true;
                let mut z = 0;
                while z < p.planes {
                    let v = filtered[z as usize * plane + pix].unpack().variance;
                    if !(v >= 0.0 && math::is_finite(v)) {
                        bad = true;
                    } else if v > worst {
                        worst = v;
                    }
                    z += 1;
                }
            }
            x += 1;
        }
        y += 1;
    }
    let (level, slot) = if any {
        let n = if bad {
            p.iterations
        } else {
            iterations_needed(worst, p)
        };
        (n, 1 + n)
    } else {
        (0, 0)
    };
    tiles[(id.y * tw + id.x) as usize] = level;
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
}
