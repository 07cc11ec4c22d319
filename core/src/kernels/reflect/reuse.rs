//! Ray reuse between neighbours, weighted by each pixel's own lobe pdf.

use super::*;

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
        depth,
        normal_roughness,
        geometry,
        view,
        hits,
        samples,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let pix = pixel_index(id.x, id.y, p.width);
    let i = (p.plane * p.width * p.height) as usize + pix;
    let camera = view[0].camera;
    let s = surface::load_with_hit(
        &view[0],
        pix,
        p.width,
        p.height,
        depth,
        normal_roughness,
        geometry,
    );
    let Some((n, wo, alpha)) = lobe(&s, &p.shading) else {
        return;
    };
    let own = samples[i].unpack();
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
                    surface::load(
                        &camera,
                        qx as u32,
                        qy as u32,
                        p.width,
                        p.height,
                        depth,
                        normal_roughness,
                    )
                    .position(),
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
        }
        .pack();
    }
}
