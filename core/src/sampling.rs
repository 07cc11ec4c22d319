//! Per-pixel hash random numbers and the sampling routines built on them.
//!
//! Seed: vrrt-call-of-duty-2026, "How to handle rng?": every pixel owns an independent random
//! sequence (its *seed* comes from the pixel coordinates and the signal plane), and the position in
//! that sequence (the *rng index*) is reprojected with the payload and advanced by the number of
//! rays traced. The `i`-th ray of a frame uses index `rng_index + i`.
//!
//! Everything here is integer hashing plus plain float arithmetic, so all backends produce the same
//! bits: a ray is a pure function of `(seed, index, G-buffer texel)`, which is what the temporal
//! gradient pass needs to re-create last frame's ray.

use crate::math;
use glam::Vec3;

/// One round of the PCG output permutation as a 32-bit hash (Jarzynski & Olano 2020, "Hash
/// Functions for GPU Rendering"). A bijection of `u32`, integer ops only.
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// Seed of the random sequence of pixel `(x, y)` in signal plane `plane`.
#[inline]
pub fn pixel_seed(x: u32, y: u32, plane: u32) -> u32 {
    pcg_hash(x ^ pcg_hash(y ^ pcg_hash(plane ^ 0x9e37_79b9)))
}

/// The `dimension`-th random number of sample `index` in the sequence `seed`, as 32 random bits.
///
/// `hash(seed ^ hash(index + hash(dimension)))`: for a fixed seed and dimension the map
/// `index → bits` is a bijection (no two indices of a pixel share a value), and changing any input
/// decorrelates the output.
#[inline]
pub fn rand_u32(seed: u32, index: u32, dimension: u32) -> u32 {
    pcg_hash(seed ^ pcg_hash(index.wrapping_add(pcg_hash(dimension))))
}

/// The `dimension`-th random number of sample `index` in the sequence `seed`, in `[0, 1)`.
///
/// The top 24 bits of [`rand_u32`] times `2^-24`: exact on every target, never 1.
#[inline]
pub fn rand(seed: u32, index: u32, dimension: u32) -> f32 {
    (rand_u32(seed, index, dimension) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// An orthonormal basis `(t, b)` completing unit vector `n` (right-handed: `t × b = n`).
///
/// Duff et al. 2017, "Building an Orthonormal Basis, Revisited": continuous everywhere except the
/// `n.z` sign switch, and exact at `n = ±z` (no division by a vanishing quantity).
#[inline]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

/// Cosine-weighted direction on the hemisphere around unit `n` from `(u1, u2) ∈ [0,1)²`.
///
/// Malley's method: `r = √u1`, `φ = 2π·u2`, local `(r cos φ, r sin φ, √(1 − u1))`; pdf `cos θ / π`.
#[inline]
pub fn cosine_hemisphere(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = math::sqrt(u1);
    let (s, c) = math::sin_cos_turns(u2);
    let z = math::sqrt(math::max(1.0 - u1, 0.0));
    let (t, b) = orthonormal_basis(n);
    t * (r * c) + b * (r * s) + n * z
}

/// A point distributed uniformly on the parallelogram `corner + u1·edge_u + u2·edge_v`
/// (a rectangle when the edges are orthogonal); pdf `1 / |edge_u × edge_v|` per unit area.
#[inline]
pub fn parallelogram_point(corner: Vec3, edge_u: Vec3, edge_v: Vec3, u1: f32, u2: f32) -> Vec3 {
    corner + edge_u * u1 + edge_v * u2
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    #[test]
    fn rand_is_in_unit_interval_and_well_spread() {
        let seed = pixel_seed(17, 42, 0);
        let mut sum = 0.0f64;
        let mut buckets = [0u32; 16];
        let n = 100_000u32;
        for i in 0..n {
            let u = rand(seed, i, 0);
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
            buckets[(u * 16.0) as usize] += 1;
        }
        let mean = sum / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "mean {mean}");
        for b in buckets {
            assert!(
                (b as f64 - n as f64 / 16.0).abs() < 0.05 * n as f64 / 16.0,
                "{buckets:?}"
            );
        }
        assert_eq!(rand(seed, 7, 3), rand(seed, 7, 3));
        assert_ne!(rand(seed, 7, 3), rand(seed, 7, 4));
        assert_ne!(pixel_seed(0, 1, 0), pixel_seed(1, 0, 0));
        assert_ne!(pixel_seed(0, 0, 1), pixel_seed(0, 0, 0));
    }

    #[test]
    fn dimensions_are_uncorrelated() {
        let seed = pixel_seed(3, 5, 1);
        let n = 50_000;
        let (mut sxy, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..n {
            let x = rand(seed, i, 0) as f64;
            let y = rand(seed, i, 1) as f64;
            sxy += x * y;
            sx += x;
            sy += y;
        }
        let n = n as f64;
        let cov = sxy / n - (sx / n) * (sy / n);
        assert!(cov.abs() < 0.002, "covariance {cov}");
    }

    #[test]
    fn basis_is_orthonormal_including_poles() {
        let dirs = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.0, 0.0, -0.0),
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
            Vec3::new(0.3, -0.4, 0.866).normalize(),
            Vec3::new(-0.6, 0.1, -0.2).normalize(),
        ];
        for n in dirs {
            let n = if n.length() == 0.0 { Vec3::Z } else { n };
            let (t, b) = orthonormal_basis(n);
            for (u, v) in [(t, b), (t, n), (b, n)] {
                assert!(u.dot(v).abs() < 1e-6, "{n} {t} {b}");
            }
            assert!((t.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
            assert!((t.cross(b) - n).length() < 1e-5, "handedness at {n}");
        }
    }

    #[test]
    fn cosine_hemisphere_has_cosine_mean() {
        // E[cos θ] = 2/3 under the cosine-weighted pdf.
        let n = Vec3::new(0.2, -0.5, 0.8).normalize();
        let seed = pixel_seed(1, 2, 3);
        let count = 50_000;
        let mut sum = 0.0f64;
        for i in 0..count {
            let d = cosine_hemisphere(n, rand(seed, i, 0), rand(seed, i, 1));
            assert!((d.length() - 1.0).abs() < 1e-5);
            let c = d.dot(n);
            assert!(c >= -1e-6);
            sum += c as f64;
        }
        let mean = sum / count as f64;
        assert!((mean - 2.0 / 3.0).abs() < 0.005, "mean cos {mean}");
    }

    #[test]
    fn parallelogram_corners() {
        let p = parallelogram_point(Vec3::ONE, Vec3::X, Vec3::Y * 2.0, 0.5, 0.5);
        assert_eq!(p, Vec3::new(1.5, 2.0, 1.0));
    }
}
