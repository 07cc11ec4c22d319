//! Temporal reprojection, its own pass before raygen, so the ray budget can be decided from what
//! history survived.
//!
//! Seed: vrrt-call-of-duty-2026, "Supersampling" (`TemporalReprojection`, `GetRejectionWeights`)
//! and ALGORITHMS.md "Reprojection with per-texel rejection". Each texel of the 2×2 bilinear
//! footprint is tested on its own (normal, plane distance, non-empty history; depth and normals
//! are never interpolated); the payload is the bilinear blend of the valid texels only, and never
//! weighted by history length (that makes the signal swim). The rng index is point-sampled from
//! the valid texel with the largest bilinear weight.
//!
//! Reprojection is also where VRRT decides how many rays each pixel asks for (seed: "Temporal
//! reprojection pass is where most of the magic happens"): pixels with less history than
//! `supersample_target` ask for enough rays to refill it (up to 16), pixels with full history ask
//! for a fraction of a ray picked from their variance (4 thresholds, seed "Advanced
//! undersampling"), sky and VRS-masked pixels ask for none. The request is a bucket index
//! (`buckets::rate_to_bucket`), one per plane group (`plane_groups`: each signal of a
//! multi-signal frame asks from its own planes' history, so a refilling shadow does not make the
//! converged AO of the same pixel trace too).
//!
//! With temporal gradients on (`gradient_stratum > 0`, see `kernels::gradient`), each plane's
//! reconstructed `λ` at the pixel's cell shortens the reprojected history to `count · (1 − λ)`
//! (A-SVGF: history `N·(1 − λ)`), and above `gradient_threshold` drops it like a disocclusion, so
//! VRRT asks for a refill and supersamples where the signal changed — detection instead of
//! variance clamping.

use super::buckets::rate_to_bucket;
use super::ReprojectIo;
use super::{pixel_index, plane_index};
use crate::camera::Camera;
use crate::math;
use crate::payload::Payload;
use crate::surface::{self, Surface};
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Flag: no texel of the footprint was valid — history is lost (disocclusion, camera cut).
pub const FLAG_DISOCCLUDED: u32 = 1;
/// Flag: the pixel hit no geometry.
pub const FLAG_SKY: u32 = 2;

/// `parallax_plane` when no plane reprojects along the reflection parallax.
pub const NO_PLANE: u32 = u32::MAX;
/// `importance_group` when no group's requests are scaled.
pub const NO_GROUP: u32 = u32::MAX;

/// Push constants of [`reproject`].
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Pod, Zeroable)]
pub struct ReprojectParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal planes (1..=4).
    pub planes: u32,
    /// Nonzero on the first frame and on camera cuts: every pixel starts empty.
    pub reset: u32,
    /// A texel is valid when `dot(n, n_prev)` is at least this (cosine).
    pub normal_threshold: f32,
    /// A texel is valid when its distance from the current point's previous tangent plane is at
    /// most this fraction of its view depth.
    pub plane_threshold: f32,
    /// Footprint weight sum below which the pixel counts as disoccluded.
    pub disocclusion_threshold: f32,
    /// Starting rng index of pixels whose history was lost (the frame index).
    pub frame_index: u32,
    /// Supersampling: pixels with less history (rays) than this ask for the difference, up to 16
    /// rays. 0 turns VRRT requests off: every geometry pixel asks for `base_rate`.
    pub supersample_target: f32,
    /// History length from which a pixel counts as converged and may undersample.
    pub full_history: f32,
    /// Rate of pixels that are neither refilling nor converged, and of every pixel without VRRT.
    pub base_rate: f32,
    /// Nonzero: `mask[pixel] == 0` means the pixel needs no ray (a VRS-style mask).
    pub use_mask: u32,
    /// Variance thresholds of the undersampling buckets, increasing; a converged pixel whose
    /// (largest-plane) temporal variance is below `variance_threshold[i]` asks for
    /// `variance_rate[i]`.
    pub variance_threshold: [f32; 4],
    /// Ray rates of the undersampling buckets.
    pub variance_rate: [f32; 4],
    /// Temporal-gradient stratum size in pixels; 0 = no gradient this frame (`gradient` unread).
    pub gradient_stratum: u32,
    /// Gradient cells per row.
    pub gradient_width: u32,
    /// Gradient cell rows.
    pub gradient_height: u32,
    /// `λ` above which history is dropped like a disocclusion.
    pub gradient_threshold: f32,
    /// Gain on the reconstructed `λ` before use (`min(1, scale · λ)`).
    pub gradient_scale: f32,
    /// On a frame where nothing moved: history length from which a pixel whose estimate is
    /// quiet (`variance / count < still_variance`) asks only for the floor, `variance_rate[0]`: its
    /// history stays valid and further rays barely change it. Pixels with less history ask for
    /// the difference (up to 16 rays; the balancer fits that to the budget), so history completes
    /// as fast as the budget allows. 0 = the frame is not still (or the still rule is off).
    pub still_history: f32,
    /// Variance of the estimate below which a full-history pixel of a still frame drops to the
    /// floor.
    pub still_variance: f32,
    /// History length clamp of this frame (rays): reprojected history is cut to it. Longer than
    /// `temporal.max_history` only on a still frame with the still rule on (history kept valid
    /// longer, `still_history`); the first frame after one cuts it back.
    pub max_history: f32,
    /// Scale the requests of this plane group by the `importance` of the pixel's tile
    /// (`reflect::TILE` pixels square, `reflect::tile_grid`), e.g. the reflection tile
    /// classification's; [`NO_GROUP`] for none.
    pub importance_group: u32,
    /// Plane reprojected from the `parallax` positions instead of the surface motion (the
    /// reflections); [`NO_PLANE`] for none.
    pub parallax_plane: u32,
    /// Which group each plane belongs to (`super::plane_group`): one request per group and pixel.
    pub plane_groups: u32,
}

impl Default for ReprojectParams {
    fn default() -> Self {
        ReprojectParams {
            width: 0,
            height: 0,
            planes: 1,
            reset: 0,
            normal_threshold: 0.9,
            plane_threshold: 0.02,
            disocclusion_threshold: 1e-3,
            frame_index: 0,
            supersample_target: 0.0,
            full_history: 64.0,
            base_rate: 1.0,
            use_mask: 0,
            variance_threshold: [1e-4, 1e-3, 1e-2, 0.0],
            variance_rate: [0.125, 0.25, 0.5, 1.0],
            gradient_stratum: 0,
            gradient_width: 0,
            gradient_height: 0,
            gradient_threshold: 0.5,
            gradient_scale: 1.0,
            still_history: 0.0,
            still_variance: 0.0,
            max_history: 64.0,
            importance_group: NO_GROUP,
            parallax_plane: NO_PLANE,
            plane_groups: 0,
        }
    }
}

/// Whether previous-frame texel `t` shows the same surface as current texel `c`.
#[inline]
pub fn same_surface(c: &Surface, t: &Surface, p: &ReprojectParams) -> bool {
    if !t.is_valid() {
        return false;
    }
    let n_ok = c.normal().dot(t.normal()) >= p.normal_threshold;
    let dist = math::abs(t.normal().dot(c.prev_position() - t.position()));
    n_ok && dist <= p.plane_threshold * math::max(t.depth, 1e-6)
}

/// Ray rate a pixel asks for, from its shortest history and largest variance over the planes.
#[inline]
pub fn requested_rate(min_count: f32, max_variance: f32, p: &ReprojectParams) -> f32 {
    if p.supersample_target <= 0.0 {
        return p.base_rate;
    }
    if min_count < p.supersample_target {
        return math::clamp(
            math::floor(p.supersample_target - min_count + 0.5),
            1.0,
            16.0,
        );
    }
    if p.still_history > 0.0 {
        if min_count < p.still_history {
            // Still frame: history stays valid, so it is completed first, at whatever the budget
            // grants (the refill rule with `still_history` as the target).
            return math::clamp(math::floor(p.still_history - min_count + 0.5), 1.0, 16.0);
        }
        if max_variance < p.still_variance * min_count {
            return p.variance_rate[0];
        }
    }
    if min_count >= p.full_history {
        let mut i = 0;
        while i < 4 {
            if max_variance < p.variance_threshold[i] {
                return p.variance_rate[i];
            }
            i += 1;
        }
    }
    p.base_rate
}

/// The 2×2 bilinear footprint of previous-frame position `(x, y)` in pixels: texel indices,
/// bilinear weights with every texel that fails [`same_surface`] (or lies off-screen) set to 0,
/// and whether any survived.
#[inline]
#[allow(clippy::too_many_arguments)] // The SPIR-V ABI passes slices one by one.
fn footprint(
    c: &Surface,
    x: f32,
    y: f32,
    geometry_ok: bool,
    prev_camera: &Camera,
    prev_depth: &[f32],
    prev_normal_roughness: &[u32],
    p: &ReprojectParams,
) -> ([usize; 4], [f32; 4], bool) {
    // Texel centres are at integer pixel coordinates.
    let x0f = math::floor(x);
    let y0f = math::floor(y);
    let (ax, ay) = (x - x0f, y - y0f);
    let ok = geometry_ok && math::is_finite(ax) && math::is_finite(ay);
    let mut texel = [0usize; 4];
    let mut bilinear = [
        (1.0 - ax) * (1.0 - ay),
        ax * (1.0 - ay),
        (1.0 - ax) * ay,
        ax * ay,
    ];
    let mut any = false;
    let mut k = 0;
    while k < 4 {
        let tx = x0f + (k & 1) as f32;
        let ty = y0f + (k >> 1) as f32;
        let inside = tx >= 0.0 && ty >= 0.0 && tx < p.width as f32 && ty < p.height as f32;
        if ok && inside {
            let (ux, uy) = (tx as u32, ty as u32);
            texel[k] = pixel_index(ux, uy, p.width);
            let t = surface::load(
                prev_camera,
                ux,
                uy,
                p.width,
                p.height,
                prev_depth,
                prev_normal_roughness,
            );
            if same_surface(c, &t, p) {
                any = true;
            } else {
                bilinear[k] = 0.0;
            }
        } else {
            bilinear[k] = 0.0;
        }
        k += 1;
    }
    (texel, bilinear, any)
}

/// One invocation per pixel; loops over the signal planes so the geometric tests run once.
/// Writes the reprojected history of every plane to `out`, the pixel's flags to `flags` and its
/// ray request (a bucket) to `requests`.
pub fn reproject(id: UVec3, p: &ReprojectParams, io: ReprojectIo<'_>) {
    let ReprojectIo {
        depth,
        normal_roughness,
        motion,
        prev_depth,
        prev_normal_roughness,
        view,
        history,
        mask,
        gradient,
        importance,
        parallax,
        out,
        requests,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let pix = pixel_index(id.x, id.y, p.width);
    let v = view[0];
    let c = Surface::current(
        &v,
        id.x,
        id.y,
        p.width,
        p.height,
        depth[pix],
        normal_roughness[pix],
        motion[pix],
    );
    let empty = Payload {
        m1: 0.0,
        m2: 0.0,
        count: 0.0,
        rng_index: p.frame_index,
    };

    let geometry_ok = c.is_valid() && p.reset == 0;
    let (pd, pn) = (prev_depth, prev_normal_roughness);
    let cam = v.prev_camera;
    let (texel, bilinear, any) = footprint(&c, c.prev_x, c.prev_y, geometry_ok, &cam, pd, pn, p);
    // Reflections move with the reflected image, not the surface (`reflect::reflect_motion`).
    let (ptexel, pbilinear, _) = if p.parallax_plane < p.planes {
        let [x, y] = parallax[pix];
        footprint(&c, x, y, geometry_ok, &cam, pd, pn, p)
    } else {
        (texel, bilinear, any)
    };
    let wanted = c.is_valid() && (p.use_mask == 0 || mask[pix] != 0);
    let pixels = (p.width * p.height) as usize;
    // Per group, reset when the group's last plane is written.
    let mut lost = !any;
    let mut min_count = f32::MAX;
    let mut max_variance = 0.0f32;
    let mut z = 0;
    while z < p.planes {
        let i = plane_index(UVec3::new(id.x, id.y, z), p.width, p.height);
        let mut acc = Payload::default();
        let mut sum_w = 0.0;
        let mut best_w = 0.0;
        let mut rng_index = p.frame_index;
        let (texel, bilinear) = if z == p.parallax_plane {
            (ptexel, pbilinear)
        } else {
            (texel, bilinear)
        };
        let mut k = 0;
        while k < 4 {
            if bilinear[k] > 0.0 {
                let h = history[z as usize * (p.width * p.height) as usize + texel[k]].unpack();
                // Empty texels (undersampled, never traced) are rejected one by one.
                let w = if h.count >= 1.0 { bilinear[k] } else { 0.0 };
                if w > 0.0 {
                    acc.m1 += w * h.m1;
                    acc.m2 += w * h.m2;
                    acc.count += w * h.count;
                    sum_w += w;
                    if w > best_w {
                        best_w = w;
                        rng_index = h.rng_index;
                    }
                }
            }
            k += 1;
        }
        let reprojected = if sum_w > p.disocclusion_threshold {
            // A history longer than this frame allows (kept on still frames) is cut back.
            let mut count = math::min(acc.count / sum_w, p.max_history);
            // Plain division after the check: the same instructions on every target.
            #[allow(clippy::manual_checked_ops)]
            if p.gradient_stratum > 0 {
                let lambda = gradient[super::gradient::cell_index(
                    id.x / p.gradient_stratum,
                    id.y / p.gradient_stratum,
                    z,
                    p.gradient_width,
                    p.gradient_height,
                )]
                .lambda();
                let lambda = math::min(1.0, lambda * p.gradient_scale);
                if lambda > p.gradient_threshold {
                    // The signal changed under the history: a disocclusion in all but geometry.
                    lost = true;
                    count = 0.0;
                } else {
                    count *= 1.0 - lambda;
                }
            }
            Payload {
                m1: acc.m1 / sum_w,
                m2: acc.m2 / sum_w,
                count,
                rng_index,
            }
        } else {
            lost = true;
            empty
        };
        min_count = math::min(min_count, reprojected.count);
        max_variance = math::max(max_variance, reprojected.variance());
        out[i] = reprojected.pack();
        let group = super::plane_group(p.plane_groups, z);
        z += 1;
        if z == p.planes || super::plane_group(p.plane_groups, z) != group {
            let bucket = if wanted {
                let scale = if group == p.importance_group {
                    importance[super::reflect::tile_index(id.x, id.y, p.width)]
                } else {
                    1.0
                };
                rate_to_bucket(requested_rate(min_count, max_variance, p) * scale)
            } else {
                super::buckets::NO_RAYS
            };
            let flags = if !c.is_valid() {
                FLAG_SKY
            } else if lost {
                FLAG_DISOCCLUDED
            } else {
                0
            };
            requests[group as usize * pixels + pix] = request_word(bucket, flags);
            lost = !any;
            min_count = f32::MAX;
            max_variance = 0.0;
        }
    }
}

/// The word reprojection writes per pixel and plane group: the requested bucket in the low 16
/// bits ([`buckets::NO_RAYS`](super::buckets::NO_RAYS) becomes `0xffff`, still no bucket) and
/// the group's `FLAG_*` in the high 16 bits, so one buffer carries both.
#[inline]
pub fn request_word(bucket: u32, flags: u32) -> u32 {
    let bucket = if bucket < 0xffff { bucket } else { 0xffff };
    bucket | (flags << 16)
}

/// The requested bucket of a [`request_word`] (`0xffff`: none).
#[inline]
pub fn bucket_of(word: u32) -> u32 {
    word & 0xffff
}

/// The `FLAG_*` bits of a [`request_word`].
#[inline]
pub fn flags_of(word: u32) -> u32 {
    word >> 16
}
