//! The engine's projection: reversed Z with an infinite far plane, built from VRRT's pinhole
//! camera so that pixel `(x, y)`'s centre sees what VRRT's ray through it sees.

use vrrt_core::camera::Camera;
use vrrt_core::glam::{Mat4, Vec4};

/// The near plane of the engine's projection, in metres. Reversed Z puts it at device depth 1
/// and infinity at 0, which spends the float's precision evenly over distance.
pub const NEAR: f32 = 0.05;

/// World to clip space for `camera` over a `width × height` image: clip `x, y` are the camera's
/// `right`, `up` offsets scaled by the half field of view, `w` is the view depth and `z` the near
/// plane, so device depth is `NEAR / view depth`.
///
/// Why from VRRT's camera: a framebuffer pixel's centre `(x + ½, y + ½)` is then exactly the
/// direction VRRT's primary ray through pixel `(x, y)` takes (`Camera::primary_ray`), so the
/// rasterized G-buffer samples the surfaces the ray-traced one does.
pub fn view_proj(camera: &Camera, (width, height): (u32, u32)) -> Mat4 {
    let tan_y = camera.tan_half_fov_y;
    let tan_x = tan_y * width as f32 / height as f32;
    let o = camera.origin();
    let row = |axis: vrrt_core::glam::Vec3, scale: f32| (axis / scale).extend(-axis.dot(o) / scale);
    Mat4::from_cols(
        row(camera.right(), tan_x),
        row(camera.up(), tan_y),
        Vec4::new(0.0, 0.0, 0.0, NEAR),
        row(camera.forward(), 1.0),
    )
    .transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use vrrt_core::glam::Vec3;

    /// A point on the primary ray of a pixel lands on that pixel's centre, at device depth
    /// `NEAR / view depth`.
    #[test]
    fn pixel_centres_are_the_primary_rays() {
        let camera = Camera::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y, 0.9);
        let (w, h) = (64, 36);
        let m = view_proj(&camera, (w, h));
        for (x, y) in [(0, 0), (63, 35), (20, 7)] {
            let ray = camera.primary_ray(x, y, w, h);
            let p = ray.origin + ray.dir * 4.0;
            let clip = m * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let fx = (ndc.x * 0.5 + 0.5) * w as f32;
            let fy = (0.5 - ndc.y * 0.5) * h as f32;
            assert!((fx - (x as f32 + 0.5)).abs() < 1e-3, "x {fx} vs {x}");
            assert!((fy - (y as f32 + 0.5)).abs() < 1e-3, "y {fy} vs {y}");
            let depth = camera.depth(p);
            assert!((ndc.z - NEAR / depth).abs() < 1e-6);
        }
    }
}
