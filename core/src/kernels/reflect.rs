//! Glossy reflections (seed stochastic-ssr-frostbite-2015): GGX rays traced with the core BVH
//! instead of the screen-space hi-Z march, then the seed's pipeline around them.
//!
//! ```text
//! tiles (tracer rays → importance) ─► motion (parallax) ─► [denoiser: reproject … apply] ─► raygen ─► reuse ─► [accumulate …]
//! ```
//!
//! **Signal.** The reflection plane holds the GGX-lobe average of incoming radiance,
//! `E[L(ωi)]` with `ωi` drawn from the lobe the sampler uses: the split-sum convention (seed:
//! "weight normalization", and the reason its variance reduction may drop constant factors) —
//! the renderer multiplies by the directional albedo (the pre-integrated `F·G` term) when it
//! composites. Pixels rougher than `max_roughness` reflect nothing (value 0, no ray traced), sky
//! pixels have no signal.
//!
//! **Rays.** `ωo` points from the surface to the eye; `n` is the shading normal (the geometric
//! one where they disagree, as for AO). Try `k = 0` takes its two numbers from the pixel's R2
//! sequence ([`low_discrepancy`], seed: "low discrepancy Halton sequence"), retries `k = 1..4`
//! from hash dimensions `2k, 2k+1`; each draws a visible normal ([`ggx_vndf`], the seed's
//! "future work", Heitz 2018) and reflects `ωo` about it. Directions under the geometric or
//! shading surface are regenerated (seed: "some rays go under the surface, we re-generate them");
//! after four failures the pixel's ray returns 0 with pdf 0.
//!
//! **Hit radiance** (simple direct lighting): a ray reaching a light before any triangle sees
//! `light_radiance` (two-sided emitters); a ray leaving the scene sees `sky`; a triangle hit is
//! a Lambertian surface of albedo `albedo` lit by `ambient` plus one light-sample per light
//! (hash dimensions `8 + 2l, 9 + 2l`) with a shadow ray: `albedo/π · Le · cos θ · |cos θ_l| · A / d²`.
//!
//! A ray is a pure function of `(seed, index, Surface, eye)`, so converged references are traced
//! by the same [`raygen_reflect`] and the denoiser's estimate must converge to them.

use super::pixel_index;
use super::raygen::{ray_origin, AreaLight, SHADOW_T_SHRINK};
use super::RaygenReflectIo;
use super::ReflectMotionIo;
use super::ReflectReuseIo;
use super::ReflectTilesIo;
use crate::camera::Camera;
use crate::math;
use crate::payload::Sample;
use crate::sampling::{
    ggx_reflection_pdf, ggx_vndf, low_discrepancy, parallelogram_point, pixel_seed, rand, reflect,
    MIN_ALPHA,
};
use crate::surface::{plane_distance, Surface};
use crate::trace::{self, normalize, BvhNode, Ray, Triangle};
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

/// Attempts at drawing a direction above the surface before the ray gives up.
pub const MAX_TRIES: u32 = 4;

/// Hit distance given to rays that leave the scene: far enough that their parallax is the sky's.
pub const MISS_DISTANCE: f32 = 1.0e4;

/// Side of the classification tiles in pixels (seed: "split screen in tiles").
pub const TILE: u32 = 16;

/// Tracer rays per tile (seed: "shoot tracer rays at 1/8th resolution": 4 per 16×16 tile is one
/// per 8×8 pixels).
pub const TRACERS: u32 = 4;

/// Signal plane of the tracer rays' random sequences: never a denoised plane, so tracers do not
/// repeat the rays they classify for.
pub const TRACER_PLANE: u32 = 0xffff;

/// What the reflection passes share: where the eye is and how hits are lit (32 bytes).
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Pod, Zeroable)]
pub struct Shading {
    /// Eye position, x.
    pub eye_x: f32,
    /// Eye position, y.
    pub eye_y: f32,
    /// Eye position, z.
    pub eye_z: f32,
    /// Surfaces with a larger GGX alpha reflect nothing (no ray).
    pub max_roughness: f32,
    /// Radiance of the area lights seen directly.
    pub light_radiance: f32,
    /// Albedo of every surface a reflection ray hits.
    pub albedo: f32,
    /// Radiance of rays that leave the scene.
    pub sky: f32,
    /// Constant ambient irradiance term at hits (times `albedo`).
    pub ambient: f32,
}

impl Default for Shading {
    fn default() -> Self {
        Shading {
            eye_x: 0.0,
            eye_y: 0.0,
            eye_z: 0.0,
            max_roughness: 0.5,
            light_radiance: 5.0,
            albedo: 0.7,
            sky: 0.3,
            ambient: 0.1,
        }
    }
}

impl Shading {
    /// Eye position.
    #[inline]
    pub fn eye(&self) -> Vec3 {
        Vec3::new(self.eye_x, self.eye_y, self.eye_z)
    }
}

/// One reflection ray's record (32 bytes): what [`reflect_reuse`] lends to neighbours and
/// [`reflect_motion`] reads the reflection depth from.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RayHit {
    /// Hit point (or `origin + MISS_DISTANCE · ω` for a miss), x.
    pub hx: f32,
    /// Hit point, y.
    pub hy: f32,
    /// Hit point, z.
    pub hz: f32,
    /// Radiance the ray returned.
    pub radiance: f32,
    /// Density the direction was drawn with (0: no ray, the record is not to be used).
    pub pdf: f32,
    /// Distance from the ray origin to the hit.
    pub distance: f32,
    /// Frame index the ray was traced in: records of other frames are stale.
    pub frame: u32,
    /// Reserved.
    pub _pad: u32,
}

impl RayHit {
    /// Hit point.
    #[inline]
    pub fn point(&self) -> Vec3 {
        Vec3::new(self.hx, self.hy, self.hz)
    }
    /// True when the record holds a ray traced in frame `frame`.
    #[inline]
    pub fn is_from(&self, frame: u32) -> bool {
        self.frame == frame && self.pdf > 0.0
    }
}

/// The lobe of a surface seen from the eye: `(n, ωo, alpha)`, or `None` when the surface
/// reflects nothing (sky, rougher than `max_roughness`, or seen from behind).
#[inline]
pub fn lobe(s: &Surface, sh: &Shading) -> Option<(Vec3, Vec3, f32)> {
    if !s.is_valid() || !(s.roughness <= sh.max_roughness) {
        return None;
    }
    let g = s.geometric_normal();
    let ns = s.normal();
    let wo = normalize(sh.eye() - s.position());
    let n = if ns.dot(g) > 0.0 && ns.dot(wo) > 0.0 {
        ns
    } else {
        g
    };
    if !(n.dot(wo) > 0.0) {
        return None;
    }
    Some((n, wo, math::max(s.roughness, MIN_ALPHA)))
}

/// Distance along `ray` to the parallelogram light `l` (two-sided), or `t_max` when missed.
#[inline]
pub fn light_distance(l: &AreaLight, ray: &Ray, t_max: f32) -> f32 {
    let nl = l.edge_u().cross(l.edge_v());
    let denom = ray.dir.dot(nl);
    if !(math::abs(denom) > 0.0) {
        return t_max;
    }
    let t = (l.corner() - ray.origin).dot(nl) / denom;
    if !(t > 0.0 && t < t_max) {
        return t_max;
    }
    let q = ray.origin + ray.dir * t - l.corner();
    let inv = 1.0 / nl.dot(nl);
    let a = q.cross(l.edge_v()).dot(nl) * inv;
    let b = l.edge_u().cross(q).dot(nl) * inv;
    // Plain comparisons: the same instructions on every target.
    #[allow(clippy::manual_range_contains)]
    let inside = a >= 0.0 && a <= 1.0 && b >= 0.0 && b <= 1.0;
    if inside {
        t
    } else {
        t_max
    }
}

/// What reflection rays hit and light: the BVH and the first `light_count` area lights.
#[derive(Copy, Clone)]
pub struct HitScene<'a> {
    /// BVH nodes.
    pub nodes: &'a [BvhNode],
    /// BVH triangles.
    pub tris: &'a [Triangle],
    /// Area lights.
    pub lights: &'a [AreaLight],
    /// Lights in use.
    pub light_count: u32,
}

/// Radiance along `ray` and the distance it travelled (hit-radiance rules in the module docs);
/// light samples use dimensions `8 + 2l, 9 + 2l` of `(seed, index)`.
pub fn radiance(ray: &Ray, sh: &Shading, seed: u32, index: u32, scene: HitScene<'_>) -> (f32, f32) {
    let HitScene {
        nodes,
        tris,
        lights,
        light_count,
    } = scene;
    let hit = trace::closest_hit(nodes, tris, ray, MISS_DISTANCE);
    let mut t_light = MISS_DISTANCE;
    let mut l = 0;
    while l < light_count && (l as usize) < lights.len() {
        t_light = math::min(t_light, light_distance(&lights[l as usize], ray, t_light));
        l += 1;
    }
    if t_light < hit.t {
        return (sh.light_radiance, t_light);
    }
    if !hit.is_hit() {
        return (sh.sky, MISS_DISTANCE);
    }
    let tri = tris[hit.tri as usize];
    let mut g = tri.face_normal();
    if g.dot(ray.dir) > 0.0 {
        g = -g;
    }
    let p = ray.origin + ray.dir * hit.t;
    let scale = math::max(
        1.0,
        math::max(math::abs(p.x), math::max(math::abs(p.y), math::abs(p.z))),
    );
    let origin = p + g * (super::raygen::RAY_OFFSET * scale);
    let mut irradiance = sh.ambient;
    let mut l = 0;
    while l < light_count && (l as usize) < lights.len() {
        let light = lights[l as usize];
        let q = parallelogram_point(
            light.corner(),
            light.edge_u(),
            light.edge_v(),
            rand(seed, index, 8 + 2 * l),
            rand(seed, index, 9 + 2 * l),
        );
        let d = q - origin;
        let dist2 = d.dot(d);
        let dir = normalize(d);
        let cos_p = dir.dot(g);
        if dist2 > 0.0 && cos_p > 0.0 {
            let dist = math::sqrt(dist2);
            let shadow = Ray { origin, dir };
            if !trace::occluded(nodes, tris, &shadow, dist * (1.0 - SHADOW_T_SHRINK)) {
                let cos_l_area = math::abs(dir.dot(light.edge_u().cross(light.edge_v())));
                irradiance += sh.light_radiance * cos_p * cos_l_area / dist2;
            }
        }
        l += 1;
    }
    (sh.albedo * core::f32::consts::FRAC_1_PI * irradiance, hit.t)
}

/// Direction of reflection ray `index` of a lobe and its pdf, or `None` after [`MAX_TRIES`]
/// directions under the surface (`g` the geometric normal).
#[inline]
pub fn sample_direction(
    n: Vec3,
    g: Vec3,
    wo: Vec3,
    alpha: f32,
    seed: u32,
    index: u32,
) -> Option<(Vec3, f32)> {
    let mut k = 0;
    while k < MAX_TRIES {
        let (u1, u2) = if k == 0 {
            low_discrepancy(seed, index)
        } else {
            (rand(seed, index, 2 * k), rand(seed, index, 2 * k + 1))
        };
        let wi = reflect(wo, ggx_vndf(n, wo, alpha, u1, u2));
        if wi.dot(g) > 0.0 && wi.dot(n) > 0.0 {
            let pdf = ggx_reflection_pdf(n, wo, wi, alpha);
            if pdf > 0.0 && math::is_finite(pdf) {
                return Some((wi, pdf));
            }
        }
        k += 1;
    }
    None
}

/// Reflection ray `index` of surface `s`: its record (radiance, pdf, hit point, distance).
/// `pdf == 0` when the surface reflects nothing or no direction above it was found.
pub fn reflection_ray(
    s: &Surface,
    sh: &Shading,
    seed: u32,
    index: u32,
    scene: HitScene<'_>,
) -> RayHit {
    let Some((n, wo, alpha)) = lobe(s, sh) else {
        return RayHit::default();
    };
    let Some((dir, pdf)) = sample_direction(n, s.geometric_normal(), wo, alpha, seed, index) else {
        return RayHit::default();
    };
    let ray = Ray {
        origin: ray_origin(s),
        dir,
    };
    let (value, t) = radiance(&ray, sh, seed, index, scene);
    let hit = ray.origin + dir * t;
    RayHit {
        hx: hit.x,
        hy: hit.y,
        hz: hit.z,
        radiance: value,
        pdf,
        distance: t,
        frame: 0,
        _pad: 0,
    }
}

/// Push constants of [`raygen_reflect`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RaygenParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal plane the reflections are written to (the other planes are left alone).
    pub plane: u32,
    /// Lights in `lights` to use.
    pub lights: u32,
    /// Frame index stamped into the ray records.
    pub frame: u32,
    /// Reserved.
    pub _pad: [u32; 3],
    /// Eye and hit lighting.
    pub shading: Shading,
}

/// One invocation per work-list entry (like `raygen::raygen_ao`): `rays[pixel]` reflection rays
/// from the rng index the reprojected history carries, their [`Sample`] in plane `plane`, and the
/// 0th ray's record in `hits` (stamped with `frame`). A surface that reflects nothing gets value 0
/// for its rays without tracing, so its history fills like any other plane's.
pub fn raygen_reflect(id: UVec3, p: &RaygenParams, io: RaygenReflectIo<'_>) {
    let RaygenReflectIo {
        work,
        args,
        rays,
        surfaces,
        history,
        nodes,
        tris,
        lights,
        out,
        hits,
    } = io;
    let scene = HitScene {
        nodes,
        tris,
        lights,
        light_count: p.lights,
    };
    if id.x >= args[0] {
        return;
    }
    let pix = work[id.x as usize] as usize;
    let n = rays[pix];
    let s = surfaces[pix];
    let i = (p.plane * p.width * p.height) as usize + pix;
    let (x, y) = (pix as u32 % p.width, pix as u32 / p.width);
    let seed = pixel_seed(x, y, p.plane);
    let first_index = history[i].rng_index;
    let (mut sum, mut sum_sq, mut first) = (0.0f32, 0.0f32, 0.0f32);
    let mut record = RayHit::default();
    let mut k = 0u32;
    while k < n && s.is_valid() {
        let r = reflection_ray(&s, &p.shading, seed, first_index.wrapping_add(k), scene);
        let v = if r.pdf > 0.0 { r.radiance } else { 0.0 };
        if k == 0 {
            first = v;
            record = r;
        }
        sum += v;
        sum_sq += v * v;
        k += 1;
    }
    record.frame = p.frame;
    hits[pix] = record;
    out[i] = if n == 0 || !s.is_valid() {
        Sample::default()
    } else {
        let nf = n as f32;
        Sample {
            m1: sum / nf,
            m2: sum_sq / nf,
            rays: n,
            first,
        }
    };
}

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
        surfaces,
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
            let s = surfaces[pixel_index(x, y, p.width)];
            let r = reflection_ray(
                &s,
                &p.shading,
                pixel_seed(x, y, TRACER_PLANE),
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

/// Push constants of [`reflect_motion`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MotionParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Frame index of the records to read (last frame's).
    pub frame: u32,
    /// Window radius over which the reflection depth is averaged (seed: "average from local rays").
    pub radius: u32,
    /// This frame's eye, x.
    pub eye_x: f32,
    /// This frame's eye, y.
    pub eye_y: f32,
    /// This frame's eye, z.
    pub eye_z: f32,
    /// Surfaces with a larger GGX alpha keep the surface motion.
    pub max_roughness: f32,
    /// Last frame's camera.
    pub prev_camera: Camera,
}

/// Reflection parallax (seed: "reprojection along G-buffer depth smears; add reflection depth"),
/// one invocation per pixel: the reflected image lies `d` behind the surface along the view ray,
/// `d` the mean hit distance of last frame's records within `radius` of where the surface was.
/// That virtual point, carried by the surface's own motion, projected with last frame's camera is
/// where the reflection was: `motion[pixel] = (x, y)` in last frame's pixels. Pixels without a
/// reflecting surface or a nearby record keep the surface motion.
pub fn reflect_motion(id: UVec3, p: &MotionParams, io: ReflectMotionIo<'_>) {
    let ReflectMotionIo {
        surfaces,
        hits,
        motion,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let pix = pixel_index(id.x, id.y, p.width);
    let s = surfaces[pix];
    let mut out = [s.prev_x, s.prev_y];
    let (cx, cy) = (math::floor(s.prev_x + 0.5), math::floor(s.prev_y + 0.5));
    // A moving reflector's image does not follow a fixed virtual point: keep its surface motion.
    let reflective =
        s.is_valid() && s.roughness <= p.max_roughness && s.prev_position() == s.position();
    if reflective && math::is_finite(cx) && math::is_finite(cy) {
        let r = p.radius as i32;
        let (mut sum, mut n) = (0.0f32, 0.0f32);
        let mut dy = -r;
        while dy <= r {
            let mut dx = -r;
            while dx <= r {
                let (qx, qy) = (cx + dx as f32, cy + dy as f32);
                if qx >= 0.0 && qy >= 0.0 && qx < p.width as f32 && qy < p.height as f32 {
                    let h = hits[pixel_index(qx as u32, qy as u32, p.width)];
                    if h.is_from(p.frame) && h.distance < MISS_DISTANCE {
                        sum += h.distance;
                        n += 1.0;
                    }
                }
                dx += 1;
            }
            dy += 1;
        }
        if n > 0.0 {
            let eye = Vec3::new(p.eye_x, p.eye_y, p.eye_z);
            let view = normalize(s.position() - eye);
            let virtual_prev = s.prev_position() + view * (sum / n);
            let (x, y) = p.prev_camera.project_point(virtual_prev, p.width, p.height);
            out = [x, y];
        }
    }
    motion[pix] = out;
}

/// Push constants of [`reflect_reuse`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ReuseParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal plane of the reflections in `samples`.
    pub plane: u32,
    /// Frame index of the records to reuse (this frame's).
    pub frame: u32,
    /// Neighbourhood radius in pixels (0 = no reuse).
    pub radius: u32,
    /// A neighbour whose point lies farther than this fraction of view depth off the pixel's
    /// tangent plane is another surface (its visibility differs): not reused.
    pub plane_threshold: f32,
    /// Reserved.
    pub _pad: [u32; 2],
    /// Eye and roughness cut-off.
    pub shading: Shading,
}

/// Ray reuse (seed: "hit point reuse across neighbors", "variance reduction for ray reuse"), one
/// invocation per pixel: the pixel's own rays (weight 1 each) plus the 0th ray of every
/// neighbour within `radius` that traced this frame, on the same surface. A neighbour's hit is
/// seen from this pixel in direction `ω = normalize(hit − origin)`; its weight is this pixel's
/// lobe density at `ω` over the density the neighbour drew its ray with, and the moments are
/// normalised by the weight sum — the seed's `localBrdf / hitPdf … / weightSum`, self-normalised
/// importance sampling with the neighbours as proposal distributions. A pixel that traced nothing
/// but receives neighbours' rays counts them as one ray, so sparse tracing still yields a full
/// resolution estimate.
pub fn reflect_reuse(id: UVec3, p: &ReuseParams, io: ReflectReuseIo<'_>) {
    let ReflectReuseIo {
        surfaces,
        hits,
        samples,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let pix = pixel_index(id.x, id.y, p.width);
    let i = (p.plane * p.width * p.height) as usize + pix;
    let s = surfaces[pix];
    let Some((n, wo, alpha)) = lobe(&s, &p.shading) else {
        return;
    };
    let own = samples[i];
    let own_rays = own.rays as f32;
    let (mut w_sum, mut s1, mut s2) = (own_rays, own.m1 * own_rays, own.m2 * own_rays);
    let origin = ray_origin(&s);
    let g = s.geometric_normal();
    let r = p.radius as i32;
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let (qx, qy) = (id.x as i32 + dx, id.y as i32 + dy);
            let inside = qx >= 0 && qy >= 0 && qx < p.width as i32 && qy < p.height as i32;
            if inside && (dx != 0 || dy != 0) {
                let q = pixel_index(qx as u32, qy as u32, p.width);
                let h = hits[q];
                let same = plane_distance(
                    s.position(),
                    s.geometric_normal(),
                    surfaces[q].position(),
                    p.plane_threshold * s.depth,
                ) <= 1.0;
                if h.is_from(p.frame) && same {
                    let dir = normalize(h.point() - origin);
                    let local = if dir.dot(g) > 0.0 {
                        ggx_reflection_pdf(n, wo, dir, alpha)
                    } else {
                        0.0
                    };
                    let w = local / h.pdf;
                    if w > 0.0 && math::is_finite(w) {
                        w_sum += w;
                        s1 += w * h.radiance;
                        s2 += w * h.radiance * h.radiance;
                    }
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    if w_sum > own_rays && w_sum > 0.0 {
        samples[i] = Sample {
            m1: s1 / w_sum,
            m2: s2 / w_sum,
            rays: if own.rays == 0 { 1 } else { own.rays },
            first: own.first,
        };
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    fn empty_scene(lights: &[AreaLight], light_count: u32) -> HitScene<'_> {
        HitScene {
            nodes: &[],
            tris: &[],
            lights,
            light_count,
        }
    }

    fn floor_surface(roughness: f32) -> Surface {
        Surface {
            py: 0.0,
            depth: 3.0,
            ny: 1.0,
            gy: 1.0,
            roughness,
            instance: 0,
            ..Surface::default()
        }
    }

    #[test]
    fn light_distance_hits_inside_and_misses_outside() {
        let l = AreaLight::new(Vec3::new(-1.0, 2.0, -1.0), Vec3::X * 2.0, Vec3::Z * 2.0);
        let up = Ray {
            origin: Vec3::ZERO,
            dir: Vec3::Y,
        };
        assert!((light_distance(&l, &up, 100.0) - 2.0).abs() < 1e-6);
        let aside = Ray {
            origin: Vec3::new(1.5, 0.0, 0.0),
            dir: Vec3::Y,
        };
        assert_eq!(light_distance(&l, &aside, 100.0), 100.0);
        let down = Ray {
            origin: Vec3::ZERO,
            dir: -Vec3::Y,
        };
        assert_eq!(light_distance(&l, &down, 100.0), 100.0);
    }

    #[test]
    fn rays_stay_above_the_surface_and_rough_surfaces_reflect_nothing() {
        let sh = Shading {
            eye_x: 0.0,
            eye_y: 0.3,
            eye_z: 3.0,
            ..Shading::default()
        };
        let s = floor_surface(0.3);
        let (n, wo, alpha) = lobe(&s, &sh).expect("glossy floor reflects");
        let seed = pixel_seed(1, 2, 0);
        let mut found = 0;
        for i in 0..2000 {
            if let Some((d, pdf)) = sample_direction(n, n, wo, alpha, seed, i) {
                assert!(d.y > 0.0 && pdf > 0.0);
                found += 1;
            }
        }
        // Grazing view, alpha 0.3: retries find a direction above the floor almost always.
        assert!(found > 1990, "{found}");
        assert!(lobe(&floor_surface(0.9), &sh).is_none());
        let lone = reflection_ray(&floor_surface(0.9), &sh, seed, 0, empty_scene(&[], 0));
        assert_eq!(lone.pdf, 0.0);
    }

    #[test]
    fn empty_scene_reflects_the_sky_and_the_light() {
        let sh = Shading {
            eye_x: 0.0,
            eye_y: 2.0,
            eye_z: 2.0,
            ..Shading::default()
        };
        let s = floor_surface(0.05);
        let light = AreaLight::new(
            Vec3::new(-50.0, 10.0, -60.0),
            Vec3::X * 100.0,
            Vec3::Z * 55.0,
        );
        let seed = pixel_seed(0, 0, 0);
        let sky = reflection_ray(&s, &sh, seed, 3, empty_scene(&[light], 0));
        assert_eq!((sky.radiance, sky.distance), (sh.sky, MISS_DISTANCE));
        // The mirror direction from (0,2,2) off the origin points up and away (−z): the light.
        let lit = reflection_ray(&s, &sh, seed, 3, empty_scene(&[light], 1));
        assert_eq!(lit.radiance, sh.light_radiance);
        assert!((lit.point().y - 10.0).abs() < 1e-3);
    }
}
