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

use super::plane_index;
use super::DetectIo;
use crate::math;
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
    /// Padding.
    pub _pad: u32,
    /// Significance (in standard deviations of `D`) from which a change counts fully.
    pub z_full: f32,
    /// Floor of the per-ray variance (signal units squared): a converged pixel's history
    /// variance may read 0.
    pub min_variance: f32,
    /// Padding.
    pub _pad1: [f32; 2],
}

/// One invocation per pixel and signal plane: `changes = λ` in `[0, 1]` (module rule).
pub fn detect(id: UVec3, p: &DetectParams, io: DetectIo<'_>) {
    let DetectIo {
        history,
        samples,
        changes,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let r = p.radius as i32;
    let (mut sum_s, mut sum_m, mut var) = (0.0f32, 0.0f32, 0.0f32);
    let mut dy = -r;
    while dy <= r {
        let mut dx = -r;
        while dx <= r {
            let (qx, qy) = (id.x as i32 + dx, id.y as i32 + dy);
            if qx >= 0 && qy >= 0 && qx < p.width as i32 && qy < p.height as i32 {
                let q = plane_index(UVec3::new(qx as u32, qy as u32, id.z), p.width, p.height);
                let s = samples[q].unpack();
                let h = history[q].unpack();
                if s.rays > 0 && h.count > 0.0 && math::is_finite(s.m1) {
                    sum_s += s.m1;
                    sum_m += h.m1;
                    let sigma2 = math::max(h.variance(), p.min_variance);
                    var += sigma2 * (1.0 / s.rays as f32 + 1.0 / h.count);
                }
            }
            dx += 1;
        }
        dy += 1;
    }
    let i = plane_index(id, p.width, p.height);
    let diff = math::abs(sum_s - sum_m);
    let top = math::max(sum_s, sum_m);
    changes[i] = if top > 0.0 && var > 0.0 {
        let z = diff / math::sqrt(var);
        let significance = math::saturate(z - (p.z_full - 1.0));
        math::saturate(diff / top) * significance
    } else {
        0.0
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::payload::{PackedPayload, PackedSample, Payload, Sample};

    const W: u32 = 9;

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
            detect(UVec3::new(i % W, i / W, 0), &p, io);
        }
        changes[(W * W / 2) as usize]
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
