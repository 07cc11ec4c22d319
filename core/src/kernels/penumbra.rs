//! The penumbra guide: how far the filter may blur a shadow at each pixel, in pixels.
//!
//! A shadow's edge is sharp where its blocker is near the receiver (a contact) and wide where it
//! is far: the light's penumbra. The G-buffer sees neither, and a few binary rays are too noisy
//! for the luminance test to tell a wide penumbra from noise, so at 1 rpp à-trous leaves blotches
//! in the soft part and smears the sharp part. Shadow raygen records, per pixel, the mean
//! penumbra width its blocked rays' blockers cast ([`crate::kernels::raygen::penumbra_width`]);
//! this pass averages it over a window and turns it into pixels, and à-trous then keeps its
//! taps within it (NVIDIA's SIGMA blurs shadows by the same measure).

use super::reflect::NO_GUIDE;
use super::PenumbraGuideIo;
use crate::math;
use crate::payload::PackedSample;
use crate::surface;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`penumbra_guide`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PenumbraParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The shadow plane whose samples say which pixels traced this frame.
    pub plane: u32,
    /// Window radius (2 → 5×5).
    pub radius: u32,
    /// Angle one pixel subtends (`FrameInfo::pixel_angle`): a pixel at view depth `d` is
    /// `d · pixel_angle` wide.
    pub pixel_angle: f32,
}

/// Penumbra guide, one invocation per pixel: `guide[pixel]` is the mean penumbra width of the
/// blocked records of pixels that traced plane `plane` this frame within `radius`, in pixels
/// at this pixel's depth, or [`NO_GUIDE`] (nothing blocked nearby, or no surface).
pub fn penumbra_guide(id: UVec3, p: &PenumbraParams, io: PenumbraGuideIo<'_>) {
    let PenumbraGuideIo {
        samples,
        blockers,
        depth,
        guide,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let pix = (id.y * p.width + id.x) as usize;
    let d = depth[pix];
    let r = p.radius as i32;
    let plane = (p.plane * p.width * p.height) as usize;
    let (mut sum, mut n) = (0.0f32, 0.0f32);
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let (qx, qy) = (id.x as i32 + dx, id.y as i32 + dy);
            if qx >= 0 && qy >= 0 && qx < p.width as i32 && qy < p.height as i32 {
                let q = (qy as u32 * p.width + qx as u32) as usize;
                let b = blockers[q];
                if b >= 0.0 && traced(samples[plane + q]) {
                    sum += b;
                    n += 1.0;
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    guide[pix] = if n > 0.0 && surface::has_surface(d) {
        sum / n / (d * p.pixel_angle)
    } else {
        NO_GUIDE
    };
}

/// `scale / max(W, 1)` for a centre whose penumbra is `W` pixels wide, or 0 (no limit) for one
/// with no blocker nearby ([`NO_GUIDE`]).
#[inline(always)]
pub fn reach(width: f32, scale: f32) -> f32 {
    if width == NO_GUIDE {
        0.0
    } else {
        scale / math::max(width, 1.0)
    }
}

/// Whether raygen traced the sample this frame (its record is this frame's).
#[inline]
fn traced(s: PackedSample) -> bool {
    s.rays() > 0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::raygen::NO_BLOCKER;
    use crate::payload::Sample;

    #[test]
    fn the_guide_averages_traced_blocked_records_in_pixels() {
        let (w, h) = (5u32, 1u32);
        let traced = |rays| {
            Sample {
                m1: 0.0,
                m2: 0.0,
                rays,
                first: 0.0,
            }
            .pack()
        };
        // Pixel 0 lit, 1 and 2 blocked (widths 0.2 and 0.4), 3 blocked but untraced this frame
        // (a stale record), 4 blocked.
        let samples = [traced(2), traced(2), traced(1), traced(0), traced(1)];
        let blockers = [NO_BLOCKER, 0.2, 0.4, 9.0, 0.3];
        let depth = [4.0; 5];
        let mut guide = [0.0f32; 5];
        let p = PenumbraParams {
            width: w,
            height: h,
            plane: 0,
            radius: 1,
            pixel_angle: 0.01,
        };
        let footprint = 4.0 * 0.01;
        for x in 0..w {
            let io = PenumbraGuideIo {
                samples: &samples,
                blockers: &blockers,
                depth: &depth,
                guide: &mut guide,
            };
            penumbra_guide(UVec3::new(x, 0, 0), &p, io);
        }
        assert_eq!(guide[0], 0.2 / footprint);
        assert!((guide[1] - 0.3 / footprint).abs() < 1e-4);
        assert!((guide[3] - 0.35 / footprint).abs() < 1e-4);
        // Only a stale record and a lit one around: nothing blocked this frame.
        let lone = [NO_BLOCKER, NO_BLOCKER, NO_BLOCKER, 9.0, NO_BLOCKER];
        let io = PenumbraGuideIo {
            samples: &samples,
            blockers: &lone,
            depth: &depth,
            guide: &mut guide,
        };
        penumbra_guide(UVec3::new(3, 0, 0), &p, io);
        assert_eq!(guide[3], NO_GUIDE);
    }
}
