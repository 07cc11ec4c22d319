//! Variance estimation: turns the accumulated moments into the `(value, variance)` pair the
//! à-trous filter reads.
//!
//! Seed: q2vkpt-path-tracing-denoising-2019 (SVGF: "variance estimation … also acts as a fallback
//! if there's no temporal information yet") and vrrt-call-of-duty-2026 ("Spatial temporal variance
//! estimate? … good as emergency fallback only"). With a long history the temporal variance of
//! the moments is used as is. While the history is shorter than `spatial_until` rays, a bilateral
//! (normal + plane) estimate over a `(2r+1)²` window is blended in:
//! `t = count / spatial_until`, `value = lerp(spatial_mean, m1, t)`,
//! `variance = lerp(spatial_variance, temporal_variance, t)`. Both are variances of single rays;
//! the output is the variance of the pixel's *estimate*, divided by the rays it holds
//! (`max(count, 1)`), so the luminance edge-stopping of the à-trous filter tightens as history
//! converges — SVGF's "stops applying blur after temporal stability is achieved" — instead of
//! blurring a converged pixel as hard as a 1-ray one. A pixel with no history at all
//! (`count = 0`) therefore takes the spatial estimate entirely — this is also how undersampled
//! pixels get a value without feeding it back into history.
//!
//! The pass also gathers what tile classification needs: each pixel with a surface folds the
//! variance it stored into its tile's word with an atomic max ([`classify::tile_key`]), so the
//! classification reads one word per tile instead of the whole image again.

use super::classify;
use super::VarianceIo;
use super::{pixel_index, plane_index};
use crate::atomic;
use crate::camera::{PixelRays, View};
use crate::math;
use crate::packing;
use crate::payload::{Filtered, PackedPayload};
use crate::surface::{self, TangentPlane};
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`variance`].
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Pod, Zeroable)]
pub struct VarianceParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Window radius of the spatial fallback (3 → 7×7).
    pub radius: u32,
    /// Padding.
    pub _pad: u32,
    /// History length (rays) from which the temporal estimate is used alone (SVGF: 4).
    pub spatial_until: f32,
    /// Plane-distance tolerance, as [`crate::kernels::atrous::AtrousParams::plane_scale`].
    pub plane_scale: f32,
    /// Exponent of the normal weight.
    pub normal_power: f32,
    /// Padding.
    pub _pad1: f32,
}

impl Default for VarianceParams {
    fn default() -> Self {
        VarianceParams {
            width: 0,
            height: 0,
            radius: 3,
            _pad: 0,
            spatial_until: 4.0,
            plane_scale: 0.01,
            normal_power: 128.0,
            _pad1: 0.0,
        }
    }
}

/// One invocation per pixel and signal plane: writes the estimate to `out` and folds it into the
/// pixel's tile word in `tiles` (zeroed by the host before; [`classify::tile_key`]).
pub fn variance(id: UVec3, p: &VarianceParams, io: VarianceIo<'_>) {
    let VarianceIo {
        payload,
        depth,
        normal_roughness,
        view,
        out,
        tiles,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let i = plane_index(id, p.width, p.height);
    let pix = pixel_index(id.x, id.y, p.width);
    let f = estimate(id, p, payload, depth, normal_roughness, &view[0]).pack();
    out[i] = f;
    if surface::has_surface(depth[pix]) {
        let tile = classify::tile_index(id.x, id.y, p.width);
        atomic::max(&mut tiles[tile], classify::tile_key(f.unpack().variance));
    }
}

/// The `(value, variance)` of pixel and plane `id` (module rule).
fn estimate(
    id: UVec3,
    p: &VarianceParams,
    payload: &[PackedPayload],
    depth: &[f32],
    normal_roughness: &[u32],
    view: &View,
) -> Filtered {
    let i = plane_index(id, p.width, p.height);
    let h = payload[i].unpack();
    let per_estimate = 1.0 / math::max(h.count, 1.0);
    let temporal = Filtered {
        value: h.m1,
        variance: h.variance() * per_estimate,
    };
    let pix = pixel_index(id.x, id.y, p.width);
    let cd = depth[pix];
    if h.count >= p.spatial_until || !surface::has_surface(cd) {
        return temporal;
    }
    let n = packing::unpack_normal(normal_roughness[pix]);
    let rays = PixelRays::new(&view.camera, p.width, p.height);
    let plane = TangentPlane::new(&rays, n, id.x, id.y, cd);
    let r = p.radius as i32;
    let (mut s1, mut s2, mut sw) = (0.0f32, 0.0f32, 0.0f32);
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let qx = id.x as i32 + dx;
            let qy = id.y as i32 + dy;
            if qx >= 0 && qy >= 0 && qx < p.width as i32 && qy < p.height as i32 {
                let (qx, qy) = (qx as u32, qy as u32);
                let q = payload[plane_index(UVec3::new(qx, qy, id.z), p.width, p.height)].unpack();
                let t = pixel_index(qx, qy, p.width);
                let qd = depth[t];
                if q.count > 0.0 && surface::has_surface(qd) {
                    let offset = math::sqrt((dx * dx + dy * dy) as f32);
                    let m = packing::unpack_normal(normal_roughness[t]);
                    let scale = math::max(p.plane_scale * cd * offset, 1e-12);
                    let w = surface::normal_weight(n, m, p.normal_power)
                        * math::exp(-plane.distance(qx, qy, qd) / scale);
                    // Each neighbour counts by the rays it holds: a 1-ray pixel is one sample.
                    let w = w * q.count;
                    s1 += w * q.m1;
                    s2 += w * q.m2;
                    sw += w;
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    if sw <= 0.0 {
        return temporal;
    }
    let (m1s, m2s) = (s1 / sw, s2 / sw);
    let spatial_var = math::max(m2s - m1s * m1s, 0.0);
    let t = math::saturate(h.count / p.spatial_until);
    Filtered {
        value: math::lerp(m1s, h.m1, t),
        variance: math::lerp(spatial_var, h.variance(), t) * per_estimate,
    }
}
