//! Refill: after the change detector, a second, small work list of the pixels whose history it
//! drops and that traced no ray this frame; raygen traces them before accumulation.
//!
//! Why: the detector ([`super::detect`]) can only run after raygen, since it tests this frame's
//! rays. Undersampling leaves 45–49% of a converged image untraced each frame, so where it drops
//! history (`λ` above the threshold) such a pixel would have no estimate at all and the à-trous
//! filter would fill it from its far taps (on the dragon, two pixels whose reference is 0 came
//! out at 8.7 and 10.3, pulled from a highlight 24 rows away). A few rays give it an estimate of
//! its own, as a fresh pixel's request would have. Its rays come out of the ray budget: the
//! balancer takes the lists' counts times their rays off the next frame's budget
//! ([`super::balance`]).
//!
//! The shadow planes also list the pixels to verify: those that traced fewer rays than a listed
//! pixel gets and whose own rays disagree with their history ([`super::detect::pixel_z`]). One
//! binary ray under a lit history is too weak to drop it, and the detector's window dilutes it
//! (a thin umbra the camera slides under lit history: 1.97σ, `λ` 0.12); raygen re-traces the
//! pixel from the same rng index (its first ray again, three new), and accumulation
//! ([`super::accumulate`]) drops the history if the rays together still disagree.

use super::apply::append;
use super::buckets::BUCKET_COUNT;
use super::RefillIo;
use crate::lanes::{self, Lanes};
use crate::payload::{PackedPayload, PackedSample};
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`refill`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RefillParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal planes.
    pub planes: u32,
    /// Which group each plane belongs to (`super::plane_group`); the dispatch's z is the group.
    pub plane_groups: u32,
    /// `λ` above which accumulation drops history (`gradient.threshold`).
    pub threshold: f32,
    /// `threshold` of the planes in `shadow_planes`.
    pub shadow_threshold: f32,
    /// Planes (bit per plane) that take `shadow_threshold` (`Settings::shadow_planes`).
    pub shadow_planes: u32,
    /// Rays of each listed pixel (`gradient.refill_rays`).
    pub rays: u32,
    /// Significance of one pixel's own rays against its history ([`super::detect::pixel_z`])
    /// from which a pixel that traced fewer than `rays` is listed to verify, on the planes in
    /// `shadow_planes`; 0 lists none.
    pub verify_sigma: f32,
    /// History length (rays) from which a pixel's history variance is trusted for that test.
    pub verify_history: f32,
    /// Floor of the per-ray variance of that test (`gradient.detect_min_variance`).
    pub min_variance: f32,
    /// Padding.
    pub _pad: u32,
}

/// One call per `N` consecutive pixels of a row and plane group (z) ([`crate::lanes`]): appends
/// each pixel that asked for rays (not sky, not masked), traced none in the group's planes, and
/// whose history the detector drops in one of them, with `rays` rays, to the group's list
/// ([`append`]; the balancer reset `args` to `[0, 0, 1, 1]`).
#[inline(always)]
pub fn refill<const N: usize>(id: UVec3, p: &RefillParams, io: RefillIo<'_>) {
    let RefillIo {
        requests,
        samples,
        history,
        changes,
        work,
        args,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let pixels = w * h;
    let (group, row) = (id.z, id.y * w);
    let x0 = id.x as i32;
    let requests = Lanes::<u32, N>::load_row(requests, group * pixels + row, x0, w);
    let mut traced = Lanes::<bool, N>::splat(false);
    let mut dropped = Lanes::<bool, N>::splat(false);
    let mut surprised = Lanes::<bool, N>::splat(false);
    let mut fewer = Lanes::<bool, N>::splat(false);
    let mut z = 0;
    while z < p.planes {
        if super::plane_group(p.plane_groups, z) == group {
            let threshold =
                super::detect::per_plane(p.threshold, p.shadow_threshold, p.shadow_planes, z);
            let s = Lanes::<PackedSample, N>::load_row(samples, z * pixels + row, x0, w);
            let lambda = Lanes::<f32, N>::load_row(changes, z * pixels + row, x0, w);
            traced = traced.zip(s, |t, s| t || s.rays() > 0);
            dropped = dropped.zip(lambda, |d, l| d || l > threshold);
            // Verification, on the shadow planes only (a uniform branch).
            if p.verify_sigma > 0.0 && super::plane_in(p.shadow_planes, z) {
                let m = Lanes::<PackedPayload, N>::load_row(history, z * pixels + row, x0, w);
                fewer = fewer.zip(s, |f, s| f || (s.rays() > 0 && s.rays() < p.rays));
                lanes::each_lane!(l in N {
                    let (s, m) = (s.0[l].unpack(), m.0[l].unpack());
                    let sigmas = super::detect::pixel_z(s, m, p.min_variance);
                    surprised.0[l] |= m.count >= p.verify_history && sigmas >= p.verify_sigma;
                });
            }
        }
        z += 1;
    }
    let mut refills = Lanes::<bool, N>::splat(false);
    lanes::each_lane!(l in N {
        let asked = super::reproject::bucket_of(requests.0[l]) < BUCKET_COUNT;
        let verify = fewer.0[l] && surprised.0[l] && !dropped.0[l];
        let refill = !traced.0[l] && dropped.0[l];
        refills.0[l] = id.x + (l as u32) < w && asked && (refill || verify);
    });
    append(
        work,
        args,
        group,
        pixels,
        row + id.x,
        refills,
        Lanes::splat(p.rays),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::apply;
    use crate::payload::{Payload, Sample};

    /// The work list of one pixel of plane 0 that asked for rays, traced `rays` of value `value`
    /// and has a lit history (mean 0.9 over 16 rays), with the shadow-plane mask
    /// `shadow_planes`.
    fn listed(rays: u32, value: f32, shadow_planes: u32) -> std::vec::Vec<(usize, u32)> {
        let history = [Payload::binary(0.9, 16.0).pack()];
        let samples = [Sample::uniform(value, rays).pack()];
        let (mut work, mut args) = ([0u32; 1], [0u32, 0, 1, 1]);
        let p = RefillParams {
            width: 1,
            height: 1,
            planes: 1,
            threshold: 0.5,
            shadow_threshold: 0.3,
            shadow_planes,
            rays: 4,
            verify_sigma: 1.5,
            verify_history: 1.0,
            min_variance: 1e-4,
            ..Default::default()
        };
        let io = RefillIo {
            requests: &[0],
            samples: &samples,
            history: &history,
            changes: &[0.0],
            work: &mut work,
            args: &mut args,
        };
        refill::<1>(UVec3::ZERO, &p, io);
        work[..args[0] as usize]
            .iter()
            .map(|&e| apply::work_item(e))
            .collect()
    }

    #[test]
    fn a_shadow_ray_that_disagrees_with_its_history_is_verified() {
        // One dark ray under p = 0.9: 2.9σ, re-traced with four rays (the first one again).
        assert_eq!(listed(1, 0.0, 1), [(0, 4)]);
        // A lit ray agrees; other planes verify nothing; four rays are already verified.
        assert!(listed(1, 1.0, 1).is_empty());
        assert!(listed(1, 0.0, 0).is_empty());
        assert!(listed(4, 0.0, 1).is_empty());
    }
}
