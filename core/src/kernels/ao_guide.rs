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
//!   the bands came through the ratio as structure the filter kept. With `refresh` directions
//!   (`filter.ao_guide_refresh`) the fraction is kept across frames: reprojected like history
//!   (the same texel tests), a pixel whose kept fraction holds `directions` directions marches
//!   only `refresh` new ones, turned from frame to frame, and blends them in (at most
//!   [`HISTORY`] × `directions` kept); the others march all `directions`. A fresh guide each
//!   frame from a dither fixed to the screen flickers where the camera moves; a kept one does
//!   not, and the march costs less.
//! - [`blur`]: the mean of `raw` over each pixel's 4×4 block on its own surface (normals within
//!   [`BLUR_COSINE`], depths within [`BLUR_DEPTH`]), floored at [`FLOOR`], so that a crevice
//!   no step escapes does not divide by 0. Stored as binary16, two horizontal neighbours a word
//!   ([`guide_at`]): 2 bytes a pixel (and 8 for the kept raw fractions, this frame's and last).
//!
//! [`demodulate`] writes the divided history for the variance pass to read (the history itself
//! stays as it is: next frame's guide differs), and [`remodulate`] / [`remodulate_into`]
//! multiply the filter's last output back. Measured in `docs/algorithms/fresh-pixels.md`.

use super::plane_index;
use super::reproject::{self, ReprojectParams};
use super::{AoDemodulateIo, AoGuideBlurIo, AoGuideMarchIo, AoRemodulateIntoIo, AoRemodulateIo};
use crate::camera::{Camera, PixelRays, View};
use crate::lanes::{self, Lanes};
use crate::math;
use crate::packing;
use crate::payload::{pack_filtered, unpack_filtered, PackedFiltered, PackedPayload, PayloadLanes};
use crate::sampling;
use crate::surface::{self, Moved};
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
    /// Directions a pixel with history marches (`filter.ao_guide_refresh`, `1..=directions`);
    /// 0: no pixel keeps history, every one marches `directions` with the dither alone.
    pub refresh: u32,
    /// Nonzero on the first frame and on camera cuts: no pixel has history.
    pub reset: u32,
    /// The stratum of this frame's first direction (`directions` strata, `refresh` a frame).
    pub first: u32,
    /// A turn (in `[0, 1)`) added this frame to the rotation of the pixels that march
    /// `refresh` directions, so that kept fractions gather new ones.
    pub turn: f32,
    /// Reprojection's texel tests (`temporal.normal_threshold`).
    pub normal_threshold: f32,
    /// ...and `temporal.plane_threshold`.
    pub plane_threshold: f32,
}

/// A pixel's kept fraction holds at most this many times `directions` directions: the blend of
/// a frame's `refresh` new ones then weighs `refresh / (HISTORY · directions)`.
pub const HISTORY: f32 = 4.0;

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

/// Raw guide, one call per `N` consecutive pixels of a row ([`crate::lanes`]): the fraction of
/// each pixel's directions no step of which is blocked, kept across frames with `refresh`
/// (module docs), as binary16 `(fraction, directions it holds)` in one word; `(1, 0)` where
/// there is no surface.
#[inline(always)]
pub fn march<const N: usize>(id: UVec3, p: &MarchParams, io: AoGuideMarchIo<'_>) {
    let AoGuideMarchIo {
        depth,
        normal_roughness,
        motion,
        prev_depth,
        prev_normal_roughness,
        view,
        prev_raw,
        raw,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let (row, x0) = (id.y * w, id.x as i32);
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let out = (row + id.x) as usize;
    let d = Lanes::<f32, N>::load_row(depth, row, x0, w);
    let surfaced = d.map(surface::has_surface);
    if !surfaced.any() || p.directions == 0 {
        Lanes::splat(packing::pack_f16x2(1.0, 0.0)).store(raw, out, live);
        return;
    }
    let nr = Lanes::<u32, N>::load_row(normal_roughness, row, x0, w);
    let (kept, held) = if p.refresh > 0 && p.reset == 0 {
        let mv = Lanes::<[u32; 2], N>::load_row(motion, row, x0, w);
        let prev = (prev_depth, prev_normal_roughness, prev_raw);
        kept_fraction(id, p, &view[0], (d, nr, mv), prev)
    } else {
        (Lanes::splat(0.0), Lanes::splat(0.0))
    };
    // A pixel whose kept fraction holds every stratum marches `refresh` more, the others all.
    let all = p.directions as f32;
    let marched = held.map(|n| if n >= all { p.refresh } else { p.directions });
    let open = open_directions(id, p, &view[0], (d, nr), marched, depth);
    let mut word = Lanes::<u32, N>::splat(0);
    lanes::each_lane!(l in N {
        let m = marched.0[l] as f32;
        let fraction = open.0[l] as f32 / m;
        let n = math::min(held.0[l] + m, HISTORY * all);
        let value = kept.0[l] + (fraction - kept.0[l]) * (m / n);
        word.0[l] = if surfaced.0[l] {
            packing::pack_f16x2(value, n)
        } else {
            packing::pack_f16x2(1.0, 0.0)
        };
    });
    word.store(raw, out, live);
}

/// Last frame's fractions reprojected to pixels `(id.x + l, id.y)` (`inputs`: this frame's
/// depth, normal + roughness and motion there): the bilinear blend of the footprint's texels
/// that pass reprojection's tests and hold directions, and the directions they hold, weighted
/// by the footprint as history lengths are (`kernels::reproject`).
#[inline(always)]
fn kept_fraction<const N: usize>(
    id: UVec3,
    p: &MarchParams,
    view: &View,
    (d, nr, mv): (Lanes<f32, N>, Lanes<u32, N>, Lanes<[u32; 2], N>),
    (prev_depth, prev_normal_roughness, prev_raw): (&[f32], &[u32], &[u32]),
) -> (Lanes<f32, N>, Lanes<f32, N>) {
    let (w, h) = (p.width, p.height);
    let xs = Lanes::<u32, N>::from_index(|l| lanes::clamp_column(id.x as i32 + l as i32, w));
    let c = Moved::new(view, xs, id.y, (w, h), d, nr, mv);
    let tests = ReprojectParams {
        width: w,
        height: h,
        normal_threshold: p.normal_threshold,
        plane_threshold: p.plane_threshold,
        ..ReprojectParams::default()
    };
    let (n, prev, cam) = (c.normal, c.prev_position, &view.prev_camera);
    let (pd, pn) = (prev_depth, prev_normal_roughness);
    let f = reproject::footprint(n, prev, c.prev_xy, c.valid, cam, pd, pn, &tests);
    let zero = Lanes::<f32, N>::splat(0.0);
    let (mut value, mut held, mut sum_w) = (zero, zero, zero);
    let mut k = 0;
    while k < 4 {
        let (v, count) = packing::unpack_f16x2_lanes(Lanes::gather(prev_raw, f.texel[k]));
        lanes::each_lane!(l in N {
            // A texel without a surface last frame holds no directions.
            let b = if count.0[l] > 0.0 { f.bilinear[k].0[l] } else { 0.0 };
            value.0[l] += b * v.0[l];
            held.0[l] += b * count.0[l];
            sum_w.0[l] += b;
        });
        k += 1;
    }
    lanes::each_lane!(l in N {
        value.0[l] = if sum_w.0[l] > 0.0 { value.0[l] / sum_w.0[l] } else { 0.0 };
    });
    (value, held)
}

/// How many of each pixel's first `marched[l]` directions this frame no step of which is
/// blocked (`inputs`: depth and normal + roughness of pixels `(id.x + l, id.y)`).
#[inline(always)]
fn open_directions<const N: usize>(
    id: UVec3,
    p: &MarchParams,
    view: &View,
    (d, nr): (Lanes<f32, N>, Lanes<u32, N>),
    marched: Lanes<u32, N>,
    depth: &[f32],
) -> Lanes<u32, N> {
    let (w, h) = (p.width, p.height);
    let q = Projection::new(&view.camera, w, h);
    let rays = PixelRays::new(&view.camera, w, h);
    // Per lane: the normal, its basis, the start in projected form, the rotation.
    let n = nr.map(packing::unpack_normal);
    let mut start = Lanes::<Vec3, N>::splat(Vec3::ZERO);
    let (mut tangent, mut bitangent) = (start, start);
    // Direction `k` of a pixel of rotation `ρ`: `u1 = (k + ρ) / directions` and azimuth
    // `k·GOLDEN + ρ·PLASTIC` turns, the sum's sine and cosine from the two terms' (the first
    // shared by every lane, the second by every direction).
    let zero = Lanes::<f32, N>::splat(0.0);
    let (mut rotation, mut turn_sin, mut turn_cos) = (zero, zero, zero);
    lanes::each_lane!(l in N {
        let x = id.x + l as u32;
        let v = rays.dir(x as f32, id.y as f32) * d.0[l] + n.0[l] * (LIFT * d.0[l]);
        start.0[l] = q.project(v);
        (tangent.0[l], bitangent.0[l]) = sampling::orthonormal_basis(n.0[l]);
        // A pixel marching every direction takes the dither alone: where nothing moves, the
        // same fraction as last frame's.
        let turn = if marched.0[l] < p.directions { p.turn } else { 0.0 };
        rotation.0[l] = fract(dither(x, id.y) + turn);
        (turn_sin.0[l], turn_cos.0[l]) = math::sin_cos_turns(rotation.0[l] * PLASTIC);
    });
    let mut most = 0;
    lanes::each_lane!(l in N {
        most = if marched.0[l] > most { marched.0[l] } else { most };
    });
    let mut open = Lanes::<u32, N>::splat(0);
    let mut j = 0;
    while j < most {
        let k = (p.first + j) % p.directions;
        let (sk, ck) = math::sin_cos_turns(fract(k as f32 * GOLDEN));
        let mut step = Lanes::<Vec3, N>::splat(Vec3::ZERO);
        lanes::each_lane!(l in N {
            let u1 = (k as f32 + rotation.0[l]) / p.directions as f32;
            let (sr, cr) = (turn_sin.0[l], turn_cos.0[l]);
            let (s, c) = (sk * cr + ck * sr, ck * cr - sk * sr);
            let r = math::sqrt(u1);
            let (t, b) = (tangent.0[l], bitangent.0[l]);
            let dir = t * (r * c) + b * (r * s) + n.0[l] * math::sqrt(math::max(1.0 - u1, 0.0));
            step.0[l] = q.project(dir);
        });
        let blocked = blocked(&q, &start, &step, p, depth);
        lanes::each_lane!(l in N {
            if !blocked.0[l] && j < marched.0[l] {
                open.0[l] += 1;
            }
        });
        j += 1;
    }
    open
}

/// The fractional part of a non-negative `x`.
#[inline]
fn fract(x: f32) -> f32 {
    x - math::floor(x)
}

/// The projection as linear functions of a point `v` relative to the eye: it is at view depth
/// `v·f`, pixel `x = v·sx / (v·f) + cx`, `y = v·sy / (v·f) + cy`.
struct Projection {
    sx: Vec3,
    sy: Vec3,
    f: Vec3,
    centre: (f32, f32),
}

impl Projection {
    fn new(camera: &Camera, w: u32, h: u32) -> Self {
        let tan_y = camera.tan_half_fov_y;
        let tan_x = tan_y * (w as f32 / h as f32);
        Projection {
            sx: camera.right() * (0.5 * w as f32 / tan_x),
            sy: camera.up() * (-0.5 * h as f32 / tan_y),
            f: camera.forward(),
            centre: (0.5 * w as f32 - 0.5, 0.5 * h as f32 - 0.5),
        }
    }

    /// `(v·sx, v·sy, v·f)`: linear in `v`, so a march's steps are `start + step · t`.
    #[inline]
    fn project(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.sx), v.dot(self.sy), v.dot(self.f))
    }
}

/// Whether a step of each lane's march from `start` along `step` (both projected) is blocked
/// (module docs). Steps fall at `radius · ((s + ½) / steps)^1.5`, denser near the surface,
/// where a crevice's walls are. Stops early once every lane is blocked (on the GPU, one lane:
/// at its first blocked step).
#[inline(always)]
fn blocked<const N: usize>(
    q: &Projection,
    start: &Lanes<Vec3, N>,
    step: &Lanes<Vec3, N>,
    p: &MarchParams,
    depth: &[f32],
) -> Lanes<bool, N> {
    let (w, h) = (p.width, p.height);
    let thickness = THICKNESS * p.radius;
    let mut hit = Lanes::<bool, N>::splat(false);
    let mut s = 0;
    while s < p.steps {
        let u = (s as f32 + 0.5) / p.steps as f32;
        let t = p.radius * u * math::sqrt(u);
        let mut index = Lanes::<u32, N>::splat(0);
        let mut inside = Lanes::<bool, N>::splat(false);
        let mut z = Lanes::<f32, N>::splat(0.0);
        lanes::each_lane!(l in N {
            let v = start.0[l] + step.0[l] * t;
            let inv = 1.0 / v.z;
            let (x, y) = (v.x * inv + q.centre.0, v.y * inv + q.centre.1);
            let ok = v.z > 0.0 && x > -0.5 && x < w as f32 - 0.5 && y > -0.5 && y < h as f32 - 0.5;
            // `x + 0.5` rounds up to `w` for some `x` just below `w − 0.5` (at widths past a
            // power of two), hence the clamps to the last column and row.
            let (ix, iy) = if ok { (x + 0.5, y + 0.5) } else { (0.0, 0.0) };
            let (ix, iy) = (math::floor_small(ix), math::floor_small(iy));
            let ix = if ix < w { ix } else { w - 1 };
            let iy = if iy < h { iy } else { h - 1 };
            index.0[l] = iy * w + ix;
            inside.0[l] = ok;
            z.0[l] = v.z;
        });
        let seen = Lanes::gather(depth, index);
        lanes::each_lane!(l in N {
            let (z, seen) = (z.0[l], seen.0[l]);
            hit.0[l] |= inside.0[l]
                && surface::has_surface(seen)
                && z > seen * (1.0 + RELATIVE_BIAS) + ABSOLUTE_BIAS
                && z - seen < thickness;
        });
        if hit.all() {
            break;
        }
        s += 1;
    }
    hit
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

/// The guide, one call per `N` consecutive words of a row ([`crate::lanes`]); a word holds two
/// horizontal neighbours (`x = 2·id.x` and `2·id.x + 1`), binary16 each ([`guide_at`]).
#[inline(always)]
pub fn blur<const N: usize>(id: UVec3, p: &GuideParams, io: AoGuideBlurIo<'_>) {
    let AoGuideBlurIo {
        raw,
        depth,
        normal_roughness,
        guide,
    } = io;
    let (w, h, words) = (p.width, p.height, guide_row_words(p.width));
    if id.x >= words || id.y >= h {
        return;
    }
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < words);
    let inputs = (raw, depth, normal_roughness);
    let even = blurred::<N>(2 * id.x, id.y, p, inputs);
    let odd = blurred::<N>(2 * id.x + 1, id.y, p, inputs);
    // The odd half of a row's last word lies past an odd width.
    let odd = odd.select(
        Lanes::from_index(|l| 2 * (id.x + l) + 1 < w),
        Lanes::splat(1.0),
    );
    packing::pack_f16x2_lanes(even, odd).store(guide, (id.y * words + id.x) as usize, live);
}

/// `raw`'s mean over the 4×4 block (offsets −2..=1) of pixels `(x0 + 2·l, y)` on each one's
/// own surface, at least [`FLOOR`]; 1 where there is no surface (or past the row's end).
#[inline(always)]
fn blurred<const N: usize>(
    x0: u32,
    y: u32,
    p: &GuideParams,
    (raw, depth, normal_roughness): (&[u32], &[f32], &[u32]),
) -> Lanes<f32, N> {
    let (w, h) = (p.width, p.height);
    let xs = Lanes::<u32, N>::from_index(|l| x0 + 2 * l);
    let centre = xs.map(|x| y * w + lanes::clamp_column(x as i32, w));
    let d = Lanes::gather(depth, centre);
    let n = Lanes::gather(normal_roughness, centre).map(packing::unpack_normal);
    let (mut sum, mut count) = (Lanes::<f32, N>::splat(0.0), Lanes::<f32, N>::splat(0.0));
    let mut dy = -2;
    while dy < 2 {
        let qy = y as i32 + dy;
        let mut dx = -2;
        while dx < 2 {
            let mut index = Lanes::<u32, N>::splat(0);
            let mut inside = Lanes::<bool, N>::splat(false);
            lanes::each_lane!(l in N {
                let qx = xs.0[l] as i32 + dx;
                let ok = qx >= 0 && qy >= 0 && qx < w as i32 && qy < h as i32;
                index.0[l] = if ok { qy as u32 * w + qx as u32 } else { centre.0[l] };
                inside.0[l] = ok;
            });
            let (qd, qn) = (
                Lanes::gather(depth, index),
                Lanes::gather(normal_roughness, index),
            );
            let (qr, _) = packing::unpack_f16x2_lanes(Lanes::gather(raw, index));
            lanes::each_lane!(l in N {
                let (d, qd) = (d.0[l], qd.0[l]);
                let same = n.0[l].dot(packing::unpack_normal(qn.0[l])) > BLUR_COSINE
                    && math::abs(qd - d) < BLUR_DEPTH * d;
                if inside.0[l] && surface::has_surface(qd) && same {
                    sum.0[l] += qr.0[l];
                    count.0[l] += 1.0;
                }
            });
            dx += 1;
        }
        dy += 1;
    }
    // The centre counts wherever it has a surface, so `count >= 1` there.
    let mut out = Lanes::<f32, N>::splat(1.0);
    lanes::each_lane!(l in N {
        if xs.0[l] < w && surface::has_surface(d.0[l]) {
            out.0[l] = math::max(sum.0[l] / count.0[l], FLOOR);
        }
    });
    out
}

/// Whether plane `z` is one the guide divides.
#[inline]
fn guided(p: &GuideParams, z: u32) -> bool {
    (p.ao_planes >> z) & 1 != 0
}

/// [`guide_at`] of pixels `(x + l, y)` (clamped to the row).
#[inline(always)]
fn guide_lanes<const N: usize>(guide: &[u32], x: u32, y: u32, width: u32) -> Lanes<f32, N> {
    let xs = Lanes::<u32, N>::from_index(|l| lanes::clamp_column((x + l) as i32, width));
    let row = y * guide_row_words(width);
    let (even, odd) = packing::unpack_f16x2_lanes(Lanes::gather(guide, xs.map(|x| row + x / 2)));
    even.select(xs.map(|x| x & 1 == 0), odd)
}

/// The history the variance pass reads, one call per `N` consecutive pixels of a row and
/// plane ([`crate::lanes`]): on the guided planes the moments divided by the guide (`m1 / g`,
/// `m2 / g²`), elsewhere as they are.
#[inline(always)]
pub fn demodulate<const N: usize>(id: UVec3, p: &GuideParams, io: AoDemodulateIo<'_>) {
    let AoDemodulateIo {
        history,
        guide,
        out,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let row = (id.z * h + id.y) * w;
    let q = Lanes::<PackedPayload, N>::load_row(history, row, id.x as i32, w);
    let i = plane_index(id, w, h);
    if !guided(p, id.z) {
        q.store(out, i, live);
        return;
    }
    let g = guide_lanes::<N>(guide, id.x, id.y, w);
    let mut u = PayloadLanes::unpack(q);
    u.m1 = u.m1.zip(g, |m1, g| m1 / g);
    u.m2 = u.m2.zip(g, |m2, g| m2 / (g * g));
    u.pack().store(out, i, live);
}

/// A filtered `(value, variance)` multiplied back by the guide `g`: value by `g`, at most 1
/// (AO is a fraction of the hemisphere; a neighbour whose guide was too dark can lift the mean
/// of ratios past `1 / g`), variance by `g²`.
#[inline(always)]
fn times(value: f32, variance: f32, g: f32) -> (f32, f32) {
    (math::min(value * g, 1.0), variance * (g * g))
}

/// The filter's output multiplied back by the guide on the guided planes, in place, one call
/// per `N` consecutive pixels of a row and plane ([`crate::lanes`]).
#[inline(always)]
pub fn remodulate<const N: usize>(id: UVec3, p: &GuideParams, io: AoRemodulateIo<'_>) {
    let AoRemodulateIo { guide, out } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h || !guided(p, id.z) {
        return;
    }
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let row = (id.z * h + id.y) * w;
    let (value, variance) = unpack_filtered(Lanes::<PackedFiltered, N>::load_row(
        out,
        row,
        id.x as i32,
        w,
    ));
    let g = guide_lanes::<N>(guide, id.x, id.y, w);
    let (mut v, mut var) = (value, variance);
    lanes::each_lane!(l in N {
        (v.0[l], var.0[l]) = times(value.0[l], variance.0[l], g.0[l]);
    });
    pack_filtered(v, var).store(out, plane_index(id, w, h), live);
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
    let mut f = input[i].unpack();
    if guided(p, id.z) {
        // Through binary16 as `remodulate` stores it, so both paths give the same value.
        (f.value, f.variance) = times(f.value, f.variance, guide_at(guide, id.x, id.y, w));
        f = f.pack().unpack();
    }
    let value = f.value;
    out.store(id.x, id.y + id.z * h, w, Vec4::new(value, 0.0, 0.0, 1.0));
}
