//! The reflection rays of the work list: one record per ray, its sample in the reflection plane.

use super::*;

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
    /// Frame index stamped into the ray records (and the screen-blue pattern's temporal shift).
    pub frame: u32,
    /// The work list traced: the plane group's (`apply`).
    pub list: u32,
    /// [`crate::sampling::SamplePattern::code`] of the rays' first two random numbers.
    pub sampling: u32,
    /// Nonzero: the rays add to the pixel's sample and record instead of replacing them (the
    /// refill lists' pass: a fresh pixel keeps its first ray and its neighbours' reused ones,
    /// and the new rays continue its sequence).
    pub merge: u32,
    /// Eye and hit lighting.
    pub shading: Shading,
}

/// One invocation per work-list entry (like `raygen::raygen_ao`): the entry's reflection rays
/// from the rng index the reprojected history carries, their [`Sample`] in plane `plane`, and the
/// 0th ray's record in `hits` (stamped with `frame`, with the mean `log_distance` of all of
/// them). A surface that reflects nothing gets value 0 for its rays without tracing, so its
/// history fills like any other plane's.
pub fn raygen_reflect(id: UVec3, p: &RaygenParams, io: RaygenReflectIo<'_>) {
    let RaygenReflectIo {
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
        hits,
    } = io;
    let scene = HitScene {
        nodes,
        tris,
        lights,
        light_count: p.lights,
    };
    let Some((pix, n)) =
        crate::kernels::raygen::work_item(id, p.list, p.width * p.height, work, args)
    else {
        return;
    };
    let i = (p.plane * p.width * p.height) as usize + pix;
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
    let prior = if p.merge != 0 {
        out[i].unpack()
    } else {
        Sample::default()
    };
    let start = history[i].rng_index();
    let first_index = start.wrapping_add(prior.rays);
    let stream = Stream::new(p.sampling, x, y, p.plane, p.frame, start);
    let (mut sum, mut sum_sq, mut first) = (0.0f32, 0.0f32, 0.0f32);
    let mut record = RayHit::default();
    let (mut log_sum, mut drawn) = (0.0f32, 0.0f32);
    let mut k = 0u32;
    while k < n && s.is_valid() {
        let r = reflection_ray(&s, &p.shading, stream, first_index.wrapping_add(k), scene);
        let v = if r.pdf > 0.0 { r.radiance } else { 0.0 };
        if k == 0 {
            first = v;
            record = r;
        }
        if r.pdf > 0.0 {
            log_sum += r.log_distance;
            drawn += 1.0;
        }
        sum += v;
        sum_sq += v * v;
        k += 1;
    }
    if prior.rays > 0 && s.is_valid() {
        // The pixel's first ray and its record stay; the new rays join its moments and its mean
        // hit distance as if traced with it.
        let old = prior.rays as f32;
        let mut kept = hits[pix];
        if drawn > 0.0 {
            kept.log_distance = (kept.log_distance * old + log_sum) / (old + drawn);
        }
        hits[pix] = kept;
        let total = old + n as f32;
        out[i] = Sample {
            m1: (prior.m1 * old + sum) / total,
            m2: (prior.m2 * old + sum_sq) / total,
            rays: prior.rays + n,
            first: prior.first,
        }
        .pack();
        return;
    }
    record.frame = p.frame;
    if drawn > 0.0 {
        record.log_distance = log_sum / drawn;
    }
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
    }
    .pack();
}
