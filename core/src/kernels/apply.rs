//! VRRT apply: turns each pixel's requested bucket and the balancer's thresholds into the rays it
//! traces this frame, and compacts the pixels that trace into a work list for an indirect raygen.
//! Each work entry carries its pixel and its ray count ([`work_entry`](super::work_list::work_entry)), so ray generation needs
//! no per-pixel ray buffer: it reads only the list.
//!
//! Seed: vrrt-call-of-duty-2026, "VRRT Apply / Produce ray args" (`VrrtApply`) and "Undersampling"
//! (fractional rates realised by a spatio-temporal blue-noise test, `rate > noise ? 1 : 0`).
//! Pixels that trace nothing get an empty [`crate::payload::Sample`] in every plane here, so accumulation sees
//! "no ray" instead of last frame's sample. The realised rays are trimmed to the budget
//! ([`super::trim`], which runs first and decides which last rays go).

use super::balance::Balance;
use super::trim;
use super::work_list::append;
use super::ApplyIo;
use crate::lanes::{self, clamp_column, Lanes};
use crate::payload::PackedSample;
use bytemuck::{Pod, Zeroable};
use glam::UVec3;

/// Push constants of [`apply`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ApplyParams {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Signal planes (empty samples are written to each).
    pub planes: u32,
    /// Frame number: animates the blue-noise thresholds.
    pub frame_index: u32,
    /// Which group each plane belongs to (`super::plane_group`); the dispatch's z is the group.
    pub plane_groups: u32,
}

/// Rays pixel `(x, y)` traces for plane group `group`: its granted rate realised by a blue-noise
/// test, less the last ray where the trim takes it ([`trim::trimmed_rays`]: the group's rays
/// never exceed its budget).
#[inline(always)]
pub fn resolve_rays(
    x: u32,
    y: u32,
    group: u32,
    bucket: u32,
    p: &ApplyParams,
    d: &Balance,
    noise: &[f32],
) -> u32 {
    trim::trimmed_rays(x, y, group, bucket, &p.trim(), d, noise)
}

impl ApplyParams {
    /// What [`trim`] realises rays with.
    #[inline(always)]
    pub fn trim(&self) -> trim::TrimParams {
        trim::TrimParams {
            width: self.width,
            height: self.height,
            frame_index: self.frame_index,
        }
    }
}

/// One call per `N` consecutive pixels of a row and plane group (z) ([`crate::lanes`]). Appends
/// each tracing pixel and its rays to the group's list, `work[group · pixels..]` ([`work_entry`](super::work_list::work_entry)),
/// and counts them in `args[4 · group]`; `args[4 · group + 1]` ends as the number of
/// [`LIST_GROUP`](super::work_list::LIST_GROUP)-wide groups (the balancer reset the arguments to `[0, 0, 1, 1]` before this
/// pass; [`append`]). A pixel that traces nothing gets empty samples in the group's planes.
#[inline(always)]
pub fn apply<const N: usize>(id: UVec3, p: &ApplyParams, io: ApplyIo<'_>) {
    let ApplyIo {
        requests,
        decision,
        noise,
        work,
        args,
        samples,
    } = io;
    let (w, h) = (p.width, p.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let pixels = w * h;
    let (group, row) = (id.z, id.y * w);
    let x0 = id.x as i32;
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let requests = Lanes::<u32, N>::load_row(requests, group * pixels + row, x0, w);
    // A loop, not a closure: a closure capturing the storage reference `d` is a pointer to a
    // pointer, which SPIR-V's logical addressing does not have.
    let d = &decision[group as usize];
    let xs = Lanes::<u32, N>::from_index(|l| clamp_column(x0 + l as i32, w));
    // `resolve_rays` of each pixel, the noise gathered apart so that the rest is vector code.
    let tp = p.trim();
    let mut rates = Lanes::<f32, N>::splat(0.0);
    lanes::each_lane!(l in N {
        let bucket = super::requests::bucket_of(requests.0[l]);
        rates.0[l] = trim::bucket_rate(xs.0[l], id.y, bucket, &tp, d);
    });
    let (whole, bins) = trim::realise_row(rates, xs, id.y, group, &tp, noise);
    let cut = d.cut;
    let rays = whole.zip(bins, |n, b| trim::trim_last(n, b, cut));
    let traces = live.zip(rays, |live, n| live && n > 0);
    let empty = live.zip(traces, |live, traces| live && !traces);
    let mut z = 0;
    while z < p.planes {
        if super::plane_group(p.plane_groups, z) == group {
            Lanes::splat(PackedSample::default()).store(
                samples,
                (z * pixels + row + id.x) as usize,
                empty,
            );
        }
        z += 1;
    }
    append(work, args, group, pixels, row + id.x, traces, rays);
}
