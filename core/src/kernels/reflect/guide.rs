//! The hit-distance guide: what the reflected image's edges look like, for the à-trous weights.

use super::*;

/// A pixel with no record of this frame in its window: taps to and from it skip the guide test.
pub const NO_GUIDE: f32 = f32::MAX;

/// Push constants of [`reflect_guide`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GuideParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Frame index of the records to read (this frame's).
    pub frame: u32,
    /// Window radius (2 → 5×5).
    pub radius: u32,
}

/// Hit-distance guide, one invocation per pixel: `guide[pixel]` is the mean
/// [`RayHit::log_distance`] of this frame's records within `radius` (misses at
/// [`MISS_DISTANCE`]), or [`NO_GUIDE`].
///
/// The G-buffer does not see the edges *inside* a reflection: where a floor mirrors the dark
/// underside of an object, the floor is one flat surface and at 1 rpp the luminance test is too
/// noisy to stop the filter, so the dark reflection is blurred into the bright one around it.
/// The rays' hit distances do see that edge (the object is near, the wall behind it far), and
/// their log is steady enough, averaged over a few pixels, for an edge-stopping weight
/// (`FilterSettings::guide_sigma`): on the bunny's first frame a bilateral on the raw samples
/// guided by it has much less error than one without (`docs/algorithms/reflections.md`).
pub fn reflect_guide(id: UVec3, p: &GuideParams, io: ReflectGuideIo<'_>) {
    let ReflectGuideIo { hits, guide } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let (sum, n) = window_sum(
        hits,
        (p.width, p.height),
        (id.x as i32, id.y as i32),
        p.radius,
        p.frame,
        |h| Some(h.log_distance),
    );
    guide[pixel_index(id.x, id.y, p.width)] = if n > 0.0 { sum / n } else { NO_GUIDE };
}

/// The sum of `value(record)` over the records of frame `frame` within `radius` of pixel
/// `centre` (which may lie outside the image) that `value` accepts, and how many it accepted.
#[inline]
pub(super) fn window_sum(
    hits: &[RayHit],
    (width, height): (u32, u32),
    (cx, cy): (i32, i32),
    radius: u32,
    frame: u32,
    value: impl Fn(&RayHit) -> Option<f32>,
) -> (f32, f32) {
    let r = radius as i32;
    let (mut sum, mut n) = (0.0f32, 0.0f32);
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let (qx, qy) = (cx + dx, cy + dy);
            if qx >= 0 && qy >= 0 && qx < width as i32 && qy < height as i32 {
                let h = hits[pixel_index(qx as u32, qy as u32, width)];
                if h.is_from(frame) {
                    if let Some(v) = value(&h) {
                        sum += v;
                        n += 1.0;
                    }
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    (sum, n)
}
