//! The G-buffer texel every pass reads, and the bilateral tests on it.

use crate::math;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Instance id of a pixel that hit nothing (sky): no signal, no rays, skipped by the filters.
pub const NO_INSTANCE: u32 = u32::MAX;

/// One pixel of the G-buffer (80 bytes, scalars only so the layout is identical on every target).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Surface {
    /// World-space position, x.
    pub px: f32,
    /// World-space position, y.
    pub py: f32,
    /// World-space position, z.
    pub pz: f32,
    /// Distance from the camera along its forward axis (linear view depth).
    pub depth: f32,
    /// Shading normal (interpolated), x.
    pub nx: f32,
    /// Shading normal, y.
    pub ny: f32,
    /// Shading normal, z.
    pub nz: f32,
    /// Instance hit, or [`NO_INSTANCE`].
    pub instance: u32,
    /// Geometric (face) normal, x: the normal rays are offset along.
    pub gx: f32,
    /// Geometric normal, y.
    pub gy: f32,
    /// Geometric normal, z.
    pub gz: f32,
    /// Surface roughness (GGX alpha), 1 for diffuse-only.
    pub roughness: f32,
    /// Where this surface point was in the previous frame, in pixels (x; pixel centres at integer
    /// coordinates, see `camera`).
    pub prev_x: f32,
    /// Where this surface point was in the previous frame, in pixels (y).
    pub prev_y: f32,
    /// Where this surface point was in the previous frame, in world space (x): reprojection
    /// compares it with the previous G-buffer, so moving objects keep their history.
    pub prev_px: f32,
    /// Previous world-space position, y.
    pub prev_py: f32,
    /// Previous world-space position, z.
    pub prev_pz: f32,
    /// Reserved.
    pub _pad0: f32,
    /// Reserved.
    pub _pad1: f32,
    /// Reserved.
    pub _pad2: f32,
}

impl Surface {
    /// World-space position.
    #[inline]
    pub fn position(&self) -> Vec3 {
        Vec3::new(self.px, self.py, self.pz)
    }
    /// World-space position in the previous frame.
    #[inline]
    pub fn prev_position(&self) -> Vec3 {
        Vec3::new(self.prev_px, self.prev_py, self.prev_pz)
    }
    /// Shading normal.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        Vec3::new(self.nx, self.ny, self.nz)
    }
    /// Geometric normal.
    #[inline]
    pub fn geometric_normal(&self) -> Vec3 {
        Vec3::new(self.gx, self.gy, self.gz)
    }
    /// True when the pixel hit geometry.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.instance != NO_INSTANCE
    }
}

/// Normal edge-stopping weight `max(0, n·m)^power` (SVGF uses power 128).
#[inline]
pub fn normal_weight(n: Vec3, m: Vec3, power: f32) -> f32 {
    math::pow(math::max(n.dot(m), 0.0), power)
}

/// Plane-distance edge-stopping weight: how far `q` lies off the tangent plane of `(p, n)`,
/// relative to `scale` (typically `sigma * view depth`, so the test is resolution- and
/// distance-independent).
#[inline]
pub fn plane_weight(p: Vec3, n: Vec3, q: Vec3, scale: f32) -> f32 {
    math::exp(-plane_distance(p, n, q, scale))
}

/// The exponent of [`plane_weight`]: `|n·(q − p)| / scale`. Filters that multiply it with other
/// exponential weights add the exponents instead and pay for one `exp` per tap.
#[inline]
pub fn plane_distance(p: Vec3, n: Vec3, q: Vec3, scale: f32) -> f32 {
    math::abs(n.dot(q - p)) / math::max(scale, 1e-12)
}

/// Combined geometric edge-stopping weight of neighbour `s` seen from centre `c` at `offset_px`
/// pixels: normal similarity times plane distance, the tolerance growing with the offset and the
/// centre's view depth (`plane_scale` = σ times the angle one pixel subtends).
#[inline]
pub fn geometry_weight(
    c: &Surface,
    s: &Surface,
    offset_px: f32,
    plane_scale: f32,
    normal_power: f32,
) -> f32 {
    normal_weight(c.normal(), s.normal(), normal_power)
        * plane_weight(
            c.position(),
            c.normal(),
            s.position(),
            plane_scale * c.depth * offset_px,
        )
}
