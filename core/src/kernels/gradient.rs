//! Temporal gradients (A-SVGF, Schied 2018) as a low-resolution prepass before reprojection.
//!
//! Seed: vrrt-call-of-duty-2026, "Temporal gradients in Call of Duty" (`forwardProjection`), and
//! ALGORITHMS.md "Temporal gradients (A-SVGF)". The image is cut into strata of `S × S` pixels
//! (`S` = `gradient_stratum`, 3..=8); the gradient image has one cell per stratum. Three passes:
//!
//! 1. [`project`] (one invocation per stratum): picks one *previous-frame* pixel of the stratum at
//!    random (hash of stratum and frame), only among pixels that traced last frame (their sample's `rays > 0`:
//!    with undersampling most pixels did not). Its previous surface is carried forward by its
//!    instance's previous→current map ([`move_surface`]; `InstanceData` inverted on the host) and
//!    projected with the current camera. The sample survives the occlusion test when the current
//!    G-buffer at the nearest pixel shows the same instance, a similar normal and the moved point
//!    on its tangent plane. Several strata may land in the same gradient cell: each writes a packed
//!    key `(hash(pixel, frame) high bits) | previous pixel index` with an atomic *min*, so the
//!    winner is a pure function of the inputs and every backend picks the same one (never "last
//!    writer wins"). The hash in the high bits keeps the winner unbiased across the cell.
//! 2. [`retrace_ao`] / [`retrace_shadow`] (one invocation per cell): decodes the winner and
//!    re-traces *last frame's 0th ray of that pixel*: same stream (`Stream::new` of the previous
//!    pixel and last frame's index and pattern), same rng index (the one raygen started from:
//!    last frame's accumulated `rng_index` less the rays it traced),
//!    same origin/direction derivation ([`ao_ray`] / [`shadow_ray`]) from the moved surface, but
//!    against the current scene (geometry, lights). It is compared with last frame's value of that
//!    ray, which raygen kept in [`crate::payload::Sample::first`]. Output per cell and plane: `|curr − prev|` and
//!    `max(curr, prev)` ([`GradientSample`]); `λ = |curr − prev| / max(curr, prev)`.
//! 3. [`atrous`]: à-trous blur of both channels at cell resolution, **without** bilateral weights
//!    (seed: "better overestimate than underestimate"; VRRT supersamples what it flags). `λ` is
//!    taken after the blur as the ratio of the blurred channels, as A-SVGF normalizes it.
//!
//! Static scenes re-trace bit-identical rays (the identity map reproduces the surface exactly), so
//! `λ = 0` there: no false positives from noise.

use super::gbuffer::InstanceData;
use super::pixel_index;
use super::raygen::{ao_ray, shadow_ray};
use super::GradientAoIo;
use super::GradientAtrousIo;
use super::GradientProjectIo;
use super::GradientShadowIo;
use crate::atomic;
use crate::camera::Camera;
use crate::camera::View;
use crate::math;
use crate::payload::{PackedPayload, PackedSample};
use crate::sampling::Stream;
use crate::sequence::pcg_hash;
use crate::surface::{self, Surface};
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Key of a gradient cell no sample reached (the fill value before [`project`]).
pub const EMPTY_KEY: u32 = u32::MAX;

/// One gradient cell of one plane: the (blurred) absolute change and the (blurred) brightness it
/// is relative to.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GradientSample {
    /// `|curr − prev|` of the re-traced ray (0 where the cell has no sample).
    pub delta: f32,
    /// `max(curr, prev)` (0 where the cell has no sample).
    pub luminance: f32,
}

impl GradientSample {
    /// The normalized gradient `λ = delta / luminance` in `[0, 1]`; 0 when both are 0.
    #[inline]
    pub fn lambda(&self) -> f32 {
        if self.luminance > 0.0 {
            math::clamp(self.delta / self.luminance, 0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// Push constants of [`project`] (88 bytes).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ProjectParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Stratum size `S` in pixels.
    pub stratum: u32,
    /// Gradient cells per row: `width.div_ceil(S)`.
    pub grid_width: u32,
    /// Gradient cell rows: `height.div_ceil(S)`.
    pub grid_height: u32,
    /// Frame number: varies the chosen pixel of each stratum.
    pub frame_index: u32,
    /// Low bits of a key that hold the pixel index ([`index_mask`]).
    pub index_mask: u32,
    /// Occlusion test: minimum cosine between the moved and the current normal.
    pub normal_threshold: f32,
    /// Occlusion test: maximum distance of the moved point from the current tangent plane, as a
    /// fraction of view depth.
    pub plane_threshold: f32,
    /// This frame's camera.
    pub camera: Camera,
}

/// Push constants of [`retrace_ao`] and [`retrace_shadow`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RetraceParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal planes.
    pub planes: u32,
    /// Gradient cells per row.
    pub grid_width: u32,
    /// Gradient cell rows.
    pub grid_height: u32,
    /// Low bits of a key that hold the pixel index.
    pub index_mask: u32,
    /// AO radius (unused by shadows).
    pub max_distance: f32,
    /// Where the rng index wraps (nonzero): last frame's start index is recovered from the
    /// accumulated history as `stored − rays` modulo this.
    pub rng_wrap: u32,
    /// Last frame's index (the frame whose rays are re-created).
    pub frame: u32,
    /// [`crate::sampling::SamplePattern::code`] last frame's rays drew with.
    pub sampling: u32,
    /// Reserved.
    pub _pad: [u32; 2],
}

/// Push constants of [`atrous`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GradientAtrousParams {
    /// Gradient cells per row.
    pub grid_width: u32,
    /// Gradient cell rows.
    pub grid_height: u32,
    /// Tap spacing in cells (1, 2, 4, …).
    pub step: u32,
    /// Reserved.
    pub _pad: u32,
}

/// Mask of the pixel-index bits of a key for `pixels` pixels: the smallest `2^k − 1` above every
/// index, so no key equals [`EMPTY_KEY`]; the bits above carry the random priority.
pub fn index_mask(pixels: u32) -> u32 {
    let bits = 32 - pixels.leading_zeros();
    if bits >= 32 {
        u32::MAX
    } else {
        (1u32 << bits) - 1
    }
}

/// Last frame's surface `s` carried to this frame by `next` (its instance's previous→current map):
/// position and both normals. Other fields are kept. An identity map reproduces `s` exactly.
#[inline]
pub fn move_surface(s: &Surface, next: &[InstanceData]) -> Surface {
    if (s.instance as usize) >= next.len() {
        return *s;
    }
    let m = next[s.instance as usize];
    let p = m.previous_position(s.position());
    let n = m.transform_vector(s.normal());
    let g = m.transform_vector(s.geometric_normal());
    Surface {
        px: p.x,
        py: p.y,
        pz: p.z,
        nx: n.x,
        ny: n.y,
        nz: n.z,
        gx: g.x,
        gy: g.y,
        gz: g.z,
        ..*s
    }
}

/// Whether the moved sample `m` is visible at the current G-buffer texel `c`: same instance,
/// similar normal, `m` on `c`'s tangent plane.
#[inline]
pub fn visible(c: &Surface, m: &Surface, p: &ProjectParams) -> bool {
    if !c.is_valid() || c.instance != m.instance {
        return false;
    }
    let n_ok = c.normal().dot(m.normal()) >= p.normal_threshold;
    let dist = math::abs(c.normal().dot(m.position() - c.position()));
    n_ok && dist <= p.plane_threshold * math::max(c.depth, 1e-6)
}

/// One invocation per stratum (`id.xy`): choose, move, test and splat one previous-frame sample.
/// `prev_samples` (plane 0) is last frame's noisy signal, whose ray count tells which pixels traced;
/// `keys` one `u32` per cell, filled with
/// [`EMPTY_KEY`] before.
pub fn project(id: UVec3, p: &ProjectParams, io: GradientProjectIo<'_>) {
    let GradientProjectIo {
        prev_depth,
        prev_normal_roughness,
        prev_geometry,
        depth,
        normal_roughness,
        geometry,
        view,
        prev_samples,
        next,
        keys,
    } = io;
    if id.x >= p.grid_width || id.y >= p.grid_height {
        return;
    }
    let (x0, y0) = (id.x * p.stratum, id.y * p.stratum);
    let sw = if p.width - x0 < p.stratum {
        p.width - x0
    } else {
        p.stratum
    };
    let sh = if p.height - y0 < p.stratum {
        p.height - y0
    } else {
        p.stratum
    };
    let n = sw * sh;
    // Candidates: pixels that traced last frame (so their 0th ray value exists).
    let mut traced = 0u32;
    let mut j = 0u32;
    while j < n {
        let pix = pixel_index(x0 + j % sw, y0 + j / sw, p.width);
        if prev_samples[pix].rays() > 0 && surface::has_surface(prev_depth[pix]) {
            traced += 1;
        }
        j += 1;
    }
    if traced == 0 {
        return;
    }
    let pick = pcg_hash(pcg_hash(id.x ^ pcg_hash(id.y)) ^ p.frame_index) % traced;
    let mut chosen = 0usize;
    let mut seen = 0u32;
    let mut j = 0u32;
    while j < n {
        let pix = pixel_index(x0 + j % sw, y0 + j / sw, p.width);
        if prev_samples[pix].rays() > 0 && surface::has_surface(prev_depth[pix]) {
            if seen == pick {
                chosen = pix;
            }
            seen += 1;
        }
        j += 1;
    }
    let prev = previous_surface(
        chosen,
        p.width,
        p.height,
        &view[0],
        prev_depth,
        prev_normal_roughness,
        prev_geometry,
    );
    let moved = move_surface(&prev, next);
    let (fx, fy) = p.camera.project_point(moved.position(), p.width, p.height);
    let (cx, cy) = (math::floor(fx + 0.5), math::floor(fy + 0.5));
    if !(cx >= 0.0 && cy >= 0.0 && cx < p.width as f32 && cy < p.height as f32) {
        return;
    }
    let (cx, cy) = (cx as u32, cy as u32);
    let c = surface::load(
        &view[0].camera,
        cx,
        cy,
        p.width,
        p.height,
        depth,
        normal_roughness,
    )
    .with_hit(geometry[pixel_index(cx, cy, p.width)]);
    if !visible(&c, &moved, p) {
        return;
    }
    let cell = pixel_index(cx / p.stratum, cy / p.stratum, p.grid_width);
    let priority = pcg_hash(chosen as u32 ^ pcg_hash(p.frame_index)) & !p.index_mask;
    atomic::min(&mut keys[cell], priority | chosen as u32);
}

/// Last frame's surface at pixel index `pix`, from last frame's inputs and camera: bit for bit the
/// surface last frame's raygen built, so a still scene re-traces the very same ray.
#[inline]
fn previous_surface(
    pix: usize,
    width: u32,
    height: u32,
    view: &View,
    prev_depth: &[f32],
    prev_normal_roughness: &[u32],
    prev_geometry: &[[u32; 2]],
) -> Surface {
    let (x, y) = (pix as u32 % width, pix as u32 / width);
    surface::load(
        &view.prev_camera,
        x,
        y,
        width,
        height,
        prev_depth,
        prev_normal_roughness,
    )
    .with_hit(prev_geometry[pix])
}

/// The previous pixel a cell re-traces, if any: `(pixel index, moved surface)`.
#[inline]
fn cell_sample(id: UVec3, p: &RetraceParams, last: &LastFrame<'_>) -> Option<(usize, Surface)> {
    let key = last.keys[pixel_index(id.x, id.y, p.grid_width)];
    if key == EMPTY_KEY {
        return None;
    }
    let pix = (key & p.index_mask) as usize;
    let prev = previous_surface(
        pix,
        p.width,
        p.height,
        &last.view[0],
        last.prev_depth,
        last.prev_normal_roughness,
        last.prev_geometry,
    );
    Some((pix, move_surface(&prev, last.next)))
}

/// The gradient sample of a re-traced ray `curr` against last frame's `prev`.
#[inline]
fn gradient_of(curr: f32, prev: f32) -> GradientSample {
    GradientSample {
        delta: math::abs(curr - prev),
        luminance: math::max(curr, prev),
    }
}

/// Index of cell `(x, y)` of plane `z` in a plane-stacked gradient image.
#[inline]
pub fn cell_index(x: u32, y: u32, z: u32, grid_width: u32, grid_height: u32) -> usize {
    ((z * grid_height + y) * grid_width + x) as usize
}

/// What a re-trace reads of the previous frame: the chosen sample per cell, its surfaces and
/// payloads, the instance maps to this frame, and the samples it traced.
struct LastFrame<'a> {
    keys: &'a [u32],
    prev_depth: &'a [f32],
    prev_normal_roughness: &'a [u32],
    prev_geometry: &'a [[u32; 2]],
    view: &'a [View],
    next: &'a [InstanceData],
    prev_payload: &'a [PackedPayload],
    prev_samples: &'a [PackedSample],
}

/// The loop both re-traces share. For every plane whose pixel traced last frame, `trace(surface,
/// plane, stream, index)` re-creates that plane's 0th ray against this frame's scene (`None`: the
/// plane has no ray to re-create) and the gradient against last frame's value is stored.
#[inline]
fn retrace(
    id: UVec3,
    p: &RetraceParams,
    last: LastFrame<'_>,
    out: &mut [GradientSample],
    trace: impl Fn(&Surface, u32, Stream, u32) -> Option<f32>,
) {
    if id.x >= p.grid_width || id.y >= p.grid_height {
        return;
    }
    let sample = cell_sample(id, p, &last);
    let LastFrame {
        prev_payload,
        prev_samples,
        ..
    } = last;
    let mut z = 0;
    while z < p.planes {
        let o = cell_index(id.x, id.y, z, p.grid_width, p.grid_height);
        out[o] = GradientSample::default();
        if let Some((pix, s)) = sample {
            let i = (z * p.width * p.height) as usize + pix;
            let prev = prev_samples[i].unpack();
            if prev.rays > 0 {
                let (x, y) = (pix as u32 % p.width, pix as u32 / p.width);
                // Accumulation advanced the index by the rays traced: step back to the 0th.
                let wrap = p.rng_wrap;
                let start = (prev_payload[i].rng_index() % wrap + wrap - prev.rays % wrap) % wrap;
                let stream = Stream::new(p.sampling, x, y, z, p.frame, start);
                if let Some(curr) = trace(&s, z, stream, start) {
                    out[o] = gradient_of(curr, prev.first);
                }
            }
        }
        z += 1;
    }
}

/// One invocation per cell: re-trace last frame's 0th AO ray of the cell's sample in every plane.
/// `prev_payload` is last frame's accumulated history (its `rng_index`, less the rays traced, is
/// the 0th ray's index),
/// `prev_samples` last frame's raygen output.
pub fn retrace_ao(id: UVec3, p: &RetraceParams, io: GradientAoIo<'_>) {
    let GradientAoIo {
        keys,
        prev_depth,
        prev_normal_roughness,
        prev_geometry,
        view,
        next,
        prev_payload,
        prev_samples,
        nodes,
        tris,
        out,
    } = io;
    let last = LastFrame {
        keys,
        prev_depth,
        prev_normal_roughness,
        prev_geometry,
        view,
        next,
        prev_payload,
        prev_samples,
    };
    retrace(id, p, last, out, |s, _, stream, index| {
        Some(ao_ray(s, stream, index, p.max_distance, nodes, tris))
    });
}

/// As [`retrace_ao`] for the shadow of `lights[z]` in plane `z` (the lights of *this* frame).
pub fn retrace_shadow(id: UVec3, p: &RetraceParams, io: GradientShadowIo<'_>) {
    let GradientShadowIo {
        keys,
        prev_depth,
        prev_normal_roughness,
        prev_geometry,
        view,
        next,
        prev_payload,
        prev_samples,
        nodes,
        tris,
        lights,
        out,
    } = io;
    let last = LastFrame {
        keys,
        prev_depth,
        prev_normal_roughness,
        prev_geometry,
        view,
        next,
        prev_payload,
        prev_samples,
    };
    retrace(id, p, last, out, |s, z, stream, index| {
        if (z as usize) < lights.len() {
            Some(shadow_ray(
                s,
                &lights[z as usize],
                stream,
                index,
                nodes,
                tris,
            ))
        } else {
            None
        }
    });
}

/// B3-spline taps of the à-trous kernel (`[1, 4, 6, 4, 1] / 16`).
const TAPS: [f32; 5] = [1.0 / 16.0, 0.25, 0.375, 0.25, 1.0 / 16.0];

/// One invocation per cell and plane (`id.z`): one à-trous iteration over both channels with no
/// edge-stopping weights, normalized by the weights of the taps inside the grid.
pub fn atrous(id: UVec3, p: &GradientAtrousParams, io: GradientAtrousIo<'_>) {
    let GradientAtrousIo { input, out } = io;
    if id.x >= p.grid_width || id.y >= p.grid_height {
        return;
    }
    let (mut delta, mut luminance, mut sum_w) = (0.0f32, 0.0f32, 0.0f32);
    let mut j = 0;
    while j < 5 {
        let ty = id.y as i32 + (j - 2) * p.step as i32;
        let mut i = 0;
        while i < 5 {
            let tx = id.x as i32 + (i - 2) * p.step as i32;
            if tx >= 0 && ty >= 0 && tx < p.grid_width as i32 && ty < p.grid_height as i32 {
                let w = TAPS[i as usize] * TAPS[j as usize];
                let g = input[cell_index(tx as u32, ty as u32, id.z, p.grid_width, p.grid_height)];
                delta += w * g.delta;
                luminance += w * g.luminance;
                sum_w += w;
            }
            i += 1;
        }
        j += 1;
    }
    out[cell_index(id.x, id.y, id.z, p.grid_width, p.grid_height)] = GradientSample {
        delta: delta / sum_w,
        luminance: luminance / sum_w,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_never_collide_with_empty() {
        for pixels in [1u32, 2, 3, 4, 1000, 1 << 20, (1 << 20) + 1] {
            let m = index_mask(pixels);
            assert!(pixels - 1 < m, "{pixels}");
            assert_ne!(!m | (pixels - 1), EMPTY_KEY);
        }
    }

    #[test]
    fn lambda_is_normalized() {
        assert_eq!(gradient_of(0.0, 0.0).lambda(), 0.0);
        assert_eq!(gradient_of(1.0, 0.0).lambda(), 1.0);
        assert_eq!(gradient_of(1.0, 1.0).lambda(), 0.0);
        let g = GradientSample {
            delta: 0.25,
            luminance: 0.5,
        };
        assert_eq!(g.lambda(), 0.5);
    }
}
