//! Variance estimation: turns the accumulated moments into the `(value, variance)` pair the
//! à-trous filter reads.
//!
//! Seed: q2vkpt-path-tracing-denoising-2019 (SVGF: "variance estimation … also acts as a fallback
//! if there's no temporal information yet") and vrrt-call-of-duty-2026 ("Spatial temporal variance
//! estimate? … good as emergency fallback only"). With a long history the temporal variance of
//! the moments is used as is. While the history is shorter than `spatial_until` rays, a bilateral
//! (normal + plane, and on the reflections' guided plane the hit-distance guide,
//! [`super::reflect::reflect_guide`]) estimate over a `(2r+1)²` window is blended in:
//! `t = count / spatial_until`, `value = lerp(spatial_mean, m1, t)`,
//! `variance = lerp(spatial_variance, temporal_variance, t)`. Both are variances of single rays;
//! the output is the variance of the pixel's *estimate*, divided by the rays it holds
//! (`max(count, 1)`), so the luminance edge-stopping of the à-trous filter tightens as history
//! converges — SVGF's "stops applying blur after temporal stability is achieved" — instead of
//! blurring a converged pixel as hard as a 1-ray one. A pixel with no history at all
//! (`count = 0`) therefore takes the spatial estimate entirely — this is also how undersampled
//! pixels get a value without feeding it back into history.
//!
//! A pixel holding fewer than `wide_until` rays (a cut's two) on the AO and reflections planes
//! takes the window one pixel wider: its own estimate, and a 3×3 window's, are then at their
//! noisiest (the host sets `wide_until` only on images tall enough, `filter.wide_rows`).
//!
//! The pass also gathers what tile classification needs: each pixel with a surface folds the
//! variance it stored into its tile's word with an atomic max ([`classify::tile_key`]), so the
//! classification reads one word per tile instead of the whole image again.

use super::atrous::{guide_exponent, guide_row};
use super::classify;
use super::detect::per_plane;
use super::plane_index;
use super::reproject::NO_PLANE;
use super::VarianceIo;
use crate::atomic;
use crate::camera::{PixelRays, View};
use crate::lanes::{self, Lanes};
use crate::math;
use crate::packing;
use crate::payload::{pack_filtered, unpack_filtered, Filtered, PackedPayload, PayloadLanes};
use crate::surface::{self, TangentPlane};
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

/// Push constants of [`variance`].
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Pod, Zeroable)]
pub struct VarianceParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Window radius of the spatial fallback (1 → 3×3).
    pub radius: u32,
    /// Planes (bit per plane) whose normal weight takes `ao_normal_power` (`Layout::ao_planes`).
    pub ao_planes: u32,
    /// History length (rays) from which the temporal estimate is used alone (SVGF: 4).
    pub spatial_until: f32,
    /// Plane-distance tolerance, as [`crate::kernels::atrous::AtrousParams::plane_scale`].
    pub plane_scale: f32,
    /// Exponent of the normal weight.
    pub normal_power: f32,
    /// Exponent of the normal weight on the planes in `ao_planes`.
    pub ao_normal_power: f32,
    /// `spatial_until` of the planes in `ao_planes`.
    pub ao_spatial_until: f32,
    /// The plane whose spatial estimate also compares the hit-distance guide, as
    /// [`crate::kernels::atrous::AtrousParams::guide_plane`]; [`NO_PLANE`] for none.
    pub guide_plane: u32,
    /// As [`crate::kernels::atrous::AtrousParams::guide_scale`].
    pub guide_scale: f32,
    /// Pixels of the planes in `wide_planes` holding fewer rays than this take a window one
    /// pixel wider (`radius + 1`).
    pub wide_until: f32,
    /// Planes (bit per plane) whose fewest-ray pixels widen the window (`wide_until`).
    pub wide_planes: u32,
}

impl Default for VarianceParams {
    fn default() -> Self {
        VarianceParams {
            width: 0,
            height: 0,
            radius: 1,
            ao_planes: 0,
            spatial_until: 4.0,
            plane_scale: 0.01,
            normal_power: 128.0,
            ao_normal_power: 128.0,
            ao_spatial_until: 4.0,
            guide_plane: NO_PLANE,
            guide_scale: 0.0,
            wide_until: 0.0,
            wide_planes: 0,
        }
    }
}

/// One call per `N` consecutive pixels of a row and one signal plane ([`crate::lanes`]): writes
/// the estimate to `out` and folds it into the pixel's tile word in `tiles` (zeroed by the host
/// before; [`classify::tile_key`]).
#[inline(always)]
pub fn variance<const N: usize>(id: UVec3, p: &VarianceParams, io: VarianceIo<'_>) {
    let VarianceIo {
        payload,
        depth,
        normal_roughness,
        view,
        guide,
        out,
        tiles,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let f = estimate::<N>(id, p, payload, depth, normal_roughness, guide, &view[0]);
    let f = pack_filtered(f.map(|f| f.value), f.map(|f| f.variance));
    // The variance as stored, which is what the filter will read.
    let (_, stored_variance) = unpack_filtered(f);
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    f.store(out, plane_index(id, w, h), live);
    let cd = Lanes::<f32, N>::load_row(depth, id.y * w, id.x as i32, w);
    // Keys first, as vector code; 0 is no key ([`classify::tile_key`] is never 0).
    let keys = Lanes::<u32, N>::from_index(|l| {
        let l = l as usize;
        if live.0[l] && surface::has_surface(cd.0[l]) {
            classify::tile_key(stored_variance.0[l])
        } else {
            0
        }
    });
    // One atomic per tile the row of lanes crosses, with the largest key of its lanes, not one
    // per pixel: on the CPU each is a locked compare-and-swap loop.
    let (mut tile, mut key) = (classify::tile_index(id.x, id.y, w), 0);
    lanes::each_lane!(l in N {
        let t = classify::tile_index(id.x + l as u32, id.y, w);
        if t != tile {
            if key != 0 {
                atomic::max(&mut tiles[tile], key);
            }
            (tile, key) = (t, 0);
        }
        if keys.0[l] > key {
            key = keys.0[l];
        }
    });
    if key != 0 {
        atomic::max(&mut tiles[tile], key);
    }
}

/// Largest factor [`spatial_until_at`] scales by: the largest image it was measured at
/// (640x360) is 3x the default rows.
pub const MAX_SPATIAL_SCALE: f32 = 3.0;

/// `until` rays of spatial estimate (`filter.ao_spatial_until`) for an image `height` rows
/// tall: scaled by `height / rows`, between 1x and [`MAX_SPATIAL_SCALE`]; `rows` 0 keeps it.
pub fn spatial_until_at(until: f32, rows: u32, height: u32) -> f32 {
    if rows == 0 {
        return until;
    }
    until * math::clamp(height as f32 / rows as f32, 1.0, MAX_SPATIAL_SCALE)
}

/// The `(value, variance)` of each lane's pixel and plane `id.z` (module rule).
#[inline(always)]
fn estimate<const N: usize>(
    id: UVec3,
    p: &VarianceParams,
    payload: &[PackedPayload],
    depth: &[f32],
    normal_roughness: &[u32],
    guide: &[f32],
    view: &View,
) -> Lanes<Filtered, N> {
    let (w, h) = (p.width, p.height);
    let x0 = id.x as i32;
    let hist = Lanes::<PackedPayload, N>::load_row(payload, (id.z * h + id.y) * w, x0, w)
        .map(|q| q.unpack());
    let per_estimate = hist.map(|h| 1.0 / math::max(h.count, 1.0));
    let temporal = hist.zip(per_estimate, |h, per_estimate| Filtered {
        value: h.m1,
        variance: h.variance() * per_estimate,
    });
    let cd = Lanes::<f32, N>::load_row(depth, id.y * w, x0, w);
    let spatial_until = per_plane(p.spatial_until, p.ao_spatial_until, p.ao_planes, id.z);
    let young = hist.zip(cd, |h, cd| {
        !(h.count >= spatial_until) && surface::has_surface(cd)
    });
    if !young.any() {
        return temporal;
    }
    let n =
        Lanes::<u32, N>::load_row(normal_roughness, id.y * w, x0, w).map(packing::unpack_normal);
    let rays = PixelRays::new(&view.camera, w, h);
    let plane = Lanes::<TangentPlane, N>::from_index(|l| {
        let x = lanes::clamp_column(x0 + l as i32, w);
        let d = cd.0[l as usize];
        // Distances in units of the plane tolerance (as à-trous').
        TangentPlane::new(&rays, n.0[l as usize], x, id.y, d)
            .scaled(1.0 / math::max(p.plane_scale * d, 1e-12))
    });
    let guided = id.z == p.guide_plane;
    let wide_until = per_plane(0.0, p.wide_until, p.wide_planes, id.z);
    let c = WindowCentre {
        wide: hist.map(|h| h.count < wide_until),
        normal: n,
        plane,
        normal_power: per_plane(p.normal_power, p.ao_normal_power, p.ao_planes, id.z),
        guided,
        guide: guide_row::<N>(guide, guided, id.y * w, x0, w),
    };
    let [s1, s2, sw] = window_sums(id, p, &c, (payload, depth, normal_roughness, guide));
    Lanes::<Filtered, N>::from_index(|l| {
        let l = l as usize;
        let (h, s1, s2, sw) = (hist.0[l], s1.0[l], s2.0[l], sw.0[l]);
        let per_estimate = per_estimate.0[l];
        let (m1s, m2s) = (s1 / sw, s2 / sw);
        let spatial_var = math::max(m2s - m1s * m1s, 0.0);
        let t = math::saturate(h.count / spatial_until);
        let spatial = Filtered {
            value: math::lerp(m1s, h.m1, t),
            variance: math::lerp(spatial_var, h.variance(), t) * per_estimate,
        };
        if young.0[l] && !(sw <= 0.0) {
            spatial
        } else {
            temporal.0[l]
        }
    })
}

/// What the window's neighbours of `N` pixels are weighed against: the centres' unit normals,
/// tangent planes (distances in units of the plane tolerance), normal exponent and guides; and
/// which centres take the window one pixel wider (`wide_until`).
#[derive(Copy, Clone)]
struct WindowCentre<const N: usize> {
    normal: Lanes<Vec3, N>,
    plane: Lanes<TangentPlane, N>,
    normal_power: f32,
    guided: bool,
    guide: Lanes<f32, N>,
    wide: Lanes<bool, N>,
}

/// The spatial estimate's weighted sums over each lane's `(2r+1)²` window (`r + 1` for the lanes
/// in `wide`): first and second moments and weights, each neighbour counted by the rays it holds.
#[inline(always)]
fn window_sums<const N: usize>(
    id: UVec3,
    p: &VarianceParams,
    c: &WindowCentre<N>,
    (payload, depth, normal_roughness, guide): (&[PackedPayload], &[f32], &[u32], &[f32]),
) -> [Lanes<f32, N>; 3] {
    let WindowCentre {
        normal: n,
        plane,
        normal_power,
        guided,
        guide: cg,
        wide,
    } = *c;
    let (w, h) = (p.width, p.height);
    let x0 = id.x as i32;
    let inner = p.radius as i32;
    let r = if wide.any() { inner + 1 } else { inner };
    let mut s1 = Lanes::<f32, N>::splat(0.0);
    let mut s2 = s1;
    let mut sw = s1;
    let mut dy = -r;
    while dy <= r {
        let qy = id.y as i32 + dy;
        if qy >= 0 && qy < h as i32 {
            let (row, plane_row) = (qy as u32 * w, (id.z * h + qy as u32) * w);
            let mut dx = -r;
            while dx <= r {
                let qx0 = x0 + dx;
                let q = PayloadLanes::unpack(Lanes::load_row(payload, plane_row, qx0, w));
                let qd = Lanes::<f32, N>::load_row(depth, row, qx0, w);
                let u = Lanes::<u32, N>::load_row(normal_roughness, row, qx0, w);
                // The centre lies on its own plane: no plane term (its distance is 0 only
                // without fused multiply-adds, and its offset is 0).
                let per_offset = if dx == 0 && dy == 0 {
                    0.0
                } else {
                    1.0 / math::sqrt((dx * dx + dy * dy) as f32)
                };
                let w_n = surface::normal_weights(n, u, normal_power);
                let qg = guide_row::<N>(guide, guided, row, qx0, w);
                let wt = Lanes::<f32, N>::from_index(|l| {
                    let l = l as usize;
                    // Columns outside the image are never used below; clamped, they stay the
                    // finite values of some pixel.
                    let x = lanes::clamp_column(qx0 + l as i32, w);
                    let plane_e = plane.0[l].distance(x, qy as u32, qd.0[l]) * per_offset;
                    let e = plane_e + guide_exponent(cg.0[l], qg.0[l], p.guide_scale);
                    w_n.0[l] * math::exp(-e)
                });
                let valid = Lanes::<bool, N>::from_index(|l| {
                    let (l, qx) = (l as usize, qx0 + l as i32);
                    qx >= 0 && qx < w as i32 && q.count.0[l] > 0.0 && surface::has_surface(qd.0[l])
                });
                // Each neighbour counts by the rays it holds: a 1-ray pixel is one sample.
                let wt = if dx.abs() > inner || dy.abs() > inner {
                    wt.select(wide, Lanes::splat(0.0))
                } else {
                    wt
                };
                let wq = wt.zip(q.count, |w, c| w * c);
                s1 = s1.add_where(valid, wq.zip(q.m1, |w, m| w * m));
                s2 = s2.add_where(valid, wq.zip(q.m2, |w, m| w * m));
                sw = sw.add_where(valid, wq);
                dx += 1;
            }
        }
        dy += 1;
    }
    [s1, s2, sw]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::payload::{PackedFiltered, Payload};

    /// The estimate at the middle of a 5×5 wall facing the camera whose centre holds `count`
    /// rays of 0.5 and every other pixel one ray: 0.5 on the 3×3 ring, 1.0 on the outer one.
    fn middle_of_rings(count: f32, p: VarianceParams) -> Filtered {
        let camera = Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 0.9);
        let view = [View {
            camera,
            prev_camera: camera,
        }];
        let payload: std::vec::Vec<PackedPayload> = (0..25)
            .map(|i: i32| {
                let (x, y) = (i % 5 - 2, i / 5 - 2);
                let (m1, count) = match x.abs().max(y.abs()) {
                    0 => (0.5, count),
                    1 => (0.5, 1.0),
                    _ => (1.0, 1.0),
                };
                Payload {
                    m1,
                    m2: m1 * m1,
                    count,
                    rng_index: 0,
                }
                .pack()
            })
            .collect();
        let normals = std::vec![packing::pack_normal_roughness(Vec3::Z, 0.0); 25];
        let mut out = std::vec![PackedFiltered::default(); 25];
        let mut tiles = std::vec![0; 4];
        let io = VarianceIo {
            payload: &payload,
            depth: &[5.0; 25],
            normal_roughness: &normals,
            view: &view,
            guide: &[0.0],
            out: &mut out,
            tiles: &mut tiles,
        };
        let p = VarianceParams {
            width: 5,
            height: 5,
            spatial_until: 24.0,
            ..p
        };
        variance::<1>(UVec3::new(2, 2, 0), &p, io);
        out[12].unpack()
    }

    #[test]
    fn the_fewest_ray_pixels_take_the_wider_window() {
        let wide = VarianceParams {
            wide_until: 3.0,
            wide_planes: 1,
            ..Default::default()
        };
        // Two rays: the outer ring's 1.0 comes in.
        assert!(middle_of_rings(2.0, wide).value > 0.6);
        // Three rays, or a plane not in `wide_planes`: the 3×3 window alone, all 0.5.
        for (count, p) in [
            (3.0, wide),
            (
                2.0,
                VarianceParams {
                    wide_planes: 0b10,
                    ..wide
                },
            ),
        ] {
            let f = middle_of_rings(count, p);
            assert!((f.value - 0.5).abs() < 1e-3, "{count}: {}", f.value);
        }
    }

    #[test]
    fn the_spatial_estimate_lasts_longer_on_taller_images() {
        // As written up to `rows`, then with the height, up to the largest scale.
        assert_eq!(spatial_until_at(8.0, 120, 90), 8.0);
        assert_eq!(spatial_until_at(8.0, 120, 120), 8.0);
        assert_eq!(spatial_until_at(8.0, 120, 180), 12.0);
        assert_eq!(spatial_until_at(8.0, 120, 360), 24.0);
        assert_eq!(spatial_until_at(8.0, 120, 2160), 8.0 * MAX_SPATIAL_SCALE);
        // Rows 0: never scaled (SVGF's).
        assert_eq!(spatial_until_at(4.0, 0, 2160), 4.0);
    }
}
