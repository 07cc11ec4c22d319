//! The G-buffer texel as the kernels see it, rebuilt from the engine's packed inputs (view
//! depth, normal + roughness, motion; see [`crate::packing`] and the README's input contract),
//! and the bilateral tests on it.
//!
//! No buffer holds a `Surface`: each kernel reconstructs the texels it reads ([`Surface::at`]),
//! positions from view depth through the camera, so the denoiser reads 16 bytes per pixel
//! instead of 80 and any engine can feed it.

use crate::camera::{Camera, PixelRays, View};
use crate::lanes::Lanes;
use crate::math;
use crate::packing;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Instance id of a pixel that hit nothing (sky): no signal, no rays, skipped by the filters.
pub const NO_INSTANCE: u32 = u32::MAX;

/// One pixel of the G-buffer, unpacked (a value in registers, never stored).
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
}

/// Whether an engine's view depth marks a surface: positive and finite. Sky (no surface) is 0 or
/// +∞; NaN counts as sky rather than poisoning the filters.
#[inline]
pub fn has_surface(depth: f32) -> bool {
    depth > 0.0 && math::is_finite(depth)
}

/// [`Surface::at`] pixel `(x, y)` of the input buffers `depth` and `normal_roughness`.
#[inline]
pub fn load(
    camera: &Camera,
    x: u32,
    y: u32,
    width: u32,
    height: u32,
    depth: &[f32],
    normal_roughness: &[u32],
) -> Surface {
    let i = (y * width + x) as usize;
    Surface::at(camera, x, y, width, height, depth[i], normal_roughness[i])
}

/// What the renderer's ray generation sees at pixel index `pix`: [`load`] through this frame's
/// camera, with the renderer's `geometry` (geometric normal, instance).
#[inline]
pub fn load_with_hit(
    view: &View,
    pix: usize,
    width: u32,
    height: u32,
    depth: &[f32],
    normal_roughness: &[u32],
    geometry: &[[u32; 2]],
) -> Surface {
    let (x, y) = (pix as u32 % width, pix as u32 / width);
    load(&view.camera, x, y, width, height, depth, normal_roughness).with_hit(geometry[pix])
}

/// The engine's inputs at one pixel, packed as the buffers hold them.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Texel {
    /// Linear view depth (0 for sky).
    pub depth: f32,
    /// [`packing::pack_normal_roughness`] of the shading normal and alpha.
    pub normal_roughness: u32,
    /// [`packing::pack_motion`]: pixel offset and view-depth change to last frame.
    pub motion: [u32; 2],
    /// The built-in renderer's [`packing::pack_hit`] (geometric normal, instance).
    pub hit: [u32; 2],
}

impl Surface {
    /// The surface seen at pixel `(x, y)` of a `width × height` image through `camera`, from its
    /// view depth and packed normal + roughness. Not yet known, until [`Surface::with_motion`] /
    /// [`Surface::with_hit`]: last frame's position (set to this one), the geometric normal (set
    /// to the shading normal) and the instance (0, or [`NO_INSTANCE`] for sky).
    ///
    /// Always inlined: reprojection builds one per footprint texel and reads three fields; a
    /// call returned all seventeen through memory.
    #[inline(always)]
    pub fn at(
        camera: &Camera,
        x: u32,
        y: u32,
        width: u32,
        height: u32,
        depth: f32,
        normal_roughness: u32,
    ) -> Surface {
        let (xf, yf) = (x as f32, y as f32);
        // Computed for sky too and selected, not branched on: vector code over lanes.
        let valid = has_surface(depth);
        let p = camera.unproject(xf, yf, depth, width, height);
        let (n, roughness) = packing::unpack_normal_roughness(normal_roughness);
        let v = |a: f32| if valid { a } else { 0.0 };
        Surface {
            px: v(p.x),
            py: v(p.y),
            pz: v(p.z),
            depth: v(depth),
            nx: v(n.x),
            ny: v(n.y),
            nz: v(n.z),
            instance: if valid { 0 } else { NO_INSTANCE },
            gx: v(n.x),
            gy: v(n.y),
            gz: v(n.z),
            roughness: if valid { roughness } else { 1.0 },
            prev_x: xf,
            prev_y: yf,
            prev_px: v(p.x),
            prev_py: v(p.y),
            prev_pz: v(p.z),
        }
    }

    /// [`Surface::at`] with this frame's camera of `view`, plus the pixel's motion.
    #[inline]
    #[allow(clippy::too_many_arguments)] // A pixel, the image size and its three inputs.
    pub fn current(
        view: &View,
        x: u32,
        y: u32,
        width: u32,
        height: u32,
        depth: f32,
        normal_roughness: u32,
        motion: [u32; 2],
    ) -> Surface {
        Surface::at(&view.camera, x, y, width, height, depth, normal_roughness).with_motion(
            motion,
            &view.prev_camera,
            width,
            height,
        )
    }

    /// This surface with last frame's pixel and position from packed 2.5D `motion`, through last
    /// frame's camera.
    #[inline]
    pub fn with_motion(
        self,
        motion: [u32; 2],
        prev_camera: &Camera,
        width: u32,
        height: u32,
    ) -> Surface {
        let m = packing::unpack_motion(motion);
        let (prev_x, prev_y) = (self.prev_x + m.x, self.prev_y + m.y);
        // Selected, not branched on (vector code over lanes): sky keeps its (zero) position.
        let valid = self.is_valid();
        let q = prev_camera.unproject(prev_x, prev_y, self.depth + m.z, width, height);
        Surface {
            prev_x,
            prev_y,
            prev_px: if valid { q.x } else { self.prev_px },
            prev_py: if valid { q.y } else { self.prev_py },
            prev_pz: if valid { q.z } else { self.prev_pz },
            ..self
        }
    }

    /// This surface with the built-in renderer's hit data: geometric normal and instance.
    #[inline]
    pub fn with_hit(self, hit: [u32; 2]) -> Surface {
        if !self.is_valid() {
            return self;
        }
        let (g, instance) = packing::unpack_hit(hit);
        Surface {
            gx: g.x,
            gy: g.y,
            gz: g.z,
            instance,
            ..self
        }
    }

    /// The packed inputs of this surface at pixel `(x, y)`, with last frame's depth taken through
    /// `prev_camera`: what the G-buffer pass writes, and what tests feed the kernels.
    #[inline]
    pub fn pack(&self, x: u32, y: u32, prev_camera: &Camera) -> Texel {
        let (dx, dy) = (self.prev_x - x as f32, self.prev_y - y as f32);
        if !self.is_valid() {
            return Texel {
                depth: 0.0,
                normal_roughness: 0,
                motion: packing::pack_motion(dx, dy, 0.0),
                hit: [0, NO_INSTANCE],
            };
        }
        let dz = prev_camera.depth(self.prev_position()) - self.depth;
        Texel {
            depth: self.depth,
            normal_roughness: packing::pack_normal_roughness(self.normal(), self.roughness),
            motion: packing::pack_motion(dx, dy, dz),
            hit: packing::pack_hit(self.geometric_normal(), self.instance),
        }
    }

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

/// A centre pixel's tangent plane, for filters that test many taps against it: the distance of
/// tap `(x, y)` at view depth `z` from the plane is `|z·(a + x·bx + y·by) − c|` (positions
/// relative to the eye, through [`PixelRays`]), three multiply-adds and no reconstruction.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct TangentPlane {
    /// `n·d0`.
    a: f32,
    /// `n·dx`.
    bx: f32,
    /// `n·dy`.
    by: f32,
    /// `n·(p − eye)` of the centre.
    c: f32,
}

impl TangentPlane {
    /// The plane of unit normal `n` through the point at view depth `depth` of pixel `(x, y)`.
    #[inline]
    pub fn new(rays: &PixelRays, n: Vec3, x: u32, y: u32, depth: f32) -> Self {
        let (a, bx, by) = (n.dot(rays.d0), n.dot(rays.dx), n.dot(rays.dy));
        let mut t = TangentPlane { a, bx, by, c: 0.0 };
        t.c = t.height(x, y, depth);
        t
    }

    /// The plane whose [`Self::distance`] is this one's times `s > 0`: a filter that divides
    /// every tap's distance by the centre's tolerance multiplies it in once.
    #[inline]
    pub fn scaled(self, s: f32) -> Self {
        TangentPlane {
            a: self.a * s,
            bx: self.bx * s,
            by: self.by * s,
            c: self.c * s,
        }
    }

    /// `n·(q − eye)` of the point at view depth `depth` of pixel `(x, y)`.
    #[inline]
    fn height(&self, x: u32, y: u32, depth: f32) -> f32 {
        depth * math::mul_add(self.bx, x as f32, math::mul_add(self.by, y as f32, self.a))
    }

    /// Distance of the point at view depth `depth` of pixel `(x, y)` from the plane.
    #[inline]
    pub fn distance(&self, x: u32, y: u32, depth: f32) -> f32 {
        let k = math::mul_add(self.bx, x as f32, math::mul_add(self.by, y as f32, self.a));
        math::abs(math::mul_add(depth, k, -self.c))
    }
}

/// Normal edge-stopping weight `max(0, n·m)^power` (SVGF uses power 128).
#[inline]
pub fn normal_weight(n: Vec3, m: Vec3, power: f32) -> f32 {
    math::pow(normal_cosine(n, m), power)
}

/// [`normal_weight`] of `N` pixels' unit normals `n` and neighbours' packed normal + roughness
/// `words` ([`packed_squared_cosines`], [`crate::lanes`]): `(max(0, n·u)² / (u·u))^(power/2)`, the
/// squared cosine clamped to 1 so the power keeps its square-and-multiply path. No square root
/// per direction.
#[inline(always)]
pub fn normal_weights<const N: usize>(
    n: Lanes<Vec3, N>,
    words: Lanes<u32, N>,
    power: f32,
) -> Lanes<f32, N> {
    packed_squared_cosines(n, words).pow(0.5 * power)
}

/// [`squared_cosines`] of unit `n` and the directions of packed normal + roughness words
/// ([`packing::unpack_direction`]), decoded lane by lane inside: on the CPU a row of decoded
/// directions in between is an array of 3-vectors that the vector code re-gathers field by field.
#[inline(always)]
pub fn packed_squared_cosines<const N: usize>(
    n: Lanes<Vec3, N>,
    words: Lanes<u32, N>,
) -> Lanes<f32, N> {
    n.zip(words, |n, w| {
        squared_cosine(n, packing::unpack_direction(w))
    })
}

/// `min(max(0, n·u)² / (u·u), 1)` of every lane: the squared cosine between unit `n` and
/// direction `u`.
#[inline(always)]
pub fn squared_cosines<const N: usize>(n: Lanes<Vec3, N>, u: Lanes<Vec3, N>) -> Lanes<f32, N> {
    n.zip(u, squared_cosine)
}

/// One lane of [`squared_cosines`] (and of [`packed_squared_cosines`], after its decode).
#[inline(always)]
fn squared_cosine(n: Vec3, u: Vec3) -> f32 {
    let d = math::max(math::dot(n, u), 0.0);
    math::min(d * d / math::dot(u, u), 1.0)
}

/// What [`normal_weight`] raises to its power: `max(0, n·m)`.
#[inline]
fn normal_cosine(n: Vec3, m: Vec3) -> f32 {
    math::max(n.dot(m), 0.0)
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

/// What reprojection needs of [`Surface::current`] for `N` consecutive pixels of a row, built
/// lane by lane from the inputs so it runs as vector code (the same bits as `Surface::current`'s
/// fields; sky lanes' normal is unset).
#[derive(Copy, Clone)]
pub struct Moved<const N: usize> {
    /// [`Surface::is_valid`].
    pub valid: Lanes<bool, N>,
    /// [`Surface::normal`].
    pub normal: Lanes<Vec3, N>,
    /// `[prev_x, prev_y]`.
    pub prev_xy: Lanes<[f32; 2], N>,
    /// [`Surface::prev_position`].
    pub prev_position: Lanes<Vec3, N>,
}

impl<const N: usize> Moved<N> {
    /// Pixels `(xs[l], y)` with their inputs `depth`, `normal_roughness` and `motion`.
    #[inline(always)]
    pub fn new(
        view: &View,
        xs: Lanes<u32, N>,
        y: u32,
        (width, height): (u32, u32),
        depth: Lanes<f32, N>,
        normal_roughness: Lanes<u32, N>,
        motion: Lanes<[u32; 2], N>,
    ) -> Self {
        let valid = depth.map(has_surface);
        let m = motion.map(packing::unpack_motion);
        let prev_xy = xs.zip(m, |x, m| [x as f32 + m.x, y as f32 + m.y]);
        let prev_position = Lanes::<Vec3, N>::from_index(|l| {
            let (l, [x, y]) = (l as usize, prev_xy.0[l as usize]);
            let q = view
                .prev_camera
                .unproject(x, y, depth.0[l] + m.0[l].z, width, height);
            if valid.0[l] {
                q
            } else {
                Vec3::ZERO
            }
        });
        Moved {
            valid,
            normal: normal_roughness.map(packing::unpack_normal),
            prev_xy,
            prev_position,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;

    #[test]
    fn packed_cosines_are_the_decoded_ones_bit_for_bit() {
        // The buffer taps decode inside the cosine, the tile taps before it: the same words.
        let n = Lanes::<Vec3, 8>::from_index(|l| {
            Vec3::new(0.2 * l as f32 - 0.7, 0.5, 0.3 - 0.05 * l as f32).normalize()
        });
        // Even lanes near the centre's normal, odd lanes facing away from it.
        let words = Lanes::<u32, 8>::from_index(|l| {
            let tilt = Vec3::new(0.1, -0.05 * l as f32, 0.02);
            let m = n.0[l as usize] + tilt;
            let m = if l % 2 == 0 { m } else { -m };
            packing::pack_normal_roughness(m.normalize(), 0.1 * l as f32)
        });
        let decoded = squared_cosines(n, words.map(packing::unpack_direction));
        let packed = packed_squared_cosines(n, words);
        assert_eq!(packed.0.map(f32::to_bits), decoded.0.map(f32::to_bits));
        // Both ends are held: facing away (0) and nearly along (close to 1).
        assert!(packed.0.contains(&0.0));
        assert!(packed.0.iter().any(|&c| c > 0.9));
    }

    #[test]
    fn moved_lanes_are_surface_current_bit_for_bit() {
        let camera = Camera::look_at(Vec3::new(0.0, 1.0, -4.0), Vec3::ZERO, Vec3::Y, 0.9);
        let prev_camera = Camera::look_at(Vec3::new(0.2, 1.1, -4.1), Vec3::ZERO, Vec3::Y, 0.9);
        let view = View {
            camera,
            prev_camera,
        };
        let (w, h, y) = (64, 48, 17);
        let depth = Lanes::<f32, 4>([3.5, 0.0, f32::INFINITY, 12.25]);
        let nr = Lanes::<u32, 4>::from_index(|l| {
            packing::pack_normal_roughness(
                Vec3::new(0.3, 0.8, -0.5 + l as f32 * 0.1).normalize(),
                0.4,
            )
        });
        let motion = Lanes::<[u32; 2], 4>::from_index(|l| {
            packing::pack_motion(-1.5 + l as f32, 0.75, 0.125 * l as f32)
        });
        let xs = Lanes::<u32, 4>::from_index(|l| 30 + l);
        let m = Moved::new(&view, xs, y, (w, h), depth, nr, motion);
        for l in 0..4 {
            let s = Surface::current(&view, xs.0[l], y, w, h, depth.0[l], nr.0[l], motion.0[l]);
            assert_eq!(m.valid.0[l], s.is_valid());
            assert_eq!(
                m.prev_xy.0[l].map(f32::to_bits),
                [s.prev_x.to_bits(), s.prev_y.to_bits()]
            );
            assert_eq!(
                m.prev_position.0[l].to_array().map(f32::to_bits),
                s.prev_position().to_array().map(f32::to_bits)
            );
            if s.is_valid() {
                assert_eq!(
                    m.normal.0[l].to_array().map(f32::to_bits),
                    s.normal().to_array().map(f32::to_bits)
                );
            }
        }
    }
}
