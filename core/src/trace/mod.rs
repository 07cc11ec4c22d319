//! Ray tracing in compute: the flat BVH and triangle layouts every backend traces, closest-hit and
//! any-hit traversal, and the ray/box and ray/triangle tests.
//!
//! The host (`vrrt-scene`) builds the BVH; every backend then runs this one traversal, so a ray gives
//! the same hit everywhere (lavapipe has no ray-tracing extensions, and equivalence tests need
//! identical rays anyway).
//!
//! # Buffer layouts (all `#[repr(C)]`, 4-byte scalars, little endian)
//!
//! **Nodes** — `&[BvhNode]`, 32 bytes each, root at index 0:
//!
//! | bytes  | field                   | meaning                                              |
//! |--------|-------------------------|------------------------------------------------------|
//! | 0..12  | `min_x, min_y, min_z`   | lower corner of the node's box                       |
//! | 12..16 | `first`                 | inner: left child index (right = `first + 1`); leaf: first triangle |
//! | 16..28 | `max_x, max_y, max_z`   | upper corner                                         |
//! | 28..32 | `count`                 | 0 = inner node, `> 0` = leaf with triangles `first .. first + count` |
//!
//! Siblings are adjacent, so one index reaches both children. A tree over zero triangles is one
//! node with `min_x > max_x` (checked at the root), which no ray hits. The builder keeps the depth
//! below [`MAX_DEPTH`] so the fixed traversal stack never overflows.
//!
//! **Triangles** — `&[Triangle]`, 40 bytes each, in the order the leaves reference them: three
//! world-space vertices then the instance id. What traversal reads.
//!
//! **Shading normals** — `&[TriangleNormals]`, 36 bytes each, parallel to the triangles: the three
//! per-vertex normals. Only the G-buffer pass reads them, so traversal does not pay for them.
//!
//! # Ray/triangle test
//! Watertight (Woop, Benthin & Wald 2013): the triangle is sheared into a space where the ray is
//! the `+z` axis and the 2D edge functions are evaluated there. Rays through a shared edge or vertex
//! of a closed mesh always hit at least one of its triangles (no leaks between triangles). Edge
//! functions that are exactly 0 count as inside. The paper's double-precision re-evaluation of zero
//! edge functions is omitted (GPUs may lack `f64`): a ray exactly through an edge may then hit
//! both triangles, never neither.
//!
//! # Ray/box test and epsilons
//! Slab test with the conservative far bound of Ize 2013 (`t_far · (1 + 2γ₃)`), so rounding never
//! culls a box the ray really enters. Direction components below `1e-20` in magnitude are replaced
//! by `±1e-20` for the box test only, which keeps every value finite (GPUs need not preserve
//! infinities); the triangle test uses the true direction.
//!
//! # Closest hit is order-independent
//! Among hits with `0 < t < t_max`, the result is the smallest `t`, ties broken by the smallest
//! triangle index. The result therefore does not depend on the traversal order or the tree shape,
//! and equals a brute-force loop over all triangles bit for bit.

use crate::math;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Largest tree depth (root = depth 0) the traversal supports; the builder never exceeds it.
pub const MAX_DEPTH: usize = 64;

/// Triangle index of a miss.
pub const NO_HIT: u32 = u32::MAX;

/// `1 + 2γ₃` with `γₙ = n·u / (1 − n·u)`, `u = 2⁻²⁴`: enlarges the far slab distance so that the
/// three roundings of `(bound − origin) · inv_dir` cannot make a ray miss a box it enters.
const BOX_FAR_SCALE: f32 = 1.000_000_4;

/// Smallest direction component magnitude used by the box test.
const MIN_DIR: f32 = 1e-20;

/// One BVH node (see the module docs for the layout).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    /// Box lower corner, x.
    pub min_x: f32,
    /// Box lower corner, y.
    pub min_y: f32,
    /// Box lower corner, z.
    pub min_z: f32,
    /// Inner node: left child index (the right child is `first + 1`). Leaf: first triangle index.
    pub first: u32,
    /// Box upper corner, x.
    pub max_x: f32,
    /// Box upper corner, y.
    pub max_y: f32,
    /// Box upper corner, z.
    pub max_z: f32,
    /// Triangles in the leaf; 0 marks an inner node.
    pub count: u32,
}

impl BvhNode {
    /// True for a leaf.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
    /// Lower corner.
    #[inline]
    pub fn min(&self) -> Vec3 {
        Vec3::new(self.min_x, self.min_y, self.min_z)
    }
    /// Upper corner.
    #[inline]
    pub fn max(&self) -> Vec3 {
        Vec3::new(self.max_x, self.max_y, self.max_z)
    }
}

/// One triangle as traversal reads it: world-space vertices and the instance it belongs to.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Triangle {
    /// Vertex 0, x.
    pub v0x: f32,
    /// Vertex 0, y.
    pub v0y: f32,
    /// Vertex 0, z.
    pub v0z: f32,
    /// Vertex 1, x.
    pub v1x: f32,
    /// Vertex 1, y.
    pub v1y: f32,
    /// Vertex 1, z.
    pub v1z: f32,
    /// Vertex 2, x.
    pub v2x: f32,
    /// Vertex 2, y.
    pub v2y: f32,
    /// Vertex 2, z.
    pub v2z: f32,
    /// Instance id (index into the per-instance buffers of the G-buffer pass).
    pub instance: u32,
}

impl Triangle {
    /// A triangle from its vertices.
    #[inline]
    pub fn new(v0: Vec3, v1: Vec3, v2: Vec3, instance: u32) -> Self {
        Triangle {
            v0x: v0.x,
            v0y: v0.y,
            v0z: v0.z,
            v1x: v1.x,
            v1y: v1.y,
            v1z: v1.z,
            v2x: v2.x,
            v2y: v2.y,
            v2z: v2.z,
            instance,
        }
    }
    /// Vertex 0.
    #[inline]
    pub fn v0(&self) -> Vec3 {
        Vec3::new(self.v0x, self.v0y, self.v0z)
    }
    /// Vertex 1.
    #[inline]
    pub fn v1(&self) -> Vec3 {
        Vec3::new(self.v1x, self.v1y, self.v1z)
    }
    /// Vertex 2.
    #[inline]
    pub fn v2(&self) -> Vec3 {
        Vec3::new(self.v2x, self.v2y, self.v2z)
    }
    /// Unnormalized face normal `(v1 − v0) × (v2 − v0)` (counter-clockwise winding faces it).
    #[inline]
    pub fn face_normal(&self) -> Vec3 {
        (self.v1() - self.v0()).cross(self.v2() - self.v0())
    }
    /// The point with barycentrics `(1 − b1 − b2, b1, b2)`.
    #[inline]
    pub fn point(&self, b1: f32, b2: f32) -> Vec3 {
        self.v0() * (1.0 - b1 - b2) + self.v1() * b1 + self.v2() * b2
    }
}

/// Per-vertex shading normals of one triangle (parallel to the triangle buffer).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TriangleNormals {
    /// Normal at vertex 0, x.
    pub n0x: f32,
    /// Normal at vertex 0, y.
    pub n0y: f32,
    /// Normal at vertex 0, z.
    pub n0z: f32,
    /// Normal at vertex 1, x.
    pub n1x: f32,
    /// Normal at vertex 1, y.
    pub n1y: f32,
    /// Normal at vertex 1, z.
    pub n1z: f32,
    /// Normal at vertex 2, x.
    pub n2x: f32,
    /// Normal at vertex 2, y.
    pub n2y: f32,
    /// Normal at vertex 2, z.
    pub n2z: f32,
}

impl TriangleNormals {
    /// Normals from three vectors.
    #[inline]
    pub fn new(n0: Vec3, n1: Vec3, n2: Vec3) -> Self {
        TriangleNormals {
            n0x: n0.x,
            n0y: n0.y,
            n0z: n0.z,
            n1x: n1.x,
            n1y: n1.y,
            n1z: n1.z,
            n2x: n2.x,
            n2y: n2.y,
            n2z: n2.z,
        }
    }
    /// Barycentric interpolation `(1 − b1 − b2)·n0 + b1·n1 + b2·n2` (not normalized).
    #[inline]
    pub fn interpolate(&self, b1: f32, b2: f32) -> Vec3 {
        Vec3::new(self.n0x, self.n0y, self.n0z) * (1.0 - b1 - b2)
            + Vec3::new(self.n1x, self.n1y, self.n1z) * b1
            + Vec3::new(self.n2x, self.n2y, self.n2z) * b2
    }
}

/// A ray `origin + t · dir`, `t > 0`. `dir` need not be normalized (`t` is then in units of
/// `|dir|`), but must not be zero.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3,
    /// Direction.
    pub dir: Vec3,
}

/// Result of [`closest_hit`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (`t_max` on a miss).
    pub t: f32,
    /// Barycentric weight of vertex 1.
    pub b1: f32,
    /// Barycentric weight of vertex 2 (vertex 0 gets `1 − b1 − b2`).
    pub b2: f32,
    /// Index of the triangle hit, or [`NO_HIT`].
    pub tri: u32,
}

impl Hit {
    /// True when something was hit.
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.tri != NO_HIT
    }
}

/// `v · (1 / |v|)` through [`math::rsqrt`]. A zero vector gives NaN components, which callers
/// that can see one test with [`math::is_finite`] (`InverseSqrt` of 0 is undefined, so 0 takes
/// the division).
#[inline]
pub fn normalize(v: Vec3) -> Vec3 {
    let d = v.dot(v);
    let inv = if d > 0.0 {
        math::rsqrt(d)
    } else {
        1.0 / math::sqrt(d)
    };
    v * inv
}

/// Per-ray constants of the box and triangle tests.
#[derive(Copy, Clone)]
struct Prepared {
    origin: Vec3,
    inv_dir: Vec3,
    /// Rows of the permute-and-shear map of the watertight test: `A' = (r0·A, r1·A, r2·A)`.
    r0: Vec3,
    r1: Vec3,
    r2: Vec3,
}

#[inline]
fn safe_inv(d: f32) -> f32 {
    if math::abs(d) < MIN_DIR {
        if d >= 0.0 {
            1.0 / MIN_DIR
        } else {
            -1.0 / MIN_DIR
        }
    } else {
        1.0 / d
    }
}

/// Unit vector along axis `k` (0, 1, 2).
#[inline]
fn axis(k: u32) -> Vec3 {
    if k == 0 {
        Vec3::X
    } else if k == 1 {
        Vec3::Y
    } else {
        Vec3::Z
    }
}

#[inline]
fn component(v: Vec3, k: u32) -> f32 {
    if k == 0 {
        v.x
    } else if k == 1 {
        v.y
    } else {
        v.z
    }
}

#[inline]
fn prepare(ray: &Ray) -> Prepared {
    let d = ray.dir;
    let (ax, ay, az) = (math::abs(d.x), math::abs(d.y), math::abs(d.z));
    // kz: dominant axis; kx, ky: the other two, swapped when d[kz] < 0 to keep the winding.
    let kz = if ax > ay {
        if ax > az {
            0
        } else {
            2
        }
    } else if ay > az {
        1
    } else {
        2
    };
    let mut kx = if kz == 2 { 0 } else { kz + 1 };
    let mut ky = if kx == 2 { 0 } else { kx + 1 };
    let dz = component(d, kz);
    if dz < 0.0 {
        (kx, ky) = (ky, kx);
    }
    let sx = component(d, kx) / dz;
    let sy = component(d, ky) / dz;
    let sz = 1.0 / dz;
    let ez = axis(kz);
    Prepared {
        origin: ray.origin,
        inv_dir: Vec3::new(safe_inv(d.x), safe_inv(d.y), safe_inv(d.z)),
        // Each row has one exact 1 (or sz) and zeros, so `r·A` rounds exactly like the paper's
        // `A[kx] − sx·A[kz]`: the watertightness argument carries over.
        r0: axis(kx) - ez * sx,
        r1: axis(ky) - ez * sy,
        r2: ez * sz,
    }
}

/// Slab test: entry distance if the ray enters the box at some `t` in `[0, t_max]`, else `None`
/// encoded as `(false, _)`.
#[inline]
fn hit_box(p: &Prepared, min: Vec3, max: Vec3, t_max: f32) -> (bool, f32) {
    let t0 = (min - p.origin) * p.inv_dir;
    let t1 = (max - p.origin) * p.inv_dir;
    let near = math::max(
        math::max(math::min(t0.x, t1.x), math::min(t0.y, t1.y)),
        math::max(math::min(t0.z, t1.z), 0.0),
    );
    let far = math::min(
        math::min(math::max(t0.x, t1.x), math::max(t0.y, t1.y)),
        math::min(math::max(t0.z, t1.z), t_max),
    ) * BOX_FAR_SCALE;
    (near <= far, near)
}

#[inline]
fn node_box(p: &Prepared, n: &BvhNode, t_max: f32) -> (bool, f32) {
    hit_box(p, n.min(), n.max(), t_max)
}

/// Watertight ray/triangle test. Returns `(hit, t, b1, b2)`; `hit` is true for any `t > 0`
/// (the caller compares against its range, so the outcome does not depend on traversal order).
#[inline]
fn hit_triangle(p: &Prepared, tri: &Triangle) -> (bool, f32, f32, f32) {
    let a = tri.v0() - p.origin;
    let b = tri.v1() - p.origin;
    let c = tri.v2() - p.origin;
    let (ax, ay, az) = (p.r0.dot(a), p.r1.dot(a), p.r2.dot(a));
    let (bx, by, bz) = (p.r0.dot(b), p.r1.dot(b), p.r2.dot(b));
    let (cx, cy, cz) = (p.r0.dot(c), p.r1.dot(c), p.r2.dot(c));
    // Scaled barycentrics: u weighs vertex 0, v vertex 1, w vertex 2.
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let miss = (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0);
    let det = u + v + w;
    if miss || det == 0.0 {
        return (false, 0.0, 0.0, 0.0);
    }
    let t_scaled = u * az + v * bz + w * cz;
    // t > 0 needs t_scaled and det of the same sign.
    let positive = if det > 0.0 {
        t_scaled > 0.0
    } else {
        t_scaled < 0.0
    };
    if !positive {
        return (false, 0.0, 0.0, 0.0);
    }
    let inv = 1.0 / det;
    // A true division for t (not `t_scaled * inv`): one rounding, so exact distances stay exact.
    let t = t_scaled / det;
    (t > 0.0, t, v * inv, w * inv)
}

/// Shared traversal: closest hit (`ANY = false`) or first hit below `t_max` (`ANY = true`).
///
/// Iterative with a fixed stack of [`MAX_DEPTH`] entries. At an inner node both child boxes are
/// tested; the nearer child is visited first and the farther one pushed.
#[inline]
fn traverse<const ANY: bool>(nodes: &[BvhNode], tris: &[Triangle], ray: &Ray, t_max: f32) -> Hit {
    let mut best = Hit {
        t: t_max,
        b1: 0.0,
        b2: 0.0,
        tri: NO_HIT,
    };
    if nodes.is_empty() {
        return best;
    }
    let root = nodes[0];
    // An empty tree is marked by an inverted root box (the slab test alone is symmetric in
    // min/max, so it is checked here).
    if !(root.min_x <= root.max_x) {
        return best;
    }
    let p = prepare(ray);
    if !node_box(&p, &root, best.t).0 {
        return best;
    }
    let mut stack = [0u32; MAX_DEPTH];
    let mut sp = 0usize;
    let mut node = 0u32;
    // A tree visits each node at most once; the bound only guards against a corrupt buffer.
    let mut steps = 0usize;
    let limit = nodes.len();
    loop {
        steps += 1;
        if steps > limit {
            break;
        }
        let n = nodes[node as usize];
        let mut descend = false;
        if n.count > 0 {
            let mut i = n.first;
            let end = n.first + n.count;
            while i < end {
                let (hit, t, b1, b2) = hit_triangle(&p, &tris[i as usize]);
                // Strictly inside (0, t_max); among equal t the lowest index wins.
                let better = t < best.t || (t == best.t && best.tri != NO_HIT && i < best.tri);
                if hit && better {
                    best = Hit { t, b1, b2, tri: i };
                    if ANY {
                        return best;
                    }
                }
                i += 1;
            }
        } else {
            let left = n.first;
            let right = n.first + 1;
            let (hl, tl) = node_box(&p, &nodes[left as usize], best.t);
            let (hr, tr) = node_box(&p, &nodes[right as usize], best.t);
            if hl && hr {
                let (near, far) = if tl <= tr {
                    (left, right)
                } else {
                    (right, left)
                };
                if sp < MAX_DEPTH {
                    stack[sp] = far;
                    sp += 1;
                }
                node = near;
                descend = true;
            } else if hl {
                node = left;
                descend = true;
            } else if hr {
                node = right;
                descend = true;
            }
        }
        if !descend {
            if sp == 0 {
                break;
            }
            sp -= 1;
            node = stack[sp];
        }
    }
    best
}

/// Closest hit of `ray` with `0 < t < t_max` (see the module docs for the tie rule).
pub fn closest_hit(nodes: &[BvhNode], tris: &[Triangle], ray: &Ray, t_max: f32) -> Hit {
    traverse::<false>(nodes, tris, ray, t_max)
}

/// True if any triangle is hit with `0 < t < t_max` (AO rays).
pub fn occluded(nodes: &[BvhNode], tris: &[Triangle], ray: &Ray, t_max: f32) -> bool {
    any_hit(nodes, tris, ray, t_max).is_hit()
}

/// The first hit found with `0 < t < t_max`, not necessarily the closest (shadow rays: whether,
/// and roughly how far away, something blocks the light).
pub fn any_hit(nodes: &[BvhNode], tris: &[Triangle], ray: &Ray, t_max: f32) -> Hit {
    traverse::<true>(nodes, tris, ray, t_max)
}

/// Closest hit by testing every triangle: the reference the BVH traversal must equal exactly.
pub fn closest_hit_brute_force(tris: &[Triangle], ray: &Ray, t_max: f32) -> Hit {
    let p = prepare(ray);
    let mut best = Hit {
        t: t_max,
        b1: 0.0,
        b2: 0.0,
        tri: NO_HIT,
    };
    let mut i = 0usize;
    while i < tris.len() {
        let (hit, t, b1, b2) = hit_triangle(&p, &tris[i]);
        if hit && t < best.t {
            best = Hit {
                t,
                b1,
                b2,
                tri: i as u32,
            };
        }
        i += 1;
    }
    best
}

#[cfg(all(test, feature = "std"))]
mod tests;
