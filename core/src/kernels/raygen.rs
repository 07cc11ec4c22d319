//! Ray generation for the denoised signals: ambient occlusion and area-light shadows.
//!
//! Each pixel traces `rays` rays whose random numbers come from its [`Stream`]: seed
//! [`pixel_seed`](crate::sampling::pixel_seed)`(x, y, z)` (`z` = signal plane), index
//! `rng_index[pixel, z] + i` for the `i`-th ray, and the first two numbers `(u1, u2)` from the
//! pattern the settings pick (`Stream::point`: the pixel's own sequence, or screen-space blue
//! noise of the pixel and frame). A ray is a pure function of `(stream, index, Surface)` —
//! [`ao_ray`] / [`shadow_ray`] — so the temporal-gradient pass can re-trace last frame's ray
//! exactly.
//!
//! The kernels run over the VRRT apply pass's compacted work list (dispatched indirectly from its
//! argument buffer): each entry is a pixel, which traces exactly the rays its entry carries per signal
//! plane, starting at the rng index its reprojected history carries — so accumulation, which
//! advances that index by the rays traced, never repeats a ray.
//!
//! Output per pixel and plane: [`Sample`] `{ m1 = mean(v), m2 = mean(v²), rays }` over the ray
//! values `v ∈ {0, 1}`. Sky pixels ([`NO_INSTANCE`]) trace nothing and write `rays = 0`.
//!
//! **Ray origin.** Every secondary ray starts at `position + g · ε`, `g` the (camera-facing)
//! geometric normal and `ε = RAY_OFFSET · max(1, |px|, |py|, |pz|)` with
//! [`RAY_OFFSET`] `= 1e-4`: a relative offset, because float spacing grows with the coordinates.
//!
//! **AO convention.** Random numbers `(u1, u2) = stream.point(index)`.
//! Normal `n` = the shading normal if `n · g > 0`, else `g`. Direction
//! `ω = cosine_hemisphere(n, u1, u2)` (Malley: `r = √u1`, `φ = 2π·u2`, basis of
//! [`orthonormal_basis`](crate::sampling::orthonormal_basis)). Value `1` (unoccluded) iff `ω · g > 0` and no triangle is hit with
//! `0 < t < max_distance` from the offset origin (`ω` is unit length, so `t` is a distance);
//! otherwise `0`. Directions below the geometric surface count as occluded. The expectation is
//! the cosine-weighted unoccluded fraction of the hemisphere within `max_distance`.
//!
//! **Shadow convention.** One rectangular (parallelogram) area light per signal plane:
//! `lights[z]`. Random numbers `(u1, u2) = stream.point(index)`; light
//! point `q = corner + u1·edge_u + u2·edge_v` (uniform in area). `d = q − o` from the offset
//! origin `o`, `dist = |d|`, `ω = d / dist`. Value `1` (visible) iff `ω · g > 0` and no triangle
//! is hit with `0 < t < dist · (1 − SHADOW_T_SHRINK)` ([`SHADOW_T_SHRINK`] `= 1e-4`, so geometry
//! touching the light does not shadow it); otherwise `0`. The light is two-sided, and the value
//! is pure visibility: **no** cosine, distance or area factor — the expectation is the fraction
//! of the light's area visible from the point (from above its geometric surface). Light geometry
//! is never in the BVH.

use super::work_list;
use super::RaygenAoIo;
use super::RaygenShadowIo;
use crate::math;
use crate::payload::Sample;
use crate::sampling::{cosine_hemisphere, parallelogram_point, Stream};
use crate::surface::{self, Surface, NO_INSTANCE};
use crate::trace::{self, normalize, BvhNode, Ray, Triangle};
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

/// Relative ray-origin offset along the geometric normal (see the module docs).
pub const RAY_OFFSET: f32 = 1e-4;

/// Shadow rays stop this fraction short of the light point.
pub const SHADOW_T_SHRINK: f32 = 1e-4;

/// A parallelogram area light (48 bytes): the points `corner + a·edge_u + b·edge_v`, `a, b ∈ [0,1]`.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AreaLight {
    /// Corner, x.
    pub corner_x: f32,
    /// Corner, y.
    pub corner_y: f32,
    /// Corner, z.
    pub corner_z: f32,
    /// First edge, x.
    pub edge_u_x: f32,
    /// First edge, y.
    pub edge_u_y: f32,
    /// First edge, z.
    pub edge_u_z: f32,
    /// Second edge, x.
    pub edge_v_x: f32,
    /// Second edge, y.
    pub edge_v_y: f32,
    /// Second edge, z.
    pub edge_v_z: f32,
    /// Reserved.
    pub _pad0: f32,
    /// Reserved.
    pub _pad1: f32,
    /// Reserved.
    pub _pad2: f32,
}

impl AreaLight {
    /// A light from its corner and edges.
    pub fn new(corner: Vec3, edge_u: Vec3, edge_v: Vec3) -> Self {
        AreaLight {
            corner_x: corner.x,
            corner_y: corner.y,
            corner_z: corner.z,
            edge_u_x: edge_u.x,
            edge_u_y: edge_u.y,
            edge_u_z: edge_u.z,
            edge_v_x: edge_v.x,
            edge_v_y: edge_v.y,
            edge_v_z: edge_v.z,
            _pad0: 0.0,
            _pad1: 0.0,
            _pad2: 0.0,
        }
    }
    /// Corner.
    #[inline]
    pub fn corner(&self) -> Vec3 {
        Vec3::new(self.corner_x, self.corner_y, self.corner_z)
    }
    /// First edge.
    #[inline]
    pub fn edge_u(&self) -> Vec3 {
        Vec3::new(self.edge_u_x, self.edge_u_y, self.edge_u_z)
    }
    /// Second edge.
    #[inline]
    pub fn edge_v(&self) -> Vec3 {
        Vec3::new(self.edge_v_x, self.edge_v_y, self.edge_v_z)
    }
}

/// Push constants of [`raygen_ao`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AoParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal planes traced per pixel (each with its own rng sequence).
    pub planes: u32,
    /// AO radius: occluders farther than this do not count.
    pub max_distance: f32,
    /// The work list traced: the plane group's (`apply`).
    pub list: u32,
    /// Frame index (the screen-blue pattern's temporal shift).
    pub frame: u32,
    /// [`crate::sampling::SamplePattern::code`] of the rays' first two random numbers.
    pub sampling: u32,
    /// Reserved.
    pub _pad: u32,
}

/// Push constants of [`raygen_shadow`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShadowParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Shadow planes: plane `first_plane + z` is the shadow of `lights[z]` (a plane without a
    /// light is unshadowed: value 1).
    pub planes: u32,
    /// The first shadow plane (other planes hold other signals).
    pub first_plane: u32,
    /// The work list traced: the plane group's (`apply`).
    pub list: u32,
    /// Frame index (the screen-blue pattern's temporal shift).
    pub frame: u32,
    /// [`crate::sampling::SamplePattern::code`] of the rays' first two random numbers.
    pub sampling: u32,
    /// The plane whose pixels' mean penumbra widths go to `blockers` (`NO_PLANE` for none):
    /// [`crate::kernels::penumbra`].
    pub blocker_plane: u32,
}

/// Origin of the secondary rays of `s`: its position pushed off the surface along `g`.
#[inline]
pub fn ray_origin(s: &Surface) -> Vec3 {
    let scale = math::max(
        1.0,
        math::max(math::abs(s.px), math::max(math::abs(s.py), math::abs(s.pz))),
    );
    s.position() + s.geometric_normal() * (RAY_OFFSET * scale)
}

/// Value of AO ray `index` of a pixel's `stream` (AO convention in the module docs).
pub fn ao_ray(
    s: &Surface,
    stream: Stream,
    index: u32,
    max_distance: f32,
    nodes: &[BvhNode],
    tris: &[Triangle],
) -> f32 {
    let g = s.geometric_normal();
    let ns = s.normal();
    let n = if ns.dot(g) > 0.0 { ns } else { g };
    let (u1, u2) = stream.point(index);
    let dir = cosine_hemisphere(n, u1, u2);
    if !(dir.dot(g) > 0.0) {
        return 0.0;
    }
    let ray = Ray {
        origin: ray_origin(s),
        dir,
    };
    if trace::occluded(nodes, tris, &ray, max_distance) {
        0.0
    } else {
        1.0
    }
}

/// Value of shadow ray `index` towards `light` (shadow convention in the module docs).
pub fn shadow_ray(
    s: &Surface,
    light: &AreaLight,
    stream: Stream,
    index: u32,
    nodes: &[BvhNode],
    tris: &[Triangle],
) -> f32 {
    shadow_ray_penumbra(s, light, stream, index, nodes, tris).0
}

/// Shadow ray `index` towards `light`: its value, and for a blocked ray the width of the
/// penumbra its blocker casts at the surface ([`penumbra_width`]; [`NO_BLOCKER`] for a visible
/// one, and for a light point behind the surface: the horizon is no blocker, and a width of 0
/// there kept the filter from blurring a curved surface where it turns from the light,
/// `docs/algorithms/penumbra-guide.md`).
pub fn shadow_ray_penumbra(
    s: &Surface,
    light: &AreaLight,
    stream: Stream,
    index: u32,
    nodes: &[BvhNode],
    tris: &[Triangle],
) -> (f32, f32) {
    let g = s.geometric_normal();
    let origin = ray_origin(s);
    let (u1, u2) = stream.point(index);
    let q = parallelogram_point(light.corner(), light.edge_u(), light.edge_v(), u1, u2);
    let d = q - origin;
    let dist = math::sqrt(d.dot(d));
    if !(dist > 0.0) {
        return (0.0, 0.0);
    }
    let dir = normalize(d);
    if !(dir.dot(g) > 0.0) {
        return (0.0, NO_BLOCKER);
    }
    let ray = Ray { origin, dir };
    let hit = trace::any_hit(nodes, tris, &ray, dist * (1.0 - SHADOW_T_SHRINK));
    if hit.is_hit() {
        (0.0, penumbra_width(light, hit.t, dist))
    } else {
        (1.0, NO_BLOCKER)
    }
}

/// The penumbra record of a pixel none of whose rays was blocked by geometry.
pub const NO_BLOCKER: f32 = -1.0;

/// Width (world units) of the penumbra a blocker `t` from the surface casts there, for a light
/// point `dist` away: `2R · t / (dist − t)`, `R` the radius of a disc of the light's area. What
/// the filter may blur across at this point without smearing the shadow's edge (SIGMA's
/// penumbra size).
#[inline]
pub fn penumbra_width(light: &AreaLight, t: f32, dist: f32) -> f32 {
    let area = light.edge_u().cross(light.edge_v()).length();
    let radius = math::sqrt(area * core::f32::consts::FRAC_1_PI);
    2.0 * radius * t / math::max(dist - t, 1e-3 * dist)
}

/// Folds ray values into a [`Sample`]: running sums of `v` and `v²`, divided by the count, and
/// the 0th ray's value `first`.
#[inline]
fn finish(sum: f32, sum_sq: f32, first: f32, rays: u32) -> Sample {
    if rays == 0 {
        return Sample::default();
    }
    let n = rays as f32;
    Sample {
        m1: sum / n,
        m2: sum_sq / n,
        rays,
        first,
    }
}

/// AO of one pixel: `rays` rays with indices `first_index ..`, as a [`Sample`].
pub fn ao_pixel(
    s: &Surface,
    stream: Stream,
    first_index: u32,
    rays: u32,
    max_distance: f32,
    nodes: &[BvhNode],
    tris: &[Triangle],
) -> Sample {
    if s.instance == NO_INSTANCE {
        return Sample::default();
    }
    let (mut sum, mut sum_sq, mut first) = (0.0f32, 0.0f32, 0.0f32);
    let mut i = 0u32;
    while i < rays {
        let v = ao_ray(
            s,
            stream,
            first_index.wrapping_add(i),
            max_distance,
            nodes,
            tris,
        );
        if i == 0 {
            first = v;
        }
        sum += v;
        sum_sq += v * v;
        i += 1;
    }
    finish(sum, sum_sq, first, rays)
}

/// Shadow of one pixel towards `light`: `rays` rays with indices `first_index ..`, and the mean
/// penumbra width of its blocked rays ([`NO_BLOCKER`] when none was).
pub fn shadow_pixel(
    s: &Surface,
    light: &AreaLight,
    stream: Stream,
    first_index: u32,
    rays: u32,
    nodes: &[BvhNode],
    tris: &[Triangle],
) -> (Sample, f32) {
    if s.instance == NO_INSTANCE {
        return (Sample::default(), NO_BLOCKER);
    }
    let (mut sum, mut sum_sq, mut first) = (0.0f32, 0.0f32, 0.0f32);
    let (mut width, mut blocked) = (0.0f32, 0.0f32);
    let mut i = 0u32;
    while i < rays {
        let (v, w) =
            shadow_ray_penumbra(s, light, stream, first_index.wrapping_add(i), nodes, tris);
        if i == 0 {
            first = v;
        }
        sum += v;
        sum_sq += v * v;
        if w != NO_BLOCKER {
            width += w;
            blocked += 1.0;
        }
        i += 1;
    }
    let penumbra = if blocked > 0.0 {
        width / blocked
    } else {
        NO_BLOCKER
    };
    (finish(sum, sum_sq, first, rays), penumbra)
}

/// The work-list entry of invocation `id`, if any: `(pixel index, rays)` ([`work_list::work_item`]);
/// none past the list's end or for an entry the refill lists had no room for
/// ([`super::work_list::SKIPPED`]).
#[inline]
pub(crate) fn work_item(
    id: UVec3,
    list: u32,
    pixels: u32,
    work: &[u32],
    args: &[u32],
) -> Option<(usize, u32)> {
    if id.x >= args[(list * work_list::ARGS_LEN) as usize] {
        return None;
    }
    let entry = work[(list * pixels + id.x) as usize];
    if entry == super::work_list::SKIPPED {
        return None;
    }
    Some(work_list::work_item(entry))
}

/// One invocation per work-list entry: AO samples of every plane of that pixel.
pub fn raygen_ao(id: UVec3, p: &AoParams, io: RaygenAoIo<'_>) {
    let RaygenAoIo {
        work,
        args,
        depth,
        normal_roughness,
        geometry,
        view,
        history,
        nodes,
        tris,
        out,
    } = io;
    let Some((pix, n)) = work_item(id, p.list, p.width * p.height, work, args) else {
        return;
    };
    let (x, y) = (pix as u32 % p.width, pix as u32 / p.width);
    let s = surface::load_with_hit(
        &view[0],
        pix,
        p.width,
        p.height,
        depth,
        normal_roughness,
        geometry,
    );
    let mut z = 0;
    while z < p.planes {
        let i = (z * p.width * p.height) as usize + pix;
        let first = history[i].rng_index();
        let stream = Stream::new(p.sampling, x, y, z, p.frame, first);
        out[i] = ao_pixel(&s, stream, first, n, p.max_distance, nodes, tris).pack();
        z += 1;
    }
}

/// One invocation per work-list entry: shadow samples of every light (plane) of that pixel.
pub fn raygen_shadow(id: UVec3, p: &ShadowParams, io: RaygenShadowIo<'_>) {
    let RaygenShadowIo {
        work,
        args,
        depth,
        normal_roughness,
        geometry,
        view,
        history,
        nodes,
        tris,
        lights,
        out,
        blockers,
    } = io;
    let Some((pix, n)) = work_item(id, p.list, p.width * p.height, work, args) else {
        return;
    };
    let (x, y) = (pix as u32 % p.width, pix as u32 / p.width);
    let s = surface::load_with_hit(
        &view[0],
        pix,
        p.width,
        p.height,
        depth,
        normal_roughness,
        geometry,
    );
    let mut z = 0;
    while z < p.planes {
        let plane = p.first_plane + z;
        let i = (plane * p.width * p.height) as usize + pix;
        let (sample, width) = if (z as usize) < lights.len() {
            shadow_pixel(
                &s,
                &lights[z as usize],
                Stream::new(p.sampling, x, y, plane, p.frame, history[i].rng_index()),
                history[i].rng_index(),
                n,
                nodes,
                tris,
            )
        } else if n > 0 && s.instance != NO_INSTANCE {
            let lit = Sample {
                m1: 1.0,
                m2: 1.0,
                rays: n,
                first: 1.0,
            };
            (lit, NO_BLOCKER)
        } else {
            (Sample::default(), NO_BLOCKER)
        };
        out[i] = sample.pack();
        if plane == p.blocker_plane {
            blockers[pix] = width;
        }
        z += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blocker_halfway_casts_a_penumbra_as_wide_as_the_light() {
        // A 2×2 light: a disc of its area has radius 2/√π.
        let light = AreaLight::new(Vec3::ZERO, Vec3::X * 2.0, Vec3::Z * 2.0);
        let diameter = 4.0 / core::f32::consts::PI.sqrt();
        assert!((penumbra_width(&light, 3.0, 6.0) - diameter).abs() < 1e-5);
        // A blocker on the surface casts a sharp edge; one near the light a wide penumbra.
        assert_eq!(penumbra_width(&light, 0.0, 6.0), 0.0);
        assert!(penumbra_width(&light, 5.9, 6.0) > 50.0 * diameter);
    }
}
