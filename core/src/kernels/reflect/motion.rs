//! Parallax motion of the reflected image: where last frame saw the reflected point.

use super::guide::window_sum;
use super::*;

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
/// where the reflection was: `parallax[pixel] = (x, y)` in last frame's pixels. Pixels without a
/// reflecting surface or a nearby record keep the surface motion.
pub fn reflect_motion(id: UVec3, p: &MotionParams, io: ReflectMotionIo<'_>) {
    let ReflectMotionIo {
        depth,
        normal_roughness,
        motion,
        view,
        hits,
        parallax,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let pix = pixel_index(id.x, id.y, p.width);
    let v = view[0];
    let s = Surface::current(
        &v,
        id.x,
        id.y,
        p.width,
        p.height,
        depth[pix],
        normal_roughness[pix],
        motion[pix],
    );
    let mut out = [s.prev_x, s.prev_y];
    let (cx, cy) = (math::floor(s.prev_x + 0.5), math::floor(s.prev_y + 0.5));
    // A moving reflector's image does not follow a fixed virtual point: keep its surface motion.
    // (Motion arrives as binary16: "still" is within a thousandth of the depth.)
    let moved = (s.prev_position() - s.position()).length();
    let reflective = s.is_valid() && s.roughness <= p.max_roughness && moved <= 1e-3 * s.depth;
    if reflective && math::is_finite(cx) && math::is_finite(cy) {
        // Far outside the image every tap misses; clamped, the window's offsets cannot overflow.
        let centre = (
            math::clamp(cx, -1.0e6, 1.0e6) as i32,
            math::clamp(cy, -1.0e6, 1.0e6) as i32,
        );
        let (sum, n) = window_sum(hits, (p.width, p.height), centre, p.radius, p.frame, |h| {
            (h.distance < MISS_DISTANCE).then_some(h.distance)
        });
        if n > 0.0 {
            let eye = Vec3::new(p.eye_x, p.eye_y, p.eye_z);
            let dir = normalize(s.position() - eye);
            let virtual_prev = s.prev_position() + dir * (sum / n);
            let (x, y) = p.prev_camera.project_point(virtual_prev, p.width, p.height);
            out = [x, y];
        }
    }
    parallax[pix] = out;
}
