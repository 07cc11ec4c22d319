//! Tile classification: a few tracer rays per tile estimate how many rays the tile needs.

use super::*;

/// Push constants of [`reflect_tiles`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TileParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Lights in `lights` to use.
    pub lights: u32,
    /// Frame index: picks the tracer pixels and their rng indices.
    pub frame: u32,
    /// Importance of a tile with nothing to reflect or a flat reflection (user minimum).
    pub min_rate: f32,
    /// Importance of the noisiest tiles (user maximum).
    pub max_rate: f32,
    /// Standard deviation of the tone-mapped tracer values that earns `max_rate`.
    pub sigma: f32,
    /// Reserved.
    pub _pad: u32,
    /// Eye and hit lighting.
    pub shading: Shading,
}

/// Tiles across and down for a `width × height` image.
pub fn tile_grid(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(TILE), height.div_ceil(TILE))
}

/// Index of the tile holding pixel `(x, y)` of an image `width` pixels wide.
#[inline]
pub fn tile_index(x: u32, y: u32, width: u32) -> usize {
    ((y / TILE) * width.div_ceil(TILE) + x / TILE) as usize
}

/// Tile classification (seed: "estimate tile importance"), one invocation per [`TILE`]² tile:
/// [`TRACERS`] rays from hashed pixels of the tile estimate the perceptual variance of its
/// reflection (values tone-mapped `L / (1 + L)`). A tile where no tracer found a reflecting
/// surface or hit anything but sky gets `min_rate`; otherwise the rate grows linearly with the
/// standard deviation, reaching `max_rate` at `sigma`. The result scales the ray rate VRRT's
/// reprojection requests in the tile ("allocate ray count per tile, between user min and max").
pub fn reflect_tiles(id: UVec3, p: &TileParams, io: ReflectTilesIo<'_>) {
    let ReflectTilesIo {
        depth,
        normal_roughness,
        geometry,
        view,
        nodes,
        tris,
        lights,
        importance,
    } = io;
    let scene = HitScene {
        nodes,
        tris,
        lights,
        light_count: p.lights,
    };
    let (tw, th) = tile_grid(p.width, p.height);
    if id.x >= tw || id.y >= th {
        return;
    }
    let (mut s1, mut s2, mut n) = (0.0f32, 0.0f32, 0.0f32);
    let mut hit_anything = false;
    let mut k = 0;
    while k < TRACERS {
        let h = crate::sampling::rand_u32(
            pixel_seed(id.x, id.y, TRACER_PLANE),
            p.frame.wrapping_mul(TRACERS).wrapping_add(k),
            0,
        );
        let x = id.x * TILE + (h & (TILE - 1));
        let y = id.y * TILE + ((h >> 8) & (TILE - 1));
        if x < p.width && y < p.height {
            let s = surface::load_with_hit(
                &view[0],
                pixel_index(x, y, p.width),
                p.width,
                p.height,
                depth,
                normal_roughness,
                geometry,
            );
            let r = reflection_ray(
                &s,
                &p.shading,
                Stream::per_pixel(pixel_seed(x, y, TRACER_PLANE)),
                p.frame,
                scene,
            );
            if r.pdf > 0.0 {
                let v = r.radiance / (1.0 + r.radiance);
                s1 += v;
                s2 += v * v;
                n += 1.0;
                hit_anything = hit_anything || r.distance < MISS_DISTANCE;
            }
        }
        k += 1;
    }
    let rate = if !hit_anything || n < 1.0 {
        p.min_rate
    } else {
        let mean = s1 / n;
        let sd = math::sqrt(math::max(s2 / n - mean * mean, 0.0));
        let t = math::saturate(sd / math::max(p.sigma, 1e-6));
        p.min_rate + (p.max_rate - p.min_rate) * t
    };
    importance[tile_index(id.x * TILE, id.y * TILE, p.width)] = rate;
}
