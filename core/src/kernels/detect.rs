//! The change detector: before accumulation, tests whether this frame's rays still agree with
//! the reprojected history around each pixel, and where they do not, tells accumulation how much
//! history to drop (`λ`, read as the temporal gradient is read by reprojection).
//!
//! Seed: vrrt-call-of-duty-2026 ("Temporal gradients": history must react to what changed;
//! "Undersampling": rays go where history was lost). A-SVGF re-traces a few of last frame's rays
//! to take the noise out of the comparison, one binary ray per stratum; a slowly sliding penumbra
//! then reads as a small `λ` and history lags. This test spends no extra ray: it compares the
//! rays VRRT traced anyway, every pixel of a `(2r+1)²` window, and takes the noise out
//! statistically. Each traced pixel `q` with history gives `d_q = s_q − m_q` (this frame's mean
//! against its own history mean, so edges inside the window bias nothing); with nothing changed
//! `D = Σ d_q` has mean 0 and variance `V = Σ σ_q² (1/n_q + 1/c_q)` (`σ_q²` the history's per-ray
//! variance, at least `min_variance`; `n_q` rays traced; `c_q` history length). The change is the
//! relative gradient of the window sums, `|Σ s − Σ m| / max(Σ s, Σ m)` (A-SVGF's normalisation),
//! counted only as far as it is significant: fully from `z = |D| / √V` of `z_full`, not at all
//! below `z_full − 1`. A rare ray that disagrees with a converged pixel is significant but moves
//! the window sums little, so it shortens history by little.

use super::DetectIo;
use super::{plane_in, plane_index};
use crate::lanes::{self, Lanes};
use crate::math;
use crate::payload::{PackedPayload, PackedSample, Payload, Sample};
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`detect`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DetectParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Window radius in pixels.
    pub radius: u32,
    /// Window radius of the planes in `shadow_planes`.
    pub shadow_radius: u32,
    /// Significance (in standard deviations of `D`) from which a change counts fully.
    pub z_full: f32,
    /// Floor of the per-ray variance (signal units squared): a converged pixel's history
    /// variance may read 0.
    pub min_variance: f32,
    /// Planes (bit per plane) that take `shadow_radius` (`Layout::shadow_planes`).
    pub shadow_planes: u32,
    /// Planes (bit per plane) that take `ao_z_full` (`Layout::ao_planes`).
    pub ao_planes: u32,
    /// `z_full` of the planes in `ao_planes`.
    pub ao_z_full: f32,
    /// Gain of `λ` on the planes in `ao_planes` ([`plane_lambda`]); 1 or below leaves it as is.
    pub ao_gain: f32,
    /// Where that gain stops: the AO planes' drop threshold, so the gain shortens history and
    /// never drops it on its own.
    pub ao_cap: f32,
}

/// One call per `N` consecutive pixels of a row and one signal plane ([`crate::lanes`]):
/// `changes = λ` in `[0, 1]` (module rule).
#[inline(always)]
pub fn detect<const N: usize>(id: UVec3, p: &DetectParams, io: DetectIo<'_>) {
    let DetectIo {
        history,
        samples,
        changes,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    lambda::<N>(id, p, history, samples).store(changes, plane_index(id, w, h), live);
}

/// `λ` of the `N` pixels of a row from `id` on plane `id.z` (module rule); `id` inside the image.
#[inline(always)]
pub fn lambda<const N: usize>(
    id: UVec3,
    p: &DetectParams,
    history: &[PackedPayload],
    samples: &[PackedSample],
) -> Lanes<f32, N> {
    let (w, h) = (p.width, p.height);
    let (r, z_full) = plane_window(p, id.z);
    let r = r as i32;
    let x0 = id.x as i32;
    // Window sums of this frame's means, the history means and the variance of their difference.
    let mut sums = [Lanes::<f32, N>::splat(0.0); 3];
    // A row's terms do not depend on the pixel that sums them. Where the `N + 2r` columns a row
    // of lanes reads fit three blocks of `N` (the CPU's rows), each column's term is computed
    // once per row, not once per tap; otherwise (the GPU's single lane with `r > 1`) once per
    // tap. The same terms added in the same order: the same bits either way.
    let window = r <= N as i32;
    let mut dy = -r;
    while dy <= r {
        let qy = id.y as i32 + dy;
        if qy >= 0 && qy < h as i32 {
            let row = (id.z * h + qy as u32) * w;
            if window {
                // Field by field, three blocks of `N` columns: windows slide across them.
                let mut blocks = [[[0.0; N]; 3]; 3];
                let mut b = 0;
                while b * N < N + 2 * r as usize {
                    let t = terms::<N>(samples, history, row, x0 - r + (b * N) as i32, p);
                    let mut k = 0;
                    while k < 3 {
                        blocks[k][b] = t[k];
                        k += 1;
                    }
                    b += 1;
                }
                let mut k = 0;
                while k < 3 {
                    let mut acc = sums[k];
                    let mut o = 0;
                    while o <= 2 * r as usize {
                        acc = acc.zip(Lanes::window(&blocks[k], o), |a, b| a + b);
                        o += 1;
                    }
                    sums[k] = acc;
                    k += 1;
                }
            } else {
                let mut dx = -r;
                while dx <= r {
                    let t = terms::<N>(samples, history, row, x0 + dx, p);
                    // Constant indices: a GPU keeps the sums in registers (indexed by a loop
                    // counter, the arrays went through memory).
                    sums[0] = sums[0].zip(Lanes(t[0]), |a, b| a + b);
                    sums[1] = sums[1].zip(Lanes(t[1]), |a, b| a + b);
                    sums[2] = sums[2].zip(Lanes(t[2]), |a, b| a + b);
                    dx += 1;
                }
            }
        }
        dy += 1;
    }
    let [sum_s, sum_m, var] = sums;
    Lanes::<f32, N>::from_index(|l| {
        let l = l as usize;
        plane_lambda(
            p,
            id.z,
            lambda_of([sum_s.0[l], sum_m.0[l], var.0[l]], z_full),
        )
    })
}

/// `λ` of plane `z` from the window's [`lambda_of`]: on the AO planes times `ao_gain`, up to
/// `ao_cap`, and never below `λ` itself. AO changes only where geometry moves and changes
/// slowly there (a soft contact shadow darkens a floor pixel by a few hundredths a frame): the
/// window's relative gradient reads such a ramp as a `λ` of a few hundredths, which leaves a
/// history about as long as a converged one, and the pixel lags. Scaled up, the same `λ` keeps
/// the history short for as long as the change goes on, while a chance `λ` on converged history
/// stays small: what is shortened by chance refills in a few frames. Capped at the drop
/// threshold, the gain never drops a history that `λ` alone would keep (see
/// `docs/algorithms/change-detector.md`).
#[inline(always)]
pub fn plane_lambda(p: &DetectParams, z: u32, lambda: f32) -> f32 {
    if plane_in(p.ao_planes, z) {
        gained(lambda, p.ao_gain, p.ao_cap)
    } else {
        lambda
    }
}

/// `λ · gain` up to `cap`, and never below `λ`.
#[inline(always)]
fn gained(lambda: f32, gain: f32, cap: f32) -> f32 {
    math::max(lambda, math::min(lambda * gain, cap))
}

/// `λ` of a pixel from its window's sums of this frame's means, the history means and the
/// variance of their difference (module rule), counted fully from `z_full` standard deviations.
#[inline(always)]
pub fn lambda_of([sum_s, sum_m, var]: [f32; 3], z_full: f32) -> f32 {
    let diff = math::abs(sum_s - sum_m);
    let top = math::max(sum_s, sum_m);
    let z = diff / math::sqrt(var);
    let significance = math::saturate(z - (z_full - 1.0));
    let lambda = math::saturate(diff / top) * significance;
    if top > 0.0 && var > 0.0 {
        lambda
    } else {
        0.0
    }
}

/// `z_full` of the AO planes at this frame's budget of `rays_per_pixel`: `ao_sigma` from one ray
/// per pixel up, raised as `1/√rpp` below it. The window's variance of the change rests on the
/// rays it holds: with half as many, chance differences reach a given z more often and
/// converged history is shortened by chance, while at one ray per pixel and more the lowest
/// significance let the contact shadows of moving objects lag least
/// (`docs/algorithms/change-detector.md`). Host-side, once a frame.
pub fn ao_significance(ao_sigma: f32, rays_per_pixel: f32) -> f32 {
    ao_sigma / math::sqrt(math::clamp(rays_per_pixel, 1.0 / 64.0, 1.0))
}

/// The window radius and `z_full` of plane `z` (`p.radius` and `p.z_full`, or the shadow and
/// AO planes' own).
#[inline(always)]
pub fn plane_window(p: &DetectParams, z: u32) -> (u32, f32) {
    (
        per_plane(p.radius, p.shadow_radius, p.shadow_planes, z),
        per_plane(p.z_full, p.ao_z_full, p.ao_planes, z),
    )
}

/// The detector's setting for plane `plane` (its window radius, significance, the `λ` above
/// which history is dropped): `special` on the planes of the mask `planes` (e.g.
/// `Layout::shadow_planes`), `general` on the others.
#[inline]
pub fn per_plane<T: Copy>(general: T, special: T, planes: u32, plane: u32) -> T {
    if plane_in(planes, plane) {
        special
    } else {
        general
    }
}

/// Variance of the difference between the mean of `n` new rays and a history mean of `c` rays,
/// both of per-ray variance `v` (at least `min_variance`): the noise both tests measure against.
#[inline]
fn difference_variance(v: f32, min_variance: f32, n: u32, c: f32) -> f32 {
    math::max(v, min_variance) * (1.0 / n as f32 + 1.0 / c)
}

/// How many standard deviations this frame's rays `s` lie from the pixel's history `m` (its
/// per-ray variance taken at least `min_variance`): the pixel's own test, which the window sums
/// dilute. 0 without rays or history.
#[inline]
pub fn pixel_z(s: Sample, m: Payload, min_variance: f32) -> f32 {
    let (n, c) = (s.rays, m.count);
    let var = difference_variance(m.variance(), min_variance, n, c);
    let z = math::abs(s.m1 - m.m1) / math::sqrt(var);
    if n > 0 && c > 0.0 && var > 0.0 && math::is_finite(z) {
        z
    } else {
        0.0
    }
}

/// What the pixels of `N` lanes add to the window sums around them (module rule): this frame's
/// mean, its history mean and the variance of their difference where the pixel counts (inside
/// the image, traced, with history, finite), +0 where it does not. The sums start at +0, so
/// adding +0 gives the bits of not adding.
type Terms<const N: usize> = [[f32; N]; 3];

/// The [`Terms`] of row `row` at columns `qx0 + l`.
#[inline(always)]
fn terms<const N: usize>(
    samples: &[PackedSample],
    history: &[PackedPayload],
    row: u32,
    qx0: i32,
    p: &DetectParams,
) -> Terms<N> {
    let w = p.width;
    let s = Lanes::<PackedSample, N>::load_row(samples, row, qx0, w);
    let m = Lanes::<PackedPayload, N>::load_row(history, row, qx0, w);
    let mut t = [[0.0; N]; 3];
    // The test spelled out here, not through `pixel_terms`: called, the row stayed scalar
    // code (the detector took three times as long on the CPU).
    lanes::each_lane!(l in N {
        let (s, m, qx) = (s.0[l].unpack(), m.0[l].unpack(), qx0 + l as i32);
        let counts =
            qx >= 0 && qx < w as i32 && s.rays > 0 && m.count > 0.0 && math::is_finite(s.m1);
        let v = difference_variance(m.variance(), p.min_variance, s.rays, m.count);
        if counts {
            t[0][l] = s.m1;
            t[1][l] = m.m1;
            t[2][l] = v;
        }
    });
    t
}

/// Whether a pixel (its rays `s`, its history `m`, `inside` the image) adds to the window sums
/// around it: traced, with history, finite.
#[inline(always)]
fn counts(s: Sample, m: Payload, inside: bool) -> bool {
    inside && s.rays > 0 && m.count > 0.0 && math::is_finite(s.m1)
}

/// What one pixel adds to the window sums around it: this frame's mean, its history mean and the
/// variance of their difference where it counts (`inside` the image, traced, with history,
/// finite), +0 where it does not.
#[inline(always)]
pub fn pixel_terms(s: Sample, m: Payload, inside: bool, p: &DetectParams) -> [f32; 3] {
    let v = difference_variance(m.variance(), p.min_variance, s.rays, m.count);
    if counts(s, m, inside) {
        [s.m1, m.m1, v]
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::payload::{Payload, Sample};

    const W: u32 = 9;

    /// [`pixel_z`] of `n` rays of mean `s` against a history of mean `m`, `c` rays and per-ray
    /// variance `v`.
    fn z_of(s: f32, n: u32, m: f32, c: f32, v: f32, min_variance: f32) -> f32 {
        let rays = Sample {
            m1: s,
            m2: s * s,
            rays: n,
            first: s,
        };
        let history = Payload {
            m1: m,
            m2: v + m * m,
            count: c,
            rng_index: 0,
        };
        pixel_z(rays, history, min_variance)
    }

    #[test]
    fn ao_significance_rises_only_below_one_ray_per_pixel() {
        assert_eq!(ao_significance(1.0, 1.0), 1.0);
        assert_eq!(ao_significance(1.0, 4.0), 1.0);
        assert!((ao_significance(1.0, 0.5) - 2f32.sqrt()).abs() < 1e-6);
        assert!((ao_significance(1.5, 0.25) - 3.0).abs() < 1e-6);
        // A vanishing budget gives a finite significance.
        assert!((ao_significance(1.0, 1e-6) - 8.0).abs() < 1e-5);
    }

    #[test]
    fn pixel_z_measures_a_pixel_against_its_history() {
        // Four dark rays under a lit history of 5.7 rays (p = 0.82): 3.27σ.
        let z = z_of(0.0, 4, 0.82, 5.7, 0.82 * 0.18, 1e-4);
        assert!((z - 3.27).abs() < 0.01, "{z}");
        // One dark ray is a fifth of the time what that history gives: under 2σ.
        assert!(z_of(0.0, 1, 0.82, 5.7, 0.82 * 0.18, 1e-4) < 2.0);
        // A converged history of variance 0 takes the floor.
        let floor = z_of(0.01, 1, 0.0, 64.0, 0.0, 1e-4);
        assert!((floor - 0.01 / (1e-4f32 * (1.0 + 1.0 / 64.0)).sqrt()).abs() < 1e-4);
        // No rays, no history, or no variance at all: nothing to test.
        assert_eq!(z_of(0.0, 0, 0.82, 5.7, 0.15, 1e-4), 0.0);
        assert_eq!(z_of(0.0, 4, 0.82, 0.0, 0.15, 1e-4), 0.0);
        assert_eq!(z_of(0.5, 4, 0.82, 5.7, 0.0, 0.0), 0.0);
    }

    /// `λ` at the centre of a `W × W` image whose history has mean `m` (variance `v`, 32 rays)
    /// and whose pixels traced one ray each this frame, of value `sample(x, y)`.
    fn lambda_at_centre(m: f32, v: f32, sample: impl Fn(u32, u32) -> f32) -> f32 {
        let history: std::vec::Vec<PackedPayload> = (0..W * W)
            .map(|_| {
                Payload {
                    m1: m,
                    m2: v + m * m,
                    count: 32.0,
                    rng_index: 0,
                }
                .pack()
            })
            .collect();
        let samples: std::vec::Vec<PackedSample> = (0..W * W)
            .map(|i| {
                let s = sample(i % W, i / W);
                Sample {
                    m1: s,
                    m2: s * s,
                    rays: 1,
                    first: s,
                }
                .pack()
            })
            .collect();
        let mut changes = std::vec![0.0f32; (W * W) as usize];
        let p = DetectParams {
            width: W,
            height: W,
            radius: 2,
            z_full: 3.0,
            min_variance: 1e-4,
            ..Default::default()
        };
        for i in 0..W * W {
            let io = DetectIo {
                history: &history,
                samples: &samples,
                changes: &mut changes,
            };
            detect::<1>(UVec3::new(i % W, i / W, 0), &p, io);
        }
        changes[(W * W / 2) as usize]
    }

    /// `λ` of every pixel of a `w × h` image of pseudo-random history and samples (some
    /// pixels untraced, without history or NaN), computed `N` lanes per call.
    fn lambdas<const N: usize>(w: u32, h: u32, radius: u32) -> std::vec::Vec<u32> {
        let p = DetectParams {
            width: w,
            height: h,
            radius,
            z_full: 1.5,
            min_variance: 1e-4,
            ..Default::default()
        };
        lambdas_with::<N>(&p)
    }

    /// [`lambdas`] of plane 0 under the parameters `p`.
    fn lambdas_with<const N: usize>(p: &DetectParams) -> std::vec::Vec<u32> {
        let (w, h) = (p.width, p.height);
        let mut rng = 0x9e37_79b9u32;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 17;
            rng ^= rng << 5;
            rng
        };
        let (mut history, mut samples) = (std::vec::Vec::new(), std::vec::Vec::new());
        for _ in 0..w * h {
            let (m, c) = ((next() % 1000) as f32 / 999.0, (next() % 40) as f32);
            history.push(
                Payload {
                    m1: m,
                    m2: m * m + 0.01,
                    count: c,
                    rng_index: 0,
                }
                .pack(),
            );
            let s = if next() % 50 == 0 {
                f32::NAN
            } else {
                (next() % 1000) as f32 / 999.0
            };
            let rays = next() % 3;
            samples.push(
                Sample {
                    m1: s,
                    m2: s * s,
                    rays,
                    first: s,
                }
                .pack(),
            );
        }
        let mut changes = std::vec![0.0f32; (w * h) as usize];
        for y in 0..h {
            for x in (0..w).step_by(N) {
                let io = DetectIo {
                    history: &history,
                    samples: &samples,
                    changes: &mut changes,
                };
                detect::<N>(UVec3::new(x, y, 0), p, io);
            }
        }
        changes.iter().map(|c| c.to_bits()).collect()
    }

    #[test]
    fn rows_of_lanes_give_the_bits_of_single_pixels() {
        // One lane sums per tap (radius > 1), rows of 8 and 16 through the sliding window
        // (radius up to the row width) or per tap (radius 9 over 8 lanes).
        for radius in [1, 2, 3, 9] {
            let one = lambdas::<1>(37, 11, radius);
            assert!(one.iter().any(|&b| f32::from_bits(b) > 0.0));
            assert_eq!(lambdas::<8>(37, 11, radius), one, "radius {radius}");
            assert_eq!(lambdas::<16>(37, 11, radius), one, "radius {radius}");
        }
    }

    #[test]
    fn shadow_planes_take_the_shadow_radius() {
        let (w, h) = (37, 11);
        let one = lambdas::<8>(w, h, 1);
        let mut p = DetectParams {
            width: w,
            height: h,
            radius: 3,
            shadow_radius: 1,
            z_full: 1.5,
            min_variance: 1e-4,
            ..Default::default()
        };
        assert_ne!(lambdas_with::<8>(&p), one, "radius 3 must differ");
        p.shadow_planes = 1;
        assert_eq!(lambdas_with::<8>(&p), one);
        p.shadow_planes = 2;
        assert_eq!(lambdas_with::<8>(&p), lambdas::<8>(w, h, 3));
    }

    #[test]
    fn ao_planes_take_the_gain_up_to_the_drop_threshold() {
        let mut p = DetectParams {
            width: 37,
            height: 11,
            radius: 2,
            z_full: 1.5,
            ao_z_full: 1.5,
            min_variance: 1e-4,
            ao_gain: 3.0,
            ao_cap: 0.5,
            ..Default::default()
        };
        let plain = lambdas_with::<8>(&p);
        p.ao_planes = 1;
        let gained = lambdas_with::<8>(&p);
        let (mut raised, mut capped) = (0, 0);
        for (a, b) in plain.iter().zip(&gained) {
            let (a, b) = (f32::from_bits(*a), f32::from_bits(*b));
            // Never below λ, never a drop λ alone would not make, else exactly λ · gain.
            assert!(b >= a, "{b} < {a}");
            if a <= 0.5 {
                assert!(b <= 0.5, "{a} became {b}, past the drop threshold");
            }
            let expected = if a * 3.0 >= 0.5 { a.max(0.5) } else { a * 3.0 };
            assert!(
                (b - expected).abs() <= 1e-6 * expected.max(1.0),
                "{a} → {b}"
            );
            raised += (b > a) as u32;
            capped += (a < 0.5 && b == 0.5) as u32;
        }
        assert!(raised > 0 && capped > 0, "raised {raised}, capped {capped}");
        // The other planes keep their λ, and a gain of 1 changes nothing.
        p.ao_planes = 2;
        assert_eq!(lambdas_with::<8>(&p), plain);
        p.ao_planes = 1;
        p.ao_gain = 1.0;
        assert_eq!(lambdas_with::<8>(&p), plain);
    }

    #[test]
    fn ao_planes_take_the_ao_significance() {
        let mut p = DetectParams {
            width: 37,
            height: 11,
            radius: 2,
            z_full: 1.5,
            ao_z_full: 3.0,
            min_variance: 1e-4,
            ..Default::default()
        };
        let general = lambdas_with::<8>(&p);
        p.z_full = 3.0;
        let strict = lambdas_with::<8>(&p);
        assert_ne!(general, strict, "the significance must matter here");
        p.z_full = 1.5;
        p.ao_planes = 1;
        assert_eq!(lambdas_with::<8>(&p), strict);
        p.ao_planes = 2;
        assert_eq!(lambdas_with::<8>(&p), general);
    }

    #[test]
    fn a_shadow_arriving_on_converged_light_is_a_full_change() {
        let l = lambda_at_centre(1.0, 0.0, |_, _| 0.0);
        assert!(l > 0.99, "{l}");
    }

    #[test]
    fn rays_that_agree_with_history_change_nothing() {
        assert_eq!(lambda_at_centre(0.5, 0.0, |_, _| 0.5), 0.0);
        // Binary rays around a 50% penumbra: the window's sum is within its noise.
        let l = lambda_at_centre(0.5, 0.25, |x, y| ((x + y) % 2) as f32);
        assert_eq!(l, 0.0);
    }

    #[test]
    fn one_stray_ray_shortens_history_by_little() {
        let l = lambda_at_centre(1.0, 0.0, |x, y| if (x, y) == (4, 4) { 0.0 } else { 1.0 });
        assert!(l > 0.0 && l < 0.05, "{l}");
    }
}
