//! Temporal reprojection, its own pass before raygen, so the ray budget can be decided from what
//! history survived.
//!
//! Seed: vrrt-call-of-duty-2026, "Supersampling" (`TemporalReprojection`, `GetRejectionWeights`)
//! and ALGORITHMS.md "Reprojection with per-texel rejection". Each texel of the 2×2 bilinear
//! footprint is tested on its own (normal, plane distance, non-empty history; depth and normals
//! are never interpolated); the payload is the bilinear blend of the valid texels only, and never
//! weighted by history length (that makes the signal swim). The rng index is point-sampled from
//! the valid texel with the largest bilinear weight. The history *length* is not renormalised:
//! rejected texels add no rays, so a pixel that kept a quarter of its footprint keeps a quarter of
//! its history. Its moments come from texels up to a pixel away (at a silhouette, a thin part, a
//! partly uncovered surface), and counting them whole let that offset history outweigh the
//! pixel's own new rays.
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
use super::gradient::GradientSample;
use super::requests::{request_word, FLAG_DISOCCLUDED, FLAG_SKY};
use super::{pixel_index, plane_index};
use super::{ReprojectEngineIo, ReprojectIo};
use crate::camera::{Camera, PixelRays, View};
use crate::inputs;
use crate::lanes::{self, Lanes};
use crate::math;
use crate::packing;
use crate::payload::{PackedPayload, Payload, PayloadLanes};
use crate::surface::{self, Moved};
use crate::textures::Fetch;
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

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

/// Whether the previous-frame texel at view depth `depth`, position `t` and normal direction `u`
/// (any length but 0: [`packing::unpack_direction`]) shows the current surface of unit normal
/// `n`, whose last-frame position was `prev`: `n·m ≥ normal_threshold` and
/// `|m·(prev − t)| ≤ plane_threshold · depth` for the unit normal `m = u / |u|`, compared squared
/// so that `u` needs no normalisation.
#[inline]
pub fn same_surface(
    n: Vec3,
    prev: Vec3,
    depth: f32,
    t: Vec3,
    u: Vec3,
    p: &ReprojectParams,
) -> bool {
    let (nu, uu) = (math::dot(n, u), math::dot(u, u));
    let thr = p.normal_threshold;
    let (above, within) = (nu * nu >= thr * thr * uu, nu * nu <= thr * thr * uu);
    // `nu ≥ thr·|u|`: for a threshold ≥ 0 a non-negative cosine at least that large; below 0,
    // any non-negative cosine or a negative one no larger in magnitude.
    let n_ok = ((nu >= 0.0) & above) | ((thr < 0.0) & ((nu >= 0.0) | within));
    let reach = p.plane_threshold * math::max(depth, 1e-6);
    let ud = math::dot(u, prev - t);
    // `&`, not `&&`: no branch, so a row of lanes is vector code.
    surface::has_surface(depth) & n_ok & (ud * ud <= reach * reach * uu)
}

/// Ray rate a pixel asks for, from its shortest history and largest variance over the planes.
///
/// In order: nothing but `base_rate` without VRRT requests; the refill of a history short of
/// `supersample_target`; on a still frame, the refill up to `still_history`, then the floor for
/// a quiet estimate; from `full_history` on, the rate of the first variance threshold it is
/// under; else `base_rate`. Written as selects from the last rule to the first, not early
/// returns, so a row of lanes decides without a branch per pixel.
#[inline]
pub fn requested_rate(min_count: f32, max_variance: f32, p: &ReprojectParams) -> f32 {
    let mut converged = p.base_rate;
    let mut i = 4;
    while i > 0 {
        i -= 1;
        if max_variance < p.variance_threshold[i] {
            converged = p.variance_rate[i];
        }
    }
    let mut rate = if min_count >= p.full_history {
        converged
    } else {
        p.base_rate
    };
    if p.still_history > 0.0 {
        if max_variance < p.still_variance * min_count {
            rate = p.variance_rate[0];
        }
        if min_count < p.still_history {
            // Still frame: history stays valid, so it is completed first, at whatever the budget
            // grants (the refill rule with `still_history` as the target).
            rate = math::clamp(math::floor(p.still_history - min_count + 0.5), 1.0, 16.0);
        }
    }
    if min_count < p.supersample_target {
        rate = math::clamp(
            math::floor(p.supersample_target - min_count + 0.5),
            1.0,
            16.0,
        );
    }
    if p.supersample_target <= 0.0 {
        p.base_rate
    } else {
        rate
    }
}

/// The 2×2 bilinear footprints of `N` pixels (one lane each): texel indices and bilinear weights
/// with every texel that fails [`same_surface`] (or lies off-screen) set to 0, per texel `k`.
#[derive(Copy, Clone)]
pub(super) struct Footprint<const N: usize> {
    pub(super) texel: [Lanes<u32, N>; 4],
    pub(super) bilinear: [Lanes<f32, N>; 4],
    /// Whether any texel survived.
    any: Lanes<bool, N>,
}

/// The [`Footprint`]s of previous-frame positions `xy` (pixels) of surfaces `c`.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // The SPIR-V ABI passes slices one by one.
pub(super) fn footprint<const N: usize>(
    n: Lanes<Vec3, N>,
    prev: Lanes<Vec3, N>,
    xy: Lanes<[f32; 2], N>,
    geometry_ok: Lanes<bool, N>,
    prev_camera: &Camera,
    prev_depth: &[f32],
    prev_normal_roughness: &[u32],
    p: &ReprojectParams,
) -> Footprint<N> {
    // Texel centres are at integer pixel coordinates.
    let x0 = xy.map(|[x, _]| math::floor(x));
    let y0 = xy.map(|[_, y]| math::floor(y));
    let ax = xy.zip(x0, |[x, _], x0| x - x0);
    let ay = xy.zip(y0, |[_, y], y0| y - y0);
    let ok = Lanes::<bool, N>::from_index(|l| {
        let l = l as usize;
        geometry_ok.0[l] && math::is_finite(ax.0[l]) && math::is_finite(ay.0[l])
    });
    let mut f = Footprint {
        texel: [Lanes::splat(0); 4],
        bilinear: [
            ax.zip(ay, |ax, ay| (1.0 - ax) * (1.0 - ay)),
            ax.zip(ay, |ax, ay| ax * (1.0 - ay)),
            ax.zip(ay, |ax, ay| (1.0 - ax) * ay),
            ax.zip(ay, |ax, ay| ax * ay),
        ],
        any: Lanes::splat(false),
    };
    // `Camera::unproject` of the texels, with the rays set up once.
    let (origin, rays) = (
        prev_camera.origin(),
        PixelRays::new(prev_camera, p.width, p.height),
    );
    let mut k = 0;
    while k < 4 {
        let (dx, dy) = ((k & 1) as f32, (k >> 1) as f32);
        // Texels off-screen (or of invalid lanes) read texel (0, 0) and are rejected: every lane
        // computes, selects decide (vector code over lanes).
        let used = Lanes::<bool, N>::from_index(|l| {
            let l = l as usize;
            let (tx, ty) = (x0.0[l] + dx, y0.0[l] + dy);
            ok.0[l] && tx >= 0.0 && ty >= 0.0 && tx < p.width as f32 && ty < p.height as f32
        });
        let t = Lanes::<[f32; 2], N>::from_index(|l| {
            let l = l as usize;
            if used.0[l] {
                [x0.0[l] + dx, y0.0[l] + dy]
            } else {
                [0.0, 0.0]
            }
        });
        // Whole, on-screen coordinates: `floor_small` converts them in vector registers.
        let texel =
            t.map(|[x, y]| pixel_index(math::floor_small(x), math::floor_small(y), p.width) as u32);
        let pd = Lanes::<f32, N>::gather(prev_depth, texel);
        // Decoded inside the test, lane by lane: a row of decoded directions in between would
        // be an array of 3-vectors that the CPU's vector code re-gathers field by field.
        let words = Lanes::<u32, N>::gather(prev_normal_roughness, texel);
        let same = Lanes::<bool, N>::from_index(|l| {
            let l = l as usize;
            let [x, y] = t.0[l];
            let q = math::mul_add3(rays.dir(x, y), pd.0[l], origin);
            let m = packing::unpack_direction(words.0[l]);
            used.0[l] & same_surface(n.0[l], prev.0[l], pd.0[l], q, m, p)
        });
        f.texel[k] = texel;
        f.bilinear[k] = f.bilinear[k].select(same, Lanes::splat(0.0));
        f.any = f.any.zip(same, |a, s| a || s);
        k += 1;
    }
    f
}

/// The bilinear blend of the valid texels of footprint `f` in the history plane starting at
/// `plane` (module docs: empty texels rejected one by one; the rng index from the texel of
/// largest weight, `frame_index` where none), unnormalised, and the weights' sum.
#[inline(always)]
fn blend_history<const N: usize>(
    history: &[PackedPayload],
    f: &Footprint<N>,
    plane: u32,
    frame_index: u32,
) -> (PayloadLanes<N>, Lanes<f32, N>) {
    // Sums start at +0, so masked adds give the bits of adding only the used texels.
    let zero = Lanes::<f32, N>::splat(0.0);
    let (mut m1, mut m2, mut count, mut sum_w, mut best_w) = (zero, zero, zero, zero, zero);
    let mut rng_index = Lanes::<u32, N>::splat(frame_index);
    let mut k = 0;
    while k < 4 {
        let index = f.texel[k].map(|t| plane + t);
        let hk = PayloadLanes::unpack(Lanes::<PackedPayload, N>::gather(history, index));
        // Empty texels (undersampled, never traced) are rejected one by one.
        let wk = f.bilinear[k].zip(hk.count, |b, c| if b > 0.0 && c >= 1.0 { b } else { 0.0 });
        let used = wk.map(|w| w > 0.0);
        m1 = m1.add_where(used, wk.zip(hk.m1, |w, m| w * m));
        m2 = m2.add_where(used, wk.zip(hk.m2, |w, m| w * m));
        count = count.add_where(used, wk.zip(hk.count, |w, c| w * c));
        sum_w = sum_w.add_where(used, wk);
        let best = wk.zip(best_w, |w, b| w > b);
        best_w = wk.select(best, best_w);
        rng_index = hk.rng_index.select(best, rng_index);
        k += 1;
    }
    let sums = PayloadLanes {
        m1,
        m2,
        count,
        rng_index,
    };
    (sums, sum_w)
}

/// The temporal gradient's `λ` (scaled, at most 1) of plane `z` at the cells of pixels `xs` of
/// row `y`; 0 without a gradient this frame.
#[inline(always)]
fn plane_lambda<const N: usize>(
    gradient: &[GradientSample],
    xs: Lanes<u32, N>,
    y: u32,
    z: u32,
    p: &ReprojectParams,
) -> Lanes<f32, N> {
    if p.gradient_stratum == 0 {
        return Lanes::splat(0.0);
    }
    let cell = xs.map(|x| {
        let (cx, cy) = (x / p.gradient_stratum, y / p.gradient_stratum);
        super::gradient::cell_index(cx, cy, z, p.gradient_width, p.gradient_height) as u32
    });
    Lanes::<GradientSample, N>::gather(gradient, cell)
        .map(|g| math::min(1.0, g.lambda() * p.gradient_scale))
}

/// What a plane group's planes gathered of a row of pixels for its request: whether any plane
/// lost its history, the shortest history and the largest variance.
struct GroupState<const N: usize> {
    lost: Lanes<bool, N>,
    min_count: Lanes<f32, N>,
    max_variance: Lanes<f32, N>,
}

/// The request words of a plane group's row of pixels: the bucket of the rate each asks for
/// (scaled by `scale`; none where not `wanted`), and its flags.
#[inline(always)]
fn request_words<const N: usize>(
    wanted: Lanes<bool, N>,
    valid: Lanes<bool, N>,
    g: &GroupState<N>,
    scale: Lanes<f32, N>,
    p: &ReprojectParams,
) -> Lanes<u32, N> {
    Lanes::<u32, N>::from_index(|l| {
        let l = l as usize;
        let bucket = if wanted.0[l] {
            rate_to_bucket(requested_rate(g.min_count.0[l], g.max_variance.0[l], p) * scale.0[l])
        } else {
            super::buckets::NO_RAYS
        };
        let flags = if !valid.0[l] {
            FLAG_SKY
        } else if g.lost.0[l] {
            FLAG_DISOCCLUDED
        } else {
            0
        };
        request_word(bucket, flags)
    })
}

/// One plane's reprojected history from its footprint's blend (`sums`, weights `sum_w`) and
/// its `λ`, and where it was dropped (footprint lost, or changed past the threshold).
#[inline(always)]
fn reprojected_plane<const N: usize>(
    sums: PayloadLanes<N>,
    sum_w: Lanes<f32, N>,
    lambda: Lanes<f32, N>,
    parallax: bool,
    p: &ReprojectParams,
) -> (PayloadLanes<N>, Lanes<bool, N>) {
    let PayloadLanes {
        m1,
        m2,
        count,
        rng_index,
    } = sums;
    // Enough of the footprint was the same surface; the signal changed under the history
    // (a disocclusion in all but geometry).
    let kept = sum_w.map(|s| s > p.disocclusion_threshold);
    let changed = lambda.map(|g| p.gradient_stratum > 0 && g > p.gradient_threshold);
    let mut reprojected = PayloadLanes {
        m1,
        m2,
        count,
        rng_index,
    };
    lanes::each_lane!(l in N {
        let s = sum_w.0[l];
        // A history longer than this frame allows (kept on still frames) is cut back; a
        // partial footprint keeps its share `s` of it (module docs). Not the reflections'
        // parallax footprint: the reflected image's motion lands on other surfaces far more
        // often, and its history is no worse for it (cut, the room's reflections got worse;
        // see docs/algorithms/change-detector.md).
        let share = if parallax { 1.0 } else { s };
        let full = math::min(count.0[l] / s, p.max_history) * share;
        let count = if changed.0[l] {
            0.0
        } else if p.gradient_stratum == 0 {
            full
        } else {
            full * (1.0 - lambda.0[l])
        };
        let payload = Payload {
            m1: m1.0[l] / s,
            m2: m2.0[l] / s,
            count,
            rng_index: rng_index.0[l],
        };
        let empty = Payload {
            m1: 0.0,
            m2: 0.0,
            count: 0.0,
            rng_index: p.frame_index,
        };
        reprojected.set(l, if kept.0[l] { payload } else { empty });
    });
    let dropped = kept.zip(changed, |kept, changed| !kept || changed);
    (reprojected, dropped)
}

/// What reprojection reads and writes besides this frame's inputs: shared by [`reproject`] (the
/// inputs in the denoiser's buffers) and [`reproject_engine`] (decoded from the engine's textures).
struct Rest<'a> {
    prev_depth: &'a [f32],
    prev_normal_roughness: &'a [u32],
    view: &'a [View],
    history: &'a [PackedPayload],
    mask: &'a [u32],
    gradient: &'a [GradientSample],
    importance: &'a [f32],
    parallax: &'a [[f32; 2]],
    out: &'a mut [PackedPayload],
    requests: &'a mut [u32],
}

/// One call per `N` consecutive pixels of a row ([`crate::lanes`]; the GPU runs `N = 1`); loops
/// over the signal planes so the geometric tests run once. Writes the reprojected history of
/// every plane to `out`, and per plane group the pixel's flags and ray request (a bucket) to
/// `requests`.
#[inline(always)]
pub fn reproject<const N: usize>(id: UVec3, p: &ReprojectParams, io: ReprojectIo<'_>) {
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
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let (row, x0) = (id.y * w, id.x as i32);
    let d = Lanes::<f32, N>::load_row(depth, row, x0, w);
    let nr = Lanes::<u32, N>::load_row(normal_roughness, row, x0, w);
    let mv = Lanes::<[u32; 2], N>::load_row(motion, row, x0, w);
    let rest = Rest {
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
    };
    reproject_pixels(id, p, rest, d, nr, mv);
}

/// [`reproject`] with this frame's inputs read from the engine's own textures in its conventions
/// (`conventions`, [`crate::inputs`]) and written, decoded, to the denoiser's input buffers for
/// the passes after it and for next frame: the decode fused into reprojection, its first reader.
#[inline(always)]
pub fn reproject_engine<const N: usize>(
    id: UVec3,
    p: &ReprojectParams,
    io: ReprojectEngineIo<'_>,
    engine_depth: impl Fetch,
    engine_normal: impl Fetch,
    engine_motion: impl Fetch,
) {
    let ReprojectEngineIo {
        conventions,
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
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let (c, v) = (&conventions[0], &view[0]);
    let xs = Lanes::<u32, N>::from_index(|l| lanes::clamp_column(id.x as i32 + l as i32, w));
    let d = xs.map(|x| inputs::decode_depth(engine_depth.load(x, id.y, w).x, c));
    let nr = xs.map(|x| {
        let (n, r) = inputs::decode_normal(engine_normal.load(x, id.y, w), c, &v.camera);
        packing::pack_normal_roughness(n, r * r)
    });
    let mv = Lanes::<[u32; 2], N>::from_index(|l| {
        let x = xs.0[l as usize];
        let cams = [&v.camera, &v.prev_camera];
        let t = engine_motion.load(x, id.y, w);
        let m = inputs::decode_motion(t, c, x, id.y, d.0[l as usize], cams);
        packing::pack_motion(m.x, m.y, m.z)
    });
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let start = pixel_index(id.x, id.y, w);
    d.store(depth, start, live);
    nr.store(normal_roughness, start, live);
    mv.store(motion, start, live);
    let rest = Rest {
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
    };
    reproject_pixels(id, p, rest, d, nr, mv);
}

/// Reprojection of `N` pixels of a row (`id` the first, inside the image) whose inputs are
/// `d`, `nr` and `mv`.
#[inline(always)]
fn reproject_pixels<const N: usize>(
    id: UVec3,
    p: &ReprojectParams,
    io: Rest<'_>,
    d: Lanes<f32, N>,
    nr: Lanes<u32, N>,
    mv: Lanes<[u32; 2], N>,
) {
    let Rest {
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
    let (w, h) = (p.width, p.height);
    let x0 = id.x as i32;
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let xs = Lanes::<u32, N>::from_index(|l| lanes::clamp_column(x0 + l as i32, w));
    let row = id.y * w;
    let v = view[0];
    let c = Moved::new(&v, xs, id.y, (w, h), d, nr, mv);
    let valid = c.valid;
    let geometry_ok = valid.map(|v| v && p.reset == 0);
    let (pd, pn, cam) = (prev_depth, prev_normal_roughness, &v.prev_camera);
    let (n, prev) = (c.normal, c.prev_position);
    let fp = footprint(n, prev, c.prev_xy, geometry_ok, cam, pd, pn, p);
    // Reflections move with the reflected image, not the surface (`reflect::reflect_motion`).
    let pfp = if p.parallax_plane < p.planes {
        let xy = Lanes::<[f32; 2], N>::load_row(parallax, row, x0, w);
        footprint(n, prev, xy, geometry_ok, cam, pd, pn, p)
    } else {
        fp
    };
    let wanted = if p.use_mask == 0 {
        valid
    } else {
        let m = Lanes::<u32, N>::load_row(mask, row, x0, w);
        valid.zip(m, |v, m| v && m != 0)
    };
    let pixels = (w * h) as usize;
    // Per group, reset when the group's last plane is written.
    let mut lost = fp.any.map(|a| !a);
    let mut min_count = Lanes::<f32, N>::splat(f32::MAX);
    let mut max_variance = Lanes::<f32, N>::splat(0.0);
    let mut z = 0;
    while z < p.planes {
        let f = if z == p.parallax_plane { pfp } else { fp };
        let plane = z * w * h;
        let (sums, sum_w) = blend_history(history, &f, plane, p.frame_index);
        let lambda = plane_lambda(gradient, xs, id.y, z, p);
        let (reprojected, dropped) =
            reprojected_plane(sums, sum_w, lambda, z == p.parallax_plane, p);
        lost = lost.zip(dropped, |a, b| a || b);
        min_count = min_count.zip(reprojected.count, math::min);
        max_variance = Lanes::from_index(|l| {
            math::max(
                max_variance.0[l as usize],
                reprojected.lane(l as usize).variance(),
            )
        });
        let packed = reprojected.pack();
        packed.store(out, plane_index(UVec3::new(id.x, id.y, z), w, h), live);
        let group = super::plane_group(p.plane_groups, z);
        z += 1;
        if z == p.planes || super::plane_group(p.plane_groups, z) != group {
            let scale = if group == p.importance_group {
                Lanes::<f32, N>::gather(
                    importance,
                    xs.map(|x| super::reflect::tile_index(x, id.y, w) as u32),
                )
            } else {
                Lanes::splat(1.0)
            };
            let state = GroupState {
                lost,
                min_count,
                max_variance,
            };
            let word = request_words(wanted, valid, &state, scale, p);
            word.store(
                requests,
                group as usize * pixels + pixel_index(id.x, id.y, w),
                live,
            );
            lost = fp.any.map(|a| !a);
            min_count = Lanes::splat(f32::MAX);
            max_variance = Lanes::splat(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::View;

    /// [`requested_rate`] as it was written with early returns: the selects decide the same.
    fn branchy(min_count: f32, max_variance: f32, p: &ReprojectParams) -> f32 {
        if p.supersample_target <= 0.0 {
            return p.base_rate;
        }
        if min_count < p.supersample_target {
            return (p.supersample_target - min_count + 0.5)
                .floor()
                .clamp(1.0, 16.0);
        }
        if p.still_history > 0.0 {
            if min_count < p.still_history {
                return (p.still_history - min_count + 0.5).floor().clamp(1.0, 16.0);
            }
            if max_variance < p.still_variance * min_count {
                return p.variance_rate[0];
            }
        }
        if min_count >= p.full_history {
            for i in 0..4 {
                if max_variance < p.variance_threshold[i] {
                    return p.variance_rate[i];
                }
            }
        }
        p.base_rate
    }

    #[test]
    fn requested_rate_selects_as_the_branches_did() {
        let counts = [0.0, 0.5, 1.0, 3.9, 4.0, 8.0, 31.5, 32.0, 63.0, 64.0, 100.0];
        let variances = [0.0, 5e-5, 1e-4, 5e-4, 1e-3, 5e-3, 1e-2, 0.1, f32::NAN];
        for (target, still) in [(0.0, 0.0), (8.0, 0.0), (8.0, 32.0), (32.0, 16.0)] {
            let p = ReprojectParams {
                supersample_target: target,
                still_history: still,
                still_variance: 2e-5,
                ..Default::default()
            };
            for &c in &counts {
                for &v in &variances {
                    let (a, b) = (requested_rate(c, v, &p), branchy(c, v, &p));
                    assert_eq!(a.to_bits(), b.to_bits(), "{c} {v} {target} {still}");
                }
            }
        }
    }

    const W: u32 = 8;
    const H: u32 = 4;

    /// The squared comparisons of [`same_surface`] decide as the unit normal's would, for every
    /// threshold sign, on directions of any length.
    #[test]
    fn same_surface_needs_no_unit_normal() {
        let n = Vec3::new(0.0, 0.0, 1.0);
        let (prev, t) = (Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.3, -0.2, 5.0));
        for thr in [-0.9f32, -0.2, 0.0, 0.5, 0.9] {
            let p = ReprojectParams {
                normal_threshold: thr,
                plane_threshold: 0.02,
                ..Default::default()
            };
            for i in 0..200 {
                let a = i as f32 * 0.0317;
                let m = Vec3::new(a.cos() * 0.8, a.sin() * 0.3, (a * 1.7).cos()).normalize();
                let offset = Vec3::new(0.0, 0.0, (i % 7) as f32 * 0.03 - 0.09);
                let unit =
                    n.dot(m) >= thr && m.dot(prev - (t + offset)).abs() <= p.plane_threshold * 5.0;
                for len in [0.6f32, 1.0, 1.7] {
                    let got = same_surface(n, prev, 5.0, t + offset, m * len, &p);
                    assert_eq!(got, unit, "thr {thr} i {i} len {len}");
                }
            }
        }
    }

    /// Reprojected history of a wall at view depth 5 facing the camera, which moved half a pixel
    /// (every pixel's last position is `x + 0.5`), when last frame an occluder at depth 2 stood in
    /// column `occluder`: the history lengths, row 1.
    fn counts_with_occluder_at(occluder: u32) -> std::vec::Vec<f32> {
        let camera = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0);
        let view = [View {
            camera,
            prev_camera: camera,
        }];
        let pixels = (W * H) as usize;
        let depth = std::vec![5.0f32; pixels];
        let normal = std::vec![packing::pack_normal_roughness(Vec3::Z, 0.5); pixels];
        let motion = std::vec![packing::pack_motion(0.5, 0.0, 0.0); pixels];
        let prev_depth: std::vec::Vec<f32> = (0..W * H)
            .map(|i| if i % W == occluder { 2.0 } else { 5.0 })
            .collect();
        let history = std::vec![
            Payload {
                m1: 0.25,
                m2: 0.125,
                count: 32.0,
                rng_index: 7,
            }
            .pack();
            pixels
        ];
        let mut out = std::vec![PackedPayload::zeroed(); pixels];
        let mut requests = std::vec![0u32; pixels];
        let p = ReprojectParams {
            width: W,
            height: H,
            ..Default::default()
        };
        for i in 0..W * H {
            let io = ReprojectIo {
                depth: &depth,
                normal_roughness: &normal,
                motion: &motion,
                prev_depth: &prev_depth,
                prev_normal_roughness: &normal,
                view: &view,
                history: &history,
                mask: &[1],
                gradient: &[GradientSample::default()],
                importance: &[1.0],
                parallax: &[[0.0; 2]],
                out: &mut out,
                requests: &mut requests,
            };
            reproject::<1>(UVec3::new(i % W, i / W, 0), &p, io);
        }
        (0..W)
            .map(|x| {
                let h = out[pixel_index(x, 1, W)].unpack();
                assert_eq!(h.m1, 0.25, "the moments stay the valid texels' blend");
                h.count
            })
            .collect()
    }

    #[test]
    fn a_partial_footprint_keeps_its_share_of_history() {
        // Pixel x reads texels x and x + 1 at half weight each; texel 4 was the occluder.
        let counts = counts_with_occluder_at(4);
        assert_eq!(&counts[2..6], &[32.0, 16.0, 16.0, 32.0]);
        // The last column's second texel is off-screen: half the footprint, half the history.
        assert_eq!(counts[7], 16.0);
        // Without the occluder the same footprints keep everything.
        let counts = counts_with_occluder_at(W);
        assert_eq!(&counts[..7], &[32.0; 7]);
    }
}
