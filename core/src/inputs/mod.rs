//! The engine's own G-buffer textures and the conventions they are written in.
//!
//! An engine that rasterizes writes depth, normals and motion in its own formats and conventions:
//! reversed-Z or standard depth, view-space or world-space normals in RGB10A2 or RGBA16F, motion
//! in UV or pixel units, to last frame or from it. [`InputConventions`] names them; the denoiser's
//! `ingest` pass ([`crate::kernels::ingest`]) reads the engine's textures through
//! [`Fetch`](crate::textures::Fetch) (sampled images on the GPU backends, texel slices on the CPU
//! backend), decodes them here once,
//! and writes the denoiser's own formats ([`crate::packing`]), which it keeps as last frame's depth
//! and normals anyway. Every later pass reads those.
//!
//! The texel a decode function takes is what a texel fetch returns: four floats, unorm formats
//! already in `[0, 1]`, missing channels 0 (alpha 1).

use crate::camera::Camera;
use crate::math;
use glam::{Vec3, Vec4};

/// How the engine's depth texture encodes distance. Depth is stored in the red channel.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum DepthEncoding {
    /// Linear view depth: the distance along the camera's forward axis (our own format). 0 or
    /// +∞ where there is no surface.
    #[default]
    Linear,
    /// Reversed-Z device depth in `[0, 1]` (near plane 1, far plane 0) of a perspective
    /// projection with [`InputConventions::near`] and [`InputConventions::far`]; 0 is the sky.
    ReversedZ,
    /// Standard device depth in `[0, 1]` (near plane 0, far plane 1; Vulkan, D3D, wgpu); 1 is
    /// the sky.
    StandardZ,
}

/// The space of the engine's normals.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum NormalSpace {
    /// World space.
    #[default]
    World,
    /// The camera's view space: x right, y up, z towards the viewer (the camera looks down −z).
    View,
}

/// How the engine's normal + roughness texture holds them. Roughness is linear roughness
/// (`√α` of GGX, as NRD), in `[0, 1]`.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum NormalEncoding {
    /// Signed `xyz` in `[-1, 1]`, roughness in `w` (RGBA16F, RGBA32F).
    #[default]
    Signed,
    /// `xyz · ½ + ½`, roughness in `w` (RGBA8 or RGBA16 unorm).
    Unsigned,
    /// The octahedral code `· ½ + ½` in `xy`, roughness in `z` (NRD's RGB10A2 packing).
    Octahedral,
}

/// The units of the engine's motion vectors.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum MotionUnits {
    /// Pixels, y down (our own format).
    #[default]
    Pixels,
    /// Texture coordinates: the image is `[0, 1]²`, y down.
    Uv,
    /// Normalized device coordinates: the image is `[-1, 1]²`, y up.
    Ndc,
}

/// Which way the engine's motion vectors point.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum MotionSign {
    /// Last frame's position minus this frame's (our own format, NRD's).
    #[default]
    ToPrevious,
    /// This frame's position minus last frame's (a velocity, as many engines store it).
    ToCurrent,
}

/// Where the view-depth change of a pixel's surface since last frame comes from.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum MotionDepth {
    /// The motion texture's `z`: last frame's view depth minus this frame's (NRD's 2.5D motion),
    /// with the sign of [`InputConventions::motion_sign`].
    #[default]
    Texture,
    /// Not given (RG motion): the change of a point that did not move in the world, from the two
    /// cameras. Exact for static geometry; a surface moving along the view axis is compared
    /// against last frame's depth as if it had not, and loses history where it moved by more than
    /// the reprojection's plane tolerance.
    Static,
}

/// The conventions of the engine's G-buffer textures. The default is the denoiser's own
/// (linear depth, world normals, motion to last frame in pixels with the depth change in `z`).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct InputConventions {
    /// How depth is encoded (default `linear`).
    pub depth: DepthEncoding,
    /// The projection's near plane in view units, for `reversed_z` and `standard_z` (> 0;
    /// default 0.1).
    pub near: f32,
    /// The projection's far plane in view units, for `reversed_z` and `standard_z` (> `near`,
    /// `inf` for an infinite projection; default `inf`).
    pub far: f32,
    /// The normals' space (default `world`).
    pub normal_space: NormalSpace,
    /// The normals' encoding (default `signed`).
    pub normal_encoding: NormalEncoding,
    /// Motion units (default `pixels`).
    pub motion_units: MotionUnits,
    /// Motion direction (default `to_previous`).
    pub motion_sign: MotionSign,
    /// Where the view-depth change comes from (default `texture`).
    pub motion_depth: MotionDepth,
}

impl Default for InputConventions {
    fn default() -> Self {
        InputConventions {
            depth: DepthEncoding::Linear,
            near: 0.1,
            far: f32::INFINITY,
            normal_space: NormalSpace::World,
            normal_encoding: NormalEncoding::Signed,
            motion_units: MotionUnits::Pixels,
            motion_sign: MotionSign::ToPrevious,
            motion_depth: MotionDepth::Texture,
        }
    }
}

/// A convention that cannot be decoded.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ConventionError {
    /// The field (`near`, `far`).
    pub field: &'static str,
    /// What it must be.
    pub expected: &'static str,
    /// Its value.
    pub value: f32,
}

impl core::fmt::Display for ConventionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "input conventions: `{}` must be {} (got {})",
            self.field, self.expected, self.value
        )
    }
}

impl core::error::Error for ConventionError {}

impl InputConventions {
    /// Refuses a projection that cannot be inverted: `near` finite and > 0, `far` > `near`
    /// (+∞ allowed). Linear depth ignores both.
    pub fn validate(&self) -> Result<(), ConventionError> {
        if self.depth == DepthEncoding::Linear {
            return Ok(());
        }
        if !(self.near > 0.0 && math::is_finite(self.near)) {
            return Err(ConventionError {
                field: "near",
                expected: "finite and > 0",
                value: self.near,
            });
        }
        if !(self.far > self.near) {
            return Err(ConventionError {
                field: "far",
                expected: "> near (inf for an infinite projection)",
                value: self.far,
            });
        }
        Ok(())
    }

    /// The push constants of the `ingest` pass for a `width × height` image (validate first).
    pub fn params(&self, width: u32, height: u32) -> IngestParams {
        // Device depth z of a perspective projection inverts to view depth a / (z·scale + b).
        let infinite = self.far == f32::INFINITY;
        let range = self.far - self.near;
        let a = if infinite {
            self.near
        } else {
            self.near * self.far / range
        };
        let (a, b, scale) = match self.depth {
            DepthEncoding::Linear => (0.0, 0.0, 0.0),
            DepthEncoding::ReversedZ if infinite => (a, 0.0, 1.0),
            DepthEncoding::ReversedZ => (a, self.near / range, 1.0),
            DepthEncoding::StandardZ if infinite => (a, 1.0, -1.0),
            DepthEncoding::StandardZ => (a, self.far / range, -1.0),
        };
        let sign = match self.motion_sign {
            MotionSign::ToPrevious => 1.0,
            MotionSign::ToCurrent => -1.0,
        };
        let (w, h) = (width as f32, height as f32);
        let (mx, my) = match self.motion_units {
            MotionUnits::Pixels => (1.0, 1.0),
            MotionUnits::Uv => (w, h),
            MotionUnits::Ndc => (0.5 * w, -0.5 * h),
        };
        IngestParams {
            width,
            height,
            depth_mode: self.depth as u32,
            depth_a: a,
            depth_b: b,
            depth_scale: scale,
            normal_view: (self.normal_space == NormalSpace::View) as u32,
            normal_encoding: self.normal_encoding as u32,
            motion_x: mx * sign,
            motion_y: my * sign,
            motion_z: if self.motion_depth == MotionDepth::Texture {
                sign
            } else {
                0.0
            },
            static_depth: (self.motion_depth == MotionDepth::Static) as u32,
        }
    }
}

/// [`InputConventions`] reduced to what the decode needs: the `ingest` pass's push constants, and
/// the one element of `reproject_engine`'s `conventions` binding.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct IngestParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// [`DepthEncoding`] as its discriminant.
    pub depth_mode: u32,
    /// View depth is `depth_a / (z · depth_scale + depth_b)` for device depth `z`.
    pub depth_a: f32,
    /// See `depth_a`.
    pub depth_b: f32,
    /// See `depth_a` (1 reversed-Z, −1 standard Z).
    pub depth_scale: f32,
    /// 1 when normals are in view space.
    pub normal_view: u32,
    /// [`NormalEncoding`] as its discriminant.
    pub normal_encoding: u32,
    /// Pixels (to last frame) per unit of the texture's `x`.
    pub motion_x: f32,
    /// Pixels (to last frame) per unit of the texture's `y`.
    pub motion_y: f32,
    /// View-depth change (last frame minus this) per unit of the texture's `z`.
    pub motion_z: f32,
    /// 1 when the view-depth change is that of a static point ([`MotionDepth::Static`]).
    pub static_depth: u32,
}

/// Linear view depth of the depth texel's red channel `z`; 0 (no surface) for the sky and for
/// anything that does not decode to a positive finite depth.
#[inline]
pub fn decode_depth(z: f32, p: &IngestParams) -> f32 {
    // Device depth at or beyond the far plane (0 reversed, 1 standard) is the sky, even where
    // a finite far plane would decode it to a distance.
    let beyond_far = if p.depth_scale > 0.0 { z } else { 1.0 - z };
    let d = if p.depth_mode == DepthEncoding::Linear as u32 {
        z
    } else if beyond_far > 0.0 {
        p.depth_a / (z * p.depth_scale + p.depth_b)
    } else {
        0.0
    };
    if d > 0.0 && math::is_finite(d) {
        d
    } else {
        0.0
    }
}

/// The world-space unit normal and linear roughness of a normal texel, seen by `camera`.
#[inline]
pub fn decode_normal(t: Vec4, p: &IngestParams, camera: &Camera) -> (Vec3, f32) {
    let (n, roughness) = if p.normal_encoding == NormalEncoding::Octahedral as u32 {
        let e = glam::Vec2::new(t.x, t.y) * 2.0 - 1.0;
        (crate::packing::oct_direction(e), t.z)
    } else if p.normal_encoding == NormalEncoding::Unsigned as u32 {
        (Vec3::new(t.x, t.y, t.z) * 2.0 - 1.0, t.w)
    } else {
        (Vec3::new(t.x, t.y, t.z), t.w)
    };
    let n = if p.normal_view != 0 {
        camera.right() * n.x + camera.up() * n.y - camera.forward() * n.z
    } else {
        n
    };
    (crate::trace::normalize(n), math::clamp(roughness, 0.0, 1.0))
}

/// The motion to last frame in pixels and the view-depth change (last frame minus this) of pixel
/// `(x, y)` at view depth `depth`, from its motion texel.
#[inline]
pub fn decode_motion(
    t: Vec4,
    p: &IngestParams,
    x: u32,
    y: u32,
    depth: f32,
    cameras: [&Camera; 2],
) -> Vec3 {
    let dz = if p.static_depth != 0 && crate::surface::has_surface(depth) {
        let [camera, prev] = cameras;
        let world = camera.unproject(x as f32, y as f32, depth, p.width, p.height);
        prev.depth(world) - depth
    } else {
        t.z * p.motion_z
    };
    Vec3::new(t.x * p.motion_x, t.y * p.motion_y, dz)
}

#[cfg(all(test, feature = "std"))]
mod tests;
