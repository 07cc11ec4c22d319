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
use crate::sequence::{pcg_hash, R2_STEP};
use glam::Vec3;

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

/// Point `index` of pixel `seed`'s low-discrepancy sequence in `[0, 1)²`: the R2 sequence,
/// Cranley–Patterson rotated by a hash of the seed so neighbouring pixels decorrelate. Wrapping
/// integer arithmetic, so every target gives the same bits and successive indices of one pixel
/// (its rays over frames) stratify the square like the seed's Halton points.
#[inline]
pub fn low_discrepancy(seed: u32, index: u32) -> (f32, f32) {
    let a = pcg_hash(seed).wrapping_add(index.wrapping_mul(R2_STEP[0]));
    let b = pcg_hash(seed ^ 0x85eb_ca6b).wrapping_add(index.wrapping_mul(R2_STEP[1]));
    unit_pair(a, b)
}

/// Fixed-point `[0, 1)²` point to floats: the top 24 bits times `2^-24` (exact, never 1).
#[inline]
pub(crate) fn unit_pair(a: u32, b: u32) -> (f32, f32) {
    let scale = 1.0 / 16_777_216.0;
    ((a >> 8) as f32 * scale, (b >> 8) as f32 * scale)
}

/// Where a pixel's rays draw their first two random numbers
/// ([`TemporalSettings::sampling`](crate::settings::TemporalSettings::sampling)). In settings
/// files: `"per-pixel"` or `"screen-blue"`.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum SamplePattern {
    /// Each pixel's own hashed sequence at the rng index its history carries (AO and shadows:
    /// [`rand`]; reflections: [`low_discrepancy`]): white noise across the screen.
    PerPixel,
    /// [`crate::blue_noise::screen_point`]: a screen-space blue-noise point per pixel, shifted
    /// each frame along R2, so neighbours' samples spread over the square whatever history they
    /// carry, and a still pixel's samples over frames stratify. The default: lower relMSE on
    /// the moving scenes (`docs/algorithms/blue-noise.md`).
    #[default]
    ScreenBlue,
}

/// Pattern code of a reference's replicates (not a setting): every plane's first two random
/// numbers from the per-pixel low-discrepancy sequence, its rotation drawn anew for each
/// replicate (`Stream::new`'s `frame` names the replicate). A reference traced as one
/// stratified sequence per pixel is more accurate than independent samples, and its samples'
/// spread overstates its error; a few independently rotated replicates give an error estimate
/// that does not (randomised quasi-Monte Carlo, `vrrt_scene::render::REPLICATES`).
pub const REPLICATE_PATTERN: u32 = 2;

impl SamplePattern {
    /// The code passed to kernels (`Stream::pattern`).
    pub fn code(self) -> u32 {
        match self {
            SamplePattern::PerPixel => 0,
            SamplePattern::ScreenBlue => 1,
        }
    }
}

/// 32-bit fixed-point steps between the rays one pixel traces in one frame under
/// [`SamplePattern::ScreenBlue`]: `1/φ₃`, `1/φ₃²` for the root `φ₃` of `x⁴ = x + 1`, a Kronecker
/// generator unrelated to the frame's R2 steps, so ray `k` of frame `f` never lands on ray 0 of
/// frame `f + k`.
const RAY_STEP: [u32; 2] = [3_518_319_155, 2_882_110_345];

/// The random numbers of one pixel's rays in one plane and frame: a pure function of the pixel,
/// plane, frame and the index of the frame's 0th ray, so the gradient pass re-creates them.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Stream {
    /// [`pixel_seed`] of the pixel and plane: every random number besides the first two.
    pub seed: u32,
    /// Rng index of the frame's 0th ray.
    pub first: u32,
    /// [`SamplePattern::code`].
    pub pattern: u32,
    /// Screen-blue point of ray 0, first coordinate in 32-bit fixed point; under
    /// [`REPLICATE_PATTERN`] the replicate's salt of the low-discrepancy sequence's seed.
    pub base_u: u32,
    /// Second coordinate of `base_u`'s point.
    pub base_v: u32,
}

impl Stream {
    /// The stream of pixel `(x, y)` in `plane` whose frame `frame` starts at rng index `first`.
    #[inline]
    pub fn new(pattern: u32, x: u32, y: u32, plane: u32, frame: u32, first: u32) -> Self {
        let (base_u, base_v) = if pattern == 1 {
            crate::blue_noise::screen_point(x, y, plane, frame)
        } else if pattern == REPLICATE_PATTERN {
            // Nonzero for every replicate, so none repeats the per-pixel pattern's rotation.
            (pcg_hash(frame ^ 0x6a09_e667) | 1, 0)
        } else {
            (0, 0)
        };
        Stream {
            seed: pixel_seed(x, y, plane),
            first,
            pattern,
            base_u,
            base_v,
        }
    }

    /// Today's per-pixel stream of `seed` (tracer rays, tests).
    #[inline]
    pub fn per_pixel(seed: u32) -> Self {
        Stream {
            seed,
            first: 0,
            pattern: 0,
            base_u: 0,
            base_v: 0,
        }
    }

    /// The screen-blue point of ray `index`: ray 0's point stepped by [`RAY_STEP`] per ray.
    #[inline]
    fn blue(&self, index: u32) -> (f32, f32) {
        let k = index.wrapping_sub(self.first);
        unit_pair(
            self.base_u.wrapping_add(k.wrapping_mul(RAY_STEP[0])),
            self.base_v.wrapping_add(k.wrapping_mul(RAY_STEP[1])),
        )
    }

    /// First two random numbers of ray `index` (AO, shadows): per pixel `rand` dimensions 0, 1;
    /// a reference's replicate ([`REPLICATE_PATTERN`]) takes [`Stream::point_ld`]'s.
    #[inline]
    pub fn point(&self, index: u32) -> (f32, f32) {
        if self.pattern == 1 {
            self.blue(index)
        } else if self.pattern == REPLICATE_PATTERN {
            low_discrepancy(self.seed ^ self.base_u, index)
        } else {
            (rand(self.seed, index, 0), rand(self.seed, index, 1))
        }
    }

    /// As [`Stream::point`], with the per-pixel pattern's [`low_discrepancy`] (reflections),
    /// its rotation salted per replicate under [`REPLICATE_PATTERN`].
    #[inline]
    pub fn point_ld(&self, index: u32) -> (f32, f32) {
        if self.pattern == 1 {
            self.blue(index)
        } else {
            low_discrepancy(self.seed ^ self.base_u, index)
        }
    }
}

/// Smallest GGX alpha the samplers accept: below it the lobe's pdf overflows `f32`.
pub const MIN_ALPHA: f32 = 0.02;

/// GGX (Trowbridge–Reitz) normal distribution `D(h)` for `cos θ_h = n·h` and roughness `alpha`.
#[inline]
pub fn ggx_d(n_dot_h: f32, alpha: f32) -> f32 {
    if !(n_dot_h > 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    a2 / (core::f32::consts::PI * t * t)
}

/// Smith masking `G1(v)` of GGX for `cos θ_v = n·v`.
#[inline]
pub fn smith_g1(n_dot_v: f32, alpha: f32) -> f32 {
    if !(n_dot_v > 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    2.0 * n_dot_v / (n_dot_v + math::sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v))
}

/// A GGX microfacet normal drawn from the distribution of normals visible from `wo` (Heitz 2018,
/// "Sampling the GGX Distribution of Visible Normals"), around unit normal `n`, from
/// `(u1, u2) ∈ [0,1)²`. Reflecting `wo` about it gives [`ggx_reflection_pdf`]'s distribution;
/// unlike sampling `D(h)`, no half vector faces away from the viewer.
#[inline]
pub fn ggx_vndf(n: Vec3, wo: Vec3, alpha: f32, u1: f32, u2: f32) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    let local = Vec3::new(wo.dot(t), wo.dot(b), wo.dot(n));
    // Stretch to the hemisphere configuration (roughness 1).
    let v = crate::trace::normalize(Vec3::new(alpha * local.x, alpha * local.y, local.z));
    let len2 = v.x * v.x + v.y * v.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-v.y, v.x, 0.0) * (1.0 / math::sqrt(len2))
    } else {
        Vec3::X
    };
    let t2 = v.cross(t1);
    let r = math::sqrt(u1);
    let (s, c) = math::sin_cos_turns(u2);
    let p1 = r * c;
    let h = 0.5 * (1.0 + v.z);
    let p2 = (1.0 - h) * math::sqrt(math::max(1.0 - p1 * p1, 0.0)) + h * r * s;
    let p3 = math::sqrt(math::max(1.0 - p1 * p1 - p2 * p2, 0.0));
    let m = t1 * p1 + t2 * p2 + v * p3;
    // Unstretch and back to world space.
    let m = crate::trace::normalize(Vec3::new(alpha * m.x, alpha * m.y, math::max(m.z, 0.0)));
    t * m.x + b * m.y + n * m.z
}

/// Density (per solid angle) of the direction `wi` obtained by reflecting `wo` about a
/// [`ggx_vndf`] normal: `G1(wo)·D(h) / (4·n·wo)` with `h = wo + wi`; 0 for directions below the
/// surface or a `wo` behind it.
///
/// `D` is evaluated as `α² / (π·(α²·cos²θ_h + sin²θ_h)²)` with `sin²θ_h` from `|n × h|²`, not
/// `1 − cos²θ_h`: near the mirror direction of a smooth lobe the textbook form cancels
/// catastrophically (one ULP of `cos θ_h` moves the pdf of an alpha-0.02 lobe by 1e-4).
#[inline]
pub fn ggx_reflection_pdf(n: Vec3, wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let n_dot_o = n.dot(wo);
    if !(n_dot_o > 0.0) || !(n.dot(wi) > 0.0) {
        return 0.0;
    }
    let h = wo + wi;
    let cos = n.dot(h);
    let sin = n.cross(h);
    let len2 = h.dot(h);
    if !(len2 > 0.0) || !(cos > 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    // (α²cos² + sin²) / |h|², kept unnormalised until the end.
    let t = a2 * cos * cos + sin.dot(sin);
    let d = a2 * len2 * len2 / (core::f32::consts::PI * t * t);
    smith_g1(n_dot_o, alpha) * d / (4.0 * n_dot_o)
}

/// Mirror reflection of `v` (pointing away from the surface) about unit `n`.
#[inline]
pub fn reflect(v: Vec3, n: Vec3) -> Vec3 {
    n * (2.0 * v.dot(n)) - v
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

    #[test]
    fn low_discrepancy_stratifies_the_square() {
        // 256 successive points of one pixel: every cell of a 4x4 grid holds 16 ± 3.
        let seed = pixel_seed(9, 4, 2);
        let mut cells = [0u32; 16];
        for i in 0..256 {
            let (a, b) = low_discrepancy(seed, i);
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
            cells[(a * 4.0) as usize * 4 + (b * 4.0) as usize] += 1;
        }
        assert!(cells.iter().all(|&c| (13..=19).contains(&c)), "{cells:?}");
        assert_ne!(low_discrepancy(seed, 0), low_discrepancy(seed ^ 1, 0));
    }

    #[test]
    fn streams_are_pure_and_never_repeat_a_ray() {
        for pattern in [0, 1] {
            let s = Stream::new(pattern, 4, 9, 1, 30, 100);
            assert_eq!(s, Stream::new(pattern, 4, 9, 1, 30, 100));
            let (a, b) = s.point(103);
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
            assert_ne!(s.point(100), s.point(101));
        }
        // Screen-blue: ray k of frame f is not ray 0 of frame f + k, whatever the index.
        let s = Stream::new(1, 4, 9, 1, 30, 100);
        for k in 1..16 {
            let later = Stream::new(1, 4, 9, 1, 30 + k, 100 + k);
            assert_ne!(s.point(100 + k), later.point(100 + k), "ray {k}");
        }
        // The per-pixel pattern is today's numbers.
        let seed = pixel_seed(4, 9, 1);
        let s = Stream::new(0, 4, 9, 1, 30, 100);
        assert_eq!(s.point(7), (rand(seed, 7, 0), rand(seed, 7, 1)));
        assert_eq!(s.point_ld(7), low_discrepancy(seed, 7));
        // A replicate: the low-discrepancy sequence for both points, its rotation differing
        // from the per-pixel pattern's and from every other replicate's.
        let replicates: [Stream; 8] =
            core::array::from_fn(|j| Stream::new(REPLICATE_PATTERN, 4, 9, 1, j as u32, 100));
        for (j, r) in replicates.iter().enumerate() {
            assert_eq!(r.point(7), r.point_ld(7));
            assert_ne!(r.point_ld(7), s.point_ld(7));
            for other in &replicates[..j] {
                assert_ne!(r.point_ld(7), other.point_ld(7));
            }
        }
    }

    /// Monte Carlo integral of `f` over the sphere with `count` uniform directions.
    fn sphere_integral(count: u32, f: impl Fn(Vec3) -> f64) -> f64 {
        let seed = pixel_seed(5, 6, 7);
        let mut sum = 0.0;
        for i in 0..count {
            let z = 1.0 - 2.0 * rand(seed, i, 0);
            let r = (1.0 - z * z).max(0.0).sqrt();
            let (s, c) = math::sin_cos_turns(rand(seed, i, 1));
            sum += f(Vec3::new(r * c, r * s, z));
        }
        sum * 4.0 * core::f64::consts::PI / count as f64
    }

    #[test]
    fn ggx_reflection_pdf_integrates_to_the_mass_above_the_surface() {
        let n = Vec3::new(0.1, 0.2, 0.97).normalize();
        for (alpha, wo) in [
            (0.3, Vec3::new(0.5, 0.0, 0.8).normalize()),
            (0.6, Vec3::new(-0.9, 0.1, 0.3).normalize()),
            (1.0, n),
        ] {
            let total = sphere_integral(400_000, |w| ggx_reflection_pdf(n, wo, w, alpha) as f64);
            // Reflected directions below the surface are cut: the mass is at most 1.
            let seed = pixel_seed(1, 1, 1);
            let above = (0..20_000)
                .filter(|&i| {
                    let m = ggx_vndf(n, wo, alpha, rand(seed, i, 0), rand(seed, i, 1));
                    reflect(wo, m).dot(n) > 0.0
                })
                .count() as f64
                / 20_000.0;
            assert!(
                (total - above).abs() < 0.03,
                "alpha {alpha}: {total} vs {above}"
            );
        }
    }

    #[test]
    fn vndf_samples_follow_the_reflection_pdf() {
        // E_pdf[g] = ∫ g·pdf for g = n·wi: sampled mean against the integral.
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let alpha = 0.4;
        let seed = pixel_seed(2, 3, 4);
        let count = 100_000;
        let mut sum = 0.0f64;
        for i in 0..count {
            let m = ggx_vndf(n, wo, alpha, rand(seed, i, 0), rand(seed, i, 1));
            assert!((m.length() - 1.0).abs() < 1e-4 && m.dot(n) >= 0.0 && m.dot(wo) >= -1e-5);
            let wi = reflect(wo, m);
            sum += wi.dot(n).max(0.0) as f64;
        }
        let sampled = sum / count as f64;
        let integral = sphere_integral(400_000, |w| {
            (w.dot(n) as f64) * ggx_reflection_pdf(n, wo, w, alpha) as f64
        });
        assert!((sampled - integral).abs() < 0.01, "{sampled} vs {integral}");
    }
}
