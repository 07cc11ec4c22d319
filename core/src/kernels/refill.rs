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

use super::apply::append;
use super::buckets::BUCKET_COUNT;
use super::RefillIo;
use crate::lanes::{self, Lanes};
use crate::payload::PackedSample;
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
    let mut z = 0;
    while z < p.planes {
        if super::plane_group(p.plane_groups, z) == group {
            let threshold =
                super::detect::per_plane(p.threshold, p.shadow_threshold, p.shadow_planes, z);
            let s = Lanes::<PackedSample, N>::load_row(samples, z * pixels + row, x0, w);
            let lambda = Lanes::<f32, N>::load_row(changes, z * pixels + row, x0, w);
            traced = traced.zip(s, |t, s| t || s.rays() > 0);
            dropped = dropped.zip(lambda, |d, l| d || l > threshold);
        }
        z += 1;
    }
    let mut refills = Lanes::<bool, N>::splat(false);
    lanes::each_lane!(l in N {
        let asked = super::reproject::bucket_of(requests.0[l]) < BUCKET_COUNT;
        refills.0[l] = id.x + (l as u32) < w && asked && !traced.0[l] && dropped.0[l];
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
