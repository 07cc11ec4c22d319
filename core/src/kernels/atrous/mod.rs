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
use super::detect::per_plane;
use super::penumbra;
use super::reflect::NO_GUIDE;
use super::reproject::NO_PLANE;
use super::{AtrousEngineIo, AtrousIo};
use crate::camera::{PixelRays, View};
use crate::lanes::{self, Lanes};
use crate::math;
use crate::packing;
use crate::payload::{self, PackedFiltered};
use crate::surface::{self, TangentPlane};
use crate::textures::Store;
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3, Vec4};

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
    /// Nonzero: the luminance test's variance (the 3×3-blurred one) is capped at the pixel's
    /// own (VRRT; SVGF as published does not cap it).
    pub cap_variance: u32,
    /// Planes (bit per plane) whose normal weight takes `ao_normal_power` (`Layout::ao_planes`).
    pub ao_planes: u32,
    /// Exponent of the normal weight on the planes in `ao_planes`.
    pub ao_normal_power: f32,
    /// Planes (bit per plane) whose taps count in point-symmetric pairs, each pair at the
    /// geometric mean of its two weights (`FilterSettings::ao_symmetric_taps`): a window the
    /// edge-stopping weights cut on one side (a crease, a contact) no longer leans to the other.
    pub symmetric_planes: u32,
    /// The plane whose taps also compare the hit-distance guide (`guide`,
    /// [`crate::kernels::reflect::reflect_guide`]); [`NO_PLANE`] for none (`guide` is not read).
    pub guide_plane: u32,
    /// `1 / (σ_g √2)`: a tap whose guide differs by `Δ` is weighted by `exp(−(Δ · guide_scale)²)`
    /// (`FilterSettings::guide_sigma`).
    pub guide_scale: f32,
    /// `sigma_luminance` of `guide_plane` (`FilterSettings::guided_sigma_luminance`).
    pub guided_sigma_luminance: f32,
    /// The plane whose taps stay within the centre's penumbra (`penumbra`, from
    /// [`crate::kernels::penumbra`]); [`NO_PLANE`] for none (`penumbra` is not read).
    pub penumbra_plane: u32,
    /// `1 / k`: a tap `r` pixels away from a centre whose penumbra is `W` pixels wide is weighted
    /// by `exp(−(r / (k · max(W, 1)))²)` (`FilterSettings::penumbra_reach`).
    pub penumbra_scale: f32,
    /// `sigma_luminance` of `penumbra_plane` (`FilterSettings::penumbra_sigma_luminance`).
    pub penumbra_sigma_luminance: f32,
    /// Iterations the planes in `ao_planes` run ([`ao_iterations`]): from this one on they
    /// pass through, whatever their tile needs.
    pub ao_iterations: u32,
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
            cap_variance: 0,
            ao_planes: 0,
            ao_normal_power: 128.0,
            symmetric_planes: 0,
            guide_plane: NO_PLANE,
            guide_scale: 0.0,
            guided_sigma_luminance: 4.0,
            penumbra_plane: NO_PLANE,
            penumbra_scale: 0.0,
            penumbra_sigma_luminance: 4.0,
            ao_iterations: u32::MAX,
        }
    }
}

/// À-trous iterations of the AO planes on an image `rows` tall (`FilterSettings::ao_reach`):
/// the most, up to `iterations`, whose footprint (`2·(2ⁿ − 1)` pixels from the centre) stays
/// within `reach × rows`, and at least one; `iterations` for `reach` 0. Host-side, once a frame.
pub fn ao_iterations(reach: f32, rows: u32, iterations: u32) -> u32 {
    if reach <= 0.0 || iterations == 0 {
        return iterations;
    }
    let mut n = 1;
    while n < iterations && (2 * ((2u32 << n) - 1)) as f32 <= reach * rows as f32 {
        n += 1;
    }
    n
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

/// What an à-trous iteration reads, shared by [`atrous`] and [`atrous_engine`].
struct Reads<'a> {
    input: &'a [PackedFiltered],
    depth: &'a [f32],
    normal_roughness: &'a [u32],
    view: &'a [View],
    tiles: &'a [u32],
    guide: &'a [f32],
    penumbra: &'a [f32],
}

/// One call per `N` consecutive pixels of a row and one signal plane ([`crate::lanes`]): the
/// GPU runs `N = 1`, one invocation per pixel.
#[inline(always)]
pub fn atrous<const N: usize>(id: UVec3, p: &AtrousParams, io: AtrousIo<'_>) {
    let AtrousIo {
        input,
        depth,
        normal_roughness,
        view,
        tiles,
        guide,
        penumbra,
        out,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let reads = Reads {
        input,
        depth,
        normal_roughness,
        view,
        tiles,
        guide,
        penumbra,
    };
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let plane_row = (id.z * h + id.y) * w;
    iterate(id, p, reads).store(out, (plane_row + id.x) as usize, live);
}

/// [`atrous`]'s last iteration written into the engine's texture (`out`, R32F): plane `z`'s
/// pixel `(x, y)` at texel `(x, y + z · height)`, the denoised value in red.
#[inline(always)]
pub fn atrous_engine<const N: usize>(
    id: UVec3,
    p: &AtrousParams,
    io: AtrousEngineIo<'_>,
    out: impl Store,
) {
    let AtrousEngineIo {
        input,
        depth,
        normal_roughness,
        view,
        tiles,
        guide,
        penumbra,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let reads = Reads {
        input,
        depth,
        normal_roughness,
        view,
        tiles,
        guide,
        penumbra,
    };
    let (value, _) = payload::unpack_filtered(iterate::<N>(id, p, reads));
    let mut l = 0;
    while l < N {
        if id.x + (l as u32) < w {
            let texel = Vec4::new(value.0[l], 0.0, 0.0, 1.0);
            out.store(id.x + l as u32, id.y + id.z * h, w, texel);
        }
        l += 1;
    }
}

/// The iteration's result at `N` pixels of a row (`id` the first, inside the image): filtered,
/// or passed through where the tile needs no more iterations or there is no surface.
#[inline(always)]
fn iterate<const N: usize>(
    id: UVec3,
    p: &AtrousParams,
    reads: Reads<'_>,
) -> Lanes<PackedFiltered, N> {
    let Reads {
        input,
        depth,
        normal_roughness,
        view,
        tiles,
        guide,
        penumbra,
    } = reads;
    let (w, h) = (p.width, p.height);
    let x0 = id.x as i32;
    let xs = Lanes::<u32, N>::from_index(|l| lanes::clamp_column(x0 + l as i32, w));
    let plane_row = (id.z * h + id.y) * w;
    let row = id.y * w;
    let packed = Lanes::<PackedFiltered, N>::load_row(input, plane_row, x0, w);
    let cd = Lanes::<f32, N>::load_row(depth, row, x0, w);
    let needed = Lanes::<u32, N>::gather(tiles, xs.map(|x| tile_index(x, id.y, w) as u32));
    let pass = cd.zip(needed, |d, t| passes_through(p, id.z, d, t));
    if pass.all() {
        return packed;
    }
    let (value, variance) = payload::unpack_filtered(packed);
    let n = Lanes::<u32, N>::load_row(normal_roughness, row, x0, w).map(packing::unpack_normal);
    let centre = CentreTexels {
        depth: cd,
        normal: n,
        value,
        variance,
    };
    let rows = Rows {
        input,
        depth,
        normal_roughness,
    };
    let extra = Extra {
        view: &view[0],
        guide,
        penumbra,
    };
    let variances = InputVariance::new(input, id, p);
    let filtered = filter_at(id, p, (rows, variances), extra, xs, &centre);
    filtered.select(pass.map(|p| !p), packed)
}

/// Whether a pixel of plane `z` at view depth `depth` passes iteration `p.iteration` through
/// unfiltered: it has no surface, its tile needs no more than `needed` iterations
/// ([`super::classify`]), or its plane is an AO plane that has run its `p.ao_iterations`.
#[inline(always)]
fn passes_through(p: &AtrousParams, z: u32, depth: f32, needed: u32) -> bool {
    let needed = per_plane(needed, needed.min(p.ao_iterations), p.ao_planes, z);
    !surface::has_surface(depth) || p.iteration >= needed
}

/// What the centre pixels of a filter step bring: view depth, unit normal, value and variance,
/// and the 3×3-blurred variance.
#[derive(Copy, Clone)]
struct CentreTexels<const N: usize> {
    depth: Lanes<f32, N>,
    normal: Lanes<Vec3, N>,
    value: Lanes<f32, N>,
    variance: Lanes<f32, N>,
}

/// What a filter step reads besides its taps: the camera and the two guides.
#[derive(Copy, Clone)]
struct Extra<'a> {
    view: &'a View,
    guide: &'a [f32],
    penumbra: &'a [f32],
}

/// The filtered `(value, variance)` of `N` pixels of a row (`id` the first, at columns `xs`)
/// whose taps come from `src`: the weights of every tap against the centre's, whose 3×3-blurred
/// variance comes from `variances` ([`blurred_from`]).
#[inline(always)]
fn filter_at<const N: usize, S: TapSource<N>>(
    id: UVec3,
    p: &AtrousParams,
    (src, variances): (S, impl VarianceRows<N>),
    extra: Extra<'_>,
    xs: Lanes<u32, N>,
    centre: &CentreTexels<N>,
) -> Lanes<PackedFiltered, N> {
    let Extra {
        view,
        guide,
        penumbra,
    } = extra;
    let (w, h) = (p.width, p.height);
    let (row, x0) = (id.y * w, id.x as i32);
    let CentreTexels {
        depth: cd,
        normal: n,
        value,
        variance,
    } = *centre;
    let rays = PixelRays::new(&view.camera, w, h);
    // Distances in units of the plane tolerance at one pixel of offset: the per-pixel
    // reciprocal folded into the plane, so every tap multiplies by its offset's only.
    let plane = Lanes::<TangentPlane, N>::from_index(|l| {
        let l = l as usize;
        let d = cd.0[l];
        TangentPlane::new(&rays, n.0[l], xs.0[l], id.y, d)
            .scaled(1.0 / math::max(p.plane_scale * d, 1e-12))
    });
    let mut blurred = blurred_from(id, p, variances);
    if p.cap_variance != 0 {
        // The blur steadies σ in flat noise, but next to a noisier surface (a highlight above a
        // dark contact line) it raises the dark pixel's σ to the bright side's and the luminance
        // test lets the bright taps in. Capped, the blur may only lower σ.
        blurred = blurred.zip(variance, math::min);
    }
    let normal_power = per_plane(p.normal_power, p.ao_normal_power, p.ao_planes, id.z);
    let guided = id.z == p.guide_plane;
    let penumbral = id.z == p.penumbra_plane;
    let sigma_luminance = if guided {
        p.guided_sigma_luminance
    } else if penumbral {
        p.penumbra_sigma_luminance
    } else {
        p.sigma_luminance
    };
    // Reciprocals once per pixel: every tap multiplies instead of dividing.
    let lum_scale = blurred.map(|b| 1.0 / (sigma_luminance * math::sqrt(math::max(b, 0.0)) + 1e-6));
    let c = Centre {
        id,
        p: *p,
        guided,
        penumbral,
        guide: guide_row(guide, guided, row, x0, w),
        reach: guide_row::<N>(penumbra, penumbral, row, x0, w)
            .map(|pw| penumbra::reach(pw, p.penumbra_scale)),
        value,
        normal: n,
        plane,
        lum_scale,
        normal_power,
    };
    let symmetric = super::plane_in(p.symmetric_planes, id.z);
    let (sum, sum_var, sum_w) = filter_taps(src, guide, &c, variance, symmetric);
    payload::pack_filtered(
        sum.zip(sum_w, |sum, s| sum / s),
        sum_var.zip(sum_w, |sum_var, s| sum_var / (s * s)),
    )
}

/// The weighted sums over the centre `c`'s 24 taps, the centre's own sample (`variance`)
/// included at weight 1: value, variance (squared weights) and weight. On `symmetric` planes
/// the taps count in point-symmetric pairs.
#[inline(always)]
fn filter_taps<const N: usize, S: TapSource<N>>(
    src: S,
    guide: &[f32],
    c: &Centre<N>,
    variance: Lanes<f32, N>,
    symmetric: bool,
) -> (Lanes<f32, N>, Lanes<f32, N>, Lanes<f32, N>) {
    let mut sum = c.value;
    let mut sum_var = variance;
    let mut sum_w = Lanes::<f32, N>::splat(1.0);
    let mut ty = -2;
    while ty <= 2 {
        let mut tx = -2;
        while tx <= 2 {
            if !symmetric {
                if tx != 0 || ty != 0 {
                    let t = tap(src, guide, c, tx, ty);
                    let w_n = t.cosine2.pow(0.5 * c.normal_power);
                    lanes::each_lane!(l in N {
                        if t.valid.0[l] {
                            let w = t.weight * w_n.0[l] * math::exp(-t.exponent.0[l]);
                            sum.0[l] += w * t.value.0[l];
                            sum_var.0[l] += w * w * t.variance.0[l];
                            sum_w.0[l] += w;
                        }
                    });
                }
            } else if ty > 0 || (ty == 0 && tx > 0) {
                // The pair (tx, ty), (-tx, -ty): both or neither, at one weight, the geometric
                // mean of theirs. Their B3 weights are equal, so it is
                // `tw · ((n·a)²(n·b)²)^(p/4) · exp(−(e_a + e_b)/2)`: one power, one exponential.
                let a = tap(src, guide, c, tx, ty);
                let b = tap(src, guide, c, -tx, -ty);
                let w_n = a
                    .cosine2
                    .zip(b.cosine2, |a, b| a * b)
                    .pow(0.25 * c.normal_power);
                lanes::each_lane!(l in N {
                    if a.valid.0[l] && b.valid.0[l] {
                        let e = 0.5 * (a.exponent.0[l] + b.exponent.0[l]);
                        let w = a.weight * w_n.0[l] * math::exp(-e);
                        sum.0[l] = math::mul_add(w, a.value.0[l] + b.value.0[l], sum.0[l]);
                        sum_var.0[l] =
                            math::mul_add(w * w, a.variance.0[l] + b.variance.0[l], sum_var.0[l]);
                        sum_w.0[l] += 2.0 * w;
                    }
                });
            }
            tx += 1;
        }
        ty += 1;
    }
    (sum, sum_var, sum_w)
}

/// What every tap of a pixel compares itself with, and the iteration's parameters.
struct Centre<const N: usize> {
    id: UVec3,
    p: AtrousParams,
    /// This plane compares the hit-distance guide, the centre's is `guide`.
    guided: bool,
    /// This plane's taps stay within the centre's penumbra (`reach`).
    penumbral: bool,
    guide: Lanes<f32, N>,
    /// `1 / (k · W)` of the centre's penumbra `W` ([`penumbra::reach`]), 0 for no limit.
    reach: Lanes<f32, N>,
    value: Lanes<f32, N>,
    normal: Lanes<Vec3, N>,
    /// The centre's tangent plane, its distances scaled to exponents one pixel of offset away.
    plane: Lanes<TangentPlane, N>,
    /// Exponent per unit of luminance difference.
    lum_scale: Lanes<f32, N>,
    normal_power: f32,
}

/// One tap: whether it counts (inside the image, on a surface), its value and variance, and the
/// parts of its weight `weight · cosine2^(p/2) · exp(−exponent)`, kept apart so a symmetric
/// pair takes one power and one exponential for both.
struct Tap<const N: usize> {
    valid: Lanes<bool, N>,
    /// The B3-spline weight relative to the centre's.
    weight: f32,
    /// `max(0, n·m)²` of the centre's and the tap's normals: squared, so the tap's decoded
    /// direction needs no square root (`(n·u)² / (u·u)` for its direction `u`).
    cosine2: Lanes<f32, N>,
    /// The plane, luminance and guide exponents, summed.
    exponent: Lanes<f32, N>,
    value: Lanes<f32, N>,
    variance: Lanes<f32, N>,
}

/// Where a filter step's taps come from: the buffers ([`Rows`]), or a workgroup's tile of
/// texels decoded once ([`tile`]). Each method gives one quantity of the centre `c`'s tap
/// `(tx, ty)` ([`TapAt`]), so a row of lanes
/// flows into the weights without a struct of them in between.
trait TapSource<const N: usize>: Copy {
    /// View depth (0 where no surface).
    fn depth(&self, c: &Centre<N>, t: TapAt) -> Lanes<f32, N>;
    /// Value and variance.
    fn filtered(&self, c: &Centre<N>, t: TapAt) -> (Lanes<f32, N>, Lanes<f32, N>);
    /// `max(0, n·m)²` of the centre's normal `n` and the tap's `m`
    /// ([`surface::squared_cosines`]).
    fn cosine2(&self, c: &Centre<N>, t: TapAt) -> Lanes<f32, N>;
}

/// Where a tap lies: `(tx, ty)` in steps from the centre, pixel columns `qx0 + l` of row `qy`.
#[derive(Copy, Clone)]
struct TapAt {
    tx: i32,
    ty: i32,
    qx0: i32,
    qy: u32,
}

/// Taps read from the buffers, a row of `N` at a time (the CPU's lanes; one on the GPU).
#[derive(Copy, Clone)]
struct Rows<'a> {
    input: &'a [PackedFiltered],
    depth: &'a [f32],
    normal_roughness: &'a [u32],
}

impl<const N: usize> TapSource<N> for Rows<'_> {
    #[inline(always)]
    fn depth(&self, c: &Centre<N>, t: TapAt) -> Lanes<f32, N> {
        let w = c.p.width;
        Lanes::load_row(self.depth, t.qy * w, t.qx0, w)
    }

    #[inline(always)]
    fn filtered(&self, c: &Centre<N>, t: TapAt) -> (Lanes<f32, N>, Lanes<f32, N>) {
        let (w, h) = (c.p.width, c.p.height);
        let row = (c.id.z * h + t.qy) * w;
        payload::unpack_filtered(Lanes::load_row(self.input, row, t.qx0, w))
    }

    #[inline(always)]
    fn cosine2(&self, c: &Centre<N>, t: TapAt) -> Lanes<f32, N> {
        let w = c.p.width;
        let m = Lanes::<u32, N>::load_row(self.normal_roughness, t.qy * w, t.qx0, w);
        surface::packed_squared_cosines(c.normal, m)
    }
}

/// Tap `(tx, ty)` (in steps) of the centre `c`.
#[inline(always)]
fn tap<const N: usize, S: TapSource<N>>(
    src: S,
    guide: &[f32],
    c: &Centre<N>,
    tx: i32,
    ty: i32,
) -> Tap<N> {
    let (p, id) = (&c.p, c.id);
    let (w, h) = (p.width, p.height);
    let step = p.step as i32;
    let qy = id.y as i32 + ty * step;
    let (ax, ay) = (tx.unsigned_abs() as usize, ty.unsigned_abs() as usize);
    if qy < 0 || qy >= h as i32 {
        let zero = Lanes::<f32, N>::splat(0.0);
        return Tap {
            valid: Lanes::splat(false),
            weight: 0.0,
            cosine2: zero,
            exponent: zero,
            value: zero,
            variance: zero,
        };
    }
    let qx0 = id.x as i32 + tx * step;
    let qx = Lanes::<i32, N>::from_index(|l| qx0 + l as i32);
    let at = TapAt {
        tx,
        ty,
        qx0,
        qy: qy as u32,
    };
    let qd = src.depth(c, at);
    let valid = qx.zip(qd, |x, d| x >= 0 && x < w as i32 && surface::has_surface(d));
    let (value, variance) = src.filtered(c, at);
    let offset_len = TAP_DISTANCE[ay][ax] * p.step as f32;
    let per_offset = 1.0 / offset_len;
    let cosine2 = src.cosine2(c, at);
    // Plane and luminance weights are both exponentials: one exp of the summed exponents (the
    // exp was most of the filter's time on the CPU).
    let mut e = Lanes::<f32, N>::from_index(|l| {
        let l = l as usize;
        // Columns outside the image are never used (`valid`); clamped, they stay the finite
        // values of some pixel.
        let x = lanes::clamp_column(qx.0[l], w);
        math::mul_add(
            c.plane.0[l].distance(x, qy as u32, qd.0[l]),
            per_offset,
            math::abs(c.value.0[l] - value.0[l]) * c.lum_scale.0[l],
        )
    });
    // The guides' terms only on their planes (uniform branches).
    if c.guided {
        let qg = guide_row::<N>(guide, true, qy as u32 * w, qx0, w);
        lanes::each_lane!(l in N {
            e.0[l] += guide_exponent(c.guide.0[l], qg.0[l], p.guide_scale);
        });
    }
    if c.penumbral {
        lanes::each_lane!(l in N {
            let r = offset_len * c.reach.0[l];
            e.0[l] += r * r;
        });
    }
    Tap {
        valid,
        weight: TAP_WEIGHT[ay][ax],
        cosine2,
        exponent: e,
        value,
        variance,
    }
}

/// The guide of `N` pixels of a row (`Lanes::load_row`) on a guided plane, or [`NO_GUIDE`]
/// without reading `guide` (one element when no plane is guided).
#[inline(always)]
pub fn guide_row<const N: usize>(
    guide: &[f32],
    guided: bool,
    row_start: u32,
    x0: i32,
    width: u32,
) -> Lanes<f32, N> {
    if guided {
        Lanes::load_row(guide, row_start, x0, width)
    } else {
        Lanes::splat(NO_GUIDE)
    }
}

/// The guide's part of a tap's exponent: `(Δ · scale)²`, or 0 when either pixel has no guide.
#[inline(always)]
pub fn guide_exponent(centre: f32, tap: f32, scale: f32) -> f32 {
    if centre == NO_GUIDE || tap == NO_GUIDE {
        return 0.0;
    }
    let d = (centre - tap) * scale;
    d * d
}

/// Where [`blurred_from`] reads the variances it blurs: a row of `N` pixels at a time.
trait VarianceRows<const N: usize>: Copy {
    /// The variances of the pixels at columns `x0 + l` (clamped to the row) of row `y`, which
    /// lies inside the image.
    fn row(&self, x0: i32, y: u32) -> Lanes<f32, N>;
}

/// The variances of an iteration's input buffer, plane `plane`.
#[derive(Copy, Clone)]
struct InputVariance<'a> {
    input: &'a [PackedFiltered],
    plane: u32,
    width: u32,
    height: u32,
}

impl<'a> InputVariance<'a> {
    /// The variances of `input` on pixel `id`'s plane.
    #[inline(always)]
    fn new(input: &'a [PackedFiltered], id: UVec3, p: &AtrousParams) -> Self {
        InputVariance {
            input,
            plane: id.z,
            width: p.width,
            height: p.height,
        }
    }
}

impl<const N: usize> VarianceRows<N> for InputVariance<'_> {
    #[inline(always)]
    fn row(&self, x0: i32, y: u32) -> Lanes<f32, N> {
        let row = (self.plane * self.height + y) * self.width;
        let q = Lanes::<PackedFiltered, N>::load_row(self.input, row, x0, self.width);
        payload::unpack_filtered(q).1
    }
}

/// The variances `rows` gives at each lane's pixel blurred by a 3×3 Gaussian (edges clamped): a
/// less noisy σ for the luminance weight.
#[inline(always)]
fn blurred_from<const N: usize>(
    id: UVec3,
    p: &AtrousParams,
    rows: impl VarianceRows<N>,
) -> Lanes<f32, N> {
    let mut sum = Lanes::<f32, N>::splat(0.0);
    let mut dy: i32 = -1;
    while dy <= 1 {
        let qy = lanes::clamp_column(id.y as i32 + dy, p.height);
        let mut dx: i32 = -1;
        while dx <= 1 {
            let wt = GAUSS3[dx.unsigned_abs() as usize] * GAUSS3[dy.unsigned_abs() as usize];
            let variance = rows.row(id.x as i32 + dx, qy);
            sum = sum.zip(variance, |s, v| s + wt * v);
            dx += 1;
        }
        dy += 1;
    }
    sum
}

pub mod pair;
pub mod tile;

#[cfg(test)]
mod tests;
