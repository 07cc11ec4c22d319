//! One à-trous wavelet iteration of SVGF with edge-stopping weights.
//!
//! Seed: q2vkpt-path-tracing-denoising-2019 (SVGF) and vrrt-call-of-duty-2026, "Denoising basics –
//! variance-guided filtering" (`Weight_Variance`). A 5×5 B3-spline footprint dilated by `step`;
//! each tap is weighted by normal similarity, distance from the centre's tangent plane, and the
//! luminance difference relative to the centre's (3×3 pre-blurred) standard deviation. Variance is
//! filtered along with squared weights, so later iterations blur less where the signal is known.
//!
//! Tiles that [`super::classify`] found need fewer iterations than this one pass the input through
//! (a copy, uniform per workgroup): converged regions skip the wide late iterations.

use super::classify::tile_index;
use super::AtrousIo;
use super::{pixel_index, plane_index};
use crate::camera::PixelRays;
use crate::math;
use crate::packing;
use crate::payload::{Filtered, PackedFiltered};
use crate::surface::{self, TangentPlane};
use bytemuck::{Pod, Zeroable};
use glam::{IVec2, UVec3};

/// Push constants of [`atrous`].
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Pod, Zeroable)]
pub struct AtrousParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Tap spacing in pixels: 1, 2, 4, 8, 16 for the five SVGF iterations.
    pub step: u32,
    /// This iteration's number (0-based): tiles needing no more than this many pass through.
    pub iteration: u32,
    /// Luminance sharpness σ_l (SVGF: 4). Larger blurs more.
    pub sigma_luminance: f32,
    /// Plane-distance tolerance per pixel of offset and unit of view depth: σ_p times the angle one
    /// pixel subtends (host computes it from the field of view and the height).
    pub plane_scale: f32,
    /// Exponent of the normal weight (SVGF: 128).
    pub normal_power: f32,
    /// Padding.
    pub _pad1: f32,
}

impl Default for AtrousParams {
    fn default() -> Self {
        AtrousParams {
            width: 0,
            height: 0,
            step: 1,
            iteration: 0,
            sigma_luminance: 4.0,
            plane_scale: 0.01,
            normal_power: 128.0,
            _pad1: 0.0,
        }
    }
}

const B3: [f32; 3] = [3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];

/// B3-spline weight of tap `(±i, ±j)` relative to the centre's, `[j][i]`: constants, so the taps
/// do not recompute them (the same products, in the same order, as a per-tap evaluation).
const TAP_WEIGHT: [[f32; 3]; 3] = {
    let mut t = [[0.0; 3]; 3];
    let mut j = 0;
    while j < 3 {
        let mut i = 0;
        while i < 3 {
            t[j][i] = B3[i] * B3[j] * (1.0 / (B3[0] * B3[0]));
            i += 1;
        }
        j += 1;
    }
    t
};

/// `sqrt(i² + j²)` of tap `(±i, ±j)`, `[j][i]`: the correctly rounded roots `math::sqrt` gives,
/// without a square root per tap.
const TAP_DISTANCE: [[f32; 3]; 3] = [
    [0.0, 1.0, 2.0],
    [1.0, core::f32::consts::SQRT_2, SQRT_5],
    [2.0, SQRT_5, 2.0 * core::f32::consts::SQRT_2],
];
/// √5 rounded to nearest f32 (the test below checks it against `math::sqrt`).
const SQRT_5: f32 = 2.236_068;
const GAUSS3: [f32; 2] = [1.0 / 2.0, 1.0 / 4.0];

#[inline]
fn clamp_coord(v: i32, n: u32) -> u32 {
    if v < 0 {
        0
    } else if v >= n as i32 {
        n - 1
    } else {
        v as u32
    }
}

/// Variance at `(x, y)` blurred by a 3×3 Gaussian (edges clamped): a less noisy σ for the
/// luminance weight.
fn blurred_variance(input: &[PackedFiltered], x: u32, y: u32, plane: u32, p: &AtrousParams) -> f32 {
    let mut sum = 0.0;
    let mut dy = -1;
    while dy <= 1 {
        let mut dx = -1;
        while dx <= 1 {
            let qx = clamp_coord(x as i32 + dx, p.width);
            let qy = clamp_coord(y as i32 + dy, p.height);
            let w = GAUSS3[dx.unsigned_abs() as usize] * GAUSS3[dy.unsigned_abs() as usize];
            let q = input[plane_index(UVec3::new(qx, qy, plane), p.width, p.height)];
            sum += w * q.unpack().variance;
            dx += 1;
        }
        dy += 1;
    }
    sum
}

/// One invocation per pixel and signal plane.
pub fn atrous(id: UVec3, p: &AtrousParams, io: AtrousIo<'_>) {
    let AtrousIo {
        input,
        depth,
        normal_roughness,
        view,
        tiles,
        out,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let i = plane_index(id, p.width, p.height);
    let packed = input[i];
    let center = packed.unpack();
    let pix = pixel_index(id.x, id.y, p.width);
    let cd = depth[pix];
    if !surface::has_surface(cd) || p.iteration >= tiles[tile_index(id.x, id.y, p.width)] {
        out[i] = packed;
        return;
    }
    let n = packing::unpack_normal(normal_roughness[pix]);
    let rays = PixelRays::new(&view[0].camera, p.width, p.height);
    let plane = TangentPlane::new(&rays, n, id.x, id.y, cd);
    let sigma = math::sqrt(math::max(blurred_variance(input, id.x, id.y, id.z, p), 0.0));
    let lum_scale = p.sigma_luminance * sigma + 1e-6;

    let mut sum = center.value;
    let mut sum_var = center.variance;
    let mut sum_w = 1.0f32;
    let step = p.step as i32;
    let mut ty = -2;
    while ty <= 2 {
        let mut tx = -2;
        while tx <= 2 {
            let q = IVec2::new(id.x as i32 + tx * step, id.y as i32 + ty * step);
            let inside = q.x >= 0 && q.y >= 0 && q.x < p.width as i32 && q.y < p.height as i32;
            if (tx != 0 || ty != 0) && inside {
                let (qx, qy) = (q.x as u32, q.y as u32);
                let q = pixel_index(qx, qy, p.width);
                let qd = depth[q];
                if surface::has_surface(qd) {
                    let tap =
                        input[plane_index(UVec3::new(qx, qy, id.z), p.width, p.height)].unpack();
                    let (ax, ay) = (tx.unsigned_abs() as usize, ty.unsigned_abs() as usize);
                    let offset_len = TAP_DISTANCE[ay][ax] * p.step as f32;
                    let m = packing::unpack_normal(normal_roughness[q]);
                    let w_n = surface::normal_weight(n, m, p.normal_power);
                    // Plane and luminance weights are both exponentials: one exp of the summed
                    // exponents (the exp was most of the filter's time on the CPU).
                    let scale = math::max(p.plane_scale * cd * offset_len, 1e-12);
                    let e = plane.distance(qx, qy, qd) / scale
                        + math::abs(center.value - tap.value) / lum_scale;
                    let w = TAP_WEIGHT[ay][ax] * w_n * math::exp(-e);
                    sum += w * tap.value;
                    sum_var += w * w * tap.variance;
                    sum_w += w;
                }
            }
            tx += 1;
        }
        ty += 1;
    }
    out[i] = Filtered {
        value: sum / sum_w,
        variance: sum_var / (sum_w * sum_w),
    }
    .pack();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tap_tables_match_the_per_tap_formulas() {
        for j in 0..3 {
            for i in 0..3 {
                let w = B3[i] * B3[j] * (1.0 / (B3[0] * B3[0]));
                assert_eq!(TAP_WEIGHT[j][i].to_bits(), w.to_bits());
                let d = math::sqrt((i * i + j * j) as f32);
                assert_eq!(TAP_DISTANCE[j][i].to_bits(), d.to_bits());
            }
        }
    }
}
