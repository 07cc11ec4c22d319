//! G-buffer: one primary ray per pixel through its centre, writing what an engine's G-buffer
//! holds (view depth, normal + roughness, 2.5D motion; [`crate::packing`]) plus the built-in
//! renderer's own `geometry` (geometric normal, instance) for its ray generation.
//!
//! Conventions (what an independent renderer must match):
//! - `position` is the barycentric interpolation of the hit triangle's vertices (on the surface,
//!   not `origin + t·dir`); `depth` is its distance along the camera's forward axis.
//! - Surfaces are two-sided. The geometric normal is the normalized face normal, flipped to face
//!   the camera (`g · dir < 0`); the shading normal (interpolated vertex normals, normalized) is
//!   flipped together with it. A degenerate shading normal (zero or non-finite) is replaced by `g`.
//! - Motion: `prev = prev_from_current(instance) · position`, projected with the previous
//!   frame's camera; the view-depth change is `prev_camera.depth(prev) − depth` (pixel centres at integer coordinates, [`crate::camera::OFFSCREEN`] when behind it).
//! - Sky pixels get depth 0, instance [`NO_INSTANCE`], and the previous pixel of their view
//!   direction under the previous camera's rotation.

use super::pixel_index;
use super::GbufferIo;
use crate::camera::Camera;
use crate::math;
use crate::surface::{Surface, NO_INSTANCE};
use crate::trace::{self, normalize, BvhNode, Triangle, TriangleNormals};
use bytemuck::{Pod, Zeroable};
use glam::{UVec3, Vec3};

/// Far limit of primary rays.
pub const PRIMARY_T_MAX: f32 = 1.0e30;

/// Per-instance data of the G-buffer pass (64 bytes), indexed by [`Triangle::instance`].
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Pod, Zeroable)]
pub struct InstanceData {
    /// Rigid (or affine) map from this frame's world position of a point on the instance to the
    /// same point's world position last frame, row-major 3×4: row 0 `m00 m01 m02 m03`.
    pub m00: f32,
    /// Row 0, column 1.
    pub m01: f32,
    /// Row 0, column 2.
    pub m02: f32,
    /// Row 0, translation.
    pub m03: f32,
    /// Row 1, column 0.
    pub m10: f32,
    /// Row 1, column 1.
    pub m11: f32,
    /// Row 1, column 2.
    pub m12: f32,
    /// Row 1, translation.
    pub m13: f32,
    /// Row 2, column 0.
    pub m20: f32,
    /// Row 2, column 1.
    pub m21: f32,
    /// Row 2, column 2.
    pub m22: f32,
    /// Row 2, translation.
    pub m23: f32,
    /// GGX alpha written to [`Surface::roughness`] (1 = diffuse).
    pub roughness: f32,
    /// Reserved.
    pub _pad0: f32,
    /// Reserved.
    pub _pad1: f32,
    /// Reserved.
    pub _pad2: f32,
}

impl Default for InstanceData {
    fn default() -> Self {
        InstanceData::from_rows(
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            1.0,
        )
    }
}

impl InstanceData {
    /// From the three rows of the current→previous map and a roughness.
    pub fn from_rows(r0: [f32; 4], r1: [f32; 4], r2: [f32; 4], roughness: f32) -> Self {
        InstanceData {
            m00: r0[0],
            m01: r0[1],
            m02: r0[2],
            m03: r0[3],
            m10: r1[0],
            m11: r1[1],
            m12: r1[2],
            m13: r1[3],
            m20: r2[0],
            m21: r2[1],
            m22: r2[2],
            m23: r2[3],
            roughness,
            _pad0: 0.0,
            _pad1: 0.0,
            _pad2: 0.0,
        }
    }

    /// Where the point now at `p` was last frame.
    #[inline]
    pub fn previous_position(&self, p: Vec3) -> Vec3 {
        Vec3::new(
            self.m00 * p.x + self.m01 * p.y + self.m02 * p.z + self.m03,
            self.m10 * p.x + self.m11 * p.y + self.m12 * p.z + self.m13,
            self.m20 * p.x + self.m21 * p.y + self.m22 * p.z + self.m23,
        )
    }

    /// The linear part applied to a direction `v` (no translation, not renormalized: rigid maps
    /// keep unit length, and an identity map returns `v` exactly).
    #[inline]
    pub fn transform_vector(&self, v: Vec3) -> Vec3 {
        Vec3::new(
            self.m00 * v.x + self.m01 * v.y + self.m02 * v.z,
            self.m10 * v.x + self.m11 * v.y + self.m12 * v.z,
            self.m20 * v.x + self.m21 * v.y + self.m22 * v.z,
        )
    }

    /// The inverse map (previous→current when `self` is current→previous), same roughness: what
    /// the temporal-gradient pass needs to carry last frame's surfaces forward. The identity
    /// inverts to the identity exactly.
    #[cfg(not(target_arch = "spirv"))]
    pub fn inverse(&self) -> InstanceData {
        let m = glam::Affine3A::from_cols_array(&[
            self.m00, self.m10, self.m20, self.m01, self.m11, self.m21, self.m02, self.m12,
            self.m22, self.m03, self.m13, self.m23,
        ]);
        let i = m.inverse();
        let (x, y, z, t) = (
            i.matrix3.x_axis,
            i.matrix3.y_axis,
            i.matrix3.z_axis,
            i.translation,
        );
        InstanceData::from_rows(
            [x.x, y.x, z.x, t.x],
            [x.y, y.y, z.y, t.y],
            [x.z, y.z, z.z, t.z],
            self.roughness,
        )
    }
}

/// Push constants of [`gbuffer`] (112 bytes, within Vulkan's guaranteed 128).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GbufferParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// This frame's camera.
    pub camera: Camera,
    /// Last frame's camera (equal to `camera` on the first frame).
    pub prev_camera: Camera,
}

/// The G-buffer texel of pixel `(x, y)`: trace its primary ray and shade the hit.
pub fn surface_at(
    x: u32,
    y: u32,
    p: &GbufferParams,
    nodes: &[BvhNode],
    tris: &[Triangle],
    normals: &[TriangleNormals],
    instances: &[InstanceData],
) -> Surface {
    let ray = p.camera.primary_ray(x, y, p.width, p.height);
    let hit = trace::closest_hit(nodes, tris, &ray, PRIMARY_T_MAX);
    if !hit.is_hit() {
        let (prev_x, prev_y) = p.prev_camera.project_direction(ray.dir, p.width, p.height);
        return Surface {
            instance: NO_INSTANCE,
            roughness: 1.0,
            prev_x,
            prev_y,
            ..Surface::default()
        };
    }
    let tri = tris[hit.tri as usize];
    let position = tri.point(hit.b1, hit.b2);
    let mut g = normalize(tri.face_normal());
    let mut n = normalize(normals[hit.tri as usize].interpolate(hit.b1, hit.b2));
    if g.dot(ray.dir) > 0.0 {
        g = -g;
        n = -n;
    }
    if !(math::is_finite(n.x) && math::is_finite(n.y) && math::is_finite(n.z)) {
        n = g;
    }
    let (prev_position, roughness) = if (tri.instance as usize) < instances.len() {
        let inst = instances[tri.instance as usize];
        (inst.previous_position(position), inst.roughness)
    } else {
        (position, 1.0)
    };
    let (prev_x, prev_y) = p
        .prev_camera
        .project_point(prev_position, p.width, p.height);
    Surface {
        px: position.x,
        py: position.y,
        pz: position.z,
        depth: p.camera.depth(position),
        nx: n.x,
        ny: n.y,
        nz: n.z,
        instance: tri.instance,
        gx: g.x,
        gy: g.y,
        gz: g.z,
        roughness,
        prev_x,
        prev_y,
        prev_px: prev_position.x,
        prev_py: prev_position.y,
        prev_pz: prev_position.z,
    }
}

/// One invocation per pixel (`id.z` must be 0): [`surface_at`] the pixel, packed as an engine
/// writes its G-buffer ([`Surface::pack`]).
pub fn gbuffer(id: UVec3, p: &GbufferParams, io: GbufferIo<'_>) {
    let GbufferIo {
        nodes,
        tris,
        normals,
        instances,
        depth,
        normal_roughness,
        motion,
        geometry,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let pix = pixel_index(id.x, id.y, p.width);
    let t =
        surface_at(id.x, id.y, p, nodes, tris, normals, instances).pack(id.x, id.y, &p.prev_camera);
    depth[pix] = t.depth;
    normal_roughness[pix] = t.normal_roughness;
    motion[pix] = t.motion;
    geometry[pix] = t.hit;
}
