//! Pinhole camera: primary rays through pixel centres and the inverse, projecting a world point to
//! pixel coordinates (motion vectors).
//!
//! Pixel coordinates are continuous with pixel `(x, y)`'s **centre at `(x, y)`** (so a static
//! point's previous position in pixel `(3, 4)` is `(3.0, 4.0)`); the image spans
//! `[-0.5, width - 0.5] × [-0.5, height - 0.5]`, `y` grows downward.

use crate::math;
use crate::trace::{normalize, Ray};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Pixel coordinate given to points that do not project into the camera (behind it): far outside
/// any image, but still a valid `i32` after `floor`, so reprojection sees an off-screen texel.
pub const OFFSCREEN: f32 = -1.0e9;

/// A pinhole camera as the kernels take it (52 bytes, push-constant friendly).
///
/// `right`, `up`, `forward` must be orthonormal; image `x` grows along `right`, image `y` along
/// `-up`. The vertical field of view is `2·atan(tan_half_fov_y)`; the horizontal one follows from
/// the image aspect ratio (square pixels).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Camera {
    /// Eye position, x.
    pub origin_x: f32,
    /// Eye position, y.
    pub origin_y: f32,
    /// Eye position, z.
    pub origin_z: f32,
    /// Right axis, x.
    pub right_x: f32,
    /// Right axis, y.
    pub right_y: f32,
    /// Right axis, z.
    pub right_z: f32,
    /// Up axis, x.
    pub up_x: f32,
    /// Up axis, y.
    pub up_y: f32,
    /// Up axis, z.
    pub up_z: f32,
    /// Viewing direction, x.
    pub forward_x: f32,
    /// Viewing direction, y.
    pub forward_y: f32,
    /// Viewing direction, z.
    pub forward_z: f32,
    /// `tan(vertical fov / 2)`.
    pub tan_half_fov_y: f32,
}

/// The camera's view directions as a linear function of pixel coordinates: the ray through `(x,
/// y)` is `d0 + x·dx + y·dy`, scaled so its component along `forward` is 1 (a point at view depth
/// `z` is `origin + z·dir`). Filters precompute dot products with `d0`, `dx`, `dy` once per pixel
/// and reconstruct each tap's position term with three multiply-adds, no division.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct PixelRays {
    /// Direction through pixel coordinates `(0, 0)` minus the centre offsets: `forward + ..`.
    pub d0: Vec3,
    /// Change of the direction per pixel along `x`.
    pub dx: Vec3,
    /// Change of the direction per pixel along `y`.
    pub dy: Vec3,
}

impl PixelRays {
    /// The rays of `camera` over a `width × height` image.
    #[inline]
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let w = width as f32;
        let h = height as f32;
        let tan_y = camera.tan_half_fov_y;
        let tan_x = tan_y * (w / h);
        // sx = (2(x + ½)/w − 1)·tan_x and sy = (1 − 2(y + ½)/h)·tan_y, linear in x and y.
        let (sx0, sy0) = ((1.0 / w - 1.0) * tan_x, (1.0 - 1.0 / h) * tan_y);
        PixelRays {
            d0: camera.forward() + camera.right() * sx0 + camera.up() * sy0,
            dx: camera.right() * (2.0 * tan_x / w),
            dy: camera.up() * (-2.0 * tan_y / h),
        }
    }

    /// The direction through continuous pixel coordinates `(x, y)`.
    #[inline]
    pub fn dir(&self, x: f32, y: f32) -> Vec3 {
        self.d0 + self.dx * x + self.dy * y
    }
}

/// This frame's and last frame's camera: the one-element buffer every kernel that reconstructs
/// positions from view depth binds (too large for push constants beside the other parameters).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct View {
    /// This frame's camera.
    pub camera: Camera,
    /// Last frame's camera (the same as `camera` on a first frame or a cut).
    pub prev_camera: Camera,
}

impl Camera {
    /// A camera at `origin` looking at `target`, with `world_up` fixing the roll and a vertical
    /// field of view in radians. `world_up` must not be parallel to the view direction.
    #[cfg(not(target_arch = "spirv"))]
    pub fn look_at(origin: Vec3, target: Vec3, world_up: Vec3, fov_y: f32) -> Self {
        let forward = normalize(target - origin);
        let right = normalize(forward.cross(world_up));
        let up = right.cross(forward);
        Camera::from_basis(
            origin,
            right,
            up,
            forward,
            math::sin(fov_y * 0.5) / math::cos(fov_y * 0.5),
        )
    }

    /// A camera from its basis vectors.
    pub fn from_basis(
        origin: Vec3,
        right: Vec3,
        up: Vec3,
        forward: Vec3,
        tan_half_fov_y: f32,
    ) -> Self {
        Camera {
            origin_x: origin.x,
            origin_y: origin.y,
            origin_z: origin.z,
            right_x: right.x,
            right_y: right.y,
            right_z: right.z,
            up_x: up.x,
            up_y: up.y,
            up_z: up.z,
            forward_x: forward.x,
            forward_y: forward.y,
            forward_z: forward.z,
            tan_half_fov_y,
        }
    }

    /// Eye position.
    #[inline]
    pub fn origin(&self) -> Vec3 {
        Vec3::new(self.origin_x, self.origin_y, self.origin_z)
    }
    /// Right axis.
    #[inline]
    pub fn right(&self) -> Vec3 {
        Vec3::new(self.right_x, self.right_y, self.right_z)
    }
    /// Up axis.
    #[inline]
    pub fn up(&self) -> Vec3 {
        Vec3::new(self.up_x, self.up_y, self.up_z)
    }
    /// Viewing direction.
    #[inline]
    pub fn forward(&self) -> Vec3 {
        Vec3::new(self.forward_x, self.forward_y, self.forward_z)
    }

    /// The ray through the centre of pixel `(x, y)` of a `width × height` image, with a unit
    /// direction: `normalize(forward + sx·right + sy·up)`, where
    /// `sx = (2(x + ½)/width − 1)·tan·aspect`, `sy = (1 − 2(y + ½)/height)·tan`.
    #[inline]
    pub fn primary_ray(&self, x: u32, y: u32, width: u32, height: u32) -> Ray {
        let w = width as f32;
        let h = height as f32;
        let tan_y = self.tan_half_fov_y;
        let tan_x = tan_y * (w / h);
        let sx = (2.0 * (x as f32 + 0.5) / w - 1.0) * tan_x;
        let sy = (1.0 - 2.0 * (y as f32 + 0.5) / h) * tan_y;
        Ray {
            origin: self.origin(),
            dir: normalize(self.forward() + self.right() * sx + self.up() * sy),
        }
    }

    /// The world point at view depth `depth` seen through continuous pixel coordinates `(x, y)`
    /// (centre convention of the module docs), the inverse of [`Camera::project_point`] and
    /// [`Camera::depth`]: `origin + depth · PixelRays::dir(x, y)`. How the denoiser reconstructs
    /// positions from the engine's view depth.
    #[inline]
    pub fn unproject(&self, x: f32, y: f32, depth: f32, width: u32, height: u32) -> Vec3 {
        self.origin() + PixelRays::new(self, width, height).dir(x, y) * depth
    }

    /// Linear view depth of `p`: its distance along `forward`.
    #[inline]
    pub fn depth(&self, p: Vec3) -> f32 {
        (p - self.origin()).dot(self.forward())
    }

    /// Pixel coordinates (centre convention of the module docs) where the view-space vector `d`
    /// (relative to the eye) projects; [`OFFSCREEN`] for both when it is not in front of the eye.
    #[inline]
    fn project_offset(&self, d: Vec3, width: u32, height: u32) -> (f32, f32) {
        let z = d.dot(self.forward());
        if !(z > 1e-12) {
            return (OFFSCREEN, OFFSCREEN);
        }
        let w = width as f32;
        let h = height as f32;
        let tan_y = self.tan_half_fov_y;
        let tan_x = tan_y * (w / h);
        let sx = d.dot(self.right()) / z;
        let sy = d.dot(self.up()) / z;
        let x = (sx / tan_x + 1.0) * 0.5 * w - 0.5;
        let y = (1.0 - sy / tan_y) * 0.5 * h - 0.5;
        if !math::is_finite(x) || !math::is_finite(y) {
            return (OFFSCREEN, OFFSCREEN);
        }
        (x, y)
    }

    /// Pixel coordinates of world point `p`, or [`OFFSCREEN`] twice when `p` is behind the eye.
    #[inline]
    pub fn project_point(&self, p: Vec3, width: u32, height: u32) -> (f32, f32) {
        self.project_offset(p - self.origin(), width, height)
    }

    /// Pixel coordinates of the direction `dir` at infinity (the sky: only rotation matters).
    #[inline]
    pub fn project_direction(&self, dir: Vec3, width: u32, height: u32) -> (f32, f32) {
        self.project_offset(dir, width, height)
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    #[test]
    fn primary_rays_project_back_to_their_pixel() {
        let cam = Camera::look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.0, 0.5, -4.0),
            Vec3::Y,
            1.0,
        );
        let (w, h) = (64, 48);
        for (x, y) in [(0, 0), (63, 47), (31, 20), (5, 40)] {
            let ray = cam.primary_ray(x, y, w, h);
            assert!((ray.dir.length() - 1.0).abs() < 1e-6);
            let (px, py) = cam.project_point(ray.origin + ray.dir * 7.5, w, h);
            assert!(
                (px - x as f32).abs() < 1e-3 && (py - y as f32).abs() < 1e-3,
                "{px} {py}"
            );
            let q = cam.unproject(
                x as f32,
                y as f32,
                cam.depth(ray.origin + ray.dir * 7.5),
                w,
                h,
            );
            assert!((q - (ray.origin + ray.dir * 7.5)).length() < 1e-4, "{q}");
            let (dx, dy) = cam.project_direction(ray.dir, w, h);
            assert!((dx - x as f32).abs() < 1e-3 && (dy - y as f32).abs() < 1e-3);
        }
        assert_eq!(
            cam.project_point(cam.origin() - cam.forward(), w, h),
            (OFFSCREEN, OFFSCREEN)
        );
    }

    #[test]
    fn image_orientation() {
        let cam = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0);
        // Top-left pixel looks up and left.
        let r = cam.primary_ray(0, 0, 10, 10);
        assert!(r.dir.x < 0.0 && r.dir.y > 0.0 && r.dir.z < 0.0);
        assert!((cam.depth(Vec3::new(3.0, 1.0, -2.0)) - 2.0).abs() < 1e-6);
    }
}
