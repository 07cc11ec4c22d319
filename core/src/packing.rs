//! The engine's G-buffer formats and their conversions, written once with integer ops so every
//! backend decodes the same bits (see [`crate::quantize`] for the binary16 conversions).
//!
//! - **Normal + roughness** in one 32-bit word (NRD's `IN_NORMAL_ROUGHNESS` in R11G11B10 spirit):
//!   the unit shading normal octahedron-encoded in 11 + 11 bits (about 0.06° apart), and the
//!   *linear* roughness `√alpha` (the GGX alpha is its square) as unorm10 in the top bits, so
//!   near-mirror surfaces keep their precision.
//! - **Motion** in two 32-bit words laid out as RGBA16F: `x`, `y` = where the pixel's surface
//!   was last frame minus where it is now, in pixels; `z` = its view depth last frame minus now
//!   (NRD's 2.5D motion: "viewZ delta"); `w` reserved (0). Reprojection needs the previous depth
//!   for its plane test, and the delta keeps full binary16 precision where it matters (small
//!   motion). Values beyond ±65504 saturate: such a pixel was off-screen anyway.
//! - **Hit** (the built-in renderer's own ray-generation data, not a denoiser input): the
//!   geometric normal octahedron-encoded in 16 + 16 bits, and the instance id.

use crate::binary16::{f16_to_f32, f32_to_f16, F16_MAX};
use crate::lanes::Lanes;
use crate::math;
use glam::{Vec2, Vec3};

/// Octahedral encoding of unit `n` in `[-1, 1]²` (Cigolle et al. 2014).
#[inline]
pub fn oct_encode(n: Vec3) -> Vec2 {
    let l1 = math::abs(n.x) + math::abs(n.y) + math::abs(n.z);
    let inv = if l1 > 0.0 { 1.0 / l1 } else { 0.0 };
    let (x, y) = (n.x * inv, n.y * inv);
    if n.z >= 0.0 {
        Vec2::new(x, y)
    } else {
        let sx = if x >= 0.0 { 1.0 } else { -1.0 };
        let sy = if y >= 0.0 { 1.0 } else { -1.0 };
        Vec2::new((1.0 - math::abs(y)) * sx, (1.0 - math::abs(x)) * sy)
    }
}

/// The unit vector of an octahedral code in `[-1, 1]²`.
#[inline]
pub fn oct_decode(e: Vec2) -> Vec3 {
    crate::trace::normalize(oct_direction(e))
}

/// The direction of an octahedral code in `[-1, 1]²`, not normalised (its L1 norm is 1): for
/// callers that divide by its length where it cancels (the filters' normal weights).
#[inline]
pub fn oct_direction(e: Vec2) -> Vec3 {
    let z = 1.0 - math::abs(e.x) - math::abs(e.y);
    // The folded lower half, computed always and selected (vector code over lanes).
    let sx = if e.x >= 0.0 { 1.0 } else { -1.0 };
    let sy = if e.y >= 0.0 { 1.0 } else { -1.0 };
    let fx = (1.0 - math::abs(e.y)) * sx;
    let fy = (1.0 - math::abs(e.x)) * sy;
    let upper = z >= 0.0;
    let x = if upper { e.x } else { fx };
    let y = if upper { e.y } else { fy };
    Vec3::new(x, y, z)
}

/// `v` in `[lo, 1]` (`lo` = −1 or 0) to an unsigned code of `bits` bits, rounded to nearest (NaN
/// gives the code of `lo`).
#[inline]
fn to_code(v: f32, lo: f32, bits: u32) -> u32 {
    let max = ((1u32 << bits) - 1) as f32;
    let t = if v >= lo { math::min(v, 1.0) } else { lo };
    math::floor_small((t - lo) / (1.0 - lo) * max + 0.5)
}

/// The value of a code of [`to_code`].
#[inline]
fn from_code(c: u32, lo: f32, bits: u32) -> f32 {
    let max = ((1u32 << bits) - 1) as f32;
    lo + c as f32 * ((1.0 - lo) / max)
}

/// Packs a unit shading normal and a GGX alpha (stored as its square root, unorm10).
#[inline]
pub fn pack_normal_roughness(n: Vec3, alpha: f32) -> u32 {
    let e = oct_encode(n);
    let r = math::sqrt(math::clamp(alpha, 0.0, 1.0));
    to_code(e.x, -1.0, 11) | (to_code(e.y, -1.0, 11) << 11) | (to_code(r, 0.0, 10) << 22)
}

/// The unit shading normal and GGX alpha of a packed word.
#[inline]
pub fn unpack_normal_roughness(w: u32) -> (Vec3, f32) {
    let r = from_code(w >> 22, 0.0, 10);
    (unpack_normal(w), r * r)
}

/// The unit shading normal of a packed normal + roughness word.
#[inline]
pub fn unpack_normal(w: u32) -> Vec3 {
    crate::trace::normalize(unpack_direction(w))
}

/// The shading normal's direction of a packed normal + roughness word, not normalised
/// ([`oct_direction`]).
#[inline]
pub fn unpack_direction(w: u32) -> Vec3 {
    oct_direction(Vec2::new(
        from_code(w & 0x7ff, -1.0, 11),
        from_code((w >> 11) & 0x7ff, -1.0, 11),
    ))
}

/// `x` saturated to `±65504` (NaN gives 0).
#[inline]
fn saturate_f16(x: f32) -> f32 {
    if x >= -F16_MAX {
        math::min(x, F16_MAX)
    } else if x < 0.0 {
        -F16_MAX
    } else {
        0.0
    }
}

/// binary16 code of `x` saturated to `±65504` (NaN gives 0).
#[inline]
fn f16_saturated(x: f32) -> u32 {
    f32_to_f16(saturate_f16(x))
}

/// binary16 code of a signal value: finite values saturate to ±65504 (a bright sample keeps its
/// ceiling instead of becoming ∞ and being dropped), NaN and ±∞ stay NaN and ±∞ so the noisy
/// signal's clean-up still drops and counts them.
#[inline]
fn f16_signal(x: f32) -> u32 {
    if math::is_finite(x) {
        f16_saturated(x)
    } else {
        f32_to_f16(x)
    }
}

/// Two signal values as binary16 in one word (`a` low): finite values saturate to ±65504, NaN
/// and ±∞ stay NaN and ±∞.
#[inline]
pub fn pack_signal_f16x2(a: f32, b: f32) -> u32 {
    f16_signal(a) | (f16_signal(b) << 16)
}

/// Two values as binary16 in one word (`a` in the low half), saturated to ±65504.
#[inline]
pub fn pack_f16x2(a: f32, b: f32) -> u32 {
    f16_saturated(a) | (f16_saturated(b) << 16)
}

/// The two values of a [`pack_f16x2`] word.
#[inline]
pub fn unpack_f16x2(w: u32) -> (f32, f32) {
    (f16_to_f32(w & 0xffff), f16_to_f32(w >> 16))
}

/// [`pack_f16x2`] of `N` pairs ([`crate::lanes`]), the same codes.
#[inline(always)]
pub fn pack_f16x2_lanes<const N: usize>(a: Lanes<f32, N>, b: Lanes<f32, N>) -> Lanes<u32, N> {
    let (a, b) = (
        a.map(saturate_f16).f32_to_f16(),
        b.map(saturate_f16).f32_to_f16(),
    );
    a.zip(b, |a, b| a | (b << 16))
}

/// [`unpack_f16x2`] of `N` words ([`crate::lanes`]), the same values.
#[inline(always)]
pub fn unpack_f16x2_lanes<const N: usize>(w: Lanes<u32, N>) -> (Lanes<f32, N>, Lanes<f32, N>) {
    #[cfg(target_arch = "spirv")]
    {
        // One conversion instruction for both halves.
        let v = w.map(spirv_std::float::f16x2_to_vec2);
        (v.map(|v| v.x), v.map(|v| v.y))
    }
    #[cfg(not(target_arch = "spirv"))]
    (w.f16_to_f32(), w.map(|w| w >> 16).f16_to_f32())
}

/// Packs 2.5D motion: pixel offset `(dx, dy)` to last frame's position and view-depth change `dz`.
#[inline]
pub fn pack_motion(dx: f32, dy: f32, dz: f32) -> [u32; 2] {
    [pack_f16x2(dx, dy), f16_saturated(dz)]
}

/// `(dx, dy, dz)` of a packed motion.
#[inline]
pub fn unpack_motion(m: [u32; 2]) -> Vec3 {
    let (dx, dy) = unpack_f16x2(m[0]);
    Vec3::new(dx, dy, f16_to_f32(m[1] & 0xffff))
}

/// Packs the renderer's hit data: unit geometric normal (oct 16 + 16 bits) and instance.
#[inline]
pub fn pack_hit(g: Vec3, instance: u32) -> [u32; 2] {
    let e = oct_encode(g);
    [
        to_code(e.x, -1.0, 16) | (to_code(e.y, -1.0, 16) << 16),
        instance,
    ]
}

/// Geometric normal and instance of a packed hit.
#[inline]
pub fn unpack_hit(h: [u32; 2]) -> (Vec3, u32) {
    let e = Vec2::new(
        from_code(h[0] & 0xffff, -1.0, 16),
        from_code(h[0] >> 16, -1.0, 16),
    );
    (oct_decode(e), h[1])
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    fn dirs() -> impl Iterator<Item = Vec3> {
        (0..400).map(|i| {
            let t = i as f32 * 0.618_034;
            let z = 1.0 - 2.0 * ((i as f32 + 0.5) / 400.0);
            let r = (1.0 - z * z).sqrt();
            Vec3::new(
                r * (t * core::f32::consts::TAU).cos(),
                r * (t * core::f32::consts::TAU).sin(),
                z,
            )
        })
    }

    #[test]
    fn normals_and_roughness_survive_packing() {
        for n in dirs().chain([Vec3::X, -Vec3::Y, Vec3::Z, -Vec3::Z]) {
            for alpha in [0.0, 0.0001, 0.04, 0.25, 1.0] {
                let (m, a) = unpack_normal_roughness(pack_normal_roughness(n, alpha));
                assert!(n.dot(m) > 0.999_999 - 2e-6, "{n} {m}");
                assert!((m.length() - 1.0).abs() < 1e-6);
                assert!(
                    (a.sqrt() - alpha.sqrt()).abs() <= 0.5 / 1023.0 + 1e-6,
                    "{alpha} {a}"
                );
            }
        }
        assert_eq!(
            unpack_normal_roughness(pack_normal_roughness(Vec3::Z, 1.0)).1,
            1.0
        );
    }

    #[test]
    fn motion_is_binary16_and_saturates() {
        let m = unpack_motion(pack_motion(3.25, -0.5, 0.001));
        assert_eq!((m.x, m.y), (3.25, -0.5));
        assert!((m.z - 0.001).abs() < 1e-6);
        let far = unpack_motion(pack_motion(-1e9, f32::INFINITY, f32::NAN));
        assert_eq!((far.x, far.y, far.z), (-F16_MAX, F16_MAX, 0.0));
    }

    #[test]
    fn hits_keep_instance_and_geometric_normal() {
        for n in dirs() {
            let (g, i) = unpack_hit(pack_hit(n, 7));
            assert_eq!(i, 7);
            assert!(n.dot(g) > 0.999_999, "{n} {g}");
        }
    }
}
