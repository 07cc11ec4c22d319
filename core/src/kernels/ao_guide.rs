//! The AO guide: a noise-free guess of each pixel's AO from the G-buffer alone (screen-space
//! AO), by which the AO planes' spatial filter divides before it blurs and multiplies after.
//!
//! A pixel without history leans on its neighbours, and where AO changes within the filter's
//! footprint — a crevice, a contact, a silhouette — their mean is not the pixel's: the filter
//! fills the crevice in. Filtering `AO / g` instead, where `g` follows the geometry's own
//! darkening, leaves a signal that is flat across those edges, and `g · filtered` puts the
//! detail back (a ratio estimator, as SVGF demodulates albedo and Heitz et al. 2018 denoise a
//! shadow's ratio to its unshadowed shading). Where `g` is wrong the ratio carries the error
//! and the filter blurs it as it blurs AO itself.
//!
//! The guide is built in two passes:
//! - [`march`]: per pixel, `directions` cosine-distributed directions around the normal, each
//!   marched in `steps` steps out to the AO radius against the depth buffer; a step is blocked
//!   when it lies behind the visible surface by less than [`THICKNESS`] of the radius. `raw`
//!   is the unblocked fraction. The directions are rotated per pixel by a 4×4 ordered-dither
//!   pattern, so a 4×4 block holds sixteen sets; one set for every pixel bands the guide, and
//!   the bands came through the ratio as structure the filter kept.
//! - [`blur`]: the mean of `raw` over each pixel's 4×4 block on its own surface (normals within
//!   [`BLUR_COSINE`], depths within [`BLUR_DEPTH`]), floored at [`FLOOR`], so that a crevice
//!   no step escapes does not divide by 0. Stored as binary16, two horizontal neighbours a word
//!   ([`guide_at`]): 2 bytes a pixel, which keep AO's memory within its 48.
//!
//! [`demodulate`] writes the divided history for the variance pass to read (the history itself
//! stays as it is: next frame's guide differs), and [`remodulate`] / [`remodulate_into`]
//! multiply the filter's last output back. Measured in `docs/algorithms/fresh-pixels.md`.

use super::plane_index;
use super::{AoDemodulateIo, AoGuideBlurIo, AoGuideMarchIo, AoRemodulateIntoIo, AoRemodulateIo};
use crate::camera::PixelRays;
use crate::math;
use crate::packing;
use crate::payload::{PackedFiltered, PackedPayload};
use crate::sampling;
use crate::surface;
use crate::textures::Store;
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3, Vec4};

/// A step is blocked when it lies behind the depth buffer by less than this fraction of the AO
/// radius: a surface seen in front is assumed this thick (deeper, the step passes behind it).
pub const THICKNESS: f32 = 0.6;
/// The guide never goes below this, so that the ratio stays bounded (`1 / FLOOR`).
pub const FLOOR: f32 = 0.1;
/// Neighbours in the blur lie on the pixel's surface: normals' cosine above this...
pub const BLUR_COSINE: f32 = 0.9;
/// ...and view depths within this fraction of the pixel's.
pub const BLUR_DEPTH: f32 = 0.02;
/// Where a march starts, above the surface, as a fraction of the view depth (so that a step
/// does not find the pixel's own surface behind it).
const LIFT: f32 = 1.0e-3;
/// A step is behind the depth buffer only by more than this fraction of its depth, and
/// [`ABSOLUTE_BIAS`]: the depth buffer's own sampling error on a slanted surface.
const RELATIVE_BIAS: f32 = 2.0e-3;
/// See [`RELATIVE_BIAS`].
const ABSOLUTE_BIAS: f32 = 1.0e-3;
/// The directions' second coordinate steps by the golden ratio's fraction...
const GOLDEN: f32 = 0.618_034;
/// ...and the per-pixel rotation shifts it by the plastic number's (an unrelated irrational).
const PLASTIC: f32 = 0.754_877_7;

/// Push constants of [`march`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MarchParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Directions per pixel (`filter.ao_guide_directions`, > 0).
    pub directions: u32,
    /// Steps per direction (`filter.ao_guide_steps`, > 0).
    pub steps: u32,
    /// The AO rays' length (world units).
    pub radius: f32,
}

/// Push constants of [`blur`], [`demodulate`], [`remodulate`] and [`remodulate_into`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GuideParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Planes (bit per plane) the guide divides (`Layout::ao_planes`); the others pass as they are.
    pub ao_planes: u32,
}

/// The 4×4 ordered-dither rank of pixel `(x, y)`, in `[0, 1)`: a 2×2 Bayer matrix of 2×2 ones.
#[inline]
pub fn dither(x: u32, y: u32) -> f32 {
    let bayer2 = |x: u32, y: u32| ((x ^ y) & 1) * 2 + (y & 1);
    let rank = 4 * bayer2(x & 1, y & 1) + bayer2((x >> 1) & 1, (y >> 1) & 1);
    rank as f32 / 16.0
}

/// Raw guide, one invocation per pixel: the fraction of the pixel's directions no step of
/// which is blocked (module docs); 1 where there is no surface.
pub fn march(id: UVec3, p: &MarchParams, io: AoGuideMarchIo<'_>) {
    let AoGuideMarchIo {
        depth,
        normal_roughness,
        view,
        raw,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let pix = (id.y * w + id.x) as usize;
    let d = depth[pix];
    if !surface::has_surface(d) || p.directions == 0 {
        raw[pix] = 1.0;
        return;
    }
    let camera = &view[0].camera;
    let n = packing::unpack_normal(normal_roughness[pix]);
    // Eye-relative start, and the projection as linear functions of it: a point `v` (relative
    // to the eye) is at view depth `v·f`, pixel `x = v·sx / (v·f) + cx`, `y = v·sy / (v·f) + cy`.
    let start = PixelRays::new(camera, w, h).dir(id.x as f32, id.y as f32) * d + n * (LIFT * d);
    let tan_y = camera.tan_half_fov_y;
    let tan_x = tan_y * (w as f32 / h as f32);
    let sx = camera.right() * (0.5 * w as f32 / tan_x);
    let sy = camera.up() * (-0.5 * h as f32 / tan_y);
    let f = camera.forward();
    let projection = Projection {
        start: Vec3::new(start.dot(sx), start.dot(sy), start.dot(f)),
        sx,
        sy,
        f,
        centre: (0.5 * w as f32 - 0.5, 0.5 * h as f32 - 0.5),
    };
    let rotation = dither(id.x, id.y);
    let (t, b) = sampling::orthonormal_basis(n);
    let mut open = 0u32;
    let mut k = 0;
    while k < p.directions {
        let u1 = (k as f32 + rotation) / p.directions as f32;
        let (s, c) = math::sin_cos_turns(fract(k as f32 * GOLDEN + rotation * PLASTIC));
        let r = math::sqrt(u1);
        let dir = t * (r * c) + b * (r * s) + n * math::sqrt(math::max(1.0 - u1, 0.0));
        if !blocked(&projection, dir, p, depth) {
            open += 1;
        }
        k += 1;
    }
    raw[pix] = open as f32 / p.directions as f32;
}

/// The fractional part of a non-negative `x`.
#[inline]
fn fract(x: f32) -> f32 {
    x - math::floor(x)
}

/// A march's start in projected form (`(v·sx, v·sy, v·f)`) and the projection's rows.
struct Projection {
    start: Vec3,
    sx: Vec3,
    sy: Vec3,
    f: Vec3,
    centre: (f32, f32),
}

/// Whether a step of the march from the projection's start along `dir` is blocked (module
/// docs). Steps fall at `radius · ((s + ½) / steps)^1.5`, denser near the surface, where a
/// crevice's walls are.
#[inline]
fn blocked(q: &Projection, dir: Vec3, p: &MarchParams, depth: &[f32]) -> bool {
    let (w, h) = (p.width, p.height);
    let step = Vec3::new(dir.dot(q.sx), dir.dot(q.sy), dir.dot(q.f));
    let thickness = THICKNESS * p.radius;
    let mut s = 0;
    while s < p.steps {
        let u = (s as f32 + 0.5) / p.steps as f32;
        let v = q.start + step * (p.radius * u * math::sqrt(u));
        if v.z > 0.0 {
            let inv = 1.0 / v.z;
            let (x, y) = (v.x * inv + q.centre.0, v.y * inv + q.centre.1);
            if x > -0.5 && x < w as f32 - 0.5 && y > -0.5 && y < h as f32 - 0.5 {
                let (ix, iy) = (math::floor(x + 0.5) as u32, math::floor(y + 0.5) as u32);
                let seen = depth[(math::min(iy as f32, (h - 1) as f32) as u32 * w
                    + math::min(ix as f32, (w - 1) as f32) as u32)
                    as usize];
                if surface::has_surface(seen)
                    && v.z > seen * (1.0 + RELATIVE_BIAS) + ABSOLUTE_BIAS
                    && v.z - seen < thickness
                {
                    return true;
                }
            }
        }
        s += 1;
    }
    false
}

/// Words of the guide per row: two pixels a word.
#[inline]
pub fn guide_row_words(width: u32) -> u32 {
    width.div_ceil(2)
}

/// The guide at pixel `(x, y)` of a `width`-wide image ([`blur`]'s packing).
#[inline]
pub fn guide_at(guide: &[u32], x: u32, y: u32, width: u32) -> f32 {
    let (even, odd) = packing::unpack_f16x2(guide[(y * guide_row_words(width) + x / 2) as usize]);
    if x & 1 == 0 {
        even
    } else {
        odd
    }
}

/// The guide, one invocation per two horizontal neighbours (`x = 2·id.x` and `2·id.x + 1`, one
/// word, binary16 each; [`guide_at`]).
pub fn blur(id: UVec3, p: &GuideParams, io: AoGuideBlurIo<'_>) {
    let AoGuideBlurIo {
        raw,
        depth,
        normal_roughness,
        guide,
    } = io;
    let (w, h) = (p.width, p.height);
    let x = 2 * id.x;
    if x >= w || id.y >= h {
        return;
    }
    let even = blurred(x, id.y, p, (raw, depth, normal_roughness));
    let odd = if x + 1 < w {
        blurred(x + 1, id.y, p, (raw, depth, normal_roughness))
    } else {
        1.0
    };
    guide[(id.y * guide_row_words(w) + id.x) as usize] = packing::pack_f16x2(even, odd);
}

/// `raw`'s mean over the 4×4 block of pixel `(x, y)` (offsets −2..=1) on its own surface, at
/// least [`FLOOR`]; 1 where there is no surface.
#[inline]
fn blurred(
    x: u32,
    y: u32,
    p: &GuideParams,
    (raw, depth, normal_roughness): (&[f32], &[f32], &[u32]),
) -> f32 {
    let (w, h) = (p.width, p.height);
    let pix = (y * w + x) as usize;
    let d = depth[pix];
    if !surface::has_surface(d) {
        return 1.0;
    }
    let n = packing::unpack_normal(normal_roughness[pix]);
    let (mut sum, mut count) = (0.0f32, 0.0f32);
    let mut dy = -2;
    while dy < 2 {
        let mut dx = -2;
        while dx < 2 {
            let (qx, qy) = (x as i32 + dx, y as i32 + dy);
            if qx >= 0 && qy >= 0 && qx < w as i32 && qy < h as i32 {
                let q = (qy as u32 * w + qx as u32) as usize;
                let qd = depth[q];
                let same = n.dot(packing::unpack_normal(normal_roughness[q])) > BLUR_COSINE
                    && math::abs(qd - d) < BLUR_DEPTH * d;
                if surface::has_surface(qd) && same {
                    sum += raw[q];
                    count += 1.0;
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    // The centre always counts, so `count >= 1`.
    math::max(sum / count, FLOOR)
}

/// Whether plane `z` is one the guide divides.
#[inline]
fn guided(p: &GuideParams, z: u32) -> bool {
    (p.ao_planes >> z) & 1 != 0
}

/// The history the variance pass reads, one invocation per pixel and plane: on the guided
/// planes the moments divided by the guide (`m1 / g`, `m2 / g²`), elsewhere as they are.
pub fn demodulate(id: UVec3, p: &GuideParams, io: AoDemodulateIo<'_>) {
    let AoDemodulateIo {
        history,
        guide,
        out,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let i = plane_index(id, w, h);
    let q: PackedPayload = history[i];
    out[i] = if guided(p, id.z) {
        let g = guide_at(guide, id.x, id.y, w);
        let mut u = q.unpack();
        u.m1 /= g;
        u.m2 /= g * g;
        u.pack()
    } else {
        q
    };
}

/// `f` multiplied back by the guide `g`: value by `g`, at most 1 (AO is a fraction of the
/// hemisphere; a neighbour whose guide was too dark can lift the mean of ratios past `1 / g`),
/// variance by `g²`.
#[inline]
fn times(f: PackedFiltered, g: f32) -> PackedFiltered {
    let mut u = f.unpack();
    u.value = math::min(u.value * g, 1.0);
    u.variance *= g * g;
    u.pack()
}

/// The filter's output multiplied back by the guide on the guided planes, in place, one
/// invocation per pixel and plane.
pub fn remodulate(id: UVec3, p: &GuideParams, io: AoRemodulateIo<'_>) {
    let AoRemodulateIo { guide, out } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h || !guided(p, id.z) {
        return;
    }
    let i = plane_index(id, w, h);
    out[i] = times(out[i], guide_at(guide, id.x, id.y, w));
}

/// [`remodulate`] into the engine's texture (R32F, plane `z`'s pixel `(x, y)` at texel
/// `(x, y + z · height)`, as `atrous_engine` writes it): every plane's value, the guided ones
/// multiplied back.
pub fn remodulate_into(id: UVec3, p: &GuideParams, io: AoRemodulateIntoIo<'_>, out: impl Store) {
    let AoRemodulateIntoIo { input, guide } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let i = plane_index(id, w, h);
    let f = if guided(p, id.z) {
        times(input[i], guide_at(guide, id.x, id.y, w))
    } else {
        input[i]
    };
    let value = f.unpack().value;
    out.store(id.x, id.y + id.z * h, w, Vec4::new(value, 0.0, 0.0, 1.0));
}
