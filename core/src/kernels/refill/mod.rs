//! Refill: after the change detector, a second, small work list of the pixels whose history it
//! drops and that traced no ray this frame; raygen traces them before accumulation.
//!
//! Why: the detector ([`super::detect`]) can only run after raygen, since it tests this frame's
//! rays. Undersampling leaves much of a converged image untraced each frame, so where it drops
//! history (`λ` above the threshold) such a pixel would have no estimate at all and the à-trous
//! filter would fill it from its far taps, pulling in a highlight many rows away (see
//! docs/algorithms/change-detector.md, "Refill lists"). A few rays give it an estimate of
//! its own, as a fresh pixel's request would have. Its rays come out of the frame's own budget:
//! the balancer sets rays aside for the lists (`balance::refill_reserve`, from last frame's
//! lists), and [`fit`] shares what the main pass left among the entries, so the frame never
//! traces more than its budget, however many pixels the detector lists.
//!
//! The shadow planes also list the pixels to verify: those that traced fewer rays than a listed
//! pixel gets and whose own rays disagree with their history ([`super::detect::pixel_z`]). One
//! binary ray under a lit history is too weak to drop it, and the detector's window dilutes it
//! (a thin umbra the camera slides under lit history: 1.97σ, `λ` 0.12); raygen re-traces the
//! pixel from the same rng index (its first ray again, three new), and accumulation
//! ([`super::accumulate`]) drops the history if the rays together still disagree.
//!
//! A reset frame (first frame, camera cut) has no history and no detector; there the lists hold
//! the shadow planes' pixels whose 3×3 window of rays is mixed, or AO's and the reflections'
//! whose window is contrasted, and [`fit`] shares the rays the frame set aside
//! (`rates.reset_refill`, `rates.ao_reset_refill`, `reflections.reset_refill`) among them: the
//! penumbrae, crevices and highlights' edges get the cut's extra rays that more rays everywhere
//! would spend where the filter does as well without them.

use super::balance::Balance;
use super::buckets::{BUCKET_COUNT, MAX_RATE};
use super::detect::DetectParams;
use super::work_list::{self, append, ARGS_LEN, SKIPPED};
use super::{DetectRefillIo, RefillCapIo, RefillFitIo, RefillIo};
use crate::atomic;
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
    /// `λ` above which accumulation drops history (`detector.threshold`).
    pub threshold: f32,
    /// `threshold` of the planes in `shadow_planes`.
    pub shadow_threshold: f32,
    /// Planes (bit per plane) that take `shadow_threshold` (`Layout::shadow_planes`).
    pub shadow_planes: u32,
    /// Rays of each listed pixel (`detector.refill_rays`).
    pub rays: u32,
    /// Significance of one pixel's own rays against its history ([`super::detect::pixel_z`])
    /// from which a pixel that traced fewer than `rays` is listed to verify, on the planes in
    /// `shadow_planes`; 0 lists none.
    pub verify_sigma: f32,
    /// History length (rays) from which a pixel's history variance is trusted for that test.
    pub verify_history: f32,
    /// Floor of the per-ray variance of that test (`detector.min_variance`).
    pub min_variance: f32,
    /// Frame number: varies which entries [`fit`] keeps when the lists do not fit ([`priority`]).
    pub frame_index: u32,
    /// Planes (bit per plane) that list their pixels without history (disoccluded this frame)
    /// that traced fewer than `rays`: the reflections' (`detector.refill_fresh`). 0: none.
    pub fresh_planes: u32,
    /// Planes (bit per plane) whose windows a reset frame's lists test ([`refill`]): those in
    /// `shadow_planes` list a mixed window, the others a contrasted one (`reset_contrast`).
    pub reset_planes: u32,
    /// Factor by which a window's brightest ray must exceed its darkest for a reset frame to
    /// list the pixel on a plane of `reset_planes` outside `shadow_planes` (the signal's alone:
    /// `rates.ao_reset_contrast` or `reflections.reset_contrast`).
    pub reset_contrast: f32,
}

/// A reset frame's lists (no history, no detector: [`detect_refill`] makes the others): one call
/// per `N` consecutive pixels of a row and plane group (z) ([`crate::lanes`]), appending the
/// pixels of the group's `reset_planes` whose 3×3 window of rays is mixed or contrasted
/// (`reset_listed`), with `rays` rays each until [`cap`] sets them (the balancer reset `args` to
/// `[0, 0, 1, 1]`).
#[inline(always)]
pub fn refill<const N: usize>(id: UVec3, p: &RefillParams, io: RefillIo<'_>) {
    let RefillIo {
        requests,
        samples,
        work,
        args,
        hist,
    } = io;
    if id.x >= p.width || id.y >= p.height {
        return;
    }
    let listed = reset_listed::<N>(id, p, samples);
    list(id, p, requests, listed, (work, args, hist));
}

/// The detector fused with the lists it feeds ([`super::detect::detect`], then the lists):
/// one call per `N` pixels of a row and plane group (z), `λ` of each of the group's planes
/// written to `changes` and tested where it was computed, not read back. Appends each pixel that
/// asked for rays (not sky, not masked), traced none in the group's planes and whose history the
/// detector drops in one of them, or that the shadow planes verify, with `rays` rays, to the
/// group's list ([`append`]; the balancer reset `args` to `[0, 0, 1, 1]`). Reset frames have no
/// detector: their lists are [`refill`]'s.
#[inline(always)]
pub fn detect_refill<const N: usize>(id: UVec3, p: &DetectRefillParams, io: DetectRefillIo<'_>) {
    let DetectRefillIo {
        requests,
        samples,
        history,
        changes,
        work,
        args,
        hist,
    } = io;
    let r = &p.refill;
    let (w, h) = (r.width, r.height);
    if id.x >= w || id.y >= h {
        return;
    }
    let live = Lanes::<bool, N>::from_index(|l| id.x + l < w);
    let mut seen = Seen::<N>::new();
    let mut z = 0;
    while z < r.planes {
        if super::plane_group(r.plane_groups, z) == id.z {
            let at = UVec3::new(id.x, id.y, z);
            let lambda = super::detect::lambda::<N>(at, &p.detect, history, samples);
            lambda.store(changes, super::plane_index(at, w, h), live);
            seen.plane(id, z, r, (samples, history), lambda);
        }
        z += 1;
    }
    list(id, r, requests, seen.listed(), (work, args, hist));
}

/// Push constants of [`detect_refill`]: the detector's and the lists'.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DetectRefillParams {
    /// The detector's.
    pub detect: DetectParams,
    /// The lists'.
    pub refill: RefillParams,
}

/// What the planes of a group say about `N` pixels: whether a plane traced them, dropped their
/// history, or (the shadow planes' verification) found their own rays far from it with fewer
/// than a listed pixel's rays.
#[derive(Copy, Clone)]
struct Seen<const N: usize> {
    traced: Lanes<bool, N>,
    dropped: Lanes<bool, N>,
    surprised: Lanes<bool, N>,
    fewer: Lanes<bool, N>,
    fresh: Lanes<bool, N>,
}

impl<const N: usize> Seen<N> {
    /// Nothing seen yet.
    #[inline(always)]
    fn new() -> Self {
        let no = Lanes::splat(false);
        Seen {
            traced: no,
            dropped: no,
            surprised: no,
            fewer: no,
            fresh: no,
        }
    }

    /// Adds plane `z`'s samples and `λ` (row `id.y` from `id.x`).
    #[inline(always)]
    fn plane(
        &mut self,
        id: UVec3,
        z: u32,
        p: &RefillParams,
        (samples, history): (&[PackedSample], &[PackedPayload]),
        lambda: Lanes<f32, N>,
    ) {
        let (w, x0) = (p.width, id.x as i32);
        let start = z * w * p.height + id.y * w;
        let threshold =
            super::detect::per_plane(p.threshold, p.shadow_threshold, p.shadow_planes, z);
        let s = Lanes::<PackedSample, N>::load_row(samples, start, x0, w);
        self.traced = self.traced.zip(s, |t, s| t || s.rays() > 0);
        self.dropped = self.dropped.zip(lambda, |d, l| d || l > threshold);
        // Fresh pixels, on the planes that list them (a uniform branch).
        if super::plane_in(p.fresh_planes, z) {
            let m = Lanes::<PackedPayload, N>::load_row(history, start, x0, w);
            let fresh = &mut self.fresh;
            lanes::each_lane!(l in N {
                let rays = s.0[l].rays();
                fresh.0[l] |= rays > 0 && rays < p.rays && !(m.0[l].unpack().count >= 1.0);
            });
        }
        // Verification, on the shadow planes only (a uniform branch).
        if p.verify_sigma > 0.0 && super::plane_in(p.shadow_planes, z) {
            let m = Lanes::<PackedPayload, N>::load_row(history, start, x0, w);
            self.fewer = self
                .fewer
                .zip(s, |f, s| f || (s.rays() > 0 && s.rays() < p.rays));
            let surprised = &mut self.surprised;
            lanes::each_lane!(l in N {
                let (s, m) = (s.0[l].unpack(), m.0[l].unpack());
                let sigmas = super::detect::pixel_z(s, m, p.min_variance);
                surprised.0[l] |= m.count >= p.verify_history && sigmas >= p.verify_sigma;
            });
        }
    }

    /// The pixels to list: dropped and untraced, or to verify.
    #[inline(always)]
    fn listed(&self) -> Lanes<bool, N> {
        let mut out = Lanes::<bool, N>::splat(false);
        lanes::each_lane!(l in N {
            let verify = self.fewer.0[l] && self.surprised.0[l] && !self.dropped.0[l];
            out.0[l] = (!self.traced.0[l] && self.dropped.0[l]) || verify || self.fresh.0[l];
        });
        out
    }
}

/// Appends the `listed` pixels that asked for rays and lie inside the image to group `id.z`'s
/// list, with `p.rays` rays each, and counts each in its [`priority`] bin of the group's
/// histogram (`hist`, [`FIT_BINS`] words per group, zeroed before) for [`fit`].
#[inline(always)]
fn list<const N: usize>(
    id: UVec3,
    p: &RefillParams,
    requests: &[u32],
    listed: Lanes<bool, N>,
    (work, args, hist): (&mut [u32], &mut [u32], &mut [u32]),
) {
    let (w, pixels) = (p.width, p.width * p.height);
    let row = id.y * w;
    let requests = Lanes::<u32, N>::load_row(requests, id.z * pixels + row, id.x as i32, w);
    let mut refills = Lanes::<bool, N>::splat(false);
    lanes::each_lane!(l in N {
        let asked = super::requests::bucket_of(requests.0[l]) < BUCKET_COUNT;
        refills.0[l] = id.x + (l as u32) < w && asked && listed.0[l];
        if refills.0[l] {
            let b = priority(row + id.x + l as u32, p.frame_index);
            atomic::add(&mut hist[(id.z * FIT_BINS + b) as usize], 1);
        }
    });
    append(
        work,
        args,
        id.z,
        pixels,
        row + id.x,
        refills,
        Lanes::splat(p.rays),
    );
}

/// On a reset frame: whether each lane's pixel traced fewer than `p.rays` on a plane of
/// `p.reset_planes` in group `id.z` whose 3×3 window of traced samples is
///
/// - on a shadow plane, mixed (samples that differ): a penumbra or a shadow's edge, where one or
///   two binary rays are the noisiest and the filter has no history to lean on. Lit and umbra
///   windows (all 1, all 0) need no more (see `docs/algorithms/penumbra-guide.md`);
/// - on another plane (AO's, the reflections'), contrasted: its brightest sample more than
///   `p.reset_contrast` times its darkest. A highlight's or a reflected silhouette's edge, where
///   the filter and ray reuse spread a neighbour's bright ray over dark pixels, or AO's crevices
///   and silhouettes, which the filter brightens from their neighbours; a flat reflection's or
///   an open surface's rays differ less, and its pixels keep the main pass's rays (see
///   `docs/algorithms/reflections.md`, `docs/algorithms/fresh-pixels.md`).
#[inline(always)]
fn reset_listed<const N: usize>(
    id: UVec3,
    p: &RefillParams,
    samples: &[PackedSample],
) -> Lanes<bool, N> {
    let (w, h) = (p.width, p.height);
    let pixels = w * h;
    let x0 = id.x as i32;
    let mut listed = Lanes::<bool, N>::splat(false);
    let mut z = 0;
    while z < p.planes {
        if super::plane_group(p.plane_groups, z) == id.z && super::plane_in(p.reset_planes, z) {
            // A contrast of 1 is the shadows' mixed window: any two samples that differ.
            let contrast = if super::plane_in(p.shadow_planes, z) {
                1.0
            } else {
                p.reset_contrast
            };
            let own = Lanes::<PackedSample, N>::load_row(samples, z * pixels + id.y * w, x0, w);
            let mut lo = Lanes::<f32, N>::splat(f32::MAX);
            let mut hi = Lanes::<f32, N>::splat(-f32::MAX);
            let mut dy: i32 = -1;
            while dy <= 1 {
                let qy = lanes::clamp_column(id.y as i32 + dy, h);
                let mut dx: i32 = -1;
                while dx <= 1 {
                    let q = Lanes::<PackedSample, N>::load_row(
                        samples,
                        z * pixels + qy * w,
                        x0 + dx,
                        w,
                    );
                    lanes::each_lane!(l in N {
                        if q.0[l].rays() > 0 {
                            let m1 = q.0[l].unpack().m1;
                            lo.0[l] = crate::math::min(lo.0[l], m1);
                            hi.0[l] = crate::math::max(hi.0[l], m1);
                        }
                    });
                    dx += 1;
                }
                dy += 1;
            }
            lanes::each_lane!(l in N {
                let n = own.0[l].rays();
                listed.0[l] |= n > 0 && n < p.rays && hi.0[l] > contrast * lo.0[l];
            });
        }
        z += 1;
    }
    listed
}

/// Rays a reset frame set aside for a group's refill list: `share` of what its main pass was
/// granted (`decision.budget`, rays over the pixels that asked, sky excluded), so the two add up
/// to the frame's boosted budget.
#[inline]
pub fn reserve(decision: &Balance, share: f32) -> u32 {
    (decision.budget * share) as u32
}

/// Bins of the refill lists' histogram ([`priority`]).
pub const FIT_BINS: u32 = 256;

/// The bin of pixel `pix`'s entry in frame `frame`: a hash, so the entries that go when the lists
/// do not fit are spread over the image and change from frame to frame, and the histogram, not
/// the order of the appends, decides which (the same on every backend and run).
#[inline]
pub fn priority(pix: u32, frame: u32) -> u32 {
    crate::sequence::pcg_hash(pix ^ crate::sequence::pcg_hash(frame)) >> 24
}

/// Push constants of [`fit`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FitParams {
    /// Plane groups (one invocation each).
    pub groups: u32,
    /// Rays of an entry where no budget bounds the lists (`unbounded`): `RefillParams::rays`,
    /// the detector's `detector.refill_rays` or a reset frame's [`MAX_RATE`].
    pub rays: u32,
    /// Fewest rays of a kept entry: a reset frame's are what a pixel may have traced in the
    /// main pass, so a re-trace never holds fewer (`rates::reset_least`); 1 for the detector's.
    pub least: u32,
    /// Nonzero: the balancer grants every request (`balance::POLICY_KEEP`), with no budget to
    /// hold; the entries keep `rays`.
    pub unbounded: u32,
}

/// One invocation per plane group, after its refill list is complete: how many rays its
/// entries get so that the frame's rays stay within what it may trace
/// ([`Balance::allowed`], less the main pass's [`Balance::traced`]). Entries in bins from
/// [`Balance::refill_cut`] get [`Balance::refill_hi`] rays, the others [`Balance::refill_lo`]
/// (0: skipped); [`cap`] writes them.
///
/// Why a fit: the lists are made after the main pass traced, from what its rays showed, so their
/// size is known only now. The balancer sets rays aside for them from last frame's lists (and a
/// reset frame its reserve). Whatever the room, it is shared: equally (up to [`MAX_RATE`] each),
/// the remainder one ray each to the entries of the highest bins, and with less than `least` for
/// every entry, `least` each to as many entries as fit; rays set aside but not needed go to the
/// entries instead of being lost.
pub fn fit(id: UVec3, p: &FitParams, io: RefillFitIo<'_>) {
    let RefillFitIo {
        args,
        hist,
        decision,
    } = io;
    let g = id.x;
    if g >= p.groups {
        return;
    }
    let count = args[(g * ARGS_LEN) as usize];
    let d = &mut decision[g as usize];
    // Written out: the shader target has no saturating subtraction.
    #[allow(clippy::implicit_saturating_sub)]
    let room = if d.allowed > d.traced {
        d.allowed - d.traced
    } else {
        0
    };
    let base = (g * FIT_BINS) as usize;
    let least = if p.least > 1 { p.least } else { 1 };
    let (lo, hi, keep) = if p.unbounded != 0 || count == 0 {
        (p.rays, p.rays, count)
    } else if room / count >= MAX_RATE {
        (MAX_RATE, MAX_RATE, count)
    } else if room / count >= least {
        let lo = room / count;
        (lo, lo + 1, room - lo * count)
    } else {
        (0, least, room / least)
    };
    // The lowest bin from which the entries, counted from the top, are at most `keep`.
    let mut cut = FIT_BINS;
    let mut above = 0;
    while cut > 0 && above + hist[base + cut as usize - 1] <= keep {
        above += hist[base + cut as usize - 1];
        cut -= 1;
    }
    d.refill_lo = lo;
    d.refill_hi = hi;
    d.refill_cut = cut;
    d.refill_traced = lo * (count - above) + hi * above;
}

/// Push constants of [`cap`].
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CapParams {
    /// Pixels of the image (the stride of the groups' lists).
    pub pixels: u32,
    /// The refill list capped (a plane group's).
    pub list: u32,
    /// Frame number ([`priority`]).
    pub frame_index: u32,
}

/// One invocation per entry of refill list `p.list` (dispatched indirectly from its arguments,
/// after [`fit`]): the entry's rays become what [`fit`] gave its bin, or [`SKIPPED`] for none.
pub fn cap(id: UVec3, p: &CapParams, io: RefillCapIo<'_>) {
    let RefillCapIo {
        decision,
        args,
        work,
    } = io;
    let count = args[(p.list * ARGS_LEN) as usize];
    if id.x >= count {
        return;
    }
    let i = (p.list * p.pixels + id.x) as usize;
    let (pix, _) = work_list::work_item(work[i]);
    let d = &decision[p.list as usize];
    let rays = if priority(pix as u32, p.frame_index) >= d.refill_cut {
        d.refill_hi
    } else {
        d.refill_lo
    };
    work[i] = if rays == 0 {
        SKIPPED
    } else {
        work_list::work_entry(pix as u32, rays)
    };
}

pub mod tile;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::payload::{Payload, Sample};

    /// The work list of one pixel of plane 0 that asked for rays, traced `rays` of value `value`
    /// and has a lit history (mean 0.9 over 16 rays), with the shadow-plane mask
    /// `shadow_planes`.
    fn listed(rays: u32, value: f32, shadow_planes: u32) -> std::vec::Vec<(usize, u32)> {
        listed_over(Payload::binary(0.9, 16.0), rays, value, (shadow_planes, 0))
    }

    /// As [`listed`], over `history`, with the masks `(shadow_planes, fresh_planes)`.
    fn listed_over(
        history: Payload,
        rays: u32,
        value: f32,
        (shadow_planes, fresh_planes): (u32, u32),
    ) -> std::vec::Vec<(usize, u32)> {
        let history = [history.pack()];
        let samples = [Sample::uniform(value, rays).pack()];
        let (mut work, mut args) = ([0u32; 1], [0u32, 0, 1, 1]);
        let p = DetectRefillParams {
            // A detector that never counts a change (`λ` 0): only the verification lists.
            detect: DetectParams {
                width: 1,
                height: 1,
                z_full: 1e30,
                ao_z_full: 1e30,
                ..Default::default()
            },
            refill: RefillParams {
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
                fresh_planes,
                ..Default::default()
            },
        };
        let io = DetectRefillIo {
            requests: &[0],
            samples: &samples,
            history: &history,
            changes: &mut [f32::NAN],
            work: &mut work,
            args: &mut args,
            hist: &mut [0; FIT_BINS as usize],
        };
        detect_refill::<1>(UVec3::ZERO, &p, io);
        work[..args[0] as usize]
            .iter()
            .map(|&e| work_list::work_item(e))
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

    #[test]
    fn a_fresh_reflection_pixel_is_listed_for_more_rays() {
        // No history (disoccluded) and one ray: four more.
        let fresh = Payload::default();
        assert_eq!(listed_over(fresh, 1, 0.5, (0, 1)), [(0, 4)]);
        // With history, with the list's rays already, or on a plane that lists no fresh pixels:
        // none.
        assert!(listed_over(Payload::binary(0.5, 1.0), 1, 0.5, (0, 1)).is_empty());
        assert!(listed_over(fresh, 4, 0.5, (0, 1)).is_empty());
        assert!(listed_over(fresh, 1, 0.5, (0, 0)).is_empty());
    }

    /// The work list of a reset frame over a 4×3 image of one shadow plane (mask
    /// `shadow_planes`, which a reset tests) whose first ray was `lit` at each pixel.
    fn reset_listed_pixels(lit: [[bool; 4]; 3], shadow_planes: u32) -> std::vec::Vec<usize> {
        let values = lit.map(|row| row.map(|l| if l { 1.0 } else { 0.0 }));
        let p = RefillParams {
            shadow_planes,
            reset_planes: 1,
            ..Default::default()
        };
        reset_listed_values(values, p)
    }

    /// The work list of a reset frame over a 4×3 image of one plane whose first ray read
    /// `values`, with `p`'s masks and contrast.
    fn reset_listed_values(values: [[f32; 4]; 3], p: RefillParams) -> std::vec::Vec<usize> {
        let samples: std::vec::Vec<PackedSample> = values
            .iter()
            .flatten()
            .map(|&v| Sample::uniform(v, 1).pack())
            .collect();
        let (mut work, mut args) = ([0u32; 12], [0u32, 0, 1, 1]);
        let mut hist = [0u32; FIT_BINS as usize];
        let p = RefillParams {
            width: 4,
            height: 3,
            planes: 1,
            rays: MAX_RATE,
            ..p
        };
        for y in 0..3 {
            for x in 0..4 {
                let io = RefillIo {
                    requests: &[0; 12],
                    samples: &samples,
                    work: &mut work,
                    args: &mut args,
                    hist: &mut hist,
                };
                refill::<1>(UVec3::new(x, y, 0), &p, io);
            }
        }
        let mut listed: std::vec::Vec<usize> = work[..args[0] as usize]
            .iter()
            .map(|&e| work_list::work_item(e).0)
            .collect();
        listed.sort();
        listed
    }

    #[test]
    fn a_reset_frame_lists_the_shadows_mixed_windows() {
        // An umbra in the left column: the two columns beside the edge are mixed, the lit
        // column beyond is not.
        let edge = [[false, true, true, true]; 3];
        assert_eq!(reset_listed_pixels(edge, 1), [0, 1, 4, 5, 8, 9]);
        assert!(reset_listed_pixels([[true; 4]; 3], 1).is_empty());
        assert!(reset_listed_pixels([[false; 4]; 3], 1).is_empty());
    }

    #[test]
    fn a_reset_frame_lists_the_reflections_contrasted_windows() {
        // A highlight (8) in the left column of a floor at 1, and a floor whose rays differ
        // by less than the contrast.
        let highlight = [[8.0, 1.0, 1.0, 1.0]; 3];
        let flat = [[1.0, 3.0, 1.0, 3.0]; 3];
        let reflections = RefillParams {
            reset_planes: 1,
            reset_contrast: 4.0,
            ..Default::default()
        };
        assert_eq!(
            reset_listed_values(highlight, reflections),
            [0, 1, 4, 5, 8, 9]
        );
        assert!(reset_listed_values(flat, reflections).is_empty());
        // The same windows on a shadow plane are mixed; on a plane a reset does not test,
        // nothing.
        let shadows = RefillParams {
            shadow_planes: 1,
            ..reflections
        };
        assert_eq!(reset_listed_values(flat, shadows).len(), 12);
        let untested = RefillParams {
            reset_planes: 0,
            ..reflections
        };
        assert!(reset_listed_values(highlight, untested).is_empty());
    }

    /// A list of `count` entries (pixels `0..count`) fitted into `room` rays at `rays` each,
    /// `least` at least, then capped: the rays of every entry.
    fn fitted(count: u32, room: u32, rays: u32, least: u32) -> std::vec::Vec<u32> {
        let frame = 17;
        let mut hist = [0u32; FIT_BINS as usize];
        for pix in 0..count {
            hist[priority(pix, frame) as usize] += 1;
        }
        let args = [count, 0, 1, 1];
        let mut decision = [Balance {
            allowed: 1000 + room,
            traced: 1000,
            ..Balance::default()
        }];
        let p = FitParams {
            groups: 1,
            rays,
            least,
            unbounded: 0,
        };
        let io = RefillFitIo {
            args: &args,
            hist: &hist,
            decision: &mut decision,
        };
        fit(UVec3::ZERO, &p, io);
        let mut work: std::vec::Vec<u32> = (0..count)
            .map(|pix| work_list::work_entry(pix, rays))
            .collect();
        let p = CapParams {
            pixels: count,
            list: 0,
            frame_index: frame,
        };
        for i in 0..count {
            let io = RefillCapIo {
                decision: &decision,
                args: &args,
                work: &mut work,
            };
            cap(UVec3::new(i, 0, 0), &p, io);
        }
        let rays: std::vec::Vec<u32> = work
            .iter()
            .map(|&e| {
                if e == SKIPPED {
                    0
                } else {
                    work_list::work_item(e).1
                }
            })
            .collect();
        assert_eq!(rays.iter().sum::<u32>(), decision[0].refill_traced);
        rays
    }

    #[test]
    fn refill_lists_fit_the_room_left() {
        for (count, room) in [
            (0, 0),
            (10, 40),
            (10, 39),
            (10, 25),
            (10, 9),
            (10, 0),
            (300, 1000),
            (300, 200),
            (7, 500),
        ] {
            for least in [1, 3] {
                let rays = fitted(count, room, 4, least);
                let total: u32 = rays.iter().sum();
                assert!(total <= room, "{count} entries, room {room}: {total} rays");
                // Kept entries hold at least `least` (a reset frame's re-trace never holds fewer
                // than its main pass) and at most MAX_RATE.
                assert!(rays
                    .iter()
                    .all(|&r| r == 0 || (least..=MAX_RATE).contains(&r)));
                // The room is used: what is left is less than one more entry's least.
                if count > 0 && room < count * MAX_RATE {
                    assert!(
                        room - total < least.max(1) * count.min(room + 1),
                        "{count} {room} {total}"
                    );
                }
            }
        }
        // Room for every entry's rays and more: the rest goes to the entries.
        assert_eq!(fitted(10, 60, 4, 1).iter().sum::<u32>(), 60);
        assert!(fitted(10, 1000, 4, 1).iter().all(|&r| r == MAX_RATE));
    }
}
