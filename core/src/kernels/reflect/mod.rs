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
//! one where they disagree, as for AO). Try `k = 0` takes its two numbers from the pixel's
//! [`Stream`] ([`Stream::point_ld`]: the pixel's R2 sequence, [`low_discrepancy`](crate::sampling::low_discrepancy), seed: "low
//! discrepancy Halton sequence", or the screen-blue pattern), retries `k = 1..4` from hash
//! dimensions `2k, 2k+1`; each draws a visible normal ([`ggx_vndf`], the seed's
//! "future work", Heitz 2018) and reflects `ωo` about it. Directions under the geometric or
//! shading surface are regenerated (seed: "some rays go under the surface, we re-generate them");
//! after four failures the pixel's ray returns 0 with pdf 0.
//!
//! **Hit radiance** (simple direct lighting): a ray reaching a light before any triangle sees
//! `light_radiance` (two-sided emitters); a ray leaving the scene sees `sky`; a triangle hit is
//! a Lambertian surface of albedo `albedo` lit by `ambient` plus one light-sample per light
//! (hash dimensions `8 + 2l, 9 + 2l`) with a shadow ray: `albedo/π · Le · cos θ · |cos θ_l| · A / d²`.
//!
//! **Light probes.** Lights are small and bright (radiance 5 against surfaces near 0.3), so one
//! lobe direction in seventy that finds one carries nearly all of a 1-rpp frame's variance. Each
//! ray therefore also draws [`Shading::light_probes`] more lobe directions (hash dimensions
//! `16 + 8j + 2k, 17 + 8j + 2k`, the same tries as the ray) that only ask whether they reach a
//! light: an analytic test per light, and a shadow ray only for the few that do. The ray's value
//! is what its own direction hits *other than* a light, plus `light_radiance` times the fraction
//! of all its directions (its own included) that reach one. Both parts have the ray's own
//! expectation, so the estimate stays unbiased; the lights' part averages `1 + light_probes`
//! draws for the price of a few shadow rays.
//!
//! A ray is a pure function of `(stream, index, Surface, eye)`, so converged references are traced
//! by the same [`raygen_reflect`] and the denoiser's estimate must converge to them.

use super::pixel_index;
use super::raygen::{ray_origin, AreaLight, SHADOW_T_SHRINK};
use super::RaygenReflectIo;
use super::ReflectGuideIo;
use super::ReflectMotionIo;
use super::ReflectReuseIo;
use super::ReflectTilesIo;
use crate::camera::Camera;
use crate::math;
use crate::payload::Sample;
use crate::sampling::{
    ggx_reflection_pdf, ggx_vndf, parallelogram_point, pixel_seed, rand, reflect, Stream, MIN_ALPHA,
};
use crate::surface::{self, plane_distance, Surface};
use crate::trace::{self, normalize, BvhNode, Ray, Triangle};
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

/// Attempts at drawing a direction above the surface before the ray gives up.
pub const MAX_TRIES: u32 = 4;

/// Hit distance given to rays that leave the scene: far enough that their parallax is the sky's.
pub const MISS_DISTANCE: f32 = 1.0e4;

/// Most light probes per ray: a bound on the work of one ray, whatever the settings say.
pub const MAX_LIGHT_PROBES: u32 = 15;

/// First hash dimension of the light probes: after the ray's tries (2..8) and the hit's light
/// samples (`8 + 2l`, at most four lights).
const PROBE_DIMENSION: u32 = 16;

/// Side of the classification tiles in pixels (seed: "split screen in tiles").
pub const TILE: u32 = 16;

/// Tracer rays per tile (seed: "shoot tracer rays at 1/8th resolution": 4 per 16×16 tile is one
/// per 8×8 pixels).
pub const TRACERS: u32 = 4;

/// Signal plane of the tracer rays' random sequences: never a denoised plane, so tracers do not
/// repeat the rays they classify for.
pub const TRACER_PLANE: u32 = 0xffff;

/// What the reflection passes share: where the eye is and how hits are lit (48 bytes).
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
    /// Extra lobe directions per ray that only look for lights (module docs; at most
    /// [`MAX_LIGHT_PROBES`]; 0: the lights' part from the ray's own direction alone).
    pub light_probes: u32,
    /// Reserved.
    pub _pad: [u32; 3],
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
            light_probes: 7,
            _pad: [0; 3],
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
    /// `log2` of the hit distance (clamped to `[1e-4, MISS_DISTANCE]`), averaged over all the
    /// pixel's rays of the pass that drew a direction: [`reflect_guide`]'s input, steadier where
    /// a pixel traced several.
    pub log_distance: f32,
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

/// Distance along `ray` to the nearest of the scene's lights, or [`MISS_DISTANCE`].
#[inline]
fn nearest_light(ray: &Ray, scene: HitScene<'_>) -> f32 {
    let mut t_light = MISS_DISTANCE;
    let mut l = 0;
    while l < scene.light_count && (l as usize) < scene.lights.len() {
        t_light = math::min(
            t_light,
            light_distance(&scene.lights[l as usize], ray, t_light),
        );
        l += 1;
    }
    t_light
}

/// What `ray` sees: `(value, distance, reaches_light)`. A ray that reaches a light first has
/// value 0 here (the lights' part is counted by [`reflection_ray`] with its probes) and the
/// light's distance; otherwise the sky or the lit surface (hit-radiance rules in the module
/// docs). Light samples at a hit use dimensions `8 + 2l, 9 + 2l` of `(seed, index)`.
pub fn radiance(
    ray: &Ray,
    sh: &Shading,
    seed: u32,
    index: u32,
    scene: HitScene<'_>,
) -> (f32, f32, bool) {
    let HitScene {
        nodes,
        tris,
        lights,
        light_count,
    } = scene;
    let hit = trace::closest_hit(nodes, tris, ray, MISS_DISTANCE);
    let t_light = nearest_light(ray, scene);
    if t_light < hit.t {
        return (0.0, t_light, true);
    }
    if !hit.is_hit() {
        return (sh.sky, MISS_DISTANCE, false);
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
    (
        sh.albedo * core::f32::consts::FRAC_1_PI * irradiance,
        hit.t,
        false,
    )
}

/// True when `ray` reaches a light before any triangle: the analytic light test first, a shadow
/// ray only when it passes.
#[inline]
fn reaches_light(ray: &Ray, scene: HitScene<'_>) -> bool {
    let t_light = nearest_light(ray, scene);
    t_light < MISS_DISTANCE
        && !trace::occluded(
            scene.nodes,
            scene.tris,
            ray,
            t_light * (1.0 - SHADOW_T_SHRINK),
        )
}

/// Direction of reflection ray `index` of a lobe and its pdf, or `None` after [`MAX_TRIES`]
/// directions under the surface (`g` the geometric normal).
#[inline]
pub fn sample_direction(
    n: Vec3,
    g: Vec3,
    wo: Vec3,
    alpha: f32,
    stream: Stream,
    index: u32,
) -> Option<(Vec3, f32)> {
    let seed = stream.seed;
    let mut k = 0;
    while k < MAX_TRIES {
        let (u1, u2) = if k == 0 {
            stream.point_ld(index)
        } else {
            (rand(seed, index, 2 * k), rand(seed, index, 2 * k + 1))
        };
        if let Some(found) = try_direction(n, g, wo, alpha, u1, u2) {
            return Some(found);
        }
        k += 1;
    }
    None
}

/// Direction of light probe `j` of ray `index` ([`sample_direction`]'s tries, from hash
/// dimensions only).
#[inline]
fn probe_direction(
    n: Vec3,
    g: Vec3,
    wo: Vec3,
    alpha: f32,
    seed: u32,
    index: u32,
    j: u32,
) -> Option<Vec3> {
    let mut k = 0;
    while k < MAX_TRIES {
        let d = PROBE_DIMENSION + 8 * j + 2 * k;
        let (u1, u2) = (rand(seed, index, d), rand(seed, index, d + 1));
        if let Some((wi, _)) = try_direction(n, g, wo, alpha, u1, u2) {
            return Some(wi);
        }
        k += 1;
    }
    None
}

/// The lobe direction of one try from `(u1, u2)` and its pdf, or `None` under the surface.
#[inline]
fn try_direction(n: Vec3, g: Vec3, wo: Vec3, alpha: f32, u1: f32, u2: f32) -> Option<(Vec3, f32)> {
    let wi = reflect(wo, ggx_vndf(n, wo, alpha, u1, u2));
    if wi.dot(g) > 0.0 && wi.dot(n) > 0.0 {
        let pdf = ggx_reflection_pdf(n, wo, wi, alpha);
        if pdf > 0.0 && math::is_finite(pdf) {
            return Some((wi, pdf));
        }
    }
    None
}

/// Reflection ray `index` of surface `s`: its record (radiance, pdf, hit point, distance).
/// `pdf == 0` when the surface reflects nothing or no direction above it was found.
#[inline]
pub fn reflection_ray(
    s: &Surface,
    sh: &Shading,
    stream: Stream,
    index: u32,
    scene: HitScene<'_>,
) -> RayHit {
    let Some((n, wo, alpha)) = lobe(s, sh) else {
        return RayHit::default();
    };
    let Some((dir, pdf)) = sample_direction(n, s.geometric_normal(), wo, alpha, stream, index)
    else {
        return RayHit::default();
    };
    let origin = ray_origin(s);
    let ray = Ray { origin, dir };
    let (value, t, lit) = radiance(&ray, sh, stream.seed, index, scene);
    let probes = if sh.light_probes < MAX_LIGHT_PROBES {
        sh.light_probes
    } else {
        MAX_LIGHT_PROBES
    };
    let mut reached = if lit { 1.0 } else { 0.0 };
    let mut j = 0;
    while j < probes {
        let probe = probe_direction(n, s.geometric_normal(), wo, alpha, stream.seed, index, j);
        if let Some(dir) = probe {
            if reaches_light(&Ray { origin, dir }, scene) {
                reached += 1.0;
            }
        }
        j += 1;
    }
    let lights = sh.light_radiance * reached / (1 + probes) as f32;
    let hit = ray.origin + dir * t;
    RayHit {
        hx: hit.x,
        hy: hit.y,
        hz: hit.z,
        radiance: value + lights,
        pdf,
        distance: t,
        frame: 0,
        log_distance: math::log2(math::clamp(t, 1e-4, MISS_DISTANCE)),
    }
}

mod guide;
mod motion;
mod rays;
mod reuse;
mod tiles;

pub use guide::{reflect_guide, GuideParams, NO_GUIDE};
pub use motion::{reflect_motion, MotionParams};
pub use rays::{raygen_reflect, RaygenParams};
pub use reuse::{reflect_reuse, ReuseParams};
pub use tiles::{reflect_tiles, tile_grid, tile_index, TileParams};

#[cfg(all(test, feature = "std"))]
mod tests;
